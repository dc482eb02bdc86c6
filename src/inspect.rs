//! What an MCAP file holds and whether all of it can be read: the report `autoact info` prints.
//!
//! [`inspect`] reads every message once: per channel its schema, encodings, counts, log-time range
//! and, for the message types autoact knows, whether each decodes, the layouts it names and the
//! frame stamps of each animation stream (person and variant); the `/segments` of a capture bag
//! give the dataset's hierarchy. The [`Report`] renders as a table or a JSON document and says
//! which checks failed (a ROS 2 profile, an index, ROS 2 encodings, decodable messages, log times
//! in order, unique clip ids) and whether parts of the file could not be read at all.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use serde_json::json;

use crate::mcap_io::{BagReader, McapIoError};
use crate::ros::autoact_msgs::{BoneFrame, Segment, Skeleton3D};
use crate::ros::{self, RosMessage};
use crate::table::table;

/// What an MCAP file (or rosbag2 folder) holds, and what is wrong with it.
#[derive(Debug)]
pub struct Report {
    /// The file as given.
    path: PathBuf,
    /// The header's profile (`ros2` for ROS 2 bags).
    profile: String,
    /// The header's writer library.
    library: String,
    /// Per topic, what its messages hold.
    channels: BTreeMap<String, ChannelStats>,
    /// Every metadata record: name and key-value pairs.
    metadata: Vec<(String, BTreeMap<String, String>)>,
    /// The dataset hierarchy its `/segments` describe.
    hierarchy: Hierarchy,
    /// Parts of the file that could not be read (their messages are lost).
    unreadable: Vec<String>,
    /// Every failed check, the unreadable parts last.
    problems: Vec<String>,
    /// Per pose track: bone-length spread and ground (see [`bodies`]).
    bodies: Vec<BodyReport>,
}

/// Reads every message of the MCAP file or rosbag2 folder at `path` and checks it.
///
/// # Errors
/// A file that cannot be opened or is not MCAP. Damage past the header is not an error: it is
/// reported (see [`crate::outcome::LostInput::lost_input`]).
pub fn inspect(path: &Path) -> Result<Report, McapIoError> {
    let readers = BagReader::open_all(path)?;
    let (profile, library) = readers
        .first()
        .and_then(BagReader::header)
        .unwrap_or_default();
    let Scan {
        channels,
        hierarchy,
        unreadable,
    } = scan(&readers);
    let metadata: Vec<_> = readers.iter().flat_map(BagReader::metadata).collect();
    let indexed = readers.iter().all(BagReader::has_chunk_index);
    let mut problems = file_problems(&profile, indexed);
    problems.extend(channel_problems(&channels));
    if hierarchy.duplicate_ids > 0 {
        problems.push(format!(
            "/segments: {} segments repeat an id (a segment id must be unique)",
            hierarchy.duplicate_ids
        ));
    }
    problems.extend(unreadable.iter().cloned());
    Ok(Report {
        path: path.to_path_buf(),
        profile,
        library,
        channels,
        metadata,
        hierarchy,
        unreadable,
        problems,
        bodies: bodies(path),
    })
}

/// What one pass over the messages found.
struct Scan {
    channels: BTreeMap<String, ChannelStats>,
    hierarchy: Hierarchy,
    unreadable: Vec<String>,
}

