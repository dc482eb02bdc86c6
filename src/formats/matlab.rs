//! A minimal reader of MATLAB level-5 MAT-files (as MATLAB `-v7` and `scipy.io.savemat`
//! write them): real numeric arrays only.
//!
//! # Format
//!
//! A 128-byte header (116 bytes of text starting `MATLAB 5.0 MAT-file`, 8 bytes of subsystem
//! offset, the version `0x0100` and the endian indicator `IM` or `MI`), then top-level data
//! elements, little- or big-endian. Each element is a tag (data type and byte count, or the
//! "small data element" form holding up to 4 bytes in the tag) and its data, padded to 8 bytes.
//! A top-level element is an uncompressed `miMATRIX` or a zlib-compressed `miCOMPRESSED` one
//! holding a `miMATRIX`. A `miMATRIX` holds the array flags (class, complex, logical), the
//! dimensions, the name and, for numeric classes, the real part.
//!
//! [`read_arrays`] returns the arrays of the names asked for, in file order; other variables
//! are read only as far as their names. Non-numeric classes (cell, struct, char, …) come back
//! with [`Values::Skipped`]. MAT v7.3 (HDF5) files are refused.
//!
//! # Errors
//!
//! Never a panic: every problem is a [`MatError`] naming the file and the byte offset of the
//! top-level element: not a MAT v5 file (bad header), a truncated or malformed element, or a
//! compressed element that does not inflate (or inflates past [`MAX_DECOMPRESSED_BYTES`]).

use std::io::Read;

use thiserror::Error;

/// Largest decompressed size accepted for one compressed element (guards against zip bombs).
pub const MAX_DECOMPRESSED_BYTES: u64 = 1 << 29;

/// Why a MAT-file could not be read.
#[derive(Debug, Error)]
#[non_exhaustive]
pub enum MatError {
    /// The file could not be read.
    #[error("{file}: cannot read the file: {error}")]
    Io {
        /// The file.
        file: String,
        /// The underlying error.
        #[source]
        error: std::io::Error,
    },
    /// The 128-byte header is not that of a MAT v5 file.
    #[error("{file}: not a mat v5 file: header {field}: {message}")]
    NotMatV5 {
        /// The file.
        file: String,
        /// The header field that is wrong (`text`, `version`, `endian` or `length`).
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// An element extends past the end of the file (or of its compressed container).
    #[error(
        "{file}: byte {offset}: {element} is truncated: needs {needed} bytes, {available} left"
    )]
    Truncated {
        /// The file.
        file: String,
        /// Byte offset in the file of the top-level element involved.
        offset: usize,
        /// What was being read.
        element: String,
        /// Bytes needed.
        needed: usize,
        /// Bytes available.
        available: usize,
    },
    /// An element is not laid out as MAT v5 requires.
    #[error("{file}: byte {offset}: {element}: {message}")]
    Malformed {
        /// The file.
        file: String,
        /// Byte offset in the file of the top-level element involved.
        offset: usize,
        /// What was being read.
        element: String,
        /// What is wrong.
        message: String,
    },
    /// A compressed element does not inflate.
    #[error("{file}: byte {offset}: compressed element does not decompress")]
    Decompress {
        /// The file.
        file: String,
        /// Byte offset in the file of the compressed element.
        offset: usize,
        /// The decoder's error.
        #[source]
        source: std::io::Error,
    },
    /// A compressed element inflates past [`MAX_DECOMPRESSED_BYTES`].
    #[error(
        "{file}: byte {offset}: compressed element does not decompress: inflates to more than {limit} bytes"
    )]
    TooLarge {
        /// The file.
        file: String,
        /// Byte offset in the file of the compressed element.
        offset: usize,
        /// The limit, bytes.
        limit: u64,
    },
}

const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MI_UTF8: u32 = 16;

const HEADER_LEN: usize = 128;
const COMPLEX_FLAG: u32 = 0x0800;
const LOGICAL_FLAG: u32 = 0x0200;

