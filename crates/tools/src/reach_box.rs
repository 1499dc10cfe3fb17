//! A sound over-approximation of the states the reduced two-link swing ([`ReducedTwoLink`]) can be
//! in at each time, and the check that none of them is at the bar at rest.
//!
//! The system is the one of [`crate::swing_dp`]: state `(q1, H, q2)`, the elbow's rate `u = q2dot`
//! any measurable function with `|u| <= u_max`, `|q2| <= q2_max` at all times, and `q1` within
//! `q1_range` at the step times `k dt` (so at least every motion that keeps it there throughout). It
//! works in `(z, H, q2)` with `z = q1 + phi(q2)` ([`ReachModel`]), where `u` moves only `q2`.
//!
//! The state space is cut into cells: `n_q2` over `[-q2_max, q2_max]`, width `dz` in `z` and `dh` in
//! `H`. Each occupied cell holds a box (in `z` and `H`; in `q2` the whole cell) that contains every
//! reachable state in the cell. One step of `dt` maps each box, for each `q2` cell `j` it can reach,
//! through a validated enclosure of the flow:
//!
//! 1. the elbow's angle: it ends in `Q2e = (C_i + [-u dt, u dt]) ∩ C_j` and stays within `Q2p`, the
//!    angles a path of rate at most `u_max` from `C_i` to `Q2e` can pass (within `+-q2_max`);
//! 2. an a-priori enclosure over `[0, dt]`: `H ∈ Hp0 = H + [-dt, dt] gmax` (`|Hdot| <= gmax`
//!    everywhere) and `z ∈ Z + [0, dt] (Hp0 / M11(Q2p) + [-s, s])` (`s` [`ReachModel::z_slack`]);
//! 3. `Hdot ∈ G = -dV/dq1` over that enclosure, `H` over the step in `Hp = H + [0, dt] G`, and at the
//!    end `H(dt) ∈ H + dt G`, `z(dt) ∈ Z + dt (Hp / M11(Q2p) + [-s, s])` (the mean-value theorem for
//!    the integral of the rate);
//! 4. the end box is cut to `|H| <= |H0| + gmax t` (`H0` the start's) and to `z - phi(Q2e)` meeting `q1_range`, and every
//!    cell it meets gets the part of it inside the cell, merged into the cell's box (the smallest box
//!    holding both).
//!
//! By induction every reachable state lies in some cell's box. All interval operations round outward
//! ([`crate::reach_interval`]). At a swing time, [`ReachBox::target`] bounds from below, over every
//! box (its `q2` cell split into `target_split` parts), the hand's distance `d` to the bar and `|H|`;
//! the target set `{d <= eps, lambda |H| <= eps}` is unreachable when every box has
//! `max(d, lambda |H|) > eps`.
use crate::reach_interval::Iv;
use crate::reach_model::{ReachModel, ReachModelError};
use crate::reduced_two_link::ReducedTwoLink;
use rayon::prelude::*;

/// The grid, the bounds and the target.
#[derive(Debug, Clone)]
pub struct ReachSettings {
    /// Time step, s.
    pub dt: f64,
    /// Cells over `[-q2_max, q2_max]`.
    pub n_q2: usize,
    /// Cell width in `z`, rad.
    pub dz: f64,
    /// Cell width in `H`, kg m^2/s.
    pub dh: f64,
    /// The elbow's range, rad.
    pub q2_max: f64,
    /// The elbow's largest rate, rad/s.
    pub u_max: f64,
    /// The range `q1` keeps at the step times, rad.
    pub q1_range: [f64; 2],
    /// The longest time the grid covers, s (sets the momentum range `+-gmax t_max`).
    pub t_max: f64,
    /// The bar, m.
    pub bar: [f64; 2],
    /// The momentum's weight in the target set and the margin, m per kg m^2/s.
    pub lambda: f64,
    /// Parts each `q2` cell is split into when checking the target.
    pub target_split: usize,
}

/// The target check at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetBound {
    /// The least, over every box, of the lower bound on `max(d, lambda |H|)`, m: no reachable state
    /// has the hand within this distance of the bar with `lambda |H|` below it.
    pub margin: f64,
    /// The least lower bound on the hand's distance to the bar over every box, m (any momentum).
    pub hand: f64,
}

