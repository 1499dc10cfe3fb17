//! Exact squared distances between points and segments, generic over the scalar type.
//!
//! These are the primitives of the capsule collision model (paper eqs. 11-13, see
//! [`crate::model::ClearanceFn`] and `docs/collision.md`): a link is a segment plus a radius, an obstacle
//! a point plus a radius, so every clearance is a point-segment or segment-segment distance minus radii.
//! Points are `[T; N]` (the model is planar, `N = 2`, but nothing here depends on it); lengths in m,
//! squared distances in m^2.
//!
//! # Closed form and clamping
//! The closest-point parameters are computed in closed form. Every *branch decision* (which endpoint is
//! clamped, which candidate is the smallest) is taken on real parts only, so for `T = Dual64` or
//! `HyperDual64` the returned value is one smooth closed-form expression of the inputs and its derivative
//! parts are the exact derivatives of that expression ("piece").
//!
//! # Where the functions are differentiable (what a solver sees)
//! Both squared distances are continuous everywhere and piecewise smooth (C-infinity inside each piece).
//!
//! * [`point_segment_dist2`] (segment `a != b`): three pieces, selected by the unclamped projection
//!   parameter `t* = (p - a).(b - a) / |b - a|^2`: `t* <= 0` (distance to `a`), `0 < t* < 1` (distance
//!   to the line), `t* >= 1` (distance to `b`). Across the piece boundaries the function is **C1**
//!   (envelope property: at `t* = 0` both pieces equal `|p - a|^2` and, since `d/dt |p - a - t (b - a)|^2
//!   = 0` at the optimum, so do their gradients); the **second derivative jumps** there (the interior
//!   piece has zero curvature along the segment, an endpoint piece has curvature 2). The AD Hessian is the
//!   one of the piece selected by the real part, i.e. a one-sided Hessian on the boundary.
//! * Zero-length segment `a == b` (exactly, `|b - a|^2 == 0`): the result is `|p - a|^2` with `t = 0`.
//!   The squared distance is still continuous there but **not differentiable** with respect to `a` and
//!   `b` separately (the minimiser over `t` is not unique; the directional derivative along a change
//!   `db` of `b` is `min(0, -2 (p - a).db)`); the value returned treats the segment as the point `a`.
//!   Robot links have positive length (validated), so the collision model never hits this case.
//! * [`segment_segment_dist2`]: the minimum of a convex quadratic over `(s, t)` in `[0, 1]^2`. By
//!   Danskin's theorem it is **C1 wherever the closest pair of points is unique**, i.e. everywhere except
//!   (i) parallel (or collinear) segments whose projections overlap in more than a point and (ii)
//!   zero-length segments. There the distance has a genuine kink: turning one of two parallel,
//!   overlapping segments about a point makes one end approach the other segment, at first order in the
//!   angle, whichever way it turns, so the distance is locally the `min` of two smooth functions. The AD
//!   derivative there is the one of the candidate selected first (a one-sided derivative, an element of
//!   the Clarke subdifferential). Away from those sets the AD gradient is the true gradient, and the
//!   second derivative jumps
//!   where the selected piece changes (an unclamped closest-point parameter crosses 0 or 1).
//! * In 2-D, crossing segments have squared distance identically 0 in an open set, so the derivative is
//!   **zero** there: a constraint `d^2 >= R^2` gives a solver no direction out of a crossing. Near-contact
//!   configurations (`0 < d`) are unaffected; across the crossing boundary the function is C1 (like
//!   `max(h, 0)^2`).
//!
//! Tests: brute-force minimisation on dense grids and AD-vs-finite-difference checks, in this file.

use crate::math::{re, Scalar};

/// Which closed-form piece [`point_segment_closest`] used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointSegmentPiece {
    /// The projection falls before the start: the distance to `a` (`t = 0`).
    Start,
    /// The projection falls strictly inside the segment: the distance to the line (`0 < t < 1`).
    Interior,
    /// The projection falls after the end: the distance to `b` (`t = 1`).
    End,
    /// The segment has length exactly zero: the distance to `a` (`t = 0`); not differentiable in `a`,
    /// `b` separately (see the module docs).
    Degenerate,
}

/// Result of [`point_segment_closest`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointSegmentClosest<T> {
    /// Squared distance, m^2.
    pub dist2: T,
    /// Parameter of the closest point `a + t (b - a)`, `t` in `[0, 1]`.
    pub t: T,
    /// The piece used.
    pub piece: PointSegmentPiece,
}

