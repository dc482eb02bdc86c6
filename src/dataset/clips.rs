//! The clip policy: how `autoact trim` cuts each segment of a capture into clips.
//!
//! A segment on the capture timeline is `lead-in | animation | lead-out`; the leads hold the
//! pose still. A policy says which frames become clips:
//!
//! - `whole` (default): one clip of the animation;
//! - `windows`: fixed-length windows (`length_frames`) every `stride_frames` over the
//!   animation; the frames after the last full window follow the `tail` rule;
//! - `instances`: one clip per action instance found from the motion (bursts of body-frame
//!   joint speed separated by rests), `min_frames` to `max_frames` long, each padded by
//!   `pad_frames` of context on both sides.
//!
//! The leads are part of a clip only with `include_lead = true` (then `whole` is the segment,
//! `windows` cover the segment, and an instance's padding may reach into the leads). Written in
//! the spec as `[clips]` and per class as `[class.clips]` (a class's keys override the dataset's),
//! and on `autoact trim` as options that override both.

use std::ops::Range;

use serde::{Deserialize, Serialize};

/// What a clip is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum ClipMode {
    /// One clip of the whole animation.
    #[default]
    Whole,
    /// Fixed-length windows at a fixed stride.
    Windows,
    /// One clip per action instance found from the motion.
    Instances,
}

impl ClipMode {
    /// `whole`, `windows` or `instances`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ClipMode::Whole => "whole",
            ClipMode::Windows => "windows",
            ClipMode::Instances => "instances",
        }
    }
}

/// What happens to the frames after the last full window.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "snake_case")]
pub enum Tail {
    /// One more full window, ending on the span's last frame (it overlaps the one before by
    /// more than the stride); a span shorter than a window gives one clip of the whole span.
    #[default]
    Shift,
    /// Left out; a span shorter than a window gives no clip.
    Drop,
    /// One shorter window from the next stride to the span's end; a span shorter than a window
    /// gives one clip of the whole span.
    Keep,
}

/// A resolved clip policy (every value set).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClipPolicy {
    /// What a clip is.
    pub policy: ClipMode,
    /// Whether the still lead-in and lead-out are part of the clips.
    pub include_lead: bool,
    /// `windows`: frames per window.
    pub length_frames: u64,
    /// `windows`: frames from one window's start to the next's.
    pub stride_frames: u64,
    /// `windows`: the rule for the frames after the last full window.
    pub tail: Tail,
    /// `instances`: shorter bursts of motion are left out.
    pub min_frames: u64,
    /// `instances`: longer ones are cut into equal parts no longer than this.
    pub max_frames: u64,
    /// `instances`: frames of context kept before and after each instance.
    pub pad_frames: u64,
    /// `instances`: a rest shorter than this does not separate two instances.
    pub min_rest_frames: u64,
}

impl Default for ClipPolicy {
    fn default() -> ClipPolicy {
        ClipPolicy {
            policy: ClipMode::Whole,
            include_lead: false,
            length_frames: 64,
            stride_frames: 32,
            tail: Tail::Shift,
            min_frames: 10,
            max_frames: 300,
            pad_frames: 5,
            min_rest_frames: 8,
        }
    }
}

/// A clip policy as written (`[clips]`, `[class.clips]`, or `trim`'s options): each key
/// optional, filled in from the policy it overrides ([`ClipsSection::over`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClipsSection {
    /// What a clip is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub policy: Option<ClipMode>,
    /// Whether the leads are part of the clips.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub include_lead: Option<bool>,
    /// `windows`: frames per window.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub length_frames: Option<u64>,
    /// `windows`: frames between window starts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stride_frames: Option<u64>,
    /// `windows`: the tail rule.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub tail: Option<Tail>,
    /// `instances`: the shortest instance kept.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_frames: Option<u64>,
    /// `instances`: the longest clip.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_frames: Option<u64>,
    /// `instances`: context frames on each side.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pad_frames: Option<u64>,
    /// `instances`: the shortest rest that separates two instances.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub min_rest_frames: Option<u64>,
}

/// A resolved policy that cannot cut clips: the key and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{key}: {message}")]
pub struct ClipPolicyError {
    /// The offending key (`length_frames`, …).
    pub key: &'static str,
    /// What is wrong and what would be right.
    pub message: String,
}

/// The longest window, instance or padding accepted, frames (over an hour at 60 fps).
pub const MAX_CLIP_FRAMES: u64 = 1 << 18;

impl ClipsSection {
    /// `base` with every key this section sets replaced.
    #[must_use]
    pub fn over(&self, base: &ClipPolicy) -> ClipPolicy {
        ClipPolicy {
            policy: self.policy.unwrap_or(base.policy),
            include_lead: self.include_lead.unwrap_or(base.include_lead),
            length_frames: self.length_frames.unwrap_or(base.length_frames),
            stride_frames: self.stride_frames.unwrap_or(base.stride_frames),
            tail: self.tail.unwrap_or(base.tail),
            min_frames: self.min_frames.unwrap_or(base.min_frames),
            max_frames: self.max_frames.unwrap_or(base.max_frames),
            pad_frames: self.pad_frames.unwrap_or(base.pad_frames),
            min_rest_frames: self.min_rest_frames.unwrap_or(base.min_rest_frames),
        }
    }

    /// Whether no key is set.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        *self == ClipsSection::default()
    }
}

