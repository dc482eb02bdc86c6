//! Reader for NTU RGB+D `.skeleton` files: raw Microsoft Kinect v2 body tracking.
//!
//! # Format
//!
//! Plain text, fields separated by whitespace, one record per line (the layout of the NTU RGB+D
//! 60/120 release, `read_skeleton_file.m`):
//!
//! ```text
//! <frameCount>
//! per frame:  <bodyCount>
//!   per body: <bodyID> <clippedEdges> <handLeftConfidence> <handLeftState> <handRightConfidence>
//!             <handRightState> <isRestricted> <leanX> <leanY> <trackingState>
//!             <jointCount = 25>
//!             25 lines: x y z depthX depthY colorX colorY orientationW orientationX orientationY
//!                       orientationZ trackingState
//! ```
//!
//! Blank lines are ignored; anything but whitespace after the last frame is an error. Joints come
//! in the Kinect v2 order of [`JOINT_NAMES`]; [`JOINT_PARENTS`] gives the skeleton tree.
//!
//! # Units and axes
//!
//! * `x y z`: Kinect v2 camera space, **metres**, right-handed, **+Y up**, +Z away from the
//!   camera ([`AXES`] = [`SourceAxes::YUp`]). [`NtuJoint::camera_m`] keeps them as written;
//!   [`NtuSkeleton::to_pose_sequences`] converts them to the autoact frame, once, through
//!   [`SourceAxes::point_to_autoact`].
//! * `depthX depthY`: pixels in the 512×424 depth image; `colorX colorY`: pixels in the
//!   1920×1080 colour image.
//! * `orientationW..Z`: the joint's absolute orientation in camera space as a quaternion
//!   (w, x, y, z); its local +Y axis points along the bone parent→joint. Leaf joints (Head,
//!   feet, hand tips, thumbs) have an all-zero quaternion, read as `None`. Convert with
//!   [`SourceAxes::orientation_to_autoact`].
//! * `trackingState` per joint: 2 tracked, 1 inferred, 0 not tracked ([`TrackingState`]).
//! * The frame rate is not in the file; NTU RGB+D is recorded at 30 fps ([`FPS`]).
//!
//! # Pose sequences
//!
//! Bodies are grouped into tracks by `bodyID`, one [`PoseSequence`] per body in order of first
//! appearance, with `track_id = bodyID`. A track has a frame only where its body is in the file:
//! frames are never invented. Frame `i` of the file is stamped `stamp_nanos_at(i, fps)`.
//! Confidence: tracked 1.0, inferred 0.5, not tracked 0.0; a not-tracked joint also gets NaN
//! coordinates (the crate's "not observed" convention).
//!
//! # Errors
//!
//! [`parse`] and [`read`] never panic; every problem is an [`NtuError`] naming the file and the
//! 1-based line (and, where it applies, the frame, body, joint and field): a file that ends early,
//! a line with the wrong number of fields, a non-numeric or non-finite number, a joint count other
//! than 25, a negative or absurd frame or body count (more than [`MAX_FRAMES`] frames or
//! [`MAX_BODIES_PER_FRAME`] bodies), an out-of-range state, the same `bodyID` twice in one
//! frame, or trailing data.

use std::path::Path;

use nalgebra::{Point2, Point3, Quaternion, UnitQuaternion};
use thiserror::Error;

use crate::skeleton::frames::SourceAxes;
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// Kinect v2 joint names, in file order.
pub const JOINT_NAMES: [&str; 25] = [
    "SpineBase",
    "SpineMid",
    "Neck",
    "Head",
    "ShoulderLeft",
    "ElbowLeft",
    "WristLeft",
    "HandLeft",
    "ShoulderRight",
    "ElbowRight",
    "WristRight",
    "HandRight",
    "HipLeft",
    "KneeLeft",
    "AnkleLeft",
    "FootLeft",
    "HipRight",
    "KneeRight",
    "AnkleRight",
    "FootRight",
    "SpineShoulder",
    "HandTipLeft",
    "ThumbLeft",
    "HandTipRight",
    "ThumbRight",
];

