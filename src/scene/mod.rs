//! Scene customization: every animation is shown in seeded random scenes — weather, time of
//! day, location and character — so a dataset sees each action under many conditions.
//!
//! This is the paper's *scene customization* (environment, character and map).
//! Its published scripts step through the weathers, times and peds *in order* on key presses
//! (with an off-by-one that applies `nil`), so consecutive clips are correlated and a run is
//! not reproducible from a seed. Here every choice is an independent draw from explicit
//! weights, made with the caller's seeded RNG (ChaCha8 in practice): the same seed gives the
//! same scenes on every machine, and nothing here seeds itself or keeps global state.
//!
//! - [`weather`]: the 14 weathers and their physical parameters (visibility, fog, cloud,
//!   precipitation, wind, light, wet/snowy ground).
//! - [`sky`]: clock times (the paper's dawn/noon/evening/midnight or any `HH:MM`), the sun's
//!   position and the daylight factor.
//! - [`location`]: floors, backdrops and props, filtered by what an action needs.
//! - [`cast`]: a population model of ages, sexes, heights, proportions, skin, hair, clothes.
//!
//! [`SceneConfig`] bundles the distributions (as a dataset spec section, TOML) and
//! [`SceneConfig::draw`] makes one [`Scene`]. Conventions: metres, degrees only where the name
//! says `_deg`; location frame x east, y north, z up with the character at the origin; sun
//! azimuth clockwise from north; colours sRGB in [0, 1].

pub mod body_mesh;
pub mod cast;
pub mod color;
pub mod environment;
pub mod fast_float;
pub mod location;
pub mod sky;
pub mod weather;

use std::collections::BTreeMap;

use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};
use thiserror::Error;

use self::cast::{Look, Population};
use self::location::{Location, LocationInstance};
use self::sky::{ClockTime, SunPosition, ambient_from_sun, sun_position};
use self::weather::{Weather, WeatherParams};

/// What can be wrong with a scene description.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SceneError {
    /// A weight list is empty.
    #[error("{field}: no weights given")]
    NoWeights {
        /// Which weights.
        field: String,
    },
    /// A weight is negative, NaN or infinite.
    #[error("{field}: weight #{index} is {value}; weights must be finite and ≥ 0")]
    BadWeight {
        /// Which weights.
        field: String,
        /// Its position in the list (0-based).
        index: usize,
        /// The bad value.
        value: f64,
    },
    /// Every weight is zero.
    #[error("{field}: all {count} weights are 0; at least one must be positive")]
    AllZeroWeights {
        /// Which weights.
        field: String,
        /// How many there are.
        count: usize,
    },
    /// The weights are finite but their sum is not.
    #[error("{field}: the weights sum to infinity; scale them down")]
    WeightSumOverflow {
        /// Which weights.
        field: String,
    },
    /// A weather name that is not one of the 14.
    #[error("unknown weather `{name}`; valid names: {valid}")]
    UnknownWeather {
        /// The name given.
        name: String,
        /// The valid names, comma-separated.
        valid: String,
    },
    /// A clock time that does not parse or is out of range.
    #[error("bad clock time `{text}`: {reason}")]
    BadClock {
        /// The text given.
        text: String,
        /// What is wrong.
        reason: &'static str,
    },
    /// A location description that makes no sense.
    #[error("location `{name}`: {problem}")]
    BadLocation {
        /// The location's name.
        name: String,
        /// What is wrong.
        problem: String,
    },
    /// No location meets an action's requirements.
    #[error("none of the {pool} locations suits the requirements [{requirements}]")]
    NoSuitableLocation {
        /// The requirements, comma-separated.
        requirements: String,
        /// How many locations there were.
        pool: usize,
    },
    /// A number outside its allowed range.
    #[error("{field} = {value}: must be {allowed}")]
    OutOfRange {
        /// Which field.
        field: &'static str,
        /// The bad value.
        value: f64,
        /// The allowed range, in words.
        allowed: &'static str,
    },
}

