//! URDF import: the serial chain from the grip joint to the tip, projected onto the plane normal to
//! its joints' common axis (see the module docs of [`crate::urdf`]).

use super::frames::{finite3, Frame};
use crate::error::{Error, Result};
use crate::model::{ActuatorParams, LinkParams, RobotParams, MAX_LINKS};
use nalgebra::{Matrix3, Vector3};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::Path;
use urdf_rs::JointType;

/// Two axes are parallel when the sine of their angle is below this.
const PARALLEL_SIN: f64 = 1e-6;

/// A link length below this (m) is a link of zero length.
const ZERO_LENGTH: f64 = 1e-12;

/// The largest magnitude of a tip coordinate (m) or a torque limit (N m) taken from a URDF file: the
/// limit every robot's link values obey (`LinkParams`).
const VALUE_MAX: f64 = 1e6;

/// The tip of the chain: a URDF link and a point in its frame (m). Written `link` or
/// `link:x,y,z`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "String")]
pub struct Tip {
    /// The link's name.
    pub link: String,
    /// The point in the link's frame, m. Default the link's origin.
    pub point: [f64; 3],
}

impl TryFrom<String> for Tip {
    type Error = String;
    fn try_from(s: String) -> std::result::Result<Self, String> {
        s.parse()
    }
}

impl From<Tip> for String {
    fn from(t: Tip) -> String {
        t.to_string()
    }
}

impl std::fmt::Display for Tip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.point == [0.0; 3] {
            write!(f, "{}", self.link)
        } else {
            let [x, y, z] = self.point;
            write!(f, "{}:{x},{y},{z}", self.link)
        }
    }
}

impl std::str::FromStr for Tip {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let (link, point) = match s.split_once(':') {
            None => (s, [0.0; 3]),
            Some((l, p)) => {
                let v: Vec<f64> = p
                    .split(',')
                    .map(|x| x.trim().parse::<f64>())
                    .collect::<std::result::Result<_, _>>()
                    .map_err(|_| format!("tip `{s}`: the point must be three numbers x,y,z"))?;
                let pt: [f64; 3] = v
                    .try_into()
                    .map_err(|_| format!("tip `{s}`: the point must be three numbers x,y,z"))?;
                if !finite3(&pt) {
                    return Err(format!("tip `{s}`: the point must be finite"));
                }
                if pt.iter().any(|v| v.abs() > VALUE_MAX) {
                    return Err(format!(
                        "tip `{s}`: the point must lie within {:e} m of the link's origin",
                        VALUE_MAX
                    ));
                }
                (l, pt)
            }
        };
        if link.trim().is_empty() {
            return Err(format!("tip `{s}`: needs a link name"));
        }
        Ok(Tip {
            link: link.trim().to_string(),
            point,
        })
    }
}

fn default_gravity() -> f64 {
    9.81
}

/// How to read a URDF file as a brachia robot (the `[urdf]` table of a scenario).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct UrdfOptions {
    /// The joint at the grip: a revolute or continuous joint (passive), or the fixed joint where
    /// the hand holds the bar.
    pub grip: String,
    /// The tip of the swinging end: `link` or `link:x,y,z` (a point in the link's frame, m).
    pub tip: Tip,
    /// Joints without an actuator when the file has no `<transmission>` elements; the grip is
    /// always passive. Default none.
    #[serde(default)]
    pub passive: Vec<String>,
    /// Joints (or the links they carry) off the chain to leave out with everything below them.
    /// Fixed joints off the chain are left out without being listed. Default none.
    #[serde(default)]
    pub ignore: Vec<String>,
    /// Gravitational acceleration of the URDF world along -z, m/s^2. Default 9.81.
    #[serde(default = "default_gravity")]
    pub gravity: f64,
}

impl UrdfOptions {
    /// Options with the grip joint and the tip, everything else at its default.
    pub fn new(grip: impl Into<String>, tip: Tip) -> Self {
        UrdfOptions {
            grip: grip.into(),
            tip,
            passive: vec![],
            ignore: vec![],
            gravity: default_gravity(),
        }
    }
}

