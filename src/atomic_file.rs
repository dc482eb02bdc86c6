//! How outputs appear only when complete: every file autoact writes that a reader could mistake
//! for finished (videos, clips, PNGs, render bags, exports, annotation lists, folders of frames)
//! is written under a hidden temporary sibling, `.<name>.part`, synced, and renamed into place
//! when complete. An interrupted or failed run leaves at most a `.part` file, never a
//! complete-looking one. The one place that knows the convention.

use std::ffi::OsString;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// An output that is its input: writing it would destroy the data being read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "the output `{}` is the input `{}` (the same file): writing it would destroy the input; choose another output",
    output.display(),
    input.display()
)]
pub struct OutputIsInput {
    /// The input, as given.
    pub input: PathBuf,
    /// The output, as given.
    pub output: PathBuf,
}

/// Refuses an `output` that is the `input` file or folder itself — by identity (device and
/// inode), so `./a.mcap`, `dir/../a.mcap` and a symbolic link to it are caught, not only the
/// same spelling. An output that does not exist yet is never the input.
///
/// # Errors
/// [`OutputIsInput`] naming both.
pub fn refuse_input_as_output(input: &Path, output: &Path) -> Result<(), OutputIsInput> {
    if same_file(input, output) {
        return Err(OutputIsInput {
            input: input.to_path_buf(),
            output: output.to_path_buf(),
        });
    }
    Ok(())
}

/// Whether both paths exist and name the same file or folder (on Unix by device and inode,
/// elsewhere by their canonical paths).
fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        match (std::fs::metadata(a), std::fs::metadata(b)) {
            (Ok(a), Ok(b)) => a.dev() == b.dev() && a.ino() == b.ino(),
            _ => false,
        }
    }
    #[cfg(not(unix))]
    {
        match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        }
    }
}

/// The temporary sibling `dir/.<name>.part` of `dir/<name>`; `None` when `path` has no file name.
#[must_use]
pub fn temporary_sibling(path: &Path) -> Option<PathBuf> {
    let name = path.file_name()?;
    let mut part = OsString::from(".");
    part.push(name);
    part.push(".part");
    Some(path.with_file_name(part))
}

/// A temporary sibling being filled by a writer (a bag writer, an encoder): removed when dropped
/// unless [`Part::commit`] put it in place, so a run that fails or is interrupted by an error
/// leaves neither a truncated file under the final name nor a stray `.part`.
#[derive(Debug)]
pub struct Part {
    /// The temporary sibling being written.
    temporary: PathBuf,
    /// Where it goes when complete.
    target: PathBuf,
    committed: bool,
}

impl Part {
    /// The part for `path` (see [`temporary_sibling`]); a stale part from an earlier run is
    /// removed. `None` when `path` has no file name.
    #[must_use]
    pub fn new(path: &Path) -> Option<Part> {
        let temporary = temporary_sibling(path)?;
        remove_any(&temporary);
        Some(Part {
            temporary,
            target: path.to_path_buf(),
            committed: false,
        })
    }

    /// Where the writer writes.
    #[must_use]
    pub fn temporary(&self) -> &Path {
        &self.temporary
    }

    /// Syncs the part (a file, or a folder and every file in it) and renames it over the final
    /// path, replacing what is there.
    ///
    /// # Errors
    /// The I/O error of the sync or the rename; the part is then removed.
    pub fn commit(mut self) -> std::io::Result<()> {
        if self.temporary.is_dir() {
            sync_folder(&self.temporary)?;
            commit_folder(&self.temporary, &self.target)?;
        } else {
            commit(&self.temporary, &self.target)?;
        }
        self.committed = true;
        Ok(())
    }
}

impl Drop for Part {
    fn drop(&mut self) {
        if !self.committed {
            remove_any(&self.temporary);
        }
    }
}

