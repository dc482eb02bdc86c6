//! `autoact record`: live ROS 2 topics (DDS, no ROS installation needed) into MCAP — the same
//! bags `import` writes, so `convert` takes them as they are.

use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use regex::Regex;

use super::{Outcome, print_stdout};
use crate::mcap_io::Compression;
use crate::record::dds::{DdsConfig, parse_domain_id};
use crate::record::run::{DurabilityArg, RecordOptions, ReliabilityArg, TopicFilter, record};
use crate::record::session::SplitPolicy;

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
    /// Keep-last history depth per topic: the samples a topic holds, and the backlog absorbed
    /// when the recorder falls behind (e.g. stopped by Ctrl-Z) before the oldest is lost
    /// [default: 1000; 100 for images, compressed video and point clouds]
    #[arg(long, value_parser = clap::value_parser!(i32).range(1..))]
    pub depth: Option<i32>,
    /// Output: a `.mcap` file (splits go beside it as `<stem>_1.mcap`, `<stem>_2.mcap`, …), or
    /// a rosbag2 directory (any other path: `<dir>/<dir>_0.mcap`, … and `metadata.yaml`, which
    /// `ros2 bag play` and `autoact convert` open).
    #[arg(short, long, value_name = "FILE.mcap|DIR")]
    pub output: PathBuf,
    /// The format of a rosbag2 directory's `metadata.yaml`.
    #[command(flatten)]
    pub rosbag2: super::Rosbag2Args,
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
    let regex = |r: &Option<String>, flag| r.as_deref().map(Regex::new).transpose().context(flag);
    let topics = TopicFilter::new(
        &args.topics,
        args.all,
        regex(&args.include, "--include")?,
        regex(&args.exclude, "--exclude")?,
    );
    if topics.is_empty() {
        bail!("name topics to record, or give --all or --include REGEX");
    }
    let env_domain = std::env::var("ROS_DOMAIN_ID").ok();
    let options = RecordOptions {
        topics,
        dds: DdsConfig {
            domain_id: args
                .domain_id
                .map_or_else(|| parse_domain_id(env_domain.as_deref()), Ok)?,
            reliability: args.reliability.into(),
            durability: args.durability.into(),
            history_depth: args.depth,
        },
        compression: args.compression,
        split: SplitPolicy {
            max_bytes: args.split_size.map(|mb| mb * 1_000_000),
            max_duration: seconds("--split-duration", args.split_duration)?,
        },
        max_duration: seconds("--max-duration", args.max_duration)?,
        max_messages: args.max_messages,
        flush_every: seconds("--flush-interval", Some(args.flush_interval))?
            .unwrap_or(Duration::from_secs(1)),
        output: args.output,
        rosbag2_version: args.rosbag2.rosbag2_version,
        force: args.force,
    };
    let summary = record(&options, crate::interrupt::Interrupt::install()?.flag())?;
    print_stdout(&summary.report())?;
    Ok(Outcome::from_run(&summary))
}
