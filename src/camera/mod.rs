//! The virtual camera and the paper's **Random Camera Moving (RCM)**: where the camera stands,
//! where it looks, and what it sees, so that an animated character is filmed from random
//! viewpoints and always stays whole in the picture.
//!
//! The pieces, in the order a capture uses them:
//!
//! 1. [`Intrinsics`]: a pinhole camera from a resolution and a horizontal field of view, with
//!    what ROS `sensor_msgs/CameraInfo` needs ([`Intrinsics::k`], [`Intrinsics::p`],
//!    [`DISTORTION_MODEL`]).
//! 2. [`CameraPose`] and [`look_at`]: the camera's position and its **optical** frame in the world
//!    (ROS convention: z forward, x right, y down), never rolled.
//! 3. [`Subject`] and [`framing_band`]: how far the camera must stay from the character so that
//!    every joint of every frame fits in the image with a margin.
//! 4. [`RcmRanges`] and [`random_viewpoints`]: the RCM random walk itself, in cylindrical
//!    coordinates about the character's ground point, clamped into the framing and height bands,
//!    with every draw recorded.
//! 5. [`Shot`] and [`camera_at`]: the camera pose at any instant of a static or moving shot,
//!    tracking the character's ground position and looking at its current centre.
//!
//! ```
//! use autoact::camera::{self, Intrinsics, RcmRanges, Shot, Subject};
//! use autoact::skeleton::{character::Character, fk::BonePose, rig::Rig};
//! use rand::SeedableRng;
//!
//! let rig = Rig::standard();
//! let body = Character::standard(&rig);
//! let clip = vec![BonePose::rest(&rig); 30];
//! let lens = Intrinsics::from_horizontal_fov(1280, 720, 60.0)?;
//! let subject = Subject::from_poses(&rig, &body, &clip, 1.0)?;
//! let band = camera::framing_band(&lens, &subject, 0.05, 12.0)?;
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
//! let walk = camera::random_viewpoints(&mut rng, &RcmRanges::default(), band, 4)?;
//! // Viewpoint 0 as a moving shot to viewpoint 1, one pose per frame of the clip.
//! for f in 0..clip.len() {
//!     let s = f as f64 / (clip.len() - 1) as f64;
//!     let (ground, centre) = (subject.ground_xy_m[f], subject.centres_m[f]);
//!     let pose = camera::camera_at(&walk[0], walk.get(1), Shot::Moving, s, ground, centre);
//!     assert!(pose.project(&lens, &centre).is_some());
//! }
//! # Ok::<(), camera::CameraError>(())
//! ```
//!
//! **Why it differs from the reference code** (`reference/gtautoact-reference-code.md` §5): there,
//! the first camera stood at the character's own origin, steps were key-hold seconds (so metres
//! depended on the frame rate), the "radius" could go negative and mirror the point, nothing kept
//! the character in frame, and nothing was logged. Here the camera starts at a distance, every
//! length is in metres, the distance is clamped into a band computed from the character and the
//! lens, and every drawn and applied step is returned for logging. All draws come from a caller
//! supplied RNG (seed it; ChaCha8 in the crate) so a plan is a pure function of its seed.
//!
//! **Frames.** Everything is in the autoact world frame ([`crate::skeleton::frames`]: metres, +Z up, ground
//! at `z = 0`). The camera's ROS frame is [`CAMERA_FRAME`], an optical frame; see [`CameraPose`]
//! for what to write into `geometry_msgs/PoseStamped`, TF and `sensor_msgs/CameraInfo`.

mod framing;
mod intrinsics;
mod pose;
mod rcm;

#[cfg(test)]
mod tests;

pub use framing::{BODY_ALLOWANCE_M, Subject, framing_band, subject_points_into};
pub use intrinsics::{DISTORTION_MODEL, Intrinsics, MAX_HFOV_DEG, MIN_HFOV_DEG};
pub use pose::{CameraPose, look_at, optical_from_camera_link};
pub use rcm::{RcmRanges, Shot, StepDraw, Viewpoint, camera_at, random_viewpoints};

/// Name of the camera's ROS frame: the **optical** frame (z forward, x right, y down). Use it as
/// the TF `child_frame_id` of the camera pose and as `header.frame_id` of `sensor_msgs/CameraInfo`.
pub const CAMERA_FRAME: &str = "camera";

