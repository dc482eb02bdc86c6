//! A fast decoder of `autoact_msgs/msg/Skeleton3D` for readers that decode message after
//! message of one stream ([`SkeletonReader`]).
//!
//! A 133-keypoint whole-body skeleton is 5,970 bytes of CDR, and its 133 joint names are most of
//! what serde decodes: each one a length, a UTF-8 check and a copy into its `String`, although
//! the names are the same in every message of a stream (a fifth of a whole-body `convert`'s
//! instructions). Here the bytes of the names are kept: when the next message holds the same
//! bytes at the same place, its names are the ones already decoded, and one comparison of the
//! bytes stands for 133 decodings. Otherwise each string is compared with the one in place and
//! decoded only when it differs. Numbers are read straight from the bytes. The value decoded is
//! the one [`super::cdr::decode_in_place`] gives, field for field; anything this path does not
//! take (big-endian CDR, a payload that ends early, a string that is not UTF-8 or lacks its
//! NUL) goes to that serde path, which decodes it or names the problem.

use super::autoact_msgs::Skeleton3D;
use super::cdr::{self, CdrError, HEADER_LE};
use super::geometry_msgs::Point;

/// Decodes skeleton after skeleton into one [`Skeleton3D`], reusing its allocations and the
/// names of the message before.
#[derive(Debug, Default)]
pub struct SkeletonReader {
    message: Skeleton3D,
    /// The CDR bytes of `message.joint_names` (count, strings and the padding between them), and
    /// where in the body they started; empty when unknown.
    names_bytes: Vec<u8>,
    names_at: usize,
}

impl SkeletonReader {
    /// Decodes `payload` (CDR with its encapsulation header) as [`cdr::decode`] would, and
    /// returns the message.
    ///
    /// # Errors
    /// As [`cdr::decode`].
    pub fn decode(&mut self, payload: &[u8]) -> Result<&Skeleton3D, CdrError> {
        if let Some(body) = payload.strip_prefix(&HEADER_LE)
            && self.fast(body).is_some()
        {
            return Ok(&self.message);
        }
        self.names_bytes.clear();
        cdr::decode_in_place(payload, &mut self.message)?;
        Ok(&self.message)
    }

    fn fast(&mut self, body: &[u8]) -> Option<()> {
        let mut c = Cursor { body, pos: 0 };
        let s = &mut self.message;
        s.header.stamp.sec = i32::from_le_bytes(c.array()?);
        s.header.stamp.nanosec = c.u32()?;
        c.string(&mut s.header.frame_id)?;
        c.string(&mut s.layout)?;
        s.track_id = u64::from_le_bytes(c.array()?);
        let at = c.pos;
        let known = self.names_at == at
            && !self.names_bytes.is_empty()
            && body.get(at..at + self.names_bytes.len()) == Some(&self.names_bytes[..]);
        if known {
            c.pos = at + self.names_bytes.len();
        } else {
            self.names_bytes.clear();
            c.names(&mut s.joint_names)?;
            self.names_bytes.extend_from_slice(&body[at..c.pos]);
            self.names_at = at;
        }
        let n = c.length(24)?;
        let bytes = c.take(8, n * 24)?;
        s.positions.clear();
        s.positions.extend(bytes.chunks_exact(24).map(|p| {
            let f = |k: usize| f64::from_le_bytes(p[k..k + 8].try_into().unwrap_or_default());
            Point {
                x: f(0),
                y: f(8),
                z: f(16),
            }
        }));
        let n = c.length(4)?;
        let bytes = c.take(4, n * 4)?;
        s.confidence.clear();
        s.confidence.extend(
            bytes
                .chunks_exact(4)
                .map(|v| f32::from_le_bytes(v.try_into().unwrap_or_default())),
        );
        Some(())
    }
}

/// A little-endian CDR body being read: primitives aligned to their size from the body's start,
/// as `cdr-encoding` reads them. `None` from any read: not this path's to decode.
struct Cursor<'b> {
    body: &'b [u8],
    pos: usize,
}

