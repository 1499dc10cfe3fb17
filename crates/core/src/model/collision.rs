//! Obstacle and self-collision clearance of the capsule model (paper eqs. 11-13, done exactly).
//!
//! Conventions (repeated from the crate docs): planar, body frame at the grip point (origin), x right,
//! y up, gravity along -y; `q[0]` is the absolute angle of link 1 from +x, `q[i > 0]` relative angles;
//! SI units (m, rad). Link `i` (0-based here, "link i+1" in names and in the paper) is the capsule of
//! radius `robot.radii()[i]` around the segment from joint `i` to joint `i+1`
//! ([`Robot::link_segments`]); an obstacle is a [`Circle`].
//!
//! The constraint rows are **squared** distances compared with **squared** thresholds,
//! `g = d^2 - (r_a + r_b + margin)^2 >= 0`, with `d` the exact segment distance
//! ([`crate::geometry`]). `g >= 0` if and only if the surfaces are at least `margin` apart, and `g` is a
//! polynomial-like (no square root) function of the link end points, so it stays differentiable where
//! `d = 0` is approached. See `docs/collision.md` for why the paper's eq. (12)-(13) is not used verbatim
//! and for the points where `g` is not smooth.

use super::{Robot, MAX_LINKS, P2};
use crate::ad::LocalFn;
use crate::error::{Error, Result};
use crate::geometry::{point_segment_dist2, segment_segment_dist2};
use crate::math::{c, Scalar};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::sync::Arc;

/// A circular obstacle in the plane of the robot (a sphere cut by that plane).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Circle {
    /// Centre `[x, y]` in the body frame, m.
    #[serde(deserialize_with = "crate::serde_exact::pair")]
    pub center: [f64; 2],
    /// Radius, m (>= 0; 0 is a point obstacle).
    pub radius: f64,
}

impl Circle {
    /// The paper's obstacle (section V): radius 0.1 m centred at (0.55, -0.2) m.
    pub const PAPER: Circle = Circle {
        center: [0.55, -0.2],
        radius: 0.1,
    };

    /// Check the values; `source_name` and `field` (e.g. `obstacles[0]`) name it in errors.
    pub fn validate(&self, source_name: &str, field: &str) -> Result<()> {
        for (k, v) in self.center.iter().enumerate() {
            if !v.is_finite() {
                return Err(Error::invalid(
                    source_name,
                    format!("{field}.center[{k}]"),
                    v,
                    "must be finite",
                ));
            }
        }
        if !(self.radius.is_finite() && self.radius >= 0.0) {
            return Err(Error::invalid(
                source_name,
                format!("{field}.radius"),
                self.radius,
                "must be finite and >= 0",
            ));
        }
        Ok(())
    }
}

/// A set of link indices (0-based, below [`MAX_LINKS`]), stored as a bit mask.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LinkSet(u32);

impl LinkSet {
    /// Every link (whatever the robot's number of links).
    pub const ALL: LinkSet = LinkSet(u32::MAX);
    /// No link.
    pub const NONE: LinkSet = LinkSet(0);

    /// The links with the given 0-based indices; every index must be below `n_links`.
    pub fn from_indices(indices: &[usize], n_links: usize) -> Result<Self> {
        let mut m = 0u32;
        for (k, &i) in indices.iter().enumerate() {
            if i >= n_links.min(MAX_LINKS) {
                return Err(Error::invalid(
                    "<memory>",
                    format!("links[{k}]"),
                    i,
                    format!("link index must be below the number of links ({n_links}); indices are 0-based"),
                ));
            }
            m |= 1 << i;
        }
        Ok(LinkSet(m))
    }

    /// True when link `i` (0-based) is in the set.
    pub fn contains(&self, i: usize) -> bool {
        i < 32 && self.0 & (1 << i) != 0
    }
}

impl Default for LinkSet {
    fn default() -> Self {
        LinkSet::ALL
    }
}

/// What one constraint row of a [`ClearanceFn`] measures. Indices are 0-based; `Display` numbers links
/// from 1 as the paper does ("link 3 vs obstacle 0", "link 1 vs link 3") and obstacles from 0 (their
/// position in the obstacle list).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ClearancePair {
    /// Link `link` against obstacle `obstacle`.
    LinkObstacle {
        /// 0-based link index.
        link: usize,
        /// 0-based obstacle index.
        obstacle: usize,
    },
    /// Joint `joint` (0-based: joint 0 is the grip, joint `n` the end effector, joint `j` the start of
    /// link `j`) against link `link`: one self-collision row. Two non-adjacent links are kept apart by
    /// the rows of each one's end points against the other (see [`ClearanceFn`] for why that is the
    /// link-link distance), so `joint` is not an end of `link`.
    JointLink {
        /// 0-based joint index, `0..=n`.
        joint: usize,
        /// 0-based link index.
        link: usize,
    },
    /// Link `a` against link `b`, `b >= a + 2`, by the exact segment-segment distance: not a
    /// constraint row, the self-collision check that [`ClearanceFn::min_clearance_pair`] reports
    /// (adjacent links share a joint and are never checked).
    LinkLink {
        /// 0-based index of the proximal link.
        a: usize,
        /// 0-based index of the distal link.
        b: usize,
    },
}

