//! MCAP files: the one writer preset and the one streaming reader.
//!
//! **Writing** ([`BagWriter`]): profile `ros2`, schema encoding `ros2msg` (definitions from
//! [`crate::ros::definition`]), message encoding `cdr`, chunked (zstd by default; lz4 or none),
//! with message indexes, chunk indexes, statistics and summary, and `library` stamped
//! `autoact <version>`. Compression runs single-threaded so the same input gives byte-identical
//! files on any machine; with [`WriteConfig::writer_thread`] that one thread is not the caller's
//! (`mcap_io/writer_thread.rs`), and the file is still the same. Schemas and channels are
//! registered on first use, in that order.
//!
//! **Reading** ([`BagReader`], in `mcap_io/read.rs`): the file is memory-mapped, never loaded;
//! records are framed and parsed by autoact itself (`mcap_io/records.rs`), every length checked
//! against the bytes that are there before anything is allocated, and streamed in file order.
//! Each chunk is decompressed and CRC-checked on its own, so a corrupt chunk costs only its own
//! messages ([`ReadIssue::CorruptChunk`]); a damaged length is skipped to the next record that
//! frames, through the summary's chunk index or by scanning ([`ReadIssue::Damaged`]). A file
//! that ends mid-record yields everything before the cut, then [`ReadIssue::Truncated`]; one
//! that ends between records without its summary was never finished ([`ReadIssue::NoSummary`]).
//! Every issue is lost input.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use crate::ros::{self, RosMessage};
use writer_thread::{Failure, WriterThread};

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
    /// A directory where one MCAP file is wanted.
    #[error("{0} is a directory, not an MCAP file")]
    IsDirectory(PathBuf),
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
    writer: Records<W>,
    schemas: BTreeMap<String, u16>,
    /// Type name → its RIHS01 type description hash (empty if its schema text does not give one).
    type_hashes: BTreeMap<String, String>,
    /// Topic → index in `channels`.
    topics: BTreeMap<String, usize>,
    channels: Vec<Channel>,
    /// Earliest and latest log time written, nanoseconds.
    time_range: Option<(u64, u64)>,
    journal: Option<Journal>,
}

/// The `mcap` writer's calls as a [`BagWriter`] makes them, each failure with its action; on
/// the caller's thread, or on the writer's own (`mcap_io/writer_thread.rs`).
struct Inline<W: Write + Seek>(mcap::Writer<W>);

impl<W: Write + Seek> Inline<W> {
    fn add_schema(&mut self, name: &str, data: &[u8]) -> Result<u16, Failure> {
        self.0
            .add_schema(name, "ros2msg", data)
            .map_err(|e| ("cannot add a schema to", e))
    }

    fn add_channel(
        &mut self,
        schema_id: u16,
        topic: &str,
        metadata: &BTreeMap<String, String>,
    ) -> Result<u16, Failure> {
        self.0
            .add_channel(schema_id, topic, "cdr", metadata)
            .map_err(|e| ("cannot add a channel to", e))
    }

    fn write_to_known_channel(
        &mut self,
        header: &mcap::records::MessageHeader,
        payload: &[u8],
    ) -> Result<(), Failure> {
        self.0
            .write_to_known_channel(header, payload)
            .map_err(|e| ("cannot write a message to", e))
    }

    fn write_metadata(&mut self, record: &mcap::records::Metadata) -> Result<(), Failure> {
        self.0
            .write_metadata(record)
            .map_err(|e| ("cannot write metadata to", e))
    }

    fn flush(&mut self) -> Result<(), Failure> {
        self.0.flush().map_err(|e| ("cannot flush", e))
    }

    fn finish(&mut self) -> Result<(), Failure> {
        self.0.finish().map(drop).map_err(|e| ("cannot finish", e))
    }
}

/// The `mcap` writer of a [`BagWriter`]: on the caller's thread, or on its own.
enum Records<W: Write + Seek> {
    Here(Box<Inline<W>>),
    Thread(WriterThread),
}

impl<W: Write + Seek> Records<W> {
    fn add_schema(&mut self, name: &str, data: &[u8]) -> Result<u16, Failure> {
        match self {
            Records::Here(w) => w.add_schema(name, data),
            Records::Thread(t) => t.add_schema(name, data),
        }
    }

    fn add_channel(
        &mut self,
        schema_id: u16,
        topic: &str,
        metadata: &BTreeMap<String, String>,
    ) -> Result<u16, Failure> {
        match self {
            Records::Here(w) => w.add_channel(schema_id, topic, metadata),
            Records::Thread(t) => t.add_channel(schema_id, topic, metadata),
        }
    }

    fn write_to_known_channel(
        &mut self,
        header: &mcap::records::MessageHeader,
        payload: &[u8],
    ) -> Result<(), Failure> {
        match self {
            Records::Here(w) => w.write_to_known_channel(header, payload),
            Records::Thread(t) => t.write_to_known_channel(header, payload),
        }
    }

    fn write_metadata(&mut self, record: mcap::records::Metadata) -> Result<(), Failure> {
        match self {
            Records::Here(w) => w.write_metadata(&record),
            Records::Thread(t) => t.write_metadata(record),
        }
    }

    fn flush(&mut self) -> Result<(), Failure> {
        match self {
            Records::Here(w) => w.flush(),
            Records::Thread(t) => t.flush(),
        }
    }

