//! Instants on a bag's timeline as people write them: ISO 8601 / RFC 3339 with a UTC offset
//! (parsed and printed with `chrono`), to and from nanoseconds since the Unix epoch, the unit of
//! every stamp autoact writes. The one place both directions are decided: the dataset spec's
//! `[dataset] start_time` and `import --start-time` read instants here, metadata records print
//! them here.

/// Where timelines without a time of their own start (a dataset spec without `start_time`, a
/// file `import` reads): fixed, so that the same input gives byte-identical bags.
pub const DEFAULT_START_TIME: &str = "2000-01-01T00:00:00Z";

/// Why a text is not an instant a bag can stamp.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum StartTimeError {
    /// Not ISO 8601 / RFC 3339, or without a UTC offset.
    #[error("{text:?} is not an ISO 8601 instant with a UTC offset (e.g. {DEFAULT_START_TIME})")]
    Parse {
        /// The value.
        text: String,
        /// chrono's reason.
        #[source]
        source: chrono::ParseError,
    },
    /// Before the Unix epoch, or past what 64-bit nanoseconds hold.
    #[error("{text}: must be between 1970 and 2554")]
    OutOfRange {
        /// The value.
        text: String,
    },
}

/// Nanoseconds since the Unix epoch of `text`, an ISO 8601 / RFC 3339 instant with a UTC offset
/// (`2024-05-01T09:00:00Z`, `2024-05-01T09:00:00.5+02:00`).
///
/// # Errors
/// [`StartTimeError`]: no UTC offset, not an instant, before 1970 or after 2554.
pub fn nanos_since_epoch(text: &str) -> Result<u64, StartTimeError> {
    match chrono::DateTime::parse_from_rfc3339(text) {
        Ok(instant) => instant
            .timestamp_nanos_opt()
            .and_then(|n| u64::try_from(n).ok())
            .ok_or_else(|| StartTimeError::OutOfRange {
                text: text.to_owned(),
            }),
        Err(source) => Err(StartTimeError::Parse {
            text: text.to_owned(),
            source,
        }),
    }
}

/// `nanos` since the Unix epoch as an ISO 8601 instant in UTC (`2000-01-01T00:00:00Z`, with as
/// many fraction digits as it needs).
#[must_use]
pub fn iso_8601(nanos: u64) -> String {
    let nanos = i64::try_from(nanos).unwrap_or(i64::MAX);
    chrono::DateTime::from_timestamp_nanos(nanos)
        .to_rfc3339_opts(chrono::SecondsFormat::AutoSi, true)
}

#[cfg(test)]
mod tests {
    use super::{DEFAULT_START_TIME, iso_8601, nanos_since_epoch};

    #[test]
    fn instants_read_and_print_back() {
        assert_eq!(
            nanos_since_epoch(DEFAULT_START_TIME).unwrap(),
            946_684_800_000_000_000
        );
        assert_eq!(iso_8601(946_684_800_000_000_000), DEFAULT_START_TIME);
        let t = nanos_since_epoch("2024-05-01T09:00:00.25+02:00").unwrap();
        assert_eq!(iso_8601(t), "2024-05-01T07:00:00.250Z");
        for bad in ["2024-05-01T09:00:00", "yesterday", "1969-12-31T23:59:59Z"] {
            let e = nanos_since_epoch(bad).unwrap_err().to_string();
            assert!(e.contains(bad), "{e}");
        }
    }
}
