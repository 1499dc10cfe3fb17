//! Interval enclosures of the reduced two-link model ([`ReducedTwoLink`]) in the coordinates the
//! reachable-set bound of [`crate::reach_box`] works in.
//!
//! The elbow's rate `u` enters the grip's rate through `M12/M11`; the coordinate
//! `z = q1 + phi(q2)`, with `phi(q2) = int_0^q2 M12(s) / M11(s) ds`, removes it:
//!
//! ```text
//! zdot = H / M11(q2),   Hdot = -dV/dq1 (z - phi(q2), q2),   q2dot = u.
//! ```
//!
//! `phi` has a closed form for `M11 = a0 + a1 cos q2`, `M12 = b0 + b1 cos q2` (links whose centres of
//! mass lie on their axes); the `sin q2` terms of a general model are kept in `M11` and their effect
//! on `zdot` is bounded by [`ReachModel::z_slack`] (zero for the hook robot). Every point evaluation
//! of `phi` is widened by [`PHI_PAD`], far above its rounding error (about 1e-14 on these ranges).
use crate::reach_interval::Iv;
use crate::reduced_two_link::ReducedTwoLink;

/// The absolute widening of every evaluation of `phi` and `q2 - phi` at a point, rad.
pub const PHI_PAD: f64 = 1e-12;

/// Why a reduced model has no enclosures here.
#[derive(Debug, Clone, PartialEq)]
pub enum ReachModelError {
    /// `M11` is not bounded away from zero by its coefficients, or `a1` is zero.
    Degenerate,
    /// The hand is not at the end of link 2 on its axis (largest misfit, m).
    HandOffset(f64),
}

impl std::fmt::Display for ReachModelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Degenerate => write!(
                f,
                "the mass matrix's M11 = a0 + a1 cos q2 + a2 sin q2 needs a0 > |a1| + |a2| and a1 != 0"
            ),
            Self::HandOffset(m) => write!(
                f,
                "the hand is not at the end of link 2 on its axis (misfit {m:.3e} m)"
            ),
        }
    }
}

impl std::error::Error for ReachModelError {}

/// The enclosures of `M11`, `M12`, `phi`, `dV/dq1` and the hand.
#[derive(Debug, Clone)]
pub struct ReachModel {
    a: [f64; 3],
    b: [f64; 3],
    g: [f64; 4],
    len: [f64; 2],
    /// `|Hdot| <= gmax` everywhere, N m.
    gmax: f64,
    /// The bound on the `zdot` the `sin q2` terms add, rad/s.
    z_slack: f64,
}

impl ReachModel {
    /// The enclosures of `model`, whose elbow rate stays within `+-u_max` rad/s.
    pub fn new(model: &ReducedTwoLink, u_max: f64) -> Result<Self, ReachModelError> {
        let (a, b, g) = model.coefficients();
        let m11_min = a[0] - a[1].abs() - a[2].abs();
        if m11_min.is_nan() || m11_min <= 0.0 || a[1] == 0.0 {
            return Err(ReachModelError::Degenerate);
        }
        // |M12/M11 - (b0 + b1 c)/(a0 + a1 c)| <= (|b2| + |a2| (|b0| + |b1|) / (a0 - |a1|)) / m11_min
        let dr =
            (b[2].abs() + a[2].abs() * (b[0].abs() + b[1].abs()) / (a[0] - a[1].abs())) / m11_min;
        let z_slack = (u_max.abs() * dr * (1.0 + 1e-9)).next_up();
        let gmax = ((g[0].hypot(g[1]) + g[2].hypot(g[3])) * (1.0 + 1e-12)).next_up();
        let p0 = model.hand(0.0, 0.0);
        let pp = model.hand(0.0, std::f64::consts::PI);
        let len = [(p0[0] + pp[0]) / 2.0, (p0[0] - pp[0]) / 2.0];
        let mut mis = 0.0f64;
        for k in 0..32 {
            let q1 = -3.0 + 0.19 * k as f64;
            let q2 = 2.9 - 0.18 * k as f64;
            let p = model.hand(q1, q2);
            let e = [
                len[0] * q1.cos() + len[1] * (q1 + q2).cos(),
                len[0] * q1.sin() + len[1] * (q1 + q2).sin(),
            ];
            mis = mis.max((p[0] - e[0]).abs()).max((p[1] - e[1]).abs());
        }
        if mis > 1e-12 {
            return Err(ReachModelError::HandOffset(mis));
        }
        Ok(Self {
            a,
            b,
            g,
            len,
            gmax,
            z_slack,
        })
    }

