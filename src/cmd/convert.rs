//! `autoact convert`: a pose bag → an animation bag.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};

use super::{BagOutput, Outcome, OutputArgs, file_name, print_stdout, warn_list};
use crate::animation_bag::{self, Track};
use crate::convert::{Animation, ConvertOptions, RootMotion, convert_sequence};
use crate::layout::Layout;
use crate::pose_bag::{self, METADATA_NAME};
use crate::resample::resample;
use crate::rig::Rig;

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
    let mut animations: Vec<Animation> = Vec::new();
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
        let animation = convert_sequence(&rig, &layout, seq, options)
            .with_context(|| format!("converting {topic} track {}", seq.track_id))?;
        animations.push(animation);
    }
    if animations.is_empty() {
        bail!("{}: no frames could be converted", input.display());
    }
    let resampled: Vec<_> = animations
        .iter()
        .map(|a| resample(&a.frames, fps))
        .collect();
    let tracks: Vec<Track<'_>> = topics
        .sequences
        .iter()
        .filter(|(_, s)| !s.frames.is_empty())
        .zip(&animations)
        .zip(&resampled)
        .map(|(((_, seq), animation), frames)| Track {
            animation,
            frames,
            track_id: seq.track_id,
        })
        .collect();

    let mut out = BagOutput::create(&output)?;
    for (name, record) in &topics.metadata {
        out.writer.write_metadata(name, record.clone())?;
    }
    let mut meta = animation_bag::convert_metadata(&rig, &tracks, fps, &file_name(&input));
    meta.insert("root_motion".into(), format!("{root_motion:?}"));
    out.writer
        .write_metadata(&format!("{METADATA_NAME}.convert"), meta)?;
    animation_bag::write_animation(&mut out.writer, &rig, &tracks)?;
    out.finish()?;

    let mut text = format!("wrote {}\n", output.output.display());
    let mut lost = topics.lost_data();
    for t in &tracks {
        let r = &t.animation.report;
        lost |= r.lost_data();
        text.push_str(&format!(
            "  track {}: {} frames in, {} out at {fps} fps; {} frames needed the degenerate-input path; {} bones at rest ({})\n",
            t.track_id,
            r.frames,
            t.frames.len(),
            r.degenerate_frames,
            r.coverage.at_rest.len(),
            t.animation.layout_name,
        ));
        if !r.dropped_non_monotonic.is_empty() {
            tracing::warn!(
                "track {}: {} frames dropped for non-monotonic stamps",
                t.track_id,
                r.dropped_non_monotonic.len()
            );
        }
    }
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
