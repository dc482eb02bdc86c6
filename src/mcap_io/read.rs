//! The one streaming MCAP reader: a memory-mapped file, walked record by record by autoact's
//! own framing ([`super::records`]), so that no length read from the file is trusted before it is
//! checked against the bytes that are there.
//!
//! A corrupt chunk costs only its own messages ([`ReadIssue::CorruptChunk`], with the count its
//! message index lists). A record whose length is damaged is skipped, and reading resumes at the
//! next record: through the summary's chunk index when the summary is intact, else at the next
//! position where a record frames and parses ([`ReadIssue::Damaged`]). A file that ends inside a
//! record yields everything before the cut ([`ReadIssue::Truncated`]); one that ends between
//! records but before its data-end record and summary was not finished
//! ([`ReadIssue::NoSummary`]): all four are lost input.

use std::borrow::Cow;
use std::collections::{BTreeMap, VecDeque};
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::McapIoError;
use super::records::{self, Framed, op};

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
    /// Index of this message on its channel, counting from 0 in file order; messages of a lost
    /// chunk are counted too where its message index says how many there were.
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
        "{path}: chunk {chunk} (byte {offset}, messages logged {start_nanos}..={end_nanos} ns) is unreadable and was skipped: {reason}; {}",
        lost_messages(*messages)
    )]
    CorruptChunk {
        /// The file.
        path: PathBuf,
        /// Chunk number, from 1, in file order.
        chunk: usize,
        /// Where the chunk record starts, bytes from the start of the file.
        offset: u64,
        /// First message time in the chunk.
        start_nanos: u64,
        /// Last message time in the chunk.
        end_nanos: u64,
        /// Messages the chunk held, as its message index lists them (`None`: unknown).
        messages: Option<u64>,
        /// What was wrong.
        reason: Box<str>,
    },
    /// Bytes whose records could not be framed (a damaged length, garbage): skipped up to the
    /// next record that frames and parses, where reading resumed.
    #[error(
        "{path}: bytes {from_byte}..{to_byte} are damaged and were skipped ({reason}); {}; reading resumed at byte {to_byte}",
        lost_messages(*messages)
    )]
    Damaged {
        /// The file.
        path: PathBuf,
        /// First damaged byte.
        from_byte: u64,
        /// Where reading resumed.
        to_byte: u64,
        /// Messages in the chunks skipped, as their message indexes list them (`None`: unknown).
        messages: Option<u64>,
        /// What was wrong.
        reason: Box<str>,
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
    /// The file ends between two records, before its data-end record and summary: the writer
    /// never finished it (a crash, `kill -9`, a full disk), so whatever it wrote after its last
    /// complete record is lost, and how much that was is unknown.
    #[error(
        "{path}: file ends without a summary: {messages_read} messages recovered (it was never finished — a crash, kill -9 or a full disk; whatever came after its last complete chunk is lost; `autoact recover` rewrites it whole)"
    )]
    NoSummary {
        /// The file.
        path: PathBuf,
        /// Messages read.
        messages_read: u64,
    },
}

/// How a loss report reads the messages lost: "its index lists 37 messages".
fn lost_messages(messages: Option<u64>) -> String {
    match messages {
        Some(n) => format!("its message index lists {n} messages"),
        None => "how many messages it held is unknown (message numbers after it count only the messages read)".to_string(),
    }
}

/// What the summary section gives a reader: the schemas and channels (for messages whose
/// definitions were in a lost chunk), the chunk index (to resume after damage), statistics.
#[derive(Debug, Default)]
struct Summary {
    schemas: BTreeMap<u16, Arc<SchemaInfo>>,
    /// Channel id → (schema id, topic, message encoding).
    channels: BTreeMap<u16, (u16, String, String)>,
    /// Chunk start offsets with their message index offsets, in file order.
    chunks: Vec<records::ChunkIndex>,
    /// Message count, first and last log time.
    statistics: Option<(u64, u64, u64)>,
}

impl Summary {
    /// The summary of a finished file: its footer (before the closing magic) and the records from
    /// the footer's summary start on; `None` without an intact footer. Records after a damaged one
    /// are ignored.
    fn read(bytes: &[u8]) -> Option<Summary> {
        let magic = mcap::MAGIC.len();
        let footer_at = bytes.len().checked_sub(magic + records::FRAME_BYTES + 20)?;
        if !bytes.ends_with(mcap::MAGIC) || footer_at < magic {
            return None;
        }
        let footer = records::frame_at(&bytes[..bytes.len() - magic], footer_at).ok()??;
        if footer.opcode != op::FOOTER || footer.body.len() != 20 {
            return None;
        }
        let start = usize::try_from(records::footer(footer.body).ok()?).ok()?;
        let mut summary = Summary::default();
        if start == 0 || start < magic || start > footer_at {
            return Some(summary);
        }
        let section = &bytes[..footer_at];
        let mut at = start;
        while let Ok(Some(Framed { opcode, body })) = records::frame_at(section, at) {
            at += records::FRAME_BYTES + body.len();
            if summary.take(opcode, body).is_err() {
                break;
            }
        }
        summary.chunks.sort_by_key(|c| c.chunk_start_offset);
        Some(summary)
    }

