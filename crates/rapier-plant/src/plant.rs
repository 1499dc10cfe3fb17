//! The rapier plant: the robot as a multibody chain in a rapier2d-f64 world, plus obstacles.
//!
//! Conventions: `x = [q, qd]` with `q[0]` the absolute angle of link 1 from +x and `q[i >= 1]`
//! relative (rad, rad/s, continuous); `tau` = torques of joints 2..n (N m); gravity along -y; SI units.

use crate::obstacle::{point_segment_distance, ContactBody, ContactEvent, Obstacle};
use crate::settings::RapierSettings;
use brachia::sim::{Plant, StepClock};
use brachia::{Error, Result, Robot};
use rapier2d_f64::prelude::*;

/// Mass properties of one link as the engine holds them (to check they match the robot's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkMassProperties {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in the link frame `[along the link, across]`, m (the frame's origin is the
    /// proximal joint).
    pub local_com: [f64; 2],
    /// Planar inertia about the centre of mass, kg m^2.
    pub inertia: f64,
}

/// One obstacle in the world.
#[derive(Debug, Clone)]
struct ObstacleEntry {
    spec: Obstacle,
    body: RigidBodyHandle,
    collider: ColliderHandle,
}

/// The robot simulated by rapier2d-f64 (see the crate docs for the construction).
///
/// Implements [`Plant`]: `state` reads the multibody's joint coordinates and velocities, `step`
/// applies the clamped torques as equal and opposite body torques and advances
/// [`RapierSettings::substeps`] engine steps, `energy` sums the robot's kinetic and potential energy
/// from the engine's body poses and velocities.
pub struct RapierPlant {
    robot: Robot,
    settings: RapierSettings,
    world: PhysicsWorld,
    /// Joint 1 of the current chain, world, m.
    grip: [f64; 2],
    /// The robot's bodies and joints.
    chain: Chain,
    obstacles: Vec<ObstacleEntry>,
    contacts: Vec<ContactEvent>,
    /// Impulses accumulated over the current control step: (link, body, impulse).
    pending: Vec<(usize, ContactBody, f64)>,
    /// Obstacle centres over time, one row per control step from the first step on:
    /// `[t, x_0, y_0, x_1, y_1, ...]` (s, m), obstacles in id order.
    track: Vec<f64>,
    tau: Vec<f64>,
    /// Time since the last grip switch.
    clock: StepClock,
    /// Time before the last grip switch, s.
    t_before: f64,
    /// Pushes to apply over the next step: (link, impulse N s, point in the world m).
    pushes: Vec<(usize, [f64; 2], [f64; 2])>,
}

impl std::fmt::Debug for RapierPlant {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RapierPlant")
            .field("n_links", &self.robot.n())
            .field("settings", &self.settings)
            .field("t", &self.clock.time())
            .field("obstacles", &self.obstacles.len())
            .field("contacts", &self.contacts.len())
            .finish()
    }
}

/// `w x r` for a planar angular velocity `w` (rad/s) and a vector `r`.
fn cross(w: f64, r: [f64; 2]) -> [f64; 2] {
    [-w * r[1], w * r[0]]
}

/// Largest distance between a joint before and after [`RapierPlant::regrip`] (the rebuilt pose),
/// m: the re-rooting map keeps world positions to about 1e-12 m.
pub const REGRIP_TOLERANCE_M: f64 = 1e-9;

/// Check a grip: finite coordinates.
fn check_grip(grip: [f64; 2]) -> Result<()> {
    if let Some(i) = grip.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "<grip>",
            format!("grip[{i}]"),
            grip[i],
            "must be finite",
        ));
    }
    Ok(())
}

/// The robot's bodies and joints in the world (rebuilt by [`RapierPlant::regrip`]).
#[derive(Debug, Clone)]
struct Chain {
    /// The fixed body at the grip.
    root: RigidBodyHandle,
    /// Link bodies, link 1 first.
    links: Vec<RigidBodyHandle>,
    /// Link colliders, link 1 first.
    link_colliders: Vec<ColliderHandle>,
    /// Multibody link ids of the robot's links.
    mb_links: Vec<usize>,
    /// A joint of the chain (the first), to reach the multibody.
    joint: MultibodyJointHandle,
}