impl ClearancePair {
    /// The joint index range `lo..=hi` of the relative angles a self-collision quantity depends on
    /// (it is invariant to rigid motions of the chain): joint `j` against link `l` depends on the
    /// angles at the joints strictly between them, `q[j+1..=l]` for `j < l` and `q[l+1..=j-1]` for
    /// `j > l + 1`; link `a` against link `b` on `q[a+1..=b]`. A link-obstacle row on link `i`
    /// depends on `q[0..=i]`.
    pub fn dependence(self) -> (usize, usize) {
        match self {
            ClearancePair::LinkObstacle { link, .. } => (0, link),
            ClearancePair::JointLink { joint, link } if joint < link => (joint + 1, link),
            ClearancePair::JointLink { joint, link } => (link + 1, joint - 1),
            ClearancePair::LinkLink { a, b } => (a + 1, b),
        }
    }
}

impl fmt::Display for ClearancePair {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ClearancePair::LinkObstacle { link, obstacle } => {
                write!(f, "link {} vs obstacle {obstacle}", link + 1)
            }
            ClearancePair::JointLink { joint: 0, link } => write!(f, "grip vs link {}", link + 1),
            ClearancePair::JointLink { joint, link } => {
                write!(f, "end of link {joint} vs link {}", link + 1)
            }
            ClearancePair::LinkLink { a, b } => write!(f, "link {} vs link {}", a + 1, b + 1),
        }
    }
}

/// Clearance constraints as a [`LocalFn`]: `q` (n) -> `g` (one row per [`ClearancePair`]), every row
/// required to be `>= 0`:
///
/// * for every checked link `i` and obstacle `k` (rows first, link-major: `i` outer, `k` inner):
///   `g = dist(center_k, segment_i)^2 - (r_i + radius_k + margin)^2`;
/// * if `self_collision` (after all obstacle rows, link-major: `l` outer, `j` inner ascending), for
///   every checked link `l` and every joint `j` that ends a checked link `a` not adjacent to `l`
///   (`a` in `{j - 1, j}`, `|a - l| >= 2`): `g = dist(p_j, segment_l)^2 - (r_l + R_j + margin)^2`,
///   `R_j` the largest radius of such links `a` ([`ClearancePair::JointLink`]).
///
/// Why end points: the distance of two segments in the plane that do not cross is attained at an end
/// point of one of them, so `dist(segment_a, segment_b) >= r` holds if and only if the four end-point
/// rows do (a joint shared by two links is one row with the larger radius). Unlike the segment-segment
/// distance, which has a kink where the closest pair moves from one end point to another (links
/// folded parallel), each end-point row is smooth away from its own segment's ends: the planner's
/// Newton steps no longer stall on that kink (docs/collision.md, "Self-collision by end points").
/// Crossing segments (reachable only by passing through a violation) are caught by the exact check,
/// [`ClearanceFn::min_clearance_pair`], which every plan's report uses.
///
/// Units m^2. `g < 0` means the capsules (grown by `margin`) overlap. Use [`ClearanceFn::pairs`] /
/// [`ClearanceFn::row_names`] to label rows. Derivatives through [`crate::ad::Diff`] are exact inside
/// each smooth piece; see [`crate::geometry`] for where the pieces meet.
///
/// Owns shared handles to the robot and the obstacles (`Arc`), so the shooting problem and the
/// persistent planner that hold its rows own their data; cloning one copies two pointers.
#[derive(Debug, Clone)]
pub struct ClearanceFn {
    /// The robot (link segments from [`Robot::link_segments`], capsule radii from [`Robot::radii`]).
    pub robot: Arc<Robot>,
    /// The obstacles.
    pub obstacles: Arc<[Circle]>,
    /// Extra clearance required between surfaces, m (>= 0).
    pub margin: f64,
    /// Whether the non-adjacent link pairs are checked.
    pub self_collision: bool,
    /// Which links are checked (against obstacles, and among themselves). Default: all.
    pub links: LinkSet,
}

