//! The least terminal miss of the reduced two-link swing ([`ReducedTwoLink`]) for every swing time,
//! by dynamic programming on a grid.
//!
//! The value `V_k(x)` is the least terminal miss reachable from the state `x = (q1, H, q2)` in `k` steps
//! of `dt` s with a piecewise-constant elbow rate `u` from a finite set in `[-u_max, u_max]`, `q2`
//! kept within `+-q2_max` (a step that would leave the range stops at its edge), `q1` free or kept
//! in a range. The terminal miss is
//! `sqrt(d^2 + (lambda H)^2)`: `d` the distance from the hand to the bar (m; zero on both arm poses
//! that grasp it, at any turn of `q1`), `H` the momentum left (zero for a swing ending at rest, the
//! elbow's rate dropping to zero at once), `lambda` the distance in m the hand would drift in
//! `drift_s` s at the speed `H` gives it with the elbow still, at the target pose. The system is
//! time-invariant, so one backward pass of `K` steps gives, at the start, the least miss of every
//! swing time `k dt <= K dt`.
//!
//! Backward semi-Lagrangian value iteration: `V_0` is the miss at the grid's nodes and
//! `V_{k+1}(node) = min_u V_k(step(node, u))`, `V_k` trilinear between the nodes. A free `q1` is periodic
//! (the model and the miss are), `q2` spans its range; beyond `+-h_max` the value is the lower bound
//! `lambda max(0, |H| - Gmax k dt)` (`Gmax` bounds `|dH/dt|`). The value at the start is an estimate
//! with a grid error, neither a lower nor an upper bound; [`ValueHistory::rollout`] turns it into a
//! motion of the reduced system whose miss is attained (an upper bound on the least miss).
use crate::reduced_two_link::ReducedTwoLink;
use rayon::prelude::*;
use std::f64::consts::PI;

/// The grid and the problem it is solved for.
#[derive(Debug, Clone)]
pub struct DpSettings {
    /// Nodes over one turn of q1 (periodic), or over `q1_range`.
    pub n_q1: usize,
    /// The range q1 must stay in, rad (the planner's default is `[-pi, 0]`, link 1 below the bar);
    /// `None`: q1 free (a full turn, periodic). A step that lands outside it has the miss
    /// [`OUT_OF_RANGE`].
    pub q1_range: Option<[f64; 2]>,
    /// Nodes over `[-h_max, h_max]`.
    pub n_h: usize,
    /// Nodes over `[-q2_max, q2_max]`.
    pub n_q2: usize,
    /// The momentum range of the grid, kg m^2/s.
    pub h_max: f64,
    /// The elbow's range, rad.
    pub q2_max: f64,
    /// The elbow's largest rate, rad/s.
    pub u_max: f64,
    /// Elbow rates per step: `n_u` values evenly over `[-u_max, u_max]` (odd, so 0 is one).
    pub n_u: usize,
    /// Time step, s.
    pub dt: f64,
    /// Number of steps (the longest swing time is `steps dt`).
    pub steps: usize,
    /// RK4 substeps per step.
    pub substeps: usize,
    /// The bar, m.
    pub bar: [f64; 2],
    /// The time scale that weighs the momentum left against the hand's distance, s.
    pub drift_s: f64,
    /// Keep every `V_k` (needed for [`ValueHistory::rollout`]).
    pub keep_history: bool,
}

impl DpSettings {
    /// Number of grid nodes.
    pub fn nodes(&self) -> usize {
        self.n_q1 * self.n_h * self.n_q2
    }
}

/// The value of a state outside `q1_range`, m (more than any miss within it).
pub const OUT_OF_RANGE: f32 = 2.0;

/// Where a step from a node lands on the grid: the lower corner and the fractions (or, beyond the
/// momentum range, `ih == u16::MAX` and `fh` the momentum).
#[derive(Debug, Clone, Copy)]
struct Stencil {
    i1: u16,
    ih: u16,
    i2: u16,
    f1: f32,
    fh: f32,
    f2: f32,
}

