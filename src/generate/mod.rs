//! `autoact generate`: a dataset spec → a finished clip dataset in one call, through the same
//! library stages as `convert --spec`, `render` and `trim`, one capture session at a time:
//!
//! ```text
//! DIR/generate.json                      journal: settings, shard, how far each session came
//! DIR/plan.json                          the dataset's plan (what the splits are decided over)
//! DIR/captures/<session>.capture.mcap    intermediates, deleted once the session's clips are
//! DIR/renders/<session>.mp4 (+.render.mcap)  final (kept with --keep-intermediates)
//! DIR/previews/<session>.png             contact sheets (with --previews)
//! DIR/dataset/                           the dataset, as `autoact trim` lays it out
//! ```
//!
//! Every output is written under a temporary name and renamed when complete, and the journal
//! names a unit (a session's capture, its render, its clips) only after its outputs are in
//! place, so a re-run after a crash, `kill -9` or Ctrl-C redoes at most the unit it stopped in;
//! a render is itself made in pieces that outlive a kill (`renders/<session>.pieces/`,
//! [`crate::render::session::pieces`]), so a render resumes at the piece it stopped in.
//! Without `--keep-intermediates` a render draws only the frames some clip uses
//! ([`crate::trim::run::clip_frames`]), and `trim` finds the clips in it through the render
//! bag's frame table ([`crate::bags::render::DrawnFrames`]).
//! With `--shard K/N` a machine makes only its share of the sessions ([`shard`]); [`merge`]
//! joins the parts into the dataset one machine would have made.

pub mod journal;
pub mod merge;
pub mod progress;
pub mod shard;

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::Instant;

use self::journal::{Journal, Settings, Stage};
use self::progress::{DatasetProgress, Totals};
use self::shard::Shard;
use crate::bags::capture::{Capture, TimelineError};
use crate::bags::render::{RenderBagError, RenderedVideo};
use crate::dataset::capture::{CaptureError, Converted};
use crate::dataset::plan::Plan;
use crate::dataset::spec::Spec;
use crate::pipeline::PipelineError;
use crate::render::session::pieces::{PieceJob, render_in_pieces};
use crate::render::session::{Outputs, RenderError, RenderSettings};
use crate::skeleton::rig::Rig;
use crate::trim::TrimError;
use crate::trim::lists::ListSummary;
use crate::trim::planned::PlannedClips;
use crate::trim::policy::ClipPolicies;
use crate::trim::qa::Thresholds;
use crate::trim::run::{RunError, TrimOptions, VideoSource, trim_capture};
use crate::trim::split::{Key, SplitConfig};
use crate::video::{Ffmpeg, Rational, ReencodeSettings, VideoError};

/// The plan's file name in the output folder.
pub const PLAN_FILE: &str = "plan.json";
/// Folder of the capture bags.
pub const CAPTURES_DIR: &str = "captures";
/// Folder of the rendered videos and render bags.
pub const RENDERS_DIR: &str = "renders";
/// Folder of the contact sheets.
pub const PREVIEWS_DIR: &str = "previews";
/// Folder of the dataset.
pub const DATASET_DIR: &str = "dataset";
/// Exit code of the `--abort-after` test hook (as a process killed mid-run).
pub const ABORT_HOOK_EXIT: i32 = 86;

/// How each capture is rendered (`autoact render`'s options).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderChoice {
    /// Output size, pixels; default: the spec's.
    pub resolution: Option<(u32, u32)>,
    /// Output frame rate; default: the spec's.
    pub fps: Option<f64>,
    /// x264 constant rate factor.
    pub crf: u8,
    /// x264 preset.
    pub preset: String,
    /// x264 options after the preset (empty: none).
    pub x264_options: String,
    /// Longest keyframe interval, frames.
    pub gop_frames: Option<u32>,
    /// x264 threads (the videos' bytes depend on it).
    pub encoder_threads: u8,
    /// The depth and mask passes to render, for every clip's `depth/` and `masks/` frames.
    pub passes: crate::render::passes::Wanted,
    /// The engine asked for (`None`: the spec's `[dataset] engine`).
    pub engine: Option<crate::dataset::spec::EngineName>,
    /// How the Blender engine renders, when it is the one.
    pub blender: crate::render::blender::BlenderSettings,
    /// Least frames of a render piece (whole segments; `1`: a piece per segment): a killed
    /// render resumes at its first unfinished piece ([`crate::render::session::pieces`]).
    pub piece_frames: u64,
}