/// What a grip switch did to the robot in the world ([`RapierPlant::regrip`]). Joints are listed
/// in the order of the chain **before** the switch (its grip first, its EE last), world frame, m and
/// m/s, read from the engine's bodies before and after the rebuild.
#[derive(Debug, Clone, PartialEq)]
pub struct Regrip {
    /// The grip before, world, m.
    pub grip_before: [f64; 2],
    /// The grip after (the old EE where the hand closed), world, m.
    pub grip_after: [f64; 2],
    /// Every joint's world position before the switch (n + 1 points), m.
    pub joints_before: Vec<[f64; 2]>,
    /// Every joint's world position after the switch, in the same order, m.
    pub joints_after: Vec<[f64; 2]>,
    /// Every joint's world velocity before the switch, m/s.
    pub velocities_before: Vec<[f64; 2]>,
    /// Every joint's world velocity after the switch, m/s.
    pub velocities_after: Vec<[f64; 2]>,
    /// Largest distance between a joint's position before and after, m (the rebuild's residual).
    pub position_residual_m: f64,
    /// Distance of the old EE (the new grip's hand) from `grip_after` before the switch, m.
    pub grip_offset_m: f64,
    /// Speed of the old EE just before the switch, m/s.
    pub ee_speed_before_m_s: f64,
    /// Largest change of a joint's world velocity across the switch, m/s (the capture impulse).
    pub velocity_change_m_s: f64,
}

/// Insert `robot`'s chain into `world`, hinged at `grip` (world, m) in state `x0 = [q, qd]`.
fn build_chain(
    world: &mut PhysicsWorld,
    robot: &Robot,
    grip: [f64; 2],
    x0: &[f64],
    settings: &RapierSettings,
) -> Result<Chain> {
    let n = robot.n();
    let (q0, qd0) = x0.split_at(n);
    let root =
        world.insert_body(RigidBodyBuilder::fixed().translation(Vector::new(grip[0], grip[1])));
    let mut links = Vec::with_capacity(n);
    let mut link_colliders = Vec::with_capacity(n);
    let mut joint = None;
    for i in 0..n {
        let (l, r) = (robot.lengths()[i], robot.radii()[i]);
        let body = RigidBodyBuilder::dynamic()
            .translation(Vector::new(grip[0], grip[1]))
            .additional_mass_properties(MassProperties::new(
                Vector::new(robot.coms()[i], robot.coms_across()[i]),
                robot.masses()[i],
                robot.inertias()[i],
            ))
            .linear_damping(0.0)
            .angular_damping(0.0)
            .can_sleep(false);
        // capsule along the link from joint to joint; zero density so the colliders add no mass
        let collider = ColliderBuilder::capsule_x(0.5 * l, r)
            .translation(Vector::new(0.5 * l, 0.0))
            .density(0.0)
            .friction(settings.link_friction)
            .restitution(settings.link_restitution)
            .restitution_combine_rule(CoefficientCombineRule::Max);
        let (h, c) = world.insert(body, collider);
        let (parent, anchor1) = if i == 0 {
            (root, Vector::ZERO)
        } else {
            (links[i - 1], Vector::new(robot.lengths()[i - 1], 0.0))
        };
        let jh = world
            .insert_multibody_joint(
                parent,
                h,
                RevoluteJointBuilder::new()
                    .local_anchor1(anchor1)
                    .local_anchor2(Vector::ZERO)
                    .contacts_enabled(false),
            )
            .ok_or_else(|| {
                Error::InfeasibleTask(format!("rapier refused the multibody joint of link {i}"))
            })?;
        joint.get_or_insert(jh);
        links.push(h);
        link_colliders.push(c);
    }
    let joint = joint.ok_or_else(|| Error::InfeasibleTask("robot without links".into()))?;
    // rapier folds the additional mass properties in during the next step only; do it now so the
    // initial forward kinematics (and anything read before the first step) sees the exact values.
    for &h in &links {
        if let Some(rb) = world.bodies.get_mut(h) {
            rb.recompute_mass_properties_from_colliders(&world.colliders);
        }
    }

    let mb_links = {
        let (mb, _) = world
            .multibody_joints
            .get_mut(joint)
            .ok_or_else(|| Error::InfeasibleTask("rapier lost the multibody".into()))?;
        // The first forward kinematics turns the fixed root into a 0-dof link (before it the root
        // counts as a free body), so the dof vectors below have exactly n entries.
        mb.forward_kinematics(&world.bodies, true);
        mb.set_self_contacts_enabled(settings.self_contacts);
        // rapier gives every revolute dof a damping of 0.1 by default: the robot has none.
        mb.damping_mut().fill(0.0);
        mb.armature_mut().fill(0.0);
        mb.frictions_mut().fill(0.0);
        let mut ids = Vec::with_capacity(n);
        for &h in &links {
            let id = mb
                .links()
                .find(|lk| lk.rigid_body_handle() == h)
                .map(|lk| lk.link_id())
                .ok_or_else(|| Error::InfeasibleTask("link missing from multibody".into()))?;
            ids.push(id);
        }
        // Joint coordinates start at 0 (a straight chain along +x) whatever the body poses:
        // displace them to q0, and set the relative joint velocities to qd0.
        if mb.ndofs() != n {
            return Err(Error::Dimension {
                what: "rapier multibody dofs".into(),
                expected: n,
                got: mb.ndofs(),
            });
        }
        let assembly: Vec<usize> = ids
            .iter()
            .map(|&id| mb.link(id).map_or(usize::MAX, |lk| lk.assembly_id()))
            .collect();
        if let Some(&a) = assembly.iter().find(|&&a| a >= n) {
            return Err(Error::Dimension {
                what: "rapier multibody assembly id".into(),
                expected: n,
                got: a,
            });
        }
        let mut disp = vec![0.0; n];
        for i in 0..n {
            disp[assembly[i]] = q0[i];
        }
        mb.apply_displacements(&disp);
        {
            let mut v = mb.generalized_velocity_mut();
            for i in 0..n {
                v[assembly[i]] = qd0[i];
            }
        }
        mb.forward_kinematics(&world.bodies, true);
        mb.update_rigid_bodies(&mut world.bodies, true);
        ids
    };

    // The engine derives the body velocities from the joint velocities only during a step, and
    // uses the bodies' current velocities for the Coriolis terms of that step: set them too.
    let mut th = 0.0;
    let mut w = 0.0;
    let mut v = [0.0, 0.0];
    for i in 0..n {
        th += q0[i];
        w += qd0[i];
        let (s, c) = th.sin_cos();
        let (cx, cy) = (robot.coms()[i], robot.coms_across()[i]);
        let rc = [c * cx - s * cy, s * cx + c * cy];
        let wc = cross(w, rc);
        if let Some(rb) = world.bodies.get_mut(links[i]) {
            rb.set_linvel(Vector::new(v[0] + wc[0], v[1] + wc[1]), true);
            rb.set_angvel(w, true);
        }
        let rl = [c * robot.lengths()[i], s * robot.lengths()[i]];
        let wl = cross(w, rl);
        v = [v[0] + wl[0], v[1] + wl[1]];
    }
    Ok(Chain {
        root,
        links,
        link_colliders,
        mb_links,
        joint,
    })
}

