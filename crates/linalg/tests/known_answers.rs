//! The kernels against known answers and against nalgebra on random matrices: Cholesky factors and
//! solves of random SPD matrices, refusal of indefinite, singular and non-finite ones, the products,
//! the four-lane dot products and the Jacobi eigendecomposition.

use brachia_linalg::{
    add_lincomb, add_lincomb2, cholesky, cholesky_solve, cholesky_solve_in_place,
    cholesky_with_pivot, dot_acc, dot_lanes, dot_lanes_x4, eigen_solve, gemm_nn, gemm_nn_acc,
    gemm_nt, gemm_tn_acc, gemv_n_acc, gemv_t_acc, sym_eigen, NotPositiveDefinite, Scaling,
};
use nalgebra::DMatrix;
use num_dual::Dual64;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random(rng: &mut ChaCha8Rng, len: usize) -> Vec<f64> {
    (0..len).map(|_| rng.gen_range(-1.0..1.0)).collect()
}

/// A random SPD matrix `Q diag(eig) Q^T` with eigenvalues spread log-uniformly over `cond`.
fn random_spd(rng: &mut ChaCha8Rng, n: usize, cond: f64) -> DMatrix<f64> {
    let a = DMatrix::from_row_slice(n, n, &random(rng, n * n));
    let q = a.qr().q();
    let eig: Vec<f64> = (0..n)
        .map(|i| {
            cond.powf(if n > 1 {
                i as f64 / (n - 1) as f64
            } else {
                0.0
            })
        })
        .collect();
    let d = DMatrix::from_diagonal(&nalgebra::DVector::from_vec(eig));
    let m = &q * d * q.transpose();
    (&m + m.transpose()) * 0.5
}

fn row_major(m: &DMatrix<f64>) -> Vec<f64> {
    let mut v = Vec::with_capacity(m.nrows() * m.ncols());
    for i in 0..m.nrows() {
        for j in 0..m.ncols() {
            v.push(m[(i, j)]);
        }
    }
    v
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn cholesky_of_a_known_matrix() {
    // A = L L^T with L = [[2, 0, 0], [1, 3, 0], [-1, 2, 1]]
    let mut a = [4.0, 2.0, -2.0, 2.0, 10.0, 5.0, -2.0, 5.0, 6.0];
    let upper = [a[1], a[2], a[5]];
    cholesky(&mut a, 3, Scaling::Divide).expect("SPD");
    let l = [a[0], a[3], a[4], a[6], a[7], a[8]];
    assert_eq!(l, [2.0, 1.0, 3.0, -1.0, 2.0, 1.0]);
    // the strict upper triangle is left alone
    assert_eq!([a[1], a[2], a[5]], upper);
    // A x = b for x = [1, -2, 3]
    let mut b = [4.0 - 4.0 - 6.0, 2.0 - 20.0 + 15.0, -2.0 - 10.0 + 18.0];
    cholesky_solve(&a, 3, &mut b, 1, Scaling::Divide);
    assert!(max_abs_diff(&b, &[1.0, -2.0, 3.0]) < 1e-14, "{b:?}");
}

#[test]
fn random_spd_matrices_factor_and_solve_as_nalgebra_does() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for n in 1..=20 {
        for cond in [1.0, 1e3, 1e8] {
            let a = random_spd(&mut rng, n, cond);
            let scaling = [Scaling::Divide, Scaling::Reciprocal][n % 2];
            let mut l = row_major(&a);
            cholesky(&mut l, n, scaling).expect("SPD");
            let reference = a.clone().cholesky().expect("nalgebra: SPD").l();
            for i in 0..n {
                for j in 0..=i {
                    let (got, want) = (l[i * n + j], reference[(i, j)]);
                    assert!(
                        (got - want).abs() <= 1e-12 * (1.0 + want.abs()) * cond.sqrt(),
                        "n {n} cond {cond} L[{i}][{j}] {got} vs {want}"
                    );
                }
            }
            for m in [1, 3, 8] {
                let b = DMatrix::from_row_slice(n, m, &random(&mut rng, n * m));
                let want = a.clone().cholesky().unwrap().solve(&b);
                let mut x = row_major(&b);
                cholesky_solve(&l, n, &mut x, m, scaling);
                let scale = row_major(&want).iter().fold(1.0f64, |s, v| s.max(v.abs()));
                let err = max_abs_diff(&x, &row_major(&want));
                assert!(
                    err <= 1e-13 * cond * scale,
                    "n {n} m {m} cond {cond}: {err:e}"
                );
                // and the residual A x - b is small
                let xm = DMatrix::from_row_slice(n, m, &x);
                let res = (&a * xm - &b).abs().max();
                // backward stable: |A x - b| ~ n eps |A| |x|, |A| = cond
                let bound = 1e-14 * n as f64 * cond * scale;
                assert!(res <= bound, "n {n} m {m} cond {cond}: residual {res:e}");
            }
        }
    }
}

