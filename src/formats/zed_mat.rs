//! Reader for ZED 2i body tracking (BODY_34) recordings saved as MATLAB v5 `.mat` files
//! (by `scipy.io.savemat`).
//!
//! # Format
//!
//! A MATLAB level-5 MAT-file (128-byte header, then data elements, little- or big-endian,
//! uncompressed `miMATRIX` or zlib-compressed `miCOMPRESSED` elements) holding two variables:
//!
//! * `keypoints`: single (or double) array of shape (T, 34, 3): joint positions. MAT arrays are
//!   column-major, so element (t, j, c) is value `t + T·(j + 34·c)`.
//! * `timestampList`: integer (or integral double) array of shape (1, T) or (T, 1):
//!   milliseconds since the Unix epoch.
//!
//! Other variables are skipped. The MAT-file itself is read by [`crate::formats::matlab`]
//! (real numeric arrays); MAT v7.3 (HDF5) files are not supported.
//!
//! # Units and axes
//!
//! Positions are **metres** in the ZED camera frame, right-handed, **+Y up** (the subject stands
//! in front of the camera at negative z), i.e. [`AXES`] = [`SourceAxes::YUp`].
//! [`ZedRecording::camera_keypoints_m`] keeps them as stored; [`ZedRecording::to_pose_sequence`]
//! converts each point once through [`SourceAxes::point_to_autoact`]. Joints follow the ZED
//! BODY_34 order of [`JOINT_NAMES`]; [`JOINT_PARENTS`] gives the tree.
//!
//! # Time
//!
//! Frame stamps are the real timestamps relative to the first frame (ms → ns), so dropped frames
//! stay visible as longer gaps; no frame rate is assumed. Timestamps must strictly increase.
//!
//! # Missing joints
//!
//! The ZED SDK writes NaN for a joint it does not track: such a joint (any coordinate not
//! finite) gets NaN coordinates and confidence 0; every other joint has confidence 1 (the files
//! carry no per-joint confidence).
//!
//! # Errors
//!
//! [`parse`] and [`read`] never panic; every problem is a [`ZedError`] naming the file and the
//! byte offset of the element, the variable, or the frame: not a MAT v5 file (bad header), a
//! truncated or malformed element, a decompression failure, a missing or repeated variable, a
//! wrong class or shape (expected vs found), or a bad or non-increasing timestamp.

use std::path::Path;

use thiserror::Error;

use super::matlab::{self as mat, MatError};
use crate::skeleton::frames::SourceAxes;
use crate::skeleton::pose::{PoseFrame, PoseSequence};

/// ZED BODY_34 joint names, in stored order.
pub const JOINT_NAMES: [&str; 34] = [
    "PELVIS",
    "NAVAL_SPINE",
    "CHEST_SPINE",
    "NECK",
    "L_CLAVICLE",
    "L_SHOULDER",
    "L_ELBOW",
    "L_WRIST",
    "L_HAND",
    "L_HANDTIP",
    "L_THUMB",
    "R_CLAVICLE",
    "R_SHOULDER",
    "R_ELBOW",
    "R_WRIST",
    "R_HAND",
    "R_HANDTIP",
    "R_THUMB",
    "L_HIP",
    "L_KNEE",
    "L_ANKLE",
    "L_FOOT",
    "R_HIP",
    "R_KNEE",
    "R_ANKLE",
    "R_FOOT",
    "HEAD",
    "NOSE",
    "L_EYE",
    "L_EAR",
    "R_EYE",
    "R_EAR",
    "L_HEEL",
    "R_HEEL",
];

