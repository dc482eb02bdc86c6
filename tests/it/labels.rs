//! Pose and box labels leaving the render bag: two captures of one plan rendered for real, trimmed
//! one after the other into one folder; the exported 2-D keypoints reproject the exported 3-D
//! ones through the recorded camera, and the dataset-wide files hold every clip of both.

#![expect(clippy::unwrap_used, reason = "test helpers fail loudly")]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use crate::common::{self, arg, autoact, stderr};
use autoact::bags::capture::Capture;
use autoact::skeleton::layout::Layout;
use autoact::skeleton::rig::Rig;
use autoact::trim::labels::{
    COCO_SKELETON, ClipLabels, SKELETON_2D_FILE, SKELETON_3D_FILE, layout_landmarks, read_sidecar,
};

/// Render resolution of the test.
const RES: (u32, u32) = (160, 120);

/// Two classes of one sample animation each, 1 variant × 1 scene × 3 viewpoints, one capture bag
/// per animation: two bags of one plan.
fn two_bags(dir: &Path) -> Vec<PathBuf> {
    let spec = format!(
        r#"[dataset]
name = "l"
seed = 3
fps = 30.0
resolution = [320, 240]
lead_in_s = 0.1
lead_out_s = 0.1
session = "animation"
[counts]
variants = 1
scenes = 1
viewpoints = 3
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
    );
    let bags = common::capture_bags_from_spec(dir, &spec);
    assert_eq!(bags.len(), 2, "{bags:?}");
    bags
}