    fn take(&mut self, opcode: u8, body: &[u8]) -> Result<(), records::ParseError> {
        match opcode {
            op::SCHEMA => {
                let s = records::schema(body)?;
                self.schemas.insert(s.id, Arc::new(SchemaInfo::from(&s)));
            }
            op::CHANNEL => {
                let c = records::channel(body)?;
                let entry = (c.schema_id, c.topic.to_string(), c.message_encoding.into());
                self.channels.insert(c.id, entry);
            }
            op::CHUNK_INDEX => self.chunks.push(records::chunk_index(body)?),
            op::STATISTICS => self.statistics = Some(records::statistics(body)?),
            _ => {}
        }
        Ok(())
    }
}

impl From<&records::Schema<'_>> for SchemaInfo {
    fn from(s: &records::Schema<'_>) -> SchemaInfo {
        SchemaInfo {
            name: s.name.to_string(),
            encoding: s.encoding.to_string(),
            data: s.data.to_vec(),
        }
    }
}

/// A memory-mapped MCAP file.
pub struct BagReader {
    path: PathBuf,
    map: memmap2::Mmap,
    summary: Option<Summary>,
}

impl std::fmt::Debug for BagReader {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("BagReader")
            .field("path", &self.path)
            .field("bytes", &self.map.len())
            .finish_non_exhaustive()
    }
}

impl BagReader {
    /// Opens and maps `path`.
    ///
    /// # Errors
    /// [`McapIoError`] for a missing, empty or non-MCAP file, or a directory.
    pub fn open(path: &Path) -> Result<BagReader, McapIoError> {
        if path.is_dir() {
            return Err(McapIoError::IsDirectory(path.to_path_buf()));
        }
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
        let map = map_file(&file).map_err(|source| McapIoError::Io {
            action: "cannot map",
            path: path.to_path_buf(),
            source,
        })?;
        if !map.starts_with(mcap::MAGIC) {
            return Err(McapIoError::NotMcap(path.to_path_buf()));
        }
        let summary = Summary::read(&map);
        Ok(BagReader {
            path: path.to_path_buf(),
            map,
            summary,
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
        mcap_files_in(path)?
            .iter()
            .map(|f| BagReader::open(f))
            .collect()
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
        let (count, start, end) = self.summary.as_ref()?.statistics?;
        (count > 0).then_some((start, end))
    }

    /// First and last message log times, nanoseconds: from the summary's statistics where the
    /// file has them, else from the messages themselves (a pass over every readable one, for an
    /// unfinished file); `None` when no message is readable.
    #[must_use]
    pub fn time_range_or_scan(&self) -> Option<(u64, u64)> {
        if let Some(range) = self.time_range() {
            return Some(range);
        }
        self.messages()
            .filter_map(Result::ok)
            .map(|m| (m.log_time, m.log_time))
            .reduce(|(a, b), (x, y)| (a.min(x), b.max(y)))
    }

    /// Whether the file ends with a summary holding chunk indexes (what indexed readers, e.g.
    /// Foxglove's, need).
    #[must_use]
    pub fn has_chunk_index(&self) -> bool {
        self.summary.as_ref().is_some_and(|s| !s.chunks.is_empty())
    }

    /// The header's profile and library, if the header record is readable.
    #[must_use]
    pub fn header(&self) -> Option<(String, String)> {
        let framed = records::frame_at(&self.map, mcap::MAGIC.len()).ok()??;
        (framed.opcode == op::HEADER)
            .then(|| records::header(framed.body).ok())
            .flatten()
    }

    /// Every readable metadata record, in file order (a pass over the top-level records that
    /// skips chunks undecompressed).
    #[must_use]
    pub fn metadata(&self) -> Vec<(String, BTreeMap<String, String>)> {
        let mut walker = Walker::new(&self.map, self.summary.as_ref());
        let mut out = Vec::new();
        // The walk touches every record's header across the whole file: give its pages back as
        // it goes, so that a long bag does not become resident at once (a 233 MB bag did).
        let mut released_at = 0;
        while let Some(step) = walker.next() {
            self.release_walked(walker.at, &mut released_at);
            if let Step::Record {
                framed: Framed { opcode, body },
                ..
            } = step
                && opcode == op::METADATA
                && let Ok(m) = records::metadata(body)
            {
                out.push(m);
            }
        }
        out
    }

    /// Streams the messages in file order, with issues in place of what could not be read.
    /// The pages read are given back every few megabytes ([`BagReader::release_pages`]), so a
    /// whole-file pass keeps resident what it holds, not the file.
    #[must_use]
    pub fn messages(&self) -> Messages<'_> {
        Messages {
            reader: self,
            walker: Walker::new(&self.map, self.summary.as_ref()),
            summary: self.summary.as_ref(),
            window: None,
            pending: VecDeque::new(),
            held: None,
            count_indexes: false,
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            counts: BTreeMap::new(),
            chunk: 0,
            read: 0,
            released_at: 0,
            done: false,
        }
    }

    /// The messages logged within `log_times` (inclusive), in file order, with every issue met
    /// on the way: the messages of a full [`BagReader::messages`] pass in that range, with the
    /// same indexes on their channels. A file with a summary skips, undecompressed, every chunk
    /// its chunk index places outside the range (its messages still counted from its message
    /// indexes); a file without one is read whole and filtered.
    #[must_use]
    pub fn messages_where(&self, log_times: std::ops::RangeInclusive<u64>) -> Messages<'_> {
        Messages {
            window: Some(log_times),
            ..self.messages()
        }
    }
}

