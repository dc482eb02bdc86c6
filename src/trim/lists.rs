//! The annotation files, all written from one class list and the manifest's complete clips, each
//! atomically (a hidden temporary sibling, synced, then renamed), so a list is either the old
//! one or the new one, never half of one.
//!
//! Formats (paths relative to the dataset folder, which is MMAction2's `data_prefix`):
//! - `classes.txt`: one label per line, sorted; line index = class id (0-based). Written once:
//!   a later run with other classes is refused ([`ensure_classes`]). `label_map.json`:
//!   `{label: id}` in id order.
//! - `kinetics_<split>.csv`: Kinetics-700's header `label,youtube_id,time_start,time_end,split`;
//!   `label` is the original label, CSV-quoted when it holds a space, comma, quote or line break
//!   (RFC 4180); `youtube_id` is the clip id; the times are the clip's start and end in its
//!   capture video, seconds with three decimals (not Kinetics' whole seconds: our clips are
//!   shorter than a second's rounding can describe).
//! - `<split>_list_videos.txt`: MMAction2 `VideoDataset` lines `<path> <label_id>`, single
//!   space, no trailing space, LF; paths never contain spaces (they are sanitised).
//! - `<split>_list_rawframes.txt`: MMAction2 `RawframeDataset` lines
//!   `<dir> <total_frames> <label_id>`, frames `img_00001.jpg` … (1-based).
//! - `activitynet.json`: ActivityNet 1.3's ground-truth shape, one entry per capture video with
//!   one annotation per clip, keyed by the video's stem (by `<bag>/<video>` where two captures'
//!   videos share a stem); an annotation's `segment` is the clip's action span in the capture
//!   video (seconds), `clip_segment` the clip itself, `action_span` the span in every frame of
//!   reference ([`super::ActionSpan`]); `subset` is the split when all its clips share one, else
//!   `mixed` (each annotation also carries its own `subset`).
//! - `clips.jsonl`: every clip's record (source animation, variant, weather, time, location,
//!   character, camera, seed, clip policy, part, action span, …) plus its `split` and `split_by`, what it shares its split with
//!   (`animation`, or the finer `variant`, `scene`, `clip` its class fell back to, …, or
//!   `held-out`).

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use super::split::{Assignment, Split};
use super::{ClipRecord, TrimError};

/// The annotations folder inside the dataset folder.
pub const ANNOTATIONS_DIR: &str = "annotations";

/// Writes `bytes` to `path` so that it appears only complete ([`crate::atomic_file::write`]).
///
/// # Errors
/// [`TrimError::Io`] naming `path`; `path` is left as it was.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), TrimError> {
    crate::atomic_file::write(path, bytes).map_err(TrimError::io("write", path))
}

/// Makes sure `dir/annotations/classes.txt` lists exactly `labels` (sorted, unique): writes it
/// if absent, refuses if it lists others.
///
/// # Errors
/// [`TrimError::ClassesChanged`]; [`TrimError::NoLabels`], [`TrimError::LabelsUnsorted`] or
/// [`TrimError::LabelLineBreak`] for no, unsorted or duplicate labels or a label with a line
/// break; [`TrimError::Io`].
pub fn ensure_classes(dir: &Path, labels: &[String]) -> Result<(), TrimError> {
    if labels.is_empty() {
        return Err(TrimError::NoLabels);
    }
    if labels.windows(2).any(|w| w[0] >= w[1]) {
        return Err(TrimError::LabelsUnsorted {
            labels: labels.to_vec(),
        });
    }
    if let Some(l) = labels.iter().find(|l| l.contains(['\n', '\r'])) {
        return Err(TrimError::LabelLineBreak { label: l.clone() });
    }
    let ann = dir.join(ANNOTATIONS_DIR);
    std::fs::create_dir_all(&ann).map_err(TrimError::io("create", &ann))?;
    let path = ann.join("classes.txt");
    match crate::text_file::read_to_string(&path) {
        Ok(text) => {
            let existing: Vec<String> = text.lines().map(str::to_owned).collect();
            if existing != labels {
                return Err(TrimError::ClassesChanged {
                    path,
                    existing,
                    new: labels.to_vec(),
                });
            }
            Ok(())
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            let mut text = labels.join("\n");
            text.push('\n');
            write_atomic(&path, text.as_bytes())?;
            let map: serde_json::Map<String, Value> = labels
                .iter()
                .enumerate()
                .map(|(i, l)| (l.clone(), json!(i)))
                .collect();
            let map_path = ann.join("label_map.json");
            let mut text = serde_json::to_string_pretty(&Value::Object(map))
                .map_err(TrimError::json(&map_path))?;
            text.push('\n');
            write_atomic(&map_path, text.as_bytes())
        }
        Err(e) => Err(TrimError::io("read", &path)(e)),
    }
}