/// The cells of a bound's grid in `z`, `H` and `q2` ([`ReachBox::grid`]).
#[derive(Debug, Clone, Copy)]
pub struct Grid {
    z: Axis,
    h: Axis,
    q2: Axis,
}

/// One axis of the grid: cell `i` is `[lo + i w, lo + (i + 1) w]`.
#[derive(Debug, Clone, Copy)]
struct Axis {
    lo: f64,
    w: f64,
    n: usize,
    /// Where the last cell ends at least (the axis's end, whatever `lo + n w` rounds to).
    end: f64,
}

impl Axis {
    fn cell(&self, i: usize) -> Iv {
        // the last cell ends at the axis's end exactly (a rounded `lo + n w` could fall short of it)
        let hi = self.lo + (i + 1) as f64 * self.w;
        let hi = if i + 1 == self.n {
            hi.max(self.end)
        } else {
            hi
        };
        Iv::new(self.lo + i as f64 * self.w, hi)
    }

    /// The cells `x` may meet (one more each way than its bounds round to).
    fn span(&self, x: Iv) -> Option<(usize, usize)> {
        let a = ((x.lo - self.lo) / self.w).floor() - 1.0;
        let b = ((x.hi - self.lo) / self.w).floor() + 1.0;
        if b < 0.0 || a > (self.n - 1) as f64 {
            return None;
        }
        Some((a.max(0.0) as usize, b.min((self.n - 1) as f64) as usize))
    }
}

/// What one step from `q2` cell `i` into cell `j` needs, the same for every box.
#[derive(Debug, Clone, Copy)]
struct Pair {
    i: usize,
    /// `1 / M11` over the path's angles.
    m11inv: Iv,
    /// The mean of `1 / M11` along any path ([`ReachModel::m11inv_mean`]).
    m11inv_mean: Iv,
    /// `phi`, `psi` and `M12/M11` over the path's angles.
    phi: Iv,
    psi: Iv,
    slope: Iv,
    /// `phi` and `psi` over the angles the path can start at.
    phi0: Iv,
    psi0: Iv,
    /// The `z` a state ending in `Q2e` with `q1` in range can have.
    zlim: Iv,
}

/// The largest `|H|` of a start, kg m^2/s (the grid's momentum range is the same for every start).
pub const START_H_MAX: f64 = 1.0;

/// The occupied cells of a bound, per `q2` cell: `(iz * n_h + ih, [z_lo, z_hi, h_lo, h_hi])`, sorted;
/// each box rounded outward to `f32` ([`widen_to_f32`]), so it holds the bound's `f64` box (half the
/// memory of the bound's own boxes).
pub type Snapshot = Vec<Vec<(u32, [f32; 4])>>;

/// The box `[z_lo, z_hi, h_lo, h_hi]` rounded outward to `f32`: the lower ends down, the upper ends
/// up, so the `f32` box holds the `f64` one (an empty box stays empty).
pub fn widen_to_f32(b: &[f64; 4]) -> [f32; 4] {
    let down = |v: f64| {
        let x = v as f32;
        if f64::from(x) > v {
            x.next_down()
        } else {
            x
        }
    };
    let up = |v: f64| {
        let x = v as f32;
        if f64::from(x) < v {
            x.next_up()
        } else {
            x
        }
    };
    [down(b[0]), up(b[1]), down(b[2]), up(b[3])]
}

/// A stored box in `f64` (exact).
#[inline]
fn widened(b: &[f32; 4]) -> [f64; 4] {
    b.map(f64::from)
}

/// A box of a cell: `[z_lo, z_hi, h_lo, h_hi]`.
type CellBox = [f64; 4];

/// The most cells of a grid whose step accumulates in a dense array per thread (32 bytes a cell).
const DENSE_CELLS: usize = 1 << 23;

