//! Joint-position sequences: what every reader produces and what conversion consumes.
//!
//! A [`PoseSequence`] is one tracked person: joint names (in a keypoint layout's order), and per
//! frame a stamp in nanoseconds, positions in metres in the autoact frame (see [`crate::skeleton::frames`])
//! and a confidence per joint. A joint that the source did not observe has NaN coordinates and
//! confidence 0; readers never invent or drop frames.

use nalgebra::Point3;

/// One person's joint positions over time.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseSequence {
    /// Where the data came from (a path, or a description for synthesised data).
    pub source: String,
    /// Tracker id of this person in the source (0 when the source has only one person).
    pub track_id: u64,
    /// Joint names, in the order of every frame's arrays.
    pub joint_names: Vec<String>,
    /// Frames in stamp order.
    pub frames: Vec<PoseFrame>,
}

/// The joints of one person at one instant.
#[derive(Debug, Clone, PartialEq)]
pub struct PoseFrame {
    /// Time of the frame, nanoseconds (relative to the start of the clip unless the source has
    /// absolute stamps).
    pub stamp_nanos: u64,
    /// Joint positions, metres, autoact frame; NaN coordinates for a joint that was not seen.
    pub positions_m: Vec<Point3<f64>>,
    /// Per-joint confidence in [0, 1]; 0 for a joint that was not seen.
    pub confidence: Vec<f32>,
}

impl PoseFrame {
    /// A frame whose joints are all missing.
    #[must_use]
    pub fn missing(stamp_nanos: u64, joint_count: usize) -> Self {
        PoseFrame {
            stamp_nanos,
            positions_m: vec![Point3::new(f64::NAN, f64::NAN, f64::NAN); joint_count],
            confidence: vec![0.0; joint_count],
        }
    }

    /// A frame of points given in the `axes` convention (metres), converted once to the autoact
    /// frame: a point with a coordinate that is not finite is missing, every other one has
    /// confidence 1 (for sources that keep no per-joint confidence).
    #[must_use]
    pub fn from_source_points(
        stamp_nanos: u64,
        points_m: &[[f64; 3]],
        axes: crate::skeleton::frames::SourceAxes,
    ) -> Self {
        let mut frame = PoseFrame::missing(stamp_nanos, points_m.len());
        for (j, xyz) in points_m.iter().enumerate() {
            if xyz.iter().all(|c| c.is_finite()) {
                frame.positions_m[j] = axes.point_to_autoact(Point3::from(*xyz));
                frame.confidence[j] = 1.0;
            }
        }
        frame
    }
}

impl PoseSequence {
    /// Index of a joint by name.
    #[must_use]
    pub fn joint_index(&self, name: &str) -> Option<usize> {
        self.joint_names.iter().position(|n| n == name)
    }
}

/// Which of `joint_count` joints some frame observes (finite position, confidence above 0):
/// joints a source never provides are not in its data at all.
#[must_use]
pub fn observed_joints(frames: &[PoseFrame], joint_count: usize) -> Vec<bool> {
    (0..joint_count)
        .map(|j| {
            frames.iter().any(|f| {
                f.confidence.get(j).is_some_and(|&c| c > 0.0)
                    && f.positions_m
                        .get(j)
                        .is_some_and(|p| p.coords.iter().all(|v| v.is_finite()))
            })
        })
        .collect()
}

impl PoseSequence {
    /// This sequence without the joints no frame observes (see [`observed_joints`]): a skeleton
    /// message names its joints, so a source carries only what it has.
    #[must_use]
    pub fn without_unobserved_joints(self) -> PoseSequence {
        let keep: Vec<usize> = observed_joints(&self.frames, self.joint_names.len())
            .iter()
            .enumerate()
            .filter(|(_, o)| **o)
            .map(|(j, _)| j)
            .collect();
        if keep.len() == self.joint_names.len() {
            return self;
        }
        let pick = |f: &PoseFrame| PoseFrame {
            stamp_nanos: f.stamp_nanos,
            positions_m: keep.iter().map(|&j| f.positions_m[j]).collect(),
            confidence: keep.iter().map(|&j| f.confidence[j]).collect(),
        };
        PoseSequence {
            joint_names: keep.iter().map(|&j| self.joint_names[j].clone()).collect(),
            frames: self.frames.iter().map(pick).collect(),
            ..self
        }
    }
}

/// The frame rate of frames stamped `stamps_nanos`: `stated` when given, else measured as one
/// over the median step between stamps. `None` with no statement and fewer than two frames.
#[must_use]
pub fn frame_rate(stated: Option<f64>, stamps_nanos: &[u64]) -> Option<f64> {
    if stated.is_some() {
        return stated;
    }
    let mut steps: Vec<f64> = stamps_nanos
        .windows(2)
        .map(|w| nanos_to_secs(w[1].saturating_sub(w[0])))
        .filter(|s| *s > 0.0)
        .collect();
    let step = crate::skeleton::character::median(&mut steps)?;
    Some(1.0 / step)
}

/// A duration (a difference of stamps) in nanoseconds, as seconds. The one place nanoseconds
/// become seconds.
#[must_use]
#[expect(
    clippy::cast_precision_loss,
    reason = "exact below 2^53 ns (104 days); every caller passes a span within a recording"
)]
pub fn nanos_to_secs(nanos: u64) -> f64 {
    nanos as f64 * 1e-9
}

/// The stamp of frame `index` of a clip sampled at a constant `fps`, in nanoseconds.
///
/// The one place where a frame index and a rate become a time.
#[must_use]
pub fn stamp_nanos_at(index: usize, fps: f64) -> u64 {
    #[expect(
        clippy::cast_precision_loss,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "frame counts and rates are far inside f64's exact range"
    )]
    let nanos = (index as f64 * 1e9 / fps).round() as u64;
    nanos
}
