//! Reader and forward kinematics for the Human3.6M **exponential-map release** (the 99-column
//! text files used by Fragkiadaki et al., Jain et al. (S-RNN) and Martinez et al.
//! "human-motion-prediction", and redistributed by many motion-prediction repositories).
//!
//! # Format
//!
//! Plain text, one frame per line, **99 comma-separated floats**, **50 fps**. Columns are
//! numbered from 0 here (error messages count columns from 1, like lines):
//!
//! | columns            | meaning                                                              |
//! |--------------------|----------------------------------------------------------------------|
//! | 0–2                | root **translation delta** of this frame, mm, expressed in the root frame of the previous frame |
//! | 3–5                | root **rotation delta** of this frame, exp-map (axis·angle, radians)  |
//! | 3+3j … 5+3j, j ≥ 1 | exp-map of joint `j` relative to its parent ([`EXPMAP_COLUMN`])      |
//!
//! Row 0 has zero root deltas. Joints without a rotation channel in the reference skeleton
//! ([`HAS_ROTATION`] is `false`: the seven end-effector `Site`s) have all-zero columns in the
//! released files; their columns are kept in [`ExpmapClip::rows`] but ignored by FK. (Some other
//! joints — thumbs, wrist ends, the unused axes of knees and toes — are also always zero in the
//! data, but the reference skeleton gives them a rotation channel, so FK applies them.)
//! Blank lines are skipped; line numbers in errors are those of the file.
//!
//! # Skeleton
//!
//! The skeleton is not in the data files. It is the 32-joint Human3.6M tree: [`PARENTS`] and the
//! bone offsets [`OFFSETS_MM`] (mm, in the parent joint's frame, H36M axes). The numbers are
//! taken from `_some_variables()` in `src/forward_kinematics.py` of
//! `una-dinosauria/human-motion-prediction` (MIT licence; the same numbers are in
//! `limaosen0/DMGNN`, `h36m-short/processor/data_tools.py`, also MIT). Only the numbers were
//! taken: the parent list, the 32×3 offsets, the per-joint exp-map columns
//! (`expmapInd = 3+3j … 5+3j`) and which joints have an empty `rotInd` (no rotation). The code
//! in this module is our own.
//!
//! Joint names are the standard H36M 32-joint names ([`JOINT_NAMES`]), with the seven duplicate
//! `Site` end effectors renamed to be unique. As in BVH, a joint is named after the bone that
//! starts at it: `LArm` is the left shoulder joint, `LForeArm` the left elbow, `LHand` the left
//! wrist, `Spine1` the thorax. The usual 17-joint H36M subset is [`H36M_17_JOINTS`].
//!
//! # Forward kinematics
//!
//! The reference code uses **row vectors**: with `R[j] = expmap2rotmat(r_j) @ R[parent]` and
//! `xyz[j] = offset[j] @ R[parent] + xyz[parent]`. `expmap2rotmat` is Rodrigues' formula (the
//! usual column-vector rotation by |r| about r/|r|). Transposing, this module computes with
//! nalgebra column vectors and the rotation `world_from_joint` `W[j] = R[j]ᵀ`:
//!
//! * `W[j] = W[parent] · exp(r_j)ᵀ` — the joint's local rotation `parent_from_joint` is
//!   `exp(r_j)ᵀ = exp(−r_j)`;
//! * `p[j] = p[parent] + W[parent] · offset[j]`.
//!
//! The unit tests check this against a literal row-vector implementation of the reference
//! formulas. (The reference `fkl` also adds `angles[rotInd[j]]` to each offset, a leftover of
//! an older channel layout that adds the joint's own exp-map values, in radians, to offsets in
//! mm; it moves joints by at most a few mm and we do not reproduce it.)
//!
//! At rest (all exp-maps zero) every bone is aligned with the H36M axes: legs point down (−Y),
//! spine, neck and arms point up (+Y), feet point forward (+Z), the left hip is at +X. The
//! figure is 1.62 m from the ankles to the head top at rest, and 1.5–1.6 m tall (head top above
//! the lowest foot joint) in the real standing frames once levelled.
//!
//! # Root: [`RootMode`]
//!
//! * [`RootMode::Centred`]: columns 0–5 are treated as zero, as the motion-prediction papers do:
//!   the hip stays at the origin with the identity root rotation. The pelvis frame of the H36M
//!   skeleton is not upright in the world, so in this mode the figure leans back by 15–21° on
//!   the S1 clips (hips flexed and spine extended relative to the pelvis); this is how the
//!   reference renders it.
//! * [`RootMode::Trajectory`]: the root deltas are integrated as in `revert_coordinate_space` of
//!   the reference code (a port of S-RNN's `revertCoordinateSpace.m`), whose row-vector
//!   recursion is `R_k = expmap(ω_k) @ R_{k−1}`, `T_k = T_{k−1} + R_{k−1}ᵀ d_k`. In
//!   column-vector terms, with `W_k = R_kᵀ` the root's `world_from_root`:
//!   `T_k = T_{k−1} + W_{k−1} · d_k` (the translation delta is expressed in the previous root
//!   frame) and `W_k = W_{k−1} · exp(ω_k)ᵀ` (the rotation delta is composed on the root side).
//!   The hip is at `T_k`. (The reference `fkl` takes the root position from `rotInd[0]`, which
//!   points at the rotation columns 4, 5, 3, so its plots never travel; we use `T_k`.)
//!
//!   The delta encoding loses the absolute orientation of the first frame; the reference starts
//!   from `R_0 = I`, which leaves the whole trajectory tilted by the pelvis tilt (about 20° on the
//!   S1 clips: walking would climb and sink by more than a metre). We start instead from
//!   `W_{−1} =` [`ExpmapClip::levelling_source`], the smallest rotation that makes frame 0's
//!   axis from the mid-point of the ankles to the head top vertical, with `T_{−1} = 0`. This
//!   assumes the subject stands (or walks) upright in frame 0, as in the S1 clips checked.
//!   Because the deltas compose on the right, the start rotation only rotates the trajectory
//!   rigidly; on S1 walking the integrated hip path is planar to 14 mm RMS and its plane normal is
//!   1.5° from the levelled vertical, which supports both the recursion and the levelling.
//!
//! # Units and axes
//!
//! Raw values and [`OFFSETS_MM`] are millimetres in H36M axes: right-handed, **+Y up**, the
//! rest-pose body facing +Z. Outputs ([`ExpmapClip::to_pose_sequence`],
//! [`ExpmapClip::positions_m`], [`ExpmapClip::world_rotations`]) are metres in the autoact frame,
//! converted once through [`SourceAxes::YUp`] (a proper rotation, so left stays left). H36M +Z
//! becomes autoact +Y, so the rest pose faces autoact +Y as the autoact convention wants. The hip of frame 0 is
//! at the origin in both modes; nothing is moved onto the ground plane.