thread_local! {
    /// [`ReachBox::step`]'s accumulator: a box per cell of the grid (all EMPTY between uses) and
    /// the cells touched.
    static STEP_BUF: std::cell::RefCell<(Vec<CellBox>, Vec<u32>)> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

const EMPTY: CellBox = [
    f64::INFINITY,
    f64::NEG_INFINITY,
    f64::INFINITY,
    f64::NEG_INFINITY,
];

/// The smallest box holding the boxes `a` and `b` ([`EMPTY`] holds nothing).
fn hull(a: &CellBox, b: &CellBox) -> CellBox {
    [
        a[0].min(b[0]),
        a[1].max(b[1]),
        a[2].min(b[2]),
        a[3].max(b[3]),
    ]
}

/// The reachable-set bound, stepped forward in time.
#[derive(Debug)]
pub struct ReachBox {
    s: ReachSettings,
    m: ReachModel,
    q2: Axis,
    z: Axis,
    h: Axis,
    /// For each destination `q2` cell, the pairs that step into it.
    pairs: Vec<Vec<Pair>>,
    /// The occupied cells of each `q2` cell: `(iz * n_h + ih, box)`, sorted.
    slices: Vec<Vec<(u32, CellBox)>>,
    k: usize,
    /// `|H|` at the start (`|H(t)| <= |H(0)| + gmax t`).
    h_start: f64,
    /// The most cells of a grid stepped with a dense accumulator ([`DENSE_CELLS`]).
    dense_cells: usize,
}

/// Why the bound cannot be set up.
#[derive(Debug, Clone, PartialEq)]
pub enum ReachError {
    /// The model has no enclosures here.
    Model(ReachModelError),
    /// A setting is out of its range (which, and why).
    Setting(&'static str),
    /// The grid would have more cells than an index holds.
    TooLarge,
    /// A step past `t_max`, beyond which the momentum grid may not hold every reachable state.
    BeyondTMax,
}

impl std::fmt::Display for ReachError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Model(e) => write!(f, "{e}"),
            Self::Setting(w) => write!(f, "reach settings: {w}"),
            Self::TooLarge => write!(f, "the reach grid has more than 2^32 cells in a q2 slice"),
            Self::BeyondTMax => write!(f, "a step past t_max, which sizes the momentum grid"),
        }
    }
}

impl std::error::Error for ReachError {}

/// The angles a path of rate at most `u` can pass in `dt` from `a` to `e`.
fn path_range(a: Iv, e: Iv, u: f64, dt: f64) -> Iv {
    // lowest: min over t of max(a.lo - u t, e.lo - u (dt - t)); highest likewise
    let tl = ((a.lo - e.lo + u * dt) / (2.0 * u)).clamp(0.0, dt);
    let lo = (a.lo - u * tl).max(e.lo - u * (dt - tl));
    let th = ((e.hi - a.hi + u * dt) / (2.0 * u)).clamp(0.0, dt);
    let hi = (a.hi + u * th).min(e.hi + u * (dt - th));
    // the products and sums above are rounded: a margin of 1e-12 rad covers them
    Iv::new(lo.min(a.lo).min(e.lo), hi.max(a.hi).max(e.hi)).pad(1e-12)
}

impl ReachBox {
    /// The bound at time 0: the single state `start = [q1, H, q2]`.
    pub fn new(
        model: &ReducedTwoLink,
        s: &ReachSettings,
        start: [f64; 3],
    ) -> Result<Self, ReachError> {
        let [a, b, c] = start.map(|v| Iv::point(v).pad(1e-12));
        Self::from_box(model, s, [a, b, c])
    }

