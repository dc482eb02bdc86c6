//! Characters: a population model from which each scene draws who performs the action — age,
//! sex, height, body proportions, build, skin, hair and clothes.
//!
//! The paper swaps among a handful of GTA peds (six active, no outfit changes) to show "actions
//! by individuals in diverse ages, genders and professions". Here every scene draws a fresh
//! [`Look`] from a [`Population`], and [`Look::character`] turns it into a
//! [`Character`] for the rig, so the same rotations play on a 6-year-old or an 80-year-old.
//!
//! The model, draw by draw (this order is part of the seed contract):
//! 1. **Age group** by `age_weights` — child 6–12, adult 18–64, older 65–85 years — then the
//!    age uniform over the group's whole years, then the sex (female with `female_fraction`).
//! 2. **Height**, normal by group, age and sex ([`height_model_cm`]), clamped to ±3 SD.
//! 3. **Proportions**: leg, arm, torso and head scales, each the group's mean
//!    ([`part_scale_means`]) times N(1, 0.03) clamped to ±3 SD; [`Look::character`] then scales
//!    the whole body so its rest stature equals the drawn height.
//! 4. **Build** as body-mass index, kg/m² ([`bmi_model`]): a renderer can widen limbs and torso
//!    by [`Look::girth_scale`].
//! 5. **Skin**, one of the ten Monk Skin Tone anchors by `skin_tone_weights`, with jitter.
//! 6. **Hair**, pigmented or grey by age, with jitter.
//! 7. **Clothes**: top, bottom and shoes from garment palettes, with jitter.
//!
//! Colours are sRGB (gamma-encoded) in [0, 1], as `[r, g, b]` `f32`; a renderer linearises them
//! before lighting.

use rand::{Rng, RngExt};
use serde::{Deserialize, Serialize};

use super::{SceneError, check_weights, standard_normal, weighted_index};
use crate::skeleton::character::{Character, Proportions};
use crate::skeleton::rig::Rig;

/// An age group.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AgeGroup {
    /// 6–12 years.
    Child,
    /// 18–64 years.
    Adult,
    /// 65–85 years.
    Older,
}

impl AgeGroup {
    /// The groups, in the order of [`Population::age_weights`].
    pub const ALL: [AgeGroup; 3] = [AgeGroup::Child, AgeGroup::Adult, AgeGroup::Older];

    /// Youngest and oldest age in the group, whole years, inclusive.
    #[must_use]
    pub fn age_range_years(self) -> [u8; 2] {
        match self {
            AgeGroup::Child => [6, 12],
            AgeGroup::Adult => [18, 64],
            AgeGroup::Older => [65, 85],
        }
    }
}

/// Sex (drives the adult height and build distributions).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sex {
    /// Female.
    Female,
    /// Male.
    Male,
}

/// Who the characters are: the proportions of each group in the drawn cast.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Population {
    /// Relative weights of child (6–12), adult (18–64) and older (65–85) characters.
    pub age_weights: [f64; 3],
    /// Probability a character is female, [0, 1].
    pub female_fraction: f64,
    /// Relative weights of the ten Monk Skin Tone anchors, lightest (1) to darkest (10).
    pub skin_tone_weights: [f64; 10],
}

impl Default for Population {
    /// Mostly adults (child 0.15, adult 0.7, older 0.15), half female, every skin tone alike.
    fn default() -> Population {
        Population {
            age_weights: [0.15, 0.7, 0.15],
            female_fraction: 0.5,
            skin_tone_weights: [1.0; 10],
        }
    }
}

/// Clothing colours, sRGB in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Clothing {
    /// Shirt, jacket or dress.
    pub top_rgb: [f32; 3],
    /// Trousers, shorts or skirt.
    pub bottom_rgb: [f32; 3],
    /// Shoes.
    pub shoes_rgb: [f32; 3],
}

/// One drawn character's appearance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Look {
    /// Age group.
    pub age_group: AgeGroup,
    /// Sex.
    pub sex: Sex,
    /// Age, whole years.
    pub age_years: u8,
    /// Standing height, ground to the top of the head, metres.
    pub height_m: f64,
    /// Height and the leg/arm/torso scales (relative to the rig's adult).
    pub proportions: Proportions,
    /// Scale of the head relative to the rig's adult (before the stature is normalised).
    pub head_scale: f64,
    /// Body-mass index, kg/m².
    pub bmi_kg_per_m2: f64,
    /// Which Monk Skin Tone anchor the skin came from, 1 (lightest) to 10 (darkest).
    pub skin_tone: u8,
    /// Skin colour, sRGB.
    pub skin_rgb: [f32; 3],
    /// Hair colour, sRGB.
    pub hair_rgb: [f32; 3],
    /// Clothing colours.
    pub clothing: Clothing,
}

