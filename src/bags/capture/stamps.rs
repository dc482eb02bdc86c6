//! A timeline's stamps as runs on a clock: a run holds the stamps `origin + stamp_nanos_at(j,
//! fps)` for `j` in `0..count` ([`crate::skeleton::pose::stamp_nanos_at`], the one rule that
//! writes them). A capture bag's timeline is one run per stretch without a break, so memory
//! grows with its breaks, not with its frames.

use crate::skeleton::pose::stamp_nanos_at;

/// Strictly increasing stamps, nanoseconds, as runs on a clock of [`Stamps::fps`] frames a
/// second.
#[derive(Debug, Clone, PartialEq)]
pub struct Stamps {
    fps: f64,
    runs: Vec<Run>,
}

/// Stamps `origin + stamp_nanos_at(j, fps)` for `j` in `0..count`; `first` stamps come before.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Run {
    origin: u64,
    first: u64,
    count: u64,
}

impl Run {
    fn stamp(&self, j: u64, fps: f64) -> u64 {
        self.origin + clock(j, fps)
    }

    fn last(&self, fps: f64) -> u64 {
        self.stamp(self.count - 1, fps)
    }
}

/// Nanoseconds from a clock's origin to its tick `j`.
fn clock(j: u64, fps: f64) -> u64 {
    stamp_nanos_at(usize::try_from(j).unwrap_or(usize::MAX), fps)
}

/// How many ticks of a clock of `fps` from `origin` come before `t` (the first tick at or after
/// it).
fn ticks_before(origin: u64, fps: f64, t: u64) -> u64 {
    let Some(span) = t.checked_sub(origin) else {
        return 0;
    };
    #[expect(
        clippy::cast_precision_loss,
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "an estimate, corrected below"
    )]
    let mut j = (span as f64 * fps / 1e9).ceil().max(0.0) as u64;
    while j > 0 && origin + clock(j - 1, fps) >= t {
        j -= 1;
    }
    while origin + clock(j, fps) < t {
        j += 1;
    }
    j
}

impl Stamps {
    /// No stamps, on a clock of `fps` (positive, finite).
    #[must_use]
    pub fn new(fps: f64) -> Stamps {
        Stamps {
            fps,
            runs: Vec::new(),
        }
    }

    /// `count` ticks of a clock of `fps` from `origin`.
    #[must_use]
    pub fn clock(origin: u64, fps: f64, count: u64) -> Stamps {
        let mut out = Stamps::new(fps);
        if count > 0 {
            out.runs.push(Run {
                origin,
                first: 0,
                count,
            });
        }
        out
    }

    /// The ticks of a clock of `fps` from `origin` up to `last` (inclusive).
    #[must_use]
    pub fn clock_until(origin: u64, fps: f64, last: u64) -> Stamps {
        Stamps::clock(
            origin,
            fps,
            ticks_before(origin, fps, last.saturating_add(1)),
        )
    }

    /// The clock's rate, frames a second.
    #[must_use]
    pub fn fps(&self) -> f64 {
        self.fps
    }

    /// How many stamps.
    #[must_use]
    pub fn len(&self) -> usize {
        self.runs.last().map_or(0, |r| {
            usize::try_from(r.first + r.count).unwrap_or(usize::MAX)
        })
    }

    /// Whether there is none.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.runs.is_empty()
    }

    /// The first stamp.
    #[must_use]
    pub fn first(&self) -> Option<u64> {
        self.runs.first().map(|r| r.origin)
    }

    /// The last stamp.
    #[must_use]
    pub fn last(&self) -> Option<u64> {
        self.runs.last().map(|r| r.last(self.fps))
    }

    /// Stamp `k`.
    #[must_use]
    pub fn get(&self, k: usize) -> Option<u64> {
        let k = k as u64;
        let i = self.runs.partition_point(|r| r.first <= k).checked_sub(1)?;
        let r = &self.runs[i];
        (k - r.first < r.count).then(|| r.stamp(k - r.first, self.fps))
    }

    /// How many stamps come before `t`.
    #[must_use]
    pub fn count_before(&self, t: u64) -> usize {
        let i = self.runs.partition_point(|r| r.origin < t);
        let Some(r) = i.checked_sub(1).map(|i| &self.runs[i]) else {
            return 0;
        };
        let n = r.first + ticks_before(r.origin, self.fps, t).min(r.count);
        usize::try_from(n).unwrap_or(usize::MAX)
    }

    /// The index of stamp `t`, if it is one.
    #[must_use]
    pub fn position(&self, t: u64) -> Option<usize> {
        let k = self.count_before(t);
        (self.get(k) == Some(t)).then_some(k)
    }

    /// The first `len` stamps.
    pub fn truncate(&mut self, len: usize) {
        let len = len as u64;
        self.runs.retain(|r| r.first < len);
        if let Some(r) = self.runs.last_mut() {
            r.count = r.count.min(len - r.first);
        }
    }

    /// Every stamp, in order.
    pub fn iter(&self) -> impl Iterator<Item = u64> + '_ {
        self.runs
            .iter()
            .flat_map(|r| (0..r.count).map(|j| r.stamp(j, self.fps)))
    }

    /// Appends `t`, which must come after the last stamp.
    fn push_after(&mut self, t: u64) {
        let fps = self.fps;
        if let Some(r) = self.runs.last_mut()
            && r.stamp(r.count, fps) == t
        {
            r.count += 1;
            return;
        }
        let first = self.len() as u64;
        self.runs.push(Run {
            origin: t,
            first,
            count: 1,
        });
    }
}

