//! `geometry_msgs`: points, vectors, quaternions, poses, transforms — and the one conversion
//! between a ROS quaternion (x, y, z, w) and nalgebra's (w first).

use nalgebra::{Point3, UnitQuaternion, Vector3 as NVector3};
use serde::{Deserialize, Serialize};

use super::RosMessage;
use super::std_msgs::Header;

/// `geometry_msgs/msg/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl RosMessage for Point {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Point";
}

impl From<Point3<f64>> for Point {
    fn from(p: Point3<f64>) -> Self {
        Point {
            x: p.x,
            y: p.y,
            z: p.z,
        }
    }
}

impl From<Point> for Point3<f64> {
    fn from(p: Point) -> Self {
        Point3::new(p.x, p.y, p.z)
    }
}

/// `geometry_msgs/msg/Vector3`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Vector3 {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

impl RosMessage for Vector3 {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Vector3";
}

impl From<NVector3<f64>> for Vector3 {
    fn from(v: NVector3<f64>) -> Self {
        Vector3 {
            x: v.x,
            y: v.y,
            z: v.z,
        }
    }
}

impl From<Vector3> for NVector3<f64> {
    fn from(v: Vector3) -> Self {
        NVector3::new(v.x, v.y, v.z)
    }
}

/// `geometry_msgs/msg/Quaternion`, stored x, y, z, w.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

impl Default for Quaternion {
    /// The identity, as the `.msg` default (`float64 w 1`) says.
    fn default() -> Self {
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 1.0,
        }
    }
}

impl RosMessage for Quaternion {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Quaternion";
}

impl From<UnitQuaternion<f64>> for Quaternion {
    fn from(q: UnitQuaternion<f64>) -> Self {
        let q = q.as_ref();
        Quaternion {
            x: q.i,
            y: q.j,
            z: q.k,
            w: q.w,
        }
    }
}

/// A quaternion that is not a rotation.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("quaternion ({x}, {y}, {z}, {w}) is not a rotation (norm {norm})")]
pub struct BadQuaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
    /// Its norm.
    pub norm: f64,
}

impl TryFrom<Quaternion> for UnitQuaternion<f64> {
    type Error = BadQuaternion;

    /// Normalises any finite quaternion of norm ≥ 1e-6; rejects others.
    fn try_from(q: Quaternion) -> Result<Self, Self::Error> {
        let raw = nalgebra::Quaternion::new(q.w, q.x, q.y, q.z);
        let norm = raw.norm();
        if norm.is_finite() && norm >= 1e-6 {
            Ok(UnitQuaternion::from_quaternion(raw))
        } else {
            Err(BadQuaternion {
                x: q.x,
                y: q.y,
                z: q.z,
                w: q.w,
                norm,
            })
        }
    }
}

/// `geometry_msgs/msg/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

impl RosMessage for Pose {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Pose";
}

/// `geometry_msgs/msg/PoseArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseArray {
    /// Header.
    pub header: Header,
    /// Poses.
    pub poses: Vec<Pose>,
}

impl RosMessage for PoseArray {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/PoseArray";
}

/// `geometry_msgs/msg/PoseStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PoseStamped {
    /// Stamp and the frame the pose is in.
    pub header: Header,
    /// The pose.
    pub pose: Pose,
}

impl RosMessage for PoseStamped {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/PoseStamped";
}

/// `geometry_msgs/msg/Transform`: `parent_from_child`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Transform {
    /// Translation of the child frame's origin in the parent frame.
    pub translation: Vector3,
    /// Rotation of the child frame in the parent frame.
    pub rotation: Quaternion,
}

impl RosMessage for Transform {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/Transform";
}

/// `geometry_msgs/msg/TransformStamped`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TransformStamped {
    /// Stamp and parent frame.
    pub header: Header,
    /// Child frame.
    pub child_frame_id: String,
    /// `parent_from_child`.
    pub transform: Transform,
}

impl RosMessage for TransformStamped {
    const TYPE_NAME: &'static str = "geometry_msgs/msg/TransformStamped";
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        /// Law: nalgebra → ROS → nalgebra is the identity rotation-wise.
        #[test]
        fn quaternion_round_trip(x in -3.0..3.0f64, y in -3.0..3.0f64, z in -3.0..3.0f64) {
            let q = UnitQuaternion::from_scaled_axis(NVector3::new(x, y, z));
            let back = UnitQuaternion::try_from(Quaternion::from(q)).unwrap();
            prop_assert!(crate::skeleton::geom::rotation_distance(&q, &back) < 1e-12);
        }
    }

    #[test]
    fn ros_order_is_xyzw_and_bad_quaternions_are_rejected() {
        let q = Quaternion::from(UnitQuaternion::from_axis_angle(
            &NVector3::z_axis(),
            std::f64::consts::PI,
        ));
        assert!((q.z.abs() - 1.0).abs() < 1e-12 && q.w.abs() < 1e-12);
        assert!(
            UnitQuaternion::try_from(Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 0.0
            })
            .is_err()
        );
        assert!(
            UnitQuaternion::try_from(Quaternion {
                x: f64::NAN,
                y: 0.0,
                z: 0.0,
                w: 1.0
            })
            .is_err()
        );
        let scaled = UnitQuaternion::try_from(Quaternion {
            x: 0.0,
            y: 0.0,
            z: 0.0,
            w: 2.0,
        })
        .unwrap();
        assert!(scaled.angle() < 1e-12);
    }
}
