//! Readers for the motion-capture and skeleton file formats autoact imports.
//!
//! Each reader is its own module with its own error type; errors name the file and the line,
//! frame or field that was wrong. Readers produce [`crate::skeleton::pose::PoseSequence`]s in the autoact
//! frame (converting axes once, through [`crate::skeleton::frames::SourceAxes`]) and in metres.

pub mod bvh;
pub mod bvh_map;
pub mod h36m_expmap;
pub mod import;
pub mod matlab;
pub mod mmpose_json;
pub mod ntu;
pub mod panoptic;
pub mod utd_mat;
pub mod zed_mat;

/// Why a text file could not be read.
#[derive(Debug)]
pub(crate) enum TextError {
    /// The file could not be read.
    Io(std::io::Error),
    /// It is not UTF-8: the first bad byte is on this 1-based line.
    NotUtf8 { line: usize },
}

/// Reads a whole file as UTF-8 text, locating the first invalid byte (one place for every
/// text reader).
pub(crate) fn read_text(path: &std::path::Path) -> Result<String, TextError> {
    let bytes = std::fs::read(path).map_err(TextError::Io)?;
    String::from_utf8(bytes).map_err(|e| {
        let valid = e
            .as_bytes()
            .get(..e.utf8_error().valid_up_to())
            .unwrap_or_default();
        TextError::NotUtf8 {
            line: 1 + valid.iter().filter(|b| **b == b'\n').count(),
        }
    })
}
