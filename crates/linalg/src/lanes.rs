//! Dot products in four independent accumulators: for long rows (the box QP's factor), where one
//! accumulator would be one long chain of dependent additions. Their rounding differs from
//! [`crate::dot_acc`]'s: lanes `k mod 4` are summed apart, then `(0 + 1) + (2 + 3)`, then the
//! remainder in order.

/// Dot product with four independent accumulators (lets the compiler vectorise; no bounds checks).
#[inline]
pub fn dot_lanes(a: &[f64], b: &[f64]) -> f64 {
    let len = a.len().min(b.len());
    let (a, b) = (&a[..len], &b[..len]);
    let mut acc = [0.0; 4];
    let mut ca = a.chunks_exact(4);
    let mut cb = b.chunks_exact(4);
    for (x, y) in (&mut ca).zip(&mut cb) {
        acc[0] += x[0] * y[0];
        acc[1] += x[1] * y[1];
        acc[2] += x[2] * y[2];
        acc[3] += x[3] * y[3];
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
        s += x * y;
    }
    s
}

/// `[dot(a[0], b), .., dot(a[3], b)]` with the rounding of [`dot_lanes`] (four accumulators per product,
/// summed `(0 + 1) + (2 + 3)`, then the remainder in order), each loaded entry of `b` serving four
/// products. The rows `a[r]` must be at least as long as `b`.
#[inline(always)]
pub fn dot_lanes_x4(a: [&[f64]; 4], b: &[f64]) -> [f64; 4] {
    let len = b.len();
    let (bq, br) = b.as_chunks::<4>();
    let nq = bq.len();
    let rows = a.map(|r| &r[..len]);
    let [a0, a1, a2, a3] = rows.map(|r| &r.as_chunks::<4>().0[..nq]);
    // Named two-lane accumulators (lanes 0, 1 and 2, 3 of each product's four), straight-line code
    // the compiler keeps in vector registers.
    let f = |s: [f64; 2], x0: f64, y0: f64, x1: f64, y1: f64| [s[0] + x0 * y0, s[1] + x1 * y1];
    let z = [0.0f64; 2];
    let (mut l0, mut h0, mut l1, mut h1, mut l2, mut h2, mut l3, mut h3) = (z, z, z, z, z, z, z, z);
    for k in 0..nq {
        let y = bq[k];
        let x = a0[k];
        l0 = f(l0, x[0], y[0], x[1], y[1]);
        h0 = f(h0, x[2], y[2], x[3], y[3]);
        let x = a1[k];
        l1 = f(l1, x[0], y[0], x[1], y[1]);
        h1 = f(h1, x[2], y[2], x[3], y[3]);
        let x = a2[k];
        l2 = f(l2, x[0], y[0], x[1], y[1]);
        h2 = f(h2, x[2], y[2], x[3], y[3]);
        let x = a3[k];
        l3 = f(l3, x[0], y[0], x[1], y[1]);
        h3 = f(h3, x[2], y[2], x[3], y[3]);
    }
    let sum = |l: [f64; 2], h: [f64; 2], r: &[f64]| {
        let mut s = (l[0] + l[1]) + (h[0] + h[1]);
        for (x, y) in r[4 * nq..].iter().zip(br) {
            s += x * y;
        }
        s
    };
    [
        sum(l0, h0, rows[0]),
        sum(l1, h1, rows[1]),
        sum(l2, h2, rows[2]),
        sum(l3, h3, rows[3]),
    ]
}
