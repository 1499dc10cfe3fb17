//! Export of a brachia robot as URDF (through `urdf-rs`) and as MuJoCo MJCF.
//!
//! The exported world: the bar at the origin, the chain in the vertical x-z plane (brachia's x is
//! the world's x, brachia's y the world's z, gravity along -z), every joint turning about -y (about
//! +y when the joint is reversed), so that a joint's angle in the file is the robot's own joint
//! angle `phi = s (q - joint_offset)`. Link i's frame is brachia's link frame (x along the link, z
//! across it); the joint offsets are rotations of the joints' `<origin>`s.

use crate::error::{Error, Result};
use crate::Robot;
use std::fmt::Write as _;

/// The joint names of the export: `grip`, `joint_2`, ..., `joint_n`.
fn joint_name(k: usize) -> String {
    if k == 0 {
        "grip".into()
    } else {
        format!("joint_{}", k + 1)
    }
}

/// The position range of joint `k` in the file's joint angle, if the robot has one.
fn phi_range(robot: &Robot, k: usize) -> Option<[f64; 2]> {
    let l = &robot.params().links[k];
    let (lo, hi) = (l.q_min?, l.q_max?);
    let s = if l.joint_reversed { -1.0 } else { 1.0 };
    let (a, b) = (s * (lo - l.joint_offset), s * (hi - l.joint_offset));
    Some([a.min(b), a.max(b)])
}

fn pose(xyz: [f64; 3], rpy: [f64; 3]) -> urdf_rs::Pose {
    urdf_rs::Pose {
        xyz: urdf_rs::Vec3(xyz),
        rpy: urdf_rs::Vec3(rpy),
    }
}

fn name_of(robot: &Robot) -> String {
    if robot.params().name.is_empty() {
        "brachia".into()
    } else {
        robot.params().name.clone()
    }
}

/// The robot as a URDF document (see the module docs). URDF cannot express gravity (the file's
/// world has -z; the magnitude is the reader's), asymmetric torque limits (the effort is the larger
/// magnitude) or a position limit on one side only (such a joint is written continuous).
pub fn to_urdf(robot: &Robot) -> Result<String> {
    let n = robot.n();
    let p = robot.params();
    let massless = urdf_rs::Link {
        name: "bar".into(),
        inertial: Default::default(),
        visual: vec![],
        collision: vec![],
    };
    let mut links = vec![massless];
    let mut joints = vec![];
    for k in 0..n {
        let l = &p.links[k];
        links.push(urdf_rs::Link {
            name: format!("link_{}", k + 1),
            inertial: urdf_rs::Inertial {
                origin: pose([l.com, 0.0, l.com_across], [0.0; 3]),
                mass: urdf_rs::Mass { value: l.mass },
                // the planar inertia about the joints' axis (y); the other two only make the
                // tensor physical
                inertia: urdf_rs::Inertia {
                    ixx: l.inertia,
                    iyy: l.inertia,
                    izz: l.inertia,
                    ..Default::default()
                },
            },
            visual: vec![],
            collision: vec![],
        });
        let parent = if k == 0 {
            "bar".to_string()
        } else {
            format!("link_{k}")
        };
        let x = if k == 0 { 0.0 } else { p.links[k - 1].length };
        let range = phi_range(robot, k);
        let effort = if k == 0 {
            0.0
        } else {
            robot.tau_min()[k - 1]
                .abs()
                .max(robot.tau_max()[k - 1].abs())
        };
        let s = if l.joint_reversed { -1.0 } else { 1.0 };
        joints.push(urdf_rs::Joint {
            name: joint_name(k),
            joint_type: if range.is_some() {
                urdf_rs::JointType::Revolute
            } else {
                urdf_rs::JointType::Continuous
            },
            // a rotation by the offset about -y is one by -offset about y (the pitch)
            origin: pose([x, 0.0, 0.0], [0.0, -l.joint_offset, 0.0]),
            parent: urdf_rs::LinkName { link: parent },
            child: urdf_rs::LinkName {
                link: format!("link_{}", k + 1),
            },
            axis: urdf_rs::Axis {
                xyz: urdf_rs::Vec3([0.0, -s, 0.0]),
            },
            limit: urdf_rs::JointLimit {
                lower: range.map_or(0.0, |r| r[0]),
                upper: range.map_or(0.0, |r| r[1]),
                effort,
                velocity: l.qd_max.unwrap_or(0.0),
                ..Default::default()
            },
            calibration: None,
            dynamics: None,
            mimic: None,
            safety_controller: None,
        });
    }
    let [ex, ey] = robot.end_effector();
    links.push(urdf_rs::Link {
        name: "tip".into(),
        inertial: Default::default(),
        visual: vec![],
        collision: vec![],
    });
    joints.push(urdf_rs::Joint {
        name: "tip".into(),
        joint_type: urdf_rs::JointType::Fixed,
        origin: pose([ex, 0.0, ey], [0.0; 3]),
        parent: urdf_rs::LinkName {
            link: format!("link_{n}"),
        },
        child: urdf_rs::LinkName { link: "tip".into() },
        axis: Default::default(),
        limit: Default::default(),
        calibration: None,
        dynamics: None,
        mimic: None,
        safety_controller: None,
    });
    let doc = urdf_rs::Robot {
        name: name_of(robot),
        version: None,
        links,
        joints,
        materials: vec![],
    };
    let body = urdf_rs::write_to_string(&doc).map_err(|e| Error::Parse {
        path: "<urdf export>".into(),
        message: e.to_string(),
    })?;
    let mut out = String::from("<?xml version=\"1.0\"?>\n");
    out.push_str(&format!(
        "<!-- brachia robot \"{}\": grip joint \"grip\", tip link \"tip\"; gravity {} m/s^2 \
         along -z; joints 2..n actuated -->\n",
        xml_escape(&name_of(robot)),
        robot.gravity()
    ));
    out.push_str(&body);
    out.push('\n');
    Ok(out)
}