/// MATLAB array class.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// `double`.
    Double,
    /// `single`.
    Single,
    /// `int8`.
    Int8,
    /// `uint8`.
    UInt8,
    /// `int16`.
    Int16,
    /// `uint16`.
    UInt16,
    /// `int32`.
    Int32,
    /// `uint32`.
    UInt32,
    /// `int64`.
    Int64,
    /// `uint64`.
    UInt64,
    /// A non-numeric class (cell, struct, object, char, sparse, ...), by code.
    Other(u8),
}

impl Class {
    fn from_code(code: u8) -> Self {
        match code {
            6 => Class::Double,
            7 => Class::Single,
            8 => Class::Int8,
            9 => Class::UInt8,
            10 => Class::Int16,
            11 => Class::UInt16,
            12 => Class::Int32,
            13 => Class::UInt32,
            14 => Class::Int64,
            15 => Class::UInt64,
            other => Class::Other(other),
        }
    }

    /// Whether it is one of the integer classes.
    #[must_use]
    pub fn is_integer(self) -> bool {
        !matches!(self, Class::Double | Class::Single | Class::Other(_))
    }

    fn name(self) -> String {
        match self {
            Class::Double => "double".into(),
            Class::Single => "single".into(),
            Class::Int8 => "int8".into(),
            Class::UInt8 => "uint8".into(),
            Class::Int16 => "int16".into(),
            Class::UInt16 => "uint16".into(),
            Class::Int32 => "int32".into(),
            Class::UInt32 => "uint32".into(),
            Class::Int64 => "int64".into(),
            Class::UInt64 => "uint64".into(),
            Class::Other(1) => "cell".into(),
            Class::Other(2) => "struct".into(),
            Class::Other(3) => "object".into(),
            Class::Other(4) => "char".into(),
            Class::Other(5) => "sparse".into(),
            Class::Other(code) => format!("class {code}"),
        }
    }
}

/// Decoded values of a numeric array, by storage kind.
#[derive(Debug, Clone, PartialEq)]
pub enum Values {
    /// `single` or `double` data, widened.
    Float(Vec<f64>),
    /// Integer data of any width and sign, widened.
    Int(Vec<i128>),
    /// Not decoded (non-numeric class).
    Skipped,
}

/// One array asked for, as stored: column-major values.
#[derive(Debug, Clone, PartialEq)]
pub struct Array {
    /// The variable's name.
    pub name: String,
    /// Byte offset of its top-level element in the file.
    pub offset: usize,
    /// Its class.
    pub class: Class,
    /// The complex flag (only the real part is read).
    pub complex: bool,
    /// The logical flag.
    pub logical: bool,
    /// Its dimensions.
    pub dims: Vec<usize>,
    /// Its real part (as many values as the dimensions hold).
    pub values: Values,
}

impl Array {
    /// Its type for messages: `complex single array`, `int32 array`, ….
    #[must_use]
    pub fn describe_type(&self) -> String {
        let mut s = String::new();
        if self.complex {
            s += "complex ";
        }
        if self.logical {
            s += "logical ";
        }
        s += &self.class.name();
        s += " array";
        s
    }
}

/// Dimensions for messages: `(a, b, c)`.
#[must_use]
pub fn shape(dims: &[usize]) -> String {
    let parts: Vec<String> = dims.iter().map(ToString::to_string).collect();
    format!("({})", parts.join(", "))
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum Endian {
    Little,
    Big,
}

/// Reading state: file name, byte order, and the top-level element being read.
struct Ctx<'a> {
    file: &'a str,
    endian: Endian,
    /// Offset in the file of the current top-level element.
    offset: usize,
}

/// An element tag: data type and the data bytes; `next` is where the following element
/// starts (after padding).
struct Element<'b> {
    data_type: u32,
    data: &'b [u8],
    next: usize,
}

