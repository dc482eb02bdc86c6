//! `autoact record`: live ROS 2 topics (DDS, no ROS installation needed) into MCAP — the same
//! bags `import` writes, so `convert` takes them as they are.

use std::collections::BTreeSet;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use anyhow::{Context, Result, bail};
use regex::Regex;

use super::{Outcome, print_stdout};
use crate::mcap_io::{Compression, WriteConfig};
use crate::record::dds::{DdsConfig, Durability, Recorder, Reliability, parse_domain_id};
use crate::record::session::{Output, Received, RecordWriter, SplitPolicy};
use crate::ros;

/// Reader reliability on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReliabilityArg {
    /// Lost samples are resent (matches reliable publishers, the ROS 2 default).
    Reliable,
    /// No resends (matches every publisher, e.g. sensor-data QoS).
    BestEffort,
}

/// Reader durability on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum DurabilityArg {
    /// Only what is published after the match.
    Volatile,
    /// Also a transient-local publisher's retained history.
    TransientLocal,
}

/// Arguments of `autoact record`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// ROS topics to record (e.g. `/skeleton`); see also --all, --include.
    pub topics: Vec<String>,
    /// Record every topic of a type autoact knows, as they are discovered.
    #[arg(long)]
    pub all: bool,
    /// Also record discovered topics matching this regular expression.
    #[arg(long, value_name = "REGEX")]
    pub include: Option<String>,
    /// Never record topics matching this regular expression.
    #[arg(long, value_name = "REGEX")]
    pub exclude: Option<String>,
    /// DDS domain [default: $ROS_DOMAIN_ID, or 0].
    #[arg(long, value_name = "ID")]
    pub domain_id: Option<u16>,
    /// Reader reliability.
    #[arg(long, value_enum, default_value_t = ReliabilityArg::Reliable)]
    pub reliability: ReliabilityArg,
    /// Reader durability.
    #[arg(long, value_enum, default_value_t = DurabilityArg::Volatile)]
    pub durability: DurabilityArg,
    /// Keep-last history depth per topic.
    #[arg(long, default_value_t = 100)]
    pub depth: i32,
    /// Output: a `.mcap` file (splits go beside it as `<stem>_1.mcap`, `<stem>_2.mcap`, …), or
    /// a rosbag2 directory (any other path: `<dir>/<dir>_0.mcap`, … and `metadata.yaml`, which
    /// `ros2 bag play` and `autoact convert` open).
    #[arg(short, long, value_name = "FILE.mcap|DIR")]
    pub output: PathBuf,
    /// Replace an existing output.
    #[arg(long)]
    pub force: bool,
    /// Chunk compression.
    #[arg(long, value_enum, default_value_t = Compression::Zstd)]
    pub compression: Compression,
    /// Start a new file after this many megabytes of messages.
    #[arg(long, value_name = "MB")]
    pub split_size: Option<u64>,
    /// Start a new file after this many seconds.
    #[arg(long, value_name = "S")]
    pub split_duration: Option<f64>,
    /// Stop after this many seconds.
    #[arg(long, value_name = "S")]
    pub max_duration: Option<f64>,
    /// Stop after this many messages.
    #[arg(long, value_name = "N")]
    pub max_messages: Option<u64>,
    /// Hand what was received to the operating system at least this often: a crash (`kill -9`,
    /// power loss) costs at most this much; `autoact recover` restores the rest.
    #[arg(long, value_name = "S", default_value_t = 1.0)]
    pub flush_interval: f64,
}

fn seconds(name: &str, v: Option<f64>) -> Result<Option<Duration>> {
    match v {
        None => Ok(None),
        Some(s) if s.is_finite() && s > 0.0 => Ok(Some(Duration::from_secs_f64(s))),
        Some(s) => bail!("{name} must be a positive number of seconds, not {s}"),
    }
}

