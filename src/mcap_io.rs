//! MCAP files: the one writer preset and the one streaming reader.
//!
//! **Writing** ([`BagWriter`]): profile `ros2`, schema encoding `ros2msg` (definitions from
//! [`crate::ros::definition`]), message encoding `cdr`, chunked (zstd by default; lz4 or none),
//! with message indexes, chunk indexes, statistics and summary, and `library` stamped
//! `autoact <version>`. Compression runs single-threaded so the same input gives byte-identical
//! files on any machine. Schemas and channels are registered on first use, in that order.
//!
//! **Reading** ([`BagReader`]): the file is memory-mapped, never loaded; records are streamed in
//! file order and each chunk is decompressed and CRC-checked on its own, so a corrupt chunk costs
//! only its own messages: the stream reports it ([`ReadIssue::CorruptChunk`]) and goes on with
//! the next chunk. A file that ends mid-record yields everything before the cut, then
//! [`ReadIssue::Truncated`].

use std::collections::{BTreeMap, VecDeque};
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::ros::{self, RosMessage};

/// The `library` field of files autoact writes.
pub const LIBRARY: &str = concat!("autoact ", env!("CARGO_PKG_VERSION"));

/// Chunk compression.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Compression {
    /// zstd (the default): small files, fast enough.
    #[default]
    Zstd,
    /// lz4: faster, larger.
    Lz4,
    /// Uncompressed chunks.
    None,
}

/// Errors writing or opening MCAP files.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum McapIoError {
    /// A file system error.
    #[error("{action} {path}")]
    Io {
        /// What was being done.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The MCAP library refused.
    #[error("{action} {path}")]
    Mcap {
        /// What was being done.
        action: &'static str,
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: mcap::McapError,
    },
    /// A message could not be encoded.
    #[error("cannot encode a {type_name} for {topic} in {path}")]
    Encode {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The message type.
        type_name: &'static str,
        /// The cause.
        #[source]
        source: ros::cdr::CdrError,
    },
    /// The file is empty.
    #[error("{0} is empty (0 bytes): not an MCAP file")]
    Empty(PathBuf),
    /// A directory given as a bag holds no `.mcap` file.
    #[error(
        "{0} is a directory with no .mcap file in it (a rosbag2 directory holds metadata.yaml and .mcap files)"
    )]
    NoMcapInDirectory(PathBuf),
    /// The file does not start with the MCAP magic.
    #[error("{0} is not an MCAP file (it does not start with the MCAP magic bytes)")]
    NotMcap(PathBuf),
    /// A message of one type on a topic that already carries another.
    #[error(
        "cannot write a {type_name} on {topic} in {path}: the topic already carries {existing}"
    )]
    TopicType {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// The type of the message refused.
        type_name: String,
        /// The type the topic was created with.
        existing: String,
    },
}

/// Writes ROS 2 messages to an MCAP file.
pub struct BagWriter<W: Write + Seek> {
    path: PathBuf,
    writer: mcap::Writer<W>,
    schemas: BTreeMap<String, u16>,
    /// Topic → index in `channels`.
    topics: BTreeMap<String, usize>,
    channels: Vec<Channel>,
    /// Earliest and latest log time written, nanoseconds.
    time_range: Option<(u64, u64)>,
    journal: Option<Journal>,
}

/// One topic of a [`BagWriter`].
#[derive(Debug)]
struct Channel {
    /// The MCAP channel id.
    id: u16,
    topic: String,
    type_name: String,
    /// Messages written (the last one's MCAP sequence number, which wraps).
    messages: u64,
    /// The last message encoded for it: the bytes [`ros::cdr::encode_over`] writes the next
    /// message over.
    payload: Vec<u8>,
}

/// What a finished bag holds, per topic (for `metadata.yaml` and reports).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct BagStats {
    /// Per topic: (type name, message count).
    pub topics: BTreeMap<String, (String, u64)>,
    /// Earliest and latest log time, nanoseconds.
    pub time_range: Option<(u64, u64)>,
}

impl BagStats {
    /// Total messages.
    #[must_use]
    pub fn message_count(&self) -> u64 {
        self.topics.values().map(|(_, n)| n).sum()
    }
}

