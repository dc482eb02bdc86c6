//! Time of day and the sun: the clock a scene is set at, where the sun stands then, and how much
//! daylight there is.
//!
//! The paper shows four clock times — dawn 05:30, noon 12:00, evening 20:00, midnight 23:00 —
//! and any other is allowed. The sun's position comes from the NOAA solar calculator's
//! formulas (Spencer's 1971 Fourier series for the solar declination and the equation of time),
//! good to a fraction of a degree, with no atmospheric refraction. The clock is read as *local
//! mean solar time*: 12:00 is when the mean sun crosses the meridian, so the true sun culminates
//! at 12:00 − equation of time (within ±16 minutes of noon). A scene therefore never depends
//! on a time zone or a longitude, only on latitude and day of the year.
//!
//! Angles: elevation above the horizon, degrees; azimuth clockwise from north, degrees in
//! [0, 360) (90 = east, 180 = south, 270 = west).

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::SceneError;

/// A clock time, minutes since midnight in `0..1440`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct ClockTime {
    minutes: u16,
}

impl ClockTime {
    /// Minutes in a day.
    pub const MINUTES_PER_DAY: u16 = 1440;
    /// The paper's dawn, 05:30.
    pub const DAWN: ClockTime = ClockTime {
        minutes: 5 * 60 + 30,
    };
    /// The paper's noon, 12:00.
    pub const NOON: ClockTime = ClockTime { minutes: 12 * 60 };
    /// The paper's evening, 20:00.
    pub const EVENING: ClockTime = ClockTime { minutes: 20 * 60 };
    /// The paper's midnight, 23:00 (sic: the paper's "midnight" is an hour before it).
    pub const MIDNIGHT: ClockTime = ClockTime { minutes: 23 * 60 };
    /// The named presets, as accepted by [`FromStr`].
    pub const PRESETS: [(&'static str, ClockTime); 4] = [
        ("dawn", ClockTime::DAWN),
        ("noon", ClockTime::NOON),
        ("evening", ClockTime::EVENING),
        ("midnight", ClockTime::MIDNIGHT),
    ];

    /// The clock at `hour:minute` (hour 0–23, minute 0–59).
    ///
    /// # Errors
    /// [`SceneError::BadClock`] when either is out of range.
    pub fn new(hour: u16, minute: u16) -> Result<ClockTime, SceneError> {
        if hour > 23 || minute > 59 {
            return Err(SceneError::BadClock {
                text: format!("{hour}:{minute:02}"),
                reason: "hours run 0–23 and minutes 0–59",
            });
        }
        Ok(ClockTime {
            minutes: hour * 60 + minute,
        })
    }

    /// The clock `minutes` after midnight.
    ///
    /// # Errors
    /// [`SceneError::BadClock`] unless `minutes < 1440`.
    pub fn from_minutes(minutes: u16) -> Result<ClockTime, SceneError> {
        if minutes >= Self::MINUTES_PER_DAY {
            return Err(SceneError::BadClock {
                text: format!("{minutes} minutes"),
                reason: "a clock time is 0..1440 minutes after midnight",
            });
        }
        Ok(ClockTime { minutes })
    }

    /// Minutes since midnight, `0..1440`.
    #[must_use]
    pub fn minutes(self) -> u16 {
        self.minutes
    }

    /// Hours since midnight, fractional (`05:30` → 5.5).
    #[must_use]
    pub fn hours(self) -> f64 {
        f64::from(self.minutes) / 60.0
    }
}

impl fmt::Display for ClockTime {
    /// `HH:MM`, zero-padded.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{:02}:{:02}", self.minutes / 60, self.minutes % 60)
    }
}

impl FromStr for ClockTime {
    type Err = SceneError;