/// The `.mcap` files of a directory, in name order.
///
/// # Errors
/// [`McapIoError::Io`], or [`McapIoError::NoMcapInDirectory`].
pub fn mcap_files_in(dir: &Path) -> Result<Vec<PathBuf>, McapIoError> {
    let entries = std::fs::read_dir(dir).map_err(|source| McapIoError::Io {
        action: "cannot list",
        path: dir.to_path_buf(),
        source,
    })?;
    let mut files: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "mcap") && p.is_file())
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(McapIoError::NoMcapInDirectory(dir.to_path_buf()));
    }
    Ok(files)
}

/// How far a whole-file walk goes between two [`BagReader::release_pages`].
const RELEASE_EVERY_BYTES: usize = 4 << 20;

impl BagReader {
    /// Gives the pages back when a walk now at byte `at` has gone [`RELEASE_EVERY_BYTES`] since
    /// `released_at` (then moved to `at`): how every walk over the file keeps it from becoming
    /// resident.
    fn release_walked(&self, at: usize, released_at: &mut usize) {
        #[cfg(unix)]
        if at.saturating_sub(*released_at) >= RELEASE_EVERY_BYTES {
            self.release_pages();
            *released_at = at;
        }
    }

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

/// One step of a [`Walker`].
#[derive(Debug)]
enum Step<'a> {
    /// A record that frames, starting at byte `at`.
    Record { at: usize, framed: Framed<'a> },
    /// Bytes `at..resumed` could not be framed; the record at `resumed` frames and parses.
    Damaged {
        at: usize,
        resumed: usize,
        reason: String,
    },
    /// A record runs past the end of the file, and nothing after it frames.
    Cut { reason: String },
    /// The end of the file, before any data-end record or footer.
    Unfinished,
}

/// Walks the top-level records of the data section, resuming after damage.
struct Walker<'a> {
    bytes: &'a [u8],
    /// Start offsets of the chunks the summary indexes, in order.
    chunk_starts: Vec<usize>,
    at: usize,
    done: bool,
}

impl<'a> Walker<'a> {
    fn new(bytes: &'a [u8], summary: Option<&Summary>) -> Walker<'a> {
        let chunk_starts = summary
            .map(|s| {
                s.chunks
                    .iter()
                    .filter_map(|c| usize::try_from(c.chunk_start_offset).ok())
                    .collect()
            })
            .unwrap_or_default();
        Walker {
            bytes,
            chunk_starts,
            at: mcap::MAGIC.len(),
            done: false,
        }
    }

    /// The next record, or what went wrong; `None` after the data section's end (or the file's).
    fn next(&mut self) -> Option<Step<'a>> {
        if self.done {
            return None;
        }
        let at = self.at;
        let reason = match records::frame_at(self.bytes, at) {
            Ok(None) => {
                self.done = true;
                return Some(Step::Unfinished);
            }
            Ok(Some(framed))
                if framed.opcode == op::CHUNK
                    && let Err(e) = records::chunk(framed.body) =>
            {
                format!("a chunk record at byte {at} does not parse: {e}")
            }
            Ok(Some(framed)) if defined(framed.opcode) || framed.opcode >= 0x80 => {
                if matches!(framed.opcode, op::DATA_END | op::FOOTER) {
                    self.done = true;
                    return None;
                }
                self.at = at + records::FRAME_BYTES + record_len(framed);
                return Some(Step::Record { at, framed });
            }
            Ok(Some(framed)) => format!(
                "byte {at} holds opcode {:#04x}, which no MCAP record has",
                framed.opcode
            ),
            Err(None) => format!(
                "the file ends {} bytes into a record's opcode and length",
                self.bytes.len() - at
            ),
            Err(Some(declared)) => format!(
                "{} record at byte {at} declares {declared} bytes, {} are left in the file",
                opcode_name(self.bytes[at]),
                self.bytes.len() - at - records::FRAME_BYTES
            ),
        };
        if let Some(resumed) = self.resume_after(at) {
            self.at = resumed;
            return Some(Step::Damaged {
                at,
                resumed,
                reason,
            });
        }
        self.done = true;
        Some(Step::Cut { reason })
    }

    /// Where reading resumes after damage at `at`: the first record after it that frames and
    /// parses, found through the chunk index (where the summary has one) or by scanning forward.
    fn resume_after(&self, at: usize) -> Option<usize> {
        let indexed = self
            .chunk_starts
            .iter()
            .copied()
            .filter(|&c| c > at)
            .find(|&c| plausible_at(self.bytes, c, true));
        // A damaged chunk the index knows is skipped whole (scanning it could take the records
        // of an uncompressed chunk for top-level ones, and count its messages twice).
        if indexed.is_some() && self.chunk_starts.contains(&at) {
            return indexed;
        }
        let scan_end = indexed.unwrap_or(self.bytes.len());
        (at + 1..scan_end)
            .find(|&p| plausible_at(self.bytes, p, false))
            .or(indexed)
    }
}