/// One pass over every message of every file, in file order.
fn scan(readers: &[BagReader]) -> Scan {
    let mut channels: BTreeMap<String, ChannelStats> = BTreeMap::new();
    let mut unreadable = Vec::new();
    let mut hierarchy = Hierarchy::default();
    for item in readers.iter().flat_map(BagReader::messages) {
        let msg = match item {
            Ok(m) => m,
            Err(e) => {
                unreadable.push(e.to_string());
                continue;
            }
        };
        let stats = channels.entry(msg.channel.topic.clone()).or_default();
        if stats.count == 0 {
            stats.schema = msg.channel.schema_name().to_string();
            stats.schema_encoding = msg
                .channel
                .schema
                .as_ref()
                .map(|s| s.encoding.clone())
                .unwrap_or_default();
            stats
                .message_encoding
                .clone_from(&msg.channel.message_encoding);
        }
        if stats.first.is_some() && msg.log_time < stats.last {
            stats.non_monotonic += 1;
        }
        stats.first.get_or_insert(msg.log_time);
        stats.last = stats.last.max(msg.log_time);
        stats.count += 1;
        let schema = stats.schema.clone();
        if schema == Segment::TYPE_NAME
            && let Ok(seg) = ros::cdr::decode::<Segment>(&msg.data)
        {
            hierarchy.add(&seg);
        }
        if let Some(Err(e)) = check_message(&schema, &msg.data, msg.log_time, stats) {
            stats.undecodable += 1;
            stats
                .first_undecodable
                .get_or_insert((msg.index_on_channel, e.to_string()));
        }
    }
    Scan {
        channels,
        hierarchy,
        unreadable,
    }
}

/// The file-level checks: a ROS 2 profile, and chunk indexes for indexed readers.
fn file_problems(profile: &str, indexed: bool) -> Vec<String> {
    let mut problems = Vec::new();
    if profile != "ros2" {
        problems.push(format!(
            "header profile is `{profile}`, not `ros2` (rosbags refuses such files)"
        ));
    }
    if !indexed {
        problems.push(
            "no summary with chunk indexes (indexed readers, e.g. Foxglove's, may show nothing)"
                .into(),
        );
    }
    problems
}

/// The per-channel checks: ROS 2 encodings, decodable messages, log times in order.
fn channel_problems(channels: &BTreeMap<String, ChannelStats>) -> Vec<String> {
    let mut problems = Vec::new();
    for (topic, c) in channels {
        if c.schema_encoding != "ros2msg" {
            problems.push(format!(
                "{topic}: schema encoding `{}`, not `ros2msg`",
                c.schema_encoding
            ));
        }
        if c.message_encoding != "cdr" {
            problems.push(format!(
                "{topic}: message encoding `{}`, not `cdr`",
                c.message_encoding
            ));
        }
        if let Some((index, why)) = &c.first_undecodable {
            problems.push(format!(
                "{topic}: {} messages do not decode as {} (first: message {index}: {why})",
                c.undecodable, c.schema
            ));
        }
        if c.non_monotonic > 0 {
            problems.push(format!(
                "{topic}: {} messages are logged earlier than the one before",
                c.non_monotonic
            ));
        }
    }
    problems
}