impl Ctx<'_> {
    fn truncated(&self, element: &str, needed: usize, available: usize) -> MatError {
        MatError::Truncated {
            file: self.file.to_owned(),
            offset: self.offset,
            element: element.to_owned(),
            needed,
            available,
        }
    }

    fn malformed(&self, element: &str, message: String) -> MatError {
        MatError::Malformed {
            file: self.file.to_owned(),
            offset: self.offset,
            element: element.to_owned(),
            message,
        }
    }

    fn u32_at(&self, bytes: &[u8], pos: usize, element: &str) -> Result<u32, MatError> {
        let available = bytes.len().saturating_sub(pos);
        let chunk: [u8; 4] = bytes
            .get(pos..pos.saturating_add(4))
            .and_then(|s| s.try_into().ok())
            .ok_or_else(|| self.truncated(element, 4, available))?;
        Ok(match self.endian {
            Endian::Little => u32::from_le_bytes(chunk),
            Endian::Big => u32::from_be_bytes(chunk),
        })
    }

    /// The element whose tag starts at `pos` in `bytes`. `padded`: data is followed by
    /// padding to a multiple of 8 bytes (not so for compressed elements).
    fn element<'b>(
        &self,
        bytes: &'b [u8],
        pos: usize,
        element: &str,
    ) -> Result<Element<'b>, MatError> {
        let first = self.u32_at(bytes, pos, element)?;
        if first >> 16 != 0 {
            // Small data element: type and size in 4 bytes, up to 4 data bytes.
            let size = (first >> 16) as usize;
            let data_type = first & 0xffff;
            if size > 4 {
                return Err(self.malformed(
                    element,
                    format!("small data element claims {size} bytes (at most 4)"),
                ));
            }
            let start = pos.saturating_add(4);
            let data = bytes
                .get(start..start.saturating_add(size))
                .ok_or_else(|| self.truncated(element, 4, bytes.len().saturating_sub(start)))?;
            return Ok(Element {
                data_type,
                data,
                next: pos.saturating_add(8),
            });
        }
        let size = self.u32_at(bytes, pos.saturating_add(4), element)? as usize;
        let start = pos.saturating_add(8);
        let end = start.saturating_add(size);
        let data = bytes
            .get(start..end)
            .ok_or_else(|| self.truncated(element, size, bytes.len().saturating_sub(start)))?;
        let next = if first == MI_COMPRESSED {
            end
        } else {
            end.saturating_add(7) / 8 * 8
        };
        Ok(Element {
            data_type: first,
            data,
            next,
        })
    }
}

/// The bytes of the file at `path`, and the path as errors show it: the one place the readers
/// of MAT formats (ZED, UTD-MHAD) open their files.
///
/// # Errors
/// [`MatError::Io`] naming the file.
pub fn read_file(path: &std::path::Path) -> Result<(Vec<u8>, String), MatError> {
    let file = path.display().to_string();
    match std::fs::read(path) {
        Ok(bytes) => Ok((bytes, file)),
        Err(error) => Err(MatError::Io { file, error }),
    }
}

/// Parse a MAT v5 file and return the arrays named in `wanted` (in file order; other
/// variables are validated only as far as their names); `file` names it in errors.
///
/// # Errors
/// [`MatError`]; see the module docs.
pub fn read_arrays(bytes: &[u8], file: &str, wanted: &[&str]) -> Result<Vec<Array>, MatError> {
    let not_mat = |field, message: &str| MatError::NotMatV5 {
        file: file.to_owned(),
        field,
        message: message.to_owned(),
    };
    let header = bytes.get(..HEADER_LEN).ok_or_else(|| {
        not_mat(
            "length",
            &format!("file has {} bytes, the header alone 128", bytes.len()),
        )
    })?;
    let text = header.get(..116).unwrap_or_default();
    if text.starts_with(b"MATLAB 7.3") {
        return Err(not_mat(
            "text",
            "this is a mat v7.3 (hdf5) file; save with -v7 or scipy",
        ));
    }
    if !text.starts_with(b"MATLAB 5.0 MAT-file") {
        return Err(not_mat(
            "text",
            "does not start with \"MATLAB 5.0 MAT-file\"",
        ));
    }
    let endian = match header.get(126..128) {
        Some(b"IM") => Endian::Little,
        Some(b"MI") => Endian::Big,
        _ => return Err(not_mat("endian", "indicator is neither \"IM\" nor \"MI\"")),
    };
    let version = match (endian, header.get(124..126)) {
        (Endian::Little, Some(&[a, b])) => u16::from_le_bytes([a, b]),
        (Endian::Big, Some(&[a, b])) => u16::from_be_bytes([a, b]),
        _ => 0,
    };
    if version != 0x0100 {
        return Err(not_mat(
            "version",
            &format!("is {version:#06x}, expected 0x0100"),
        ));
    }

    let mut arrays = Vec::new();
    let mut pos = HEADER_LEN;
    while pos < bytes.len() {
        let ctx = Ctx {
            file,
            endian,
            offset: pos,
        };
        let what = "top-level element";
        let element = ctx.element(bytes, pos, what)?;
        let found = match element.data_type {
            MI_MATRIX => matrix(&ctx, element.data, wanted)?,
            MI_COMPRESSED => {
                let inflated = inflate(&ctx, element.data)?;
                let inner = ctx.element(&inflated, 0, "compressed element's content")?;
                if inner.data_type != MI_MATRIX {
                    return Err(ctx.malformed(
                        "compressed element's content",
                        format!("data type {} is not miMATRIX (14)", inner.data_type),
                    ));
                }
                matrix(&ctx, inner.data, wanted)?
            }
            other => {
                return Err(ctx.malformed(
                    what,
                    format!("data type {other} is not miMATRIX (14) or miCOMPRESSED (15)"),
                ));
            }
        };
        arrays.extend(found);
        pos = element.next;
    }
    Ok(arrays)
}

