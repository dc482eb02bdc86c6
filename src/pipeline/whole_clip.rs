//! `convert` with DSI: each person's clip solved whole, then cut into unit motions, resampled,
//! varied and smoothed ([`crate::dsi`]); every animation (variant 0 first) gets its own writer,
//! and all of them are written in one stamp order.

use std::collections::BTreeMap;

use super::PipelineError;
use super::convert::{DsiSummary, Person, TrackSummary};
use crate::bags::animation::{TrackWriter, frame_prefix};
use crate::bags::output::BagOutput;
use crate::dsi::{self, DsiOptions, Pace};
use crate::loss::{Losses, WARN_LIMIT};
use crate::mcap_io::McapIoError;
use crate::skeleton::convert::{AnimationFrame, SequenceConverter};
use crate::skeleton::pose::{PoseFrame, stamp_nanos_at};
use crate::skeleton::rig::Rig;

/// Each animation's writer and frames.
pub type Animations = Vec<(TrackWriter, Vec<AnimationFrame>)>;

/// One person's clip, solved frame by frame as the input is read: its key frames and where a
/// gap in its stamps splits it.
#[derive(Debug, Default)]
pub(super) struct Clip {
    keys: Vec<AnimationFrame>,
    /// Indices of the keys that start a stretch after a gap.
    breaks: Vec<usize>,
}

impl Clip {
    /// An empty clip with room for `frames` keys (the count pass 1 read), so that collecting
    /// them never holds twice their memory while growing.
    pub(super) fn with_capacity(frames: u64) -> Clip {
        Clip {
            keys: Vec::with_capacity(usize::try_from(frames).unwrap_or(0)),
            breaks: Vec::new(),
        }
    }

    /// Solves the next frame and keeps its pose (`after_gap`: it starts a new stretch).
    ///
    /// # Errors
    /// [`PipelineError::Solve`] for a frame that cannot be solved.
    pub(super) fn take(
        &mut self,
        converter: &mut SequenceConverter<'_>,
        frame: &PoseFrame,
        after_gap: bool,
    ) -> Result<(), PipelineError> {
        if let Some((stamp_nanos, pose)) = converter.push(frame)? {
            if after_gap && !self.keys.is_empty() {
                self.breaks.push(self.keys.len());
            }
            self.keys.push(AnimationFrame {
                stamp_nanos,
                pose: pose.clone(),
            });
        }
        Ok(())
    }
}

/// Runs DSI on every person's clip: one summary per person, and every animation (per person,
/// variant 0 first). Frames dropped for non-monotonic stamps are logged and added to `losses`.
///
/// # Errors
/// [`PipelineError::Dsi`] naming the track.
pub(super) fn solve_all(
    rig: &Rig,
    people: Vec<Person<'_>>,
    clips: Vec<Clip>,
    options: &DsiOptions,
    several_people: bool,
    losses: &mut Losses,
) -> Result<(Vec<TrackSummary>, Animations), PipelineError> {
    let mut tracks = Vec::with_capacity(people.len());
    let mut all = Vec::new();
    for (person, clip) in people.into_iter().zip(clips) {
        let (summary, animations) = whole_clip(rig, person, clip, options, several_people, losses)?;
        tracks.push(summary);
        all.extend(animations);
    }
    Ok((tracks, all))
}

/// DSI on a clip stretch by stretch (a gap splits it): the plans, and per variant the stretches'
/// frames end to end. A stretch whose output would start before the previous one's ends (DSI
/// can lengthen a stretch) is moved to start one output frame after it.
fn run_stretches(
    rig: &Rig,
    track_id: u64,
    clip: &Clip,
    options: &DsiOptions,
) -> Result<(Vec<dsi::plan::Plan>, Vec<Vec<AnimationFrame>>), PipelineError> {
    let mut bounds = vec![0];
    bounds.extend(&clip.breaks);
    bounds.push(clip.keys.len());
    let mut plans = Vec::new();
    let mut animations: Vec<Vec<AnimationFrame>> = Vec::new();
    for w in bounds.windows(2) {
        let result = dsi::run(rig, &clip.keys[w[0]..w[1]], options)
            .map_err(|source| PipelineError::Dsi { track_id, source })?;
        let start = result.animations[0].first().map_or(0, |f| f.stamp_nanos);
        let shift = animations.first().and_then(|a| a.last()).map_or(0, |last| {
            (last.stamp_nanos + stamp_nanos_at(1, options.out_fps)).saturating_sub(start)
        });
        animations.resize_with(result.animations.len(), Vec::new);
        for (all, frames) in animations.iter_mut().zip(result.animations) {
            all.extend(frames.into_iter().map(|mut f| {
                f.stamp_nanos += shift;
                f
            }));
        }
        plans.push(result.plan);
    }
    Ok((plans, animations))
}