impl SceneError {
    /// The same error about the weights named `field`.
    #[must_use]
    pub fn in_field(self, name: &str) -> SceneError {
        match self {
            SceneError::NoWeights { .. } => SceneError::NoWeights { field: name.into() },
            SceneError::BadWeight { index, value, .. } => SceneError::BadWeight {
                field: name.into(),
                index,
                value,
            },
            SceneError::AllZeroWeights { count, .. } => SceneError::AllZeroWeights {
                field: name.into(),
                count,
            },
            SceneError::WeightSumOverflow { .. } => {
                SceneError::WeightSumOverflow { field: name.into() }
            }
            other => other,
        }
    }
}

/// Checks weights (non-empty, finite, ≥ 0, not all 0, finite sum) and returns their sum.
///
/// # Errors
/// The [`SceneError`] weight variant naming the problem (field `weights`).
pub fn check_weights(weights: &[f64]) -> Result<f64, SceneError> {
    let field = || "weights".to_owned();
    if weights.is_empty() {
        return Err(SceneError::NoWeights { field: field() });
    }
    if let Some((index, &value)) = weights
        .iter()
        .enumerate()
        .find(|(_, w)| !(w.is_finite() && **w >= 0.0))
    {
        return Err(SceneError::BadWeight {
            field: field(),
            index,
            value,
        });
    }
    let total: f64 = weights.iter().sum();
    if total == 0.0 {
        return Err(SceneError::AllZeroWeights {
            field: field(),
            count: weights.len(),
        });
    }
    if !total.is_finite() {
        return Err(SceneError::WeightSumOverflow { field: field() });
    }
    Ok(total)
}

/// Draws an index with probability proportional to its weight (one uniform draw from `rng`;
/// a zero weight is never drawn).
///
/// # Errors
/// As [`check_weights`].
pub fn weighted_index(rng: &mut (impl Rng + ?Sized), weights: &[f64]) -> Result<usize, SceneError> {
    let total = check_weights(weights)?;
    let mut x = rng.random_range(0.0..total);
    for (i, &w) in weights.iter().enumerate() {
        if w > 0.0 {
            if x < w {
                return Ok(i);
            }
            x -= w;
        }
    }
    // Only rounding in the running subtraction gets here: the last positive weight.
    Ok(weights.iter().rposition(|&w| w > 0.0).unwrap_or(0))
}

/// Draws one of `choices` with probability proportional to its weight.
///
/// # Errors
/// As [`check_weights`].
pub fn weighted_choice<T: Copy>(
    rng: &mut (impl Rng + ?Sized),
    choices: &[(T, f64)],
) -> Result<T, SceneError> {
    let weights: Vec<f64> = choices.iter().map(|c| c.1).collect();
    Ok(choices[weighted_index(rng, &weights)?].0)
}

/// A standard normal draw (Box–Muller, two uniforms per draw).
pub(crate) fn standard_normal(rng: &mut (impl Rng + ?Sized)) -> f64 {
    let u1 = 1.0 - rng.random::<f64>(); // (0, 1]: ln is finite
    let u2 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// One drawn scene: everything a renderer needs to set the stage, and what the dataset logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    /// The weather.
    pub weather: Weather,
    /// Its physical parameters.
    pub weather_params: WeatherParams,
    /// The clock time (local mean solar time).
    pub clock: ClockTime,
    /// Where the sun stands then.
    pub sun: SunPosition,
    /// The location and its placed props.
    pub location: LocationInstance,
    /// The character's appearance.
    pub look: Look,
}

impl Scene {
    /// The sky's ambient light relative to a clear day at full daylight, [0, 1]: the time of
    /// day's [`ambient_from_sun`] times the weather's `ambient_light_scale`.
    #[must_use]
    pub fn ambient_light_scale(&self) -> f64 {
        ambient_from_sun(self.sun.elevation_deg) * self.weather_params.ambient_light_scale
    }
}

