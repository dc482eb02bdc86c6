//! The `convert` stage: a pose bag → an animation bag.
//!
//! Every person of the input is prepared (body fitted, layout bound); then either all of them
//! are streamed out in time order — each input frame solved, resampled and written at once — or,
//! with DSI options, each person's clip is solved whole, interpolated, varied and smoothed
//! ([`super::whole_clip`]) before the output is created.

use std::borrow::Cow;
use std::collections::BTreeMap;
use std::path::PathBuf;

use nalgebra::Isometry3;

use super::PipelineError;
use super::whole_clip;
use crate::bags;
use crate::bags::animation::{TF_STATIC_TOPIC, TrackWriter, frame_prefix};
use crate::bags::output::{BagOutput, OutputOptions};
use crate::bags::pose::{PoseScan, StampReport, StreamedFrame};
use crate::dsi::{DsiOptions, Pace};
use crate::file_name;
use crate::loss::{Loss, Losses, WARN_LIMIT};
use crate::mcap_io::McapIoError;
use crate::ros::tf2_msgs::TFMessage;
use crate::skeleton::convert::{ConvertOptions, SequenceConverter};
use crate::skeleton::ground::{self, GroundMode};
use crate::skeleton::layout::Layout;
use crate::skeleton::pose::PoseFrame;
use crate::skeleton::resample::Resampler;
use crate::skeleton::rig::Rig;

/// The default longest gap interpolated across, in source frame periods: a few dropped frames
/// are bridged, a pause in the stream or a stamp far ahead is not.
pub const DEFAULT_MAX_GAP_FRAMES: u64 = 5;

/// What to convert and how.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertJob {
    /// The pose bag (`.mcap` or rosbag2 directory).
    pub input: PathBuf,
    /// Convert only this topic (`None`: every topic carrying a pose type).
    pub topic: Option<String>,
    /// The input's keypoint layout (built-in name or `.toml` file); `None`: the one each
    /// skeleton message names.
    pub layout: Option<String>,
    /// Output frame rate.
    pub fps: f64,
    /// How poses are solved (confidence floor, root motion).
    pub solve: ConvertOptions,
    /// DSI, smoothing and variants on whole clips; `None` streams.
    pub dsi: Option<DsiOptions>,
    /// The longest gap in a person's stamps that is interpolated across, seconds (`--max-gap`);
    /// a longer one ends the stretch before it and the animation resumes after it. `None`:
    /// [`DEFAULT_MAX_GAP_FRAMES`] of the person's own frame periods (median step).
    pub max_gap_s: Option<f64>,
    /// Where the animation bag goes.
    pub output: OutputOptions,
    /// Whether camera-frame tracks (marker and pose arrays) are stood on the ground first.
    pub ground: GroundMode,
}

impl ConvertJob {
    /// Checks the options: a positive rate, a confidence floor in [0, 1], a positive DSI pace
    /// and η, and no more variants than a `BoneFrame` numbers.
    ///
    /// # Errors
    /// [`PipelineError::OutOfRange`] naming the option, [`PipelineError::TooManyVariants`].
    pub fn check(&self) -> Result<(), PipelineError> {
        let out_of_range = |option, expected, value: &dyn std::fmt::Display| {
            Err(PipelineError::OutOfRange {
                option,
                expected,
                value: value.to_string(),
            })
        };
        let positive = |v: f64| v.is_finite() && v > 0.0;
        if !positive(self.fps) {
            return out_of_range("--fps", "a positive number of frames per second", &self.fps);
        }
        if let Some(g) = self.max_gap_s
            && !positive(g)
        {
            return out_of_range("--max-gap", "a positive number of seconds", &g);
        }
        let min_confidence = self.solve.min_confidence;
        if !(0.0..=1.0).contains(&min_confidence) {
            return out_of_range("--min-confidence", "in [0, 1]", &min_confidence);
        }
        let Some(dsi) = &self.dsi else {
            return Ok(());
        };
        let pace = match dsi.pace {
            Pace::Speed(s) => ("--speed", s),
            Pace::Delta(d) => ("--delta", d),
        };
        for (option, v) in [Some(pace), dsi.eta.map(|e| ("--eta", e))]
            .into_iter()
            .flatten()
        {
            if !positive(v) {
                return out_of_range(option, "a positive number", &v);
            }
        }
        if dsi.variants > u64::from(u32::MAX) {
            return Err(PipelineError::TooManyVariants);
        }
        Ok(())
    }
}

