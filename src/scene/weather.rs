//! The paper's 14 weathers and the physical parameters a renderer needs to show each one.
//!
//! GTAutoAct switches among GTA V's weather presets by name; an embedded renderer or an export
//! to another engine needs numbers instead: how far one sees, how much cloud, what falls from
//! the sky and how hard, how wet or white the ground is, how much light reaches it. Those numbers
//! live in one table, [`TABLE`], each row from meteorological definitions (sources in the table's
//! doc comment), and [`Weather::params`] reads it — no randomness: the random part of a scene is
//! *which* weather is drawn (see [`super::weighted_choice`]), never cycled in order as the
//! reference code did.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::SceneError;

/// One of GTA V's weather presets the paper uses (its Table "alternative weathers").
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Weather {
    /// Heavy snow driven by strong wind.
    Blizzard,
    /// Clear sky, a few clouds.
    Clear,
    /// The sky breaking up after rain: wet ground, broken clouds.
    Clearing,
    /// Partly cloudy.
    Clouds,
    /// Cloudless, very clear air.
    ExtraSunny,
    /// Fog at the ground.
    Foggy,
    /// Mild, mixed: some cloud, light haze.
    Neutral,
    /// A closed cloud deck, dry.
    Overcast,
    /// Moderate rain.
    Rain,
    /// Photochemical haze in stagnant air.
    Smog,
    /// Moderate snowfall.
    Snow,
    /// Light snowfall.
    SnowLight,
    /// Thunderstorm: heavy showers, gusts, lightning.
    Thunder,
    /// Snow-covered ground under light snowfall (GTA's Christmas weather).
    Xmas,
}

impl Weather {
    /// All 14, in the paper's (alphabetical) order.
    pub const ALL: [Weather; 14] = [
        Weather::Blizzard,
        Weather::Clear,
        Weather::Clearing,
        Weather::Clouds,
        Weather::ExtraSunny,
        Weather::Foggy,
        Weather::Neutral,
        Weather::Overcast,
        Weather::Rain,
        Weather::Smog,
        Weather::Snow,
        Weather::SnowLight,
        Weather::Thunder,
        Weather::Xmas,
    ];

    /// GTA V's name for it, upper case (`"EXTRASUNNY"`).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Weather::Blizzard => "BLIZZARD",
            Weather::Clear => "CLEAR",
            Weather::Clearing => "CLEARING",
            Weather::Clouds => "CLOUDS",
            Weather::ExtraSunny => "EXTRASUNNY",
            Weather::Foggy => "FOGGY",
            Weather::Neutral => "NEUTRAL",
            Weather::Overcast => "OVERCAST",
            Weather::Rain => "RAIN",
            Weather::Smog => "SMOG",
            Weather::Snow => "SNOW",
            Weather::SnowLight => "SNOWLIGHT",
            Weather::Thunder => "THUNDER",
            Weather::Xmas => "XMAS",
        }
    }

    /// Its physical parameters (a row of [`TABLE`]).
    #[must_use]
    pub fn params(self) -> WeatherParams {
        // TABLE lists the weathers in declaration order (a test checks it).
        let (
            _,
            visibility_m,
            cloud_cover,
            precipitation,
            rate,
            wind,
            ambient,
            direct,
            wet,
            snow,
            lightning,
        ) = TABLE[self as usize];
        WeatherParams {
            visibility_m,
            fog_density_per_m: KOSCHMIEDER_CONSTANT / visibility_m,
            cloud_cover,
            precipitation,
            precipitation_rate_mm_per_h: rate,
            wind_speed_m_per_s: wind,
            ambient_light_scale: ambient,
            direct_light_scale: direct,
            ground_wetness: wet,
            snow_cover: snow,
            lightning,
        }
    }
}

impl fmt::Display for Weather {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Weather {
    type Err = SceneError;