/// Every message and metadata record as the writer meant it, as JSON: the contract of the
/// interoperability checks (`tools/interop`), which decode the file with independent readers
/// and compare field by field.
#[derive(Debug, Clone, Default)]
struct Journal {
    messages: Vec<serde_json::Value>,
    metadata: Vec<serde_json::Value>,
}

impl std::fmt::Debug for BagWriter<FileSink> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagWriter")
            .field("path", &self.path)
            .field("topics", &self.topics)
            .finish_non_exhaustive()
    }
}

/// How a [`BagWriter`] lays out its file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteConfig {
    /// Chunk compression.
    pub compression: Compression,
    /// Target uncompressed chunk size, bytes.
    pub chunk_size_bytes: u64,
}

impl Default for WriteConfig {
    fn default() -> Self {
        WriteConfig {
            compression: Compression::Zstd,
            chunk_size_bytes: 256 * 1024,
        }
    }
}

/// The buffered file a [`BagWriter`] writes, knowing its own position.
///
/// The `mcap` writer asks for the stream position several times per chunk; `BufWriter` answers
/// that with a flush and an `lseek`, which made about ten small writes and fourteen `lseek` calls
/// per 256 KiB chunk. Here only real seeks (back to a chunk header and on to the end) reach the
/// file.
#[derive(Debug)]
pub struct FileSink {
    file: BufWriter<File>,
    position: u64,
}

impl FileSink {
    fn new(file: File) -> FileSink {
        FileSink {
            file: BufWriter::with_capacity(64 * 1024, file),
            position: 0,
        }
    }
}

impl Write for FileSink {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.file.write(buf)?;
        self.position += n as u64;
        Ok(n)
    }

    fn flush(&mut self) -> std::io::Result<()> {
        self.file.flush()
    }
}

impl Seek for FileSink {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        self.position = self.file.seek(pos)?;
        Ok(self.position)
    }

    fn stream_position(&mut self) -> std::io::Result<u64> {
        Ok(self.position)
    }
}

impl BagWriter<FileSink> {
    /// Creates (or truncates) `path`.
    ///
    /// # Errors
    /// [`McapIoError`] naming the file.
    pub fn create(path: &Path, config: WriteConfig) -> Result<Self, McapIoError> {
        let file = File::create(path).map_err(|source| McapIoError::Io {
            action: "cannot create",
            path: path.to_path_buf(),
            source,
        })?;
        BagWriter::new(FileSink::new(file), path, config)
    }
}

impl<W: Write + Seek> BagWriter<W> {
    /// Wraps a writer; `path` names it in errors.
    ///
    /// # Errors
    /// [`McapIoError::Mcap`] if the header cannot be written.
    pub fn new(w: W, path: &Path, config: WriteConfig) -> Result<Self, McapIoError> {
        let compression = match config.compression {
            Compression::Zstd => Some(mcap::Compression::Zstd),
            Compression::Lz4 => Some(mcap::Compression::Lz4),
            Compression::None => None,
        };
        let writer = mcap::WriteOptions::new()
            .profile("ros2")
            .library(LIBRARY)
            .compression(compression)
            .chunk_size(Some(config.chunk_size_bytes))
            .compression_threads(0)
            // Level 1: about twice as fast as zstd's default for ~10% more bytes; conversion
            // throughput is bounded by compression otherwise.
            .compression_level(1)
            .create(w)
            .map_err(|source| McapIoError::Mcap {
                action: "cannot start MCAP file",
                path: path.to_path_buf(),
                source,
            })?;
        Ok(BagWriter {
            path: path.to_path_buf(),
            writer,
            schemas: BTreeMap::new(),
            topics: BTreeMap::new(),
            channels: Vec::new(),
            time_range: None,
            journal: None,
        })
    }

    /// Keeps a JSON journal of everything written, for [`BagWriter::finish_with_journal`].
    pub fn keep_journal(&mut self) {
        self.journal = Some(Journal::default());
    }

