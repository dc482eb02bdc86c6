//! Command-line surface: the [`Cli`] parser, global flags, dispatch to [`crate::cmd`], logging.
//!
//! The dependency runs one way: this module names each command's `Args` and calls its `run`;
//! the exit codes, [`Outcome`] and the listing [`crate::cmd::Format`] live in [`crate::cmd`].

use clap::{Args, Parser, Subcommand};

use crate::cmd::{self, Outcome};

const EXIT_CODES_HELP: &str = "\
Exit codes:
  0  success
  1  failure (nothing usable was written)
  2  usage error
  3  finished, but some input was lost (skipped frames or records; see the warnings)";

/// Turn 3D human pose-estimation output into rotation-based animation on a 53-bone rig, and into
/// labelled multi-view action-recognition datasets stored in ROS 2 MCAP.
#[derive(Debug, Parser)]
#[command(name = "autoact", version, about, long_about = None, after_help = EXIT_CODES_HELP)]
pub struct Cli {
    /// Flags every command takes.
    #[command(flatten)]
    pub global: GlobalArgs,
    /// The command to run.
    #[command(subcommand)]
    pub command: Command,
}

/// Flags every command takes.
#[derive(Debug, Args)]
pub struct GlobalArgs {
    /// More diagnostics on stderr (repeat for more); `RUST_LOG` overrides.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Only errors on stderr.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
}

