//! `autoact recover`: rewrite a bag that was cut off (a crash, `kill -9`, power loss) or damaged
//! into a complete one — every message of every readable chunk, with its schema, channel and
//! times, the metadata records, and a fresh summary and index.

use std::collections::BTreeMap;
use std::path::PathBuf;

use anyhow::{Context, Result, bail};

use super::{Outcome, print_stdout};
use crate::file_name;
use crate::mcap_io::{BagReader, BagWriter, Compression, WriteConfig};

/// Arguments of `autoact recover`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The damaged or unfinished `.mcap`.
    pub input: PathBuf,
    /// Where to write the recovered bag.
    #[arg(short, long, value_name = "PATH")]
    pub output: PathBuf,
    /// Replace the output if it exists.
    #[arg(long)]
    pub force: bool,
    /// Chunk compression of the output.
    #[arg(long, value_enum, default_value_t = Compression::Zstd)]
    pub compression: Compression,
}

/// Runs `autoact recover`.
///
/// # Errors
/// An unreadable input, an output that exists (without `--force`) or cannot be written.
pub fn run(args: Args) -> Result<Outcome> {
    let Args {
        input,
        output,
        force,
        compression,
    } = args;
    if output.exists() && !force {
        bail!("{} exists: give --force to replace it", output.display());
    }
    if output == input {
        bail!("the output must not be the input ({})", input.display());
    }
    let reader = BagReader::open(&input)?;
    let complete = reader.time_range().is_some();
    let mut writer = BagWriter::create(
        &output,
        WriteConfig {
            compression,
            ..WriteConfig::default()
        },
    )?;
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
    let stats = writer
        .finish()
        .with_context(|| format!("finishing {}", output.display()))?;
    let kept: BTreeMap<&String, u64> = stats.topics.iter().map(|(t, (_, n))| (t, *n)).collect();
    let mut text = format!(
        "wrote {}: {} messages kept from {}\n",
        output.display(),
        stats.message_count(),
        file_name(&input)
    );
    for (topic, n) in &kept {
        text.push_str(&format!("  {topic}: {n}\n"));
    }
    print_stdout(&text)?;
    for issue in &issues {
        tracing::warn!("{issue}");
    }
    if without_schema > 0 {
        tracing::warn!("{without_schema} messages on channels without a schema were left out");
    }
    if !complete {
        tracing::warn!(
            "{} was not finished (no summary): whatever was after its last complete chunk is lost",
            input.display()
        );
    }
    Ok(if issues.is_empty() && complete && without_schema == 0 {
        Outcome::Success
    } else {
        Outcome::DataLost
    })
}
