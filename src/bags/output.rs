//! Where and how a command writes its bag: a bare `.mcap`, or a rosbag2 directory
//! (`metadata.yaml` + one `.mcap`), and optionally the interop journal beside it.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::atomic_file::Part;

use crate::mcap_io::{
    BagStats, BagWriter, Compression, FileSink, McapIoError, Rosbag2Version, WriteConfig,
};

/// Where and how to write a bag.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputOptions {
    /// The `.mcap` file, or the directory with `rosbag2`.
    pub path: PathBuf,
    /// Chunk compression.
    pub compression: Compression,
    /// Write a rosbag2 directory (`metadata.yaml` in this format version + `<dir name>_0.mcap`)
    /// instead of a bare file.
    pub rosbag2: Option<Rosbag2Version>,
    /// Also write the journal: every message as autoact meant it, as `<output>.expected.json`
    /// (for the interoperability checks in `tools/interop`).
    pub journal: bool,
    /// Replace an output that exists (else it is refused before anything is read).
    pub force: bool,
}

impl OutputOptions {
    /// Refuses an output that exists, unless `force` (a device or a pipe such as `/dev/null` is
    /// always fine), and a rosbag2 directory onto a device. Commands call it before reading
    /// anything, so a refused run costs nothing; [`BagOutput::create`] calls it again.
    ///
    /// # Errors
    /// [`BagOutputError::Exists`] or [`BagOutputError::SpecialRosbag2`].
    pub fn refuse_existing(&self) -> Result<(), BagOutputError> {
        let path = &self.path;
        if crate::atomic_file::is_special(path) {
            if self.rosbag2.is_some() {
                return Err(BagOutputError::SpecialRosbag2 { path: path.clone() });
            }
        } else if !self.force && std::fs::symlink_metadata(path).is_ok() {
            return Err(BagOutputError::Exists { path: path.clone() });
        }
        Ok(())
    }
}

/// Why an output bag could not be written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BagOutputError {
    /// The output exists and `force` was not given.
    #[error("{} exists; pass --force to replace it", path.display())]
    Exists {
        /// The output.
        path: PathBuf,
    },
    /// The output has no file name (`..`, `/`).
    #[error("{} cannot be an output: it names no file", path.display())]
    NoFileName {
        /// The output.
        path: PathBuf,
    },
    /// A rosbag2 directory cannot be written onto a device or a pipe.
    #[error("{} is not a regular file or folder: a rosbag2 directory cannot be written there", path.display())]
    SpecialRosbag2 {
        /// The output.
        path: PathBuf,
    },
    /// The rosbag2 directory could not be created.
    #[error("cannot create the rosbag2 directory {path}")]
    CreateDirectory {
        /// The directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The complete bag could not be put in place (synced and renamed, or copied to a device).
    #[error("cannot put the finished bag in place as {}", path.display())]
    Commit {
        /// The output.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Writing the bag, its journal or `metadata.yaml` failed.
    #[error(transparent)]
    Write(#[from] McapIoError),
}

/// An open output bag and how to finish it. The bag is written under a hidden temporary sibling
/// (`.<name>.part`, see [`crate::atomic_file`]) and renamed into place by [`BagOutput::finish`],
/// so a failure (a full disk, an error, a dropped output) never leaves a truncated file under
/// the final name and never touches an existing output. An output that is a device or a pipe
/// (`-o /dev/null`) is spooled to a temporary file and copied there when complete.
pub struct BagOutput {
    /// The bag being written.
    pub writer: BagWriter<FileSink>,
    /// The `.mcap` file being written (inside the part folder with `rosbag2`).
    mcap_path: PathBuf,
    part: Part,
    /// Where the spooled bag is copied to, for an output that is a device or a pipe.
    special: Option<PathBuf>,
    options: OutputOptions,
}

impl std::fmt::Debug for BagOutput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagOutput")
            .field("mcap_path", &self.mcap_path)
            .field("options", &self.options)
            .finish_non_exhaustive()
    }
}

