//! Random Camera Moving: the paper's random walk of the camera around the character, and the
//! camera pose at any instant of a shot.
//!
//! **Coordinates.** A [`Viewpoint`] is cylindrical about the character's ground point `g` (the
//! root bone's head projected on the ground): horizontal distance `distance_m`, azimuth
//! `azimuth_deg` counter-clockwise from world +X seen from above (90° is in front of a character
//! at rest, which faces +Y), and `height_m` above the ground plane `z = 0`. The camera stands at
//! `(g + distance·(cos az, sin az), height)`.
//!
//! **The walk** ([`random_viewpoints`]). The paper writes `Pos_{i+1} = Pos_i + ΔPos` with
//! `Δmagnitude_xy ~ U(a_m, b_m)`, `Δθ ~ U(a_θ, b_θ)`, `Δz ~ U(a_z, b_z)`. As in the authors' code,
//! `Δmagnitude_xy` changes the camera's distance from the character and `Δθ` turns it about the
//! character (the paper's text reads Δθ as the direction of the displacement; turning about the
//! character is what gives the multi-view coverage, and it keeps the character at a controlled
//! distance). The first viewpoint is at `start_distance_m`, at a uniformly random azimuth and at
//! `start_height_m` — never at the character (the reference code started *at* the ped).
//! Each further viewpoint draws, in this order, `Δxy`, `Δθ`, `Δz` and applies
//!
//! ```text
//! distance_{i+1} = clamp(distance_i + Δxy, band_low, band_high)
//! azimuth_{i+1}  = (azimuth_i + Δθ) mod 360°
//! height_{i+1}   = clamp(height_i + Δz, height_low, height_high)
//! ```
//!
//! where the distance band is the intersection of the framing band ([`super::framing_band`]) and
//! the user's `distance_m`, and the height band is `height_m`. A clamped step stops at the band's
//! edge (it neither bounces nor is redrawn, so the draws stay exactly `U(a, b)`); each viewpoint
//! records what was drawn and what was applied. Lengths are metres, not the reference code's
//! key-hold seconds, so they do not depend on the frame rate, and the distance can never go
//! negative and mirror the camera through the character.
//!
//! **Shots** ([`camera_at`]). The camera rides along with the character's ground point it is
//! given — a tracking shot. A character that walks or jumps away from where it started (root
//! motion) would otherwise leave the frame or shrink, and the framing band could not hold. It
//! looks at the subject centre it is given, unrolled. A capture gives a static shot one ground
//! point and one centre for the whole clip (a still camera) when that keeps the body in frame,
//! and each frame's otherwise.

use nalgebra::Point3;
use rand::{Rng, RngExt};

use super::{CameraError, CameraPose, check_range};

/// The RCM parameters, as a dataset spec embeds them (TOML/JSON keys are the field names; a
/// missing key takes its [`Default`]; unknown keys are an error).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RcmRanges {
    /// Horizontal distance of the first viewpoint from the character's ground point, metres
    /// (> 0; clamped into the framing band if the character needs more room).
    pub start_distance_m: f64,
    /// Height of the first viewpoint above the ground, metres (inside `height_m`).
    pub start_height_m: f64,
    /// `[a_m, b_m]`: the change of horizontal distance per step, `U(a_m, b_m)`, metres.
    pub delta_xy_m: [f64; 2],
    /// `[a_θ, b_θ]`: the turn about the character per step, `U(a_θ, b_θ)`, degrees
    /// (positive = counter-clockwise seen from above).
    pub delta_theta_deg: [f64; 2],
    /// `[a_z, b_z]`: the change of height per step, `U(a_z, b_z)`, metres.
    pub delta_z_m: [f64; 2],
    /// The camera height band above the ground, metres (`0 ≤ low ≤ high`).
    pub height_m: [f64; 2],
    /// An optional band of horizontal distances, metres (`0 < low ≤ high`), intersected with the
    /// framing band; absent = the framing band alone.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub distance_m: Option<[f64; 2]>,
}