/// The distributions scenes are drawn from: a dataset spec's `[scene]` section.
///
/// Every field is optional in TOML and a given field replaces its default whole:
/// ```toml
/// [scene]
/// weather_weights = { CLEAR = 3, RAIN = 1, FOGGY = 0.5 }   # unlisted weathers never occur
/// clock_weights = { dawn = 1, noon = 2, "17:45" = 1 }      # presets or HH:MM
/// latitude_deg = 34.0
/// day_of_year = 172
/// clear_radius_m = 2.5
/// population = { age_weights = [0.2, 0.6, 0.2], female_fraction = 0.5 }
/// # [[scene.locations]] ... replaces the built-in pool (see `location`)
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SceneConfig {
    /// Weather → relative weight (GTA names, any case). Default: the 14 alike.
    pub weather_weights: BTreeMap<Weather, f64>,
    /// Clock time → relative weight. Default: the paper's four presets alike.
    pub clock_weights: BTreeMap<ClockTime, f64>,
    /// Latitude for the sun, degrees north. Default 34.0 (Los Santos is Los Angeles, 34.05° N).
    pub latitude_deg: f64,
    /// Day of the year for the sun, 1–366. Default 172 (21 June: GTA's long summer days, when
    /// 05:30 is just after sunrise and 20:00 in the dusk).
    pub day_of_year: u16,
    /// The locations to choose among (uniformly, among those that suit the action). Default:
    /// [`Location::builtin_pool`].
    pub locations: Vec<Location>,
    /// Who the characters are.
    pub population: Population,
    /// Radius kept free of props around the character, metres. Default 2.5 (arm span plus a
    /// step, so props do not intrude on most actions).
    pub clear_radius_m: f64,
}

impl Default for SceneConfig {
    fn default() -> SceneConfig {
        SceneConfig {
            weather_weights: Weather::ALL.into_iter().map(|w| (w, 1.0)).collect(),
            clock_weights: ClockTime::PRESETS
                .into_iter()
                .map(|(_, t)| (t, 1.0))
                .collect(),
            latitude_deg: 34.0,
            day_of_year: 172,
            locations: Location::builtin_pool(),
            population: Population::default(),
            clear_radius_m: 2.5,
        }
    }
}

impl SceneConfig {
    /// The scene of `weather` at `clock` in `location` with `look`, the sun placed for this
    /// configuration's latitude and day of the year.
    #[must_use]
    pub fn scene(
        &self,
        weather: Weather,
        clock: ClockTime,
        location: LocationInstance,
        look: Look,
    ) -> Scene {
        Scene {
            weather,
            weather_params: weather.params(),
            clock,
            sun: sun_position(clock, self.latitude_deg, self.day_of_year),
            location,
            look,
        }
    }

    /// Checks every field.
    ///
    /// # Errors
    /// The first problem found, naming the field and value.
    pub fn validate(&self) -> Result<(), SceneError> {
        let weights = |m: Vec<f64>, field: &str| check_weights(&m).map_err(|e| e.in_field(field));
        weights(
            self.weather_weights.values().copied().collect(),
            "weather_weights",
        )?;
        weights(
            self.clock_weights.values().copied().collect(),
            "clock_weights",
        )?;
        if !(-90.0..=90.0).contains(&self.latitude_deg) {
            return Err(SceneError::OutOfRange {
                field: "latitude_deg",
                value: self.latitude_deg,
                allowed: "in [-90, 90]",
            });
        }
        if !(1..=366).contains(&self.day_of_year) {
            return Err(SceneError::OutOfRange {
                field: "day_of_year",
                value: f64::from(self.day_of_year),
                allowed: "in 1..=366",
            });
        }
        if !(self.clear_radius_m.is_finite() && self.clear_radius_m >= 0.0) {
            return Err(SceneError::OutOfRange {
                field: "clear_radius_m",
                value: self.clear_radius_m,
                allowed: "finite and ≥ 0",
            });
        }
        for l in &self.locations {
            l.validate()?;
        }
        self.population.validate()
    }

