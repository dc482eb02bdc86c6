//! Contact sheets: one picture per class, so a person can see in a glance what the class's clips
//! show (a squat class that shows no squat, a dancer hidden behind a prop) before training on it.
//!
//! `annotations/contact_sheets/<class>.png` tiles up to [`MAX_TILES`] clips of the class, each at
//! the middle frame of its action span: every clip the quality checks flag comes first (framed in
//! red, its flags written on it), then clips spread evenly over the rest in clip-id order. Beside
//! it, `<class>.json` says which clip and frame each tile is, and what the class's clips were
//! flagged for. A sheet is redrawn only when that index changes, so re-runs and resumed runs cost
//! nothing; the choice depends only on the dataset's clips, so shards merged into one dataset get
//! the sheets of a single run.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use rayon::prelude::*;
use serde::Serialize;

use super::lists::{ANNOTATIONS_DIR, write_atomic};
use super::qa::{ClipFlag, Thresholds};
use super::{ClipRecord, TrimError};
use crate::video::{Ffmpeg, StillRequest, Tile, contact_sheet, still_frames, write_png};

/// Folder of the sheets, inside the annotations folder.
pub const SHEETS_DIR: &str = "contact_sheets";
/// Most tiles on one class's sheet.
pub const MAX_TILES: usize = 24;
/// Tiles per row.
const COLUMNS: u32 = 6;
/// Widest tile, pixels (smaller videos are shown at their own width).
const MAX_TILE_WIDTH_PX: u32 = 320;
/// Frame drawn inside a flagged clip's tile.
const FLAG_RGB: [u8; 3] = [230, 30, 30];
/// Its thickness, pixels.
const FLAG_FRAME_PX: usize = 3;

/// One tile of a sheet.
#[derive(Debug, Clone, PartialEq, Serialize)]
struct SheetTile {
    clip_id: String,
    /// The clip's file, relative to the dataset folder.
    video: String,
    /// The frame shown, 0 being the clip's first.
    frame: u64,
    /// What the quality checks flag the clip for.
    flags: Vec<ClipFlag>,
    /// What the tile says: the clip's variant, scene, viewpoint and part, and its flags.
    label: String,
}

/// `<class>.json`: what the sheet shows.
#[derive(Debug, Clone, PartialEq, Serialize)]
struct SheetIndex {
    label: String,
    /// Clips of the class in the dataset.
    clips: usize,
    /// Of which flagged.
    flagged: usize,
    columns: u32,
    tile_width: u32,
    tile_height: u32,
    /// Left to right, top to bottom.
    tiles: Vec<SheetTile>,
}

/// What [`write_contact_sheets`] did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SheetSummary {
    /// Sheets drawn in this run.
    pub drawn: usize,
    /// Sheets already up to date.
    pub unchanged: usize,
    /// Classes whose sheet could not be drawn, with why (said on stderr too).
    pub failed: Vec<(String, String)>,
    /// Where the sheets are.
    pub dir: PathBuf,
}

/// Draws the sheet of every class of `clips` (the dataset's complete clips) that changed, with
/// flags decided by `thresholds`, and removes sheets of classes that have no clip any more. A
/// class whose videos cannot be read is warned about and left without a sheet; the others are
/// still drawn.
///
/// # Errors
/// [`TrimError::Io`] when the sheets folder or a sheet cannot be written.
pub fn write_contact_sheets(
    ffmpeg: &Ffmpeg,
    dataset: &Path,
    clips: &BTreeMap<String, ClipRecord>,
    thresholds: &Thresholds,
) -> Result<SheetSummary, TrimError> {
    let dir = dataset.join(ANNOTATIONS_DIR).join(SHEETS_DIR);
    let mut by_class: BTreeMap<&str, Vec<&ClipRecord>> = BTreeMap::new();
    for clip in clips.values() {
        by_class.entry(&clip.label_dir).or_default().push(clip);
    }
    remove_stale(&dir, &by_class.keys().copied().collect())?;
    let mut summary = SheetSummary {
        dir: dir.clone(),
        ..SheetSummary::default()
    };
    if by_class.is_empty() {
        return Ok(summary);
    }
    std::fs::create_dir_all(&dir).map_err(TrimError::io("create", &dir))?;
    let mut changed = Vec::new();
    for (label_dir, class_clips) in by_class {
        let index = sheet_index(&class_clips, thresholds);
        let json_path = dir.join(format!("{label_dir}.json"));
        let png_path = dir.join(format!("{label_dir}.png"));
        let json = serde_json::to_string_pretty(&index).map_err(|source| TrimError::Json {
            path: json_path.clone(),
            source,
        })? + "\n";
        if png_path.is_file() && std::fs::read_to_string(&json_path).is_ok_and(|j| j == json) {
            summary.unchanged += 1;
        } else {
            changed.push((index, class_clips, json, json_path, png_path));
        }
    }
    // Each sheet is one ffmpeg decoding a frame of each of its tiles' videos (1–2 s for 24
    // tiles at 320×240): the sheets are drawn side by side, one per core, and written in order.
    let drawn: Vec<_> = changed
        .par_iter()
        .map(|(index, class_clips, ..)| draw(ffmpeg, dataset, index, class_clips))
        .collect();
    for ((index, _, json, json_path, png_path), sheet) in changed.into_iter().zip(drawn) {
        match sheet {
            Ok((w, h, rgb)) => {
                write_png(&png_path, w, h, &rgb).map_err(|e| TrimError::Sheet {
                    path: png_path.clone(),
                    source: Box::new(e),
                })?;
                write_atomic(&json_path, json.as_bytes())?;
                summary.drawn += 1;
            }
            Err(e) => {
                tracing::warn!("no contact sheet for class `{}`: {e}", index.label);
                summary.failed.push((index.label.clone(), e.to_string()));
            }
        }
    }
    Ok(summary)
}