/// Runs DSI on one person's clip: the person's summary and a writer with its frames per
/// animation (variant 0 first).
fn whole_clip(
    rig: &Rig,
    person: Person<'_>,
    clip: Clip,
    options: &DsiOptions,
    several_people: bool,
    losses: &mut Losses,
) -> Result<(TrackSummary, Animations), PipelineError> {
    let Person {
        track_id,
        topic,
        source,
        converter,
        writer,
        ..
    } = person;
    let layout_name = converter.layout_name().to_string();
    let coverage = converter.coverage().clone();
    let (character, report) = converter.finish();
    let dropped = Losses::non_monotonic(source, topic, track_id, &report.dropped_non_monotonic);
    dropped.warn(WARN_LIMIT);
    losses.append(dropped);
    let (plans, result_animations) = run_stretches(rig, track_id, &clip, options)?;
    drop(clip);
    let Some(plan) = plans.first() else {
        return Err(PipelineError::Dsi {
            track_id,
            source: dsi::DsiError::NoFrames,
        });
    };
    let summary = TrackSummary {
        track_id,
        frames_in: report.frames,
        frames_out: result_animations.first().map_or(0, |a| a.len() as u64),
        fps: options.out_fps,
        degenerate_frames: report.degenerate_frames,
        bones_at_rest: report.coverage.at_rest.len(),
        layout_name,
        dsi: Some(DsiSummary {
            threshold_rad: plan.threshold_rad,
            segments: plans.iter().map(|p| p.segments).sum(),
            transitions: plans.iter().map(dsi::plan::Plan::transition_count).sum(),
            frames_added: plans.iter().map(dsi::plan::Plan::frames_added).sum(),
            eta: plan.eta,
            delta: plan.delta,
            smoothed: options.smoothing.is_some(),
            variants: options.variants,
            seed: options.seed,
        }),
    };
    let mut writer = Some(writer);
    let animations = result_animations
        .into_iter()
        .zip(0u32..)
        .map(|(frames, v)| {
            let w = writer.take().filter(|_| v == 0).unwrap_or_else(|| {
                TrackWriter::new(
                    rig,
                    &character,
                    &coverage,
                    track_id,
                    v,
                    &frame_prefix(track_id, v, several_people),
                )
            });
            (w, frames)
        })
        .collect();
    Ok((summary, animations))
}

/// Writes all animations in stamp order (ties: person, then variant).
///
/// # Errors
/// [`McapIoError`] from the writer.
pub(super) fn write_in_stamp_order(
    out: &mut BagOutput,
    animations: &mut Animations,
) -> Result<(), McapIoError> {
    let mut order: Vec<(u64, usize, usize)> = animations
        .iter()
        .enumerate()
        .flat_map(|(c, (_, frames))| {
            frames
                .iter()
                .enumerate()
                .map(move |(k, f)| (f.stamp_nanos, c, k))
        })
        .collect();
    order.sort_unstable();
    for (stamp, c, k) in order {
        let (writer, frames) = &mut animations[c];
        writer.write_frame(&mut out.writer, stamp, &frames[k].pose)?;
    }
    Ok(())
}

/// Puts every DSI parameter in the `autoact.convert` record, so a bag says how it was made.
pub(super) fn record_options(meta: &mut BTreeMap<String, String>, o: &DsiOptions) {
    meta.insert("dsi_threshold".to_string(), o.threshold.to_string());
    meta.insert(
        "dsi_eta".to_string(),
        o.eta
            .map_or_else(|| "1/threshold".to_string(), |e| e.to_string()),
    );
    meta.insert(
        "dsi_pace".to_string(),
        match o.pace {
            Pace::Speed(s) => format!("speed {s}"),
            Pace::Delta(d) => format!("delta {d}"),
        },
    );
    meta.insert(
        "dsi_weights".to_string(),
        o.weights
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join(","),
    );
    meta.insert(
        "smoothing".to_string(),
        o.smoothing.map_or_else(
            || "off".to_string(),
            |s| {
                format!(
                    "supersmoother spans_s={:?} bass={}",
                    s.spans_s,
                    s.bass.map_or_else(|| "none".to_string(), |b| b.to_string())
                )
            },
        ),
    );
    meta.insert("variants".to_string(), o.variants.to_string());
    meta.insert("variation_deg".to_string(), o.bounds.to_string());
    meta.insert("seed".to_string(), o.seed.to_string());
    meta.insert(
        "variant_rng".to_string(),
        "variant k: ChaCha8 seeded with `seed` (seed_from_u64), stream k".to_string(),
    );
}
