//! `convert` with DSI: each person's clip collected (its keys in a temporary file next to the
//! output), planned stretch by stretch (a gap splits it), then solved in windows
//! ([`crate::dsi::stream`]) while it is written: every animation (per person, variant 0 first)
//! has its own writer, and all of them are written in one stamp order. Memory stays bounded
//! whatever the clip's length.

use std::cmp::Reverse;
use std::collections::{BTreeMap, BinaryHeap, VecDeque};
use std::path::{Path, PathBuf};

use super::PipelineError;
use super::convert::{DsiSummary, Person, TrackSummary};
use crate::bags::animation::{TrackWriter, frame_prefix};
use crate::bags::output::BagOutput;
use crate::dsi::store::Shelf;
use crate::dsi::stream::{ClipKeys, Solver};
use crate::dsi::{self, DsiError, DsiOptions, Pace};
use crate::loss::{Losses, WARN_LIMIT};
use crate::skeleton::convert::{AnimationFrame, SequenceConverter};
use crate::skeleton::pose::{PoseFrame, stamp_nanos_at};
use crate::skeleton::rig::Rig;

/// One person's clip, solved frame by frame as the input is read: its keys, a new stretch
/// after each gap in its stamps. All stretches share two temporary files (the keys as they
/// come, and with their outliers replaced), created with the first key.
#[derive(Debug)]
pub(super) struct Clip {
    track_id: u64,
    spill_dir: PathBuf,
    bones: usize,
    /// The raw and the clean store, once there is a key.
    stores: Option<(Shelf, Shelf)>,
    stretches: Vec<ClipKeys>,
}

impl Clip {
    /// An empty clip of person `track_id`, its keys to be kept in `spill_dir`.
    pub(super) fn new(track_id: u64, spill_dir: &Path, bones: usize) -> Clip {
        Clip {
            track_id,
            spill_dir: spill_dir.to_path_buf(),
            bones,
            stores: None,
            stretches: Vec::new(),
        }
    }

    /// Solves the next frame and keeps its pose (`after_gap`: it starts a new stretch).
    ///
    /// # Errors
    /// [`PipelineError::Solve`] for a frame that cannot be solved, [`PipelineError::Dsi`] when
    /// the key cannot be kept.
    pub(super) fn take(
        &mut self,
        converter: &mut SequenceConverter<'_>,
        frame: &PoseFrame,
        after_gap: bool,
    ) -> Result<(), PipelineError> {
        let Some((stamp_nanos, pose)) = converter.push(frame)? else {
            return Ok(());
        };
        let dsi_error = |source| PipelineError::Dsi {
            track_id: self.track_id,
            source,
        };
        if self
            .stretches
            .last()
            .is_none_or(|s| after_gap && !s.is_empty())
        {
            let stores = if let Some(stores) = self.stores.take() {
                stores
            } else {
                let spill = || Shelf::spill(&self.spill_dir, self.bones).map_err(dsi_error);
                (spill()?, spill()?)
            };
            let (raw, clean) = self.stores.insert(stores);
            self.stretches
                .push(ClipKeys::new(raw.next(), clean.clone()));
        }
        let key = AnimationFrame {
            stamp_nanos,
            pose: pose.clone(),
        };
        match self.stretches.last_mut() {
            Some(stretch) => stretch.push(key).map_err(dsi_error),
            None => Ok(()),
        }
    }
}

/// One person's animations (variant 0 first), made window by window as they are written.
#[derive(Debug)]
struct PersonAnimations<'r> {
    track_id: u64,
    writers: Vec<TrackWriter>,
    /// The stretches not yet made, each with the shift that starts it one output frame after
    /// the one before ends.
    stretches: VecDeque<(Solver<'r>, u64)>,
    /// Per animation: frames made, not yet written.
    pending: Vec<VecDeque<AnimationFrame>>,
}

impl PersonAnimations<'_> {
    /// The stamp of animation `v`'s next frame, making the next window when none is pending.
    fn next_stamp(&mut self, v: usize) -> Result<Option<u64>, PipelineError> {
        while self.pending[v].is_empty() {
            let Some((solver, shift)) = self.stretches.front_mut() else {
                return Ok(None);
            };
            let shift = *shift;
            match solver.next_window() {
                Ok(Some(window)) => {
                    for (pending, frames) in self.pending.iter_mut().zip(window) {
                        pending.extend(frames.into_iter().map(|mut f| {
                            f.stamp_nanos += shift;
                            f
                        }));
                    }
                }
                Ok(None) => {
                    self.stretches.pop_front();
                }
                Err(source) => {
                    return Err(PipelineError::Dsi {
                        track_id: self.track_id,
                        source,
                    });
                }
            }
        }
        Ok(self.pending[v].front().map(|f| f.stamp_nanos))
    }
}

/// Every person's animations, planned and ready to be written.
#[derive(Debug)]
pub struct Animations<'r> {
    people: Vec<PersonAnimations<'r>>,
}

impl Animations<'_> {
    /// Every animation's writer (per person, variant 0 first).
    pub fn writers(&self) -> impl Iterator<Item = &TrackWriter> {
        self.people.iter().flat_map(|p| &p.writers)
    }
}

