//! A render written in pieces that outlive the process, so a render killed part-way (`kill -9`,
//! a crash, Ctrl-C) resumes at its first unfinished piece instead of at frame 0.
//!
//! A piece is a run of whole segments: it starts at frame 0 or at the first output frame of a
//! segment (where the render makes a keyframe anyway) and holds at least
//! [`PieceJob::min_frames`] frames (`1`: every segment is a piece). Each piece is encoded by an
//! encoder of its own (so its bytes do not depend on what came before it, and a piece rendered
//! by a later run is the same as one rendered in one go), and its labels go to a render bag of
//! its own. A piece's video, labels, passes and contact-sheet tiles are written in this process's
//! scratch folder, moved into [`PieceJob::dir`], and only then counted as done in
//! `pieces.json` there (rewritten atomically). Once every piece is done, the pieces are joined:
//! the videos by copying their H.264 samples into one MP4 ([`crate::video::concat_mp4`]), the
//! labels by copying every frame's message into one render bag, the passes by linking their
//! frames into one folder — the same outputs, in the same places, as [`super::render_capture`]
//! writes (the render bag byte for byte; the video differs, its encoder restarting at each
//! piece). The pieces stay until the caller deletes them, so a join cut short is made again.
//!
//! At most the piece in progress is drawn again after a kill; the joined outputs depend only on
//! the capture, the settings and the piece size.

use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};

use serde::{Deserialize, Serialize};

use super::{
    FrameSinks, LabelSink, Outputs, Plan, RenderError, RenderSettings, RenderSummary, Scenes,
    check_resolution, draw_all, preview_label, render_capture, write_preview,
};
use crate::bags::capture::Capture;
use crate::bags::render::{ANNOTATIONS_TOPIC, decode_annotation};
use crate::mcap_io::BagReader;
use crate::ros::autoact_msgs::FrameAnnotation;
use crate::skeleton::rig::Rig;
use crate::video::{EncodedVideo, Ffmpeg, Mp4Source, Rational};

/// The pieces' journal in [`PieceJob::dir`].
const JOURNAL_FILE: &str = "pieces.json";
/// Its format version.
const VERSION: u32 = 1;
/// The folders of the finished pieces' depth and mask passes in [`PieceJob::dir`].
const DEPTH_DIR: &str = "depth";
const MASK_DIR: &str = "mask";

/// Where and how a render is made in pieces.
pub struct PieceJob<'a> {
    /// The finished pieces: kept from run to run, a render resumes from what is here.
    pub dir: PathBuf,
    /// This process's own folder for the piece in progress (an encoder left running by a killed
    /// process finishes its file there, never in [`PieceJob::dir`]).
    pub scratch: PathBuf,
    /// Least frames of a piece (whole segments): `1` makes every segment a piece; larger pieces
    /// start fewer encoders (about 0.1 s of CPU each) and redraw more after a kill.
    pub min_frames: u64,
    /// Called with a batch's first frame and frame count just before the batch is drawn (frames
    /// drawn and then lost to a kill are counted too).
    pub drawing: &'a (dyn Fn(u64, u64) + Sync),
}

/// What a render in pieces did.
#[derive(Debug, Clone, PartialEq)]
pub struct PiecesSummary {
    /// The joined render.
    pub render: RenderSummary,
    /// Pieces of the render.
    pub pieces: usize,
    /// Pieces an earlier run had finished (not drawn again).
    pub resumed: usize,
    /// Frames this call drew.
    pub frames_drawn: u64,
}

/// `pieces.json`: the pieces' bounds and how many are done (they are made in order).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Journal {
    version: u32,
    /// Output frames of the whole render.
    frames: u64,
    /// First frame of each piece.
    starts: Vec<u64>,
    /// Pieces finished, from the first.
    done: usize,
    /// The renderer's description (the render bag's `settings_json` names it).
    renderer: String,
    /// Frames of the render's timeline, when only some are drawn (a render of other frames
    /// starts over).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    timeline_frames: Option<u64>,
}