/// Check a state `[q, qd]` for an n-link chain: 2n finite values.
fn check_state(n: usize, x0: &[f64], what: &str) -> Result<()> {
    if x0.len() != 2 * n {
        return Err(Error::Dimension {
            what: format!("{what} = [q, qd]"),
            expected: 2 * n,
            got: x0.len(),
        });
    }
    if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
        return Err(Error::invalid(
            "<x0>",
            format!("x0[{i}]"),
            x0[i],
            "must be finite",
        ));
    }
    Ok(())
}

impl RapierPlant {
    /// Build the world for `robot` hanging from the origin, starting at `x0 = [q, qd]` (2n values)
    /// at t = 0 ([`RapierPlant::new_at`] with the grip at the origin).
    ///
    /// Errors: `x0` of the wrong length ([`Error::Dimension`]) or not finite, invalid `settings`
    /// ([`Error::InvalidValue`]).
    pub fn new(robot: &Robot, x0: &[f64], settings: &RapierSettings) -> Result<Self> {
        Self::new_at(robot, [0.0, 0.0], x0, settings)
    }

    /// Build the world for `robot` hanging from `grip` (world, m), starting at `x0 = [q, qd]` (2n
    /// values) at t = 0. The engine's frame is the world: obstacles are given and read in it.
    ///
    /// Errors: as [`RapierPlant::new`]; a non-finite grip ([`Error::InvalidValue`]).
    pub fn new_at(
        robot: &Robot,
        grip: [f64; 2],
        x0: &[f64],
        settings: &RapierSettings,
    ) -> Result<Self> {
        settings.validate("<rapier settings>")?;
        check_state(robot.n(), x0, "rapier plant initial state x0")?;
        check_grip(grip)?;
        let mut world = PhysicsWorld::new();
        world.gravity = Vector::new(0.0, -robot.gravity);
        world.integration_parameters.dt = 1e-3 / settings.substeps as f64;
        let chain = build_chain(&mut world, robot, grip, x0, settings)?;
        Ok(RapierPlant {
            tau: vec![0.0; robot.nu()],
            robot: robot.clone(),
            settings: settings.clone(),
            world,
            grip,
            chain,
            obstacles: Vec::new(),
            contacts: Vec::new(),
            pending: Vec::new(),
            track: Vec::new(),
            clock: StepClock::new(0.0),
            t_before: 0.0,
            pushes: Vec::new(),
        })
    }