#[test]
fn non_spd_matrices_are_refused_with_the_failing_column() {
    // indefinite: eigenvalues 3 and -1
    let mut a = [1.0, 2.0, 2.0, 1.0];
    let err = cholesky(&mut a, 2, Scaling::Divide).unwrap_err();
    assert_eq!(err.column, 1);
    assert!(err.pivot < 0.0);
    // singular (rank 1)
    let mut s = [1.0, 1.0, 1.0, 1.0];
    assert_eq!(cholesky(&mut s, 2, Scaling::Divide).unwrap_err().column, 1);
    // negative first pivot
    let mut neg = [-1.0, 0.0, 0.0, 1.0];
    assert_eq!(
        cholesky(&mut neg, 2, Scaling::Divide),
        Err(NotPositiveDefinite {
            column: 0,
            pivot: -1.0
        })
    );
    // non-finite entries
    let mut nan = [1.0, 0.0, 0.0, f64::NAN];
    assert_eq!(
        cholesky(&mut nan, 2, Scaling::Divide).unwrap_err().column,
        1
    );
    let mut inf = [f64::INFINITY, 0.0, 0.0, 1.0];
    assert_eq!(
        cholesky(&mut inf, 2, Scaling::Divide).unwrap_err().column,
        0
    );
    // positive semidefinite with an exactly zero second pivot
    let mut psd = [4.0, 2.0, 2.0, 2.0, 1.0, 1.0, 2.0, 1.0, 5.0];
    assert_eq!(
        cholesky(&mut psd, 3, Scaling::Divide),
        Err(NotPositiveDefinite {
            column: 1,
            pivot: 0.0
        })
    );
    // a pivot below 1e-13 of its diagonal entry is singular to working precision
    let nearly = [1.0, 1.0, 1.0, 1.0 + 1e-15];
    let err = cholesky(&mut nearly.clone(), 2, Scaling::Divide).unwrap_err();
    assert_eq!(err.column, 1);
    // ... unless the threshold is lowered: with 0 any positive pivot passes
    let mut l = nearly;
    cholesky_with_pivot(&mut l, 2, Scaling::Divide, 0.0).expect("positive pivot");
    assert!(l[3] > 0.0 && l[3] < 1e-7, "{l:?}");
    assert!(cholesky_with_pivot(&mut [1.0, 1.0, 1.0, 1.0], 2, Scaling::Divide, 0.0).is_err());
    assert!(cholesky_with_pivot(&mut [f64::NAN], 1, Scaling::Divide, 0.0).is_err());
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    // and the solve leaves b alone on failure
    let mut bad = [1.0, 2.0, 2.0, 1.0];
    let mut b = [1.0, 2.0];
    assert!(
        cholesky_solve_in_place(&mut bad, 2, &mut b, Scaling::Divide, Scaling::Divide).is_err()
    );
    assert_eq!(b, [1.0, 2.0]);
    // random indefinite matrices: nalgebra refuses them too
    for n in 2..=12 {
        let mut a = random_spd(&mut rng, n, 10.0);
        a[(n / 2, n / 2)] -= 20.0;
        assert!(a.clone().cholesky().is_none());
        assert!(
            cholesky(&mut row_major(&a), n, Scaling::Divide).is_err(),
            "n {n}"
        );
    }
}