/// Whether a chunk record frames and parses at `at` (where an index says one is).
fn frames_as_chunk(bytes: &[u8], at: usize) -> bool {
    matches!(records::frame_at(bytes, at), Ok(Some(f)) if f.opcode == op::CHUNK && records::chunk(f.body).is_ok())
}

/// Whether the specification defines `opcode`.
fn defined(opcode: u8) -> bool {
    (1..=op::LAST_DEFINED).contains(&opcode)
}

/// The bytes of a record's body that its fields use: for a chunk, up to the end of its records
/// (a chunk whose length field says more is read up to there, so an inflated length swallows
/// nothing after it); for every other record, its declared length.
fn record_len(framed: Framed<'_>) -> usize {
    if framed.opcode == op::CHUNK
        && let Ok(chunk) = records::chunk(framed.body)
    {
        let end = chunk.records.as_ptr() as usize + chunk.records.len();
        return end - framed.body.as_ptr() as usize;
    }
    framed.body.len()
}

/// Whether a record that can start the rest of a data section frames and parses at `at`, and
/// the bytes after it frame too (or are the end of the file). `chunk_only`: only a chunk will do.
fn plausible_at(bytes: &[u8], at: usize, chunk_only: bool) -> bool {
    let opcode = bytes[at];
    let wanted = if chunk_only {
        opcode == op::CHUNK
    } else {
        matches!(
            opcode,
            op::SCHEMA
                | op::CHANNEL
                | op::MESSAGE
                | op::CHUNK
                | op::MESSAGE_INDEX
                | op::METADATA
                | op::DATA_END
        )
    };
    if !wanted {
        return false;
    }
    let Ok(Some(framed)) = records::frame_at(bytes, at) else {
        return false;
    };
    let parses = match opcode {
        op::SCHEMA => records::schema(framed.body).is_ok(),
        op::CHANNEL => records::channel(framed.body).is_ok(),
        op::MESSAGE => records::message(framed.body).is_ok(),
        op::CHUNK => records::chunk(framed.body).is_ok() && record_len(framed) == framed.body.len(),
        op::MESSAGE_INDEX => records::message_index(framed.body).is_ok(),
        op::METADATA => records::metadata(framed.body).is_ok(),
        _ => framed.body.len() == 4,
    };
    let next = at + records::FRAME_BYTES + framed.body.len();
    parses
        && match records::frame_at(bytes, next) {
            Ok(None) => true,
            Ok(Some(after)) => defined(after.opcode),
            Err(_) => false,
        }
}

/// A record's kind, for messages: "a chunk".
fn opcode_name(opcode: u8) -> String {
    match opcode {
        op::HEADER => "a header".into(),
        op::SCHEMA => "a schema".into(),
        op::CHANNEL => "a channel".into(),
        op::MESSAGE => "a message".into(),
        op::CHUNK => "a chunk".into(),
        op::MESSAGE_INDEX => "a message index".into(),
        op::METADATA => "a metadata".into(),
        other => format!("an opcode {other:#04x}"),
    }
}

/// The message stream of a [`BagReader`].
pub struct Messages<'a> {
    reader: &'a BagReader,
    walker: Walker<'a>,
    summary: Option<&'a Summary>,
    /// Only messages logged in this range ([`BagReader::messages_where`]).
    window: Option<std::ops::RangeInclusive<u64>>,
    pending: VecDeque<Result<BagMessage, ReadIssue>>,
    /// The loss of a chunk, held until the message index records after it are counted.
    held: Option<ReadIssue>,
    /// Whether the message index records after the held loss count its messages (they were not
    /// counted from the summary's index).
    count_indexes: bool,
    schemas: BTreeMap<u16, Arc<SchemaInfo>>,
    channels: BTreeMap<u16, Arc<ChannelInfo>>,
    /// Messages per channel so far, read or lost: the next one's index on its channel.
    counts: BTreeMap<u16, u64>,
    /// Chunks met, read or lost.
    chunk: usize,
    read: u64,
    /// Where the walk was when the pages were last given back.
    released_at: usize,
    done: bool,
}

impl std::fmt::Debug for Messages<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Messages")
            .field("path", &self.reader.path)
            .field("read", &self.read)
            .finish_non_exhaustive()
    }
}

/// Largest chunk autoact will decompress (a guard against a corrupt size field).
const MAX_CHUNK_BYTES: u64 = 1 << 30;