impl ClearanceFn {
    /// All links against `obstacles` with the given `margin` (m), self-collision on. Checks the obstacles
    /// and the margin. `robot`: a `Robot` or a shared `Arc<Robot>`; `obstacles`: a slice (copied
    /// once), a `Vec` or a shared `Arc<[Circle]>`.
    pub fn new(
        robot: impl Into<Arc<Robot>>,
        obstacles: impl Into<Arc<[Circle]>>,
        margin: f64,
    ) -> Result<Self> {
        let (robot, obstacles) = (robot.into(), obstacles.into());
        for (k, o) in obstacles.iter().enumerate() {
            o.validate("<memory>", &format!("obstacles[{k}]"))?;
        }
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(Error::invalid(
                "<memory>",
                "margin",
                margin,
                "must be finite and >= 0",
            ));
        }
        Ok(ClearanceFn {
            robot,
            obstacles,
            margin,
            self_collision: true,
            links: LinkSet::ALL,
        })
    }

    /// Switch self-collision rows on or off.
    pub fn with_self_collision(mut self, on: bool) -> Self {
        self.self_collision = on;
        self
    }

    /// Check only the links in `links`.
    pub fn with_links(mut self, links: LinkSet) -> Self {
        self.links = links;
        self
    }

    /// Call `f(row, pair)` for every row, in row order.
    pub fn for_each_pair(&self, mut f: impl FnMut(usize, ClearancePair)) {
        let n = self.robot.n;
        let mut k = 0;
        for link in (0..n).filter(|&i| self.links.contains(i)) {
            for obstacle in 0..self.obstacles.len() {
                f(k, ClearancePair::LinkObstacle { link, obstacle });
                k += 1;
            }
        }
        if self.self_collision {
            for link in (0..n).filter(|&i| self.links.contains(i)) {
                for joint in 0..=n {
                    if self.joint_radius(joint, link).is_some() {
                        f(k, ClearancePair::JointLink { joint, link });
                        k += 1;
                    }
                }
            }
        }
    }

    /// The largest radius of the checked links ending at joint `joint` that are not adjacent to link
    /// `link` (`None`: joint `joint` gets no row against `link`).
    fn joint_radius(&self, joint: usize, link: usize) -> Option<f64> {
        let n = self.robot.n;
        [joint.checked_sub(1), Some(joint)]
            .into_iter()
            .flatten()
            .filter(|&a| a < n && self.links.contains(a) && a.abs_diff(link) >= 2)
            .map(|a| self.robot.radius[a])
            .reduce(f64::max)
    }

    /// Call `f(pair)` for every pair of checked non-adjacent links ([`ClearancePair::LinkLink`]),
    /// lexicographic, when self-collision is on.
    fn for_each_link_pair(&self, mut f: impl FnMut(ClearancePair)) {
        if self.self_collision {
            let n = self.robot.n;
            for a in (0..n).filter(|&i| self.links.contains(i)) {
                for b in (a + 2..n).filter(|&j| self.links.contains(j)) {
                    f(ClearancePair::LinkLink { a, b });
                }
            }
        }
    }

    /// The pair measured by each row, in row order.
    pub fn pairs(&self) -> Vec<ClearancePair> {
        let mut v = Vec::with_capacity(self.n_out());
        self.for_each_pair(|_, p| v.push(p));
        v
    }

    /// A readable name per row ("link 3 vs obstacle 0", "end of link 1 vs link 3", "grip vs link 3").
    pub fn row_names(&self) -> Vec<String> {
        self.pairs().iter().map(|p| p.to_string()).collect()
    }

    /// Sum of the two radii plus the margin for `pair`: the required distance, m.
    pub fn threshold(&self, pair: ClearancePair) -> f64 {
        self.radii(pair) + self.margin
    }

    fn radii(&self, pair: ClearancePair) -> f64 {
        match pair {
            ClearancePair::LinkObstacle { link, obstacle } => {
                self.robot.radius[link] + self.obstacles[obstacle].radius
            }
            ClearancePair::JointLink { joint, link } => {
                self.robot.radius[link] + self.joint_radius(joint, link).unwrap_or(0.0)
            }
            ClearancePair::LinkLink { a, b } => self.robot.radius[a] + self.robot.radius[b],
        }
    }

    fn dist2<T: Scalar>(&self, segs: &[(P2<T>, P2<T>)], pair: ClearancePair) -> T {
        match pair {
            ClearancePair::LinkObstacle { link, obstacle } => {
                let o = &self.obstacles[obstacle];
                let (a, b) = segs[link];
                point_segment_dist2([c(o.center[0]), c(o.center[1])], a, b)
            }
            ClearancePair::JointLink { joint, link } => {
                let p = if joint == 0 {
                    segs[0].0
                } else {
                    segs[joint - 1].1
                };
                point_segment_dist2(p, segs[link].0, segs[link].1)
            }
            ClearancePair::LinkLink { a, b } => {
                segment_segment_dist2(segs[a].0, segs[a].1, segs[b].0, segs[b].1)
            }
        }
    }

    /// True surface distances `d - r_a - r_b` (m, not squared, margin not subtracted) of every row, in
    /// row order, into `out` (length [`LocalFn::n_out`]); negative means penetration (then `-(r_a + r_b)`
    /// <= value < 0). Plain f64, for reports. `q` must hold n angles (a programmer's error otherwise:
    /// panics on a short slice).
    pub fn surface_distances(&self, q: &[f64], out: &mut [f64]) {
        let mut segs = [([0.0; 2], [0.0; 2]); MAX_LINKS];
        self.robot.link_segments(q, &mut segs[..self.robot.n]);
        self.for_each_pair(|k, p| out[k] = self.dist2(&segs, p).sqrt() - self.radii(p));
    }

    /// The exact check: the pair with the smallest true surface distance `d - r_a - r_b` (m) at `q`, and
    /// that distance, over the link-obstacle rows and, for self-collision, every pair of checked
    /// non-adjacent links by their segment-segment distance ([`ClearancePair::LinkLink`], which also
    /// sees crossing links); `None` when nothing is checked. Does not allocate. `q` as in
    /// [`Self::surface_distances`].
    pub fn min_clearance_pair(&self, q: &[f64]) -> Option<(ClearancePair, f64)> {
        let mut segs = [([0.0; 2], [0.0; 2]); MAX_LINKS];
        self.robot.link_segments(q, &mut segs[..self.robot.n]);
        let mut best: Option<(ClearancePair, f64)> = None;
        let mut consider = |p: ClearancePair| {
            let v = self.dist2(&segs, p).sqrt() - self.radii(p);
            if best.is_none_or(|(_, b)| v < b) {
                best = Some((p, v));
            }
        };
        self.for_each_pair(|_, p| {
            if let ClearancePair::LinkObstacle { .. } = p {
                consider(p);
            }
        });
        self.for_each_link_pair(consider);
        best
    }

    /// Whether every pair of the exact check ([`Self::min_clearance_pair`]) keeps a surface distance
    /// of at least `need` (m, >= 0) with the links at `segs` ([`Robot::link_segments`], n
    /// segments): [`Self::min_clearance`] `>= need` up to rounding, compared in squared distances
    /// and ended at the first pair closer than that.
    pub fn keeps(&self, segs: &[(P2<f64>, P2<f64>)], need: f64) -> bool {
        let pair_keeps = |p: ClearancePair| {
            let r = self.radii(p) + need;
            self.dist2(segs, p) >= r * r
        };
        for link in (0..self.robot.n).filter(|&i| self.links.contains(i)) {
            for obstacle in 0..self.obstacles.len() {
                if !pair_keeps(ClearancePair::LinkObstacle { link, obstacle }) {
                    return false;
                }
            }
        }
        let mut keeps = true;
        self.for_each_link_pair(|p| keeps = keeps && pair_keeps(p));
        keeps
    }

    /// The smallest true surface distance `d - r_a - r_b` (m) of the exact check
    /// ([`Self::min_clearance_pair`]) at `q`, `+inf` when nothing is checked. Negative: some capsules
    /// overlap (by at most the sum of their radii).
    pub fn min_clearance(&self, q: &[f64]) -> f64 {
        self.min_clearance_pair(q).map_or(f64::INFINITY, |(_, v)| v)
    }
}