/// A robot read from a URDF file, with where each number came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    /// The parameters (validated by [`crate::Robot::from_params`] when used).
    pub params: RobotParams,
    /// For a field path of `params` (`gravity`, `links[1].mass`, `actuators.tau_max[0]`, ...), the
    /// URDF elements it was computed from.
    pub trace: Vec<(String, String)>,
    /// The URDF names of the chain's joints, grip first.
    pub joints: Vec<String>,
}

/// `<transmission>` elements: only the joints they name are read.
#[derive(Debug, Deserialize, Default)]
struct TransmissionRoot {
    #[serde(rename = "transmission", default)]
    transmissions: Vec<Transmission>,
}

#[derive(Debug, Deserialize)]
struct Transmission {
    #[serde(rename = "@name", default)]
    name: String,
    #[serde(rename = "joint", default)]
    joints: Vec<NamedElement>,
}

#[derive(Debug, Deserialize)]
struct NamedElement {
    #[serde(rename = "@name")]
    name: String,
}

/// Read and import a URDF file.
pub fn import_urdf_file(path: &Path, opts: &UrdfOptions) -> Result<Imported> {
    let text = crate::limits::read_text_capped(path, crate::limits::MAX_TOML_BYTES, "URDF file")?;
    import_urdf_str(&text, &path.display().to_string(), opts)
}

/// Import the URDF document `text`; `src` names it in messages.
pub fn import_urdf_str(text: &str, src: &str, opts: &UrdfOptions) -> Result<Imported> {
    let parse_err = |message: String| Error::Parse {
        path: src.into(),
        message,
    };
    super::nesting::check_nesting(text, src)?;
    super::numbers::check_numbers(text, src)?;
    let urdf = urdf_rs::read_from_string(text).map_err(|e| parse_err(e.to_string()))?;
    let trans: TransmissionRoot =
        quick_xml::de::from_str(text).map_err(|e| parse_err(format!("<transmission>: {e}")))?;
    Importer::new(&urdf, src, opts)?.run(&trans)
}

/// The URDF tree indexed by name.
struct Importer<'a> {
    urdf: &'a urdf_rs::Robot,
    src: &'a str,
    opts: &'a UrdfOptions,
    link: HashMap<&'a str, usize>,
    /// The joint whose child a link is (by link index).
    parent_joint: Vec<Option<usize>>,
    /// Joints whose parent a link is (by link index).
    child_joints: Vec<Vec<usize>>,
    /// Zero-angle frame of each link in the root link's frame (the world).
    frame: Vec<Frame>,
}

fn jname(j: &urdf_rs::Joint) -> String {
    format!("joint \"{}\"", j.name)
}

fn lname(l: &urdf_rs::Link) -> String {
    format!("link \"{}\"", l.name)
}

fn moving(t: &JointType) -> bool {
    !matches!(t, JointType::Fixed)
}

/// The chain's bodies and joints, found by [`Importer::chain`].
struct Chain {
    /// Joint indices of the chain's joints, grip first (one per body).
    joints: Vec<usize>,
    /// Body index of each link of the moving part (None: not part of it).
    body: Vec<Option<usize>>,
    /// Fixed joints merged into each body (names, for the trace).
    merged: Vec<Vec<String>>,
}

