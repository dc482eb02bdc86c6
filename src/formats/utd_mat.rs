//! Reader for the skeleton files of UTD-MHAD (Chen, Jafari and Kehtarnavaz, 2015): Kinect v1
//! body tracking saved as MATLAB `.mat` files, one clip per file (`a1_s1_t2_skeleton.mat`).
//!
//! # Format
//!
//! A MATLAB level-5 MAT-file holding the variable `d_skel`: a real double (or single) array of
//! shape (20, 3, T), joint × coordinate × frame (MATLAB drops a trailing 1, so a one-frame clip
//! is (20, 3)). MAT arrays are column-major, so element (j, c, t) is value `j + 20·(c + 3·t)`.
//! Other variables are skipped. The MAT-file itself is read by [`crate::formats::matlab`].
//!
//! The 20 joints are in UTD's order ([`UTD_ORDER`]: head, shoulder centre, spine, hip centre,
//! then the arms and legs); the pose sequence lists them in the Kinect SDK's order, the joint
//! order of layout `kinect-v1-20` ([`JOINT_NAMES`]), which other Kinect v1 datasets also use.
//!
//! # Units, axes, time
//!
//! Positions are **metres** in Kinect v1 camera space: right-handed, **+Y up**, +Z from the
//! sensor into the scene ([`AXES`] = [`SourceAxes::YUp`]); import grounds them like other
//! camera-frame sources. The files carry no time: frames are [`FPS`] (30) apart unless
//! `--fps` says otherwise.
//!
//! # Missing joints
//!
//! A joint with a coordinate that is not finite, or at exactly (0, 0, 0) (the sensor itself,
//! where the Kinect SDK puts a joint it does not track), is missing: NaN, confidence 0. Every
//! other joint has confidence 1 (the files keep no tracking state).
//!
//! # Errors
//!
//! [`parse`] and [`read`] never panic; every problem is a [`UtdError`] naming the file and what
//! is wrong: not a MAT v5 file, a truncated or malformed element, no `d_skel` or two of them, or
//! a `d_skel` of the wrong class or shape (expected against found).

use std::path::Path;

use thiserror::Error;

use super::matlab::{self as mat, MatError};
use crate::skeleton::frames::SourceAxes;
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// The skeleton variable.
pub const VARIABLE: &str = "d_skel";

/// Number of joints.
pub const JOINT_COUNT: usize = 20;

/// Frame rate of UTD-MHAD's Kinect recordings.
pub const FPS: f64 = 30.0;

/// Axis convention of Kinect v1 camera space.
pub const AXES: SourceAxes = SourceAxes::YUp;

/// The joints of layout `kinect-v1-20`, in the Kinect SDK's order (`NUI_SKELETON_POSITION_*`).
/// "Left" is the person's left.
pub const JOINT_NAMES: [&str; JOINT_COUNT] = [
    "HipCenter",
    "Spine",
    "ShoulderCenter",
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
];

/// For each row of `d_skel` (UTD's `Skeleton_joint_order.txt`: 1 head, 2 shoulder_center,
/// 3 spine, 4 hip_center, 5–20 as the SDK), its index in [`JOINT_NAMES`].
pub const UTD_ORDER: [usize; JOINT_COUNT] = [
    3, 2, 1, 0, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16, 17, 18, 19,
];

/// Everything that can go wrong reading a UTD-MHAD skeleton file.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum UtdError {
    /// The MAT-file cannot be read, or is not valid: header, element layout or compression.
    #[error(transparent)]
    Mat(#[from] MatError),
    /// `d_skel` is absent, repeated, or not a (20, 3, T) real array.
    #[error("{file}: variable \"d_skel\": {problem}")]
    Skeleton {
        /// The file.
        file: String,
        /// What is wrong, with what was found.
        problem: String,
    },
}

/// A UTD-MHAD clip: per frame, the 20 joints in [`JOINT_NAMES`] order, metres, Kinect camera
/// space, NaN where missing.
#[derive(Debug, Clone, PartialEq)]
pub struct UtdClip {
    source: String,
    joints_m: Vec<[[f64; 3]; JOINT_COUNT]>,
}

impl UtdClip {
    /// Per frame, the joints as stored (camera space, metres), in [`JOINT_NAMES`] order.
    #[must_use]
    pub fn camera_joints_m(&self) -> &[[[f64; 3]; JOINT_COUNT]] {
        &self.joints_m
    }

