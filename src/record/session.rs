//! The file side of `autoact record`: received CDR into MCAP, split by size or duration with
//! nothing lost or duplicated at a seam, flushed on a clock so a crash costs at most one flush
//! interval, and every loss counted per topic — sequence gaps the DDS layer shows, payloads that
//! do not decode as their type — for the status line, the bag's metadata and the exit code.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crate::mcap_io::{BagWriter, McapIoError, WriteConfig};
use crate::ros;

/// One received message.
#[derive(Debug, Clone, PartialEq)]
pub struct Received<'a> {
    /// ROS topic, e.g. `/skeleton`.
    pub topic: &'a str,
    /// ROS type, e.g. `autoact_msgs/msg/Skeleton3D`.
    pub type_name: &'a str,
    /// CDR with its encapsulation header.
    pub cdr: &'a [u8],
    /// When it arrived (the MCAP log time), ns since the UNIX epoch.
    pub receive_time_nanos: u64,
    /// When it was published (the writer's source time), if known.
    pub source_time_nanos: Option<u64>,
    /// The DDS writer it came from.
    pub writer: [u8; 16],
    /// Its sequence number from that writer.
    pub sequence_number: i64,
}

/// When to start a new file.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SplitPolicy {
    /// After this many payload bytes.
    pub max_bytes: Option<u64>,
    /// After this much log time.
    pub max_duration: Option<Duration>,
}

/// What one topic saw.
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize)]
pub struct TopicStats {
    /// ROS type.
    pub type_name: String,
    /// Messages written.
    pub messages: u64,
    /// Payload bytes written.
    pub bytes: u64,
    /// Messages the DDS layer skipped (sequence-number gaps per writer).
    pub dropped: u64,
    /// Messages that did not decode as their type (not written).
    pub rejected: u64,
    /// The last sequence number seen from each DDS writer of the topic.
    #[serde(skip)]
    last_sequence: BTreeMap<[u8; 16], i64>,
}

/// Where the files go.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Output {
    /// A bare `.mcap`; splits go beside it as `<stem>_1.mcap`, `<stem>_2.mcap`, …
    File(PathBuf),
    /// A rosbag2 directory: `<dir>/<name>_0.mcap`, `<name>_1.mcap`, … and `metadata.yaml`
    /// (in the format version given) listing them, `<name>` being the directory's name.
    Rosbag2(PathBuf, crate::mcap_io::Rosbag2Version),
}

impl Output {
    /// The file of split `index`.
    #[must_use]
    pub fn path(&self, index: usize) -> PathBuf {
        match self {
            Output::File(base) => split_path(base, index),
            Output::Rosbag2(dir, _) => {
                let name = dir
                    .file_name()
                    .map_or_else(|| "record".into(), |s| s.to_string_lossy().into_owned());
                dir.join(format!("{name}_{index}.mcap"))
            }
        }
    }
}

/// Writes received messages into one or more MCAP files.
pub struct RecordWriter {
    output: Output,
    config: WriteConfig,
    split: SplitPolicy,
    flush_every: Duration,
    current: Option<BagWriter<crate::mcap_io::FileSink>>,
    current_bytes: u64,
    current_start_nanos: Option<u64>,
    last_flush: Instant,
    files: Vec<PathBuf>,
    file_stats: Vec<(String, crate::mcap_io::BagStats)>,
    topics: BTreeMap<String, TopicStats>,
    metadata: BTreeMap<String, String>,
}

/// The file for split `index` of `base`: `base` itself first, then `<stem>_<index>.mcap`.
#[must_use]
pub fn split_path(base: &Path, index: usize) -> PathBuf {
    if index == 0 {
        return base.to_path_buf();
    }
    let stem = base
        .file_stem()
        .map_or_else(|| "record".into(), |s| s.to_string_lossy().into_owned());
    base.with_file_name(format!("{stem}_{index}.mcap"))
}

/// Whether `cdr` decodes as `type_name`, for the types autoact knows (others need only a CDR
/// encapsulation header).
fn decodes(type_name: &str, cdr: &[u8]) -> bool {
    ros::check_decodes(type_name, cdr).map_or(cdr.len() >= 4, |r| r.is_ok())
}