fn inflate(ctx: &Ctx<'_>, data: &[u8]) -> Result<Vec<u8>, MatError> {
    let mut out = Vec::new();
    flate2::read::ZlibDecoder::new(data)
        .take(MAX_DECOMPRESSED_BYTES + 1)
        .read_to_end(&mut out)
        .map_err(|source| MatError::Decompress {
            file: ctx.file.to_owned(),
            offset: ctx.offset,
            source,
        })?;
    if out.len() as u64 > MAX_DECOMPRESSED_BYTES {
        return Err(MatError::TooLarge {
            file: ctx.file.to_owned(),
            offset: ctx.offset,
            limit: MAX_DECOMPRESSED_BYTES,
        });
    }
    Ok(out)
}

/// The content of a miMATRIX element → the array, if its name is wanted.
fn matrix(ctx: &Ctx<'_>, content: &[u8], wanted: &[&str]) -> Result<Option<Array>, MatError> {
    let flags = ctx.element(content, 0, "array flags")?;
    if flags.data_type != MI_UINT32 || flags.data.len() != 8 {
        return Err(ctx.malformed(
            "array flags",
            format!(
                "expected miUINT32 (6) with 8 bytes, found type {} with {} bytes",
                flags.data_type,
                flags.data.len()
            ),
        ));
    }
    let flag_word = ctx.u32_at(flags.data, 0, "array flags")?;
    let class = Class::from_code((flag_word & 0xff) as u8);
    let complex = flag_word & COMPLEX_FLAG != 0;
    let logical = flag_word & LOGICAL_FLAG != 0;

    let dims_el = ctx.element(content, flags.next, "dimensions")?;
    if dims_el.data_type != MI_INT32
        || !dims_el.data.len().is_multiple_of(4)
        || dims_el.data.len() < 8
    {
        return Err(ctx.malformed(
            "dimensions",
            format!(
                "expected at least two miINT32 (5), found type {} with {} bytes",
                dims_el.data_type,
                dims_el.data.len()
            ),
        ));
    }
    let mut dims = Vec::with_capacity(dims_el.data.len() / 4);
    for i in 0..dims_el.data.len() / 4 {
        let raw = ctx.u32_at(dims_el.data, i * 4, "dimensions")?;
        let dim = i32::from_ne_bytes(raw.to_ne_bytes());
        let dim = usize::try_from(dim).map_err(|_| {
            ctx.malformed("dimensions", format!("dimension {i} is negative ({dim})"))
        })?;
        dims.push(dim);
    }

    let name_el = ctx.element(content, dims_el.next, "array name")?;
    if !matches!(name_el.data_type, MI_INT8 | MI_UINT8 | MI_UTF8) {
        return Err(ctx.malformed(
            "array name",
            format!("expected miINT8 (1), found type {}", name_el.data_type),
        ));
    }
    let name = String::from_utf8_lossy(name_el.data).into_owned();
    if !wanted.contains(&name.as_str()) {
        return Ok(None);
    }
    let element = format!("variable {name:?}");

    let values = if matches!(class, Class::Other(_)) {
        Values::Skipped
    } else {
        let real = ctx.element(content, name_el.next, &format!("{element} real part"))?;
        let values = decode(ctx, &element, real.data_type, real.data)?;
        let count = dims.iter().try_fold(1_usize, |acc, d| acc.checked_mul(*d));
        let stored = match &values {
            Values::Float(v) => v.len(),
            Values::Int(v) => v.len(),
            Values::Skipped => 0,
        };
        if count != Some(stored) {
            return Err(ctx.malformed(
                &element,
                format!(
                    "holds {stored} values but its shape {} needs more or fewer",
                    shape(&dims)
                ),
            ));
        }
        values
    };
    Ok(Some(Array {
        name,
        offset: ctx.offset,
        class,
        complex,
        logical,
        dims,
        values,
    }))
}

