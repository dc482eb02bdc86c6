//! `generate.json`: what a dataset folder (or a shard's part) was made with and which of its
//! units are finished. Rewritten whole and atomically after every finished unit, so it is always
//! one complete document; a unit's outputs are themselves written atomically before the journal
//! names it, so a unit the journal names is complete, and one it does not name is redone.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::GenerateError;
use super::shard::Shard;

/// The journal's file name in the output folder.
pub const JOURNAL_FILE: &str = "generate.json";

/// The format version written.
const VERSION: u32 = 1;

/// How far a session has come: each stage's outputs are complete once it is recorded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Stage {
    /// The capture bag is complete.
    Capture,
    /// The video and the render bag are complete.
    Render,
    /// Every clip of the session is in the dataset and listed.
    Clips,
}

/// Everything that decides a dataset's bytes besides the spec's sources: a re-run, and every
/// part of a merge, must have the same.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// FNV-1a of the spec file's text, hex.
    pub spec_fnv1a: String,
    /// Video size `WxH`, empty for the spec's.
    pub resolution: String,
    /// Video frame rate; `None`: the spec's.
    pub fps: Option<f64>,
    /// x264 constant rate factor of the captures.
    pub crf: u8,
    /// x264 preset of the captures.
    pub preset: String,
    /// x264 options after the preset (absent in journals from before the option: none, as
    /// those runs had).
    #[serde(default)]
    pub x264_options: String,
    /// Longest keyframe interval, frames.
    pub gop_frames: Option<u32>,
    /// x264 threads of the captures (absent in journals from before it was fixed, when x264
    /// took the machine's count: 0, which no run now has, so such a folder is refused rather
    /// than mixed).
    #[serde(default)]
    pub encoder_threads: u8,
    /// The depth and mask passes rendered (absent in journals of earlier versions: none).
    #[serde(default)]
    pub passes: crate::render::passes::Wanted,
    /// Least frames of a render piece (absent in journals from before renders were made in
    /// pieces: 0, which no run now has, so such a folder is refused rather than mixed).
    #[serde(default)]
    pub piece_frames: u64,
    /// The engine asked for with `--engine` (absent: the spec's, which its hash covers).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub engine: Option<crate::dataset::spec::EngineName>,
    /// What clips of one split share (`--split-by`).
    pub split_by: String,
    /// Train, val and test fractions.
    pub split_ratios: [f64; 3],
    /// Seed of the split; `None`: the dataset's.
    pub split_seed: Option<u64>,
    /// Held-out `KEY=VALUE`s.
    pub hold_out: Vec<String>,
    /// Every clip re-encoded.
    pub reencode: bool,
    /// Frames extracted too.
    pub rawframes: bool,
    /// A contact sheet per capture.
    pub previews: bool,
    /// Captures and renders kept (`--keep-intermediates`): a render then draws every frame of
    /// its timeline, else only the frames its clips use, so the two make other renders (absent
    /// in journals from before it was recorded, which are refused rather than mixed).
    #[serde(default)]
    pub keep_intermediates: Option<bool>,
}

/// The journal of one output folder.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Journal {
    /// Format version.
    pub version: u32,
    /// What the folder is made with.
    pub settings: Settings,
    /// The shard this folder is a part of; `None`: the whole dataset (one machine, or a merge).
    pub shard: Option<Shard>,
    /// This folder's sessions, in plan order.
    pub sessions: Vec<String>,
    /// How far each session has come (absent: not started).
    pub done: BTreeMap<String, Stage>,
}

impl Journal {
    /// A journal with nothing done yet.
    #[must_use]
    pub fn new(settings: Settings, shard: Option<Shard>, sessions: Vec<String>) -> Journal {
        Journal {
            version: VERSION,
            settings,
            shard,
            sessions,
            done: BTreeMap::new(),
        }
    }

    /// The journal at `dir/generate.json`, `None` when there is none.
    ///
    /// # Errors
    /// [`GenerateError::Io`] when it cannot be read, [`GenerateError::Journal`] when it is not a
    /// journal of this version.
    pub fn read(dir: &Path) -> Result<Option<Journal>, GenerateError> {
        let path = dir.join(JOURNAL_FILE);
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => return Err(GenerateError::io("reading", &path)(source)),
        };
        let journal: Journal =
            serde_json::from_slice(&bytes).map_err(|source| GenerateError::Journal {
                path: path.clone(),
                source,
            })?;
        if journal.version != VERSION {
            return Err(GenerateError::JournalVersion {
                path,
                version: journal.version,
            });
        }
        Ok(Some(journal))
    }

    /// Writes the journal to `dir/generate.json`, complete or not at all.
    ///
    /// # Errors
    /// [`GenerateError::Io`].
    pub fn write(&self, dir: &Path) -> Result<(), GenerateError> {
        let path = dir.join(JOURNAL_FILE);
        let mut text =
            serde_json::to_string_pretty(self).map_err(|source| GenerateError::Journal {
                path: path.clone(),
                source,
            })?;
        text.push('\n');
        crate::atomic_file::write(&path, text.as_bytes())
            .map_err(GenerateError::io("writing", &path))
    }

    /// How far session `name` has come.
    #[must_use]
    pub fn stage(&self, name: &str) -> Option<Stage> {
        self.done.get(name).copied()
    }

    /// Records that session `name` reached `stage` and writes the journal.
    ///
    /// # Errors
    /// [`GenerateError::Io`].
    pub fn record(&mut self, dir: &Path, name: &str, stage: Stage) -> Result<(), GenerateError> {
        self.done.insert(name.to_owned(), stage);
        self.write(dir)
    }

    /// The sessions whose clips are not all final yet.
    #[must_use]
    pub fn unfinished(&self) -> Vec<&str> {
        self.sessions
            .iter()
            .filter(|s| self.stage(s) != Some(Stage::Clips))
            .map(String::as_str)
            .collect()
    }

    /// Refuses to continue in `dir` with other settings, another shard or another session list
    /// than the journal there was made with.
    ///
    /// # Errors
    /// [`GenerateError::OtherJob`] naming what differs.
    pub fn check_same_job(&self, dir: &Path, now: &Journal) -> Result<(), GenerateError> {
        let what = if self.settings != now.settings {
            let was = serde_json::to_value(&self.settings).unwrap_or_default();
            let is = serde_json::to_value(&now.settings).unwrap_or_default();
            let fields: Vec<String> = match (was, is) {
                (serde_json::Value::Object(a), serde_json::Value::Object(b)) => a
                    .iter()
                    .filter(|(k, v)| b.get(*k) != Some(v))
                    .map(|(k, v)| {
                        format!("{k} was {v}, now {}", b.get(k).cloned().unwrap_or_default())
                    })
                    .collect(),
                _ => vec!["settings".to_owned()],
            };
            fields.join("; ")
        } else if self.shard != now.shard {
            format!(
                "shard was {}, now {}",
                shard_text(self.shard),
                shard_text(now.shard)
            )
        } else if self.sessions != now.sessions {
            "the plan's sessions differ (the spec's sources changed?)".to_owned()
        } else {
            return Ok(());
        };
        Err(GenerateError::OtherJob {
            dir: dir.to_path_buf(),
            what,
        })
    }
}

/// `K/N`, or `none` for a whole dataset.
pub(crate) fn shard_text(shard: Option<Shard>) -> String {
    shard.map_or_else(|| "none".to_owned(), |s| s.to_string())
}

/// The journal's path in `dir`.
#[must_use]
pub fn journal_path(dir: &Path) -> PathBuf {
    dir.join(JOURNAL_FILE)
}