impl Messages<'_> {
    fn take_schema(&mut self, body: &[u8]) -> Result<(), records::ParseError> {
        let s = records::schema(body)?;
        self.schemas.insert(s.id, Arc::new(SchemaInfo::from(&s)));
        Ok(())
    }

    fn take_channel(&mut self, body: &[u8]) -> Result<(), records::ParseError> {
        let c = records::channel(body)?;
        let info = ChannelInfo {
            id: c.id,
            topic: c.topic.to_string(),
            message_encoding: c.message_encoding.to_string(),
            schema: self.schema(c.schema_id),
        };
        self.channels.insert(c.id, Arc::new(info));
        Ok(())
    }

    /// Schema `id`: as the data section defined it, else as the summary does.
    fn schema(&self, id: u16) -> Option<Arc<SchemaInfo>> {
        self.schemas
            .get(&id)
            .or_else(|| self.summary?.schemas.get(&id))
            .cloned()
    }

    /// Channel `id`: as the data section defined it, else as the summary does (its definition
    /// was in a chunk that is lost).
    fn channel(&mut self, id: u16) -> Option<Arc<ChannelInfo>> {
        if let Some(c) = self.channels.get(&id) {
            return Some(Arc::clone(c));
        }
        let (schema_id, topic, encoding) = self.summary?.channels.get(&id)?.clone();
        let info = Arc::new(ChannelInfo {
            id,
            topic,
            message_encoding: encoding,
            schema: self.schema(schema_id),
        });
        self.channels.insert(id, Arc::clone(&info));
        Some(info)
    }

    fn message(&mut self, m: &records::Message<'_>) -> Result<BagMessage, ReadIssue> {
        let Some(channel) = self.channel(m.channel_id) else {
            return Err(ReadIssue::UnknownChannel {
                path: self.reader.path.clone(),
                channel_id: m.channel_id,
                log_time: m.log_time,
            });
        };
        let count = self.counts.entry(m.channel_id).or_insert(0);
        let index_on_channel = *count;
        *count += 1;
        self.read += 1;
        Ok(BagMessage {
            channel,
            index_on_channel,
            log_time: m.log_time,
            publish_time: m.publish_time,
            data: m.data.to_vec(),
        })
    }

    /// The records of one chunk, all parsed before any is used, so that a damaged record inside
    /// a CRC-less chunk drops the whole chunk rather than half of it silently.
    fn take_chunk_records(&mut self, records_bytes: &[u8]) -> Result<(), ChunkError> {
        let mut parsed = Vec::new();
        let mut at = 0;
        loop {
            match records::frame_at(records_bytes, at) {
                Ok(None) => break,
                Ok(Some(framed)) => {
                    let ok = match framed.opcode {
                        op::SCHEMA => records::schema(framed.body).map(|_| ()),
                        op::CHANNEL => records::channel(framed.body).map(|_| ()),
                        op::MESSAGE => records::message(framed.body).map(|_| ()),
                        _ => Ok(()),
                    };
                    ok.map_err(|source| ChunkError::Record { at, source })?;
                    at += records::FRAME_BYTES + framed.body.len();
                    parsed.push(framed);
                }
                Err(_) => return Err(ChunkError::PastEnd { at }),
            }
        }
        for framed in parsed {
            match framed.opcode {
                op::SCHEMA => self.take_schema(framed.body)?,
                op::CHANNEL => self.take_channel(framed.body)?,
                op::MESSAGE => {
                    let m = records::message(framed.body)?;
                    let item = self.message(&m);
                    self.pending.push_back(item);
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Chunk number of the chunk at byte `at`: its place in the chunk index, else the count of
    /// chunks met.
    fn chunk_number(&self, at: usize) -> usize {
        self.summary
            .and_then(|s| {
                s.chunks
                    .iter()
                    .position(|c| c.chunk_start_offset == at as u64)
            })
            .map_or(self.chunk, |k| k + 1)
    }

    /// Messages the chunk at byte `at` held, per channel, from the message indexes the summary
    /// lists for it; `None` without them.
    fn indexed_counts(&self, bytes: &[u8], at: usize) -> Option<BTreeMap<u16, u64>> {
        let index = self
            .summary?
            .chunks
            .iter()
            .find(|c| c.chunk_start_offset == at as u64)?;
        let mut counts = BTreeMap::new();
        for &offset in &index.message_index_offsets {
            let framed = records::frame_at(bytes, usize::try_from(offset).ok()?).ok()??;
            if framed.opcode != op::MESSAGE_INDEX {
                return None;
            }
            let (channel, n) = records::message_index(framed.body).ok()?;
            *counts.entry(channel).or_insert(0) += n;
        }
        Some(counts)
    }

    /// Counts the messages of a lost chunk at byte `at` as read (so later messages keep their
    /// index on their channel); returns how many, where known.
    fn count_lost(&mut self, bytes: &[u8], at: usize) -> Option<u64> {
        let counts = self.indexed_counts(bytes, at)?;
        let mut total = 0;
        for (channel, n) in counts {
            *self.counts.entry(channel).or_insert(0) += n;
            total += n;
        }
        Some(total)
    }

    fn take_chunk(&mut self, bytes: &[u8], at: usize, body: &[u8]) {
        self.chunk += 1;
        let number = self.chunk_number(at);
        let (start_nanos, end_nanos, result) = match records::chunk(body) {
            Ok(chunk) => (
                chunk.message_start_time,
                chunk.message_end_time,
                chunk_records(&chunk).and_then(|r| self.take_chunk_records(&r)),
            ),
            Err(e) => (0, 0, Err(ChunkError::Header(e))),
        };
        if let Err(e) = result {
            let reason = e.to_string();
            let messages = self.count_lost(bytes, at);
            self.count_indexes = messages.is_none();
            self.held = Some(ReadIssue::CorruptChunk {
                path: self.reader.path.clone(),
                chunk: number,
                offset: at as u64,
                start_nanos,
                end_nanos,
                messages,
                reason: reason.into(),
            });
        }
    }

    /// Counts a message index record after a lost chunk whose count is not known yet.
    fn take_message_index(&mut self, body: &[u8]) {
        if !self.count_indexes {
            return;
        }
        let (
            Some(ReadIssue::CorruptChunk { messages, .. } | ReadIssue::Damaged { messages, .. }),
            Ok((channel, n)),
        ) = (self.held.as_mut(), records::message_index(body))
        else {
            return;
        };
        *messages = Some(messages.unwrap_or(0) + n);
        *self.counts.entry(channel).or_insert(0) += n;
    }

    /// Bytes `at..resumed` were skipped: the chunks the summary indexes there are lost.
    fn take_damage(&mut self, bytes: &[u8], at: usize, resumed: usize, reason: String) {
        let lost: Vec<usize> = self
            .summary
            .map(|s| {
                s.chunks
                    .iter()
                    .filter_map(|c| usize::try_from(c.chunk_start_offset).ok())
                    .filter(|&c| c == at || (at..resumed).contains(&c) && frames_as_chunk(bytes, c))
                    .collect()
            })
            .unwrap_or_default();
        let mut messages = (!lost.is_empty()).then_some(0);
        for c in &lost {
            self.chunk += 1;
            messages = messages.zip(self.count_lost(bytes, *c)).map(|(a, b)| a + b);
        }
        if lost.is_empty() && bytes[at] == op::CHUNK {
            self.chunk += 1;
        }
        self.count_indexes = messages.is_none();
        self.held = Some(ReadIssue::Damaged {
            path: self.reader.path.clone(),
            from_byte: at as u64,
            to_byte: resumed as u64,
            messages,
            reason: reason.into(),
        });
    }

    /// Whether the chunk at byte `at` is outside the window by the summary's chunk index (its
    /// messages then counted from its message indexes, as for a lost chunk); `false` without a
    /// window, an index entry or countable message indexes: the chunk is read.
    fn skip_chunk(&mut self, bytes: &[u8], at: usize) -> bool {
        let (Some(window), Some(summary)) = (&self.window, self.summary) else {
            return false;
        };
        let Ok(i) = summary
            .chunks
            .binary_search_by_key(&(at as u64), |c| c.chunk_start_offset)
        else {
            return false;
        };
        let c = &summary.chunks[i];
        if c.message_start_time <= *window.end() && *window.start() <= c.message_end_time {
            return false;
        }
        let Some(counts) = self.indexed_counts(bytes, at) else {
            return false;
        };
        self.chunk += 1;
        for (channel, n) in counts {
            *self.counts.entry(channel).or_insert(0) += n;
        }
        true
    }

    /// Reads the next top-level record into `pending`.
    fn step(&mut self, bytes: &[u8]) {
        self.reader
            .release_walked(self.walker.at, &mut self.released_at);
        let Some(step) = self.walker.next() else {
            self.done = true;
            return;
        };
        let is_index = matches!(
            step,
            Step::Record {
                framed: Framed {
                    opcode: op::MESSAGE_INDEX,
                    ..
                },
                ..
            }
        );
        if !is_index && let Some(issue) = self.held.take() {
            self.pending.push_back(Err(issue));
        }
        let path = self.reader.path.clone();
        match step {
            Step::Record { at, framed } => {
                let damaged = match framed.opcode {
                    op::CHUNK => {
                        if !self.skip_chunk(bytes, at) {
                            self.take_chunk(bytes, at, framed.body);
                        }
                        Ok(())
                    }
                    op::MESSAGE_INDEX => {
                        self.take_message_index(framed.body);
                        Ok(())
                    }
                    op::SCHEMA => self.take_schema(framed.body),
                    op::CHANNEL => self.take_channel(framed.body),
                    op::MESSAGE => records::message(framed.body).map(|m| {
                        let item = self.message(&m);
                        self.pending.push_back(item);
                    }),
                    _ => Ok(()),
                };
                if let Err(e) = damaged {
                    let end = at + records::FRAME_BYTES + framed.body.len();
                    self.pending.push_back(Err(ReadIssue::Damaged {
                        path,
                        from_byte: at as u64,
                        to_byte: end as u64,
                        messages: (framed.opcode == op::MESSAGE).then_some(1),
                        reason: format!("{} record: {e}", opcode_name(framed.opcode)).into(),
                    }));
                }
            }
            Step::Damaged {
                at,
                resumed,
                reason,
            } => self.take_damage(bytes, at, resumed, reason),
            Step::Cut { reason } => {
                self.pending.push_back(Err(ReadIssue::Truncated {
                    path,
                    messages_read: self.read,
                    reason,
                }));
            }
            Step::Unfinished => self.pending.push_back(Err(ReadIssue::NoSummary {
                path,
                messages_read: self.read,
            })),
        }
    }
}

/// Why a chunk's messages cannot be used (its text becomes the chunk's [`ReadIssue`] reason).
#[derive(Debug, thiserror::Error)]
enum ChunkError {
    /// The chunk's header does not parse.
    #[error("its header: {0}")]
    Header(#[source] records::ParseError),
    /// An uncompressed size beyond [`MAX_CHUNK_BYTES`].
    #[error("declared size {0} bytes is implausible")]
    Implausible(u64),
    /// The records do not decompress.
    #[error(transparent)]
    Decompress(#[from] DecompressError),
    /// The records are not what was written.
    #[error("CRC mismatch (stored {stored:08x}, computed {computed:08x})")]
    Crc {
        /// The chunk's CRC.
        stored: u32,
        /// The records' CRC.
        computed: u32,
    },
    /// A record inside does not parse.
    #[error("record at byte {at} of the chunk's records: {source}")]
    Record {
        /// Where it starts in the records.
        at: usize,
        /// Why.
        #[source]
        source: records::ParseError,
    },
    /// A record inside runs past the records' end.
    #[error("the record at byte {at} of the chunk's records runs past their end")]
    PastEnd {
        /// Where it starts in the records.
        at: usize,
    },
    /// A record inside does not parse (found when it is used).
    #[error(transparent)]
    Parse(#[from] records::ParseError),
}

/// The records of a chunk, decompressed and CRC-checked.
fn chunk_records<'c>(chunk: &records::Chunk<'c>) -> Result<Cow<'c, [u8]>, ChunkError> {
    if chunk.uncompressed_size > MAX_CHUNK_BYTES {
        return Err(ChunkError::Implausible(chunk.uncompressed_size));
    }
    let records = decompress(chunk.compression, chunk.records, chunk.uncompressed_size)?;
    if chunk.uncompressed_crc != 0 {
        let computed = crc32fast::hash(&records);
        if computed != chunk.uncompressed_crc {
            return Err(ChunkError::Crc {
                stored: chunk.uncompressed_crc,
                computed,
            });
        }
    }
    Ok(records)
}

/// Why a chunk does not decompress (its text becomes the chunk's [`ReadIssue`] reason).
#[derive(Debug, thiserror::Error)]
enum DecompressError {
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
    #[error("{what} {actual} bytes, the chunk says {declared}")]
    Length {
        /// What holds the other size.
        what: &'static str,
        /// Bytes found.
        actual: u64,
        /// Bytes the chunk declares.
        declared: u64,
    },
}

/// Decompresses a chunk's records, declared to be `size` bytes. Memory grows with the bytes
/// actually produced (never more than `size` + 1), not with what a size field says: a corrupt
/// size costs an error, not an allocation.
fn decompress<'d>(
    compression: &str,
    data: &'d [u8],
    size: u64,
) -> Result<Cow<'d, [u8]>, DecompressError> {
    let length = |what, actual| DecompressError::Length {
        what,
        actual,
        declared: size,
    };
    // Enough for a typical ratio in one allocation; more only as output appears.
    let capacity = usize::try_from(size.min(4 * data.len() as u64 + 65_536)).unwrap_or(0);
    let mut out = Vec::with_capacity(capacity);
    match compression {
        "" if data.len() as u64 == size => return Ok(Cow::Borrowed(data)),
        "" => return Err(length("the records are", data.len() as u64)),
        "zstd" => {
            if let Ok(Some(frame)) = zstd::zstd_safe::get_frame_content_size(data)
                && frame != size
            {
                return Err(length("its zstd frame says", frame));
            }
            // One decompression context per thread, reset for each chunk: creating one per
            // chunk cost 2.6 % of a whole-body `convert`.
            thread_local! {
                static CONTEXT: std::cell::RefCell<Option<zstd::zstd_safe::DCtx<'static>>> =
                    const { std::cell::RefCell::new(None) };
            }
            CONTEXT
                .with_borrow_mut(|context| {
                    let context = match context {
                        Some(c) => c,
                        None => context.insert(zstd::zstd_safe::DCtx::try_create().ok_or_else(
                            || std::io::Error::other("no memory for a zstd context"),
                        )?),
                    };
                    let reset = |context: &mut zstd::zstd_safe::DCtx<'static>| {
                        context
                            .reset(zstd::zstd_safe::ResetDirective::SessionOnly)
                            .map_err(|code| {
                                std::io::Error::other(zstd::zstd_safe::get_error_name(code))
                            })
                    };
                    reset(context)?;
                    if one_shot_zstd(context, data, size, &mut out) {
                        return Ok(out.len());
                    }
                    // Anything else (several frames, an unknown or lying size, damage) goes
                    // through the stream, which reads at most `size + 1` bytes and names the
                    // problem.
                    out.clear();
                    reset(context)?;
                    zstd::stream::read::Decoder::with_context(data, context)
                        .take(size + 1)
                        .read_to_end(&mut out)
                })
                .map_err(DecompressError::Zstd)?;
        }
        "lz4" => {
            let decoder = lz4::Decoder::new(data).map_err(DecompressError::Lz4)?;
            decoder
                .take(size + 1)
                .read_to_end(&mut out)
                .map_err(DecompressError::Lz4)?;
        }
        other => return Err(DecompressError::Unsupported(other.to_string())),
    }
    if out.len() as u64 == size {
        Ok(Cow::Owned(out))
    } else {
        Err(length("decompressed to", out.len() as u64))
    }
}

/// Most compressed bytes a chunk may declare per compressed byte for [`one_shot_zstd`] to
/// allocate its whole declared size at once (plus [`ONE_SHOT_FLOOR_BYTES`]): beyond that, a
/// damaged size could cost more memory than the bytes that are there justify.
const ONE_SHOT_RATIO: u64 = 64;

/// Declared sizes up to this always decompress in one shot.
const ONE_SHOT_FLOOR_BYTES: u64 = 1 << 20;

/// Decompresses `data` into `out` in one call when its zstd frame declares `size` bytes or no
/// size, and `size` is plausible for the bytes there: straight into `out`'s spare capacity, where the
/// stream reader first zeroes its buffer and then copies every block out of zstd's own (together
/// 6 % of a whole-body `convert`). `false` when it does not apply or zstd refuses; `out` is then
/// to be cleared and the stream used.
fn one_shot_zstd(
    context: &mut zstd::zstd_safe::DCtx<'static>,
    data: &[u8],
    size: u64,
    out: &mut Vec<u8>,
) -> bool {
    let plausible = ONE_SHOT_RATIO
        .saturating_mul(data.len() as u64)
        .saturating_add(ONE_SHOT_FLOOR_BYTES);
    // The `mcap` writer streams its chunks, so their frames do not declare their size; one that
    // does must declare the chunk's.
    let declared_fits = match zstd::zstd_safe::get_frame_content_size(data) {
        Ok(None) => true,
        Ok(Some(n)) => n == size,
        Err(_) => false,
    };
    if size > plausible || !declared_fits {
        return false;
    }
    let Ok(size) = usize::try_from(size) else {
        return false;
    };
    out.clear();
    out.reserve_exact(size);
    matches!(context.decompress(out, data), Ok(n) if n == size)
}

impl Iterator for Messages<'_> {
    type Item = Result<BagMessage, ReadIssue>;

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            if let Some(item) = self.pending.pop_front() {
                let outside = |m: &BagMessage| {
                    self.window
                        .as_ref()
                        .is_some_and(|w| !w.contains(&m.log_time))
                };
                if matches!(&item, Ok(m) if outside(m)) {
                    continue;
                }
                return Some(item);
            }
            if self.done {
                return self.held.take().map(Err);
            }
            let bytes = self.walker.bytes;
            self.step(bytes);
        }
    }
}