/// Body-mass index the rig's default figure stands for, kg/m² (a lean adult).
pub const REFERENCE_BMI_KG_PER_M2: f64 = 22.0;

impl Look {
    /// The body on `rig`: the proportions' part scales and the head scale, then the whole body
    /// scaled so that its rest stature (ground to the `head_top` landmark) is `height_m`.
    #[must_use]
    pub fn character(&self, rig: &Rig) -> Character {
        let mut scales = Character::with_proportions(rig, self.proportions).bone_scale;
        if let Some(head) = rig.bone_index("head") {
            scales[head] *= self.head_scale;
        }
        let body = Character::from_scales(rig, scales);
        let Some(top) = rig.landmark_index("head_top") else {
            return body;
        };
        let stature_m = body.landmark_from_root_m(rig, top).z;
        if !(stature_m.is_finite() && stature_m > 0.0) {
            return body;
        }
        let k = self.height_m / stature_m;
        Character::from_scales(rig, body.bone_scale.iter().map(|s| s * k).collect())
    }

    /// Girth factor relative to the rig's figure: at a fixed height, body mass ∝ BMI and
    /// cross-sections ∝ mass, so widths scale as √(BMI / 22).
    #[must_use]
    pub fn girth_scale(&self) -> f64 {
        (self.bmi_kg_per_m2 / REFERENCE_BMI_KG_PER_M2).sqrt()
    }
}

/// Mean and standard deviation of standing height, cm, for a group, sex and age.
///
/// - Children 6–12: the CDC 2000 growth charts' medians, averaged over sexes (boys and girls
///   differ by ≈ 1 cm at these ages), grow about linearly from 115.4 cm at 6 y to 150.2 cm at
///   12 y; the SD widens from ≈ 4.9 to ≈ 7 cm.
/// - Adults: women 162 ± 7 cm, men 175 ± 7 cm (NHANES 2015–2018: 161.7 and 175.4 cm).
/// - Older adults: the adult mean minus 3 cm at 65 and a further 0.15 cm per year (NHANES:
///   ≈ 3 cm shorter over 60, ≈ 6 cm over 80, from cohort and spinal compression), same SD.
#[must_use]
pub fn height_model_cm(group: AgeGroup, sex: Sex, age_years: u8) -> (f64, f64) {
    let age = f64::from(age_years);
    let adult = match sex {
        Sex::Female => 162.0,
        Sex::Male => 175.0,
    };
    match group {
        AgeGroup::Child => (115.4 + 5.8 * (age - 6.0), 4.9 + 0.35 * (age - 6.0)),
        AgeGroup::Adult => (adult, 7.0),
        AgeGroup::Older => (adult - 3.0 - 0.15 * (age - 65.0), 7.0),
    }
}

/// Mean `[leg, arm, torso, head]` scales for a group and age, relative to an adult of the same
/// height (the stature is normalised afterwards).
///
/// - Children: the sitting-height ratio (sitting height / stature) falls from ≈ 0.555 at 6 y
///   to ≈ 0.525 at 12 y and ≈ 0.52 in adults (Fredriks et al. 2005), so the legs are ≈ 0.92
///   of the adult share at 6 and ≈ 0.98 at 12; the head is ≈ 1/6 of stature at 6 against
///   ≈ 1/7.5 in adults (head 1.25 → 1.08); arms a little short (0.95 → 0.98). Linear in age.
/// - Adults: 1.
/// - Older adults: a trunk ≈ 3 % shorter (disc compression, kyphosis).
#[must_use]
pub fn part_scale_means(group: AgeGroup, age_years: u8) -> [f64; 4] {
    match group {
        AgeGroup::Child => {
            let t = ((f64::from(age_years) - 6.0) / 6.0).clamp(0.0, 1.0);
            let lerp = |a: f64, b: f64| a + (b - a) * t;
            [lerp(0.92, 0.98), lerp(0.95, 0.98), 1.0, lerp(1.25, 1.08)]
        }
        AgeGroup::Adult => [1.0; 4],
        AgeGroup::Older => [1.0, 1.0, 0.97, 1.0],
    }
}

