//! Where the camera is and which way it looks.
//!
//! Two body conventions, both from ROS REP 103 / REP 105:
//!
//! * the **optical** frame (the one [`CameraPose`] stores): +z forward along the optical axis,
//!   +x to the right of the image, +y down the image. Pixels come from it through
//!   [`super::Intrinsics::project`]; `sensor_msgs/CameraInfo` refers to it.
//! * the **camera link** (body) frame: +x forward, +y left, +z up — what a robot's `camera_link`
//!   uses. [`CameraPose::world_from_camera_link`] gives it for consumers that want it;
//!   `world_from_camera_link = world_from_optical · optical_from_camera_link`.
//!
//! [`look_at`] never rolls the camera: the image's x axis stays horizontal, so world up is image
//! up.

use nalgebra::{Isometry3, Matrix3, Point3, Rotation3, Translation3, UnitQuaternion, Vector3};

use super::Intrinsics;

/// Below this norm of `forward × up` the camera looks (almost) straight up or down and the
/// horizon gives no image x axis; [`look_at`] then uses its fallback.
const VERTICAL_EPS: f64 = 1e-9;

/// The camera's pose in the world: its centre of projection and its optical frame.
///
/// For ROS: a `geometry_msgs/PoseStamped` with `header.frame_id = "world"`, `position =
/// position_m` and `orientation = world_from_optical` (the quaternion that rotates optical-frame
/// vectors into the world, i.e. the optical frame's orientation), and a TF
/// `world → `[`super::CAMERA_FRAME`] with the same translation and rotation.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CameraPose {
    /// Centre of projection, metres, autoact world frame.
    pub position_m: Point3<f64>,
    /// Rotation taking vectors in the optical frame (z forward, x right, y down) to the world.
    pub world_from_optical: UnitQuaternion<f64>,
}

impl CameraPose {
    /// A camera at `position_m` looking at `target_m`, unrolled (see [`look_at`]).
    #[must_use]
    pub fn looking_at(position_m: Point3<f64>, target_m: Point3<f64>) -> CameraPose {
        CameraPose {
            position_m,
            world_from_optical: look_at(&position_m, &target_m),
        }
    }

    /// The rigid transform `world_from_optical` (rotation and translation).
    #[must_use]
    pub fn isometry_world_from_optical(&self) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(self.position_m.coords),
            self.world_from_optical,
        )
    }

    /// The orientation of the ROS body frame (x forward, y left, z up) at the same position.
    #[must_use]
    pub fn world_from_camera_link(&self) -> UnitQuaternion<f64> {
        self.world_from_optical * optical_from_camera_link()
    }

    /// A world point expressed in the optical frame, metres.
    #[must_use]
    pub fn point_in_optical(&self, point_in_world: &Point3<f64>) -> Vector3<f64> {
        self.world_from_optical
            .inverse_transform_vector(&(point_in_world - self.position_m))
    }

    /// Projects a world point to continuous pixel coordinates (see [`Intrinsics::project`]);
    /// `None` behind the camera.
    #[must_use]
    pub fn project(
        &self,
        intrinsics: &Intrinsics,
        point_in_world: &Point3<f64>,
    ) -> Option<[f64; 2]> {
        intrinsics.project(self.point_in_optical(point_in_world))
    }
}

/// The rotation `optical_from_camera_link`: the body frame's forward (+x) is optical +z, its left
/// (+y) is optical −x, its up (+z) is optical −y.
#[must_use]
pub fn optical_from_camera_link() -> UnitQuaternion<f64> {
    let m = Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
}

