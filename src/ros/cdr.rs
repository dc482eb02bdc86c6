//! CDR, the ROS 2 wire format, in one place: a 4-byte encapsulation header (`00 01 00 00`,
//! little-endian plain CDR) followed by the serde encoding from `cdr-encoding` (the crate RustDDS
//! and ros2-client use). Alignment counts from the first byte after the header, so the header is
//! written before the serializer runs, never through it. [`encode_over`] adds a fast path for
//! streams of messages of one shape, which writes the numbers of a message over the previous
//! one's bytes; it gives `cdr-encoding`'s bytes exactly, and falls back to it for anything else.

use serde::{Deserialize, Serialize, de::DeserializeOwned};

/// CDR little-endian encapsulation header.
pub const HEADER_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Errors decoding a CDR payload.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CdrError {
    /// Shorter than the encapsulation header.
    #[error("payload of {0} bytes is too short for a CDR encapsulation header")]
    TooShort(usize),
    /// An encapsulation other than plain CDR.
    #[error("unsupported CDR encapsulation {0:02x}{1:02x} (plain CDR, 0000 or 0001, is supported)")]
    Encapsulation(u8, u8),
    /// The body does not decode as the expected type.
    #[error("{0}")]
    Body(String),
}

/// Encodes a message: header, then the little-endian body.
///
/// # Errors
/// Only if the message cannot be represented in CDR (it always can for the types in
/// [`crate::ros`]).
pub fn encode<M: Serialize>(msg: &M) -> Result<Vec<u8>, CdrError> {
    let mut out = Vec::with_capacity(256);
    encode_into(msg, &mut out)?;
    Ok(out)
}

/// Encodes a message into `out`, replacing its contents (a reusable buffer).
///
/// # Errors
/// As [`encode`].
pub fn encode_into<M: Serialize>(msg: &M, out: &mut Vec<u8>) -> Result<(), CdrError> {
    out.clear();
    out.extend_from_slice(&HEADER_LE);
    cdr_encoding::to_writer::<_, byteorder::LittleEndian, _>(&mut *out, msg)
        .map_err(|e| CdrError::Body(e.to_string()))
}

/// Decodes a message with its encapsulation header (little- or big-endian plain CDR).
///
/// # Errors
/// [`CdrError`] naming what is wrong.
pub fn decode<M: DeserializeOwned>(payload: &[u8]) -> Result<M, CdrError> {
    let (header, body) = split_header(payload)?;
    let decoded = match (header[0], header[1]) {
        (0, 1) => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body),
        (0, 0) => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body),
        (a, b) => return Err(CdrError::Encapsulation(a, b)),
    };
    decoded
        .map(|(m, _)| m)
        .map_err(|e| CdrError::Body(e.to_string()))
}

/// Decodes a message into `place`, reusing its strings' and sequences' allocations (serde's
/// in-place deserialisation): a reader that decodes message after message into one value
/// allocates only when a message is longer than every one before it. On an error, `place` holds
/// a partly decoded message and must not be used.
///
/// # Errors
/// As [`decode`].
pub fn decode_in_place<'de, M: Deserialize<'de>>(
    payload: &'de [u8],
    place: &mut M,
) -> Result<(), CdrError> {
    let (header, body) = split_header(payload)?;
    let decoded = match (header[0], header[1]) {
        (0, 1) => M::deserialize_in_place(
            &mut cdr_encoding::CdrDeserializer::<byteorder::LittleEndian>::new(body),
            place,
        ),
        (0, 0) => M::deserialize_in_place(
            &mut cdr_encoding::CdrDeserializer::<byteorder::BigEndian>::new(body),
            place,
        ),
        (a, b) => return Err(CdrError::Encapsulation(a, b)),
    };
    decoded.map_err(|e| CdrError::Body(e.to_string()))
}

fn split_header(payload: &[u8]) -> Result<(&[u8], &[u8]), CdrError> {
    match (payload.get(..4), payload.get(4..)) {
        (Some(header), Some(body)) => Ok((header, body)),
        _ => Err(CdrError::TooShort(payload.len())),
    }
}