use std::fmt;
use std::path::{Path, PathBuf};

use nalgebra::{Point3, Unit, UnitQuaternion, Vector3};

use crate::skeleton::frames::SourceAxes;
use crate::skeleton::pose::{PoseFrame, PoseSequence, stamp_nanos_at};

/// Number of joints in the H36M skeleton.
pub const JOINT_COUNT: usize = 32;

/// Number of comma-separated values per line.
pub const COLUMNS: usize = 99;

/// Frame rate of the release, frames per second.
pub const FPS: f64 = 50.0;

/// The axis convention of the raw data and of [`OFFSETS_MM`].
pub const SOURCE_AXES: SourceAxes = SourceAxes::YUp;

/// The usual 17-joint Human3.6M subset, as indices of the 32 joints, in the order of the
/// `h36m-17` layout (MMPose, VideoPose3D, MotionBERT).
pub const H36M_17_JOINTS: [usize; 17] =
    [0, 1, 2, 3, 6, 7, 8, 12, 13, 14, 15, 17, 18, 19, 25, 26, 27];

/// Joint names, index = joint. The standard H36M 32-joint names, with the duplicate `Site` end
/// effectors renamed: 5 `RToeSite`, 10 `LToeSite`, 15 `HeadSite`, 21 `LThumbSite`,
/// 23 `LWristSite` (end of `L_Wrist_End`), 29 `RThumbSite`, 31 `RWristSite` (end of
/// `R_Wrist_End`).
pub const JOINT_NAMES: [&str; JOINT_COUNT] = [
    "Hip",         // 0
    "RHip",        // 1
    "RKnee",       // 2
    "RFoot",       // 3
    "RToeBase",    // 4
    "RToeSite",    // 5
    "LHip",        // 6
    "LKnee",       // 7
    "LFoot",       // 8
    "LToeBase",    // 9
    "LToeSite",    // 10
    "Spine",       // 11
    "Spine1",      // 12
    "Neck",        // 13
    "Head",        // 14
    "HeadSite",    // 15
    "LShoulder",   // 16
    "LArm",        // 17
    "LForeArm",    // 18
    "LHand",       // 19
    "LHandThumb",  // 20
    "LThumbSite",  // 21
    "L_Wrist_End", // 22
    "LWristSite",  // 23
    "RShoulder",   // 24
    "RArm",        // 25
    "RForeArm",    // 26
    "RHand",       // 27
    "RHandThumb",  // 28
    "RThumbSite",  // 29
    "R_Wrist_End", // 30
    "RWristSite",  // 31
];

/// Joints used to level the trajectory (ankles and head top).
const RFOOT: usize = 3;
const LFOOT: usize = 8;
const HEAD_SITE: usize = 15;

// Skeleton numbers (parents, offsets, rotation channels) from
// una-dinosauria/human-motion-prediction, src/forward_kinematics.py, `_some_variables()`,
// MIT licence (identical in limaosen0/DMGNN, h36m-short/processor/data_tools.py, MIT).
// Parents converted from the 1-based list there to 0-based indices.

/// Parent of each joint (`None` for the root, joint 0 `Hip`). Every parent index is smaller
/// than its child's.
pub const PARENTS: [Option<usize>; JOINT_COUNT] = [
    None,
    Some(0),
    Some(1),
    Some(2),
    Some(3),
    Some(4),
    Some(0),
    Some(6),
    Some(7),
    Some(8),
    Some(9),
    Some(0),
    Some(11),
    Some(12),
    Some(13),
    Some(14),
    Some(12),
    Some(16),
    Some(17),
    Some(18),
    Some(19),
    Some(20),
    Some(19),
    Some(22),
    Some(12),
    Some(24),
    Some(25),
    Some(26),
    Some(27),
    Some(28),
    Some(27),
    Some(30),
];

