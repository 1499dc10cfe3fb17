//! Row kernels of the closed-form derivatives and the multiple-shooting stage: linear combinations
//! of the rows of a small row-major matrix, added to one or two output rows.
//!
//! The work of those derivatives is mostly products of matrices of a stage's size (rows of
//! `3n - 1` entries). Written over slices, the compiler keeps every output entry in memory and
//! loads and stores it once per term; here an output row is accumulated in registers (a constant
//! width `W` for the row widths of robots of up to 6 links, the plain loops otherwise), and two
//! output rows share the loads of the matrix's rows. Every kernel does the same arithmetic in the
//! same order as its any-width reference (each entry `((out_j + c_0 r_0j) + c_1 r_1j) + ...`), so
//! results are bit for bit those of the plain loops, whatever the width's path.

/// Calls `$kernel::<W>(args)` with the run-time width `$w` as the constant `W` for the widths
/// 1..=12, 14 and 17 (the blocks of stages `3n - 1` wide, n <= 6); any other width runs `$fallback`.
macro_rules! with_row_width {
    ($w:expr, $kernel:ident $args:tt, $fallback:expr) => {
        $crate::dispatch_width!(
            $w,
            [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 14, 17],
            $kernel $args,
            $fallback
        )
    };
}

/// `out[j] += sum_{i < k} c[i cs] rows[i rs + j]` for `j < out.len()`, each entry summed in the order
/// of i. `c` holds at least `(k - 1) cs + 1` values, `rows` at least `(k - 1) rs + out.len()`.
/// Inlined, so that callers with constant sizes get the kernel of their width without a dispatch.
#[inline(always)]
pub fn add_lincomb(out: &mut [f64], c: &[f64], cs: usize, rows: &[f64], rs: usize, k: usize) {
    if k == 0 {
        return;
    }
    with_row_width!(
        out.len(),
        add_lincomb_w(out, c, cs, rows, rs, k),
        add_lincomb_any(out, c, cs, rows, rs, k)
    )
}

/// [`add_lincomb`] for two output rows of equal length over the same matrix rows (coefficients `c0`
/// and `c1`, both with stride `cs`): each matrix row is loaded once for both. Inlined as
/// [`add_lincomb`].
#[inline(always)]
pub fn add_lincomb2(
    out0: &mut [f64],
    out1: &mut [f64],
    c0: &[f64],
    c1: &[f64],
    cs: usize,
    rows: &[f64],
    rs: usize,
    k: usize,
) {
    assert_eq!(out0.len(), out1.len(), "two output rows of one width");
    if k == 0 {
        return;
    }
    // two rows of more than 12 entries do not fit the registers: one at a time
    crate::dispatch_width!(
        out0.len(),
        [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12],
        add_lincomb2_w(out0, out1, c0, c1, cs, rows, rs, k),
        {
            add_lincomb(out0, c0, cs, rows, rs, k);
            add_lincomb(out1, c1, cs, rows, rs, k);
        }
    )
}

#[inline(always)]
fn add_lincomb_w<const W: usize>(
    out: &mut [f64],
    c: &[f64],
    cs: usize,
    rows: &[f64],
    rs: usize,
    k: usize,
) {
    let out: &mut [f64; W] = out.try_into().expect("W entries");
    let rows = &rows[..(k - 1) * rs + W];
    let mut acc = *out;
    for i in 0..k {
        let ci = c[i * cs];
        let row: &[f64; W] = rows[i * rs..i * rs + W].try_into().expect("W entries");
        for j in 0..W {
            acc[j] += ci * row[j];
        }
    }
    *out = acc;
}

#[inline(always)]
fn add_lincomb2_w<const W: usize>(
    out0: &mut [f64],
    out1: &mut [f64],
    c0: &[f64],
    c1: &[f64],
    cs: usize,
    rows: &[f64],
    rs: usize,
    k: usize,
) {
    let out0: &mut [f64; W] = out0.try_into().expect("W entries");
    let out1: &mut [f64; W] = out1.try_into().expect("W entries");
    let rows = &rows[..(k - 1) * rs + W];
    let (c0, c1) = (&c0[..(k - 1) * cs + 1], &c1[..(k - 1) * cs + 1]);
    let (mut x0, mut x1) = (*out0, *out1);
    for i in 0..k {
        let (a0, a1) = (c0[i * cs], c1[i * cs]);
        let row: &[f64; W] = rows[i * rs..i * rs + W].try_into().expect("W entries");
        for j in 0..W {
            x0[j] += a0 * row[j];
            x1[j] += a1 * row[j];
        }
    }
    (*out0, *out1) = (x0, x1);
}

/// [`add_lincomb`] for any width (the reference of the fixed-width kernels).
fn add_lincomb_any(out: &mut [f64], c: &[f64], cs: usize, rows: &[f64], rs: usize, k: usize) {
    let w = out.len();
    for i in 0..k {
        let ci = c[i * cs];
        for (o, r) in out.iter_mut().zip(&rows[i * rs..i * rs + w]) {
            *o += ci * r;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::values;

    #[test]
    fn fixed_width_kernels_match_the_reference_bit_for_bit() {
        // every width with a kernel and its neighbours, strided coefficients and rows
        for w in (1..=18).chain([23]) {
            for (k, cs, extra) in [(1, 1, 0), (4, 1, 0), (8, 11, 3), (3, 5, 1)] {
                let rs = w + extra;
                let seed = (w * 1000 + k * 10 + cs) as u64;
                let c0 = values((k - 1) * cs + 1, seed);
                let c1 = values((k - 1) * cs + 1, seed + 1);
                let rows = values((k - 1) * rs + w, seed + 2);
                let (o0, o1) = (values(w, seed + 3), values(w, seed + 4));
                let (mut r0, mut r1) = (o0.clone(), o1.clone());
                add_lincomb_any(&mut r0, &c0, cs, &rows, rs, k);
                add_lincomb_any(&mut r1, &c1, cs, &rows, rs, k);
                let mut x0 = o0.clone();
                add_lincomb(&mut x0, &c0, cs, &rows, rs, k);
                assert_eq!(x0, r0, "add_lincomb w {w} k {k} cs {cs} rs {rs}");
                let (mut y0, mut y1) = (o0.clone(), o1.clone());
                add_lincomb2(&mut y0, &mut y1, &c0, &c1, cs, &rows, rs, k);
                assert_eq!(
                    (y0, y1),
                    (r0, r1),
                    "add_lincomb2 w {w} k {k} cs {cs} rs {rs}"
                );
            }
        }
    }
}