/// The grid's geometry and the terminal weighting.
#[derive(Debug, Clone)]
struct Grid {
    n1: usize,
    nh: usize,
    n2: usize,
    /// The first node of q1 and whether q1 is periodic.
    q1_lo: f64,
    periodic: bool,
    d1: f64,
    dh: f64,
    d2: f64,
    h_max: f64,
    q2_max: f64,
    lambda: f64,
    gmax: f64,
}

impl Grid {
    fn node(&self, i1: usize, ih: usize, i2: usize) -> [f64; 3] {
        [
            self.q1_lo + i1 as f64 * self.d1,
            -self.h_max + ih as f64 * self.dh,
            -self.q2_max + i2 as f64 * self.d2,
        ]
    }

    fn stencil(&self, x: [f64; 3]) -> Stencil {
        let s1 = (x[0] - self.q1_lo) / self.d1;
        let top = (self.n1 - 1) as f64;
        let (i1, f1) = if self.periodic {
            let fl1 = s1.floor();
            (
                (fl1 as i64).rem_euclid(self.n1 as i64) as u16,
                (s1 - fl1) as f32,
            )
        } else if !(0.0..=top).contains(&s1) {
            (u16::MAX, 0.0)
        } else {
            let s1 = s1.min(top - 1e-9);
            let fl1 = s1.floor();
            (fl1 as u16, (s1 - fl1) as f32)
        };
        let q2 = x[2].clamp(-self.q2_max, self.q2_max);
        let s2 = ((q2 + self.q2_max) / self.d2).min((self.n2 - 1) as f64 - 1e-9);
        let i2 = s2.floor() as u16;
        let f2 = (s2 - i2 as f64) as f32;
        if x[1].abs() > self.h_max {
            return Stencil {
                i1,
                ih: u16::MAX,
                i2,
                f1,
                fh: x[1] as f32,
                f2,
            };
        }
        let sh = ((x[1] + self.h_max) / self.dh).min((self.nh - 1) as f64 - 1e-9);
        let ih = sh.floor() as u16;
        Stencil {
            i1,
            ih,
            i2,
            f1,
            fh: (sh - ih as f64) as f32,
            f2,
        }
    }

    #[inline]
    fn index(&self, i1: usize, ih: usize, i2: usize) -> usize {
        (i1 * self.nh + ih) * self.n2 + i2
    }

    /// `V_k` at a stencil (`tau` = k dt, for the bound beyond the momentum range).
    #[inline]
    fn interp(&self, v: &[f32], s: &Stencil, tau: f64) -> f32 {
        if s.i1 == u16::MAX {
            return OUT_OF_RANGE;
        }
        if s.ih == u16::MAX {
            return (self.lambda * (s.fh.abs() as f64 - self.gmax * tau).max(0.0)) as f32;
        }
        let i1a = s.i1 as usize;
        let i1b = if i1a + 1 == self.n1 { 0 } else { i1a + 1 };
        let (ih, i2) = (s.ih as usize, s.i2 as usize);
        let mut acc = 0.0f32;
        for (i1, w1) in [(i1a, 1.0 - s.f1), (i1b, s.f1)] {
            for (jh, wh) in [(ih, 1.0 - s.fh), (ih + 1, s.fh)] {
                let base = self.index(i1, jh, i2);
                let w = w1 * wh;
                acc += w * ((1.0 - s.f2) * v[base] + s.f2 * v[base + 1]);
            }
        }
        acc
    }
}

/// The terminal miss and its two parts at a state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Miss {
    /// `sqrt(d^2 + (lambda H)^2)`, m.
    pub miss: f64,
    /// The hand's distance to the bar, m.
    pub hand_m: f64,
    /// `|H|`, kg m^2/s.
    pub momentum: f64,
}

