//! `autoact merge`: the parts `generate --shard K/N` wrote, joined into the dataset one machine
//! would have made. The parts' clips are linked (copied across file systems) into one dataset
//! folder, their manifests concatenated in shard order (each shard is a contiguous run of the
//! plan's sessions, so this is the single run's order), and every list rewritten over the
//! plan: lists, splits, label ids and annotation files byte-identical to a single run's.

use std::path::{Path, PathBuf};

use super::journal::{Journal, Stage, shard_text};
use super::{
    CAPTURES_DIR, ClipChoice, DATASET_DIR, GenerateError, PLAN_FILE, PREVIEWS_DIR, RENDERS_DIR,
    trim_options,
};
use crate::trim::lists::ListSummary;
use crate::trim::manifest::Manifest;
use crate::trim::planned::PlannedClips;
use crate::trim::split::Key;
use crate::video::ReencodeSettings;

/// What a merge did.
#[derive(Debug, Clone, PartialEq)]
pub struct MergeSummary {
    /// The merged folder.
    pub dir: PathBuf,
    /// Parts merged.
    pub parts: usize,
    /// Sessions in all.
    pub sessions: usize,
    /// Clips in the merged dataset.
    pub clips: usize,
    /// The lists written.
    pub lists: ListSummary,
}

/// One part, read.
struct Part {
    dir: PathBuf,
    journal: Journal,
}

/// Merges the finished parts `parts` (every shard of one `--shard K/N` run, in any order) into
/// `output`, which must not exist (or is replaced with `force`); the merged folder appears only
/// when complete.
///
/// # Errors
/// [`GenerateError::Parts`] for parts that are not every shard of one job, finished;
/// [`GenerateError::Io`] and [`GenerateError::Trim`] for the files.
pub fn merge(parts: &[PathBuf], output: &Path, force: bool) -> Result<MergeSummary, GenerateError> {
    let parts = read_parts(parts)?;
    if output.exists() && !force {
        return Err(GenerateError::Parts(format!(
            "`{}` exists: merge into a new folder, or pass --force to replace it",
            output.display()
        )));
    }
    let plan_bytes = one_plan(&parts)?;
    let temporary = crate::atomic_file::temporary_sibling(output).ok_or_else(|| {
        GenerateError::Parts(format!("`{}` has no folder name", output.display()))
    })?;
    if temporary.exists() {
        std::fs::remove_dir_all(&temporary).map_err(GenerateError::io("removing", &temporary))?;
    }
    let result = fill(&parts, plan_bytes.as_deref(), &temporary);
    let summary = match result {
        Ok(s) => s,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&temporary);
            return Err(e);
        }
    };
    crate::atomic_file::sync_folder(&temporary)
        .map_err(GenerateError::io("syncing", &temporary))?;
    crate::atomic_file::commit_folder(&temporary, output)
        .map_err(GenerateError::io("renaming into place", output))?;
    Ok(MergeSummary {
        dir: output.to_path_buf(),
        ..summary
    })
}