/// The commands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print the 53-bone rig: bones, parents, rest geometry, degree-of-freedom classes.
    ///
    /// With `--layout`, also which bones a keypoint layout drives, which it leaves at rest, and
    /// whose twist it cannot observe. `--landmarks` lists the named points layouts bind to,
    /// `--recipes` which landmarks drive each bone.
    Rig(crate::cmd::rig::Args),
    /// List the built-in keypoint layouts, or show one (or a layout file) joint by joint.
    Layouts(crate::cmd::layouts::Args),
    /// Turn a dataset file into a pose bag: skeleton messages at the source's own stamps.
    ///
    /// Reads BVH (through a built-in mapping of its skeleton onto a layout), NTU RGB+D
    /// `.skeleton`, Human3.6M exponential-map `.txt`, ZED BODY_34 and UTD-MHAD (Kinect v1) `.mat`,
    /// MMPose-style whole-body `.json` and CMU Panoptic `body3DScene` `.json` (a file, or a
    /// sequence's folder of them). The label (`--category`, `--action`) and the provenance go
    /// into the bag's `autoact` metadata record.
    Import(crate::cmd::import::Args),
    /// Turn a pose bag into an animation bag: bone rotations on the 53-bone rig, TF and a
    /// marker skeleton, at an explicit frame rate.
    ///
    /// Reads `autoact_msgs/Skeleton3D`, `visualization_msgs/MarkerArray` (sphere or points
    /// markers, one namespace per person, or sphere ids `person × 100 + joint` as the Azure
    /// Kinect ROS driver writes them) and `geometry_msgs/PoseArray` topics; markers and pose
    /// arrays need `--layout`. Writes `/animation` (BoneFrame) and `/tf` every frame, `/tf_static`,
    /// `/skeleton/markers` (lines fixed in the bones' tf frames, which `/tf` moves; sent once a
    /// second) and the same skeleton as points for Rerun, which draws no markers
    /// (`/skeleton/points/<bone frame>`, sensor_msgs/PointCloud2, sent with the markers).
    /// Unreadable chunks or messages are skipped, reported, and end the run with exit code 3.
    ///
    /// With `--spec DATASET.toml` it builds a dataset's capture sessions instead: every source
    /// converted (DSI, variants), every segment of the plan laid on a timeline with its drawn scene,
    /// its camera (`/camera/pose`, a `camera` TF frame, `/camera/camera_info`) and its segment
    /// (`/scene`, `/segments`), one bag per session in the `-o` folder.
    Convert(crate::cmd::convert::Args),
    /// Print a dataset spec's recording plan before anything is converted or rendered: segments
    /// and clips per class, segments per weather, time of day, location and character, the
    /// expected size, or every segment (`--format json|csv`).
    ///
    /// A segment is one viewpoint of one scene on a capture's timeline; `trim` cuts it into
    /// clips by its class's `[clips]` policy (`whole`: one; `windows`: as many as fit; the
    /// clips of `instances` are found from the motion, so the plan cannot count them).
    ///
    /// The hierarchy is category → action → animation → variant → scene → viewpoint; every draw
    /// comes from the spec's seed (see `examples/dataset.toml`).
    Plan(crate::cmd::plan::Args),
    /// Rewrite a bag that was cut off (crash, `kill -9`) or damaged into a complete one: every
    /// message of every readable chunk, its metadata, a fresh summary and index.
    ///
    /// Prints how many messages were kept per topic; exits with code 3 when the input was
    /// unfinished or damaged (something may be lost), 0 when it was whole.
    Recover(crate::cmd::recover::Args),
    /// Record live ROS 2 topics (DDS; no ROS installation needed) into MCAP — the pose bags
    /// `convert` reads, like `import` writes.
    ///
    /// Records autoact_msgs/Skeleton3D, MarkerArray, PoseArray, TFMessage, CameraInfo and the
    /// other types autoact has definitions of, with receive time as log time and the writer's
    /// source time as publish time. SIGINT and SIGTERM finish the file; a crash costs at most
    /// `--flush-interval` (see `autoact recover`). Sequence gaps and undecodable messages are
    /// counted per topic, in the status line, the bag's `autoact.record` metadata and exit code 3.
    Record(crate::cmd::record::Args),
    /// Render a capture bag with the embedded CPU renderer: H.264 video with a keyframe on every
    /// segment boundary, a render bag mapping video frames to timeline stamps with per-frame
    /// annotations (2D/3D joints, visibility, bounding box), PNG frames and a contact sheet.
    ///
    /// The character is a skinned body in its scene's look; light, sky, fog, rain, snow and
    /// lightning follow the drawn weather and time of day; the location's ground, props and
    /// backdrop surround it. Frames render in parallel and are encoded in order through
    /// ffmpeg (`apt-get install ffmpeg`).
    Render(crate::cmd::render::Args),
    /// Cut a rendered capture into clips (frame-exact) by the dataset's clip policy, each with
    /// its action span, with the annotation lists action-recognition code reads: Kinetics CSV,
    /// MMAction2 video and rawframe lists, ActivityNet JSON, per-clip metadata, one shared class
    /// list.
    ///
    /// The policy (the spec's `[clips]`, from `plan.json`; `--clips` overrides it) makes one
    /// clip of each segment's animation (`whole`, default; the still lead-in and lead-out only
    /// with `--include-lead`), fixed-length `windows`, or one clip per action `instances` found
    /// from the body's motion.
    ///
    /// Clips go to `DATASET_DIR/videos/<label>/<clip_id>.mp4`; splits (train/val/test) are drawn
    /// by source animation (`--split-by`), seeded and stratified by class, so no motion is in
    /// two splits. Stream copy where a clip starts on a keyframe, re-encoding elsewhere (videos
    /// from other engines or screen recorders, placed with `--video-start`). Re-runs resume.
    /// Exit code 3 when segments were left out because the video does not cover them.
    Trim(crate::cmd::trim::Args),
    /// Build a whole dataset from a spec in one command: plan → capture → render → clips, one
    /// capture session at a time, resumable after a crash, `kill -9` or Ctrl-C.
    ///
    /// Runs the stages of `convert --spec`, `render` and `trim` in-process with their options.
    /// Every output appears only when complete and a journal (`DIR/generate.json`) names each
    /// finished unit (a session's capture, its render, its clips), so running the same command
    /// again continues where the last run stopped. `--shard K/N` makes one machine's share of
    /// the sessions; `autoact merge` joins the parts into the dataset one machine would make.
    Generate(crate::cmd::generate::Args),
    /// Join the parts of `generate --shard K/N` into one dataset, byte-identical in its lists,
    /// splits, label ids and annotation files to what one `generate` would have made.
    Merge(crate::cmd::generate::MergeArgs),
    /// Describe an MCAP file: channels, schemas, counts, time range, rate, layouts, labels, and
    /// whether ROS 2 tools and autoact can read all of it.
    ///
    /// `rate_hz` is a channel's message rate (log times); `fps` is the frame rate of each person
    /// and variant on it, from the frames' own stamps (one over the median step, as `convert`
    /// and `export` measure it; a range where they differ): three people at 30 fps on
    /// `/skeleton` show 90 messages per second and 30 fps.
    Info(crate::cmd::info::Args),
    /// Write the animations of an animation or capture bag as BVH, GTA V `.onim` or glTF/GLB
    /// files, at the bag's frame rate.
    ///
    /// An animation is one person (track id) and one variant of the bag's `/animation` frames;
    /// `--list` shows them, `--animation` and `--variant` pick, and by default all are written,
    /// one file each. BVH carries the rig's hierarchy and the body's offsets with ZXY Euler
    /// rotations, for Blender and other animation tools; `.onim` is GTA V's text animation, with
    /// the rig's bones mapped onto the ped skeleton's frames (`--onim-template`); glTF/GLB holds
    /// the skinned body, the rig and the animation, and for a capture bag the animated camera.
    Export(crate::cmd::export::Args),
}

impl Command {
    /// Runs the command.
    ///
    /// # Errors
    /// Whatever the command reports; the caller prints it and exits with code 1.
    pub fn run(self) -> anyhow::Result<Outcome> {
        match self {
            Command::Rig(args) => cmd::rig::run(args),
            Command::Layouts(args) => cmd::layouts::run(args),
            Command::Import(args) => cmd::import::run(args),
            Command::Convert(args) => cmd::convert::run(args),
            Command::Info(args) => cmd::info::run(args),
            Command::Plan(args) => cmd::plan::run(args),
            Command::Recover(args) => cmd::recover::run(args),
            Command::Record(args) => cmd::record::run(args),
            Command::Export(args) => cmd::export::run(args),
            Command::Render(args) => cmd::render::run(args),
            Command::Trim(args) => cmd::trim::run(args),
            Command::Generate(args) => cmd::generate::run(args),
            Command::Merge(args) => cmd::generate::merge(&args),
        }
    }
}