impl Default for RcmRanges {
    /// Start 3.5 m away at eye height (1.6 m); steps Δxy ~ U(−0.8, 0.8) m, Δθ ~ U(30°, 90°),
    /// Δz ~ U(−0.4, 0.4) m; heights 0.4–2.6 m.
    fn default() -> RcmRanges {
        RcmRanges {
            start_distance_m: 3.5,
            start_height_m: 1.6,
            delta_xy_m: [-0.8, 0.8],
            delta_theta_deg: [30.0, 90.0],
            delta_z_m: [-0.4, 0.4],
            height_m: [0.4, 2.6],
            distance_m: None,
        }
    }
}

impl RcmRanges {
    /// Checks every field; the error names the first bad one.
    ///
    /// # Errors
    /// [`CameraError::Value`] or [`CameraError::Range`] naming the field: non-finite values,
    /// reversed ranges, a start distance ≤ 0, negative heights or distances, a start outside its
    /// band.
    pub fn validate(&self) -> Result<(), CameraError> {
        if !(self.start_distance_m.is_finite() && self.start_distance_m > 0.0) {
            return Err(CameraError::Value {
                field: "start_distance_m",
                value: self.start_distance_m,
                expected: "finite and > 0 (the camera never starts at the character)",
            });
        }
        if !(self.start_height_m.is_finite() && self.start_height_m >= 0.0) {
            return Err(CameraError::Value {
                field: "start_height_m",
                value: self.start_height_m,
                expected: "finite and ≥ 0 (above the ground)",
            });
        }
        let any = "finite with low ≤ high";
        check_range("delta_xy_m", self.delta_xy_m, None, any)?;
        check_range("delta_theta_deg", self.delta_theta_deg, None, any)?;
        check_range("delta_z_m", self.delta_z_m, None, any)?;
        check_range(
            "height_m",
            self.height_m,
            Some(0.0),
            "finite with 0 ≤ low ≤ high (above the ground)",
        )?;
        if let Some(d) = self.distance_m {
            check_range(
                "distance_m",
                d,
                Some(f64::MIN_POSITIVE),
                "finite with 0 < low ≤ high",
            )?;
            if !(d[0]..=d[1]).contains(&self.start_distance_m) {
                return Err(CameraError::Value {
                    field: "start_distance_m",
                    value: self.start_distance_m,
                    expected: "inside distance_m",
                });
            }
        }
        if !(self.height_m[0]..=self.height_m[1]).contains(&self.start_height_m) {
            return Err(CameraError::Value {
                field: "start_height_m",
                value: self.start_height_m,
                expected: "inside height_m",
            });
        }
        Ok(())
    }

    /// The distance band the walk uses: `framing_band` (from [`super::framing_band`])
    /// intersected with `distance_m` when given.
    ///
    /// # Errors
    /// [`CameraError::Range`] naming `framing_band` when it is not finite with
    /// `0 < low ≤ high`; [`CameraError::NoDistance`] when the two do not overlap.
    pub fn distance_band(&self, framing_band: [f64; 2]) -> Result<[f64; 2], CameraError> {
        check_range(
            "framing_band",
            framing_band,
            Some(f64::MIN_POSITIVE),
            "finite with 0 < low ≤ high",
        )?;
        let Some(user) = self.distance_m else {
            return Ok(framing_band);
        };
        let lo = framing_band[0].max(user[0]);
        let hi = framing_band[1].min(user[1]);
        if lo > hi {
            return Err(CameraError::NoDistance {
                user_low: user[0],
                user_high: user[1],
                framing_low: framing_band[0],
                framing_high: framing_band[1],
            });
        }
        Ok([lo, hi])
    }
}

/// One step's changes of distance, azimuth and height.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct StepDraw {
    /// Change of horizontal distance, metres.
    pub delta_xy_m: f64,
    /// Turn about the character, degrees (counter-clockwise seen from above).
    pub delta_theta_deg: f64,
    /// Change of height, metres.
    pub delta_z_m: f64,
}

/// One camera viewpoint, relative to the character (see the module docs for the coordinates).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Viewpoint {
    /// Position in the walk (0 = the start).
    pub index: usize,
    /// Horizontal distance from the character's ground point, metres.
    pub distance_m: f64,
    /// Azimuth about the character, degrees in [0, 360), counter-clockwise from world +X.
    pub azimuth_deg: f64,
    /// Height above the ground, metres.
    pub height_m: f64,
    /// The step's draws from `U(a, b)`; `None` for the start.
    pub drawn: Option<StepDraw>,
    /// The step actually taken after clamping (new − old; the turn is the drawn one); `None`
    /// for the start.
    pub applied: Option<StepDraw>,
}

