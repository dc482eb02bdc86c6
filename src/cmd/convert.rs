//! `autoact convert`: a pose bag → an animation bag.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};

use super::{BagOutput, Outcome, OutputArgs, print_stdout, warn_list};
use crate::bags;
use crate::bags::animation::{TF_STATIC_TOPIC, TrackWriter, frame_prefix};
use crate::bags::pose::METADATA_NAME;
use crate::dsi::plan::Threshold;
use crate::dsi::smoothing::Smoothing;
use crate::dsi::variants::VariationBounds;
use crate::dsi::{self, DsiOptions, Pace};
use crate::file_name;
use crate::ros::tf2_msgs::TFMessage;
use crate::skeleton::convert::{AnimationFrame, ConvertOptions, RootMotion, SequenceConverter};
use crate::skeleton::layout::Layout;
use crate::skeleton::resample::Resampler;
use crate::skeleton::rig::Rig;

/// Arguments of `autoact convert`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The pose bag (`.mcap` or rosbag2 directory).
    #[arg(required_unless_present = "spec")]
    pub input: Option<PathBuf>,
    /// Build a dataset's capture sessions from this spec instead (see `examples/dataset.toml`
    /// and `autoact plan`): `-o` is then a folder that receives `<session>.capture.mcap` per
    /// session and `plan.json`.
    #[arg(long, value_name = "DATASET.toml", conflicts_with_all = ["input", "topic", "layout", "rosbag2"])]
    pub spec: Option<PathBuf>,
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
    /// Dynamic Skeletal Interpolation, smoothing and variants.
    #[command(flatten)]
    pub dsi: DsiArgs,
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

/// `convert`'s DSI options. Without any of them, `convert` streams: each frame is solved,
/// resampled by slerp and written at once. With any, each person's clip is solved whole, then
/// interpolated, varied and smoothed.
#[derive(Debug, clap::Args)]
#[command(next_help_heading = "Dynamic Skeletal Interpolation (whole clips)")]
pub struct DsiArgs {
    /// Run DSI: cut the clip into unit motions at fast transitions, resample them at real speed
    /// with a tangent-space cubic, give each transition extra frames, smooth (SuperSmoother).
    #[arg(long)]
    pub dsi: bool,
    /// Where DSI cuts: `3x` (3 × the clip's median weighted angular distance, never below
    /// 0.5 rad/s), `0.05rad` (radians per source frame, the paper's unit), `1.5rad/s`, `90deg/s`,
    /// or `off` [default: 3x]. Implies --dsi.
    #[arg(long, value_name = "THRESHOLD")]
    pub dsi_threshold: Option<Threshold>,
    /// η: a transition whose weighted angular distance is d radians gets ⌈η·d/δ⌉ output frames
    /// (never fewer than at real speed) [default: 1/threshold, so a transition at the threshold
    /// keeps its duration]. Implies --dsi.
    #[arg(long, value_name = "ETA")]
    pub eta: Option<f64>,
    /// Weight of a bone in the angular distance, BONE=WEIGHT (repeatable). Defaults: upper
    /// arms and thighs 3, forearms, calves and root 2, spine 1.5, neck, head, hands and feet 1,
    /// fingers 0.2, static bones 0. Implies --dsi.
    #[arg(long = "dsi-weight", value_name = "BONE=WEIGHT")]
    pub dsi_weights: Vec<String>,
    /// Playback speed of the unit motions, × real time [default: 1].
    #[arg(long, value_name = "FACTOR", conflicts_with = "delta")]
    pub speed: Option<f64>,
    /// The paper's interpolation rate δ: source frames per output frame (δ = speed × source
    /// fps / --fps), instead of --speed.
    #[arg(long, value_name = "DELTA")]
    pub delta: Option<f64>,
    /// SuperSmoother in the tangent space: `on`, `off`, or the tweeter, midrange and woofer
    /// spans in seconds `T,M,W` [default: on (0.1,0.2,0.6) with DSI, off without].
    #[arg(long, value_name = "on|off|T,M,W")]
    pub smooth: Option<SmoothArg>,
    /// Friedman's bass control α in [0, 10]: higher prefers the woofer (smoother) where the fit
    /// allows [default: none].
    #[arg(long, value_name = "ALPHA")]
    pub smooth_bass: Option<f64>,
    /// Seeded random variants to write besides each animation: variant k of person N is its own
    /// animation (BoneFrame `variant` = k, tf frames under `v<k>/`).
    #[arg(long, value_name = "V", default_value_t = 0)]
    pub variants: u64,
    /// Bound of the variants' perturbation per DoF class, degrees: one number (every class but
    /// the root) or CLASS=DEG pairs of 3d, 2d, hinge, root.
    #[arg(long, value_name = "DEG", default_value = "3d=6,2d=6,hinge=8,root=0")]
    pub variation_deg: VariationBounds,
    /// Seed of the variants (recorded in the bag's metadata): the same seed gives the same
    /// variants on every machine.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
}