/// Parent of each joint (0-based index into [`JOINT_NAMES`]); `None` for the root, SpineBase.
pub const JOINT_PARENTS: [Option<usize>; 25] = [
    None,     // SpineBase
    Some(0),  // SpineMid
    Some(20), // Neck
    Some(2),  // Head
    Some(20), // ShoulderLeft
    Some(4),  // ElbowLeft
    Some(5),  // WristLeft
    Some(6),  // HandLeft
    Some(20), // ShoulderRight
    Some(8),  // ElbowRight
    Some(9),  // WristRight
    Some(10), // HandRight
    Some(0),  // HipLeft
    Some(12), // KneeLeft
    Some(13), // AnkleLeft
    Some(14), // FootLeft
    Some(0),  // HipRight
    Some(16), // KneeRight
    Some(17), // AnkleRight
    Some(18), // FootRight
    Some(1),  // SpineShoulder
    Some(7),  // HandTipLeft
    Some(6),  // ThumbLeft
    Some(11), // HandTipRight
    Some(10), // ThumbRight
];

/// Number of joints per body.
pub const JOINT_COUNT: usize = 25;

/// Frame rate of NTU RGB+D recordings (Kinect v2), frames per second.
pub const FPS: f64 = 30.0;

/// Axis convention of Kinect v2 camera space.
pub const AXES: SourceAxes = SourceAxes::YUp;

/// Largest accepted frame count (about nine hours at 30 fps).
pub const MAX_FRAMES: u64 = 1_000_000;

/// Largest accepted body count per frame (Kinect v2 tracks at most six bodies).
pub const MAX_BODIES_PER_FRAME: u64 = 6;

/// Fields of a body header line.
const BODY_FIELDS: usize = 10;
/// Fields of a joint line.
const JOINT_FIELDS: usize = 12;
/// A quaternion whose norm is below this is "no orientation" (the file writes all zeros).
const MIN_QUATERNION_NORM: f64 = 1e-6;

/// Everything that can go wrong reading a `.skeleton` file.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum NtuError {
    /// The file could not be read.
    #[error("{file}: cannot read the file: {error}")]
    Io {
        /// The file.
        file: String,
        /// The underlying error.
        #[source]
        error: std::io::Error,
    },
    /// The file is not UTF-8 text.
    #[error("{file}:{line}: not utf-8 text")]
    Encoding {
        /// The file.
        file: String,
        /// 1-based line of the first invalid byte.
        line: usize,
    },
    /// The file ends before the data it announced.
    #[error("{file}:{line}: file ends early: expected {expected}")]
    Truncated {
        /// The file.
        file: String,
        /// 1-based line that is missing.
        line: usize,
        /// What was expected there.
        expected: String,
    },
    /// A line has the wrong number of fields.
    #[error("{file}:{line}: {what}: expected {expected} fields, found {found}")]
    FieldCount {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// Which record the line holds (names the frame, body and joint).
        what: String,
        /// Fields expected.
        expected: usize,
        /// Fields found.
        found: usize,
    },
    /// A field is not a (finite) number.
    #[error("{file}:{line}: {what}: field {field} is not a valid number: {text:?}")]
    NotANumber {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// Which record the line holds.
        what: String,
        /// The field's name.
        field: &'static str,
        /// The text found.
        text: String,
    },
    /// A count or state is negative, absurd or not one of the allowed values.
    #[error("{file}:{line}: {what}: field {field} = {value} is out of range ({allowed})")]
    OutOfRange {
        /// The file.
        file: String,
        /// 1-based line.
        line: usize,
        /// Which record the line holds.
        what: String,
        /// The field's name.
        field: &'static str,
        /// The value found.
        value: i64,
        /// The allowed range.
        allowed: &'static str,
    },
    /// A body has a joint count other than 25.
    #[error("{file}:{line}: frame {frame}, body {body}: joint count is {found}, expected 25")]
    JointCount {
        /// The file.
        file: String,
        /// 1-based line of the joint count.
        line: usize,
        /// 0-based frame index.
        frame: usize,
        /// 0-based body index within the frame.
        body: usize,
        /// The count found.
        found: i64,
    },
    /// The same body id appears twice in one frame.
    #[error("{file}:{line}: frame {frame}: body id {body_id} appears twice")]
    DuplicateBody {
        /// The file.
        file: String,
        /// 1-based line of the second body header.
        line: usize,
        /// 0-based frame index.
        frame: usize,
        /// The repeated id.
        body_id: u64,
    },
    /// Something other than whitespace follows the last frame.
    #[error("{file}:{line}: unexpected data after the last frame")]
    TrailingData {
        /// The file.
        file: String,
        /// 1-based line of the first extra data.
        line: usize,
    },
}

/// Kinect v2 joint tracking state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TrackingState {
    /// 0: the joint was not tracked; its data is meaningless.
    NotTracked,
    /// 1: the joint position was inferred (occluded or unsure).
    Inferred,
    /// 2: the joint was tracked.
    Tracked,
}