/// Runs `autoact record`.
///
/// # Errors
/// Bad arguments, DDS that cannot start, or an output that cannot be written (a full disk ends
/// the recording; what was flushed stays readable).
pub fn run(args: Args) -> Result<Outcome> {
    if args.topics.is_empty() && !args.all && args.include.is_none() {
        bail!("name topics to record, or give --all or --include REGEX");
    }
    if args.output.exists() && !args.force {
        bail!(
            "{} exists: give --force to replace it",
            args.output.display()
        );
    }
    let include = args
        .include
        .as_deref()
        .map(Regex::new)
        .transpose()
        .context("--include")?;
    let exclude = args
        .exclude
        .as_deref()
        .map(Regex::new)
        .transpose()
        .context("--exclude")?;
    let split = SplitPolicy {
        max_bytes: args.split_size.map(|mb| mb * 1_000_000),
        max_duration: seconds("--split-duration", args.split_duration)?,
    };
    let max_duration = seconds("--max-duration", args.max_duration)?;
    let flush_every =
        seconds("--flush-interval", Some(args.flush_interval))?.unwrap_or(Duration::from_secs(1));
    let domain_id = match args.domain_id {
        Some(d) => d,
        None => parse_domain_id(std::env::var("ROS_DOMAIN_ID").ok().as_deref())?,
    };
    let config = DdsConfig {
        domain_id,
        reliability: match args.reliability {
            ReliabilityArg::Reliable => Reliability::Reliable,
            ReliabilityArg::BestEffort => Reliability::BestEffort,
        },
        durability: match args.durability {
            DurabilityArg::Volatile => Durability::Volatile,
            DurabilityArg::TransientLocal => Durability::TransientLocal,
        },
        history_depth: args.depth,
    };
    let explicit: BTreeSet<String> = args
        .topics
        .iter()
        .map(|t| {
            if t.starts_with('/') {
                t.clone()
            } else {
                format!("/{t}")
            }
        })
        .collect();
    let wanted = |topic: &str| {
        !exclude.as_ref().is_some_and(|r| r.is_match(topic))
            && (explicit.contains(topic)
                || args.all
                || include.as_ref().is_some_and(|r| r.is_match(topic)))
    };

    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .context("installing signal handlers")?;
    }
    let output = if args.output.extension().is_some_and(|e| e == "mcap") {
        Output::File(args.output.clone())
    } else {
        if args.output.is_dir() {
            std::fs::remove_dir_all(&args.output)
                .with_context(|| format!("replacing {}", args.output.display()))?;
        }
        std::fs::create_dir_all(&args.output)
            .with_context(|| format!("creating {}", args.output.display()))?;
        Output::Rosbag2(args.output.clone())
    };
    let mut recorder = Recorder::new(&config)?;
    let mut writer = RecordWriter::new(
        output,
        WriteConfig {
            compression: args.compression,
            ..WriteConfig::default()
        },
        split,
        flush_every,
    );
    writer.set_metadata("domain_id", domain_id.to_string());
    writer.set_metadata(
        "qos",
        format!(
            "{:?} {:?} keep-last {}",
            args.reliability, args.durability, args.depth
        ),
    );
    let started = Instant::now();
    let mut subscribed: BTreeSet<String> = BTreeSet::new();
    let mut skipped_types: BTreeSet<String> = BTreeSet::new();
    let mut last_discovery: Option<Instant> = None;
    let mut last_status = Instant::now();
    let mut total = 0u64;
    let mut failure: Option<anyhow::Error> = None;
    'recording: while !stop.load(Ordering::Relaxed) {
        if last_discovery.is_none_or(|t| t.elapsed() >= Duration::from_millis(250)) {
            last_discovery = Some(Instant::now());
            for (topic, type_name) in recorder.discovered() {
                if subscribed.contains(&topic) || !wanted(&topic) {
                    continue;
                }
                if ros::definition(&type_name).is_none() {
                    if skipped_types.insert(format!("{topic} ({type_name})")) {
                        tracing::warn!(
                            "{topic}: autoact has no definition of {type_name}; not recorded"
                        );
                    }
                    continue;
                }
                recorder.subscribe(&topic, &type_name)?;
                tracing::info!("recording {topic} ({type_name})");
                subscribed.insert(topic);
            }
        }
        recorder.wait(Duration::from_millis(50));
        for s in recorder.take() {
            let received = Received {
                topic: &s.topic,
                type_name: &s.type_name,
                cdr: &s.cdr,
                receive_time_nanos: s.receive_time_nanos,
                source_time_nanos: s.source_time_nanos,
                writer: s.writer,
                sequence_number: s.sequence_number,
            };
            if let Err(e) = writer.write(&received) {
                failure = Some(anyhow::Error::new(e).context(
                    "recording stopped; what was flushed before is readable (autoact recover)",
                ));
                break 'recording;
            }
            total += 1;
            if args.max_messages.is_some_and(|n| total >= n) {
                break 'recording;
            }
        }
        if let Err(e) = writer.flush_if_due() {
            failure = Some(anyhow::Error::new(e).context("recording stopped"));
            break;
        }
        if max_duration.is_some_and(|d| started.elapsed() >= d) {
            break;
        }
        if last_status.elapsed() >= Duration::from_secs(1) {
            last_status = Instant::now();
            status(&writer, started, &subscribed);
        }
    }
    let missing: Vec<&String> = explicit
        .iter()
        .filter(|t| !subscribed.contains(*t))
        .collect();
    if !missing.is_empty() {
        tracing::warn!("never discovered: {missing:?}");
    }
    if let Some(e) = failure {
        // Finishing writes the summary into the same file, which (a full disk) usually fails
        // too: report the first error, the one that stopped the recording.
        if let Err(finish) = writer.finish() {
            tracing::warn!("the file could not be finished either: {finish}");
        }
        return Err(e);
    }
    let (files, topics) = writer.finish()?;
    let mut text = format!(
        "recorded {total} messages from {} topics in {:.1} s into {}\n",
        topics.len(),
        started.elapsed().as_secs_f64(),
        files
            .iter()
            .map(|f| f.display().to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let mut lost = recorder.rejected() > 0;
    for (topic, t) in &topics {
        text.push_str(&format!(
            "  {topic} ({}): {} messages, {} bytes, {} dropped, {} rejected\n",
            t.type_name, t.messages, t.bytes, t.dropped, t.rejected
        ));
        lost |= t.dropped > 0 || t.rejected > 0;
    }
    print_stdout(&text)?;
    Ok(if lost {
        Outcome::DataLost
    } else {
        Outcome::Success
    })
}

/// One status line on stderr: topics, rate, messages, bytes, drops (rewritten in place on a
/// terminal; silent with `-q`).
fn status(writer: &RecordWriter, started: Instant, subscribed: &BTreeSet<String>) {
    use std::io::{IsTerminal, Write};
    if !tracing::enabled!(tracing::Level::WARN) {
        return;
    }
    let topics = writer.topics();
    let messages: u64 = topics.values().map(|t| t.messages).sum();
    let bytes: u64 = topics.values().map(|t| t.bytes).sum();
    let dropped: u64 = topics.values().map(|t| t.dropped).sum();
    let rejected: u64 = topics.values().map(|t| t.rejected).sum();
    let elapsed = started.elapsed().as_secs_f64();
    #[expect(clippy::cast_precision_loss, reason = "display only")]
    let rate = messages as f64 / elapsed.max(1e-3);
    #[expect(clippy::cast_precision_loss, reason = "display only")]
    let mb = bytes as f64 / 1e6;
    let line = format!(
        "recording {:.0} s | {} topics | {messages} messages ({rate:.0}/s) | {mb:.1} MB | {dropped} dropped | {rejected} rejected",
        elapsed,
        subscribed.len()
    );
    let mut err = std::io::stderr().lock();
    let _ = if err.is_terminal() {
        write!(err, "\r{line}\x1b[K")
    } else {
        writeln!(err, "{line}")
    };
}