    /// The bound at time 0: every state in the box `start = [q1, H, q2]`.
    pub fn from_box(
        model: &ReducedTwoLink,
        s: &ReachSettings,
        start: [Iv; 3],
    ) -> Result<Self, ReachError> {
        if [s.dt, s.dz, s.dh, s.u_max, s.q2_max]
            .iter()
            .any(|v| v.is_nan() || *v <= 0.0)
        {
            return Err(ReachError::Setting(
                "dt, dz, dh, u_max and q2_max must be positive",
            ));
        }
        if s.q2_max >= 3.1 || s.n_q2 < 2 || s.target_split == 0 {
            return Err(ReachError::Setting(
                "q2_max must be below 3.1 rad, n_q2 at least 2, target_split at least 1",
            ));
        }
        if s.q1_range[0] >= s.q1_range[1] {
            return Err(ReachError::Setting(
                "q1_range must be increasing, the start's q2 in range",
            ));
        }
        let m = ReachModel::new(model, s.u_max).map_err(ReachError::Model)?;
        let q2 = Axis {
            lo: -s.q2_max,
            w: 2.0 * s.q2_max / s.n_q2 as f64,
            n: s.n_q2,
            end: s.q2_max,
        };
        let phi_all = m.phi(Iv::new(-s.q2_max, s.q2_max));
        let zr = Iv::new(s.q1_range[0], s.q1_range[1]) + phi_all;
        // the same grid for every start (bounds from different starts are compared cell by cell)
        if start[1].lo.abs().max(start[1].hi.abs()) > START_H_MAX {
            return Err(ReachError::Setting(
                "the start's |H| must be at most 1 kg m^2/s",
            ));
        }
        let hmax = START_H_MAX + m.gmax() * s.t_max + 2.0 * s.dh;
        let z = Axis {
            lo: zr.lo - s.dz,
            w: s.dz,
            n: (zr.width() / s.dz).ceil() as usize + 2,
            end: f64::NEG_INFINITY,
        };
        let h = Axis {
            lo: -hmax,
            w: s.dh,
            n: (2.0 * hmax / s.dh).ceil() as usize,
            end: f64::NEG_INFINITY,
        };
        if (z.n as u64) * (h.n as u64) >= u32::MAX as u64 {
            return Err(ReachError::TooLarge);
        }
        let reach = (s.u_max * s.dt / q2.w).ceil() as usize + 1;
        let mut pairs = vec![vec![]; q2.n];
        for (j, pj) in pairs.iter_mut().enumerate() {
            let cj = q2.cell(j);
            for i in j.saturating_sub(reach)..=(j + reach).min(q2.n - 1) {
                let ci = q2.cell(i);
                let e = (ci.pad(s.u_max * s.dt)).meet(cj);
                if e.is_empty() {
                    continue;
                }
                let path = path_range(ci, e, s.u_max, s.dt).meet(Iv::new(-s.q2_max, s.q2_max));
                let m11inv = m
                    .m11(path)
                    .recip()
                    .ok_or(ReachError::Model(ReachModelError::Degenerate))?;
                let s0 = ci.meet(e.pad(s.u_max * s.dt));
                let m11inv_mean = m
                    .m11inv_mean(ci, e, s.u_max, s.dt, 8)
                    .ok_or(ReachError::Model(ReachModelError::Degenerate))?
                    .meet(m11inv);
                pj.push(Pair {
                    i,
                    m11inv,
                    m11inv_mean,
                    phi: m.phi(path),
                    psi: m.psi(path),
                    slope: m.slope(path),
                    phi0: m.phi(s0),
                    psi0: m.psi(s0),
                    zlim: Iv::new(s.q1_range[0], s.q1_range[1]) + m.phi(e),
                });
            }
        }
        let mut slices: Vec<Vec<(u32, CellBox)>> = vec![vec![]; q2.n];
        // every (q2 cell, z cell, H cell) the start box meets gets its part
        let q2_all = Iv::new(-s.q2_max, s.q2_max);
        let (sq1, sh, sq2) = (start[0], start[1], start[2].meet(q2_all));
        if sq1.is_empty() || sh.is_empty() || sq2.is_empty() {
            return Err(ReachError::Setting(
                "the start is empty or its q2 out of range",
            ));
        }
        let span2 = q2
            .span(sq2)
            .ok_or(ReachError::Setting("start q2 out of range"))?;
        for (i2, slice) in slices
            .iter_mut()
            .enumerate()
            .take(span2.1 + 1)
            .skip(span2.0)
        {
            let c2 = sq2.meet(q2.cell(i2));
            if c2.is_empty() {
                continue;
            }
            let z0 = sq1 + m.phi(c2);
            let (Some((z_a, z_b)), Some((h_a, h_b))) = (z.span(z0), h.span(sh)) else {
                return Err(ReachError::Setting("the start is outside the grid"));
            };
            for iz in z_a..=z_b {
                for ih in h_a..=h_b {
                    let (bz, bh) = (z0.meet(z.cell(iz)), sh.meet(h.cell(ih)));
                    if !bz.is_empty() && !bh.is_empty() {
                        slice.push(((iz * h.n + ih) as u32, [bz.lo, bz.hi, bh.lo, bh.hi]));
                    }
                }
            }
            slice.sort_by_key(|c| c.0);
        }
        Ok(Self {
            s: s.clone(),
            m,
            q2,
            z,
            h,
            pairs,
            slices,
            k: 0,
            h_start: start[1].lo.abs().max(start[1].hi.abs()),
            dense_cells: DENSE_CELLS,
        })
    }

    /// The time of the bound, s (`k dt` after `k` steps).
    pub fn time(&self) -> f64 {
        self.k as f64 * self.s.dt
    }

    /// Steps taken.
    pub fn steps(&self) -> usize {
        self.k
    }