impl Report {
    /// Whether every check passed.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.problems.is_empty()
    }

    /// Every failed check, in the order the report lists them.
    #[must_use]
    pub fn problems(&self) -> &[String] {
        &self.problems
    }

    /// The verdict line.
    fn verdict(&self) -> &'static str {
        if self.is_valid() {
            "valid: every message is readable by ROS 2 tools and autoact"
        } else {
            "problems found"
        }
    }

    /// The report as text: the file's header and time range, a table of its channels, its
    /// metadata, the hierarchy of its `/segments`, the verdict and each problem.
    #[must_use]
    pub fn table(&self) -> String {
        let channels = &self.channels;
        let start = channels.values().filter_map(|c| c.first).min();
        let end = channels.values().map(|c| c.last).max();
        let mut s = format!(
            "file: {}\nprofile: {}\nlibrary: {}\n",
            self.path.display(),
            self.profile,
            self.library
        );
        if let (Some(a), Some(b)) = (start, end) {
            let span = crate::skeleton::pose::nanos_to_secs(b - a);
            s.push_str(&format!(
                "time: {} .. {} ({span:.3} s; {a} .. {b} ns)\n",
                crate::instant::iso_8601(a),
                crate::instant::iso_8601(b)
            ));
        }
        s.push_str(&format!(
            "messages: {}\n\n",
            channels.values().map(|c| c.count).sum::<u64>()
        ));
        let rows: Vec<Vec<String>> = channels.iter().map(|(t, c)| c.row(t)).collect();
        s.push_str(&table(
            &[
                "topic",
                "schema",
                "messages",
                "rate_hz",
                "fps",
                "layout/rig",
                "tracks",
                "variants",
            ],
            &rows,
        ));
        for (name, m) in &self.metadata {
            let kv: Vec<String> = m
                .iter()
                .filter(|(_, v)| !v.is_empty())
                .map(|(k, v)| {
                    if v.contains('\n') {
                        format!("{k}=({} lines)", v.lines().count())
                    } else {
                        format!("{k}={v}")
                    }
                })
                .collect();
            s.push_str(&format!("\nmetadata {name}: {}", kv.join(" ")));
        }
        if !self.hierarchy.is_empty() {
            s.push_str(&format!("\n\n{}", self.hierarchy.tree()));
        }
        s.push_str(&bodies_text(&self.bodies));
        s.push_str(&format!("\n\nverdict: {}\n", self.verdict()));
        for p in &self.problems {
            s.push_str(&format!("  - {p}\n"));
        }
        s
    }

    /// The report as one JSON document: every channel with its streams, the metadata, the
    /// hierarchy, whether the file is valid and its problems.
    #[must_use]
    pub fn json(&self) -> serde_json::Value {
        let ch: Vec<_> = self.channels.iter().map(|(t, c)| c.json(t)).collect();
        let md: Vec<_> = self
            .metadata
            .iter()
            .map(|(n, m)| json!({"name": n, "metadata": m}))
            .collect();
        json!({"file": self.path.display().to_string(), "profile": self.profile, "library": self.library, "channels": ch,
               "metadata": md, "hierarchy": self.hierarchy.json(), "bodies": bodies_json(&self.bodies), "valid": self.is_valid(), "problems": self.problems})
    }
}

/// What one channel holds.
#[derive(Debug, Default)]
struct ChannelStats {
    schema: String,
    schema_encoding: String,
    message_encoding: String,
    count: u64,
    first: Option<u64>,
    last: u64,
    undecodable: u64,
    first_undecodable: Option<(u64, String)>,
    non_monotonic: u64,
    layouts: BTreeSet<String>,
    /// Per animation stream (track, variant) of a `Skeleton3D` or `BoneFrame` channel: its frames'
    /// header stamps, in file order.
    streams: BTreeMap<(u64, u32), Vec<u64>>,
}

impl ChannelStats {
    /// Notes a frame of stream `(track, variant)` stamped `stamp_nanos`.
    fn add_frame(&mut self, track: u64, variant: u32, stamp_nanos: u64) {
        self.streams
            .entry((track, variant))
            .or_default()
            .push(stamp_nanos);
    }

    /// The track ids of its streams.
    fn tracks(&self) -> BTreeSet<u64> {
        self.streams.keys().map(|&(track, _)| track).collect()
    }

    /// The variants of its streams.
    fn variants(&self) -> BTreeSet<u32> {
        self.streams.keys().map(|&(_, variant)| variant).collect()
    }

    /// The frame rates of its streams, measured as export and convert measure a rate
    /// ([`crate::skeleton::pose::frame_rate`]: one over the median step), lowest and highest.
    fn frame_rate_range_hz(&self) -> Option<(f64, f64)> {
        self.streams
            .values()
            .filter_map(|stamps| crate::skeleton::pose::frame_rate(None, stamps))
            .fold(None, |range, r| match range {
                None => Some((r, r)),
                Some((lo, hi)) => Some((f64::min(lo, r), f64::max(hi, r))),
            })
    }
    /// The channel's message rate, as `mcap info` gives it: messages less one over the span of
    /// their log times.
    fn rate_hz(&self) -> Option<f64> {
        let span = crate::skeleton::pose::nanos_to_secs(self.last - self.first?);
        #[expect(clippy::cast_precision_loss, reason = "display only")]
        let steps = self.count.saturating_sub(1) as f64;
        (span > 0.0).then(|| steps / span)
    }

