//! MCAP records parsed by autoact itself, straight from the mapped bytes: the framing (opcode,
//! length) and the records the reader needs. Every length is checked against the bytes that are
//! actually there before anything is sliced or allocated, so a corrupt length costs a parse
//! error, never a huge allocation (the `mcap` crate's parser reserves whatever a string's length
//! prefix says, up to 4 GiB, before reading it).

/// Record opcodes (MCAP specification, "Records").
pub(super) mod op {
    pub const HEADER: u8 = 0x01;
    pub const FOOTER: u8 = 0x02;
    pub const SCHEMA: u8 = 0x03;
    pub const CHANNEL: u8 = 0x04;
    pub const MESSAGE: u8 = 0x05;
    pub const CHUNK: u8 = 0x06;
    pub const MESSAGE_INDEX: u8 = 0x07;
    pub const CHUNK_INDEX: u8 = 0x08;
    pub const STATISTICS: u8 = 0x0B;
    pub const METADATA: u8 = 0x0C;
    pub const DATA_END: u8 = 0x0F;
    /// The highest opcode the specification defines.
    pub const LAST_DEFINED: u8 = 0x0F;
}

/// Opcode and length: the bytes before every record's body.
pub(super) const FRAME_BYTES: usize = 9;

/// Why a record's bytes do not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(super) enum ParseError {
    /// A field runs past the end of the record.
    #[error("{field} needs {needed} bytes, {available} are left in the record")]
    Short {
        /// The field.
        field: &'static str,
        /// Bytes the field needs.
        needed: u64,
        /// Bytes left.
        available: usize,
    },
    /// A string that is not UTF-8.
    #[error("{field} is not UTF-8")]
    Utf8 {
        /// The field.
        field: &'static str,
    },
}

/// A `map<string, string>` field.
pub(super) type StringMap = std::collections::BTreeMap<String, String>;

/// A bounds-checked reader over one record's body.
#[derive(Debug, Clone)]
pub(super) struct Fields<'a> {
    bytes: &'a [u8],
}

impl<'a> Fields<'a> {
    pub(super) fn new(bytes: &'a [u8]) -> Fields<'a> {
        Fields { bytes }
    }

    /// The next `n` bytes.
    fn take(&mut self, field: &'static str, n: u64) -> Result<&'a [u8], ParseError> {
        let short = ParseError::Short {
            field,
            needed: n,
            available: self.bytes.len(),
        };
        let n = usize::try_from(n).map_err(|_| short.clone())?;
        if n > self.bytes.len() {
            return Err(short);
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(head)
    }

    fn array<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], ParseError> {
        let bytes = self.take(field, N as u64)?;
        let mut out = [0u8; N];
        out.copy_from_slice(bytes);
        Ok(out)
    }

    pub(super) fn u16(&mut self, field: &'static str) -> Result<u16, ParseError> {
        self.array(field).map(u16::from_le_bytes)
    }

    pub(super) fn u32(&mut self, field: &'static str) -> Result<u32, ParseError> {
        self.array(field).map(u32::from_le_bytes)
    }

    pub(super) fn u64(&mut self, field: &'static str) -> Result<u64, ParseError> {
        self.array(field).map(u64::from_le_bytes)
    }

    /// Bytes prefixed by a `u32` length.
    fn bytes32(&mut self, field: &'static str) -> Result<&'a [u8], ParseError> {
        let n = self.u32(field)?;
        self.take(field, u64::from(n))
    }

    /// A string prefixed by a `u32` length.
    fn string(&mut self, field: &'static str) -> Result<&'a str, ParseError> {
        std::str::from_utf8(self.bytes32(field)?).map_err(|_| ParseError::Utf8 { field })
    }

    /// A `map<string, string>`: a `u32` byte length, then key and value strings.
    fn string_map(&mut self, field: &'static str) -> Result<StringMap, ParseError> {
        let mut inner = Fields::new(self.bytes32(field)?);
        let mut map = std::collections::BTreeMap::new();
        while !inner.bytes.is_empty() {
            let key = inner.string(field)?;
            let value = inner.string(field)?;
            map.insert(key.to_string(), value.to_string());
        }
        Ok(map)
    }

    /// The rest of the record.
    fn rest(&mut self) -> &'a [u8] {
        std::mem::take(&mut self.bytes)
    }
}

/// One framed record: opcode and body, borrowed from the file.
#[derive(Debug, Clone, Copy)]
pub(super) struct Framed<'a> {
    pub(super) opcode: u8,
    pub(super) body: &'a [u8],
}

/// What is at `at` in `bytes`: `Ok(Some(record))`, `Ok(None)` at the very end, or the length
/// the record claims when it runs past the end (`Err(Some(declared body bytes))`, `Err(None)`
/// when not even its opcode and length are there).
pub(super) fn frame_at(bytes: &[u8], at: usize) -> Result<Option<Framed<'_>>, Option<u64>> {
    if at >= bytes.len() {
        return Ok(None);
    }
    let Some(frame) = bytes.get(at..at + FRAME_BYTES) else {
        return Err(None);
    };
    let opcode = frame[0];
    let mut len = [0u8; 8];
    len.copy_from_slice(&frame[1..]);
    let len = u64::from_le_bytes(len);
    let start = at + FRAME_BYTES;
    let available = (bytes.len() - start) as u64;
    if len > available {
        return Err(Some(len));
    }
    // `len <= available`, which fits in usize.
    let end = start + usize::try_from(len).map_err(|_| Some(len))?;
    Ok(Some(Framed {
        opcode,
        body: &bytes[start..end],
    }))
}

/// The header record: profile and library.
pub(super) fn header(body: &[u8]) -> Result<(String, String), ParseError> {
    let mut f = Fields::new(body);
    let profile = f.string("header profile")?.to_string();
    let library = f.string("header library")?.to_string();
    Ok((profile, library))
}

/// A schema record.
#[derive(Debug, Clone)]
pub(super) struct Schema<'a> {
    pub(super) id: u16,
    pub(super) name: &'a str,
    pub(super) encoding: &'a str,
    pub(super) data: &'a [u8],
}