impl TrackingState {
    /// The state for a file value (0, 1 or 2).
    #[must_use]
    pub fn from_code(code: i64) -> Option<Self> {
        match code {
            0 => Some(TrackingState::NotTracked),
            1 => Some(TrackingState::Inferred),
            2 => Some(TrackingState::Tracked),
            _ => None,
        }
    }

    /// Confidence given to a joint in this state: tracked 1.0, inferred 0.5, not tracked 0.0.
    #[must_use]
    pub fn confidence(self) -> f32 {
        match self {
            TrackingState::Tracked => 1.0,
            TrackingState::Inferred => 0.5,
            TrackingState::NotTracked => 0.0,
        }
    }
}

/// One joint of one body in one frame, as written in the file (Kinect camera space).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NtuJoint {
    /// Position, metres, Kinect camera space (+Y up, +Z away from the camera).
    pub camera_m: Point3<f64>,
    /// Pixel position in the 512×424 depth image.
    pub depth_px: Point2<f64>,
    /// Pixel position in the 1920×1080 colour image.
    pub color_px: Point2<f64>,
    /// Absolute orientation in camera space (local +Y along parent→joint); `None` for the leaf
    /// joints, whose quaternion is all zeros.
    pub orientation: Option<UnitQuaternion<f64>>,
    /// Tracking state.
    pub tracking: TrackingState,
}

/// One body in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct NtuBody {
    /// Kinect tracking id; constant while the body stays tracked.
    pub body_id: u64,
    /// Bit mask of the image edges that clip the body.
    pub clipped_edges: u32,
    /// Left hand tracking confidence (0 low, 1 high).
    pub hand_left_confidence: u32,
    /// Left hand state (0 unknown, 1 not tracked, 2 open, 3 closed, 4 lasso).
    pub hand_left_state: u32,
    /// Right hand tracking confidence (0 low, 1 high).
    pub hand_right_confidence: u32,
    /// Right hand state (0 unknown, 1 not tracked, 2 open, 3 closed, 4 lasso).
    pub hand_right_state: u32,
    /// Whether the body is restricted (Kinect `IsRestricted`).
    pub is_restricted: bool,
    /// Lean of the body, (left/right, forward/back), each in [−1, 1].
    pub lean: [f64; 2],
    /// Body tracking state (Kinect `LeanTrackingState`, 0..2).
    pub tracking_state: u32,
    /// The 25 joints, in [`JOINT_NAMES`] order.
    pub joints: [NtuJoint; JOINT_COUNT],
}

/// One frame: the bodies seen in it (possibly none).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct NtuFrame {
    /// Bodies, in file order.
    pub bodies: Vec<NtuBody>,
}

/// A whole `.skeleton` file.
#[derive(Debug, Clone, PartialEq)]
pub struct NtuSkeleton {
    /// Where the data came from.
    pub source: String,
    /// Frames, in file order.
    pub frames: Vec<NtuFrame>,
}

impl NtuBody {
    /// This body's joints as a [`PoseFrame`] in the autoact frame (see the module docs for the
    /// confidence mapping).
    #[must_use]
    pub fn to_pose_frame(&self, stamp_nanos: u64) -> PoseFrame {
        let mut frame = PoseFrame::missing(stamp_nanos, JOINT_COUNT);
        for ((joint, position), confidence) in self
            .joints
            .iter()
            .zip(&mut frame.positions_m)
            .zip(&mut frame.confidence)
        {
            if joint.tracking != TrackingState::NotTracked {
                *position = AXES.point_to_autoact(joint.camera_m);
                *confidence = joint.tracking.confidence();
            }
        }
        frame
    }
}

impl NtuSkeleton {
    /// Distinct body ids, in order of first appearance.
    #[must_use]
    pub fn body_ids(&self) -> Vec<u64> {
        let mut ids = Vec::new();
        for body in self.frames.iter().flat_map(|f| &f.bodies) {
            if !ids.contains(&body.body_id) {
                ids.push(body.body_id);
            }
        }
        ids
    }

