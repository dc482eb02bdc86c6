//! Light, sky, fog and weather of one scene, as numbers the rasteriser uses: a drawn
//! [`Scene`] (time of day, weather, indoor or not) becomes a key light with its direction and
//! colour, a hemisphere ambient, a sky gradient with the sun's glow, exponential fog, and the
//! precipitation, ground state and lightning the frame passes draw.
//!
//! Units are relative: a white surface facing a clear noon sun reaches about 0.9 of full scale.
//! The world frame is east-north-up (x east, y north, z up), the frame
//! [`crate::scene::SunPosition::direction_enu`] is given in.
//!
//! Night (the sun more than a few degrees below the horizon) is lit dimly: outdoors a warm
//! street-lamp key from high up and a faint sky glow, indoors a ceiling key; daylight fades into
//! it through twilight. Outdoors the ground's light never falls as the sun rises, whatever the
//! weather (the night's floor is below the darkest weather's daylight, a noon thunderstorm), and
//! a camera exposure makes up part of a dark scene's shortfall (brightness goes as the light to
//! the power 0.5), so darker scenes stay darker but readable.

use super::color::{Rgb, add, mix, scale};
use super::fast_float::{floor_small, pow2};
use crate::scene::weather::Precipitation;
use crate::scene::weather::Weather;
use crate::scene::{Scene, sky::ambient_from_sun};

/// Everything the passes need to light and colour one scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Environment {
    /// Unit vector towards the key light (the sun by day), world frame.
    pub key_dir: [f32; 3],
    /// Irradiance of the key light on a surface facing it, linear RGB.
    pub key_rgb: Rgb,
    /// Whether the key light casts shadows (false under a closed cloud deck, where it is weak).
    pub key_shadows: bool,
    /// Ambient light from above (sky or ceiling), linear RGB.
    pub sky_ambient_rgb: Rgb,
    /// Ambient light from below (ground bounce), linear RGB.
    pub ground_ambient_rgb: Rgb,
    /// Sky colour straight up.
    pub zenith_rgb: Rgb,
    /// Sky colour at the horizon (also the fog colour).
    pub horizon_rgb: Rgb,
    /// Direction towards the sun, and the colour of its glow in the sky (zero when hidden).
    pub sun_glow: ([f32; 3], Rgb),
    /// Exponential fog: the fraction of light kept over `d` metres is `exp(−fog_per_m·d)`.
    pub fog_per_m: f32,
    /// Cloud cover, [0, 1].
    pub cloud_cover: f32,
    /// What falls, and how hard (mm/h of water).
    pub precipitation: (Precipitation, f32),
    /// Wind, m/s (slants rain and snow).
    pub wind_m_per_s: f32,
    /// Ground wetness, [0, 1].
    pub wetness: f32,
    /// Snow cover, [0, 1].
    pub snow_cover: f32,
    /// Whether lightning flashes (THUNDER).
    pub lightning: bool,
    /// Whether the scene is inside (walls and ceiling, no sky, no weather).
    pub indoor: bool,
}

/// `exp(−x)` for `x ≥ 0` to about 2·10⁻⁴ relative, without a libm call: the fog factor is
/// needed once per pixel. Both formulas are computed and one is selected, without a branch,
/// so that a loop over pixels calling this can be vectorised.
#[inline]
#[must_use]
pub fn fast_exp_neg(x: f32) -> f32 {
    // Thin air (most fog-free pixels): the series is exact to 2e-10 below 1e-3.
    let series = 1.0 - x + 0.5 * x * x;
    // e^−x = 2^y with y = −x·log2(e); split y into integer k and fraction f in [0, 1). x is
    // clamped to where this formula is used (NaN to its low end), so that the integers below
    // stay in range.
    #[expect(
        clippy::manual_clamp,
        reason = "`clamp` keeps NaN, which must not reach the integers"
    )]
    let y = -x.max(1e-3).min(80.0) * std::f32::consts::LOG2_E;
    // y is in [−116, 0).
    let (floor, k) = floor_small(y);
    let f = y - floor;
    // 2^f on [0, 1): a cubic fit (max relative error ~1e-4).
    let p = 1.0 + f * (0.695_976_1 + f * (0.224_940_72 + f * 0.079_083_07));
    let fitted = p * pow2(k);
    let small = if x < 1e-3 { series } else { fitted };
    let finite = if x > 80.0 { 0.0 } else { small };
    // NaN and x ≤ 0 give 1.
    if x > 0.0 { finite } else { 1.0 }
}