impl LocalFn for ClearanceFn {
    type Scratch<T: Scalar> = Vec<(P2<T>, P2<T>)>;

    fn n_in(&self) -> usize {
        self.robot.n
    }

    fn n_out(&self) -> usize {
        let mut k = 0;
        self.for_each_pair(|_, _| k += 1);
        k
    }

    fn scratch<T: Scalar>(&self) -> Self::Scratch<T> {
        vec![([T::zero(), T::zero()], [T::zero(), T::zero()]); self.robot.n]
    }

    fn eval<T: Scalar>(&self, ws: &mut Self::Scratch<T>, z: &[T], out: &mut [T]) {
        self.robot.link_segments(z, ws);
        self.for_each_pair(|k, p| {
            let r = self.threshold(p);
            out[k] = self.dist2(ws, p) - c::<T>(r * r);
        });
    }

    fn hessian_entry_is_zero(&self, i: usize, j: usize) -> bool {
        let mut zero = true;
        self.for_each_pair(|_, p| {
            let (lo, hi) = p.dependence();
            if (lo..=hi).contains(&i) && (lo..=hi).contains(&j) {
                zero = false;
            }
        });
        zero
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::ad::{as_f64_fn, Diff};
    use crate::fdcheck::{assert_hessian, assert_jacobian};
    use crate::model::{ActuatorParams, LinkParams, RobotParams};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn paper_robot() -> Robot {
        let m = [0.35, 0.56, 0.56, 0.35];
        let com = [0.2059, 0.1832, 0.1718, 0.1491];
        let inertia = [0.98, 0.10, 0.10, 0.98];
        let links = (0..4)
            .map(|i| LinkParams {
                length: 0.355,
                mass: m[i],
                com: com[i],
                inertia: inertia[i],
                radius: 0.02,
                ..Default::default()
            })
            .collect();
        let params = RobotParams {
            name: "paper".into(),
            gravity: 9.81,
            links,
            actuators: ActuatorParams {
                tau_min: vec![-5.0; 3],
                tau_max: vec![5.0; 3],
            },
            end_effector: None,
        };
        Robot::from_params(params, "<test>").unwrap()
    }

    /// Three obstacles: the paper's, one elsewhere, and a point (radius 0).
    pub(crate) const TEST_OBSTACLES: [Circle; 3] = [
        Circle::PAPER,
        Circle {
            center: [-0.3, -0.4],
            radius: 0.07,
        },
        Circle {
            center: [0.1, 0.05],
            radius: 0.0,
        },
    ];

    /// A 5-link robot with unequal lengths and radii, to catch index mix-ups.
    pub(crate) fn odd_robot() -> Robot {
        let links = (0..5)
            .map(|i| LinkParams {
                length: 0.2 + 0.07 * i as f64,
                mass: 0.3,
                com: 0.1,
                inertia: 0.01,
                radius: 0.01 + 0.005 * i as f64,
                ..Default::default()
            })
            .collect();
        let params = RobotParams {
            name: "odd".into(),
            gravity: 9.81,
            links,
            actuators: ActuatorParams {
                tau_min: vec![-5.0; 4],
                tau_max: vec![5.0; 4],
            },
            end_effector: None,
        };
        Robot::from_params(params, "<test>").unwrap()
    }

    /// Independent joint positions from the angle convention (not `link_segments`).
    fn joints(robot: &Robot, q: &[f64]) -> Vec<[f64; 2]> {
        let mut p = vec![[0.0, 0.0]];
        let mut th = 0.0;
        for i in 0..robot.n {
            th += q[i];
            let last = p[i];
            p.push([
                last[0] + robot.len[i] * th.cos(),
                last[1] + robot.len[i] * th.sin(),
            ]);
        }
        p
    }

    /// Squared distance by sampling: dense samples of segment A against dense samples of B (or a point).
    fn sampled_d2(a0: [f64; 2], a1: [f64; 2], b0: [f64; 2], b1: [f64; 2]) -> f64 {
        let m = 1500;
        let mb = if b0 == b1 { 0 } else { m };
        let mut best = f64::INFINITY;
        for i in 0..=m {
            let s = i as f64 / m as f64;
            let pa = [a0[0] + s * (a1[0] - a0[0]), a0[1] + s * (a1[1] - a0[1])];
            for j in 0..=mb {
                let t = if mb == 0 { 0.0 } else { j as f64 / mb as f64 };
                let pb = [b0[0] + t * (b1[0] - b0[0]), b0[1] + t * (b1[1] - b0[1])];
                best = best.min((pa[0] - pb[0]).powi(2) + (pa[1] - pb[1]).powi(2));
            }
        }
        best
    }

    /// The early-ended check in squared distances ([`ClearanceFn::keeps`]) on segments composed by
    /// rotation ([`Robot::link_segments_rotated`]) says what the exact check says, at random poses
    /// of two robots against random circles, self-collision on and off, away from the boundary.
    #[test]
    fn the_early_ended_check_agrees_with_the_exact_clearance() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let (mut kept, mut broken) = (0, 0);
        for robot in [paper_robot(), odd_robot()] {
            let n = robot.n;
            for case in 0..400 {
                let obstacles: Vec<Circle> = (0..rng.gen_range(1..4))
                    .map(|_| Circle {
                        center: [rng.gen_range(-1.0..1.0), rng.gen_range(-1.2..0.3)],
                        radius: rng.gen_range(0.02..0.2),
                    })
                    .collect();
                let cf = ClearanceFn::new(robot.clone(), obstacles, 0.0)
                    .unwrap()
                    .with_self_collision(case % 2 == 0);
                let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
                let mut segs = vec![([0.0; 2], [0.0; 2]); n];
                let mut turned = segs.clone();
                robot.link_segments(&q, &mut segs);
                let rot: Vec<[f64; 2]> = q.iter().map(|a| [a.cos(), a.sin()]).collect();
                robot.link_segments_rotated(&rot, &mut turned);
                for (s, t) in segs.iter().zip(&turned) {
                    for (u, v) in [s.0, s.1].iter().zip([t.0, t.1]) {
                        assert!((u[0] - v[0]).abs() < 1e-12 && (u[1] - v[1]).abs() < 1e-12);
                    }
                }
                let exact = cf.min_clearance(&q);
                for need in [0.0, 0.01, 0.03] {
                    if (exact - need).abs() < 1e-9 {
                        continue;
                    }
                    assert_eq!(cf.keeps(&turned, need), exact >= need, "{q:?} {need}");
                    if exact >= need {
                        kept += 1;
                    } else {
                        broken += 1;
                    }
                }
            }
        }
        assert!(kept > 200 && broken > 200, "{kept} kept, {broken} broken");
    }

