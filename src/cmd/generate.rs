//! `autoact generate`: a dataset spec → a finished dataset in one resumable command, and
//! `autoact merge`: the parts of a sharded run → one dataset ([`crate::generate`]).

use std::path::PathBuf;

use anyhow::{Context, Result};

use super::Outcome;
use super::render::{EngineArgs, PassArgs};
use super::trim::{CutArgs, SplitArgs};
use crate::generate::shard::Shard;
use crate::generate::{
    ClipChoice, GenerateJob, RenderChoice, generate, merge::merge as merge_parts,
};
use crate::video::ReencodeSettings;

/// x264 preset of clips re-encoded by `generate` (as `trim`'s default).
const REENCODE_PRESET: &str = "veryfast";
/// x264 constant rate factor of clips re-encoded by `generate` (as `trim`'s default).
const REENCODE_CRF: u8 = 18;

/// Build a dataset from a spec: capture, render and cut every session, resumably.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Examples:
  autoact generate examples/dataset.toml -o out/ --resolution 320x240
  # one machine of four (Slurm: --shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT), then:
  autoact generate examples/dataset.toml -o parts/0 --shard 0/4 --resolution 320x240
  autoact merge parts/0 parts/1 parts/2 parts/3 -o out/

Layout of DIR:
  generate.json                     journal: the settings, the shard, how far each session came
  plan.json                         the dataset's plan (the splits are decided over all of it)
  dataset/                          the dataset, laid out as `autoact trim` describes (its
                                    lists, label files and contact sheets written once, after
                                    the last session)
  previews/<session>.png            contact sheets, with --previews
  captures/, renders/               each session's capture bag, video and render bag, deleted
                                    once its clips are final unless --keep-intermediates
A re-run with the same spec and options continues where the last one stopped (after Ctrl-C,
a crash or kill -9): finished units are not redone, and a render resumes at its first unfinished
piece (--piece-frames); one with other options is refused.
Progress: a bar on a terminal, a line at once and every 5 s otherwise (-q: none).")]
pub struct Args {
    /// The dataset spec (see `examples/dataset.toml`).
    pub spec: PathBuf,
    /// Output folder (created; re-runs resume in it).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Make only shard K of N (0-based): a deterministic share of the plan's sessions, the same
    /// on every machine. Join the parts with `autoact merge`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
    /// Rendering and encoding.
    #[command(flatten)]
    pub engine: EngineArgs,
    /// Per-pixel labels.
    #[command(flatten)]
    pub passes: PassArgs,
    /// Splitting.
    #[command(flatten)]
    pub split: SplitArgs,
    /// Cutting.
    #[command(flatten)]
    pub cut: CutArgs,
    /// Write a contact sheet of each capture into `DIR/previews/`.
    #[arg(long)]
    pub previews: bool,
    /// Keep each session's capture bag, video and render bag once its clips are final. Their
    /// renders then draw every frame; without this option a render draws only the frames some
    /// clip uses.
    #[arg(long)]
    pub keep_intermediates: bool,
    /// Test hook: end the process abruptly at the N-th event (frame rendered, clip cut, unit
    /// recorded), as kill -9 would, with exit code 86.
    #[arg(long, hide = true, value_name = "N")]
    pub abort_after: Option<u64>,
    /// Test hook: append `SESSION FIRST COUNT` to FILE before each batch of frames is drawn
    /// (FIRST: the batch's first frame in the session's video).
    #[arg(long, hide = true, value_name = "FILE")]
    pub drawn_log: Option<PathBuf>,
    /// Renders are made in pieces of whole segments, each at least N frames; a render killed
    /// part-way resumes at its first unfinished piece (1: a piece per segment, the least redrawn
    /// after a kill, one encoder start of about 0.1 s CPU per segment).
    #[arg(long, value_name = "N", default_value_t = 1000, value_parser = clap::value_parser!(u64).range(1..))]
    pub piece_frames: u64,
}

/// Join the parts of `generate --shard K/N` into one dataset.
#[derive(Debug, clap::Args)]
#[command(after_help = "\
Example:
  autoact merge parts/0 parts/1 parts/2 parts/3 -o out/

Every part must be finished, and the parts must be all the shards of one run (same spec, same
options). The clips are hard-linked (copied across file systems) into DIR/dataset, the manifests
joined in shard order and every list rewritten over the plan; DIR appears only when complete.")]
pub struct MergeArgs {
    /// The parts (the `-o` folders of `generate --shard`), in any order.
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// The merged folder (must not exist).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Replace DIR if it exists.
    #[arg(long)]
    pub force: bool,
}

/// Runs `autoact generate`.
///
/// # Errors
/// A spec that cannot be loaded, a folder made with other options, ffmpeg missing, a stage
/// failing (finished units are kept), Ctrl-C.
pub fn run(args: Args) -> Result<Outcome> {
    args.engine.set_threads()?;
    let engine = args.engine;
    let job = GenerateJob {
        spec: args.spec,
        output: args.output,
        shard: args.shard,
        render: RenderChoice {
            resolution: engine.resolution,
            fps: engine.fps,
            crf: engine.crf,
            preset: engine.preset,
            x264_options: engine.x264_options,
            gop_frames: engine.gop,
            encoder_threads: engine.encoder_threads,
            passes: args.passes.wanted(),
            engine: engine.engine,
            blender: crate::render::blender::BlenderSettings {
                python: engine.blender_python.clone(),
                samples: engine.blender_samples,
                threads: engine.threads,
                ..crate::render::blender::BlenderSettings::default()
            },
            piece_frames: args.piece_frames,
        },
        clips: ClipChoice {
            split_by: args.split.split_by,
            split_ratios: args.split.split_ratios,
            seed: args.split.seed,
            hold_out: args.split.hold_out,
            reencode: args.cut.reencode,
            reencode_settings: ReencodeSettings {
                preset: REENCODE_PRESET.to_owned(),
                crf: REENCODE_CRF,
            },
            rawframes: args.cut.rawframes,
        },
        previews: args.previews,
        keep_intermediates: args.keep_intermediates,
        download_ffmpeg: engine.download_ffmpeg,
        abort_after_events: args.abort_after,
        drawn_log: args.drawn_log,
    };
    let summary = generate(&job, crate::interrupt::Interrupt::install()?.flag())?;
    super::print_stdout(&summary.to_string()).context("writing to stdout")?;
    Ok(Outcome::from_run(&summary))
}

/// Runs `autoact merge`.
///
/// # Errors
/// Parts that are not every shard of one run, finished; unwritable output.
pub fn merge(args: &MergeArgs) -> Result<Outcome> {
    let summary = merge_parts(&args.parts, &args.output, args.force)?;
    super::print_stdout(&summary.to_string()).context("writing to stdout")?;
    Ok(Outcome::Success)
}