/// Renders `capture` as [`render_capture`] does, in pieces that a later call resumes ([`self`]).
/// A render without a video, or with a frames folder, is not made in pieces (it is made by
/// [`render_capture`] in one go).
///
/// # Errors
/// [`RenderError`]; finished pieces stay finished, no output that looks complete is left.
#[expect(
    clippy::too_many_arguments,
    reason = "render_capture's arguments and the pieces' job"
)]
pub fn render_in_pieces(
    rig: &Rig,
    capture: &Capture,
    settings: &RenderSettings,
    outputs: &Outputs,
    job: &PieceJob<'_>,
    ffmpeg: Option<&Ffmpeg>,
    progress: &(dyn Fn(u64) + Sync),
    stop: &AtomicBool,
) -> Result<PiecesSummary, RenderError> {
    let (Some(video), None) = (&outputs.video, &outputs.frames_dir) else {
        let render = render_capture(rig, capture, settings, outputs, ffmpeg, progress, stop)?;
        return Ok(PiecesSummary {
            frames_drawn: render.frames,
            render,
            pieces: 1,
            resumed: 0,
        });
    };
    check_resolution(settings)?;
    let plan = Plan::new(capture, settings)?;
    let starts = piece_starts(capture, &plan, job.min_frames);
    let ranges = ranges(&starts, plan.len());
    let mut journal = resume(&job.dir, &starts, &plan)?;
    let resumed = journal.done;
    let scenes = Scenes::prepare(rig, capture, settings);
    let mut frames_drawn = 0;
    for (i, range) in ranges.iter().enumerate().skip(journal.done) {
        if stop.load(Ordering::Relaxed) {
            return Err(RenderError::Interrupted);
        }
        let piece = plan.piece(range.clone());
        journal.renderer = render_piece(
            &scenes,
            &piece,
            i,
            job,
            settings,
            outputs,
            ffmpeg,
            progress,
            job.drawing,
            stop,
        )?;
        frames_drawn += range.len() as u64;
        journal.done = i + 1;
        write_journal(&job.dir, &journal)?;
    }
    progress(plan.timeline_frames());
    let encoded = join_video(&job.dir, ranges.len(), video, &plan)?;
    let render = join_labels(
        rig, capture, settings, outputs, job, &plan, &journal, encoded, ffmpeg,
    )?;
    Ok(PiecesSummary {
        render: RenderSummary {
            unknown_prop_kinds: scenes.unknown_prop_kinds(),
            ..render
        },
        pieces: ranges.len(),
        resumed,
        frames_drawn,
    })
}

/// First frame of each piece: frame 0, then the first output frame of a segment once the piece
/// so far holds at least `min_frames` frames; a last piece shorter than that joins the one before.
/// A piece starts only at a keyframe of the plan (a render of every frame makes each segment's
/// first frame one; a render of some frames, the first drawn frame of a segment that starts a
/// clip), so that the image effects, which start afresh in each piece, draw as one render does.
fn piece_starts(capture: &Capture, plan: &Plan, min_frames: u64) -> Vec<u64> {
    let len = plan.len() as u64;
    let mut bounds: Vec<u64> = capture
        .segments
        .iter()
        .filter_map(|s| s.start.to_nanos())
        .map(|t| plan.count_before(t) as u64)
        .filter(|&k| k > 0 && k < len && plan.keyframes.binary_search(&k).is_ok())
        .collect();
    bounds.sort_unstable();
    bounds.dedup();
    let least = min_frames.max(1);
    let mut starts = vec![0];
    for k in bounds {
        if starts.last().is_some_and(|&s| k - s >= least) {
            starts.push(k);
        }
    }
    if starts.len() > 1 && starts.last().is_some_and(|&s| len - s < least) {
        starts.pop();
    }
    starts
}

/// The frame ranges of the pieces starting at `starts`, over `len` frames.
fn ranges(starts: &[u64], len: usize) -> Vec<Range<usize>> {
    let at = |k: u64| usize::try_from(k).unwrap_or(usize::MAX);
    starts
        .iter()
        .enumerate()
        .map(|(i, &s)| at(s)..starts.get(i + 1).map_or(len, |&e| at(e)))
        .collect()
}