/// Which closed-form piece [`segment_segment_closest`] used.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SegmentSegmentPiece {
    /// Both parameters strictly inside `(0, 1)`: the common perpendicular (0 for crossing 2-D segments).
    Interior,
    /// `a0` against segment B (`s = 0`).
    A0,
    /// `a1` against segment B (`s = 1`).
    A1,
    /// `b0` against segment A (`t = 0`).
    B0,
    /// `b1` against segment A (`t = 1`).
    B1,
}

/// Result of [`segment_segment_closest`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentSegmentClosest<T> {
    /// Squared distance, m^2.
    pub dist2: T,
    /// Parameter of the closest point `a0 + s (a1 - a0)` on segment A, in `[0, 1]`.
    pub s: T,
    /// Parameter of the closest point `b0 + t (b1 - b0)` on segment B, in `[0, 1]`.
    pub t: T,
    /// The piece used.
    pub piece: SegmentSegmentPiece,
}

/// Below this value of `sin^2` of the angle between two segments they are treated as parallel: the
/// interior candidate is skipped and the distance is the smallest endpoint-to-segment distance. The
/// error this makes is at most `(L sin(angle))^2 <= 1e-14 L^2` (L the shorter length), and the interior
/// candidate is in any case only used when it beats the four endpoint candidates.
pub const PARALLEL_SIN2: f64 = 1e-14;

#[inline(always)]
fn sub<T: Scalar, const N: usize>(a: [T; N], b: [T; N]) -> [T; N] {
    std::array::from_fn(|k| a[k] - b[k])
}

#[inline(always)]
fn dot<T: Scalar, const N: usize>(a: [T; N], b: [T; N]) -> T {
    let mut s = a[0] * b[0];
    for k in 1..N {
        s += a[k] * b[k];
    }
    s
}

/// Squared distance from point `p` to the segment `[a, b]`, m^2. See [`point_segment_closest`].
#[inline]
pub fn point_segment_dist2<T: Scalar, const N: usize>(p: [T; N], a: [T; N], b: [T; N]) -> T {
    point_segment_closest(p, a, b).dist2
}

/// Closest point of the segment `[a, b]` to `p`: squared distance, parameter and the piece used.
///
/// The clamping of `t* = (p - a).(b - a) / |b - a|^2` to `[0, 1]` is decided on real parts (without
/// dividing), and the returned squared distance is computed from the residual `p - a - t (b - a)` (no
/// cancellation). Never panics; non-finite inputs give non-finite outputs. `N >= 1`.
pub fn point_segment_closest<T: Scalar, const N: usize>(
    p: [T; N],
    a: [T; N],
    b: [T; N],
) -> PointSegmentClosest<T> {
    let d = sub(b, a);
    let w = sub(p, a);
    let l2 = dot(d, d);
    let l2r = re(l2);
    // `l2r <= 0` or NaN: treat as a point (NaN propagates through the value)
    if l2r.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return PointSegmentClosest {
            dist2: dot(w, w),
            t: T::zero(),
            piece: PointSegmentPiece::Degenerate,
        };
    }
    let num = dot(w, d);
    let nr = re(num);
    if nr <= 0.0 {
        PointSegmentClosest {
            dist2: dot(w, w),
            t: T::zero(),
            piece: PointSegmentPiece::Start,
        }
    } else if nr >= l2r {
        let v = sub(p, b);
        PointSegmentClosest {
            dist2: dot(v, v),
            t: T::one(),
            piece: PointSegmentPiece::End,
        }
    } else {
        let t = num / l2;
        let r: [T; N] = std::array::from_fn(|k| w[k] - t * d[k]);
        PointSegmentClosest {
            dist2: dot(r, r),
            t,
            piece: PointSegmentPiece::Interior,
        }
    }
}

/// Squared distance between the segments `[a0, a1]` and `[b0, b1]`, m^2. See
/// [`segment_segment_closest`].
#[inline]
pub fn segment_segment_dist2<T: Scalar, const N: usize>(
    a0: [T; N],
    a1: [T; N],
    b0: [T; N],
    b1: [T; N],
) -> T {
    segment_segment_closest(a0, a1, b0, b1).dist2
}

