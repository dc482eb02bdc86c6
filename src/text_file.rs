//! Reading a text input (a TOML layout or spec, an H36M exp-map file): one place that says
//! *where* a file stops being UTF-8, as a line and column, instead of the standard library's
//! bare "stream did not contain valid UTF-8".

use std::path::Path;

/// Reads `path` as UTF-8 text.
///
/// # Errors
/// The I/O error of reading; for bytes that are not UTF-8, an [`std::io::ErrorKind::InvalidData`]
/// error naming the line, column and byte offset of the first bad byte.
pub fn read_to_string(path: &Path) -> std::io::Result<String> {
    let bytes = std::fs::read(path)?;
    String::from_utf8(bytes).map_err(|e| {
        let bytes = e.as_bytes();
        let offset = e.utf8_error().valid_up_to();
        let before = &bytes[..offset];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let line_start = before.iter().rposition(|&b| b == b'\n').map_or(0, |k| k + 1);
        // Columns count characters, as editors do; what precedes the bad byte is valid.
        let column = String::from_utf8_lossy(&before[line_start..]).chars().count() + 1;
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text: invalid byte 0x{:02x} at line {line}, column {column} (byte {offset})", bytes[offset]),
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_first_bad_byte_is_named_by_line_column_and_offset() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.toml");
        std::fs::write(&path, b"a = 1\nb = \"\xc3\xa9\xff\"\n").unwrap();
        let err = read_to_string(&path).unwrap_err();
        assert_eq!(err.kind(), std::io::ErrorKind::InvalidData);
        assert_eq!(
            err.to_string(),
            "not UTF-8 text: invalid byte 0xff at line 2, column 7 (byte 13)"
        );
        std::fs::write(&path, "fine ✓\n").unwrap();
        assert_eq!(read_to_string(&path).unwrap(), "fine ✓\n");
        assert_eq!(
            read_to_string(&dir.path().join("missing"))
                .unwrap_err()
                .kind(),
            std::io::ErrorKind::NotFound
        );
    }
}