impl RenderChoice {
    /// The engine to render with: the one asked for, else `spec_engine`.
    #[must_use]
    pub fn engine(
        &self,
        spec_engine: crate::dataset::spec::EngineName,
    ) -> crate::render::blender::Engine {
        match self.engine.unwrap_or(spec_engine) {
            crate::dataset::spec::EngineName::Embedded => crate::render::blender::Engine::Embedded,
            crate::dataset::spec::EngineName::Blender => {
                crate::render::blender::Engine::Blender(self.blender.clone())
            }
        }
    }
}

/// How clips are cut and split (`autoact trim`'s options).
#[derive(Debug, Clone, PartialEq)]
pub struct ClipChoice {
    /// What clips of one split share.
    pub split_by: Key,
    /// Train, val and test fractions.
    pub split_ratios: [f64; 3],
    /// Seed of the split; default: the dataset's.
    pub seed: Option<u64>,
    /// Values whose clips all go to test.
    pub hold_out: Vec<(Key, String)>,
    /// Re-encode every clip.
    pub reencode: bool,
    /// Encoder settings of re-encoded clips.
    pub reencode_settings: ReencodeSettings,
    /// Also extract every clip's frames.
    pub rawframes: bool,
}

/// What to generate, and where.
#[derive(Debug, Clone, PartialEq)]
pub struct GenerateJob {
    /// The dataset spec.
    pub spec: PathBuf,
    /// The output folder (re-runs resume in it).
    pub output: PathBuf,
    /// Make only this shard's sessions.
    pub shard: Option<Shard>,
    /// Rendering.
    pub render: RenderChoice,
    /// Cutting and splitting.
    pub clips: ClipChoice,
    /// Write a contact sheet per capture into `previews/`.
    pub previews: bool,
    /// Keep each session's capture bag, video and render bag after its clips are final; their
    /// renders then draw every frame (without it, a render draws only the frames some clip uses).
    pub keep_intermediates: bool,
    /// Download ffmpeg when it is not installed.
    pub download_ffmpeg: bool,
    /// Test hook: end the process abruptly (no clean-up, exit code [`ABORT_HOOK_EXIT`]) at the
    /// N-th event (a frame rendered, a clip cut, a unit recorded), as `kill -9` would.
    pub abort_after_events: Option<u64>,
    /// Test hook: append `SESSION FIRST COUNT` to this file just before each batch of frames is
    /// drawn (its first frame in the session's video, its frame count), so the frames drawn by
    /// runs that were killed can be counted.
    pub drawn_log: Option<PathBuf>,
}