impl<'a> Importer<'a> {
    fn new(urdf: &'a urdf_rs::Robot, src: &'a str, opts: &'a UrdfOptions) -> Result<Self> {
        let bad = |field: String, value: String, reason: String| {
            Err(Error::invalid(src, field, value, reason))
        };
        let mut link = HashMap::new();
        for (i, l) in urdf.links.iter().enumerate() {
            if link.insert(l.name.as_str(), i).is_some() {
                return bad(lname(l), l.name.clone(), "two links of this name".into());
            }
        }
        let mut joint_names = std::collections::HashSet::new();
        for jt in &urdf.joints {
            if !joint_names.insert(jt.name.as_str()) {
                return bad(jname(jt), jt.name.clone(), "two joints of this name".into());
            }
        }
        let nl = urdf.links.len();
        let (mut parent_joint, mut child_joints) = (vec![None; nl], vec![vec![]; nl]);
        for (j, jt) in urdf.joints.iter().enumerate() {
            let find = |name: &str, role: &str| {
                link.get(name).copied().ok_or_else(|| {
                    Error::invalid(
                        src,
                        format!("{} <{role}>", jname(jt)),
                        name,
                        "no link of that name in the file",
                    )
                })
            };
            let (p, c) = (
                find(&jt.parent.link, "parent")?,
                find(&jt.child.link, "child")?,
            );
            if parent_joint[c].is_some() {
                return bad(
                    jname(jt),
                    jt.child.link.clone(),
                    "its child link already has a parent joint: a URDF is a tree".into(),
                );
            }
            parent_joint[c] = Some(j);
            child_joints[p].push(j);
        }
        let roots: Vec<usize> = (0..nl).filter(|&l| parent_joint[l].is_none()).collect();
        if roots.len() != 1 {
            let names: Vec<&str> = roots.iter().map(|&l| urdf.links[l].name.as_str()).collect();
            return bad(
                "<robot>".into(),
                format!("{names:?}"),
                "needs exactly one root link (the world or base)".into(),
            );
        }
        // zero-angle frames, depth first from the root
        let mut frame = vec![Frame::identity(); nl];
        let mut stack = vec![roots[0]];
        while let Some(l) = stack.pop() {
            for &j in &child_joints[l] {
                let jt = &urdf.joints[j];
                if !(finite3(&jt.origin.xyz.0) && finite3(&jt.origin.rpy.0)) {
                    return bad(
                        format!("{} <origin>", jname(jt)),
                        format!("{:?} {:?}", jt.origin.xyz.0, jt.origin.rpy.0),
                        "must be finite".into(),
                    );
                }
                let c = link[jt.child.link.as_str()];
                frame[c] = frame[l].then(&Frame::from_pose(&jt.origin));
                stack.push(c);
            }
        }
        Ok(Importer {
            urdf,
            src,
            opts,
            link,
            parent_joint,
            child_joints,
            frame,
        })
    }

    fn err(
        &self,
        field: impl Into<String>,
        value: impl ToString,
        reason: impl Into<String>,
    ) -> Error {
        Error::invalid(self.src, field, value, reason)
    }

    fn ignored(&self, j: usize) -> bool {
        let jt = &self.urdf.joints[j];
        self.opts
            .ignore
            .iter()
            .any(|n| *n == jt.name || *n == jt.child.link)
    }

    /// Every name of `urdf.ignore` must be a joint or link of the file, off the chain `path`: a
    /// name that matches nothing, or a part of the chain, would be ignored silently.
    fn check_ignore(&self, path: &[usize]) -> Result<()> {
        for n in &self.opts.ignore {
            let joint = self.urdf.joints.iter().position(|j| j.name == *n);
            let link = self.link.contains_key(n.as_str());
            if joint.is_none() && !link {
                return Err(self.err(
                    "urdf.ignore",
                    n,
                    "no joint or link of that name in the file",
                ));
            }
            let on_chain = path.iter().any(|&j| {
                let jt = &self.urdf.joints[j];
                jt.name == *n || jt.child.link == *n
            });
            if on_chain {
                return Err(self.err(
                    "urdf.ignore",
                    n,
                    "is part of the chain from the grip to the tip; only branches off it can be \
                     left out",
                ));
            }
        }
        Ok(())
    }

