//! Labels for free: the character's joints projected with the frame's camera, their visibility
//! against the rendered depth, and the character's bounding box from its rendered silhouette.

use nalgebra::Point3;

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
const OCCLUSION_MARGIN_M: f64 = 0.25;

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
        self.keypoints_2d
            .iter()
            .flat_map(|p| [(p[0] - 0.5) as f32, (p[1] - 0.5) as f32])
            .collect()
    }
}

/// Labels the joints of `pose` in `image`, rendered with `camera`.
#[must_use]
pub fn annotate(pose: &WorldPose, camera: &Camera, image: &Image) -> Annotation {
    let optical_from_world = camera.world_from_optical.inverse();
    let k = &camera.intrinsics;
    let (w, h) = (image.width as usize, image.height as usize);
    let mut out = Annotation::default();
    for head in &pose.heads_m {
        let q = optical_from_world * Point3::from(head.coords);
        out.keypoints_3d.push(Point {
            x: q.x,
            y: q.y,
            z: q.z,
        });
        let Some(px) = k.project(q.coords) else {
            out.keypoints_2d.push([f64::NAN; 2]);
            out.visibility.push(OUT_OF_VIEW);
            continue;
        };
        out.keypoints_2d.push(px);
        let inside = px[0] >= 0.0 && px[1] >= 0.0 && px[0] < w as f64 && px[1] < h as f64;
        if !inside {
            out.visibility.push(OUT_OF_VIEW);
            continue;
        }
        let i = px[1] as usize * w + px[0] as usize;
        let shown = image.surface[i];
        let surface_depth_m = if image.depth[i] > 0.0 {
            1.0 / f64::from(image.depth[i])
        } else {
            f64::INFINITY
        };
        let hidden =
            shown != Surface::Character as u8 && surface_depth_m < q.z - OCCLUSION_MARGIN_M;
        out.visibility.push(if hidden { OCCLUDED } else { VISIBLE });
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