#[test]
fn a_dual_solve_carries_the_exact_derivative() {
    // A(t) = A0 + t A1, x(t) = A(t)^-1 b: dx/dt = -A^-1 A1 x
    let a0 = [4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0];
    let a1 = [0.3, -0.1, 0.0, -0.1, 0.2, 0.4, 0.0, 0.4, -0.2];
    let b = [1.0, -1.0, 2.0];
    let mut a: Vec<Dual64> = a0
        .iter()
        .zip(&a1)
        .map(|(&v, &d)| Dual64::new(v, d))
        .collect();
    let mut x: Vec<Dual64> = b.iter().map(|&v| Dual64::from(v)).collect();
    cholesky_solve_in_place(&mut a, 3, &mut x, Scaling::Reciprocal, Scaling::Divide).expect("SPD");
    let am = DMatrix::from_row_slice(3, 3, &a0);
    let xm = am
        .clone()
        .lu()
        .solve(&DMatrix::from_row_slice(3, 1, &b))
        .unwrap();
    let dx = -am
        .lu()
        .solve(&(DMatrix::from_row_slice(3, 3, &a1) * &xm))
        .unwrap();
    for i in 0..3 {
        assert!((x[i].re - xm[i]).abs() < 1e-14);
        assert!(
            (x[i].eps - dx[i]).abs() < 1e-13,
            "{} vs {}",
            x[i].eps,
            dx[i]
        );
    }
}

#[test]
fn products_agree_with_nalgebra() {
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for (m, r, n) in [
        (1, 1, 1),
        (2, 3, 4),
        (5, 8, 8),
        (7, 4, 11),
        (3, 13, 17),
        (9, 6, 20),
    ] {
        let a = DMatrix::from_row_slice(m, r, &random(&mut rng, m * r));
        let b = DMatrix::from_row_slice(r, n, &random(&mut rng, r * n));
        let c0 = DMatrix::from_row_slice(m, n, &random(&mut rng, m * n));
        let tol = 1e-14 * r as f64;
        // c = a b
        let mut c = vec![9.0; m * n];
        gemm_nn(&row_major(&a), &row_major(&b), &mut c, m, r, n);
        assert!(max_abs_diff(&c, &row_major(&(&a * &b))) < tol);
        // c += a b
        let mut c = row_major(&c0);
        gemm_nn_acc(&row_major(&a), &row_major(&b), &mut c, m, r, n);
        assert!(max_abs_diff(&c, &row_major(&(&c0 + &a * &b))) < tol);
        // c += at^T b with at = a^T (r x m)
        let mut c = row_major(&c0);
        gemm_tn_acc(&row_major(&a.transpose()), &row_major(&b), &mut c, r, m, n);
        assert!(max_abs_diff(&c, &row_major(&(&c0 + &a * &b))) < tol);
        // c = a bt^T with bt = b^T (n x r)
        let mut c = vec![9.0; m * n];
        gemm_nt(&row_major(&a), &row_major(&b.transpose()), &mut c, m, r, n);
        assert!(max_abs_diff(&c, &row_major(&(&a * &b))) < tol);
        // y += a x, y += a^T x
        let x = random(&mut rng, r);
        let y0 = random(&mut rng, m);
        let mut y = y0.clone();
        gemv_n_acc(&row_major(&a), &x, &mut y, m, r);
        let want = DMatrix::from_row_slice(m, 1, &y0) + &a * DMatrix::from_row_slice(r, 1, &x);
        assert!(max_abs_diff(&y, want.as_slice()) < tol);
        let xt = random(&mut rng, m);
        let yt0 = random(&mut rng, r);
        let mut yt = yt0.clone();
        gemv_t_acc(&row_major(&a), &xt, &mut yt, m, r);
        let want = DMatrix::from_row_slice(r, 1, &yt0)
            + a.transpose() * DMatrix::from_row_slice(m, 1, &xt);
        assert!(max_abs_diff(&yt, want.as_slice()) < tol);
    }
}

