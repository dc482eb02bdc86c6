//! Train/val/test without leakage: every clip of a group (by default, of one source animation)
//! lands in the same split, drawn from a seed, stratified by class.
//!
//! - **From the plan.** The groups are those of every clip the dataset will have (the spec's
//!   `plan.json`, [`super::planned`]), not only of the clips trimmed so far
//!   ([`assign_clips`]): a clip's split is the same whatever order the captures are trimmed in
//!   and however many have been. Without a plan, the clips in the dataset folder are all there
//!   is, and a split may change as captures arrive.
//! - Groups are ordered by a hash of `(seed, class, group)` (SplitMix64 over FNV-1a), so the
//!   same seed gives the same splits on every machine, and adding a group to a class moves no
//!   other group across splits unless the split sizes change.
//! - If every group belongs to one class, each class is split on its own (stratified): of a
//!   class's `n` groups, `round(n · test)` go to test, `round(n · val)` to val, the rest to
//!   train ([`allocate`]); once `n` is at least the number of splits with a non-zero ratio,
//!   each of them gets at least one group (3 groups at `0.7,0.15,0.15`: 1/1/1), and train keeps
//!   at least one whenever its ratio is not zero. If groups span classes (e.g.
//!   `--split-by weather`), the groups are split as one pool instead, since one group cannot be
//!   in two splits.
//! - **Finer groups when there are too few.** A class (pool) with fewer groups than splits to
//!   fill, but at least as many clips, is grouped by the next finer level of the hierarchy that
//!   has enough: `animation` → `variant` → `scene` → `clip`. The motion then leaks across splits
//!   (a [`Refined`] says how; `trim` prints it and writes each clip's grouping as `split_by` in
//!   `clips.jsonl`). Keys outside the hierarchy (`weather`, …) are never refined.
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
    /// The item's value of this key.
    #[must_use]
    pub fn of(self, item: &SplitItem) -> String {
        match self {
            Key::Animation => item.animation.clone(),
            Key::Variant => format!("{}#v{}", item.animation, item.variant),
            Key::Scene => format!("{}#v{}#s{}", item.animation, item.variant, item.scene),
            Key::Clip => item.clip_id.clone(),
            Key::Weather => item.weather.clone(),
            Key::Location => item.location.clone(),
            Key::Character => item.character.clone(),
            Key::Time => item.time.clone(),
        }
    }

    /// Its name on the command line and in `clips.jsonl` (`animation`, `variant`, …).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Key::Animation => "animation",
            Key::Variant => "variant",
            Key::Scene => "scene",
            Key::Clip => "clip",
            Key::Weather => "weather",
            Key::Location => "location",
            Key::Character => "character",
            Key::Time => "time",
        }
    }

    /// The finer levels of the hierarchy below this key, coarsest first (none for keys outside
    /// the hierarchy).
    #[must_use]
    pub fn finer(self) -> &'static [Key] {
        match self {
            Key::Animation => &[Key::Variant, Key::Scene, Key::Clip],
            Key::Variant => &[Key::Scene, Key::Clip],
            Key::Scene => &[Key::Clip],
            _ => &[],
        }
    }

    /// `n` groups of this key, in words (`1 source animation`, `2 variants`).
    fn count(self, n: usize) -> String {
        let (one, many) = match self {
            Key::Animation => ("source animation", "source animations"),
            Key::Variant => ("variant", "variants"),
            Key::Scene => ("scene", "scenes"),
            Key::Clip => ("clip", "clips"),
            Key::Weather => ("weather", "weathers"),
            Key::Location => ("location", "locations"),
            Key::Character => ("character", "characters"),
            Key::Time => ("time of day", "times of day"),
        };
        format!("{n} {}", if n == 1 { one } else { many })
    }

    /// What a split by this finer key shows in more than one split.
    fn leak(self) -> &'static str {
        match self {
            Key::Variant => {
                "the same source animation (other variants of it) is in more than one split"
            }
            Key::Scene => {
                "the same motion (source animation and variant) is in more than one split, in other scenes"
            }
            _ => {
                "the same scene (motion, character, place) is in more than one split, from other viewpoints"
            }
        }
    }
}