/// Reads every part's journal and checks they are the shards `0..N` of one job, all finished;
/// sorted by shard.
fn read_parts(dirs: &[PathBuf]) -> Result<Vec<Part>, GenerateError> {
    let mut parts = Vec::with_capacity(dirs.len());
    for dir in dirs {
        let journal = Journal::read(dir)?.ok_or_else(|| {
            GenerateError::Parts(format!(
                "`{}` holds no generate journal: not a part of `autoact generate --shard`",
                dir.display()
            ))
        })?;
        let unfinished = journal.unfinished();
        if !unfinished.is_empty() {
            return Err(GenerateError::Parts(format!(
                "part `{}` (shard {}) is not finished: {} sessions left ({}); run its generate again",
                dir.display(),
                shard_text(journal.shard),
                unfinished.len(),
                unfinished.join(", ")
            )));
        }
        parts.push(Part {
            dir: dir.clone(),
            journal,
        });
    }
    let Some(first) = parts.first() else {
        return Err(GenerateError::Parts("no parts to merge".to_owned()));
    };
    let Some(count) = first.journal.shard.map(|s| s.count) else {
        return Err(GenerateError::Parts(format!(
            "`{}` is a whole dataset, not a shard's part",
            first.dir.display()
        )));
    };
    for p in &parts[1..] {
        first.journal.check_same_job(
            &p.dir,
            &Journal {
                shard: first.journal.shard,
                sessions: first.journal.sessions.clone(),
                ..p.journal.clone()
            },
        )?;
    }
    parts.sort_by_key(|p| p.journal.shard.map_or(usize::MAX, |s| s.index));
    let mut missing = Vec::new();
    for k in 0..count {
        let matching: Vec<&Part> = parts
            .iter()
            .filter(|p| {
                p.journal
                    .shard
                    .is_some_and(|s| s.index == k && s.count == count)
            })
            .collect();
        match matching.len() {
            0 => missing.push(format!("{k}/{count}")),
            1 => {}
            _ => {
                return Err(GenerateError::Parts(format!(
                    "shard {k}/{count} given twice: {}",
                    matching
                        .iter()
                        .map(|p| format!("`{}`", p.dir.display()))
                        .collect::<Vec<_>>()
                        .join(", ")
                )));
            }
        }
    }
    if !missing.is_empty() || parts.len() != count {
        return Err(GenerateError::Parts(format!(
            "the parts are not the {count} shards of one run: missing {}",
            if missing.is_empty() {
                "none, but shards of other counts were given".to_owned()
            } else {
                missing.join(", ")
            }
        )));
    }
    Ok(parts)
}

/// The plan every part wrote (byte-identical in each that has one; a part with no sessions has
/// none); `None` when no part has sessions.
fn one_plan(parts: &[Part]) -> Result<Option<Vec<u8>>, GenerateError> {
    let mut plan: Option<(Vec<u8>, &Path)> = None;
    for p in parts.iter().filter(|p| !p.journal.sessions.is_empty()) {
        let path = p.dir.join(PLAN_FILE);
        let bytes = std::fs::read(&path).map_err(GenerateError::io("reading", &path))?;
        match &plan {
            Some((b, first)) if *b != bytes => {
                return Err(GenerateError::Parts(format!(
                    "`{}` and `{}` differ: the parts were made from different specs or sources",
                    first.join(PLAN_FILE).display(),
                    path.display()
                )));
            }
            Some(_) => {}
            None => plan = Some((bytes, &p.dir)),
        }
    }
    Ok(plan.map(|(b, _)| b))
}

