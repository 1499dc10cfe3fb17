//! Rigid transforms of a URDF tree (rotation and translation), in f64.

use nalgebra::{Matrix3, Rotation3, Vector3};

/// A rigid transform `p -> r p + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Frame {
    pub r: Matrix3<f64>,
    pub t: Vector3<f64>,
}

impl Frame {
    /// The identity.
    pub fn identity() -> Self {
        Frame {
            r: Matrix3::identity(),
            t: Vector3::zeros(),
        }
    }

    /// A URDF `<origin xyz rpy>`: `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub fn from_pose(pose: &urdf_rs::Pose) -> Self {
        let [x, y, z] = pose.xyz.0;
        let [roll, pitch, yaw] = pose.rpy.0;
        Frame {
            r: Rotation3::from_euler_angles(roll, pitch, yaw).into_inner(),
            t: Vector3::new(x, y, z),
        }
    }

    /// `self * other`: first `other`, then `self`.
    pub fn then(&self, other: &Frame) -> Frame {
        Frame {
            r: self.r * other.r,
            t: self.r * other.t + self.t,
        }
    }

    /// A point of this frame in the parent frame.
    pub fn point(&self, p: Vector3<f64>) -> Vector3<f64> {
        self.r * p + self.t
    }
}

/// True when every entry is finite.
pub(crate) fn finite3(v: &[f64; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}