/// `--smooth`'s value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SmoothArg {
    /// Default spans.
    On,
    /// No smoothing.
    Off,
    /// These spans, seconds.
    Spans([f64; 3]),
}

impl std::str::FromStr for SmoothArg {
    type Err = String;

    fn from_str(s: &str) -> Result<SmoothArg, String> {
        match s.trim() {
            "on" => Ok(SmoothArg::On),
            "off" => Ok(SmoothArg::Off),
            spans => {
                let v: Vec<f64> = spans
                    .split(',')
                    .map(|x| x.trim().parse::<f64>())
                    .collect::<Result<_, _>>()
                    .map_err(|_| format!("`{s}`: give on, off, or three spans in seconds T,M,W"))?;
                let [t, m, w] = v[..] else {
                    return Err(format!("`{s}`: give three spans in seconds T,M,W"));
                };
                Ok(SmoothArg::Spans([t, m, w]))
            }
        }
    }
}

impl DsiArgs {
    /// DSI's options, or `None` when none was asked for (streaming conversion).
    fn options(&self, rig: &Rig, fps: f64) -> Result<Option<DsiOptions>> {
        let segmenting = self.dsi
            || self.dsi_threshold.is_some()
            || self.eta.is_some()
            || !self.dsi_weights.is_empty();
        let whole = segmenting
            || self.speed.is_some()
            || self.delta.is_some()
            || self.smooth.is_some_and(|s| s != SmoothArg::Off)
            || self.smooth_bass.is_some()
            || self.variants > 0;
        if !whole {
            return Ok(None);
        }
        let mut options = DsiOptions::new(rig);
        options.out_fps = fps;
        options.threshold = if segmenting {
            self.dsi_threshold.unwrap_or_default()
        } else {
            Threshold::Off
        };
        options.eta = self.eta;
        dsi::apply_weight_overrides(rig, &mut options.weights, &self.dsi_weights)?;
        options.pace = match (self.speed, self.delta) {
            (_, Some(d)) => Pace::Delta(d),
            (s, None) => Pace::Speed(s.unwrap_or(1.0)),
        };
        let spans = match self.smooth {
            Some(SmoothArg::Off) => None,
            Some(SmoothArg::Spans(s)) => Some(s),
            Some(SmoothArg::On) => Some(Smoothing::default().spans_s),
            None => {
                (segmenting || self.smooth_bass.is_some()).then(|| Smoothing::default().spans_s)
            }
        };
        options.smoothing = spans.map(|spans_s| Smoothing {
            spans_s,
            bass: self.smooth_bass,
        });
        options.variants = self.variants;
        options.bounds = self.variation_deg;
        options.seed = self.seed;
        if let Some(s) = &options.smoothing {
            s.validate().map_err(anyhow::Error::msg)?;
        }
        for (name, v) in [
            ("--speed", self.speed),
            ("--delta", self.delta),
            ("--eta", self.eta),
        ] {
            if let Some(v) = v
                && !(v.is_finite() && v > 0.0)
            {
                bail!("{name} must be a positive number, not {v}");
            }
        }
        if self.variants > u64::from(u32::MAX) {
            bail!("--variants is at most {}", u32::MAX);
        }
        Ok(Some(options))
    }
}