/// Installs the stderr logger: warnings by default, `-v` info, `-vv` debug, `-q` errors only;
/// `RUST_LOG` overrides.
pub fn init_logging(global: &GlobalArgs) {
    let level = if global.quiet {
        "error"
    } else {
        match global.verbose {
            0 => "warn",
            1 => "info",
            2 => "debug",
            _ => "trace",
        }
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(level));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_target(false)
        .without_time()
        .try_init();
}

/// Whether the error chain ends in a closed pipe (`autoact rig | head`), which is not a failure.
#[must_use]
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|e| {
        e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}

/// Prints an error once, with its causes, on stderr.
pub fn report_error(err: &anyhow::Error) {
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "Error: {}", error_chain(err));
}

/// `err` and its causes joined by `: `, as `{:#}` joins them, less any cause whose text the
/// message already ends with: an error that names its cause in its own message and also keeps
/// it as its `source` would otherwise print the cause twice.
#[must_use]
pub fn error_chain(err: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in err.chain() {
        let text = capped(cause.to_string());
        if out.is_empty() {
            out = text;
        } else if !out.ends_with(text.trim_end()) {
            out.push_str(": ");
            out.push_str(&text);
        }
    }
    out
}

/// The most of one error message that is printed: a parser that quotes the offending input (a
/// TOML error on an 8 MB line) must not flood the terminal.
const MAX_MESSAGE_CHARS: usize = 2000;

/// `text`, cut to [`MAX_MESSAGE_CHARS`] characters with a note of how much was left out.
fn capped(text: String) -> String {
    match text.char_indices().nth(MAX_MESSAGE_CHARS) {
        None => text,
        Some((cut, _)) => format!(
            "{} … [{} more bytes not shown]",
            &text[..cut],
            text.len() - cut
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cmd::Format;
    use clap::CommandFactory;

    #[test]
    fn a_huge_error_message_is_capped() {
        let line = "x".repeat(8 * 1024 * 1024);
        let err = anyhow::anyhow!("bad value {line}").context("spec.toml");
        let text = error_chain(&err);
        assert!(text.len() < 3 * MAX_MESSAGE_CHARS, "{} bytes", text.len());
        assert!(
            text.starts_with("spec.toml: bad value xxx"),
            "{}",
            &text[..40]
        );
        assert!(text.ends_with("more bytes not shown]"));
        assert_eq!(capped("é".repeat(10)), "é".repeat(10));
    }

    #[test]
    fn an_error_chain_prints_each_cause_once() {
        #[derive(Debug, thiserror::Error)]
        #[error("outer: {source}")]
        struct Names {
            #[source]
            source: std::io::Error,
        }
        #[derive(Debug, thiserror::Error)]
        #[error("outer")]
        struct Keeps {
            #[source]
            source: std::io::Error,
        }
        let io = || std::io::Error::other("the cause");
        let named = anyhow::Error::new(Names { source: io() }).context("reading x");
        assert_eq!(error_chain(&named), "reading x: outer: the cause");
        let kept = anyhow::Error::new(Keeps { source: io() });
        assert_eq!(error_chain(&kept), "outer: the cause");
        assert_eq!(error_chain(&kept), format!("{kept:#}"));
    }

    #[test]
    fn cli_definition_is_consistent() {
        Cli::command().debug_assert();
    }

    #[test]
    fn rig_defaults_and_flags_parse() {
        let cli = Cli::try_parse_from(["autoact", "rig"]).unwrap();
        let Command::Rig(args) = cli.command else {
            panic!("not rig")
        };
        assert_eq!(args.format, Format::Table);
        assert!(args.layout.is_none() && !args.landmarks && !args.recipes);
        let cli = Cli::try_parse_from([
            "autoact", "-v", "rig", "--format", "json", "--layout", "h36m-17",
        ])
        .unwrap();
        assert_eq!(cli.global.verbose, 1);
        let Command::Rig(args) = cli.command else {
            panic!("not rig")
        };
        assert_eq!(args.format, Format::Json);
        assert_eq!(args.layout.as_deref(), Some("h36m-17"));
        assert!(
            Cli::try_parse_from(["autoact", "rig", "--landmarks", "--recipes"]).is_err(),
            "one listing at a time"
        );
        assert!(Cli::try_parse_from(["autoact", "-q", "-v", "rig"]).is_err());
    }

    #[test]
    fn layouts_parses_with_and_without_a_name() {
        let cli = Cli::try_parse_from(["autoact", "layouts"]).unwrap();
        let Command::Layouts(args) = cli.command else {
            panic!("not layouts")
        };
        assert!(args.layout.is_none());
        let cli = Cli::try_parse_from(["autoact", "layouts", "my.toml"]).unwrap();
        let Command::Layouts(args) = cli.command else {
            panic!("not layouts")
        };
        assert_eq!(args.layout.as_deref(), Some("my.toml"));
    }
}
