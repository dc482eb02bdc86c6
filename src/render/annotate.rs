//! Labels for free: the character's joints and landmarks projected with the frame's camera, their
//! visibility against the rendered depth, and the character's bounding box from its rendered
//! silhouette.
//!
//! # Visibility (COCO's `v`)
//! - [`OUT_OF_VIEW`] (0): the point projects outside the image, or lies behind the camera.
//! - [`OCCLUDED`] (1): in the image, but hidden. A joint (a bone head, inside the body) is hidden
//!   when scenery (not the character) is nearer than it by more than [`OCCLUSION_MARGIN_M`]; the
//!   body's own surface in front of a joint does not hide it. A surface point (the face
//!   landmarks: nose, eyes, ears, see [`SURFACE_LANDMARKS`]) is hidden by anything nearer than it
//!   by more than [`SURFACE_MARGIN_M`], the character's own head included: the far ear in a
//!   profile view, or the face of a character seen from behind, is 1.
//! - [`VISIBLE`] (2): otherwise.

use nalgebra::{Isometry3, Point3};

use super::world::Surface;
use super::{Camera, Image};
use crate::ros::geometry_msgs::Point;
use crate::ros::sensor_msgs::RegionOfInterest;
use crate::skeleton::fk::WorldPose;

/// COCO visibility: outside the image or behind the camera.
pub const OUT_OF_VIEW: u8 = 0;
/// COCO visibility: in the image, hidden behind scenery.
pub const OCCLUDED: u8 = 1;
/// COCO visibility: visible.
pub const VISIBLE: u8 = 2;

/// Scenery nearer than a joint by more than this hides it, metres (the body's own surface lies
/// at most about this far in front of a joint).
pub const OCCLUSION_MARGIN_M: f64 = 0.25;

/// Something nearer than a surface landmark by more than this hides it, metres (the rendered
/// mesh is flat between its vertices, so a point on the skin may lie a little behind it).
pub const SURFACE_MARGIN_M: f64 = 0.04;

/// Landmarks on the body's surface (the face), whose own body can hide them.
pub const SURFACE_LANDMARKS: [&str; 5] = ["nose", "l_eye", "r_eye", "l_ear", "r_ear"];

/// One frame's labels.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Annotation {
    /// Joints in the optical frame, metres.
    pub keypoints_3d: Vec<Point>,
    /// Continuous pixel coordinates `[x, y]` (pixel `(i, j)` covers `[i, i+1) × [j, j+1)`),
    /// NaN where the joint is behind the camera.
    pub keypoints_2d: Vec<[f64; 2]>,
    /// [`OUT_OF_VIEW`], [`OCCLUDED`] or [`VISIBLE`] per joint.
    pub visibility: Vec<u8>,
    /// Bounding box of the silhouette `[x0, y0, x1, y1]` in whole pixels (x1, y1 exclusive),
    /// `None` when no pixel shows the character.
    pub bbox: Option<[u32; 4]>,
    /// Pixels showing the character.
    pub silhouette_pixels: u32,
    /// The rig's landmarks (in [`crate::skeleton::rig::Rig::landmarks`] order) in the optical
    /// frame, metres.
    pub landmarks_3d: Vec<Point>,
    /// Their continuous pixel coordinates, as [`Annotation::keypoints_2d`].
    pub landmarks_2d: Vec<[f64; 2]>,
    /// Their visibility, as [`Annotation::visibility`] (surface landmarks by the surface rule).
    pub landmark_visibility: Vec<u8>,
}

impl Annotation {
    /// The bounding box as `sensor_msgs/RegionOfInterest` (zero size when not in view).
    #[must_use]
    pub fn roi(&self) -> RegionOfInterest {
        self.bbox
            .map_or_else(RegionOfInterest::default, |[x0, y0, x1, y1]| {
                RegionOfInterest {
                    x_offset: x0,
                    y_offset: y0,
                    width: x1 - x0,
                    height: y1 - y0,
                    do_rectify: false,
                }
            })
    }

    /// Keypoints in the ROS/OpenCV pixel convention (the top-left pixel's centre is (0, 0)),
    /// interleaved x, y.
    #[must_use]
    pub fn keypoints_2d_ros(&self) -> Vec<f32> {
        to_ros_pixels(&self.keypoints_2d)
    }

