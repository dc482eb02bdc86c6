//! H.264 Annex B access units, one per frame, for `foxglove_msgs/CompressedVideo`.
//!
//! Foxglove wants each message to hold exactly one frame in Annex B form (start codes, no
//! length prefixes), with the SPS and PPS in every keyframe's message, and no B-frames. The
//! encoder's files already have no B-frames. The stream is extracted without re-encoding:
//!
//! ```text
//! ffmpeg -i FILE -map 0:v:0 -c copy -bsf:v h264_mp4toannexb,h264_metadata=aud=insert -f h264 -
//! ```
//!
//! `h264_mp4toannexb` turns length-prefixed NAL units into start-code ones and repeats the
//! SPS/PPS before every IDR frame; `h264_metadata=aud=insert` puts an access unit delimiter
//! (NAL type 9) at the start of every frame, which is where [`split_access_units`] cuts. The
//! delimiters stay in the units (6 bytes each; decoders accept them).

use std::ffi::OsStr;
use std::path::Path;

use super::tools::ffmpeg_path_arg;
use super::{Ffmpeg, VideoError};

/// NAL unit type of an IDR slice.
const NAL_IDR: u8 = 5;
/// NAL unit type of an access unit delimiter.
const NAL_AUD: u8 = 9;

/// One frame's NAL units in Annex B form, starting with its access unit delimiter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AccessUnit {
    /// The bytes: start code + NAL unit, repeated.
    pub data: Vec<u8>,
    /// Whether it holds an IDR slice (a frame decodable on its own).
    pub key: bool,
}

impl AccessUnit {
    /// The NAL unit types in this unit, in order (7 = SPS, 8 = PPS, 5 = IDR slice, 1 = non-IDR
    /// slice, 6 = SEI, 9 = delimiter).
    #[must_use]
    pub fn nal_types(&self) -> Vec<u8> {
        nal_units(&self.data)
            .into_iter()
            .map(|(_, start)| self.data.get(start).map_or(0, |b| b & 0x1f))
            .collect()
    }
}

/// The H.264 stream of `path`'s first video stream as Annex B access units, one per frame, in
/// decode order (= presentation order for the encoder's files, which have no B-frames), ready
/// for `foxglove_msgs/CompressedVideo` (format `h264`).
///
/// Nothing is re-encoded: `ffmpeg -i FILE -map 0:v:0 -c copy -bsf:v
/// h264_mp4toannexb,h264_metadata=aud=insert -f h264 -` gives start-code NAL units with the
/// SPS and PPS repeated before every IDR frame and an access unit delimiter opening every
/// frame, where the stream is split (the delimiters stay in the units: 6 bytes each).
///
/// # Errors
/// [`VideoError::Exited`] if ffmpeg fails (e.g. the stream is not H.264),
/// [`VideoError::AccessUnits`] if the output is not delimited as expected.
pub fn annexb_access_units(ffmpeg: &Ffmpeg, path: &Path) -> Result<Vec<AccessUnit>, VideoError> {
    let input = ffmpeg_path_arg(path);
    let args: [&OsStr; 16] = [
        OsStr::new("-hide_banner"),
        OsStr::new("-nostdin"),
        OsStr::new("-loglevel"),
        OsStr::new("error"),
        OsStr::new("-i"),
        &input,
        OsStr::new("-map"),
        OsStr::new("0:v:0"),
        OsStr::new("-c"),
        OsStr::new("copy"),
        OsStr::new("-bsf:v"),
        OsStr::new("h264_mp4toannexb,h264_metadata=aud=insert"),
        OsStr::new("-f"),
        OsStr::new("h264"),
        OsStr::new("-y"),
        OsStr::new("-"),
    ];
    let stream = ffmpeg.run_ffmpeg(args, path)?;
    split_access_units(&stream).map_err(|source| VideoError::AccessUnits {
        path: path.to_path_buf(),
        source,
    })
}

/// Why an Annex B stream does not split into access units.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum AnnexBError {
    /// No start code at all.
    #[error("the H.264 stream is empty (no start code)")]
    Empty,
    /// Bytes other than zeros before the first start code.
    #[error("{bytes} bytes before the first start code")]
    LeadingBytes {
        /// Offset of the first start code.
        bytes: usize,
    },
    /// A NAL unit before the first access unit delimiter.
    #[error("NAL unit of type {nal_type} at byte {offset} before any access unit delimiter")]
    BeforeDelimiter {
        /// Its NAL unit type.
        nal_type: u8,
        /// Offset of its start code.
        offset: usize,
    },
}