/// Parent of each joint (0-based index into [`JOINT_NAMES`]); `None` for the root, PELVIS.
pub const JOINT_PARENTS: [Option<usize>; 34] = [
    None,
    Some(0),
    Some(1),
    Some(2),
    Some(2),
    Some(4),
    Some(5),
    Some(6),
    Some(7),
    Some(8),
    Some(7),
    Some(2),
    Some(11),
    Some(12),
    Some(13),
    Some(14),
    Some(15),
    Some(14),
    Some(0),
    Some(18),
    Some(19),
    Some(20),
    Some(0),
    Some(22),
    Some(23),
    Some(24),
    Some(3),
    Some(26),
    Some(26),
    Some(26),
    Some(26),
    Some(26),
    Some(20),
    Some(24),
];

/// Number of joints.
pub const JOINT_COUNT: usize = 34;

/// Axis convention of the ZED camera frame in these recordings.
pub const AXES: SourceAxes = SourceAxes::YUp;

/// Name of the keypoint variable.
pub const KEYPOINTS_VARIABLE: &str = "keypoints";

/// Name of the timestamp variable.
pub const TIMESTAMPS_VARIABLE: &str = "timestampList";

pub use super::matlab::MAX_DECOMPRESSED_BYTES;

/// Everything that can go wrong reading a ZED `.mat` recording.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum ZedError {
    /// The MAT-file cannot be read, or is not valid: header, element layout or compression.
    #[error(transparent)]
    Mat(#[from] MatError),
    /// A required variable is absent.
    #[error("{file}: missing variable {name:?}")]
    MissingVariable {
        /// The file.
        file: String,
        /// The variable's name.
        name: &'static str,
    },
    /// A variable appears twice.
    #[error("{file}: byte {offset}: variable {name:?} appears twice")]
    DuplicateVariable {
        /// The file.
        file: String,
        /// Byte offset of the second occurrence.
        offset: usize,
        /// The variable's name.
        name: &'static str,
    },
    /// A variable has the wrong class.
    #[error("{file}: variable {variable:?}: wrong type: expected {expected}, found {found}")]
    WrongType {
        /// The file.
        file: String,
        /// The variable's name.
        variable: &'static str,
        /// The classes accepted.
        expected: &'static str,
        /// The class found.
        found: String,
    },
    /// A variable has the wrong dimensions.
    #[error("{file}: variable {variable:?}: wrong shape: expected {expected}, found {found}")]
    WrongShape {
        /// The file.
        file: String,
        /// The variable's name.
        variable: &'static str,
        /// The shape expected.
        expected: String,
        /// The shape found.
        found: String,
    },
    /// A timestamp is not an integer number of milliseconds, or is out of range.
    #[error("{file}: variable \"timestampList\", frame {frame}: invalid timestamp: {message}")]
    InvalidTimestamp {
        /// The file.
        file: String,
        /// 0-based frame.
        frame: usize,
        /// What is wrong.
        message: String,
    },
    /// A timestamp does not exceed the previous one.
    #[error(
        "{file}: variable \"timestampList\", frame {frame}: timestamp {stamp_ms} ms does not follow {previous_ms} ms (stamps must strictly increase)"
    )]
    NonMonotonic {
        /// The file.
        file: String,
        /// 0-based frame.
        frame: usize,
        /// The previous frame's stamp, ms.
        previous_ms: i64,
        /// This frame's stamp, ms.
        stamp_ms: i64,
    },
}

/// A ZED BODY_34 recording as stored (camera frame).
#[derive(Debug, Clone, PartialEq)]
pub struct ZedRecording {
    source: String,
    keypoints_m: Vec<[[f64; 3]; JOINT_COUNT]>,
    timestamps_ms: Vec<i64>,
    stamps_nanos: Vec<u64>,
}

impl ZedRecording {
    /// Where the data came from.
    #[must_use]
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Number of frames.
    #[must_use]
    pub fn len(&self) -> usize {
        self.timestamps_ms.len()
    }