/// Bone offsets: the position of each joint in its parent's frame, millimetres, H36M axes
/// (+Y up, rest pose facing +Z). Joint 0's offset is zero.
#[allow(
    clippy::unreadable_literal,
    reason = "the numbers as printed in the reference"
)]
pub const OFFSETS_MM: [[f64; 3]; JOINT_COUNT] = [
    [0.0, 0.0, 0.0],
    [-132.948591, 0.0, 0.0],
    [0.0, -442.894612, 0.0],
    [0.0, -454.206447, 0.0],
    [0.0, 0.0, 162.767078],
    [0.0, 0.0, 74.999437],
    [132.948826, 0.0, 0.0],
    [0.0, -442.894413, 0.0],
    [0.0, -454.206590, 0.0],
    [0.0, 0.0, 162.767426],
    [0.0, 0.0, 74.999948],
    [0.0, 0.1, 0.0],
    [0.0, 233.383263, 0.0],
    [0.0, 257.077681, 0.0],
    [0.0, 121.134938, 0.0],
    [0.0, 115.002227, 0.0],
    [0.0, 257.077681, 0.0],
    [0.0, 151.034226, 0.0],
    [0.0, 278.882773, 0.0],
    [0.0, 251.733451, 0.0],
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 99.999627],
    [0.0, 100.000188, 0.0],
    [0.0, 0.0, 0.0],
    [0.0, 257.077681, 0.0],
    [0.0, 151.031437, 0.0],
    [0.0, 278.892924, 0.0],
    [0.0, 251.728680, 0.0],
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 99.999888],
    [0.0, 137.499922, 0.0],
    [0.0, 0.0, 0.0],
];

/// First of the three columns holding each joint's exp-map: `3 + 3·j` (`expmapInd` of the
/// reference). For joint 0 these are the root rotation-delta columns.
pub const EXPMAP_COLUMN: [usize; JOINT_COUNT] = {
    let mut columns = [0; JOINT_COUNT];
    let mut j = 0;
    while j < JOINT_COUNT {
        columns[j] = 3 + 3 * j;
        j += 1;
    }
    columns
};

/// Whether a joint has a rotation channel in the reference skeleton (non-empty `rotInd`). The
/// seven `Site` end effectors (5, 10, 15, 21, 23, 29, 31) have none: their local rotation is the
/// identity whatever their columns hold.
pub const HAS_ROTATION: [bool; JOINT_COUNT] = {
    let mut has = [true; JOINT_COUNT];
    has[5] = false;
    has[10] = false;
    has[15] = false;
    has[21] = false;
    has[23] = false;
    has[29] = false;
    has[31] = false;
    has
};

/// The offset of `joint` from its parent in the autoact frame, metres: the vector `v` with
/// `position(joint) = position(parent) + world_rotations(parent) · v`.
///
/// # Panics
///
/// If `joint >= JOINT_COUNT`.
#[must_use]
pub fn offset_autoact_m(joint: usize) -> Vector3<f64> {
    SOURCE_AXES.to_autoact(Vector3::from(OFFSETS_MM[joint])) / 1000.0
}

/// How the root (hip) moves.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum RootMode {
    /// Root deltas (columns 0–5) treated as zero: hip fixed at the origin, identity root
    /// rotation. The motion-prediction convention.
    #[default]
    Centred,
    /// Root deltas integrated into a global trajectory starting at the origin, levelled so that
    /// frame 0 stands upright (see the module documentation for the exact recursion).
    Trajectory,
}

/// An error reading an exp-map file. Lines and columns are 1-based (column 1 is the value the
/// module documentation calls column 0).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum H36mError {
    /// The file could not be read (missing, unreadable, not UTF-8).
    #[error("cannot read h36m exp-map file {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        #[source]
        source: std::io::Error,
    },
    /// A line does not have 99 values.
    #[error("{file}: line {line}: expected {COLUMNS} columns, found {found}")]
    ColumnCount {
        /// The file (or source description).
        file: String,
        /// 1-based line number.
        line: usize,
        /// Number of comma-separated fields found.
        found: usize,
    },
    /// A field is not a number.
    #[error("{file}: line {line}, column {column}: not a number: {text:?}")]
    NotNumeric {
        /// The file (or source description).
        file: String,
        /// 1-based line number.
        line: usize,
        /// 1-based column number.
        column: usize,
        /// The offending field (trimmed, at most 40 characters).
        text: String,
    },
    /// A field is NaN or infinite (or overflows `f64`).
    #[error("{file}: line {line}, column {column}: non-finite value {text:?}")]
    NonFinite {
        /// The file (or source description).
        file: String,
        /// 1-based line number.
        line: usize,
        /// 1-based column number.
        column: usize,
        /// The offending field (trimmed, at most 40 characters).
        text: String,
    },
    /// The file has no frames.
    #[error("{file}: empty file, no frames")]
    Empty {
        /// The file (or source description).
        file: String,
    },
}

/// One exp-map clip: the raw rows, plus the integrated root trajectory.
#[derive(Clone, PartialEq)]
pub struct ExpmapClip {
    source: String,
    rows: Vec<[f64; COLUMNS]>,
    /// `world_from_root` of each frame for [`RootMode::Trajectory`]: rotation and translation
    /// (mm), H36M axes.
    trajectory: Vec<(UnitQuaternion<f64>, Vector3<f64>)>,
}

impl fmt::Debug for ExpmapClip {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("ExpmapClip")
            .field("source", &self.source)
            .field("frames", &self.rows.len())
            .finish_non_exhaustive()
    }
}