impl RecordWriter {
    /// A writer to `output`, flushing at least every `flush_every`.
    #[must_use]
    pub fn new(
        output: Output,
        config: WriteConfig,
        split: SplitPolicy,
        flush_every: Duration,
    ) -> RecordWriter {
        RecordWriter {
            output,
            config,
            split,
            flush_every,
            current: None,
            current_bytes: 0,
            current_start_nanos: None,
            last_flush: Instant::now(),
            files: Vec::new(),
            file_stats: Vec::new(),
            topics: BTreeMap::new(),
            metadata: BTreeMap::new(),
        }
    }

    /// Adds a key to the `autoact.record` metadata record of every file.
    pub fn set_metadata(&mut self, key: &str, value: String) {
        self.metadata.insert(key.to_string(), value);
    }

    /// Per topic, what was seen so far.
    #[must_use]
    pub fn topics(&self) -> &BTreeMap<String, TopicStats> {
        &self.topics
    }

    /// The files written so far.
    #[must_use]
    pub fn files(&self) -> &[PathBuf] {
        &self.files
    }

    fn roll_if_due(&mut self, log_time_nanos: u64) -> Result<(), McapIoError> {
        let due = self.current.is_some()
            && (self
                .split
                .max_bytes
                .is_some_and(|b| self.current_bytes >= b)
                || self.split.max_duration.is_some_and(|d| {
                    self.current_start_nanos.is_some_and(|s| {
                        u128::from(log_time_nanos.saturating_sub(s)) >= d.as_nanos()
                    })
                }));
        if due {
            self.close_current()?;
        }
        if self.current.is_none() {
            let path = self.output.path(self.files.len());
            self.current = Some(BagWriter::create(&path, self.config)?);
            self.files.push(path);
            self.current_bytes = 0;
            self.current_start_nanos = None;
        }
        Ok(())
    }

    fn close_current(&mut self) -> Result<(), McapIoError> {
        if let Some(mut w) = self.current.take() {
            let mut meta = self.metadata.clone();
            meta.insert(
                "topics".to_string(),
                serde_json::to_string(&self.topics).unwrap_or_default(),
            );
            meta.insert(
                "split_index".to_string(),
                (self.files.len() - 1).to_string(),
            );
            w.write_metadata(
                &format!("{}.record", crate::bags::pose::METADATA_NAME),
                meta,
            )?;
            let stats = w.finish()?;
            let name = self
                .files
                .last()
                .and_then(|p| p.file_name())
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
            self.file_stats.push((name, stats));
        }
        Ok(())
    }

    /// Writes one received message (or counts it as rejected), counting sequence gaps.
    ///
    /// # Errors
    /// [`McapIoError`] from the file (e.g. a full disk): stop recording then.
    pub fn write(&mut self, m: &Received<'_>) -> Result<(), McapIoError> {
        // Keys are allocated once per topic and writer, not once per message.
        let stats = match self.topics.get_mut(m.topic) {
            Some(stats) => stats,
            None => self
                .topics
                .entry(m.topic.to_string())
                .or_insert(TopicStats {
                    type_name: m.type_name.to_string(),
                    ..TopicStats::default()
                }),
        };
        match stats.last_sequence.get_mut(&m.writer) {
            Some(last) => {
                if m.sequence_number > *last + 1 {
                    stats.dropped += u64::try_from(m.sequence_number - *last - 1).unwrap_or(0);
                }
                *last = (*last).max(m.sequence_number);
            }
            None => {
                stats.last_sequence.insert(m.writer, m.sequence_number);
            }
        }
        if !decodes(m.type_name, m.cdr) {
            stats.rejected += 1;
            return Ok(());
        }
        stats.messages += 1;
        stats.bytes += m.cdr.len() as u64;
        self.roll_if_due(m.receive_time_nanos)?;
        let Some(w) = self.current.as_mut() else {
            return Ok(());
        };
        w.write_raw(
            m.topic,
            m.type_name,
            || ros::definition(m.type_name).unwrap_or_default(),
            m.receive_time_nanos,
            m.source_time_nanos.unwrap_or(m.receive_time_nanos),
            m.cdr,
        )?;
        self.current_bytes += m.cdr.len() as u64;
        self.current_start_nanos.get_or_insert(m.receive_time_nanos);
        self.flush_if_due()
    }

