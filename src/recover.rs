//! Recovering a bag that was cut off (a crash, `kill -9`, power loss) or damaged: every message
//! of every readable chunk, with its schema, channel and times, and the metadata records, are
//! rewritten into a complete file with a fresh summary and index. A rosbag2 folder is recovered
//! into a folder: each of its `.mcap` files under its own name, and a fresh `metadata.yaml`.

use std::path::{Path, PathBuf};

use crate::atomic_file::Part;
use crate::bags::output::{BagOutput, BagOutputError, OutputOptions};
use crate::mcap_io::{
    BagReader, BagStats, BagWriter, Compression, FileSink, McapIoError, Rosbag2Version, WriteConfig,
};

/// What a recovery kept and what it could not.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recovery {
    /// The recovered bag.
    pub output: PathBuf,
    /// What was written.
    pub stats: BagStats,
    /// Why parts of the input could not be read.
    pub issues: Vec<String>,
    /// Messages left out because their channel has no schema.
    pub without_schema: u64,
    /// Whether the input was finished (had a summary with statistics). An unfinished input's
    /// loss is among `issues` (the file ends without a summary, or is cut short).
    pub complete: bool,
    /// The damaged bag.
    pub input: PathBuf,
    /// The files written: the output itself, or for a folder each recovered `.mcap` in it.
    pub files: Vec<PathBuf>,
}

/// Why a recovery failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecoverError {
    /// The output exists and replacing it was not asked for.
    #[error("{} exists: give --force to replace it", .0.display())]
    OutputExists(PathBuf),
    /// The output is the input.
    #[error(transparent)]
    OutputIsInput(#[from] crate::atomic_file::OutputIsInput),
    /// The input cannot be opened, or writing the output failed.
    #[error(transparent)]
    Bag(#[from] McapIoError),
    /// A rosbag2 folder given, and a file named as the output.
    #[error(
        "{} is a rosbag2 folder: it is recovered into a folder (each .mcap under its own name, and a fresh metadata.yaml), and {} is a file",
        input.display(),
        output.display()
    )]
    FolderIntoFile {
        /// The folder.
        input: PathBuf,
        /// The file named as output.
        output: PathBuf,
    },
    /// The output folder could not be made.
    #[error("cannot create the output folder {}", path.display())]
    CreateDir {
        /// The folder.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The output bag could not be created or put in place.
    #[error(transparent)]
    Output(Box<BagOutputError>),
    /// The output could not be finished.
    #[error("finishing {}", path.display())]
    Finish {
        /// The output.
        path: PathBuf,
        /// The cause.
        #[source]
        source: McapIoError,
    },
}

/// Rewrites every readable message and metadata record of `input` into a new bag at `output`,
/// which must not be the input and is replaced only with `force`. The output appears only when
/// complete ([`crate::bags::output::BagOutput`]): a failure leaves an existing output as it was.
/// A rosbag2 folder `input` is recovered into the folder `output` ([`recover_folder`]).
///
/// # Errors
/// [`RecoverError`]: an output that is the input or exists (without `force`), an input that
/// cannot be opened at all, an output that cannot be written.
pub fn recover(
    input: &Path,
    output: &Path,
    compression: Compression,
    force: bool,
    rosbag2_version: Rosbag2Version,
) -> Result<Recovery, RecoverError> {
    crate::atomic_file::refuse_input_as_output(input, output)?;
    if input.is_dir() {
        return recover_folder(input, output, compression, force, rosbag2_version);
    }
    let options = OutputOptions {
        path: output.to_path_buf(),
        compression,
        rosbag2: None,
        journal: false,
        force,
    };
    options.refuse_existing().map_err(output_error)?;
    let reader = BagReader::open(input)?;
    let mut out = BagOutput::create(&options).map_err(output_error)?;
    let copied = copy_all(&reader, &mut out.writer)?;
    let stats = out.finish().map_err(output_error)?;
    Ok(copied.into_recovery(input, output, stats, vec![output.to_path_buf()]))
}