/// The `world_from_optical` rotation of a camera at `position` looking at `target`.
///
/// The optical +z points at the target; the image x axis is `forward × world up` (horizontal:
/// no roll), so world up projects upwards in the image.
///
/// **Fallbacks.** Looking straight down or up (the forward direction within 1e-9 of vertical),
/// the horizon is undefined; the image's x axis is then world +X (the character's right at rest)
/// made perpendicular to the forward direction, so looking down the image's top is world +Y.
/// A camera *at* its target (no direction at all) looks horizontally along world +Y.
#[must_use]
pub fn look_at(position: &Point3<f64>, target: &Point3<f64>) -> UnitQuaternion<f64> {
    let forward = crate::skeleton::geom::direction(target - position)
        .map_or_else(Vector3::y, nalgebra::Unit::into_inner);
    let across = forward.cross(&Vector3::z());
    let norm = across.norm();
    let right = if norm > VERTICAL_EPS {
        across / norm
    } else {
        (Vector3::x() - forward * forward.x).normalize()
    };
    let down = forward.cross(&right);
    let m = Matrix3::from_columns(&[right, down, forward]);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use proptest::prelude::*;

    fn hd() -> Intrinsics {
        Intrinsics::from_horizontal_fov(1280, 720, 60.0).unwrap()
    }

    #[test]
    fn target_projects_to_the_centre_and_up_is_up() {
        let cam = CameraPose::looking_at(Point3::new(3.0, -2.0, 1.6), Point3::new(0.2, 0.5, 1.0));
        let c = hd();
        let [x, y] = cam.project(&c, &Point3::new(0.2, 0.5, 1.0)).unwrap();
        assert_relative_eq!(x, c.cx_px, epsilon = 1e-9);
        assert_relative_eq!(y, c.cy_px, epsilon = 1e-9);
        let [xa, ya] = cam.project(&c, &Point3::new(0.2, 0.5, 1.5)).unwrap();
        assert_relative_eq!(xa, c.cx_px, epsilon = 1e-9);
        assert!(
            ya < c.cy_px,
            "a point above the target must be above the centre: {ya}"
        );
    }

    #[test]
    fn looking_along_plus_y_has_image_right_on_plus_x() {
        let q = look_at(&Point3::new(0.0, -3.0, 1.0), &Point3::new(0.0, 0.0, 1.0));
        assert_relative_eq!(q * Vector3::z(), Vector3::y(), epsilon = 1e-12);
        assert_relative_eq!(q * Vector3::x(), Vector3::x(), epsilon = 1e-12);
        assert_relative_eq!(q * Vector3::y(), -Vector3::z(), epsilon = 1e-12);
    }

    #[test]
    fn straight_down_and_up_use_the_documented_fallback() {
        for (target_z, forward) in [(0.0, -Vector3::z()), (5.0, Vector3::z())] {
            let q = look_at(
                &Point3::new(1.0, 2.0, 3.0),
                &Point3::new(1.0, 2.0, target_z),
            );
            assert!(q.coords.iter().all(|v| v.is_finite()));
            assert_relative_eq!(q.coords.norm(), 1.0, epsilon = 1e-12);
            assert_relative_eq!(q * Vector3::z(), forward, epsilon = 1e-12);
            assert_relative_eq!(q * Vector3::x(), Vector3::x(), epsilon = 1e-12);
        }
        // Looking down, the top of the image (−y optical) is world +Y.
        let q = look_at(&Point3::new(0.0, 0.0, 3.0), &Point3::origin());
        assert_relative_eq!(q * -Vector3::y(), Vector3::y(), epsilon = 1e-12);
        // Almost straight down still gives a proper, finite rotation.
        let q = look_at(&Point3::new(1e-12, 0.0, 3.0), &Point3::origin());
        assert_relative_eq!(
            q.to_rotation_matrix().matrix().determinant(),
            1.0,
            epsilon = 1e-9
        );
        assert_relative_eq!(q * Vector3::z(), -Vector3::z(), epsilon = 1e-9);
    }

    #[test]
    fn camera_at_its_target_looks_along_plus_y() {
        let p = Point3::new(1.0, 1.0, 1.0);
        let q = look_at(&p, &p);
        assert_relative_eq!(q * Vector3::z(), Vector3::y(), epsilon = 1e-12);
    }

    #[test]
    fn camera_link_is_x_forward_y_left_z_up() {
        let cam = CameraPose::looking_at(Point3::new(0.0, -3.0, 1.0), Point3::new(0.0, 0.0, 1.0));
        let link = cam.world_from_camera_link();
        assert_relative_eq!(link * Vector3::x(), Vector3::y(), epsilon = 1e-12);
        assert_relative_eq!(link * Vector3::y(), -Vector3::x(), epsilon = 1e-12);
        assert_relative_eq!(link * Vector3::z(), Vector3::z(), epsilon = 1e-12);
        // The ROS static transform camera_link → optical is (x, y, z, w) = (−½, ½, −½, ½).
        let q = optical_from_camera_link().inverse();
        let c = q.coords;
        let expected = nalgebra::Vector4::new(-0.5, 0.5, -0.5, 0.5);
        assert!(
            (c - expected).norm() < 1e-12 || (c + expected).norm() < 1e-12,
            "{c:?}"
        );
    }

    #[test]
    fn isometry_maps_optical_points_to_world() {
        let cam = CameraPose::looking_at(Point3::new(2.0, 1.0, 1.5), Point3::new(0.0, 0.0, 1.0));
        let p = Point3::new(0.3, -0.4, 2.0);
        let back = cam.isometry_world_from_optical() * Point3::from(cam.point_in_optical(&p));
        assert_relative_eq!(back, p, epsilon = 1e-12);
    }

    proptest! {
        /// For any camera not looking vertically: the target projects to the principal point,
        /// the image x axis is horizontal (no roll), and a point straight above the target
        /// projects above the centre.
        #[test]
        fn look_at_is_unrolled_and_centred(
            px in -10.0..10.0f64, py in -10.0..10.0f64, pz in 0.0..5.0f64,
            tx in -10.0..10.0f64, ty in -10.0..10.0f64, tz in 0.0..3.0f64,
        ) {
            let position = Point3::new(px, py, pz);
            let target = Point3::new(tx, ty, tz);
            prop_assume!(((target - position).xy()).norm() > 0.05);
            let cam = CameraPose::looking_at(position, target);
            let c = hd();
            let [x, y] = cam.project(&c, &target).unwrap();
            prop_assert!((x - c.cx_px).abs() < 1e-6 && (y - c.cy_px).abs() < 1e-6);
            prop_assert!((cam.world_from_optical * Vector3::x()).z.abs() < 1e-12);
            let above = cam.point_in_optical(&(target + Vector3::new(0.0, 0.0, 0.01)));
            prop_assert!(above.y < 0.0, "above the target must be up (−y) in the image");
        }
    }
}