    /// The grip (joint 1 of the current chain), world, m.
    pub fn grip(&self) -> [f64; 2] {
        self.grip
    }

    /// Time since the plant was built, s: [`Plant::time`] counts from the last grip switch, this
    /// from the start (contacts and the obstacle track are stamped with it).
    pub fn total_time(&self) -> f64 {
        self.t_before + self.clock.time()
    }

    /// Every joint's world position and velocity (n + 1 points, grip first), read from the engine's
    /// bodies (m, m/s).
    pub fn world_joints(&self) -> (Vec<[f64; 2]>, Vec<[f64; 2]>) {
        let n = self.robot.n();
        let mut p = Vec::with_capacity(n + 1);
        let mut v = Vec::with_capacity(n + 1);
        for (i, &h) in self.chain.links.iter().enumerate() {
            let Some(rb) = self.world.bodies.get(h) else {
                return (vec![[f64::NAN; 2]; n + 1], vec![[f64::NAN; 2]; n + 1]);
            };
            let t = rb.translation();
            let th = rb.rotation().angle();
            let (s, c) = th.sin_cos();
            let w = rb.angvel();
            let lv = rb.linvel();
            // linvel is the centre-of-mass velocity; the body frame is at the proximal joint
            let (cx, cy) = (self.robot.coms()[i], self.robot.coms_across()[i]);
            let com = [c * cx - s * cy, s * cx + c * cy];
            let at = |r: [f64; 2]| {
                let wr = cross(w, [r[0] - com[0], r[1] - com[1]]);
                [lv.x + wr[0], lv.y + wr[1]]
            };
            p.push([t.x, t.y]);
            v.push(at([0.0, 0.0]));
            if i + 1 == n {
                let [ex, ey] = self.robot.end_effector();
                let r = [c * ex - s * ey, s * ex + c * ey];
                p.push([t.x + r[0], t.y + r[1]]);
                v.push(at(r));
            }
        }
        (p, v)
    }

