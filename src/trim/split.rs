//! Train/val/test without leakage: every clip of a group (by default, of one source animation)
//! lands in the same split, drawn from a seed, stratified by class.
//!
//! - Groups are ordered by a hash of `(seed, class, group)` (SplitMix64 over FNV-1a), so the
//!   same seed gives the same splits on every machine, and adding a group to a class moves no
//!   other group across splits unless the rounded split sizes change.
//! - If every group belongs to one class, each class is split on its own (stratified): of a
//!   class's `n` groups, `round(n · test)` go to test, `round(n · val)` to val, the rest (at
//!   least one, when `n > 0`) to train. If groups span classes (e.g. `--split-by weather`), the
//!   groups are split as one pool instead, since one group cannot be in two splits.
//! - Held-out values (`--hold-out weather=RAIN`) send every clip with that value to test: the
//!   test split then holds conditions the model never saw. The clips' groups may also have
//!   clips in train (the held-out condition, not the group, is what is unseen).

use std::collections::{BTreeMap, BTreeSet};

use super::{ClipRecord, TrimError};
use crate::hash::mix64;

/// A split.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    /// Training.
    Train,
    /// Validation.
    Val,
    /// Testing.
    Test,
}

impl Split {
    /// All three, in file order.
    pub const ALL: [Split; 3] = [Split::Train, Split::Val, Split::Test];

    /// `train`, `val` or `test`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Split::Train => "train",
            Split::Val => "val",
            Split::Test => "test",
        }
    }

    /// ActivityNet's subset name: `training`, `validation`, `testing`.
    #[must_use]
    pub fn activitynet_subset(self) -> &'static str {
        match self {
            Split::Train => "training",
            Split::Val => "validation",
            Split::Test => "testing",
        }
    }
}

/// A level of the hierarchy or a scene property, to group or hold out clips by.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Key {
    /// The source animation (default: no motion is seen in two splits).
    Animation,
    /// Source animation and variant.
    Variant,
    /// The scene (animation, variant, scene).
    Scene,
    /// The clip itself (no grouping: leaks motion across splits).
    Clip,
    /// The weather.
    Weather,
    /// The location.
    Location,
    /// The drawn character (its look's hash).
    Character,
    /// The time of day.
    Time,
}

impl Key {
    /// The clip's value of this key.
    #[must_use]
    pub fn of(self, clip: &ClipRecord) -> String {
        match self {
            Key::Animation => clip.animation.clone(),
            Key::Variant => format!("{}#v{}", clip.animation, clip.variant),
            Key::Scene => format!("{}#v{}#s{}", clip.animation, clip.variant, clip.scene),
            Key::Clip => clip.clip_id.clone(),
            Key::Weather => clip.weather.clone(),
            Key::Location => clip.location.clone(),
            Key::Character => clip.character.clone(),
            Key::Time => clip.time.clone(),
        }
    }
}

/// How to split.
#[derive(Debug, Clone, PartialEq)]
pub struct SplitConfig {
    /// What a group is.
    pub by: Key,
    /// Train, val, test fractions (normalised to sum 1).
    pub ratios: [f64; 3],
    /// Seed.
    pub seed: u64,
    /// Values whose clips all go to test.
    pub hold_out: Vec<(Key, String)>,
}

impl Default for SplitConfig {
    fn default() -> SplitConfig {
        SplitConfig {
            by: Key::Animation,
            ratios: [0.7, 0.15, 0.15],
            seed: 0,
            hold_out: Vec::new(),
        }
    }
}

/// FNV-1a, 64-bit: a stable hash of text (the one the dataset plan draws scene streams with).
pub use crate::dataset::plan::stream_of as fnv1a;