/// What splitting needs of a clip: its id, its class and every value it can be grouped or held
/// out by. From a trimmed clip ([`ClipRecord`]) or a planned one ([`super::planned`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SplitItem {
    /// The clip id.
    pub clip_id: String,
    /// Its class label.
    pub label: String,
    /// Source animation.
    pub animation: String,
    /// Variant index.
    pub variant: u32,
    /// Scene index within the variant.
    pub scene: u32,
    /// Weather name.
    pub weather: String,
    /// Clock time, `HH:MM`.
    pub time: String,
    /// Location name.
    pub location: String,
    /// Character id.
    pub character: String,
}

impl From<&ClipRecord> for SplitItem {
    /// The item of the segment `c` was cut from (its clip id the segment's, as in the plan: all
    /// clips of one segment are one item).
    fn from(c: &ClipRecord) -> SplitItem {
        SplitItem {
            clip_id: super::clip_id(&c.segment_id),
            label: c.label.clone(),
            animation: c.animation.clone(),
            variant: c.variant,
            scene: c.scene,
            weather: c.weather.clone(),
            time: c.time.clone(),
            location: c.location.clone(),
            character: c.character.clone(),
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

/// How a clip's split was decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Grouping {
    /// With every clip of its group by this key.
    By(Key),
    /// Held out (`--hold-out`): test, whatever its group.
    HeldOut,
}

impl Grouping {
    /// `animation`, `variant`, …, or `held-out`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Grouping::By(k) => k.name(),
            Grouping::HeldOut => "held-out",
        }
    }
}

/// A class (or the pool of all classes) grouped more finely than asked, since it has too few
/// groups to fill every split.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Refined {
    /// The class; `None` when the groups span classes and all are split as one pool.
    pub class: Option<String>,
    /// The key asked for.
    pub requested: Key,
    /// How many groups the class has by it.
    pub groups: usize,
    /// How many splits are to be filled (those with a non-zero ratio).
    pub splits: usize,
    /// The key used instead.
    pub used: Key,
}

impl std::fmt::Display for Refined {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.class {
            Some(class) => write!(f, "class {class}")?,
            None => f.write_str("all classes")?,
        }
        write!(
            f,
            ": {} for {} splits, split by {} instead: {}",
            self.requested.count(self.groups),
            self.splits,
            self.used.name(),
            self.used.leak()
        )
    }
}

/// The split of every clip, how each was grouped, and the classes grouped more finely than
/// asked.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Assignment {
    /// Split by clip id.
    pub splits: BTreeMap<String, Split>,
    /// Grouping by clip id.
    pub grouped_by: BTreeMap<String, Grouping>,
    /// Classes grouped more finely than asked, in class order.
    pub refined: Vec<Refined>,
}

/// `ratios` normalised to sum 1.
fn normalised(ratios: [f64; 3]) -> Result<[f64; 3], TrimError> {
    let sum: f64 = ratios.iter().sum();
    if !ratios.iter().all(|r| r.is_finite() && *r >= 0.0) || sum <= 0.0 {
        return Err(TrimError::SplitRatios { ratios });
    }
    Ok(ratios.map(|r| r / sum))
}

/// How many of `n` groups go to train, val and test at `ratios` (normalised): `round(n · val)`
/// to val and `round(n · test)` to test, but at least one to each split with a non-zero ratio
/// once `n` is at least the number of such splits, and at least one to train (when its ratio
/// is not zero and `n > 0`), taken from the larger of val and test.
#[must_use]
pub fn allocate(n: usize, ratios: [f64; 3]) -> [usize; 3] {
    let [tr, va, te] = ratios;
    let needed = ratios.iter().filter(|r| **r > 0.0).count();
    let floor = |r: f64| usize::from(n >= needed && r > 0.0);
    #[expect(
        clippy::cast_possible_truncation,
        clippy::cast_sign_loss,
        clippy::cast_precision_loss,
        reason = "group counts are small; fractions are in [0, 1]"
    )]
    let round = |r: f64| (n as f64 * r).round() as usize;
    let (mut val, mut test) = (round(va).max(floor(va)), round(te).max(floor(te)));
    while tr > 0.0 && n > 0 && val + test >= n {
        if val >= test && val > floor(va) {
            val -= 1;
        } else if test > floor(te) {
            test -= 1;
        } else if val > floor(va) {
            val -= 1;
        } else {
            break;
        }
    }
    test = test.min(n);
    val = val.min(n - test);
    [n - val - test, val, test]
}