    /// Occupied cells.
    pub fn cells(&self) -> usize {
        self.slices.iter().map(Vec::len).sum()
    }

    /// The extent of the bound: the least and largest `z` and `H` over every box.
    pub fn extent(&self) -> [f64; 4] {
        self.slices
            .iter()
            .flatten()
            .fold(EMPTY, |a, (_, b)| hull(&a, b))
    }

    /// The model's enclosures.
    pub fn model(&self) -> &ReachModel {
        &self.m
    }

    /// Step with a dense accumulator only on grids of at most `n` cells (else a sorted list; the
    /// same boxes either way).
    pub fn set_dense_cells(&mut self, n: usize) {
        self.dense_cells = n;
    }

    /// Advance the bound by one step of `dt`. Refused past `t_max`: the momentum grid is sized for
    /// it, and a state beyond the grid would be lost.
    pub fn step(&mut self) -> Result<(), ReachError> {
        let (dt, slack) = (self.s.dt, self.m.z_slack());
        let t_end = (self.k + 1) as f64 * dt;
        if t_end > self.s.t_max * (1.0 + 1e-12) {
            return Err(ReachError::BeyondTMax);
        }
        let hb = self.h_start + self.m.gmax() * t_end;
        let hcap = Iv::new(-hb, hb).pad(1e-12);
        let (z, h, nh) = (self.z, self.h, self.h.n);
        let m = &self.m;
        let slices = &self.slices;
        let dense_cells = self.dense_cells;
        let uu = Iv::new(-self.s.u_max, self.s.u_max);
        let new: Vec<Vec<(u32, CellBox)>> = self
            .pairs
            .par_iter()
            .map(|pj| {
                // a dense accumulator per thread, kept between steps (every entry used is reset
                // to EMPTY before it is handed back), so a small bound steps in time to its boxes
                // (on a grid of more than DENSE_CELLS cells, a list sorted and merged instead)
                STEP_BUF.with(|cell| {
                    let mut guard = cell.borrow_mut();
                    let (buf, touched) = &mut *guard;
                    let dense = z.n * h.n <= dense_cells;
                    if dense && buf.len() < z.n * h.n {
                        buf.resize(z.n * h.n, EMPTY);
                    }
                    let mut pending: Vec<(u32, CellBox)> = vec![];
                    for p in pj {
                        for &(_, b) in &slices[p.i] {
                            let (zb, hb) = (Iv::new(b[0], b[1]), Iv::new(b[2], b[3]));
                            // a-priori enclosure over [0, dt]
                            let hp0 = hb.pad(dt * m.gmax());
                            let zr0 = (hp0 * p.m11inv).pad(slack).scale(dt);
                            let zp = zb + zr0.hull(Iv::point(0.0));
                            let (q1p, q12p) = (zp - p.phi, zp + p.psi);
                            let g = -m.dv(q1p, q12p);
                            let hp = hb + g.scale(dt).hull(Iv::point(0.0));
                            // second order: H(dt) = H - dt dV(0) - dt^2/2 D, D = d/dt dV/dq1
                            // = dV1 (H / M11) + u (E - dV1 M12/M11) over the enclosure
                            let (dv1, e) = m.dv_partials(q1p, q12p);
                            let d = dv1 * (hp0 * p.m11inv).pad(slack) + (e - dv1 * p.slope) * uu;
                            let dv0 = m.dv(zb - p.phi0, zb + p.psi0);
                            let he = (hb - dv0.scale(dt) - d.scale(dt).scale(0.5 * dt)).meet(hcap);
                            // z(dt) = Z + int H / M11: H within hp, the mean of 1 / M11 bounded
                            let ze =
                                (zb + (hp * p.m11inv_mean).scale(dt).pad(slack * dt)).meet(p.zlim);
                            if he.is_empty() || ze.is_empty() {
                                continue;
                            }
                            let (Some((z0, z1)), Some((h0, h1))) = (z.span(ze), h.span(he)) else {
                                continue;
                            };
                            for iz in z0..=z1 {
                                let cz = ze.meet(z.cell(iz));
                                if cz.is_empty() {
                                    continue;
                                }
                                for ih in h0..=h1 {
                                    let ch = he.meet(h.cell(ih));
                                    if ch.is_empty() {
                                        continue;
                                    }
                                    let idx = iz * nh + ih;
                                    if !dense {
                                        pending.push((idx as u32, [cz.lo, cz.hi, ch.lo, ch.hi]));
                                        continue;
                                    }
                                    let c = &mut buf[idx];
                                    if c[0] > c[1] {
                                        touched.push(idx as u32);
                                        *c = [cz.lo, cz.hi, ch.lo, ch.hi];
                                    } else {
                                        *c = hull(c, &[cz.lo, cz.hi, ch.lo, ch.hi]);
                                    }
                                }
                            }
                        }
                    }
                    if !dense {
                        pending.sort_unstable_by_key(|c| c.0);
                        let mut out: Vec<(u32, CellBox)> = Vec::with_capacity(pending.len());
                        for (i, b) in pending {
                            match out.last_mut() {
                                Some((j, c)) if *j == i => {
                                    *c = hull(c, &b);
                                }
                                _ => out.push((i, b)),
                            }
                        }
                        return out;
                    }
                    touched.sort_unstable();
                    let out: Vec<(u32, CellBox)> = touched
                        .iter()
                        .map(|&i| {
                            let b = buf[i as usize];
                            buf[i as usize] = EMPTY;
                            (i, b)
                        })
                        .collect();
                    touched.clear();
                    out
                })
            })
            .collect();
        self.slices = new;
        self.k += 1;
        Ok(())
    }