/// Splits an Annex B byte stream at its access unit delimiters. Every unit must begin with a
/// delimiter (the stream may not hold bytes before the first one).
///
/// # Errors
/// [`AnnexBError`] when the stream is empty or does not start with a delimiter.
pub fn split_access_units(stream: &[u8]) -> Result<Vec<AccessUnit>, AnnexBError> {
    let nals = nal_units(stream);
    let Some(&(first_code, _)) = nals.first() else {
        return Err(AnnexBError::Empty);
    };
    if stream[..first_code].iter().any(|&b| b != 0) {
        return Err(AnnexBError::LeadingBytes { bytes: first_code });
    }
    let nal_type = |start: usize| stream.get(start).map_or(0, |b| b & 0x1f);
    let mut units = Vec::new();
    let mut current: Option<(usize, bool)> = None;
    for &(code, start) in &nals {
        let kind = nal_type(start);
        if kind == NAL_AUD {
            if let Some((begin, key)) = current.take() {
                units.push(AccessUnit {
                    data: stream[begin..code].to_vec(),
                    key,
                });
            }
            current = Some((code, false));
        } else {
            let Some((_, key)) = current.as_mut() else {
                return Err(AnnexBError::BeforeDelimiter {
                    nal_type: kind,
                    offset: code,
                });
            };
            *key |= kind == NAL_IDR;
        }
    }
    if let Some((begin, key)) = current {
        units.push(AccessUnit {
            data: stream[begin..].to_vec(),
            key,
        });
    }
    Ok(units)
}

/// `(start code offset, NAL header offset)` of every NAL unit. A start code is `00 00 01`,
/// or `00 00 00 01` (the extra zero is counted as part of the start code).
fn nal_units(stream: &[u8]) -> Vec<(usize, usize)> {
    let mut found = Vec::new();
    let mut i = 0;
    while i + 3 <= stream.len() {
        if stream[i] == 0 && stream[i + 1] == 0 && stream[i + 2] == 1 {
            let code = if i > 0 && stream[i - 1] == 0 {
                i - 1
            } else {
                i
            };
            found.push((code, i + 3));
            i += 3;
        } else {
            i += 1;
        }
    }
    found
}

#[cfg(test)]
mod tests {
    use super::{AnnexBError, split_access_units};

    #[test]
    fn splits_at_delimiters_and_marks_idr_units() {
        let stream: Vec<u8> = [
            &[0, 0, 0, 1, 0x09, 0xf0][..],      // AUD
            &[0, 0, 0, 1, 0x67, 1, 2],          // SPS
            &[0, 0, 0, 1, 0x68, 3],             // PPS
            &[0, 0, 1, 0x65, 0xaa, 0, 0, 3, 1], // IDR (with an emulation-prevented 00 00 03)
            &[0, 0, 0, 1, 0x09, 0xf0],          // AUD
            &[0, 0, 1, 0x41, 0xbb],             // non-IDR slice
        ]
        .concat();
        let units = split_access_units(&stream).unwrap();
        assert_eq!(units.len(), 2);
        assert!(units[0].key);
        assert!(!units[1].key);
        assert_eq!(units[0].nal_types(), vec![9, 7, 8, 5]);
        assert_eq!(units[1].nal_types(), vec![9, 1]);
        assert_eq!(
            units.iter().map(|u| u.data.len()).sum::<usize>(),
            stream.len()
        );
        assert_eq!(units[1].data[..5], [0, 0, 0, 1, 0x09]);
    }

    #[test]
    fn rejects_streams_without_delimiters() {
        assert_eq!(split_access_units(&[]), Err(AnnexBError::Empty));
        assert_eq!(
            split_access_units(&[0, 0, 1, 0x65, 1]),
            Err(AnnexBError::BeforeDelimiter {
                nal_type: 5,
                offset: 0
            })
        );
        let err = split_access_units(&[7, 0, 0, 1, 0x09, 0xf0]).unwrap_err();
        assert_eq!(err, AnnexBError::LeadingBytes { bytes: 1 });
        assert_eq!(err.to_string(), "1 bytes before the first start code");
    }
}