pub(super) fn schema(body: &[u8]) -> Result<Schema<'_>, ParseError> {
    let mut f = Fields::new(body);
    Ok(Schema {
        id: f.u16("schema id")?,
        name: f.string("schema name")?,
        encoding: f.string("schema encoding")?,
        data: f.bytes32("schema data")?,
    })
}

/// A channel record (its metadata is checked, not kept).
#[derive(Debug, Clone)]
pub(super) struct Channel<'a> {
    pub(super) id: u16,
    pub(super) schema_id: u16,
    pub(super) topic: &'a str,
    pub(super) message_encoding: &'a str,
}

pub(super) fn channel(body: &[u8]) -> Result<Channel<'_>, ParseError> {
    let mut f = Fields::new(body);
    let channel = Channel {
        id: f.u16("channel id")?,
        schema_id: f.u16("channel schema id")?,
        topic: f.string("channel topic")?,
        message_encoding: f.string("channel message encoding")?,
    };
    f.string_map("channel metadata")?;
    Ok(channel)
}

/// A message record.
#[derive(Debug, Clone)]
pub(super) struct Message<'a> {
    pub(super) channel_id: u16,
    pub(super) log_time: u64,
    pub(super) publish_time: u64,
    pub(super) data: &'a [u8],
}

pub(super) fn message(body: &[u8]) -> Result<Message<'_>, ParseError> {
    let mut f = Fields::new(body);
    let channel_id = f.u16("message channel id")?;
    let _sequence = f.u32("message sequence")?;
    Ok(Message {
        channel_id,
        log_time: f.u64("message log time")?,
        publish_time: f.u64("message publish time")?,
        data: f.rest(),
    })
}

/// A chunk record.
#[derive(Debug, Clone)]
pub(super) struct Chunk<'a> {
    pub(super) message_start_time: u64,
    pub(super) message_end_time: u64,
    pub(super) uncompressed_size: u64,
    pub(super) uncompressed_crc: u32,
    pub(super) compression: &'a str,
    /// The (compressed) records.
    pub(super) records: &'a [u8],
}

pub(super) fn chunk(body: &[u8]) -> Result<Chunk<'_>, ParseError> {
    let mut f = Fields::new(body);
    let message_start_time = f.u64("chunk start time")?;
    let message_end_time = f.u64("chunk end time")?;
    let uncompressed_size = f.u64("chunk uncompressed size")?;
    let uncompressed_crc = f.u32("chunk CRC")?;
    let compression = f.string("chunk compression")?;
    let records_len = f.u64("chunk records length")?;
    let records = f.take("chunk records", records_len)?;
    Ok(Chunk {
        message_start_time,
        message_end_time,
        uncompressed_size,
        uncompressed_crc,
        compression,
        records,
    })
}

/// A message index record: its channel and how many messages it lists.
pub(super) fn message_index(body: &[u8]) -> Result<(u16, u64), ParseError> {
    let mut f = Fields::new(body);
    let channel_id = f.u16("message index channel id")?;
    let entries = f.bytes32("message index entries")?;
    Ok((channel_id, entries.len() as u64 / 16))
}

/// A chunk index record: where its chunk is, and where its message indexes are.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct ChunkIndex {
    /// First and last message log time in the chunk, nanoseconds.
    pub(super) message_start_time: u64,
    pub(super) message_end_time: u64,
    pub(super) chunk_start_offset: u64,
    /// Offsets of the chunk's message index records.
    pub(super) message_index_offsets: Vec<u64>,
}

pub(super) fn chunk_index(body: &[u8]) -> Result<ChunkIndex, ParseError> {
    let mut f = Fields::new(body);
    let message_start_time = f.u64("chunk index start time")?;
    let message_end_time = f.u64("chunk index end time")?;
    let chunk_start_offset = f.u64("chunk index offset")?;
    let _length = f.u64("chunk index length")?;
    let mut offsets = Fields::new(f.bytes32("chunk index message index offsets")?);
    let mut message_index_offsets = Vec::new();
    while !offsets.bytes.is_empty() {
        let _channel = offsets.u16("message index offset channel")?;
        message_index_offsets.push(offsets.u64("message index offset")?);
    }
    Ok(ChunkIndex {
        message_start_time,
        message_end_time,
        chunk_start_offset,
        message_index_offsets,
    })
}

/// A statistics record: message count, first and last log time.
pub(super) fn statistics(body: &[u8]) -> Result<(u64, u64, u64), ParseError> {
    let mut f = Fields::new(body);
    let message_count = f.u64("statistics message count")?;
    let _schemas = f.u16("statistics schema count")?;
    let _channels = f.u32("statistics channel count")?;
    let _attachments = f.u32("statistics attachment count")?;
    let _metadata = f.u32("statistics metadata count")?;
    let _chunks = f.u32("statistics chunk count")?;
    let start = f.u64("statistics start time")?;
    let end = f.u64("statistics end time")?;
    Ok((message_count, start, end))
}

/// A metadata record: name and key-value pairs.
pub(super) fn metadata(body: &[u8]) -> Result<(String, StringMap), ParseError> {
    let mut f = Fields::new(body);
    let name = f.string("metadata name")?.to_string();
    let map = f.string_map("metadata")?;
    Ok((name, map))
}

/// The footer: where the summary starts (0: none).
pub(super) fn footer(body: &[u8]) -> Result<u64, ParseError> {
    Fields::new(body).u64("footer summary start")
}
