//! A segment's frames → its clips, by the clip policy ([`crate::dataset::clips`]): the whole
//! animation, fixed windows, or one clip per action instance; each clip with its action span.

use std::collections::BTreeMap;
use std::ops::Range;

use super::TrimError;
use super::motion::{Segmentation, instances};
use super::plan::FrameRange;
use crate::dataset::clips::{ClipMode, ClipPolicy, ClipsSection};

/// The clip policy of each class: the plan's (or the default), with `trim`'s options over it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ClipPolicies {
    /// Per label, as the plan gives it.
    pub by_label: BTreeMap<String, ClipPolicy>,
    /// `trim`'s options: they override every class's policy.
    pub overrides: ClipsSection,
}

impl ClipPolicies {
    /// The policy of `label`'s segments.
    ///
    /// # Errors
    /// [`TrimError::ClipPolicy`] when `trim`'s options make it unusable.
    pub fn of(&self, label: &str) -> Result<ClipPolicy, TrimError> {
        let base = self.by_label.get(label).copied().unwrap_or_default();
        let policy = self.overrides.over(&base);
        policy.validate().map_err(|source| TrimError::ClipPolicy {
            label: label.to_owned(),
            source,
        })?;
        Ok(policy)
    }
}

/// The clips of `segment` (a segment's video frames, its animation as `action`) under `policy`.
/// `speeds` are the body-frame joint speeds of the animation's frames (`segment.action`, one a
/// frame), which only `instances` needs (without them it finds none).
#[must_use]
pub fn clips_of(
    segment: &FrameRange,
    policy: &ClipPolicy,
    speeds: Option<&[f64]>,
) -> Vec<FrameRange> {
    let action = segment.action.clone();
    let frames = segment.start_frame..segment.end_frame();
    let clip = |part: Option<u32>, frames: Range<u64>, act: Range<u64>| FrameRange {
        segment: segment.segment,
        part,
        start_frame: frames.start,
        frame_count: frames.end - frames.start,
        action: act,
        animation_start_frame: segment.animation_start_frame,
    };
    let numbered = |ranges: Vec<(Range<u64>, Range<u64>)>| -> Vec<FrameRange> {
        ranges
            .into_iter()
            .enumerate()
            .map(|(k, (frames, act))| clip(Some(u32::try_from(k).unwrap_or(u32::MAX)), frames, act))
            .collect()
    };
    match policy.policy {
        ClipMode::Whole => policy
            .fixed_clips(&frames, &action)
            .into_iter()
            .flatten()
            .map(|(frames, act)| clip(None, frames, act))
            .collect(),
        ClipMode::Windows => numbered(policy.fixed_clips(&frames, &action).unwrap_or_default()),
        ClipMode::Instances => {
            let seg = Segmentation {
                min_frames: policy.min_frames,
                max_frames: policy.max_frames,
                min_rest_frames: policy.min_rest_frames,
            };
            let bounds = policy.bounds(&frames, &action);
            let found = speeds.map(|s| instances(s, &seg)).unwrap_or_default();
            numbered(
                found
                    .into_iter()
                    .map(|r| {
                        let act = action.start + r.start..action.start + r.end;
                        let frames = act
                            .start
                            .saturating_sub(policy.pad_frames)
                            .max(bounds.start)
                            ..(act.end + policy.pad_frames).min(bounds.end);
                        (frames, act)
                    })
                    .collect(),
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::clips_of;
    use crate::dataset::clips::{ClipMode, ClipPolicy, Tail};
    use crate::trim::plan::FrameRange;

    /// A segment of video frames 100..230: lead-in 100..115, animation 115..215, lead-out.
    fn segment() -> FrameRange {
        FrameRange {
            segment: 3,
            part: None,
            start_frame: 100,
            frame_count: 130,
            action: 115..215,
            animation_start_frame: 115,
        }
    }

    #[test]
    fn whole_is_the_animation_unless_the_leads_are_asked_for() {
        let p = ClipPolicy::default();
        let c = clips_of(&segment(), &p, None);
        assert_eq!(c.len(), 1);
        assert_eq!(
            (c[0].start_frame, c[0].frame_count, c[0].part),
            (115, 100, None)
        );
        assert_eq!(c[0].action, 115..215);
        let with_lead = ClipPolicy {
            include_lead: true,
            ..p
        };
        let c = clips_of(&segment(), &with_lead, None);
        assert_eq!((c[0].start_frame, c[0].frame_count), (100, 130));
        assert_eq!(c[0].action, 115..215);
    }

    #[test]
    fn windows_cover_the_animation_and_windows_without_action_are_left_out() {
        let p = ClipPolicy {
            policy: ClipMode::Windows,
            length_frames: 40,
            stride_frames: 30,
            tail: Tail::Shift,
            ..ClipPolicy::default()
        };
        let c = clips_of(&segment(), &p, None);
        let got: Vec<(u64, u64, Option<u32>)> = c
            .iter()
            .map(|r| (r.start_frame, r.frame_count, r.part))
            .collect();
        assert_eq!(
            got,
            vec![(115, 40, Some(0)), (145, 40, Some(1)), (175, 40, Some(2))]
        );
        assert!(c.iter().all(|r| r.action == (r.start_frame..r.end_frame())));
        // With the leads: windows over the segment, the action span only the animation's part.
        let lead = ClipPolicy {
            include_lead: true,
            length_frames: 10,
            stride_frames: 10,
            tail: Tail::Drop,
            ..p
        };
        let c = clips_of(&segment(), &lead, None);
        // 13 windows over 100..230, the one at 100..110 wholly in the lead-in and the one at
        // 220..230 wholly in the lead-out left out.
        assert_eq!(c.len(), 11);
        assert_eq!((c[0].start_frame, c[0].action.clone()), (110, 115..120));
        assert_eq!(c[10].action, 210..215);
        assert_eq!(c[10].part, Some(10));
    }

    #[test]
    fn instances_are_padded_within_the_animation_and_span_the_motion() {
        let mut speeds = vec![0.0; 100];
        for r in [5..25, 50..70, 85..99] {
            for k in r {
                speeds[k] = 1.0;
            }
        }
        let p = ClipPolicy {
            policy: ClipMode::Instances,
            pad_frames: 8,
            ..ClipPolicy::default()
        };
        let c = clips_of(&segment(), &p, Some(&speeds));
        assert_eq!(c.len(), 3);
        // The first is padded into the animation's start only (not the lead-in).
        assert_eq!(c[0].start_frame, 115);
        assert!(c[0].action.start <= 120 && c[0].action.end >= 140);
        assert_eq!(c[1].start_frame, c[1].action.start - 8);
        assert_eq!(c[2].end_frame(), 215);
        assert!(clips_of(&segment(), &p, None).is_empty());
        let lead = ClipPolicy {
            include_lead: true,
            ..p
        };
        let c = clips_of(&segment(), &lead, Some(&speeds));
        assert!(c[0].start_frame < 115 && c[0].start_frame >= 100);
    }
}