/// What a conversion wrote, and what input it lost.
#[derive(Debug, Clone, PartialEq)]
pub struct ConvertSummary {
    /// The output bag.
    pub output: PathBuf,
    /// One entry per person converted.
    pub tracks: Vec<TrackSummary>,
    /// Input that could not be used (already logged as warnings).
    pub losses: Losses,
}

/// One person's conversion.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackSummary {
    /// The person's tracker id.
    pub track_id: u64,
    /// Input frames solved.
    pub frames_in: usize,
    /// Output frames (per animation, with DSI).
    pub frames_out: u64,
    /// Output frame rate.
    pub fps: f64,
    /// Frames in which a bone needed the degenerate-input path.
    pub degenerate_frames: usize,
    /// The bones that needed it, with their counts per kind
    /// ([`crate::skeleton::convert::Degeneracy::ALL`] order), the most frequent first.
    pub degenerate_bones: Vec<(String, [usize; 5])>,
    /// Bones the layout does not drive.
    pub bones_at_rest: usize,
    /// The input's layout.
    pub layout_name: String,
    /// What DSI did, when it ran.
    pub dsi: Option<DsiSummary>,
}

/// What DSI did to one person's clip.
#[derive(Debug, Clone, PartialEq)]
pub struct DsiSummary {
    /// Where DSI cut, radians per source frame (`None`: resampled whole).
    pub threshold_rad: Option<f64>,
    /// Unit motions.
    pub segments: usize,
    /// Transitions above the threshold.
    pub transitions: usize,
    /// Frames the transitions gained.
    pub frames_added: usize,
    /// η.
    pub eta: f64,
    /// δ: source frames per output frame.
    pub delta: f64,
    /// What the clip was smoothed as (`--dsi-source`, `auto` resolved for the track).
    pub source: crate::dsi::SourceKind,
    /// Whether the animations were smoothed.
    pub smoothed: bool,
    /// Variants written besides the animation.
    pub variants: u64,
    /// The variants' seed.
    pub seed: u64,
}

impl std::fmt::Display for ConvertSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "wrote {}", self.output.display())?;
        self.tracks.iter().try_for_each(|t| t.fmt(f))
    }
}

impl std::fmt::Display for TrackSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "  track {}: {} frames in, {} out{} at {} fps; {} frames needed the degenerate-input path{}; {} bones at rest ({})",
            self.track_id,
            self.frames_in,
            self.frames_out,
            if self.dsi.is_some() {
                " per animation"
            } else {
                ""
            },
            self.fps,
            self.degenerate_frames,
            if self.degenerate_frames > 0 {
                " (per bone and kind: -v, or `autoact info` on the output)"
            } else {
                ""
            },
            self.bones_at_rest,
            self.layout_name,
        )?;
        self.dsi.as_ref().map_or(Ok(()), |d| d.fmt(f))
    }
}

impl std::fmt::Display for DsiSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.threshold_rad {
            Some(t) => writeln!(
                f,
                "    DSI: {} unit motions, {} transitions above {t:.4} rad/frame (+{} frames, η = {:.3}), δ = {:.3}",
                self.segments, self.transitions, self.frames_added, self.eta, self.delta,
            )?,
            None => writeln!(f, "    resampled whole (no cuts), δ = {:.3}", self.delta)?,
        }
        if self.smoothed || self.variants > 0 {
            writeln!(
                f,
                "    {}{} variants (seed {})",
                if self.smoothed {
                    format!("smoothed as {}; ", self.source.name())
                } else {
                    String::new()
                },
                self.variants,
                self.seed
            )?;
        }
        Ok(())
    }
}