/// A file written as a stream, piece by piece, into its temporary sibling through a buffer, and
/// put in place by [`StreamedFile::commit`]: what [`write`] does for a file too large to hold
/// in memory whole. Dropped without a commit (an error, a panic), the `.part` is removed and
/// the file already at the path is left as it was. For regular files only (a device or a pipe
/// is never renamed over: use [`write`]).
#[derive(Debug)]
pub struct StreamedFile {
    /// The buffered writer into the part; declared before `part` so that it is dropped (and its
    /// file closed) before the part is removed.
    writer: BufWriter<std::fs::File>,
    part: Part,
}

impl StreamedFile {
    /// Starts writing `path` (a stale `.part` from an earlier run is replaced).
    ///
    /// # Errors
    /// The I/O error of creating the part, or [`std::io::ErrorKind::InvalidInput`] when `path`
    /// has no file name.
    pub fn create(path: &Path) -> std::io::Result<StreamedFile> {
        let part = Part::new(path).ok_or_else(no_file_name)?;
        let file = std::fs::File::create(part.temporary())?;
        Ok(StreamedFile {
            writer: BufWriter::new(file),
            part,
        })
    }

    /// Where the file goes when complete.
    #[must_use]
    pub fn target(&self) -> &Path {
        &self.part.target
    }

    /// Flushes the buffer, syncs the part and renames it over the final path.
    ///
    /// # Errors
    /// The I/O error of the flush, the sync or the rename; the part is then removed and the
    /// final path left as it was.
    pub fn commit(self) -> std::io::Result<()> {
        let StreamedFile { writer, part } = self;
        let file = writer
            .into_inner()
            .map_err(std::io::IntoInnerError::into_error)?;
        drop(file);
        part.commit()
    }
}

impl Write for StreamedFile {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.writer.write(buf)
    }

    fn write_all(&mut self, buf: &[u8]) -> std::io::Result<()> {
        self.writer.write_all(buf)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.writer.flush()
    }
}

/// The error of a path without a file name, which has no temporary sibling.
fn no_file_name() -> std::io::Error {
    std::io::Error::new(std::io::ErrorKind::InvalidInput, "not a file name")
}

/// Removes a file or a folder if it is there (best effort: it is only ever a `.part`).
fn remove_any(path: &Path) {
    if path.is_dir() {
        let _ = std::fs::remove_dir_all(path);
    } else {
        let _ = std::fs::remove_file(path);
    }
}

/// Where scratch files for making `output` go (the keys of DSI clips, say): the output's folder,
/// so that a long job costs space where its output goes, or the system's temporary folder for
/// an output that is a device or a pipe ([`is_special`]).
#[must_use]
pub fn scratch_dir(output: &Path) -> std::path::PathBuf {
    if is_special(output) {
        return std::env::temp_dir();
    }
    match output.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    }
}