    /// One [`PoseSequence`] per body id (first-appearance order), stamped at `fps` (use [`FPS`]
    /// for NTU RGB+D). A track has frames only where its body appears. `fps` must be positive
    /// and finite; otherwise the stamps are meaningless (but nothing panics).
    #[must_use]
    pub fn to_pose_sequences(&self, fps: f64) -> Vec<PoseSequence> {
        let mut sequences: Vec<PoseSequence> = Vec::new();
        for (index, frame) in self.frames.iter().enumerate() {
            let stamp = stamp_nanos_at(index, fps);
            for body in &frame.bodies {
                let pose = body.to_pose_frame(stamp);
                if let Some(seq) = sequences.iter_mut().find(|s| s.track_id == body.body_id) {
                    seq.frames.push(pose);
                } else {
                    sequences.push(PoseSequence {
                        source: self.source.clone(),
                        track_id: body.body_id,
                        joint_names: JOINT_NAMES.iter().map(|n| (*n).to_owned()).collect(),
                        frames: vec![pose],
                    });
                }
            }
        }
        sequences
    }
}

/// Read a `.skeleton` file.
///
/// # Errors
///
/// [`NtuError::Io`] if the file cannot be read, otherwise as [`parse`].
pub fn read(path: impl AsRef<Path>) -> Result<NtuSkeleton, NtuError> {
    let path = path.as_ref();
    let file = path.display().to_string();
    match super::read_text(path) {
        Ok(text) => parse(&text, &file),
        Err(super::TextError::Io(error)) => Err(NtuError::Io { file, error }),
        Err(super::TextError::NotUtf8 { line }) => Err(NtuError::Encoding { file, line }),
    }
}

/// Parse the text of a `.skeleton` file; `source` names it in errors and in the result.
///
/// # Errors
///
/// Any [`NtuError`] but `Io` and `Encoding`; see the module docs.
pub fn parse(text: &str, source: &str) -> Result<NtuSkeleton, NtuError> {
    let mut cursor = Cursor {
        file: source,
        lines: text.lines().enumerate(),
        last_line: 0,
    };

    let (line, fields) = cursor.record(|| "the frame count".to_owned())?;
    let what = || "frame count line".to_owned();
    let [count] = cursor.fields::<1>(line, &fields, what)?;
    let frame_count = cursor.count(line, count, "frameCount", MAX_FRAMES, "0 to 1000000", what)?;

    let mut frames = Vec::with_capacity(usize::try_from(frame_count.min(100_000)).unwrap_or(0));
    for frame_index in 0..usize::try_from(frame_count).unwrap_or(0) {
        frames.push(parse_frame(&mut cursor, frame_index)?);
    }

    if let Some((index, _)) = cursor.lines.find(|(_, l)| !l.trim().is_empty()) {
        return Err(NtuError::TrailingData {
            file: source.to_owned(),
            line: index + 1,
        });
    }
    Ok(NtuSkeleton {
        source: source.to_owned(),
        frames,
    })
}

fn parse_frame(cursor: &mut Cursor<'_>, frame: usize) -> Result<NtuFrame, NtuError> {
    let what = || format!("frame {frame}: body count line");
    let (line, fields) = cursor.record(|| format!("the body count of frame {frame}"))?;
    let [count] = cursor.fields::<1>(line, &fields, what)?;
    let body_count = cursor.count(
        line,
        count,
        "bodyCount",
        MAX_BODIES_PER_FRAME,
        "0 to 6",
        what,
    )?;

    let mut bodies: Vec<NtuBody> = Vec::new();
    for body in 0..usize::try_from(body_count).unwrap_or(0) {
        let (line, parsed) = parse_body(cursor, frame, body)?;
        if bodies.iter().any(|b| b.body_id == parsed.body_id) {
            return Err(NtuError::DuplicateBody {
                file: cursor.file.to_owned(),
                line,
                frame,
                body_id: parsed.body_id,
            });
        }
        bodies.push(parsed);
    }
    Ok(NtuFrame { bodies })
}

