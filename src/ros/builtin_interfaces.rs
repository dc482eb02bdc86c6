//! `builtin_interfaces`: time and duration, and the one conversion from autoact's `u64`
//! nanoseconds.

use serde::{Deserialize, Serialize};

use super::RosMessage;

/// `builtin_interfaces/msg/Time`: seconds and nanoseconds since an epoch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second, `< 1e9`.
    pub nanosec: u32,
}

impl RosMessage for Time {
    const TYPE_NAME: &'static str = "builtin_interfaces/msg/Time";
}

impl Time {
    /// From nanoseconds; instants past `i32::MAX` seconds (2038 for epoch stamps) saturate.
    #[must_use]
    pub fn from_nanos(nanos: u64) -> Time {
        let sec = nanos / 1_000_000_000;
        let nanosec = u32::try_from(nanos % 1_000_000_000).unwrap_or(0);
        match i32::try_from(sec) {
            Ok(sec) => Time { sec, nanosec },
            Err(_) => Time {
                sec: i32::MAX,
                nanosec: 999_999_999,
            },
        }
    }

    /// To nanoseconds; `None` before the epoch or for an invalid `nanosec`.
    #[must_use]
    pub fn to_nanos(self) -> Option<u64> {
        let sec = u64::try_from(self.sec).ok()?;
        (self.nanosec < 1_000_000_000).then(|| sec * 1_000_000_000 + u64::from(self.nanosec))
    }
}

/// `builtin_interfaces/msg/Duration`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Duration {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl RosMessage for Duration {
    const TYPE_NAME: &'static str = "builtin_interfaces/msg/Duration";
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_round_trips_and_saturates() {
        for ns in [
            0u64,
            1,
            999_999_999,
            1_000_000_000,
            1_700_000_000_123_456_789,
        ] {
            assert_eq!(Time::from_nanos(ns).to_nanos(), Some(ns));
        }
        assert_eq!(Time::from_nanos(u64::MAX).sec, i32::MAX);
        assert_eq!(
            Time {
                sec: -1,
                nanosec: 0
            }
            .to_nanos(),
            None
        );
        assert_eq!(
            Time {
                sec: 1,
                nanosec: 1_000_000_000
            }
            .to_nanos(),
            None
        );
    }
}