    /// Switch the grip to the hand at the chain's EE: the gripper there closes on its bar and the
    /// old one opens. The chain's bodies and joints are removed and the chain is rebuilt as
    /// `robot` (the re-rooted chain, [`brachia::Robot::rerooted`] of [`RapierPlant::robot`]) hinged
    /// by a new root joint at `grip` (world, m) in state `x = [q', qd']`, which the caller maps
    /// with [`brachia::model::switch_grip`] (the capture impulse and the re-rooting). Obstacles and
    /// balls keep their world state; [`Plant::time`] starts again at 0 ([`RapierPlant::total_time`]
    /// runs on); contacts after the switch name the new chain's links.
    ///
    /// Returns the residuals read from the engine: every joint's world position and velocity
    /// before and after ([`Regrip`]). Errors: `robot` of another link count or `x` of the wrong
    /// length or not finite ([`Error::Dimension`], [`Error::InvalidValue`]); the rebuilt chain
    /// further than [`REGRIP_TOLERANCE_M`] from the old one at any joint ([`Error::InfeasibleTask`]:
    /// `x` is not the re-rooted pose, and the plant is left as rebuilt).
    pub fn regrip(&mut self, robot: &Robot, grip: [f64; 2], x: &[f64]) -> Result<Regrip> {
        let n = self.robot.n();
        if robot.n() != n {
            return Err(Error::Dimension {
                what: "regrip: links of the new chain".into(),
                expected: n,
                got: robot.n(),
            });
        }
        check_state(n, x, "regrip: new state x")?;
        check_grip(grip)?;
        let (joints_before, velocities_before) = self.world_joints();
        for &h in &self.chain.links {
            self.world.remove_body(h);
        }
        self.world.remove_body(self.chain.root);
        self.chain = build_chain(&mut self.world, robot, grip, x, &self.settings)?;
        let grip_before = self.grip;
        self.robot = robot.clone();
        self.grip = grip;
        self.tau = vec![0.0; robot.nu()];
        self.pushes.clear();
        self.t_before += self.clock.time();
        self.clock = StepClock::new(0.0);
        let (mut joints_after, mut velocities_after) = self.world_joints();
        joints_after.reverse();
        velocities_after.reverse();
        let dist = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        let maxd = |a: &[[f64; 2]], b: &[[f64; 2]]| {
            a.iter()
                .zip(b)
                .map(|(p, q)| dist(*p, *q))
                .fold(0.0, f64::max)
        };
        let r = Regrip {
            grip_before,
            grip_after: grip,
            position_residual_m: maxd(&joints_before, &joints_after),
            grip_offset_m: dist(joints_before[n], grip),
            ee_speed_before_m_s: velocities_before[n][0].hypot(velocities_before[n][1]),
            velocity_change_m_s: maxd(&velocities_before, &velocities_after),
            joints_before,
            joints_after,
            velocities_before,
            velocities_after,
        };
        if r.position_residual_m.is_nan() || r.position_residual_m > REGRIP_TOLERANCE_M {
            return Err(Error::InfeasibleTask(format!(
                "regrip: the rebuilt chain is {:.3e} m from the old one (tolerance {REGRIP_TOLERANCE_M} m): the new state is not the old pose re-rooted at grip [{}, {}]",
                r.position_residual_m, grip[0], grip[1]
            )));
        }
        Ok(r)
    }

    /// The robot simulated.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The settings in use.
    pub fn settings(&self) -> &RapierSettings {
        &self.settings
    }

    /// Add an obstacle; returns its id (0, 1, ... in the order added), used in [`ContactEvent`]s.
    ///
    /// Errors: invalid values ([`Error::InvalidValue`]); an obstacle overlapping the robot's capsules
    /// in the current pose ([`Error::InfeasibleTask`]).
    pub fn add_obstacle(&mut self, obstacle: &Obstacle) -> Result<usize> {
        let id = self.obstacles.len();
        obstacle.validate("<obstacle>", id)?;
        let (center, radius) = obstacle.shape();
        let mut x = vec![0.0; 2 * self.robot.n()];
        self.state(&mut x);
        let mut segs = vec![([0.0; 2], [0.0; 2]); self.robot.n()];
        self.robot.link_segments(&x[..self.robot.n()], &mut segs);
        let g = self.grip;
        for (a, b) in segs.iter_mut() {
            *a = [a[0] + g[0], a[1] + g[1]];
            *b = [b[0] + g[0], b[1] + g[1]];
        }
        for (i, (a, b)) in segs.iter().enumerate() {
            let d = point_segment_distance(center, *a, *b);
            if d < radius + self.robot.radii()[i] {
                return Err(Error::InfeasibleTask(format!(
                    "obstacle {id} (centre [{}, {}], radius {radius} m) overlaps link {} at the \
                     current pose (distance {d:.4} m)",
                    center[0],
                    center[1],
                    i + 1
                )));
            }
        }
        let c = Vector::new(center[0], center[1]);
        let (body, collider) = match obstacle {
            Obstacle::Circle(_) => self.world.insert(
                RigidBodyBuilder::fixed().translation(c),
                ColliderBuilder::ball(radius),
            ),
            Obstacle::Ball(b) => self.world.insert(
                RigidBodyBuilder::dynamic()
                    .translation(c)
                    .gravity_scale(if b.gravity { 1.0 } else { 0.0 })
                    .linear_damping(0.0)
                    .angular_damping(0.0)
                    .can_sleep(false),
                ColliderBuilder::ball(radius)
                    .mass(b.mass)
                    .restitution(b.restitution)
                    .restitution_combine_rule(CoefficientCombineRule::Max),
            ),
        };
        // an obstacle added after the first step was not there before: its columns of the earlier
        // rows of the track are NaN, so every row keeps the width of the current obstacle set
        if !self.track.is_empty() {
            let width = 1 + 2 * id;
            let rows = self.track.len() / width.max(1);
            let mut padded = Vec::with_capacity(rows * (width + 2));
            for row in self.track.chunks_exact(width) {
                padded.extend_from_slice(row);
                padded.extend_from_slice(&[f64::NAN; 2]);
            }
            self.track = padded;
        }
        self.obstacles.push(ObstacleEntry {
            spec: obstacle.clone(),
            body,
            collider,
        });
        Ok(id)
    }

