//! `manifest.jsonl`: the journal of complete clips, one JSON line each, appended (and synced)
//! only after the clip's file was checked, synced and renamed into place.
//!
//! A crash can leave at most a torn last line; [`Manifest::open`] drops it (and truncates the
//! file back to the last complete line) so the next append starts on a fresh line. A clip
//! listed twice (re-cut with `--force`) counts once, its last line winning.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{Read, Write};
use std::path::{Path, PathBuf};

use super::{ClipRecord, TrimError};

/// The journal, open for appending.
#[derive(Debug)]
pub struct Manifest {
    path: PathBuf,
    file: File,
    records: BTreeMap<String, ClipRecord>,
}

impl Manifest {
    /// File name inside the dataset folder.
    pub const FILE_NAME: &'static str = "manifest.jsonl";

    /// Opens (or creates) `dir/manifest.jsonl` and reads every complete line.
    ///
    /// # Errors
    /// [`TrimError::Io`]; [`TrimError::Corrupt`] for a complete line that is not a clip record.
    pub fn open(dir: &Path) -> Result<Manifest, TrimError> {
        let path = dir.join(Self::FILE_NAME);
        let io = |action: &'static str| TrimError::io(action, &path);
        let mut file = OpenOptions::new()
            .read(true)
            .append(true)
            .create(true)
            .open(&path)
            .map_err(io("open"))?;
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes).map_err(io("read"))?;
        let complete = bytes.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
        if complete < bytes.len() {
            tracing::warn!(
                path = %path.display(),
                bytes = bytes.len() - complete,
                "dropping a torn last line (an earlier run was interrupted)"
            );
            file.set_len(complete as u64).map_err(io("truncate"))?;
        }
        let mut records = BTreeMap::new();
        for (i, line) in bytes[..complete].split(|&b| b == b'\n').enumerate() {
            if line.iter().all(u8::is_ascii_whitespace) {
                continue;
            }
            let r: ClipRecord =
                serde_json::from_slice(line).map_err(|source| TrimError::Corrupt {
                    path: path.clone(),
                    line: i + 1,
                    source,
                })?;
            records.insert(r.clip_id.clone(), r);
        }
        Ok(Manifest {
            path,
            file,
            records,
        })
    }

    /// The clips recorded, by clip id.
    #[must_use]
    pub fn records(&self) -> &BTreeMap<String, ClipRecord> {
        &self.records
    }

    /// Removes the clips `ids` from the journal: the file is rewritten with the others (atomic:
    /// the old journal or the new one, never half), then appended to as before.
    ///
    /// # Errors
    /// [`TrimError::Io`], [`TrimError::Json`].
    pub fn forget<'a>(&mut self, ids: impl IntoIterator<Item = &'a str>) -> Result<(), TrimError> {
        for id in ids {
            self.records.remove(id);
        }
        let mut text = Vec::new();
        for r in self.records.values() {
            text.extend(serde_json::to_vec(r).map_err(TrimError::json(&self.path))?);
            text.push(b'\n');
        }
        crate::atomic_file::write(&self.path, &text)
            .map_err(TrimError::io("rewrite", &self.path))?;
        self.file = OpenOptions::new()
            .append(true)
            .open(&self.path)
            .map_err(TrimError::io("open", &self.path))?;
        Ok(())
    }

    /// Appends `record` as one line, synced to disk before returning.
    ///
    /// # Errors
    /// [`TrimError::Io`] (e.g. a full disk; the line is then torn at worst, and dropped on the
    /// next open).
    pub fn append(&mut self, record: ClipRecord) -> Result<(), TrimError> {
        let mut line = serde_json::to_vec(&record).map_err(TrimError::json(&self.path))?;
        line.push(b'\n');
        self.file
            .write_all(&line)
            .map_err(TrimError::io("append to", &self.path))?;
        self.file
            .sync_data()
            .map_err(TrimError::io("append to", &self.path))?;
        self.records.insert(record.clip_id.clone(), record);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::Manifest;
    use crate::trim::split::tests::record;

    #[test]
    fn a_torn_last_line_is_dropped_and_appends_start_fresh() {
        let dir = tempfile::tempdir().unwrap();
        let mut m = Manifest::open(dir.path()).unwrap();
        m.append(record("a", "x", "x0", "CLEAR")).unwrap();
        m.append(record("b", "x", "x1", "CLEAR")).unwrap();
        drop(m);
        let path = dir.path().join(Manifest::FILE_NAME);
        let mut text = std::fs::read_to_string(&path).unwrap();
        text.push_str("{\"clip_id\":\"c\",\"vid");
        std::fs::write(&path, &text).unwrap();
        let mut m = Manifest::open(dir.path()).unwrap();
        assert_eq!(m.records().keys().collect::<Vec<_>>(), ["a", "b"]);
        m.append(record("a", "x", "x0", "RAIN")).unwrap();
        drop(m);
        let m = Manifest::open(dir.path()).unwrap();
        assert_eq!(m.records().len(), 2);
        assert_eq!(m.records()["a"].weather, "RAIN", "the last line wins");
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.lines().count(), 3);
        assert!(text.ends_with('\n'));
    }

    #[test]
    fn a_bad_complete_line_is_an_error_naming_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(Manifest::FILE_NAME), "{}\n").unwrap();
        let err = Manifest::open(dir.path()).unwrap_err().to_string();
        assert!(
            err.contains("manifest.jsonl") && err.contains("line 1"),
            "{err}"
        );
    }
}