    /// The lower bound on `max(d, lambda |H|)` over one box with `q2` in `q2s`.
    fn box_bound(&self, b: &CellBox, q2s: Iv) -> (f64, f64) {
        let zb = Iv::new(b[0], b[1]);
        let q1 = (zb - self.m.phi(q2s)).meet(Iv::new(self.s.q1_range[0], self.s.q1_range[1]));
        if q1.is_empty() {
            return (f64::INFINITY, f64::INFINITY);
        }
        let [px, py] = self.m.hand(q1, zb + self.m.psi(q2s));
        let dx = (px - Iv::point(self.s.bar[0])).mag_lo();
        let dy = (py - Iv::point(self.s.bar[1])).mag_lo();
        // hypot's rounding (a few units in the last place) is covered by the factor
        let d = dx.hypot(dy) * (1.0 - 1e-12);
        let hm = Iv::new(b[2], b[3]).mag_lo() * self.s.lambda * (1.0 - 1e-12);
        (d.max(hm), d)
    }

    /// The target check at the current time.
    pub fn target(&self) -> TargetBound {
        let n = self.s.target_split;
        let per: Vec<TargetBound> = (0..self.q2.n)
            .into_par_iter()
            .map(|i| {
                let c = self.q2.cell(i);
                let parts: Vec<Iv> = (0..n)
                    .map(|k| {
                        let a = c.lo + c.width() * k as f64 / n as f64;
                        let b = if k + 1 == n {
                            c.hi
                        } else {
                            c.lo + c.width() * (k + 1) as f64 / n as f64
                        };
                        Iv::new(a, b)
                    })
                    .collect();
                let mut best = TargetBound {
                    margin: f64::INFINITY,
                    hand: f64::INFINITY,
                };
                for (_, b) in &self.slices[i] {
                    let (coarse, hand) = self.box_bound(b, c);
                    if coarse >= best.margin && hand >= best.hand {
                        continue;
                    }
                    for q in &parts {
                        let (mg, hd) = self.box_bound(b, *q);
                        best.margin = best.margin.min(mg);
                        best.hand = best.hand.min(hd);
                    }
                }
                best
            })
            .collect();
        per.into_iter().fold(
            TargetBound {
                margin: f64::INFINITY,
                hand: f64::INFINITY,
            },
            |a, b| TargetBound {
                margin: a.margin.min(b.margin),
                hand: a.hand.min(b.hand),
            },
        )
    }

    /// Cells over the momentum range.
    pub fn h_cells(&self) -> u32 {
        self.h.n as u32
    }

    /// The occupied cells, per `q2` cell, rounded outward to `f32` (for [`Self::meets_reversed`]
    /// and the sweeps' stores).
    pub fn snapshot(&self) -> Snapshot {
        self.slices
            .iter()
            .map(|sl| sl.iter().map(|(i, b)| (*i, widen_to_f32(b))).collect())
            .collect()
    }

