//! The recording session: discover topics and subscribe to the wanted ones, write what arrives,
//! show a status line, stop on a signal or a limit, and finish the files.

use std::collections::{BTreeMap, BTreeSet};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use regex::Regex;

use super::dds::{DdsConfig, DdsError, Durability, Recorder, Reliability, describe_depth};
use super::session::{Output, Received, RecordWriter, SplitPolicy, TopicStats};
use crate::mcap_io::{Compression, McapIoError, WriteConfig};
use crate::ros;

/// How often the recorder looks for new topics.
const DISCOVERY_INTERVAL: Duration = Duration::from_millis(250);
/// How long one wait for samples lasts.
const WAIT: Duration = Duration::from_millis(50);
/// How often the status line is redrawn.
const STATUS_INTERVAL: Duration = Duration::from_secs(1);
/// How often the recorder checks that RustDDS's threads still run.
const LIVENESS_INTERVAL: Duration = Duration::from_millis(500);

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

impl From<ReliabilityArg> for Reliability {
    fn from(arg: ReliabilityArg) -> Reliability {
        match arg {
            ReliabilityArg::Reliable => Reliability::Reliable,
            ReliabilityArg::BestEffort => Reliability::BestEffort,
        }
    }
}

impl From<DurabilityArg> for Durability {
    fn from(arg: DurabilityArg) -> Durability {
        match arg {
            DurabilityArg::Volatile => Durability::Volatile,
            DurabilityArg::TransientLocal => Durability::TransientLocal,
        }
    }
}

/// Which topics to record.
#[derive(Debug, Clone, Default)]
pub struct TopicFilter {
    /// Topics named explicitly (with their leading `/`).
    pub explicit: BTreeSet<String>,
    /// Every topic of a type autoact knows.
    pub all: bool,
    /// Also topics matching this.
    pub include: Option<Regex>,
    /// Never topics matching this.
    pub exclude: Option<Regex>,
}

impl TopicFilter {
    /// The filter for `topics` (a missing leading `/` is added), `all`, `include` and `exclude`.
    #[must_use]
    pub fn new(
        topics: &[String],
        all: bool,
        include: Option<Regex>,
        exclude: Option<Regex>,
    ) -> TopicFilter {
        let explicit = topics
            .iter()
            .map(|t| {
                if t.starts_with('/') {
                    t.clone()
                } else {
                    format!("/{t}")
                }
            })
            .collect();
        TopicFilter {
            explicit,
            all,
            include,
            exclude,
        }
    }

    /// Whether the filter selects anything at all.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.explicit.is_empty() && !self.all && self.include.is_none()
    }

    /// Whether `topic` is to be recorded.
    #[must_use]
    pub fn wants(&self, topic: &str) -> bool {
        !self.exclude.as_ref().is_some_and(|r| r.is_match(topic))
            && (self.explicit.contains(topic)
                || self.all
                || self.include.as_ref().is_some_and(|r| r.is_match(topic)))
    }
}

/// What and how to record.
#[derive(Debug, Clone)]
pub struct RecordOptions {
    /// Which topics.
    pub topics: TopicFilter,
    /// The DDS domain and reader QoS.
    pub dds: DdsConfig,
    /// A `.mcap` file (splits beside it) or a rosbag2 directory (any other path).
    pub output: PathBuf,
    /// The `metadata.yaml` format of a rosbag2 directory output.
    pub rosbag2_version: crate::mcap_io::Rosbag2Version,
    /// Replace an existing output.
    pub force: bool,
    /// Chunk compression of the MCAP files.
    pub compression: Compression,
    /// When to start a new file.
    pub split: SplitPolicy,
    /// Stop after this long.
    pub max_duration: Option<Duration>,
    /// Stop after this many messages.
    pub max_messages: Option<u64>,
    /// Hand what was received to the operating system at least this often.
    pub flush_every: Duration,
}