/// A body: header line, joint count line, 25 joint lines. Returns the header's line too.
fn parse_body(
    cursor: &mut Cursor<'_>,
    frame: usize,
    body: usize,
) -> Result<(usize, NtuBody), NtuError> {
    let what = || format!("frame {frame}, body {body}: body header");
    let (header_line, fields) =
        cursor.record(|| format!("the header of body {body} in frame {frame}"))?;
    let [
        id,
        clipped,
        hl_conf,
        hl_state,
        hr_conf,
        hr_state,
        restricted,
        lean_x,
        lean_y,
        tracking,
    ] = cursor.fields::<BODY_FIELDS>(header_line, &fields, what)?;
    let body_id = cursor.number::<u64>(header_line, id, "bodyID", what)?;
    let line = header_line;
    let small = |c: &Cursor<'_>, text: &str, field: &'static str| -> Result<u32, NtuError> {
        let value = c.count(
            line,
            text,
            field,
            u64::from(u32::MAX),
            "0 to 4294967295",
            what,
        )?;
        Ok(u32::try_from(value).unwrap_or(u32::MAX))
    };
    let clipped_edges = small(cursor, clipped, "clippedEdges")?;
    let hand_left_confidence = small(cursor, hl_conf, "handLeftConfidence")?;
    let hand_left_state = small(cursor, hl_state, "handLeftState")?;
    let hand_right_confidence = small(cursor, hr_conf, "handRightConfidence")?;
    let hand_right_state = small(cursor, hr_state, "handRightState")?;
    let is_restricted = small(cursor, restricted, "isRestricted")? != 0;
    let lean = [
        cursor.finite(line, lean_x, "leanX", what)?,
        cursor.finite(line, lean_y, "leanY", what)?,
    ];
    let tracking_state = small(cursor, tracking, "trackingState")?;

    let what = || format!("frame {frame}, body {body}: joint count line");
    let (line, fields) =
        cursor.record(|| format!("the joint count of body {body} in frame {frame}"))?;
    let [count] = cursor.fields::<1>(line, &fields, what)?;
    let found = cursor.number::<i64>(line, count, "jointCount", what)?;
    if found != 25 {
        return Err(NtuError::JointCount {
            file: cursor.file.to_owned(),
            line,
            frame,
            body,
            found,
        });
    }

    let mut joints = [NtuJoint {
        camera_m: Point3::origin(),
        depth_px: Point2::origin(),
        color_px: Point2::origin(),
        orientation: None,
        tracking: TrackingState::NotTracked,
    }; JOINT_COUNT];
    for (index, slot) in joints.iter_mut().enumerate() {
        *slot = parse_joint(cursor, frame, body, index)?;
    }

    Ok((
        header_line,
        NtuBody {
            body_id,
            clipped_edges,
            hand_left_confidence,
            hand_left_state,
            hand_right_confidence,
            hand_right_state,
            is_restricted,
            lean,
            tracking_state,
            joints,
        },
    ))
}

fn parse_joint(
    cursor: &mut Cursor<'_>,
    frame: usize,
    body: usize,
    joint: usize,
) -> Result<NtuJoint, NtuError> {
    const NAMES: [&str; JOINT_FIELDS - 1] = [
        "x",
        "y",
        "z",
        "depthX",
        "depthY",
        "colorX",
        "colorY",
        "orientationW",
        "orientationX",
        "orientationY",
        "orientationZ",
    ];
    let name = JOINT_NAMES.get(joint).copied().unwrap_or("?");
    let what = || format!("frame {frame}, body {body}, joint {joint} ({name})");
    let (line, fields) =
        cursor.record(|| format!("joint {joint} ({name}) of body {body} in frame {frame}"))?;
    let texts = cursor.fields::<JOINT_FIELDS>(line, &fields, what)?;
    let mut v = [0.0_f64; JOINT_FIELDS - 1];
    for ((value, text), field) in v.iter_mut().zip(texts).zip(NAMES) {
        *value = cursor.finite(line, text, field, what)?;
    }
    let [x, y, z, dx, dy, cx, cy, qw, qx, qy, qz] = v;
    let [.., state_text] = texts;
    let code = cursor.number::<i64>(line, state_text, "trackingState", what)?;
    let tracking = TrackingState::from_code(code).ok_or_else(|| NtuError::OutOfRange {
        file: cursor.file.to_owned(),
        line,
        what: what(),
        field: "trackingState",
        value: code,
        allowed: "0, 1 or 2",
    })?;
    let q = Quaternion::new(qw, qx, qy, qz);
    let orientation = (q.norm() >= MIN_QUATERNION_NORM).then(|| UnitQuaternion::from_quaternion(q));
    Ok(NtuJoint {
        camera_m: Point3::new(x, y, z),
        depth_px: Point2::new(dx, dy),
        color_px: Point2::new(cx, cy),
        orientation,
        tracking,
    })
}

/// Line-by-line reader that skips blank lines and remembers where it is.
struct Cursor<'a> {
    file: &'a str,
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    /// 1-based number of the last line consumed.
    last_line: usize,
}