/// One person being converted.
pub(super) struct Person<'a> {
    pub(super) track_id: u64,
    /// The topic the person is on and the file it came from, to name lost frames.
    pub(super) topic: &'a str,
    pub(super) source: &'a str,
    pub(super) converter: SequenceConverter<'a>,
    pub(super) resampler: Resampler,
    pub(super) writer: TrackWriter,
    pub(super) frames_out: u64,
    /// For a camera-frame track: the transform that stands it on the ground
    /// ([`crate::skeleton::ground`]), applied to every frame before it is solved.
    pub(super) world_from_camera: Option<Isometry3<f64>>,
    /// Whether the track is an estimator's output (its points in a camera's frame, or imported
    /// from a camera-frame format): what `--dsi-source auto` smooths as
    /// [`crate::dsi::SourceKind::Estimator`].
    pub(super) estimator: bool,
}

/// `frame` in the world frame: moved by `world_from_camera` when the track is grounded.
pub(super) fn grounded<'f>(
    world_from_camera: Option<&Isometry3<f64>>,
    frame: &'f PoseFrame,
) -> Cow<'f, PoseFrame> {
    match world_from_camera {
        None => Cow::Borrowed(frame),
        Some(t) => {
            let mut moved = frame.clone();
            for p in &mut moved.positions_m {
                *p = t * *p;
            }
            Cow::Owned(moved)
        }
    }
}

/// The grounding of each track of `scan` (by index), for the tracks `job` grounds. The tracks
/// of one topic are one estimator's people, seen by one camera: they share one grounding
/// ([`ground::shared`], estimated on a pass-1 sample), so the people keep their places relative
/// to each other. A topic whose ground cannot be found is converted as it is, with a warning.
fn shared_groundings(
    job: &ConvertJob,
    scan: &PoseScan,
    layouts: &[Layout],
) -> Vec<Option<Isometry3<f64>>> {
    let mut groundings = vec![None; scan.tracks.len()];
    let mut topics: BTreeMap<&str, Vec<usize>> = BTreeMap::new();
    for (i, track) in scan.tracks.iter().enumerate() {
        if job.ground.applies(track.camera_frame) {
            topics.entry(track.topic.as_str()).or_default().push(i);
        }
    }
    for (topic, members) in topics {
        let found = ground::shared(
            &members,
            |&i| (scan.tracks[i].track_id, scan.tracks[i].frames),
            |&i| {
                let t = &scan.tracks[i];
                ground::estimate_frames(&layouts[i], &t.joint_names, &t.source, &t.sample)
            },
        );
        let shared = match found {
            Some(Ok(shared)) => shared,
            Some(Err(e)) => {
                tracing::warn!("{topic}: not grounded, converted in its own frame: {e}");
                continue;
            }
            None => continue,
        };
        if let Some(w) = shared.grounding.loose_fit_warning() {
            tracing::warn!("{topic} track {}: {w}", shared.track_id);
        }
        for &i in &members {
            let track_id = scan.tracks[i].track_id;
            tracing::info!("{topic} track {track_id}: {}", shared.note(track_id));
            groundings[i] = Some(shared.grounding.world_from_camera);
        }
    }
    groundings
}