/// Recovers every `.mcap` file of the rosbag2 folder `input` into the folder `output` (an
/// existing one replaced only with `force`), each under its own name, and writes the folder's
/// `metadata.yaml` from what was recovered. The folder is written under a temporary name and
/// put in place when complete.
///
/// # Errors
/// As [`recover`]; [`RecoverError::FolderIntoFile`] when `output` is a file.
pub fn recover_folder(
    input: &Path,
    output: &Path,
    compression: Compression,
    force: bool,
    version: Rosbag2Version,
) -> Result<Recovery, RecoverError> {
    crate::atomic_file::refuse_input_as_output(input, output)?;
    if output.exists() && !output.is_dir() {
        return Err(RecoverError::FolderIntoFile {
            input: input.to_path_buf(),
            output: output.to_path_buf(),
        });
    }
    if output.exists() && !force {
        return Err(RecoverError::OutputExists(output.to_path_buf()));
    }
    let files = crate::mcap_io::mcap_files_in(input)?;
    let create_error = |source| RecoverError::CreateDir {
        path: output.to_path_buf(),
        source,
    };
    let part = Part::new(output).ok_or_else(|| {
        create_error(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "not a folder name",
        ))
    })?;
    std::fs::create_dir(part.temporary()).map_err(create_error)?;
    let config = WriteConfig {
        compression,
        ..WriteConfig::default()
    };
    let mut all = Copied::default();
    let mut stats_all = BagStats::default();
    let mut written = Vec::new();
    let mut recovered = Vec::new();
    for file in &files {
        let name = crate::file_name(file);
        let reader = BagReader::open(file)?;
        let shown = output.join(&name);
        let mut writer = BagWriter::create_as(&part.temporary().join(&name), &shown, config)?;
        let one = copy_all(&reader, &mut writer)?;
        let stats = writer.finish().map_err(|source| RecoverError::Finish {
            path: shown.clone(),
            source,
        })?;
        stats_all.merge(&stats);
        all.issues.extend(one.issues);
        all.without_schema += one.without_schema;
        all.complete &= one.complete;
        recovered.push(shown);
        written.push((name, stats));
    }
    crate::mcap_io::write_rosbag2_metadata(part.temporary(), &written, version)?;
    part.commit().map_err(create_error)?;
    Ok(all.into_recovery(input, output, stats_all, recovered))
}

/// What copying one file kept and lost.
#[derive(Debug)]
struct Copied {
    issues: Vec<String>,
    without_schema: u64,
    complete: bool,
}

impl Default for Copied {
    fn default() -> Self {
        Copied {
            issues: Vec::new(),
            without_schema: 0,
            complete: true,
        }
    }
}

impl Copied {
    fn into_recovery(
        self,
        input: &Path,
        output: &Path,
        stats: BagStats,
        files: Vec<PathBuf>,
    ) -> Recovery {
        Recovery {
            output: output.to_path_buf(),
            stats,
            issues: self.issues,
            without_schema: self.without_schema,
            complete: self.complete,
            input: input.to_path_buf(),
            files,
        }
    }
}

/// Copies every readable message and metadata record of `reader` into `writer`.
fn copy_all(reader: &BagReader, writer: &mut BagWriter<FileSink>) -> Result<Copied, McapIoError> {
    let mut copied = Copied {
        complete: reader.time_range().is_some(),
        ..Copied::default()
    };
    for item in reader.messages() {
        let m = match item {
            Ok(m) => m,
            Err(issue) => {
                copied.issues.push(issue.to_string());
                continue;
            }
        };
        let Some(schema) = &m.channel.schema else {
            copied.without_schema += 1;
            continue;
        };
        writer.write_raw(
            &m.channel.topic,
            &schema.name,
            || String::from_utf8_lossy(&schema.data).into_owned(),
            m.log_time,
            m.publish_time,
            &m.data,
        )?;
    }
    for (name, record) in reader.metadata() {
        writer.write_metadata(&name, record)?;
    }
    Ok(copied)
}

/// A bag output's refusal or failure, as a recovery error.
fn output_error(e: BagOutputError) -> RecoverError {
    match e {
        BagOutputError::Exists { path } => RecoverError::OutputExists(path),
        BagOutputError::Write(e) => RecoverError::Bag(e),
        other => RecoverError::Output(Box::new(other)),
    }
}

impl Recovery {
    /// What was kept: the total, then messages per topic.
    #[must_use]
    pub fn report(&self) -> String {
        let mut text = format!(
            "wrote {}: {} messages kept from {}\n",
            self.output.display(),
            self.stats.message_count(),
            crate::file_name(&self.input)
        );
        if self.files.len() > 1 || self.files.first() != Some(&self.output) {
            let names: Vec<String> = self.files.iter().map(|f| crate::file_name(f)).collect();
            text.push_str(&format!("  files: {}, metadata.yaml\n", names.join(", ")));
        }
        for (topic, (_, n)) in &self.stats.topics {
            text.push_str(&format!("  {topic}: {n}\n"));
        }
        text
    }

    /// What was lost, one warning each.
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        let mut out = self.issues.clone();
        if self.without_schema > 0 {
            out.push(format!(
                "{} messages on channels without a schema were left out",
                self.without_schema
            ));
        }
        out
    }
}

impl crate::outcome::LostInput for Recovery {
    /// Whether anything was lost: exit code 3.
    fn lost_input(&self) -> bool {
        !(self.issues.is_empty() && self.without_schema == 0)
    }
}