    /// The channel of `topic` (an index into `channels`), created with `type_name`'s schema on
    /// first use (`definition` gives the schema text then).
    ///
    /// # Errors
    /// [`McapIoError::TopicType`] if the topic carries another type.
    fn channel_for(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: impl FnOnce() -> String,
    ) -> Result<usize, McapIoError> {
        if let Some(&k) = self.topics.get(topic) {
            let existing = &self.channels[k].type_name;
            if existing != type_name {
                return Err(McapIoError::TopicType {
                    path: self.path.clone(),
                    topic: topic.to_string(),
                    type_name: type_name.to_string(),
                    existing: existing.clone(),
                });
            }
            return Ok(k);
        }
        let schema_id = if let Some(&id) = self.schemas.get(type_name) {
            id
        } else {
            let id = self
                .writer
                .add_schema(type_name, "ros2msg", definition().as_bytes())
                .map_err(|source| McapIoError::Mcap {
                    action: "cannot add a schema to",
                    path: self.path.clone(),
                    source,
                })?;
            self.schemas.insert(type_name.to_string(), id);
            id
        };
        let mut metadata = BTreeMap::new();
        // Empty, as rosbags writes it: a QoS list here that differs from a rosbag2 directory's
        // metadata.yaml makes rosbags drop the channel.
        metadata.insert("offered_qos_profiles".to_string(), String::new());
        let id = self
            .writer
            .add_channel(schema_id, topic, "cdr", &metadata)
            .map_err(|source| McapIoError::Mcap {
                action: "cannot add a channel to",
                path: self.path.clone(),
                source,
            })?;
        self.topics.insert(topic.to_string(), self.channels.len());
        self.channels.push(Channel {
            id,
            topic: topic.to_string(),
            type_name: type_name.to_string(),
            messages: 0,
            payload: Vec::new(),
        });
        Ok(self.channels.len() - 1)
    }

    /// Appends one encoded message (CDR with its encapsulation header) to channel `k`.
    fn append(
        &mut self,
        k: usize,
        log_time_nanos: u64,
        publish_time_nanos: u64,
        payload: &[u8],
    ) -> Result<(), McapIoError> {
        let channel = &mut self.channels[k];
        channel.messages += 1;
        self.time_range = Some(match self.time_range {
            Some((a, b)) => (a.min(log_time_nanos), b.max(log_time_nanos)),
            None => (log_time_nanos, log_time_nanos),
        });
        let header = mcap::records::MessageHeader {
            channel_id: channel.id,
            // MCAP sequence numbers are 32 bits and may wrap.
            sequence: (channel.messages % (1 << 32)) as u32,
            log_time: log_time_nanos,
            publish_time: publish_time_nanos,
        };
        self.writer
            .write_to_known_channel(&header, payload)
            .map_err(|source| McapIoError::Mcap {
                action: "cannot write a message to",
                path: self.path.clone(),
                source,
            })
    }

    /// Writes a message that is already CDR (with its 4-byte encapsulation header), of ROS type
    /// `type_name` — as received from DDS, or read from another bag. `definition` gives its
    /// `.msg` text (rosbag2 form, dependencies included); it is called only for a new channel.
    ///
    /// # Errors
    /// [`McapIoError`] naming the file and topic.
    pub fn write_raw(
        &mut self,
        topic: &str,
        type_name: &str,
        definition: impl FnOnce() -> String,
        log_time_nanos: u64,
        publish_time_nanos: u64,
        cdr: &[u8],
    ) -> Result<(), McapIoError> {
        let k = self.channel_for(topic, type_name, definition)?;
        self.append(k, log_time_nanos, publish_time_nanos, cdr)
    }

    /// Ends the current chunk and hands everything written so far to the operating system, so
    /// that a crash after this point loses nothing before it.
    ///
    /// # Errors
    /// [`McapIoError::Mcap`] (e.g. a full disk).
    pub fn flush(&mut self) -> Result<(), McapIoError> {
        let path = self.path.clone();
        self.writer.flush().map_err(|source| McapIoError::Mcap {
            action: "cannot flush",
            path,
            source,
        })
    }