    /// The obstacles added, in id order.
    pub fn obstacles(&self) -> impl Iterator<Item = &Obstacle> {
        self.obstacles.iter().map(|o| &o.spec)
    }

    /// Current centre `[x, y]` (m) of obstacle `id`, `None` for an unknown id.
    pub fn obstacle_position(&self, id: usize) -> Option<[f64; 2]> {
        let o = self.obstacles.get(id)?;
        let p = self.world.bodies.get(o.body)?.translation();
        Some([p.x, p.y])
    }

    /// Current velocity `[vx, vy]` (m/s) of obstacle `id`, `None` for an unknown id.
    pub fn obstacle_velocity(&self, id: usize) -> Option<[f64; 2]> {
        let o = self.obstacles.get(id)?;
        let v = self.world.bodies.get(o.body)?.linvel();
        Some([v.x, v.y])
    }

    /// Centres `[x, y]` (m) of the free balls, in the order they were added (fixed circles left out;
    /// [`Self::obstacle_track`] has every obstacle over time).
    pub fn ball_positions(&self) -> Vec<[f64; 2]> {
        (0..self.obstacles.len())
            .filter(|&i| matches!(self.obstacles[i].spec, Obstacle::Ball(_)))
            .filter_map(|i| self.obstacle_position(i))
            .collect()
    }

    /// Every obstacle's centre over time: one row `[t, x_0, y_0, x_1, y_1, ...]` (s, m; obstacles in id
    /// order) at the start of the first step and after every step since. Empty before the first step or
    /// without obstacles. An obstacle added after the first step (a ball thrown in later) has NaN
    /// in the rows before it existed; every row has one column pair per obstacle added so far.
    pub fn obstacle_track(&self) -> impl Iterator<Item = &[f64]> {
        self.track.chunks_exact(1 + 2 * self.obstacles.len())
    }

    /// [`Self::obstacle_track`] as CSV text with the header `t,obstacle_0_x,obstacle_0_y,...` (s, m).
    pub fn obstacle_track_csv(&self) -> String {
        use std::fmt::Write as _;
        let mut s = String::from("t");
        for i in 0..self.obstacles.len() {
            let _ = write!(s, ",obstacle_{i}_x,obstacle_{i}_y");
        }
        s.push('\n');
        for row in self.obstacle_track() {
            let _ = write!(s, "{:.6}", row[0]);
            for v in &row[1..] {
                let _ = write!(s, ",{v:.9}");
            }
            s.push('\n');
        }
        s
    }

    fn record_obstacles(&mut self) {
        if self.obstacles.is_empty() {
            return;
        }
        self.track.push(self.total_time());
        for id in 0..self.obstacles.len() {
            let p = self.obstacle_position(id).unwrap_or([f64::NAN; 2]);
            self.track.extend_from_slice(&p);
        }
    }

    /// Every contact of a link so far, in time order (one event per link, body and control step).
    pub fn contacts(&self) -> &[ContactEvent] {
        &self.contacts
    }

    /// Time of the first logged contact, s (`None` if the robot has touched nothing).
    pub fn first_contact_time(&self) -> Option<f64> {
        self.contacts.first().map(|c| c.t)
    }

    /// The torques applied during the last step, after clamping, N m (n - 1 values).
    pub fn applied_torques(&self) -> &[f64] {
        &self.tau
    }

    /// The engine's joint damping per dof (zero: the trap of rapier's default 0.1 is handled).
    pub fn engine_joint_damping(&self) -> Vec<f64> {
        self.multibody()
            .map(|mb| mb.damping().iter().copied().collect())
            .unwrap_or_default()
    }