/// Plans DSI on every person's clip: one summary per person, and every animation (per person,
/// variant 0 first), to be written by [`write_in_stamp_order`]. Frames dropped for
/// non-monotonic stamps are logged and added to `losses`.
///
/// # Errors
/// [`PipelineError::Dsi`] naming the track.
pub(super) fn solve_all<'r>(
    rig: &'r Rig,
    people: Vec<Person<'_>>,
    clips: Vec<Clip>,
    options: &DsiOptions,
    several_people: bool,
    losses: &mut Losses,
) -> Result<(Vec<TrackSummary>, Animations<'r>), PipelineError> {
    let mut tracks = Vec::with_capacity(people.len());
    let mut all = Vec::with_capacity(people.len());
    for (person, clip) in people.into_iter().zip(clips) {
        let (summary, animations) = whole_clip(rig, person, clip, options, several_people, losses)?;
        tracks.push(summary);
        all.push(animations);
    }
    Ok((tracks, Animations { people: all }))
}

/// Plans every stretch of a clip, each shifted to start one output frame after the one before
/// ends (DSI can lengthen a stretch).
fn plan_stretches<'r>(
    rig: &'r Rig,
    track_id: u64,
    clip: Clip,
    options: &DsiOptions,
) -> Result<VecDeque<(Solver<'r>, u64)>, PipelineError> {
    let mut stretches = VecDeque::with_capacity(clip.stretches.len());
    let mut end: Option<u64> = None;
    for keys in clip.stretches {
        let solver = keys
            .solve(rig, options)
            .map_err(|source| PipelineError::Dsi { track_id, source })?;
        let shift = end.map_or(0, |last| {
            (last + stamp_nanos_at(1, options.out_fps)).saturating_sub(solver.first_stamp_nanos())
        });
        end = Some(solver.stamp_nanos(solver.frames().saturating_sub(1)) + shift);
        stretches.push_back((solver, shift));
    }
    Ok(stretches)
}

/// Plans DSI on one person's clip: the person's summary, and a writer per animation (variant 0
/// first) with its stretches.
fn whole_clip<'r>(
    rig: &'r Rig,
    person: Person<'_>,
    clip: Clip,
    options: &DsiOptions,
    several_people: bool,
    losses: &mut Losses,
) -> Result<(TrackSummary, PersonAnimations<'r>), PipelineError> {
    let Person {
        track_id,
        topic,
        source,
        converter,
        writer,
        estimator,
        ..
    } = person;
    let options = &options.for_source(dsi::SourceKind::from_camera_frame(estimator));
    let layout_name = converter.layout_name().to_string();
    let coverage = converter.coverage().clone();
    let (character, report) = converter.finish();
    let dropped = Losses::non_monotonic(source, topic, track_id, &report.dropped_non_monotonic);
    dropped.warn(WARN_LIMIT);
    losses.append(dropped);
    let stretches = plan_stretches(rig, track_id, clip, options)?;
    let plans: Vec<&dsi::plan::Plan> = stretches.iter().map(|(s, _)| s.plan()).collect();
    let Some(plan) = plans.first() else {
        return Err(PipelineError::Dsi {
            track_id,
            source: DsiError::NoFrames,
        });
    };
    let summary = TrackSummary {
        track_id,
        frames_in: report.frames,
        frames_out: stretches.iter().map(|(s, _)| s.frames() as u64).sum(),
        fps: options.out_fps,
        degenerate_frames: report.degenerate_frames,
        degenerate_bones: report.degenerate_bones(rig),
        bones_at_rest: report.coverage.at_rest.len(),
        layout_name,
        dsi: Some(DsiSummary {
            threshold_rad: plan.threshold_rad,
            segments: plans.iter().map(|p| p.segments).sum(),
            transitions: plans.iter().map(|p| p.transition_count()).sum(),
            frames_added: plans.iter().map(|p| p.frames_added()).sum(),
            eta: plan.eta,
            delta: plan.delta,
            source: options.source_kind(),
            smoothed: options.smoothing.is_some(),
            variants: options.variants,
            seed: options.seed,
        }),
    };
    let mut writers = vec![writer];
    for v in 1..=options.variants {
        // `ConvertJob::check` keeps the variants within u32.
        let v = u32::try_from(v).unwrap_or(u32::MAX);
        writers.push(TrackWriter::new(
            rig,
            &character,
            &coverage,
            track_id,
            v,
            &frame_prefix(track_id, v, several_people),
        ));
    }
    let pending = (0..writers.len()).map(|_| VecDeque::new()).collect();
    Ok((
        summary,
        PersonAnimations {
            track_id,
            writers,
            stretches,
            pending,
        },
    ))
}

/// Makes and writes all animations in stamp order (ties: person, then variant), holding a
/// window of each at a time.
///
/// # Errors
/// [`PipelineError`] from DSI or the writer.
pub(super) fn write_in_stamp_order(
    out: &mut BagOutput,
    animations: &mut Animations<'_>,
) -> Result<(), PipelineError> {
    let index: Vec<(usize, usize)> = animations
        .people
        .iter()
        .enumerate()
        .flat_map(|(p, person)| (0..person.writers.len()).map(move |v| (p, v)))
        .collect();
    let mut heads = BinaryHeap::with_capacity(index.len());
    for (c, &(p, v)) in index.iter().enumerate() {
        if let Some(stamp) = animations.people[p].next_stamp(v)? {
            heads.push(Reverse((stamp, c)));
        }
    }
    while let Some(Reverse((stamp, c))) = heads.pop() {
        let (p, v) = index[c];
        let person = &mut animations.people[p];
        if let Some(frame) = person.pending[v].pop_front() {
            person.writers[v].write_frame(&mut out.writer, stamp, &frame.pose)?;
        }
        if let Some(next) = person.next_stamp(v)? {
            heads.push(Reverse((next, c)));
        }
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
        "dsi_source".to_string(),
        o.source
            .map_or("auto (estimator for camera-frame tracks)", |k| k.name())
            .to_string(),
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
