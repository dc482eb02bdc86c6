//! DSI on a clip of any length in bounded memory.
//!
//! The clip's keys are collected once ([`ClipKeys::push`], which also gathers what needs the
//! whole clip: the key times, which bones move, the mean rotation of each bone's range) into a
//! [`KeyStore`] (a temporary file for `convert --dsi`). [`ClipKeys::solve`] then reads them back
//! in windows, twice: the ranges' boxes and the outliers rejected (each window with
//! [`KEY_MARGIN`] keys on each side, so a window's edge never looks like the clip's end), then
//! the noise levels and the per-interval distances, from which the plan is made. With variants,
//! two passes over the output measure each variant's own range. [`Solver::next_window`] finally
//! makes the output window by window: every output frame interpolated from the keys around it,
//! varied, smoothed with [`Solver::margin_frames`] frames on each side (more than the
//! SuperSmoother reaches), limited (motion capture), eased into the source range, clamped and
//! finished with the state of the window before.
//!
//! Memory: a window of keys and of output frames, plus a few numbers per key (times,
//! distances, the plan), whatever the clip's length. The result is the whole-clip computation's:
//! the windows change only rounding (a few 1e-15 rad), except where a chain of outliers longer
//! than the margin straddles a window's edge.

use std::ops::Range;

use nalgebra::UnitQuaternion;

use super::interp::{self, Sample};
use super::outliers::{self, NoiseLevels};
use super::plan::{self, Distances, Plan};
use super::range::{Chart, MeanRotation, RangeBox, SourceRange};
use super::store::{KeyStore, Shelf};
use super::variants::Variation;
use super::{DsiError, DsiOptions};
use crate::skeleton::convert::AnimationFrame;
use crate::skeleton::fk::BonePose;
use crate::skeleton::pose::{nanos_to_secs, stamp_nanos_at};
use crate::skeleton::rig::{Dof, Rig};

/// Keys on each side of a window of keys that outlier rejection also reads (its tests reach
/// 14 keys; the rest is room for replacements that depend on each other).
pub const KEY_MARGIN: usize = 64;

/// How much of a clip is in memory at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Windows {
    /// Keys per window of keys.
    pub keys: usize,
    /// Output frames per window of output.
    pub frames: usize,
}

impl Default for Windows {
    /// 4,096 keys and 2,048 output frames: a few MB each on the 53-bone rig.
    fn default() -> Windows {
        Windows {
            keys: 4096,
            frames: 2048,
        }
    }
}

/// A clip's keys, being collected.
#[derive(Debug)]
pub struct ClipKeys {
    /// Where the keys go as they come.
    raw: Shelf,
    /// Where the keys with their outliers replaced go when the clip is solved (a new part of
    /// this store).
    clean: Shelf,
    first_stamp_nanos: Option<u64>,
    last_stamp_nanos: u64,
    times_s: Vec<f64>,
    first: Option<BonePose>,
    moving: Vec<bool>,
    means: Vec<MeanRotation>,
}

impl ClipKeys {
    /// No keys yet, to be kept in memory.
    #[must_use]
    pub fn in_memory() -> ClipKeys {
        ClipKeys::new(
            Shelf::new(KeyStore::memory()),
            Shelf::new(KeyStore::memory()),
        )
    }

    /// No keys yet: they are to be appended to `raw`, and, when the clip is solved, with their
    /// outliers replaced, to `clean`'s store (one of each per person for `convert --dsi`).
    #[must_use]
    pub fn new(raw: Shelf, clean: Shelf) -> ClipKeys {
        ClipKeys {
            raw,
            clean,
            first_stamp_nanos: None,
            last_stamp_nanos: 0,
            times_s: Vec::new(),
            first: None,
            moving: Vec::new(),
            means: Vec::new(),
        }
    }

    /// Number of keys.
    #[must_use]
    pub fn len(&self) -> usize {
        self.times_s.len()
    }