    /// Writes one message on `topic` at `log_time_nanos` (also its publish time).
    ///
    /// # Errors
    /// [`McapIoError`] naming the file and topic.
    pub fn write<M: RosMessage>(
        &mut self,
        topic: &str,
        log_time_nanos: u64,
        msg: &M,
    ) -> Result<(), McapIoError> {
        let k = self.channel_for(topic, M::TYPE_NAME, ros::definition_of::<M>)?;
        let mut payload = std::mem::take(&mut self.channels[k].payload);
        ros::cdr::encode_over(msg, &mut payload).map_err(|source| McapIoError::Encode {
            path: self.path.clone(),
            topic: topic.to_string(),
            type_name: M::TYPE_NAME,
            source,
        })?;
        if let Some(journal) = self.journal.as_mut() {
            journal.messages.push(serde_json::json!({
                "topic": topic,
                "schema": M::TYPE_NAME,
                "log_time": log_time_nanos,
                "publish_time": log_time_nanos,
                "message": serde_json::to_value(msg).unwrap_or(serde_json::Value::Null),
            }));
        }
        let result = self.append(k, log_time_nanos, log_time_nanos, &payload);
        self.channels[k].payload = payload;
        result
    }

    /// Writes a metadata record (e.g. the dataset label).
    ///
    /// # Errors
    /// [`McapIoError::Mcap`].
    pub fn write_metadata(
        &mut self,
        name: &str,
        metadata: BTreeMap<String, String>,
    ) -> Result<(), McapIoError> {
        if let Some(journal) = self.journal.as_mut() {
            journal
                .metadata
                .push(serde_json::json!({ "name": name, "metadata": metadata }));
        }
        let record = mcap::records::Metadata {
            name: name.to_string(),
            metadata,
        };
        let path = self.path.clone();
        self.writer
            .write_metadata(&record)
            .map_err(|source| McapIoError::Mcap {
                action: "cannot write metadata to",
                path,
                source,
            })
    }

    /// Writes the summary and footer, and returns what the file holds. Always call it: dropping
    /// a writer hides its errors.
    ///
    /// # Errors
    /// [`McapIoError::Mcap`] (e.g. a full disk).
    pub fn finish(mut self) -> Result<BagStats, McapIoError> {
        let path = self.path.clone();
        self.writer.finish().map_err(|source| McapIoError::Mcap {
            action: "cannot finish",
            path,
            source,
        })?;
        Ok(BagStats {
            topics: self
                .channels
                .iter()
                .filter(|c| c.messages > 0)
                .map(|c| (c.topic.clone(), (c.type_name.clone(), c.messages)))
                .collect(),
            time_range: self.time_range,
        })
    }

    /// Finishes the file and writes the journal (see [`BagWriter::keep_journal`]) to
    /// `journal_path` as `{"messages": [...], "metadata": [...]}`.
    ///
    /// # Errors
    /// As [`BagWriter::finish`], or [`McapIoError::Io`] for the journal.
    pub fn finish_with_journal(mut self, journal_path: &Path) -> Result<BagStats, McapIoError> {
        let journal = self.journal.take().unwrap_or_default();
        let stats = self.finish()?;
        let doc = serde_json::json!({ "messages": journal.messages, "metadata": journal.metadata });
        std::fs::write(journal_path, doc.to_string()).map_err(|source| McapIoError::Io {
            action: "cannot write",
            path: journal_path.to_path_buf(),
            source,
        })?;
        Ok(stats)
    }
}

