//! DSI's segmentation and time map: where the sequence is cut into unit motions, and which
//! instant of the source every output frame shows.
//!
//! The per-interval angular distance is the paper's
//! `d_f = Σ_b w_b · 2·acos(|⟨q_b^f, q_b^(f−1)⟩|) / Σ_b w_b`, a weighted mean over the bones that
//! move in the clip, in radians per source frame: an interval that spans a dropped frame is
//! divided by its length in frames, so a gap is not mistaken for a fast movement.
//!
//! Where `d_f` exceeds the threshold the interval `[f−1, f]` is a *transition*. Inside unit
//! motions the output clock runs at the source's real speed (times `speed`): an interval of
//! `Δt` seconds lasts `Δt · out_fps / speed` output frames, which is `1/δ` per source frame, δ
//! being the paper's interpolation rate. A transition lasts `⌈η · d_f · n / δ⌉` output frames
//! (`n` its length in source frames), never fewer than at real speed: fast movements are
//! slowed down so they are not lost, slow ones are never stretched. With the default
//! `η = 1 / threshold` the stretch is continuous: an interval exactly at the threshold keeps its
//! real duration, one at twice the threshold lasts twice as long.

use std::fmt;
use std::str::FromStr;

use super::interp::Sample;
use super::{DsiError, DsiOptions};
use crate::skeleton::character::median;
use crate::skeleton::fk::BonePose;

/// With a relative threshold, the cut never falls below this angular speed (radians per second
/// of the weighted mean bone), so an almost still clip is not cut at its noise.
pub const RELATIVE_FLOOR_RAD_PER_S: f64 = 0.5;

/// The clip ends on the output frame nearest its real end, which shows the last key (as in
/// [`crate::skeleton::resample::Resampler`]): a clip of `N` keys played at its own nominal rate has
/// `N` frames even when its stamps drift from the nominal clock (a BVH frame time of `0.008333` s
/// is 120.005 fps).
const END_TOLERANCE_FRAMES: f64 = 0.5;

/// Fraction of an interval within which an output time is its key's.
const SNAP_TO_KEY: f64 = 1e-6;

/// Where DSI cuts a sequence into unit motions.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Threshold {
    /// No cut: one unit motion, resampled at real speed.
    Off,
    /// `k ×` the median `d_f` of the sequence, never below [`RELATIVE_FLOOR_RAD_PER_S`].
    TimesMedian(f64),
    /// Radians per source frame (the paper's unit).
    RadPerFrame(f64),
    /// Radians per second (independent of the source's frame rate).
    RadPerSecond(f64),
}

impl Default for Threshold {
    fn default() -> Threshold {
        Threshold::TimesMedian(3.0)
    }
}

impl fmt::Display for Threshold {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Threshold::Off => write!(f, "off"),
            Threshold::TimesMedian(k) => write!(f, "{k}x"),
            Threshold::RadPerFrame(r) => write!(f, "{r}rad"),
            Threshold::RadPerSecond(r) => write!(f, "{r}rad/s"),
        }
    }
}

/// A threshold that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ThresholdError {
    /// Not one of the threshold's forms.
    #[error(
        "`{given}`: give `off`, a multiple of the median distance (`3x`), radians per source frame (`0.05rad`), or an angular speed (`1.5rad/s`, `90deg/s`)"
    )]
    Form {
        /// The text given (trimmed).
        given: String,
    },
    /// A number that is not positive (the range is (0, ∞)).
    #[error("`{given}`: the number must be positive")]
    NotPositive {
        /// The text given (trimmed).
        given: String,
    },
}

impl FromStr for Threshold {
    type Err = ThresholdError;

    fn from_str(s: &str) -> Result<Threshold, ThresholdError> {
        let s = s.trim();
        if s == "off" {
            return Ok(Threshold::Off);
        }
        let (number, make): (&str, fn(f64) -> Threshold) = if let Some(n) = s.strip_suffix("rad/s")
        {
            (n, Threshold::RadPerSecond)
        } else if let Some(n) = s.strip_suffix("deg/s") {
            (n, |d: f64| Threshold::RadPerSecond(d.to_radians()))
        } else if let Some(n) = s.strip_suffix("rad") {
            (n, Threshold::RadPerFrame)
        } else if let Some(n) = s.strip_suffix('x') {
            (n, Threshold::TimesMedian)
        } else {
            return Err(ThresholdError::Form {
                given: s.to_string(),
            });
        };
        match number.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(make(v)),
            _ => Err(ThresholdError::NotPositive {
                given: s.to_string(),
            }),
        }
    }
}

