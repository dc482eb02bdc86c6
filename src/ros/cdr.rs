//! CDR, the ROS 2 wire format, in one place: a 4-byte encapsulation header (`00 01 00 00`,
//! little-endian plain CDR) followed by the serde encoding from `cdr-encoding` (the crate RustDDS
//! and ros2-client use). Alignment counts from the first byte after the header, so the header is
//! written before the serializer runs, never through it.

use serde::{Serialize, de::DeserializeOwned};

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
    let (Some(header), Some(body)) = (payload.get(..4), payload.get(4..)) else {
        return Err(CdrError::TooShort(payload.len()));
    };
    let decoded = match (header[0], header[1]) {
        (0, 1) => cdr_encoding::from_bytes::<M, byteorder::LittleEndian>(body),
        (0, 0) => cdr_encoding::from_bytes::<M, byteorder::BigEndian>(body),
        (a, b) => return Err(CdrError::Encapsulation(a, b)),
    };
    decoded
        .map(|(m, _)| m)
        .map_err(|e| CdrError::Body(e.to_string()))
}