    /// A GTA weather name, in any case (`"rain"`, `"ExtraSunny"`).
    fn from_str(s: &str) -> Result<Weather, SceneError> {
        let s = s.trim();
        Weather::ALL
            .into_iter()
            .find(|w| w.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| SceneError::UnknownWeather {
                name: s.to_owned(),
                valid: Weather::ALL.map(Weather::name).join(", "),
            })
    }
}

impl Serialize for Weather {
    /// As its GTA name.
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for Weather {
    /// From its GTA name, in any case.
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Weather, D::Error> {
        let s = String::deserialize(deserializer)?;
        s.parse().map_err(serde::de::Error::custom)
    }
}

/// What falls from the sky.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Precipitation {
    /// Nothing.
    None,
    /// Rain (liquid).
    Rain,
    /// Snow.
    Snow,
}

/// The physical parameters of a weather, as a renderer uses them.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WeatherParams {
    /// Meteorological visibility, metres (the distance at which a dark object's contrast against
    /// the horizon falls to 2 %).
    pub visibility_m: f64,
    /// Extinction coefficient of the air, per metre: β = 3.912 / `visibility_m` (Koschmieder).
    /// Exponential fog: the fraction of an object's light that reaches an eye `d` metres away is
    /// `exp(−β·d)`; the rest is replaced by the horizon colour.
    pub fog_density_per_m: f64,
    /// Fraction of the sky covered by cloud, [0, 1] (oktas / 8).
    pub cloud_cover: f64,
    /// What falls from the sky.
    pub precipitation: Precipitation,
    /// Precipitation rate, millimetres of liquid water per hour (snow as its melted water
    /// equivalent; 0 when `precipitation` is `None`).
    pub precipitation_rate_mm_per_h: f64,
    /// Mean wind speed at 10 m, metres per second (drives rain/snow slant, cloth, foliage).
    pub wind_speed_m_per_s: f64,
    /// Multiplier on the clear-sky ambient (sky) light at the same sun elevation, [0, 1]: the
    /// daylight level under this weather relative to a clear day. Combine with
    /// [`super::sky::ambient_from_sun`] for the time of day.
    pub ambient_light_scale: f64,
    /// Multiplier on the direct sunlight (and the strength of hard shadows), [0, 1]: about the
    /// chance the sun's disc is free of cloud, times the beam's transmittance through fog or
    /// haze; 0 under a closed cloud deck.
    pub direct_light_scale: f64,
    /// How wet the ground looks, [0, 1] (0 dry, 1 standing water and puddles).
    pub ground_wetness: f64,
    /// Fraction of the ground covered by snow, [0, 1].
    pub snow_cover: f64,
    /// Whether lightning flashes.
    pub lightning: bool,
}

/// Koschmieder's constant: `−ln(0.02)`, the log of the 2 % contrast threshold that defines
/// meteorological visibility, so that β = 3.912 / V.
pub const KOSCHMIEDER_CONSTANT: f64 = 3.912;

/// One row of [`TABLE`]: weather, visibility m, cloud cover, precipitation, rate mm/h,
/// wind m/s, ambient scale, direct scale, ground wetness, snow cover, lightning.
type Row = (
    Weather,
    f64,
    f64,
    Precipitation,
    f64,
    f64,
    f64,
    f64,
    f64,
    f64,
    bool,
);

use Precipitation as P;
use Weather as W;