/// Writes the `metadata.yaml` of a rosbag2 directory (format version 9, MCAP storage) whose
/// files are `files` (name in `dir`, and what it holds), in order — one for a bag, several for a
/// split recording — for ROS distributions whose `ros2 bag play` wants a directory.
///
/// # Errors
/// [`McapIoError::Io`].
pub fn write_rosbag2_metadata(dir: &Path, files: &[(String, BagStats)]) -> Result<(), McapIoError> {
    let mut topics_total: BTreeMap<&String, (&String, u64)> = BTreeMap::new();
    let mut range: Option<(u64, u64)> = None;
    for (_, stats) in files {
        for (topic, (type_name, n)) in &stats.topics {
            topics_total.entry(topic).or_insert((type_name, 0)).1 += n;
        }
        if let Some((a, b)) = stats.time_range {
            range = Some(range.map_or((a, b), |(x, y)| (x.min(a), y.max(b))));
        }
    }
    let (start, end) = range.unwrap_or((0, 0));
    let count: u64 = files.iter().map(|(_, s)| s.message_count()).sum();
    let mut topics = String::new();
    for (topic, (type_name, n)) in &topics_total {
        topics.push_str(&format!(
            "  - message_count: {n}\n    topic_metadata:\n      name: {topic}\n      offered_qos_profiles: []\n      serialization_format: cdr\n      type: {type_name}\n      type_description_hash: ''\n"
        ));
    }
    let mut relative = String::new();
    let mut entries = String::new();
    for (name, stats) in files {
        let (a, b) = stats.time_range.unwrap_or((start, start));
        relative.push_str(&format!("  - {name}\n"));
        entries.push_str(&format!(
            "  - path: {name}\n    starting_time:\n      nanoseconds_since_epoch: {a}\n    duration:\n      nanoseconds: {}\n    message_count: {}\n",
            b - a,
            stats.message_count()
        ));
    }
    let yaml = format!(
        "rosbag2_bagfile_information:\n  version: 9\n  storage_identifier: mcap\n  duration:\n    nanoseconds: {}\n  starting_time:\n    nanoseconds_since_epoch: {start}\n  message_count: {count}\n  topics_with_message_count:\n{topics}  compression_format: ''\n  compression_mode: ''\n  relative_file_paths:\n{relative}  files:\n{entries}  custom_data: {{}}\n  ros_distro: autoact\n",
        end - start
    );
    let path = dir.join("metadata.yaml");
    std::fs::write(&path, yaml).map_err(|source| McapIoError::Io {
        action: "cannot write",
        path,
        source,
    })
}

/// A schema as read from a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SchemaInfo {
    /// Type name, e.g. `autoact_msgs/msg/Skeleton3D`.
    pub name: String,
    /// Schema encoding, e.g. `ros2msg`.
    pub encoding: String,
    /// The definition text (or bytes).
    pub data: Vec<u8>,
}

/// A channel as read from a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChannelInfo {
    /// Channel id in the file.
    pub id: u16,
    /// Topic.
    pub topic: String,
    /// Message encoding, e.g. `cdr`.
    pub message_encoding: String,
    /// Its schema, if any.
    pub schema: Option<Arc<SchemaInfo>>,
}

impl ChannelInfo {
    /// The schema's type name, or `""`.
    #[must_use]
    pub fn schema_name(&self) -> &str {
        self.schema.as_ref().map_or("", |s| s.name.as_str())
    }
}

/// One message as read from a file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BagMessage {
    /// Its channel.
    pub channel: Arc<ChannelInfo>,
    /// Index of this message on its channel, counting from 0 in file order.
    pub index_on_channel: u64,
    /// Log time, nanoseconds.
    pub log_time: u64,
    /// Publish time, nanoseconds.
    pub publish_time: u64,
    /// The serialised payload.
    pub data: Vec<u8>,
}

/// Something that cost data while reading.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum ReadIssue {
    /// A chunk could not be used; reading goes on with the next one.
    #[error(
        "{path}: chunk {chunk} (messages logged {start_nanos}..={end_nanos} ns) is unreadable and was skipped: {reason}"
    )]
    CorruptChunk {
        /// The file.
        path: PathBuf,
        /// Chunk number, from 1.
        chunk: usize,
        /// First message time in the chunk.
        start_nanos: u64,
        /// Last message time in the chunk.
        end_nanos: u64,
        /// What was wrong.
        reason: String,
    },
    /// A message names a channel the file never defined.
    #[error(
        "{path}: a message at {log_time} ns is on channel id {channel_id}, which is not defined; skipped"
    )]
    UnknownChannel {
        /// The file.
        path: PathBuf,
        /// The channel id.
        channel_id: u16,
        /// The message's log time.
        log_time: u64,
    },
    /// The file ends early (or a record is damaged beyond recovery); nothing after it is read.
    #[error(
        "{path}: the file is cut short or damaged after {messages_read} messages ({reason}); nothing after that point could be read"
    )]
    Truncated {
        /// The file.
        path: PathBuf,
        /// Messages read before the cut.
        messages_read: u64,
        /// What the MCAP reader said.
        reason: String,
    },
}

/// A memory-mapped MCAP file.
pub struct BagReader {
    path: PathBuf,
    map: memmap2::Mmap,
}