    /// A bound on `|Hdot| = |dV/dq1|` over all poses, N m.
    pub fn gmax(&self) -> f64 {
        self.gmax
    }

    /// A bound on what the `sin q2` terms of the model add to `zdot`, rad/s.
    pub fn z_slack(&self) -> f64 {
        self.z_slack
    }

    /// The link lengths of the hand's kinematics, m.
    pub fn lengths(&self) -> [f64; 2] {
        self.len
    }

    /// `M11` over `q2`.
    pub fn m11(&self, q2: Iv) -> Iv {
        let [a0, a1, a2] = self.a;
        Iv::point(a0) + q2.cos().scale(a1) + q2.sin().scale(a2)
    }

    /// `M12` over `q2`.
    pub fn m12(&self, q2: Iv) -> Iv {
        let [b0, b1, b2] = self.b;
        Iv::point(b0) + q2.cos().scale(b1) + q2.sin().scale(b2)
    }

    /// `M12 / M11` without the `sin q2` terms over `q2` (the slope of `phi`).
    pub fn slope(&self, q2: Iv) -> Iv {
        let c = q2.cos();
        let num = Iv::point(self.b[0]) + c.scale(self.b[1]);
        let den = Iv::point(self.a[0]) + c.scale(self.a[1]);
        num * den
            .recip()
            .expect("a0 > |a1| keeps the denominator positive")
    }

    /// `phi(q2)` at a point (rounded to nearest, error far below [`PHI_PAD`]).
    pub fn phi_at(&self, s: f64) -> f64 {
        let [a0, a1, _] = self.a;
        let [b0, b1, _] = self.b;
        let root = (a0 * a0 - a1 * a1).sqrt();
        let k = ((a0 - a1) / (a0 + a1)).sqrt();
        let i = 2.0 / root * (k * (s / 2.0).tan()).atan();
        b1 / a1 * s + (b0 - b1 * a0 / a1) * i
    }

    /// The enclosure of `phi` over `q2` (`|q2| < pi`).
    pub fn phi(&self, q2: Iv) -> Iv {
        let r = self.slope(q2);
        if r.lo >= 0.0 || r.hi <= 0.0 {
            let (a, b) = (self.phi_at(q2.lo), self.phi_at(q2.hi));
            return Iv::new(a.min(b), a.max(b)).pad(PHI_PAD);
        }
        let m = 0.5 * (q2.lo + q2.hi);
        Iv::point(self.phi_at(m)).pad(PHI_PAD) + r * (q2 - Iv::point(m))
    }

    /// The enclosure of `psi = q2 - phi(q2)` over `q2` (`q1 + q2 = z + psi(q2)`).
    pub fn psi(&self, q2: Iv) -> Iv {
        let r = Iv::point(1.0) - self.slope(q2);
        if r.lo >= 0.0 || r.hi <= 0.0 {
            let (a, b) = (q2.lo - self.phi_at(q2.lo), q2.hi - self.phi_at(q2.hi));
            // each difference is rounded once more: one unit more than PHI_PAD covers it
            return Iv::new(a.min(b), a.max(b)).pad(PHI_PAD);
        }
        let m = 0.5 * (q2.lo + q2.hi);
        Iv::point(m - self.phi_at(m)).pad(PHI_PAD) + r * (q2 - Iv::point(m))
    }

    /// `dV/dq1` over the poses with grip angle in `q1` and `q1 + q2` in `q12`, N m.
    pub fn dv(&self, q1: Iv, q12: Iv) -> Iv {
        let [g0, g1, g2, g3] = self.g;
        q1.cos().scale(g0) - q1.sin().scale(g1) + q12.cos().scale(g2) - q12.sin().scale(g3)
    }

    /// The partial derivatives of `dV/dq1` over the same poses: by `q1` (with `q2` fixed) and by
    /// `q2` (with `q1` fixed), N m/rad.
    pub fn dv_partials(&self, q1: Iv, q12: Iv) -> (Iv, Iv) {
        let [g0, g1, g2, g3] = self.g;
        let (s1, c1, s12, c12) = (q1.sin(), q1.cos(), q12.sin(), q12.cos());
        let e = -(s12.scale(g2) + c12.scale(g3));
        (e - (s1.scale(g0) + c1.scale(g1)), e)
    }

