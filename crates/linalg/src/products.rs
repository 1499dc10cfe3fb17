//! Matrix products on row-major slices: `C = A B`, `C += A B`, `C += A^T B`, `C = A B^T`,
//! `y += A x`, `y += A^T x` and the dot product, each entry summed term by term in the order of the
//! inner index.

/// The widths of small stages (1..=12 and 17: the rows of a stage's blocks for up to 6 links) get
/// a kernel with the constant width `N` ([`crate::dispatch_width`]), so that a row of the result
/// lives in registers and its loops unroll; any other width runs `$fallback`. The kernels do the
/// same arithmetic in the same order as the fallback, so the result does not depend on the width's
/// path.
macro_rules! with_width {
    ($w:expr, $kernel:ident $args:tt, $fallback:expr) => {
        $crate::dispatch_width!(
            $w,
            [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 17],
            $kernel $args,
            $fallback
        )
    };
}

/// `c (m x n) = a (m x r) * b (r x n)`: every entry `0 + a_i0 b_0j + a_i1 b_1j + ...` summed in the
/// order of k (the rows of `c` start from zero in registers, not from a cleared `c`). Inlined, so
/// that a caller with constant sizes gets the kernel of its width without a dispatch.
#[inline(always)]
pub fn gemm_nn(a: &[f64], b: &[f64], c: &mut [f64], m: usize, r: usize, n: usize) {
    if n == 0 {
        return;
    }
    let c = &mut c[..m * n];
    if r == 0 {
        c.fill(0.0);
        return;
    }
    let (a, b) = (&a[..m * r], &b[..r * n]);
    with_width!(n, gemm_nn_set_w(a, b, c, r), {
        c.fill(0.0);
        gemm_nn_any(a, b, c, r, n)
    })
}

/// `c (m x n) += a (m x r) * b (r x n)`: every entry `c_ij + a_i0 b_0j + a_i1 b_1j + ...` summed in
/// the order of k.
#[inline]
pub fn gemm_nn_acc(a: &[f64], b: &[f64], c: &mut [f64], m: usize, r: usize, n: usize) {
    if n == 0 || r == 0 {
        return;
    }
    let (a, b, c) = (&a[..m * r], &b[..r * n], &mut c[..m * n]);
    with_width!(n, gemm_nn_w(a, b, c, r), gemm_nn_any(a, b, c, r, n))
}

/// [`gemm_nn_acc`] for any width (the reference of the fixed-width kernels).
fn gemm_nn_any(a: &[f64], b: &[f64], c: &mut [f64], r: usize, n: usize) {
    for (ci, ai) in c.chunks_exact_mut(n).zip(a.chunks_exact(r)) {
        for (aik, bk) in ai.iter().zip(b.chunks_exact(n)) {
            for (p, q) in ci.iter_mut().zip(bk) {
                *p += aik * q;
            }
        }
    }
}

/// [`gemm_nn_acc`] for `N` columns: rows of `c` in registers, two at a time for `N <= 8` (each
/// row of `b` loaded once for both).
#[inline(always)]
fn gemm_nn_w<const N: usize>(a: &[f64], b: &[f64], c: &mut [f64], r: usize) {
    gemm_nn_body::<N, true>(a, b, c, r)
}

/// [`gemm_nn`] for `N` columns: [`gemm_nn_w`] with the rows of `c` starting from zero.
#[inline(always)]
fn gemm_nn_set_w<const N: usize>(a: &[f64], b: &[f64], c: &mut [f64], r: usize) {
    gemm_nn_body::<N, false>(a, b, c, r)
}

/// The body of [`gemm_nn_w`] (`ACC`: add to `c`) and [`gemm_nn_set_w`] (overwrite `c`).
#[inline(always)]
fn gemm_nn_body<const N: usize, const ACC: bool>(a: &[f64], b: &[f64], c: &mut [f64], r: usize) {
    let (b, _) = b.as_chunks::<N>();
    let (c, _) = c.as_chunks_mut::<N>();
    let pairs = if N <= 8 { c.len() / 2 } else { 0 };
    let (c2, c1) = c.split_at_mut(2 * pairs);
    let (a2, a1) = a.split_at(2 * pairs * r);
    for (cp, ap) in c2.chunks_exact_mut(2).zip(a2.chunks_exact(2 * r)) {
        let (mut x0, mut x1) = if ACC {
            (cp[0], cp[1])
        } else {
            ([0.0; N], [0.0; N])
        };
        let (a0, a1) = ap.split_at(r);
        for ((s0, s1), bk) in a0.iter().zip(a1).zip(b) {
            for j in 0..N {
                x0[j] += s0 * bk[j];
                x1[j] += s1 * bk[j];
            }
        }
        (cp[0], cp[1]) = (x0, x1);
    }
    for (ci, ai) in c1.iter_mut().zip(a1.chunks_exact(r)) {
        let mut acc = if ACC { *ci } else { [0.0; N] };
        for (aik, bk) in ai.iter().zip(b) {
            for j in 0..N {
                acc[j] += aik * bk[j];
            }
        }
        *ci = acc;
    }
}