impl std::fmt::Debug for BagReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagReader")
            .field("path", &self.path)
            .field("bytes", &self.map.len())
            .finish()
    }
}

impl BagReader {
    /// Opens and maps `path`.
    ///
    /// # Errors
    /// [`McapIoError`] for a missing, empty or non-MCAP file.
    pub fn open(path: &Path) -> Result<BagReader, McapIoError> {
        let file = File::open(path).map_err(|source| McapIoError::Io {
            action: "cannot open",
            path: path.to_path_buf(),
            source,
        })?;
        let len = file
            .metadata()
            .map_err(|source| McapIoError::Io {
                action: "cannot stat",
                path: path.to_path_buf(),
                source,
            })?
            .len();
        if len == 0 {
            return Err(McapIoError::Empty(path.to_path_buf()));
        }
        // SAFETY-free: memmap2's map is `unsafe` because another process could change the file
        // while mapped; autoact only reads, and a concurrently rewritten input is a user error
        // that at worst produces decode errors, which every caller handles.
        let map = map_file(&file).map_err(|source| McapIoError::Io {
            action: "cannot map",
            path: path.to_path_buf(),
            source,
        })?;
        if !map.starts_with(mcap::MAGIC) {
            return Err(McapIoError::NotMcap(path.to_path_buf()));
        }
        Ok(BagReader {
            path: path.to_path_buf(),
            map,
        })
    }

    /// Opens a bag given as a file, or as a rosbag2 directory: its `.mcap` files in name order
    /// (rosbag2 splits long recordings into several).
    ///
    /// # Errors
    /// As [`BagReader::open`], or [`McapIoError::NoMcapInDirectory`].
    pub fn open_all(path: &Path) -> Result<Vec<BagReader>, McapIoError> {
        if !path.is_dir() {
            return Ok(vec![BagReader::open(path)?]);
        }
        let entries = std::fs::read_dir(path).map_err(|source| McapIoError::Io {
            action: "cannot list",
            path: path.to_path_buf(),
            source,
        })?;
        let mut files: Vec<PathBuf> = entries
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
            .collect();
        files.sort();
        if files.is_empty() {
            return Err(McapIoError::NoMcapInDirectory(path.to_path_buf()));
        }
        files.iter().map(|f| BagReader::open(f)).collect()
    }

    /// The file's path.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The mapped bytes.
    #[must_use]
    pub fn bytes(&self) -> &[u8] {
        &self.map
    }

    /// First and last message log times, nanoseconds, from the summary's statistics (no message
    /// is read); `None` for a file without them (unfinished, or written without a summary).
    #[must_use]
    pub fn time_range(&self) -> Option<(u64, u64)> {
        let stats = mcap::read::Summary::read(&self.map).ok()??.stats?;
        (stats.message_count > 0).then_some((stats.message_start_time, stats.message_end_time))
    }

    /// The header's profile and library, if the header record is readable.
    #[must_use]
    pub fn header(&self) -> Option<(String, String)> {
        let mut records = mcap::read::LinearReader::new_with_options(
            &self.map,
            mcap::read::Options::IgnoreEndMagic.into(),
        )
        .ok()?;
        match records.next()? {
            Ok(mcap::records::Record::Header(h)) => Some((h.profile, h.library)),
            _ => None,
        }
    }

    /// Every metadata record, in file order (a pass over the top-level records that skips chunks
    /// undecompressed).
    #[must_use]
    pub fn metadata(&self) -> Vec<(String, BTreeMap<String, String>)> {
        let Ok(records) = mcap::read::LinearReader::new_with_options(
            &self.map,
            mcap::read::Options::IgnoreEndMagic.into(),
        ) else {
            return Vec::new();
        };
        let mut out = Vec::new();
        for record in records {
            match record {
                Ok(mcap::records::Record::Metadata(m)) => out.push((m.name, m.metadata)),
                Ok(mcap::records::Record::DataEnd(_)) | Err(_) => break,
                Ok(_) => {}
            }
        }
        out
    }