    /// The mass properties of each link as held by the engine.
    pub fn link_mass_properties(&self) -> Vec<LinkMassProperties> {
        self.chain
            .links
            .iter()
            .filter_map(|&h| self.world.bodies.get(h))
            .map(|rb| {
                let mp = rb.mass_properties().local_mprops;
                LinkMassProperties {
                    mass: mp.mass(),
                    local_com: [mp.local_com.x, mp.local_com.y],
                    inertia: mp.principal_inertia(),
                }
            })
            .collect()
    }

    /// Absolute link angles read from the engine's body rotations, wrapped to (-pi, pi], rad.
    pub fn body_angles(&self) -> Vec<f64> {
        self.chain
            .links
            .iter()
            .filter_map(|&h| self.world.bodies.get(h))
            .map(|rb| rb.rotation().angle())
            .collect()
    }

    /// Absolute link angular velocities read from the engine's bodies, rad/s.
    pub fn body_angular_velocities(&self) -> Vec<f64> {
        self.chain
            .links
            .iter()
            .filter_map(|&h| self.world.bodies.get(h))
            .map(|rb| rb.angvel())
            .collect()
    }

    fn multibody(&self) -> Option<&Multibody> {
        self.world
            .multibody_joints
            .get(self.chain.joint)
            .map(|(mb, _)| mb)
    }

    /// Index of a link collider, if `c` is one.
    fn link_of(&self, c: ColliderHandle) -> Option<usize> {
        self.chain.link_colliders.iter().position(|&h| h == c)
    }

    fn accumulate(&mut self, link: usize, body: ContactBody, impulse: f64) {
        if let Some(e) = self.pending.iter_mut().find(|e| e.0 == link && e.1 == body) {
            e.2 += impulse;
        } else {
            self.pending.push((link, body, impulse));
        }
    }

    /// Read the contact impulses of the engine step just taken.
    fn collect_contacts(&mut self) {
        let mut found = Vec::new();
        for (id, o) in self.obstacles.iter().enumerate() {
            for pair in self.world.contact_pairs_with(o.collider) {
                let other = if pair.collider1 == o.collider {
                    pair.collider2
                } else {
                    pair.collider1
                };
                if let Some(link) = self.link_of(other) {
                    let imp = pair.total_impulse_magnitude();
                    if imp > 0.0 {
                        found.push((link, ContactBody::Obstacle(id), imp));
                    }
                }
            }
        }
        if self.settings.self_contacts {
            for (i, &c) in self.chain.link_colliders.iter().enumerate() {
                for pair in self.world.contact_pairs_with(c) {
                    let other = if pair.collider1 == c {
                        pair.collider2
                    } else {
                        pair.collider1
                    };
                    if let Some(j) = self.link_of(other) {
                        let imp = pair.total_impulse_magnitude();
                        if j > i && imp > 0.0 {
                            found.push((i, ContactBody::Link(j), imp));
                        }
                    }
                }
            }
        }
        for (link, body, imp) in found {
            self.accumulate(link, body, imp);
        }
    }
}

impl Plant for RapierPlant {
    fn n_links(&self) -> usize {
        self.robot.n()
    }

    fn time(&self) -> f64 {
        self.clock.time()
    }

    /// `[q, qd]` from the multibody's joint coordinates (continuous, never wrapped) and relative joint
    /// velocities. The first joint is hinged to the fixed root at the origin with the root frame
    /// aligned with the world, so its coordinate is the absolute angle of link 1.
    fn state(&self, x: &mut [f64]) {
        let n = self.robot.n();
        let Some(mb) = self.multibody() else {
            x.fill(f64::NAN);
            return;
        };
        let v = mb.generalized_velocity();
        for (i, &id) in self.chain.mb_links.iter().enumerate() {
            if let Some(lk) = mb.link(id) {
                // 2-D revolute joint: the angular coordinate follows the two linear ones
                x[i] = lk.joint().coords()[2];
                x[n + i] = v[lk.assembly_id()];
            }
        }
    }

