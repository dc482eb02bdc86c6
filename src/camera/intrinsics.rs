//! A distortion-free pinhole camera, built from a resolution and a horizontal field of view.
//!
//! **Pixel convention.** [`Intrinsics`] and [`Intrinsics::project`] use *continuous* image
//! coordinates: the image covers `[0, width_px] × [0, height_px]`, (0, 0) is the top-left
//! *corner* of the top-left pixel, pixel `(i, j)` covers `[i, i+1) × [j, j+1)` and its centre is
//! `(i + ½, j + ½)`. That is the renderer's convention (OpenGL, Blender), and in it the principal
//! point of a centred lens is exactly `(width/2, height/2)` and the edges of the field of view
//! land on `0` and `width`.
//!
//! ROS `sensor_msgs/CameraInfo` follows OpenCV, where integer coordinates are pixel *centres*
//! (the top-left pixel's centre is (0, 0)). [`Intrinsics::k`] and [`Intrinsics::p`] therefore
//! shift the principal point by −½ pixel: a ROS consumer projecting with `K` gets
//! `project(p) − (½, ½)`, i.e. the same physical point.

use nalgebra::Vector3;

use super::CameraError;

/// Smallest horizontal field of view accepted, degrees (exclusive).
pub const MIN_HFOV_DEG: f64 = 1.0;
/// Largest horizontal field of view accepted, degrees (exclusive).
pub const MAX_HFOV_DEG: f64 = 170.0;

/// The lens model written into `sensor_msgs/CameraInfo.distortion_model`. The camera is an ideal
/// pinhole, so its five coefficients ([`Intrinsics::d`]) are all zero.
pub const DISTORTION_MODEL: &str = "plumb_bob";

/// Below this depth (metres, along the optical axis) a point counts as behind the camera.
const MIN_DEPTH_M: f64 = 1e-9;

/// A pinhole camera: square pixels, principal point at the image centre, no distortion. Pixel
/// values use the continuous convention of the module docs.
///
/// Build it with [`Intrinsics::from_horizontal_fov`]; the fields are public for logging and for
/// the renderer, and are not re-validated.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Intrinsics {
    /// Image width, pixels.
    pub width_px: u32,
    /// Image height, pixels.
    pub height_px: u32,
    /// Horizontal focal length, pixels.
    pub fx_px: f64,
    /// Vertical focal length, pixels (equal to `fx_px`: square pixels).
    pub fy_px: f64,
    /// Principal point x, pixels from the image's left edge (`width_px / 2`).
    pub cx_px: f64,
    /// Principal point y, pixels from the image's top edge (`height_px / 2`).
    pub cy_px: f64,
}

impl Intrinsics {
    /// A camera of `width_px × height_px` pixels whose image spans `horizontal_fov_deg` from its
    /// left edge to its right edge: `fx = fy = (width/2) / tan(hfov/2)`, `c = (width/2, height/2)`.
    ///
    /// # Errors
    /// [`CameraError::Resolution`] for a zero dimension; [`CameraError::FieldOfView`] unless
    /// `MIN_HFOV_DEG < horizontal_fov_deg < MAX_HFOV_DEG`.
    pub fn from_horizontal_fov(
        width_px: u32,
        height_px: u32,
        horizontal_fov_deg: f64,
    ) -> Result<Intrinsics, CameraError> {
        for (field, value) in [("width_px", width_px), ("height_px", height_px)] {
            if value == 0 {
                return Err(CameraError::Resolution { field, value });
            }
        }
        if !(horizontal_fov_deg > MIN_HFOV_DEG && horizontal_fov_deg < MAX_HFOV_DEG) {
            return Err(CameraError::FieldOfView {
                value_deg: horizontal_fov_deg,
            });
        }
        let half_width = 0.5 * f64::from(width_px);
        let f = half_width / (0.5 * horizontal_fov_deg.to_radians()).tan();
        Ok(Intrinsics {
            width_px,
            height_px,
            fx_px: f,
            fy_px: f,
            cx_px: half_width,
            cy_px: 0.5 * f64::from(height_px),
        })
    }

    /// Horizontal field of view, radians: `2·atan((width/2) / fx)`.
    #[must_use]
    pub fn horizontal_fov_rad(&self) -> f64 {
        2.0 * (0.5 * f64::from(self.width_px) / self.fx_px).atan()
    }

    /// Vertical field of view, radians: `2·atan((height/2) / fy)`, i.e.
    /// `2·atan(tan(hfov/2) · height/width)` for square pixels.
    #[must_use]
    pub fn vertical_fov_rad(&self) -> f64 {
        2.0 * (0.5 * f64::from(self.height_px) / self.fy_px).atan()
    }

    /// Half of the narrower field of view (vertical for landscape images), radians: the angle
    /// that limits how large a centred sphere can appear.
    #[must_use]
    pub fn narrow_half_fov_rad(&self) -> f64 {
        0.5 * self.horizontal_fov_rad().min(self.vertical_fov_rad())
    }