/// The tiles of one class: its flagged clips first, then the others spread evenly, in clip-id
/// order within each group.
fn sheet_index(clips: &[&ClipRecord], thresholds: &Thresholds) -> SheetIndex {
    let flags_of = |c: &ClipRecord| {
        c.qa.as_ref()
            .map(|q| thresholds.flags(q))
            .unwrap_or_default()
    };
    let mut sorted: Vec<(&ClipRecord, Vec<ClipFlag>)> =
        clips.iter().map(|c| (*c, flags_of(c))).collect();
    sorted.sort_by(|a, b| a.0.clip_id.cmp(&b.0.clip_id));
    let (flagged, others): (Vec<_>, Vec<_>) = sorted.into_iter().partition(|(_, f)| !f.is_empty());
    let flagged_count = flagged.len();
    let room = MAX_TILES.saturating_sub(flagged.len());
    let chosen_others = spread(others.len(), room)
        .into_iter()
        .map(|i| others[i].clone());
    let tiles: Vec<SheetTile> = flagged
        .into_iter()
        .take(MAX_TILES)
        .chain(chosen_others)
        .map(|(c, flags)| SheetTile {
            clip_id: c.clip_id.clone(),
            video: c.video.clone(),
            frame: shown_frame(c),
            label: tile_label(c, &flags),
            flags,
        })
        .collect();
    let (tile_width, tile_height) = tile_size(clips[0]);
    SheetIndex {
        label: clips[0].label.clone(),
        clips: clips.len(),
        flagged: flagged_count,
        columns: COLUMNS,
        tile_width,
        tile_height,
        tiles,
    }
}

/// `k` indices spread evenly over `0..n` (all of them when `k ≥ n`): the middle of each of `k`
/// equal parts.
fn spread(n: usize, k: usize) -> Vec<usize> {
    if k >= n {
        return (0..n).collect();
    }
    (0..k).map(|i| (2 * i + 1) * n / (2 * k)).collect()
}

/// The middle frame of the clip's action span (of the clip when it has none).
fn shown_frame(c: &ClipRecord) -> u64 {
    let (start, end) = c
        .action_span
        .as_ref()
        .map_or((0, c.frame_count), |a| (a.start_frame, a.end_frame));
    u64::midpoint(start, end).min(c.frame_count.saturating_sub(1))
}

/// The tile size: the first clip's video at most [`MAX_TILE_WIDTH_PX`] wide, its aspect kept,
/// both sides even (4:3 when the size is unknown).
fn tile_size(c: &ClipRecord) -> (u32, u32) {
    let (w, h) = c
        .capture_resolution
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| w > 0 && h > 0)
        .unwrap_or((4, 3));
    let width = if w >= 2 {
        w.min(MAX_TILE_WIDTH_PX)
    } else {
        MAX_TILE_WIDTH_PX
    } & !1;
    let height = u32::try_from(u64::from(width) * u64::from(h) / u64::from(w))
        .unwrap_or(width)
        .max(2)
        & !1;
    (width, height)
}