    /// Whether the recording has no frames.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.timestamps_ms.is_empty()
    }

    /// Per frame, the 34 joints (x, y, z) in metres, ZED camera frame (+Y up), NaN where untracked.
    #[must_use]
    pub fn camera_keypoints_m(&self) -> &[[[f64; 3]; JOINT_COUNT]] {
        &self.keypoints_m
    }

    /// Per frame, the timestamp in milliseconds since the Unix epoch (strictly increasing).
    #[must_use]
    pub fn timestamps_ms(&self) -> &[i64] {
        &self.timestamps_ms
    }

    /// The recording as a [`PoseSequence`] (track 0) in the autoact frame, stamped relative to
    /// the first frame.
    #[must_use]
    pub fn to_pose_sequence(&self) -> PoseSequence {
        let frames = self
            .keypoints_m
            .iter()
            .zip(&self.stamps_nanos)
            .map(|(joints, &stamp)| PoseFrame::from_source_points(stamp, joints, AXES))
            .collect();
        PoseSequence {
            source: self.source.clone(),
            track_id: 0,
            joint_names: JOINT_NAMES.iter().map(|n| (*n).to_owned()).collect(),
            frames,
        }
    }
}

/// Read a ZED `.mat` recording.
///
/// # Errors
///
/// [`ZedError::Mat`] ([`MatError::Io`]) if the file cannot be read, otherwise as [`parse`].
pub fn read(path: impl AsRef<Path>) -> Result<ZedRecording, ZedError> {
    let (bytes, file) = mat::read_file(path.as_ref())?;
    parse(&bytes, &file)
}

/// Parse the bytes of a ZED `.mat` recording; `source` names it in errors and in the result.
///
/// # Errors
///
/// Any [`ZedError`] but [`MatError::Io`]; see the module docs.
pub fn parse(bytes: &[u8], source: &str) -> Result<ZedRecording, ZedError> {
    let arrays = mat::read_arrays(bytes, source, &[KEYPOINTS_VARIABLE, TIMESTAMPS_VARIABLE])?;
    let mut keypoints = None;
    let mut timestamps = None;
    for array in arrays {
        let (slot, name) = if array.name == KEYPOINTS_VARIABLE {
            (&mut keypoints, KEYPOINTS_VARIABLE)
        } else {
            (&mut timestamps, TIMESTAMPS_VARIABLE)
        };
        if slot.is_some() {
            return Err(ZedError::DuplicateVariable {
                file: source.to_owned(),
                offset: array.offset,
                name,
            });
        }
        *slot = Some(array);
    }
    let missing = |name| ZedError::MissingVariable {
        file: source.to_owned(),
        name,
    };
    let keypoints = keypoints.ok_or_else(|| missing(KEYPOINTS_VARIABLE))?;
    let timestamps = timestamps.ok_or_else(|| missing(TIMESTAMPS_VARIABLE))?;

    let keypoints_m = decode_keypoints(source, &keypoints)?;
    let frames = keypoints_m.len();
    let timestamps_ms = decode_timestamps(source, &timestamps, frames)?;

    let mut stamps_nanos = Vec::with_capacity(frames);
    let first = timestamps_ms.first().copied().unwrap_or(0);
    let mut previous: Option<i64> = None;
    for (frame, &stamp_ms) in timestamps_ms.iter().enumerate() {
        if let Some(previous_ms) = previous
            && stamp_ms <= previous_ms
        {
            return Err(ZedError::NonMonotonic {
                file: source.to_owned(),
                frame,
                previous_ms,
                stamp_ms,
            });
        }
        previous = Some(stamp_ms);
        let nanos = (i128::from(stamp_ms) - i128::from(first)) * 1_000_000;
        let nanos = u64::try_from(nanos).map_err(|_| ZedError::InvalidTimestamp {
            file: source.to_owned(),
            frame,
            message: format!("{stamp_ms} ms is too far from the first stamp {first} ms"),
        })?;
        stamps_nanos.push(nanos);
    }

    Ok(ZedRecording {
        source: source.to_owned(),
        keypoints_m,
        timestamps_ms,
        stamps_nanos,
    })
}