    /// The path from the grip joint to the tip link, and the bodies of the moving part.
    fn chain(&self) -> Result<Chain> {
        let urdf = self.urdf;
        let grip = urdf
            .joints
            .iter()
            .position(|j| j.name == self.opts.grip)
            .ok_or_else(|| {
                let names: Vec<&str> = urdf.joints.iter().map(|j| j.name.as_str()).collect();
                self.err(
                    "urdf.grip",
                    &self.opts.grip,
                    format!("no joint of that name in the file (its joints: {names:?})"),
                )
            })?;
        let gt = &urdf.joints[grip];
        if !matches!(
            gt.joint_type,
            JointType::Revolute | JointType::Continuous | JointType::Fixed
        ) {
            return Err(self.err(
                jname(gt),
                format!("type {:?}", gt.joint_type),
                "the grip joint must be revolute, continuous or fixed",
            ));
        }
        let tip = *self.link.get(self.opts.tip.link.as_str()).ok_or_else(|| {
            self.err(
                "urdf.tip",
                &self.opts.tip.link,
                "no link of that name in the file",
            )
        })?;
        // walk up from the tip to the grip joint
        let mut path = vec![];
        let mut l = tip;
        loop {
            let Some(j) = self.parent_joint[l] else {
                return Err(self.err(
                    "urdf.tip",
                    &self.opts.tip.link,
                    format!(
                        "the tip link is not below the grip joint \"{}\" in the URDF tree",
                        self.opts.grip
                    ),
                ));
            };
            path.push(j);
            if j == grip {
                break;
            }
            l = self.link[urdf.joints[j].parent.link.as_str()];
        }
        path.reverse();
        self.check_ignore(&path)?;
        for &j in &path {
            let jt = &urdf.joints[j];
            if !matches!(
                jt.joint_type,
                JointType::Revolute | JointType::Continuous | JointType::Fixed
            ) {
                return Err(self.err(
                    jname(jt),
                    format!("type {:?}", jt.joint_type),
                    "a joint of the chain must be revolute, continuous or fixed",
                ));
            }
        }
        let joints: Vec<usize> = path
            .iter()
            .copied()
            .filter(|&j| j == grip || moving(&urdf.joints[j].joint_type))
            .collect();
        self.bodies(grip, joints, &path)
    }

    /// Assign every link below the grip to a body; refuse moving branches not ignored.
    fn bodies(&self, grip: usize, joints: Vec<usize>, path: &[usize]) -> Result<Chain> {
        let urdf = self.urdf;
        let nl = urdf.links.len();
        let mut body = vec![None; nl];
        let mut merged = vec![vec![]; joints.len()];
        let first = self.link[urdf.joints[grip].child.link.as_str()];
        body[first] = Some(0);
        let mut stack = vec![first];
        while let Some(l) = stack.pop() {
            let b = body[l].expect("assigned before pushed");
            for &j in &self.child_joints[l] {
                let jt = &urdf.joints[j];
                let c = self.link[jt.child.link.as_str()];
                let on_path = path.contains(&j);
                if let Some(k) = joints.iter().position(|&x| x == j) {
                    body[c] = Some(k);
                } else if on_path || (!moving(&jt.joint_type) && !self.ignored(j)) {
                    body[c] = Some(b);
                    merged[b].push(format!("{} to {}", jname(jt), lname(&urdf.links[c])));
                } else if self.ignored(j) {
                    continue;
                } else {
                    return Err(self.err(
                        jname(jt),
                        format!("type {:?}, child link \"{}\"", jt.joint_type, jt.child.link),
                        format!(
                            "a moving branch off the chain from link \"{}\": brachia models a \
                             serial chain (list it in urdf.ignore to leave it out)",
                            jt.parent.link
                        ),
                    ));
                }
                stack.push(c);
            }
        }
        // moving joints outside the chain's part of the tree (the world side)
        for (j, jt) in urdf.joints.iter().enumerate() {
            let c = self.link[jt.child.link.as_str()];
            if body[c].is_none() && j != grip && moving(&jt.joint_type) && !self.ignored(j) {
                let below_ignored = self.below_ignored(c);
                if !below_ignored {
                    return Err(self.err(
                        jname(jt),
                        format!("type {:?}", jt.joint_type),
                        "a moving joint outside the chain (the bar and the base must be fixed; \
                         list it in urdf.ignore to leave it out)",
                    ));
                }
            }
        }
        if !(2..=MAX_LINKS).contains(&joints.len()) {
            return Err(self.err(
                "urdf.tip",
                &self.opts.tip.link,
                format!(
                    "the chain from the grip to the tip has {} moving joints; brachia needs 2 to {MAX_LINKS}",
                    joints.len()
                ),
            ));
        }
        Ok(Chain {
            joints,
            body,
            merged,
        })
    }

    /// True when link `l` hangs below an ignored joint.
    fn below_ignored(&self, mut l: usize) -> bool {
        while let Some(j) = self.parent_joint[l] {
            if self.ignored(j) {
                return true;
            }
            l = self.link[self.urdf.joints[j].parent.link.as_str()];
        }
        false
    }

