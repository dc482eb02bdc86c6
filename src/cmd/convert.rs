//! `autoact convert`: a pose bag → an animation bag.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};

use super::{BagOutput, Outcome, OutputArgs, file_name, print_stdout, warn_list};
use crate::animation_bag::{TF_STATIC_TOPIC, TrackWriter};
use crate::convert::{ConvertOptions, RootMotion, SequenceConverter};
use crate::layout::Layout;
use crate::pose_bag::{self, METADATA_NAME};
use crate::resample::Resampler;
use crate::rig::Rig;
use crate::ros::tf2_msgs::TFMessage;

/// Arguments of `autoact convert`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The pose bag (`.mcap`).
    pub input: PathBuf,
    /// Convert only this topic (default: every topic carrying a pose type).
    #[arg(long)]
    pub topic: Option<String>,
    /// Keypoint layout of the input (built-in name or .toml file). Required for MarkerArray and
    /// PoseArray topics; skeleton messages name their own.
    #[arg(long, value_name = "LAYOUT")]
    pub layout: Option<String>,
    /// Output frame rate: frames are resampled from the input stamps on the rotation group.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f64,
    /// How the root follows the pelvis.
    #[arg(long, value_enum, default_value_t = RootMotion::Full)]
    pub root_motion: RootMotion,
    /// Joints below this confidence count as missing.
    #[arg(long, default_value_t = 0.3)]
    pub min_confidence: f32,
    /// Output options.
    #[command(flatten)]
    pub output: OutputArgs,
}

/// Runs `autoact convert`.
///
/// # Errors
/// An unreadable input, no pose topic, an unknown layout, or an output that cannot be written.
pub fn run(args: Args) -> Result<Outcome> {
    let Args {
        input,
        topic,
        layout,
        fps,
        root_motion,
        min_confidence,
        output,
    } = args;
    if !(fps.is_finite() && fps > 0.0) {
        bail!("--fps must be a positive number of frames per second, not {fps}");
    }
    if !(0.0..=1.0).contains(&min_confidence) {
        bail!("--min-confidence must be in [0, 1], not {min_confidence}");
    }
    let given_layout = layout.as_deref().map(Layout::load).transpose()?;
    let topics = pose_bag::read_pose_topics(&input, topic.as_deref(), given_layout.as_ref())?;
    warn_list("unreadable parts", &topics.issues, 5);
    warn_list("skipped messages", &topics.skipped, 5);
    if topics.nan_messages.1 > 0 {
        let first: Vec<String> = topics
            .nan_messages
            .0
            .iter()
            .map(|(t, i)| format!("{t} message {i}"))
            .collect();
        tracing::warn!(
            "{}: {} messages have NaN positions (first: {}); those joints count as missing",
            input.display(),
            topics.nan_messages.1,
            first.join(", ")
        );
    }
    let rig = Rig::standard();
    let options = ConvertOptions {
        min_confidence,
        root_motion,
        ..ConvertOptions::default()
    };
    // Prepare every person (fit the body, bind the layout), then stream all of them out in time
    // order: each input frame is solved, resampled and written at once.
    let mut people: Vec<Person<'_>> = Vec::new();
    let prefixed = topics
        .sequences
        .iter()
        .filter(|(_, s)| !s.frames.is_empty())
        .count()
        > 1;
    for ((topic, seq), layout_name) in topics.sequences.iter().zip(&topics.layouts) {
        if seq.frames.is_empty() {
            continue;
        }
        let layout = match &given_layout {
            Some(l) => l.clone(),
            None => Layout::load(layout_name).with_context(|| {
                format!("{topic}: its messages name the layout `{layout_name}`; give --layout")
            })?,
        };
        let converter = SequenceConverter::new(&rig, &layout, seq, options)
            .with_context(|| format!("converting {topic} track {}", seq.track_id))?;
        let writer = TrackWriter::new(
            &rig,
            converter.character().clone(),
            converter.coverage(),
            seq.track_id,
            prefixed,
        );
        people.push(Person {
            track_id: seq.track_id,
            converter,
            resampler: Resampler::new(fps),
            writer,
            frames_out: 0,
        });
    }
    let Some(first) = people.iter().filter_map(|p| p.converter.peek_stamp()).min() else {
        bail!("{}: no frames could be converted", input.display());
    };

    let mut out = BagOutput::create(&output)?;
    for (name, record) in &topics.metadata {
        out.writer.write_metadata(name, record.clone())?;
    }
    let mut meta = BTreeMap::new();
    meta.insert("rig".to_string(), rig.name.to_string());
    meta.insert("source".to_string(), file_name(&input));
    meta.insert("fps".to_string(), format!("{fps}"));
    meta.insert("root_motion".to_string(), format!("{root_motion:?}"));
    meta.insert(
        "tracks".to_string(),
        people
            .iter()
            .map(|p| p.track_id.to_string())
            .collect::<Vec<_>>()
            .join(","),
    );
    meta.insert(
        "layouts".to_string(),
        people
            .iter()
            .map(|p| p.converter.layout_name().to_string())
            .collect::<Vec<_>>()
            .join(","),
    );
    out.writer
        .write_metadata(&format!("{METADATA_NAME}.convert"), meta)?;
    let statics = people
        .iter()
        .flat_map(|p| p.writer.static_transforms(first))
        .collect();
    out.writer.write(
        TF_STATIC_TOPIC,
        first,
        &TFMessage {
            transforms: statics,
        },
    )?;

    // Always advance the person whose next input frame is earliest.
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
    let mut text = format!("wrote {}\n", output.output.display());
    let mut lost = topics.lost_data();
    for person in people {
        let Person {
            track_id,
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
        lost |= report.lost_data();
        text.push_str(&format!(
            "  track {track_id}: {} frames in, {frames_out} out at {fps} fps; {} frames needed the degenerate-input path; {} bones at rest ({layout_name})\n",
            report.frames,
            report.degenerate_frames,
            report.coverage.at_rest.len(),
        ));
        if !report.dropped_non_monotonic.is_empty() {
            tracing::warn!(
                "track {track_id}: {} frames dropped for non-monotonic stamps",
                report.dropped_non_monotonic.len()
            );
        }
    }
    out.finish()?;
    print_stdout(&text)?;
    if lost {
        tracing::error!(
            "{}: some input could not be used ({} unreadable parts, {} skipped messages); the output holds everything else",
            input.display(),
            topics.issues.len(),
            topics.skipped.len()
        );
        return Ok(Outcome::DataLost);
    }
    Ok(Outcome::Success)
}

/// One person being converted.
struct Person<'a> {
    track_id: u64,
    converter: SequenceConverter<'a>,
    resampler: Resampler,
    writer: TrackWriter<'a>,
    frames_out: u64,
}