/// Runs `autoact convert`.
///
/// # Errors
/// An unreadable input, no pose topic, an unknown layout, or an output that cannot be written.
pub fn run(args: Args) -> Result<Outcome> {
    let Args {
        input,
        spec,
        topic,
        layout,
        fps,
        dsi,
        root_motion,
        min_confidence,
        output,
    } = args;
    if let Some(spec) = spec {
        return run_spec(&spec, &output);
    }
    let Some(input) = input else {
        bail!("give a pose bag, or --spec DATASET.toml");
    };
    if !(fps.is_finite() && fps > 0.0) {
        bail!("--fps must be a positive number of frames per second, not {fps}");
    }
    if !(0.0..=1.0).contains(&min_confidence) {
        bail!("--min-confidence must be in [0, 1], not {min_confidence}");
    }
    let given_layout = layout.as_deref().map(Layout::load).transpose()?;
    let topics = bags::pose::read_pose_topics(&input, topic.as_deref(), given_layout.as_ref())?;
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
    let dsi_options = dsi.options(&rig, fps)?;
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
            converter.character(),
            converter.coverage(),
            seq.track_id,
            0,
            &frame_prefix(seq.track_id, 0, prefixed),
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
    let mut text = format!("wrote {}\n", output.output.display());
    let mut lost = topics.lost_data();
    // Whole clips are solved before the output exists, so a failing one leaves no file.
    let mut clips = None;
    if let Some(dsi_options) = &dsi_options {
        record_dsi_options(&mut meta, dsi_options);
        let mut all = Vec::new();
        for person in std::mem::take(&mut people) {
            let (summary, clip_lost, animations) = whole_clip(&rig, person, dsi_options, prefixed)?;
            text.push_str(&summary);
            lost |= clip_lost;
            all.extend(animations);
        }
        clips = Some(all);
    }
    let mut out = BagOutput::create(&output)?;
    let writers: Vec<&TrackWriter> = match &clips {
        Some(clips) => clips.iter().map(|(w, _)| w).collect(),
        None => people.iter().map(|p| &p.writer).collect(),
    };
    write_header(&mut out, &topics.metadata, meta, first, writers.into_iter())?;
    if let Some(mut clips) = clips {
        // All animations in stamp order (ties: person, then variant).
        let mut order: Vec<(u64, usize, usize)> = clips
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
            let (writer, frames) = &mut clips[c];
            writer.write_frame(&mut out.writer, stamp, &frames[k].pose)?;
        }
    } else {
        stream(&mut out, &mut people)?;
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
            warn_non_monotonic(track_id, &report.dropped_non_monotonic);
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

/// Writes the metadata records and every writer's `/tf_static` transforms at `first`.
fn write_header<'w>(
    out: &mut BagOutput,
    source_metadata: &[(String, BTreeMap<String, String>)],
    meta: BTreeMap<String, String>,
    first: u64,
    writers: impl Iterator<Item = &'w TrackWriter>,
) -> Result<()> {
    for (name, record) in source_metadata {
        out.writer.write_metadata(name, record.clone())?;
    }
    out.writer
        .write_metadata(&format!("{METADATA_NAME}.convert"), meta)?;
    let statics = writers.flat_map(|w| w.static_transforms(first)).collect();
    out.writer.write(
        TF_STATIC_TOPIC,
        first,
        &TFMessage {
            transforms: statics,
        },
    )?;
    Ok(())
}