    fn finish(&mut self) -> Result<(), Failure> {
        match self {
            Records::Here(w) => w.finish(),
            Records::Thread(t) => t.finish(),
        }
    }
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
    /// Per type name of those topics: its RIHS01 type description hash, computed from the schema
    /// text written ([`ros::type_hash::rihs01`]; empty when the text does not give one).
    pub type_hashes: BTreeMap<String, String>,
    /// Earliest and latest log time, nanoseconds.
    pub time_range: Option<(u64, u64)>,
}

impl BagStats {
    /// Total messages.
    #[must_use]
    pub fn message_count(&self) -> u64 {
        self.topics.values().map(|(_, n)| n).sum()
    }

    /// Adds what `other` holds (another file of the same recording): message counts per topic,
    /// type hashes (the first file's for a type both have), the union of the time ranges.
    pub fn merge(&mut self, other: &BagStats) {
        for (topic, (type_name, n)) in &other.topics {
            let entry = self.topics.entry(topic.clone());
            entry.or_insert_with(|| (type_name.clone(), 0)).1 += n;
        }
        for (type_name, hash) in &other.type_hashes {
            let entry = self.type_hashes.entry(type_name.clone());
            entry.or_insert_with(|| hash.clone());
        }
        if let Some((a, b)) = other.time_range {
            let range = self
                .time_range
                .map_or((a, b), |(x, y)| (x.min(a), y.max(b)));
            self.time_range = Some(range);
        }
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
    /// Compress and write on a thread of its own, beside the caller's (the file is the same).
    /// For a producer on one thread when another core is free: `convert`'s whole-body output
    /// spends a third of its time in compression.
    pub writer_thread: bool,
}

impl Default for WriteConfig {
    fn default() -> Self {
        WriteConfig {
            compression: Compression::Zstd,
            chunk_size_bytes: 256 * 1024,
            writer_thread: false,
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
        BagWriter::create_as(path, path, config)
    }

    /// Creates (or truncates) `path`, a temporary file, naming `name` (the output it becomes)
    /// in every error.
    ///
    /// # Errors
    /// [`McapIoError`] naming `name`.
    pub fn create_as(path: &Path, name: &Path, config: WriteConfig) -> Result<Self, McapIoError> {
        let file = File::create(path).map_err(|source| McapIoError::Io {
            action: "cannot create",
            path: name.to_path_buf(),
            source,
        })?;
        BagWriter::new(FileSink::new(file), name, config)
    }
}

impl<W: Write + Seek + Send + 'static> BagWriter<W> {
    /// Wraps a writer; `path` names it in errors.
    ///
    /// # Errors
    /// [`McapIoError::Mcap`] if the header cannot be written, [`McapIoError::Io`] if the
    /// writer's thread cannot be started.
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
        let writer = Inline(writer);
        let writer = if config.writer_thread {
            let thread = WriterThread::spawn(writer).map_err(|source| McapIoError::Io {
                action: "cannot start the writer thread of",
                path: path.to_path_buf(),
                source,
            })?;
            Records::Thread(thread)
        } else {
            Records::Here(Box::new(writer))
        };
        Ok(BagWriter {
            path: path.to_path_buf(),
            writer,
            schemas: BTreeMap::new(),
            type_hashes: BTreeMap::new(),
            topics: BTreeMap::new(),
            channels: Vec::new(),
            time_range: None,
            journal: None,
        })
    }
}

impl<W: Write + Seek> BagWriter<W> {
    /// [`McapIoError::Mcap`] for what the `mcap` writer refused.
    fn failed(&self, (action, source): Failure) -> McapIoError {
        McapIoError::Mcap {
            action,
            path: self.path.clone(),
            source,
        }
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
            let text = definition();
            let hash = ros::type_hash::rihs01(type_name, &text).unwrap_or_default();
            self.type_hashes.insert(type_name.to_string(), hash);
            let id = self
                .writer
                .add_schema(type_name, text.as_bytes())
                .map_err(|f| self.failed(f))?;
            self.schemas.insert(type_name.to_string(), id);
            id
        };
        let mut metadata = BTreeMap::new();
        // Empty, as rosbags writes it: a QoS list here that differs from a rosbag2 directory's
        // metadata.yaml makes rosbags drop the channel.
        metadata.insert("offered_qos_profiles".to_string(), String::new());
        let id = self
            .writer
            .add_channel(schema_id, topic, &metadata)
            .map_err(|f| self.failed(f))?;
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
            .map_err(|f| self.failed(f))
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
        self.writer.flush().map_err(|f| self.failed(f))
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
        self.writer
            .write_metadata(record)
            .map_err(|f| self.failed(f))
    }

    /// Writes the summary and footer, and returns what the file holds. Always call it: dropping
    /// a writer hides its errors.
    ///
    /// # Errors
    /// [`McapIoError::Mcap`] (e.g. a full disk).
    pub fn finish(mut self) -> Result<BagStats, McapIoError> {
        self.writer.finish().map_err(|f| self.failed(f))?;
        let written = || self.channels.iter().filter(|c| c.messages > 0);
        Ok(BagStats {
            topics: written()
                .map(|c| (c.topic.clone(), (c.type_name.clone(), c.messages)))
                .collect(),
            type_hashes: written()
                .map(|c| {
                    let hash = self.type_hashes.get(&c.type_name).cloned();
                    (c.type_name.clone(), hash.unwrap_or_default())
                })
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

mod read;
mod records;
mod rosbag2;
mod writer_thread;

pub use read::{
    BagMessage, BagReader, ChannelInfo, Messages, ReadIssue, SchemaInfo, mcap_files_in,
};
pub use rosbag2::{Rosbag2Version, write_rosbag2_metadata};

#[cfg(test)]
#[path = "mcap_io_tests.rs"]
mod tests;