    /// Projects a point given in the camera's **optical** frame (z forward, x right, y down,
    /// metres) to continuous pixel coordinates `[x, y]`; `None` when it is not in front of the
    /// camera (depth ≤ 1 nm) or not finite. Points outside the image still project.
    #[must_use]
    pub fn project(&self, point_in_optical: Vector3<f64>) -> Option<[f64; 2]> {
        let p = point_in_optical;
        if !(p.z > MIN_DEPTH_M && p.x.is_finite() && p.y.is_finite()) {
            return None;
        }
        Some([
            self.fx_px * p.x / p.z + self.cx_px,
            self.fy_px * p.y / p.z + self.cy_px,
        ])
    }

    /// Whether continuous pixel coordinates lie inside the image shrunk by `margin_fraction` of
    /// its half-size on each axis: `|x − cx| ≤ (1 − margin)·width/2` and the same for y.
    #[must_use]
    pub fn contains(&self, pixel: [f64; 2], margin_fraction: f64) -> bool {
        let keep = 1.0 - margin_fraction;
        (pixel[0] - self.cx_px).abs() <= keep * 0.5 * f64::from(self.width_px)
            && (pixel[1] - self.cy_px).abs() <= keep * 0.5 * f64::from(self.height_px)
    }

    /// `sensor_msgs/CameraInfo.k`: the 3×3 camera matrix, row-major,
    /// `[fx, 0, cx', 0, fy, cy', 0, 0, 1]`, with the principal point in the ROS/OpenCV pixel
    /// convention (`cx' = cx_px − ½`, see the module docs).
    #[must_use]
    pub fn k(&self) -> [f64; 9] {
        let [cx, cy] = self.ros_principal_point();
        [self.fx_px, 0.0, cx, 0.0, self.fy_px, cy, 0.0, 0.0, 1.0]
    }

    /// `sensor_msgs/CameraInfo.p`: the 3×4 projection matrix, row-major,
    /// `[fx, 0, cx', 0, 0, fy, cy', 0, 0, 0, 1, 0]` (monocular: no baseline, `Tx = Ty = 0`).
    #[must_use]
    pub fn p(&self) -> [f64; 12] {
        let [cx, cy] = self.ros_principal_point();
        [
            self.fx_px, 0.0, cx, 0.0, 0.0, self.fy_px, cy, 0.0, 0.0, 0.0, 1.0, 0.0,
        ]
    }