    /// Whether there is no key.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.times_s.is_empty()
    }

    /// Adds the next key.
    ///
    /// # Errors
    /// [`DsiError::NonMonotonic`] for a stamp not after the last one, [`DsiError::Spill`] when
    /// the temporary file cannot be written.
    pub fn push(&mut self, key: AnimationFrame) -> Result<(), DsiError> {
        let stamp = key.stamp_nanos;
        let first_stamp = match self.first_stamp_nanos {
            Some(_) if stamp <= self.last_stamp_nanos => {
                return Err(DsiError::NonMonotonic { index: self.len() });
            }
            Some(first) => first,
            None => {
                self.first_stamp_nanos = Some(stamp);
                stamp
            }
        };
        let pose = key.pose;
        match &self.first {
            None => {
                self.moving = vec![false; pose.local_rotations.len()];
                self.means = vec![MeanRotation::default(); pose.local_rotations.len()];
                self.first = Some(pose.clone());
            }
            Some(first) => {
                for ((m, q), q0) in self
                    .moving
                    .iter_mut()
                    .zip(&pose.local_rotations)
                    .zip(&first.local_rotations)
                {
                    *m |= q != q0;
                }
            }
        }
        for (mean, q) in self.means.iter_mut().zip(&pose.local_rotations) {
            mean.push(q);
        }
        self.times_s.push(nanos_to_secs(stamp - first_stamp));
        self.last_stamp_nanos = stamp;
        self.raw.push(pose)
    }

    /// Plans the clip (see the module docs) in [`Windows::default`].
    ///
    /// # Errors
    /// [`DsiError`] for bad parameters, no keys, or a temporary file that cannot be used.
    pub fn solve<'r>(self, rig: &'r Rig, options: &DsiOptions) -> Result<Solver<'r>, DsiError> {
        self.solve_in(rig, options, Windows::default())
    }

    /// [`ClipKeys::solve`] in `windows`.
    ///
    /// # Errors
    /// As [`ClipKeys::solve`].
    pub fn solve_in<'r>(
        self,
        rig: &'r Rig,
        options: &DsiOptions,
        windows: Windows,
    ) -> Result<Solver<'r>, DsiError> {
        super::check(rig, options)?;
        let Some(first_stamp_nanos) = self.first_stamp_nanos else {
            return Err(DsiError::NoFrames);
        };
        let windows = Windows {
            keys: windows.keys.max(1),
            frames: windows.frames.max(1),
        };
        let Self {
            raw,
            clean,
            times_s,
            moving,
            means,
            ..
        } = self;
        let mut clip = Passes {
            rig,
            times_s: &times_s,
            moving: &moving,
            window: windows.keys,
        };
        let (key_ranges, keys) =
            clip.ranges_and_outliers(&raw, &clean, &means, options.reject_outliers)?;
        let Measured {
            noise_rad,
            distances_rad,
            without_largest,
        } = clip.noise_and_distances(&keys, options)?;
        let plan = plan::plan_from_distances(&times_s, distances_rad, &without_largest, options)?;
        let mut solver = Solver {
            rig,
            options: options.clone(),
            keys,
            times_s,
            first_stamp_nanos,
            moving,
            key_ranges,
            noise_rad,
            plan,
            variant_ranges: Vec::new(),
            windows,
            next_frame: 0,
            carry: Vec::new(),
        };
        solver.variant_ranges = solver.measure_variants()?;
        solver.carry = (0..=options.variants)
            .map(|_| Carry::new(rig.bones.len()))
            .collect();
        Ok(solver)
    }
}

/// The passes over a clip's keys that [`ClipKeys::solve_in`] makes.
struct Passes<'a> {
    rig: &'a Rig,
    times_s: &'a [f64],
    moving: &'a [bool],
    window: usize,
}

/// Whether bone `b` of a clip whose bones move as `moving` says has a range (it moves and is
/// not static).
fn has_range(rig: &Rig, moving: &[bool], b: usize) -> bool {
    moving.get(b).copied().unwrap_or(false) && !matches!(rig.bones[b].dof, Dof::Static)
}