/// Encodes `msg` into `out`, which holds nothing or the previous message of type `M` encoded into
/// it: a writer that sends message after message of one shape (a stream whose strings and array
/// lengths stay the same from one message to the next, such as a skeleton's bone names) keeps
/// one buffer per stream and pays only for its numbers. The numbers are written over the
/// previous encoding; when a string or an array length differs, or the message has a part this
/// fast path does not take (options, maps, enums), it encodes afresh with [`encode_into`]. The
/// bytes are the same either way: every number is written and every string and length checked,
/// and the padding, which sits where the previous encoding of the same shape had its (zero)
/// padding, is left as it is. Debug builds check every message against a fresh encoding.
///
/// `out` must not hold another type's encoding: its padding could then survive a shape that
/// happens to match. [`crate::mcap_io::BagWriter`] keeps one buffer per topic, and a topic keeps
/// its type.
///
/// # Errors
/// As [`encode`].
pub fn encode_over<M: Serialize>(msg: &M, out: &mut Vec<u8>) -> Result<(), CdrError> {
    if out.starts_with(&HEADER_LE) {
        let mut over = Overwriter {
            body: &mut out[HEADER_LE.len()..],
            pos: 0,
        };
        if msg.serialize(&mut over).is_ok() && over.pos == over.body.len() {
            debug_assert_eq!(
                *out,
                encode(msg)?,
                "in-place CDR differs from a fresh encoding"
            );
            return Ok(());
        }
    }
    encode_into(msg, out)
}

/// Why [`Overwriter`] gave up: the message's shape is not the buffer's.
#[derive(Debug)]
struct ShapeChanged;

impl std::fmt::Display for ShapeChanged {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("the message's shape differs from the previous encoding")
    }
}

impl std::error::Error for ShapeChanged {}

impl serde::ser::Error for ShapeChanged {
    fn custom<T: std::fmt::Display>(_: T) -> Self {
        ShapeChanged
    }
}

/// A serde serializer that writes a message's numbers over an earlier little-endian CDR body of
/// the same shape, and checks its strings and sequence lengths against it. It follows the rules
/// of `cdr-encoding`'s serializer (primitives aligned to their size from the body's start;
/// strings as a `u32` length counting a NUL, the bytes, the NUL; sequences as a `u32` count, then
/// the elements; structs and fixed arrays as their elements), for the parts ROS messages use.
struct Overwriter<'b> {
    body: &'b mut [u8],
    pos: usize,
}

impl Overwriter<'_> {
    /// Writes `bytes` aligned to their size (the padding before them is left as it is).
    fn put<const N: usize>(&mut self, bytes: [u8; N]) -> Result<(), ShapeChanged> {
        let start = self.pos.next_multiple_of(N);
        let slot = self.body.get_mut(start..start + N).ok_or(ShapeChanged)?;
        slot.copy_from_slice(&bytes);
        self.pos = start + N;
        Ok(())
    }

    /// Checks that the body holds `bytes` at the current position (after aligning to `align`).
    fn expect(&mut self, align: usize, bytes: &[u8]) -> Result<(), ShapeChanged> {
        let start = self.pos.next_multiple_of(align);
        if self.body.get(start..start + bytes.len()) != Some(bytes) {
            return Err(ShapeChanged);
        }
        self.pos = start + bytes.len();
        Ok(())
    }

    fn length(&mut self, n: usize) -> Result<(), ShapeChanged> {
        let n = u32::try_from(n).map_err(|_| ShapeChanged)?;
        self.expect(4, &n.to_le_bytes())
    }
}

/// A number: little-endian, aligned to its size.
macro_rules! overwrite_numbers {
    ($($method:ident : $t:ty),*) => {$(
        fn $method(self, v: $t) -> Result<(), ShapeChanged> {
            self.put(v.to_le_bytes())
        }
    )*};
}