/// A motion of the reduced system from the start.
#[derive(Debug, Clone)]
pub struct Rollout {
    /// Times, s.
    pub t: Vec<f64>,
    /// States `[q1, H, q2]` at the times.
    pub x: Vec<[f64; 3]>,
    /// The elbow rate over each step, rad/s (one fewer than the states).
    pub u: Vec<f64>,
    /// The miss at the end.
    pub end: Miss,
}

/// The solved value functions.
#[derive(Debug)]
pub struct ValueHistory {
    settings: DpSettings,
    grid: Grid,
    model: ReducedTwoLink,
    /// `V_k` for every k (only `V_steps` unless `keep_history`).
    values: Vec<Vec<f32>>,
    /// `V_k` at each start for every k.
    at_start: Vec<Vec<f64>>,
}

/// The distance weight `lambda` (m per kg m^2/s): `drift_s` times the hand's speed per unit momentum
/// with the elbow still, at the pose nearest the bar's direction (`|hand| = |bar|`).
pub fn lambda(model: &ReducedTwoLink, bar: [f64; 2], q2_max: f64, drift_s: f64) -> f64 {
    // the elbow angle that puts the hand at the bar's distance from the grip
    let r = bar[0].hypot(bar[1]);
    let mut best = (f64::INFINITY, 0.0);
    for k in 0..=2000 {
        let q2 = -q2_max + 2.0 * q2_max * k as f64 / 2000.0;
        let p = model.hand(0.0, q2);
        let e = (p[0].hypot(p[1]) - r).abs();
        if e < best.0 {
            best = (e, q2);
        }
    }
    drift_s * r / model.m11(best.1)
}

impl ValueHistory {
    /// Run the backward pass, recording the value at each of `starts` (`[q1, H, q2]`).
    pub fn solve(model: &ReducedTwoLink, s: &DpSettings, starts: &[[f64; 3]]) -> Self {
        let grid = Grid {
            n1: s.n_q1,
            nh: s.n_h,
            n2: s.n_q2,
            q1_lo: s.q1_range.map_or(-PI, |r| r[0]),
            periodic: s.q1_range.is_none(),
            d1: s.q1_range.map_or(2.0 * PI / s.n_q1 as f64, |r| {
                (r[1] - r[0]) / (s.n_q1 - 1) as f64
            }),
            dh: 2.0 * s.h_max / (s.n_h - 1) as f64,
            d2: 2.0 * s.q2_max / (s.n_q2 - 1) as f64,
            h_max: s.h_max,
            q2_max: s.q2_max,
            lambda: lambda(model, s.bar, s.q2_max, s.drift_s),
            gmax: model.max_dv_dq1(),
        };
        let controls: Vec<f64> = (0..s.n_u)
            .map(|j| -s.u_max + 2.0 * s.u_max * j as f64 / (s.n_u - 1) as f64)
            .collect();
        let per_slab = s.n_h * s.n_q2;
        // every node's landing points, one per control (time-invariant: computed once)
        let stencils: Vec<Stencil> = (0..s.n_q1)
            .into_par_iter()
            .flat_map_iter(|i1| {
                let (grid, controls) = (&grid, &controls);
                (0..per_slab).flat_map(move |r| {
                    let x = grid.node(i1, r / s.n_q2, r % s.n_q2);
                    controls.iter().map(move |&u| {
                        let q2n = (x[2] + u * s.dt).clamp(-s.q2_max, s.q2_max);
                        let ue = (q2n - x[2]) / s.dt;
                        grid.stencil(model.step(x, ue, s.dt, s.substeps))
                    })
                })
            })
            .collect();
        let v0: Vec<f32> = (0..s.nodes())
            .into_par_iter()
            .map(|i| {
                let x = grid.node(i / per_slab, (i % per_slab) / s.n_q2, i % s.n_q2);
                miss_at(model, grid.lambda, s.bar, x).miss as f32
            })
            .collect();
        let start_st: Vec<Stencil> = starts.iter().map(|&x| grid.stencil(x)).collect();
        let mut at_start: Vec<Vec<f64>> = start_st
            .iter()
            .map(|st| vec![grid.interp(&v0, st, 0.0) as f64])
            .collect();
        let mut values = vec![v0];
        let nu = s.n_u;
        for k in 0..s.steps {
            let prev = values.last().expect("V_0 is always kept");
            let tau = k as f64 * s.dt;
            let next: Vec<f32> = stencils
                .par_chunks(nu * s.n_q2)
                .flat_map_iter(|row| {
                    row.chunks(nu).map(|st| {
                        st.iter()
                            .map(|x| grid.interp(prev, x, tau))
                            .fold(f32::INFINITY, f32::min)
                    })
                })
                .collect();
            for (a, st) in at_start.iter_mut().zip(&start_st) {
                a.push(grid.interp(&next, st, tau + s.dt) as f64);
            }
            if s.keep_history {
                values.push(next);
            } else {
                values[0] = next;
            }
        }
        Self {
            settings: s.clone(),
            grid,
            model: model.clone(),
            values,
            at_start,
        }
    }