/// Whether `path` exists and is neither a regular file nor a folder (`/dev/null`, a FIFO, a
/// terminal): such an output is written in place, never renamed over.
#[must_use]
pub fn is_special(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// Puts a complete temporary sibling that something else wrote (ffmpeg, an encoder, a bag
/// writer) in place: synced to disk, then renamed over `path`. Callers remove `part` if this
/// fails.
///
/// # Errors
/// The I/O error of the sync or the rename.
pub fn commit(part: &Path, path: &Path) -> std::io::Result<()> {
    std::fs::File::open(part)?.sync_all()?;
    std::fs::rename(part, path)
}

/// Syncs every file in the temporary sibling folder `part` that something else filled (ffmpeg's
/// frames) and returns how many there are; [`commit_folder`] then puts it in place. A folder,
/// like a file, appears only once what it holds is on disk.
///
/// # Errors
/// The I/O error of listing the folder or syncing a file in it.
pub fn sync_folder(part: &Path) -> std::io::Result<u64> {
    let mut files = 0;
    for entry in std::fs::read_dir(part)? {
        std::fs::File::open(entry?.path())?.sync_all()?;
        files += 1;
    }
    Ok(files)
}

/// Puts the synced folder `part` (see [`sync_folder`]) in place as `path`, replacing a folder
/// there. Callers remove `part` if this fails.
///
/// # Errors
/// The I/O error of removing the old folder or of the rename.
pub fn commit_folder(part: &Path, path: &Path) -> std::io::Result<()> {
    if path.exists() {
        std::fs::remove_dir_all(path)?;
    }
    std::fs::rename(part, path)
}

/// Gives `to` the contents of `from` by a hard link, or by a copy where a link cannot be made
/// (another file system): what the dataset's per-clip files of one render or one part are.
///
/// # Errors
/// The I/O error of the copy.
pub fn link_or_copy(from: &Path, to: &Path) -> std::io::Result<()> {
    if std::fs::hard_link(from, to).is_err() {
        std::fs::copy(from, to)?;
    }
    Ok(())
}

/// Writes `bytes` to `path` through its [`temporary_sibling`], synced, then renamed over `path`
/// (a device or a pipe, see [`is_special`], is written in place).
///
/// # Errors
/// The I/O error (the temporary file is removed and `path` left as it was); callers name `path`.
pub fn write(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    if is_special(path) {
        return write_in_place(path, bytes);
    }
    write_through_sibling(path, bytes, |part| std::fs::rename(part, path))
}

/// As [`write`], but never replaces a file: if `path` exists when the new one is complete
/// (another process made it meanwhile), the error is [`std::io::ErrorKind::AlreadyExists`] and
/// `path` is untouched. The new file appears by a hard link, which fails rather than replaces.
///
/// # Errors
/// As [`write`], or `AlreadyExists`.
pub fn write_new(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    write_through_sibling(path, bytes, |part| {
        std::fs::hard_link(part, path)?;
        std::fs::remove_file(part)
    })
}

/// Writes into a device or a pipe (`/dev/null`, `/dev/stdout`), which is never renamed over.
fn write_in_place(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut file = std::fs::OpenOptions::new().write(true).open(path)?;
    file.write_all(bytes)?;
    file.flush()
}

fn write_through_sibling(
    path: &Path,
    bytes: &[u8],
    commit: impl FnOnce(&Path) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let part = temporary_sibling(path).ok_or_else(no_file_name)?;
    let result = (|| {
        let mut file = std::fs::File::create(&part)?;
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        commit(&part)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&part);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_through_a_hidden_sibling_and_leaves_nothing_on_failure() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.csv");
        assert_eq!(
            temporary_sibling(&path).unwrap(),
            dir.path().join(".a.csv.part")
        );
        write(&path, b"one").unwrap();
        write(&path, b"two").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        let missing = dir.path().join("no/such/dir/b.csv");
        assert!(write(&missing, b"x").is_err());
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "only a.csv: no temporary file left");
        assert!(temporary_sibling(Path::new("/")).is_none());
        let e = write_new(&path, b"three").unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::AlreadyExists);
        assert_eq!(std::fs::read(&path).unwrap(), b"two");
        write_new(&dir.path().join("c.csv"), b"new").unwrap();
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    #[test]
    fn a_streamed_file_appears_on_commit_and_a_dropped_one_leaves_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.json");
        let mut f = StreamedFile::create(&path).unwrap();
        assert_eq!(f.target(), path);
        f.write_all(b"one, ").unwrap();
        f.write_all(b"two").unwrap();
        assert!(
            !path.exists(),
            "nothing under the final name before the commit"
        );
        f.commit().unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"one, two");

        let mut f = StreamedFile::create(&path).unwrap();
        f.write_all(&vec![b'x'; 100_000]).unwrap();
        assert!(temporary_sibling(&path).unwrap().exists());
        drop(f);
        assert_eq!(std::fs::read(&path).unwrap(), b"one, two", "the old file");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1, "no .part left: {names:?}");
        let missing = dir.path().join("no/such/dir/b.json");
        assert!(StreamedFile::create(&missing).is_err());
        assert!(StreamedFile::create(Path::new("/")).is_err());
    }
}