/// The sheet's pixels: every tile's frame, flagged ones framed in red, labelled.
fn draw(
    ffmpeg: &Ffmpeg,
    dataset: &Path,
    index: &SheetIndex,
    clips: &[&ClipRecord],
) -> Result<(u32, u32, Vec<u8>), crate::video::VideoError> {
    let fps_of: BTreeMap<&str, f64> = clips.iter().map(|c| (c.clip_id.as_str(), c.fps)).collect();
    let paths: Vec<PathBuf> = index.tiles.iter().map(|t| dataset.join(&t.video)).collect();
    let requests: Vec<StillRequest<'_>> = index
        .tiles
        .iter()
        .zip(&paths)
        .map(|(t, path)| StillRequest {
            path,
            frame: t.frame,
            fps: fps_of[t.clip_id.as_str()],
        })
        .collect();
    let size = (index.tile_width, index.tile_height);
    let mut frames = still_frames(ffmpeg, &requests, size)?;
    for (frame, tile) in frames.iter_mut().zip(&index.tiles) {
        if !tile.flags.is_empty() {
            frame_in_red(frame, size);
        }
    }
    let tiles: Vec<Tile<'_>> = frames
        .iter()
        .zip(&index.tiles)
        .map(|(rgb24, t)| Tile {
            rgb24,
            width: size.0,
            height: size.1,
            label: &t.label,
        })
        .collect();
    contact_sheet(&tiles, index.columns, index.tile_width)
}

/// A tile's label: the clip's variant, scene, viewpoint and part (as in clips.jsonl), and its
/// flags.
fn tile_label(c: &ClipRecord, flags: &[ClipFlag]) -> String {
    let mut label = format!("v{} s{} c{}", c.variant, c.scene, c.viewpoint);
    if let Some(part) = c.part {
        label.push_str(&format!(" #{part}"));
    }
    for f in flags {
        label.push_str(&format!(" {f:?}").to_uppercase());
    }
    label
}

/// Draws a red frame inside an `rgb24` tile.
fn frame_in_red(rgb: &mut [u8], (width, height): (u32, u32)) {
    let (w, h) = (width as usize, height as usize);
    for y in 0..h {
        for x in 0..w {
            let edge = x < FLAG_FRAME_PX
                || y < FLAG_FRAME_PX
                || x + FLAG_FRAME_PX >= w
                || y + FLAG_FRAME_PX >= h;
            if edge {
                rgb[(y * w + x) * 3..][..3].copy_from_slice(&FLAG_RGB);
            }
        }
    }
}

/// Removes the sheets (and their indexes) of classes not in `keep`.
fn remove_stale(dir: &Path, keep: &BTreeSet<&str>) -> Result<(), TrimError> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Ok(());
    };
    for entry in entries.flatten() {
        let path = entry.path();
        let ours = matches!(
            path.extension().and_then(|e| e.to_str()),
            Some("png" | "json")
        );
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if ours && !keep.contains(stem) {
            std::fs::remove_file(&path).map_err(TrimError::io("remove", &path))?;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_takes_the_middle_of_equal_parts_and_everything_when_there_is_room() {
        assert_eq!(spread(5, 10), [0, 1, 2, 3, 4]);
        assert_eq!(spread(10, 2), [2, 7]);
        assert_eq!(spread(100, 4), [12, 37, 62, 87]);
        assert!(spread(7, 0).is_empty());
        for n in 1..60 {
            for k in 1..n {
                let s = spread(n, k);
                assert_eq!(s.len(), k);
                assert!(s.windows(2).all(|w| w[0] < w[1]), "{n} {k} {s:?}");
                assert!(*s.last().unwrap() < n);
            }
        }
    }

    #[test]
    fn a_red_frame_is_drawn_on_the_tiles_edges_only() {
        let mut rgb = vec![0_u8; 10 * 8 * 3];
        frame_in_red(&mut rgb, (10, 8));
        let px = |x: usize, y: usize| &rgb[(y * 10 + x) * 3..][..3];
        assert_eq!(px(0, 0), FLAG_RGB);
        assert_eq!(px(9, 7), FLAG_RGB);
        assert_eq!(px(2, 4), FLAG_RGB);
        assert_eq!(px(3, 3), [0, 0, 0]);
        assert_eq!(px(6, 4), [0, 0, 0]);
        assert_eq!(px(7, 4), FLAG_RGB);
    }
}