/// Forward kinematics of one frame in the source convention: H36M axes, millimetres.
#[derive(Debug, Clone, PartialEq)]
pub struct SourceFk {
    /// Joint positions, mm, H36M axes.
    pub positions_mm: [Point3<f64>; JOINT_COUNT],
    /// Joint orientations `world_from_joint`, H36M axes (the rotation whose matrix is the
    /// transpose of the reference's row-vector `R[j]`).
    pub world_from_joint: [UnitQuaternion<f64>; JOINT_COUNT],
}

/// Parse the text of an exp-map file; `source` names it in errors and in the output.
///
/// # Errors
///
/// [`H36mError`] for a line without 99 values, a value that is not a number or not finite, or
/// a text without any (non-blank) line.
pub fn parse(text: &str, source: &str) -> Result<ExpmapClip, H36mError> {
    let mut rows = Vec::new();
    for (index, line) in text.lines().enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let line_number = index + 1;
        let found = line.split(',').count();
        if found != COLUMNS {
            return Err(H36mError::ColumnCount {
                file: source.to_owned(),
                line: line_number,
                found,
            });
        }
        let mut row = [0.0; COLUMNS];
        for (column, (slot, field)) in row.iter_mut().zip(line.split(',')).enumerate() {
            let field = field.trim();
            let shown = || field.chars().take(40).collect::<String>();
            let value: f64 = field.parse().map_err(|_| H36mError::NotNumeric {
                file: source.to_owned(),
                line: line_number,
                column: column + 1,
                text: shown(),
            })?;
            if !value.is_finite() {
                return Err(H36mError::NonFinite {
                    file: source.to_owned(),
                    line: line_number,
                    column: column + 1,
                    text: shown(),
                });
            }
            *slot = value;
        }
        rows.push(row);
    }
    if rows.is_empty() {
        return Err(H36mError::Empty {
            file: source.to_owned(),
        });
    }
    let trajectory = integrate_root(&rows);
    Ok(ExpmapClip {
        source: source.to_owned(),
        rows,
        trajectory,
    })
}

/// A clip's own joint motion (positions and world rotations per frame), what
/// [`crate::skeleton::eval::twist_spin`] compares a conversion with.
#[must_use]
pub fn source_motion(clip: &ExpmapClip, root: RootMode) -> crate::skeleton::eval::SourceMotion {
    crate::skeleton::eval::SourceMotion {
        parents: PARENTS.to_vec(),
        frames: (0..clip.frame_count())
            .map(|f| {
                clip.positions_m(f, root)
                    .into_iter()
                    .zip(clip.world_rotations(f, root))
                    .collect()
            })
            .collect(),
    }
}