/// The weather table: one row per weather, columns as in [`WeatherParams`].
///
/// Sources and reasoning for the numbers:
/// - **Visibility** follows the WMO/ICAO categories: fog < 1 km (here 300 m, a dense radiation
///   fog), mist 1–5 km, haze (smog) 2–5 km (here 3 km); clear air ≥ 20 km, very clean air
///   ≥ 50 km. In precipitation, NWS intensity-by-visibility rules for snow: light ≥ 1 km (here
///   2 km), moderate 0.4–1 km (600 m), heavy < 0.4 km; a blizzard (NWS) has visibility
///   < ¼ mile (400 m) and wind ≥ 35 mph (15.6 m/s) — here 150 m and 18 m/s. Moderate rain leaves
///   ~3–5 km (4 km); a thunderstorm downpour ~1–2 km (1.5 km).
/// - **Rates** follow the AMS Glossary: light rain < 2.5 mm/h, moderate 2.5–7.6 mm/h (RAIN:
///   5 mm/h), heavy > 7.6 mm/h (THUNDER: a convective shower, 20 mm/h). Snow as its water
///   equivalent at the usual 10:1 snow-to-liquid ratio: light snowfall < 1 cm/h of snow
///   (SNOWLIGHT 0.8 mm/h, XMAS 0.5 mm/h), moderate ~2.5 cm/h (SNOW 2.5 mm/h), heavy ≥ 5 cm/h
///   (BLIZZARD 5 mm/h).
/// - **Cloud cover** in oktas/8: clear 0–1 okta, partly cloudy ("scattered") 3–4, broken 5–7
///   (CLEARING 0.65), overcast 8 (every precipitating weather).
/// - **Ambient** follows Kasten & Czeplak (1980), global irradiance under cloud cover N relative
///   to clear sky: `1 − 0.75·N^3.4` (N = 0.4 → 0.97, 0.6 → 0.87, 0.65 → 0.83, 1 → 0.25), lowered
///   further for thick precipitating cloud (rain 0.2, snow 0.25, thunderstorm 0.12, blizzard
///   0.15) and for aerosol (smog 0.8); a fog layer scatters a bright grey sky (0.6).
/// - **Direct** sunlight: ≈ 1 − N (the chance the sun's disc is free of cloud), times the beam
///   transmittance `exp(−β·h)` through the fog layer (≈ 100 m deep: exp(−1.3) ≈ 0.27) or the
///   haze (aerosol optical depth ≈ 0.5: 0.6); 0 under an overcast deck.
/// - **Wind**: Beaufort light air to gentle breeze (1–5 m/s) for fair weather; radiation fog
///   and smog form in calm, stagnant air (≤ 1.5 m/s); fresh breeze with rain (6 m/s),
///   gusty thunderstorm outflow (12 m/s), blizzard as above.
/// - **Ground**: wet during and right after rain (CLEARING 0.6), damp with fog (0.3); snow
///   cover grows with snowfall and is complete in XMAS and BLIZZARD.
#[rustfmt::skip]
pub const TABLE: [Row; 14] = [
    //              vis m     cloud precip   mm/h  wind  amb   direct wet  snow lightning
    (W::Blizzard,   150.0,    1.0,  P::Snow, 5.0,  18.0, 0.15, 0.0,   0.2, 1.0, false),
    (W::Clear,      30_000.0, 0.1,  P::None, 0.0,  3.0,  1.0,  0.9,   0.0, 0.0, false),
    (W::Clearing,   15_000.0, 0.65, P::None, 0.0,  5.0,  0.83, 0.35,  0.6, 0.0, false),
    (W::Clouds,     20_000.0, 0.6,  P::None, 0.0,  4.0,  0.87, 0.4,   0.0, 0.0, false),
    (W::ExtraSunny, 50_000.0, 0.0,  P::None, 0.0,  2.0,  1.0,  1.0,   0.0, 0.0, false),
    (W::Foggy,      300.0,    0.3,  P::None, 0.0,  1.5,  0.6,  0.19,  0.3, 0.0, false),
    (W::Neutral,    12_000.0, 0.4,  P::None, 0.0,  3.5,  0.95, 0.6,   0.0, 0.0, false),
    (W::Overcast,   10_000.0, 1.0,  P::None, 0.0,  5.0,  0.25, 0.0,   0.0, 0.0, false),
    (W::Rain,       4_000.0,  1.0,  P::Rain, 5.0,  6.0,  0.2,  0.0,   1.0, 0.0, false),
    (W::Smog,       3_000.0,  0.2,  P::None, 0.0,  1.0,  0.8,  0.48,  0.0, 0.0, false),
    (W::Snow,       600.0,    1.0,  P::Snow, 2.5,  6.0,  0.25, 0.0,   0.3, 0.9, false),
    (W::SnowLight,  2_000.0,  1.0,  P::Snow, 0.8,  3.0,  0.3,  0.0,   0.2, 0.4, false),
    (W::Thunder,    1_500.0,  1.0,  P::Rain, 20.0, 12.0, 0.12, 0.0,   1.0, 0.0, true),
    (W::Xmas,       5_000.0,  0.9,  P::Snow, 0.5,  2.0,  0.48, 0.1,   0.1, 1.0, false),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_in_any_case() {
        for w in Weather::ALL {
            assert_eq!(w.name().parse::<Weather>().unwrap(), w);
            assert_eq!(w.name().to_lowercase().parse::<Weather>().unwrap(), w);
            assert_eq!(w.to_string(), w.name());
            let json = serde_json::to_string(&w).unwrap();
            assert_eq!(json, format!("\"{}\"", w.name()));
            assert_eq!(serde_json::from_str::<Weather>(&json).unwrap(), w);
        }
        assert_eq!(
            " ExtraSunny ".parse::<Weather>().unwrap(),
            Weather::ExtraSunny
        );
    }

    #[test]
    fn unknown_names_error_with_the_valid_list() {
        for bad in ["HALLOWEEN", "", "sunny", "RAINY"] {
            let err = bad.parse::<Weather>().unwrap_err();
            let msg = err.to_string();
            assert!(msg.contains(&format!("`{bad}`")), "{msg}");
            assert!(msg.contains("BLIZZARD") && msg.contains("XMAS"), "{msg}");
        }
    }

    #[test]
    fn the_table_has_each_weather_once_in_order() {
        assert_eq!(TABLE.map(|r| r.0), Weather::ALL);
        let mut names = Weather::ALL.map(Weather::name);
        names.sort_unstable();
        assert_eq!(
            names,
            Weather::ALL.map(Weather::name),
            "ALL is alphabetical"
        );
    }

    #[test]
    fn every_param_is_finite_and_in_range() {
        for w in Weather::ALL {
            let p = w.params();
            let unit = [
                p.cloud_cover,
                p.ambient_light_scale,
                p.direct_light_scale,
                p.ground_wetness,
                p.snow_cover,
            ];
            assert!(unit.iter().all(|x| (0.0..=1.0).contains(x)), "{w}: {p:?}");
            assert!(p.visibility_m.is_finite() && p.visibility_m > 0.0, "{w}");
            assert!(
                p.fog_density_per_m.is_finite() && p.fog_density_per_m > 0.0,
                "{w}"
            );
            assert!(
                (p.fog_density_per_m * p.visibility_m - 3.912).abs() < 1e-9,
                "{w}"
            );
            assert!(
                (0.0..=100.0).contains(&p.precipitation_rate_mm_per_h),
                "{w}"
            );
            assert!((0.0..=40.0).contains(&p.wind_speed_m_per_s), "{w}");
            assert_eq!(
                p.precipitation == Precipitation::None,
                p.precipitation_rate_mm_per_h == 0.0,
                "{w}: a rate iff something falls"
            );
        }
    }

    #[test]
    fn the_table_matches_the_meteorology_it_cites() {
        let b = Weather::Blizzard.params();
        assert!(b.visibility_m < 200.0 && b.wind_speed_m_per_s > 15.0);
        let fog = Weather::Foggy.params().visibility_m;
        assert!((200.0..=500.0).contains(&fog));
        let smog = Weather::Smog.params().visibility_m;
        assert!((2_000.0..=5_000.0).contains(&smog));
        for w in [Weather::Clear, Weather::ExtraSunny] {
            assert!(w.params().visibility_m >= 20_000.0);
        }
        let rain = Weather::Rain.params();
        assert_eq!(rain.precipitation, Precipitation::Rain);
        assert!((2.5..=7.6).contains(&rain.precipitation_rate_mm_per_h));
        let x = Weather::Xmas.params();
        assert_eq!(x.precipitation, Precipitation::Snow);
        assert!(x.snow_cover == 1.0 && x.precipitation_rate_mm_per_h < 1.0);
        let c = Weather::Clearing.params();
        assert!(c.ground_wetness > 0.3 && (0.5..0.9).contains(&c.cloud_cover));
        assert_eq!(c.precipitation, Precipitation::None);
        assert!(Weather::Thunder.params().lightning);
        assert_eq!(
            Weather::ALL.iter().filter(|w| w.params().lightning).count(),
            1
        );
    }
}
