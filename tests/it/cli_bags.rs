//! `autoact import`, `convert` and `info` on bags synthesised here: the round trip, determinism,
//! every kind of bad input, marker and pose-array topics, several people.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use crate::common::{self, arg, autoact, repo, stderr};
use std::path::{Path, PathBuf};

use autoact::mcap_io::{BagReader, BagWriter, Compression, WriteConfig};
use autoact::ros::autoact_msgs::{BoneFrame, Skeleton3D};
use autoact::ros::geometry_msgs::{Point, Pose, PoseArray};
use autoact::ros::std_msgs::Header;
use autoact::ros::visualization_msgs::{Marker, MarkerArray};
use autoact::ros::{builtin_interfaces::Time, cdr};
use autoact::skeleton::character::Character;
use autoact::skeleton::fk::{self, BonePose};
use autoact::skeleton::layout::Layout;
use autoact::skeleton::pose::{PoseFrame, stamp_nanos_at};
use autoact::skeleton::rig::{Dof, Rig};
use nalgebra::{UnitQuaternion, Vector3};

/// H36M-17 keypoints of the rig walking and waving: frame `k` at 30 fps.
fn h36m_frame(k: usize) -> PoseFrame {
    posed_frame("h36m-17", k)
}

/// The keypoints of the built-in layout `layout` of the rig walking and waving: frame `k` at 30
/// fps.
fn posed_frame(layout: &str, k: usize) -> PoseFrame {
    let rig = Rig::standard();
    let layout = Layout::builtin(layout).unwrap();
    let character = Character::standard(&rig);
    #[expect(clippy::cast_precision_loss, reason = "small frame numbers")]
    let t = k as f64 / 30.0;
    let mut pose = BonePose::rest(&rig);
    for (b, bone) in rig.bones.iter().enumerate() {
        if let Dof::Hinge { axis } = bone.dof {
            pose.local_rotations[b] =
                UnitQuaternion::from_axis_angle(&axis, 0.4 + 0.3 * (2.0 * t).sin());
        }
    }
    let arm = rig.bone_index("r_upper_arm").unwrap();
    pose.local_rotations[arm] =
        UnitQuaternion::from_axis_angle(&Vector3::y_axis(), -1.0 + 0.5 * (3.0 * t).sin());
    pose.local_rotations[0] = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.2 * t);
    pose.root_translation_m = Vector3::new(0.0, 0.8 * t, 0.0);
    let world = fk::forward(&rig, &character, &pose, 1.0);
    layout.keypoints_from_rig(&rig, &character, &world, stamp_nanos_at(k, 30.0))
}

/// [`h36m_frame`]'s keypoints as MMPose JSON writes them.
fn h36m_keypoints(k: usize) -> Vec<[f64; 3]> {
    h36m_frame(k)
        .positions_m
        .iter()
        .map(|p| [p.x, p.y, p.z])
        .collect()
}

/// `autoact import JSON -o BAG` of H36M-17 keypoints at 30 fps, z up, plus `extra`.
fn import_h36m_json(json: &Path, bag: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "import",
        arg(json),
        "-o",
        arg(bag),
        "--layout",
        "h36m-17",
        "--fps",
        "30",
        "--axes",
        "z-up",
    ];
    args.extend_from_slice(extra);
    autoact(&args)
}

fn skeleton(k: usize, track_id: u64) -> Skeleton3D {
    let layout = Layout::builtin("h36m-17").unwrap();
    let f = h36m_frame(k);
    Skeleton3D {
        header: Header {
            stamp: Time::from_nanos(f.stamp_nanos),
            frame_id: "world".into(),
        },
        layout: "h36m-17".into(),
        track_id,
        joint_names: layout.joints.clone(),
        #[expect(clippy::cast_precision_loss, reason = "small ids")]
        positions: f
            .positions_m
            .iter()
            .map(|p| Point {
                x: p.x + track_id as f64,
                y: p.y,
                z: p.z,
            })
            .collect(),
        confidence: f.confidence,
    }
}

/// A pose bag of `n` skeleton messages (small chunks, so damage can hit one), after `edit`.
fn pose_bag(dir: &Path, name: &str, n: usize, edit: impl Fn(usize, &mut Skeleton3D)) -> PathBuf {
    let path = dir.join(name);
    let mut w = BagWriter::create(
        &path,
        WriteConfig {
            compression: Compression::Zstd,
            chunk_size_bytes: 4096,
            writer_thread: false,
        },
    )
    .unwrap();
    for k in 0..n {
        let mut s = skeleton(k, 0);
        edit(k, &mut s);
        let stamp = s.header.stamp.to_nanos().unwrap();
        w.write("/skeleton", stamp, &s).unwrap();
    }
    w.finish().unwrap();
    path
}

/// `two.mcap`: people 3 and 8 on `/skeleton` at 30 fps for `n` frames, where `keep(k, track)`.
fn two_people_bag(dir: &Path, n: usize, keep: impl Fn(usize, u64) -> bool) -> PathBuf {
    let path = dir.join("two.mcap");
    let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
    for k in 0..n {
        for track in [3, 8].into_iter().filter(|&t| keep(k, t)) {
            let s = skeleton(k, track);
            w.write("/skeleton", s.header.stamp.to_nanos().unwrap(), &s)
                .unwrap();
        }
    }
    w.finish().unwrap();
    path
}

fn bone_frames(path: &Path) -> Vec<(u64, BoneFrame)> {
    BagReader::open(path)
        .unwrap()
        .messages()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == "/animation")
        .map(|m| (m.log_time, cdr::decode::<BoneFrame>(&m.data).unwrap()))
        .collect()
}

/// Every child frame named on a bag's `/tf`.
fn tf_children(path: &Path) -> std::collections::BTreeSet<String> {
    BagReader::open(path)
        .unwrap()
        .messages()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == "/tf")
        .flat_map(|m| {
            cdr::decode::<autoact::ros::tf2_msgs::TFMessage>(&m.data)
                .unwrap()
                .transforms
        })
        .map(|t| t.child_frame_id)
        .collect()
}

fn chunk_ranges(bytes: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() && bytes[at] != 0x02 {
        let len = usize::try_from(u64::from_le_bytes(
            bytes[at + 1..at + 9].try_into().unwrap(),
        ))
        .unwrap();
        if bytes[at] == 0x06 {
            out.push((at, at + 9 + len));
        }
        at += 9 + len;
    }
    out
}

#[test]
fn convert_writes_bone_frames_tf_and_markers_that_info_calls_valid() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "in.mcap", 90, |_, _| {});
    let out = dir.path().join("out.mcap");
    let o = autoact(&["convert", arg(&input), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let frames = bone_frames(&out);
    assert_eq!(frames.len(), 90);
    for (t, f) in &frames {
        assert_eq!(f.bone_names.len(), 53);
        assert_eq!(f.header.stamp.to_nanos(), Some(*t));
        for q in &f.local_rotations {
            let n = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
            assert!((n - 1.0).abs() < 1e-9);
        }
    }
    // Walking moves the root forward (0.8 m/s for 3 s).
    let dy = frames.last().unwrap().1.root_translation.y - frames[0].1.root_translation.y;
    assert!((dy - 0.8 * 89.0 / 30.0).abs() < 0.01, "{dy}");
    let info = autoact(&["info", arg(&out), "--format", "json"]);
    assert!(info.status.success());
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    assert_eq!(v["valid"], true, "{v:#}");
    let topics: Vec<&str> = v["channels"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["topic"].as_str().unwrap())
        .collect();
    // Besides these, one point cloud per marker, for Rerun, in the same bone frame.
    let (points, others): (Vec<&str>, Vec<&str>) = topics
        .iter()
        .partition(|t| t.starts_with("/skeleton/points/"));
    assert_eq!(
        others,
        ["/animation", "/skeleton/markers", "/tf", "/tf_static"]
    );
    assert!(points.contains(&"/skeleton/points/l_forearm"), "{points:?}");
    assert!(points.contains(&"/skeleton/points/pelvis"), "{points:?}");
}

#[test]
fn the_output_rate_is_explicit() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "in.mcap", 91, |_, _| {});
    let out = dir.path().join("out.mcap");
    assert!(
        autoact(&["convert", arg(&input), "-o", arg(&out), "--fps", "60"])
            .status
            .success()
    );
    assert_eq!(bone_frames(&out).len(), 181, "3 s at 60 fps, both ends");
}