impl Viewpoint {
    /// The camera's world position when the character's ground point is `ground_xy_m`.
    #[must_use]
    pub fn position_m(&self, ground_xy_m: [f64; 2]) -> Point3<f64> {
        cylindrical_to_world(
            self.distance_m,
            self.azimuth_deg,
            self.height_m,
            ground_xy_m,
        )
    }
}

/// Draws `n` viewpoints of one RCM walk (call it afresh for every scene: the walk resets).
/// `framing_band` is [`super::framing_band`]'s result for the character and lens. Draw order:
/// the start azimuth `U(0, 360)`, then per step `Δxy`, `Δθ`, `Δz` (inclusive ranges, so
/// `a = b` is a fixed step).
///
/// # Errors
/// What [`RcmRanges::validate`] and [`RcmRanges::distance_band`] report.
pub fn random_viewpoints<R: Rng + ?Sized>(
    rng: &mut R,
    ranges: &RcmRanges,
    framing_band: [f64; 2],
    n: usize,
) -> Result<Vec<Viewpoint>, CameraError> {
    ranges.validate()?;
    let [d_lo, d_hi] = ranges.distance_band(framing_band)?;
    let [h_lo, h_hi] = ranges.height_m;
    let mut out = Vec::with_capacity(n);
    if n == 0 {
        return Ok(out);
    }
    let mut vp = Viewpoint {
        index: 0,
        distance_m: ranges.start_distance_m.clamp(d_lo, d_hi),
        azimuth_deg: rng.random_range(0.0..360.0),
        height_m: ranges.start_height_m,
        drawn: None,
        applied: None,
    };
    out.push(vp);
    let uniform = |rng: &mut R, r: [f64; 2]| rng.random_range(r[0]..=r[1]);
    for index in 1..n {
        let drawn = StepDraw {
            delta_xy_m: uniform(rng, ranges.delta_xy_m),
            delta_theta_deg: uniform(rng, ranges.delta_theta_deg),
            delta_z_m: uniform(rng, ranges.delta_z_m),
        };
        let distance_m = (vp.distance_m + drawn.delta_xy_m).clamp(d_lo, d_hi);
        let height_m = (vp.height_m + drawn.delta_z_m).clamp(h_lo, h_hi);
        let azimuth_deg = (vp.azimuth_deg + drawn.delta_theta_deg).rem_euclid(360.0);
        vp = Viewpoint {
            index,
            distance_m,
            azimuth_deg,
            height_m,
            drawn: Some(drawn),
            applied: Some(StepDraw {
                delta_xy_m: distance_m - vp.distance_m,
                delta_theta_deg: drawn.delta_theta_deg,
                delta_z_m: height_m - vp.height_m,
            }),
        };
        out.push(vp);
    }
    Ok(out)
}

/// How the camera behaves during one viewpoint's segment of video.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Shot {
    /// The camera holds its viewpoint (relative to the character).
    Static,
    /// The camera glides from its viewpoint to the next one.
    Moving,
}