/// Decode numeric data of MAT data type `data_type`.
fn decode(ctx: &Ctx<'_>, element: &str, data_type: u32, data: &[u8]) -> Result<Values, MatError> {
    let width = match data_type {
        MI_INT8 | MI_UINT8 => 1,
        MI_INT16 | MI_UINT16 => 2,
        MI_INT32 | MI_UINT32 | MI_SINGLE => 4,
        MI_DOUBLE | MI_INT64 | MI_UINT64 => 8,
        other => {
            return Err(ctx.malformed(
                element,
                format!("data type {other} is not a numeric mat type"),
            ));
        }
    };
    if !data.len().is_multiple_of(width) {
        return Err(ctx.malformed(
            element,
            format!("{} data bytes are not a multiple of {width}", data.len()),
        ));
    }
    let little = ctx.endian == Endian::Little;
    let words = data.chunks_exact(width).map(|c| {
        let mut b = [0u8; 8];
        for (dst, src) in b.iter_mut().zip(c) {
            *dst = *src;
        }
        if !little {
            b.get_mut(..width).unwrap_or_default().reverse();
        }
        u64::from_le_bytes(b)
    });
    #[allow(
        clippy::cast_possible_truncation,
        reason = "each word holds only `width` bytes"
    )]
    let values = match data_type {
        MI_SINGLE => Values::Float(words.map(|w| f64::from(f32::from_bits(w as u32))).collect()),
        MI_DOUBLE => Values::Float(words.map(f64::from_bits).collect()),
        MI_INT8 => Values::Int(words.map(|w| i128::from(w as u8 as i8)).collect()),
        MI_INT16 => Values::Int(words.map(|w| i128::from(w as u16 as i16)).collect()),
        MI_INT32 => Values::Int(words.map(|w| i128::from(w as u32 as i32)).collect()),
        MI_INT64 => Values::Int(words.map(|w| i128::from(w as i64)).collect()),
        _ => Values::Int(words.map(i128::from).collect()),
    };
    Ok(values)
}

/// MAT v5 files built byte by byte, for the tests of this reader and of the readers on it.
#[cfg(test)]
pub(crate) mod test_files {
    use std::io::Write;

    /// Builds MAT v5 files for tests.
    pub(crate) struct Mat {
        big: bool,
        pub(crate) bytes: Vec<u8>,
    }

    impl Mat {
        pub(crate) fn new(big: bool) -> Self {
            let mut bytes =
                b"MATLAB 5.0 MAT-file, Platform: test, Created by autoact tests".to_vec();
            bytes.resize(116, b' ');
            bytes.extend([0u8; 8]);
            if big {
                bytes.extend([0x01, 0x00]);
                bytes.extend(b"MI");
            } else {
                bytes.extend([0x00, 0x01]);
                bytes.extend(b"IM");
            }
            Mat { big, bytes }
        }

        pub(crate) fn u32(&self, v: u32) -> [u8; 4] {
            if self.big {
                v.to_be_bytes()
            } else {
                v.to_le_bytes()
            }
        }

