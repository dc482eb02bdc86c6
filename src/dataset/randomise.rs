//! `[randomise]`, the dataset spec's domain randomisation: how much the picture varies between
//! scenes, and the H.264 and JPEG quality ranges. What the settings do to a picture is the
//! renderer's ([`crate::render::randomise`]); this is the section itself, its checks, its record
//! in a capture bag (the `autoact.dataset` metadata record's `randomise` key, read back by
//! `render` and `trim`) and the draws of the qualities.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::hash::hash2;

/// `[randomise]`: how much the picture varies between scenes (see the module's documentation).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Randomise {
    /// Largest hue rotation of the clothes', props' and ground's colours, degrees (each drawn
    /// uniformly in ±this, per scene and per item: top, trousers, shoes, props, ground).
    pub hue_jitter_deg: f64,
    /// Largest relative change of their saturation (±this).
    pub saturation_jitter: f64,
    /// Largest relative change of their brightness (±this).
    pub brightness_jitter: f64,
    /// Camera sensor noise: the standard deviation of a per-pixel, per-channel Gaussian noise, as a
    /// fraction of the full 8-bit scale, drawn per scene uniformly in `[min, max]`.
    pub sensor_noise: [f64; 2],
    /// Motion blur: the weight of the previous frame's picture in a frame, drawn per scene
    /// uniformly in `[min, max]`.
    pub motion_blur: [f64; 2],
    /// H.264 quality: when set, each capture's video is encoded at an x264 CRF drawn uniformly
    /// in `[min, max]` (replacing `--crf`); unset, every video uses `--crf`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub crf: Option<[u8; 2]>,
    /// JPEG quality of the extracted rawframes (`--rawframes`): ffmpeg's mjpeg `qscale`, 2 (best)
    /// … 31 (worst), drawn per clip uniformly in `[min, max]` ([`crate::video::jpeg_qscale`]).
    /// Clips themselves are copied from the capture video, so their H.264 quality is the
    /// capture's (`crf`), not drawn per clip.
    pub jpeg_quality: [u8; 2],
}

impl Default for Randomise {
    /// Modest defaults: ±8° hue, ±12 % saturation, ±10 % brightness, noise up to 1.2 % of full
    /// scale, blur weight up to 0.3, the CRF not jittered, JPEG qscale 2 (ffmpeg's best, what
    /// rawframes were always written with: a default that loses nothing).
    fn default() -> Randomise {
        Randomise {
            hue_jitter_deg: 8.0,
            saturation_jitter: 0.12,
            brightness_jitter: 0.1,
            sensor_noise: [0.0, 0.012],
            motion_blur: [0.0, 0.3],
            crf: None,
            jpeg_quality: [crate::video::JPEG_QSCALE_BEST; 2],
        }
    }
}