    #[test]
    fn row_layout_and_names() {
        let robot = paper_robot();
        let obs = [
            Circle::PAPER,
            Circle {
                center: [0.0, -1.0],
                radius: 0.05,
            },
        ];
        let f = ClearanceFn::new(robot.clone(), &obs[..], 0.01).unwrap();
        let names = f.row_names();
        // 12 end-point rows for the 3 non-adjacent link pairs, less the 2 joints shared by two pairs
        assert_eq!(f.n_out(), 4 * 2 + 10);
        assert_eq!(names.len(), f.n_out());
        assert_eq!(names[0], "link 1 vs obstacle 0");
        assert_eq!(names[1], "link 1 vs obstacle 1");
        assert_eq!(names[7], "link 4 vs obstacle 1");
        assert_eq!(
            &names[8..],
            [
                "end of link 2 vs link 1",
                "end of link 3 vs link 1",
                "end of link 4 vs link 1",
                "end of link 3 vs link 2",
                "end of link 4 vs link 2",
                "grip vs link 3",
                "end of link 1 vs link 3",
                "grip vs link 4",
                "end of link 1 vs link 4",
                "end of link 2 vs link 4",
            ]
        );
        let g = f.clone().with_self_collision(false);
        assert_eq!(g.n_out(), 8);
        let h = f.with_links(LinkSet::from_indices(&[0, 2, 3], 4).unwrap());
        assert_eq!(
            h.row_names(),
            [
                "link 1 vs obstacle 0",
                "link 1 vs obstacle 1",
                "link 3 vs obstacle 0",
                "link 3 vs obstacle 1",
                "link 4 vs obstacle 0",
                "link 4 vs obstacle 1",
                "end of link 2 vs link 1",
                "end of link 3 vs link 1",
                "end of link 4 vs link 1",
                "grip vs link 3",
                "end of link 1 vs link 3",
                "grip vs link 4",
                "end of link 1 vs link 4",
            ]
        );
        assert_eq!(
            ClearanceFn::new(robot.clone(), [], 0.0).unwrap().n_out(),
            10
        );
        assert_eq!(
            ClearanceFn::new(robot.clone(), [], 0.0)
                .unwrap()
                .with_self_collision(false)
                .min_clearance(&[0.0; 4]),
            f64::INFINITY
        );
    }

    #[test]
    fn invalid_inputs_are_typed_errors() {
        let robot = paper_robot();
        let bad = [Circle {
            center: [f64::NAN, 0.0],
            radius: 0.1,
        }];
        assert!(matches!(
            ClearanceFn::new(robot.clone(), &bad[..], 0.0),
            Err(Error::InvalidValue { ref field, .. }) if field == "obstacles[0].center[0]"
        ));
        let bad = [
            Circle::PAPER,
            Circle {
                center: [0.0, 0.0],
                radius: -0.1,
            },
        ];
        assert!(matches!(
            ClearanceFn::new(robot.clone(), &bad[..], 0.0),
            Err(Error::InvalidValue { ref field, .. }) if field == "obstacles[1].radius"
        ));
        assert!(ClearanceFn::new(robot.clone(), [], -0.01).is_err());
        assert!(ClearanceFn::new(robot.clone(), [], f64::INFINITY).is_err());
        assert!(LinkSet::from_indices(&[4], 4).is_err());
        assert!(LinkSet::from_indices(&[3], 4).is_ok());
    }

