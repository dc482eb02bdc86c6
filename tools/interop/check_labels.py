#!/usr/bin/env python3
"""Reads the pose and box labels of a dataset `autoact trim` wrote the way their consumers do.

    check_labels.py DATASET_DIR [--captures DIR]

- `annotations/skeleton_2d_coco17.pkl` and `skeleton_3d_ntu25.pkl` with Python's `pickle` and
  numpy, as MMAction2's / PYSKL's `PoseDataset` does (mmaction/datasets/pose_dataset.py:
  `load(ann_file)`, `split = set(data['split'][name])`, the annotations whose `frame_dir` is in
  it; then `PoseDecode`: `keypoint[:, frame_inds].astype(np.float32)`): a `split` dict with
  train, val and test, none empty, naming the clips of clips.jsonl in their splits; per clip
  `frame_dir`, `label` (its class id), `img_shape` and `original_shape` (h, w), `total_frames`
  (= its frame count), `keypoint` float32 1 x T x V x C (V, C = 17, 2 and 25, 3), finite, and
  `keypoint_score` float32 1 x T x V in [0, 1] (2-D only); the values equal the clip's sidecar
  (`labels/<label>/<clip>.json`).
- `annotations/coco_keypoints_{train,val,test}.json` with pycocotools (`COCO(path)`,
  `getCatIds`, `getAnnIds`, `loadAnns`, `loadImgs`): one image per frame of the split's clips,
  annotations with 17 keypoints (x, y, v), `num_keypoints` = the points with v > 0, a box inside
  the image, the person category with COCO's 17 names and 19-limb skeleton.
- With `--captures DIR` (the folder of the capture bags): the 12 joints COCO-17 and NTU-25 share
  (shoulders, elbows, wrists, hips, knees, ankles) reproject from the exported 3-D joints through
  the recorded camera (the capture bag's `sensor_msgs/CameraInfo`, read with mcap-ros2-support,
  scaled to the render's width as autoact's renderer does: same horizontal field of view, image
  centre kept) onto the exported 2-D keypoints to under 0.5 px, on every frame of every clip.
Exits non-zero with a message on the first failure.
"""

import argparse
import json
import os
import pickle
import sys

import numpy as np
from pycocotools.coco import COCO

SPLITS = ("train", "val", "test")
COCO_NAMES = [
    "nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder", "right_shoulder",
    "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip",
    "left_knee", "right_knee", "left_ankle", "right_ankle",
]
COCO_SKELETON = [
    [16, 14], [14, 12], [17, 15], [15, 13], [12, 13], [6, 12], [7, 13], [6, 7], [6, 8],
    [7, 9], [8, 10], [9, 11], [2, 3], [1, 2], [1, 3], [2, 4], [3, 5], [4, 6], [5, 7],
]


