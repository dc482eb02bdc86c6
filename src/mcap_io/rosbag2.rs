//! The `metadata.yaml` of a rosbag2 directory, in the format version the user's ROS distribution
//! reads: 9 (Jazzy and later, the default) or 5 (Humble, which refuses newer versions; Iron and
//! later read it too).
//!
//! rosbag2's format history: 5 added per-file entries (`files`), 6 `custom_data`, 7 the per-topic
//! `type_description_hash`, 8 `ros_distro`, 9 wrote `offered_qos_profiles` as a YAML list rather
//! than a YAML string. Version 9 here carries the RIHS01 hash of every topic's type (computed from
//! the schema text written, [`crate::ros::type_hash`]) and names [`crate::ros::ROS_DISTRO`], the
//! distribution whose standard definitions `schemas/` holds; version 5 has neither field and
//! writes `offered_qos_profiles` as the empty string Humble's player takes for "none recorded".

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

use super::{BagStats, McapIoError};

/// The rosbag2 metadata format version to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Rosbag2Version {
    /// Humble's format (Iron and later read it too).
    #[value(name = "5")]
    V5,
    /// Jazzy's format, with type description hashes and the ROS distribution.
    #[default]
    #[value(name = "9")]
    V9,
}

impl Rosbag2Version {
    /// The number written as `version:`.
    #[must_use]
    pub fn number(self) -> u32 {
        match self {
            Rosbag2Version::V5 => 5,
            Rosbag2Version::V9 => 9,
        }
    }
}

/// Writes the `metadata.yaml` of a rosbag2 directory (MCAP storage) in format `version`, whose
/// files are `files` (name in `dir`, and what it holds), in order — one for a bag, several for a
/// split recording — for ROS distributions whose `ros2 bag play` wants a directory.
///
/// # Errors
/// [`McapIoError::Io`].
pub fn write_rosbag2_metadata(
    dir: &Path,
    files: &[(String, BagStats)],
    version: Rosbag2Version,
) -> Result<(), McapIoError> {
    let path = dir.join("metadata.yaml");
    std::fs::write(&path, metadata_yaml(files, version)).map_err(|source| McapIoError::Io {
        action: "cannot write",
        path,
        source,
    })
}

/// The text of `metadata.yaml` (see [`write_rosbag2_metadata`]).
fn metadata_yaml(files: &[(String, BagStats)], version: Rosbag2Version) -> String {
    let mut all = BagStats::default();
    for (_, stats) in files {
        all.merge(stats);
    }
    let (start, end) = all.time_range.unwrap_or((0, 0));
    let mut out = format!(
        "rosbag2_bagfile_information:\n  version: {}\n  storage_identifier: mcap\n  duration:\n    nanoseconds: {}\n  starting_time:\n    nanoseconds_since_epoch: {start}\n  message_count: {}\n  topics_with_message_count:\n",
        version.number(),
        end - start,
        all.message_count()
    );
    out.push_str(&topics_yaml(&all, version));
    out.push_str("  compression_format: ''\n  compression_mode: ''\n  relative_file_paths:\n");
    for (name, _) in files {
        let _ = writeln!(out, "  - {name}");
    }
    out.push_str("  files:\n");
    for (name, stats) in files {
        let (a, b) = stats.time_range.unwrap_or((start, start));
        let _ = write!(
            out,
            "  - path: {name}\n    starting_time:\n      nanoseconds_since_epoch: {a}\n    duration:\n      nanoseconds: {}\n    message_count: {}\n",
            b - a,
            stats.message_count()
        );
    }
    if version == Rosbag2Version::V9 {
        let _ = write!(
            out,
            "  custom_data: {{}}\n  ros_distro: {}\n",
            crate::ros::ROS_DISTRO
        );
    }
    out
}

