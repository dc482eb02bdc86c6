//! `autoact plan` and `autoact convert --spec` on specs written here: counts, determinism, every
//! kind of bad spec, the camera keeping the character in frame in the written bags, and the
//! paper's NTU-scale plan.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::common::{self, arg, autoact, stderr, stdout};

use autoact::bags::animation::TfTree;
use autoact::mcap_io::BagReader;
use autoact::ros::autoact_msgs::Segment;
use autoact::ros::builtin_interfaces::Time;
use autoact::ros::cdr;
use autoact::ros::geometry_msgs::PoseStamped;
use autoact::ros::sensor_msgs::CameraInfo;
use autoact::ros::tf2_msgs::TFMessage;
use autoact::ros::visualization_msgs::MarkerArray;
use nalgebra::{Point3, UnitQuaternion};

/// A spec over the two sample bags, with `dataset`, `counts` and extra sections.
fn spec_text(seed: u64, counts: &str, extra: &str) -> String {
    format!(
        r#"[dataset]
name = "t"
seed = {seed}
fps = 30.0
resolution = [640, 360]
[counts]
{counts}
{extra}
[[class]]
category = "gesture"
action = "wave"
sources = ["{wave}"]

[[class]]
category = "locomotion"
action = "walk"
sources = ["{walk}"]
"#,
        wave = common::repo("bags/bandai_wave.pose.mcap"),
        walk = common::repo("bags/bandai_walk.pose.mcap"),
    )
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn plan_counts_and_its_three_formats_agree() {
    let dir = tempfile::tempdir().unwrap();
    let spec = write(
        dir.path(),
        "s.toml",
        &spec_text(1, "variants = 2\nscenes = 3\nviewpoints = 2", ""),
    );
    let o = autoact(&["plan", arg(&spec)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = stdout(&o);
    assert!(
        text.contains(
            "2 animations × 2 variants × 3 scenes × 2 viewpoints = 24 segments in 2 sessions"
        ),
        "{text}"
    );
    for section in ["weather", "time", "location", "character", "expected size"] {
        assert!(text.contains(section), "{section}: {text}");
    }
    let csv = stdout(&autoact(&["plan", arg(&spec), "--format", "csv"]));
    assert_eq!(csv.lines().count(), 25);
    let ids: BTreeSet<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').next().unwrap())
        .collect();
    assert_eq!(ids.len(), 24);
    let json: serde_json::Value =
        serde_json::from_str(&stdout(&autoact(&["plan", arg(&spec), "--format", "json"]))).unwrap();
    assert_eq!(json["plan"]["leaves"].as_array().unwrap().len(), 24);
    assert_eq!(json["plan"]["labels"], serde_json::json!(["walk", "wave"]));
    // The default policy (`whole`): one clip a segment, in all three formats.
    assert!(text.contains("expected size: 24 clips,"), "{text}");
    assert_eq!(json["expected"]["clips"], 24);
    assert!(csv.lines().skip(1).all(|l| l.ends_with(",1")), "{csv}");

    // Clips found from the motion cannot be counted before it is trimmed: said, not guessed.
    let spec = write(
        dir.path(),
        "i.toml",
        &spec_text(
            1,
            "variants = 2\nscenes = 3\nviewpoints = 2",
            "[clips]\npolicy = \"instances\"",
        ),
    );
    let text = stdout(&autoact(&["plan", arg(&spec)]));
    assert!(
        text.contains(
            "expected size: the clips found in 24 segments cut into instances (not known from the plan"
        ),
        "{text}"
    );
    let csv = stdout(&autoact(&["plan", arg(&spec), "--format", "csv"]));
    assert!(csv.lines().skip(1).all(|l| l.ends_with(',')), "{csv}");
}

fn segments(path: &Path) -> Vec<Segment> {
    BagReader::open(path)
        .unwrap()
        .messages()
        .map(Result::unwrap)
        .filter(|m| m.channel.topic == "/segments")
        .map(|m| cdr::decode::<Segment>(&m.data).unwrap())
        .collect()
}

#[test]
fn capture_bags_are_deterministic_labelled_and_keep_the_character_in_frame() {
    let dir = tempfile::tempdir().unwrap();
    let counts = "variants = 2\nscenes = 2\nviewpoints = 3\nshot = \"moving\"";
    let spec = write(dir.path(), "s.toml", &spec_text(5, counts, ""));
    let run = |name: &str, spec: &Path| {
        let out = dir.path().join(name);
        let o = autoact(&["convert", "--spec", arg(spec), "-o", arg(&out)]);
        assert!(o.status.success(), "{}", stderr(&o));
        out
    };
    let (a, b) = (run("a", &spec), run("b", &spec));
    let bags: Vec<PathBuf> = {
        let mut v: Vec<PathBuf> = std::fs::read_dir(&a)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
            .collect();
        v.sort();
        v
    };
    assert_eq!(bags.len(), 2, "one session per animation");
    for bag in &bags {
        let twin = b.join(bag.file_name().unwrap());
        assert_eq!(
            std::fs::read(bag).unwrap(),
            std::fs::read(&twin).unwrap(),
            "{bag:?}"
        );
    }
    // Another seed: other bags.
    let other = write(dir.path(), "o.toml", &spec_text(6, counts, ""));
    let c = run("c", &other);
    assert_ne!(
        std::fs::read(&bags[0]).unwrap(),
        std::fs::read(c.join(bags[0].file_name().unwrap())).unwrap()
    );

    // Segments: 12 per session, unique ids, labels by sorted name, back to back from the
    // timeline's start: the spec's start_time, by default 2000-01-01T00:00:00Z (not 1970).
    let mut ids = BTreeSet::new();
    for bag in &bags {
        let segs = segments(bag);
        assert_eq!(segs.len(), 12);
        let mut end = Time::from_nanos(946_684_800_000_000_000);
        for s in &segs {
            assert!(ids.insert(s.id.clone()));
            assert_eq!(s.label_id, u32::from(s.action == "wave"));
            assert_eq!(s.start, end);
            assert!(s.start.to_nanos() < s.content_start.to_nanos());
            assert!(s.content_end.to_nanos() < s.end.to_nanos());
            end = s.end;
        }
    }

    // Framing: every point of the drawn skeleton in every frame projects inside the image with
    // the 5% margin, and the camera is above the ground. The skeleton is placed as a viewer
    // places it: the markers in their bones' tf frames, the frames by `/tf_static` and `/tf`.
    for bag in &bags {
        let mut tf = TfTree::default();
        let (mut camera, mut info, mut markers) = (None, None, None);
        let mut frames = 0;
        // Checks the instant whose messages have all been read.
        let mut check = |tf: &TfTree,
                         camera: &Option<PoseStamped>,
                         info: &Option<CameraInfo>,
                         markers: &Option<MarkerArray>,
                         stamp: u64| {
            let (Some(cam), Some(info), Some(markers)) = (camera, info, markers) else {
                panic!("{bag:?} {stamp} ns: no camera or no markers yet");
            };
            assert_eq!(cam.header.stamp.to_nanos(), Some(stamp));
            assert!(cam.pose.position.z > 0.0, "camera below the ground");
            let q: UnitQuaternion<f64> = cam.pose.orientation.try_into().unwrap();
            let c = Point3::from(cam.pose.position);
            let (w, h) = (f64::from(info.width), f64::from(info.height));
            for marker in &markers.markers {
                let world_from_bone = tf.world_from(&marker.header.frame_id).unwrap();
                for p in &marker.points {
                    let v = q.inverse() * (world_from_bone * Point3::from(*p) - c);
                    assert!(v.z > 0.0, "a joint behind the camera");
                    let u = info.k[0] * v.x / v.z + info.k[2] + 0.5;
                    let y = info.k[4] * v.y / v.z + info.k[5] + 0.5;
                    let (mu, mv) = (0.05 * w / 2.0, 0.05 * h / 2.0);
                    assert!(
                        u > mu && u < w - mu && y > mv && y < h - mv,
                        "{bag:?} frame {frames}: a joint at ({u:.0}, {y:.0}) leaves the {w}×{h} image"
                    );
                }
            }
            frames += 1;
        };
        let mut instant = None;
        // Every rest offset each tf frame of the body is given over the whole bag (bit patterns).
        let mut offsets: BTreeMap<String, BTreeSet<[u64; 3]>> = BTreeMap::new();
        for m in BagReader::open(bag).unwrap().messages().map(Result::unwrap) {
            if instant.is_some_and(|t| t != m.log_time) && m.channel.topic != "/tf_static" {
                check(&tf, &camera, &info, &markers, instant.unwrap());
                instant = None;
            }
            match m.channel.topic.as_str() {
                "/camera/pose" => camera = Some(cdr::decode(&m.data).unwrap()),
                "/camera/camera_info" => info = Some(cdr::decode(&m.data).unwrap()),
                "/skeleton/markers" => markers = Some(cdr::decode(&m.data).unwrap()),
                topic @ ("/tf_static" | "/tf") => {
                    let message: TFMessage = cdr::decode(&m.data).unwrap();
                    for t in &message.transforms {
                        let v = t.transform.translation;
                        if !t.child_frame_id.ends_with("root") && t.child_frame_id != "camera" {
                            offsets
                                .entry(t.child_frame_id.clone())
                                .or_default()
                                .insert([v.x, v.y, v.z].map(f64::to_bits));
                        }
                    }
                    tf.update(&message).unwrap();
                    if topic == "/tf" {
                        instant = Some(m.log_time);
                    }
                }
                _ => {}
            }
        }
        check(&tf, &camera, &info, &markers, instant.unwrap());
        assert!(frames > 1000, "{frames} frames");
        // Each scene draws a new body, in frames of its own (`scene<i>/`): no tf frame's offset
        // ever changes, so a viewer interpolating over time cannot blend two scenes' bodies.
        let changing: Vec<&String> = offsets
            .iter()
            .filter(|(_, o)| o.len() > 1)
            .map(|(f, _)| f)
            .collect();
        assert!(
            changing.is_empty(),
            "{bag:?}: frames whose rest offset changes: {changing:?}"
        );
        for scene in 0..4 {
            let prefix = format!("scene{scene}/");
            assert!(
                offsets.keys().any(|f| f.starts_with(&prefix)),
                "{bag:?}: no frame of scene {scene}"
            );
        }
    }

    let info = autoact(&["info", arg(&bags[0])]);
    let text = stdout(&info);
    assert!(
        text.contains("hierarchy (/segments): 1 categories, 1 actions, 1 animations, 2 variants, 4 scenes, 12 segments"),
        "{text}"
    );
    assert!(text.contains("verdict: valid"), "{text}");
}

#[test]
fn bad_specs_are_clear_errors_naming_the_key() {
    let dir = tempfile::tempdir().unwrap();
    let good = spec_text(1, "", "");
    let cases: [(&str, String, &str); 8] = [
        (
            "unknown weather",
            spec_text(1, "", "[scene]\nweather_weights = { SUNNY = 1 }"),
            "SUNNY",
        ),
        (
            "negative range",
            spec_text(1, "", "[camera]\ndelta_xy_m = [0.8, -0.8]"),
            "delta_xy_m",
        ),
        (
            "negative height",
            spec_text(1, "", "[camera]\nheight_m = [-1.0, 2.0]"),
            "height_m",
        ),
        (
            "no sources",
            good.replace(
                &format!("[\"{}\"]", common::repo("bags/bandai_walk.pose.mcap")),
                "[]",
            ),
            "class[1].sources",
        ),
        (
            "missing path",
            good.replace("bandai_walk.pose.mcap", "nope.mcap"),
            "class[1].sources[0]",
        ),
        (
            "escaping label",
            good.replace("action = \"walk\"", "action = \"../x\""),
            "escape the output folder",
        ),
        (
            "unknown key",
            good.replace("fps = 30.0", "fsp = 30.0"),
            "fsp",
        ),
        (
            "zero scenes",
            spec_text(1, "scenes = 0", ""),
            "counts.scenes",
        ),
    ];
    for (what, text, expect) in cases {
        let spec = write(dir.path(), "bad.toml", &text);
        let o = autoact(&["plan", arg(&spec)]);
        assert_eq!(o.status.code(), Some(1), "{what}: {}", stderr(&o));
        let err = stderr(&o);
        assert!(
            err.contains(expect) && err.contains("bad.toml"),
            "{what}: {err}"
        );
    }
}

#[test]
fn the_papers_ntu_scale_plan_has_exact_counts_and_unique_ids() {
    // 1,566 animations × 4 positions × 3 viewpoints = 18,792 clips (the paper's NTU-like plan).
    // Every source a copy of the walking sample (its summary is all a plan reads).
    let dir = tempfile::tempdir().unwrap();
    let bag = PathBuf::from(common::repo("bags/bandai_walk.pose.mcap"));
    let mut classes = String::new();
    let mut n = 0;
    for c in 0..54 {
        let sources: Vec<String> = (0..29)
            .map(|i| {
                let name = format!("c{c:02}_{i:02}.mcap");
                std::fs::copy(&bag, dir.path().join(&name)).unwrap();
                n += 1;
                format!("\"{name}\"")
            })
            .collect();
        classes.push_str(&format!(
            "[[class]]\ncategory = \"daily\"\naction = \"A{c:03}\"\nsources = [{}]\n",
            sources.join(", ")
        ));
    }
    assert_eq!(n, 1566);
    let spec = write(
        dir.path(),
        "ntu.toml",
        &format!(
            "[dataset]\nname = \"ntu\"\nseed = 3\n[counts]\nscenes = 4\nviewpoints = 3\n{classes}"
        ),
    );
    let o = autoact(&["plan", arg(&spec), "--format", "csv"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = stdout(&o);
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 18_792);
    let ids: BTreeSet<&str> = rows.iter().map(|r| r.split(',').next().unwrap()).collect();
    assert_eq!(ids.len(), 18_792, "every clip has its own id");
    assert!(
        rows.iter()
            .all(|r| r.split(',').nth(3).is_some_and(|a| a.starts_with('A')))
    );
    let summary = stdout(&autoact(&["plan", arg(&spec)]));
    assert!(
        summary.contains("1566 animations × 1 variants × 4 scenes × 3 viewpoints = 18792 segments"),
        "{summary}"
    );
}

#[test]
fn a_spec_source_may_be_a_file_import_reads() {
    // The wave as a BVH file (written by `export`, read back through the autoact53 mapping):
    // planned and captured like the bag it came from; MMPose JSON is refused with the way out.
    let dir = tempfile::tempdir().unwrap();
    let bvh = dir.path().join("wave.bvh");
    let o = autoact(&[
        "export",
        &common::repo("bags/bandai_wave.anim.mcap"),
        "--format",
        "bvh",
        "-o",
        arg(&bvh),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = spec_text(3, "variants = 1\nscenes = 1\nviewpoints = 1", "")
        .replace(&common::repo("bags/bandai_wave.pose.mcap"), "wave.bvh");
    let spec = write(dir.path(), "s.toml", &text);
    let o = autoact(&["plan", arg(&spec)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let planned = stdout(&o);
    let out = dir.path().join("capture");
    let o = autoact(&["convert", "--spec", arg(&spec), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bags = std::fs::read_dir(&out)
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .path()
                .extension()
                .is_some_and(|x| x == "mcap")
        })
        .count();
    assert_eq!(bags, 2, "one capture bag per animation");
    // The same spec over the bag plans the same clip lengths to within a frame or two.
    let from_bag = stdout(&autoact(&[
        "plan",
        arg(&write(
            dir.path(),
            "b.toml",
            &spec_text(3, "variants = 1\nscenes = 1\nviewpoints = 1", ""),
        )),
    ]));
    assert_eq!(
        planned.lines().find(|l| l.contains("segments in")),
        from_bag.lines().find(|l| l.contains("segments in")),
        "{planned}\n{from_bag}"
    );
    let json = write(dir.path(), "wave.json", "[]");
    let text = text.replace("wave.bvh", &json.display().to_string());
    let o = autoact(&["plan", arg(&write(dir.path(), "j.toml", &text))]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("autoact import"), "{}", stderr(&o));
}

/// A CMU Panoptic sequence folder (`body3DScene_<frame>.json`, centimetres, +Y down): one person,
/// the rig's rest landmarks swaying sideways and raising the right wrist, 29.97 fps.
fn panoptic_folder(dir: &Path, frames: usize) -> PathBuf {
    use autoact::skeleton::layout::{JointExpr, Layout};
    use autoact::skeleton::rig::Rig;
    let rig = Rig::standard();
    let layout = Layout::builtin("panoptic-coco19").unwrap();
    let rest: Vec<Point3<f64>> = layout
        .joints
        .iter()
        .map(|joint| {
            let (landmark, _) = layout
                .landmarks
                .iter()
                .find(|(_, e)| **e == JointExpr::Joint(joint.clone()))
                .unwrap();
            rig.landmarks[rig.landmark_index(landmark).unwrap()].rest_m
        })
        .collect();
    let folder = dir.join("hdPose3d_stage1_coco19");
    std::fs::create_dir(&folder).unwrap();
    for k in 0..frames {
        let t = k as f64 / 29.97;
        let values: Vec<String> = rest
            .iter()
            .zip(&layout.joints)
            .flat_map(|(p, joint)| {
                let mut p = *p + nalgebra::Vector3::new(0.1 * t.sin(), 0.0, 0.0);
                if joint == "rWrist" {
                    p.z += 0.4 * (1.0 - (2.0 * t).cos());
                }
                // autoact (x, y, z) m, +Z up → Panoptic (x, −z, y) cm, +Y down.
                [p.x * 100.0, -p.z * 100.0, p.y * 100.0, 0.6].map(|v| format!("{v:.3}"))
            })
            .collect();
        let text = format!(
            "{{ \"version\": 0.7, \"univTime\": {:.3}, \"fpsType\": \"hd_29_97\",\n\"bodies\": [{{ \"id\": 0, \"joints19\": [{}] }}] }}",
            1000.0 + t * 1000.0,
            values.join(", ")
        );
        std::fs::write(
            folder.join(format!("body3DScene_{:08}.json", 100 + k)),
            text,
        )
        .unwrap();
    }
    folder
}

#[test]
fn a_spec_source_may_be_a_cmu_panoptic_folder() {
    // A folder is not a bag: it is read as `import` reads it, at the files' own rate.
    let dir = tempfile::tempdir().unwrap();
    let folder = panoptic_folder(dir.path(), 90);
    let text = spec_text(3, "variants = 1\nscenes = 1\nviewpoints = 1", "").replace(
        &common::repo("bags/bandai_wave.pose.mcap"),
        &folder.display().to_string(),
    );
    let spec = write(dir.path(), "s.toml", &text);
    let o = autoact(&["plan", arg(&spec)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = dir.path().join("capture");
    let o = autoact(&["convert", "--spec", arg(&spec), "-o", arg(&out)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bags: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".capture.mcap"))
        .collect();
    assert_eq!(bags.len(), 2, "one capture bag per animation: {bags:?}");
    // And `import` finds it by itself, keeping the files' rate and frame.
    let bag = dir.path().join("p.pose.mcap");
    let o = autoact(&["import", arg(&folder), "-o", arg(&bag)]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stdout(&o).contains("90 skeletons (1 track), layout panoptic-coco19, 2.97 s"),
        "{}",
        stdout(&o)
    );
    let o = autoact(&[
        "import",
        arg(&folder),
        "-o",
        arg(&bag),
        "--force",
        "--fps",
        "30",
    ]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("state their own rate (fpsType); drop --fps"),
        "{}",
        stderr(&o)
    );
}