/// `c (m x n) += a^T b` with `a` r x m and `b` r x n: every entry `c_ij + a_0i b_0j + a_1i b_1j + ...`
/// summed in the order of k.
#[inline]
pub fn gemm_tn_acc(a: &[f64], b: &[f64], c: &mut [f64], r: usize, m: usize, n: usize) {
    if n == 0 || m == 0 {
        return;
    }
    let (a, b, c) = (&a[..r * m], &b[..r * n], &mut c[..m * n]);
    with_width!(n, gemm_tn_w(a, b, c, m), gemm_tn_any(a, b, c, m, n))
}

/// [`gemm_tn_acc`] for any width (the reference of the fixed-width kernels).
fn gemm_tn_any(a: &[f64], b: &[f64], c: &mut [f64], m: usize, n: usize) {
    for (ak, bk) in a.chunks_exact(m).zip(b.chunks_exact(n)) {
        for (aki, ci) in ak.iter().zip(c.chunks_exact_mut(n)) {
            for (p, q) in ci.iter_mut().zip(bk) {
                *p += aki * q;
            }
        }
    }
}

/// [`gemm_tn_acc`] for `N` columns: rows of `c` in registers, two at a time for `N <= 8` (each
/// row of `b` loaded once for both).
#[inline(always)]
fn gemm_tn_w<const N: usize>(a: &[f64], b: &[f64], c: &mut [f64], m: usize) {
    let (b, _) = b.as_chunks::<N>();
    let (c, _) = c.as_chunks_mut::<N>();
    let pairs = if N <= 8 { m / 2 } else { 0 };
    let (c2, c1) = c.split_at_mut(2 * pairs);
    for (p, cp) in c2.chunks_exact_mut(2).enumerate() {
        let i = 2 * p;
        let (mut x0, mut x1) = (cp[0], cp[1]);
        for (ak, bk) in a.chunks_exact(m).zip(b) {
            let (s0, s1) = (ak[i], ak[i + 1]);
            for j in 0..N {
                x0[j] += s0 * bk[j];
                x1[j] += s1 * bk[j];
            }
        }
        (cp[0], cp[1]) = (x0, x1);
    }
    for (i, ci) in c1.iter_mut().enumerate() {
        let i = 2 * pairs + i;
        let mut acc = *ci;
        for (ak, bk) in a.chunks_exact(m).zip(b) {
            let aki = ak[i];
            for j in 0..N {
                acc[j] += aki * bk[j];
            }
        }
        *ci = acc;
    }
}

/// `y (m) += a (m x n) x`: `y_i + (a_i0 x_0 + a_i1 x_1 + ...)`, the dot product summed from 0 in the
/// order of j.
#[inline]
pub fn gemv_n_acc(a: &[f64], x: &[f64], y: &mut [f64], m: usize, n: usize) {
    if n == 0 {
        return;
    }
    let (a, x, y) = (&a[..m * n], &x[..n], &mut y[..m]);
    with_width!(n, gemv_n_w(a, x, y), gemv_n_any(a, x, y, n))
}

/// [`gemv_n_acc`] for any width (the reference of the fixed-width kernels).
fn gemv_n_any(a: &[f64], x: &[f64], y: &mut [f64], n: usize) {
    for (yi, ai) in y.iter_mut().zip(a.chunks_exact(n)) {
        let mut s = 0.0;
        for (p, q) in ai.iter().zip(x) {
            s += p * q;
        }
        *yi += s;
    }
}

/// [`gemv_n_acc`] for `N` columns.
#[inline(always)]
fn gemv_n_w<const N: usize>(a: &[f64], x: &[f64], y: &mut [f64]) {
    let (a, _) = a.as_chunks::<N>();
    let x: &[f64; N] = x.try_into().expect("x has N entries");
    for (yi, ai) in y.iter_mut().zip(a) {
        let mut s = 0.0;
        for j in 0..N {
            s += ai[j] * x[j];
        }
        *yi += s;
    }
}

/// `y (n) += a^T x` with `a` m x n: every entry `y_j + x_0 a_0j + x_1 a_1j + ...` summed in the order
/// of i.
#[inline]
pub fn gemv_t_acc(a: &[f64], x: &[f64], y: &mut [f64], m: usize, n: usize) {
    if n == 0 {
        return;
    }
    let (a, x, y) = (&a[..m * n], &x[..m], &mut y[..n]);
    with_width!(n, gemv_t_w(a, x, y), gemv_t_any(a, x, y, n))
}

/// [`gemv_t_acc`] for any width (the reference of the fixed-width kernels).
fn gemv_t_any(a: &[f64], x: &[f64], y: &mut [f64], n: usize) {
    for (xi, ai) in x.iter().zip(a.chunks_exact(n)) {
        for (p, q) in y.iter_mut().zip(ai) {
            *p += xi * q;
        }
    }
}