/// Relative SD of each part scale around its mean.
pub const PART_SCALE_SD: f64 = 0.03;

/// Mean, SD and bounds `[min, max]` of the body-mass index, kg/m², for a group and age.
///
/// - Children: the CDC 2000 BMI-for-age medians rise from ≈ 15.3 at 6 y to ≈ 18 at 12 y;
///   SD 2; bounds 13–25.
/// - Adults: the world mean is ≈ 25 (NCD-RisC), SD 4.5; bounds 17–40.
/// - Older adults: 26 ± 4; bounds 17–38.
#[must_use]
pub fn bmi_model(group: AgeGroup, age_years: u8) -> (f64, f64, [f64; 2]) {
    match group {
        AgeGroup::Child => (
            15.3 + 0.45 * (f64::from(age_years) - 6.0),
            2.0,
            [13.0, 25.0],
        ),
        AgeGroup::Adult => (25.0, 4.5, [17.0, 40.0]),
        AgeGroup::Older => (26.0, 4.0, [17.0, 38.0]),
    }
}

/// The ten Monk Skin Tone scale anchors (Monk 2019, published by Google in 2022), sRGB from
/// their hex codes `#f6ede4 … #292420`, lightest to darkest.
pub const MONK_SKIN_TONES: [[u8; 3]; 10] = [
    [0xf6, 0xed, 0xe4],
    [0xf3, 0xe7, 0xdb],
    [0xf7, 0xea, 0xd0],
    [0xea, 0xda, 0xba],
    [0xd7, 0xbd, 0x96],
    [0xa0, 0x7e, 0x56],
    [0x82, 0x5c, 0x43],
    [0x60, 0x41, 0x34],
    [0x3a, 0x31, 0x2a],
    [0x29, 0x24, 0x20],
];

/// Natural hair colours, sRGB 0–255: black, dark brown, brown, light brown, blond, auburn.
const HAIR_PIGMENTED: [[u8; 3]; 6] = [
    [0x1a, 0x16, 0x14],
    [0x3d, 0x29, 0x1c],
    [0x6b, 0x4a, 0x30],
    [0x99, 0x73, 0x4d],
    [0xd8, 0xb8, 0x7a],
    [0x8c, 0x40, 0x1f],
];
/// Weights of [`HAIR_PIGMENTED`] for skin tones 1–4 (mixed, mostly dark) and 5–10 (black and
/// dark brown dominate).
const HAIR_WEIGHTS_LIGHT_SKIN: [f64; 6] = [0.25, 0.3, 0.2, 0.1, 0.1, 0.05];
const HAIR_WEIGHTS_DARK_SKIN: [f64; 6] = [0.7, 0.3, 0.0, 0.0, 0.0, 0.0];
/// Grey and white hair, sRGB 0–255.
const HAIR_GREY: [[u8; 3]; 2] = [[0x9e, 0x9e, 0x99], [0xe0, 0xde, 0xd6]];

/// Probability of grey hair at an age: none before 30, then rising by 2 % a year to 90 %.
#[must_use]
pub fn grey_hair_probability(age_years: u8) -> f64 {
    ((f64::from(age_years) - 30.0) * 0.02).clamp(0.0, 0.9)
}

/// Garment colours for tops, sRGB 0–255: navy, black, white, heather grey, charcoal, denim,
/// khaki, olive, burgundy, red, forest green, beige, mustard, sky blue, pink, brown.
const TOPS: [[u8; 3]; 16] = [
    [0x1f, 0x29, 0x4a],
    [0x14, 0x14, 0x17],
    [0xeb, 0xeb, 0xe6],
    [0x8c, 0x8c, 0x8f],
    [0x40, 0x40, 0x45],
    [0x40, 0x59, 0x85],
    [0xc2, 0xb0, 0x80],
    [0x6b, 0x6e, 0x3d],
    [0x73, 0x1a, 0x2b],
    [0xbf, 0x1f, 0x24],
    [0x21, 0x54, 0x33],
    [0xdb, 0xcc, 0xad],
    [0xd4, 0xa6, 0x2e],
    [0x87, 0xb8, 0xe0],
    [0xed, 0x9e, 0xb3],
    [0x66, 0x42, 0x26],
];
/// Bottoms draw from the sober part of [`TOPS`] (indices): navy, black, heather grey,
/// charcoal, denim, khaki, olive, beige, brown.
const BOTTOMS: [usize; 9] = [0, 1, 3, 4, 5, 6, 7, 11, 15];
/// Shoes, sRGB 0–255: black, white, brown, grey, navy.
const SHOES: [[u8; 3]; 5] = [
    [0x14, 0x14, 0x14],
    [0xf0, 0xf0, 0xed],
    [0x59, 0x38, 0x21],
    [0x73, 0x73, 0x73],
    [0x1f, 0x29, 0x4a],
];
/// Per-channel jitter on hair and clothing colours, ± this (sRGB units).
pub const COLOUR_JITTER: f64 = 0.04;