/// The camera pose at fraction `s` (clamped to [0, 1]; NaN counts as 0) through a segment.
///
/// * [`Shot::Static`], or `to = None`: the camera holds `from`.
/// * [`Shot::Moving`]: distance, height and azimuth go from `from` to `to` along a smoothstep
///   `w = 3s² − 2s³` (zero speed at both ends, so chained segments are C1), the azimuth the
///   shortest way round. Distance and height are convex combinations of in-band ends, so they
///   stay in band.
///
/// Either way the viewpoint is placed about `character_ground_xy_m` (this frame's ground point:
/// the camera tracks root motion) and the camera looks at `look_at_centre_m` (this frame's
/// subject centre), unrolled.
#[must_use]
pub fn camera_at(
    from: &Viewpoint,
    to: Option<&Viewpoint>,
    shot: Shot,
    s: f64,
    character_ground_xy_m: [f64; 2],
    look_at_centre_m: Point3<f64>,
) -> CameraPose {
    let (distance_m, azimuth_deg, height_m) = match (shot, to) {
        (Shot::Moving, Some(to)) => {
            let s = if s.is_nan() { 0.0 } else { s.clamp(0.0, 1.0) };
            let w = s * s * (3.0 - 2.0 * s);
            let turn = (to.azimuth_deg - from.azimuth_deg + 180.0).rem_euclid(360.0) - 180.0;
            (
                from.distance_m + w * (to.distance_m - from.distance_m),
                from.azimuth_deg + w * turn,
                from.height_m + w * (to.height_m - from.height_m),
            )
        }
        _ => (from.distance_m, from.azimuth_deg, from.height_m),
    };
    CameraPose::looking_at(
        cylindrical_to_world(distance_m, azimuth_deg, height_m, character_ground_xy_m),
        look_at_centre_m,
    )
}