#[cfg(test)]
mod decompress_tests {
    use super::*;

    /// Bytes that compress, but not to nothing.
    fn records(n: usize) -> Vec<u8> {
        (0..n)
            .map(|k| ((k % 251) ^ (k / 997)).to_le_bytes()[0])
            .collect()
    }

    fn size(bytes: &[u8]) -> u64 {
        bytes.len() as u64
    }

    /// `plain` as one streamed zstd frame, which does not declare its size (as the `mcap` writer
    /// writes chunks).
    fn streamed(plain: &[u8]) -> Vec<u8> {
        let mut frame = Vec::new();
        let mut encoder = zstd::stream::write::Encoder::new(&mut frame, 1).unwrap();
        std::io::Write::write_all(&mut encoder, plain).unwrap();
        encoder.finish().unwrap();
        frame
    }

    #[test]
    fn sized_unsized_and_multi_frame_chunks_decompress_to_their_records() {
        let plain = records(300_000);
        let one = zstd::bulk::compress(&plain, 1).unwrap();
        assert_eq!(*decompress("zstd", &one, size(&plain)).unwrap(), plain[..]);
        let unsized_frame = streamed(&plain);
        let content_size = zstd::zstd_safe::get_frame_content_size(&unsized_frame);
        assert_eq!(content_size.ok(), Some(None));
        assert_eq!(
            *decompress("zstd", &unsized_frame, size(&plain)).unwrap(),
            plain[..]
        );
        // Two frames back to back, neither declaring its size.
        let (a, b) = plain.split_at(100_000);
        let mut two = streamed(a);
        two.extend(streamed(b));
        assert_eq!(*decompress("zstd", &two, size(&plain)).unwrap(), plain[..]);
        assert!(decompress("zstd", &two, size(a)).is_err());
        // A first frame that declares only its own part is refused, as before the one-shot path.
        let mut two = zstd::bulk::compress(a, 1).unwrap();
        two.extend(zstd::bulk::compress(b, 1).unwrap());
        assert!(decompress("zstd", &two, size(&plain)).is_err());
    }

    #[test]
    fn a_chunk_that_declares_another_size_than_its_records_is_an_error() {
        let plain = records(50_000);
        let one = zstd::bulk::compress(&plain, 1).unwrap();
        for declared in [0, 1, size(&plain) - 1, size(&plain) + 1, 1 << 40] {
            assert!(
                matches!(
                    decompress("zstd", &one, declared),
                    Err(DecompressError::Length { .. })
                ),
                "declared {declared}"
            );
        }
        let unsized_frame = streamed(&plain);
        for declared in [0, 1, size(&plain) - 1, size(&plain) + 1, 1 << 40] {
            assert!(
                matches!(
                    decompress("zstd", &unsized_frame, declared),
                    Err(DecompressError::Length { .. })
                ),
                "declared {declared}, unsized frame"
            );
        }
        // Damaged bytes: an error, whichever way it is read.
        for frame in [one, unsized_frame] {
            let cut = &frame[..frame.len() / 2];
            assert!(decompress("zstd", cut, size(&plain)).is_err());
        }
    }
}