    /// Its row of the channel table.
    fn row(&self, topic: &str) -> Vec<String> {
        vec![
            topic.to_string(),
            self.schema.clone(),
            self.count.to_string(),
            self.rate_hz()
                .map_or_else(|| "-".into(), |r| format!("{r:.2}")),
            self.frame_rate_range_hz()
                .map_or_else(String::new, show_rate_range),
            self.layouts.iter().cloned().collect::<Vec<_>>().join(", "),
            self.tracks()
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(","),
            self.variants()
                .iter()
                .map(ToString::to_string)
                .collect::<Vec<_>>()
                .join(","),
        ]
    }

    /// Its entry of the JSON report, with one entry per stream.
    fn json(&self, topic: &str) -> serde_json::Value {
        let streams: Vec<_> = self
            .streams
            .iter()
            .map(|(&(track, variant), stamps)| {
                json!({"track_id": track, "variant": variant, "frames": stamps.len(),
                       "first_stamp": stamps.iter().min(), "last_stamp": stamps.iter().max(),
                       "fps": crate::skeleton::pose::frame_rate(None, stamps)})
            })
            .collect();
        json!({"topic": topic, "schema": self.schema, "schema_encoding": self.schema_encoding, "message_encoding": self.message_encoding,
               "messages": self.count, "first_log_time": self.first, "last_log_time": self.last, "rate_hz": self.rate_hz(),
               "layouts": self.layouts, "tracks": self.tracks(), "variants": self.variants(), "streams": streams,
               "undecodable": self.undecodable})
    }
}

/// A rate range as one number when its ends agree to the shown precision.
fn show_rate_range((lo, hi): (f64, f64)) -> String {
    let (lo, hi) = (format!("{lo:.2}"), format!("{hi:.2}"));
    if lo == hi { lo } else { format!("{lo}-{hi}") }
}

/// Decodes one message of a type autoact knows, noting the layouts, tracks and variants it
/// names and the stamp of the frame it carries (its header's, else `log_time_nanos`); `None` for
/// other types.
fn check_message(
    schema: &str,
    data: &[u8],
    log_time_nanos: u64,
    stats: &mut ChannelStats,
) -> Option<Result<(), ros::cdr::CdrError>> {
    match schema {
        s if s == Skeleton3D::TYPE_NAME => Some(ros::cdr::decode::<Skeleton3D>(data).map(|m| {
            let stamp = m.header.stamp.to_nanos().unwrap_or(log_time_nanos);
            stats.add_frame(m.track_id, 0, stamp);
            stats.layouts.insert(m.layout);
        })),
        s if s == BoneFrame::TYPE_NAME => Some(ros::cdr::decode::<BoneFrame>(data).map(|m| {
            let stamp = crate::bags::animation::frame_stamp(&m, log_time_nanos);
            stats.add_frame(m.track_id, m.variant, stamp);
            stats.layouts.insert(format!("rig {}", m.rig));
        })),
        _ => ros::check_decodes(schema, data),
    }
}

/// Per animation: its variants, its scene ids, its segments.
type AnimationCounts = (BTreeSet<u32>, BTreeSet<String>, usize);

/// A dataset's recording hierarchy as its `/segments` describe it: per category, action and
/// animation, the variants, scenes and segments.
#[derive(Debug, Default)]
struct Hierarchy {
    /// (category, action) → label id and per animation: variants, scene ids, segments.
    classes: BTreeMap<(String, String), (u32, BTreeMap<String, AnimationCounts>)>,
    ids: BTreeSet<String>,
    duplicate_ids: usize,
}

impl Hierarchy {
    /// Counts one clip.
    fn add(&mut self, s: &Segment) {
        if !self.ids.insert(s.id.clone()) {
            self.duplicate_ids += 1;
        }
        let (_, animations) = self
            .classes
            .entry((s.category.clone(), s.action.clone()))
            .or_insert((s.label_id, BTreeMap::new()));
        let a = animations.entry(s.animation.clone()).or_default();
        a.0.insert(s.variant);
        a.1.insert(s.scene_id.clone());
        a.2 += 1;
    }

    /// Whether no clip was counted.
    fn is_empty(&self) -> bool {
        self.classes.is_empty()
    }