    /// Apply `tau` (clamped to the robot's limits; a missing or non-finite entry counts as 0) for
    /// `dt` seconds as `substeps` engine steps of `dt / substeps`. A `dt` that is not a finite
    /// positive number leaves the plant unchanged.
    fn step(&mut self, tau: &[f64], dt: f64) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        for j in 0..self.tau.len() {
            let t = tau.get(j).copied().unwrap_or(0.0);
            self.tau[j] = if t.is_finite() {
                t.clamp(self.robot.tau_min[j], self.robot.tau_max[j])
            } else {
                0.0
            };
        }
        // Joint j+2 (tau[j]) acts between link j (parent) and link j+1 (child): +tau on the child,
        // -tau on the parent, which is a generalized force tau on q[j+1] only. User torques persist
        // across engine steps until reset.
        for &h in &self.chain.links {
            if let Some(rb) = self.world.bodies.get_mut(h) {
                rb.reset_torques(false);
                rb.reset_forces(false);
            }
        }
        // a push is the force impulse / dt held over this control period, at its point
        for (link, j, p) in self.pushes.drain(..) {
            if let Some(rb) = self.world.bodies.get_mut(self.chain.links[link]) {
                rb.add_force_at_point(
                    Vector::new(j[0] / dt, j[1] / dt),
                    Vector::new(p[0], p[1]),
                    true,
                );
            }
        }
        for j in 0..self.tau.len() {
            let t = self.tau[j];
            if let Some(rb) = self.world.bodies.get_mut(self.chain.links[j + 1]) {
                rb.add_torque(t, true);
            }
            if let Some(rb) = self.world.bodies.get_mut(self.chain.links[j]) {
                rb.add_torque(-t, true);
            }
        }
        if self.track.is_empty() {
            self.record_obstacles();
        }
        self.world.integration_parameters.dt = dt / self.settings.substeps as f64;
        self.pending.clear();
        for _ in 0..self.settings.substeps {
            self.world.step();
            self.collect_contacts();
        }
        self.clock.advance(dt);
        let t = self.total_time();
        self.contacts.extend(
            self.pending
                .drain(..)
                .map(|(link, body, impulse)| ContactEvent {
                    t,
                    link,
                    body,
                    impulse,
                }),
        );
        self.record_obstacles();
    }

    /// A push is applied by the engine as the force `impulse / dt` at the point (grip frame, where
    /// it is at the start of the period), held over the next control period of length `dt`.
    fn push(&mut self, link: usize, point_m: f64, impulse: [f64; 2]) -> Result<()> {
        let n = self.robot.n();
        if link >= n || !point_m.is_finite() || !impulse.iter().all(|v| v.is_finite()) {
            return Err(Error::invalid(
                "RapierPlant",
                "push",
                format!("link {link}, point {point_m} m, impulse {impulse:?}"),
                format!("needs a link 0..{n} and finite values"),
            ));
        }
        let mut x = vec![0.0; 2 * n];
        self.state(&mut x);
        let mut joints = vec![[0.0; 2]; n + 1];
        self.robot.joint_positions(&x[..n], &mut joints);
        let mut th = vec![0.0; n];
        self.robot.absolute_angles(&x[..n], &mut th);
        let (sn, co) = th[link].sin_cos();
        let p = [
            self.grip[0] + joints[link][0] + point_m * co,
            self.grip[1] + joints[link][1] + point_m * sn,
        ];
        self.pushes.push((link, impulse, p));
        Ok(())
    }

    /// Kinetic plus potential energy of the links (obstacles excluded), J, from the engine's body
    /// poses and velocities (`linvel` is the centre-of-mass velocity); potential zero at the grip height.
    fn energy(&self) -> f64 {
        let g = self.robot.gravity;
        let mut e = 0.0;
        for (i, &h) in self.chain.links.iter().enumerate() {
            let Some(rb) = self.world.bodies.get(h) else {
                return f64::NAN;
            };
            // the body frame sits at the proximal joint; the centre of mass is `com` along the link
            // and `com_across` across it
            let (s, c) = rb.rotation().angle().sin_cos();
            let y_com = rb.translation().y - self.grip[1]
                + s * self.robot.coms()[i]
                + c * self.robot.coms_across()[i];
            let v = rb.linvel();
            let w = rb.angvel();
            e += 0.5 * self.robot.masses()[i] * (v.x * v.x + v.y * v.y)
                + 0.5 * self.robot.inertias()[i] * w * w
                + self.robot.masses()[i] * g * y_com;
        }
        e
    }

    fn name(&self) -> &'static str {
        "rapier"
    }
}