/// A capture bag's recorded `[randomise]` that cannot be used.
#[derive(Debug, thiserror::Error)]
pub enum RecordedRandomiseError {
    /// Not the JSON of a `[randomise]`.
    #[error("the `randomise` key of the autoact.dataset record is not a [randomise] section")]
    Json(#[source] serde_json::Error),
    /// A value out of range.
    #[error("the `randomise` key of the autoact.dataset record")]
    Range(#[source] RandomiseError),
}

/// A `[randomise]` value out of range: the key (without `randomise.`) and what would be right.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("randomise.{key}: {message}")]
pub struct RandomiseError {
    /// The key, e.g. `sensor_noise`.
    pub key: &'static str,
    /// What is wrong.
    pub message: String,
}

impl Randomise {
    /// Whether these are the defaults (the spec then leaves the section out when written back).
    #[must_use]
    pub fn is_default(&self) -> bool {
        *self == Randomise::default()
    }

    /// No randomisation at all (`autoact render --no-randomise`): no colour jitter, noise or
    /// blur, the CRF not drawn, the best JPEG quality.
    #[must_use]
    pub fn none() -> Randomise {
        Randomise {
            hue_jitter_deg: 0.0,
            saturation_jitter: 0.0,
            brightness_jitter: 0.0,
            sensor_noise: [0.0, 0.0],
            motion_blur: [0.0, 0.0],
            crf: None,
            jpeg_quality: [crate::video::JPEG_QSCALE_BEST; 2],
        }
    }

    /// The `[randomise]` a capture bag recorded (`json`, the `autoact.dataset` record's
    /// `randomise` key), checked; the defaults when the bag has none (bags written before it was
    /// recorded).
    ///
    /// # Errors
    /// [`RecordedRandomiseError`]: the text is not a `[randomise]` or a value is out of range.
    pub fn recorded(json: Option<&str>) -> Result<Randomise, RecordedRandomiseError> {
        let Some(json) = json else {
            return Ok(Randomise::default());
        };
        let r: Randomise = serde_json::from_str(json).map_err(RecordedRandomiseError::Json)?;
        r.validate().map_err(RecordedRandomiseError::Range)?;
        Ok(r)
    }

    /// As recorded in a capture bag's metadata (see [`Randomise::recorded`]).
    #[must_use]
    pub fn to_record(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// The x264 CRF of the capture video of session `session` of the dataset seeded `seed`
    /// ([`Randomise::video_crf`] keyed by both): what `generate` and `render` encode at.
    #[must_use]
    pub fn capture_crf(&self, fallback: u8, seed: u64, session: &str) -> u8 {
        self.video_crf(fallback, hash2(seed, crate::hash::of_str(session)))
    }

    /// Checks every value's range.
    ///
    /// # Errors
    /// [`RandomiseError`] naming the first bad key.
    pub fn validate(&self) -> Result<(), RandomiseError> {
        let bad = |key, message: String| Err(RandomiseError { key, message });
        for (key, v, max) in [
            ("hue_jitter_deg", self.hue_jitter_deg, 180.0),
            ("saturation_jitter", self.saturation_jitter, 1.0),
            ("brightness_jitter", self.brightness_jitter, 0.9),
        ] {
            if !(v.is_finite() && (0.0..=max).contains(&v)) {
                return bad(key, format!("{v} is not in [0, {max}]"));
            }
        }
        for (key, [lo, hi], max) in [
            ("sensor_noise", self.sensor_noise, 0.2),
            ("motion_blur", self.motion_blur, 0.9),
        ] {
            if !(lo.is_finite() && hi.is_finite() && 0.0 <= lo && lo <= hi && hi <= max) {
                return bad(
                    key,
                    format!("[{lo}, {hi}] is not a range [min, max] with 0 ≤ min ≤ max ≤ {max}"),
                );
            }
        }
        if let Some([lo, hi]) = self.crf
            && !(lo <= hi && hi <= 51)
        {
            return bad(
                "crf",
                format!("[{lo}, {hi}] is not a CRF range [min, max] with min ≤ max ≤ 51"),
            );
        }
        crate::video::check_jpeg_qscale(self.jpeg_quality).map_err(|e| RandomiseError {
            key: "jpeg_quality",
            message: e.to_string(),
        })
    }

    /// The x264 CRF of the video keyed by `key` (e.g. the dataset's seed hashed with the
    /// capture's session): drawn in the `crf` range, else `fallback` (`--crf`).
    #[must_use]
    pub fn video_crf(&self, fallback: u8, key: u64) -> u8 {
        match self.crf {
            Some([lo, hi]) if lo < hi => {
                let mut rng = ChaCha8Rng::seed_from_u64(hash2(key, 0xc2f));
                rng.random_range(lo..=hi)
            }
            Some([lo, _]) => lo,
            None => fallback,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_ranges_are_named() {
        let with = |f: fn(&mut Randomise)| {
            let mut r = Randomise::default();
            f(&mut r);
            r.validate().unwrap_err()
        };
        assert_eq!(with(|r| r.sensor_noise = [0.02, 0.01]).key, "sensor_noise");
        assert_eq!(with(|r| r.motion_blur = [0.0, 1.5]).key, "motion_blur");
        assert_eq!(with(|r| r.crf = Some([30, 20])).key, "crf");
        assert_eq!(with(|r| r.jpeg_quality = [1, 5]).key, "jpeg_quality");
        assert_eq!(with(|r| r.jpeg_quality = [9, 8]).key, "jpeg_quality");
        let nan = with(|r| r.hue_jitter_deg = f64::NAN).to_string();
        assert!(nan.starts_with("randomise.hue_jitter_deg"), "{nan}");
        assert!(Randomise::default().validate().is_ok());
    }

    #[test]
    fn a_recorded_randomise_reads_back_and_bad_records_are_refused() {
        assert_eq!(Randomise::recorded(None).unwrap(), Randomise::default());
        let r = Randomise {
            sensor_noise: [0.03, 0.05],
            crf: Some([20, 28]),
            jpeg_quality: [4, 9],
            ..Randomise::none()
        };
        assert_eq!(Randomise::recorded(Some(&r.to_record())).unwrap(), r);
        // Keys a record leaves out are the defaults.
        let partial = Randomise::recorded(Some(r#"{"hue_jitter_deg": 0.0}"#)).unwrap();
        assert_eq!(partial.sensor_noise, Randomise::default().sensor_noise);
        assert!(matches!(
            Randomise::recorded(Some(r#"{"sensor_noise": "loud"}"#)),
            Err(RecordedRandomiseError::Json(_))
        ));
        assert!(matches!(
            Randomise::recorded(Some(r#"{"motion_blur": [0.5, 0.1]}"#)),
            Err(RecordedRandomiseError::Range(RandomiseError {
                key: "motion_blur",
                ..
            }))
        ));
        let none = Randomise::none();
        assert!(none.validate().is_ok());
        assert_eq!(none.capture_crf(23, 1, "s"), 23);
    }

    #[test]
    fn the_crf_is_drawn_in_its_range_per_video_and_reproducibly() {
        assert_eq!(Randomise::default().video_crf(23, 7), 23);
        let r = Randomise {
            crf: Some([18, 30]),
            ..Randomise::default()
        };
        let crfs: Vec<u8> = (0..64).map(|k| r.video_crf(23, k)).collect();
        assert!(crfs.iter().all(|c| (18..=30).contains(c)));
        assert!(crfs.iter().collect::<std::collections::BTreeSet<_>>().len() > 6);
        assert_eq!(
            crfs,
            (0..64).map(|k| r.video_crf(23, k)).collect::<Vec<_>>()
        );
    }
}