    /// `sensor_msgs/CameraInfo.r`: the rectification rotation, identity for a monocular camera.
    #[must_use]
    pub fn r(&self) -> [f64; 9] {
        [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
    }

    /// `sensor_msgs/CameraInfo.d`: the five [`DISTORTION_MODEL`] coefficients
    /// `(k1, k2, t1, t2, k3)`, all zero.
    #[must_use]
    pub fn d(&self) -> [f64; 5] {
        [0.0; 5]
    }

    /// The principal point in the ROS/OpenCV convention (integer coordinates = pixel centres).
    fn ros_principal_point(&self) -> [f64; 2] {
        [self.cx_px - 0.5, self.cy_px - 0.5]
    }

    /// The inverse of [`Intrinsics::k`]: a camera from `sensor_msgs/CameraInfo`'s size and `k`
    /// (OpenCV pixel convention), `None` unless the focal lengths are positive and finite and
    /// the principal point is finite.
    #[must_use]
    pub fn from_ros(width_px: u32, height_px: u32, k: &[f64; 9]) -> Option<Intrinsics> {
        let ok = |v: f64| v.is_finite();
        let (fx, fy, cx, cy) = (k[0], k[4], k[2], k[5]);
        (ok(fx)
            && ok(fy)
            && fx > 0.0
            && fy > 0.0
            && ok(cx)
            && ok(cy)
            && width_px > 0
            && height_px > 0)
            .then_some(Intrinsics {
                width_px,
                height_px,
                fx_px: fx,
                fy_px: fy,
                cx_px: cx + 0.5,
                cy_px: cy + 0.5,
            })
    }

    /// The same lens on a sensor of `width_px × height_px`: scaled by the width ratio (the
    /// horizontal field of view is kept), the principal point moved with the image centre, so
    /// another aspect ratio shows more or less above and below.
    #[must_use]
    pub fn resized(&self, width_px: u32, height_px: u32) -> Intrinsics {
        let s = f64::from(width_px) / f64::from(self.width_px);
        Intrinsics {
            width_px,
            height_px,
            fx_px: self.fx_px * s,
            fy_px: self.fy_px * s,
            cx_px: self.cx_px * s,
            cy_px: self.cy_px * s + 0.5 * (f64::from(height_px) - s * f64::from(self.height_px)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;

    fn hd() -> Intrinsics {
        Intrinsics::from_horizontal_fov(1280, 720, 60.0).unwrap()
    }

    #[test]
    fn optical_axis_projects_to_the_principal_point_at_the_centre() {
        let c = hd();
        let [x, y] = c.project(Vector3::new(0.0, 0.0, 4.2)).unwrap();
        assert_relative_eq!(x, 640.0, epsilon = 1e-12);
        assert_relative_eq!(y, 360.0, epsilon = 1e-12);
        assert_eq!([x, y], [c.cx_px, c.cy_px]);
    }

    #[test]
    fn points_at_the_edges_of_the_field_of_view_land_on_the_image_edges() {
        let c = hd();
        let half_h = 30f64.to_radians();
        let z = 3.0;
        let [left, _] = c.project(Vector3::new(-z * half_h.tan(), 0.0, z)).unwrap();
        let [right, _] = c.project(Vector3::new(z * half_h.tan(), 0.0, z)).unwrap();
        assert_relative_eq!(left, 0.0, epsilon = 1e-9);
        assert_relative_eq!(right, 1280.0, epsilon = 1e-9);
        let half_v = 0.5 * c.vertical_fov_rad();
        let [_, top] = c.project(Vector3::new(0.0, -z * half_v.tan(), z)).unwrap();
        let [_, bottom] = c.project(Vector3::new(0.0, z * half_v.tan(), z)).unwrap();
        assert_relative_eq!(top, 0.0, epsilon = 1e-9);
        assert_relative_eq!(bottom, 720.0, epsilon = 1e-9);
        // +x is right and +y is down in the image.
        let [x, y] = c.project(Vector3::new(0.5, 0.5, 3.0)).unwrap();
        assert!(x > c.cx_px && y > c.cy_px);
    }

    #[test]
    fn field_of_view_round_trips_and_vertical_follows_the_aspect() {
        let c = hd();
        assert_relative_eq!(c.horizontal_fov_rad().to_degrees(), 60.0, epsilon = 1e-12);
        let expected = 2.0 * (30f64.to_radians().tan() * 720.0 / 1280.0).atan();
        assert_relative_eq!(c.vertical_fov_rad(), expected, epsilon = 1e-12);
        assert_relative_eq!(c.narrow_half_fov_rad(), 0.5 * expected, epsilon = 1e-12);
        let portrait = Intrinsics::from_horizontal_fov(720, 1280, 45.0).unwrap();
        assert_relative_eq!(
            portrait.narrow_half_fov_rad().to_degrees(),
            22.5,
            epsilon = 1e-12
        );
    }

    #[test]
    fn behind_and_on_the_camera_plane_do_not_project() {
        let c = hd();
        assert_eq!(c.project(Vector3::new(0.1, 0.1, -1.0)), None);
        assert_eq!(c.project(Vector3::new(0.1, 0.1, 0.0)), None);
        assert_eq!(c.project(Vector3::new(f64::NAN, 0.1, 1.0)), None);
    }

    #[test]
    fn camera_info_matrices_have_the_ros_layout() {
        let c = hd();
        let f = 640.0 / 30f64.to_radians().tan();
        assert_eq!(
            c.k(),
            [f, 0.0, 639.5, 0.0, f, 359.5, 0.0, 0.0, 1.0],
            "row-major, principal point shifted to the pixel-centre convention"
        );
        assert_eq!(
            c.p(),
            [f, 0.0, 639.5, 0.0, 0.0, f, 359.5, 0.0, 0.0, 0.0, 1.0, 0.0]
        );
        assert_eq!(c.r(), [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]);
        assert_eq!(c.d(), [0.0; 5]);
        assert_eq!(DISTORTION_MODEL, "plumb_bob");
        // K applied to a point gives project() − ½ px: the same physical point.
        let p = Vector3::new(0.3, -0.2, 2.5);
        let k = c.k();
        let u = (k[0] * p.x + k[1] * p.y + k[2] * p.z) / p.z;
        let v = (k[3] * p.x + k[4] * p.y + k[5] * p.z) / p.z;
        let [x, y] = c.project(p).unwrap();
        assert_relative_eq!(u, x - 0.5, epsilon = 1e-9);
        assert_relative_eq!(v, y - 0.5, epsilon = 1e-9);
    }

    #[test]
    fn margin_shrinks_the_accepted_area_on_both_axes() {
        let c = hd();
        assert!(c.contains([0.0, 0.0], 0.0));
        assert!(!c.contains([0.0, 360.0], 0.1));
        assert!(c.contains([64.5, 36.5], 0.1));
        assert!(!c.contains([63.9, 360.0], 0.1));
        assert!(!c.contains([640.0, 35.9], 0.1));
    }

    #[test]
    fn bad_intrinsics_name_the_bad_value() {
        let e = Intrinsics::from_horizontal_fov(0, 720, 60.0).unwrap_err();
        assert!(e.to_string().contains("width_px is 0"), "{e}");
        let e = Intrinsics::from_horizontal_fov(1280, 0, 60.0).unwrap_err();
        assert!(e.to_string().contains("height_px is 0"), "{e}");
        for bad in [1.0, 170.0, 0.5, 179.0, f64::NAN, -60.0] {
            let e = Intrinsics::from_horizontal_fov(1280, 720, bad).unwrap_err();
            assert!(matches!(e, CameraError::FieldOfView { .. }), "{bad}");
            assert!(e.to_string().contains(&format!("{bad}°")), "{e}");
        }
        assert!(Intrinsics::from_horizontal_fov(1, 1, 1.001).is_ok());
        assert!(Intrinsics::from_horizontal_fov(1, 1, 169.999).is_ok());
    }
}