    /// The occupied cells, per `q2` cell, as the bound holds them: `(iz * n_h + ih, [z_lo, z_hi,
    /// h_lo, h_hi])`, sorted.
    pub fn boxes(&self) -> &[Vec<(u32, [f64; 4])>] {
        &self.slices
    }

    /// How many boxes of this bound meet a box of `other` (a snapshot of a bound with the same settings,
    /// hence the same grid)
    /// with its momentum reversed. The relaxed system is reversible (`t -> -t`, `H -> -H`,
    /// `u -> -u`), so a motion of duration `t1 + t2` from this bound's start to a state of `other`'s
    /// start with `H` reversed passes, at `t1`, through such a pair (this bound at `t1`, `other` at
    /// `t2`): with none, no such motion exists.
    pub fn meets_reversed(&self, other: &[Vec<(u32, [f32; 4])>]) -> usize {
        meets_reversed(&self.snapshot(), other, self.h.n as u32)
    }

    /// Up to `n` boxes (as `[q2, z, H]` intervals) whose bound on `max(d, lambda |H|)` is at most
    /// `eps`: where the target check fails.
    pub fn witnesses(&self, eps: f64, n: usize) -> Vec<[Iv; 3]> {
        let mut out = vec![];
        for (i, sl) in self.slices.iter().enumerate() {
            let c = self.q2.cell(i);
            for (_, b) in sl {
                if self.box_bound(b, c).0 <= eps && out.len() < n {
                    out.push([c, Iv::new(b[0], b[1]), Iv::new(b[2], b[3])]);
                }
            }
        }
        out
    }

    /// Keep of each box only the smallest box holding its intersections with the boxes of `other` (a
    /// snapshot of a bound with the same settings) with their momentum reversed, and drop the boxes
    /// that meet none. A motion from this bound's start that reaches a state of `other`'s start (its
    /// momentum reversed) in `other`'s time passes now through a state in both, so every such motion
    /// stays in the pruned bound. Returns the boxes left.
    pub fn prune_reversed(&mut self, other: &[Vec<(u32, [f32; 4])>]) -> usize {
        let g = self.grid();
        self.prune_by(other, &g, true)
    }

    /// The cells of this bound's grid (for [`Self::prune_by`] across grids).
    pub fn grid(&self) -> Grid {
        Grid {
            z: self.z,
            h: self.h,
            q2: self.q2,
        }
    }

    /// [`Self::prune_reversed`] by a snapshot `other` on the grid `grid` (the same range of `q2`;
    /// cells of any width), its momentum reversed when `reversed`, else as it is (a bound of the same
    /// direction at the same time, e.g. on a coarser grid). A box of a `q2` cell is cut to the hull
    /// of its intersections with the boxes of every cell of `other` that meets its cell. Returns the
    /// boxes left; all of them when the `q2` ranges differ.
    pub fn prune_by(
        &mut self,
        other: &[Vec<(u32, [f32; 4])>],
        grid: &Grid,
        reversed: bool,
    ) -> usize {
        if grid.q2.lo != self.q2.lo || grid.q2.end != self.q2.end || other.len() != grid.q2.n {
            return self.cells();
        }
        let (oz, oh, oq) = (grid.z, grid.h, grid.q2);
        let onh = oh.n as u32;
        let q2 = self.q2;
        self.slices.par_iter_mut().enumerate().for_each(|(i, a)| {
            // the cells of `other` that meet cell i (closed cells: both at a shared edge)
            let ci = q2.cell(i);
            let Some((c0, c1)) = oq.span(ci) else {
                a.clear();
                return;
            };
            let near: Vec<&Vec<(u32, [f32; 4])>> = (c0..=c1)
                .filter(|&c| !oq.cell(c).meet(ci).is_empty())
                .map(|c| &other[c])
                .collect();
            a.retain_mut(|(_, x)| {
                // `x`'s momentum as `other` holds it
                let hx = if reversed {
                    Iv::new(-x[3], -x[2])
                } else {
                    Iv::new(x[2], x[3])
                };
                let (Some((z0, z1)), Some((h0, h1))) = (oz.span(Iv::new(x[0], x[1])), oh.span(hx))
                else {
                    return false;
                };
                let mut keep = EMPTY;
                for b in &near {
                    for iz in z0 as u32..=z1 as u32 {
                        let lo = b.partition_point(|c| c.0 < iz * onh + h0 as u32);
                        let hi = b.partition_point(|c| c.0 <= iz * onh + h1 as u32);
                        for (_, y) in &b[lo..hi.max(lo)] {
                            let y = widened(y);
                            let (ya, yb) = if reversed {
                                (-y[3], -y[2])
                            } else {
                                (y[2], y[3])
                            };
                            let m = [x[0].max(y[0]), x[1].min(y[1]), x[2].max(ya), x[3].min(yb)];
                            if m[0] <= m[1] && m[2] <= m[3] {
                                keep = hull(&keep, &m);
                            }
                        }
                    }
                }
                *x = keep;
                keep[0] <= keep[1]
            });
        });
        self.cells()
    }