    /// An enclosure of the mean of `1 / M11(q2(t))` over `[0, dt]`, for every elbow path of rate at
    /// most `u` from `a` into `e`: at each time the path lies between the lowest and the highest such
    /// path, and `[0, dt]` is cut into `pieces` on each of which `1 / M11` is enclosed over that band.
    pub fn m11inv_mean(&self, a: Iv, e: Iv, u: f64, dt: f64, pieces: usize) -> Option<Iv> {
        let low = |t: f64| (a.lo - u * t).max(e.lo - u * (dt - t));
        let high = |t: f64| (a.hi + u * t).min(e.hi + u * (dt - t));
        // the lowest path is convex with its kink at tl, the highest concave with its kink at th
        let tl = (a.lo - e.lo + u * dt) / (2.0 * u);
        let th = (e.hi - a.hi + u * dt) / (2.0 * u);
        let mut acc = Iv::point(0.0);
        for k in 0..pieces {
            let (t0, t1) = (
                dt * k as f64 / pieces as f64,
                dt * (k + 1) as f64 / pieces as f64,
            );
            let mut lo = low(t0).min(low(t1));
            if tl > t0 && tl < t1 {
                lo = lo.min(low(tl));
            }
            let mut hi = high(t0).max(high(t1));
            if th > t0 && th < t1 {
                hi = hi.max(high(th));
            }
            // the band's rounding (a few units in the last place) is covered by the margin
            let band = Iv::new(lo.min(hi), hi.max(lo)).pad(1e-12);
            acc = acc + self.m11(band).recip()?;
        }
        Some(acc.scale(1.0 / pieces as f64).pad(0.0))
    }

    /// Boxes `[q1, q2]` (one per arm pose, elbow forward and back) that hold every pose with the hand
    /// within `eps` of `bar` (`eps` below the bar's distance from the grip and the reach of the arm).
    pub fn poses_near(&self, bar: [f64; 2], eps: f64) -> Vec<[Iv; 2]> {
        let [l1, l2] = self.len;
        let r = bar[0].hypot(bar[1]);
        let (r_lo, r_hi) = ((r - eps) * (1.0 - 1e-12), (r + eps) * (1.0 + 1e-12));
        // |hand|^2 = l1^2 + l2^2 + 2 l1 l2 cos q2
        let c = |rr: f64| ((rr * rr - l1 * l1 - l2 * l2) / (2.0 * l1 * l2)).clamp(-1.0, 1.0);
        let (a_lo, a_hi) = (
            c(r_hi).acos() * (1.0 - 1e-12) - 1e-12,
            c(r_lo).acos() * (1.0 + 1e-12) + 1e-12,
        );
        // the hand's direction is within asin(eps / r) of the bar's; q1 = direction - beta(q2) with
        // beta = atan2(l2 sin q2, l1 + l2 cos q2), |dbeta/dq2| <= l2 (l1 + l2) / |hand|^2
        let dir = bar[1].atan2(bar[0]);
        let spread = (eps / r).asin() * (1.0 + 1e-12) + 1e-12;
        let slope = l2 * (l1 + l2) / (r_lo * r_lo);
        [Iv::new(a_lo, a_hi), Iv::new(-a_hi, -a_lo)]
            .into_iter()
            .map(|q2| {
                let m = 0.5 * (q2.lo + q2.hi);
                let beta = (l2 * m.sin()).atan2(l1 + l2 * m.cos());
                let half = 0.5 * q2.width() * slope + 1e-12;
                let q1 = Iv::new(dir - spread - beta - half, dir + spread - beta + half).pad(1e-12);
                [q1, q2]
            })
            .collect()
    }

    /// The hand's position over the poses with grip angle in `q1` and `q1 + q2` in `q12`, m.
    pub fn hand(&self, q1: Iv, q12: Iv) -> [Iv; 2] {
        let [l1, l2] = self.len;
        [
            q1.cos().scale(l1) + q12.cos().scale(l2),
            q1.sin().scale(l1) + q12.sin().scale(l2),
        ]
    }
}
