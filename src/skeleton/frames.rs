//! autoact's one coordinate convention, and the only place where other conventions are converted
//! into it.
//!
//! **The autoact frame** (used by every type in this crate unless its name says otherwise):
//! right-handed, metres, **+Z up**, and a character at rest stands on the ground plane `z = 0`
//! facing **+Y**, so **+X is the character's right**. Angles are radians inside the crate.
//!
//! Source data arrives in other conventions (BVH and Kinect are Y-up, camera-space pose
//! estimators are Y-down). Readers state which [`SourceAxes`] their format uses and call
//! [`SourceAxes::to_autoact`] exactly once per point; nothing else in the crate swaps axes.
//! Every conversion here is a proper rotation (determinant +1), so a left arm stays a left arm:
//! the reference implementation's NTU path mirrored the body with an axis swap of determinant −1.

use nalgebra::{Matrix3, Point3, Rotation3, UnitQuaternion, Vector3};

/// The axis convention of a data source, converted to the autoact frame by a proper rotation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SourceAxes {
    /// Already the autoact frame: +Z up.
    ZUp,
    /// +Y up, right-handed, subject facing +Z (BVH, Kinect camera space, ZED, OpenGL):
    /// (x, y, z) → (−x, z, y), a half turn about the vertical after the tilt, so that a body
    /// facing +Z with its right hand at −X lands facing +Y with its right hand at +X.
    YUp,
    /// +Y down, right-handed camera frame (OpenCV, Human3.6M camera space): (x, y, z) → (x, z, −y).
    YDown,
}

impl SourceAxes {
    /// Its name, as `--axes` and serde write it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            SourceAxes::ZUp => "z-up",
            SourceAxes::YUp => "y-up",
            SourceAxes::YDown => "y-down",
        }
    }

    /// The rotation `autoact_from_source`.
    #[must_use]
    pub fn autoact_from_source(self) -> Rotation3<f64> {
        let m = match self {
            SourceAxes::ZUp => Matrix3::identity(),
            SourceAxes::YUp => Matrix3::new(-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0),
            SourceAxes::YDown => Matrix3::new(1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0),
        };
        Rotation3::from_matrix_unchecked(m)
    }

    /// A vector or point given in this source convention, expressed in the autoact frame.
    #[must_use]
    pub fn to_autoact(self, v: Vector3<f64>) -> Vector3<f64> {
        self.autoact_from_source() * v
    }

    /// A point given in this source convention, expressed in the autoact frame.
    #[must_use]
    pub fn point_to_autoact(self, p: Point3<f64>) -> Point3<f64> {
        Point3::from(self.to_autoact(p.coords))
    }

    /// An orientation `source_from_x`, re-expressed as `autoact_from_x'` where x' is the same
    /// body frame with its axes mapped the same way (a change of basis, `R · q · R⁻¹`).
    #[must_use]
    pub fn orientation_to_autoact(self, q: UnitQuaternion<f64>) -> UnitQuaternion<f64> {
        let r = UnitQuaternion::from_rotation_matrix(&self.autoact_from_source());
        r * q * r.inverse()
    }
}

/// Name of the world frame in ROS messages (`header.frame_id`, the TF root).
pub const WORLD_FRAME: &str = "world";

/// The world up axis of the autoact frame.
#[must_use]
pub fn up() -> Vector3<f64> {
    Vector3::z()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn conversions_are_proper_rotations() {
        for axes in [SourceAxes::ZUp, SourceAxes::YUp, SourceAxes::YDown] {
            let det = axes.autoact_from_source().matrix().determinant();
            assert!((det - 1.0).abs() < 1e-12, "{axes:?} has determinant {det}");
        }
    }

    #[test]
    fn y_up_facing_plus_z_lands_facing_plus_y() {
        assert_eq!(SourceAxes::YUp.to_autoact(Vector3::z()), Vector3::y());
        assert_eq!(
            SourceAxes::YUp.to_autoact(-Vector3::x()),
            Vector3::x(),
            "the right hand"
        );
    }

    #[test]
    fn source_up_becomes_autoact_up() {
        assert_eq!(SourceAxes::YUp.to_autoact(Vector3::y()), Vector3::z());
        assert_eq!(SourceAxes::YDown.to_autoact(-Vector3::y()), Vector3::z());
        assert_eq!(SourceAxes::ZUp.to_autoact(Vector3::z()), Vector3::z());
    }
}