/// Each bone's empty range box in its chart about the mean of `means`, for the bones that have
/// one.
fn range_boxes(rig: &Rig, moving: &[bool], means: &[MeanRotation]) -> Vec<Option<RangeBox>> {
    means
        .iter()
        .enumerate()
        .map(|(b, m)| {
            m.mean()
                .filter(|_| has_range(rig, moving, b))
                .map(|mean| RangeBox::new(Chart::of(&rig.bones[b]), mean))
        })
        .collect()
}

impl Passes<'_> {
    /// The windows of a pass over `n` keys (or frames).
    fn windows(n: usize, size: usize) -> impl Iterator<Item = Range<usize>> {
        (0..n).step_by(size).map(move |a| a..(a + size).min(n))
    }

    /// Pass 2: each bone's range over the keys as they came, and the keys with their outliers
    /// replaced (a new part of `clean`'s store; `raw` itself when outliers are kept).
    fn ranges_and_outliers(
        &mut self,
        raw: &Shelf,
        clean: &Shelf,
        means: &[MeanRotation],
        reject: bool,
    ) -> Result<(Vec<Option<SourceRange>>, Shelf), DsiError> {
        let mut boxes = range_boxes(self.rig, self.moving, means);
        let cleaned = reject.then(|| clean.next());
        let n = self.times_s.len();
        for core in Self::windows(n, self.window) {
            let margin = if reject { KEY_MARGIN } else { 0 };
            let read = core.start.saturating_sub(margin)..(core.end + margin).min(n);
            let mut keys = raw.read(read.clone())?;
            let inner = core.start - read.start..core.end - read.start;
            for key in &keys[inner.clone()] {
                for (range, q) in boxes.iter_mut().zip(&key.local_rotations) {
                    if let Some(r) = range {
                        r.push(q);
                    }
                }
            }
            if let Some(cleaned) = &cleaned {
                outliers::reject(self.rig, &mut keys, &self.times_s[read], self.moving);
                for key in keys.drain(inner) {
                    cleaned.push(key)?;
                }
            }
        }
        let ranges = boxes
            .into_iter()
            .map(|r| r.and_then(RangeBox::finish))
            .collect();
        Ok((ranges, cleaned.unwrap_or_else(|| raw.clone())))
    }

    /// Pass 3: the noise level of every bone, and the distances of every interval with and
    /// without the two largest bones (see [`plan`]).
    fn noise_and_distances(
        &mut self,
        keys: &Shelf,
        options: &DsiOptions,
    ) -> Result<Measured, DsiError> {
        let n = self.times_s.len();
        let mut noise = NoiseLevels::new(self.rig.bones.len(), n);
        let distances = Distances::new(
            &options.weights,
            self.moving,
            plan::source_period_s(self.times_s),
        );
        let mut with = Vec::with_capacity(n.saturating_sub(1));
        let mut without = Vec::with_capacity(n.saturating_sub(1));
        for core in Self::windows(n, self.window) {
            let read = core.start.saturating_sub(2)..(core.end + 2).min(n);
            let poses = keys.read(read.clone())?;
            let times = &self.times_s[read.clone()];
            noise.push(
                self.rig,
                self.moving,
                &poses,
                times,
                read.start,
                core.clone(),
            );
            // The intervals that end at the window's keys.
            let pairs = core.start.max(1) - 1 - read.start..core.end - read.start;
            let (d, w) = distances.of(&poses[pairs.clone()], &times[pairs]);
            with.extend(d);
            without.extend(w);
        }
        Ok(Measured {
            noise_rad: noise.levels(),
            distances_rad: with,
            without_largest: without,
        })
    }
}

/// What pass 3 measures.
struct Measured {
    noise_rad: Vec<f64>,
    distances_rad: Vec<f64>,
    without_largest: Vec<f64>,
}

/// What the previous window of one animation left: each bone's last rotation after clamping
/// and after finishing.
#[derive(Debug, Clone)]
struct Carry {
    clamped: Vec<Option<UnitQuaternion<f64>>>,
    finished: Vec<Option<UnitQuaternion<f64>>>,
}

impl Carry {
    fn new(bones: usize) -> Carry {
        Carry {
            clamped: vec![None; bones],
            finished: vec![None; bones],
        }
    }
}