    fn run(&self, trans: &TransmissionRoot) -> Result<Imported> {
        let urdf = self.urdf;
        let ch = self.chain()?;
        let nb = ch.joints.len();
        let jt = |k: usize| &urdf.joints[ch.joints[k]];
        let joint_frame = |k: usize| self.frame[self.link[jt(k).child.link.as_str()]];
        // the common axis
        let mut axes = vec![None; nb];
        for k in 0..nb {
            if !moving(&jt(k).joint_type) {
                continue;
            }
            let a = Vector3::from(jt(k).axis.xyz.0);
            if !finite3(&jt(k).axis.xyz.0) || a.norm() < 1e-9 {
                return Err(self.err(
                    format!("{} <axis>", jname(jt(k))),
                    format!("{:?}", jt(k).axis.xyz.0),
                    "must be a finite non-zero vector",
                ));
            }
            axes[k] = Some(joint_frame(k).r * a.normalize());
        }
        let n_ax = axes.iter().flatten().next().copied().ok_or_else(|| {
            self.err(
                "urdf.grip",
                &self.opts.grip,
                "the chain has no revolute joint",
            )
        })?;
        let mut sign = vec![1.0; nb];
        for k in 0..nb {
            if let Some(a) = axes[k] {
                let sin = a.cross(&n_ax).norm();
                if sin > PARALLEL_SIN {
                    return Err(self.err(
                        format!("{} <axis>", jname(jt(k))),
                        format!("{:?}", jt(k).axis.xyz.0),
                        format!(
                            "not parallel to the chain's first axis {:?} (in the world frame; \
                             sine of the angle {sin:.3e}): brachia models a planar chain",
                            [n_ax.x, n_ax.y, n_ax.z]
                        ),
                    ));
                }
                if a.dot(&n_ax) < 0.0 {
                    sign[k] = -1.0;
                }
            }
        }
        Projected::build(self, &ch, n_ax, sign, trans)
    }
}

/// The plane of the chain and the quantities projected into it.
struct Projected {
    ex: Vector3<f64>,
    ey: Vector3<f64>,
    origin: Vector3<f64>,
}

impl Projected {
    fn p(&self, v: Vector3<f64>) -> [f64; 2] {
        let d = v - self.origin;
        [d.dot(&self.ex), d.dot(&self.ey)]
    }

