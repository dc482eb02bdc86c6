//! Where and how a command writes its bag: a bare `.mcap`, or a rosbag2 directory
//! (`metadata.yaml` + one `.mcap`), and optionally the interop journal beside it.

use std::path::PathBuf;

use crate::mcap_io::{BagStats, BagWriter, Compression, FileSink, McapIoError, WriteConfig};

/// Where and how to write a bag.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OutputOptions {
    /// The `.mcap` file, or the directory with `rosbag2`.
    pub path: PathBuf,
    /// Chunk compression.
    pub compression: Compression,
    /// Write a rosbag2 directory (`metadata.yaml` + `<dir name>_0.mcap`) instead of a bare file.
    pub rosbag2: bool,
    /// Also write the journal: every message as autoact meant it, as `<output>.expected.json`
    /// (for the interoperability checks in `tools/interop`).
    pub journal: bool,
}

/// Why an output bag could not be written.
#[derive(Debug, thiserror::Error)]
pub enum BagOutputError {
    /// The rosbag2 directory could not be created.
    #[error("cannot create the rosbag2 directory {path}")]
    CreateDirectory {
        /// The directory.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Writing the bag, its journal or `metadata.yaml` failed.
    #[error(transparent)]
    Write(#[from] McapIoError),
}

/// An open output bag and how to finish it.
pub struct BagOutput {
    /// The bag being written.
    pub writer: BagWriter<FileSink>,
    mcap_path: PathBuf,
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
    /// Creates the output (and the rosbag2 directory if asked).
    ///
    /// # Errors
    /// [`BagOutputError`] when the directory or the file cannot be created.
    pub fn create(options: &OutputOptions) -> Result<BagOutput, BagOutputError> {
        let mcap_path = if options.rosbag2 {
            std::fs::create_dir_all(&options.path).map_err(|source| {
                BagOutputError::CreateDirectory {
                    path: options.path.clone(),
                    source,
                }
            })?;
            let name = options
                .path
                .file_name()
                .map_or_else(|| "bag".to_string(), |n| n.to_string_lossy().into_owned());
            options.path.join(format!("{name}_0.mcap"))
        } else {
            options.path.clone()
        };
        let mut writer = BagWriter::create(
            &mcap_path,
            WriteConfig {
                compression: options.compression,
                ..WriteConfig::default()
            },
        )?;
        if options.journal {
            writer.keep_journal();
        }
        Ok(BagOutput {
            writer,
            mcap_path,
            options: options.clone(),
        })
    }

    /// Finishes the file (and `metadata.yaml`, and the journal); returns what was written.
    ///
    /// # Errors
    /// [`BagOutputError::Write`] when the file, the journal or `metadata.yaml` cannot be written.
    pub fn finish(self) -> Result<BagStats, BagOutputError> {
        let BagOutput {
            writer,
            mcap_path,
            options,
        } = self;
        let stats = if options.journal {
            writer.finish_with_journal(&journal_path(&options))?
        } else {
            writer.finish()?
        };
        if options.rosbag2 {
            let name = mcap_path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            crate::mcap_io::write_rosbag2_metadata(&options.path, &[(name, stats.clone())])?;
        }
        Ok(stats)
    }
}

/// The interop contract: `X.mcap` ↔ `X.expected.json`, directory `D` ↔ `D.expected.json`.
fn journal_path(options: &OutputOptions) -> PathBuf {
    if options.rosbag2 {
        let mut p = options.path.clone().into_os_string();
        p.push(".expected.json");
        PathBuf::from(p)
    } else {
        options.path.with_extension("expected.json")
    }
}