/// Why generating failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GenerateError {
    /// A file or folder could not be read or written.
    #[error("{action} `{}`", path.display())]
    Io {
        /// What was being done.
        action: &'static str,
        /// The file or folder.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The journal is not one.
    #[error("`{}` is not a generate journal (delete it to start over)", path.display())]
    Journal {
        /// The journal.
        path: PathBuf,
        /// Why.
        source: serde_json::Error,
    },
    /// The journal is of another format version.
    #[error("`{}`: journal format version {version}, this autoact reads version 1", path.display())]
    JournalVersion {
        /// The journal.
        path: PathBuf,
        /// Its version.
        version: u32,
    },
    /// The folder holds another job's outputs.
    #[error(
        "`{}` was generated with other settings ({what}): continue with the same ones, or use another folder",
        dir.display()
    )]
    OtherJob {
        /// The output folder.
        dir: PathBuf,
        /// What differs.
        what: String,
    },
    /// The spec cannot be loaded, planned or captured.
    #[error(transparent)]
    Pipeline(#[from] PipelineError),
    /// A capture bag cannot be written.
    #[error(transparent)]
    Capture(#[from] CaptureError),
    /// A capture bag cannot be read back.
    #[error(transparent)]
    Timeline(#[from] TimelineError),
    /// The exact plan's sessions are not the estimated plan's.
    #[error(
        "the plan's sessions changed once the sources were converted ({estimated} estimated, {exact} exact): the shards would not agree"
    )]
    SessionsChanged {
        /// Sessions of the estimated plan.
        estimated: usize,
        /// Sessions of the exact plan.
        exact: usize,
    },
    /// ffmpeg is missing.
    #[error(transparent)]
    Ffmpeg(#[from] VideoError),
    /// A render failed.
    #[error("rendering `{}`", path.display())]
    Render {
        /// The capture bag.
        path: PathBuf,
        /// Why (boxed: it is large).
        source: Box<RenderError>,
    },
    /// A render bag cannot be read.
    #[error(transparent)]
    RenderBag(#[from] RenderBagError),
    /// The plan or the dataset folder.
    #[error(transparent)]
    Trim(#[from] TrimError),
    /// Cutting failed.
    #[error("trimming `{}` (complete clips are kept; run again to resume)", path.display())]
    Cut {
        /// The video.
        path: PathBuf,
        /// Why (boxed: it is large).
        source: Box<RunError>,
    },
    /// Stopped by Ctrl-C or SIGTERM; finished units are kept.
    #[error("interrupted: finished units are kept, run the same command again to continue")]
    Interrupted,
    /// A merge was given parts that do not make one dataset.
    #[error("{0}")]
    Parts(String),
}

impl GenerateError {
    /// An [`GenerateError::Io`] maker for `path`.
    pub(crate) fn io(
        action: &'static str,
        path: &Path,
    ) -> impl FnOnce(std::io::Error) -> GenerateError + use<> {
        let path = path.to_path_buf();
        move |source| GenerateError::Io {
            action,
            path,
            source,
        }
    }
}

/// Wall time per stage, seconds.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct StageSeconds {
    /// Converting the sources and laying out the plan.
    pub convert: f64,
    /// Writing capture bags.
    pub capture: f64,
    /// Rendering.
    pub render: f64,
    /// Cutting clips and writing lists.
    pub trim: f64,
}

/// What a run did.
#[derive(Debug, Clone, PartialEq)]
pub struct GenerateSummary {
    /// The output folder.
    pub dir: PathBuf,
    /// The shard made.
    pub shard: Option<Shard>,
    /// Sessions of this folder, and how many were already finished.
    pub sessions: usize,
    /// Sessions finished by earlier runs.
    pub already_done: usize,
    /// Clips of this folder's sessions.
    pub clips: usize,
    /// Frames drawn by this run (a resumed render draws only its unfinished pieces).
    pub frames_rendered: u64,
    /// Wall time per stage.
    pub seconds: StageSeconds,
    /// Wall time in all.
    pub total_seconds: f64,
    /// The lists after the last trim of this run (`None`: nothing trimmed).
    pub lists: Option<ListSummary>,
    /// Segments left out because a video did not cover them.
    pub truncated: usize,
}

impl crate::outcome::LostInput for GenerateSummary {
    fn lost_input(&self) -> bool {
        self.truncated > 0
    }
}

impl GenerateJob {
    /// The settings the journal records, with the spec's text hashed.
    fn settings(&self, spec_text: &str) -> Settings {
        let r = &self.render;
        let c = &self.clips;
        Settings {
            spec_fnv1a: format!("{:016x}", crate::dataset::plan::stream_of(spec_text)),
            resolution: r
                .resolution
                .map(|(w, h)| format!("{w}x{h}"))
                .unwrap_or_default(),
            fps: r.fps,
            crf: r.crf,
            preset: r.preset.clone(),
            x264_options: r.x264_options.clone(),
            gop_frames: r.gop_frames,
            encoder_threads: r.encoder_threads,
            passes: r.passes,
            piece_frames: r.piece_frames,
            engine: r.engine,
            split_by: c.split_by.name().to_owned(),
            split_ratios: c.split_ratios,
            split_seed: c.seed,
            hold_out: c
                .hold_out
                .iter()
                .map(|(k, v)| format!("{}={v}", k.name()))
                .collect(),
            reencode: c.reencode,
            rawframes: c.rawframes,
            previews: self.previews,
            keep_intermediates: Some(self.keep_intermediates),
        }
    }
}

/// The trim options of `choice` over the plan's clips `planned` (seed: the split's, else the
/// plan's).
pub(crate) fn trim_options(choice: &ClipChoice, planned: &PlannedClips) -> TrimOptions {
    TrimOptions {
        split: SplitConfig {
            by: choice.split_by,
            ratios: choice.split_ratios,
            seed: choice.seed.unwrap_or(planned.seed),
            hold_out: choice.hold_out.clone(),
        },
        force_reencode: choice.reencode,
        reencode: choice.reencode_settings.clone(),
        rawframes: choice.rawframes,
        // `generate`'s trim sets the spec's `[randomise] jpeg_quality`; the lists need none.
        jpeg_quality: [crate::video::JPEG_QSCALE_BEST; 2],
        planned: Some(planned.items.clone()),
        qa: Thresholds::default(),
        clips: clip_policies(&planned.clips),
        // Written once over every clip at the end ([`Run::finish_dataset`]), not per capture.
        lists: false,
    }
}

/// The clip policies `generate` cuts with: each class's as the spec (through the plan) gives
/// it, nothing over them.
fn clip_policies(
    by_label: &std::collections::BTreeMap<String, crate::dataset::clips::ClipPolicy>,
) -> ClipPolicies {
    ClipPolicies {
        by_label: by_label.clone(),
        overrides: crate::dataset::clips::ClipsSection::default(),
    }
}

/// The clips `trim` will cut out of `session`'s segments ([`Plan::expected_clips`]); a segment
/// cut into `instances` counts as one, since its motion decides (the progress line corrects the
/// total when a session's clips are cut).
fn estimated_clips(plan: &Plan, session: &crate::dataset::plan::Session) -> u64 {
    plan.leaves[session.leaves.clone()]
        .iter()
        .map(|leaf| {
            plan.expected_clips(leaf)
                .map_or(1, |clips| clips.len() as u64)
        })
        .sum()
}

/// Where one session's files go.
struct SessionPaths {
    capture: PathBuf,
    video: PathBuf,
    render_bag: PathBuf,
    /// The render's finished pieces, while it is being made.
    pieces: PathBuf,
    /// The depth and mask passes beside the video.
    depth: PathBuf,
    mask: PathBuf,
    preview: PathBuf,
}

impl SessionPaths {
    fn new(dir: &Path, name: &str) -> SessionPaths {
        let video = dir.join(RENDERS_DIR).join(format!("{name}.mp4"));
        SessionPaths {
            capture: crate::bags::capture::session_path(&dir.join(CAPTURES_DIR), name),
            render_bag: crate::bags::render::render_bag_beside(&video),
            depth: crate::bags::render::depth_dir_beside(&video),
            mask: crate::bags::render::mask_dir_beside(&video),
            pieces: dir.join(RENDERS_DIR).join(format!("{name}.pieces")),
            video,
            preview: dir.join(PREVIEWS_DIR).join(format!("{name}.png")),
        }
    }

    /// Removes the capture bag, the video, the render bag and the passes (once the clips are
    /// final: theirs are hard links or copies).
    fn remove_intermediates(&self) -> Result<(), GenerateError> {
        for path in [
            &self.capture,
            &self.video,
            &self.render_bag,
            &self.depth,
            &self.mask,
            &self.pieces,
        ] {
            let removed = if path.is_dir() {
                std::fs::remove_dir_all(path)
            } else {
                std::fs::remove_file(path)
            };
            match removed {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(GenerateError::io("removing", path)(e)),
            }
        }
        Ok(())
    }
}

/// The `--abort-after` test hook's event counter.
struct AbortHook {
    after: Option<u64>,
    events: AtomicU64,
}

impl AbortHook {
    /// Counts an event; ends the process at the N-th, as a kill would (nothing cleaned up).
    fn event(&self) {
        if let Some(n) = self.after
            && self.events.fetch_add(1, Ordering::Relaxed) + 1 >= n
        {
            std::process::exit(ABORT_HOOK_EXIT);
        }
    }
}

/// What every session of one run shares.
struct Run<'a> {
    job: &'a GenerateJob,
    rig: Rig,
    spec: &'a Spec,
    plan: &'a Plan,
    /// The converted sources (`None` when every session was already finished).
    converted: Option<Vec<Converted>>,
    planned: Option<PlannedClips>,
    ffmpeg: Ffmpeg,
    progress: DatasetProgress,
    hook: AbortHook,
    /// The `--drawn-log` test hook's file.
    drawn_log: Option<std::sync::Mutex<std::fs::File>>,
    stop: &'a AtomicBool,
}

/// Generates the dataset (or the shard of it) `job` asks for, resuming in its output folder;
/// `stop` (Ctrl-C, SIGTERM) ends the run after the unit in progress has been abandoned cleanly.
///
/// # Errors
/// [`GenerateError`]; every unit finished before the error stays finished.
pub fn generate(job: &GenerateJob, stop: &AtomicBool) -> Result<GenerateSummary, GenerateError> {
    let started = Instant::now();
    let dir = &job.output;
    std::fs::create_dir_all(dir).map_err(GenerateError::io("creating", dir))?;
    let _lock = lock_folder(dir)?;
    let spec_text =
        std::fs::read_to_string(&job.spec).map_err(GenerateError::io("reading", &job.spec))?;
    let (spec, mut plan) = crate::pipeline::spec::estimated_plan(&job.spec)?;
    let frames: Vec<u64> = plan.sessions.iter().map(|s| s.frames).collect();
    let mine = job.shard.map_or(0..frames.len(), |s| s.sessions(&frames));
    let names: Vec<String> = plan.sessions[mine.clone()]
        .iter()
        .map(|s| s.name.clone())
        .collect();
    // The journal fixes the settings for every later run into this folder: x264 must take
    // them before it is written (and before a capture is made for nothing).
    let ffmpeg = Ffmpeg::locate_or_download(job.download_ffmpeg)?;
    crate::video::check_x264(&ffmpeg, dir, &job.render.preset, &job.render.x264_options)?;
    let fresh = Journal::new(job.settings(&spec_text), job.shard, names);
    let mut journal = if let Some(j) = Journal::read(dir)? {
        j.check_same_job(dir, &fresh)?;
        j
    } else {
        fresh.write(dir)?;
        fresh
    };
    let mut seconds = StageSeconds::default();
    let converted = if journal.unfinished().is_empty() {
        None
    } else {
        let t = Instant::now();
        let estimated = plan.sessions.len();
        let rig = Rig::standard();
        let converted = crate::pipeline::spec::convert_sources(&rig, &spec, &mut plan)?;
        if plan.sessions.len() != estimated {
            return Err(GenerateError::SessionsChanged {
                estimated,
                exact: plan.sessions.len(),
            });
        }
        crate::pipeline::spec::write_plan(&dir.join(PLAN_FILE), &plan)?;
        seconds.convert = t.elapsed().as_secs_f64();
        Some(converted)
    };
    let totals = Totals {
        captures: mine.len() as u64,
        clips: plan.sessions[mine.clone()]
            .iter()
            .map(|s| estimated_clips(&plan, s))
            .sum(),
        frames: plan.sessions[mine.clone()].iter().map(|s| s.frames).sum(),
    };
    let planned = match &converted {
        Some(_) => Some(PlannedClips::read(&dir.join(PLAN_FILE))?),
        None => None,
    };
    let run = Run {
        job,
        rig: Rig::standard(),
        spec: &spec,
        plan: &plan,
        converted,
        planned,
        ffmpeg,
        progress: DatasetProgress::new(totals),
        hook: AbortHook {
            after: job.abort_after_events,
            events: AtomicU64::new(0),
        },
        drawn_log: match &job.drawn_log {
            Some(path) => Some(std::sync::Mutex::new(
                std::fs::OpenOptions::new()
                    .create(true)
                    .append(true)
                    .open(path)
                    .map_err(GenerateError::io("opening", path))?,
            )),
            None => None,
        },
        stop,
    };
    let mut summary = GenerateSummary {
        dir: dir.clone(),
        shard: job.shard,
        sessions: mine.len(),
        already_done: mine.len() - journal.unfinished().len(),
        clips: 0,
        frames_rendered: 0,
        seconds,
        total_seconds: 0.0,
        lists: None,
        truncated: 0,
    };
    run.remove_run_dirs(false)?;
    let result = mine
        .into_iter()
        .try_for_each(|i| run.session(i, &mut journal, &mut summary));
    run.progress.finish();
    result?;
    if let Some(lists) = run.finish_dataset()? {
        summary.clips = lists.clips.values().sum();
        summary.lists = Some(lists);
    }
    run.remove_run_dirs(true)?;
    if !run.job.keep_intermediates {
        remove_empty_dirs(
            &[CAPTURES_DIR, RENDERS_DIR, PREVIEWS_DIR].map(|d| run.job.output.join(d)),
        );
    }
    summary.total_seconds = started.elapsed().as_secs_f64();
    Ok(summary)
}

/// Removes each of `dirs` that is empty: the intermediates' folders once a run without
/// `--keep-intermediates` has deleted what they held (`previews/` stays when `--previews` filled
/// it). A folder that is not empty, or not there, is left as it is.
fn remove_empty_dirs(dirs: &[PathBuf]) {
    for dir in dirs {
        let _ = std::fs::remove_dir(dir);
    }
}

/// The output folder, held for one run (`flock` on `.autoact-generate.lock`): a second
/// `generate` into it waits, saying so.
fn lock_folder(dir: &Path) -> Result<std::fs::File, GenerateError> {
    let path = dir.join(".autoact-generate.lock");
    let file = std::fs::OpenOptions::new()
        .create(true)
        .write(true)
        .truncate(false)
        .open(&path)
        .map_err(GenerateError::io("opening", &path))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(std::fs::TryLockError::WouldBlock) => {
            tracing::warn!(
                "another generate is writing into {}: waiting for it to finish",
                dir.display()
            );
            file.lock().map_err(GenerateError::io("locking", &path))?;
        }
        Err(std::fs::TryLockError::Error(e)) => {
            return Err(GenerateError::io("locking", &path)(e));
        }
    }
    Ok(file)
}