/// Builds [`Stamps`] from stamps in any order: in runs while they come in order (a capture
/// bag's do), as a plain list once one does not.
#[derive(Debug, Clone)]
pub struct StampsBuilder {
    stamps: Stamps,
    /// Every stamp, once they came out of order.
    unordered: Option<Vec<u64>>,
    /// The first stamp met twice (in order: at once).
    repeated: Option<u64>,
}

impl StampsBuilder {
    /// A builder of stamps on a clock of `fps` (stamps off that clock are held in more runs).
    #[must_use]
    pub fn new(fps: f64) -> StampsBuilder {
        let fps = if fps.is_finite() && fps > 0.0 {
            fps
        } else {
            1.0
        };
        StampsBuilder {
            stamps: Stamps::new(fps),
            unordered: None,
            repeated: None,
        }
    }

    /// Adds `t`.
    pub fn push(&mut self, t: u64) {
        if let Some(list) = &mut self.unordered {
            list.push(t);
            return;
        }
        match self.stamps.last() {
            Some(last) if t == last => {
                self.repeated.get_or_insert(t);
            }
            Some(last) if t < last => {
                let mut list: Vec<u64> = self.stamps.iter().collect();
                list.push(t);
                self.unordered = Some(list);
            }
            _ => self.stamps.push_after(t),
        }
    }

    /// The stamps, once each, and the first one met twice (in order of stamps once they came
    /// out of order).
    #[must_use]
    pub fn finish(self) -> (Stamps, Option<u64>) {
        let Some(mut list) = self.unordered else {
            return (self.stamps, self.repeated);
        };
        list.sort_unstable();
        let twice = list.windows(2).find(|w| w[0] == w[1]).map(|w| w[0]);
        list.dedup();
        let mut stamps = Stamps::new(self.stamps.fps);
        for t in list {
            stamps.push_after(t);
        }
        (stamps, self.repeated.or(twice))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn build(fps: f64, stamps: &[u64]) -> (Stamps, Option<u64>) {
        let mut b = StampsBuilder::new(fps);
        for &t in stamps {
            b.push(t);
        }
        b.finish()
    }

    #[test]
    fn a_clock_is_one_run() {
        let s = build(
            30.0,
            &(0..1000).map(|k| 7 + clock(k, 30.0)).collect::<Vec<_>>(),
        )
        .0;
        assert_eq!(s.runs.len(), 1);
        assert_eq!(s.len(), 1000);
        assert_eq!(s.last(), Some(7 + clock(999, 30.0)));
        let until = Stamps::clock_until(7, 30.0, 7 + clock(999, 30.0));
        assert_eq!(until, s);
        assert_eq!(
            Stamps::clock_until(7, 30.0, 7 + clock(999, 30.0) - 1).len(),
            999
        );
    }

    proptest! {
        /// Against the sorted, deduplicated list of the same stamps, whatever their order and
        /// whether or not they fall on the clock.
        #[test]
        fn stamps_behave_as_their_sorted_list(
            fps in prop_oneof![Just(30.0), Just(29.97), Just(1.0e9 / 3.0), 0.5f64..200.0],
            ticks in proptest::collection::vec((0u64..3, 0u64..5_000_000), 0..60),
            shuffle in any::<bool>(),
            probe in 0u64..20_000_000_000,
            cut in 0usize..70,
        ) {
            // Mostly on the clock, with jumps and stray stamps.
            let mut k = 0u64;
            let mut raw = Vec::new();
            for (kind, extra) in ticks {
                k += 1 + u64::from(kind == 2) * 3;
                raw.push(if kind == 1 { clock(k, fps) + extra } else { clock(k, fps) });
            }
            if shuffle {
                raw.reverse();
            }
            let (mut s, twice) = build(fps, &raw);
            let mut list = raw.clone();
            list.sort_unstable();
            let dup = list.windows(2).find(|w| w[0] == w[1]).map(|w| w[0]);
            list.dedup();
            prop_assert_eq!(twice.is_some(), dup.is_some());
            prop_assert_eq!(s.iter().collect::<Vec<_>>(), list.clone());
            prop_assert_eq!(s.len(), list.len());
            prop_assert_eq!(s.first(), list.first().copied());
            prop_assert_eq!(s.last(), list.last().copied());
            prop_assert_eq!(s.count_before(probe), list.partition_point(|&x| x < probe));
            for (i, &t) in list.iter().enumerate() {
                prop_assert_eq!(s.get(i), Some(t));
                prop_assert_eq!(s.position(t), Some(i));
                prop_assert_eq!(s.count_before(t), i);
                prop_assert_eq!(s.count_before(t + 1), i + 1);
            }
            prop_assert_eq!(s.get(list.len()), None);
            prop_assert_eq!(s.position(probe), list.binary_search(&probe).ok());
            s.truncate(cut);
            list.truncate(cut);
            prop_assert_eq!(s.iter().collect::<Vec<_>>(), list);
        }
    }
}