/// The journal of the pieces in `dir` when it is of this render (the same frames and bounds),
/// else a fresh one, with `dir` emptied and created.
fn resume(dir: &Path, starts: &[u64], plan: &Plan) -> Result<Journal, RenderError> {
    let fresh = Journal {
        version: VERSION,
        frames: plan.len() as u64,
        starts: starts.to_vec(),
        done: 0,
        renderer: String::new(),
        timeline_frames: plan.timeline_of_some,
    };
    let path = dir.join(JOURNAL_FILE);
    if let Ok(bytes) = std::fs::read(&path)
        && let Ok(found) = serde_json::from_slice::<Journal>(&bytes)
        && found.version == VERSION
        && found.frames == fresh.frames
        && found.starts == fresh.starts
        && found.timeline_frames == fresh.timeline_frames
        && found.done <= starts.len()
    {
        return Ok(found);
    }
    if dir.exists() {
        tracing::debug!(dir = %dir.display(), "render pieces of other bounds: starting over");
        std::fs::remove_dir_all(dir).map_err(io("remove the old pieces in", dir))?;
    }
    std::fs::create_dir_all(dir).map_err(io("create", dir))?;
    Ok(fresh)
}

fn write_journal(dir: &Path, journal: &Journal) -> Result<(), RenderError> {
    let path = dir.join(JOURNAL_FILE);
    let mut text = serde_json::to_string_pretty(journal).unwrap_or_default();
    text.push('\n');
    crate::atomic_file::write(&path, text.as_bytes()).map_err(io("write", &path))
}

fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> RenderError + use<> {
    let path = path.to_path_buf();
    move |source| RenderError::Io {
        action,
        path,
        source,
    }
}

/// Piece `i`'s video and render bag file names.
fn piece_video(i: usize) -> String {
    format!("{i:05}.mp4")
}
fn piece_bag(i: usize) -> String {
    format!("{i:05}.render.mcap")
}
fn tile_file(k: usize) -> String {
    format!("tile_{k:06}.png")
}

/// Renders `piece` (number `i`) into the scratch folder and moves its files into the pieces'
/// folder; returns the renderer's description.
#[expect(
    clippy::too_many_arguments,
    reason = "one piece of render_in_pieces' work"
)]
fn render_piece(
    scenes: &Scenes<'_>,
    piece: &Plan,
    i: usize,
    job: &PieceJob<'_>,
    settings: &RenderSettings,
    outputs: &Outputs,
    ffmpeg: Option<&Ffmpeg>,
    progress: &(dyn Fn(u64) + Sync),
    drawing: &(dyn Fn(u64, u64) + Sync),
    stop: &AtomicBool,
) -> Result<String, RenderError> {
    let scratch = &job.scratch;
    std::fs::create_dir_all(scratch).map_err(io("create", scratch))?;
    let pass_dir = |wanted: bool, name: &str| wanted.then(|| scratch.join(format!("{name}-{i}")));
    let staged = Outputs {
        video: Some(scratch.join(piece_video(i))),
        render_bag: Some(scratch.join(piece_bag(i))),
        frames_dir: None,
        preview: None,
        depth_dir: pass_dir(outputs.depth_dir.is_some(), DEPTH_DIR),
        mask_dir: pass_dir(outputs.mask_dir.is_some(), MASK_DIR),
    };
    let wanted = super::Wanted {
        depth: staged.depth_dir.is_some(),
        mask: staged.mask_dir.is_some(),
    };
    let picks = piece.blender_samples(scenes.rig, scenes.capture, settings)?;
    let first = piece.first as u64;
    let blender_progress = |k: u64| progress(first + k);
    let blender = scenes.blender(settings, &picks, wanted, &blender_progress, stop)?;
    drop(picks);
    let renderer = blender
        .as_ref()
        .map_or_else(|| "autoact cpu".to_owned(), |b| b.description.clone());
    let (Some(video), Some(bag)) = (&staged.video, &staged.render_bag) else {
        return Err(RenderError::NoFrames { limit: None });
    };
    let labels = LabelSink::create(
        bag,
        video,
        scenes.capture,
        settings,
        piece,
        scenes.rig,
        &renderer,
    )?;
    let mut sinks = FrameSinks::open(piece, &staged, settings, ffmpeg, Some(labels))?;
    draw_all(
        scenes,
        piece,
        &mut sinks,
        blender.as_ref(),
        progress,
        drawing,
        stop,
    )?;
    if let Some(labels) = sinks.labels.take() {
        labels.writer.finish()?;
    }
    for (&k, (rgb, _)) in piece.preview_picks.iter().zip(&sinks.preview_tiles) {
        let path = scratch.join(tile_file(piece.first + k));
        crate::video::write_png(&path, settings.width, settings.height, rgb)?;
    }
    keep_piece(&staged, piece, i, &job.dir, scratch)?;
    Ok(renderer)
}