/// Read and parse an exp-map file.
///
/// # Errors
///
/// [`H36mError::Io`] if the file cannot be read as UTF-8 text, otherwise as [`parse`].
pub fn read(path: impl AsRef<Path>) -> Result<ExpmapClip, H36mError> {
    let path = path.as_ref();
    let text = crate::text_file::read_to_string(path).map_err(|source| H36mError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse(&text, &path.display().to_string())
}

/// The rotation of an exp-map (axis·angle) in the usual column-vector sense — the rotation whose
/// matrix is the reference's `expmap2rotmat`. Robust to zero and to very large finite vectors.
fn expmap_rotation(r: Vector3<f64>) -> UnitQuaternion<f64> {
    let scale = r.amax();
    if scale == 0.0 || !scale.is_finite() {
        return UnitQuaternion::identity();
    }
    let scaled = r / scale;
    let scaled_norm = scaled.norm();
    let angle = (scale * scaled_norm).rem_euclid(std::f64::consts::TAU);
    UnitQuaternion::from_axis_angle(&Unit::new_unchecked(scaled / scaled_norm), angle)
}

fn vec_at(row: &[f64; COLUMNS], column: usize) -> Vector3<f64> {
    Vector3::new(row[column], row[column + 1], row[column + 2])
}

/// Forward kinematics of one row with the given root pose (H36M axes, mm); the row's root
/// columns are not used.
fn fk_row(
    row: &[f64; COLUMNS],
    root_rotation: UnitQuaternion<f64>,
    root_translation: Vector3<f64>,
) -> SourceFk {
    let mut positions_mm = [Point3::origin(); JOINT_COUNT];
    let mut world_from_joint = [UnitQuaternion::identity(); JOINT_COUNT];
    positions_mm[0] = Point3::from(root_translation + Vector3::from(OFFSETS_MM[0]));
    world_from_joint[0] = root_rotation;
    for joint in 1..JOINT_COUNT {
        let Some(parent) = PARENTS[joint] else {
            continue;
        };
        let parent_rotation = world_from_joint[parent];
        positions_mm[joint] =
            positions_mm[parent] + parent_rotation * Vector3::from(OFFSETS_MM[joint]);
        world_from_joint[joint] = if HAS_ROTATION[joint] {
            parent_rotation * expmap_rotation(vec_at(row, EXPMAP_COLUMN[joint])).inverse()
        } else {
            parent_rotation
        };
    }
    SourceFk {
        positions_mm,
        world_from_joint,
    }
}

/// The levelling rotation: the smallest rotation taking the frame-0 body axis (from the mid-point
/// of the ankles to the head end, with the identity root) onto H36M +Y. Identity if that axis is
/// degenerate or points straight down.
fn levelling(first_row: &[f64; COLUMNS]) -> UnitQuaternion<f64> {
    let fk = fk_row(first_row, UnitQuaternion::identity(), Vector3::zeros());
    let p = &fk.positions_mm;
    let ankles = (p[RFOOT].coords + p[LFOOT].coords) / 2.0;
    let axis = p[HEAD_SITE].coords - ankles;
    UnitQuaternion::rotation_between(&axis, &Vector3::y()).unwrap_or_else(UnitQuaternion::identity)
}

/// `world_from_root` per frame: `T_k = T_{k−1} + W_{k−1} d_k`, `W_k = W_{k−1} exp(ω_k)ᵀ`, from
/// `W_{−1} = levelling`, `T_{−1} = 0`.
fn integrate_root(rows: &[[f64; COLUMNS]]) -> Vec<(UnitQuaternion<f64>, Vector3<f64>)> {
    let Some(first) = rows.first() else {
        return Vec::new();
    };
    let mut world_from_root = levelling(first);
    let mut translation = Vector3::zeros();
    rows.iter()
        .map(|row| {
            translation += world_from_root * vec_at(row, 0);
            world_from_root *= expmap_rotation(vec_at(row, 3)).inverse();
            // Keep the product a unit quaternion over thousands of frames.
            world_from_root.renormalize();
            (world_from_root, translation)
        })
        .collect()
}

impl ExpmapClip {
    /// Where the clip came from.
    #[must_use]
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Number of frames (never 0).
    #[must_use]
    pub fn frame_count(&self) -> usize {
        self.rows.len()
    }

    /// The raw values, one row of 99 per frame, unchanged.
    #[must_use]
    pub fn rows(&self) -> &[[f64; COLUMNS]] {
        &self.rows
    }

    /// The raw exp-map of `joint` in `frame` (for joint 0: the root rotation delta).
    ///
    /// # Panics
    ///
    /// If `frame >= frame_count()` or `joint >= JOINT_COUNT`.
    #[must_use]
    pub fn expmap(&self, frame: usize, joint: usize) -> Vector3<f64> {
        vec_at(&self.rows[frame], EXPMAP_COLUMN[joint])
    }

    /// The raw root translation delta of `frame`, mm, in the previous frame's root frame.
    ///
    /// # Panics
    ///
    /// If `frame >= frame_count()`.
    #[must_use]
    pub fn root_translation_delta_mm(&self, frame: usize) -> Vector3<f64> {
        vec_at(&self.rows[frame], 0)
    }

    /// The levelling rotation that starts the [`RootMode::Trajectory`] integration (H36M axes):
    /// the smallest rotation that makes frame 0's ankles-to-head-top axis vertical.
    #[must_use]
    pub fn levelling_source(&self) -> UnitQuaternion<f64> {
        self.rows
            .first()
            .map_or_else(UnitQuaternion::identity, levelling)
    }

    /// The root's `world_from_root` of `frame` in H36M axes: rotation and translation (mm).
    ///
    /// # Panics
    ///
    /// If `frame >= frame_count()`.
    #[must_use]
    pub fn root_pose_source(
        &self,
        frame: usize,
        root: RootMode,
    ) -> (UnitQuaternion<f64>, Vector3<f64>) {
        match root {
            RootMode::Centred => {
                // Index anyway so that an out-of-range frame panics in both modes.
                let _ = &self.rows[frame];
                (UnitQuaternion::identity(), Vector3::zeros())
            }
            RootMode::Trajectory => self.trajectory[frame],
        }
    }

    /// Forward kinematics of `frame` in the source convention (H36M axes, mm).
    ///
    /// # Panics
    ///
    /// If `frame >= frame_count()`.
    #[must_use]
    pub fn forward_kinematics_source(&self, frame: usize, root: RootMode) -> SourceFk {
        let (root_rotation, root_translation) = self.root_pose_source(frame, root);
        fk_row(&self.rows[frame], root_rotation, root_translation)
    }

    /// Joint positions of `frame`, metres, autoact frame.
    ///
    /// # Panics
    ///
    /// If `frame >= frame_count()`.
    #[must_use]
    pub fn positions_m(&self, frame: usize, root: RootMode) -> [Point3<f64>; JOINT_COUNT] {
        let fk = self.forward_kinematics_source(frame, root);
        fk.positions_mm
            .map(|p| SOURCE_AXES.point_to_autoact(p) / 1000.0)
    }

    /// Ground-truth joint orientations of `frame`, each `world_from_joint` in the autoact frame:
    /// the H36M orientation re-expressed by the change of basis
    /// [`SourceAxes::orientation_to_autoact`], so that the identity is the rest pose and
    /// `position(j) = position(parent) + world_rotations[parent] · offset_autoact_m(j)`.
    ///
    /// # Panics
    ///
    /// If `frame >= frame_count()`.
    #[must_use]
    pub fn world_rotations(
        &self,
        frame: usize,
        root: RootMode,
    ) -> [UnitQuaternion<f64>; JOINT_COUNT] {
        let fk = self.forward_kinematics_source(frame, root);
        fk.world_from_joint
            .map(|q| SOURCE_AXES.orientation_to_autoact(q))
    }

    /// All frames as a [`PoseSequence`]: the 32 [`JOINT_NAMES`], metres, autoact frame, stamps at
    /// 50 fps from 0, confidence 1, track id 0.
    #[must_use]
    pub fn to_pose_sequence(&self, root: RootMode) -> PoseSequence {
        let frames = (0..self.rows.len())
            .map(|frame| PoseFrame {
                stamp_nanos: stamp_nanos_at(frame, FPS),
                positions_m: self.positions_m(frame, root).to_vec(),
                confidence: vec![1.0; JOINT_COUNT],
            })
            .collect();
        PoseSequence {
            source: self.source.clone(),
            track_id: 0,
            joint_names: JOINT_NAMES.iter().map(|&n| n.to_owned()).collect(),
            frames,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, RowVector3};
    use proptest::prelude::*;

    fn line(values: &[f64; COLUMNS]) -> String {
        values
            .iter()
            .map(|v| format!("{v:.7}"))
            .collect::<Vec<_>>()
            .join(",")
    }

    fn clip(rows: &[[f64; COLUMNS]]) -> ExpmapClip {
        let text = rows.iter().map(line).collect::<Vec<_>>().join("\n") + "\n";
        parse(&text, "synthetic").expect("synthetic text parses")
    }

    fn descendants_of(joint: usize) -> Vec<bool> {
        (0..JOINT_COUNT)
            .map(|j| {
                let mut k = j;
                while let Some(p) = PARENTS[k] {
                    if p == joint {
                        return true;
                    }
                    k = p;
                }
                false
            })
            .collect()
    }

    /// Rodrigues' formula written out, as the reference's `expmap2rotmat`.
    fn rodrigues(r: Vector3<f64>) -> Matrix3<f64> {
        let theta = r.norm();
        if theta == 0.0 {
            return Matrix3::identity();
        }
        let k = r / theta;
        let kx = Matrix3::new(0.0, -k.z, k.y, k.z, 0.0, -k.x, -k.y, k.x, 0.0);
        Matrix3::identity() + kx * theta.sin() + kx * kx * (1.0 - theta.cos())
    }

    /// The reference's row-vector FK and root integration, written literally, for comparison.
    fn reference_row_fk(
        rows: &[[f64; COLUMNS]],
        frame: usize,
        trajectory: bool,
    ) -> Vec<RowVector3<f64>> {
        // revert_coordinate_space with R0 = levellingᵀ (row-vector form of our start), T0 = 0.
        let r0 = levelling(&rows[0])
            .to_rotation_matrix()
            .matrix()
            .transpose();
        let (mut r_prev, mut t_prev) = (r0, RowVector3::zeros());
        for row in &rows[..=frame] {
            let d = Vector3::new(row[0], row[1], row[2]);
            let r = rodrigues(vec_at(row, 3)) * r_prev;
            let t = t_prev + (r_prev.transpose() * d).transpose();
            (r_prev, t_prev) = (r, t);
        }
        let row = &rows[frame];
        let mut rot = vec![Matrix3::identity(); JOINT_COUNT];
        let mut xyz = vec![RowVector3::zeros(); JOINT_COUNT];
        if trajectory {
            rot[0] = r_prev;
            xyz[0] = t_prev;
        }
        for j in 1..JOINT_COUNT {
            let p = PARENTS[j].expect("non-root");
            let offset = RowVector3::new(OFFSETS_MM[j][0], OFFSETS_MM[j][1], OFFSETS_MM[j][2]);
            xyz[j] = offset * rot[p] + xyz[p];
            let local = if HAS_ROTATION[j] {
                rodrigues(vec_at(row, EXPMAP_COLUMN[j]))
            } else {
                Matrix3::identity()
            };
            rot[j] = local * rot[p];
        }
        xyz
    }

    fn pseudo_random_rows(n: usize, seed: u64) -> Vec<[f64; COLUMNS]> {
        // A small LCG: deterministic values in [-1.5, 1.5] (translations in [-150, 150] mm).
        let mut state = seed;
        let mut next = move || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            f64::from(u32::try_from(state >> 40).expect("24 bits")) / f64::from(1u32 << 24) * 3.0
                - 1.5
        };
        (0..n)
            .map(|_| {
                let mut row = [0.0; COLUMNS];
                for (c, v) in row.iter_mut().enumerate() {
                    *v = if c < 3 { next() * 100.0 } else { next() };
                }
                row
            })
            .collect()
    }

    #[test]
    fn all_zero_line_is_the_rest_pose() {
        let c = clip(&[[0.0; COLUMNS]]);
        assert_eq!(c.frame_count(), 1);
        for root in [RootMode::Centred, RootMode::Trajectory] {
            let p = c.positions_m(0, root);
            let q = c.world_rotations(0, root);
            for j in 1..JOINT_COUNT {
                let parent = PARENTS[j].expect("non-root");
                let length = (p[j] - p[parent]).norm();
                let expected = Vector3::from(OFFSETS_MM[j]).norm() / 1000.0;
                assert!(
                    (length - expected).abs() < 1e-12,
                    "{}: {length} vs {expected}",
                    JOINT_NAMES[j]
                );
                assert!(q[j].angle() < 1e-6);
            }
            assert!(p[0].coords.norm() < 1e-12);
            // Rest pose: head above hip along autoact +Z, left hip at −X (the autoact
            // convention: +X is the body's right).
            assert!(p[15].z > 0.6 && p[3].z < -0.8);
            assert!(p[6].x < -0.1 && p[1].x > 0.1);
            // Toes forward: H36M +Z is autoact +Y.
            assert!(p[4].y > p[3].y + 0.1);
        }
    }

    #[test]
    fn one_rotation_moves_exactly_the_descendants() {
        let rest = clip(&[[0.0; COLUMNS]]).positions_m(0, RootMode::Centred);
        // Left elbow (LForeArm, 18): 90° about H36M +X.
        let joint = 18;
        let mut row = [0.0; COLUMNS];
        row[EXPMAP_COLUMN[joint]] = std::f64::consts::FRAC_PI_2;
        let moved = clip(&[row]).positions_m(0, RootMode::Centred);
        let below = descendants_of(joint);
        for j in 0..JOINT_COUNT {
            let shift = (moved[j] - rest[j]).norm();
            if below[j] {
                assert!(shift > 1e-3, "{} should move", JOINT_NAMES[j]);
            } else {
                assert!(
                    shift < 1e-12,
                    "{} should not move ({shift})",
                    JOINT_NAMES[j]
                );
            }
        }
        // The wrist (LHand, 19) is 0.2517 m along H36M +Y from the elbow at rest (autoact +Z).
        // Row-vector convention: offset @ expmap2rotmat(+90° about x) maps +Y to −Z (H36M),
        // which is autoact −Y. (π/2 is written with 7 decimals, hence the tolerance.)
        let wrist = moved[19] - moved[18];
        let len = OFFSETS_MM[19][1] / 1000.0;
        assert!(
            (wrist - Vector3::new(0.0, -len, 0.0)).norm() < 1e-7,
            "{wrist:?}"
        );
        // A fixed joint's columns are ignored.
        let mut row = [0.0; COLUMNS];
        row[EXPMAP_COLUMN[15]] = 1.0;
        let fixed = clip(&[row]);
        assert_eq!(fixed.positions_m(0, RootMode::Centred), rest);
        assert_eq!(
            fixed.world_rotations(0, RootMode::Centred)[15],
            UnitQuaternion::identity()
        );
        assert_eq!(fixed.expmap(0, 15), Vector3::new(1.0, 0.0, 0.0));
    }

    #[test]
    fn fk_matches_the_row_vector_reference() {
        let rows = pseudo_random_rows(6, 7);
        let c = clip(&rows);
        // Re-read the rounded values the parser saw.
        let rows = c.rows().to_vec();
        for frame in 0..rows.len() {
            for (root, trajectory) in [(RootMode::Centred, false), (RootMode::Trajectory, true)] {
                let ours = c.forward_kinematics_source(frame, root);
                let reference = reference_row_fk(&rows, frame, trajectory);
                for (j, expected) in reference.iter().enumerate() {
                    let diff = (ours.positions_mm[j].coords - expected.transpose()).norm();
                    assert!(diff < 1e-9, "frame {frame} joint {j} {root:?}: {diff}");
                }
            }
        }
    }

    #[test]
    fn trajectory_integrates_deltas_in_the_previous_root_frame() {
        let mut rows = vec![[0.0; COLUMNS]; 3];
        // Frame 1: step 100 mm along root +Z, then turn 90° (row-vector expmap about +Y).
        rows[1][2] = 100.0;
        rows[1][4] = std::f64::consts::FRAC_PI_2;
        // Frame 2: step 100 mm along the (turned) root +Z.
        rows[2][2] = 100.0;
        let c = clip(&rows);
        let (_, t1) = c.root_pose_source(1, RootMode::Trajectory);
        let (w2, t2) = c.root_pose_source(2, RootMode::Trajectory);
        assert!((t1 - Vector3::new(0.0, 0.0, 100.0)).norm() < 1e-4);
        // W1 = exp(ω)ᵀ = rotation of −90° about +Y: root +Z → world −X.
        assert!(
            (t2 - Vector3::new(-100.0, 0.0, 100.0)).norm() < 1e-4,
            "{t2:?}"
        );
        assert!((w2 * Vector3::z() - Vector3::new(-1.0, 0.0, 0.0)).norm() < 1e-6);
        // Centred ignores the deltas.
        assert_eq!(
            c.positions_m(2, RootMode::Centred),
            c.positions_m(0, RootMode::Centred)
        );
    }

    #[test]
    fn trajectory_levels_a_leaning_first_frame() {
        let mut row = [0.0; COLUMNS];
        // Hips flexed and spine extended relative to the pelvis, like the real data.
        row[EXPMAP_COLUMN[1]] = 0.35;
        row[EXPMAP_COLUMN[6]] = 0.35;
        row[EXPMAP_COLUMN[11]] = 0.5;
        let c = clip(&[row, [0.0; COLUMNS]]);
        let axis = |p: &[Point3<f64>; JOINT_COUNT]| {
            (p[HEAD_SITE].coords - (p[RFOOT].coords + p[LFOOT].coords) / 2.0).normalize()
        };
        let centred = axis(&c.positions_m(0, RootMode::Centred));
        let levelled = axis(&c.positions_m(0, RootMode::Trajectory));
        assert!(centred.angle(&Vector3::z()) > 0.2, "{centred:?}");
        assert!(levelled.angle(&Vector3::z()) < 1e-9, "{levelled:?}");
        // Only a rigid rotation: same shape in both modes.
        let a = c.positions_m(0, RootMode::Centred);
        let b = c.positions_m(0, RootMode::Trajectory);
        for j in 1..JOINT_COUNT {
            assert!(((a[j] - a[0]).norm() - (b[j] - b[0]).norm()).abs() < 1e-12);
        }
        assert!(c.levelling_source().angle() > 0.2);
        // The rest pose is upright up to the 0.2 µm asymmetry of the hip offsets.
        assert!(clip(&[[0.0; COLUMNS]]).levelling_source().angle() < 1e-6);
    }

    #[test]
    fn world_rotations_are_consistent_with_positions() {
        let c = clip(&pseudo_random_rows(4, 11));
        for frame in 0..c.frame_count() {
            for root in [RootMode::Centred, RootMode::Trajectory] {
                let p = c.positions_m(frame, root);
                let q = c.world_rotations(frame, root);
                for j in 1..JOINT_COUNT {
                    let parent = PARENTS[j].expect("non-root");
                    let predicted = p[parent] + q[parent] * offset_autoact_m(j);
                    assert!((predicted - p[j]).norm() < 1e-12);
                }
            }
        }
    }

    #[test]
    fn pose_sequence_has_names_stamps_and_confidence() {
        let c = clip(&pseudo_random_rows(3, 3));
        let seq = c.to_pose_sequence(RootMode::Trajectory);
        assert_eq!(seq.joint_names.len(), JOINT_COUNT);
        assert_eq!(seq.source, "synthetic");
        let stamps: Vec<u64> = seq.frames.iter().map(|f| f.stamp_nanos).collect();
        assert_eq!(stamps, vec![0, 20_000_000, 40_000_000]);
        assert!(
            seq.frames
                .iter()
                .all(|f| f.confidence == vec![1.0; JOINT_COUNT])
        );
        let mut names = JOINT_NAMES.to_vec();
        names.sort_unstable();
        names.dedup();
        assert_eq!(names.len(), JOINT_COUNT, "joint names are unique");
        for (j, parent) in PARENTS.iter().enumerate() {
            assert!(parent.is_none_or(|p| p < j));
        }
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let good = line(&[0.0; COLUMNS]);
        let short = vec!["0"; 98].join(",");
        let err = parse(&format!("{good}\n\n{short}\n"), "a.txt").expect_err("short line");
        assert!(
            matches!(
                err,
                H36mError::ColumnCount {
                    line: 3,
                    found: 98,
                    ..
                }
            ),
            "{err:?}"
        );
        assert_eq!(
            err.to_string(),
            "a.txt: line 3: expected 99 columns, found 98"
        );

        let mut fields = vec!["0"; COLUMNS];
        fields[4] = "abc";
        let err = parse(&format!("{good}\r\n{}\r\n", fields.join(",")), "b.txt").expect_err("text");
        assert!(
            matches!(
                err,
                H36mError::NotNumeric {
                    line: 2,
                    column: 5,
                    ..
                }
            ),
            "{err:?}"
        );
        assert_eq!(
            err.to_string(),
            "b.txt: line 2, column 5: not a number: \"abc\""
        );

        fields[4] = "0";
        for bad in ["NaN", "1e400"] {
            fields[98] = bad;
            let err = parse(&fields.join(","), "c.txt").expect_err(bad);
            assert!(
                matches!(
                    err,
                    H36mError::NonFinite {
                        line: 1,
                        column: 99,
                        ..
                    }
                ),
                "{bad}: {err:?}"
            );
            assert!(
                err.to_string()
                    .starts_with("c.txt: line 1, column 99: non-finite"),
                "{err}"
            );
        }

        for empty in ["", "\n\n", "  \r\n"] {
            let err = parse(empty, "d.txt").expect_err("empty");
            assert!(matches!(err, H36mError::Empty { .. }));
            assert_eq!(err.to_string(), "d.txt: empty file, no frames");
        }
        let err = read("/nonexistent/h36m.txt").expect_err("missing");
        assert!(err.to_string().contains("/nonexistent/h36m.txt"));
    }

    #[test]
    fn huge_finite_values_do_not_panic() {
        let mut row = [1e308; COLUMNS];
        row[5] = -1e308;
        let c = ExpmapClip {
            source: String::new(),
            rows: vec![row; 2],
            trajectory: integrate_root(&[row; 2]),
        };
        let _ = c.to_pose_sequence(RootMode::Trajectory);
        let _ = c.world_rotations(1, RootMode::Trajectory);
    }

    fn number_like() -> impl Strategy<Value = String> {
        prop_oneof![
            any::<f64>().prop_map(|v| v.to_string()),
            (-4.0..4.0f64).prop_map(|v| format!("{v:.7}")),
            Just(String::new()),
            Just("nan".to_owned()),
            Just("-inf".to_owned()),
            "\\PC{0,4}",
        ]
    }

    fn near_valid_text() -> impl Strategy<Value = String> {
        let line = prop::collection::vec(number_like(), 97..=100).prop_map(|v| v.join(","));
        prop::collection::vec(line, 0..4).prop_map(|v| v.join("\n"))
    }

    proptest! {
        #[test]
        fn arbitrary_text_never_panics(text in "\\PC*") {
            if let Ok(c) = parse(&text, "prop") {
                let _ = c.to_pose_sequence(RootMode::Trajectory);
            }
        }

        #[test]
        fn near_valid_text_never_panics(text in near_valid_text()) {
            if let Ok(c) = parse(&text, "prop") {
                prop_assert!(c.frame_count() > 0);
                let _ = c.to_pose_sequence(RootMode::Trajectory);
                let _ = c.world_rotations(c.frame_count() - 1, RootMode::Centred);
            }
        }
    }
}