/// The time map DSI found for one clip.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Where every output frame falls between the keys.
    pub samples: Vec<Sample>,
    /// Per interval (keys `i → i + 1`): a transition.
    pub transitions: Vec<bool>,
    /// `d_f` per interval, radians per source frame.
    pub distances_rad: Vec<f64>,
    /// The threshold in radians per source frame (`None`: no segmentation).
    pub threshold_rad: Option<f64>,
    /// The interpolation coefficient used, output frames per radian·δ.
    pub eta: f64,
    /// The interpolation rate δ: source frames per output frame.
    pub delta: f64,
    /// Unit motions (segments between transitions).
    pub segments: usize,
    /// Frames the clip would have at real speed.
    pub frames_real_speed: usize,
}

impl Plan {
    /// Output frames added by slowing the transitions down.
    #[must_use]
    pub fn frames_added(&self) -> usize {
        self.samples.len().saturating_sub(self.frames_real_speed)
    }

    /// Number of transition intervals.
    #[must_use]
    pub fn transition_count(&self) -> usize {
        self.transitions.iter().filter(|&&t| t).count()
    }
}

/// The weighted mean angular distance per interval, radians per source frame (see the module
/// docs). `weights` has one entry per bone; bones that never move in the clip do not count.
#[must_use]
pub fn angular_distances(keys: &[BonePose], times_s: &[f64], weights: &[f64]) -> Vec<f64> {
    let moving = crate::skeleton::fk::moving_bones(keys);
    Distances::new(weights, &moving, source_period_s(times_s))
        .of(keys, times_s)
        .0
}

/// The per-interval distances of a clip ([`angular_distances`]), and the same with the two
/// bones that contribute most to each interval left out: a cut between takes or a dropped span
/// moves the body, a jump carried by one bone and the child that compensates it (a limb's twist
/// flipping by half a turn) is an artefact of the source, not a cut. Made once per clip (its
/// moving bones and frame period), then applied to the clip piece by piece.
#[derive(Debug, Clone)]
pub struct Distances<'w> {
    weights: &'w [f64],
    /// The bones that count: moving in the clip, with a positive weight.
    moving: Vec<usize>,
    total: f64,
    period_s: f64,
}