def fail(msg):
    print(f"check_labels: FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def check_pickle(path, clips, sidecars, joints, channels):
    """The skeleton file at `path`, against the labelled clips of clips.jsonl."""
    with open(path, "rb") as f:
        data = pickle.load(f)
    if set(data) != {"split", "annotations"}:
        fail(f"{path}: keys {sorted(data)}")
    split = data["split"]
    for s in SPLITS:
        want = sorted(c["clip_id"] for c in clips.values() if c["split"] == s)
        if sorted(split.get(s, [])) != want:
            fail(f"{path}: split {s} lists {split.get(s)}, clips.jsonl {want}")
        if not want:
            fail(f"{path}: split {s} is empty")
    anns = data["annotations"]
    if sorted(a["frame_dir"] for a in anns) != sorted(clips):
        fail(f"{path}: annotations are not one per labelled clip")
    for a in anns:
        c = clips[a["frame_dir"]]
        t = c["frame_count"]
        h, w = sidecars[c["clip_id"]]["height"], sidecars[c["clip_id"]]["width"]
        if a["label"] != c["label_id"] or not isinstance(a["label"], int):
            fail(f"{path}: {c['clip_id']}: label {a['label']!r}, not {c['label_id']}")
        for key in ("img_shape", "original_shape"):
            if a[key] != (h, w):
                fail(f"{path}: {c['clip_id']}: {key} {a[key]!r}, not {(h, w)}")
        if a["total_frames"] != t:
            fail(f"{path}: {c['clip_id']}: total_frames {a['total_frames']}, clip has {t}")
        span = c.get("action_span")
        want_span = (span["start_frame"], span["end_frame"]) if span else (0, t)
        if a.get("action_span") != want_span:
            fail(f"{path}: {c['clip_id']}: action_span {a.get('action_span')!r}, clips.jsonl {want_span}")
        kp = a["keypoint"]
        # 2-D has scores; 3-D has none (MMAction2's NTU 3-D pipeline refuses them).
        score = a.get("keypoint_score") if channels == 2 else np.zeros((1, t, joints), np.float32)
        if channels == 3 and "keypoint_score" in a:
            fail(f"{path}: {c['clip_id']}: a 3-D annotation with keypoint_score (GenSkeFeat refuses it)")
        for name, arr, shape in (("keypoint", kp, (1, t, joints, channels)),
                                 ("keypoint_score", score, (1, t, joints))):
            if not isinstance(arr, np.ndarray) or arr.dtype != np.float32 or arr.shape != shape:
                fail(f"{path}: {c['clip_id']}: {name} {type(arr).__name__} "
                     f"{getattr(arr, 'dtype', None)} {getattr(arr, 'shape', None)}, not float32 {shape}")
        if not np.isfinite(kp).all() or score.min() < 0 or score.max() > 1:
            fail(f"{path}: {c['clip_id']}: non-finite keypoints or scores outside [0, 1]")
        # PoseDecode: frames picked by index, a float32 copy.
        inds = np.linspace(0, t - 1, min(t, 48)).astype(np.int64)
        if kp[:, inds].astype(np.float32).shape != (1, len(inds), joints, channels):
            fail(f"{path}: {c['clip_id']}: PoseDecode-style indexing fails")
        kp[0, 0, 0, 0] += 0.0  # writable, as in-place transforms need
        side = sidecars[c["clip_id"]]["frames"]
        key = "coco17" if channels == 2 else "ntu25"
        want = np.array([np.array(f[key], np.float32).reshape(joints, 3)[:, :channels] for f in side])
        if not np.array_equal(kp[0], want):
            fail(f"{path}: {c['clip_id']}: keypoints differ from its sidecar")
    return {s: len(split[s]) for s in SPLITS}


def check_coco(path, clips, split):
    """The COCO keypoint file of `split`, through pycocotools."""
    coco = COCO(path)
    cats = coco.loadCats(coco.getCatIds(catNms=["person"]))
    if len(cats) != 1 or cats[0]["keypoints"] != COCO_NAMES or cats[0]["skeleton"] != COCO_SKELETON:
        fail(f"{path}: the person category is not COCO's")
    in_split = {k: c for k, c in clips.items() if c["split"] == split}
    images = coco.loadImgs(coco.getImgIds())
    if len(images) != sum(c["frame_count"] for c in in_split.values()):
        fail(f"{path}: {len(images)} images for the split's frames")
    if {im["clip_id"] for im in images} != set(in_split):
        fail(f"{path}: images not of the split's clips")
    for im in images:
        # With --rawframes, file_name is the frame `trim` extracted.
        if in_split[im["clip_id"]].get("rawframes") and not os.path.isfile(
                os.path.join(os.path.dirname(os.path.dirname(path)), im["file_name"])):
            fail(f"{path}: image {im['id']}: no file {im['file_name']}")
    ann_ids = coco.getAnnIds(catIds=[cats[0]["id"]], iscrowd=False)
    anns = coco.loadAnns(ann_ids)
    if not anns:
        fail(f"{path}: no annotations")
    for a in anns:
        im = coco.imgs[a["image_id"]]
        kp = np.array(a["keypoints"], np.float64).reshape(17, 3)
        if a["num_keypoints"] != int((kp[:, 2] > 0).sum()):
            fail(f"{path}: annotation {a['id']}: num_keypoints {a['num_keypoints']}")
        if not set(np.unique(kp[:, 2])) <= {0.0, 1.0, 2.0}:
            fail(f"{path}: annotation {a['id']}: visibility not 0, 1 or 2")
        x, y, w, h = a["bbox"]
        if w <= 0 or h <= 0 or x < 0 or y < 0 or x + w > im["width"] or y + h > im["height"]:
            fail(f"{path}: annotation {a['id']}: box {a['bbox']} outside {im['width']}x{im['height']}")
        seen = kp[kp[:, 2] > 0]
        if ((seen[:, 0] < -0.5) | (seen[:, 0] > im["width"] - 0.5)
                | (seen[:, 1] < -0.5) | (seen[:, 1] > im["height"] - 0.5)).any():
            fail(f"{path}: annotation {a['id']}: a point with v > 0 lies outside the image")
    return len(images), len(anns)


# (COCO-17 index, NTU-25 index) of the joints both layouts take from one rig landmark.
SHARED = [(5, 4), (6, 8), (7, 5), (8, 9), (9, 6), (10, 10), (11, 12), (12, 16), (13, 13),
          (14, 17), (15, 14), (16, 18)]


def camera_k(bag):
    """fx, fy, cx, cy (OpenCV pixels) and the size of the capture bag's first CameraInfo."""
    from mcap_ros2.reader import read_ros2_messages
    for m in read_ros2_messages(bag):
        if m.schema.name == "sensor_msgs/msg/CameraInfo":
            k = m.ros_msg.k
            return k[0], k[4], k[2], k[5], m.ros_msg.width, m.ros_msg.height
    fail(f"{bag}: no sensor_msgs/CameraInfo")


def check_reprojection(captures, clips, sidecars):
    """The exported 2-D keypoints against the exported 3-D joints seen by the recorded camera."""
    cams = {}
    worst, n = 0.0, 0
    for c in clips.values():
        if c["capture_bag"] not in cams:
            cams[c["capture_bag"]] = camera_k(os.path.join(captures, c["capture_bag"]))
        fx, fy, cx, cy, w0, h0 = cams[c["capture_bag"]]
        side = sidecars[c["clip_id"]]
        w, h = side["width"], side["height"]
        s = w / w0
        # The lens on the render's sensor: pixel-edge principal point scaled, centre kept.
        fx, fy = fx * s, fy * s
        cx = (cx + 0.5) * s - 0.5
        cy = (cy + 0.5) * s + 0.5 * (h - s * h0) - 0.5
        for f in side["frames"]:
            kp2 = np.array(f["coco17"], np.float64).reshape(17, 3)
            kp3 = np.array(f["ntu25"], np.float64).reshape(25, 3)
            for i, j in SHARED:
                x, y, z = -kp3[j, 0], -kp3[j, 1], kp3[j, 2]  # Kinect space -> optical frame
                if z <= 0.05:
                    continue
                err = np.hypot(fx * x / z + cx - kp2[i, 0], fy * y / z + cy - kp2[i, 1])
                worst, n = max(worst, err), n + 1
    if n == 0 or worst >= 0.5:
        fail(f"reprojection: {n} joints, worst {worst:.3g} px")
    print(f"ok reprojection: {n} joints, 2-D from 3-D through the recorded camera within {worst:.2g} px")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("--captures", help="folder of the capture bags: check the reprojection")
    args = ap.parse_args()
    ann = os.path.join(args.dataset, "annotations")
    with open(os.path.join(ann, "clips.jsonl")) as f:
        records = [json.loads(line) for line in f if line.strip()]
    clips = {r["clip_id"]: r for r in records if r.get("labels")}
    if not clips:
        fail("no clip in clips.jsonl has labels")
    sidecars = {}
    for c in clips.values():
        with open(os.path.join(args.dataset, c["labels"])) as f:
            sidecars[c["clip_id"]] = json.load(f)
        if any(fr is None for fr in sidecars[c["clip_id"]]["frames"]):
            fail(f"{c['clip_id']}: a frame without labels")
    if args.captures:
        check_reprojection(args.captures, clips, sidecars)
    counts = check_pickle(os.path.join(ann, "skeleton_2d_coco17.pkl"), clips, sidecars, 17, 2)
    check_pickle(os.path.join(ann, "skeleton_3d_ntu25.pkl"), clips, sidecars, 25, 3)
    for s in SPLITS:
        images, anns = check_coco(os.path.join(ann, f"coco_keypoints_{s}.json"), clips, s)
        print(f"ok coco_keypoints_{s}.json: {images} images, {anns} person annotations (pycocotools)")
    print(f"ok skeleton_2d_coco17.pkl, skeleton_3d_ntu25.pkl: {len(clips)} clips, splits {counts} "
          f"({len(records) - len(clips)} clips without labels)")


if __name__ == "__main__":
    main()