    /// `dawn`, `noon`, `evening`, `midnight` (any case) or `H:MM` / `HH:MM` (24-hour clock).
    fn from_str(s: &str) -> Result<ClockTime, SceneError> {
        let text = s.trim();
        if let Some(&(_, t)) = ClockTime::PRESETS
            .iter()
            .find(|(name, _)| name.eq_ignore_ascii_case(text))
        {
            return Ok(t);
        }
        let bad = |reason| SceneError::BadClock {
            text: text.to_owned(),
            reason,
        };
        let (h, m) = text
            .split_once(':')
            .ok_or_else(|| bad("expected dawn, noon, evening, midnight or a 24-hour time HH:MM"))?;
        let digits = |part: &str, max_len: usize| {
            (!part.is_empty() && part.len() <= max_len && part.bytes().all(|b| b.is_ascii_digit()))
                .then(|| part.parse::<u16>().ok())
                .flatten()
        };
        let hour = digits(h, 2).ok_or_else(|| bad("the hour must be 1 or 2 digits"))?;
        let minute = (m.len() == 2)
            .then(|| digits(m, 2))
            .flatten()
            .ok_or_else(|| bad("the minutes must be 2 digits"))?;
        ClockTime::new(hour, minute).map_err(|_| bad("hours run 0–23 and minutes 0–59"))
    }
}