    /// The hierarchy as an indented tree: category, action, animation, with their counts.
    fn tree(&self) -> String {
        let animations: usize = self.classes.values().map(|(_, a)| a.len()).sum();
        let variants: usize = self
            .classes
            .values()
            .flat_map(|(_, a)| a.values().map(|v| v.0.len()))
            .sum();
        let scenes: usize = self
            .classes
            .values()
            .flat_map(|(_, a)| a.values().map(|v| v.1.len()))
            .sum();
        let categories: BTreeSet<&String> = self.classes.keys().map(|(c, _)| c).collect();
        let mut out = format!(
            "hierarchy (/segments): {} categories, {} actions, {animations} animations, {variants} variants, {scenes} scenes, {} segments{}\n",
            categories.len(),
            self.classes.len(),
            self.ids.len() + self.duplicate_ids,
            if self.duplicate_ids > 0 {
                format!(" ({} duplicate ids!)", self.duplicate_ids)
            } else {
                String::new()
            }
        );
        for category in categories {
            let segments: usize = self
                .classes
                .iter()
                .filter(|((c, _), _)| c == category)
                .flat_map(|(_, (_, a))| a.values().map(|v| v.2))
                .sum();
            out.push_str(&format!("  {category}: {segments} segments\n"));
            for ((_, action), (label, animations)) in
                self.classes.iter().filter(|((c, _), _)| c == category)
            {
                let segments: usize = animations.values().map(|v| v.2).sum();
                out.push_str(&format!(
                    "    {action} (label {label}): {segments} segments\n"
                ));
                for (name, (variants, scenes, segments)) in animations {
                    out.push_str(&format!(
                        "      {name}: {} variants, {} scenes, {segments} segments\n",
                        variants.len(),
                        scenes.len()
                    ));
                }
            }
        }
        out.trim_end().to_string()
    }

    /// The hierarchy as JSON: the segment count and one entry per class.
    fn json(&self) -> serde_json::Value {
        let classes: Vec<_> = self
            .classes
            .iter()
            .map(|((category, action), (label, animations))| {
                let anims: Vec<_> = animations
                    .iter()
                    .map(|(name, (v, s, c))| json!({"animation": name, "variants": v.len(), "scenes": s.len(), "segments": c}))
                    .collect();
                json!({"category": category, "action": action, "label_id": label, "animations": anims})
            })
            .collect();
        json!({"segments": self.ids.len() + self.duplicate_ids, "duplicate_ids": self.duplicate_ids, "classes": classes})
    }
}

impl crate::outcome::LostInput for Report {
    /// Whether parts of the file could not be read (damaged or cut-off chunks or records).
    fn lost_input(&self) -> bool {
        !self.unreadable.is_empty()
    }
}

/// One pose track's body: how much its bone lengths vary, and where its ground is.
#[derive(Debug)]
struct BodyReport {
    topic: String,
    track: u64,
    layout: String,
    stability: Vec<crate::skeleton::eval::LengthStability>,
    ground: Option<crate::skeleton::ground::Grounding>,
}

/// The pose tracks of a pose bag, each with its bone-length spread and its ground estimated
/// afresh ([`crate::skeleton::ground::estimate`]: a grounded track shows up ≈ 0° from +Z and its
/// feet ≈ 0 at contact). Other bags, and tracks in layouts autoact does not know, give none.
fn bodies(path: &Path) -> Vec<BodyReport> {
    use crate::skeleton::{ground, layout::Layout, lengths};
    let Ok(topics) = crate::bags::pose::read_pose_topics(path, None, None) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for ((topic, seq), layout) in topics.sequences.iter().zip(&topics.layouts) {
        let Ok(loaded) = Layout::load(layout) else {
            continue;
        };
        out.push(BodyReport {
            topic: topic.clone(),
            track: seq.track_id,
            layout: layout.clone(),
            stability: lengths::stability(seq, &loaded).unwrap_or_default(),
            ground: ground::estimate(seq, &loaded, 1).ok(),
        });
    }
    out
}