    /// Draws one scene for an action that needs `requirements` (see [`Location::suits`]).
    /// The draws, in this order: weather, clock, location, its props, the character.
    ///
    /// # Errors
    /// As [`SceneConfig::validate`], or [`SceneError::NoSuitableLocation`].
    pub fn draw(
        &self,
        rng: &mut (impl Rng + ?Sized),
        requirements: &[String],
    ) -> Result<Scene, SceneError> {
        self.validate()?;
        let weathers: Vec<(Weather, f64)> =
            self.weather_weights.iter().map(|(&w, &p)| (w, p)).collect();
        let weather = weighted_choice(rng, &weathers)?;
        let clocks: Vec<(ClockTime, f64)> =
            self.clock_weights.iter().map(|(&c, &p)| (c, p)).collect();
        let clock = weighted_choice(rng, &clocks)?;
        let suitable: Vec<&Location> = self
            .locations
            .iter()
            .filter(|l| l.suits(requirements))
            .collect();
        if suitable.is_empty() {
            return Err(SceneError::NoSuitableLocation {
                requirements: requirements.join(", "),
                pool: self.locations.len(),
            });
        }
        let place = suitable[rng.random_range(0..suitable.len())];
        let location = place.draw(rng, self.clear_radius_m);
        let look = self.population.draw(rng)?;
        Ok(self.scene(weather, clock, location, look))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    /// A scene for tests: `weather` at `clock` in the open field, a drawn adult.
    pub(crate) fn test_scene(
        weather: crate::scene::weather::Weather,
        clock: crate::scene::sky::ClockTime,
    ) -> Scene {
        use rand::SeedableRng;
        let config = crate::scene::SceneConfig {
            weather_weights: [(weather, 1.0)].into_iter().collect(),
            clock_weights: [(clock, 1.0)].into_iter().collect(),
            locations: crate::scene::location::Location::builtin_pool()
                .into_iter()
                .filter(|l| l.name == "open_field")
                .collect(),
            ..crate::scene::SceneConfig::default()
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        config.draw(&mut rng, &[]).expect("a valid config draws")
    }

    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Pearson's χ² of the counts of `seq` (values `0..weights.len()`) against the
    /// probabilities the weights give; df = categories − 1.
    pub(crate) fn chi_square_fit(seq: &[usize], weights: &[f64]) -> f64 {
        let total: f64 = weights.iter().sum();
        let mut counts = vec![0.0; weights.len()];
        for &s in seq {
            counts[s] += 1.0;
        }
        let n = seq.len() as f64;
        counts
            .iter()
            .zip(weights)
            .map(|(&o, &w)| {
                let e = n * w / total;
                (o - e) * (o - e) / e
            })
            .sum()
    }

    /// Pearson's χ² of independence on the `k × k` table of consecutive pairs
    /// (previous draw → next draw); df = (k − 1)². A sequence that cycles fails it.
    pub(crate) fn chi_square_transitions(seq: &[usize], k: usize) -> f64 {
        let mut table = vec![vec![0.0; k]; k];
        for pair in seq.windows(2) {
            table[pair[0]][pair[1]] += 1.0;
        }
        let n: f64 = table.iter().flatten().sum();
        let rows: Vec<f64> = table.iter().map(|r| r.iter().sum()).collect();
        let cols: Vec<f64> = (0..k).map(|j| table.iter().map(|r| r[j]).sum()).collect();
        let mut chi = 0.0;
        for i in 0..k {
            for j in 0..k {
                let e = rows[i] * cols[j] / n;
                if e > 0.0 {
                    chi += (table[i][j] - e) * (table[i][j] - e) / e;
                }
            }
        }
        chi
    }

    // χ² critical values at p = 0.001 (upper tail), for the degrees of freedom used here.
    const CHI2_DF3: f64 = 16.266;
    const CHI2_DF9: f64 = 27.877;
    const CHI2_DF13: f64 = 34.528;
    const CHI2_DF169: f64 = 231.552;

    /// Non-uniform weather weights with every transition cell expecting ≥ 12 of 9,999 pairs,
    /// so the 14 × 14 independence test is valid.
    const WEATHER_WEIGHTS: [f64; 14] = [
        3.0, 1.0, 2.0, 1.0, 3.0, 2.0, 1.0, 2.0, 3.0, 1.0, 2.0, 3.0, 1.0, 2.0,
    ];

    #[test]
    fn weather_draws_follow_the_weights_and_do_not_cycle() {
        let choices: Vec<(Weather, f64)> = Weather::ALL.into_iter().zip(WEATHER_WEIGHTS).collect();
        let mut rng = ChaCha8Rng::seed_from_u64(42);
        let seq: Vec<usize> = (0..10_000)
            .map(|_| weighted_choice(&mut rng, &choices).unwrap() as usize)
            .collect();
        let fit = chi_square_fit(&seq, &WEATHER_WEIGHTS);
        let indep = chi_square_transitions(&seq, 14);
        assert!(fit < CHI2_DF13, "goodness of fit χ² = {fit}");
        assert!(indep < CHI2_DF169, "transition independence χ² = {indep}");
    }

    #[test]
    fn the_reference_codes_cycling_fails_the_independence_test() {
        // The paper's scripts step EXTRASUNNY → CLEAR → … in order: each draw fixes the next.
        let cycled: Vec<usize> = (0..10_000).map(|i| i % 14).collect();
        assert!(chi_square_transitions(&cycled, 14) > 100.0 * CHI2_DF169);
        // Cycling even passes the goodness-of-fit test for equal weights: only the
        // transitions reveal it.
        assert!(chi_square_fit(&cycled, &[1.0; 14]) < CHI2_DF13);
    }

    #[test]
    fn clock_presets_follow_the_weights_and_do_not_cycle() {
        let weights = [1.0, 3.0, 2.0, 1.5];
        let choices: Vec<(ClockTime, f64)> = ClockTime::PRESETS
            .iter()
            .zip(weights)
            .map(|(&(_, t), w)| (t, w))
            .collect();
        let mut rng = ChaCha8Rng::seed_from_u64(1234);
        let seq: Vec<usize> = (0..10_000)
            .map(|_| {
                let t = weighted_choice(&mut rng, &choices).unwrap();
                choices.iter().position(|c| c.0 == t).unwrap()
            })
            .collect();
        let fit = chi_square_fit(&seq, &weights);
        let indep = chi_square_transitions(&seq, 4);
        assert!(fit < CHI2_DF3, "goodness of fit χ² = {fit}");
        assert!(indep < CHI2_DF9, "transition independence χ² = {indep}");
    }

    #[test]
    fn weighted_index_never_draws_a_zero_weight_and_validates() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let w = [0.0, 2.0, 0.0, 1.0, 0.0];
        for _ in 0..2_000 {
            let i = weighted_index(&mut rng, &w).unwrap();
            assert!(i == 1 || i == 3);
        }
        assert_eq!(weighted_index(&mut rng, &[0.0, 5.0]).unwrap(), 1);
        let mut err = |w: &[f64]| weighted_index(&mut rng, w).unwrap_err();
        assert!(matches!(err(&[]), SceneError::NoWeights { .. }));
        assert!(matches!(
            err(&[0.0, 0.0]),
            SceneError::AllZeroWeights { count: 2, .. }
        ));
        let msg = err(&[1.0, -2.0]).to_string();
        assert!(msg.contains("#1") && msg.contains("-2"), "{msg}");
        assert!(matches!(
            err(&[1.0, f64::NAN]),
            SceneError::BadWeight { index: 1, .. }
        ));
        assert!(matches!(
            err(&[f64::INFINITY]),
            SceneError::BadWeight { index: 0, .. }
        ));
        assert!(matches!(
            err(&[f64::MAX, f64::MAX]),
            SceneError::WeightSumOverflow { .. }
        ));
        let named = err(&[]).in_field("weather_weights").to_string();
        assert!(named.starts_with("weather_weights:"), "{named}");
    }

    #[test]
    fn standard_normal_has_mean_0_and_variance_1() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let x: Vec<f64> = (0..40_000).map(|_| standard_normal(&mut rng)).collect();
        let n = x.len() as f64;
        let mean = x.iter().sum::<f64>() / n;
        let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / n;
        // Standard errors: 0.005 for the mean, 0.007 for the variance.
        assert!(
            mean.abs() < 0.025 && (var - 1.0).abs() < 0.035,
            "{mean} {var}"
        );
        assert!(x.iter().all(|v| v.is_finite()));
    }