/// The split of every item, decided over `items` alone.
///
/// # Errors
/// [`TrimError::SplitRatios`] for ratios that are negative, not finite or all zero.
pub fn assign(items: &[SplitItem], config: &SplitConfig) -> Result<Assignment, TrimError> {
    let ratios = normalised(config.ratios)?;
    let mut out = Assignment::default();
    let mut kept = Vec::new();
    for c in items {
        if config.hold_out.iter().any(|(k, v)| k.of(c) == *v) {
            out.splits.insert(c.clip_id.clone(), Split::Test);
            out.grouped_by.insert(c.clip_id.clone(), Grouping::HeldOut);
        } else {
            kept.push(c);
        }
    }
    // group → its classes
    let mut classes: BTreeMap<String, BTreeSet<&str>> = BTreeMap::new();
    for c in &kept {
        classes
            .entry(config.by.of(c))
            .or_default()
            .insert(c.label.as_str());
    }
    let stratified = classes.values().all(|c| c.len() == 1);
    // pool → its items
    let mut pools: BTreeMap<&str, Vec<&SplitItem>> = BTreeMap::new();
    for c in kept {
        let pool = if stratified { c.label.as_str() } else { "" };
        pools.entry(pool).or_default().push(c);
    }
    let needed = ratios.iter().filter(|r| **r > 0.0).count();
    for (pool, members) in pools {
        let groups = |k: Key| {
            members
                .iter()
                .map(|c| k.of(c))
                .collect::<BTreeSet<_>>()
                .len()
        };
        let requested = groups(config.by);
        let by = if requested >= needed || groups(Key::Clip) < needed {
            config.by
        } else {
            config
                .by
                .finer()
                .iter()
                .copied()
                .find(|k| groups(*k) >= needed)
                .unwrap_or(config.by)
        };
        if by != config.by {
            out.refined.push(Refined {
                class: stratified.then(|| pool.to_owned()),
                requested: config.by,
                groups: requested,
                splits: needed,
                used: by,
            });
        }
        split_pool(pool, &members, by, config.seed, ratios, &mut out);
    }
    Ok(out)
}

/// Splits the items of one pool (a class, or all classes) by `by`: groups ordered by a hash of
/// `(seed, pool, group)`, the first to test, the next to val, the rest to train.
fn split_pool(
    pool: &str,
    members: &[&SplitItem],
    by: Key,
    seed: u64,
    ratios: [f64; 3],
    out: &mut Assignment,
) {
    let mut groups: BTreeMap<String, Vec<&SplitItem>> = BTreeMap::new();
    for c in members {
        groups.entry(by.of(c)).or_default().push(c);
    }
    let pool_seed = mix64(seed ^ mix64(fnv1a(pool)));
    let mut names: Vec<&String> = groups.keys().collect();
    names.sort_by_key(|n| (mix64(pool_seed ^ fnv1a(n)), (*n).clone()));
    let [_, n_val, n_test] = allocate(names.len(), ratios);
    for (i, name) in names.iter().enumerate() {
        let split = if i < n_test {
            Split::Test
        } else if i < n_test + n_val {
            Split::Val
        } else {
            Split::Train
        };
        for c in &groups[*name] {
            out.splits.insert(c.clip_id.clone(), split);
            out.grouped_by.insert(c.clip_id.clone(), Grouping::By(by));
        }
    }
}

