//! Recovering a bag that was cut off (a crash, `kill -9`, power loss) or damaged: every message
//! of every readable chunk, with its schema, channel and times, and the metadata records, are
//! rewritten into a complete file with a fresh summary and index. A rosbag2 folder is recovered
//! into a folder: each of its `.mcap` files under its own name, and a fresh `metadata.yaml`.

use std::path::{Path, PathBuf};

use super::{BagReader, BagStats, BagWriter, Compression, McapIoError, WriteConfig};

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
/// which must not be the input and is replaced only with `force`. A rosbag2 folder `input` is
/// recovered into the folder `output` ([`recover_folder`]).
///
/// # Errors
/// [`RecoverError`]: an output that is the input or exists (without `force`), an input that
/// cannot be opened at all, an output that cannot be written.
pub fn recover(
    input: &Path,
    output: &Path,
    compression: Compression,
    force: bool,
) -> Result<Recovery, RecoverError> {
    crate::atomic_file::refuse_input_as_output(input, output)?;
    if input.is_dir() {
        return recover_folder(input, output, compression, force);
    }
    if output.exists() && !force {
        return Err(RecoverError::OutputExists(output.to_path_buf()));
    }
    recover_file(input, output, compression)
}

/// Recovers every `.mcap` file of the rosbag2 folder `input` into the folder `output` (made if
/// missing; an existing one only with `force`), each under its own name, and writes the folder's
/// `metadata.yaml` from what was recovered.
///
/// # Errors
/// As [`recover`]; [`RecoverError::FolderIntoFile`] when `output` is a file.
pub fn recover_folder(
    input: &Path,
    output: &Path,
    compression: Compression,
    force: bool,
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
    let files = super::mcap_files_in(input)?;
    std::fs::create_dir_all(output).map_err(|source| RecoverError::CreateDir {
        path: output.to_path_buf(),
        source,
    })?;
    let mut all = Recovery {
        output: output.to_path_buf(),
        stats: BagStats::default(),
        issues: Vec::new(),
        without_schema: 0,
        complete: true,
        input: input.to_path_buf(),
        files: Vec::new(),
    };
    let mut written = Vec::new();
    for file in &files {
        let name = crate::file_name(file);
        let one = recover_file(file, &output.join(&name), compression)?;
        for (topic, (type_name, n)) in &one.stats.topics {
            let entry = all.stats.topics.entry(topic.clone());
            entry.or_insert_with(|| (type_name.clone(), 0)).1 += n;
        }
        if let Some((a, b)) = one.stats.time_range {
            let range = all
                .stats
                .time_range
                .map_or((a, b), |(x, y)| (x.min(a), y.max(b)));
            all.stats.time_range = Some(range);
        }
        all.issues.extend(one.issues);
        all.without_schema += one.without_schema;
        all.complete &= one.complete;
        all.files.extend(one.files);
        written.push((name, one.stats));
    }
    super::write_rosbag2_metadata(output, &written)?;
    Ok(all)
}

/// Recovers one file (the checks on `output` done).
fn recover_file(
    input: &Path,
    output: &Path,
    compression: Compression,
) -> Result<Recovery, RecoverError> {
    crate::atomic_file::refuse_input_as_output(input, output)?;
    let reader = BagReader::open(input)?;
    let complete = reader.time_range().is_some();
    let config = WriteConfig {
        compression,
        ..WriteConfig::default()
    };
    let mut writer = BagWriter::create(output, config)?;
    let mut issues = Vec::new();
    let mut without_schema = 0u64;
    for item in reader.messages() {
        let m = match item {
            Ok(m) => m,
            Err(issue) => {
                issues.push(issue.to_string());
                continue;
            }
        };
        let Some(schema) = &m.channel.schema else {
            without_schema += 1;
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
    let stats = writer.finish().map_err(|source| RecoverError::Finish {
        path: output.to_path_buf(),
        source,
    })?;
    Ok(Recovery {
        output: output.to_path_buf(),
        stats,
        issues,
        without_schema,
        complete,
        input: input.to_path_buf(),
        files: vec![output.to_path_buf()],
    })
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