    /// Streams the messages in file order, with issues in place of what could not be read.
    #[must_use]
    pub fn messages(&self) -> Messages<'_> {
        let top = mcap::read::LinearReader::new_with_options(
            &self.map,
            mcap::read::Options::IgnoreEndMagic.into(),
        )
        .ok();
        Messages {
            path: &self.path,
            top,
            pending: VecDeque::new(),
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            counts: BTreeMap::new(),
            chunk: 0,
            read: 0,
            done: false,
        }
    }
}

impl BagReader {
    /// Drops the file's pages from this process's resident memory: a page touched again is read
    /// again (from the page cache, or the file). A long streaming read (`convert`) calls it now
    /// and then, so that its resident memory is what it holds, not the size of the file.
    #[cfg(unix)]
    pub fn release_pages(&self) {
        #[expect(
            unsafe_code,
            reason = "MADV_DONTNEED is `unsafe` in memmap2 because it zeroes private anonymous maps"
        )]
        // SAFETY: the map is a read-only, shared file mapping (`map_file`): MADV_DONTNEED only
        // unmaps its pages from this process, and the next access reads the same bytes back from
        // the file. Failing is harmless (the pages stay resident).
        let _ = unsafe {
            self.map
                .unchecked_advise(memmap2::UncheckedAdvice::DontNeed)
        };
    }
}

#[expect(
    unsafe_code,
    reason = "memory-mapping is the documented way to read MCAP without loading it; see BagReader::open"
)]
fn map_file(file: &File) -> std::io::Result<memmap2::Mmap> {
    // SAFETY: the map is read-only and only ever read through bounds-checked slices; a file
    // truncated underneath us is the one hazard, accepted as for every mmap-based reader.
    unsafe { memmap2::Mmap::map(file) }
}

/// The message stream of a [`BagReader`].
pub struct Messages<'a> {
    path: &'a Path,
    top: Option<mcap::read::LinearReader<'a>>,
    pending: VecDeque<Result<BagMessage, ReadIssue>>,
    schemas: BTreeMap<u16, Arc<SchemaInfo>>,
    channels: BTreeMap<u16, Arc<ChannelInfo>>,
    counts: BTreeMap<u16, u64>,
    chunk: usize,
    read: u64,
    done: bool,
}

impl std::fmt::Debug for Messages<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Messages")
            .field("path", &self.path)
            .field("read", &self.read)
            .finish_non_exhaustive()
    }
}

/// Largest chunk autoact will decompress (a guard against a corrupt size field).
const MAX_CHUNK_BYTES: u64 = 1 << 30;

impl Messages<'_> {
    fn take_record(&mut self, record: mcap::records::Record<'_>) {
        use mcap::records::Record;
        match record {
            Record::Schema { header, data } => {
                let info = SchemaInfo {
                    name: header.name,
                    encoding: header.encoding,
                    data: data.into_owned(),
                };
                self.schemas.insert(header.id, Arc::new(info));
            }
            Record::Channel(c) => {
                let info = ChannelInfo {
                    id: c.id,
                    topic: c.topic,
                    message_encoding: c.message_encoding,
                    schema: self.schemas.get(&c.schema_id).cloned(),
                };
                self.channels.insert(c.id, Arc::new(info));
            }
            Record::Message { header, data } => {
                let item = match self.channels.get(&header.channel_id) {
                    Some(channel) => {
                        let count = self.counts.entry(header.channel_id).or_insert(0);
                        let index_on_channel = *count;
                        *count += 1;
                        self.read += 1;
                        Ok(BagMessage {
                            channel: Arc::clone(channel),
                            index_on_channel,
                            log_time: header.log_time,
                            publish_time: header.publish_time,
                            data: data.into_owned(),
                        })
                    }
                    None => Err(ReadIssue::UnknownChannel {
                        path: self.path.to_path_buf(),
                        channel_id: header.channel_id,
                        log_time: header.log_time,
                    }),
                };
                self.pending.push_back(item);
            }
            _ => {}
        }
    }

    fn take_chunk(&mut self, header: &mcap::records::ChunkHeader, data: &[u8]) {
        self.chunk += 1;
        let corrupt = |reason: String| ReadIssue::CorruptChunk {
            path: self.path.to_path_buf(),
            chunk: self.chunk,
            start_nanos: header.message_start_time,
            end_nanos: header.message_end_time,
            reason,
        };
        if header.uncompressed_size > MAX_CHUNK_BYTES {
            self.pending.push_back(Err(corrupt(format!(
                "declared size {} bytes is implausible",
                header.uncompressed_size
            ))));
            return;
        }
        let decompressed = match decompress(&header.compression, data, header.uncompressed_size) {
            Ok(d) => d,
            Err(reason) => {
                self.pending.push_back(Err(corrupt(reason.to_string())));
                return;
            }
        };
        if header.uncompressed_crc != 0 {
            let crc = crc32fast::hash(&decompressed);
            if crc != header.uncompressed_crc {
                self.pending.push_back(Err(corrupt(format!(
                    "CRC mismatch (stored {:08x}, computed {crc:08x})",
                    header.uncompressed_crc
                ))));
                return;
            }
        }
        // Parse everything first, so a damaged record inside a CRC-less chunk drops the whole
        // chunk rather than half of it silently.
        let records: Result<Vec<_>, _> =
            mcap::read::LinearReader::sans_magic(&decompressed).collect();
        match records {
            Ok(records) => {
                for r in records {
                    self.take_record(r);
                }
            }
            Err(e) => self.pending.push_back(Err(corrupt(e.to_string()))),
        }
    }
}

