//! `autoact convert`: a pose bag → an animation bag ([`crate::pipeline::convert`]), or a dataset
//! spec → its capture sessions ([`crate::pipeline::spec`]).

use std::path::PathBuf;

use anyhow::{Result, bail};

use super::{Outcome, OutputArgs, print_stdout};
use crate::dsi::plan::Threshold;
use crate::dsi::smoothing::Smoothing;
use crate::dsi::variants::VariationBounds;
use crate::dsi::{self, DsiOptions, Pace, SourceKind};
use crate::pipeline;
use crate::pipeline::convert::ConvertJob;
use crate::pipeline::spec::SpecJob;
use crate::skeleton::convert::{ConvertOptions, RootMotion};
use crate::skeleton::ground::GroundMode;
use crate::skeleton::rig::{DofSet, Rig};

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
    /// The longest gap in a person's stamps that is interpolated across, seconds: after a longer
    /// one the animation resumes at the next frame, with nothing invented in between (the gap
    /// is warned about) [default: 5 of the person's own frame periods].
    #[arg(long, value_name = "SECONDS", conflicts_with = "spec")]
    pub max_gap: Option<f64>,
    /// Stand camera-frame tracks (marker and pose arrays, read with --layout) on z = 0 facing
    /// +Y, up and ground estimated from the feet: `auto` does so for those, never for skeleton
    /// messages (`import` and `record` already wrote them in the world frame). The people of
    /// one topic share one grounding (one camera), so they keep their places.
    #[arg(long, value_enum, default_value_t = GroundMode::Auto, conflicts_with = "spec")]
    pub ground: GroundMode,
    /// Degrees of freedom solved: `full` turns the pelvis in 3-D (tilt and roll under the
    /// yaw-only root) and swings the clavicles; `paper` keeps both at rest, as the paper's rig
    /// did. Recorded in the bag's `autoact.convert` metadata (`dof`). A spec converts with `full`.
    #[arg(long, value_enum, default_value_t = DofSet::Full, conflicts_with = "spec")]
    pub dof: DofSet,
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
    /// The clip is planned whole and solved in windows: its solved keys wait in an unnamed
    /// temporary file in the output's folder (1.7 KB per input frame), not in memory.
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
    /// What made the input, which sets how hard DSI smooths it (see docs/dsi.md).
    #[arg(long, value_enum, value_name = "KIND", default_value_t = DsiSourceArg::Auto)]
    pub dsi_source: DsiSourceArg,
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

/// `--dsi-source`'s value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DsiSourceArg {
    /// `estimator` for the tracks of pose bags imported from ZED, NTU or MMPose JSON and for
    /// MarkerArray and PoseArray topics (camera-frame sources), `mocap` for the others.
    Auto,
    /// Motion capture: each bone's correction within 3 × its measured noise level.
    Mocap,
    /// A pose estimator's output: no noise band (the source range still bounds every rotation),
    /// Friedman's bass control 10 unless --smooth-bass is given.
    Estimator,
}

impl DsiSourceArg {
    /// The kind declared, `None` for `auto`.
    #[must_use]
    pub fn kind(self) -> Option<SourceKind> {
        match self {
            DsiSourceArg::Auto => None,
            DsiSourceArg::Mocap => Some(SourceKind::Mocap),
            DsiSourceArg::Estimator => Some(SourceKind::Estimator),
        }
    }
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
        options.source = self.dsi_source.kind();
        options.variants = self.variants;
        options.bounds = self.variation_deg;
        options.seed = self.seed;
        if let Some(s) = &options.smoothing {
            s.validate()?;
        }
        Ok(Some(options))
    }
}

impl Args {
    /// The library's conversion job, with the DSI options built on `rig` (the library checks the
    /// rest: [`ConvertJob::check`]).
    fn job(self, rig: &Rig) -> Result<ConvertJob> {
        let Some(input) = self.input else {
            bail!("give a pose bag, or --spec DATASET.toml");
        };
        Ok(ConvertJob {
            input,
            topic: self.topic,
            layout: self.layout,
            fps: self.fps,
            solve: ConvertOptions {
                min_confidence: self.min_confidence,
                root_motion: self.root_motion,
                dof: self.dof,
                ..ConvertOptions::default()
            },
            dsi: self.dsi.options(rig, self.fps)?,
            max_gap_s: self.max_gap,
            ground: self.ground,
            output: self.output.options(),
        })
    }
}

/// Runs `autoact convert`: one library stage, its summary on stdout, exit code 3 when input was
/// lost.
///
/// # Errors
/// An unreadable input, no pose topic, an unknown layout, or an output that cannot be written.
pub fn run(args: Args) -> Result<Outcome> {
    let rig = Rig::standard();
    let (input, text, losses) = if let Some(spec) = &args.spec {
        let job = SpecJob {
            spec: spec.clone(),
            output: args.output.options(),
        };
        let summary = pipeline::spec::convert_spec(&rig, &job)?;
        (job.spec, summary.to_string(), summary.losses)
    } else {
        let job = args.job(&rig)?;
        let summary = pipeline::convert::convert_bag(&rig, &job)?;
        (job.input, summary.to_string(), summary.losses)
    };
    print_stdout(&text)?;
    losses.log_closing(&input);
    Ok(Outcome::from_run(&losses))
}