/// The splits of `clips` (the dataset folder's), decided over every clip of `plan` when there
/// is one (and over those of `clips` it does not list), else over `clips` alone: given the
/// plan, a clip's split does not depend on which other clips are trimmed yet. The assignment
/// covers `clips` only; its `refined` is about every clip it was decided over.
///
/// # Errors
/// [`TrimError::SplitRatios`] for ratios that are negative, not finite or all zero.
pub fn assign_clips(
    plan: Option<&[SplitItem]>,
    clips: &[ClipRecord],
    config: &SplitConfig,
) -> Result<Assignment, TrimError> {
    let mut items: Vec<SplitItem> = plan.map(<[SplitItem]>::to_vec).unwrap_or_default();
    let planned: BTreeSet<String> = items.iter().map(|i| i.clip_id.clone()).collect();
    // The segments (items) of the clips, each once.
    let of_clips: Vec<SplitItem> = clips.iter().map(SplitItem::from).collect();
    let unplanned: BTreeMap<String, SplitItem> = of_clips
        .iter()
        .filter(|i| !planned.contains(&i.clip_id))
        .map(|i| (i.clip_id.clone(), i.clone()))
        .collect();
    if plan.is_some()
        && let Some(first) = unplanned.keys().next()
    {
        tracing::warn!(
            "{} segments of clips in the dataset folder are not in the plan (e.g. `{first}`): their splits may change as other captures are trimmed",
            unplanned.len(),
        );
    }
    items.extend(unplanned.into_values());
    let by_segment = assign(&items, config)?;
    // Every clip takes its segment's split.
    let mut out = Assignment {
        refined: by_segment.refined,
        ..Assignment::default()
    };
    for (c, item) in clips.iter().zip(&of_clips) {
        if let Some(split) = by_segment.splits.get(&item.clip_id) {
            out.splits.insert(c.clip_id.clone(), *split);
        }
        if let Some(g) = by_segment.grouped_by.get(&item.clip_id) {
            out.grouped_by.insert(c.clip_id.clone(), *g);
        }
    }
    Ok(out)
}

#[cfg(test)]
pub(crate) mod tests {
    use std::collections::{BTreeMap, BTreeSet};

    use super::{Grouping, Key, Split, SplitConfig, SplitItem, allocate, assign, assign_clips};
    use crate::trim::ClipRecord;
    use crate::video::CutMethod;