impl<'b> Cursor<'b> {
    /// The next `n` bytes after aligning to `align` (a power of two).
    fn take(&mut self, align: usize, n: usize) -> Option<&'b [u8]> {
        let start = self.pos.checked_add(align - 1)? & !(align - 1);
        let bytes = self.body.get(start..start.checked_add(n)?)?;
        self.pos = start + n;
        Some(bytes)
    }

    fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        self.take(N, N)?.try_into().ok()
    }

    fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_le_bytes)
    }

    /// A sequence length, when the bytes left can hold that many elements of at least
    /// `min_bytes` each (so that a damaged length allocates nothing).
    fn length(&mut self, min_bytes: usize) -> Option<usize> {
        let n = usize::try_from(self.u32()?).ok()?;
        (n.checked_mul(min_bytes)? <= self.body.len().saturating_sub(self.pos)).then_some(n)
    }

    /// A string into `place`: its length (counting the NUL), its bytes, the NUL. Left as it is
    /// when equal. One without its NUL is serde's (`cdr-encoding` takes it, with a warning).
    fn string(&mut self, place: &mut String) -> Option<()> {
        let n = usize::try_from(self.u32()?).ok()?;
        let bytes = self.take(1, n)?;
        let (&0, text) = bytes.split_last()? else {
            return None;
        };
        if text != place.as_bytes() {
            let text = std::str::from_utf8(text).ok()?;
            place.clear();
            place.push_str(text);
        }
        Some(())
    }

    /// A sequence of strings into `names`.
    fn names(&mut self, names: &mut Vec<String>) -> Option<()> {
        // A string is at least its 4-byte length.
        let n = self.length(4)?;
        names.truncate(n);
        for k in 0..n {
            if k == names.len() {
                names.push(String::new());
            }
            self.string(&mut names[k])?;
        }
        Some(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros::builtin_interfaces::Time;
    use crate::ros::std_msgs::Header;
    use proptest::prelude::*;

    fn skeleton(names: &[&str], sec: i32, layout: &str, x: f64) -> Skeleton3D {
        Skeleton3D {
            header: Header {
                stamp: Time { sec, nanosec: 7 },
                frame_id: "world".into(),
            },
            layout: layout.into(),
            track_id: 3,
            joint_names: names.iter().map(|n| (*n).to_string()).collect(),
            positions: (0..names.len())
                .map(|k| Point {
                    x: x + k as f64,
                    y: -1.5,
                    z: f64::NAN,
                })
                .collect(),
            confidence: (0..names.len()).map(|k| k as f32 / 10.0).collect(),
        }
    }

    /// What the serde path decodes `payload` to over `place`, or its error.
    fn serde_over(payload: &[u8], mut place: Skeleton3D) -> Result<String, String> {
        cdr::decode_in_place(payload, &mut place)
            .map(|()| format!("{place:?}"))
            .map_err(|e| e.to_string())
    }

    /// What a reader that last decoded `place` (fast, when it can) decodes `payload` to.
    fn fast_over(payload: &[u8], place: &Skeleton3D) -> Result<String, String> {
        let mut reader = SkeletonReader::default();
        reader.decode(&cdr::encode(place).unwrap()).unwrap();
        reader
            .decode(payload)
            .map(|m| format!("{m:?}"))
            .map_err(|e| e.to_string())
    }

    #[test]
    fn a_stream_decodes_as_serde_decodes_it_names_changing_or_not() {
        let stream = [
            skeleton(&["a", "bb", "ccc"], 1, "h36m-17", 0.5),
            skeleton(&["a", "bb", "ccc"], 2, "h36m-17", 1.5),
            skeleton(&["a", "bX", "ccc", "dddd"], 3, "other", 2.5),
            skeleton(&["é"], 4, "", -1.0),
            skeleton(&[], 5, "h36m-17", 0.0),
            skeleton(&["a", "bb", "ccc"], 6, "h36m-17", 0.5),
        ];
        let mut reader = SkeletonReader::default();
        for msg in &stream {
            let payload = cdr::encode(msg).unwrap();
            let expected: Skeleton3D = cdr::decode(&payload).unwrap();
            let fast = reader.decode(&payload).unwrap();
            // Debug text: NaN positions compare unequal with `==`.
            assert_eq!(format!("{fast:?}"), format!("{expected:?}"));
        }
        // The same names after a message that failed: decoded, not taken from before.
        let payload = cdr::encode(&stream[0]).unwrap();
        assert!(reader.decode(&payload[..payload.len() / 2]).is_err());
        let after = reader.decode(&payload).unwrap();
        assert_eq!(format!("{after:?}"), format!("{:?}", stream[0]));
    }

    #[test]
    fn damaged_and_big_endian_payloads_give_serdes_result() {
        let msg = skeleton(&["a", "bb", "ccc"], 1, "h36m-17", 0.5);
        let payload = cdr::encode(&msg).unwrap();
        let place = skeleton(&["a", "zz"], 9, "x", 4.0);
        for cut in 0..payload.len() {
            let short = &payload[..cut];
            assert_eq!(
                fast_over(short, &place),
                serde_over(short, place.clone()),
                "cut at {cut}"
            );
        }
        // A name that is not UTF-8, and a joint count far beyond the bytes.
        let name_at = payload.windows(3).position(|w| w == b"bb\0").unwrap();
        let mut bad = payload.clone();
        bad[name_at] = 0xff;
        assert!(fast_over(&bad, &place).is_err());
        assert_eq!(fast_over(&bad, &place), serde_over(&bad, place.clone()));
        let mut huge = payload.clone();
        let count_at = name_at - 4 - 8 - 4;
        huge[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        assert_eq!(fast_over(&huge, &place), serde_over(&huge, place.clone()));
        // Big-endian CDR is serde's.
        let mut be = vec![0, 0, 0, 0];
        cdr_encoding::to_writer::<_, byteorder::BigEndian, _>(&mut be, &msg).unwrap();
        assert_eq!(fast_over(&be, &place), serde_over(&be, place));
    }

    proptest! {
        #[test]
        fn any_skeleton_over_any_other_decodes_as_serde_does(
            names in proptest::collection::vec("[a-z_é]{0,12}", 0..20),
            old in proptest::collection::vec("[a-z_é]{0,12}", 0..20),
            sec in any::<i32>(),
            x in any::<f64>(),
            flip in any::<usize>(),
        ) {
            let names: Vec<&str> = names.iter().map(String::as_str).collect();
            let old: Vec<&str> = old.iter().map(String::as_str).collect();
            let msg = skeleton(&names, sec, "coco-wholebody-133", x);
            let mut payload = cdr::encode(&msg).unwrap();
            let place = skeleton(&old, 0, "h36m-17", 0.0);
            prop_assert_eq!(fast_over(&payload, &place), serde_over(&payload, place.clone()));
            // Any one byte damaged: the same value, or the same error.
            let k = 4 + flip % (payload.len() - 4);
            payload[k] ^= 0x80;
            prop_assert_eq!(fast_over(&payload, &place), serde_over(&payload, place));
        }
    }
}