    #[test]
    fn scenes_are_deterministic_per_seed() {
        let config = SceneConfig::default();
        let draw = |seed| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            (0..20)
                .map(|_| config.draw(&mut rng, &[]).unwrap())
                .collect::<Vec<_>>()
        };
        let a = draw(99);
        assert_eq!(a, draw(99));
        assert_ne!(a, draw(100));
        let json = serde_json::to_string(&a[0]).unwrap();
        assert_eq!(json, serde_json::to_string(&draw(99)[0]).unwrap());
        for key in [
            "\"weather\"",
            "\"fog_density_per_m\"",
            "\"clock\"",
            "\"azimuth_deg\"",
        ] {
            assert!(json.contains(key), "{json}");
        }
        for s in &a {
            let amb = s.ambient_light_scale();
            assert!((0.0..=1.0).contains(&amb));
            assert_eq!(s.weather_params, s.weather.params());
        }
    }

    #[test]
    fn requirements_pick_suitable_locations_or_error() {
        let config = SceneConfig::default();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let water = vec!["water".to_owned()];
        for _ in 0..50 {
            let s = config.draw(&mut rng, &water).unwrap();
            assert!(s.location.has_water, "{}", s.location.name);
        }
        let impossible = vec!["indoor".to_owned(), "water".to_owned()];
        let msg = config.draw(&mut rng, &impossible).unwrap_err().to_string();
        assert!(
            msg.contains("indoor, water") && msg.contains("10 locations"),
            "{msg}"
        );
    }

    #[test]
    fn config_parses_from_toml_and_names_bad_fields() {
        let text = r#"
            weather_weights = { clear = 3, RAIN = 1, FOGGY = 0.5 }
            clock_weights = { dawn = 1, noon = 2, "17:45" = 1 }
            latitude_deg = 51.5
            population = { age_weights = [0.2, 0.6, 0.2] }
        "#;
        let c: SceneConfig = toml::from_str(text).unwrap();
        c.validate().unwrap();
        assert_eq!(c.weather_weights.len(), 3);
        assert_eq!(c.weather_weights[&Weather::Clear], 3.0);
        assert_eq!(c.clock_weights[&"17:45".parse().unwrap()], 1.0);
        assert_eq!(c.population.female_fraction, 0.5);
        assert_eq!(c.locations.len(), Location::builtin_pool().len());
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        for _ in 0..100 {
            let s = c.draw(&mut rng, &[]).unwrap();
            assert!(c.weather_weights.contains_key(&s.weather));
        }
        // The default round-trips through TOML.
        let d = SceneConfig::default();
        assert_eq!(
            toml::from_str::<SceneConfig>(&toml::to_string(&d).unwrap()).unwrap(),
            d
        );

        let err = toml::from_str::<SceneConfig>("weather_weights = { HALLOWEEN = 1 }")
            .unwrap_err()
            .to_string();
        assert!(err.contains("HALLOWEEN") && err.contains("XMAS"), "{err}");
        let c: SceneConfig = toml::from_str("clock_weights = { noon = 0 }").unwrap();
        let err = c.validate().unwrap_err().to_string();
        assert!(err.contains("clock_weights"), "{err}");
        let c: SceneConfig = toml::from_str("latitude_deg = 95.0").unwrap();
        assert!(
            c.validate()
                .unwrap_err()
                .to_string()
                .contains("latitude_deg = 95")
        );
    }
}