impl<'a> Cursor<'a> {
    /// The next non-blank line (1-based number) split into fields, or `Truncated`.
    fn record(&mut self, expected: impl Fn() -> String) -> Result<(usize, Vec<&'a str>), NtuError> {
        for (index, text) in self.lines.by_ref() {
            self.last_line = index + 1;
            let fields: Vec<&str> = text.split_whitespace().collect();
            if !fields.is_empty() {
                return Ok((index + 1, fields));
            }
        }
        Err(NtuError::Truncated {
            file: self.file.to_owned(),
            line: self.last_line + 1,
            expected: expected(),
        })
    }

    /// Exactly `N` fields.
    fn fields<const N: usize>(
        &self,
        line: usize,
        fields: &[&'a str],
        what: impl Fn() -> String,
    ) -> Result<[&'a str; N], NtuError> {
        <[&str; N]>::try_from(fields).map_err(|_| NtuError::FieldCount {
            file: self.file.to_owned(),
            line,
            what: what(),
            expected: N,
            found: fields.len(),
        })
    }

    fn number<T: std::str::FromStr>(
        &self,
        line: usize,
        text: &str,
        field: &'static str,
        what: impl Fn() -> String,
    ) -> Result<T, NtuError> {
        text.parse::<T>().map_err(|_| NtuError::NotANumber {
            file: self.file.to_owned(),
            line,
            what: what(),
            field,
            text: text.to_owned(),
        })
    }

    fn finite(
        &self,
        line: usize,
        text: &str,
        field: &'static str,
        what: impl Fn() -> String,
    ) -> Result<f64, NtuError> {
        let value: f64 = self.number(line, text, field, &what)?;
        if value.is_finite() {
            Ok(value)
        } else {
            Err(NtuError::NotANumber {
                file: self.file.to_owned(),
                line,
                what: what(),
                field,
                text: text.to_owned(),
            })
        }
    }

    /// A non-negative integer no larger than `max`.
    fn count(
        &self,
        line: usize,
        text: &str,
        field: &'static str,
        max: u64,
        allowed: &'static str,
        what: impl Fn() -> String,
    ) -> Result<u64, NtuError> {
        let value: i64 = self.number(line, text, field, &what)?;
        match u64::try_from(value) {
            Ok(v) if v <= max => Ok(v),
            _ => Err(NtuError::OutOfRange {
                file: self.file.to_owned(),
                line,
                what: what(),
                field,
                value,
                allowed,
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A joint line: position (x, y, z) and tracking state; orientation zero for leaves.
    fn joint_line(j: usize, offset: f64, state: u8) -> String {
        let x = 0.1 * j as f64 + offset;
        let y = 0.05 * j as f64;
        let quat = if JOINT_PARENTS.contains(&Some(j)) {
            "0.7071068 0 0.7071068 0"
        } else {
            "0 0 0 0"
        };
        format!("{x} {y} 3.5 250.1 180.2 1000.5 500.25 {quat} {state}\n")
    }

    /// A synthetic file: per frame, the body ids present.
    fn synth(frames: &[&[u64]]) -> String {
        let mut s = format!("{}\n", frames.len());
        for (f, bodies) in frames.iter().enumerate() {
            s += &format!("{}\n", bodies.len());
            for id in *bodies {
                s += &format!("{id} 0 1 1 1 1 0 0.02 -0.05 2\n25\n");
                for j in 0..25 {
                    let state = [2, 2, 1, 0][(j + f) % 4];
                    s += &joint_line(j, f as f64, state);
                }
            }
        }
        s
    }

    fn err(text: &str) -> NtuError {
        match parse(text, "t.skeleton") {
            Ok(s) => panic!("expected an error, got {} frames", s.frames.len()),
            Err(e) => e,
        }
    }

    #[test]
    fn parses_a_synthetic_file() {
        let text = synth(&[&[7], &[7, 9], &[9]]);
        let skel = parse(&text, "t.skeleton").expect("valid");
        assert_eq!(skel.frames.len(), 3);
        assert_eq!(skel.frames[1].bodies.len(), 2);
        let body = &skel.frames[0].bodies[0];
        assert_eq!(body.body_id, 7);
        assert_eq!(body.lean, [0.02, -0.05]);
        assert!(!body.is_restricted);
        let j = &body.joints[2];
        assert_eq!(j.camera_m, Point3::new(0.2, 0.1, 3.5));
        assert_eq!(j.depth_px, Point2::new(250.1, 180.2));
        assert_eq!(j.color_px, Point2::new(1000.5, 500.25));
        assert_eq!(j.tracking, TrackingState::Inferred);
        let q = j.orientation.expect("Neck has a child");
        assert!((q.w - std::f64::consts::FRAC_1_SQRT_2).abs() < 1e-6);
        assert!(body.joints[3].orientation.is_none(), "Head is a leaf");
        assert_eq!(skel.body_ids(), vec![7, 9]);
    }

    #[test]
    fn tracks_are_grouped_by_body_id_without_inventing_frames() {
        let text = synth(&[&[7], &[7, 9], &[9]]);
        let seqs = parse(&text, "t.skeleton")
            .expect("valid")
            .to_pose_sequences(FPS);
        assert_eq!(seqs.len(), 2);
        assert_eq!(seqs[0].track_id, 7);
        assert_eq!(seqs[1].track_id, 9);
        let stamps = |s: &PoseSequence| s.frames.iter().map(|f| f.stamp_nanos).collect::<Vec<_>>();
        assert_eq!(stamps(&seqs[0]), vec![0, 33_333_333]);
        assert_eq!(stamps(&seqs[1]), vec![33_333_333, 66_666_667]);
        assert_eq!(seqs[0].joint_names.len(), 25);
        assert_eq!(seqs[0].joint_index("ThumbRight"), Some(24));
    }

    #[test]
    fn confidence_mapping_and_axes() {
        let text = synth(&[&[1]]);
        let seq = &parse(&text, "t.skeleton")
            .expect("valid")
            .to_pose_sequences(FPS)[0];
        let frame = &seq.frames[0];
        // frame 0: joint j has state [2, 2, 1, 0][j % 4]
        assert_eq!(frame.confidence[0], 1.0);
        assert_eq!(frame.confidence[2], 0.5);
        assert_eq!(frame.confidence[3], 0.0);
        assert!(frame.positions_m[3].x.is_nan());
        // converted once through AXES (Y up): source +Y (0.05) becomes autoact +Z
        let camera = Point3::new(0.1, 0.05, 3.5);
        let p = frame.positions_m[1];
        assert_eq!(p, AXES.point_to_autoact(camera));
        assert!(
            (p.z - 0.05).abs() < 1e-12 && (p.coords.norm() - camera.coords.norm()).abs() < 1e-12
        );
    }

    #[test]
    fn empty_and_blank_lines() {
        assert!(parse("0\n", "t").expect("valid").frames.is_empty());
        let skel = parse("2\n0\n\n0\n\n", "t").expect("valid");
        assert_eq!(skel.frames.len(), 2);
        assert!(skel.to_pose_sequences(FPS).is_empty());
        let crlf = synth(&[&[3]]).replace('\n', "\r\n");
        assert_eq!(parse(&crlf, "t").expect("crlf is fine").frames.len(), 1);
    }

    #[test]
    fn truncated_file_names_the_missing_line() {
        let text = synth(&[&[7]]);
        let cut: String = text.lines().take(10).flat_map(|l| [l, "\n"]).collect();
        match err(&cut) {
            NtuError::Truncated {
                file,
                line,
                expected,
            } => {
                assert_eq!(file, "t.skeleton");
                assert_eq!(line, 11);
                assert!(
                    expected.contains("joint 6 (WristLeft) of body 0 in frame 0"),
                    "{expected}"
                );
            }
            e => panic!("{e}"),
        }
        let msg = err("").to_string();
        assert_eq!(
            msg,
            "t.skeleton:1: file ends early: expected the frame count"
        );
    }

    #[test]
    fn every_truncation_is_an_error() {
        let text = synth(&[&[7], &[7, 9]]);
        let end = text.trim_end().len();
        for k in 0..end {
            assert!(parse(&text[..k], "t").is_err(), "cut at {k} parsed");
        }
    }

    #[test]
    fn wrong_field_count() {
        let text = synth(&[&[7]]).replacen(" 2\n25\n", " 2 5\n25\n", 1);
        match err(&text) {
            NtuError::FieldCount {
                line: 3,
                expected: 10,
                found: 11,
                ..
            } => {}
            e => panic!("{e}"),
        }
        let mut lines: Vec<String> = synth(&[&[7]]).lines().map(str::to_owned).collect();
        lines[6] = "1 2 3".into();
        match err(&lines.join("\n")) {
            NtuError::FieldCount {
                line: 7,
                expected: 12,
                found: 3,
                what,
                ..
            } => {
                assert!(what.contains("joint 2 (Neck)"), "{what}");
            }
            e => panic!("{e}"),
        }
    }

    #[test]
    fn non_numeric_and_non_finite() {
        let mut lines: Vec<String> = synth(&[&[7]]).lines().map(str::to_owned).collect();
        lines[5] = lines[5].replacen("3.5", "abc", 1);
        match err(&lines.join("\n")) {
            NtuError::NotANumber {
                line: 6,
                field: "z",
                text,
                ..
            } => assert_eq!(text, "abc"),
            e => panic!("{e}"),
        }
        lines[5] = lines[5].replacen("abc", "NaN", 1);
        assert!(matches!(
            err(&lines.join("\n")),
            NtuError::NotANumber { field: "z", .. }
        ));
        assert!(matches!(
            err("x\n"),
            NtuError::NotANumber {
                line: 1,
                field: "frameCount",
                ..
            }
        ));
        let text = synth(&[&[7]]).replacen("7 0 1", "seven 0 1", 1);
        assert!(matches!(
            err(&text),
            NtuError::NotANumber {
                line: 3,
                field: "bodyID",
                ..
            }
        ));
    }

    #[test]
    fn joint_count_must_be_25() {
        let text = synth(&[&[7]]).replacen("\n25\n", "\n24\n", 1);
        match err(&text) {
            NtuError::JointCount {
                line: 4,
                frame: 0,
                body: 0,
                found: 24,
                ..
            } => {}
            e => panic!("{e}"),
        }
    }

    #[test]
    fn negative_and_absurd_counts() {
        match err("-1\n") {
            NtuError::OutOfRange {
                line: 1,
                field: "frameCount",
                value: -1,
                ..
            } => {}
            e => panic!("{e}"),
        }
        assert!(matches!(
            err("99999999999\n"),
            NtuError::OutOfRange {
                field: "frameCount",
                ..
            }
        ));
        assert!(matches!(
            err("1\n7\n"),
            NtuError::OutOfRange {
                line: 2,
                field: "bodyCount",
                ..
            }
        ));
        let text = synth(&[&[7]]).replacen(" 2\n25\n", " -2\n25\n", 1);
        assert!(matches!(
            err(&text),
            NtuError::OutOfRange {
                field: "trackingState",
                ..
            }
        ));
        let mut lines: Vec<String> = synth(&[&[7]]).lines().map(str::to_owned).collect();
        lines[4] = lines[4].replace(" 2", " 3");
        match err(&lines.join("\n")) {
            NtuError::OutOfRange {
                line: 5,
                field: "trackingState",
                value: 3,
                what,
                ..
            } => {
                assert!(what.contains("SpineBase"), "{what}");
            }
            e => panic!("{e}"),
        }
    }

    #[test]
    fn duplicate_body_and_trailing_data() {
        let text = synth(&[&[7, 7]]);
        assert!(matches!(
            err(&text),
            NtuError::DuplicateBody {
                line: 30,
                frame: 0,
                body_id: 7,
                ..
            }
        ));
        let text = synth(&[&[7]]) + "\n1\n";
        assert!(matches!(
            err(&text),
            NtuError::TrailingData { line: 31, .. }
        ));
    }

    #[test]
    fn read_reports_io_and_encoding() {
        assert!(matches!(
            read("/nonexistent/x.skeleton"),
            Err(NtuError::Io { .. })
        ));
        let dir = std::env::temp_dir().join(format!("autoact-ntu-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("bad.skeleton");
        std::fs::write(&path, b"1\n0\n\xff\n").expect("write");
        assert!(matches!(
            read(&path),
            Err(NtuError::Encoding { line: 3, .. })
        ));
        std::fs::write(&path, synth(&[&[5]])).expect("write");
        assert_eq!(read(&path).expect("valid").frames.len(), 1);
        let _ = std::fs::remove_dir_all(&dir);
    }

    proptest! {
        #[test]
        fn arbitrary_text_never_panics(text in "\\PC{0,400}") {
            let _ = parse(&text, "p");
        }

        #[test]
        fn numeric_noise_never_panics(text in "[0-9 .\\-\n]{0,600}") {
            let _ = parse(&text, "p");
        }

        #[test]
        fn mutated_files_never_panic(pos in 0usize..4000, byte in any::<u8>()) {
            let mut bytes = synth(&[&[7], &[7, 9]]).into_bytes();
            let len = bytes.len();
            if let Some(b) = bytes.get_mut(pos % len) {
                *b = byte;
            }
            if let Ok(text) = String::from_utf8(bytes) {
                let _ = parse(&text, "p");
            }
        }
    }
}