/// What can be wrong with a camera, a framing request or RCM ranges. Every message names the
/// offending field or value.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CameraError {
    /// An image dimension is zero.
    #[error("image {field} is {value} px; it must be at least 1")]
    Resolution {
        /// `width_px` or `height_px`.
        field: &'static str,
        /// The value given.
        value: u32,
    },
    /// The horizontal field of view is not finite or outside (1°, 170°).
    #[error(
        "horizontal field of view is {value_deg}°; it must be finite and strictly between {MIN_HFOV_DEG}° and {MAX_HFOV_DEG}°"
    )]
    FieldOfView {
        /// The value given, degrees.
        value_deg: f64,
    },
    /// A scalar parameter is out of its domain.
    #[error("{field} is {value}; it must be {expected}")]
    Value {
        /// The parameter's name (as in the spec, e.g. `start_distance_m`).
        field: &'static str,
        /// The value given.
        value: f64,
        /// What the value must be, in words.
        expected: &'static str,
    },
    /// A `[low, high]` range is not finite, reversed, or out of its domain.
    #[error("{field} is [{low}, {high}]; it must be {expected}")]
    Range {
        /// The range's name (as in the spec, e.g. `delta_theta_deg`).
        field: &'static str,
        /// Its lower bound.
        low: f64,
        /// Its upper bound.
        high: f64,
        /// What the range must be, in words.
        expected: &'static str,
    },
    /// An animation frame does not match the rig.
    #[error("frame {frame} has {got} bone rotations but the rig has {expected} bones")]
    PoseSize {
        /// Index of the frame.
        frame: usize,
        /// Rotations in the frame.
        got: usize,
        /// Bones in the rig.
        expected: usize,
    },
    /// A frame produced a non-finite joint position.
    #[error("frame {frame} has a non-finite joint position (bad rotation or translation)")]
    NonFinitePose {
        /// Index of the frame.
        frame: usize,
    },
    /// No frames to frame.
    #[error("the animation has no frames, so there is no subject to frame")]
    NoFrames,
    /// The character cannot be framed at the allowed distances.
    #[error(
        "the character does not fit in the image: its bounding sphere (radius {radius_m:.3} m, \
         centre up to {centre_offset_m:.3} m off its ground point) needs the camera at least \
         {min_distance_m:.3} m away with a {margin_fraction} margin on the narrower \
         {narrow_fov_deg:.1}° field of view, but the maximum distance is {max_distance_m:.3} m \
         ({shortfall_m:.3} m short): raise the maximum distance, widen the field of view or \
         lower the margin"
    )]
    DoesNotFit {
        /// Radius of the subject's sphere, metres.
        radius_m: f64,
        /// Largest horizontal offset of the look-at centre from the ground point, metres.
        centre_offset_m: f64,
        /// The distance the character needs, metres.
        min_distance_m: f64,
        /// The distance allowed, metres.
        max_distance_m: f64,
        /// `min_distance_m − max_distance_m`.
        shortfall_m: f64,
        /// The margin asked for.
        margin_fraction: f64,
        /// The narrower of the two fields of view, degrees.
        narrow_fov_deg: f64,
    },
    /// The user's `distance_m` band and the framing band do not overlap.
    #[error(
        "distance_m [{user_low}, {user_high}] does not overlap the framing band \
         [{framing_low:.3}, {framing_high:.3}] m that keeps this character in the image: \
         move distance_m or drop it"
    )]
    NoDistance {
        /// Lower bound of `distance_m`.
        user_low: f64,
        /// Upper bound of `distance_m`.
        user_high: f64,
        /// Lower bound of the framing band.
        framing_low: f64,
        /// Upper bound of the framing band.
        framing_high: f64,
    },
}

/// Checks a `[low, high]` range: finite, `low ≤ high`, and `low ≥ min` when `min` is given.
fn check_range(
    field: &'static str,
    r: [f64; 2],
    min: Option<f64>,
    expected: &'static str,
) -> Result<(), CameraError> {
    let [low, high] = r;
    let ok = low.is_finite() && high.is_finite() && low <= high && min.is_none_or(|m| low >= m);
    if ok {
        Ok(())
    } else {
        Err(CameraError::Range {
            field,
            low,
            high,
            expected,
        })
    }
}