/// Fills the folder `out`: the plan, every part's dataset files and kept intermediates, the
/// manifests concatenated, the lists rewritten and a journal of the whole dataset.
fn fill(parts: &[Part], plan: Option<&[u8]>, out: &Path) -> Result<MergeSummary, GenerateError> {
    let dataset = out.join(DATASET_DIR);
    std::fs::create_dir_all(&dataset).map_err(GenerateError::io("creating", &dataset))?;
    let mut manifest = Vec::new();
    let mut sessions = Vec::new();
    let mut clips = 0;
    for p in parts {
        sessions.extend(p.journal.sessions.iter().cloned());
        let from = p.dir.join(DATASET_DIR);
        if from.join(Manifest::FILE_NAME).is_file() {
            // Opening drops a torn last line; a finished part has none.
            clips += Manifest::open(&from)?.records().len();
            let path = from.join(Manifest::FILE_NAME);
            manifest.extend(std::fs::read(&path).map_err(GenerateError::io("reading", &path))?);
        }
        // Every per-clip file: videos, frames, label sidecars, depth and masks.
        for sub in [
            crate::trim::run::VIDEOS_DIR,
            crate::trim::run::RAWFRAMES_DIR,
            crate::trim::labels::LABELS_DIR,
            crate::trim::passes::DEPTH_DIR,
            crate::trim::passes::MASKS_DIR,
        ] {
            link_tree(&from.join(sub), &dataset.join(sub))?;
        }
        for sub in [CAPTURES_DIR, RENDERS_DIR, PREVIEWS_DIR] {
            link_tree(&p.dir.join(sub), &out.join(sub))?;
        }
    }
    let manifest_path = dataset.join(Manifest::FILE_NAME);
    crate::atomic_file::write(&manifest_path, &manifest)
        .map_err(GenerateError::io("writing", &manifest_path))?;
    let first = &parts[0].journal;
    let mut journal = Journal::new(first.settings.clone(), None, sessions.clone());
    for s in &sessions {
        journal.done.insert(s.clone(), Stage::Clips);
    }
    let lists = match plan {
        Some(bytes) => {
            let path = out.join(PLAN_FILE);
            crate::atomic_file::write(&path, bytes).map_err(GenerateError::io("writing", &path))?;
            let planned = PlannedClips::read(&path)?;
            let options = trim_options(&clip_choice(first)?, &planned);
            let ffmpeg = crate::video::Ffmpeg::locate()?;
            crate::trim::run::relist(&ffmpeg, &dataset, &planned.labels, &options)?
        }
        None => ListSummary::default(),
    };
    journal.write(out)?;
    Ok(MergeSummary {
        dir: out.to_path_buf(),
        parts: parts.len(),
        sessions: sessions.len(),
        clips,
        lists,
    })
}

/// The clip options a part's journal records.
fn clip_choice(journal: &Journal) -> Result<ClipChoice, GenerateError> {
    use clap::ValueEnum;
    let s = &journal.settings;
    let key = |name: &str| {
        Key::from_str(name, true)
            .map_err(|_| GenerateError::Parts(format!("journal: unknown split key `{name}`")))
    };
    let hold_out = s
        .hold_out
        .iter()
        .map(|kv| {
            let (k, v) = kv.split_once('=').unwrap_or((kv, ""));
            Ok((key(k)?, v.to_owned()))
        })
        .collect::<Result<Vec<_>, GenerateError>>()?;
    Ok(ClipChoice {
        split_by: key(&s.split_by)?,
        split_ratios: s.split_ratios,
        seed: s.split_seed,
        hold_out,
        reencode: s.reencode,
        // Only what lists are written from matters here: no clip is cut by a merge.
        reencode_settings: ReencodeSettings {
            preset: String::new(),
            crf: 0,
        },
        rawframes: s.rawframes,
    })
}

/// Hard-links (or copies, across file systems) every file under `from` to the same place under
/// `to`; nothing when `from` does not exist. A file already at its place is an error: two parts
/// wrote the same clip.
fn link_tree(from: &Path, to: &Path) -> Result<(), GenerateError> {
    let entries = match std::fs::read_dir(from) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(GenerateError::io("reading", from)(e)),
    };
    std::fs::create_dir_all(to).map_err(GenerateError::io("creating", to))?;
    for entry in entries {
        let entry = entry.map_err(GenerateError::io("reading", from))?;
        let name = entry.file_name();
        let (src, dst) = (from.join(&name), to.join(&name));
        if name.to_string_lossy().starts_with('.') {
            continue; // temporary parts and locks
        }
        if src.is_dir() {
            link_tree(&src, &dst)?;
            continue;
        }
        if dst.exists() {
            return Err(GenerateError::Parts(format!(
                "`{}` is in two parts (the second: `{}`)",
                dst.display(),
                src.display()
            )));
        }
        crate::atomic_file::link_or_copy(&src, &dst).map_err(GenerateError::io("copying", &src))?;
    }
    Ok(())
}

impl std::fmt::Display for MergeSummary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "merged {} parts into {}: {} sessions, {} clips ({})",
            self.parts,
            self.dir.display(),
            self.sessions,
            self.clips,
            self.lists.split_counts()
        )
    }
}