/// Converts a pose bag into an animation bag, in two passes over the input: the first learns
/// each person's body from a bounded sample of their frames, the second solves, resamples and
/// writes every frame as it is read (or, with DSI, collects each person's clip). Losses
/// (unreadable parts, skipped messages, dropped frames) are logged as warnings when met and
/// returned in the summary; the output holds everything else. A gap in a person's stamps longer
/// than the maximum ([`ConvertJob::max_gap_s`]) is warned about and never interpolated across.
///
/// # Errors
/// [`PipelineError`]: options out of range ([`ConvertJob::check`]), an unreadable input, no pose topic, an unknown layout, no frame that can
/// be converted, DSI failing, or an output that cannot be written. A failing DSI leaves no file.
pub fn convert_bag(rig: &Rig, job: &ConvertJob) -> Result<ConvertSummary, PipelineError> {
    job.check()?;
    crate::atomic_file::refuse_input_as_output(&job.input, &job.output.path)?;
    job.output.refuse_existing()?;
    let given_layout = job.layout.as_deref().map(Layout::load).transpose()?;
    let scan =
        bags::pose::scan_pose_topics(&job.input, job.topic.as_deref(), given_layout.as_ref())?;
    let mut losses = Losses::from_read_issues(scan.issues.iter().cloned());
    for s in &scan.skipped {
        losses.push(Loss::Skipped(s.clone()));
    }
    losses.warn(WARN_LIMIT);
    warn_nan_messages(job, &scan.nan_messages);
    let prefixed = scan.tracks.len() > 1;
    let mut people = prepare_people(rig, job, &scan, given_layout.as_ref(), prefixed)?;
    let Some(first) = scan.tracks.iter().map(|t| t.first_stamp_nanos).min() else {
        return Err(PipelineError::NoFrames {
            input: job.input.clone(),
        });
    };
    let max_gaps: Vec<u64> = scan.tracks.iter().map(|t| max_gap_nanos(job, t)).collect();
    let mut meta = convert_metadata(rig, job, &people);
    let read_again = |on_frame: &mut dyn FnMut(StreamedFrame<'_>) -> Result<(), PipelineError>| {
        bags::pose::stream_pose_frames(
            &job.input,
            job.topic.as_deref(),
            given_layout.as_ref(),
            &scan,
            &max_gaps,
            on_frame,
        )
    };
    let tracks = if let Some(dsi) = &job.dsi {
        whole_clip::record_options(&mut meta, dsi);
        let spill_dir = crate::atomic_file::scratch_dir(&job.output.path);
        let mut clips: Vec<whole_clip::Clip> = scan
            .tracks
            .iter()
            .map(|t| whole_clip::Clip::new(t.track_id, &spill_dir, rig.bones.len()))
            .collect();
        let stamps = read_again(&mut |f| {
            let person = &mut people[f.track];
            let frame = grounded(person.world_from_camera.as_ref(), f.frame);
            clips[f.track].take(&mut person.converter, &frame, f.gap.is_some())
        })?;
        take_stamp_report(&stamps, &mut losses);
        // Whole clips are planned before the output exists, so a failing one leaves no file
        // (and the output, written under a temporary name, is never left half made).
        let (tracks, mut animations) =
            whole_clip::solve_all(rig, people, clips, dsi, prefixed, &mut losses)?;
        let mut out = BagOutput::create(&job.output)?;
        write_header(&mut out, &scan.metadata, meta, first, animations.writers())?;
        whole_clip::write_in_stamp_order(&mut out, &mut animations)?;
        write_degenerate(&mut out, &tracks)?;
        out.finish()?;
        tracks
    } else {
        let mut out = BagOutput::create(&job.output)?;
        let writers = people.iter().map(|p| &p.writer);
        write_header(&mut out, &scan.metadata, meta, first, writers)?;
        let stamps =
            read_again(&mut |f| stream_frame(&mut out, &mut people[f.track], &f, job.fps))?;
        take_stamp_report(&stamps, &mut losses);
        let tracks = finish_people(rig, &mut out, people, job.fps, &mut losses)?;
        write_degenerate(&mut out, &tracks)?;
        out.finish()?;
        tracks
    };
    Ok(ConvertSummary {
        output: job.output.path.clone(),
        tracks,
        losses,
    })
}

/// The name of the metadata record that explains the degenerate input of a conversion.
pub const DEGENERATE_RECORD: &str = "autoact.degenerate";

/// Explains every track's degenerate input (per bone, per kind) on stderr at `-v` and in the
/// [`DEGENERATE_RECORD`] metadata record (written after the frames, so `info` shows it), keyed
/// `track <id> <bone>`. Nothing when no bone needed the degenerate-input path.
fn write_degenerate(out: &mut BagOutput, tracks: &[TrackSummary]) -> Result<(), McapIoError> {
    let mut record = BTreeMap::new();
    for t in tracks {
        for (bone, events) in &t.degenerate_bones {
            let words = crate::skeleton::convert::describe_events(events);
            tracing::info!(
                "track {}: {bone} took the degenerate-input path: {words}",
                t.track_id
            );
            record.insert(format!("track {} {bone}", t.track_id), words);
        }
    }
    if record.is_empty() {
        return Ok(());
    }
    out.writer.write_metadata(DEGENERATE_RECORD, record)
}

/// The longest gap in a track's stamps that is interpolated across: `--max-gap` when given,
/// else [`DEFAULT_MAX_GAP_FRAMES`] of the track's own frame periods (no limit for a track with
/// fewer than two stamps).
fn max_gap_nanos(job: &ConvertJob, track: &bags::pose::TrackScan) -> u64 {
    match job.max_gap_s {
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            reason = "checked positive and finite; saturates at u64::MAX ns (584 years)"
        )]
        Some(s) => (s * 1e9).round() as u64,
        None => track
            .median_step_nanos
            .map_or(u64::MAX, |step| step.saturating_mul(DEFAULT_MAX_GAP_FRAMES)),
    }
}