    /// The landmarks' pixel coordinates as [`Annotation::keypoints_2d_ros`].
    #[must_use]
    pub fn landmarks_2d_ros(&self) -> Vec<f32> {
        to_ros_pixels(&self.landmarks_2d)
    }
}

/// Continuous pixel coordinates in the ROS/OpenCV convention, interleaved x, y.
fn to_ros_pixels(points: &[[f64; 2]]) -> Vec<f32> {
    points
        .iter()
        .flat_map(|p| [(p[0] - 0.5) as f32, (p[1] - 0.5) as f32])
        .collect()
}

/// One labelled point: optical-frame position, pixel and visibility.
struct Labelled {
    optical: Point,
    pixel: [f64; 2],
    visibility: u8,
}

/// Projects the world point `p` with `camera` and decides its visibility in `image`;
/// `surface`: the point is on the body's surface, which may hide it (see the module docs).
fn label_point(
    p: &Point3<f64>,
    optical_from_world: &Isometry3<f64>,
    camera: &Camera,
    image: &Image,
    surface: bool,
) -> Labelled {
    let q = optical_from_world * p;
    let optical = Point {
        x: q.x,
        y: q.y,
        z: q.z,
    };
    let (w, h) = (image.width as usize, image.height as usize);
    let Some(px) = camera.intrinsics.project(q.coords) else {
        return Labelled {
            optical,
            pixel: [f64::NAN; 2],
            visibility: OUT_OF_VIEW,
        };
    };
    let inside = px[0] >= 0.0 && px[1] >= 0.0 && px[0] < w as f64 && px[1] < h as f64;
    if !inside {
        return Labelled {
            optical,
            pixel: px,
            visibility: OUT_OF_VIEW,
        };
    }
    let i = px[1] as usize * w + px[0] as usize;
    let shown = image.surface[i];
    let surface_depth_m = if image.depth[i] > 0.0 {
        1.0 / f64::from(image.depth[i])
    } else {
        f64::INFINITY
    };
    let hidden = if surface {
        surface_depth_m < q.z - SURFACE_MARGIN_M
    } else {
        shown != Surface::Character as u8 && surface_depth_m < q.z - OCCLUSION_MARGIN_M
    };
    Labelled {
        optical,
        pixel: px,
        visibility: if hidden { OCCLUDED } else { VISIBLE },
    }
}

/// Labels the joints of `pose` and the landmarks `landmarks_m` (world positions; `surface[i]`
/// when landmark `i` is on the body's surface) in `image`, rendered with `camera`.
#[must_use]
pub fn annotate(
    pose: &WorldPose,
    landmarks_m: &[Point3<f64>],
    surface: &[bool],
    camera: &Camera,
    image: &Image,
) -> Annotation {
    let optical_from_world = camera.world_from_optical.inverse();
    let w = image.width as usize;
    let mut out = Annotation::default();
    for head in &pose.heads_m {
        let l = label_point(head, &optical_from_world, camera, image, false);
        out.keypoints_3d.push(l.optical);
        out.keypoints_2d.push(l.pixel);
        out.visibility.push(l.visibility);
    }
    for (k, p) in landmarks_m.iter().enumerate() {
        let on_surface = surface.get(k).copied().unwrap_or(false);
        let l = label_point(p, &optical_from_world, camera, image, on_surface);
        out.landmarks_3d.push(l.optical);
        out.landmarks_2d.push(l.pixel);
        out.landmark_visibility.push(l.visibility);
    }
    let mut bbox = [u32::MAX, u32::MAX, 0, 0];
    for (i, &s) in image.surface.iter().enumerate() {
        if s == Surface::Character as u8 {
            let (x, y) = ((i % w) as u32, (i / w) as u32);
            bbox[0] = bbox[0].min(x);
            bbox[1] = bbox[1].min(y);
            bbox[2] = bbox[2].max(x + 1);
            bbox[3] = bbox[3].max(y + 1);
            out.silhouette_pixels += 1;
        }
    }
    out.bbox = (out.silhouette_pixels > 0).then_some(bbox);
    out
}