fn xml_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace("--", "- -")
}

/// The robot as a MuJoCo MJCF document (see the module docs): hinge joints, explicit inertials,
/// capsules without contacts for display, motors on joints 2..n with the torque limits as control
/// ranges (asymmetric limits included), gravity in `<option>`, RK4 at 1 ms. MJCF has no velocity
/// limit for a joint: `qd_max` is not written.
pub fn to_mjcf(robot: &Robot) -> String {
    let n = robot.n();
    let p = robot.params();
    let mut s = String::new();
    let name = xml_escape(&name_of(robot));
    let _ = writeln!(s, "<mujoco model=\"{name}\">");
    let _ = writeln!(s, "  <compiler angle=\"radian\" autolimits=\"true\"/>");
    let _ = writeln!(
        s,
        "  <option gravity=\"0 0 {}\" integrator=\"RK4\" timestep=\"0.001\"/>",
        -robot.gravity()
    );
    let _ = writeln!(s, "  <worldbody>");
    let _ = writeln!(s, "    <site name=\"bar\" pos=\"0 0 0\" size=\"0.01\"/>");
    for k in 0..n {
        let l = &p.links[k];
        let ind = "  ".repeat(k + 2);
        let x = if k == 0 { 0.0 } else { p.links[k - 1].length };
        let _ = writeln!(
            s,
            "{ind}<body name=\"link_{}\" pos=\"{x:?} 0 0\" axisangle=\"0 -1 0 {:?}\">",
            k + 1,
            l.joint_offset
        );
        let sgn = if l.joint_reversed { -1.0 } else { 1.0 };
        let range = phi_range(robot, k)
            .map(|r| format!(" range=\"{:?} {:?}\"", r[0], r[1]))
            .unwrap_or_default();
        let _ = writeln!(
            s,
            "{ind}  <joint name=\"{}\" type=\"hinge\" axis=\"0 {:?} 0\" damping=\"0\" armature=\"0\"{range}/>",
            joint_name(k),
            -sgn
        );
        let _ = writeln!(
            s,
            "{ind}  <inertial pos=\"{:?} 0 {:?}\" mass=\"{:?}\" diaginertia=\"{:?} {:?} {:?}\"/>",
            l.com, l.com_across, l.mass, l.inertia, l.inertia, l.inertia
        );
        if l.length > 0.0 {
            let _ = writeln!(
                s,
                "{ind}  <geom type=\"capsule\" fromto=\"0 0 0 {:?} 0 0\" size=\"{:?}\" contype=\"0\" conaffinity=\"0\" mass=\"0\"/>",
                l.length, l.radius
            );
        } else {
            let _ = writeln!(
                s,
                "{ind}  <geom type=\"sphere\" size=\"{:?}\" contype=\"0\" conaffinity=\"0\" mass=\"0\"/>",
                l.radius
            );
        }
    }
    let [ex, ey] = robot.end_effector();
    let _ = writeln!(
        s,
        "{}<site name=\"tip\" pos=\"{ex:?} 0 {ey:?}\" size=\"0.01\"/>",
        "  ".repeat(n + 2)
    );
    for k in (0..n).rev() {
        let _ = writeln!(s, "{}</body>", "  ".repeat(k + 2));
    }
    let _ = writeln!(s, "  </worldbody>");
    let _ = writeln!(s, "  <actuator>");
    for k in 1..n {
        // the motor's torque turns about the file's joint axis: reversed joints take -tau
        let (lo, hi) = if p.links[k].joint_reversed {
            (-robot.tau_max()[k - 1], -robot.tau_min()[k - 1])
        } else {
            (robot.tau_min()[k - 1], robot.tau_max()[k - 1])
        };
        let _ = writeln!(
            s,
            "    <motor name=\"tau_{}\" joint=\"{}\" gear=\"1\" ctrlrange=\"{lo:?} {hi:?}\"/>",
            k + 1,
            joint_name(k),
        );
    }
    let _ = writeln!(s, "  </actuator>");
    let _ = writeln!(s, "</mujoco>");
    s
}