/// The split of every clip, by clip id.
///
/// # Errors
/// [`TrimError::SplitRatios`] for ratios that are negative, not finite or all zero.
pub fn assign(
    clips: &[ClipRecord],
    config: &SplitConfig,
) -> Result<BTreeMap<String, Split>, TrimError> {
    let [tr, va, te] = config.ratios;
    let sum = tr + va + te;
    if !config.ratios.iter().all(|r| r.is_finite() && *r >= 0.0) || sum <= 0.0 {
        return Err(TrimError::SplitRatios {
            ratios: config.ratios,
        });
    }
    let (val, test) = (va / sum, te / sum);
    let mut out = BTreeMap::new();
    // group → classes, group → clips
    let mut groups: BTreeMap<String, (BTreeSet<String>, Vec<&ClipRecord>)> = BTreeMap::new();
    for c in clips {
        if config.hold_out.iter().any(|(k, v)| k.of(c) == *v) {
            out.insert(c.clip_id.clone(), Split::Test);
            continue;
        }
        let g = groups.entry(config.by.of(c)).or_default();
        g.0.insert(c.label.clone());
        g.1.push(c);
    }
    let stratified = groups.values().all(|(classes, _)| classes.len() == 1);
    // pool → its groups
    let mut pools: BTreeMap<String, Vec<&String>> = BTreeMap::new();
    for (name, (classes, _)) in &groups {
        let pool = if stratified {
            classes.iter().next().cloned().unwrap_or_default()
        } else {
            String::new()
        };
        pools.entry(pool).or_default().push(name);
    }
    for (pool, mut names) in pools {
        let pool_seed = mix64(config.seed ^ mix64(fnv1a(&pool)));
        names.sort_by_key(|n| (mix64(pool_seed ^ fnv1a(n)), (*n).clone()));
        let n = names.len();
        #[expect(
            clippy::cast_possible_truncation,
            clippy::cast_sign_loss,
            clippy::cast_precision_loss,
            reason = "group counts are small; fractions are in [0, 1]"
        )]
        let (mut n_test, mut n_val) = (
            (n as f64 * test).round() as usize,
            (n as f64 * val).round() as usize,
        );
        // Keep one group for training whenever there is one.
        while n > 0 && n_test + n_val >= n && (n_test + n_val) > 0 && tr > 0.0 {
            if n_val >= n_test && n_val > 0 {
                n_val -= 1;
            } else {
                n_test -= 1;
            }
        }
        n_test = n_test.min(n);
        n_val = n_val.min(n - n_test);
        for (i, name) in names.iter().enumerate() {
            let split = if i < n_test {
                Split::Test
            } else if i < n_test + n_val {
                Split::Val
            } else {
                Split::Train
            };
            for c in &groups[*name].1 {
                out.insert(c.clip_id.clone(), split);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use std::collections::{BTreeMap, BTreeSet};

    use super::{Key, Split, SplitConfig, assign};
    use crate::trim::ClipRecord;
    use crate::video::CutMethod;

    pub(crate) fn record(clip_id: &str, label: &str, animation: &str, weather: &str) -> ClipRecord {
        ClipRecord {
            clip_id: clip_id.to_owned(),
            video: format!("videos/{label}/{clip_id}.mp4"),
            rawframes: None,
            label: label.to_owned(),
            label_id: 0,
            label_dir: label.to_owned(),
            frame_count: 30,
            fps: 30.0,
            start_s: 0.0,
            end_s: 1.0,
            start_frame: 0,
            method: CutMethod::StreamCopy,
            capture_video: "c.mp4".into(),
            capture_duration_s: 10.0,
            capture_resolution: "320x240".into(),
            capture_bag: "c.mcap".into(),
            session: "s".into(),
            segment_id: clip_id.into(),
            category: "cat".into(),
            animation: animation.to_owned(),
            variant: 0,
            scene: 0,
            viewpoint: 0,
            scene_id: "x".into(),
            weather: weather.to_owned(),
            time: "12:00".into(),
            location: "street".into(),
            character: "c0".into(),
            character_look: serde_json::Value::Null,
            camera: "viewpoint 0".into(),
            seed: Some(1),
        }
    }

    /// 4 classes × 10 animations × 6 clips, weathers alternating.
    fn clips() -> Vec<ClipRecord> {
        let mut out = Vec::new();
        for class in ["jump", "run", "sit", "wave"] {
            for a in 0..10 {
                for v in 0..6 {
                    let w = if v % 2 == 0 { "CLEAR" } else { "RAIN" };
                    out.push(record(
                        &format!("{class}_{a}_{v}"),
                        class,
                        &format!("{class}{a}"),
                        w,
                    ));
                }
            }
        }
        out
    }

    fn splits_of(
        clips: &[ClipRecord],
        by: &BTreeMap<String, Split>,
        key: Key,
    ) -> BTreeMap<String, BTreeSet<Split>> {
        let mut out: BTreeMap<String, BTreeSet<Split>> = BTreeMap::new();
        for c in clips {
            out.entry(key.of(c)).or_default().insert(by[&c.clip_id]);
        }
        out
    }

    #[test]
    fn no_animation_is_in_two_splits_and_every_class_is_in_every_split() {
        let clips = clips();
        let by = assign(
            &clips,
            &SplitConfig {
                seed: 7,
                ..SplitConfig::default()
            },
        )
        .unwrap();
        assert_eq!(by.len(), clips.len());
        for (anim, splits) in splits_of(&clips, &by, Key::Animation) {
            assert_eq!(splits.len(), 1, "{anim} in {splits:?}");
        }
        for class in ["jump", "run", "sit", "wave"] {
            let mut count = BTreeMap::new();
            for c in clips.iter().filter(|c| c.label == class) {
                *count.entry(by[&c.clip_id]).or_insert(0) += 1;
            }
            // 10 animations: 7/1.5→2/1.5→2 rounds to 6 train, 2 val, 2 test (× 6 clips).
            assert_eq!(count[&Split::Train], 36, "{class}: {count:?}");
            assert_eq!(count[&Split::Val], 12, "{class}: {count:?}");
            assert_eq!(count[&Split::Test], 12, "{class}: {count:?}");
        }
    }

    #[test]
    fn same_seed_same_splits_other_seed_other_splits() {
        let clips = clips();
        let cfg = |seed| SplitConfig {
            seed,
            ..SplitConfig::default()
        };
        let a = assign(&clips, &cfg(3)).unwrap();
        assert_eq!(a, assign(&clips, &cfg(3)).unwrap());
        let mut reversed = clips.clone();
        reversed.reverse();
        assert_eq!(
            a,
            assign(&reversed, &cfg(3)).unwrap(),
            "input order does not matter"
        );
        assert_ne!(a, assign(&clips, &cfg(4)).unwrap());
    }

    #[test]
    fn held_out_weather_is_only_in_test() {
        let clips = clips();
        let cfg = SplitConfig {
            hold_out: vec![(Key::Weather, "RAIN".into())],
            ..SplitConfig::default()
        };
        let by = assign(&clips, &cfg).unwrap();
        let w = splits_of(&clips, &by, Key::Weather);
        assert_eq!(w["RAIN"], BTreeSet::from([Split::Test]));
        assert!(w["CLEAR"].contains(&Split::Train));
    }

    #[test]
    fn groups_spanning_classes_are_split_as_one_pool() {
        let clips = clips();
        let cfg = SplitConfig {
            by: Key::Weather,
            ratios: [0.5, 0.0, 0.5],
            ..SplitConfig::default()
        };
        let by = assign(&clips, &cfg).unwrap();
        let w = splits_of(&clips, &by, Key::Weather);
        assert_eq!(w.values().map(BTreeSet::len).max(), Some(1));
        let all: BTreeSet<Split> = w.values().flatten().copied().collect();
        assert_eq!(all, BTreeSet::from([Split::Train, Split::Test]));
    }

    #[test]
    fn a_single_group_goes_to_train_and_bad_ratios_are_refused() {
        let clips = vec![record("a", "x", "x0", "CLEAR")];
        let by = assign(&clips, &SplitConfig::default()).unwrap();
        assert_eq!(by["a"], Split::Train);
        for ratios in [[0.0, 0.0, 0.0], [-1.0, 1.0, 1.0], [f64::NAN, 1.0, 0.0]] {
            assert!(
                assign(
                    &clips,
                    &SplitConfig {
                        ratios,
                        ..SplitConfig::default()
                    }
                )
                .is_err()
            );
        }
    }
}
