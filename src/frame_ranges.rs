//! A set of frame indices held as sorted, disjoint ranges: what a render draws of its timeline
//! ([`crate::render::session`]), with the count of frames before each range, so that the `k`-th
//! frame and a frame's rank are a binary search away. Memory grows with the ranges (clips), not
//! with the frames.

use std::ops::Range;

/// Frame indices as sorted, disjoint, non-adjacent, non-empty ranges.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FrameRanges {
    ranges: Vec<Range<u64>>,
    /// Frames in the ranges before each range.
    before: Vec<u64>,
}

impl FrameRanges {
    /// The frames of `ranges` (in any order; overlapping and adjacent ones are merged, empty
    /// ones dropped).
    #[must_use]
    pub fn new(ranges: impl IntoIterator<Item = Range<u64>>) -> FrameRanges {
        let mut sorted: Vec<Range<u64>> = ranges.into_iter().filter(|r| !r.is_empty()).collect();
        sorted.sort_unstable_by_key(|r| (r.start, r.end));
        let mut merged: Vec<Range<u64>> = Vec::with_capacity(sorted.len());
        for r in sorted {
            match merged.last_mut() {
                Some(last) if r.start <= last.end => last.end = last.end.max(r.end),
                _ => merged.push(r),
            }
        }
        let before = merged
            .iter()
            .scan(0, |n, r| {
                let at = *n;
                *n += r.end - r.start;
                Some(at)
            })
            .collect();
        FrameRanges {
            ranges: merged,
            before,
        }
    }

    /// Every frame of `0..len`.
    #[must_use]
    pub fn all(len: u64) -> FrameRanges {
        FrameRanges::new(std::iter::once(0..len))
    }

    /// How many frames.
    #[must_use]
    pub fn len(&self) -> u64 {
        match (self.ranges.last(), self.before.last()) {
            (Some(r), Some(&n)) => n + (r.end - r.start),
            _ => 0,
        }
    }

    /// Whether there is no frame.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.ranges.is_empty()
    }

    /// The ranges, in order.
    #[must_use]
    pub fn ranges(&self) -> &[Range<u64>] {
        &self.ranges
    }

    /// The `k`-th frame (from 0), if there are more than `k`.
    #[must_use]
    pub fn nth(&self, k: u64) -> Option<u64> {
        let i = self.before.partition_point(|&n| n <= k).checked_sub(1)?;
        let frame = self.ranges[i].start + (k - self.before[i]);
        (frame < self.ranges[i].end).then_some(frame)
    }

    /// How many frames are before `frame` (its index when it is one).
    #[must_use]
    pub fn rank(&self, frame: u64) -> u64 {
        let i = self.ranges.partition_point(|r| r.end <= frame);
        match self.ranges.get(i) {
            Some(r) => self.before[i] + frame.saturating_sub(r.start),
            None => self.len(),
        }
    }

    /// Whether `frame` is one of them.
    #[must_use]
    pub fn contains(&self, frame: u64) -> bool {
        let i = self.ranges.partition_point(|r| r.end <= frame);
        self.ranges.get(i).is_some_and(|r| r.contains(&frame))
    }

    /// The indices (ranks) of the frames that start a range: each frame not right after the one
    /// before it.
    pub fn range_starts(&self) -> impl Iterator<Item = u64> + '_ {
        self.before.iter().copied()
    }

    /// Those of them with ranks `ranks` (clamped to the frames there are).
    #[must_use]
    pub fn slice(&self, ranks: Range<u64>) -> FrameRanges {
        let end = ranks.end.min(self.len());
        let (Some(first), true) = (self.nth(ranks.start), ranks.start < end) else {
            return FrameRanges::default();
        };
        let mut out = Vec::new();
        let i = self.before.partition_point(|&n| n <= ranks.start) - 1;
        let mut at = first;
        for (r, &before) in self.ranges[i..].iter().zip(&self.before[i..]) {
            if before >= end {
                break;
            }
            let stop = r.start + (end - before).min(r.end - r.start);
            out.push(at.max(r.start)..stop);
            at = 0;
        }
        FrameRanges::new(out)
    }

    /// Every frame, in order.
    pub fn iter(&self) -> impl Iterator<Item = u64> + '_ {
        self.ranges.iter().flat_map(Clone::clone)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn ranges_merge_and_count() {
        let f = FrameRanges::new([5..7, 0..2, 2..3, 9..9, 6..8]);
        assert_eq!(f.ranges(), &[0..3, 5..8]);
        assert_eq!(f.len(), 6);
        assert_eq!(f.range_starts().collect::<Vec<_>>(), [0, 3]);
        assert_eq!(f.nth(3), Some(5));
        assert_eq!(f.nth(6), None);
        assert_eq!(f.rank(6), 4);
        assert_eq!(f.slice(2..5).ranges(), &[2..3, 5..7]);
        assert!(FrameRanges::default().nth(0).is_none());
        assert_eq!(FrameRanges::all(4).iter().collect::<Vec<_>>(), [0, 1, 2, 3]);
    }

    proptest! {
        /// Against a plain sorted list of the same frames.
        #[test]
        fn ranges_behave_as_the_sorted_list_of_their_frames(
            raw in proptest::collection::vec((0u64..60, 0u64..8), 0..8),
            probe in 0u64..80,
            slice in (0u64..40, 0u64..40),
        ) {
            let ranges: Vec<Range<u64>> = raw.iter().map(|&(s, n)| s..s + n).collect();
            let f = FrameRanges::new(ranges.clone());
            let mut list: Vec<u64> = ranges.iter().flat_map(Clone::clone).collect();
            list.sort_unstable();
            list.dedup();
            prop_assert_eq!(f.len(), list.len() as u64);
            prop_assert_eq!(f.iter().collect::<Vec<_>>(), list.clone());
            prop_assert_eq!(f.nth(probe), list.get(probe as usize).copied());
            prop_assert_eq!(f.rank(probe), list.partition_point(|&x| x < probe) as u64);
            prop_assert_eq!(f.contains(probe), list.binary_search(&probe).is_ok());
            let starts: Vec<u64> = (0..list.len())
                .filter(|&j| j == 0 || list[j - 1] + 1 != list[j])
                .map(|j| j as u64)
                .collect();
            prop_assert_eq!(f.range_starts().collect::<Vec<_>>(), starts);
            let (a, b) = (slice.0.min(slice.1), slice.0.max(slice.1));
            let want: Vec<u64> = list
                .iter()
                .skip(a as usize)
                .take(b.saturating_sub(a) as usize)
                .copied()
                .collect();
            prop_assert_eq!(f.slice(a..b).iter().collect::<Vec<_>>(), want);
        }
    }
}