impl ClipPolicy {
    /// Checks every value, naming the first bad key.
    ///
    /// # Errors
    /// [`ClipPolicyError`]: a zero or huge length, stride or instance bound, or
    /// `max_frames < min_frames`.
    pub fn validate(&self) -> Result<(), ClipPolicyError> {
        let positive = [
            ("length_frames", self.length_frames),
            ("stride_frames", self.stride_frames),
            ("min_frames", self.min_frames),
            ("max_frames", self.max_frames),
            ("min_rest_frames", self.min_rest_frames),
        ];
        for (key, v) in positive {
            if v == 0 || v > MAX_CLIP_FRAMES {
                return Err(ClipPolicyError {
                    key,
                    message: format!("{v} frames: must be 1–{MAX_CLIP_FRAMES}"),
                });
            }
        }
        if self.pad_frames > MAX_CLIP_FRAMES {
            return Err(ClipPolicyError {
                key: "pad_frames",
                message: format!(
                    "{} frames: must be at most {MAX_CLIP_FRAMES}",
                    self.pad_frames
                ),
            });
        }
        if self.max_frames < self.min_frames {
            return Err(ClipPolicyError {
                key: "max_frames",
                message: format!(
                    "{} is below min_frames ({})",
                    self.max_frames, self.min_frames
                ),
            });
        }
        Ok(())
    }

    /// The frames a clip may cover in a segment of `segment` frames whose animation plays over
    /// `action`: the segment with `include_lead`, else the animation.
    #[must_use]
    pub fn bounds(&self, segment: &Range<u64>, action: &Range<u64>) -> Range<u64> {
        if self.include_lead {
            segment.clone()
        } else {
            action.clone()
        }
    }

    /// The clips of a segment (`segment` frames, the animation over `action`) by a `whole` or
    /// `windows` policy, each as its frames and the animation's frames in it; windows without
    /// any animation frame (wholly in a lead) are left out. `None` for `instances`, whose clips
    /// the motion decides.
    #[must_use]
    pub fn fixed_clips(
        &self,
        segment: &Range<u64>,
        action: &Range<u64>,
    ) -> Option<Vec<(Range<u64>, Range<u64>)>> {
        let bounds = self.bounds(segment, action);
        match self.policy {
            ClipMode::Whole => Some(vec![(bounds, action.clone())]),
            ClipMode::Windows => Some(
                windows(&bounds, self.length_frames, self.stride_frames, self.tail)
                    .into_iter()
                    .filter_map(|w| {
                        let act = w.start.max(action.start)..w.end.min(action.end);
                        (act.start < act.end).then_some((w, act))
                    })
                    .collect(),
            ),
            ClipMode::Instances => None,
        }
    }
}

/// Windows of `length` frames every `stride` over `span`, with the frames after the last full
/// window by `tail` ([`Tail`]).
#[must_use]
pub fn windows(span: &Range<u64>, length: u64, stride: u64, tail: Tail) -> Vec<Range<u64>> {
    let (length, stride) = (length.max(1), stride.max(1));
    let mut out = Vec::new();
    let mut start = span.start;
    while start + length <= span.end {
        out.push(start..start + length);
        start += stride;
    }
    let covered = out.last().map_or(span.start, |w| w.end);
    if covered >= span.end || span.is_empty() {
        return out;
    }
    match tail {
        Tail::Drop => {}
        Tail::Shift => {
            let from = span.end.saturating_sub(length).max(span.start);
            out.push(from..span.end);
        }
        Tail::Keep => {
            let from = out.last().map_or(span.start, |w| w.start + stride);
            out.push(from..span.end);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::{ClipMode, ClipPolicy, ClipsSection, Tail, windows};

    #[test]
    fn a_section_overrides_only_the_keys_it_sets_and_bad_values_name_their_key() {
        let base = ClipPolicy::default();
        let s: ClipsSection =
            toml::from_str("policy = \"windows\"\nlength_frames = 16\ntail = \"drop\"").unwrap();
        let p = s.over(&base);
        assert_eq!(
            (p.policy, p.length_frames, p.stride_frames, p.tail),
            (ClipMode::Windows, 16, 32, Tail::Drop)
        );
        assert!(ClipsSection::default().over(&p) == p);
        assert!(toml::from_str::<ClipsSection>("lenght_frames = 3").is_err());
        let bad = ClipPolicy {
            stride_frames: 0,
            ..base
        };
        assert_eq!(bad.validate().unwrap_err().key, "stride_frames");
        let bad = ClipPolicy {
            min_frames: 20,
            max_frames: 10,
            ..base
        };
        assert!(
            bad.validate()
                .unwrap_err()
                .to_string()
                .contains("min_frames")
        );
        base.validate().unwrap();
    }

    #[test]
    fn windows_have_exact_counts_lengths_and_strides_and_each_tail_rule() {
        // 100 frames, windows of 30 every 20: 0, 20, 40, 60 (ends 90); 10 frames left.
        let span = 0..100;
        let full = vec![0..30, 20..50, 40..70, 60..90];
        assert_eq!(windows(&span, 30, 20, Tail::Drop), full);
        let mut shifted = full.clone();
        shifted.push(70..100);
        assert_eq!(windows(&span, 30, 20, Tail::Shift), shifted);
        let mut kept = full.clone();
        kept.push(80..100);
        assert_eq!(windows(&span, 30, 20, Tail::Keep), kept);
        // An exact fit has no tail whatever the rule; non-overlapping windows.
        for tail in [Tail::Drop, Tail::Shift, Tail::Keep] {
            assert_eq!(
                windows(&(10..70), 20, 20, tail),
                vec![10..30, 30..50, 50..70]
            );
            // A span shorter than a window.
            let short = windows(&(5..15), 20, 10, tail);
            let expected = usize::from(tail != Tail::Drop);
            assert_eq!(short.len(), expected, "{tail:?}");
            assert!(short.iter().all(|w| *w == (5..15)), "{tail:?}: {short:?}");
        }
        // Gaps between windows when the stride is longer than a window.
        assert_eq!(
            windows(&(0..50), 10, 20, Tail::Drop),
            vec![0..10, 20..30, 40..50]
        );
    }
}