/// Sun elevation, degrees, below which the sun gives no direct light.
const SUN_SET_DEG: f64 = -1.0;
/// Sun elevation, degrees, above which the sun's direct light is full.
const SUN_UP_DEG: f64 = 8.0;

fn smoothstep(lo: f64, hi: f64, x: f64) -> f64 {
    let t = ((x - lo) / (hi - lo)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

fn rgb(c: [f64; 3]) -> Rgb {
    [c[0] as f32, c[1] as f32, c[2] as f32]
}

fn unit(v: [f64; 3]) -> [f32; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt().max(1e-12);
    [(v[0] / n) as f32, (v[1] / n) as f32, (v[2] / n) as f32]
}

/// Direction from azimuth (degrees clockwise from north) and elevation (degrees), ENU.
fn direction(azimuth_deg: f64, elevation_deg: f64) -> [f64; 3] {
    let (az, el) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    [az.sin() * el.cos(), az.cos() * el.cos(), el.sin()]
}

/// The night's key light at full darkness (a street lamp or the moon high up), linear RGB: dim
/// enough that, with [`NIGHT_AMBIENT`], it lights the ground less than the darkest weather's
/// daylight (a noon thunderstorm), so light never falls as the sun rises.
const NIGHT_LAMP: Rgb = [0.036, 0.028, 0.019];
/// The night's ambient at full darkness (sky glow, moonlight), linear RGB.
const NIGHT_AMBIENT: Rgb = [0.009, 0.0099, 0.0135];
/// Irradiance luminance on the ground under a clear noon sun, the exposure's reference.
const REFERENCE_IRRADIANCE: f32 = 1.1;
/// How much of a darker scene's shortfall the camera's exposure makes up (0 none, 1 all): the
/// picture's brightness goes as the light's to the power `1 − EXPOSURE_COMPENSATION`, so darker
/// scenes stay darker (the order of brightness is kept) yet readable.
const EXPOSURE_COMPENSATION: f32 = 0.5;

/// Rec. 709 luminance of a linear colour.
#[inline]
#[must_use]
pub fn luminance(c: Rgb) -> f32 {
    0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]
}

/// The exposure gain for a scene whose ground receives `irradiance` (luminance): 1 at or
/// above a clear noon's, `(reference / irradiance)^EXPOSURE_COMPENSATION` below it — a
/// monotone map, so a darker scene never renders brighter.
fn exposure(irradiance: f32) -> f32 {
    (REFERENCE_IRRADIANCE / irradiance.max(1e-4))
        .max(1.0)
        .powf(EXPOSURE_COMPENSATION)
}

/// The sky's zenith and horizon colours (before exposure) for daylight factor `d`: day, dusk
/// and night blended, greyed by cloud, tinted by smog and pulled to the horizon by fog.
fn sky_colours(scene: &Scene, d: f32) -> (Rgb, Rgb) {
    let w = &scene.weather_params;
    let el = scene.sun.elevation_deg;
    let day_zenith = rgb([0.16, 0.32, 0.72]);
    let day_horizon = rgb([0.62, 0.72, 0.88]);
    let dusk = 1.0 - smoothstep(-4.0, 14.0, el) as f32;
    let zenith = mix(day_zenith, rgb([0.12, 0.16, 0.38]), dusk);
    let horizon = mix(day_horizon, rgb([0.98, 0.55, 0.32]), dusk);
    let night = rgb([0.002, 0.003, 0.008]);
    let night_horizon = rgb([0.008, 0.009, 0.014]);
    let mut zenith = mix(night, zenith, d);
    let mut horizon = mix(night_horizon, horizon, d);
    let cloud = w.cloud_cover as f32;
    let grey = scale(
        [0.55, 0.57, 0.6],
        (0.02 + 0.98 * d) * w.ambient_light_scale as f32,
    );
    zenith = mix(zenith, scale(grey, 0.85), cloud * cloud);
    horizon = mix(horizon, grey, cloud * 0.8);
    if scene.weather == Weather::Smog {
        horizon = mix(horizon, scale([0.72, 0.62, 0.45], d), 0.6);
        zenith = mix(zenith, horizon, 0.4);
    }
    // Fog thick enough to matter pulls the whole sky to its colour.
    let haze = (w.fog_density_per_m as f32 * 60.0).min(1.0);
    (mix(zenith, horizon, haze), horizon)
}

impl Environment {
    /// The environment of a drawn scene. `layout_seed` (the scene's stream) places the night
    /// lamp so scenes differ.
    #[must_use]
    pub fn from_scene(scene: &Scene, layout_seed: u64) -> Environment {
        let lamp_azimuth = (layout_seed % 360) as f64;
        if scene.location.indoor {
            return Environment::room(unit(direction(lamp_azimuth, 72.0)));
        }
        let w = &scene.weather_params;
        let el = scene.sun.elevation_deg;
        let daylight = ambient_from_sun(el);
        let d = daylight as f32;
        let (zenith, horizon) = sky_colours(scene, d);
        // Sun: warm and weak near the horizon, white high up; scaled by the weather.
        let sun_up = smoothstep(SUN_SET_DEG, SUN_UP_DEG, el);
        let warm = smoothstep(0.0, 30.0, el);
        let sun_colour = mix(rgb([1.0, 0.52, 0.28]), rgb([1.0, 0.96, 0.9]), warm as f32);
        let sun_rgb = scale(sun_colour, (0.95 * sun_up * w.direct_light_scale) as f32);
        // Ambient: the sky's light by day (weather-scaled), and the night's dim floor (moon,
        // street lamps) fading out through twilight.
        let artificial = 1.0 - d;
        let sky_day = scale(
            [0.30, 0.36, 0.46],
            (daylight * w.ambient_light_scale) as f32,
        );
        let mut sky_ambient = add(sky_day, scale(NIGHT_AMBIENT, artificial));
        let lamp_rgb = scale(NIGHT_LAMP, artificial);
        // Key light: of the sun and the night lamp, the one that lights the ground more; the
        // other's light on the ground joins the ambient, so the ground's irradiance is their
        // sum at every sun elevation (no jump where the key changes).
        let sun_dir = unit(scene.sun.direction_enu());
        let lamp_dir = unit(direction(lamp_azimuth, 62.0));
        let on_ground = |c: Rgb, dir: [f32; 3]| scale(c, dir[2].max(0.0));
        let (key_dir, key_rgb, other) =
            if luminance(on_ground(sun_rgb, sun_dir)) >= luminance(on_ground(lamp_rgb, lamp_dir)) {
                (sun_dir, sun_rgb, on_ground(lamp_rgb, lamp_dir))
            } else {
                (lamp_dir, lamp_rgb, on_ground(sun_rgb, sun_dir))
            };
        sky_ambient = add(sky_ambient, other);
        let ground_irradiance = luminance(on_ground(key_rgb, key_dir)) + luminance(sky_ambient);
        let key_shadows = luminance(on_ground(key_rgb, key_dir)) > 0.05 * ground_irradiance;
        let ground_ambient = scale(add(sky_ambient, scale(key_rgb, 0.25)), 0.35);
        let sun_glow = if sun_up > 0.0 {
            (
                sun_dir,
                scale(
                    sun_colour,
                    (0.95 * sun_up * w.direct_light_scale * 1.4) as f32,
                ),
            )
        } else {
            (sun_dir, [0.0; 3])
        };
        // The camera's exposure, part of the way towards a clear noon's, on what the light
        // falls on; the sky (and the fog, its colour) keeps its own radiance, which already
        // grows with the sun.
        let e = exposure(ground_irradiance);
        Environment {
            key_dir,
            key_rgb: scale(key_rgb, e),
            key_shadows,
            sky_ambient_rgb: scale(sky_ambient, e),
            ground_ambient_rgb: scale(ground_ambient, e),
            zenith_rgb: zenith,
            horizon_rgb: horizon,
            sun_glow,
            fog_per_m: w.fog_density_per_m as f32,
            cloud_cover: w.cloud_cover as f32,
            precipitation: (w.precipitation, w.precipitation_rate_mm_per_h as f32),
            wind_m_per_s: w.wind_speed_m_per_s as f32,
            wetness: w.ground_wetness as f32,
            snow_cover: w.snow_cover as f32,
            lightning: w.lightning,
            indoor: false,
        }
    }

    /// A lit room: a ceiling key from `key_dir`, even ambient, no sky and no weather inside.
    fn room(key_dir: [f32; 3]) -> Environment {
        Environment {
            key_dir,
            key_rgb: rgb([0.62, 0.58, 0.5]),
            key_shadows: true,
            sky_ambient_rgb: rgb([0.34, 0.33, 0.31]),
            ground_ambient_rgb: rgb([0.16, 0.15, 0.14]),
            zenith_rgb: rgb([0.8, 0.8, 0.78]),
            horizon_rgb: rgb([0.7, 0.7, 0.68]),
            sun_glow: (key_dir, [0.0; 3]),
            fog_per_m: 0.0,
            cloud_cover: 0.0,
            precipitation: (Precipitation::None, 0.0),
            wind_m_per_s: 0.0,
            wetness: 0.0,
            snow_cover: 0.0,
            lightning: false,
            indoor: true,
        }
    }

    /// Ambient light on a surface whose normal has vertical component `normal_z`: the sky's
    /// from above blended with the ground's from below.
    #[inline]
    #[must_use]
    pub fn ambient(&self, normal_z: f32) -> Rgb {
        mix(
            self.ground_ambient_rgb,
            self.sky_ambient_rgb,
            0.5 + 0.5 * normal_z,
        )
    }

    /// Sky colour in world direction `dir` (unit), before any lightning.
    #[inline]
    #[must_use]
    pub fn sky(&self, dir: [f32; 3]) -> Rgb {
        let up = dir[2].max(0.0);
        let t = up.sqrt();
        let mut c = mix(self.horizon_rgb, self.zenith_rgb, t);
        let (s, glow) = self.sun_glow;
        if glow[0] > 0.0 {
            let cos = dir[0] * s[0] + dir[1] * s[1] + dir[2] * s[2];
            if cos > 0.9 {
                // A soft halo and a bright disc (0.53° wide in reality; a few pixels here).
                let halo = ((cos - 0.9) * 10.0).powi(6) * (1.0 - 0.7 * self.cloud_cover);
                let disc = if cos > 0.9994 {
                    3.0 * (1.0 - self.cloud_cover)
                } else {
                    0.0
                };
                c = add(c, scale(glow, halo + disc));
            }
        }
        c
    }

    /// Brightness added by lightning at scene time `t_s` (0 between flashes): a flash every few
    /// seconds, with a second pulse, at times fixed by `seed`.
    #[must_use]
    pub fn lightning_flash(&self, t_s: f64, seed: u64) -> f32 {
        // Time is cut into 5 s windows; each window flashes once at a seeded offset.
        const WINDOW_S: f64 = 5.0;
        if !self.lightning {
            return 0.0;
        }
        let window = (t_s / WINDOW_S).floor();
        let h = crate::hash::hash2(seed, window as i64 as u64);
        let at = (h as f64 / u64::MAX as f64) * (WINDOW_S - 0.5);
        let dt = t_s - window * WINDOW_S - at;
        let pulse = |start: f64, length: f64| {
            if (start..start + length).contains(&dt) {
                1.0 - (dt - start) / length
            } else {
                0.0
            }
        };
        (1.6 * pulse(0.0, 0.12) + 1.2 * pulse(0.2, 0.1)) as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::sky::ClockTime;
    use crate::scene::tests::test_scene;

    #[test]
    fn noon_is_brighter_than_dusk_and_night_is_dark_but_lit() {
        let noon = Environment::from_scene(&test_scene(Weather::Clear, ClockTime::NOON), 1);
        let dusk = Environment::from_scene(&test_scene(Weather::Clear, ClockTime::EVENING), 1);
        let night = Environment::from_scene(&test_scene(Weather::Clear, ClockTime::MIDNIGHT), 1);
        let storm = Environment::from_scene(&test_scene(Weather::Thunder, ClockTime::NOON), 1);
        let lit = |e: &Environment| {
            luminance(e.key_rgb) * e.key_dir[2].max(0.0) + luminance(e.sky_ambient_rgb)
        };
        assert!(lit(&noon) > lit(&dusk), "{noon:?} {dusk:?}");
        // 20:00 in June at 34° N is past civil twilight: as dark as midnight, never darker.
        assert!(lit(&dusk) >= lit(&night), "{dusk:?} {night:?}");
        assert!(lit(&storm) > lit(&night), "{storm:?} {night:?}");
        assert!(lit(&night) < 0.3 * lit(&noon), "night is dark: {night:?}");
        assert!(lit(&night) > 0.05, "but lit: {night:?}");
        assert!(luminance(night.zenith_rgb) < 0.05);
        // The night key is the lamp, warm: more red than blue.
        assert!(night.key_rgb[0] > night.key_rgb[2]);
        // Noon's key is the sun, high up.
        assert!(noon.key_dir[2] > 0.8);
    }

    #[test]
    fn the_grounds_light_never_falls_as_the_sun_rises_in_any_weather() {
        let mut scene = test_scene(Weather::Clear, ClockTime::NOON);
        for weather in Weather::ALL {
            scene.weather = weather;
            scene.weather_params = weather.params();
            let mut last = 0.0f32;
            for tenth in -300..=900 {
                scene.sun.elevation_deg = f64::from(tenth) / 10.0;
                let e = Environment::from_scene(&scene, 1);
                let lit =
                    luminance(e.key_rgb) * e.key_dir[2].max(0.0) + luminance(e.sky_ambient_rgb);
                assert!(
                    lit >= last * (1.0 - 1e-5),
                    "{weather} at {:.1}°: {lit} after {last}",
                    scene.sun.elevation_deg
                );
                last = lit;
            }
        }
    }

    #[test]
    fn weather_changes_fog_sky_and_ground() {
        let clear = Environment::from_scene(&test_scene(Weather::Clear, ClockTime::NOON), 1);
        let foggy = Environment::from_scene(&test_scene(Weather::Foggy, ClockTime::NOON), 1);
        let rain = Environment::from_scene(&test_scene(Weather::Rain, ClockTime::NOON), 1);
        let snow = Environment::from_scene(&test_scene(Weather::Snow, ClockTime::NOON), 1);
        assert!(foggy.fog_per_m > 20.0 * clear.fog_per_m);
        assert!(luminance(clear.key_rgb) > luminance(rain.key_rgb));
        assert_eq!(rain.precipitation.0, Precipitation::Rain);
        assert!(rain.wetness > 0.3 && snow.snow_cover > 0.3);
        let thunder = Environment::from_scene(&test_scene(Weather::Thunder, ClockTime::NOON), 1);
        let flashes = (0..3000)
            .filter(|&k| thunder.lightning_flash(f64::from(k) / 30.0, 9) > 0.0)
            .count();
        assert!(
            (10..300).contains(&flashes),
            "{flashes} flash frames in 100 s"
        );
        assert_eq!(clear.lightning_flash(1.0, 9), 0.0);
    }

    #[test]
    fn fast_exp_matches_exp() {
        for i in 0..2000 {
            let x = i as f32 * 0.02;
            let (a, b) = (fast_exp_neg(x), (-x).exp());
            assert!((a - b).abs() <= 3e-4 * b + 1e-30, "{x}: {a} vs {b}");
        }
        assert_eq!(fast_exp_neg(-1.0), 1.0);
        assert_eq!(fast_exp_neg(f32::NAN), 1.0);
        assert_eq!(fast_exp_neg(1000.0), 0.0);
    }

    #[test]
    fn the_sun_glows_in_its_direction_only() {
        let e = Environment::from_scene(&test_scene(Weather::ExtraSunny, ClockTime::NOON), 1);
        let towards = e.sky(e.sun_glow.0);
        let away = e.sky([-e.sun_glow.0[0], -e.sun_glow.0[1], e.sun_glow.0[2]]);
        assert!(luminance(towards) > 2.0 * luminance(away));
    }
}