        /// A tagged sub-element padded to 8 bytes.
        pub(crate) fn sub(&self, data_type: u32, data: &[u8]) -> Vec<u8> {
            let mut out = Vec::new();
            out.extend(self.u32(data_type));
            out.extend(self.u32(data.len() as u32));
            out.extend(data);
            while out.len() % 8 != 0 {
                out.push(0);
            }
            out
        }

        /// A miMATRIX element. `values` are already encoded words of `data_type`.
        pub(crate) fn matrix(
            &self,
            class: u8,
            dims: &[i32],
            name: &str,
            data_type: u32,
            data: &[u8],
        ) -> Vec<u8> {
            let mut content = Vec::new();
            content.extend(self.sub(6, &[self.u32(u32::from(class)), [0; 4]].concat()));
            let dims: Vec<u8> = dims.iter().flat_map(|d| self.u32(*d as u32)).collect();
            content.extend(self.sub(5, &dims));
            if name.len() <= 4 {
                // small data element, as MATLAB and scipy write short names
                let mut small = self.u32((name.len() as u32) << 16 | 1).to_vec();
                small.extend(name.as_bytes());
                small.resize(8, 0);
                content.extend(small);
            } else {
                content.extend(self.sub(1, name.as_bytes()));
            }
            content.extend(self.sub(data_type, data));
            let mut out = Vec::new();
            out.extend(self.u32(14));
            out.extend(self.u32(content.len() as u32));
            out.extend(content);
            out
        }

        pub(crate) fn f32s(&self, v: &[f32]) -> Vec<u8> {
            v.iter().flat_map(|x| self.u32(x.to_bits())).collect()
        }

        /// 8-byte words in the file's byte order.
        fn words8(&self, v: impl Iterator<Item = u64>) -> Vec<u8> {
            v.flat_map(|x| {
                if self.big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                }
            })
            .collect()
        }

        pub(crate) fn f64s(&self, v: &[f64]) -> Vec<u8> {
            self.words8(v.iter().map(|x| x.to_bits()))
        }

        pub(crate) fn i64s(&self, v: &[i64]) -> Vec<u8> {
            self.words8(v.iter().map(|&x| u64::from_ne_bytes(x.to_ne_bytes())))
        }

        pub(crate) fn push(mut self, element: Vec<u8>) -> Self {
            self.bytes.extend(element);
            self
        }