impl Run<'_> {
    fn stopped(&self) -> Result<(), GenerateError> {
        if self.stop.load(Ordering::Relaxed) {
            Err(GenerateError::Interrupted)
        } else {
            Ok(())
        }
    }

    /// Takes session `index` from where the journal says it is to its final clips.
    fn session(
        &self,
        index: usize,
        journal: &mut Journal,
        summary: &mut GenerateSummary,
    ) -> Result<(), GenerateError> {
        let dir = &self.job.output;
        let session = &self.plan.sessions[index];
        let name = &session.name;
        let clips = estimated_clips(self.plan, session);
        let paths = SessionPaths::new(dir, name);
        let stage = journal.stage(name);
        if stage == Some(Stage::Clips) {
            if !self.job.keep_intermediates {
                paths.remove_intermediates()?;
            }
            self.progress.already_done(session.frames, Some(clips));
            return Ok(());
        }
        if stage.is_none() || !paths.capture.exists() {
            self.stopped()?;
            let t = Instant::now();
            self.capture(index, &paths)?;
            summary.seconds.capture += t.elapsed().as_secs_f64();
            if stage.is_none() {
                journal.record(dir, name, Stage::Capture)?;
            }
            self.hook.event();
        }
        let capture = Capture::read(&self.rig, &paths.capture)?;
        let render = &self.job.render;
        let rendered = journal.stage(name) >= Some(Stage::Render)
            && paths.video.is_file()
            && paths.render_bag.is_file()
            && (!render.passes.depth || paths.depth.is_dir())
            && (!render.passes.mask || paths.mask.is_dir());
        if rendered {
            self.progress.already_done(session.frames, None);
        } else {
            self.stopped()?;
            let t = Instant::now();
            summary.frames_rendered += self.render(&capture, &paths)?;
            summary.seconds.render += t.elapsed().as_secs_f64();
            journal.record(dir, name, Stage::Render)?;
            self.hook.event();
        }
        if paths.pieces.exists() {
            std::fs::remove_dir_all(&paths.pieces)
                .map_err(GenerateError::io("removing", &paths.pieces))?;
        }
        self.stopped()?;
        let t = Instant::now();
        let trimmed = self.trim(&capture, &paths, clips)?;
        summary.seconds.trim += t.elapsed().as_secs_f64();
        summary.truncated += trimmed.truncated.len();
        journal.record(dir, name, Stage::Clips)?;
        let cut = trimmed.copied + trimmed.reencoded + trimmed.skipped;
        self.progress.session_done(clips, cut as u64);
        self.hook.event();
        if !self.job.keep_intermediates {
            paths.remove_intermediates()?;
        }
        Ok(())
    }

    /// Writes session `index`'s capture bag.
    fn capture(&self, index: usize, paths: &SessionPaths) -> Result<(), GenerateError> {
        let converted = self.converted.as_deref().unwrap_or_default();
        let dir = paths.capture.parent().unwrap_or(Path::new("."));
        std::fs::create_dir_all(dir).map_err(GenerateError::io("creating", dir))?;
        let written = crate::dataset::capture::write_session(
            &self.rig,
            self.spec,
            self.plan,
            converted,
            index,
            dir,
            crate::mcap_io::WriteConfig::default(),
        )?;
        if written.viewpoints_pushed_out > 0 {
            tracing::warn!(
                "{}: {} viewpoints moved out beyond the plan's distance to keep a wide movement in frame",
                crate::file_name(&written.path),
                written.viewpoints_pushed_out
            );
        }
        Ok(())
    }

    /// Renders `capture` to its video and render bag (and contact sheet); the frames rendered.
    fn render(&self, capture: &Capture, paths: &SessionPaths) -> Result<u64, GenerateError> {
        let r = &self.job.render;
        let (width, height) = r
            .resolution
            .unwrap_or((capture.intrinsics.width_px, capture.intrinsics.height_px));
        let settings = RenderSettings {
            width,
            height,
            fps: r.fps,
            limit: None,
            // `[randomise] crf` draws each capture's CRF, keyed by the seed and its session.
            crf: self.spec.file.randomise.capture_crf(
                r.crf,
                self.spec.file.dataset.seed,
                &capture.session,
            ),
            preset: r.preset.clone(),
            x264_options: r.x264_options.clone(),
            gop_frames: r.gop_frames,
            encoder_threads: r.encoder_threads,
            embed_video: None,
            randomise: self.spec.file.randomise.clone(),
            engine: r.engine(self.spec.file.dataset.engine),
            extra_keyframes: self.clip_starts(capture),
            // Without --keep-intermediates the render is only for these clips: it draws only
            // their frames, and `trim` finds them through the render bag's frame table.
            only_frames: if self.job.keep_intermediates {
                None
            } else {
                self.clip_frames(capture)
            },
        };
        // Written into this run's own folder and moved into place when both are complete: an
        // encoder left running by a killed run finishes its file in that run's folder, never
        // in this run's video.
        let run_dir = self.run_dir();
        let staged = |final_path: &Path| run_dir.join(final_path.file_name().unwrap_or_default());
        let outputs = Outputs {
            video: Some(staged(&paths.video)),
            render_bag: Some(staged(&paths.render_bag)),
            frames_dir: None,
            preview: self.job.previews.then(|| paths.preview.clone()),
            depth_dir: r.passes.depth.then(|| staged(&paths.depth)),
            mask_dir: r.passes.mask.then(|| staged(&paths.mask)),
        };
        for d in [Some(run_dir.as_path()), paths.preview.parent()]
            .into_iter()
            .flatten()
        {
            std::fs::create_dir_all(d).map_err(GenerateError::io("creating", d))?;
        }
        let progress = |k: u64| {
            self.progress.rendering(k);
            self.hook.event();
        };
        let session = &capture.session;
        let drawing = |first: u64, n: u64| {
            self.progress.drawing(n);
            self.log_drawn(session, first, n);
        };
        let pieces = PieceJob {
            dir: paths.pieces.clone(),
            scratch: run_dir.join(paths.pieces.file_name().unwrap_or_default()),
            min_frames: r.piece_frames,
            drawing: &drawing,
        };
        let summary = render_in_pieces(
            &self.rig,
            capture,
            &settings,
            &outputs,
            &pieces,
            Some(&self.ffmpeg),
            &progress,
            self.stop,
        )
        .map_err(|source| match source {
            RenderError::Interrupted => GenerateError::Interrupted,
            source => GenerateError::Render {
                path: paths.capture.clone(),
                source: Box::new(source),
            },
        })?;
        for path in [&paths.video, &paths.render_bag] {
            std::fs::rename(staged(path), path)
                .map_err(GenerateError::io("moving into place", path))?;
        }
        for (wanted, dir) in [(r.passes.depth, &paths.depth), (r.passes.mask, &paths.mask)] {
            if dir.exists() {
                std::fs::remove_dir_all(dir).map_err(GenerateError::io("replacing", dir))?;
            }
            if wanted {
                std::fs::rename(staged(dir), dir)
                    .map_err(GenerateError::io("moving into place", dir))?;
            }
        }
        // Timeline frames, as the plan's totals count them (drawn or not).
        let timeline = crate::render::session::output_timeline(capture, r.fps).len() as u64;
        self.progress.rendered(timeline);
        Ok(summary.frames_drawn)
    }

    /// The `--drawn-log` test hook: `n` frames of `session`'s render from frame `first` on are
    /// about to be drawn.
    fn log_drawn(&self, session: &str, first: u64, n: u64) {
        if let Some(file) = &self.drawn_log {
            use std::io::Write as _;
            let mut file = file
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            // One write per line (appended): a kill loses no line already counted.
            if let Err(e) = file.write_all(format!("{session} {first} {n}\n").as_bytes()) {
                tracing::warn!("--drawn-log: {e}");
            }
        }
    }

    /// The output frames where the session's planned clips start, as `trim` will find them in
    /// the render about to be made (frame 0 at the first output frame's stamp): made keyframes,
    /// every clip is copied, not re-encoded. Empty when they cannot be told; `trim` then reports
    /// what is wrong, and re-encodes clips that start off a keyframe.
    fn clip_starts(&self, capture: &Capture) -> Vec<u64> {
        let Some((timing, policies)) = self.clip_timing(capture) else {
            return Vec::new();
        };
        crate::trim::run::clip_start_frames(capture, &timing, &policies).unwrap_or_default()
    }

    /// The output frames the session's planned clips use, by the clip policy `trim` will cut
    /// them with, in the render about to be made (as [`Run::clip_starts`]): the only frames a
    /// render for them needs. `None` (draw every frame) when they cannot be told or there are
    /// none; `trim` then reports what is wrong.
    fn clip_frames(&self, capture: &Capture) -> Option<Vec<std::ops::Range<u64>>> {
        let (timing, policies) = self.clip_timing(capture)?;
        crate::trim::run::clip_frames(capture, &timing, &policies)
            .ok()
            .filter(|frames| !frames.is_empty())
    }

    /// The timing of the render about to be made of `capture` (frame 0 at its first output
    /// frame's stamp, every output frame), and the clip policies `trim` will cut it by.
    fn clip_timing(
        &self,
        capture: &Capture,
    ) -> Option<(
        crate::trim::plan::VideoTiming,
        crate::trim::policy::ClipPolicies,
    )> {
        let (Some(planned), Some(first)) = (&self.planned, capture.stamps.first()) else {
            return None;
        };
        let fps = Rational::from_f64(self.job.render.fps.unwrap_or(capture.fps))?;
        let frame_count =
            crate::render::session::output_timeline(capture, self.job.render.fps).len() as u64;
        let timing = crate::trim::plan::VideoTiming {
            frame0_nanos: i128::from(first),
            fps,
            frame_count,
        };
        Some((timing, trim_options(&self.job.clips, planned).clips))
    }

    /// This run's folder for renders in progress: `renders/.run-<process id>`.
    fn run_dir(&self) -> PathBuf {
        self.job
            .output
            .join(RENDERS_DIR)
            .join(format!(".run-{}", std::process::id()))
    }

    /// Removes the render folders of earlier runs (what a killed run's renders left) and, when
    /// `ours` too, this run's.
    fn remove_run_dirs(&self, ours: bool) -> Result<(), GenerateError> {
        let renders = self.job.output.join(RENDERS_DIR);
        let Ok(entries) = std::fs::read_dir(&renders) else {
            return Ok(());
        };
        let mine = self.run_dir();
        for entry in entries.flatten() {
            let path = entry.path();
            let stale = entry.file_name().to_string_lossy().starts_with(".run-");
            if stale && (ours || path != mine) {
                std::fs::remove_dir_all(&path).map_err(GenerateError::io("removing", &path))?;
            }
        }
        Ok(())
    }

    /// The dataset-wide files (lists, splits, QA report, label files, contact sheets) written
    /// once every session is done, the sessions' trims having left them out: what `merge` does
    /// over the parts too, so both give the same files.
    fn finish_dataset(&self) -> Result<Option<ListSummary>, GenerateError> {
        let path = self.job.output.join(PLAN_FILE);
        if !path.is_file() {
            return Ok(None);
        }
        let planned = PlannedClips::read(&path)?;
        let options = trim_options(&self.job.clips, &planned);
        let dataset = self.job.output.join(DATASET_DIR);
        let lists = crate::trim::run::relist(&self.ffmpeg, &dataset, &planned.labels, &options)?;
        Ok(Some(lists))
    }

    /// Cuts `capture`'s clips out of its video into the dataset; `estimated`: the clips the
    /// plan promised for it (for the progress line).
    fn trim(
        &self,
        capture: &Capture,
        paths: &SessionPaths,
        estimated: u64,
    ) -> Result<crate::trim::run::TrimSummary, GenerateError> {
        let Some(planned) = &self.planned else {
            return Err(GenerateError::Parts(
                "internal: no plan read before trimming".to_owned(),
            ));
        };
        planned.check(capture)?;
        let rendered = RenderedVideo::read(&paths.render_bag)?;
        rendered.check_renders(capture)?;
        let options = TrimOptions {
            jpeg_quality: self.spec.file.randomise.jpeg_quality,
            ..trim_options(&self.job.clips, planned)
        };
        let source = VideoSource {
            path: &paths.video,
            frame0_nanos: rendered.frame0_nanos,
            fps: rendered.fps,
            annotations: Some(&paths.render_bag),
            drawn: rendered.drawn.as_ref(),
        };
        // `estimated`: the clips the plan promised for this capture; `trim` finds `total`
        // (instances are found only now).
        let progress = |done: usize, total: usize| {
            self.progress.trimming(done as u64, total as u64, estimated);
            if done > 0 {
                self.hook.event();
            }
        };
        trim_capture(
            &self.ffmpeg,
            capture,
            &source,
            &self.job.output.join(DATASET_DIR),
            &options,
            &progress,
            self.stop,
        )
        .map_err(|source| match source {
            RunError::Interrupted => GenerateError::Interrupted,
            source => GenerateError::Cut {
                path: paths.video.clone(),
                source: Box::new(source),
            },
        })
    }
}

impl std::fmt::Display for GenerateSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let part = self
            .shard
            .map_or_else(String::new, |s| format!(" (shard {s})"));
        writeln!(
            f,
            "generated {}{part}: {} sessions ({} finished before), {} clips, {} frames rendered in {:.1} s",
            self.dir.display(),
            self.sessions,
            self.already_done,
            self.clips,
            self.frames_rendered,
            self.total_seconds
        )?;
        let s = &self.seconds;
        writeln!(
            f,
            "  stages: convert {:.1} s, capture {:.1} s, render {:.1} s, trim {:.1} s",
            s.convert, s.capture, s.render, s.trim
        )?;
        if let Some(lists) = &self.lists {
            writeln!(
                f,
                "  dataset {}: {}",
                self.dir.join(DATASET_DIR).display(),
                lists.split_counts()
            )?;
        }
        if self.truncated > 0 {
            writeln!(
                f,
                "  {} segments left out: a video did not cover them",
                self.truncated
            )?;
        }
        Ok(())
    }
}