    pub(crate) fn record(clip_id: &str, label: &str, animation: &str, weather: &str) -> ClipRecord {
        ClipRecord {
            clip_id: clip_id.to_owned(),
            video: format!("videos/{label}/{clip_id}.mp4"),
            rawframes: None,
            jpeg_quality: None,
            depth: None,
            masks: None,
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
            policy: crate::dataset::clips::ClipMode::Whole,
            part: None,
            action_span: None,
            qa: None,
            labels: None,
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

    fn items(clips: &[ClipRecord]) -> Vec<SplitItem> {
        clips.iter().map(SplitItem::from).collect()
    }

    /// The splits of `clips`, by clip id.
    fn split(clips: &[ClipRecord], config: &SplitConfig) -> BTreeMap<String, Split> {
        assign(&items(clips), config).unwrap().splits
    }

    fn splits_of(
        clips: &[ClipRecord],
        by: &BTreeMap<String, Split>,
        key: Key,
    ) -> BTreeMap<String, BTreeSet<Split>> {
        let mut out: BTreeMap<String, BTreeSet<Split>> = BTreeMap::new();
        for c in clips {
            out.entry(key.of(&SplitItem::from(c)))
                .or_default()
                .insert(by[&c.clip_id]);
        }
        out
    }

    #[test]
    fn no_animation_is_in_two_splits_and_every_class_is_in_every_split() {
        let clips = clips();
        let by = split(
            &clips,
            &SplitConfig {
                seed: 7,
                ..SplitConfig::default()
            },
        );
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
        let a = split(&clips, &cfg(3));
        assert_eq!(a, split(&clips, &cfg(3)));
        let mut reversed = clips.clone();
        reversed.reverse();
        assert_eq!(a, split(&reversed, &cfg(3)), "input order does not matter");
        assert_ne!(a, split(&clips, &cfg(4)));
    }

    #[test]
    fn held_out_weather_is_only_in_test() {
        let clips = clips();
        let cfg = SplitConfig {
            hold_out: vec![(Key::Weather, "RAIN".into())],
            ..SplitConfig::default()
        };
        let a = assign(&items(&clips), &cfg).unwrap();
        let w = splits_of(&clips, &a.splits, Key::Weather);
        assert_eq!(w["RAIN"], BTreeSet::from([Split::Test]));
        for c in &clips {
            let held = c.weather == "RAIN";
            assert_eq!(a.grouped_by[&c.clip_id] == Grouping::HeldOut, held);
        }
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
        let by = split(&clips, &cfg);
        let w = splits_of(&clips, &by, Key::Weather);
        assert_eq!(w.values().map(BTreeSet::len).max(), Some(1));
        let all: BTreeSet<Split> = w.values().flatten().copied().collect();
        assert_eq!(all, BTreeSet::from([Split::Train, Split::Test]));
    }

    #[test]
    fn a_single_group_goes_to_train_and_bad_ratios_are_refused() {
        let clips = vec![record("a", "x", "x0", "CLEAR")];
        let by = split(&clips, &SplitConfig::default());
        assert_eq!(by["a"], Split::Train);
        for ratios in [[0.0, 0.0, 0.0], [-1.0, 1.0, 1.0], [f64::NAN, 1.0, 0.0]] {
            assert!(
                assign(
                    &items(&clips),
                    &SplitConfig {
                        ratios,
                        ..SplitConfig::default()
                    }
                )
                .is_err()
            );
        }
    }

    /// One class in the demo's shape: `animations` source animations × 2 variants × 2 scenes ×
    /// 3 viewpoints.
    fn demo_class(class: &str, animations: u32) -> Vec<ClipRecord> {
        let mut out = Vec::new();
        for a in 0..animations {
            for v in 0..2 {
                for s in 0..2 {
                    for c in 0..3 {
                        let id = format!("{class}{a}_v{v}_s{s}_c{c}");
                        let mut r = record(&id, class, &format!("{class}{a}"), "CLEAR");
                        (r.variant, r.scene, r.viewpoint) = (v, s, c);
                        out.push(r);
                    }
                }
            }
        }
        out
    }

    /// Clips of `class` per split: train, val, test.
    fn per_split(clips: &[ClipRecord], by: &BTreeMap<String, Split>, class: &str) -> [usize; 3] {
        let mut n = [0; 3];
        for c in clips.iter().filter(|c| c.label == class) {
            let split = by[&c.clip_id];
            n[Split::ALL.iter().position(|s| *s == split).unwrap()] += 1;
        }
        n
    }

    #[test]
    fn three_groups_give_one_each_and_train_keeps_one() {
        let d = [0.7, 0.15, 0.15];
        assert_eq!(allocate(3, d), [1, 1, 1]);
        assert_eq!(allocate(4, d), [2, 1, 1]);
        assert_eq!(allocate(10, d), [6, 2, 2]);
        assert_eq!(allocate(3, [0.98, 0.01, 0.01]), [1, 1, 1]);
        assert_eq!(allocate(3, [0.1, 0.45, 0.45]), [1, 1, 1]);
        assert_eq!(allocate(5, [0.1, 0.45, 0.45]), [1, 2, 2]);
        // Fewer groups than splits: as rounded, train first.
        assert_eq!(allocate(2, d), [2, 0, 0]);
        assert_eq!(allocate(2, [0.1, 0.45, 0.45]), [1, 0, 1]);
        assert_eq!(allocate(1, d), [1, 0, 0]);
        // A zero ratio gets nothing; a zero train ratio keeps nothing for train.
        assert_eq!(allocate(3, [0.5, 0.0, 0.5]), [1, 0, 2]);
        assert_eq!(allocate(3, [0.0, 0.5, 0.5]), [0, 1, 2]);
        assert_eq!(allocate(0, d), [0, 0, 0]);
        // Through assign: a class of three source animations is split 1/1/1.
        let clips: Vec<ClipRecord> = (0..6)
            .map(|i| record(&format!("c{i}"), "wave", &format!("w{}", i % 3), "CLEAR"))
            .collect();
        let a = assign(&items(&clips), &SplitConfig::default()).unwrap();
        assert_eq!(per_split(&clips, &a.splits, "wave"), [2, 2, 2]);
        assert!(a.refined.is_empty());
    }

    #[test]
    fn a_class_of_one_animation_is_split_by_scene_and_says_what_leaks() {
        let mut clips = demo_class("wave", 1);
        clips.extend(demo_class("walk", 1));
        let a = assign(&items(&clips), &SplitConfig::default()).unwrap();
        for class in ["walk", "wave"] {
            // 4 scenes of 3 viewpoints: 2/1/1 scenes.
            assert_eq!(per_split(&clips, &a.splits, class), [6, 3, 3], "{class}");
        }
        for (scene, splits) in splits_of(&clips, &a.splits, Key::Scene) {
            assert_eq!(splits.len(), 1, "{scene} in {splits:?}");
        }
        assert!(
            a.grouped_by
                .values()
                .all(|g| *g == Grouping::By(Key::Scene))
        );
        let said: Vec<String> = a.refined.iter().map(ToString::to_string).collect();
        assert_eq!(
            said,
            [
                "class walk: 1 source animation for 3 splits, split by scene instead: the same motion (source animation and variant) is in more than one split, in other scenes",
                "class wave: 1 source animation for 3 splits, split by scene instead: the same motion (source animation and variant) is in more than one split, in other scenes",
            ]
        );
        // Two source animations of 2 variants each: 4 variants are enough.
        let a = assign(&items(&demo_class("run", 2)), &SplitConfig::default()).unwrap();
        assert_eq!(a.refined[0].used, Key::Variant);
        assert!(a.refined[0].to_string().contains("2 source animations"));
        // Too few clips to fill the splits: nothing to refine, all in train.
        let two = vec![
            record("a", "x", "x0", "CLEAR"),
            record("b", "x", "x0", "CLEAR"),
        ];
        let a = assign(&items(&two), &SplitConfig::default()).unwrap();
        assert!(a.refined.is_empty());
        assert!(a.splits.values().all(|s| *s == Split::Train));
        // Keys outside the hierarchy are never refined.
        let cfg = SplitConfig {
            by: Key::Weather,
            ..SplitConfig::default()
        };
        let a = assign(&items(&demo_class("sit", 1)), &cfg).unwrap();
        assert!(a.refined.is_empty());
        assert!(a.splits.values().all(|s| *s == Split::Train));
    }

    #[test]
    fn no_split_is_empty_and_no_group_is_in_two_for_3_to_40_groups() {
        let ratio_sets = [
            [0.7, 0.15, 0.15],
            [0.8, 0.1, 0.1],
            [0.9, 0.05, 0.05],
            [0.34, 0.33, 0.33],
        ];
        for n in 3..=40_usize {
            // Two classes of n source animations, 1 to 3 clips each.
            let clips: Vec<ClipRecord> = ["jump", "wave"]
                .iter()
                .flat_map(|class| {
                    (0..n).flat_map(move |a| {
                        (0..=a % 3).map(move |k| {
                            record(
                                &format!("{class}{a}_{k}"),
                                class,
                                &format!("{class}{a}"),
                                "CLEAR",
                            )
                        })
                    })
                })
                .collect();
            for seed in 0..6 {
                for ratios in ratio_sets {
                    let cfg = SplitConfig {
                        ratios,
                        seed,
                        ..SplitConfig::default()
                    };
                    let by = split(&clips, &cfg);
                    assert_eq!(by.len(), clips.len());
                    for class in ["jump", "wave"] {
                        let counts = per_split(&clips, &by, class);
                        assert!(
                            counts.iter().all(|c| *c > 0),
                            "{n} {seed} {ratios:?}: {counts:?}"
                        );
                    }
                    for (anim, splits) in splits_of(&clips, &by, Key::Animation) {
                        assert_eq!(splits.len(), 1, "{n} {seed}: {anim} in {splits:?}");
                    }
                }
            }
        }
        // Classes with too few animations, any shape with at least 3 clips: refined, no split
        // empty, no group of the key used in two splits.
        for (animations, variants, scenes, viewpoints) in [
            (1, 1, 1, 3),
            (1, 1, 3, 1),
            (1, 3, 1, 1),
            (2, 1, 1, 2),
            (1, 2, 2, 1),
            (2, 1, 2, 1),
        ] {
            let mut clips = Vec::new();
            for (a, v, s, c) in every_index(animations, variants, scenes, viewpoints) {
                let mut r = record(&format!("k{a}{v}{s}{c}"), "k", &format!("k{a}"), "CLEAR");
                (r.variant, r.scene, r.viewpoint) = (v, s, c);
                clips.push(r);
            }
            for seed in 0..6 {
                let cfg = SplitConfig {
                    seed,
                    ..SplitConfig::default()
                };
                let a = assign(&items(&clips), &cfg).unwrap();
                let counts = per_split(&clips, &a.splits, "k");
                assert!(counts.iter().all(|c| *c > 0), "{clips:?}: {counts:?}");
                let used = a.refined[0].used;
                for (g, splits) in splits_of(&clips, &a.splits, used) {
                    assert_eq!(splits.len(), 1, "{g} in {splits:?}");
                }
            }
        }
    }

    /// Every (animation, variant, scene, viewpoint) below the given counts.
    fn every_index(a: u32, v: u32, s: u32, c: u32) -> Vec<(u32, u32, u32, u32)> {
        let mut out = Vec::new();
        for i in 0..a {
            for j in 0..v {
                for k in 0..s {
                    for l in 0..c {
                        out.push((i, j, k, l));
                    }
                }
            }
        }
        out
    }

    #[test]
    fn every_clip_cut_from_a_segment_takes_the_segments_split_from_the_plan() {
        let plan = demo_class("wave", 1);
        let planned = items(&plan);
        // Each planned segment cut into three windows.
        let windows: Vec<ClipRecord> = plan
            .iter()
            .flat_map(|seg| {
                (0..3).map(move |k| {
                    let mut c = seg.clone();
                    c.clip_id = format!("{}-w{k:03}", seg.clip_id);
                    c
                })
            })
            .collect();
        let cfg = SplitConfig {
            by: Key::Clip,
            ..SplitConfig::default()
        };
        let whole = assign_clips(Some(&planned), &plan, &cfg).unwrap();
        let cut = assign_clips(Some(&planned), &windows, &cfg).unwrap();
        assert_eq!(cut.splits.len(), windows.len());
        for c in &windows {
            assert_eq!(
                cut.splits[&c.clip_id], whole.splits[&c.segment_id],
                "{}",
                c.clip_id
            );
        }
        // Without a plan too: the 12 segments, not the 36 windows, are split (8/2/2 segments).
        let alone = assign_clips(None, &windows, &cfg).unwrap();
        assert_eq!(per_split(&windows, &alone.splits, "wave"), [24, 6, 6]);
    }

    #[test]
    fn given_the_plan_any_subset_of_captures_gets_the_same_splits() {
        // Captures of one animation each (`session = "animation"`): wave 1, walk 3, run 2.
        let mut plan = demo_class("wave", 1);
        plan.extend(demo_class("walk", 3));
        plan.extend(demo_class("run", 2));
        let captures: Vec<Vec<ClipRecord>> = ["wave0", "walk0", "walk1", "walk2", "run0", "run1"]
            .iter()
            .map(|a| plan.iter().filter(|c| c.animation == *a).cloned().collect())
            .collect();
        let planned = items(&plan);
        let cfg = SplitConfig {
            seed: 11,
            ..SplitConfig::default()
        };
        let whole = assign_clips(Some(&planned), &plan, &cfg).unwrap();
        assert_eq!(whole.splits, assign(&planned, &cfg).unwrap().splits);
        let mut differs_without_plan = false;
        for mask in 1..(1_u32 << captures.len()) {
            let subset: Vec<ClipRecord> = captures
                .iter()
                .enumerate()
                .filter(|(i, _)| mask & (1 << i) != 0)
                .flat_map(|(_, c)| c.iter().cloned())
                .collect();
            let a = assign_clips(Some(&planned), &subset, &cfg).unwrap();
            assert_eq!(a.splits.len(), subset.len());
            for c in &subset {
                assert_eq!(a.splits[&c.clip_id], whole.splits[&c.clip_id], "{mask:b}");
                assert_eq!(a.grouped_by[&c.clip_id], whole.grouped_by[&c.clip_id]);
            }
            assert_eq!(a.refined, whole.refined);
            let alone = assign_clips(None, &subset, &cfg).unwrap();
            differs_without_plan |= subset
                .iter()
                .any(|c| alone.splits[&c.clip_id] != whole.splits[&c.clip_id]);
        }
        assert!(
            differs_without_plan,
            "without the plan, some captures' splits depend on what else is trimmed"
        );
        // A clip the plan does not list is split with the rest.
        let mut extra = record("stray", "wave", "stray0", "CLEAR");
        extra.variant = 9;
        let mut with_extra = captures[0].clone();
        with_extra.push(extra);
        let a = assign_clips(Some(&planned), &with_extra, &cfg).unwrap();
        assert_eq!(a.splits.len(), with_extra.len());
    }
}