/// Why a chunk does not decompress (its text becomes the chunk's [`ReadIssue`] reason).
#[derive(Debug, thiserror::Error)]
enum DecompressError {
    /// A declared size beyond this machine's address space.
    #[error("{0}")]
    Size(#[source] std::num::TryFromIntError),
    /// zstd refused the data.
    #[error("zstd: {0}")]
    Zstd(#[source] std::io::Error),
    /// lz4 refused the data.
    #[error("lz4: {0}")]
    Lz4(#[source] std::io::Error),
    /// A compression MCAP readers need not know.
    #[error("unsupported compression `{0}`")]
    Unsupported(String),
    /// Data of another size than the chunk declares.
    #[error("decompressed to {actual} bytes, the chunk says {declared}")]
    Length {
        /// Bytes decompressed.
        actual: usize,
        /// Bytes the chunk declares.
        declared: usize,
    },
}

fn decompress(compression: &str, data: &[u8], size: u64) -> Result<Vec<u8>, DecompressError> {
    let size = usize::try_from(size).map_err(DecompressError::Size)?;
    let out = match compression {
        "" => data.to_vec(),
        "zstd" => zstd::bulk::decompress(data, size).map_err(DecompressError::Zstd)?,
        "lz4" => {
            let mut out = Vec::with_capacity(size);
            let mut decoder = lz4::Decoder::new(data).map_err(DecompressError::Lz4)?;
            std::io::copy(&mut decoder, &mut out).map_err(DecompressError::Lz4)?;
            out
        }
        other => return Err(DecompressError::Unsupported(other.to_string())),
    };
    if out.len() == size {
        Ok(out)
    } else {
        Err(DecompressError::Length {
            actual: out.len(),
            declared: size,
        })
    }
}

impl Iterator for Messages<'_> {
    type Item = Result<BagMessage, ReadIssue>;

    fn next(&mut self) -> Option<Self::Item> {
        use mcap::records::Record;
        loop {
            if let Some(item) = self.pending.pop_front() {
                return Some(item);
            }
            if self.done {
                return None;
            }
            let Some(top) = self.top.as_mut() else {
                self.done = true;
                return Some(Err(ReadIssue::Truncated {
                    path: self.path.to_path_buf(),
                    messages_read: 0,
                    reason: "no readable header".into(),
                }));
            };
            match top.next() {
                None | Some(Ok(Record::DataEnd(_) | Record::Footer(_))) => self.done = true,
                Some(Ok(Record::Chunk { header, data })) => self.take_chunk(&header, &data),
                Some(Ok(record)) => self.take_record(record),
                Some(Err(e)) => {
                    self.done = true;
                    return Some(Err(ReadIssue::Truncated {
                        path: self.path.to_path_buf(),
                        messages_read: self.read,
                        reason: e.to_string(),
                    }));
                }
            }
        }
    }
}

pub mod recover;

#[cfg(test)]
#[path = "mcap_io_tests.rs"]
mod tests;