fn decode_keypoints(
    file: &str,
    array: &mat::Array,
) -> Result<Vec<[[f64; 3]; JOINT_COUNT]>, ZedError> {
    let variable = KEYPOINTS_VARIABLE;
    let (mat::Values::Float(values), mat::Class::Double | mat::Class::Single, false) =
        (&array.values, array.class, array.complex)
    else {
        return Err(ZedError::WrongType {
            file: file.to_owned(),
            variable,
            expected: "a real single or double array",
            found: array.describe_type(),
        });
    };
    let &[frames, JOINT_COUNT, 3] = array.dims.as_slice() else {
        return Err(ZedError::WrongShape {
            file: file.to_owned(),
            variable,
            expected: "(T, 34, 3)".to_owned(),
            found: mat::shape(&array.dims),
        });
    };
    let mut out = Vec::with_capacity(frames);
    for t in 0..frames {
        let mut joints = [[f64::NAN; 3]; JOINT_COUNT];
        for (j, joint) in joints.iter_mut().enumerate() {
            for (c, coordinate) in joint.iter_mut().enumerate() {
                // Column-major: (t, j, c) is at t + T·(j + 34·c); the count was checked.
                let index = t + frames * (j + JOINT_COUNT * c);
                *coordinate = values.get(index).copied().unwrap_or(f64::NAN);
            }
        }
        out.push(joints);
    }
    Ok(out)
}