/// The `topics_with_message_count` entries, in topic order.
fn topics_yaml(all: &BagStats, version: Rosbag2Version) -> String {
    let no_hash = String::new();
    let hashes: &BTreeMap<String, String> = &all.type_hashes;
    let mut out = String::new();
    for (topic, (type_name, n)) in &all.topics {
        match version {
            Rosbag2Version::V5 => {
                let _ = write!(
                    out,
                    "  - message_count: {n}\n    topic_metadata:\n      name: {topic}\n      offered_qos_profiles: ''\n      serialization_format: cdr\n      type: {type_name}\n"
                );
            }
            Rosbag2Version::V9 => {
                let hash = hashes.get(type_name).unwrap_or(&no_hash);
                let hash = if hash.is_empty() { "''" } else { hash };
                let _ = write!(
                    out,
                    "  - message_count: {n}\n    topic_metadata:\n      name: {topic}\n      offered_qos_profiles: []\n      serialization_format: cdr\n      type: {type_name}\n      type_description_hash: {hash}\n"
                );
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use yaml_rust2::{Yaml, YamlLoader};

    fn stats(topic: &str, type_name: &str, hash: &str, n: u64, range: (u64, u64)) -> BagStats {
        BagStats {
            topics: [(topic.to_string(), (type_name.to_string(), n))].into(),
            type_hashes: [(type_name.to_string(), hash.to_string())].into(),
            time_range: Some(range),
        }
    }

    /// Two files of a split recording, read back as YAML: `rosbag2_bagfile_information`.
    fn written(version: Rosbag2Version) -> Yaml {
        let files = [
            (
                "take_0.mcap".to_string(),
                stats("/a", "p/msg/A", "RIHS01_aa", 3, (10, 20)),
            ),
            (
                "take_1.mcap".to_string(),
                stats("/b", "p/msg/B", "", 2, (25, 40)),
            ),
        ];
        let dir = tempfile::tempdir().unwrap();
        write_rosbag2_metadata(dir.path(), &files, version).unwrap();
        let text = std::fs::read_to_string(dir.path().join("metadata.yaml")).unwrap();
        let mut docs = YamlLoader::load_from_str(&text).unwrap();
        assert_eq!(docs.len(), 1, "{text}");
        docs.remove(0)["rosbag2_bagfile_information"].clone()
    }

    fn topic<'a>(info: &'a Yaml, name: &str) -> &'a Yaml {
        let topics = info["topics_with_message_count"].as_vec().unwrap();
        let t = topics
            .iter()
            .find(|t| t["topic_metadata"]["name"].as_str() == Some(name))
            .unwrap();
        &t["topic_metadata"]
    }

    #[test]
    fn version_9_has_the_type_hashes_and_the_ros_distribution() {
        let info = written(Rosbag2Version::V9);
        assert_eq!(info["version"].as_i64(), Some(9));
        assert_eq!(info["ros_distro"].as_str(), Some("jazzy"));
        assert_eq!(
            info["custom_data"],
            Yaml::Hash(yaml_rust2::yaml::Hash::new())
        );
        let a = topic(&info, "/a");
        assert_eq!(a["type"].as_str(), Some("p/msg/A"));
        assert_eq!(a["type_description_hash"].as_str(), Some("RIHS01_aa"));
        assert!(
            a["offered_qos_profiles"]
                .as_vec()
                .is_some_and(Vec::is_empty)
        );
        // A schema that gave no hash: empty, as rosbag2 writes an unknown one.
        assert_eq!(
            topic(&info, "/b")["type_description_hash"].as_str(),
            Some("")
        );
        assert_eq!(info["message_count"].as_i64(), Some(5));
        assert_eq!(
            info["starting_time"]["nanoseconds_since_epoch"].as_i64(),
            Some(10)
        );
        assert_eq!(info["duration"]["nanoseconds"].as_i64(), Some(30));
    }

    #[test]
    fn version_5_is_humbles_format() {
        let info = written(Rosbag2Version::V5);
        assert_eq!(info["version"].as_i64(), Some(5));
        assert!(info["ros_distro"].is_badvalue() && info["custom_data"].is_badvalue());
        for name in ["/a", "/b"] {
            let t = topic(&info, name);
            assert!(t["type_description_hash"].is_badvalue());
            // Humble reads the QoS profiles as a YAML string ("" = none recorded).
            assert_eq!(t["offered_qos_profiles"].as_str(), Some(""));
            assert_eq!(t["serialization_format"].as_str(), Some("cdr"));
        }
        let files = info["files"].as_vec().unwrap();
        assert_eq!(files.len(), 2);
        assert_eq!(files[1]["path"].as_str(), Some("take_1.mcap"));
        assert_eq!(files[1]["message_count"].as_i64(), Some(2));
        assert_eq!(
            files[1]["starting_time"]["nanoseconds_since_epoch"].as_i64(),
            Some(25)
        );
        let paths = info["relative_file_paths"].as_vec().unwrap();
        assert_eq!(paths.len(), 2);
        assert_eq!(info["compression_format"].as_str(), Some(""));
    }
}