    /// Merge the boxes of `other` (a bound with the same settings, at the same step) into this one:
    /// the union of the two bounds, e.g. from the two poses of a target.
    pub fn absorb(&mut self, other: ReachBox) -> Result<(), ReachError> {
        let same = |a: &Axis, b: &Axis| a.lo == b.lo && a.w == b.w && a.n == b.n;
        if other.k != self.k
            || !same(&self.q2, &other.q2)
            || !same(&self.z, &other.z)
            || !same(&self.h, &other.h)
        {
            return Err(ReachError::Setting(
                "bounds merged must share their grid and their step",
            ));
        }
        self.h_start = self.h_start.max(other.h_start);
        for (a, b) in self.slices.iter_mut().zip(other.slices) {
            let mut out = Vec::with_capacity(a.len() + b.len());
            let (mut i, mut j) = (0, 0);
            while i < a.len() || j < b.len() {
                if j == b.len() || (i < a.len() && a[i].0 < b[j].0) {
                    out.push(a[i]);
                    i += 1;
                } else if i == a.len() || b[j].0 < a[i].0 {
                    out.push(b[j]);
                    j += 1;
                } else {
                    let (x, y) = (a[i].1, b[j].1);
                    out.push((a[i].0, hull(&x, &y)));
                    i += 1;
                    j += 1;
                }
            }
            *a = out;
        }
        Ok(())
    }

    /// The distance (in the larger of `|dz|` and `|dH|`) from the state `[q1, H, q2]` to the nearest
    /// box of its `q2` cell (or either cell, on their common edge); 0 when a box holds it.
    pub fn distance(&self, x: [f64; 3]) -> f64 {
        self.distance_to(&self.slices, |b| *b, x)
    }

    /// [`Self::distance`] to the boxes of `snap`, a snapshot of a bound with the same settings.
    pub fn distance_in(&self, snap: &[Vec<(u32, [f32; 4])>], x: [f64; 3]) -> f64 {
        self.distance_to(snap, widened, x)
    }

    /// [`Self::distance`] to boxes stored as `T`, read by `get`.
    fn distance_to<T>(
        &self,
        snap: &[Vec<(u32, T)>],
        get: impl Fn(&T) -> [f64; 4],
        x: [f64; 3],
    ) -> f64 {
        let zx = x[0] + self.m.phi_at(x[2]);
        let mut best = f64::INFINITY;
        for i in 0..self.q2.n {
            let c = self.q2.cell(i);
            if x[2] < c.lo - 1e-12 || x[2] > c.hi + 1e-12 {
                continue;
            }
            for (_, b) in &snap[i] {
                let b = get(b);
                let dz = (b[0] - zx).max(zx - b[1]).max(0.0);
                let dh = (b[2] - x[1]).max(x[1] - b[3]).max(0.0);
                best = best.min(dz.max(dh));
            }
        }
        best
    }
}

/// [`ReachBox::meets_reversed`] on two snapshots of a grid with `nh` momentum cells.
pub fn meets_reversed(a: &[Vec<(u32, [f32; 4])>], b: &[Vec<(u32, [f32; 4])>], nh: u32) -> usize {
    a.par_iter()
        .zip(b.par_iter())
        .map(|(a, b)| {
            let mut n = 0;
            for (idx, x) in a {
                let iz = idx / nh;
                let lo = b.partition_point(|c| c.0 < iz * nh);
                let hi = b.partition_point(|c| c.0 < (iz + 1) * nh);
                for (_, y) in &b[lo..hi] {
                    let (x, y) = (widened(x), widened(y));
                    if x[0] <= y[1] && y[0] <= x[1] && x[2] <= -y[2] && -y[3] <= x[3] {
                        n += 1;
                    }
                }
            }
            n
        })
        .sum()
}