fn decode_timestamps(file: &str, array: &mat::Array, frames: usize) -> Result<Vec<i64>, ZedError> {
    let variable = TIMESTAMPS_VARIABLE;
    let wrong_type = || ZedError::WrongType {
        file: file.to_owned(),
        variable,
        expected: "a real integer or double array",
        found: array.describe_type(),
    };
    if array.complex || !(array.class.is_integer() || array.class == mat::Class::Double) {
        return Err(wrong_type());
    }
    if !matches!(array.dims.as_slice(), &[1, t] | &[t, 1] if t == frames) {
        return Err(ZedError::WrongShape {
            file: file.to_owned(),
            variable,
            expected: format!("(1, {frames}) to match {KEYPOINTS_VARIABLE:?}"),
            found: mat::shape(&array.dims),
        });
    }
    let invalid = |frame, message: String| ZedError::InvalidTimestamp {
        file: file.to_owned(),
        frame,
        message,
    };
    match &array.values {
        mat::Values::Int(v) => v
            .iter()
            .enumerate()
            .map(|(frame, &x)| {
                i64::try_from(x).map_err(|_| invalid(frame, format!("{x} does not fit in int64")))
            })
            .collect(),
        mat::Values::Float(v) => v
            .iter()
            .enumerate()
            .map(|(frame, &x)| {
                // 2^63 as f64; anything at or beyond it does not fit.
                const LIMIT: f64 = 9_223_372_036_854_775_808.0;
                if x.is_finite() && x.fract() == 0.0 && x.abs() < LIMIT {
                    #[allow(clippy::cast_possible_truncation, reason = "integral and in range")]
                    Ok(x as i64)
                } else {
                    Err(invalid(
                        frame,
                        format!("{x} is not an integer number of milliseconds"),
                    ))
                }
            })
            .collect(),
        mat::Values::Skipped => Err(wrong_type()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::matlab::test_files::Mat;
    use proptest::prelude::*;

    /// Keypoint value for (t, j, c) in the synthetic recordings.
    fn value(t: usize, j: usize, c: usize) -> f32 {
        (t * 1000 + j * 10 + c) as f32 * 0.001
    }

    /// Column-major (T, 34, 3) data; joint 5 of frame 1 is NaN.
    fn keypoint_data(frames: usize) -> Vec<f32> {
        let mut v = vec![0.0; frames * 34 * 3];
        for t in 0..frames {
            for j in 0..34 {
                for c in 0..3 {
                    v[t + frames * (j + 34 * c)] = if t == 1 && j == 5 {
                        f32::NAN
                    } else {
                        value(t, j, c)
                    };
                }
            }
        }
        v
    }

    const STAMPS: [i64; 3] = [1_668_529_444_633, 1_668_529_444_700, 1_668_529_444_733];

    fn recording(big: bool, compressed: bool) -> Vec<u8> {
        let m = Mat::new(big);
        let stamps = m.matrix(14, &[1, 3], "timestampList", 12, &m.i64s(&STAMPS));
        let kp = m.matrix(7, &[3, 34, 3], "keypoints", 7, &m.f32s(&keypoint_data(3)));
        let other = m.matrix(6, &[1, 1], "fps", 9, &2.5f64.to_le_bytes());
        if compressed {
            m.push_compressed(&stamps)
                .push_compressed(&other)
                .push_compressed(&kp)
                .bytes
        } else {
            m.push(stamps).push(other).push(kp).bytes
        }
    }

    fn err(bytes: &[u8]) -> ZedError {
        match parse(bytes, "t.mat") {
            Ok(r) => panic!("expected an error, got {} frames", r.len()),
            Err(e) => e,
        }
    }

    #[test]
    fn reads_plain_compressed_and_big_endian_files() {
        let reference = parse(&recording(false, false), "t.mat").expect("valid");
        for (big, compressed) in [(false, true), (true, false), (true, true)] {
            let other = parse(&recording(big, compressed), "t.mat").expect("valid");
            assert_eq!(other.timestamps_ms(), reference.timestamps_ms());
            let (a, b) = (other.camera_keypoints_m(), reference.camera_keypoints_m());
            assert_eq!(a.len(), b.len());
            for (fa, fb) in a.iter().zip(b) {
                for (ja, jb) in fa.iter().zip(fb) {
                    for (x, y) in ja.iter().zip(jb) {
                        assert!(x == y || (x.is_nan() && y.is_nan()));
                    }
                }
            }
        }
        assert_eq!(reference.len(), 3);
        assert_eq!(reference.timestamps_ms(), &STAMPS);
        // column-major order
        let kp = reference.camera_keypoints_m();
        assert_eq!(kp[2][33][1], f64::from(value(2, 33, 1)));
        assert_eq!(kp[0][7][2], f64::from(value(0, 7, 2)));
    }

    #[test]
    fn pose_sequence_keeps_real_gaps_nan_and_axes() {
        let seq = parse(&recording(false, false), "t.mat")
            .expect("valid")
            .to_pose_sequence();
        assert_eq!(seq.joint_names.len(), 34);
        assert_eq!(seq.joint_index("R_HEEL"), Some(33));
        let stamps: Vec<u64> = seq.frames.iter().map(|f| f.stamp_nanos).collect();
        assert_eq!(stamps, vec![0, 67_000_000, 100_000_000]);
        assert!(seq.frames[1].positions_m[5].x.is_nan());
        assert_eq!(seq.frames[1].confidence[5], 0.0);
        assert_eq!(seq.frames[1].confidence[4], 1.0);
        // converted once through AXES (Y up): source +Y becomes autoact +Z
        let p = seq.frames[2].positions_m[10];
        let camera =
            nalgebra::Point3::new(value(2, 10, 0), value(2, 10, 1), value(2, 10, 2)).cast::<f64>();
        assert_eq!(p, AXES.point_to_autoact(camera));
        assert_eq!(p.z, camera.y);
    }

    #[test]
    fn double_timestamps_and_column_vector_accepted() {
        let m = Mat::new(false);
        let d: Vec<u8> = STAMPS
            .iter()
            .flat_map(|s| (*s as f64).to_le_bytes())
            .collect();
        let stamps = m.matrix(6, &[3, 1], "timestampList", 9, &d);
        let kp = m.matrix(7, &[3, 34, 3], "keypoints", 7, &m.f32s(&keypoint_data(3)));
        let r = parse(&m.push(kp).push(stamps).bytes, "t").expect("valid");
        assert_eq!(r.timestamps_ms(), &STAMPS);
    }

    #[test]
    fn empty_recording() {
        let m = Mat::new(false);
        let stamps = m.matrix(14, &[1, 0], "timestampList", 12, &[]);
        let kp = m.matrix(7, &[0, 34, 3], "keypoints", 7, &[]);
        let r = parse(&m.push(kp).push(stamps).bytes, "t").expect("valid");
        assert!(r.is_empty());
        assert!(r.to_pose_sequence().frames.is_empty());
    }

    #[test]
    fn missing_and_duplicate_variables() {
        let m = Mat::new(false);
        let kp = m.matrix(7, &[3, 34, 3], "keypoints", 7, &m.f32s(&keypoint_data(3)));
        let e = err(&Mat::new(false).push(kp.clone()).bytes);
        assert!(matches!(
            e,
            ZedError::MissingVariable {
                name: "timestampList",
                ..
            }
        ));
        assert_eq!(e.to_string(), "t.mat: missing variable \"timestampList\"");
        let stamps = m.matrix(14, &[1, 3], "timestampList", 12, &m.i64s(&STAMPS));
        assert!(matches!(
            err(&Mat::new(false).push(stamps.clone()).bytes),
            ZedError::MissingVariable {
                name: "keypoints",
                ..
            }
        ));
        let offset = 128 + kp.len() + stamps.len();
        let b = Mat::new(false).push(kp.clone()).push(stamps).push(kp).bytes;
        match err(&b) {
            ZedError::DuplicateVariable {
                name: "keypoints",
                offset: o,
                ..
            } => assert_eq!(o, offset),
            e => panic!("{e}"),
        }
    }

    #[test]
    fn wrong_shapes_and_types() {
        let m = Mat::new(false);
        let stamps = m.matrix(14, &[1, 3], "timestampList", 12, &m.i64s(&STAMPS));
        let kp33 = m.matrix(
            7,
            &[3, 33, 3],
            "keypoints",
            7,
            &m.f32s(&vec![0.0; 3 * 33 * 3]),
        );
        match err(&Mat::new(false).push(kp33).push(stamps.clone()).bytes) {
            e @ ZedError::WrongShape {
                variable: "keypoints",
                ..
            } => {
                assert_eq!(
                    e.to_string(),
                    "t.mat: variable \"keypoints\": wrong shape: expected (T, 34, 3), found (3, 33, 3)"
                );
            }
            e => panic!("{e}"),
        }
        let kp4 = m.matrix(7, &[4, 34, 3], "keypoints", 7, &m.f32s(&keypoint_data(4)));
        assert!(matches!(
            err(&Mat::new(false).push(kp4).push(stamps.clone()).bytes),
            ZedError::WrongShape {
                variable: "timestampList",
                ..
            }
        ));
        let kp_char = m.matrix(4, &[3, 34, 3], "keypoints", 4, &vec![0; 2 * 306]);
        assert!(matches!(
            err(&Mat::new(false).push(kp_char).push(stamps.clone()).bytes),
            ZedError::WrongType {
                variable: "keypoints",
                ..
            }
        ));
        let kp_int = m.matrix(12, &[3, 34, 3], "keypoints", 5, &vec![0; 4 * 306]);
        match err(&Mat::new(false).push(kp_int).push(stamps).bytes) {
            ZedError::WrongType {
                variable: "keypoints",
                found,
                ..
            } => assert_eq!(found, "int32 array"),
            e => panic!("{e}"),
        }
        let kp = m.matrix(7, &[3, 34, 3], "keypoints", 7, &m.f32s(&keypoint_data(3)));
        let stamps_single = m.matrix(7, &[1, 3], "timestampList", 7, &m.f32s(&[1.0, 2.0, 3.0]));
        assert!(matches!(
            err(&Mat::new(false).push(kp).push(stamps_single).bytes),
            ZedError::WrongType {
                variable: "timestampList",
                ..
            }
        ));
    }

    #[test]
    fn non_monotonic_and_invalid_timestamps() {
        let m = Mat::new(false);
        let kp = m.matrix(7, &[3, 34, 3], "keypoints", 7, &m.f32s(&keypoint_data(3)));
        let back = m.matrix(14, &[1, 3], "timestampList", 12, &m.i64s(&[10, 20, 20]));
        match err(&Mat::new(false).push(kp.clone()).push(back).bytes) {
            ZedError::NonMonotonic {
                frame: 2,
                previous_ms: 20,
                stamp_ms: 20,
                ..
            } => {}
            e => panic!("{e}"),
        }
        let frac: Vec<u8> = [1.0, 2.5, 3.0f64]
            .iter()
            .flat_map(|s| s.to_le_bytes())
            .collect();
        let frac = m.matrix(6, &[1, 3], "timestampList", 9, &frac);
        assert!(matches!(
            err(&Mat::new(false).push(kp.clone()).push(frac).bytes),
            ZedError::InvalidTimestamp { frame: 1, .. }
        ));
        let wide = m.matrix(14, &[1, 3], "timestampList", 12, &m.i64s(&[0, 1, i64::MAX]));
        assert!(matches!(
            err(&Mat::new(false).push(kp.clone()).push(wide).bytes),
            ZedError::InvalidTimestamp { frame: 2, .. }
        ));
        let huge = m.matrix(
            15,
            &[1, 3],
            "timestampList",
            13,
            &[u64::MAX.to_le_bytes(); 3].concat(),
        );
        assert!(matches!(
            err(&Mat::new(false).push(kp).push(huge).bytes),
            ZedError::InvalidTimestamp { frame: 0, .. }
        ));
    }

    #[test]
    #[expect(
        clippy::match_same_arms,
        reason = "each accepted error is its own arm, with why a cut can cause it"
    )]
    fn truncation_at_every_offset_is_an_error() {
        for compressed in [false, true] {
            let b = recording(false, compressed);
            for k in 0..b.len() {
                match parse(&b[..k], "t.mat") {
                    Ok(_) => panic!(
                        "cut at {k} of {} parsed (compressed: {compressed})",
                        b.len()
                    ),
                    Err(ZedError::Mat(MatError::NotMatV5 { .. })) => assert!(k < 128),
                    Err(ZedError::Mat(MatError::Truncated { .. })) => {}
                    // a cut exactly between elements drops a variable
                    Err(ZedError::MissingVariable { .. }) => {}
                    Err(e) => panic!("cut at {k}: unexpected {e}"),
                }
            }
        }
    }

    #[test]
    fn read_reports_io() {
        assert!(matches!(
            read("/nonexistent/x.mat"),
            Err(ZedError::Mat(MatError::Io { .. }))
        ));
        let dir = std::env::temp_dir().join(format!("autoact-zed-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("temp dir");
        let path = dir.join("r.mat");
        std::fs::write(&path, recording(false, true)).expect("write");
        assert_eq!(read(&path).expect("valid").len(), 3);
        let _ = std::fs::remove_dir_all(&dir);
    }

    proptest! {
        #[test]
        fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            let _ = parse(&bytes, "p");
        }

        #[test]
        fn arbitrary_elements_after_a_valid_header_never_panic(
            tail in proptest::collection::vec(any::<u8>(), 0..600),
        ) {
            let mut bytes = Mat::new(false).bytes;
            bytes.extend(tail);
            let _ = parse(&bytes, "p");
        }

        #[test]
        fn mutated_recordings_never_panic(
            compressed in any::<bool>(),
            edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8),
        ) {
            let mut bytes = recording(false, compressed);
            let len = bytes.len();
            for (pos, byte) in edits {
                if let Some(b) = bytes.get_mut(pos % len) {
                    *b = byte;
                }
            }
            let _ = parse(&bytes, "p");
        }
    }
}