    /// The clip as a [`PoseSequence`] (track 0) in the autoact frame, layout `kinect-v1-20`,
    /// frames `1 / fps` apart.
    #[must_use]
    pub fn to_pose_sequence(&self, fps: f64) -> PoseSequence {
        let frames = self
            .joints_m
            .iter()
            .enumerate()
            .map(|(k, joints)| PoseFrame::from_source_points(stamp_nanos_at(k, fps), joints, AXES))
            .collect();
        PoseSequence {
            source: self.source.clone(),
            track_id: 0,
            joint_names: JOINT_NAMES.iter().map(|n| (*n).to_owned()).collect(),
            frames,
        }
    }
}

/// Whether the MAT-file `bytes` hold a `d_skel` variable (how `import` tells a UTD-MHAD file
/// from a ZED one); `false` for anything it cannot read.
#[must_use]
pub fn holds_skeleton(bytes: &[u8]) -> bool {
    mat::read_arrays(bytes, "", &[VARIABLE]).is_ok_and(|arrays| !arrays.is_empty())
}

/// Reads a UTD-MHAD skeleton `.mat` file.
///
/// # Errors
/// [`UtdError::Mat`] ([`MatError::Io`]) if the file cannot be read, otherwise as [`parse`].
pub fn read(path: impl AsRef<Path>) -> Result<UtdClip, UtdError> {
    let (bytes, file) = mat::read_file(path.as_ref())?;
    parse(&bytes, &file)
}