#[test]
fn dots_and_linear_combinations_of_known_values() {
    let a = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0];
    let b = [1.0, -1.0, 0.5, 2.0, 0.0, 1.0, -2.0];
    let want = 1.0 - 2.0 + 1.5 + 8.0 + 0.0 + 6.0 - 14.0;
    assert_eq!(dot_acc(0.0, &a, &b), want);
    assert_eq!(dot_acc(1.0, &a, &b), want + 1.0);
    assert_eq!(dot_lanes(&a, &b), want);
    let rows: [&[f64]; 4] = [&a, &b, &a, &b];
    let bb = dot_lanes(&b, &b);
    assert_eq!(dot_lanes_x4(rows, &b), [want, bb, want, bb]);
    // the four lanes round as stated: lanes summed apart, then the remainder
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for len in 0..30 {
        let (x, y) = (random(&mut rng, len), random(&mut rng, len));
        let mut lane = [0.0; 4];
        for k in 0..len / 4 * 4 {
            lane[k % 4] += x[k] * y[k];
        }
        let mut s = (lane[0] + lane[1]) + (lane[2] + lane[3]);
        for k in len / 4 * 4..len {
            s += x[k] * y[k];
        }
        assert_eq!(dot_lanes(&x, &y), s, "len {len}");
        let rows: [&[f64]; 4] = [&x, &y, &y, &x];
        let got = dot_lanes_x4(rows, &y);
        assert_eq!(got[0], s);
        assert_eq!(got[1], dot_lanes(&y, &y));
    }
    // out += 2 r0 - r1 over rows of stride 3
    let rows = [1.0, 2.0, 9.0, 3.0, 4.0, 9.0];
    let mut out = [10.0, 20.0];
    add_lincomb(&mut out, &[2.0, -1.0], 1, &rows, 3, 2);
    assert_eq!(out, [10.0 + 2.0 - 3.0, 20.0 + 4.0 - 4.0]);
    let (mut o0, mut o1) = ([0.0; 2], [1.0; 2]);
    add_lincomb2(
        &mut o0,
        &mut o1,
        &[1.0, 0.0, 1.0],
        &[0.0, 0.0, 2.0],
        2,
        &rows,
        3,
        2,
    );
    assert_eq!((o0, o1), ([4.0, 6.0], [7.0, 9.0]));
}

#[test]
fn jacobi_eigendecomposition_matches_nalgebra() {
    let mut rng = ChaCha8Rng::seed_from_u64(13);
    for n in 1..=10 {
        let s = DMatrix::from_row_slice(n, n, &random(&mut rng, n * n));
        let sym = (&s + s.transpose()) * 0.5;
        let mut a = row_major(&sym);
        let (mut d, mut v) = (vec![0.0; n], vec![0.0; n * n]);
        assert!(sym_eigen(&mut a, n, &mut d, &mut v));
        let mut want: Vec<f64> = sym
            .clone()
            .symmetric_eigen()
            .eigenvalues
            .iter()
            .copied()
            .collect();
        let mut got = d.clone();
        want.sort_by(f64::total_cmp);
        got.sort_by(f64::total_cmp);
        assert!(
            max_abs_diff(&got, &want) < 1e-12,
            "n {n}: {got:?} vs {want:?}"
        );
        // solve with an indefinite matrix
        if d.iter().all(|x| x.abs() > 1e-6) {
            let x = random(&mut rng, n);
            let mut b = vec![0.0; n];
            gemv_n_acc(&row_major(&sym), &x, &mut b, n, n);
            let mut tmp = vec![0.0; n];
            eigen_solve(&v, &d, n, &mut b, &mut tmp);
            let cond = d.iter().fold(0.0f64, |m, v| m.max(v.abs()))
                / d.iter().fold(f64::INFINITY, |m, v| m.min(v.abs()));
            assert!(max_abs_diff(&b, &x) < 1e-13 * cond, "n {n}");
        }
    }
}