impl serde::Serializer for &mut Overwriter<'_> {
    type Ok = ();
    type Error = ShapeChanged;
    type SerializeSeq = Self;
    type SerializeTuple = Self;
    type SerializeTupleStruct = Self;
    type SerializeTupleVariant = serde::ser::Impossible<(), ShapeChanged>;
    type SerializeMap = serde::ser::Impossible<(), ShapeChanged>;
    type SerializeStruct = Self;
    type SerializeStructVariant = serde::ser::Impossible<(), ShapeChanged>;

    fn serialize_bool(self, v: bool) -> Result<(), ShapeChanged> {
        self.put([u8::from(v)])
    }
    overwrite_numbers!(
        serialize_i8: i8,
        serialize_i16: i16,
        serialize_i32: i32,
        serialize_i64: i64,
        serialize_u8: u8,
        serialize_u16: u16,
        serialize_u32: u32,
        serialize_u64: u64,
        serialize_f32: f32,
        serialize_f64: f64
    );
    fn serialize_char(self, _: char) -> Result<(), ShapeChanged> {
        Err(ShapeChanged)
    }
    fn serialize_str(self, v: &str) -> Result<(), ShapeChanged> {
        self.length(v.len() + 1)?;
        self.expect(1, v.as_bytes())?;
        self.expect(1, &[0])
    }
    fn serialize_bytes(self, _: &[u8]) -> Result<(), ShapeChanged> {
        Err(ShapeChanged)
    }
    fn serialize_none(self) -> Result<(), ShapeChanged> {
        Err(ShapeChanged)
    }
    fn serialize_some<T: ?Sized + Serialize>(self, _: &T) -> Result<(), ShapeChanged> {
        Err(ShapeChanged)
    }
    fn serialize_unit(self) -> Result<(), ShapeChanged> {
        Ok(())
    }
    fn serialize_unit_struct(self, _: &'static str) -> Result<(), ShapeChanged> {
        Ok(())
    }
    fn serialize_unit_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
    ) -> Result<(), ShapeChanged> {
        Err(ShapeChanged)
    }
    fn serialize_newtype_struct<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        value: &T,
    ) -> Result<(), ShapeChanged> {
        value.serialize(self)
    }
    fn serialize_newtype_variant<T: ?Sized + Serialize>(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: &T,
    ) -> Result<(), ShapeChanged> {
        Err(ShapeChanged)
    }
    fn serialize_seq(self, len: Option<usize>) -> Result<Self, ShapeChanged> {
        self.length(len.ok_or(ShapeChanged)?)?;
        Ok(self)
    }
    fn serialize_tuple(self, _: usize) -> Result<Self, ShapeChanged> {
        Ok(self)
    }
    fn serialize_tuple_struct(self, _: &'static str, _: usize) -> Result<Self, ShapeChanged> {
        Ok(self)
    }
    fn serialize_tuple_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeTupleVariant, ShapeChanged> {
        Err(ShapeChanged)
    }
    fn serialize_map(self, _: Option<usize>) -> Result<Self::SerializeMap, ShapeChanged> {
        Err(ShapeChanged)
    }
    fn serialize_struct(self, _: &'static str, _: usize) -> Result<Self, ShapeChanged> {
        Ok(self)
    }
    fn serialize_struct_variant(
        self,
        _: &'static str,
        _: u32,
        _: &'static str,
        _: usize,
    ) -> Result<Self::SerializeStructVariant, ShapeChanged> {
        Err(ShapeChanged)
    }
    fn is_human_readable(&self) -> bool {
        false
    }
}

/// Sequences, fixed arrays and tuple structs: their elements, one after the other.
macro_rules! overwrite_elements {
    ($($trait:ident :: $method:ident),*) => {$(
        impl serde::ser::$trait for &mut Overwriter<'_> {
            type Ok = ();
            type Error = ShapeChanged;
            fn $method<T: ?Sized + Serialize>(&mut self, value: &T) -> Result<(), ShapeChanged> {
                value.serialize(&mut **self)
            }
            fn end(self) -> Result<(), ShapeChanged> {
                Ok(())
            }
        }
    )*};
}

overwrite_elements!(
    SerializeSeq::serialize_element,
    SerializeTuple::serialize_element,
    SerializeTupleStruct::serialize_field
);

impl serde::ser::SerializeStruct for &mut Overwriter<'_> {
    type Ok = ();
    type Error = ShapeChanged;
    fn serialize_field<T: ?Sized + Serialize>(
        &mut self,
        _: &'static str,
        value: &T,
    ) -> Result<(), ShapeChanged> {
        value.serialize(&mut **self)
    }
    fn end(self) -> Result<(), ShapeChanged> {
        Ok(())
    }
}