impl Serialize for ClockTime {
    /// As `HH:MM`.
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for ClockTime {
    /// From anything [`FromStr`] accepts.
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<ClockTime, D::Error> {
        let s = String::deserialize(deserializer)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// Where the sun stands.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SunPosition {
    /// Angle above the horizon, degrees (negative below it).
    pub elevation_deg: f64,
    /// Compass bearing, degrees clockwise from north in [0, 360).
    pub azimuth_deg: f64,
}

impl SunPosition {
    /// Unit vector towards the sun in the east-north-up frame (x east, y north, z up).
    #[must_use]
    pub fn direction_enu(&self) -> [f64; 3] {
        let (el, az) = (
            self.elevation_deg.to_radians(),
            self.azimuth_deg.to_radians(),
        );
        [az.sin() * el.cos(), az.cos() * el.cos(), el.sin()]
    }
}

/// The sun's position at `clock` (local mean solar time), at `latitude_deg` (north positive,
/// clamped to [−90, 90]) on day `day_of_year` (1 = 1 January, clamped to 1..=366).
///
/// NOAA's formulas, with the fractional year γ = 2π/365·(day − 1 + (hour − 12)/24):
/// - declination δ = 0.006918 − 0.399912 cos γ + 0.070257 sin γ − 0.006758 cos 2γ
///   \+ 0.000907 sin 2γ − 0.002697 cos 3γ + 0.00148 sin 3γ (radians);
/// - equation of time E = 229.18·(0.000075 + 0.001868 cos γ − 0.032077 sin γ
///   − 0.014615 cos 2γ − 0.040849 sin 2γ) (minutes);
/// - true solar time = clock + E, hour angle h = true solar time / 4 − 180° (degrees);
/// - sin(elevation) = sin φ sin δ + cos φ cos δ cos h, and the azimuth from south
///   atan2(sin h, cos h sin φ − tan δ cos φ), turned to a bearing from north.
#[must_use]
pub fn sun_position(clock: ClockTime, latitude_deg: f64, day_of_year: u16) -> SunPosition {
    use std::f64::consts::TAU;
    let phi = latitude_deg.clamp(-90.0, 90.0).to_radians();
    let day = f64::from(day_of_year.clamp(1, 366));
    let g = TAU / 365.0 * (day - 1.0 + (clock.hours() - 12.0) / 24.0);
    let decl = 0.006_918 - 0.399_912 * g.cos() + 0.070_257 * g.sin() - 0.006_758 * (2.0 * g).cos()
        + 0.000_907 * (2.0 * g).sin()
        - 0.002_697 * (3.0 * g).cos()
        + 0.001_48 * (3.0 * g).sin();
    let eqtime_min = 229.18
        * (0.000_075 + 0.001_868 * g.cos()
            - 0.032_077 * g.sin()
            - 0.014_615 * (2.0 * g).cos()
            - 0.040_849 * (2.0 * g).sin());
    let true_solar_min = f64::from(clock.minutes()) + eqtime_min;
    let h = (true_solar_min / 4.0 - 180.0).to_radians();
    let sin_el = (phi.sin() * decl.sin() + phi.cos() * decl.cos() * h.cos()).clamp(-1.0, 1.0);
    // Azimuth measured from south, westward positive, then turned to a bearing from north.
    let from_south = h.sin().atan2(h.cos() * phi.sin() - decl.tan() * phi.cos());
    SunPosition {
        elevation_deg: sin_el.asin().to_degrees(),
        azimuth_deg: (from_south.to_degrees() + 180.0).rem_euclid(360.0),
    }
}

/// Sun elevation, degrees, below which the sky gives no daylight: the end of civil twilight.
pub const NIGHT_BELOW_DEG: f64 = -6.0;
/// Sun elevation, degrees, above which the sky gives full daylight.
pub const FULL_DAYLIGHT_ABOVE_DEG: f64 = 10.0;

/// Daylight factor of the sky, [0, 1], from the sun's elevation in degrees: 0 at night (below
/// −6°, the end of civil twilight, when horizontal illuminance has fallen to a few lux), 1 in
/// full daylight (above 10°, where a clear sky's diffuse light is near its plateau), and a
/// smoothstep between — the twilight ramp. It multiplies the renderer's clear-day ambient,
/// together with [`super::weather::WeatherParams::ambient_light_scale`]; night lighting
/// (moon, street lamps) is the renderer's own floor on top of it.
#[must_use]
pub fn ambient_from_sun(elevation_deg: f64) -> f64 {
    let t = ((elevation_deg - NIGHT_BELOW_DEG) / (FULL_DAYLIGHT_ABOVE_DEG - NIGHT_BELOW_DEG))
        .clamp(0.0, 1.0);
    if t.is_nan() {
        return 0.0;
    }
    t * t * (3.0 - 2.0 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    const JUNE_SOLSTICE: u16 = 172;
    const MARCH_EQUINOX: u16 = 80;

    #[test]
    fn presets_are_the_papers() {
        assert_eq!(ClockTime::DAWN.to_string(), "05:30");
        assert_eq!(ClockTime::NOON.to_string(), "12:00");
        assert_eq!(ClockTime::EVENING.to_string(), "20:00");
        assert_eq!(ClockTime::MIDNIGHT.to_string(), "23:00");
        for (name, t) in ClockTime::PRESETS {
            assert_eq!(name.parse::<ClockTime>().unwrap(), t);
            assert_eq!(name.to_uppercase().parse::<ClockTime>().unwrap(), t);
        }
    }

    #[test]
    fn every_clock_time_prints_and_parses_back() {
        for m in 0..ClockTime::MINUTES_PER_DAY {
            let t = ClockTime::from_minutes(m).unwrap();
            let text = t.to_string();
            assert_eq!(text.len(), 5);
            assert_eq!(text.parse::<ClockTime>().unwrap(), t);
            let json = serde_json::to_string(&t).unwrap();
            assert_eq!(serde_json::from_str::<ClockTime>(&json).unwrap(), t);
        }
        assert_eq!("7:05".parse::<ClockTime>().unwrap().minutes(), 425);
        assert_eq!(" 23:59 ".parse::<ClockTime>().unwrap().minutes(), 1439);
    }

    #[test]
    fn bad_clock_times_error_naming_the_text() {
        for bad in [
            "", "24:00", "12:60", "12", "12:5", "12:005", "-1:00", "+1:00", "123:00", "ab:cd",
            "noonish", "12:00:00", "1 2:00",
        ] {
            let err = bad.parse::<ClockTime>().unwrap_err();
            assert!(
                err.to_string().contains(&format!("`{}`", bad.trim())),
                "{err}"
            );
        }
        assert!(ClockTime::from_minutes(1440).is_err());
        assert!(ClockTime::new(24, 0).is_err());
        assert!(ClockTime::new(0, 60).is_err());
    }

    #[test]
    fn equator_at_equinox_noon_has_the_sun_overhead() {
        let s = sun_position(ClockTime::NOON, 0.0, MARCH_EQUINOX);
        assert!((s.elevation_deg - 90.0).abs() < 2.0, "{s:?}");
    }

    #[test]
    fn june_solstice_noon_at_45_north() {
        // 90 − 45 + 23.44 = 68.44°, due south.
        let s = sun_position(ClockTime::NOON, 45.0, JUNE_SOLSTICE);
        assert!((s.elevation_deg - 68.44).abs() < 1.0, "{s:?}");
        assert!((s.azimuth_deg - 180.0).abs() < 3.0, "{s:?}");
        // In the southern hemisphere the noon sun stands in the north, low in June.
        let s = sun_position(ClockTime::NOON, -45.0, JUNE_SOLSTICE);
        assert!((s.elevation_deg - 21.56).abs() < 1.0, "{s:?}");
        assert!(!(90.0..270.0).contains(&s.azimuth_deg), "{s:?}");
    }

    #[test]
    fn dawn_east_evening_west_midnight_below() {
        for lat in [30.0, 34.0, 45.0, 55.0] {
            let dawn = sun_position(ClockTime::DAWN, lat, JUNE_SOLSTICE);
            assert!((0.0..180.0).contains(&dawn.azimuth_deg), "{lat}: {dawn:?}");
            let evening = sun_position(ClockTime::EVENING, lat, JUNE_SOLSTICE);
            assert!(
                (180.0..360.0).contains(&evening.azimuth_deg),
                "{lat}: {evening:?}"
            );
            for day in [1, MARCH_EQUINOX, JUNE_SOLSTICE, 266, 355] {
                let night = sun_position(ClockTime::MIDNIGHT, lat, day);
                assert!(night.elevation_deg < 0.0, "{lat} {day}: {night:?}");
            }
        }
        // In summer at mid latitudes the sun rises before 05:30 (solar time) ...
        assert!(sun_position(ClockTime::DAWN, 45.0, JUNE_SOLSTICE).elevation_deg > 0.0);
        // ... and at the equinox it has not yet.
        assert!(sun_position(ClockTime::DAWN, 45.0, MARCH_EQUINOX).elevation_deg < 0.0);
    }

    #[test]
    fn the_sun_culminates_at_noon_minus_the_equation_of_time() {
        // Early November the equation of time is ≈ +16.4 min: the sun culminates ≈ 11:44.
        let day = 307;
        let elevation = |m| sun_position(ClockTime::from_minutes(m).unwrap(), 40.0, day);
        let best = (600..800)
            .max_by(|&a, &b| {
                elevation(a)
                    .elevation_deg
                    .total_cmp(&elevation(b).elevation_deg)
            })
            .unwrap();
        assert!((i32::from(best) - (12 * 60 - 16)).abs() <= 1, "{best}");
    }

    #[test]
    fn direction_points_at_the_sun() {
        let s = SunPosition {
            elevation_deg: 30.0,
            azimuth_deg: 90.0,
        };
        let d = s.direction_enu();
        assert!((d[0] - 30f64.to_radians().cos()).abs() < 1e-12);
        assert!(d[1].abs() < 1e-12 && (d[2] - 0.5).abs() < 1e-12);
    }

    #[test]
    fn ambient_ramps_from_night_to_day() {
        assert_eq!(ambient_from_sun(-30.0), 0.0);
        assert_eq!(ambient_from_sun(-6.0), 0.0);
        assert_eq!(ambient_from_sun(10.0), 1.0);
        assert_eq!(ambient_from_sun(60.0), 1.0);
        assert_eq!(ambient_from_sun(f64::NAN), 0.0);
        let mut last = 0.0;
        for i in -60..=100 {
            let a = ambient_from_sun(f64::from(i) / 10.0);
            assert!((0.0..=1.0).contains(&a) && a >= last);
            last = a;
        }
        assert!((0.2..0.6).contains(&ambient_from_sun(0.0)));
    }
}