/// Closest points of the segments `A = [a0, a1]` and `B = [b0, b1]`.
///
/// The squared distance `min_{s, t in [0,1]} |a0 + s (a1 - a0) - b0 - t (b1 - b0)|^2` is a convex
/// quadratic minimised over the unit square, so its minimum is either the unconstrained stationary point
/// (when it lies strictly inside the square) or the minimum over one of the four edges, each of which is
/// a point-segment distance ([`point_segment_closest`]). All five candidates are evaluated in closed
/// form; the smallest real part wins (ties: the interior, then `A0, A1, B0, B1` in that order). Every
/// candidate is the value of the objective at a feasible `(s, t)`, so the result is never below the true
/// minimum, and the exact minimiser is always among the candidates (up to the near-parallel cut-off
/// [`PARALLEL_SIN2`]). Parallel, collinear and zero-length segments need no special case: the interior
/// candidate is skipped when `sin^2(angle) <= PARALLEL_SIN2`, and the minimum over a flat valley is then
/// attained on an edge. `sin^2` is computed from the Lagrange identity
/// `|d1|^2 |d2|^2 - (d1.d2)^2 = sum_{i<j} (d1_i d2_j - d1_j d2_i)^2` (no cancellation). Never panics.
pub fn segment_segment_closest<T: Scalar, const N: usize>(
    a0: [T; N],
    a1: [T; N],
    b0: [T; N],
    b1: [T; N],
) -> SegmentSegmentClosest<T> {
    use SegmentSegmentPiece as P;
    let c = [
        point_segment_closest(a0, b0, b1),
        point_segment_closest(a1, b0, b1),
        point_segment_closest(b0, a0, a1),
        point_segment_closest(b1, a0, a1),
    ];
    let mut k_best = 0;
    for k in 1..4 {
        if re(c[k].dist2) < re(c[k_best].dist2) {
            k_best = k;
        }
    }
    let mut best = match k_best {
        0 => SegmentSegmentClosest {
            dist2: c[0].dist2,
            s: T::zero(),
            t: c[0].t,
            piece: P::A0,
        },
        1 => SegmentSegmentClosest {
            dist2: c[1].dist2,
            s: T::one(),
            t: c[1].t,
            piece: P::A1,
        },
        2 => SegmentSegmentClosest {
            dist2: c[2].dist2,
            s: c[2].t,
            t: T::zero(),
            piece: P::B0,
        },
        _ => SegmentSegmentClosest {
            dist2: c[3].dist2,
            s: c[3].t,
            t: T::one(),
            piece: P::B1,
        },
    };

    // Interior candidate: stationary point of |w + s d1 - t d2|^2.
    let d1 = sub(a1, a0);
    let d2 = sub(b1, b0);
    let w = sub(a0, b0);
    let aa = dot(d1, d1);
    let ee = dot(d2, d2);
    let mut denom = T::zero();
    for i in 0..N {
        for j in i + 1..N {
            let m = d1[i] * d2[j] - d1[j] * d2[i];
            denom += m * m;
        }
    }
    let dr = re(denom);
    if dr > PARALLEL_SIN2 * re(aa) * re(ee) && dr > 0.0 {
        let bb = dot(d1, d2);
        let cc = dot(d1, w);
        let ff = dot(d2, w);
        let s_num = bb * ff - cc * ee;
        let t_num = aa * ff - bb * cc;
        let (sr, tr) = (re(s_num), re(t_num));
        if sr > 0.0 && sr < dr && tr > 0.0 && tr < dr {
            let s = s_num / denom;
            let t = t_num / denom;
            let r: [T; N] = std::array::from_fn(|k| w[k] + s * d1[k] - t * d2[k]);
            let d2i = dot(r, r);
            if re(d2i) <= re(best.dist2) {
                best = SegmentSegmentClosest {
                    dist2: d2i,
                    s,
                    t,
                    piece: P::Interior,
                };
            }
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ad::{as_f64_fn, Diff, LocalFn};
    use crate::fdcheck::{assert_hessian, assert_jacobian};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    // ---------- independent brute force ----------

    /// Minimise a convex function of one variable on `[0, 1]` by a grid and repeated zooming: for a
    /// convex function the minimiser lies within one grid step of the best sample, so zooming to
    /// +-2 steps never loses it.
    fn zoom_min(f: impl Fn(f64) -> f64, m: usize, rounds: usize) -> f64 {
        let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
        let (mut best, mut tb) = (f64::INFINITY, 0.0);
        for _ in 0..rounds {
            for i in 0..=m {
                let t = lo + (hi - lo) * i as f64 / m as f64;
                let v = f(t);
                if v < best {
                    best = v;
                    tb = t;
                }
            }
            let h = (hi - lo) / m as f64;
            lo = (tb - 2.0 * h).max(0.0);
            hi = (tb + 2.0 * h).min(1.0);
        }
        best
    }

    /// `min_{t in [0,1]} |p - a - t (b - a)|^2` by [`zoom_min`].
    fn brute_ps<const N: usize>(p: [f64; N], a: [f64; N], b: [f64; N]) -> f64 {
        zoom_min(
            |t| {
                (0..N)
                    .map(|k| (p[k] - a[k] - t * (b[k] - a[k])).powi(2))
                    .sum::<f64>()
            },
            40,
            24,
        )
    }

    /// `min_{s,t in [0,1]^2}` of the segment-segment objective as nested 1-D minimisations: the partial
    /// minimum over t of a jointly convex function is convex in s, so [`zoom_min`] applies to both.
    fn brute_ss<const N: usize>(a0: [f64; N], a1: [f64; N], b0: [f64; N], b1: [f64; N]) -> f64 {
        zoom_min(|s| brute_ps(lerp(a0, a1, s), b0, b1), 40, 24)
    }

    fn rp<const N: usize>(rng: &mut ChaCha8Rng) -> [f64; N] {
        std::array::from_fn(|_| rng.gen_range(-1.0..1.0))
    }

    fn lerp<const N: usize>(a: [f64; N], b: [f64; N], t: f64) -> [f64; N] {
        std::array::from_fn(|k| a[k] + t * (b[k] - a[k]))
    }

    /// Random segment pairs of every special kind: general, crossing, parallel (offset), collinear
    /// overlapping, collinear disjoint, touching at endpoints, endpoint on the other's interior (T),
    /// zero-length (one or both), identical, reversed-identical.
    fn cases<const N: usize>(rng: &mut ChaCha8Rng, count: usize) -> Vec<[[f64; N]; 4]> {
        let mut v = Vec::new();
        for i in 0..count {
            let (a0, a1) = (rp::<N>(rng), rp::<N>(rng));
            let kind = i % 11;
            let c = match kind {
                0 => [a0, a1, rp(rng), rp(rng)],
                1 => {
                    // crossing: both segments pass through a common point x
                    let x = lerp(a0, a1, rng.gen_range(0.05..0.95));
                    let dir = rp::<N>(rng);
                    let (u, w) = (rng.gen_range(0.1..1.0), rng.gen_range(0.1..1.0));
                    [
                        a0,
                        a1,
                        std::array::from_fn(|k| x[k] - u * dir[k]),
                        std::array::from_fn(|k| x[k] + w * dir[k]),
                    ]
                }
                2 => {
                    // parallel, offset
                    let off = rp::<N>(rng);
                    let (u, w) = (rng.gen_range(-0.5..1.5), rng.gen_range(-0.5..1.5));
                    let p = lerp(a0, a1, u);
                    let q = lerp(a0, a1, w);
                    [
                        a0,
                        a1,
                        std::array::from_fn(|k| p[k] + off[k]),
                        std::array::from_fn(|k| q[k] + off[k]),
                    ]
                }
                3 => [
                    a0,
                    a1,
                    lerp(a0, a1, rng.gen_range(-0.5..0.5)),
                    lerp(a0, a1, rng.gen_range(0.5..1.5)),
                ],
                4 => [
                    a0,
                    a1,
                    lerp(a0, a1, rng.gen_range(1.1..1.5)),
                    lerp(a0, a1, rng.gen_range(1.6..2.5)),
                ],
                5 => [a0, a1, a1, rp(rng)],
                6 => [a0, a1, lerp(a0, a1, rng.gen_range(0.1..0.9)), rp(rng)],
                7 => [a0, a0, rp(rng), rp(rng)],
                8 => {
                    let p = rp(rng);
                    [a0, a1, p, p]
                }
                9 => [a0, a0, a1, a1],
                _ => {
                    if rng.gen_bool(0.5) {
                        [a0, a1, a0, a1]
                    } else {
                        [a0, a1, a1, a0]
                    }
                }
            };
            v.push(c);
        }
        v
    }

    #[test]
    fn point_segment_matches_brute_force() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        for i in 0..600 {
            let (a, b) = (rp::<2>(&mut rng), rp::<2>(&mut rng));
            let p = match i % 6 {
                0 | 1 => rp(&mut rng),
                2 => lerp(a, b, rng.gen_range(0.0..1.0)), // on the segment
                3 => a,                                   // at an endpoint
                4 => lerp(a, b, rng.gen_range(1.0..2.0)), // on the line, beyond b
                _ => rp(&mut rng),
            };
            let b = if i % 6 == 5 { a } else { b }; // zero length
            let got = point_segment_dist2(p, a, b);
            let want = brute_ps(p, a, b);
            assert!(
                (got - want).abs() <= 1e-12 + 1e-9 * want,
                "case {i}: p {p:?} a {a:?} b {b:?}: {got} vs brute force {want}"
            );
            assert!(got >= 0.0);
        }
        // 3-D as well
        for i in 0..200 {
            let (p, a, b) = (rp::<3>(&mut rng), rp::<3>(&mut rng), rp::<3>(&mut rng));
            let (got, want) = (point_segment_dist2(p, a, b), brute_ps(p, a, b));
            assert!((got - want).abs() <= 1e-12 + 1e-9 * want, "3-D case {i}");
        }
    }

    #[test]
    fn point_segment_known_values() {
        let (a, b) = ([0.0, 0.0], [2.0, 0.0]);
        assert_eq!(point_segment_dist2([1.0, 3.0], a, b), 9.0);
        assert_eq!(point_segment_dist2([-3.0, 4.0], a, b), 25.0);
        assert_eq!(point_segment_dist2([5.0, -4.0], a, b), 25.0);
        assert_eq!(point_segment_dist2([1.0, 0.0], a, b), 0.0);
        let c = point_segment_closest([0.5, 1.0], a, b);
        assert_eq!((c.t, c.piece), (0.25, PointSegmentPiece::Interior));
        let c = point_segment_closest([0.5, 1.0], a, a);
        assert_eq!((c.dist2, c.piece), (1.25, PointSegmentPiece::Degenerate));
    }

    fn check_ss_cases<const N: usize>(seed: u64, count: usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for (i, [a0, a1, b0, b1]) in cases::<N>(&mut rng, count).into_iter().enumerate() {
            let r = segment_segment_closest(a0, a1, b0, b1);
            let want = brute_ss(a0, a1, b0, b1);
            assert!(
                (r.dist2 - want).abs() <= 1e-12 + 1e-9 * want,
                "{N}-D case {i} (kind {}): {a0:?} {a1:?} / {b0:?} {b1:?}: {} vs brute force {want}",
                i % 11,
                r.dist2
            );
            // the reported parameters realise the reported distance
            let (s, t) = (r.s, r.t);
            assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t));
            let pa = lerp(a0, a1, s);
            let pb = lerp(b0, b1, t);
            let d2: f64 = (0..N).map(|k| (pa[k] - pb[k]).powi(2)).sum();
            assert!(
                (d2 - r.dist2).abs() <= 1e-12,
                "case {i}: parameters inconsistent"
            );
            // symmetric in the order of segments and of endpoints
            for other in [
                segment_segment_dist2(b0, b1, a0, a1),
                segment_segment_dist2(a1, a0, b1, b0),
            ] {
                assert!(
                    (other - r.dist2).abs() <= 1e-12 + 1e-9 * want,
                    "case {i}: asymmetry"
                );
            }
            // known zeros: crossing, collinear overlap, touching, T, identical
            if matches!(i % 11, 1 | 3 | 5 | 6 | 10) {
                assert!(
                    r.dist2 <= 1e-24,
                    "case {i}: expected contact, got {}",
                    r.dist2
                );
            }
        }
    }

    #[test]
    fn segment_segment_matches_brute_force_2d() {
        check_ss_cases::<2>(2, 440);
    }

    #[test]
    fn segment_segment_matches_brute_force_3d() {
        check_ss_cases::<3>(3, 220);
    }

    #[test]
    fn segment_segment_known_values() {
        // parallel horizontal segments 1 apart, overlapping in x
        assert_eq!(
            segment_segment_dist2([0.0, 0.0], [2.0, 0.0], [1.0, 1.0], [3.0, 1.0]),
            1.0
        );
        // collinear, gap of 0.5
        assert_eq!(
            segment_segment_dist2([0.0, 0.0], [1.0, 0.0], [1.5, 0.0], [3.0, 0.0]),
            0.25
        );
        // X crossing
        let r: SegmentSegmentClosest<f64> =
            segment_segment_closest([-1.0, -1.0], [1.0, 1.0], [-1.0, 1.0], [1.0, -1.0]);
        assert_eq!(r.piece, SegmentSegmentPiece::Interior);
        assert!(r.dist2.abs() < 1e-30 && (r.s - 0.5).abs() < 1e-15 && (r.t - 0.5).abs() < 1e-15);
        // skew lines in 3-D: x-axis vs the line y = 1 along z
        let r: SegmentSegmentClosest<f64> = segment_segment_closest(
            [-1.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, -1.0],
            [0.0, 1.0, 1.0],
        );
        assert_eq!(r.piece, SegmentSegmentPiece::Interior);
        assert!((r.dist2 - 1.0).abs() < 1e-15);
        // both degenerate
        assert_eq!(
            segment_segment_dist2([1.0, 1.0], [1.0, 1.0], [4.0, 5.0], [4.0, 5.0]),
            25.0
        );
        // nearly parallel crossing (angle 1e-9): true distance 0, error bounded by PARALLEL_SIN2
        let e = 1e-9;
        let d2 = segment_segment_dist2([0.0, -e], [1.0, e], [0.0, 0.0], [1.0, 0.0]);
        assert!(d2 <= PARALLEL_SIN2, "{d2}");
    }

    // ---------- derivatives ----------

    struct Ps<const N: usize>;
    impl<const N: usize> LocalFn for Ps<N> {
        type Scratch<T: Scalar> = ();
        fn n_in(&self) -> usize {
            3 * N
        }
        fn n_out(&self) -> usize {
            1
        }
        fn scratch<T: Scalar>(&self) {}
        fn eval<T: Scalar>(&self, _: &mut (), z: &[T], out: &mut [T]) {
            let g = |k: usize| -> [T; N] { std::array::from_fn(|i| z[k * N + i]) };
            out[0] = point_segment_dist2(g(0), g(1), g(2));
        }
    }

    struct Ss<const N: usize>;
    impl<const N: usize> LocalFn for Ss<N> {
        type Scratch<T: Scalar> = ();
        fn n_in(&self) -> usize {
            4 * N
        }
        fn n_out(&self) -> usize {
            1
        }
        fn scratch<T: Scalar>(&self) {}
        fn eval<T: Scalar>(&self, _: &mut (), z: &[T], out: &mut [T]) {
            let g = |k: usize| -> [T; N] { std::array::from_fn(|i| z[k * N + i]) };
            out[0] = segment_segment_dist2(g(0), g(1), g(2), g(3));
        }
    }

    /// Unclamped projection parameter of p onto the line through a, b.
    fn proj<const N: usize>(p: [f64; N], a: [f64; N], b: [f64; N]) -> f64 {
        let num: f64 = (0..N).map(|k| (p[k] - a[k]) * (b[k] - a[k])).sum();
        let den: f64 = (0..N).map(|k| (b[k] - a[k]).powi(2)).sum();
        num / den
    }

    fn away(t: f64, delta: f64) -> bool {
        (t - 0.0).abs() > delta && (t - 1.0).abs() > delta
    }

    /// Check value, gradient (vs FD) and Hessian (vs FD of the exact gradient) of `f` at `z`.
    fn check_derivs<F: LocalFn>(f: &F, z: &[f64], what: &str) {
        let n = f.n_in();
        let mut diff = Diff::new(f);
        let (mut out, mut jac) = (vec![0.0; 1], vec![0.0; n]);
        diff.jacobian(f, z, &mut out, &mut jac);
        assert_jacobian(what, as_f64_fn(f), z, &jac, 1e-6);
        let mut hess = vec![0.0; n * n];
        diff.hessian_weighted(f, z, &[1.0], &mut hess);
        let mut gdiff = Diff::new(f);
        let grad = |x: &[f64], g: &mut [f64]| {
            let mut o = [0.0];
            gdiff.jacobian(f, x, &mut o, g);
        };
        assert_hessian(what, grad, z, &hess, 1e-5);
    }

    #[test]
    fn point_segment_derivatives_match_fd() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut checked = [0usize; 3];
        while checked.iter().sum::<usize>() < 300 {
            let (p, a, b) = (rp::<2>(&mut rng), rp::<2>(&mut rng), rp::<2>(&mut rng));
            let t = proj(p, a, b);
            if !away(t, 1e-3) {
                continue;
            }
            let z: Vec<f64> = [p, a, b].concat();
            let piece = point_segment_closest(p, a, b).piece;
            checked[match piece {
                PointSegmentPiece::Start => 0,
                PointSegmentPiece::Interior => 1,
                _ => 2,
            }] += 1;
            check_derivs(&Ps::<2>, &z, &format!("point-segment at {z:?}"));
        }
        assert!(checked.iter().all(|&c| c > 30), "{checked:?}");
    }

    #[test]
    fn point_segment_gradient_is_continuous_across_pieces() {
        // C1 across t* = 0: gradients just before and after the boundary agree to O(h).
        let f = Ps::<2>;
        let mut diff = Diff::new(&f);
        let (a, b) = ([0.0, 0.0], [1.0, 0.0]);
        let mut g = [[0.0; 6]; 2];
        for (k, x) in [-1e-9, 1e-9].into_iter().enumerate() {
            let z = [[x, 0.7], a, b].concat();
            diff.jacobian(&f, &z, &mut [0.0], &mut g[k]);
        }
        for i in 0..6 {
            assert!((g[0][i] - g[1][i]).abs() < 1e-8, "{g:?}");
        }
        // the Hessian jumps there: d2/dpx2 is 2 before (endpoint piece) and 0 after (interior)
        let mut h = [0.0; 36];
        diff.hessian_weighted(&f, &[[-1e-3, 0.7], a, b].concat(), &[1.0], &mut h);
        assert!((h[0] - 2.0).abs() < 1e-12);
        diff.hessian_weighted(&f, &[[1e-3, 0.7], a, b].concat(), &[1.0], &mut h);
        assert!(h[0].abs() < 1e-12);
    }

    /// Distance (in parameter space) of a segment pair from the places where the piece changes: the
    /// unclamped parameters of all four endpoint projections and of the interior stationary point, and
    /// near-parallelism.
    fn ss_away_from_kinks<const N: usize>(
        a0: [f64; N],
        a1: [f64; N],
        b0: [f64; N],
        b1: [f64; N],
    ) -> bool {
        let d = 2e-3;
        let d1: [f64; N] = std::array::from_fn(|k| a1[k] - a0[k]);
        let d2: [f64; N] = std::array::from_fn(|k| b1[k] - b0[k]);
        let w: [f64; N] = std::array::from_fn(|k| a0[k] - b0[k]);
        let dt = |x: [f64; N], y: [f64; N]| -> f64 { (0..N).map(|k| x[k] * y[k]).sum() };
        let (aa, bb, ee, cc, ff) = (dt(d1, d1), dt(d1, d2), dt(d2, d2), dt(d1, w), dt(d2, w));
        let den = aa * ee - bb * bb;
        if den < 1e-2 * aa * ee {
            return false;
        }
        let s = (bb * ff - cc * ee) / den;
        let t = (aa * ff - bb * cc) / den;
        away(s, d)
            && away(t, d)
            && away(proj(a0, b0, b1), d)
            && away(proj(a1, b0, b1), d)
            && away(proj(b0, a0, a1), d)
            && away(proj(b1, a0, a1), d)
    }

    fn check_ss_derivs<const N: usize>(seed: u64, want: usize) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut pieces = std::collections::BTreeMap::new();
        let mut n = 0;
        while n < want {
            let (a0, a1, b0, b1) = (
                rp::<N>(&mut rng),
                rp::<N>(&mut rng),
                rp::<N>(&mut rng),
                rp::<N>(&mut rng),
            );
            if !ss_away_from_kinks(a0, a1, b0, b1) {
                continue;
            }
            n += 1;
            *pieces
                .entry(format!(
                    "{:?}",
                    segment_segment_closest(a0, a1, b0, b1).piece
                ))
                .or_insert(0) += 1;
            let z: Vec<f64> = [a0, a1, b0, b1].concat();
            check_derivs(&Ss::<N>, &z, &format!("segment-segment at {z:?}"));
        }
        // every piece was exercised
        assert_eq!(pieces.len(), 5, "{pieces:?}");
    }

    #[test]
    fn segment_segment_derivatives_match_fd_2d() {
        check_ss_derivs::<2>(5, 300);
    }

    #[test]
    fn segment_segment_derivatives_match_fd_3d() {
        check_ss_derivs::<3>(6, 300);
    }
}
