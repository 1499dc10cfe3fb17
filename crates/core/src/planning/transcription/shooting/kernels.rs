//! The dense products of a shooting stage's derivatives.

use brachia_linalg::add_lincomb;

/// `g = F_x^T w` for `F_x = [[0, I], [Jq_x]]` (`2n x 2n`; `Jq` row-major `n x nz`, its first `2n`
/// columns `Jq_x`): `g_e = [e >= n] w_{e-n} + sum_r Jq[r][e] w_{n+r}`.
pub(super) fn fx_transpose_times(n: usize, nz: usize, jq: &[f64], w: &[f64], g: &mut [f64]) {
    // the paper's 4 links with constant sizes (unrolled, no bounds checks), any other count
    // through the same body: the same arithmetic either way
    match (n, nz) {
        (4, 11) => fx_transpose_times_body(4, 11, jq, w, g),
        _ => fx_transpose_times_body(n, nz, jq, w, g),
    }
}

#[inline(always)]
pub(super) fn fx_transpose_times_body(n: usize, nz: usize, jq: &[f64], w: &[f64], g: &mut [f64]) {
    let nx = 2 * n;
    let (jq, w, g) = (&jq[..n * nz], &w[..nx], &mut g[..nx]);
    g[..n].fill(0.0);
    g[n..].copy_from_slice(&w[..n]);
    add_lincomb(g, &w[n..], 1, jq, nz, n);
}

/// Add the upper triangle (`a <= b`) of `S^T H S` to `hess` (`nz x nz` row-major), for an evaluation's
/// sensitivity `S = [Sx; 0 I]` (`Sx` its first `nx` rows, `nz x nz` in all) and the symmetric Hessian `H`
/// of `w . qdd` at that evaluation. With `H = [Hxx Hxu; Hux Huu]`:
/// `S^T H S = Sx^T Hxx Sx + Sx^T Hxu E + E^T Hux Sx + E^T Huu E`, `E = [0 I]` (the input rows), so
/// the input rows of `S` are never multiplied. `i`: the evaluation's index in the stage; the first
/// (`i = 0`) has `S = I` (`H` itself), the second (`i = 1`, `y = x + (h/2) k_1` with `k_1`'s q rows
/// the qd rows of `S = I`) has the q rows of `Sx` zero but at columns `r` and `n + r` (checked): the
/// products with those zeros are skipped (they would add exact zeros). `tmp` holds at least
/// `(nx + nu) nz` values.
pub(super) fn add_sandwich_upper(
    nx: usize,
    nz: usize,
    sens: &[f64],
    i: usize,
    h: &[f64],
    tmp: &mut [f64],
    hess: &mut [f64],
) {
    let half = nx / 2;
    let identity = i == 0;
    let sparse_q = i == 1
        && (0..half).all(|r| {
            sens[r * nz..(r + 1) * nz]
                .iter()
                .enumerate()
                .all(|(c, &v)| c == r || c == half + r || v == 0.0)
        });
    crate::simd_arch().dispatch(Sandwich {
        nx,
        nz,
        sens,
        identity,
        sparse_q,
        h,
        tmp,
        hess,
    });
}

/// The arguments of [`sandwich_upper_body`], run through [`pulp::Arch::dispatch`]: the body is
/// compiled for the widest vector instructions the CPU has. The same numbers: its loops are
/// element-wise (no reordered sums) and Rust never fuses a multiply and an add.
struct Sandwich<'a> {
    nx: usize,
    nz: usize,
    sens: &'a [f64],
    identity: bool,
    sparse_q: bool,
    h: &'a [f64],
    tmp: &'a mut [f64],
    hess: &'a mut [f64],
}

impl pulp::WithSimd for Sandwich<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let Sandwich {
            nx,
            nz,
            sens,
            identity,
            sparse_q,
            h,
            tmp,
            hess,
        } = self;
        // the paper's 4-link robot with constant sizes (unrolled, no bounds checks), any other
        // size through the same code with run-time sizes
        match (nx, nz, sparse_q) {
            (8, 11, false) => sandwich_upper_body::<false>(8, 11, sens, identity, h, tmp, hess),
            (8, 11, true) => sandwich_upper_body::<true>(8, 11, sens, identity, h, tmp, hess),
            (_, _, false) => sandwich_upper_body::<false>(nx, nz, sens, identity, h, tmp, hess),
            (_, _, true) => sandwich_upper_body::<true>(nx, nz, sens, identity, h, tmp, hess),
        }
    }
}