impl Population {
    /// Checks the weights and the female fraction.
    ///
    /// # Errors
    /// [`SceneError`] naming the bad field and value.
    pub fn validate(&self) -> Result<(), SceneError> {
        check_weights(&self.age_weights).map_err(|e| e.in_field("age_weights"))?;
        check_weights(&self.skin_tone_weights).map_err(|e| e.in_field("skin_tone_weights"))?;
        if !(0.0..=1.0).contains(&self.female_fraction) {
            return Err(SceneError::OutOfRange {
                field: "female_fraction",
                value: self.female_fraction,
                allowed: "a probability in [0, 1]",
            });
        }
        Ok(())
    }

    /// Draws one character (see the module docs for the model and the order of the draws).
    ///
    /// # Errors
    /// As [`Population::validate`].
    pub fn draw(&self, rng: &mut (impl Rng + ?Sized)) -> Result<Look, SceneError> {
        self.validate()?;
        let age_group = AgeGroup::ALL[weighted_index(rng, &self.age_weights)?];
        let [young, old] = age_group.age_range_years();
        let age_years = rng.random_range(young..=old);
        let sex = if rng.random_bool(self.female_fraction) {
            Sex::Female
        } else {
            Sex::Male
        };

        let (mean_cm, sd_cm) = height_model_cm(age_group, sex, age_years);
        let height_m = clamped_normal(rng, mean_cm, sd_cm) / 100.0;
        let [leg, arm, torso, head] = part_scale_means(age_group, age_years)
            .map(|m| m * clamped_normal(rng, 1.0, PART_SCALE_SD));
        let (bmi_mean, bmi_sd, [bmi_min, bmi_max]) = bmi_model(age_group, age_years);
        let bmi_kg_per_m2 = (bmi_mean + bmi_sd * standard_normal(rng)).clamp(bmi_min, bmi_max);

        let tone = weighted_index(rng, &self.skin_tone_weights)?;
        let skin_rgb = skin_colour(rng, tone);

        let grey = rng.random_bool(grey_hair_probability(age_years));
        let hair = if grey {
            HAIR_GREY[usize::from(age_years >= 70 && rng.random_bool(0.5))]
        } else {
            let w = if tone < 4 {
                &HAIR_WEIGHTS_LIGHT_SKIN
            } else {
                &HAIR_WEIGHTS_DARK_SKIN
            };
            HAIR_PIGMENTED[weighted_index(rng, w)?]
        };
        let hair_rgb = jittered(rng, hair);
        let top = TOPS[rng.random_range(0..TOPS.len())];
        let bottom = TOPS[BOTTOMS[rng.random_range(0..BOTTOMS.len())]];
        let shoes = SHOES[rng.random_range(0..SHOES.len())];
        let clothing = Clothing {
            top_rgb: jittered(rng, top),
            bottom_rgb: jittered(rng, bottom),
            shoes_rgb: jittered(rng, shoes),
        };

        Ok(Look {
            age_group,
            sex,
            age_years,
            height_m,
            proportions: Proportions {
                height_m,
                arm_scale: arm,
                leg_scale: leg,
                torso_scale: torso,
            },
            head_scale: head,
            bmi_kg_per_m2,
            skin_tone: u8::try_from(tone + 1).unwrap_or(u8::MAX),
            skin_rgb,
            hair_rgb,
            clothing,
        })
    }
}

/// A normal draw clamped to mean ± 3 SD.
fn clamped_normal(rng: &mut (impl Rng + ?Sized), mean: f64, sd: f64) -> f64 {
    (mean + sd * standard_normal(rng)).clamp(mean - 3.0 * sd, mean + 3.0 * sd)
}