/// Adds what the second pass found in the stamps: dropped frames become losses (warned), gaps
/// are warned (they lose nothing).
fn take_stamp_report(report: &StampReport, losses: &mut Losses) {
    let mut dropped = Losses::new();
    for s in &report.skipped {
        dropped.push(Loss::Skipped(s.clone()));
    }
    dropped.warn(WARN_LIMIT);
    losses.append(dropped);
    for gap in report.gaps.iter().take(WARN_LIMIT) {
        tracing::warn!("{gap}");
    }
    if report.gaps.len() > WARN_LIMIT {
        tracing::warn!(
            "... and {} more gaps longer than the maximum",
            report.gaps.len() - WARN_LIMIT
        );
    }
}

/// Warns about messages whose positions hold NaN: not lost, but those joints count as missing.
fn warn_nan_messages(job: &ConvertJob, nan_messages: &(Vec<(String, u64)>, u64)) {
    let (first, total) = nan_messages;
    if *total > 0 {
        let first: Vec<String> = first
            .iter()
            .map(|(t, i)| format!("{t} message {i}"))
            .collect();
        tracing::warn!(
            "{}: {total} messages have NaN positions (first: {}); those joints count as missing",
            job.input.display(),
            first.join(", ")
        );
    }
}

/// Prepares every person: their layout loaded (the given one, else the one their messages
/// name), their body fitted on the first pass's sample, their writer made.
fn prepare_people<'a>(
    rig: &'a Rig,
    job: &ConvertJob,
    scan: &'a PoseScan,
    given_layout: Option<&Layout>,
    prefixed: bool,
) -> Result<Vec<Person<'a>>, PipelineError> {
    let mut people = Vec::new();
    // A pose bag that `import` wrote from an estimator's output (grounded already if it was in a
    // camera's frame, so its tracks are not grounded again) is smoothed as an estimator's.
    let imported_from_estimator =
        crate::formats::import::InputFormat::imported_from_estimator(&scan.metadata);
    let layouts = scan
        .tracks
        .iter()
        .map(|track| match given_layout {
            Some(l) => Ok(l.clone()),
            None => Layout::load(&track.layout).map_err(|source| PipelineError::TopicLayout {
                topic: track.topic.clone(),
                layout: track.layout.clone(),
                source: Box::new(source),
            }),
        })
        .collect::<Result<Vec<_>, _>>()?;
    let groundings = shared_groundings(job, scan, &layouts);
    for ((track, layout), world_from_camera) in scan.tracks.iter().zip(layouts).zip(groundings) {
        let sample: Cow<'_, [PoseFrame]> = match &world_from_camera {
            None => Cow::Borrowed(&track.sample),
            Some(t) => track
                .sample
                .iter()
                .map(|f| grounded(Some(t), f).into_owned())
                .collect(),
        };
        let converter = SequenceConverter::from_sample(
            rig,
            &layout,
            &track.source,
            &track.joint_names,
            &sample,
            &track.observed,
            job.solve,
        )
        .map_err(|source| PipelineError::Prepare {
            topic: track.topic.clone(),
            track_id: track.track_id,
            source: Box::new(source),
        })?;
        let writer = TrackWriter::new(
            rig,
            converter.character(),
            converter.coverage(),
            track.track_id,
            0,
            &frame_prefix(track.track_id, 0, prefixed),
        );
        people.push(Person {
            track_id: track.track_id,
            topic: &track.topic,
            source: &track.source,
            converter,
            resampler: Resampler::new(job.fps),
            writer,
            frames_out: 0,
            world_from_camera,
            estimator: track.camera_frame || imported_from_estimator,
        });
    }
    Ok(people)
}