    /// `V_k` at start `i` (of those given to [`Self::solve`]), for k = 0 ..= steps: the estimated
    /// least miss at swing time `k dt`, m.
    pub fn at_start(&self, i: usize) -> &[f64] {
        &self.at_start[i]
    }

    /// The weight `lambda` of the momentum in the miss, m per kg m^2/s.
    pub fn lambda(&self) -> f64 {
        self.grid.lambda
    }

    /// The miss at a state.
    pub fn miss(&self, x: [f64; 3]) -> Miss {
        miss_at(&self.model, self.grid.lambda, self.settings.bar, x)
    }

    /// The motion of `k` steps from `start` that picks, at each step, the elbow rate among `n_u`
    /// values in `[-u_max, u_max]` whose landing point has the least `V` of the steps left; its end miss
    /// is attained by the reduced system. `None` without the history or for `k > steps`.
    pub fn rollout(&self, start: [f64; 3], k: usize, n_u: usize) -> Option<Rollout> {
        let s = &self.settings;
        if !s.keep_history || k > s.steps {
            return None;
        }
        let mut x = start;
        let mut out = Rollout {
            t: vec![0.0],
            x: vec![x],
            u: vec![],
            end: self.miss(x),
        };
        for j in 0..k {
            let left = k - j - 1;
            let v = &self.values[left];
            let mut best = (f32::INFINITY, 0.0, x);
            for c in 0..n_u {
                let u = -s.u_max + 2.0 * s.u_max * c as f64 / (n_u - 1) as f64;
                let q2n = (x[2] + u * s.dt).clamp(-s.q2_max, s.q2_max);
                let ue = (q2n - x[2]) / s.dt;
                let xn = self.model.step(x, ue, s.dt, s.substeps);
                let val = if left == 0 {
                    let st = self.grid.stencil(xn);
                    if st.i1 == u16::MAX {
                        OUT_OF_RANGE
                    } else {
                        self.miss(xn).miss as f32
                    }
                } else {
                    self.grid
                        .interp(v, &self.grid.stencil(xn), left as f64 * s.dt)
                };
                if val < best.0 {
                    best = (val, ue, xn);
                }
            }
            x = best.2;
            out.u.push(best.1);
            out.t.push((j + 1) as f64 * s.dt);
            out.x.push(x);
        }
        out.end = self.miss(x);
        Some(out)
    }
}

/// The miss at a state (see the module docs).
fn miss_at(model: &ReducedTwoLink, lambda: f64, bar: [f64; 2], x: [f64; 3]) -> Miss {
    let p = model.hand(x[0], x[2]);
    let d = (p[0] - bar[0]).hypot(p[1] - bar[1]);
    Miss {
        miss: d.hypot(lambda * x[1]),
        hand_m: d,
        momentum: x[1].abs(),
    }
}