/// Parses the bytes of a UTD-MHAD skeleton file; `source` names it in errors and the result.
///
/// # Errors
/// Any [`UtdError`] but [`MatError::Io`]; see the module docs.
pub fn parse(bytes: &[u8], source: &str) -> Result<UtdClip, UtdError> {
    let bad = |problem: String| UtdError::Skeleton {
        file: source.to_owned(),
        problem,
    };
    let mut arrays = mat::read_arrays(bytes, source, &[VARIABLE])?.into_iter();
    let array = arrays
        .next()
        .ok_or_else(|| bad("missing (not a UTD-MHAD skeleton file)".to_owned()))?;
    if let Some(again) = arrays.next() {
        return Err(bad(format!(
            "appears twice (again at byte {})",
            again.offset
        )));
    }
    let (mat::Values::Float(values), mat::Class::Double | mat::Class::Single, false) =
        (&array.values, array.class, array.complex)
    else {
        return Err(bad(format!(
            "wrong type: expected a real double or single array, found {}",
            array.describe_type()
        )));
    };
    let frames = match *array.dims.as_slice() {
        [JOINT_COUNT, 3, t] => t,
        [JOINT_COUNT, 3] => 1,
        _ => {
            return Err(bad(format!(
                "wrong shape: expected (20, 3, T), found {}",
                mat::shape(&array.dims)
            )));
        }
    };
    let joints_m = (0..frames)
        .map(|t| {
            let mut joints = [[f64::NAN; 3]; JOINT_COUNT];
            for (row, &j) in UTD_ORDER.iter().enumerate() {
                // Column-major: (row, c, t) at row + 20·(c + 3·t); the count was checked.
                let xyz: [f64; 3] = std::array::from_fn(|c| {
                    values
                        .get(row + JOINT_COUNT * (c + 3 * t))
                        .copied()
                        .unwrap_or(f64::NAN)
                });
                if xyz != [0.0; 3] {
                    joints[j] = xyz;
                }
            }
            joints
        })
        .collect();
    Ok(UtdClip {
        source: source.to_owned(),
        joints_m,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats::matlab::test_files::Mat;

    /// Row `row`, coordinate `c`, frame `t`: distinct values that say where they came from.
    fn value(row: usize, c: usize, t: usize) -> f64 {
        (row * 100 + c * 10 + t) as f64 / 1000.0 + 1.0
    }

    /// A file with `d_skel` of `dims` holding [`value`]s.
    fn file(dims: &[i32], big_endian: bool) -> Vec<u8> {
        let m = Mat::new(big_endian);
        let count = dims.iter().product::<i32>() as usize;
        let rows = dims[0] as usize;
        let data: Vec<f64> = (0..count)
            .map(|i| value(i % rows, (i / rows) % 3, i / (3 * rows)))
            .collect();
        Mat::new(big_endian)
            .push(m.matrix(6, dims, VARIABLE, 9, &m.f64s(&data)))
            .bytes
    }

    #[test]
    fn joints_are_read_column_major_and_put_in_the_sdk_order() {
        for big in [false, true] {
            let clip = parse(&file(&[20, 3, 4], big), "u.mat").unwrap();
            assert_eq!(clip.camera_joints_m().len(), 4);
            for (t, joints) in clip.camera_joints_m().iter().enumerate() {
                for (row, &j) in UTD_ORDER.iter().enumerate() {
                    let want = [value(row, 0, t), value(row, 1, t), value(row, 2, t)];
                    assert_eq!(joints[j], want, "frame {t} row {row}");
                }
            }
            // UTD's first row is the head, its fourth the hip centre.
            assert_eq!(JOINT_NAMES[UTD_ORDER[0]], "Head");
            assert_eq!(JOINT_NAMES[UTD_ORDER[3]], "HipCenter");
        }
        // One frame: MATLAB drops the trailing 1.
        assert_eq!(
            parse(&file(&[20, 3], false), "u.mat")
                .unwrap()
                .camera_joints_m()
                .len(),
            1
        );
    }

    #[test]
    fn the_pose_sequence_is_in_the_autoact_frame_at_the_rate_with_untracked_joints_missing() {
        let m = Mat::new(false);
        let mut data: Vec<f64> = (0..3 * JOINT_COUNT * 2).map(|i| 0.5 + i as f64).collect();
        // Frame 1, row 0 (the head) untracked: (0, 0, 0).
        for c in 0..3 {
            data[JOINT_COUNT * (c + 3)] = 0.0;
        }
        let bytes = Mat::new(false)
            .push(m.matrix(6, &[20, 3, 2], VARIABLE, 9, &m.f64s(&data)))
            .bytes;
        let seq = parse(&bytes, "u.mat").unwrap().to_pose_sequence(30.0);
        assert_eq!(seq.joint_names, JOINT_NAMES);
        assert_eq!(seq.frames[1].stamp_nanos, 33_333_333);
        let head = seq.joint_index("Head").unwrap();
        assert!(seq.frames[1].positions_m[head].x.is_nan());
        assert_eq!(seq.frames[1].confidence[head], 0.0);
        // Frame 0's head: (0.5, 20.5, 40.5) camera space; +Y up becomes +Z up.
        let p = seq.frames[0].positions_m[head];
        assert_eq!(
            p,
            AXES.point_to_autoact(nalgebra::Point3::new(0.5, 20.5, 40.5))
        );
        assert_eq!((p.z, seq.frames[0].confidence[head]), (20.5, 1.0));
    }

    #[test]
    fn a_file_without_a_skeleton_or_of_the_wrong_shape_or_type_is_refused_by_name() {
        let m = Mat::new(false);
        let other = m.matrix(6, &[1, 2], "keypoints", 9, &m.f64s(&[1.0, 2.0]));
        let e = parse(&Mat::new(false).push(other).bytes, "z.mat").unwrap_err();
        assert_eq!(
            e.to_string(),
            "z.mat: variable \"d_skel\": missing (not a UTD-MHAD skeleton file)"
        );
        assert!(!holds_skeleton(&Mat::new(false).bytes));
        assert!(holds_skeleton(&file(&[20, 3, 2], false)));
        let e = parse(&file(&[25, 3, 2], false), "k.mat").unwrap_err();
        assert_eq!(
            e.to_string(),
            "k.mat: variable \"d_skel\": wrong shape: expected (20, 3, T), found (25, 3, 2)"
        );
        let ints = m.matrix(12, &[20, 3], VARIABLE, 5, &vec![0; 4 * 60]);
        let e = parse(&Mat::new(false).push(ints).bytes, "i.mat").unwrap_err();
        assert_eq!(
            e.to_string(),
            "i.mat: variable \"d_skel\": wrong type: expected a real double or single array, found int32 array"
        );
        let one = m.matrix(6, &[20, 3], VARIABLE, 9, &m.f64s(&[1.0; 60]));
        let e = parse(&Mat::new(false).push(one.clone()).push(one).bytes, "d.mat").unwrap_err();
        assert!(
            e.to_string().contains("appears twice (again at byte "),
            "{e}"
        );
        assert!(matches!(
            parse(b"not a mat file", "n.mat"),
            Err(UtdError::Mat(MatError::NotMatV5 { .. }))
        ));
        assert!(matches!(
            read("/nonexistent/u.mat"),
            Err(UtdError::Mat(MatError::Io { .. }))
        ));
    }

    proptest::proptest! {
        #[test]
        fn damaged_files_never_panic(
            cut in 0_usize..2_000,
            flips in proptest::collection::vec((0_usize..2_000, proptest::num::u8::ANY), 0..4),
        ) {
            let mut bytes = file(&[20, 3, 3], false);
            for (at, b) in flips {
                let n = bytes.len();
                bytes[at % n] ^= b;
            }
            bytes.truncate(cut.min(bytes.len()));
            let _ = parse(&bytes, "p.mat");
        }
    }
}
