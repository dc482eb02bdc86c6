//! The `convert` stage: a pose bag → an animation bag.
//!
//! Every person of the input is prepared (body fitted, layout bound); then either all of them
//! are streamed out in time order — each input frame solved, resampled and written at once — or,
//! with DSI options, each person's clip is solved whole, interpolated, varied and smoothed
//! ([`super::whole_clip`]) before the output is created.

use std::collections::BTreeMap;
use std::path::PathBuf;

use super::PipelineError;
use super::whole_clip;
use crate::bags;
use crate::bags::animation::{TF_STATIC_TOPIC, TrackWriter, frame_prefix};
use crate::bags::output::{BagOutput, OutputOptions};
use crate::bags::pose::PoseTopics;
use crate::dsi::{DsiOptions, Pace};
use crate::file_name;
use crate::loss::{Losses, WARN_LIMIT};
use crate::mcap_io::McapIoError;
use crate::ros::tf2_msgs::TFMessage;
use crate::skeleton::convert::{ConvertOptions, SequenceConverter};
use crate::skeleton::layout::Layout;
use crate::skeleton::resample::Resampler;
use crate::skeleton::rig::Rig;

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
    /// Where the animation bag goes.
    pub output: OutputOptions,
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
            "  track {}: {} frames in, {} out{} at {} fps; {} frames needed the degenerate-input path; {} bones at rest ({})",
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
                if self.smoothed { "smoothed; " } else { "" },
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
}

/// Converts a pose bag into an animation bag. Losses (unreadable parts, skipped messages,
/// dropped frames) are logged as warnings when met and returned in the summary; the output holds
/// everything else.
///
/// # Errors
/// [`PipelineError`]: options out of range ([`ConvertJob::check`]), an unreadable input, no pose topic, an unknown layout, no frame that can
/// be converted, DSI failing, or an output that cannot be written. A failing DSI leaves no file.
pub fn convert_bag(rig: &Rig, job: &ConvertJob) -> Result<ConvertSummary, PipelineError> {
    job.check()?;
    crate::atomic_file::refuse_input_as_output(&job.input, &job.output.path)?;
    let given_layout = job.layout.as_deref().map(Layout::load).transpose()?;
    let topics =
        bags::pose::read_pose_topics(&job.input, job.topic.as_deref(), given_layout.as_ref())?;
    let mut losses = Losses::from_pose_topics(&topics);
    losses.warn(WARN_LIMIT);
    warn_nan_messages(job, &topics);
    let prefixed = topics
        .sequences
        .iter()
        .filter(|(_, s)| !s.frames.is_empty())
        .count()
        > 1;
    let mut people = prepare_people(rig, job, &topics, given_layout.as_ref(), prefixed)?;
    let Some(first) = people.iter().filter_map(|p| p.converter.peek_stamp()).min() else {
        return Err(PipelineError::NoFrames {
            input: job.input.clone(),
        });
    };
    let mut meta = convert_metadata(rig, job, &people);
    let tracks = if let Some(dsi) = &job.dsi {
        whole_clip::record_options(&mut meta, dsi);
        // Whole clips are solved before the output exists, so a failing one leaves no file.
        let (tracks, mut animations) =
            whole_clip::solve_all(rig, people, dsi, prefixed, &mut losses)?;
        let mut out = BagOutput::create(&job.output)?;
        let writers = animations.iter().map(|(w, _)| w);
        write_header(&mut out, &topics.metadata, meta, first, writers)?;
        whole_clip::write_in_stamp_order(&mut out, &mut animations)?;
        out.finish()?;
        tracks
    } else {
        let mut out = BagOutput::create(&job.output)?;
        let writers = people.iter().map(|p| &p.writer);
        write_header(&mut out, &topics.metadata, meta, first, writers)?;
        stream(&mut out, &mut people)?;
        let tracks = finish_people(&mut out, people, job.fps, &mut losses)?;
        out.finish()?;
        tracks
    };
    Ok(ConvertSummary {
        output: job.output.path.clone(),
        tracks,
        losses,
    })
}

/// Warns about messages whose positions hold NaN: not lost, but those joints count as missing.
fn warn_nan_messages(job: &ConvertJob, topics: &PoseTopics) {
    let (first, total) = &topics.nan_messages;
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

/// Prepares every person with frames: their layout loaded (the given one, else the one their
/// messages name), their body fitted, their writer made.
fn prepare_people<'a>(
    rig: &'a Rig,
    job: &ConvertJob,
    topics: &'a PoseTopics,
    given_layout: Option<&Layout>,
    prefixed: bool,
) -> Result<Vec<Person<'a>>, PipelineError> {
    let mut people = Vec::new();
    for ((topic, seq), layout_name) in topics.sequences.iter().zip(&topics.layouts) {
        if seq.frames.is_empty() {
            continue;
        }
        let layout = match given_layout {
            Some(l) => l.clone(),
            None => Layout::load(layout_name).map_err(|source| PipelineError::TopicLayout {
                topic: topic.clone(),
                layout: layout_name.clone(),
                source: Box::new(source),
            })?,
        };
        let converter = SequenceConverter::new(rig, &layout, seq, job.solve).map_err(|source| {
            PipelineError::Prepare {
                topic: topic.clone(),
                track_id: seq.track_id,
                source: Box::new(source),
            }
        })?;
        let writer = TrackWriter::new(
            rig,
            converter.character(),
            converter.coverage(),
            seq.track_id,
            0,
            &frame_prefix(seq.track_id, 0, prefixed),
        );
        people.push(Person {
            track_id: seq.track_id,
            topic,
            source: &seq.source,
            converter,
            resampler: Resampler::new(job.fps),
            writer,
            frames_out: 0,
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

/// Streams every person out in time order: each input frame is solved, resampled and written at
/// once, always advancing the person whose next input frame is earliest.
fn stream(out: &mut BagOutput, people: &mut [Person<'_>]) -> Result<(), PipelineError> {
    while let Some(k) = (0..people.len())
        .filter(|&k| people[k].converter.peek_stamp().is_some())
        .min_by_key(|&k| people[k].converter.peek_stamp())
    {
        let Person {
            converter,
            resampler,
            writer,
            frames_out,
            ..
        } = &mut people[k];
        let Some(step) = converter.next_frame() else {
            continue;
        };
        let (stamp, pose) = step?;
        let mut result = Ok(());
        resampler.push(stamp, pose, &mut |t, p| {
            if result.is_ok() {
                result = writer.write_frame(&mut out.writer, t, p);
                *frames_out += 1;
            }
        });
        result?;
    }
    Ok(())
}

/// Ends every streamed person: the resampler's last frames written, the report summed up, the
/// frames dropped for non-monotonic stamps logged and added to `losses`.
fn finish_people(
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
            bones_at_rest: report.coverage.at_rest.len(),
            layout_name,
            dsi: None,
        });
    }
    Ok(tracks)
}