/// Moves a finished piece's files from `scratch` into the pieces' folder `dir`.
fn keep_piece(
    staged: &Outputs,
    piece: &Plan,
    i: usize,
    dir: &Path,
    scratch: &Path,
) -> Result<(), RenderError> {
    let mut moves: Vec<(PathBuf, PathBuf)> = [piece_video(i), piece_bag(i)]
        .into_iter()
        .chain(
            piece
                .preview_picks
                .iter()
                .map(|&k| tile_file(piece.first + k)),
        )
        .map(|name| (scratch.join(&name), dir.join(name)))
        .collect();
    for (from, pass) in [(&staged.depth_dir, DEPTH_DIR), (&staged.mask_dir, MASK_DIR)] {
        let Some(from) = from else { continue };
        let to = dir.join(pass);
        std::fs::create_dir_all(&to).map_err(io("create", &to))?;
        for entry in std::fs::read_dir(from).map_err(io("list", from))? {
            let entry = entry.map_err(io("list", from))?;
            moves.push((entry.path(), to.join(entry.file_name())));
        }
    }
    for (from, to) in moves {
        crate::atomic_file::commit(&from, &to).map_err(io("move into place", &to))?;
    }
    for dir in [&staged.depth_dir, &staged.mask_dir].into_iter().flatten() {
        std::fs::remove_dir_all(dir).map_err(io("remove", dir))?;
    }
    Ok(())
}

/// Joins the `count` pieces' videos in `dir` into `video`.
fn join_video(
    dir: &Path,
    count: usize,
    video: &Path,
    plan: &Plan,
) -> Result<EncodedVideo, RenderError> {
    let unreadable = |path: &Path| RenderError::Piece {
        path: path.to_path_buf(),
        detail: "not a single-track H.264 MP4 that can be copied from".to_owned(),
    };
    let mut parts = Vec::with_capacity(count);
    for i in 0..count {
        let path = dir.join(piece_video(i));
        parts.push(Mp4Source::open(&path)?.ok_or_else(|| unreadable(&path))?);
    }
    let bytes = crate::video::concat_mp4(&parts, video)?;
    let joined = Mp4Source::open(video)?.ok_or_else(|| unreadable(video))?;
    if joined.frame_count() != plan.len() as u64 {
        return Err(RenderError::Piece {
            path: video.to_path_buf(),
            detail: format!(
                "{} frames joined, {} rendered",
                joined.frame_count(),
                plan.len()
            ),
        });
    }
    let fps = Rational::from_f64(plan.fps).ok_or_else(|| RenderError::Piece {
        path: video.to_path_buf(),
        detail: format!("frame rate {} is not usable", plan.fps),
    })?;
    Ok(EncodedVideo {
        path: video.to_path_buf(),
        frame_count: joined.frame_count(),
        bytes,
        fps,
        keyframes: joined.keyframes(),
    })
}