    fn build(
        im: &Importer<'_>,
        ch: &Chain,
        n_ax: Vector3<f64>,
        sign: Vec<f64>,
        trans: &TransmissionRoot,
    ) -> Result<Imported> {
        let urdf = im.urdf;
        let nb = ch.joints.len();
        let jt = |k: usize| &urdf.joints[ch.joints[k]];
        let mut trace: Vec<(String, String)> = vec![];
        // the plane: y up (the world's +z projected), x = y cross axis
        let z = Vector3::new(0.0, 0.0, 1.0);
        let zp = z - n_ax * z.dot(&n_ax);
        let (ey, gscale) = if zp.norm() > 1e-12 {
            (zp.normalize(), zp.norm())
        } else {
            let helper = if n_ax.x.abs() < 0.9 {
                Vector3::x()
            } else {
                Vector3::y()
            };
            (n_ax.cross(&helper).normalize(), 0.0)
        };
        let ex = ey.cross(&n_ax);
        let grip_link = im.link[jt(0).child.link.as_str()];
        let pr = Projected {
            ex,
            ey,
            origin: im.frame[grip_link].t,
        };
        let gravity = im.opts.gravity * gscale;
        trace.push((
            "gravity".into(),
            format!(
                "{} m/s^2 along the URDF world's -z, projected into the plane normal to the axis {:?} (factor {gscale:.6})",
                im.opts.gravity,
                [n_ax.x, n_ax.y, n_ax.z]
            ),
        ));
        // joint positions and the tip in the plane
        let pj: Vec<[f64; 2]> = (0..nb)
            .map(|k| pr.p(im.frame[im.link[jt(k).child.link.as_str()]].t))
            .collect();
        let tip_link = im.link[im.opts.tip.link.as_str()];
        let tip = pr.p(im.frame[tip_link].point(Vector3::from(im.opts.tip.point)));
        let mut links = Vec::with_capacity(nb);
        let mut alpha_prev = 0.0;
        let mut alphas = vec![0.0; nb];
        for k in 0..nb {
            let end = if k + 1 < nb { pj[k + 1] } else { tip };
            let (dx, dy) = (end[0] - pj[k][0], end[1] - pj[k][1]);
            let len = dx.hypot(dy);
            let (length, alpha) = if len <= ZERO_LENGTH {
                (0.0, alpha_prev)
            } else {
                (len, dy.atan2(dx))
            };
            alphas[k] = alpha;
            let to = if k + 1 < nb {
                jname(jt(k + 1))
            } else {
                format!("the tip {}", im.opts.tip)
            };
            trace.push((
                format!("links[{k}].length"),
                format!("from {} to {to}, in the plane", jname(jt(k))),
            ));
            let mp = pr.mass_properties(im, ch, k, n_ax)?;
            let (cx, cy) = (mp.com[0] - pj[k][0], mp.com[1] - pj[k][1]);
            let (s, c) = alpha.sin_cos();
            let bodies = mp.links.join(", ");
            trace.push((format!("links[{k}].mass"), format!("<mass> of {bodies}")));
            trace.push((
                format!("links[{k}].com"),
                format!("<inertial><origin> of {bodies}, combined, along the link"),
            ));
            trace.push((
                format!("links[{k}].com_across"),
                format!("<inertial><origin> of {bodies}, combined, across the link"),
            ));
            trace.push((
                format!("links[{k}].inertia"),
                format!("<inertia> of {bodies} about the axis, parallel-axis rule"),
            ));
            let offset = wrap(alpha - if k == 0 { 0.0 } else { alpha_prev });
            // rounding of the frames' products: an offset of 1e-16 rad is none
            let offset = if offset.abs() < 1e-12 { 0.0 } else { offset };
            trace.push((
                format!("links[{k}].joint_offset"),
                format!(
                    "the link's direction at zero angles from {} <origin>s",
                    jname(jt(k))
                ),
            ));
            let mut lp = LinkParams {
                length,
                mass: mp.mass,
                com: c * cx + s * cy,
                com_across: -s * cx + c * cy,
                inertia: mp.inertia,
                joint_offset: offset,
                joint_reversed: sign[k] < 0.0,
                ..Default::default()
            };
            if lp.com_across.abs() < 1e-15 {
                lp.com_across = 0.0;
            }
            pr.limits(jt(k), &mut lp, &mut trace, k, im.src)?;
            links.push(lp);
            alpha_prev = alpha;
        }
        let (tau_min, tau_max) = actuation(im, ch, trans, &mut trace)?;
        Ok(Imported {
            params: RobotParams {
                name: urdf.name.clone(),
                gravity,
                links,
                actuators: ActuatorParams { tau_min, tau_max },
                end_effector: None,
            },
            trace,
            joints: ch
                .joints
                .iter()
                .map(|&j| urdf.joints[j].name.clone())
                .collect(),
        })
    }

    /// Position and velocity limits of a chain joint, in brachia's angle.
    fn limits(
        &self,
        j: &urdf_rs::Joint,
        lp: &mut LinkParams,
        trace: &mut Vec<(String, String)>,
        k: usize,
        src: &str,
    ) -> Result<()> {
        let lim = &j.limit;
        if matches!(j.joint_type, JointType::Revolute)
            && !(lim.lower.is_finite() && lim.upper.is_finite() && lim.lower <= lim.upper)
        {
            return Err(Error::invalid(
                src,
                format!("{} <limit lower upper>", jname(j)),
                format!("{} {}", lim.lower, lim.upper),
                "must be finite with lower <= upper",
            ));
        }
        if !(lim.velocity.is_finite() && lim.velocity >= 0.0) {
            return Err(Error::invalid(
                src,
                format!("{} <limit velocity>", jname(j)),
                lim.velocity,
                "must be finite and >= 0 (0: no velocity limit)",
            ));
        }
        if matches!(j.joint_type, JointType::Revolute)
            && lim.lower.is_finite()
            && lim.upper.is_finite()
            && lim.lower < lim.upper
        {
            let s = if lp.joint_reversed { -1.0 } else { 1.0 };
            let (a, b) = (
                s * lim.lower + lp.joint_offset,
                s * lim.upper + lp.joint_offset,
            );
            lp.q_min = Some(a.min(b));
            lp.q_max = Some(a.max(b));
            let what = format!("{} <limit lower upper> mapped to brachia's angle", jname(j));
            trace.push((format!("links[{k}].q_min"), what.clone()));
            trace.push((format!("links[{k}].q_max"), what));
        }
        if lim.velocity.is_finite() && lim.velocity > 0.0 {
            lp.qd_max = Some(lim.velocity);
            trace.push((
                format!("links[{k}].qd_max"),
                format!("{} <limit velocity>", jname(j)),
            ));
        }
        Ok(())
    }