/// The `autoact.convert` metadata record: rig, source, rate, root motion, DoF set, tracks and
/// layouts.
fn convert_metadata(
    rig: &Rig,
    job: &ConvertJob,
    people: &[Person<'_>],
) -> BTreeMap<String, String> {
    let mut meta = BTreeMap::new();
    meta.insert("rig".to_string(), rig.name.to_string());
    meta.insert("source".to_string(), file_name(&job.input));
    meta.insert("fps".to_string(), format!("{}", job.fps));
    meta.insert(
        "root_motion".to_string(),
        format!("{:?}", job.solve.root_motion),
    );
    meta.insert("dof".to_string(), job.solve.dof.label().to_string());
    let joined =
        |f: &dyn Fn(&Person<'_>) -> String| people.iter().map(f).collect::<Vec<_>>().join(",");
    meta.insert("tracks".to_string(), joined(&|p| p.track_id.to_string()));
    meta.insert(
        "layouts".to_string(),
        joined(&|p| p.converter.layout_name().to_string()),
    );
    if let Some(g) = job.max_gap_s {
        meta.insert("max_gap_s".to_string(), g.to_string());
    }
    meta
}

/// Writes the metadata records and every writer's `/tf_static` transforms at `first`.
fn write_header<'w>(
    out: &mut BagOutput,
    source_metadata: &[(String, BTreeMap<String, String>)],
    meta: BTreeMap<String, String>,
    first: u64,
    writers: impl Iterator<Item = &'w TrackWriter>,
) -> Result<(), McapIoError> {
    for (name, record) in source_metadata {
        out.writer.write_metadata(name, record.clone())?;
    }
    out.writer
        .write_metadata(bags::animation::METADATA_NAME, meta)?;
    let statics = writers.flat_map(|w| w.static_transforms(first)).collect();
    out.writer.write(
        TF_STATIC_TOPIC,
        first,
        &TFMessage {
            transforms: statics,
        },
    )
}

/// Solves one frame of a person, resamples and writes it at once. A frame after a gap first
/// ends the person's resampled stretch (its last frames written), so nothing is interpolated
/// across the gap.
fn stream_frame(
    out: &mut BagOutput,
    person: &mut Person<'_>,
    f: &StreamedFrame<'_>,
    fps: f64,
) -> Result<(), PipelineError> {
    let Person {
        converter,
        resampler,
        writer,
        frames_out,
        world_from_camera,
        ..
    } = person;
    let mut result = Ok(());
    let mut emit = |t, p: &_| {
        if result.is_ok() {
            result = writer.write_frame(&mut out.writer, t, p);
            *frames_out += 1;
        }
    };
    if f.gap.is_some() {
        std::mem::replace(resampler, Resampler::new(fps)).finish(&mut emit);
    }
    let frame = grounded(world_from_camera.as_ref(), f.frame);
    if let Some((stamp, pose)) = converter.push(&frame)? {
        resampler.push(stamp, pose, &mut emit);
    }
    result?;
    Ok(())
}

/// Ends every streamed person: the resampler's last frames written, the report summed up, the
/// frames dropped for non-monotonic stamps logged and added to `losses`.
fn finish_people(
    rig: &Rig,
    out: &mut BagOutput,
    people: Vec<Person<'_>>,
    fps: f64,
    losses: &mut Losses,
) -> Result<Vec<TrackSummary>, PipelineError> {
    let mut tracks = Vec::with_capacity(people.len());
    for person in people {
        let Person {
            track_id,
            topic,
            source,
            converter,
            resampler,
            mut writer,
            mut frames_out,
            world_from_camera: _,
            estimator: _,
        } = person;
        let mut result = Ok(());
        resampler.finish(&mut |t, p| {
            if result.is_ok() {
                result = writer.write_frame(&mut out.writer, t, p);
                frames_out += 1;
            }
        });
        result?;
        let layout_name = converter.layout_name().to_string();
        let (_, report) = converter.finish();
        let dropped = Losses::non_monotonic(source, topic, track_id, &report.dropped_non_monotonic);
        dropped.warn(WARN_LIMIT);
        losses.append(dropped);
        tracks.push(TrackSummary {
            track_id,
            frames_in: report.frames,
            frames_out,
            fps,
            degenerate_frames: report.degenerate_frames,
            degenerate_bones: report.degenerate_bones(rig),
            bones_at_rest: report.coverage.at_rest.len(),
            layout_name,
            dsi: None,
        });
    }
    Ok(tracks)
}