/// Skin of Monk tone `tone` (0-based): blended up to halfway towards a random neighbouring
/// tone, then its brightness scaled by U(0.97, 1.03) — variation that stays a skin colour.
fn skin_colour(rng: &mut (impl Rng + ?Sized), tone: usize) -> [f32; 3] {
    let last = MONK_SKIN_TONES.len() - 1;
    let neighbour = match tone {
        0 => 1,
        t if t == last => last - 1,
        t if rng.random_bool(0.5) => t - 1,
        t => t + 1,
    };
    let t = rng.random_range(0.0..0.5);
    let brightness = rng.random_range(0.97..1.03);
    let (a, b) = (MONK_SKIN_TONES[tone], MONK_SKIN_TONES[neighbour]);
    [0, 1, 2].map(|c| {
        let (x, y) = (f64::from(a[c]) / 255.0, f64::from(b[c]) / 255.0);
        ((x + (y - x) * t) * brightness).clamp(0.0, 1.0) as f32
    })
}

/// An sRGB 0–255 colour in [0, 1], each channel moved by U(±[`COLOUR_JITTER`]).
fn jittered(rng: &mut (impl Rng + ?Sized), rgb: [u8; 3]) -> [f32; 3] {
    rgb.map(|c| {
        let j = rng.random_range(-COLOUR_JITTER..=COLOUR_JITTER);
        (f64::from(c) / 255.0 + j).clamp(0.0, 1.0) as f32
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::tests::{chi_square_fit, chi_square_transitions};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    fn draws(pop: &Population, seed: u64, n: usize) -> Vec<Look> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        (0..n).map(|_| pop.draw(&mut rng).unwrap()).collect()
    }

    #[test]
    fn same_seed_same_cast_other_seed_other_cast() {
        let pop = Population::default();
        assert_eq!(draws(&pop, 5, 50), draws(&pop, 5, 50));
        assert_ne!(draws(&pop, 5, 50), draws(&pop, 6, 50));
    }

    #[test]
    fn age_groups_follow_the_weights_without_cycling() {
        // χ² critical values at p = 0.001: df 2 → 13.816 (3 groups), df 4 → 18.467 (3×3 table).
        let pop = Population::default();
        let looks = draws(&pop, 2024, 10_000);
        let seq: Vec<usize> = looks.iter().map(|l| l.age_group as usize).collect();
        let fit = chi_square_fit(&seq, &pop.age_weights);
        assert!(fit < 13.816, "goodness of fit χ² = {fit}");
        let indep = chi_square_transitions(&seq, 3);
        assert!(indep < 18.467, "transition independence χ² = {indep}");
    }

    #[test]
    fn everything_is_finite_and_in_range() {
        let pop = Population {
            age_weights: [1.0, 1.0, 1.0],
            ..Population::default()
        };
        for l in draws(&pop, 9, 5_000) {
            let [young, old] = l.age_group.age_range_years();
            assert!((young..=old).contains(&l.age_years), "{l:?}");
            assert!((1.0..=2.2).contains(&l.height_m), "{l:?}");
            let (mean, sd) = height_model_cm(l.age_group, l.sex, l.age_years);
            let cm = l.height_m * 100.0;
            assert!(
                cm >= mean - 3.0 * sd - 1e-9 && cm <= mean + 3.0 * sd + 1e-9,
                "{l:?}"
            );
            let p = l.proportions;
            assert_eq!(p.height_m, l.height_m);
            for s in [p.arm_scale, p.leg_scale, p.torso_scale, l.head_scale] {
                assert!((0.8..=1.4).contains(&s), "{l:?}");
            }
            assert!((13.0..=40.0).contains(&l.bmi_kg_per_m2), "{l:?}");
            assert!(l.girth_scale().is_finite() && l.girth_scale() > 0.7);
            assert!((1..=10).contains(&l.skin_tone));
            let colours = [
                l.skin_rgb,
                l.hair_rgb,
                l.clothing.top_rgb,
                l.clothing.bottom_rgb,
                l.clothing.shoes_rgb,
            ];
            for c in colours.iter().flatten() {
                assert!(c.is_finite() && (0.0..=1.0).contains(c), "{l:?}");
            }
            let means = part_scale_means(l.age_group, l.age_years);
            let scales = [p.leg_scale, p.arm_scale, p.torso_scale, l.head_scale];
            for (s, m) in scales.into_iter().zip(means) {
                let r = s / m;
                assert!(
                    (1.0 - 3.0 * PART_SCALE_SD - 1e-12..=1.0 + 3.0 * PART_SCALE_SD + 1e-12)
                        .contains(&r),
                    "{l:?}"
                );
            }
        }
    }

    #[test]
    fn children_are_shorter_than_adults_and_women_than_men() {
        let pop = Population {
            age_weights: [1.0, 1.0, 1.0],
            ..Population::default()
        };
        let looks = draws(&pop, 77, 6_000);
        let mean = |f: &dyn Fn(&Look) -> bool| {
            let v: Vec<f64> = looks.iter().filter(|l| f(l)).map(|l| l.height_m).collect();
            v.iter().sum::<f64>() / v.len() as f64
        };
        let child = mean(&|l| l.age_group == AgeGroup::Child);
        let adult_f = mean(&|l| l.age_group == AgeGroup::Adult && l.sex == Sex::Female);
        let adult_m = mean(&|l| l.age_group == AgeGroup::Adult && l.sex == Sex::Male);
        let older_m = mean(&|l| l.age_group == AgeGroup::Older && l.sex == Sex::Male);
        assert!((1.28..1.38).contains(&child), "{child}");
        assert!((adult_f - 1.62).abs() < 0.01, "{adult_f}");
        assert!((adult_m - 1.75).abs() < 0.01, "{adult_m}");
        assert!(older_m < adult_m - 0.02, "{older_m} vs {adult_m}");
        let grey = looks
            .iter()
            .filter(|l| l.age_group == AgeGroup::Child)
            .all(|l| {
                HAIR_GREY.iter().all(|g| {
                    let g = g.map(|c| f64::from(c) / 255.0);
                    (0..3).any(|c| (f64::from(l.hair_rgb[c]) - g[c]).abs() > COLOUR_JITTER + 1e-6)
                })
            });
        assert!(grey, "children are never grey");
    }

    #[test]
    fn the_character_stands_at_the_drawn_height() {
        let rig = Rig::standard();
        let top = rig.landmark_index("head_top").unwrap();
        let pop = Population {
            age_weights: [1.0, 1.0, 1.0],
            ..Population::default()
        };
        for l in draws(&pop, 31, 200) {
            let c = l.character(&rig);
            assert!(c.hip_height_m(&rig) > 0.0);
            let stature = c.landmark_from_root_m(&rig, top).z;
            assert!((stature - l.height_m).abs() < 1e-9, "{stature} vs {l:?}");
        }
    }

    #[test]
    fn hip_height_scales_with_height_and_children_have_short_legs() {
        let rig = Rig::standard();
        let mut look = draws(&Population::default(), 1, 1).remove(0);
        look.proportions = Proportions::default();
        look.head_scale = 1.0;
        look.height_m = 1.75;
        let tall = look.character(&rig).hip_height_m(&rig);
        assert!((tall - Character::standard(&rig).hip_height_m(&rig)).abs() < 1e-9);
        look.height_m = 1.40;
        let short = look.character(&rig).hip_height_m(&rig);
        assert!((short / tall - 1.40 / 1.75).abs() < 1e-9, "{short} {tall}");
        // A 6-year-old's body: at the same height, lower hips than an adult's.
        let [leg, arm, torso, head] = part_scale_means(AgeGroup::Child, 6);
        look.proportions = Proportions {
            height_m: 1.40,
            arm_scale: arm,
            leg_scale: leg,
            torso_scale: torso,
        };
        look.head_scale = head;
        let child = look.character(&rig).hip_height_m(&rig);
        assert!(child < short * 0.96, "{child} vs {short}");
    }

    #[test]
    fn bad_populations_are_named() {
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let bad = Population {
            female_fraction: 1.5,
            ..Population::default()
        };
        let msg = bad.draw(&mut rng).unwrap_err().to_string();
        assert!(
            msg.contains("female_fraction") && msg.contains("1.5"),
            "{msg}"
        );
        let bad = Population {
            age_weights: [0.0, 0.0, 0.0],
            ..Population::default()
        };
        let msg = bad.draw(&mut rng).unwrap_err().to_string();
        assert!(msg.contains("age_weights"), "{msg}");
        let bad = Population {
            skin_tone_weights: [1.0, -1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0],
            ..Population::default()
        };
        let msg = bad.draw(&mut rng).unwrap_err().to_string();
        assert!(
            msg.contains("skin_tone_weights") && msg.contains("-1"),
            "{msg}"
        );
    }

    #[test]
    fn populations_parse_from_toml_with_defaults() {
        let p: Population = toml::from_str("female_fraction = 0.3").unwrap();
        assert_eq!(p.female_fraction, 0.3);
        assert_eq!(p.age_weights, Population::default().age_weights);
        assert!(toml::from_str::<Population>("female = 0.3").is_err());
    }
}