/// Renders `bag` to `<bag>.mp4` (with its render bag beside it) and trims it into `out`.
fn render_and_trim(bag: &Path, out: &Path) {
    let video = bag.with_extension("mp4");
    let res = format!("{}x{}", RES.0, RES.1);
    let o = autoact(&[
        "-q",
        "render",
        arg(bag),
        "-o",
        arg(&video),
        "--resolution",
        &res,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = autoact(&["trim", arg(bag), arg(&video), "-o", arg(out)]);
    assert!(o.status.success(), "{}", stderr(&o));
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Every clip's record in `clips.jsonl`, by clip id.
fn clips(out: &Path) -> BTreeMap<String, serde_json::Value> {
    std::fs::read_to_string(out.join("annotations/clips.jsonl"))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .map(|v| (v["clip_id"].as_str().unwrap().to_owned(), v))
        .collect()
}

/// `(COCO-17 index, NTU-25 index)` of every joint the two layouts take from one rig landmark.
fn shared_joints() -> Vec<(usize, usize)> {
    let coco = layout_landmarks(&Layout::builtin("coco-17").unwrap());
    let ntu = layout_landmarks(&Layout::builtin("ntu-25").unwrap());
    coco.iter()
        .enumerate()
        .filter_map(|(i, l)| ntu.iter().position(|m| m == l).map(|j| (i, j)))
        .collect()
}

/// The largest distance, pixels, between a clip's exported 2-D keypoints and its exported 3-D
/// joints projected with `k` (`sensor_msgs/CameraInfo.k`, OpenCV pixels), over joints in front
/// of the camera; and how many were compared.
fn reprojection_error_px(labels: &ClipLabels, k: &[f64; 9]) -> (f64, usize) {
    let (mut worst, mut n) = (0.0f64, 0usize);
    for f in labels.frames.iter().flatten() {
        for (c, j) in shared_joints() {
            // NTU (Kinect) camera space back to the optical frame: x and y turned half a turn.
            let [x, y, z] = [
                -f64::from(f.ntu25[3 * j]),
                -f64::from(f.ntu25[3 * j + 1]),
                f64::from(f.ntu25[3 * j + 2]),
            ];
            if z <= 0.05 {
                continue;
            }
            let u = k[0] * x / z + k[2];
            let v = k[4] * y / z + k[5];
            let (du, dv) = (
                u - f64::from(f.coco17[3 * c]),
                v - f64::from(f.coco17[3 * c + 1]),
            );
            worst = worst.max(du.hypot(dv));
            n += 1;
        }
    }
    (worst, n)
}

#[test]
fn exported_labels_reproject_and_stay_whole_as_a_second_capture_arrives() {
    let Some(_ff) = common::ffmpeg_or_skip(module_path!()) else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let bags = two_bags(dir.path());
    let out = dir.path().join("ds");
    let rig = Rig::standard();

    render_and_trim(&bags[0], &out);
    let first = clips(&out);
    let first_sidecars: BTreeMap<String, Vec<u8>> = first
        .values()
        .map(|c| {
            let rel = c["labels"].as_str().expect("every clip has labels");
            (rel.to_owned(), std::fs::read(out.join(rel)).unwrap())
        })
        .collect();
    render_and_trim(&bags[1], &out);
    let all = clips(&out);
    assert_eq!(all.len(), 6);

    // A clip of the first capture keeps its labels, byte for byte.
    for (rel, bytes) in &first_sidecars {
        assert_eq!(&std::fs::read(out.join(rel)).unwrap(), bytes, "{rel}");
    }
    assert_eq!(
        shared_joints().len(),
        12,
        "shoulders, elbows, wrists, hips, knees, ankles"
    );

    for bag in &bags {
        let cap = Capture::read(&rig, bag).unwrap();
        let k = cap.intrinsics.resized(RES.0, RES.1).k();
        let bag_name = bag.file_name().unwrap().to_str().unwrap();
        for c in all.values().filter(|c| c["capture_bag"] == bag_name) {
            let labels = read_sidecar(&out, c["labels"].as_str().unwrap()).unwrap();
            assert_eq!(
                labels.frames.len() as u64,
                c["frame_count"].as_u64().unwrap()
            );
            assert!(labels.frames.iter().all(Option::is_some));
            assert_eq!((labels.width, labels.height), RES);
            let (worst, n) = reprojection_error_px(&labels, &k);
            assert!(n > 100, "{n} joints compared");
            assert!(worst < 0.5, "clip {}: {worst} px", c["clip_id"]);
        }
    }

    // The dataset-wide files: every clip of both captures, each in its split.
    let ann = out.join("annotations");
    for f in [SKELETON_2D_FILE, SKELETON_3D_FILE] {
        let bytes = std::fs::read(ann.join(f)).unwrap();
        assert_eq!(&bytes[..2], &[0x80, 4], "{f}: pickle protocol 4");
        for id in all.keys() {
            let found = bytes.windows(id.len()).any(|w| w == id.as_bytes());
            assert!(found, "{f} lacks clip {id}");
        }
    }
    let mut images_per_split = BTreeMap::new();
    let mut clips_in_coco = BTreeSet::new();
    for split in ["train", "val", "test"] {
        let coco = read_json(&ann.join(format!("coco_keypoints_{split}.json")));
        let cat = &coco["categories"][0];
        assert_eq!(cat["name"], "person");
        assert_eq!(cat["keypoints"].as_array().unwrap().len(), 17);
        assert_eq!(
            cat["skeleton"].as_array().unwrap().len(),
            COCO_SKELETON.len()
        );
        let images = coco["images"].as_array().unwrap();
        for im in images {
            let id = im["clip_id"].as_str().unwrap();
            assert_eq!(all[id]["split"], split, "{id}");
            clips_in_coco.insert(id.to_owned());
        }
        let image_ids: BTreeSet<u64> = images.iter().map(|i| i["id"].as_u64().unwrap()).collect();
        assert_eq!(image_ids.len(), images.len(), "unique image ids");
        for a in coco["annotations"].as_array().unwrap() {
            assert!(image_ids.contains(&a["image_id"].as_u64().unwrap()));
            let kp = a["keypoints"].as_array().unwrap();
            assert_eq!(kp.len(), 51);
            let shown = kp
                .chunks(3)
                .filter(|p| p[2].as_f64().unwrap() > 0.0)
                .count();
            assert_eq!(a["num_keypoints"].as_u64().unwrap() as usize, shown);
            let b: Vec<f64> = a["bbox"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            assert!(b[2] > 0.0 && b[3] > 0.0 && b[0] + b[2] <= 160.0 && b[1] + b[3] <= 120.0);
        }
        images_per_split.insert(split, images.len());
    }
    assert_eq!(clips_in_coco.len(), 6, "every clip in one COCO split");
    let frames: u64 = all
        .values()
        .map(|c| c["frame_count"].as_u64().unwrap())
        .sum();
    assert_eq!(images_per_split.values().sum::<usize>() as u64, frames);
}
