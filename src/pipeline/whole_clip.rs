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
use crate::skeleton::convert::AnimationFrame;
use crate::skeleton::rig::Rig;

/// Each animation's writer and frames.
pub type Animations = Vec<(TrackWriter, Vec<AnimationFrame>)>;

/// Solves every person's whole clip and runs DSI on it: one summary per person, and every
/// animation (per person, variant 0 first). Frames dropped for non-monotonic stamps are logged
/// and added to `losses`.
///
/// # Errors
/// [`PipelineError::Solve`] for a frame that cannot be solved, [`PipelineError::Dsi`] naming the
/// track.
pub(super) fn solve_all(
    rig: &Rig,
    people: Vec<Person<'_>>,
    options: &DsiOptions,
    several_people: bool,
    losses: &mut Losses,
) -> Result<(Vec<TrackSummary>, Animations), PipelineError> {
    let mut tracks = Vec::with_capacity(people.len());
    let mut all = Vec::new();
    for person in people {
        let (summary, animations) = whole_clip(rig, person, options, several_people, losses)?;
        tracks.push(summary);
        all.extend(animations);
    }
    Ok((tracks, all))
}

/// Solves one person's whole clip and runs DSI on it: the person's summary and a writer with its
/// frames per animation (variant 0 first).
fn whole_clip(
    rig: &Rig,
    person: Person<'_>,
    options: &DsiOptions,
    several_people: bool,
    losses: &mut Losses,
) -> Result<(TrackSummary, Animations), PipelineError> {
    let Person {
        track_id,
        topic,
        source,
        mut converter,
        writer,
        ..
    } = person;
    let mut keys = Vec::new();
    while let Some(step) = converter.next_frame() {
        let (stamp_nanos, pose) = step?;
        keys.push(AnimationFrame {
            stamp_nanos,
            pose: pose.clone(),
        });
    }
    let layout_name = converter.layout_name().to_string();
    let coverage = converter.coverage().clone();
    let (character, report) = converter.finish();
    let dropped = Losses::non_monotonic(source, topic, track_id, &report.dropped_non_monotonic);
    dropped.warn(WARN_LIMIT);
    losses.append(dropped);
    let result =
        dsi::run(rig, &keys, options).map_err(|source| PipelineError::Dsi { track_id, source })?;
    let plan = &result.plan;
    let summary = TrackSummary {
        track_id,
        frames_in: report.frames,
        frames_out: result.animations[0].len() as u64,
        fps: options.out_fps,
        degenerate_frames: report.degenerate_frames,
        bones_at_rest: report.coverage.at_rest.len(),
        layout_name,
        dsi: Some(DsiSummary {
            threshold_rad: plan.threshold_rad,
            segments: plan.segments,
            transitions: plan.transition_count(),
            frames_added: plan.frames_added(),
            eta: plan.eta,
            delta: plan.delta,
            smoothed: options.smoothing.is_some(),
            variants: options.variants,
            seed: options.seed,
        }),
    };
    let mut writer = Some(writer);
    let animations = result
        .animations
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
