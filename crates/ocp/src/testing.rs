//! Test support shared by the unit tests of this crate's dense kernels and of the robot model's row
//! kernels (`brachia`): not part of the solver's API (hidden from its documentation).

/// `len` deterministic values in [-1, 1) scaled by 1, 1e-3 or 37 (varied exponents, so that a kernel
/// that sums in another order than its reference differs in the last bits), from a xorshift
/// generator seeded by `seed` (no generator crate needed). The same `(len, seed)` always gives the
/// same values.
pub fn values(len: usize, seed: u64) -> Vec<f64> {
    let mut x = seed.wrapping_mul(0x9e37_79b9_7f4a_7c15) | 1;
    (0..len)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let u = (x >> 11) as f64 / (1u64 << 53) as f64;
            (2.0 * u - 1.0) * [1.0, 1e-3, 37.0][(x % 3) as usize]
        })
        .collect()
}