impl<'w> Distances<'w> {
    /// For a clip whose bones move as `moving` says, with keys every `period_s` seconds.
    #[must_use]
    pub fn new(weights: &'w [f64], moving: &[bool], period_s: f64) -> Distances<'w> {
        let moving: Vec<usize> = moving
            .iter()
            .enumerate()
            .filter(|&(b, &m)| m && weights.get(b).copied().unwrap_or(0.0) > 0.0)
            .map(|(b, _)| b)
            .collect();
        let total = moving.iter().map(|&b| weights[b]).sum();
        Distances {
            weights,
            moving,
            total,
            period_s,
        }
    }

    /// The distances, with and without the two largest bones, of the intervals between
    /// consecutive `keys` (at `times_s`).
    #[must_use]
    pub fn of(&self, keys: &[BonePose], times_s: &[f64]) -> (Vec<f64>, Vec<f64>) {
        keys.windows(2)
            .zip(times_s.windows(2))
            .map(|(pair, t)| self.interval(&pair[0], &pair[1], t[1] - t[0]))
            .unzip()
    }

    fn interval(&self, a: &BonePose, b: &BonePose, dt_s: f64) -> (f64, f64) {
        let (weights, total) = (self.weights, self.total);
        if total <= 0.0 {
            return (0.0, 0.0);
        }
        // The two largest contributions and their weights.
        let mut sum = 0.0;
        let mut top = [(0.0, 0.0); 2];
        for &bone in &self.moving {
            // The paper's 2·acos(|⟨q, q'⟩|): precise enough for a threshold, and cheap.
            let dot = a.local_rotations[bone]
                .as_ref()
                .dot(b.local_rotations[bone].as_ref())
                .abs()
                .min(1.0);
            let part = weights[bone] * 2.0 * dot.acos();
            sum += part;
            if part > top[0].0 {
                top = [(part, weights[bone]), top[0]];
            } else if part > top[1].0 {
                top[1] = (part, weights[bone]);
            }
        }
        let frames = (dt_s / self.period_s).max(1.0);
        let rest = total - top[0].1 - top[1].1;
        let without = if self.moving.len() <= 2 {
            // Nothing to compare with: the clip's distance itself.
            sum / total / frames
        } else if rest > 0.0 {
            (sum - top[0].0 - top[1].0) / rest / frames
        } else {
            0.0
        };
        (sum / total / frames, without)
    }
}

/// The source's frame period: the median interval between keys (robust to dropped frames).
#[must_use]
pub fn source_period_s(times_s: &[f64]) -> f64 {
    let mut dts: Vec<f64> = times_s.windows(2).map(|t| t[1] - t[0]).collect();
    median(&mut dts).unwrap_or(1.0)
}

/// Intervals a relative threshold compares each interval with, on each side.
const NEIGHBOURHOOD: usize = 5;

/// Robust z-score of an interval's `d_f` against its neighbourhood above which it can be a cut.
const Z_CUT: f64 = 5.0;

/// The relative threshold of every interval: a cut is a jump in the motion, not fast motion. An
/// interval is a transition when its `d_f` is above all of: `k` times both adjacent intervals'
/// (the velocity is discontinuous: smooth motion, however fast, changes speed gradually), the
/// median of the [`NEIGHBOURHOOD`] intervals on each side plus [`Z_CUT`] robust standard
/// deviations (1.4826 · MAD) of them (it stands out of the clip's own local statistics), and
/// `floor_rad`.
#[must_use]
pub fn local_thresholds(distances_rad: &[f64], k: f64, floor_rad: f64) -> Vec<f64> {
    let n = distances_rad.len();
    (0..n)
        .map(|i| {
            let adjacent = [i.checked_sub(1), Some(i + 1)]
                .into_iter()
                .flatten()
                .filter_map(|j| distances_rad.get(j).copied())
                .fold(0.0, f64::max);
            let lo = i.saturating_sub(NEIGHBOURHOOD);
            let hi = (i + NEIGHBOURHOOD + 1).min(n);
            let mut around: Vec<f64> = (lo..hi)
                .filter(|&j| j != i)
                .map(|j| distances_rad[j])
                .collect();
            let centre = median(&mut around).unwrap_or(0.0);
            let mut deviations: Vec<f64> = around.iter().map(|d| (d - centre).abs()).collect();
            let mad = median(&mut deviations).unwrap_or(0.0);
            (k * adjacent)
                .max(centre + Z_CUT * 1.4826 * mad)
                .max(floor_rad)
        })
        .collect()
}

/// Where a clip is cut, and at which threshold per interval.
struct Cuts {
    thresholds_rad: Option<Vec<f64>>,
    threshold_rad: Option<f64>,
    transitions: Vec<bool>,
}

/// The transitions of a clip under `threshold` (see [`local_thresholds`]), from its distances
/// with and without the two largest bones ([`Distances`]).
fn cuts(
    distances_rad: &[f64],
    without_largest: &[f64],
    threshold: Threshold,
    period_s: f64,
) -> Cuts {
    let floor_rad = RELATIVE_FLOOR_RAD_PER_S * period_s;
    let thresholds_rad: Option<Vec<f64>> = match threshold {
        Threshold::Off => None,
        Threshold::RadPerFrame(r) => Some(vec![r; distances_rad.len()]),
        Threshold::RadPerSecond(r) => Some(vec![r * period_s; distances_rad.len()]),
        Threshold::TimesMedian(k) => Some(local_thresholds(distances_rad, k, floor_rad)),
    };
    // A relative threshold cuts only where the body jumps: the interval must pass its threshold
    // also without its two largest bones.
    let without_thresholds = match threshold {
        Threshold::TimesMedian(k) => Some(local_thresholds(without_largest, k, floor_rad)),
        _ => None,
    };
    let body_wide = |i: usize| {
        without_thresholds
            .as_ref()
            .is_none_or(|t| without_largest[i] > t[i])
    };
    let threshold_rad = thresholds_rad.as_ref().map(|t| {
        let mut t = t.clone();
        median(&mut t).unwrap_or(floor_rad)
    });
    let transitions: Vec<bool> = match &thresholds_rad {
        None => vec![false; distances_rad.len()],
        Some(t) => distances_rad
            .iter()
            .zip(t)
            .enumerate()
            .map(|(i, (d, t))| d > t && body_wide(i))
            .collect(),
    };
    Cuts {
        thresholds_rad,
        threshold_rad,
        transitions,
    }
}

/// Plans the output of one clip: keys at `times_s` (seconds, strictly increasing), played at
/// `options.out_fps` and `options.pace`, cut at `options.threshold` with `options.weights`,
/// transitions stretched by `options.eta` (default `1 / threshold`).
///
/// # Errors
/// [`DsiError::NotPositive`] for a non-positive rate, speed or η.
pub fn plan(keys: &[BonePose], times_s: &[f64], options: &DsiOptions) -> Result<Plan, DsiError> {
    let moving = crate::skeleton::fk::moving_bones(keys);
    let (distances_rad, without_largest) =
        Distances::new(&options.weights, &moving, source_period_s(times_s)).of(keys, times_s);
    plan_from_distances(times_s, distances_rad, &without_largest, options)
}

/// [`plan`] from the clip's key times and its [`Distances`] (with and without the two largest
/// bones), for a clip read in pieces.
///
/// # Errors
/// [`DsiError::NotPositive`] for a non-positive rate, speed or η.
pub fn plan_from_distances(
    times_s: &[f64],
    distances_rad: Vec<f64>,
    without_largest: &[f64],
    options: &DsiOptions,
) -> Result<Plan, DsiError> {
    let DsiOptions {
        out_fps,
        pace,
        threshold,
        eta,
        ..
    } = *options;
    let period_s = source_period_s(times_s);
    let speed = pace.speed(period_s, out_fps);
    let positive = |name: &'static str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(DsiError::NotPositive {
                parameter: name,
                value: v,
            })
        }
    };
    positive("the output frame rate", out_fps)?;
    positive("the speed", speed)?;
    if let Some(e) = eta {
        positive("η", e)?;
    }
    let delta = speed / (period_s * out_fps);
    let Cuts {
        thresholds_rad,
        threshold_rad,
        transitions,
    } = cuts(&distances_rad, without_largest, threshold, period_s);
    // η per interval: given, or 1 / the interval's threshold.
    let eta_at = |i: usize| match (eta, &thresholds_rad) {
        (Some(e), _) => e,
        (None, Some(t)) => 1.0 / t[i],
        (None, None) => 1.0,
    };
    let eta = eta.or(threshold_rad.map(|t| 1.0 / t)).unwrap_or(1.0);

    // Output frames per interval, and their running sum (the time map's knots).
    let mut real_total = 0.0;
    let mut knots = Vec::with_capacity(transitions.len() + 1);
    knots.push(0.0);
    for (i, t) in times_s.windows(2).enumerate() {
        let real = (t[1] - t[0]) * out_fps / speed;
        real_total += real;
        let frames = if transitions[i] {
            let n_source = ((t[1] - t[0]) / period_s).max(1.0);
            // A hair below a whole number is that number (rounding in d_f must not add a frame).
            real.max((eta_at(i) * distances_rad[i] * n_source / delta - 1e-9).ceil())
        } else {
            real
        };
        knots.push(knots[i] + frames);
    }
    let total = knots.last().copied().unwrap_or(0.0);
    let mut samples = Vec::new();
    let mut interval = 0;
    let mut k = 0u32;
    loop {
        let u = f64::from(k);
        if u >= total - END_TOLERANCE_FRAMES || times_s.len() < 2 {
            samples.push(Sample {
                interval: times_s.len().saturating_sub(1),
                s: 0.0,
            });
            break;
        }
        while knots[interval + 1] <= u {
            interval += 1;
        }
        let s = (u - knots[interval]) / (knots[interval + 1] - knots[interval]);
        // Stamps written at a nominal rate carry rounding (1/30 s is not a whole number of ns):
        // an output time within a millionth of an interval of a key is that key.
        let sample = if s < SNAP_TO_KEY {
            Sample { interval, s: 0.0 }
        } else if s > 1.0 - SNAP_TO_KEY {
            Sample {
                interval: interval + 1,
                s: 0.0,
            }
        } else {
            Sample { interval, s }
        };
        samples.push(sample);
        k += 1;
    }
    let segments = 1 + transitions
        .iter()
        .enumerate()
        // A transition at either end does not open a new unit motion.
        .filter(|&(i, &t)| t && i > 0 && i + 1 < transitions.len())
        .count();
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        reason = "a frame count, non-negative and far below 2^52"
    )]
    let frames_real_speed = real_total.round() as usize + 1;
    Ok(Plan {
        samples,
        transitions,
        distances_rad,
        threshold_rad,
        eta,
        delta,
        segments,
        frames_real_speed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{UnitQuaternion, Vector3};

    /// Options for a two-bone clip: per-bone `weights`, the rest as given.
    fn opts(
        weights: &[f64],
        threshold: Threshold,
        eta: Option<f64>,
        out_fps: f64,
        speed: f64,
    ) -> DsiOptions {
        DsiOptions {
            weights: weights.to_vec(),
            threshold,
            eta,
            out_fps,
            pace: crate::dsi::Pace::Speed(speed),
            ..DsiOptions::new(&crate::skeleton::rig::Rig::standard())
        }
    }

    fn keys_from(angles: &[f64]) -> Vec<BonePose> {
        angles
            .iter()
            .map(|&a| BonePose {
                root_translation_m: Vector3::zeros(),
                local_rotations: vec![
                    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a),
                    UnitQuaternion::identity(),
                ],
            })
            .collect()
    }

    fn times(n: usize, fps: f64) -> Vec<f64> {
        (0..n)
            .map(|k| f64::from(u32::try_from(k).unwrap()) / fps)
            .collect()
    }

    #[test]
    fn a_clip_at_its_own_rate_keeps_every_key_and_ends_on_the_last() {
        // BVH `Frame Time: 0.008333`: stamps a little faster than 120 fps.
        let keys = keys_from(&[0.0; 140]);
        let t: Vec<f64> = (0..140).map(|k| f64::from(k) * 0.008_333).collect();
        let p = plan(
            &keys,
            &t,
            &opts(&[1.0, 1.0], Threshold::Off, None, 120.0, 1.0),
        )
        .unwrap();
        assert_eq!(p.samples.len(), 140);
        assert_eq!(p.frames_added(), 0);
        assert_eq!(
            p.samples[139],
            Sample {
                interval: 139,
                s: 0.0
            }
        );
        // And a little slower than nominal.
        let t: Vec<f64> = (0..1901).map(|k| f64::from(k) * 0.033_334).collect();
        let p = plan(
            &keys_from(&[0.0; 1901]),
            &t,
            &opts(&[1.0, 1.0], Threshold::Off, None, 30.0, 1.0),
        )
        .unwrap();
        assert_eq!(p.samples.len(), 1901);
        assert_eq!(p.samples[1900].interval, 1900);
    }

    #[test]
    fn thresholds_parse_and_print() {
        for s in ["off", "3x", "0.05rad", "1.5rad/s"] {
            assert_eq!(s.parse::<Threshold>().unwrap().to_string(), s);
        }
        assert_eq!(
            "90deg/s".parse::<Threshold>().unwrap(),
            Threshold::RadPerSecond(std::f64::consts::FRAC_PI_2)
        );
        for bad in ["", "3", "-1x", "0rad", "NaNrad/s", "fast"] {
            assert!(bad.parse::<Threshold>().is_err(), "{bad}");
        }
    }

    #[test]
    fn distance_is_the_weighted_mean_and_ignores_still_bones_and_gaps() {
        let keys = keys_from(&[0.0, 0.1, 0.3, 0.7]);
        // Bone 1 never moves: with weight it still does not dilute the mean.
        let d = angular_distances(&keys, &times(4, 30.0), &[2.0, 5.0]);
        for (got, want) in d.iter().zip([0.1, 0.2, 0.4]) {
            assert!((got - want).abs() < 1e-12);
        }
        // The third key arrives after a dropped frame: its interval counts per frame.
        let t = [0.0, 1.0 / 30.0, 3.0 / 30.0, 4.0 / 30.0];
        let d = angular_distances(&keys, &t, &[1.0, 1.0]);
        assert!((d[1] - 0.1).abs() < 1e-12, "{d:?}");
    }

    #[test]
    fn without_cuts_the_clip_keeps_its_real_duration() {
        let keys = keys_from(&[0.0; 31]);
        let p = plan(
            &keys,
            &times(31, 30.0),
            &opts(&[1.0, 1.0], Threshold::Off, None, 60.0, 1.0),
        )
        .unwrap();
        // 1 s at 60 fps: 61 frames, the last on the last key.
        assert_eq!(p.samples.len(), 61);
        assert_eq!(p.frames_added(), 0);
        assert_eq!(
            p.samples[60],
            Sample {
                interval: 30,
                s: 0.0
            }
        );
        assert!((p.samples[1].s - 0.5).abs() < 1e-12);
        assert!((p.delta - 0.5).abs() < 1e-12);
        // Twice the speed: half the frames.
        let p = plan(
            &keys,
            &times(31, 30.0),
            &opts(&[1.0, 1.0], Threshold::Off, None, 30.0, 2.0),
        )
        .unwrap();
        assert_eq!(p.samples.len(), 16);
    }

    #[test]
    fn a_fast_interval_is_a_transition_and_gets_frames_in_proportion() {
        // Slow steady motion, one jump of ten times the step.
        let mut angles = vec![0.0];
        for k in 1..20 {
            let step = if k == 10 { 0.2 } else { 0.02 };
            angles.push(angles[k - 1] + step);
        }
        let keys = keys_from(&angles);
        let t = times(20, 30.0);
        let p = plan(
            &keys,
            &t,
            &opts(&[1.0, 0.0], Threshold::RadPerFrame(0.05), None, 30.0, 1.0),
        )
        .unwrap();
        assert_eq!(p.transition_count(), 1);
        assert!(p.transitions[9]);
        assert_eq!(p.segments, 2);
        // η = 1/0.05 → ⌈20 · 0.2⌉ = 4 frames for that interval instead of 1.
        assert_eq!(p.frames_added(), 3);
        assert_eq!(p.samples.len(), 23);
        let inside: Vec<f64> = p
            .samples
            .iter()
            .filter(|s| s.interval == 9)
            .map(|s| s.s)
            .collect();
        assert_eq!(inside, vec![0.0, 0.25, 0.5, 0.75]);
        // The relative threshold finds the same cut (3 × median 0.02 < 0.2), but the floor
        // (0.5 rad/s = 0.0167 rad/frame) stays below it.
        let p = plan(
            &keys,
            &t,
            &opts(&[1.0, 0.0], Threshold::default(), None, 30.0, 1.0),
        )
        .unwrap();
        assert_eq!(p.transition_count(), 1);
        assert!((p.threshold_rad.unwrap() - 0.06).abs() < 1e-12);
    }

    #[test]
    fn a_still_clip_is_not_cut_at_its_noise() {
        let angles: Vec<f64> = (0..30)
            .map(|k| if k % 2 == 0 { 0.0 } else { 1e-4 })
            .collect();
        let keys = keys_from(&angles);
        let p = plan(
            &keys,
            &times(30, 30.0),
            &opts(&[1.0, 0.0], Threshold::default(), None, 30.0, 1.0),
        )
        .unwrap();
        assert_eq!(p.transition_count(), 0);
    }

    #[test]
    fn bad_parameters_are_errors() {
        let keys = keys_from(&[0.0, 0.1]);
        let t = times(2, 30.0);
        assert!(
            plan(
                &keys,
                &t,
                &opts(&[1.0, 1.0], Threshold::Off, None, 0.0, 1.0)
            )
            .is_err()
        );
        assert!(
            plan(
                &keys,
                &t,
                &opts(&[1.0, 1.0], Threshold::Off, None, 30.0, -1.0)
            )
            .is_err()
        );
        assert!(
            plan(
                &keys,
                &t,
                &opts(&[1.0, 1.0], Threshold::Off, Some(f64::NAN), 30.0, 1.0)
            )
            .is_err()
        );
        let one = plan(
            &keys[..1],
            &t[..1],
            &opts(&[1.0, 1.0], Threshold::Off, None, 30.0, 1.0),
        )
        .unwrap();
        assert_eq!(
            one.samples,
            vec![Sample {
                interval: 0,
                s: 0.0
            }]
        );
    }
}