    /// Flushes when the flush interval has passed since the last flush (call it when idle too).
    ///
    /// # Errors
    /// [`McapIoError`].
    pub fn flush_if_due(&mut self) -> Result<(), McapIoError> {
        if self.last_flush.elapsed() >= self.flush_every {
            self.flush()?;
        }
        Ok(())
    }

    /// Flushes the open file now (its current chunk ends).
    ///
    /// # Errors
    /// [`McapIoError`].
    pub fn flush(&mut self) -> Result<(), McapIoError> {
        self.last_flush = Instant::now();
        match self.current.as_mut() {
            Some(w) => w.flush(),
            None => Ok(()),
        }
    }

    /// Finishes the open file (summary, index, the `autoact.record` record) and returns the
    /// files and the per-topic counts.
    ///
    /// # Errors
    /// [`McapIoError`].
    pub fn finish(mut self) -> Result<(Vec<PathBuf>, BTreeMap<String, TopicStats>), McapIoError> {
        self.close_current()?;
        if let Output::Rosbag2(dir, version) = &self.output {
            crate::mcap_io::write_rosbag2_metadata(dir, &self.file_stats, *version)?;
        }
        Ok((self.files, self.topics))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mcap_io::BagReader;
    use crate::ros::RosMessage;
    use crate::ros::autoact_msgs::Skeleton3D;

    fn skeleton_cdr(k: u64) -> Vec<u8> {
        ros::cdr::encode(&Skeleton3D {
            layout: "h36m-17".into(),
            track_id: k,
            ..Skeleton3D::default()
        })
        .unwrap()
    }

    fn received(cdr: &[u8], k: i64) -> Received<'_> {
        Received {
            topic: "/skeleton",
            type_name: Skeleton3D::TYPE_NAME,
            cdr,
            receive_time_nanos: 1_000_000_000 + u64::try_from(k).unwrap() * 10_000_000,
            source_time_nanos: Some(999),
            writer: [7; 16],
            sequence_number: k,
        }
    }

    #[test]
    fn splits_lose_and_duplicate_nothing_and_gaps_are_counted() {
        let dir = tempfile::tempdir().unwrap();
        let base = dir.path().join("rec.mcap");
        let mut w = RecordWriter::new(
            Output::File(base.clone()),
            WriteConfig::default(),
            SplitPolicy {
                max_bytes: None,
                max_duration: Some(Duration::from_millis(250)),
            },
            Duration::from_millis(50),
        );
        let mut sent = Vec::new();
        for k in 1..=100i64 {
            if k == 40 || k == 41 {
                continue; // the DDS layer lost these two
            }
            let cdr = skeleton_cdr(u64::try_from(k).unwrap());
            w.write(&received(&cdr, k)).unwrap();
            sent.push(u64::try_from(k).unwrap());
        }
        // A malformed payload is counted and not written.
        w.write(&received(&[0, 1, 0, 0, 9], 101)).unwrap();
        let (files, topics) = w.finish().unwrap();
        assert!(
            files.len() >= 4,
            "1 s of log time in 250 ms files: {files:?}"
        );
        let stats = &topics["/skeleton"];
        assert_eq!((stats.messages, stats.dropped, stats.rejected), (98, 2, 1));
        let mut got = Vec::new();
        for f in &files {
            let r = BagReader::open(f).unwrap();
            assert!(r.time_range().is_some(), "{f:?} is finished");
            for m in r.messages() {
                let m = m.unwrap();
                assert_eq!(m.publish_time, 999);
                got.push(ros::cdr::decode::<Skeleton3D>(&m.data).unwrap().track_id);
            }
        }
        assert_eq!(got, sent, "every message once, in order, across the seams");
        assert_eq!(split_path(&base, 0), base);
        assert_eq!(split_path(&base, 2), dir.path().join("rec_2.mcap"));
    }