/// The bodies as text: per track its ground and its bone lengths, the most variable first.
fn bodies_text(bodies: &[BodyReport]) -> String {
    let mut s = String::new();
    for b in bodies {
        s.push_str(&format!(
            "\n\nbody {} track {} ({}):",
            b.topic, b.track, b.layout
        ));
        if let Some(g) = &b.ground {
            s.push_str(&format!(
                "\n  ground, estimated from the feet: {}",
                g.summary()
            ));
        }
        for line in crate::skeleton::lengths::report_lines(&b.stability) {
            s.push_str(&format!("\n  bone {line}"));
        }
    }
    s
}

/// The bodies as JSON.
fn bodies_json(bodies: &[BodyReport]) -> serde_json::Value {
    bodies
        .iter()
        .map(|b| {
            let bones: Vec<_> = b
                .stability
                .iter()
                .map(|l| json!({"segment": l.segment, "median_m": l.median_m, "cv": l.cv, "frames": l.frames}))
                .collect();
            let ground = b.ground.as_ref().map(|g| {
                json!({"up_tilt_deg": g.tilt_deg, "contacts": g.contacts,
                       "residual_median_m": g.residual_median_m, "residual_p95_m": g.residual_p95_m,
                       "across_spread_m": g.across_spread_m})
            });
            json!({"topic": b.topic, "track": b.track, "layout": b.layout, "ground": ground, "bones": bones})
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::outcome::LostInput;

    fn sample(name: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("bags")
            .join(name)
    }

    #[test]
    fn a_whole_animation_bag_is_valid_with_its_rates_and_metadata() {
        let report = inspect(&sample("bandai_walk.anim.mcap")).unwrap();
        assert!(report.is_valid(), "{:?}", report.problems());
        assert!(!report.lost_input());
        let text = report.table();
        assert!(text.starts_with("file: "), "{text}");
        let row = |topic: &str| {
            text.lines()
                .find(|l| l.starts_with(&format!("{topic} ")))
                .map(|l| l.split_whitespace().collect::<Vec<_>>().join(" "))
        };
        assert_eq!(
            row("/animation").as_deref(),
            Some("/animation autoact_msgs/msg/BoneFrame 195 30.00 30.00 rig autoact53 0 0"),
            "{text}"
        );
        assert!(
            text.contains("\nmetadata autoact.convert: dof=full fps=30 "),
            "{text}"
        );
        assert!(text.ends_with(
            "\n\nverdict: valid: every message is readable by ROS 2 tools and autoact\n"
        ));
        let json = report.json();
        assert_eq!(json["valid"], true);
        assert_eq!(json["profile"], "ros2");
        let animation = &json["channels"][0];
        assert_eq!(animation["topic"], "/animation");
        assert_eq!(animation["streams"][0]["frames"], 195);
        assert!((animation["streams"][0]["fps"].as_f64().unwrap() - 30.0).abs() < 1e-6);
    }

    #[test]
    fn a_cut_off_bag_is_reported_as_lost_data_not_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let bytes = std::fs::read(sample("bandai_walk.anim.mcap")).unwrap();
        let cut = dir.path().join("cut.mcap");
        std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
        let report = inspect(&cut).unwrap();
        assert!(report.lost_input() && !report.is_valid());
        assert!(
            report
                .problems()
                .iter()
                .any(|p| p.starts_with("no summary with chunk indexes")),
            "{:?}",
            report.problems()
        );
        assert!(report.table().contains("\n\nverdict: problems found\n  - "));
        assert_eq!(report.json()["valid"], false);
    }

    #[test]
    fn a_file_that_is_not_mcap_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.mcap");
        std::fs::write(&path, b"not an mcap file at all").unwrap();
        assert!(inspect(&path).is_err());
    }

    #[test]
    fn a_rate_range_shows_one_number_when_its_ends_agree() {
        assert_eq!(show_rate_range((30.0, 30.001)), "30.00");
        assert_eq!(show_rate_range((25.0, 30.0)), "25.00-30.00");
    }
}
