//! `--shard K/N`: which of a plan's sessions one machine of N makes. The partition is a pure
//! function of the sessions' (estimated) lengths, so N machines given the same spec agree on it
//! without talking, and each shard is a contiguous run of sessions in plan order: concatenating
//! the parts' manifests in shard order gives the single machine's manifest.

use std::ops::Range;

use serde::{Deserialize, Serialize};

/// Shard `index` of `count` (0-based, as Slurm's `SLURM_ARRAY_TASK_ID` and Kubernetes'
/// `JOB_COMPLETION_INDEX` number them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// Which shard, `0 ≤ index < count`.
    pub index: usize,
    /// How many shards.
    pub count: usize,
}

/// A `--shard` value that is not `K/N` with `0 ≤ K < N`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("--shard `{0}`: expected K/N with 0 <= K < N, e.g. 0/4 (shards are numbered from 0)")]
pub struct ShardError(pub String);

impl std::str::FromStr for Shard {
    type Err = ShardError;

    fn from_str(s: &str) -> Result<Shard, ShardError> {
        let err = || ShardError(s.to_owned());
        let (k, n) = s.split_once('/').ok_or_else(err)?;
        let index: usize = k.trim().parse().map_err(|_| err())?;
        let count: usize = n.trim().parse().map_err(|_| err())?;
        if index >= count {
            return Err(err());
        }
        Ok(Shard { index, count })
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

impl Shard {
    /// The sessions of this shard, given every session's length in frames (plan order): session
    /// `i` goes to the shard whose equal share of the total frames holds the middle of `i`.
    /// Contiguous, in order, every session in exactly one shard; a shard may be empty when
    /// there are fewer sessions than shards.
    #[must_use]
    pub fn sessions(self, frames: &[u64]) -> Range<usize> {
        let shard_of = shard_of_each(frames, self.count);
        let start = shard_of.partition_point(|&s| s < self.index);
        let end = shard_of.partition_point(|&s| s <= self.index);
        start..end
    }
}

/// The shard of each session (non-decreasing).
fn shard_of_each(frames: &[u64], count: usize) -> Vec<usize> {
    let total: u128 = frames.iter().map(|&f| u128::from(f)).sum();
    let count_wide = count as u128;
    let mut before: u128 = 0;
    frames
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            let f = u128::from(f);
            // Twice the session's middle, against twice the total: integers only.
            let shard = if total == 0 {
                // No lengths to weigh by: by count instead.
                (i as u128 * count_wide) / (frames.len().max(1) as u128)
            } else {
                ((2 * before + f) * count_wide) / (2 * total)
            };
            before += f;
            usize::try_from(shard).unwrap_or(usize::MAX).min(count - 1)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::Shard;

    #[test]
    fn shards_parse_or_say_what_is_expected() {
        assert_eq!(
            "1/4".parse::<Shard>().unwrap(),
            Shard { index: 1, count: 4 }
        );
        assert_eq!("1/4".parse::<Shard>().unwrap().to_string(), "1/4");
        for bad in ["4/4", "1", "a/2", "0/0", "-1/3"] {
            let e = bad.parse::<Shard>().unwrap_err().to_string();
            assert!(e.contains("K/N"), "{bad}: {e}");
        }
    }

    #[test]
    fn every_session_is_in_exactly_one_shard_in_order() {
        let frames = [100, 5, 5, 300, 40, 40, 40, 1000, 2, 2];
        for count in 1..=12 {
            let ranges: Vec<_> = (0..count)
                .map(|index| Shard { index, count }.sessions(&frames))
                .collect();
            let mut next = 0;
            for r in &ranges {
                assert_eq!(r.start, next, "{count} shards: {ranges:?}");
                next = r.end;
            }
            assert_eq!(next, frames.len(), "{count} shards: {ranges:?}");
        }
    }

    #[test]
    fn shards_get_balanced_frames_when_sessions_allow() {
        let frames = [10u64; 8];
        let sizes: Vec<usize> = (0..4)
            .map(|index| Shard { index, count: 4 }.sessions(&frames).len())
            .collect();
        assert_eq!(sizes, [2, 2, 2, 2]);
        // Fewer sessions than shards: some shards are empty, none holds two.
        let sizes: Vec<usize> = (0..4)
            .map(|index| Shard { index, count: 4 }.sessions(&[700, 700]).len())
            .collect();
        assert_eq!(sizes.iter().sum::<usize>(), 2);
        assert!(sizes.iter().all(|&n| n <= 1), "{sizes:?}");
        assert_eq!(Shard { index: 0, count: 3 }.sessions(&[]), 0..0);
    }
}