    #[test]
    fn circle_serde_round_trip() {
        let c = Circle::PAPER;
        let json = serde_json::to_string(&c).unwrap();
        assert_eq!(serde_json::from_str::<Circle>(&json).unwrap(), c);
        let t: Circle = toml::from_str("center = [0.55, -0.2]\nradius = 0.1\n").unwrap();
        assert_eq!(t, c);
        assert!(
            toml::from_str::<Circle>("center = [0.0, 0.0]\nradius = 0.1\ncolour = 1\n").is_err()
        );
    }

    #[test]
    fn values_match_sampled_distances() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        for robot in [paper_robot(), odd_robot()] {
            let n = robot.n;
            let obs = [
                Circle::PAPER,
                Circle {
                    center: [-0.3, -0.4],
                    radius: 0.07,
                },
            ];
            let margin = 0.013;
            let f = ClearanceFn::new(robot.clone(), &obs[..], margin).unwrap();
            let pairs = f.pairs();
            let mut ws = f.scratch::<f64>();
            let mut g = vec![0.0; f.n_out()];
            let mut sd = vec![0.0; f.n_out()];
            for _ in 0..6 {
                let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.2..3.2)).collect();
                f.eval(&mut ws, &q, &mut g);
                f.surface_distances(&q, &mut sd);
                let j = joints(&robot, &q);
                let mut min_true = f64::INFINITY;
                for (k, p) in pairs.iter().enumerate() {
                    let (d2, rsum) = match *p {
                        ClearancePair::LinkObstacle { link, obstacle } => {
                            let o = obs[obstacle].center;
                            (
                                sampled_d2(j[link], j[link + 1], o, o),
                                robot.radius[link] + obs[obstacle].radius,
                            )
                        }
                        ClearancePair::JointLink { joint, link } => {
                            // the partner radius: the largest of the links ending at the joint
                            // that are not adjacent to `link`
                            let partner = (joint.saturating_sub(1)..=joint.min(n - 1))
                                .filter(|a| a.abs_diff(link) >= 2)
                                .map(|a| robot.radius[a])
                                .fold(0.0, f64::max);
                            let pj = j[joint];
                            (
                                sampled_d2(j[link], j[link + 1], pj, pj),
                                robot.radius[link] + partner,
                            )
                        }
                        ClearancePair::LinkLink { .. } => unreachable!("not a row"),
                    };
                    // sampling overestimates d by at most half a sample spacing (< 0.4 mm here)
                    let want = d2 - (rsum + margin).powi(2);
                    assert!(g[k] <= want + 1e-12, "row {p}: {} vs sampled {want}", g[k]);
                    assert!(
                        g[k] >= want - 2e-3 * d2.sqrt() - 1e-6,
                        "row {p}: {} vs sampled {want}",
                        g[k]
                    );
                    let true_sd = d2.sqrt() - rsum;
                    assert!(
                        (sd[k] - true_sd).abs() < 5e-4,
                        "row {p}: {} vs {true_sd}",
                        sd[k]
                    );
                    if let ClearancePair::LinkObstacle { .. } = p {
                        min_true = min_true.min(sd[k]);
                    }
                }
                // the exact check: obstacle rows and the sampled segment-segment distances
                for a in 0..n {
                    for b in a + 2..n {
                        let d = sampled_d2(j[a], j[a + 1], j[b], j[b + 1]).sqrt();
                        min_true = min_true.min(d - robot.radius[a] - robot.radius[b]);
                    }
                }
                assert!(
                    (f.min_clearance(&q) - min_true).abs() < 5e-4,
                    "{} vs {min_true}",
                    f.min_clearance(&q)
                );
            }
        }
    }

    #[test]
    fn paper_obstacle_hit_and_start_pose() {
        let robot = paper_robot();
        let obs = [Circle::PAPER];
        let f = ClearanceFn::new(robot.clone(), &obs[..], 0.0).unwrap();
        // Links 1 and 2 straight towards the obstacle centre (0.55, -0.2): |c| = 0.585 lies between
        // L = 0.355 and 2L, so link 2 passes exactly through the centre.
        let th = (-0.2f64).atan2(0.55);
        let q = [th, 0.0, 1.0, 0.5];
        let mut g = vec![0.0; f.n_out()];
        f.eval(&mut f.scratch(), &q, &mut g);
        let names = f.row_names();
        let k2 = names
            .iter()
            .position(|s| s == "link 2 vs obstacle 0")
            .unwrap();
        assert!((g[k2] + (0.02f64 + 0.1).powi(2)).abs() < 1e-12, "{}", g[k2]);
        let (pair, v) = f.min_clearance_pair(&q).unwrap();
        assert_eq!(
            pair,
            ClearancePair::LinkObstacle {
                link: 1,
                obstacle: 0
            }
        );
        assert!((v + 0.12).abs() < 1e-9, "{v}");
        // link 1 ends 0.355 from the origin, |c| - 0.355 short of the centre
        let k1 = names
            .iter()
            .position(|s| s == "link 1 vs obstacle 0")
            .unwrap();
        let gap = 0.55f64.hypot(0.2) - 0.355;
        assert!(
            (g[k1] - (gap * gap - 0.12f64.powi(2))).abs() < 1e-12,
            "{}",
            g[k1]
        );

        // The paper's start pose is clear of the obstacle and of itself.
        let q0 = [-2.35, 0.0, -1.55, 0.0];
        f.eval(&mut f.scratch(), &q0, &mut g);
        assert!(g.iter().all(|&v| v > 0.0), "{g:?}");
        assert!(f.min_clearance(&q0) > 0.0);
    }

    #[test]
    fn touching_gives_zero_and_penetration_negative() {
        let robot = paper_robot();
        // horizontal chain (q = 0) along +x; obstacle above link 3 at distance exactly r_link + r_obs
        let r_obs = 0.05;
        let x = 0.355 * 2.5;
        for (dy, sign) in [(0.07, 0.0), (0.06, -1.0), (0.08, 1.0), (0.0, -1.0)] {
            let obs = [Circle {
                center: [x, dy],
                radius: r_obs,
            }];
            let f = ClearanceFn::new(robot.clone(), &obs[..], 0.0)
                .unwrap()
                .with_self_collision(false);
            let mut g = [0.0; 4];
            f.eval(&mut f.scratch(), &[0.0; 4], &mut g);
            let want: f64 = dy * dy - 0.07f64 * 0.07;
            assert!((g[2] - want).abs() < 1e-12);
            if sign == 0.0 {
                assert!(g[2].abs() < 1e-12);
            } else {
                assert_eq!(g[2].signum(), sign);
            }
            assert!((f.min_clearance(&[0.0; 4]) - (dy - 0.07)).abs() < 1e-12);
        }
        // self-collision: fold link 2 back so that link 3 crosses link 1. The exact check sees the
        // crossing (surface distance -(2r)); the end-point rows of the crossed pair need not (they
        // keep apart links that have not passed through each other).
        let f = ClearanceFn::new(robot.clone(), [], 0.0).unwrap();
        let q = [0.0, 2.5, 2.5, 0.0];
        let j = joints(&robot, &q);
        let sampled = sampled_d2(j[0], j[1], j[2], j[3]);
        assert!(sampled < 1e-6, "test pose must cross: {sampled}");
        let (pair, v) = f.min_clearance_pair(&q).unwrap();
        assert_eq!(pair, ClearancePair::LinkLink { a: 0, b: 2 });
        assert!((v + 0.04).abs() < 1e-12, "{v}");
    }

    #[test]
    fn end_point_rows_are_the_link_link_distance_for_links_that_do_not_cross() {
        // For every pair of non-adjacent links that do not cross, the smallest surface distance of
        // the four end-point rows is the segment-segment one (equal radii: every row's threshold is
        // the pair's); with unequal radii a shared joint takes the larger partner radius, so the rows
        // are never less safe than the pair. Also the poses the parameter study's optimum sits at:
        // long links folded parallel, where the segment-segment distance has its kink.
        let mut rng = ChaCha8Rng::seed_from_u64(17);
        for robot in [paper_robot(), odd_robot()] {
            let n = robot.n;
            let f = ClearanceFn::new(robot.clone(), [], 0.0).unwrap();
            let pairs = f.pairs();
            let mut sd = vec![0.0; f.n_out()];
            let mut poses: Vec<Vec<f64>> = (0..300)
                .map(|_| (0..n).map(|_| rng.gen_range(-3.2..3.2)).collect())
                .collect();
            // links 1 and 3 exactly antiparallel, overlapping along their length
            let mut par = vec![0.3, 2.0, std::f64::consts::PI - 2.0];
            par.resize(n, 0.4);
            poses.push(par);
            let mut compared = 0;
            for q in &poses {
                f.surface_distances(q, &mut sd);
                let j = joints(&robot, q);
                for a in 0..n {
                    for b in a + 2..n {
                        let exact = segment_segment_dist2(j[a], j[a + 1], j[b], j[b + 1]).sqrt();
                        let crossing = exact < 1e-12;
                        if crossing {
                            continue;
                        }
                        let rows = pairs.iter().zip(&sd).filter_map(|(p, &v)| match *p {
                            ClearancePair::JointLink { joint, link }
                                if (link == b && (joint == a || joint == a + 1))
                                    || (link == a && (joint == b || joint == b + 1)) =>
                            {
                                Some(v)
                            }
                            _ => None,
                        });
                        let (count, min_row) =
                            rows.fold((0, f64::INFINITY), |(c, m), v| (c + 1, m.min(v)));
                        assert_eq!(count, 4, "pair ({a}, {b})");
                        let pair_sd = exact - robot.radius[a] - robot.radius[b];
                        if robot.radius.iter().all(|&r| r == robot.radius[0]) {
                            assert!((min_row - pair_sd).abs() < 1e-12, "{min_row} vs {pair_sd}");
                        } else {
                            assert!(min_row <= pair_sd + 1e-12, "{min_row} vs {pair_sd}");
                        }
                        compared += 1;
                    }
                }
            }
            assert!(compared > 300, "{compared}");
        }
    }

    /// Smallest distance in parameter space from a piece boundary over all rows (plain f64, computed
    /// independently of `geometry`): projections of obstacle centres and of link end points, the
    /// interior stationary point of each link pair and near-parallel link pairs.
    fn away_from_kinks(robot: &Robot, obs: &[Circle], q: &[f64]) -> bool {
        let j = joints(robot, q);
        let proj = |p: [f64; 2], a: [f64; 2], b: [f64; 2]| {
            let d = [b[0] - a[0], b[1] - a[1]];
            ((p[0] - a[0]) * d[0] + (p[1] - a[1]) * d[1]) / (d[0] * d[0] + d[1] * d[1])
        };
        let ok = |t: f64| t.abs() > 1e-3 && (t - 1.0).abs() > 1e-3;
        for i in 0..robot.n {
            for o in obs {
                if !ok(proj(o.center, j[i], j[i + 1])) {
                    return false;
                }
            }
            for k in i + 2..robot.n {
                let (a0, a1, b0, b1) = (j[i], j[i + 1], j[k], j[k + 1]);
                let d1 = [a1[0] - a0[0], a1[1] - a0[1]];
                let d2 = [b1[0] - b0[0], b1[1] - b0[1]];
                let cr = d1[0] * d2[1] - d1[1] * d2[0];
                let (l1, l2) = (d1[0].hypot(d1[1]), d2[0].hypot(d2[1]));
                if cr.abs() < 1e-2 * l1 * l2 {
                    return false;
                }
                // line intersection parameters
                let w = [b0[0] - a0[0], b0[1] - a0[1]];
                let s = (w[0] * d2[1] - w[1] * d2[0]) / cr;
                let t = (w[0] * d1[1] - w[1] * d1[0]) / cr;
                let params = [
                    s,
                    t,
                    proj(a0, b0, b1),
                    proj(a1, b0, b1),
                    proj(b0, a0, a1),
                    proj(b1, a0, a1),
                ];
                if !params.into_iter().all(ok) {
                    return false;
                }
            }
        }
        true
    }

    #[test]
    fn derivatives_match_fd_on_random_poses() {
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        for robot in [paper_robot(), odd_robot()] {
            let n = robot.n;
            let obs = TEST_OBSTACLES;
            for (self_coll, links) in [
                (true, LinkSet::ALL),
                (false, LinkSet::ALL),
                (true, LinkSet::from_indices(&[1, 3], n).unwrap()),
            ] {
                let f = ClearanceFn::new(robot.clone(), &obs[..], 0.02)
                    .unwrap()
                    .with_self_collision(self_coll)
                    .with_links(links);
                let m = f.n_out();
                let mut diff = Diff::new(&f);
                let mut checked = 0;
                while checked < 40 {
                    let q: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.2..3.2)).collect();
                    if !away_from_kinks(&robot, &obs, &q) {
                        continue;
                    }
                    checked += 1;
                    let (mut g, mut jac) = (vec![0.0; m], vec![0.0; m * n]);
                    diff.jacobian(&f, &q, &mut g, &mut jac);
                    assert_jacobian("clearance Jacobian", as_f64_fn(&f), &q, &jac, 1e-6);
                    let w: Vec<f64> = (0..m).map(|_| rng.gen_range(-1.0..1.0)).collect();
                    let mut hess = vec![0.0; n * n];
                    diff.hessian_weighted(&f, &q, &w, &mut hess);
                    // FD of the exact gradient of w.g
                    let mut gd = Diff::new(&f);
                    let grad = |x: &[f64], out: &mut [f64]| {
                        let (mut gv, mut jv) = (vec![0.0; m], vec![0.0; m * n]);
                        gd.jacobian(&f, x, &mut gv, &mut jv);
                        for c in 0..n {
                            out[c] = (0..m).map(|r| w[r] * jv[r * n + c]).sum();
                        }
                    };
                    assert_hessian("clearance weighted Hessian", grad, &q, &hess, 1e-5);
                }
            }
        }
    }

    #[test]
    fn declared_hessian_zeros_are_zero() {
        // Entries declared zero by `hessian_entry_is_zero` (skipped by `Diff`) must be zero in the AD
        // Hessian of every single row computed without skipping.
        let robot = odd_robot();
        let n = robot.n;
        for obs in [&[][..], &[Circle::PAPER][..]] {
            let f = ClearanceFn::new(robot.clone(), obs, 0.0)
                .unwrap()
                .with_links(LinkSet::from_indices(&[0, 2, 3], n).unwrap());
            // an unskipped reference: same rows, no declared zeros
            struct Full(ClearanceFn);
            impl LocalFn for Full {
                type Scratch<T: Scalar> = Vec<(P2<T>, P2<T>)>;
                fn n_in(&self) -> usize {
                    self.0.n_in()
                }
                fn n_out(&self) -> usize {
                    self.0.n_out()
                }
                fn scratch<T: Scalar>(&self) -> Self::Scratch<T> {
                    self.0.scratch()
                }
                fn eval<T: Scalar>(&self, ws: &mut Self::Scratch<T>, z: &[T], out: &mut [T]) {
                    self.0.eval(ws, z, out)
                }
            }
            let full = Full(f.clone());
            let m = f.n_out();
            let q = [0.3, -1.1, 2.0, 0.4, -0.7];
            let mut skipped = 0;
            for r in 0..m {
                let mut w = vec![0.0; m];
                w[r] = 1.0;
                let mut h = vec![0.0; n * n];
                Diff::new(&full).hessian_weighted(&full, &q, &w, &mut h);
                for i in 0..n {
                    for j in 0..n {
                        if f.hessian_entry_is_zero(i, j) {
                            skipped += 1;
                            assert!(
                                h[i * n + j].abs() < 1e-12,
                                "row {r} entry ({i},{j}) = {}",
                                h[i * n + j]
                            );
                        }
                    }
                }
            }
            assert!(skipped > 0);
        }
    }
}