    #[test]
    fn images_are_checked_like_the_other_known_types() {
        use crate::ros::sensor_msgs::Image;
        let image = Image {
            height: 2,
            width: 3,
            encoding: "rgb8".into(),
            step: 9,
            data: (0..18).collect(),
            ..Image::default()
        };
        let cdr = ros::cdr::encode(&image).unwrap();
        assert!(decodes(Image::TYPE_NAME, &cdr));
        assert!(
            !decodes(Image::TYPE_NAME, &cdr[..cdr.len() - 1]),
            "one pixel byte short"
        );
        assert!(ros::definition(Image::TYPE_NAME).is_some());
    }

    #[test]
    fn a_split_rosbag2_directory_lists_every_file_in_order() {
        let dir = tempfile::tempdir().unwrap();
        let bag = dir.path().join("take");
        std::fs::create_dir(&bag).unwrap();
        let mut w = RecordWriter::new(
            Output::Rosbag2(bag.clone(), crate::mcap_io::Rosbag2Version::V9),
            WriteConfig::default(),
            SplitPolicy {
                max_bytes: Some(400),
                max_duration: None,
            },
            Duration::from_secs(1),
        );
        for k in 1..=40 {
            let cdr = skeleton_cdr(k);
            w.write(&received(&cdr, i64::try_from(k).unwrap())).unwrap();
        }
        let (files, _) = w.finish().unwrap();
        assert!(files.len() > 2, "{files:?}");
        assert_eq!(files[0], bag.join("take_0.mcap"));
        let yaml = std::fs::read_to_string(bag.join("metadata.yaml")).unwrap();
        assert!(yaml.contains("message_count: 40"), "{yaml}");
        for (i, f) in files.iter().enumerate() {
            assert!(yaml.contains(&format!("- take_{i}.mcap")), "{yaml}");
            assert!(f.exists());
        }
        let ids: Vec<u64> = BagReader::open_all(&bag)
            .unwrap()
            .iter()
            .flat_map(|r| r.messages().map(|m| m.unwrap()).collect::<Vec<_>>())
            .map(|m| ros::cdr::decode::<Skeleton3D>(&m.data).unwrap().track_id)
            .collect();
        assert_eq!(ids, (1..=40).collect::<Vec<_>>());
    }

    #[test]
    fn a_recorded_rosbag2_directory_gets_the_metadata_format_asked_for() {
        use crate::mcap_io::Rosbag2Version;
        for (version, number) in [(Rosbag2Version::V5, 5), (Rosbag2Version::V9, 9)] {
            let dir = tempfile::tempdir().unwrap();
            let bag = dir.path().join("take");
            std::fs::create_dir(&bag).unwrap();
            let mut w = RecordWriter::new(
                Output::Rosbag2(bag.clone(), version),
                WriteConfig::default(),
                SplitPolicy::default(),
                Duration::from_secs(1),
            );
            let cdr = skeleton_cdr(1);
            w.write(&received(&cdr, 1)).unwrap();
            w.finish().unwrap();
            let yaml = std::fs::read_to_string(bag.join("metadata.yaml")).unwrap();
            assert!(yaml.contains(&format!("  version: {number}\n")), "{yaml}");
            let hash = crate::ros::type_hash::rihs01(
                Skeleton3D::TYPE_NAME,
                &ros::definition_of::<Skeleton3D>(),
            )
            .unwrap();
            assert_eq!(
                yaml.contains(&format!("type_description_hash: {hash}\n")),
                version == Rosbag2Version::V9,
                "{yaml}"
            );
        }
    }

    #[test]
    fn a_flushed_file_keeps_its_messages_when_the_process_dies() {
        let dir = tempfile::tempdir().unwrap();
        let base = dir.path().join("crash.mcap");
        let mut w = RecordWriter::new(
            Output::File(base.clone()),
            WriteConfig::default(),
            SplitPolicy::default(),
            Duration::from_secs(3600),
        );
        for k in 1..=30 {
            let cdr = skeleton_cdr(k);
            w.write(&received(&cdr, i64::try_from(k).unwrap())).unwrap();
        }
        w.flush().unwrap();
        // The process "dies" here: the writer is leaked, never finished.
        std::mem::forget(w);
        let r = BagReader::open(&base).unwrap();
        assert!(r.time_range().is_none(), "no summary: an unfinished file");
        let kept = r.messages().flatten().count();
        assert_eq!(kept, 30, "every flushed message is readable");
    }
}