/// A planned clip, made window by window.
#[derive(Debug)]
pub struct Solver<'r> {
    rig: &'r Rig,
    options: DsiOptions,
    /// The keys, outliers replaced.
    keys: Shelf,
    times_s: Vec<f64>,
    first_stamp_nanos: u64,
    moving: Vec<bool>,
    key_ranges: Vec<Option<SourceRange>>,
    noise_rad: Vec<f64>,
    plan: Plan,
    /// Per variant (from 1): its own range, before smoothing.
    variant_ranges: Vec<Vec<Option<SourceRange>>>,
    windows: Windows,
    next_frame: usize,
    carry: Vec<Carry>,
}

impl Solver<'_> {
    /// The time map.
    #[must_use]
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// Output frames of every animation.
    #[must_use]
    pub fn frames(&self) -> usize {
        self.plan.samples.len()
    }

    /// The stamp of the first output frame (the first key's), nanoseconds.
    #[must_use]
    pub fn first_stamp_nanos(&self) -> u64 {
        self.first_stamp_nanos
    }

    /// The stamp of output frame `k`, nanoseconds.
    #[must_use]
    pub fn stamp_nanos(&self, k: usize) -> u64 {
        self.first_stamp_nanos + stamp_nanos_at(k, self.options.out_fps)
    }

    /// Output frames on each side of a window that are smoothed with it and then dropped:
    /// twice the three spans together (the running mean reaches half the woofer, the
    /// SuperSmoother's passes half of each of its spans), and 8 frames more, and twice the
    /// tweeter for the easing into the source range.
    #[must_use]
    pub fn margin_frames(&self) -> usize {
        self.options.smoothing.map_or(0, |s| {
            #[expect(
                clippy::cast_possible_truncation,
                clippy::cast_sign_loss,
                reason = "validated positive spans times a positive rate: a small count"
            )]
            let frames =
                (2.0 * s.spans_s.iter().sum::<f64>() * self.options.out_fps).ceil() as usize;
            // The easing into the range reaches twice the tweeter further.
            frames + 8 + 2 * s.tweeter_frames(self.options.out_fps)
        })
    }

    /// The animation's output frames `frames`, interpolated from the keys around them.
    fn base(&mut self, frames: Range<usize>) -> Result<Vec<BonePose>, DsiError> {
        let samples = &self.plan.samples[frames];
        let (Some(first), Some(last)) = (samples.first(), samples.last()) else {
            return Ok(Vec::new());
        };
        let n = self.times_s.len();
        // The cubic's stencil reaches one key before and two after each interval.
        let read = first.interval.saturating_sub(1)..(last.interval + 3).min(n);
        let rebased: Vec<Sample> = samples
            .iter()
            .map(|s| Sample {
                interval: s.interval - read.start,
                s: s.s,
            })
            .collect();
        let transitions = &self.plan.transitions;
        let transitions =
            &transitions[read.start.min(transitions.len())..(read.end - 1).min(transitions.len())];
        let keys = self.keys.read(read.clone())?;
        Ok(interp::interpolate(
            &keys,
            &self.times_s[read],
            transitions,
            &rebased,
            self.options.method,
        ))
    }

    fn variation(&self) -> Variation<'_> {
        Variation {
            rig: self.rig,
            moving: &self.moving,
            fps: self.options.out_fps,
            bounds: &self.options.bounds,
            seed: self.options.seed,
        }
    }

    /// Passes 4 and 5, with variants: each variant's own range (mean, then box) before
    /// smoothing, over its whole output.
    fn measure_variants(&mut self) -> Result<Vec<Vec<Option<SourceRange>>>, DsiError> {
        let variants = usize::try_from(self.options.variants).unwrap_or(usize::MAX);
        if variants == 0 {
            return Ok(Vec::new());
        }
        let bones = self.rig.bones.len();
        let mut means = vec![vec![MeanRotation::default(); bones]; variants];
        self.each_variant_window(|v, frames| {
            for pose in frames {
                for (m, q) in means[v].iter_mut().zip(&pose.local_rotations) {
                    m.push(q);
                }
            }
        })?;
        let mut boxes: Vec<Vec<Option<RangeBox>>> = means
            .iter()
            .map(|m| range_boxes(self.rig, &self.moving, m))
            .collect();
        self.each_variant_window(|v, frames| {
            for pose in frames {
                for (r, q) in boxes[v].iter_mut().zip(&pose.local_rotations) {
                    if let Some(r) = r {
                        r.push(q);
                    }
                }
            }
        })?;
        Ok(boxes
            .into_iter()
            .map(|b| {
                b.into_iter()
                    .map(|r| r.and_then(RangeBox::finish))
                    .collect()
            })
            .collect())
    }

    /// Calls `f(v − 1, frames)` for every variant `v` ≥ 1 on every window of its output, in
    /// order, before smoothing.
    fn each_variant_window(
        &mut self,
        mut f: impl FnMut(usize, &[BonePose]),
    ) -> Result<(), DsiError> {
        for window in Passes::windows(self.frames(), self.windows.frames) {
            let start = window.start;
            let base = self.base(window)?;
            for v in 1..=self.options.variants {
                let frames = self.variation().variant(v, &base, start);
                f(usize::try_from(v - 1).unwrap_or(usize::MAX), &frames);
            }
        }
        Ok(())
    }

    /// The next window of every animation (variant 0 first), or `None` after the last.
    ///
    /// # Errors
    /// [`DsiError::Spill`] when the temporary file cannot be read.
    pub fn next_window(&mut self) -> Result<Option<Vec<Vec<AnimationFrame>>>, DsiError> {
        let total = self.frames();
        if self.next_frame >= total {
            return Ok(None);
        }
        let core = self.next_frame..(self.next_frame + self.windows.frames).min(total);
        let margin = self.margin_frames();
        let extended = core.start.saturating_sub(margin)..(core.end + margin).min(total);
        let inner = core.start - extended.start..core.end - extended.start;
        let base = self.base(extended.clone())?;
        let mut animations = Vec::with_capacity(self.carry.len());
        for v in 0..=self.options.variants {
            let mut out = if v == 0 {
                base.clone()
            } else {
                self.variation().variant(v, &base, extended.start)
            };
            let index = usize::try_from(v).unwrap_or(usize::MAX);
            let ranges = if v == 0 {
                &self.key_ranges
            } else {
                &self.variant_ranges[index - 1]
            };
            if let Some(s) = &self.options.effective_smoothing() {
                let before = out.clone();
                s.apply_as_part(
                    self.rig,
                    &mut out,
                    self.options.out_fps,
                    &self.moving,
                    total,
                );
                if let Some(band) = self.options.noise_band() {
                    super::limit_corrections(&before, &mut out, &self.noise_rad, band);
                }
                super::ease_into_range(&mut out, ranges, s.tweeter_frames(self.options.out_fps));
            }
            let mut poses: Vec<BonePose> = out.drain(inner.clone()).collect();
            let carry = &mut self.carry[index];
            super::clamp(self.rig, &mut poses, ranges, &mut carry.clamped);
            super::finish(self.rig, &mut poses, &self.moving, &mut carry.finished);
            animations.push(
                poses
                    .into_iter()
                    .zip(core.clone())
                    .map(|(pose, k)| AnimationFrame {
                        stamp_nanos: self.stamp_nanos(k),
                        pose,
                    })
                    .collect(),
            );
        }
        self.next_frame = core.end;
        Ok(Some(animations))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dsi::{DsiOutput, fixture, run, run_in};
    use crate::skeleton::geom::rotation_distance;

    /// 30 s at 30 fps of the whole body moving, with estimator-like jitter, a cut between takes
    /// at 12 s and one-frame glitches every 97 frames.
    fn long_noisy_clip(rig: &Rig) -> Vec<AnimationFrame> {
        let cut = |t: f64| if t > 12.0 { 0.9 } else { 0.0 } + 0.4 * (0.7 * t).sin();
        let mut poses = fixture::whole_body(rig, 900, 0.03, cut);
        let elbow = rig.bone_index("l_forearm").unwrap_or(1);
        for pose in poses.iter_mut().skip(40).step_by(97) {
            let q = pose.local_rotations[elbow];
            pose.local_rotations[elbow] =
                q * UnitQuaternion::from_axis_angle(&nalgebra::Vector3::x_axis(), 0.6);
        }
        poses
            .into_iter()
            .enumerate()
            .map(|(k, pose)| AnimationFrame {
                stamp_nanos: 5_000_000_000 + stamp_nanos_at(k, 30.0),
                pose,
            })
            .collect()
    }

    fn assert_same(a: &DsiOutput, b: &DsiOutput, tolerance: f64) {
        assert_eq!(a.plan, b.plan);
        assert_eq!(a.animations.len(), b.animations.len());
        for (x, y) in a.animations.iter().zip(&b.animations) {
            assert_eq!(x.len(), y.len());
            for (k, (f, g)) in x.iter().zip(y).enumerate() {
                assert_eq!(f.stamp_nanos, g.stamp_nanos);
                let moved = (f.pose.root_translation_m - g.pose.root_translation_m).norm();
                assert!(moved <= tolerance, "frame {k}: root {moved}");
                for (bone, (p, q)) in f
                    .pose
                    .local_rotations
                    .iter()
                    .zip(&g.pose.local_rotations)
                    .enumerate()
                {
                    let angle = rotation_distance(p, q);
                    assert!(angle <= tolerance, "frame {k} bone {bone}: {angle} rad");
                    // Signs continue across the windows' edges as in one piece.
                    assert!(
                        p.as_ref().dot(q.as_ref()) > 0.0,
                        "frame {k} bone {bone}: sign"
                    );
                }
            }
        }
    }

    #[test]
    fn windows_change_nothing_but_rounding() {
        let rig = Rig::standard();
        let keys = long_noisy_clip(&rig);
        let options = DsiOptions {
            variants: 2,
            seed: 11,
            ..DsiOptions::new(&rig)
        };
        let whole = run(&rig, &keys, &options).unwrap();
        assert_eq!(whole.animations.len(), 3);
        assert!(whole.plan.transition_count() > 0, "the cut is found");
        for (keys_per_window, frames_per_window) in [(24, 20), (97, 61), (500, 333)] {
            let windows = Windows {
                keys: keys_per_window,
                frames: frames_per_window,
            };
            let pieces = run_in(&rig, &keys, &options, windows).unwrap();
            assert_same(&whole, &pieces, 1e-9);
        }
    }

    #[test]
    fn a_spilled_clip_gives_what_one_in_memory_gives() {
        let rig = Rig::standard();
        let keys = long_noisy_clip(&rig);
        let options = DsiOptions::new(&rig);
        let windows = Windows {
            keys: 200,
            frames: 150,
        };
        let dir = tempfile::tempdir().unwrap();
        let bones = rig.bones.len();
        let mut clip = ClipKeys::new(
            Shelf::spill(dir.path(), bones).unwrap(),
            Shelf::spill(dir.path(), bones).unwrap(),
        );
        for key in &keys {
            clip.push(key.clone()).unwrap();
        }
        let mut solver = clip.solve_in(&rig, &options, windows).unwrap();
        let mut frames = Vec::new();
        while let Some(window) = solver.next_window().unwrap() {
            frames.extend(window.into_iter().next().unwrap());
        }
        let spilled = DsiOutput {
            plan: solver.plan().clone(),
            animations: vec![frames],
        };
        // Bit for bit.
        assert!(run_in(&rig, &keys, &options, windows).unwrap() == spilled);
    }

    #[test]
    fn keys_out_of_order_are_refused_with_their_index() {
        let rig = Rig::standard();
        let keys = long_noisy_clip(&rig);
        let mut clip = ClipKeys::in_memory();
        clip.push(keys[0].clone()).unwrap();
        clip.push(keys[1].clone()).unwrap();
        assert!(matches!(
            clip.push(keys[1].clone()),
            Err(DsiError::NonMonotonic { index: 2 })
        ));
        assert!(matches!(
            ClipKeys::in_memory().solve(&rig, &DsiOptions::new(&rig)),
            Err(DsiError::NoFrames)
        ));
    }
}