/// Writes the render bag (every piece's labels, in order, then the embedded video if asked),
/// the passes and the contact sheet of the joined render.
#[expect(clippy::too_many_arguments, reason = "the joined render's parts")]
fn join_labels(
    rig: &Rig,
    capture: &Capture,
    settings: &RenderSettings,
    outputs: &Outputs,
    job: &PieceJob<'_>,
    plan: &Plan,
    journal: &Journal,
    video: EncodedVideo,
    ffmpeg: Option<&Ffmpeg>,
) -> Result<RenderSummary, RenderError> {
    let mut summary = RenderSummary {
        frames: plan.len() as u64,
        video: None,
        render_bag: None,
        preview: None,
        forced_keyframes: plan.keyframes.clone(),
        unknown_prop_kinds: Vec::new(),
    };
    if let Some(bag) = outputs.render_bag_path() {
        let mut labels = LabelSink::create(
            &bag,
            &video.path,
            capture,
            settings,
            plan,
            rig,
            &journal.renderer,
        )?;
        let mut annotation = FrameAnnotation::default();
        for i in 0..journal.starts.len() {
            let path = job.dir.join(piece_bag(i));
            for reader in
                BagReader::open_all(&path).map_err(crate::bags::render::RenderBagError::from)?
            {
                for m in reader.messages() {
                    let m = m.map_err(crate::bags::render::RenderBagError::from)?;
                    if m.channel.topic != ANNOTATIONS_TOPIC {
                        continue;
                    }
                    decode_annotation(&m.data, &mut annotation).map_err(|e| {
                        RenderError::Piece {
                            path: path.clone(),
                            detail: format!("{ANNOTATIONS_TOPIC}: {e}"),
                        }
                    })?;
                    labels.writer.annotation(m.log_time, &annotation)?;
                }
            }
        }
        labels.finish(Some(&video), ffmpeg, settings, plan)?;
        summary.render_bag = Some(bag);
    }
    for (wanted, name) in [
        (&outputs.depth_dir, DEPTH_DIR),
        (&outputs.mask_dir, MASK_DIR),
    ] {
        if let Some(to) = wanted {
            link_pass(&job.dir.join(name), to)?;
        }
    }
    if let Some(path) = &outputs.preview {
        let mut tiles = Vec::with_capacity(plan.preview_picks.len());
        for &k in &plan.preview_picks {
            let (_, _, rgb) = crate::video::read_png(&job.dir.join(tile_file(k)))?;
            tiles.push((rgb, preview_label(capture, plan.scene(capture, k))));
        }
        write_preview(path, &tiles, settings)?;
        summary.preview = Some(path.clone());
    }
    summary.video = Some(video);
    Ok(summary)
}

/// Fills the pass folder `to` (through its temporary sibling) with hard links to (or copies of)
/// the pieces' pass frames in `from`: the pieces keep theirs until the render is recorded, so a
/// join interrupted here is simply made again.
fn link_pass(from: &Path, to: &Path) -> Result<(), RenderError> {
    let part = crate::atomic_file::temporary_sibling(to).ok_or_else(|| RenderError::Piece {
        path: to.to_path_buf(),
        detail: "not a folder name".to_owned(),
    })?;
    if part.exists() {
        std::fs::remove_dir_all(&part).map_err(io("remove the old", &part))?;
    }
    std::fs::create_dir_all(&part).map_err(io("create", &part))?;
    if from.is_dir() {
        for entry in std::fs::read_dir(from).map_err(io("list", from))? {
            let entry = entry.map_err(io("list", from))?;
            let link = part.join(entry.file_name());
            crate::atomic_file::link_or_copy(&entry.path(), &link).map_err(io("link", &link))?;
        }
    }
    crate::atomic_file::commit_folder(&part, to).map_err(io("move into place", to))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pieces_cover_every_frame_once_in_order() {
        let starts = [0, 4, 9];
        assert_eq!(ranges(&starts, 12), vec![0..4, 4..9, 9..12]);
        assert_eq!(ranges(&[0], 5), vec![0..5]);
    }
}