/// Streams every person out in time order: each input frame is solved, resampled and written at
/// once, always advancing the person whose next input frame is earliest.
fn stream(out: &mut BagOutput, people: &mut [Person<'_>]) -> Result<()> {
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

/// `convert --spec`: every source converted, the plan laid out with the exact lengths, one bag
/// per capture session and the plan as JSON in the output folder.
fn run_spec(spec_path: &std::path::Path, output: &OutputArgs) -> Result<Outcome> {
    use crate::dataset::{capture, plan::Plan, spec::Spec};
    let spec = Spec::load(spec_path)?;
    let rig = Rig::standard();
    let estimated = crate::dataset::estimated_frames(&spec).map_err(anyhow::Error::msg)?;
    let mut plan = Plan::build(&spec, &|class, source| estimated[class][source])
        .map_err(anyhow::Error::msg)?;
    let mut converted = Vec::with_capacity(plan.animations.len());
    for (a, anim) in plan.animations.clone().iter().enumerate() {
        tracing::info!(
            "converting {} ({}/{})",
            anim.name,
            a + 1,
            plan.animations.len()
        );
        let conv = capture::convert_source(&rig, &spec, anim.class, anim.source, &anim.name)?;
        for (v, frames) in conv.variants.iter().enumerate() {
            plan.set_frames(
                &spec,
                a,
                u32::try_from(v).unwrap_or(u32::MAX),
                frames.len() as u64,
            );
        }
        converted.push(conv);
    }
    let dir = &output.output;
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let config = crate::mcap_io::WriteConfig {
        compression: output.compression,
        ..crate::mcap_io::WriteConfig::default()
    };
    let sessions = capture::write_sessions(
        &rig,
        &spec,
        &plan,
        &converted,
        dir,
        config,
        output.write_expected_json,
    )?;
    let plan_path = dir.join("plan.json");
    std::fs::write(
        &plan_path,
        serde_json::to_string_pretty(&serde_json::json!({"estimated": false, "plan": plan}))?,
    )
    .with_context(|| format!("writing {}", plan_path.display()))?;
    let mut text = format!(
        "wrote {} sessions, {} clips into {} (and plan.json)\n",
        sessions.len(),
        plan.leaves.len(),
        dir.display()
    );
    for s in &sessions {
        #[expect(clippy::cast_precision_loss, reason = "display only")]
        let seconds = s.frames as f64 / spec.file.dataset.fps;
        text.push_str(&format!(
            "  {}: {} clips, {} frames ({seconds:.1} s)\n",
            file_name(&s.path),
            s.clips,
            s.frames
        ));
        if s.viewpoints_pushed_out > 0 {
            tracing::warn!(
                "{}: {} viewpoints moved out beyond the plan's distance to keep a wide movement in frame",
                file_name(&s.path),
                s.viewpoints_pushed_out
            );
        }
    }
    print_stdout(&text)?;
    Ok(Outcome::Success)
}

/// Each animation's writer and frames.
type Animations = Vec<(TrackWriter, Vec<AnimationFrame>)>;

/// Solves one person's whole clip and runs DSI on it: the summary line, whether input was lost,
/// and a writer with its frames per animation (variant 0 first).
fn whole_clip<'r>(
    rig: &'r Rig,
    person: Person<'r>,
    options: &DsiOptions,
    several_people: bool,
) -> Result<(String, bool, Animations)> {
    let Person {
        track_id,
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
    warn_non_monotonic(track_id, &report.dropped_non_monotonic);
    let result =
        dsi::run(rig, &keys, options).with_context(|| format!("DSI on track {track_id}"))?;
    let plan = &result.plan;
    let mut summary = format!(
        "  track {track_id}: {} frames in, {} out per animation at {} fps; {} frames needed the degenerate-input path; {} bones at rest ({layout_name})\n",
        report.frames,
        result.animations[0].len(),
        options.out_fps,
        report.degenerate_frames,
        report.coverage.at_rest.len(),
    );
    summary.push_str(&match plan.threshold_rad {
        Some(t) => format!(
            "    DSI: {} unit motions, {} transitions above {:.4} rad/frame (+{} frames, η = {:.3}), δ = {:.3}\n",
            plan.segments,
            plan.transition_count(),
            t,
            plan.frames_added(),
            plan.eta,
            plan.delta,
        ),
        None => format!("    resampled whole (no cuts), δ = {:.3}\n", plan.delta),
    });
    if options.smoothing.is_some() || options.variants > 0 {
        summary.push_str(&format!(
            "    {}{} variants (seed {})\n",
            if options.smoothing.is_some() {
                "smoothed; "
            } else {
                ""
            },
            options.variants,
            options.seed
        ));
    }
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
    Ok((summary, report.lost_data(), animations))
}

/// Puts every DSI parameter in the `autoact.convert` record, so a bag says how it was made.
fn record_dsi_options(meta: &mut BTreeMap<String, String>, o: &DsiOptions) {
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

fn warn_non_monotonic(track_id: u64, dropped: &[(usize, u64)]) {
    if !dropped.is_empty() {
        tracing::warn!(
            "track {track_id}: {} frames dropped for non-monotonic stamps",
            dropped.len()
        );
    }
}

/// One person being converted.
struct Person<'a> {
    track_id: u64,
    converter: SequenceConverter<'a>,
    resampler: Resampler,
    writer: TrackWriter,
    frames_out: u64,
}