    /// Mass, centre of mass (in the plane) and inertia about the axis of body `k`.
    fn mass_properties(
        &self,
        im: &Importer<'_>,
        ch: &Chain,
        k: usize,
        n_ax: Vector3<f64>,
    ) -> Result<BodyMass> {
        let urdf = im.urdf;
        let mut parts = vec![];
        let mut names = vec![];
        for (l, b) in ch.body.iter().enumerate() {
            if *b != Some(k) {
                continue;
            }
            let link = &urdf.links[l];
            let inr = &link.inertial;
            let m = inr.mass.value;
            if !m.is_finite() || m < 0.0 {
                return Err(im.err(
                    format!("{} <mass>", lname(link)),
                    m,
                    "must be finite and >= 0",
                ));
            }
            let it = &inr.inertia;
            let local = Matrix3::new(
                it.ixx, it.ixy, it.ixz, it.ixy, it.iyy, it.iyz, it.ixz, it.iyz, it.izz,
            );
            if local.iter().any(|v| !v.is_finite()) {
                return Err(im.err(
                    format!("{} <inertia>", lname(link)),
                    format!("{local:?}"),
                    "must be finite",
                ));
            }
            if m == 0.0 {
                continue;
            }
            let f = im.frame[l].then(&Frame::from_pose(&inr.origin));
            let inn = n_ax.dot(&(f.r * local * f.r.transpose() * n_ax));
            if inn < 0.0 {
                return Err(im.err(
                    format!("{} <inertia>", lname(link)),
                    inn,
                    "its moment about the chain's axis must be >= 0",
                ));
            }
            names.push(lname(link));
            parts.push((m, self.p(f.t), inn));
        }
        let joint = jname(&urdf.joints[ch.joints[k]]);
        let mass: f64 = parts.iter().map(|p| p.0).sum();
        if mass <= 0.0 {
            return Err(im.err(
                format!("the body moved by {joint}"),
                mass,
                "its links' <mass> must add up to more than 0",
            ));
        }
        let com = [0, 1].map(|i| parts.iter().map(|p| p.0 * p.1[i]).sum::<f64>() / mass);
        let inertia: f64 = parts
            .iter()
            .map(|(m, c, i)| i + m * ((c[0] - com[0]).powi(2) + (c[1] - com[1]).powi(2)))
            .sum();
        if inertia <= 0.0 {
            return Err(im.err(
                format!("the body moved by {joint} ({})", names.join(", ")),
                inertia,
                "its inertia about the axis through its centre of mass must be > 0",
            ));
        }
        for m in &ch.merged[k] {
            names.push(format!("(merged by {m})"));
        }
        Ok(BodyMass {
            mass,
            com,
            inertia,
            links: names,
        })
    }
}

struct BodyMass {
    mass: f64,
    com: [f64; 2],
    inertia: f64,
    links: Vec<String>,
}