/// `field` as a CSV field: quoted (with `"` doubled) when it holds a space, comma, quote or line
/// break.
#[must_use]
pub fn csv_field(field: &str) -> String {
    if field.contains([' ', ',', '"', '\n', '\r']) {
        format!("\"{}\"", field.replace('"', "\"\""))
    } else {
        field.to_owned()
    }
}

/// What [`write_lists`] wrote.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ListSummary {
    /// Clips per split.
    pub clips: BTreeMap<Split, usize>,
    /// Files written.
    pub files: Vec<PathBuf>,
}

impl ListSummary {
    /// Clips per split, for people: `train 6, val 3, test 3`.
    #[must_use]
    pub fn split_counts(&self) -> String {
        Split::ALL
            .iter()
            .map(|s| format!("{} {}", s.name(), self.clips.get(s).copied().unwrap_or(0)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// Writes every list into `dir/annotations` from `clips` (complete clips, by id) and their
/// splits (and how each was grouped). Lists for a split without clips are written empty, so
/// stale ones never survive.
///
/// # Errors
/// [`TrimError::Io`]; [`TrimError::NoSplit`] if a clip has no split (then nothing is written);
/// [`TrimError::Json`].
pub fn write_lists(
    dir: &Path,
    clips: &BTreeMap<String, ClipRecord>,
    splits: &Assignment,
) -> Result<ListSummary, TrimError> {
    let ann = dir.join(ANNOTATIONS_DIR);
    std::fs::create_dir_all(&ann).map_err(TrimError::io("create", &ann))?;
    let assigned = clips
        .values()
        .map(|c| {
            splits
                .splits
                .get(&c.clip_id)
                .map(|s| (c, *s))
                .ok_or_else(|| TrimError::NoSplit {
                    clip_id: c.clip_id.clone(),
                })
        })
        .collect::<Result<Vec<Assigned<'_>>, TrimError>>()?;
    let mut summary = ListSummary::default();
    let mut write = |name: String, text: String| -> Result<(), TrimError> {
        let path = ann.join(name);
        write_atomic(&path, text.as_bytes())?;
        summary.files.push(path);
        Ok(())
    };
    let any_rawframes = clips.values().any(|c| c.rawframes.is_some());
    let mut counts = BTreeMap::new();
    for split in Split::ALL {
        let in_split: Vec<&ClipRecord> = assigned
            .iter()
            .filter(|(_, s)| *s == split)
            .map(|(c, _)| *c)
            .collect();
        counts.insert(split, in_split.len());
        let name = split.name();
        write(
            format!("kinetics_{name}.csv"),
            kinetics_csv(&in_split, split),
        )?;
        write(format!("{name}_list_videos.txt"), video_list(&in_split))?;
        if any_rawframes {
            write(
                format!("{name}_list_rawframes.txt"),
                rawframe_list(&in_split),
            )?;
        }
    }
    write("clips.jsonl".into(), clips_jsonl(&assigned, splits, &ann)?)?;
    write(
        "activitynet.json".into(),
        activitynet_json(&assigned, &ann)?,
    )?;
    summary.clips = counts;
    Ok(summary)
}

/// A complete clip and its split.
type Assigned<'c> = (&'c ClipRecord, Split);

/// `kinetics_<split>.csv`: Kinetics-700's header and one line per clip of `split`.
fn kinetics_csv(clips: &[&ClipRecord], split: Split) -> String {
    let mut csv = String::from("label,youtube_id,time_start,time_end,split\n");
    for c in clips {
        csv.push_str(&format!(
            "{},{},{:.3},{:.3},{}\n",
            csv_field(&c.label),
            c.clip_id,
            c.start_s,
            c.end_s,
            split.name()
        ));
    }
    csv
}

/// `<split>_list_videos.txt`: MMAction2 `VideoDataset` lines `<path> <label_id>`.
fn video_list(clips: &[&ClipRecord]) -> String {
    clips.iter().fold(String::new(), |mut list, c| {
        let _ = writeln!(list, "{} {}", c.video, c.label_id);
        list
    })
}

/// `<split>_list_rawframes.txt`: MMAction2 `RawframeDataset` lines
/// `<dir> <total_frames> <label_id>`, for the clips that have frames.
fn rawframe_list(clips: &[&ClipRecord]) -> String {
    clips
        .iter()
        .filter_map(|c| {
            c.rawframes
                .as_ref()
                .map(|dir| format!("{dir} {} {}\n", c.frame_count, c.label_id))
        })
        .collect()
}

/// `clips.jsonl`: every clip's record plus its `split` and `split_by`, one JSON object a line.
fn clips_jsonl(
    clips: &[Assigned<'_>],
    splits: &Assignment,
    ann: &Path,
) -> Result<String, TrimError> {
    let mut jsonl = String::new();
    for (c, split) in clips {
        let mut v = serde_json::to_value(c).map_err(TrimError::json(&ann.join("clips.jsonl")))?;
        if let Value::Object(m) = &mut v {
            m.insert("split".into(), json!(split.name()));
            if let Some(g) = splits.grouped_by.get(&c.clip_id) {
                m.insert("split_by".into(), json!(g.name()));
            }
        }
        jsonl.push_str(&v.to_string());
        jsonl.push('\n');
    }
    Ok(jsonl)
}

/// One untrimmed capture in `activitynet.json`: its annotations, the splits of its clips, and
/// its first clip.
type CaptureEntry<'c> = (Vec<Value>, Vec<Split>, &'c ClipRecord);

/// `activitynet.json`: ActivityNet 1.3's ground truth, the untrimmed captures with every
/// trimmed segment.
fn activitynet_json(clips: &[Assigned<'_>], ann: &Path) -> Result<String, TrimError> {
    // One entry per capture (video and bag).
    let mut database: BTreeMap<(&str, &str), CaptureEntry<'_>> = BTreeMap::new();
    let mut taxonomy: BTreeMap<u32, Value> = BTreeMap::new();
    for (c, split) in clips {
        let entry = database
            .entry((c.capture_video.as_str(), c.capture_bag.as_str()))
            .or_insert_with(|| (Vec::new(), Vec::new(), *c));
        // The action where the clip says it is (older records: the whole clip).
        let segment = c
            .action_span
            .as_ref()
            .map_or([c.start_s, c.end_s], |a| [a.video_start_s, a.video_end_s]);
        entry.0.push(json!({
            "segment": segment,
            "label": c.label,
            "label_id": c.label_id,
            "clip_id": c.clip_id,
            "clip_segment": [c.start_s, c.end_s],
            "action_span": c.action_span,
            "subset": split.activitynet_subset(),
        }));
        entry.1.push(*split);
        taxonomy.entry(c.label_id).or_insert_with(
            || json!({"nodeId": c.label_id, "nodeName": c.label, "parentName": c.category}),
        );
    }
    let doc = json!({
        "version": "VERSION 1.3",
        "taxonomy": taxonomy.into_values().collect::<Vec<_>>(),
        "database": activitynet_database(database),
    });
    let mut text = serde_json::to_string_pretty(&doc)
        .map_err(TrimError::json(&ann.join("activitynet.json")))?;
    text.push('\n');
    Ok(text)
}

/// The `database` object of `activitynet.json` from the captures, keyed by the video's stem, as
/// ActivityNet keys by video id; captures whose videos share a stem (`a/cap.mp4` and
/// `b/cap.mp4`) are told apart by their bag instead of being merged.
fn activitynet_database(
    database: BTreeMap<(&str, &str), CaptureEntry<'_>>,
) -> serde_json::Map<String, Value> {
    let stem = |video: &str| -> String {
        Path::new(video)
            .file_stem()
            .map_or_else(|| video.to_owned(), |s| s.to_string_lossy().into_owned())
    };
    let mut stems: BTreeMap<String, usize> = BTreeMap::new();
    for (video, _) in database.keys() {
        *stems.entry(stem(video)).or_default() += 1;
    }
    let mut db = serde_json::Map::new();
    for ((video, bag), (mut annotations, splits, first)) in database {
        let key = match stem(video) {
            s if stems[&s] == 1 => s,
            _ => format!("{bag}/{video}"),
        };
        annotations.sort_by(|a, b| {
            a["segment"][0]
                .as_f64()
                .partial_cmp(&b["segment"][0].as_f64())
                .unwrap_or(std::cmp::Ordering::Equal)
        });
        let subset = if splits.iter().all(|s| *s == splits[0]) {
            splits[0].activitynet_subset()
        } else {
            "mixed"
        };
        db.insert(
            key,
            json!({
                "subset": subset,
                "duration": first.capture_duration_s,
                "resolution": first.capture_resolution,
                "url": first.capture_video,
                "annotations": annotations,
            }),
        );
    }
    db
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use super::{csv_field, ensure_classes, write_lists};
    use crate::trim::split::tests::record;
    use crate::trim::split::{Assignment, Grouping, Key, Split};

    #[test]
    fn labels_are_quoted_only_when_needed() {
        assert_eq!(csv_field("wave"), "wave");
        assert_eq!(csv_field("air drumming"), "\"air drumming\"");
        assert_eq!(
            csv_field("say \"hi\", then go"),
            "\"say \"\"hi\"\", then go\""
        );
        assert_eq!(csv_field("ñandú"), "ñandú");
    }

    #[test]
    fn classes_are_written_once_and_never_change() {
        let dir = tempfile::tempdir().unwrap();
        let labels = vec!["air drumming".to_owned(), "wave".to_owned()];
        ensure_classes(dir.path(), &labels).unwrap();
        ensure_classes(dir.path(), &labels).unwrap();
        let text = std::fs::read_to_string(dir.path().join("annotations/classes.txt")).unwrap();
        assert_eq!(text, "air drumming\nwave\n");
        let map: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join("annotations/label_map.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(map["wave"], 1);
        let err = ensure_classes(dir.path(), &["wave".to_owned()]).unwrap_err();
        assert!(err.to_string().contains("classes.txt"), "{err}");
        assert!(ensure_classes(dir.path(), &["b".to_owned(), "a".to_owned()]).is_err());
    }

    #[test]
    fn lists_have_the_exact_formats() {
        let dir = tempfile::tempdir().unwrap();
        let mut a = record("a1", "air drumming", "a0", "CLEAR");
        a.label_dir = "air_drumming".into();
        a.video = "videos/air_drumming/a1.mp4".into();
        a.start_s = 1.5;
        a.end_s = 2.5;
        let mut b = record("b1", "wave", "b0", "RAIN");
        b.label_id = 1;
        b.rawframes = Some("rawframes/wave/b1".into());
        let clips: BTreeMap<String, _> =
            [a, b].into_iter().map(|c| (c.clip_id.clone(), c)).collect();
        let splits = Assignment {
            splits: BTreeMap::from([
                ("a1".to_owned(), Split::Train),
                ("b1".to_owned(), Split::Test),
            ]),
            grouped_by: BTreeMap::from([
                ("a1".to_owned(), Grouping::By(Key::Scene)),
                ("b1".to_owned(), Grouping::HeldOut),
            ]),
            refined: Vec::new(),
        };
        let s = write_lists(dir.path(), &clips, &splits).unwrap();
        assert_eq!(s.clips[&Split::Train], 1);
        assert_eq!(s.clips[&Split::Val], 0);
        let read =
            |n: &str| std::fs::read_to_string(dir.path().join("annotations").join(n)).unwrap();
        assert_eq!(
            read("kinetics_train.csv"),
            "label,youtube_id,time_start,time_end,split\n\"air drumming\",a1,1.500,2.500,train\n"
        );
        assert_eq!(
            read("train_list_videos.txt"),
            "videos/air_drumming/a1.mp4 0\n"
        );
        assert_eq!(read("test_list_videos.txt"), "videos/wave/b1.mp4 1\n");
        assert_eq!(read("val_list_videos.txt"), "");
        assert_eq!(read("test_list_rawframes.txt"), "rawframes/wave/b1 30 1\n");
        assert_eq!(read("train_list_rawframes.txt"), "");
        let anet: serde_json::Value = serde_json::from_str(&read("activitynet.json")).unwrap();
        assert_eq!(anet["version"], "VERSION 1.3");
        assert_eq!(anet["database"]["c"]["subset"], "mixed");
        assert_eq!(anet["database"]["c"]["annotations"][0]["label"], "wave");
        assert_eq!(anet["database"]["c"]["annotations"][1]["segment"][0], 1.5);
        // Captures are told apart by video and bag, even where the videos' names agree.
        let mut c = record("c1", "wave", "c0", "CLEAR");
        (c.capture_video, c.capture_bag) = ("c.mkv".into(), "other.mcap".into());
        let mut more = clips.clone();
        more.insert(c.clip_id.clone(), c);
        let mut more_splits = splits.clone();
        more_splits.splits.insert("c1".into(), Split::Val);
        write_lists(dir.path(), &more, &more_splits).unwrap();
        let anet: serde_json::Value = serde_json::from_str(&read("activitynet.json")).unwrap();
        let db = anet["database"].as_object().unwrap();
        let mut keys: Vec<&String> = db.keys().collect();
        keys.sort();
        assert_eq!(keys, ["c.mcap/c.mp4", "other.mcap/c.mkv"]);
        assert_eq!(
            db["c.mcap/c.mp4"]["annotations"].as_array().unwrap().len(),
            2
        );
        assert_eq!(db["other.mcap/c.mkv"]["subset"], "validation");
        assert_eq!(db["other.mcap/c.mkv"]["url"], "c.mkv");
        write_lists(dir.path(), &clips, &splits).unwrap();

        let meta = read("clips.jsonl");
        assert_eq!(meta.lines().count(), 2);
        let first: serde_json::Value = serde_json::from_str(meta.lines().next().unwrap()).unwrap();
        assert_eq!(first["split"], "train");
        assert_eq!(first["split_by"], "scene");
        assert_eq!(first["weather"], "CLEAR");
        // No temporary files left behind.
        for e in std::fs::read_dir(dir.path().join("annotations")).unwrap() {
            assert!(!e.unwrap().file_name().to_string_lossy().starts_with('.'));
        }
    }
}