impl BagOutput {
    /// Refuses an output that exists (without `force`), then creates the bag under its
    /// temporary name (and the rosbag2 directory if asked).
    ///
    /// # Errors
    /// [`BagOutputError`] when the output exists, or the directory or the file cannot be created.
    pub fn create(options: &OutputOptions) -> Result<BagOutput, BagOutputError> {
        options.refuse_existing()?;
        let path = &options.path;
        let special = crate::atomic_file::is_special(path);
        let no_name = || BagOutputError::NoFileName { path: path.clone() };
        let part = if special {
            Part::new(&spool_path(path)).ok_or_else(no_name)?
        } else {
            Part::new(path).ok_or_else(no_name)?
        };
        // The file being written, and the name errors give it: the output it becomes.
        let (mcap_path, shown) = if options.rosbag2.is_some() {
            std::fs::create_dir(part.temporary()).map_err(|source| {
                BagOutputError::CreateDirectory {
                    path: path.clone(),
                    source,
                }
            })?;
            let name = path.file_name().ok_or_else(no_name)?.to_string_lossy();
            let file = format!("{name}_0.mcap");
            (part.temporary().join(&file), path.join(file))
        } else {
            (part.temporary().to_path_buf(), path.clone())
        };
        let mut writer = BagWriter::create_as(
            &mcap_path,
            &shown,
            WriteConfig {
                compression: options.compression,
                // The commands writing a `BagOutput` (convert, import, one file's recover) produce on one
                // thread; with a second core the compression and writing run beside it.
                writer_thread: std::thread::available_parallelism().is_ok_and(|n| n.get() > 1),
                ..WriteConfig::default()
            },
        )?;
        if options.journal {
            writer.keep_journal();
        }
        Ok(BagOutput {
            writer,
            mcap_path,
            part,
            special: special.then(|| path.clone()),
            options: options.clone(),
        })
    }

    /// Finishes the file (and `metadata.yaml`, and the journal), syncs it and puts it in place;
    /// returns what was written.
    ///
    /// # Errors
    /// [`BagOutputError::Write`] when the file, the journal or `metadata.yaml` cannot be written,
    /// [`BagOutputError::Commit`] when it cannot be put in place. Either way no output appears.
    pub fn finish(self) -> Result<BagStats, BagOutputError> {
        let BagOutput {
            writer,
            mcap_path,
            part,
            special,
            options,
        } = self;
        let stats = if options.journal {
            writer.finish_with_journal(&journal_path(&options))?
        } else {
            writer.finish()?
        };
        if let Some(version) = options.rosbag2 {
            let name = mcap_path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            let files = [(name, stats.clone())];
            crate::mcap_io::write_rosbag2_metadata(part.temporary(), &files, version)?;
        }
        let commit_error = |source| BagOutputError::Commit {
            path: options.path.clone(),
            source,
        };
        match special {
            // The spool is removed when `part` drops.
            Some(device) => copy_into(part.temporary(), &device).map_err(commit_error)?,
            None => part.commit().map_err(commit_error)?,
        }
        Ok(stats)
    }
}

/// A fresh name for spooling a bag bound for the device or pipe `device`, where its scratch
/// files go ([`crate::atomic_file::scratch_dir`]: the temporary folder).
fn spool_path(device: &Path) -> PathBuf {
    static COUNT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    crate::atomic_file::scratch_dir(device).join(format!("autoact-{}-{n}.mcap", std::process::id()))
}

/// Copies the complete spooled bag into a device or a pipe.
fn copy_into(spool: &Path, device: &Path) -> std::io::Result<()> {
    let mut from = std::fs::File::open(spool)?;
    let mut to = std::fs::OpenOptions::new().write(true).open(device)?;
    std::io::copy(&mut from, &mut to)?;
    to.flush()
}

/// The interop contract: `X.mcap` ↔ `X.expected.json`, directory `D` ↔ `D.expected.json`.
fn journal_path(options: &OutputOptions) -> PathBuf {
    if options.rosbag2.is_some() {
        let mut p = options.path.clone().into_os_string();
        p.push(".expected.json");
        PathBuf::from(p)
    } else {
        options.path.with_extension("expected.json")
    }
}