/// What a recording wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct RecordSummary {
    /// Messages written.
    pub messages: u64,
    /// How long the recording ran (until its files were finished).
    pub elapsed: Duration,
    /// The files written.
    pub files: Vec<PathBuf>,
    /// Per topic, what was received, dropped and rejected.
    pub topics: BTreeMap<String, TopicStats>,
    /// Samples the DDS layer rejected before they reached a topic.
    pub rejected: u64,
}

impl RecordSummary {
    /// The summary printed at the end: totals, then one line per topic.
    #[must_use]
    pub fn report(&self) -> String {
        let mut text = format!(
            "recorded {} messages from {} topics in {:.1} s into {}\n",
            self.messages,
            self.topics.len(),
            self.elapsed.as_secs_f64(),
            self.files
                .iter()
                .map(|f| f.display().to_string())
                .collect::<Vec<_>>()
                .join(", ")
        );
        for (topic, t) in &self.topics {
            text.push_str(&format!(
                "  {topic} ({}): {} messages, {} bytes, {} dropped, {} rejected\n",
                t.type_name, t.messages, t.bytes, t.dropped, t.rejected
            ));
        }
        text
    }
}

/// Why a recording failed.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RecordError {
    /// The output exists and replacing it was not asked for.
    #[error("{} exists: give --force to replace it", .0.display())]
    OutputExists(PathBuf),
    /// The rosbag2 directory could not be replaced or created.
    #[error("{action} {}", path.display())]
    Io {
        /// What was being done.
        action: &'static str,
        /// The directory.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// DDS could not start or subscribe.
    #[error(transparent)]
    Dds(#[from] DdsError),
    /// Writing a message failed (a full disk); what was flushed before stays readable.
    #[error("recording stopped; what was flushed before is readable (autoact recover)")]
    Write(#[source] McapIoError),
    /// A timed flush failed.
    #[error("recording stopped")]
    Flush(#[source] McapIoError),
    /// The files could not be finished.
    #[error(transparent)]
    Finish(McapIoError),
    /// DDS stopped receiving mid-recording (a RustDDS thread ended); the files were finished
    /// with what arrived before.
    #[error(
        "recording stopped after {messages} messages: DDS stopped receiving, so nothing after \
         this was recorded; {} was finished with what arrived before",
        output.display()
    )]
    Transport {
        /// Messages written before it stopped.
        messages: u64,
        /// The output given (file or rosbag2 directory).
        output: PathBuf,
        /// What ended.
        #[source]
        source: DdsError,
    },
}

/// Records as `options` say until `stop` is set (Ctrl-C), a limit is reached or writing fails,
/// showing a status line each second; then finishes the files.
///
/// # Errors
/// [`RecordError`]. On a write error the files are still finished where possible, and the
/// first error — the one that stopped the recording — is returned.
pub fn record(options: &RecordOptions, stop: &AtomicBool) -> Result<RecordSummary, RecordError> {
    if options.output.exists() && !options.force {
        return Err(RecordError::OutputExists(options.output.clone()));
    }
    let output = prepare_output(&options.output, options.rosbag2_version)?;
    let mut session = Session {
        recorder: Recorder::new(&options.dds)?,
        writer: RecordWriter::new(
            output,
            WriteConfig {
                compression: options.compression,
                ..WriteConfig::default()
            },
            options.split,
            options.flush_every,
        ),
        subscribed: BTreeSet::new(),
        skipped_types: BTreeSet::new(),
        messages: 0,
        started: Instant::now(),
    };
    let dds = &options.dds;
    session
        .writer
        .set_metadata("domain_id", dds.domain_id.to_string());
    session.writer.set_metadata(
        "qos",
        format!(
            "{:?} {:?} keep-last {}",
            dds.reliability,
            dds.durability,
            describe_depth(dds.history_depth)
        ),
    );
    let failure = match session.run(options, stop) {
        // A refused subscription ends the run at once; the open file is left for `recover`.
        Err(e @ RecordError::Dds(_)) => return Err(e),
        result => result.err(),
    };
    let missing: Vec<&String> = (options.topics.explicit.iter())
        .filter(|t| !session.subscribed.contains(*t))
        .collect();
    if !missing.is_empty() {
        tracing::warn!("never discovered: {missing:?}");
    }
    let Session {
        recorder,
        writer,
        messages,
        started,
        ..
    } = session;
    if let Some(e) = failure {
        // Finishing writes the summary into the same file, which (a full disk) usually fails
        // too: report the first error, the one that stopped the recording.
        if let Err(finish) = writer.finish() {
            tracing::warn!("the file could not be finished either: {finish}");
        }
        return Err(e);
    }
    let (files, topics) = writer.finish().map_err(RecordError::Finish)?;
    Ok(RecordSummary {
        messages,
        elapsed: started.elapsed(),
        files,
        topics,
        rejected: recorder.rejected(),
    })
}

/// A `.mcap` path as it is; any other path as a rosbag2 directory (its metadata in format
/// `version`), emptied and created.
fn prepare_output(
    path: &std::path::Path,
    version: crate::mcap_io::Rosbag2Version,
) -> Result<Output, RecordError> {
    if path.extension().is_some_and(|e| e == "mcap") {
        return Ok(Output::File(path.to_path_buf()));
    }
    let io = |action| {
        move |source| RecordError::Io {
            action,
            path: path.to_path_buf(),
            source,
        }
    };
    if path.is_dir() {
        std::fs::remove_dir_all(path).map_err(io("replacing"))?;
    }
    std::fs::create_dir_all(path).map_err(io("creating"))?;
    Ok(Output::Rosbag2(path.to_path_buf(), version))
}

/// A recording in progress.
struct Session {
    recorder: Recorder,
    writer: RecordWriter,
    subscribed: BTreeSet<String>,
    skipped_types: BTreeSet<String>,
    messages: u64,
    started: Instant,
}

impl Session {
    /// The loop: discover, wait, write, flush, show the status, until stopped.
    fn run(&mut self, options: &RecordOptions, stop: &AtomicBool) -> Result<(), RecordError> {
        let mut last_discovery: Option<Instant> = None;
        let mut last_status = Instant::now();
        let mut last_liveness = Instant::now();
        while !stop.load(Ordering::Relaxed) {
            if last_discovery.is_none_or(|t| t.elapsed() >= DISCOVERY_INTERVAL) {
                last_discovery = Some(Instant::now());
                self.discover(&options.topics)?;
            }
            self.recorder.wait(WAIT);
            if self.write_received(options.max_messages)? {
                break;
            }
            self.writer.flush_if_due().map_err(RecordError::Flush)?;
            if options
                .max_duration
                .is_some_and(|d| self.started.elapsed() >= d)
            {
                break;
            }
            if last_status.elapsed() >= STATUS_INTERVAL {
                last_status = Instant::now();
                self.status();
            }
            if last_liveness.elapsed() >= LIVENESS_INTERVAL {
                last_liveness = Instant::now();
                self.check_alive(options)?;
            }
        }
        // Also when stopped by a signal or a limit: a recording that ended receiving earlier is
        // not complete.
        self.check_alive(options)
    }

    /// [`RecordError::Transport`] once a RustDDS thread has ended.
    fn check_alive(&self, options: &RecordOptions) -> Result<(), RecordError> {
        self.recorder
            .check_alive()
            .map_err(|source| RecordError::Transport {
                messages: self.messages,
                output: options.output.clone(),
                source,
            })
    }

    /// Subscribes to every newly discovered topic `filter` wants and autoact has a type for.
    fn discover(&mut self, filter: &TopicFilter) -> Result<(), RecordError> {
        for (topic, type_name) in self.recorder.discovered() {
            if self.subscribed.contains(&topic) || !filter.wants(&topic) {
                continue;
            }
            if ros::definition(&type_name).is_none() {
                if self.skipped_types.insert(format!("{topic} ({type_name})")) {
                    tracing::warn!(
                        "{topic}: autoact has no definition of {type_name}; not recorded"
                    );
                }
                continue;
            }
            self.recorder.subscribe(&topic, &type_name)?;
            tracing::info!("recording {topic} ({type_name})");
            self.subscribed.insert(topic);
        }
        Ok(())
    }

    /// Writes what arrived; `true` once `max_messages` are written.
    fn write_received(&mut self, max_messages: Option<u64>) -> Result<bool, RecordError> {
        for s in self.recorder.take() {
            let received = Received {
                topic: &s.topic,
                type_name: &s.type_name,
                cdr: &s.cdr,
                receive_time_nanos: s.receive_time_nanos,
                source_time_nanos: s.source_time_nanos,
                writer: s.writer,
                sequence_number: s.sequence_number,
            };
            self.writer.write(&received).map_err(RecordError::Write)?;
            self.messages += 1;
            if max_messages.is_some_and(|n| self.messages >= n) {
                return Ok(true);
            }
        }
        Ok(false)
    }

    /// One status line: topics, rate, messages, bytes, drops.
    fn status(&self) {
        let topics = self.writer.topics();
        let messages: u64 = topics.values().map(|t| t.messages).sum();
        let bytes: u64 = topics.values().map(|t| t.bytes).sum();
        let dropped: u64 = topics.values().map(|t| t.dropped).sum();
        let rejected: u64 = topics.values().map(|t| t.rejected).sum();
        let elapsed = self.started.elapsed().as_secs_f64();
        #[expect(clippy::cast_precision_loss, reason = "display only")]
        let rate = messages as f64 / elapsed.max(1e-3);
        #[expect(clippy::cast_precision_loss, reason = "display only")]
        let mb = bytes as f64 / 1e6;
        crate::progress::status_line(&format!(
            "recording {elapsed:.0} s | {} topics | {messages} messages ({rate:.0}/s) | {mb:.1} MB | {dropped} dropped | {rejected} rejected",
            self.subscribed.len()
        ));
    }
}

impl crate::outcome::LostInput for RecordSummary {
    /// Whether anything was lost (dropped or rejected samples): exit code 3.
    fn lost_input(&self) -> bool {
        self.rejected > 0
            || self
                .topics
                .values()
                .any(|t| t.dropped > 0 || t.rejected > 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outcome::LostInput;

    #[test]
    fn the_filter_takes_named_topics_all_or_matches_and_never_excluded_ones() {
        let named = TopicFilter::new(&["skeleton".into(), "/tf".into()], false, None, None);
        assert!(named.wants("/skeleton") && named.wants("/tf") && !named.wants("/other"));
        assert!(TopicFilter::new(&[], false, None, None).is_empty());
        let include = Regex::new("^/cam").ok();
        let exclude = Regex::new("info$").ok();
        let matched = TopicFilter::new(&[], false, include, exclude);
        assert!(!matched.is_empty());
        assert!(matched.wants("/camera/image") && !matched.wants("/camera/camera_info"));
        let all = TopicFilter::new(&[], true, None, Regex::new("^/tf").ok());
        assert!(all.wants("/anything") && !all.wants("/tf_static"));
    }

    #[test]
    fn the_summary_counts_losses_and_lists_every_topic() {
        let mut stats = TopicStats::default();
        stats.type_name = "autoact_msgs/msg/Skeleton".into();
        stats.messages = 3;
        stats.bytes = 300;
        let mut summary = RecordSummary {
            messages: 3,
            elapsed: Duration::from_millis(1500),
            files: vec![PathBuf::from("a.mcap"), PathBuf::from("a_1.mcap")],
            topics: BTreeMap::from([("/skeleton".to_owned(), stats)]),
            rejected: 0,
        };
        assert!(!summary.lost_input());
        assert_eq!(
            summary.report(),
            "recorded 3 messages from 1 topics in 1.5 s into a.mcap, a_1.mcap\n  /skeleton (autoact_msgs/msg/Skeleton): 3 messages, 300 bytes, 0 dropped, 0 rejected\n"
        );
        summary.rejected = 1;
        assert!(summary.lost_input());
    }
}
