//! Robots in and out of other formats: import of a planar serial chain from a URDF file, export of
//! any brachia robot as URDF or MuJoCo MJCF.
//!
//! **Import** ([`import_urdf_file`], [`import_urdf_str`]): the user names the grip joint (a revolute
//! or continuous joint at the bar, passive, or a fixed joint where the hand holds the bar: it then
//! turns about the chain's common axis) and the tip (a link and a point in its frame). The chain is
//! the path of joints from the grip joint down the URDF tree to the tip link. Its revolute joints
//! must turn about parallel axes (any common direction; antiparallel axes are reversed joints); the
//! model is the projection onto the plane normal to that axis, with gravity the URDF world's -z
//! projected into the plane (zero when the axis is vertical). Links joined by fixed joints form one
//! body: masses add, centres of mass combine and inertias about the axis compose by the
//! parallel-axis rule. Joint 1 (the grip) is passive and every other chain joint actuated: by the
//! file's `<transmission>` elements where it has any, else by the user's list of passive joints; a
//! passive joint elsewhere is refused. Joints off the chain (branches) are refused by name unless
//! listed to be ignored; fixed ones (a base, the bars) are ignored by default. All refusals are
//! [`crate::Error::InvalidValue`] naming the URDF element.
//!
//! Angles: brachia's `q` and the URDF joint angles `phi` are related by `q_i = s_i phi_i + offset_i`
//! (see [`crate::model::LinkParams::joint_offset`]); [`crate::Robot::q_from_joint_angles`] and
//! [`crate::Robot::q_to_joint_angles`] map them.
//!
//! **Export** ([`to_urdf`], [`to_mjcf`]): the chain in the vertical x-z plane of the exported world,
//! every joint turning about -y (so that brachia's counter-clockwise angles are the file's joint
//! angles), the bar as the world anchor, inertias, limits and actuators on joints 2..n only.

mod export;
mod frames;
mod import;
mod nesting;
mod numbers;
mod traced;

pub use export::{to_mjcf, to_urdf};
pub use import::{import_urdf_file, import_urdf_str, load_robot, Imported, Tip, UrdfOptions};
pub use nesting::MAX_URDF_DEPTH;
pub use traced::imported_toml;