#[test]
fn same_input_gives_byte_identical_output() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "in.mcap", 60, |_, _| {});
    let (a, b) = (dir.path().join("a.mcap"), dir.path().join("b.mcap"));
    assert!(
        autoact(&["convert", arg(&input), "-o", arg(&a)])
            .status
            .success()
    );
    assert!(
        autoact(&["convert", arg(&input), "-o", arg(&b)])
            .status
            .success()
    );
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    // And import: an MMPose-style JSON, twice.
    let json = dir.path().join("clip.json");
    let frames: Vec<serde_json::Value> = (0..20)
        .map(|k| {
            let f = h36m_frame(k);
            let kp: Vec<[f64; 3]> = f.positions_m.iter().map(|p| [p.x, -p.z, p.y]).collect();
            serde_json::json!({"frame_id": k, "instances": [{"keypoints": kp}]})
        })
        .collect();
    std::fs::write(&json, serde_json::to_string(&frames).unwrap()).unwrap();
    let (c, d) = (dir.path().join("c.mcap"), dir.path().join("d.mcap"));
    for out in [&c, &d] {
        let o = autoact(&[
            "import",
            arg(&json),
            "--layout",
            "h36m-17",
            "--fps",
            "25",
            "--action",
            "walk",
            "-o",
            arg(out),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(&c).unwrap(), std::fs::read(&d).unwrap());
    let info = autoact(&["info", arg(&c)]);
    let text = String::from_utf8_lossy(&info.stdout);
    assert!(
        text.contains("action=walk") && text.contains("h36m-17") && text.contains("25.00"),
        "{text}"
    );
}

#[test]
fn a_corrupt_chunk_loses_only_its_frames_and_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "bad_crc.mcap", 300, |_, _| {});
    let mut bytes = std::fs::read(&input).unwrap();
    let chunks = chunk_ranges(&bytes);
    assert!(chunks.len() >= 4);
    let (_, end) = chunks[1];
    bytes[end - 30] ^= 0xff;
    std::fs::write(&input, &bytes).unwrap();
    let out = dir.path().join("out.mcap");
    let o = autoact(&["convert", arg(&input), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("bad_crc.mcap") && err.contains("chunk 2"),
        "{err}"
    );
    // Fewer input frames survive; the output rate bridges the hole, and the frames after the bad
    // chunk are still converted.
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    let frames_in: usize = stdout
        .split("track 0: ")
        .nth(1)
        .and_then(|s| s.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap();
    assert!(frames_in > 200 && frames_in < 300, "{stdout}");
    let frames = bone_frames(&out);
    assert_eq!(
        frames.last().unwrap().0,
        stamp_nanos_at(299, 30.0),
        "frames after the bad chunk survive"
    );
}

#[test]
fn a_truncated_bag_converts_what_it_has_and_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "cut.mcap", 300, |_, _| {});
    let bytes = std::fs::read(&input).unwrap();
    let chunks = chunk_ranges(&bytes);
    let (start, end) = chunks[2];
    std::fs::write(&input, &bytes[..usize::midpoint(start, end)]).unwrap();
    let out = dir.path().join("out.mcap");
    let o = autoact(&["convert", arg(&input), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("cut.mcap") && stderr(&o).contains("cut short"),
        "{}",
        stderr(&o)
    );
    assert!(!bone_frames(&out).is_empty());
    assert_eq!(autoact(&["info", arg(&input)]).status.code(), Some(3));
}

#[test]
fn bad_messages_are_named_and_skipped() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "lengths.mcap", 30, |k, s| {
        if k == 5 {
            s.positions.pop();
        }
    });
    let out = dir.path().join("out.mcap");
    let o = autoact(&["convert", arg(&input), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3));
    let err = stderr(&o);
    assert!(
        err.contains("lengths.mcap: /skeleton message 5") && err.contains("equal lengths"),
        "{err}"
    );
    assert_eq!(
        bone_frames(&out).len(),
        30,
        "the gap is bridged at the output rate"
    );

    let input = pose_bag(dir.path(), "order.mcap", 30, |k, s| {
        if k == 10 {
            s.header.stamp = Time::from_nanos(stamp_nanos_at(3, 30.0));
        }
    });
    let o = autoact(&["convert", arg(&input), "-o", arg(&out), "--force"]);
    assert_eq!(o.status.code(), Some(3));
    assert!(
        stderr(&o).contains("/skeleton message 10") && stderr(&o).contains("non-monotonic"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn nan_positions_are_missing_joints_not_lost_frames() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "nan.mcap", 30, |k, s| {
        if (10..15).contains(&k) {
            s.positions[13].x = f64::NAN; // left wrist lost for a few frames
        }
    });
    let out = dir.path().join("out.mcap");
    let o = autoact(&["convert", arg(&input), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("NaN positions") && stderr(&o).contains("/skeleton message 10"),
        "{}",
        stderr(&o)
    );
    for (_, f) in bone_frames(&out) {
        assert!(
            f.local_rotations
                .iter()
                .all(|q| q.x.is_finite() && q.w.is_finite())
        );
    }
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("5 frames needed the degenerate-input path")
    );
}

