//! Recovering a bag that was cut off (a crash, `kill -9`, power loss) or damaged: every message
//! of every readable chunk, with its schema, channel and times, and the metadata records, are
//! rewritten into a complete file with a fresh summary and index.

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
/// which must not be the input and is replaced only with `force`.
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
    if output.exists() && !force {
        return Err(RecoverError::OutputExists(output.to_path_buf()));
    }
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