#[inline(always)]
pub(super) fn sandwich_upper_body<const SPARSE_Q: bool>(
    nx: usize,
    nz: usize,
    sens: &[f64],
    identity: bool,
    h: &[f64],
    tmp: &mut [f64],
    hess: &mut [f64],
) {
    let nu = nz - nx;
    let h = &h[..nz * nz];
    let hess = &mut hess[..nz * nz];
    if identity {
        for a in 0..nz {
            for b in a..nz {
                hess[a * nz + b] += h[a * nz + b];
            }
        }
        return;
    }
    let sx = &sens[..nx * nz];
    let (t, rest) = tmp.split_at_mut(nx * nz);
    let g = &mut rest[..nz * nu];
    // T = Hxx Sx (nx x nz), G = Sx^T Hxu (nz x nu). Rows of Hxu that are exactly zero add nothing to
    // G: the second half of x (qd) when qd and tau never multiply in qdd (true of the dynamics;
    // checked, so any H is right)
    let half = nx / 2;
    let g_rows = if (half..nx).all(|r| h[r * nz + nx..(r + 1) * nz].iter().all(|&v| v == 0.0)) {
        half
    } else {
        nx
    };
    t.fill(0.0);
    g.fill(0.0);
    // with `SPARSE_Q`, the q rows c < half of Sx have their non-zeros at c and half + c only: the
    // terms with the other entries (exact zeros) are left out, every other term in the same order
    for r in 0..nx {
        let out = &mut t[r * nz..(r + 1) * nz];
        for c in 0..nx {
            let hv = h[r * nz + c];
            let srow = &sx[c * nz..(c + 1) * nz];
            if SPARSE_Q && c < half {
                out[c] += hv * srow[c];
                out[half + c] += hv * srow[half + c];
                continue;
            }
            for e in 0..nz {
                out[e] += hv * srow[e];
            }
        }
        if r >= g_rows {
            continue;
        }
        let srow = &sx[r * nz..(r + 1) * nz];
        let hrow = &h[r * nz + nx..(r + 1) * nz];
        if SPARSE_Q && r < half {
            for a in [r, half + r] {
                let sa = srow[a];
                let grow = &mut g[a * nu..(a + 1) * nu];
                for m in 0..nu {
                    grow[m] += sa * hrow[m];
                }
            }
            continue;
        }
        for a in 0..nz {
            let sa = srow[a];
            let grow = &mut g[a * nu..(a + 1) * nu];
            for m in 0..nu {
                grow[m] += sa * hrow[m];
            }
        }
    }
    // Sx^T T, upper triangle
    for r in 0..nx {
        let srow = &sx[r * nz..(r + 1) * nz];
        let trow = &t[r * nz..(r + 1) * nz];
        if SPARSE_Q && r < half {
            for a in [r, half + r] {
                let sa = srow[a];
                let out = &mut hess[a * nz..(a + 1) * nz];
                for b in a..nz {
                    out[b] += sa * trow[b];
                }
            }
            continue;
        }
        for a in 0..nz {
            let sa = srow[a];
            let out = &mut hess[a * nz..(a + 1) * nz];
            for b in a..nz {
                out[b] += sa * trow[b];
            }
        }
    }
    // G into the input columns (a, nx + m), its mirror E^T Hux Sx on the entries (nx + m, a), a >= nx + m
    for a in 0..nz {
        for m in 0..nu {
            let v = g[a * nu + m];
            let col = nx + m;
            if a <= col {
                hess[a * nz + col] += v;
            }
            if a >= col {
                hess[col * nz + a] += v;
            }
        }
    }
    // E^T Huu E
    for a in nx..nz {
        for b in a..nz {
            hess[a * nz + b] += h[a * nz + b];
        }
    }
}