/// [`gemv_t_acc`] for `N` columns: `y` in registers.
#[inline(always)]
fn gemv_t_w<const N: usize>(a: &[f64], x: &[f64], y: &mut [f64]) {
    let (a, _) = a.as_chunks::<N>();
    let y: &mut [f64; N] = y.try_into().expect("y has N entries");
    let mut acc = *y;
    for (xi, ai) in x.iter().zip(a) {
        for j in 0..N {
            acc[j] += xi * ai[j];
        }
    }
    *y = acc;
}

/// `c (m x n) = a (m x r) * b^T` with `b` n x r: every entry `c_ij` the dot product of row i of `a`
/// and row j of `b` ([`dot_acc`] from 0, in the order of k). Inlined, so that a caller with
/// constant sizes gets unrolled loops.
#[inline(always)]
pub fn gemm_nt(a: &[f64], b: &[f64], c: &mut [f64], m: usize, r: usize, n: usize) {
    if r == 0 {
        c[..m * n].fill(0.0);
        return;
    }
    for (ai, ci) in a[..m * r]
        .chunks_exact(r)
        .zip(c[..m * n].chunks_exact_mut(n.max(1)))
    {
        for (bj, cij) in b[..n * r].chunks_exact(r).zip(ci.iter_mut()) {
            *cij = dot_acc(0.0, ai, bj);
        }
    }
}

/// `init + a . b` summed in order from `init` (`v = init; v += a_k b_k` for k = 0, 1, ...) over the
/// length of `a` (`b` at least as long). Inlined, so that a constant length unrolls.
#[inline(always)]
pub fn dot_acc(init: f64, a: &[f64], b: &[f64]) -> f64 {
    let mut v = init;
    for (x, y) in a.iter().zip(&b[..a.len()]) {
        v += x * y;
    }
    v
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::values;

    #[test]
    fn fixed_width_kernels_match_the_reference_bit_for_bit() {
        // every width with a kernel and its neighbours; odd and even row counts (the paired rows)
        for n in (1..=13).chain([16, 17, 18]) {
            for (m, r) in [(1, 1), (2, 3), (3, 8), (7, 5), (8, 8), (11, 4)] {
                let seed = (n * 100 + m * 10 + r) as u64;
                let (a, b, c0) = (
                    values(m * r, seed),
                    values(r * n, seed + 1),
                    values(m * n, seed + 2),
                );
                let (mut c, mut c_ref) = (c0.clone(), c0.clone());
                gemm_nn_acc(&a, &b, &mut c, m, r, n);
                gemm_nn_any(&a, &b, &mut c_ref, r, n);
                assert_eq!(c, c_ref, "gemm_nn_acc m {m} r {r} n {n}");
                let (mut c, mut c_ref) = (c0.clone(), vec![0.0; m * n]);
                gemm_nn(&a, &b, &mut c, m, r, n);
                gemm_nn_any(&a, &b, &mut c_ref, r, n);
                assert_eq!(c, c_ref, "gemm_nn m {m} r {r} n {n}");
                let at = values(r * m, seed + 3);
                let (mut c, mut c_ref) = (c0.clone(), c0.clone());
                gemm_tn_acc(&at, &b, &mut c, r, m, n);
                gemm_tn_any(&at, &b, &mut c_ref, m, n);
                assert_eq!(c, c_ref, "gemm_tn_acc m {m} r {r} n {n}");
                let (x, y0) = (values(n, seed + 4), values(m, seed + 5));
                let an = values(m * n, seed + 6);
                let (mut y, mut y_ref) = (y0.clone(), y0.clone());
                gemv_n_acc(&an, &x, &mut y, m, n);
                gemv_n_any(&an, &x, &mut y_ref, n);
                assert_eq!(y, y_ref, "gemv_n_acc m {m} n {n}");
                let (xt, yt0) = (values(m, seed + 7), values(n, seed + 8));
                let (mut y, mut y_ref) = (yt0.clone(), yt0.clone());
                gemv_t_acc(&an, &xt, &mut y, m, n);
                gemv_t_any(&an, &xt, &mut y_ref, n);
                assert_eq!(y, y_ref, "gemv_t_acc m {m} n {n}");
            }
        }
    }

    #[test]
    fn products_agree_with_loops() {
        let a = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]; // 2 x 3
        let b = [1.0, 0.0, -1.0, 2.0, 0.5, 1.0]; // 3 x 2
        let mut c = [0.0; 4];
        gemm_nn(&a, &b, &mut c, 2, 3, 2);
        assert_eq!(c, [1.0 - 2.0 + 1.5, 4.0 + 3.0, 4.0 - 5.0 + 3.0, 10.0 + 6.0]);
        let mut d = [0.0; 4]; // a a^T via tn with a^T: (3 x 2)^T (3 x 2)
        let at = [1.0, 4.0, 2.0, 5.0, 3.0, 6.0];
        gemm_tn_acc(&at, &at, &mut d, 3, 2, 2);
        assert_eq!(d, [14.0, 32.0, 32.0, 77.0]);
        let mut y = [0.0; 3];
        gemv_t_acc(&a, &[1.0, 1.0], &mut y, 2, 3);
        assert_eq!(y, [5.0, 7.0, 9.0]);
    }
}