        pub(crate) fn push_compressed(mut self, element: &[u8]) -> Self {
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            z.write_all(element).expect("in memory");
            let packed = z.finish().expect("in memory");
            self.bytes.extend(self.u32(15));
            self.bytes.extend(self.u32(packed.len() as u32));
            self.bytes.extend(packed);
            self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::test_files::Mat;
    use super::*;
    use proptest::prelude::*;

    const WANTED: [&str; 2] = ["keypoints", "timestampList"];

    /// A file of three variables: `timestampList` (int64, 1×3), `fps` (double, not asked for)
    /// and `keypoints` (single, 3×2).
    fn file(big: bool, compressed: bool) -> Vec<u8> {
        let m = Mat::new(big);
        let stamps = m.matrix(14, &[1, 3], "timestampList", 12, &m.i64s(&[10, -20, 30]));
        let other = m.matrix(6, &[1, 1], "fps", 9, &2.5f64.to_le_bytes());
        let kp = m.matrix(
            7,
            &[3, 2],
            "keypoints",
            7,
            &m.f32s(&[0.5, 1.0, 1.5, 2.0, 2.5, 3.0]),
        );
        if compressed {
            m.push_compressed(&stamps)
                .push_compressed(&other)
                .push_compressed(&kp)
                .bytes
        } else {
            m.push(stamps).push(other).push(kp).bytes
        }
    }

    fn err(bytes: &[u8]) -> MatError {
        match read_arrays(bytes, "t.mat", &WANTED) {
            Ok(a) => panic!("expected an error, got {} arrays", a.len()),
            Err(e) => e,
        }
    }

    #[test]
    fn reads_plain_compressed_and_big_endian_arrays() {
        for (big, compressed) in [(false, false), (false, true), (true, false), (true, true)] {
            let arrays = read_arrays(&file(big, compressed), "t.mat", &WANTED).expect("valid");
            let names: Vec<&str> = arrays.iter().map(|a| a.name.as_str()).collect();
            assert_eq!(names, ["timestampList", "keypoints"], "file order");
            assert_eq!(arrays[0].class, Class::Int64);
            assert_eq!(arrays[0].dims, [1, 3]);
            assert_eq!(arrays[0].values, Values::Int(vec![10, -20, 30]));
            assert_eq!(arrays[0].offset, 128);
            assert_eq!(arrays[1].describe_type(), "single array");
            assert_eq!(shape(&arrays[1].dims), "(3, 2)");
            assert_eq!(
                arrays[1].values,
                Values::Float(vec![0.5, 1.0, 1.5, 2.0, 2.5, 3.0])
            );
        }
    }

    #[test]
    fn bad_headers() {
        assert!(matches!(
            err(b"MATLAB 5.0"),
            MatError::NotMatV5 {
                field: "length",
                ..
            }
        ));
        let mut b = file(false, false);
        b[0] = b'X';
        assert!(matches!(err(&b), MatError::NotMatV5 { field: "text", .. }));
        let mut b = file(false, false);
        b[..10].copy_from_slice(b"MATLAB 7.3");
        assert!(matches!(err(&b), MatError::NotMatV5 { field: "text", .. }));
        let mut b = file(false, false);
        b[126] = b'X';
        assert!(matches!(
            err(&b),
            MatError::NotMatV5 {
                field: "endian",
                ..
            }
        ));
        let mut b = file(false, false);
        b[125] = 2;
        let e = err(&b);
        assert!(matches!(
            e,
            MatError::NotMatV5 {
                field: "version",
                ..
            }
        ));
        assert_eq!(
            e.to_string(),
            "t.mat: not a mat v5 file: header version: is 0x0200, expected 0x0100"
        );
    }

    #[test]
    fn malformed_and_undecompressable_elements() {
        let m = Mat::new(false);
        // a top-level element of type miDOUBLE
        let b = Mat::new(false).push(m.sub(9, &[0; 8])).bytes;
        assert!(matches!(err(&b), MatError::Malformed { offset: 128, .. }));
        // values do not fill the shape
        let short = m.matrix(7, &[3, 34, 3], "keypoints", 7, &m.f32s(&[0.0; 5]));
        match err(&Mat::new(false).push(short).bytes) {
            MatError::Malformed { element, .. } => assert_eq!(element, "variable \"keypoints\""),
            e => panic!("{e}"),
        }
        // garbage inside a compressed element
        let mut b = Mat::new(false).bytes;
        b.extend(15u32.to_le_bytes());
        b.extend(4u32.to_le_bytes());
        b.extend([1, 2, 3, 4]);
        assert!(matches!(err(&b), MatError::Decompress { offset: 128, .. }));
        // negative dimension
        let neg = m.matrix(7, &[-1, 34, 3], "keypoints", 7, &[]);
        assert!(matches!(
            err(&Mat::new(false).push(neg).bytes),
            MatError::Malformed { .. }
        ));
    }

    #[test]
    fn truncation_at_every_offset_is_an_error_or_drops_whole_variables() {
        for compressed in [false, true] {
            let b = file(false, compressed);
            for k in 0..b.len() {
                match read_arrays(&b[..k], "t.mat", &WANTED) {
                    // a cut exactly between elements drops the variables after it
                    Ok(arrays) => assert!(arrays.len() < 2, "cut at {k} kept every variable"),
                    Err(MatError::NotMatV5 { .. }) => assert!(k < 128),
                    Err(MatError::Truncated { .. }) => {}
                    Err(e) => panic!("cut at {k}: unexpected {e}"),
                }
            }
        }
    }

    proptest! {
        #[test]
        fn arbitrary_elements_after_a_valid_header_never_panic(
            tail in proptest::collection::vec(any::<u8>(), 0..600),
        ) {
            let mut bytes = Mat::new(false).bytes;
            bytes.extend(tail);
            let _ = read_arrays(&bytes, "p", &WANTED);
        }
    }
}