/// Torque limits of joints 2..n; refuses a passive joint other than the grip and an actuated grip.
fn actuation(
    im: &Importer<'_>,
    ch: &Chain,
    trans: &TransmissionRoot,
    trace: &mut Vec<(String, String)>,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let urdf = im.urdf;
    let names: Vec<&str> = ch
        .joints
        .iter()
        .map(|&j| urdf.joints[j].name.as_str())
        .collect();
    for p in &im.opts.passive {
        if !names.contains(&p.as_str()) {
            return Err(im.err(
                "urdf.passive",
                p,
                format!("not a joint of the chain (its joints: {names:?})"),
            ));
        }
    }
    let by_transmission: HashMap<&str, &str> = trans
        .transmissions
        .iter()
        .flat_map(|t| {
            t.joints
                .iter()
                .map(move |j| (j.name.as_str(), t.name.as_str()))
        })
        .collect();
    let use_trans = !trans.transmissions.is_empty();
    if let Some(t) = by_transmission.get(names[0]).filter(|_| use_trans) {
        return Err(im.err(
            format!("<transmission name=\"{t}\">"),
            names[0],
            "actuates the grip joint: the grip of a brachiation robot is passive",
        ));
    }
    let (mut lo, mut hi) = (vec![], vec![]);
    for (k, &j) in ch.joints.iter().enumerate().skip(1) {
        let jt = &urdf.joints[j];
        let passive = if use_trans {
            !by_transmission.contains_key(jt.name.as_str())
        } else {
            im.opts.passive.contains(&jt.name)
        } || !moving(&jt.joint_type);
        if passive {
            let why = if use_trans {
                "no <transmission> actuates it"
            } else {
                "it is listed in urdf.passive"
            };
            return Err(im.err(
                jname(jt),
                "passive",
                format!(
                    "{why}: only the grip joint may be passive (joint {} of the chain)",
                    k + 1
                ),
            ));
        }
        let e = jt.limit.effort;
        if !(e.is_finite() && e > 0.0 && e <= VALUE_MAX) {
            return Err(im.err(
                format!("{} <limit effort>", jname(jt)),
                e,
                format!(
                    "an actuated joint needs a torque limit > 0 and at most {:e} N m",
                    VALUE_MAX
                ),
            ));
        }
        lo.push(-e);
        hi.push(e);
        let src = format!("{} <limit effort> (symmetric)", jname(jt));
        trace.push((format!("actuators.tau_min[{}]", k - 1), src.clone()));
        trace.push((format!("actuators.tau_max[{}]", k - 1), src));
    }
    Ok((lo, hi))
}

/// An angle wrapped into (-pi, pi].
fn wrap(a: f64) -> f64 {
    crate::model::wrap_angle(a)
}

/// A refusal of a `[urdf]` option (`urdf.grip`, `urdf.tip`, `urdf.passive`, `urdf.ignore`, the
/// gravity) named where the user wrote it: the file `src` that gave the options (a scenario), with
/// the URDF file `path` in the rule. Other refusals (the URDF's own elements) keep naming the URDF.
fn in_options(e: Error, src: &str, path: &Path) -> Error {
    match e {
        Error::InvalidValue {
            field,
            value,
            reason,
            ..
        } if field.starts_with("urdf.") || field == "gravity" => {
            let field = if field == "gravity" {
                "urdf.gravity".to_string()
            } else {
                field
            };
            Error::invalid(
                src,
                field,
                value,
                format!("{reason} (in {})", path.display()),
            )
        }
        e => e,
    }
}

/// Load a robot from a parameters file: a URDF file (extension `.urdf`, read with `urdf`, which
/// it needs) or a brachia TOML file (which takes no `urdf` options). `src` names the file that
/// gave the options (a scenario) in messages.
pub fn load_robot(path: &Path, urdf: Option<&UrdfOptions>, src: &str) -> Result<crate::Robot> {
    let is_urdf = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("urdf"));
    match (is_urdf, urdf) {
        (true, Some(o)) => {
            let imp = import_urdf_file(path, o).map_err(|e| in_options(e, src, path))?;
            crate::Robot::from_params(imp.params, &path.display().to_string())
                .map_err(|e| in_options(e, src, path))
        }
        (true, None) => Err(Error::invalid(
            src,
            "urdf",
            "none",
            format!(
                "the robot {} is a URDF file: name its grip joint and tip in a [urdf] table \
                 (grip = \"JOINT\", tip = \"LINK\" or \"LINK:x,y,z\")",
                path.display()
            ),
        )),
        (false, Some(_)) => Err(Error::invalid(
            src,
            "urdf",
            "a [urdf] table",
            format!(
                "only a URDF robot (a .urdf file) takes a [urdf] table; {} is not one",
                path.display()
            ),
        )),
        (false, None) => crate::Robot::from_toml_file(path),
    }
}