#[test]
fn foreign_and_empty_files_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let other = dir.path().join("points.mcap");
    let mut w = BagWriter::create(&other, WriteConfig::default()).unwrap();
    w.write("/odom", 1, &Point::default()).unwrap();
    w.finish().unwrap();
    let out = dir.path().join("out.mcap");
    let o = autoact(&["convert", arg(&other), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("no pose topic")
            && stderr(&o).contains("/odom (geometry_msgs/msg/Point)"),
        "{}",
        stderr(&o)
    );
    let o = autoact(&["convert", arg(&other), "--topic", "/odom", "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("not a pose type"), "{}", stderr(&o));

    let empty = dir.path().join("empty.mcap");
    std::fs::write(&empty, b"").unwrap();
    for cmd in ["convert", "info"] {
        let o = autoact(&[cmd, arg(&empty), "-o", arg(&out)][..if cmd == "info" { 2 } else { 4 }]);
        assert_eq!(o.status.code(), Some(1));
        assert!(stderr(&o).contains("empty.mcap is empty"), "{}", stderr(&o));
    }
    let o = autoact(&["import", arg(&empty), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--format"), "{}", stderr(&o));
}

#[test]
fn marker_and_pose_array_topics_need_and_use_a_layout() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("markers.mcap");
    let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
    for k in 0..40 {
        let f = h36m_frame(k);
        let header = Header {
            stamp: Time::from_nanos(f.stamp_nanos),
            frame_id: "world".into(),
        };
        let spheres: Vec<Marker> = f
            .positions_m
            .iter()
            .enumerate()
            .map(|(j, p)| Marker {
                header: header.clone(),
                ns: "person".into(),
                id: i32::try_from(j).unwrap(),
                type_: Marker::SPHERE,
                pose: Pose {
                    position: Point::from(*p),
                    ..Pose::default()
                },
                ..Marker::default()
            })
            .collect();
        w.write("/markers", f.stamp_nanos, &MarkerArray { markers: spheres })
            .unwrap();
        let poses = f
            .positions_m
            .iter()
            .map(|p| Pose {
                position: Point::from(*p),
                ..Pose::default()
            })
            .collect();
        w.write("/poses", f.stamp_nanos, &PoseArray { header, poses })
            .unwrap();
    }
    w.finish().unwrap();
    let out = dir.path().join("out.mcap");
    let o = autoact(&[
        "convert",
        arg(&path),
        "--topic",
        "/markers",
        "-o",
        arg(&out),
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("give --layout"), "{}", stderr(&o));
    for topic in ["/markers", "/poses"] {
        let o = autoact(&[
            "convert",
            arg(&path),
            "--topic",
            topic,
            "--layout",
            "h36m-17",
            "-o",
            arg(&out),
            "--force",
        ]);
        assert!(o.status.success(), "{topic}: {}", stderr(&o));
        assert_eq!(bone_frames(&out).len(), 40, "{topic}");
    }
}

#[test]
fn several_people_on_one_topic_become_several_tracks() {
    let dir = tempfile::tempdir().unwrap();
    let path = two_people_bag(dir.path(), 30, |_, _| true);
    let out = dir.path().join("out.mcap");
    let o = autoact(&["convert", arg(&path), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let frames = bone_frames(&out);
    assert_eq!(frames.len(), 60);
    assert_eq!(frames.iter().filter(|(_, f)| f.track_id == 8).count(), 30);
    let tf_frames = tf_children(&out);
    assert!(tf_frames.contains("track3/l_forearm") && tf_frames.contains("track8/root"));
}

#[test]
fn info_gives_each_persons_frame_rate_beside_the_channels_message_rate() {
    let dir = tempfile::tempdir().unwrap();
    // Person 3 at 30 fps, person 8 at 15 fps, on one topic, for the same second.
    let path = two_people_bag(dir.path(), 31, |k, track| track == 3 || k % 2 == 0);
    let o = autoact(&["info", arg(&path), "--format", "json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let channel = &v["channels"][0];
    assert_eq!(channel["topic"], "/skeleton");
    let rate = channel["rate_hz"].as_f64().unwrap();
    assert!((rate - 46.0).abs() < 1e-6, "46 messages in 1 s: {rate}");
    let streams: Vec<(u64, u64, f64)> = channel["streams"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| {
            (
                s["track_id"].as_u64().unwrap(),
                s["frames"].as_u64().unwrap(),
                s["fps"].as_f64().unwrap(),
            )
        })
        .collect();
    assert_eq!(streams.len(), 2, "{streams:?}");
    assert_eq!((streams[0].0, streams[0].1), (3, 31));
    assert_eq!((streams[1].0, streams[1].1), (8, 16));
    assert!((streams[0].2 - 30.0).abs() < 1e-6 && (streams[1].2 - 15.0).abs() < 1e-6);

    let table = common::stdout(&autoact(&["info", arg(&path)]));
    let row = table.lines().find(|l| l.starts_with("/skeleton")).unwrap();
    assert!(
        row.contains("46.00") && row.contains("15.00-30.00"),
        "{table}"
    );
}

/// `rosbag2_bagfile_information` of the rosbag2 directory `dir`, as a YAML parser reads it.
fn rosbag2_info(dir: &Path) -> yaml_rust2::Yaml {
    let text = std::fs::read_to_string(dir.join("metadata.yaml")).unwrap();
    let docs = yaml_rust2::YamlLoader::load_from_str(&text).unwrap();
    docs[0]["rosbag2_bagfile_information"].clone()
}

#[test]
fn rosbag2_directories_carry_metadata_yaml() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "in.mcap", 30, |_, _| {});
    let out = dir.path().join("anim");
    let o = autoact(&["convert", arg(&input), "-o", arg(&out), "--rosbag2"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let yaml = std::fs::read_to_string(out.join("metadata.yaml")).unwrap();
    assert!(
        yaml.contains("storage_identifier: mcap")
            && yaml.contains("- anim_0.mcap")
            && yaml.contains("type: autoact_msgs/msg/BoneFrame"),
        "{yaml}"
    );
    assert_eq!(bone_frames(&out.join("anim_0.mcap")).len(), 30);
    // Version 9: every topic's RIHS01 hash, computed from the schema text in the file, and the
    // distribution the standard definitions come from.
    let info = rosbag2_info(&out);
    assert_eq!(info["version"].as_i64(), Some(9));
    assert_eq!(info["ros_distro"].as_str(), Some("jazzy"));
    let mut schemas = std::collections::BTreeMap::new();
    for m in BagReader::open(&out.join("anim_0.mcap"))
        .unwrap()
        .messages()
    {
        let m = m.unwrap();
        let schema = m.channel.schema.clone().unwrap();
        schemas.insert(m.channel.topic.clone(), schema);
    }
    let topics = info["topics_with_message_count"].as_vec().unwrap();
    assert_eq!(topics.len(), schemas.len());
    for t in topics {
        let meta = &t["topic_metadata"];
        let schema = &schemas[meta["name"].as_str().unwrap()];
        let text = String::from_utf8(schema.data.clone()).unwrap();
        let hash = meta["type_description_hash"].as_str().unwrap();
        assert!(
            hash.starts_with("RIHS01_") && hash.len() == 7 + 64,
            "{hash}"
        );
        assert_eq!(
            Some(hash),
            autoact::ros::type_hash::rihs01(&schema.name, &text).as_deref()
        );
    }
    // Version 5, for Humble: the same bag, no hash, no distribution.
    let humble = dir.path().join("humble");
    let o = autoact(&[
        "convert",
        arg(&input),
        "-o",
        arg(&humble),
        "--rosbag2",
        "--rosbag2-version",
        "5",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let info5 = rosbag2_info(&humble);
    assert_eq!(info5["version"].as_i64(), Some(5));
    assert!(info5["ros_distro"].is_badvalue());
    for t in info5["topics_with_message_count"].as_vec().unwrap() {
        assert!(t["topic_metadata"]["type_description_hash"].is_badvalue());
        assert_eq!(
            t["topic_metadata"]["offered_qos_profiles"].as_str(),
            Some("")
        );
    }
    assert_eq!(
        std::fs::read(humble.join("humble_0.mcap")).unwrap(),
        std::fs::read(out.join("anim_0.mcap")).unwrap(),
        "the version changes metadata.yaml only"
    );
    // A rosbag2 directory is a bag too, as input.
    let info = autoact(&["info", arg(&out)]);
    assert!(
        info.status.success() && String::from_utf8_lossy(&info.stdout).contains("/animation"),
        "{}",
        stderr(&info)
    );
    let none = dir.path().join("none");
    std::fs::create_dir(&none).unwrap();
    let o = autoact(&["info", arg(&none)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("no .mcap file"), "{}", stderr(&o));
}

#[test]
fn dsi_variants_are_labelled_animations_of_their_own_and_deterministic() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "in.mcap", 90, |_, _| {});
    let run = |name: &str, seed: &str| {
        let out = dir.path().join(name);
        let o = autoact(&[
            "convert",
            arg(&input),
            "-o",
            arg(&out),
            "--dsi",
            "--variants",
            "3",
            "--seed",
            seed,
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            common::stdout(&o).contains("3 variants (seed"),
            "{}",
            common::stdout(&o)
        );
        out
    };
    let (a, b, c) = (run("a.mcap", "5"), run("b.mcap", "5"), run("c.mcap", "6"));
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());

    let frames = bone_frames(&a);
    let of = |v: u32| -> Vec<&BoneFrame> {
        frames
            .iter()
            .filter(|(_, f)| f.variant == v)
            .map(|(_, f)| f)
            .collect()
    };
    let base = of(0);
    assert!(base.len() >= 88, "{} frames", base.len());
    for v in 1..=3 {
        let variant = of(v);
        assert_eq!(variant.len(), base.len(), "variant {v}");
        assert_ne!(variant[40].local_rotations, base[40].local_rotations);
    }
    assert_eq!(frames.len(), 4 * base.len(), "nothing but variants 0..=3");
    let info = autoact(&["info", arg(&a)]);
    let row = common::stdout(&info)
        .lines()
        .find(|l| l.starts_with("/animation"))
        .map(str::to_string)
        .unwrap();
    let cells: Vec<&str> = row.split_whitespace().collect();
    let message_rate: f64 = cells[3].parse().unwrap();
    assert!(
        (message_rate - 120.0).abs() < 2.0 && cells[4] == "30.00",
        "four variants at 30 fps: {row}"
    );
    for (_, f) in &frames {
        for q in &f.local_rotations {
            let n = (q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w).sqrt();
            assert!((n - 1.0).abs() < 1e-9, "|q| = {n}");
        }
    }
    // Another seed: the same animation, other variants.
    let other = bone_frames(&c);
    let other_of = |v: u32| -> Vec<&BoneFrame> {
        other
            .iter()
            .filter(|(_, f)| f.variant == v)
            .map(|(_, f)| f)
            .collect()
    };
    assert_eq!(other_of(0), base);
    assert_ne!(other_of(1), of(1));
    // Variants have their own tf frames, and the bag says how they were made.
    let tf_children = tf_children(&a);
    for name in ["root", "v1/root", "v3/l_forearm"] {
        assert!(
            tf_children.contains(name),
            "{name} missing: {tf_children:?}"
        );
    }
    let meta = BagReader::open(&a).unwrap().metadata();
    let convert = &meta.iter().find(|(n, _)| n == "autoact.convert").unwrap().1;
    assert_eq!(convert["seed"], "5");
    assert_eq!(convert["variants"], "3");
    assert_eq!(convert["dsi_threshold"], "3x");
    assert_eq!(
        convert["dsi_source"],
        "auto (estimator for camera-frame tracks)"
    );
    assert_eq!(convert["dof"], "full");
}

#[test]
fn dsi_pace_sets_the_duration() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "in.mcap", 91, |_, _| {});
    let count = |extra: &[&str]| {
        let out = dir.path().join("out.mcap");
        let mut args = vec!["convert", arg(&input), "-o", arg(&out), "--force"];
        args.extend_from_slice(extra);
        let o = autoact(&args);
        assert!(o.status.success(), "{extra:?}: {}", stderr(&o));
        bone_frames(&out).len()
    };
    assert_eq!(count(&["--smooth", "on"]), 91, "3 s at 30 fps, real speed");
    assert_eq!(
        count(&["--speed", "2"]),
        46,
        "twice as fast: half the frames"
    );
    assert_eq!(
        count(&["--delta", "0.5"]),
        181,
        "δ = 0.5: two output frames per source frame"
    );
    assert_eq!(
        count(&["--dsi-threshold", "off", "--fps", "60"]),
        181,
        "no cuts at 60 fps"
    );
}

#[test]
fn bad_dsi_options_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "in.mcap", 20, |_, _| {});
    let out = dir.path().join("out.mcap");
    for (extra, code, expect) in [
        (&["--dsi-threshold", "fast"][..], 2, "3x"),
        (&["--smooth", "0.3,0.2,1"][..], 1, "ascending"),
        (&["--smooth", "0.3,0.2"][..], 2, "three spans"),
        (
            &["--speed", "0"][..],
            1,
            "--speed must be a positive number",
        ),
        (
            &["--speed", "2", "--delta", "1"][..],
            2,
            "cannot be used with",
        ),
        (&["--dsi-weight", "knee=2"][..], 1, "not a bone"),
        (&["--variation-deg", "100"][..], 2, "[0, 90]"),
        (&["--smooth-bass", "12"][..], 1, "[0, 10]"),
    ] {
        let mut args = vec!["convert", arg(&input), "-o", arg(&out), "--force"];
        args.extend_from_slice(extra);
        let o = autoact(&args);
        assert_eq!(o.status.code(), Some(code), "{extra:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(expect), "{extra:?}: {}", stderr(&o));
    }
}

#[test]
fn recover_rewrites_a_cut_bag_with_every_complete_chunk_and_says_data_was_lost() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "in.mcap", 90, |_, _| {});
    let bytes = std::fs::read(&input).unwrap();
    let chunks = chunk_ranges(&bytes);
    assert!(chunks.len() > 3);
    // Cut in the middle of the fourth chunk, as a kill -9 would leave it.
    let (start, end) = chunks[3];
    let cut = dir.path().join("cut.mcap");
    std::fs::write(&cut, &bytes[..usize::midpoint(start, end)]).unwrap();
    let before: usize = BagReader::open(&cut).unwrap().messages().flatten().count();
    let out = dir.path().join("out.mcap");
    let o = autoact(&["recover", arg(&cut), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        common::stdout(&o).contains(&format!("{before} messages kept")),
        "{}",
        common::stdout(&o)
    );
    let r = BagReader::open(&out).unwrap();
    assert!(r.time_range().is_some(), "the recovered file has a summary");
    let frames: Vec<Skeleton3D> = r
        .messages()
        .map(|m| cdr::decode::<Skeleton3D>(&m.unwrap().data).unwrap())
        .collect();
    assert_eq!(frames.len(), before);
    assert_eq!(
        frames,
        (0..before).map(|k| skeleton(k, 0)).collect::<Vec<_>>()
    );
    // The recovered bag converts like any other.
    let anim = dir.path().join("anim.mcap");
    assert!(
        autoact(&["convert", arg(&out), "-o", arg(&anim)])
            .status
            .success()
    );
    // A whole file recovers with exit 0; an existing output needs --force.
    let o = autoact(&["recover", arg(&input), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--force"));
    let o = autoact(&["recover", arg(&input), "-o", arg(&out), "--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

#[test]
fn a_tracks_time_comes_from_its_header_stamps_or_else_its_log_times() {
    // Recorded live: header stamps from 0 (a replayed import), log times on the wall clock; and
    // a publisher that never stamps (all zero), whose log times are the only clock.
    let dir = tempfile::tempdir().unwrap();
    let wall = 1_795_000_000_000_000_000u64;
    for (name, stamped) in [("replayed.mcap", true), ("unstamped.mcap", false)] {
        let path = dir.path().join(name);
        let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
        for k in 0..30 {
            let mut s = skeleton(k, 0);
            if !stamped {
                s.header.stamp = Time::default();
            }
            w.write("/skeleton", wall + stamp_nanos_at(k, 30.0) + 5_000_000, &s)
                .unwrap();
        }
        w.finish().unwrap();
        let out = dir.path().join(format!("{name}.anim.mcap"));
        let o = autoact(&["convert", arg(&path), "-o", arg(&out)]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let frames = bone_frames(&out);
        assert_eq!(frames.len(), 30, "{name}: every frame kept");
        let first = frames[0].0;
        assert_eq!(first, if stamped { 0 } else { wall + 5_000_000 }, "{name}");
    }
}

/// `convert --spec` over one source bag: one variant, scene and viewpoint.
fn one_source_spec(dir: &Path, source: &Path) -> PathBuf {
    let spec = dir.join("one.toml");
    let text = format!(
        "[dataset]\nname = \"lossy\"\nseed = 1\nfps = 30.0\nresolution = [640, 360]\n\
         [counts]\nvariants = 1\nscenes = 1\nviewpoints = 1\n\
         [[class]]\ncategory = \"gesture\"\naction = \"wave\"\nsources = [\"{}\"]\n",
        arg(source)
    );
    std::fs::write(&spec, text).unwrap();
    spec
}

#[test]
fn convert_spec_and_convert_agree_that_a_damaged_source_lost_data() {
    let dir = tempfile::tempdir().unwrap();
    // A corrupt chunk in the middle, and a message whose arrays disagree.
    let input = pose_bag(dir.path(), "damaged.pose.mcap", 300, |k, s| {
        if k == 250 {
            s.positions.pop();
        }
    });
    let mut bytes = std::fs::read(&input).unwrap();
    let chunks = chunk_ranges(&bytes);
    assert!(chunks.len() >= 4);
    let (_, end) = chunks[1];
    bytes[end - 30] ^= 0xff;
    std::fs::write(&input, &bytes).unwrap();

    let spec = one_source_spec(dir.path(), &input);
    let out = dir.path().join("capture");
    let o = autoact(&["convert", "--spec", arg(&spec), "-o", arg(&out)]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("WARN") && err.contains("damaged.pose.mcap: chunk 2"),
        "the unreadable chunk is named with its file: {err}"
    );
    assert!(
        err.contains("damaged.pose.mcap: /skeleton message") && err.contains("equal lengths"),
        "the skipped message is named: {err}"
    );
    assert!(
        err.contains("1 unreadable parts, 1 skipped messages"),
        "{err}"
    );
    // Everything else was captured.
    assert!(
        stdout_text(&o).contains("wrote 1 sessions"),
        "{}",
        stdout_text(&o)
    );
    assert!(out.join("plan.json").exists());

    // Plain convert of the same bag says the same and ends the same way.
    let anim = dir.path().join("damaged.anim.mcap");
    let o = autoact(&["convert", arg(&input), "-o", arg(&anim)]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("damaged.pose.mcap: chunk 2")
            && err.contains("damaged.pose.mcap: /skeleton message")
            && err.contains("1 unreadable parts, 1 skipped messages"),
        "{err}"
    );

    // An undamaged source loses nothing: exit 0 on both paths.
    let clean = pose_bag(dir.path(), "clean.pose.mcap", 60, |_, _| {});
    let spec = one_source_spec(dir.path(), &clean);
    let o = autoact(&["convert", "--spec", arg(&spec), "-o", arg(&out), "--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let o = autoact(&["convert", arg(&clean), "-o", arg(&anim), "--force"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

fn stdout_text(o: &std::process::Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `convert`, `import` and `recover` refuse to write over their own input, however the output is
/// spelled (the same path, `./`, `dir/..`, a symbolic link), and leave the input untouched.
#[test]
fn an_output_that_is_the_input_is_refused_and_the_input_kept() {
    let dir = tempfile::tempdir().unwrap();
    let bag = dir.path().join("walk.pose.mcap");
    std::fs::copy(repo("bags/bandai_walk.pose.mcap"), &bag).unwrap();
    let before = std::fs::read(&bag).unwrap();
    let link = dir.path().join("link.mcap");
    std::os::unix::fs::symlink(&bag, &link).unwrap();
    let dotted = dir.path().join(".").join("walk.pose.mcap");
    let via_parent = dir.path().join("sub").join("..").join("walk.pose.mcap");
    std::fs::create_dir(dir.path().join("sub")).unwrap();
    for output in [&bag, &dotted, &via_parent, &link] {
        for command in [
            vec!["convert", arg(&bag), "-o", arg(output)],
            vec!["recover", arg(&bag), "-o", arg(output), "--force"],
            vec!["import", arg(&bag), "-o", arg(output), "--format", "bvh"],
        ] {
            let o = autoact(&command);
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(1), "{command:?}: {err}");
            assert!(
                err.contains("is the input") && err.contains("walk.pose.mcap"),
                "{command:?}: {err}"
            );
            assert_eq!(
                std::fs::read(&bag).unwrap(),
                before,
                "{command:?} touched the input"
            );
        }
    }
    // A different output is still written.
    let out = dir.path().join("walk.anim.mcap");
    let o = autoact(&["convert", arg(&bag), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Per chunk of a finished file: its start and the messages its message indexes list.
fn chunk_counts(bytes: &[u8]) -> Vec<(usize, u64)> {
    let mut out: Vec<(usize, u64)> = Vec::new();
    let mut at = 8;
    while at + 9 <= bytes.len() && bytes[at] != 0x0F {
        let len = usize::try_from(u64::from_le_bytes(
            bytes[at + 1..at + 9].try_into().unwrap(),
        ))
        .unwrap();
        match bytes[at] {
            0x06 => out.push((at, 0)),
            0x07 => {
                let entries = u32::from_le_bytes(bytes[at + 11..at + 15].try_into().unwrap());
                out.last_mut().unwrap().1 += u64::from(entries) / 16;
            }
            _ => {}
        }
        at += 9 + len;
    }
    out
}

#[test]
fn a_bag_cut_at_a_chunk_boundary_is_lost_input_for_convert_spec_and_info() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "killed.pose.mcap", 300, |_, _| {});
    let bytes = std::fs::read(&input).unwrap();
    let chunks = chunk_counts(&bytes);
    assert!(chunks.len() > 4);
    // What `record` leaves after kill -9: whole chunks, no summary.
    let (cut, _) = chunks[3];
    let kept: u64 = chunks[..3].iter().map(|c| c.1).sum();
    std::fs::write(&input, &bytes[..cut]).unwrap();
    let said = format!("killed.pose.mcap: file ends without a summary: {kept} messages recovered");

    let anim = dir.path().join("killed.anim.mcap");
    let o = autoact(&["convert", arg(&input), "-o", arg(&anim)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains(&said), "{}", stderr(&o));
    assert!(
        common::stdout(&o).contains(&format!("track 0: {kept} ")),
        "every whole chunk is converted: {}",
        common::stdout(&o)
    );

    let spec = one_source_spec(dir.path(), &input);
    let out = dir.path().join("capture");
    let o = autoact(&["convert", "--spec", arg(&spec), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(stderr(&o).contains(&said), "{}", stderr(&o));

    let o = autoact(&["info", arg(&input)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(common::stdout(&o).contains("verdict: problems found"));
    assert!(common::stdout(&o).contains(&said), "{}", common::stdout(&o));
}

/// `bytes` with the 8-byte length of the record at `at` set to `len`.
fn with_length(bytes: &[u8], at: usize, len: u64) -> Vec<u8> {
    let mut out = bytes.to_vec();
    out[at + 1..at + 9].copy_from_slice(&len.to_le_bytes());
    out
}

/// Runs `autoact ARGS` with at most 2 GB of address space (the `mcap` crate's parser reserved up
/// to 4 GiB for a corrupt string length before checking it).
fn autoact_in_2gb(args: &[&str]) -> std::process::Output {
    let quoted: Vec<String> = args.iter().map(|a| format!("'{a}'")).collect();
    std::process::Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -v 2000000; exec '{}' {}",
            env!("CARGO_BIN_EXE_autoact"),
            quoted.join(" ")
        ))
        .output()
        .unwrap()
}

#[test]
fn damaged_lengths_cost_only_their_chunk_and_never_abort_under_a_memory_limit() {
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "whole.pose.mcap", 300, |_, _| {});
    let bytes = std::fs::read(&input).unwrap();
    let chunks = chunk_counts(&bytes);
    let all: u64 = chunks.iter().map(|c| c.1).sum();
    let (start, lost) = chunks[2];
    let mut header_string = bytes.clone();
    // The header's profile length: 4 GiB.
    header_string[17..21].copy_from_slice(&u32::MAX.to_le_bytes());
    let cases: Vec<(&str, Vec<u8>, u64)> = vec![
        ("all_ones", with_length(&bytes, start, u64::MAX), all - lost),
        (
            "past_eof",
            with_length(&bytes, start, bytes.len() as u64),
            all - lost,
        ),
        (
            "garbage",
            [&bytes[..start], &[0x5a_u8; 777][..], &bytes[start..]].concat(),
            all,
        ),
        ("header_string", header_string, all),
    ];
    for (name, damaged, kept) in cases {
        let path = dir.path().join(format!("{name}.pose.mcap"));
        std::fs::write(&path, &damaged).unwrap();
        let o = autoact_in_2gb(&["info", "--format", "json", arg(&path)]);
        let report: serde_json::Value = serde_json::from_slice(&o.stdout)
            .unwrap_or_else(|e| panic!("{name}: {e}: {}", stderr(&o)));
        assert_eq!(
            report["channels"][0]["messages"].as_u64(),
            Some(kept),
            "{name}: {}",
            stderr(&o)
        );
        let expected = if name == "header_string" { 0 } else { 3 };
        assert_eq!(o.status.code(), Some(expected), "{name}: {report}");
        let anim = dir.path().join(format!("{name}.anim.mcap"));
        let o = autoact_in_2gb(&["convert", arg(&path), "-o", arg(&anim)]);
        assert_eq!(o.status.code(), Some(expected), "{name}: {}", stderr(&o));
        if name != "header_string" {
            assert!(
                stderr(&o).contains(&format!("{name}.pose.mcap: bytes {start}..")),
                "{name}: the damage is named with its place: {}",
                stderr(&o)
            );
        }
    }
}

#[test]
fn recover_takes_a_rosbag2_folder_into_a_folder() {
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("rosbag2_run");
    std::fs::create_dir(&folder).unwrap();
    let first = pose_bag(&folder, "run_0.mcap", 90, |_, _| {});
    let second = pose_bag(&folder, "run_1.mcap", 90, |_, _| {});
    // The second split was being written when the recorder was killed.
    let bytes = std::fs::read(&second).unwrap();
    let chunks = chunk_counts(&bytes);
    let kept: u64 = chunks[..2].iter().map(|c| c.1).sum();
    std::fs::write(&second, &bytes[..chunks[2].0]).unwrap();
    let out = dir.path().join("recovered");
    let o = autoact(&["recover", arg(&folder), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("run_1.mcap: file ends without a summary"),
        "{}",
        stderr(&o)
    );
    let count = |p: &Path| BagReader::open(p).unwrap().messages().count() as u64;
    assert_eq!(count(&out.join("run_0.mcap")), count(&first));
    assert_eq!(count(&out.join("run_1.mcap")), kept);
    let yaml = std::fs::read_to_string(out.join("metadata.yaml")).unwrap();
    assert!(
        yaml.contains(&format!("message_count: {}", 90 + kept)),
        "{yaml}"
    );
    // The recovered folder reads whole.
    let o = autoact(&["info", arg(&out)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert_eq!(rosbag2_info(&out)["version"].as_i64(), Some(9));
    // For Humble: the same files, metadata.yaml in version 5.
    let humble = dir.path().join("recovered_humble");
    let o = autoact(&[
        "recover",
        arg(&folder),
        "-o",
        arg(&humble),
        "--rosbag2-version",
        "5",
    ]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let info = rosbag2_info(&humble);
    assert_eq!(info["version"].as_i64(), Some(5));
    assert_eq!(
        info["message_count"].as_i64(),
        Some(i64::try_from(90 + kept).unwrap())
    );
    // A folder is never written over a file, nor over itself, nor over an existing folder
    // without --force.
    let o = autoact(&["recover", arg(&folder), "-o", arg(&first)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("is a rosbag2 folder"), "{}", stderr(&o));
    let o = autoact(&["recover", arg(&folder), "-o", arg(&folder), "--force"]);
    assert_eq!(o.status.code(), Some(1));
    let o = autoact(&["recover", arg(&folder), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--force"), "{}", stderr(&o));
}

/// An animation bag cut off at a chunk boundary (what `record` or a crash leaves): as a
/// `convert --spec` source and to `export` and `info`, that is lost input, exit 3.
#[test]
fn an_animation_bag_cut_at_a_chunk_boundary_is_lost_input_everywhere() {
    let dir = tempfile::tempdir().unwrap();
    let bytes = std::fs::read(repo("bags/bandai_walk.anim.mcap")).unwrap();
    let chunks = chunk_ranges(&bytes);
    assert!(chunks.len() >= 2, "{} chunks", chunks.len());
    let cut = dir.path().join("cut.anim.mcap");
    std::fs::write(&cut, &bytes[..chunks[chunks.len() - 1].0]).unwrap();
    let spec = one_source_spec(dir.path(), &cut);
    let runs = [
        vec![
            "convert".to_string(),
            "--spec".to_string(),
            arg(&spec).to_string(),
            "-o".to_string(),
            arg(&dir.path().join("capture")).to_string(),
        ],
        vec![
            "export".to_string(),
            arg(&cut).to_string(),
            "-o".to_string(),
            arg(&dir.path().join("walk.bvh")).to_string(),
            "--format".to_string(),
            "bvh".to_string(),
        ],
        vec!["info".to_string(), arg(&cut).to_string()],
    ];
    for run in runs {
        let args: Vec<&str> = run.iter().map(String::as_str).collect();
        let o = autoact(&args);
        let said = format!("{}{}", stdout_text(&o), stderr(&o));
        assert_eq!(o.status.code(), Some(3), "{args:?}: {said}");
        assert!(
            said.contains("cut.anim.mcap: file ends without a summary"),
            "{args:?}: {said}"
        );
    }
}

#[test]
fn a_stamp_far_ahead_is_dropped_and_named_not_interpolated_across() {
    // Two damaged bytes: message 40's stamp lands 63 years ahead. It is dropped and named; the
    // frames after it are kept and the output does not fill the 63 years.
    let dir = tempfile::tempdir().unwrap();
    let bag = pose_bag(dir.path(), "spike.mcap", 90, |k, s| {
        if k == 40 {
            s.header.stamp = Time::from_nanos(2_000_000_000_000_000_000);
        }
    });
    let out = dir.path().join("spike.anim.mcap");
    let o = autoact(&["convert", arg(&bag), "-o", arg(&out)]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("message 40") && err.contains("damaged stamp"),
        "{err}"
    );
    let frames = bone_frames(&out);
    assert_eq!(
        frames.len(),
        90,
        "frame 40 is interpolated from its neighbours, nothing added"
    );
    assert!(frames.iter().all(|(t, _)| *t < 3_000_000_000));
}

#[test]
fn a_gap_longer_than_max_gap_is_not_interpolated_and_the_animation_resumes_after_it() {
    // 60 frames, 10 s of nothing, 60 frames: both stretches are kept, the gap is warned about
    // (no input is lost: exit 0) and no output frame falls inside it.
    let dir = tempfile::tempdir().unwrap();
    let shift = 10_000_000_000u64;
    let bag = pose_bag(dir.path(), "gap.mcap", 120, |k, s| {
        if k >= 60 {
            let t = s.header.stamp.to_nanos().unwrap();
            s.header.stamp = Time::from_nanos(t + shift);
        }
    });
    let out = dir.path().join("gap.anim.mcap");
    let o = autoact(&["convert", arg(&bag), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("message 60") && err.contains("maximum gap"),
        "{err}"
    );
    let frames = bone_frames(&out);
    assert_eq!(frames.len(), 120);
    let last_before = stamp_nanos_at(59, 30.0);
    let first_after = stamp_nanos_at(60, 30.0) + shift;
    assert!(
        frames
            .iter()
            .all(|(t, _)| *t <= last_before || *t >= first_after)
    );
    // A maximum above the gap bridges it, as before.
    let bridged = dir.path().join("bridged.anim.mcap");
    let o = autoact(&["convert", arg(&bag), "-o", arg(&bridged), "--max-gap", "11"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(bone_frames(&bridged).len() > 400);
    // DSI runs stretch by stretch: nothing in the gap either.
    let dsi = dir.path().join("dsi.anim.mcap");
    let o = autoact(&["convert", arg(&bag), "-o", arg(&dsi), "--dsi"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let frames = bone_frames(&dsi);
    assert!(frames.len() < 200, "{} frames", frames.len());
    assert!(frames.windows(2).all(|w| w[0].0 < w[1].0));
}

#[test]
fn max_gap_must_be_positive() {
    let dir = tempfile::tempdir().unwrap();
    let bag = pose_bag(dir.path(), "in.mcap", 10, |_, _| {});
    let out = dir.path().join("out.mcap");
    let o = autoact(&["convert", arg(&bag), "-o", arg(&out), "--max-gap", "0"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("--max-gap"), "{}", stderr(&o));
    assert!(!out.exists());
}

#[test]
fn an_mmpose_frame_id_jump_is_a_gap_not_hours_of_invented_frames() {
    // A legal JSON whose frame ids jump by a million (9 hours at 30 fps): both stretches are
    // kept, and the output holds their frames only.
    let dir = tempfile::tempdir().unwrap();
    let frames: Vec<serde_json::Value> = (0..40usize)
        .map(|k| {
            let id = if k < 20 { k } else { 1_000_000 + k };
            serde_json::json!({"frame_id": id, "instances": [{"keypoints": h36m_keypoints(k)}]})
        })
        .collect();
    let json = dir.path().join("jump.json");
    std::fs::write(&json, serde_json::to_string(&frames).unwrap()).unwrap();
    let bag = dir.path().join("jump.pose.mcap");
    let o = import_h36m_json(&json, &bag, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("jump.anim.mcap");
    let o = autoact(&["convert", arg(&bag), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("maximum gap"), "{}", stderr(&o));
    assert_eq!(bone_frames(&out).len(), 40);
}

/// Pose arrays are estimator output in a camera's frame: `convert` stands them on the ground
/// (the tilt of the camera found and removed) unless `--ground off`.
#[test]
fn pose_arrays_in_a_tilted_camera_frame_are_grounded() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("camera.mcap");
    // A camera pitched 20° down, 1.4 m up: the body seen in its frame.
    let camera_from_world = nalgebra::Isometry3::from_parts(
        nalgebra::Translation3::new(0.3, -0.2, 1.4),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 20f64.to_radians()),
    );
    let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
    for k in 0..60 {
        let f = h36m_frame(k);
        let header = Header {
            stamp: Time::from_nanos(f.stamp_nanos),
            frame_id: "camera".into(),
        };
        let poses = f
            .positions_m
            .iter()
            .map(|p| Pose {
                position: Point::from(camera_from_world * p),
                ..Pose::default()
            })
            .collect();
        w.write("/poses", f.stamp_nanos, &PoseArray { header, poses })
            .unwrap();
    }
    w.finish().unwrap();
    let out = dir.path().join("out.mcap");
    let run = |ground: &str| {
        autoact(&[
            "-v",
            "convert",
            arg(&path),
            "--layout",
            "h36m-17",
            "--ground",
            ground,
            "-o",
            arg(&out),
            "--force",
        ])
    };
    let o = run("auto");
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    let tilt: f64 = err
        .split("from its +Z")
        .next()
        .and_then(|s| s.rsplit(", ").next())
        .and_then(|s| s.trim().trim_end_matches('°').parse().ok())
        .unwrap_or_else(|| panic!("no grounding note: {err}"));
    // The synthetic body bends both knees together, so its feet rise and fall as one and the
    // plane is fitted to their lower envelope: the tilt is found to within a few degrees (the
    // real-data tests hold ZED clips to 3°).
    assert!((tilt - 20.0).abs() < 5.0, "tilt {tilt}°: {err}");
    let o = run("off");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(!stderr(&o).contains("grounded"), "{}", stderr(&o));
}

/// The people of one marker topic were seen by one camera: `convert` stands them on one floor
/// with one grounding, so they keep their places and headings relative to each other (grounded
/// each on its own, both would stand on the origin facing +Y).
#[test]
fn the_people_of_one_camera_topic_keep_their_places() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("camera.mcap");
    let camera_from_world = nalgebra::Isometry3::from_parts(
        nalgebra::Translation3::new(0.3, -0.2, 4.0),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 20f64.to_radians()),
    );
    // Person "a" as `h36m_frame` walks, 0.6 m to the left; person "b" turned about +Z by 150°
    // and 0.6 m to the right.
    let turned = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 150f64.to_radians());
    let world = |k: usize, ns: &str| -> Vec<nalgebra::Point3<f64>> {
        h36m_frame(k)
            .positions_m
            .iter()
            .map(|p| match ns {
                "a" => p + Vector3::new(-0.6, 0.0, 0.0),
                _ => turned * p + Vector3::new(0.6, 0.0, 0.0),
            })
            .collect()
    };
    let mut w = BagWriter::create(&path, WriteConfig::default()).unwrap();
    for k in 0..60 {
        let stamp = h36m_frame(k).stamp_nanos;
        let header = Header {
            stamp: Time::from_nanos(stamp),
            frame_id: "camera".into(),
        };
        let markers = ["a", "b"]
            .into_iter()
            .flat_map(|ns| {
                let header = header.clone();
                world(k, ns)
                    .into_iter()
                    .enumerate()
                    .map(move |(j, p)| Marker {
                        header: header.clone(),
                        ns: ns.into(),
                        id: i32::try_from(j).unwrap(),
                        type_: Marker::SPHERE,
                        pose: Pose {
                            position: Point::from(camera_from_world * p),
                            ..Pose::default()
                        },
                        ..Marker::default()
                    })
            })
            .collect();
        w.write("/markers", stamp, &MarkerArray { markers })
            .unwrap();
    }
    w.finish().unwrap();
    let out = dir.path().join("out.mcap");
    let o = autoact(&[
        "-v",
        "convert",
        arg(&path),
        "--layout",
        "h36m-17",
        "-o",
        arg(&out),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("track 1: grounded with track 0"),
        "{}",
        stderr(&o)
    );
    let frames = bone_frames(&out);
    let at = |k: usize, track: u64| {
        frames
            .iter()
            .filter(|(_, f)| f.track_id == track && f.variant == 0)
            .nth(k)
            .map(|(_, f)| f.clone())
            .unwrap()
    };
    let root = |f: &BoneFrame| {
        let t = &f.root_translation;
        Vector3::new(t.x, t.y, t.z)
    };
    let heading = |f: &BoneFrame| {
        let q = &f.local_rotations[0];
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z));
        let forward = q * Vector3::y();
        forward.y.atan2(forward.x)
    };
    // The pelvis (H36M joint 0) of both people in the world they were made in.
    let pelvis_gap_m = |k: usize| (world(k, "b")[0] - world(k, "a")[0]).norm();
    for k in [0, 30, 59] {
        let (a, b) = (at(k, 0), at(k, 1));
        let gap_m = (root(&b) - root(&a)).norm();
        assert!(
            (gap_m - pelvis_gap_m(k)).abs() < 0.05,
            "frame {k}: {gap_m} m apart, made {} m apart",
            pelvis_gap_m(k)
        );
        let turn = (heading(&b) - heading(&a)).to_degrees().rem_euclid(360.0);
        assert!((turn - 150.0).abs() < 5.0, "frame {k}: turned {turn}°");
    }
}

/// A person in a marker array: namespace, person number in the sphere ids, frames seen in.
type MarkerPerson = (&'static str, i32, std::ops::Range<usize>);

/// A `MarkerArray` bag on `/body_tracking_data`: 60 frames of `people` (each [`posed_frame`] of
/// `layout`, moved along +X by its person number and namespace length), a `SPHERE` per joint
/// with id `person × 100 + joint`, every point moved by `place`.
fn marker_people_bag(
    path: &Path,
    layout: &str,
    people: &[MarkerPerson],
    place: impl Fn(nalgebra::Point3<f64>) -> nalgebra::Point3<f64>,
) {
    let mut w = BagWriter::create(path, WriteConfig::default()).unwrap();
    for k in 0..60 {
        let f = posed_frame(layout, k);
        let header = Header {
            stamp: Time::from_nanos(f.stamp_nanos),
            frame_id: "depth_camera_link".into(),
        };
        let mut markers = Vec::new();
        for (ns, person, seen) in people {
            if !seen.contains(&k) {
                continue;
            }
            #[expect(clippy::cast_precision_loss, reason = "short names")]
            let shift = Vector3::new(f64::from(*person) + ns.len() as f64, 0.0, 0.0);
            markers.extend(f.positions_m.iter().enumerate().map(|(j, p)| Marker {
                header: header.clone(),
                ns: (*ns).into(),
                id: person * 100 + i32::try_from(j).unwrap(),
                type_: Marker::SPHERE,
                pose: Pose {
                    position: Point::from(place(p + shift)),
                    ..Pose::default()
                },
                ..Marker::default()
            }));
        }
        w.write(
            "/body_tracking_data",
            f.stamp_nanos,
            &MarkerArray { markers },
        )
        .unwrap();
    }
    w.finish().unwrap();
}

/// People in marker arrays keep their tracks while others come and go, whether each has a
/// namespace or, as the Azure Kinect / Orbbec ROS drivers publish them, all share one and a
/// sphere's id is `person × 100 + joint` (here in the driver's layout, `azure-kinect-32`, and its
/// depth camera's frame: x right, y down, z ahead). Tracks were once numbered by a person's place
/// in each message, so when the first person left, the next took over their track: one
/// animation jumped from one body to the other, with no error.
#[test]
fn people_in_marker_arrays_keep_their_tracks_when_others_leave() {
    let dir = tempfile::tempdir().unwrap();
    // The depth camera 3 m behind the people, 1 m up, pitched 10° down.
    let depth_camera_from_world = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.17)
        * UnitQuaternion::from_matrix(&nalgebra::Matrix3::new(
            1.0, 0.0, 0.0, //
            0.0, 0.0, -1.0, //
            0.0, 1.0, 0.0,
        ));
    let named = dir.path().join("namespaces.mcap");
    marker_people_bag(
        &named,
        "h36m-17",
        &[("a", 0, 0..20), ("b", 0, 0..60)],
        |p| p,
    );
    let azure = dir.path().join("ids.mcap");
    marker_people_bag(
        &azure,
        "azure-kinect-32",
        &[("", 1, 10..60), ("", 2, 0..60)],
        |p| depth_camera_from_world * (p - Vector3::new(0.0, -3.0, 1.0)),
    );
    let rig = Rig::standard();
    let pelvis = rig.bone_index("pelvis").unwrap();
    for (path, layout, expected) in [
        (&named, "h36m-17", [(0, 20), (1, 60)]),
        (&azure, "azure-kinect-32", [(0, 60), (1, 50)]),
    ] {
        let out = path.with_extension("anim.mcap");
        let o = autoact(&[
            "-v",
            "convert",
            arg(path),
            "--layout",
            layout,
            "--fps",
            "30",
            "-o",
            arg(&out),
        ]);
        assert!(o.status.success(), "{layout}: {}", stderr(&o));
        assert!(
            stderr(&o).contains(": grounded: up"),
            "{layout}: {}",
            stderr(&o)
        );
        let frames = bone_frames(&out);
        for (track, count) in expected {
            let n = frames.iter().filter(|(_, f)| f.track_id == track).count();
            assert_eq!(n, count, "{layout}: track {track}");
        }
        // Stood up from the camera's frame: the pelvis (under the yaw-only root) upright.
        for (_, f) in &frames {
            let world = [0, pelvis]
                .iter()
                .fold(UnitQuaternion::identity(), |w, &b| {
                    let q = &f.local_rotations[b];
                    w * UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                        q.w, q.x, q.y, q.z,
                    ))
                });
            let up = world * Vector3::z();
            assert!(up.z > 0.95, "{layout}: track {} pelvis up {up}", f.track_id);
        }
    }
}

#[test]
fn dsi_on_long_clips_of_several_people_is_written_in_one_stamp_order() {
    // Two people for 3,000 frames (more than one of DSI's 2,048-frame windows), person 8 with a
    // 10 s gap; two variants each: six animations made window by window and merged.
    let dir = tempfile::tempdir().unwrap();
    let path = two_people_bag(dir.path(), 3000, |k, track| {
        track == 3 || !(1000..1300).contains(&k)
    });
    let out = dir.path().join("out.mcap");
    let o = autoact(&[
        "convert",
        arg(&path),
        "-o",
        arg(&out),
        "--dsi",
        "--variants",
        "2",
        "--max-gap",
        "1",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let frames = bone_frames(&out);
    let key = |(t, f): &(u64, BoneFrame)| (*t, f.track_id, f.variant);
    assert!(
        frames.windows(2).all(|w| key(&w[0]) < key(&w[1])),
        "not in (stamp, person, variant) order"
    );
    for track in [3, 8] {
        let count = |v: u32| {
            frames
                .iter()
                .filter(|(_, f)| f.track_id == track && f.variant == v)
                .count()
        };
        assert!(count(0) >= 2700, "track {track}: {} frames", count(0));
        assert_eq!(count(1), count(0), "track {track}");
        assert_eq!(count(2), count(0), "track {track}");
    }
    // Nothing of person 8 inside its gap.
    let (gap_start, gap_end) = (stamp_nanos_at(1000, 30.0), stamp_nanos_at(1299, 30.0));
    assert!(
        frames
            .iter()
            .filter(|(_, f)| f.track_id == 8)
            .all(|(t, _)| *t < gap_start || *t > gap_end)
    );
    // No temporary file is left next to the output.
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(left.len(), 2, "{left:?}");
}

#[test]
fn a_long_json_file_is_imported_frame_by_frame_in_stamp_then_track_order() {
    // 9,000 frames (past the 8,192-frame sample), two people listed as 7 then 2, person 7
    // missing for 100 frames: both grounded and length-fixed on their samples, every frame
    // written, in (stamp, track) order.
    let dir = tempfile::tempdir().unwrap();
    let poses: Vec<Vec<[f64; 3]>> = (0..300).map(h36m_keypoints).collect();
    let json = dir.path().join("long.json");
    let mut text = String::from("[");
    for k in 0..9000usize {
        let pose = &poses[k % poses.len()];
        let shifted: Vec<[f64; 3]> = pose.iter().map(|p| [p[0] + 1.0, p[1], p[2]]).collect();
        let mut people = Vec::new();
        if !(100..200).contains(&k) {
            people.push(serde_json::json!({"track_id": 7, "keypoints": pose}));
        }
        people.push(serde_json::json!({"track_id": 2, "keypoints": shifted}));
        if k > 0 {
            text.push(',');
        }
        text += &serde_json::json!({"frame_id": k, "instances": people}).to_string();
    }
    text.push(']');
    std::fs::write(&json, text).unwrap();
    let bag = dir.path().join("long.pose.mcap");
    let o = import_h36m_json(&json, &bag, &["--lengths", "fixed"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = common::stdout(&o);
    assert!(out.contains("17900 skeletons (2 tracks)"), "{out}");
    for track in [2, 7] {
        assert!(out.contains(&format!("track {track}: grounded")), "{out}");
        assert!(
            out.contains(&format!("track {track}: l_hip→l_knee→l_ankle held at")),
            "{out}"
        );
    }
    let skeletons: Vec<(u64, u64)> = BagReader::open(&bag)
        .unwrap()
        .messages()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == "/skeleton")
        .map(|m| {
            let s = cdr::decode::<Skeleton3D>(&m.data).unwrap();
            (s.header.stamp.to_nanos().unwrap(), s.track_id)
        })
        .collect();
    assert_eq!(skeletons.len(), 17_900);
    assert!(
        skeletons.windows(2).all(|w| w[0] < w[1]),
        "not in (stamp, track) order"
    );
    // The file has no time of day: its timeline starts at the default instant, 2000-01-01.
    let start = 946_684_800_000_000_000;
    assert_eq!(skeletons[0], (start, 2));
    assert_eq!(skeletons[1], (start, 7));
}

#[test]
fn import_starts_the_timeline_at_the_instant_asked_and_refuses_one_without_offset() {
    let dir = tempfile::tempdir().unwrap();
    let frames: Vec<serde_json::Value> = (0..10usize)
        .map(
            |k| serde_json::json!({"frame_id": k, "instances": [{"keypoints": h36m_keypoints(k)}]}),
        )
        .collect();
    let json = dir.path().join("short.json");
    std::fs::write(&json, serde_json::to_string(&frames).unwrap()).unwrap();
    let bag = dir.path().join("short.pose.mcap");
    let o = import_h36m_json(
        &json,
        &bag,
        &["--start-time", "2024-05-01T09:00:00.5+02:00"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let reader = BagReader::open(&bag).unwrap();
    let stamps: Vec<u64> = reader
        .messages()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == "/skeleton")
        .map(|m| {
            let s = cdr::decode::<Skeleton3D>(&m.data).unwrap();
            assert_eq!(
                s.header.stamp.to_nanos(),
                Some(m.log_time),
                "header and log time agree"
            );
            m.log_time
        })
        .collect();
    // 2024-05-01T07:00:00.5Z, then 30 fps.
    let start = 1_714_546_800_500_000_000;
    assert_eq!(stamps[0], start);
    assert_eq!(stamps[9] - stamps[0], 300_000_000);
    let info = common::stdout(&autoact(&["info", arg(&bag)]));
    assert!(
        info.contains("start_time=2024-05-01T07:00:00.500Z"),
        "{info}"
    );
    // The bag's time span is printed as instants (and in nanoseconds for scripts).
    assert!(
        info.contains(&format!(
            "time: 2024-05-01T07:00:00.500Z .. 2024-05-01T07:00:00.800Z (0.300 s; {start} .. {} ns)",
            start + 300_000_000
        )),
        "{info}"
    );

    let o = import_h36m_json(
        &json,
        &dir.path().join("bad.pose.mcap"),
        &["--start-time", "2024-05-01T09:00:00"],
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("UTC offset"), "{}", stderr(&o));
}

#[test]
fn degenerate_input_is_explained_per_bone_and_kind() {
    // A left wrist lost for 5 frames, a right elbow below the confidence threshold for 3, a left
    // knee on its hip (a zero-length thigh) for 2: each counted on the bone it drives, by kind,
    // at -v on stderr and in the output's `autoact.degenerate` record, which `info` shows.
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "bad.mcap", 40, |k, s| {
        if (10..15).contains(&k) {
            s.positions[13].x = f64::NAN;
        }
        if (20..23).contains(&k) {
            s.confidence[15] = 0.05;
        }
        if (30..32).contains(&k) {
            s.positions[5] = s.positions[4];
        }
    });
    let out = dir.path().join("out.mcap");
    let o = autoact(&["-v", "convert", arg(&input), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("l_forearm took the degenerate-input path: missing joint ×5"),
        "{err}"
    );
    assert!(common::stdout(&o).contains("10 frames needed the degenerate-input path (per bone"));
    let info = autoact(&["info", arg(&out), "--format", "json"]);
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    let record = v["metadata"]
        .as_array()
        .unwrap()
        .iter()
        .find(|m| m["name"] == "autoact.degenerate")
        .expect("the record")["metadata"]
        .clone();
    let of = |bone: &str| {
        record[format!("track 0 {bone}")]
            .as_str()
            .unwrap_or("")
            .to_string()
    };
    assert_eq!(of("l_forearm"), "missing joint ×5", "{record}");
    assert!(of("r_upper_arm").contains("low confidence ×3"), "{record}");
    assert!(of("r_forearm").contains("low confidence ×3"), "{record}");
    assert!(of("l_thigh").contains("zero-length bone ×2"), "{record}");
    // A clean clip writes no record.
    let clean = dir.path().join("clean.mcap");
    let input = pose_bag(dir.path(), "clean_in.mcap", 40, |_, _| {});
    assert!(
        autoact(&["convert", arg(&input), "-o", arg(&clean)])
            .status
            .success()
    );
    let info = common::stdout(&autoact(&["info", arg(&clean)]));
    assert!(!info.contains("autoact.degenerate"), "{info}");
}

#[test]
fn dsi_on_a_clip_cut_by_hundreds_of_gaps_opens_two_files_per_person() {
    // 900 frames, a 1 s gap after every 6th: 150 stretches, each solved on its own, all in two
    // temporary files, so that 32 open files are plenty.
    let dir = tempfile::tempdir().unwrap();
    let input = pose_bag(dir.path(), "gappy.mcap", 900, |k, s| {
        let nanos = s.header.stamp.to_nanos().unwrap() + (k as u64 / 6) * 1_000_000_000;
        s.header.stamp = Time::from_nanos(nanos);
    });
    let out = dir.path().join("out.mcap");
    let o = std::process::Command::new("sh")
        .arg("-c")
        .arg(format!(
            "ulimit -n 32; exec '{}' convert '{}' -o '{}' --dsi --max-gap 0.5",
            env!("CARGO_BIN_EXE_autoact"),
            input.display(),
            out.display()
        ))
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        common::stdout(&o).contains("150 unit motions"),
        "{}",
        common::stdout(&o)
    );
    let frames = bone_frames(&out);
    assert!(frames.windows(2).all(|w| w[0].0 < w[1].0));
    assert!(frames.len() >= 880, "{} frames", frames.len());
}

/// The 33 landmarks of the checked-in MediaPipe detection (`tests/data`, Apache-2.0), as
/// (x, y, z) in its normalised image units, y down.
fn mediapipe_landmarks() -> Vec<[f64; 3]> {
    let text = std::fs::read_to_string(repo("tests/data/mediapipe_pose_landmarks.pbtxt")).unwrap();
    let value = |line: &str, key: &str| {
        line.trim()
            .strip_prefix(key)
            .map(|v| v.trim().parse::<f64>().unwrap())
    };
    let mut points = Vec::new();
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        if line.trim() == "landmark {" {
            let mut xyz = [f64::NAN; 3];
            for (slot, key) in xyz.iter_mut().zip(["x:", "y:", "z:"]) {
                *slot = value(lines.next().unwrap(), key).unwrap();
            }
            points.push(xyz);
        }
    }
    points
}

#[test]
fn a_mediapipe_detection_converts_with_hands_and_feet_driven() {
    // A real MediaPipe Pose detection (not a pose we posed): imported as MMPose-style JSON with
    // the built-in layout and converted, no frame takes the degenerate-input path, and the hands
    // (aimed at the index knuckle, twisted by the knuckle line) and feet (aimed at the toes)
    // leave rest. The file holds image-normalised landmarks (x and y scaled by the image's width
    // and height), not the metric world landmarks the layout is for, so this checks the table on
    // a real detector's arrangement of points, not the angles it gives.
    let landmarks = mediapipe_landmarks();
    assert_eq!(landmarks.len(), 33);
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("mediapipe.json");
    let frames: Vec<serde_json::Value> = (0..3)
        .map(|k| serde_json::json!({"frame_id": k, "instances": [{"keypoints": landmarks}]}))
        .collect();
    std::fs::write(&json, serde_json::to_string(&frames).unwrap()).unwrap();
    let (pose, anim) = (dir.path().join("p.mcap"), dir.path().join("a.mcap"));
    let o = autoact(&[
        "import",
        arg(&json),
        "--layout",
        "mediapipe",
        "--fps",
        "30",
        "-o",
        arg(&pose),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = autoact(&["convert", arg(&pose), "-o", arg(&anim), "--fps", "30"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        common::stdout(&o).contains("0 frames needed the degenerate-input path"),
        "{}",
        common::stdout(&o)
    );
    let frames = bone_frames(&anim);
    assert_eq!(frames.len(), 3);
    let (_, frame) = &frames[0];
    for bone in [
        "l_hand",
        "r_hand",
        "l_foot",
        "r_foot",
        "l_forearm",
        "r_thigh",
    ] {
        let i = frame.bone_names.iter().position(|b| b == bone).unwrap();
        let q = &frame.local_rotations[i];
        let angle_deg = 2.0 * q.w.abs().min(1.0).acos().to_degrees();
        assert!(angle_deg > 1.0, "{bone} at rest ({angle_deg:.2}°)");
    }
}