fn cylindrical_to_world(
    distance_m: f64,
    azimuth_deg: f64,
    height_m: f64,
    ground_xy_m: [f64; 2],
) -> Point3<f64> {
    let (sin, cos) = azimuth_deg.to_radians().sin_cos();
    Point3::new(
        ground_xy_m[0] + distance_m * cos,
        ground_xy_m[1] + distance_m * sin,
        height_m,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_relative_eq;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Pearson's chi-square statistic of `samples` against U(a, b) on 10 equal bins.
    fn chi_square_10(samples: &[f64], [a, b]: [f64; 2]) -> f64 {
        let mut counts = [0usize; 10];
        for &x in samples {
            let k = (((x - a) / (b - a)) * 10.0).floor().clamp(0.0, 9.0) as usize;
            counts[k] += 1;
        }
        let expected = samples.len() as f64 / 10.0;
        counts
            .iter()
            .map(|&c| (c as f64 - expected).powi(2) / expected)
            .sum()
    }

    /// Kolmogorov–Smirnov statistic `D = sup |F_n(x) − F(x)|` against U(a, b).
    fn ks_statistic(samples: &[f64], [a, b]: [f64; 2]) -> f64 {
        let mut s = samples.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len() as f64;
        s.iter()
            .enumerate()
            .map(|(i, &x)| {
                let f = (x - a) / (b - a);
                (f - i as f64 / n).max((i + 1) as f64 / n - f)
            })
            .fold(0.0, f64::max)
    }

    /// χ²(df = 9) critical value at p = 0.001.
    const CHI2_9_P001: f64 = 27.877;

    /// KS critical value at p = 0.001 for n samples: `sqrt(−ln(0.001/2)/2) / sqrt(n)`.
    fn ks_critical_p001(n: usize) -> f64 {
        (-(0.0005f64).ln() / 2.0).sqrt() / (n as f64).sqrt()
    }

    #[test]
    fn drawn_steps_follow_their_uniform_distributions() {
        let ranges = RcmRanges::default();
        let n = 20_000;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let walk = random_viewpoints(&mut rng, &ranges, [2.0, 6.0], n + 1).unwrap();
        let draws: Vec<StepDraw> = walk.iter().filter_map(|v| v.drawn).collect();
        assert_eq!(draws.len(), n);
        let ks_crit = ks_critical_p001(n);
        for (name, range, samples) in [
            (
                "delta_xy_m",
                ranges.delta_xy_m,
                draws.iter().map(|d| d.delta_xy_m).collect::<Vec<_>>(),
            ),
            (
                "delta_theta_deg",
                ranges.delta_theta_deg,
                draws.iter().map(|d| d.delta_theta_deg).collect(),
            ),
            (
                "delta_z_m",
                ranges.delta_z_m,
                draws.iter().map(|d| d.delta_z_m).collect(),
            ),
        ] {
            assert!(
                samples.iter().all(|x| (range[0]..=range[1]).contains(x)),
                "{name}"
            );
            let chi2 = chi_square_10(&samples, range);
            let d = ks_statistic(&samples, range);
            assert!(
                chi2 < CHI2_9_P001,
                "{name}: chi² = {chi2:.3} ≥ {CHI2_9_P001}"
            );
            assert!(d < ks_crit, "{name}: KS D = {d:.5} ≥ {ks_crit:.5}");
        }
        // The statistics can fail: a skewed sample (the squares of uniforms) is rejected.
        let skewed: Vec<f64> = draws
            .iter()
            .map(|d| ((d.delta_z_m + 0.4) / 0.8).powi(2) * 0.8 - 0.4)
            .collect();
        assert!(chi_square_10(&skewed, ranges.delta_z_m) > CHI2_9_P001);
        assert!(ks_statistic(&skewed, ranges.delta_z_m) > ks_crit);
        // The start azimuths of many walks are uniform on [0, 360) too.
        let starts: Vec<f64> = (0..5_000)
            .map(|seed| {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                random_viewpoints(&mut rng, &ranges, [2.0, 6.0], 1).unwrap()[0].azimuth_deg
            })
            .collect();
        let chi2 = chi_square_10(&starts, [0.0, 360.0]);
        assert!(chi2 < CHI2_9_P001, "start azimuth chi² = {chi2:.3}");
    }

    #[test]
    fn applied_steps_are_the_clamped_draws_and_stay_in_band() {
        let ranges = RcmRanges {
            delta_xy_m: [-1.5, 1.5],
            delta_z_m: [-1.0, 1.0],
            ..RcmRanges::default()
        };
        let band = [3.0, 4.0];
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let walk = random_viewpoints(&mut rng, &ranges, band, 5_000).unwrap();
        let (mut clamped_d, mut clamped_h) = (0, 0);
        for pair in walk.windows(2) {
            let (a, b) = (&pair[0], &pair[1]);
            let drawn = b.drawn.unwrap();
            let applied = b.applied.unwrap();
            assert!((band[0]..=band[1]).contains(&b.distance_m));
            assert!((ranges.height_m[0]..=ranges.height_m[1]).contains(&b.height_m));
            assert!((0.0..360.0).contains(&b.azimuth_deg));
            let want_d = (a.distance_m + drawn.delta_xy_m).clamp(band[0], band[1]);
            let want_h =
                (a.height_m + drawn.delta_z_m).clamp(ranges.height_m[0], ranges.height_m[1]);
            assert_relative_eq!(b.distance_m, want_d, epsilon = 1e-12);
            assert_relative_eq!(b.height_m, want_h, epsilon = 1e-12);
            assert_relative_eq!(
                applied.delta_xy_m,
                b.distance_m - a.distance_m,
                epsilon = 1e-12
            );
            assert_relative_eq!(applied.delta_z_m, b.height_m - a.height_m, epsilon = 1e-12);
            assert_eq!(applied.delta_theta_deg, drawn.delta_theta_deg);
            let turned = (a.azimuth_deg + drawn.delta_theta_deg).rem_euclid(360.0);
            assert_relative_eq!(b.azimuth_deg, turned, epsilon = 1e-9);
            clamped_d += usize::from((applied.delta_xy_m - drawn.delta_xy_m).abs() > 1e-12);
            clamped_h += usize::from((applied.delta_z_m - drawn.delta_z_m).abs() > 1e-12);
        }
        assert!(
            clamped_d > 500 && clamped_h > 500,
            "{clamped_d} {clamped_h}"
        );
    }

    #[test]
    fn the_walk_starts_at_the_start_distance_never_at_the_character() {
        let ranges = RcmRanges::default();
        for seed in 0..200 {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            let walk = random_viewpoints(&mut rng, &ranges, [2.0, 8.0], 4).unwrap();
            let first = walk[0];
            assert_eq!(first.index, 0);
            assert_eq!(first.distance_m, 3.5);
            assert_eq!(first.height_m, 1.6);
            assert_eq!((first.drawn, first.applied), (None, None));
            let p = first.position_m([1.0, -2.0]);
            assert_relative_eq!(
                (p.xy() - nalgebra::Point2::new(1.0, -2.0)).norm(),
                3.5,
                epsilon = 1e-12
            );
            assert!(walk.iter().all(|v| v.distance_m >= 2.0));
        }
        // A character that needs more room pushes the start out to the band.
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let walk = random_viewpoints(&mut rng, &ranges, [5.0, 8.0], 2).unwrap();
        assert_eq!(walk[0].distance_m, 5.0);
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        assert!(
            random_viewpoints(&mut rng, &ranges, [5.0, 8.0], 0)
                .unwrap()
                .is_empty()
        );
    }

    #[test]
    fn same_seed_same_walk_other_seed_other_walk() {
        let ranges = RcmRanges::default();
        let walk = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            random_viewpoints(&mut rng, &ranges, [2.0, 8.0], 6).unwrap()
        };
        assert_eq!(walk(42), walk(42));
        assert_ne!(walk(42), walk(43));
        let a = walk(42);
        let b = walk(43);
        assert!(
            a.iter()
                .zip(&b)
                .all(|(x, y)| x.azimuth_deg != y.azimuth_deg)
        );
    }

    #[test]
    fn validation_names_the_field() {
        let ok = RcmRanges::default();
        assert_eq!(ok.validate(), Ok(()));
        let cases: Vec<(RcmRanges, &str)> = vec![
            (
                RcmRanges {
                    start_distance_m: 0.0,
                    ..ok
                },
                "start_distance_m is 0",
            ),
            (
                RcmRanges {
                    start_distance_m: -1.0,
                    ..ok
                },
                "start_distance_m is -1",
            ),
            (
                RcmRanges {
                    start_distance_m: f64::NAN,
                    ..ok
                },
                "start_distance_m is NaN",
            ),
            (
                RcmRanges {
                    start_height_m: -0.1,
                    ..ok
                },
                "start_height_m is -0.1",
            ),
            (
                RcmRanges {
                    start_height_m: 3.0,
                    ..ok
                },
                "start_height_m is 3; it must be inside height_m",
            ),
            (
                RcmRanges {
                    delta_xy_m: [0.8, -0.8],
                    ..ok
                },
                "delta_xy_m is [0.8, -0.8]",
            ),
            (
                RcmRanges {
                    delta_theta_deg: [30.0, f64::INFINITY],
                    ..ok
                },
                "delta_theta_deg is [30, inf]",
            ),
            (
                RcmRanges {
                    delta_z_m: [f64::NAN, 0.4],
                    ..ok
                },
                "delta_z_m is [NaN, 0.4]",
            ),
            (
                RcmRanges {
                    height_m: [-0.5, 2.0],
                    ..ok
                },
                "height_m is [-0.5, 2]",
            ),
            (
                RcmRanges {
                    height_m: [2.0, 1.0],
                    ..ok
                },
                "height_m is [2, 1]",
            ),
            (
                RcmRanges {
                    distance_m: Some([0.0, 5.0]),
                    ..ok
                },
                "distance_m is [0, 5]",
            ),
            (
                RcmRanges {
                    distance_m: Some([4.0, 6.0]),
                    ..ok
                },
                "start_distance_m is 3.5; it must be inside distance_m",
            ),
        ];
        for (r, want) in cases {
            let e = r.validate().unwrap_err().to_string();
            assert!(e.starts_with(want), "{e:?} does not start with {want:?}");
            let mut rng = ChaCha8Rng::seed_from_u64(0);
            assert!(random_viewpoints(&mut rng, &r, [2.0, 8.0], 3).is_err());
        }
    }

    #[test]
    fn distance_band_intersects_and_explains_a_miss() {
        let r = RcmRanges {
            distance_m: Some([3.0, 5.0]),
            ..RcmRanges::default()
        };
        assert_eq!(r.distance_band([2.0, 8.0]), Ok([3.0, 5.0]));
        assert_eq!(r.distance_band([4.0, 8.0]), Ok([4.0, 5.0]));
        assert_eq!(
            RcmRanges::default().distance_band([4.0, 8.0]),
            Ok([4.0, 8.0])
        );
        let e = r.distance_band([6.0, 8.0]).unwrap_err().to_string();
        assert!(
            e.starts_with("distance_m [3, 5] does not overlap the framing band [6.000, 8.000]"),
            "{e}"
        );
        let e = r.distance_band([0.0, 8.0]).unwrap_err().to_string();
        assert!(e.starts_with("framing_band is [0, 8]"), "{e}");
    }

    #[test]
    fn ranges_read_from_toml_with_defaults_and_reject_unknown_keys() {
        let r: RcmRanges =
            toml::from_str("delta_theta_deg = [60.0, 120.0]\ndistance_m = [2.5, 7.0]").unwrap();
        assert_eq!(r.delta_theta_deg, [60.0, 120.0]);
        assert_eq!(r.distance_m, Some([2.5, 7.0]));
        assert_eq!(r.start_distance_m, RcmRanges::default().start_distance_m);
        let back: RcmRanges = toml::from_str(&toml::to_string(&r).unwrap()).unwrap();
        assert_eq!(back, r);
        let d = RcmRanges::default();
        let back: RcmRanges = toml::from_str(&toml::to_string(&d).unwrap()).unwrap();
        assert_eq!(back, d);
        let e = toml::from_str::<RcmRanges>("delta_thta_deg = [1.0, 2.0]").unwrap_err();
        assert!(e.to_string().contains("delta_thta_deg"), "{e}");
        let s: Shot = serde_json::from_str("\"moving\"").unwrap();
        assert_eq!(s, Shot::Moving);
    }

    fn vp(distance_m: f64, azimuth_deg: f64, height_m: f64) -> Viewpoint {
        Viewpoint {
            index: 0,
            distance_m,
            azimuth_deg,
            height_m,
            drawn: None,
            applied: None,
        }
    }

    #[test]
    fn static_holds_and_moving_glides_the_short_way_round() {
        let a = vp(3.0, 350.0, 1.0);
        let b = vp(5.0, 10.0, 2.0);
        let centre = Point3::new(0.0, 0.0, 1.0);
        for s in [0.0, 0.3, 1.0] {
            let p = camera_at(&a, Some(&b), Shot::Static, s, [0.0, 0.0], centre);
            assert_relative_eq!(p.position_m, a.position_m([0.0, 0.0]), epsilon = 1e-12);
            let p = camera_at(&a, None, Shot::Moving, s, [0.0, 0.0], centre);
            assert_relative_eq!(p.position_m, a.position_m([0.0, 0.0]), epsilon = 1e-12);
        }
        let at = |s: f64| camera_at(&a, Some(&b), Shot::Moving, s, [0.0, 0.0], centre).position_m;
        assert_relative_eq!(at(0.0), a.position_m([0.0, 0.0]), epsilon = 1e-12);
        assert_relative_eq!(at(1.0), b.position_m([0.0, 0.0]), epsilon = 1e-12);
        assert_relative_eq!(at(-1.0), at(0.0), epsilon = 1e-12);
        assert_relative_eq!(at(2.0), at(1.0), epsilon = 1e-12);
        assert_relative_eq!(at(f64::NAN), at(0.0), epsilon = 1e-12);
        // Halfway: azimuth 0° (through +X, not through 180°), distance 4, height 1.5.
        assert_relative_eq!(at(0.5), Point3::new(4.0, 0.0, 1.5), epsilon = 1e-12);
        // Zero speed at both ends (C1 when segments chain), and everything in between in band.
        let h = 1e-6;
        assert!((at(h) - at(0.0)).norm() / h < 1e-4);
        assert!((at(1.0) - at(1.0 - h)).norm() / h < 1e-4);
        for k in 0..=100 {
            let p = at(f64::from(k) / 100.0);
            let d = p.xy().coords.norm();
            assert!((3.0 - 1e-12..=5.0 + 1e-12).contains(&d) && (1.0..=2.0).contains(&p.z));
        }
    }

    #[test]
    fn the_camera_tracks_the_ground_point_and_looks_at_the_centre() {
        let a = vp(4.0, 90.0, 1.6);
        let centre = Point3::new(10.3, -4.9, 1.1);
        let pose = camera_at(&a, None, Shot::Static, 0.5, [10.0, -5.0], centre);
        assert_relative_eq!(
            pose.position_m,
            Point3::new(10.0, -1.0, 1.6),
            epsilon = 1e-12
        );
        let forward = pose.world_from_optical * nalgebra::Vector3::z();
        assert_relative_eq!(
            forward,
            (centre - pose.position_m).normalize(),
            epsilon = 1e-12
        );
    }
}
