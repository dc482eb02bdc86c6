#!/usr/bin/env python3
"""Reads a dataset `autoact trim` wrote the way its consumers do, and checks it.

    check_trim.py DATASET_DIR [--split-key FIELD] [--expect-clips N]

- MMAction2 `VideoDataset` / `RawframeDataset` rules (mmaction/datasets/video_dataset.py,
  rawframe_dataset.py): `line.strip().split(' ')`, paths joined to the data prefix (DATASET_DIR),
  label ids ints; rawframes `img_{:05}.jpg` from 1.
- PyTorchVideo `LabeledVideoPaths.from_csv` rule: `line.rsplit(None, 1)`.
- Kinetics CSV through Python's csv module: header `label,youtube_id,time_start,time_end,split`.
- Every listed clip decoded with PyAV: frame count, duration, label id = its label's line in
  classes.txt; class ids identical across splits; no group in two splits: by each clip's
  `split_by` in clips.jsonl (its class's grouping: animation, or the finer variant, scene or clip
  a class with too few animations fell back to; held-out clips aside), or by the clips.jsonl
  field FIELD for all clips when `--split-key` is given;
  ActivityNet JSON segments match the clips.
- Depth and mask frames (captures rendered with `--depth --masks`): one PNG per clip frame,
  16-bit and 8-bit grey, mask ids 0/1 with the person present, depth on every person pixel.
- Action spans: every clip's `action_span` (clips.jsonl) lies inside the clip (frames and seconds
  agree at the clip's rate), its animation frames are the clip frames shifted by one offset per
  segment, its capture-video seconds are the clip's start plus the span; windows and instances
  have `part` 0, 1, … in order per segment; the ActivityNet annotation of each clip has the span's
  video seconds as `segment` and the clip as `clip_segment`.
Exits non-zero with a message on the first failure.
"""

import argparse
import csv
import json
import os
import sys

import av


def fail(msg):
    print(f"check_trim: FAIL: {msg}", file=sys.stderr)
    sys.exit(1)


def decode_count(path):
    with av.open(path) as c:
        stream = c.streams.video[0]
        n = sum(1 for _ in c.decode(stream))
        rate = stream.average_rate or stream.guessed_rate
        return n, float(rate) if rate else None


# The clips.jsonl fields that make a group of each `split_by`.
GROUP_FIELDS = {
    "animation": ("animation",),
    "variant": ("animation", "variant"),
    "scene": ("animation", "variant", "scene"),
    "clip": ("segment_id",),
    "weather": ("weather",),
    "location": ("location",),
    "character": ("character",),
    "time": ("time",),
}


def group_of(m, split_key):
    """The group clip record `m` shares its split with, or None for a held-out clip."""
    if split_key:
        return (split_key, m[split_key])
    by = m.get("split_by", "animation")
    if by == "held-out":
        return None
    if by not in GROUP_FIELDS:
        fail(f"{m['clip_id']}: unknown split_by {by!r}")
    return (by,) + tuple(m[f] for f in GROUP_FIELDS[by])


def check_spans(meta, anet):
    """Each clip's action span agrees with the clip, the animation and the capture video, and
    with its ActivityNet annotation."""
    eps = 1e-6
    offsets = {}
    parts = {}
    for m in meta.values():
        s = m.get("action_span")
        if s is None:
            fail(f"{m['clip_id']}: no action_span in clips.jsonl")
        fps, n = m["fps"], m["frame_count"]
        if not 0 <= s["start_frame"] < s["end_frame"] <= n:
            fail(f"{m['clip_id']}: action span frames {s['start_frame']}..{s['end_frame']} outside the clip's {n}")
        for f, sec in [("start_frame", "start_s"), ("end_frame", "end_s"),
                       ("animation_start_frame", "animation_start_s"), ("animation_end_frame", "animation_end_s")]:
            if abs(s[f] / fps - s[sec]) > eps:
                fail(f"{m['clip_id']}: {sec} {s[sec]} is not {f} {s[f]} at {fps} fps")
        if s["animation_end_frame"] - s["animation_start_frame"] != s["end_frame"] - s["start_frame"]:
            fail(f"{m['clip_id']}: the span is {s['end_frame'] - s['start_frame']} frames in the clip, "
                  f"{s['animation_end_frame'] - s['animation_start_frame']} in the animation")
        # One offset per segment between the video and the animation's frames.
        offset = m["start_frame"] + s["start_frame"] - s["animation_start_frame"]
        if offsets.setdefault(m["segment_id"], offset) != offset:
            fail(f"{m['clip_id']}: its animation starts at video frame {offset}, "
                  f"another clip of {m['segment_id']} says {offsets[m['segment_id']]}")
        if abs(m["start_s"] + s["start_s"] - s["video_start_s"]) > eps or \
                abs(m["start_s"] + s["end_s"] - s["video_end_s"]) > eps:
            fail(f"{m['clip_id']}: the span's video seconds disagree with the clip's start")
        if m.get("policy", "whole") == "whole":
            if "part" in m:
                fail(f"{m['clip_id']}: a whole clip with a part")
        else:
            parts.setdefault(m["segment_id"], []).append((m["start_frame"], m["part"]))
    for seg, ps in parts.items():
        ps.sort()
        if [p for _, p in ps] != list(range(len(ps))):
            fail(f"{seg}: parts {[p for _, p in ps]} are not 0, 1, … in frame order")
    by_clip = {}
    for v in anet["database"].values():
        for a in v["annotations"]:
            by_clip[a["clip_id"]] = a
    for m in meta.values():
        a = by_clip.get(m["clip_id"])
        if a is None:
            fail(f"{m['clip_id']}: not in activitynet.json")
        s = m["action_span"]
        if abs(a["segment"][0] - s["video_start_s"]) > eps or abs(a["segment"][1] - s["video_end_s"]) > eps:
            fail(f"activitynet {m['clip_id']}: segment {a['segment']} is not the action span")
        if abs(a["clip_segment"][0] - m["start_s"]) > eps or abs(a["clip_segment"][1] - m["end_s"]) > eps:
            fail(f"activitynet {m['clip_id']}: clip_segment {a['clip_segment']} is not the clip")
    policies = sorted({m.get("policy", "whole") for m in meta.values()})
    print(f"ok action spans: {len(meta)} clips ({', '.join(policies)}), "
          f"{len(offsets)} segments, ActivityNet segments are the spans")


def check_qa(ann, meta):
    """qa.json, when trim wrote one, agrees with clips.jsonl: every checked clip counted, every
    clip flagged there listed, its flags recomputed from its measurements and the thresholds."""
    path = os.path.join(ann, "qa.json")
    checked = [m for m in meta.values() if "qa" in m]
    if not os.path.exists(path):
        if checked:
            fail(f"{len(checked)} clips carry quality measurements but there is no qa.json")
        return
    qa = json.load(open(path, encoding="utf-8"))
    t = qa["thresholds"]
    if qa["clips_checked"] != len(checked):
        fail(f"qa.json checked {qa['clips_checked']} clips, clips.jsonl has {len(checked)} measured")
    expected = {}
    for m in checked:
        q = m["qa"]
        flags = []
        if q["frames"] > 0:
            if q["visible_joint_fraction"] < t["min_visible_fraction"]:
                flags.append("occluded")
            if q["hidden_frames"] > t["max_hidden_fraction"] * q["frames"]:
                flags.append("hidden")
            if q["box_height_fraction"] is not None and q["box_height_fraction"] < t["min_box_height_fraction"]:
                flags.append("small")
            if q["motion_m_per_s"] < t["min_motion_m_per_s"]:
                flags.append("still")
        if flags:
            expected[m["clip_id"]] = flags
    listed = {f["clip_id"]: f["qa"]["flags"] for f in qa["flagged"]}
    if listed != expected:
        fail(f"qa.json flags {listed}, clips.jsonl's measurements give {expected}")
    print(f"ok qa.json: {len(checked)} clips checked, {len(listed)} flagged, "
          f"still classes {[c for c, s in qa['classes'].items() if s['still']]}")


def png_header(path):
    """(width, height, bit depth, colour type) from a PNG's IHDR."""
    with open(path, "rb") as f:
        head = f.read(33)
    if head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        fail(f"{path}: not a PNG")
    return int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big"), head[24], head[25]


def decode_png(path):
    with av.open(path) as c:
        return next(c.decode(video=0)).to_ndarray()


def check_passes(root, meta):
    """Every clip with depth or mask frames has one per video frame, numbered from 1: depth
    16-bit grey (millimetres, > 0 on the person), masks 8-bit grey with ids 0 and 1 only, the
    person in its middle frame."""
    with_passes = [m for m in meta.values() if "depth" in m or "masks" in m]
    for m in with_passes:
        middle = m["frame_count"] // 2 + 1
        arrays = {}
        for key, depth in (("depth", 16), ("masks", 8)):
            if key not in m:
                continue
            d = os.path.join(root, m[key])
            names = sorted(os.listdir(d))
            want = [f"img_{k:05}.png" for k in range(1, m["frame_count"] + 1)]
            if names != want:
                fail(f"{m[key]}: {len(names)} files, expected img_00001.png … for {m['frame_count']} frames")
            w, h, bits, colour = png_header(os.path.join(d, want[0]))
            if (bits, colour) != (depth, 0):
                fail(f"{m[key]}: {bits}-bit colour type {colour}, expected {depth}-bit grey")
            if f"{w}x{h}" != m["capture_resolution"]:
                fail(f"{m[key]}: {w}x{h}, the video is {m['capture_resolution']}")
            arrays[key] = decode_png(os.path.join(d, f"img_{middle:05}.png"))
        if "masks" in arrays:
            ids = set(int(v) for v in set(arrays["masks"].flatten().tolist()))
            if not ids <= {0, 1} or 1 not in ids:
                fail(f"{m['masks']}: frame {middle} has ids {sorted(ids)}, expected 0 and 1")
            if "depth" in arrays and (arrays["depth"][arrays["masks"] == 1] == 0).any():
                fail(f"{m['depth']}: frame {middle} has no depth on some of the person's pixels")
    if with_passes:
        print(f"ok depth/masks: {len(with_passes)} clips, one PNG per frame, person in the mask with depth")


def check_sheets(root, ann, meta):
    """Every class has a contact sheet: its flagged clips first (flags as qa.json recomputes them),
    at most 24 tiles, the PNG as large as its grid, and each tile the frame its index names (the
    clip's frame decoded with PyAV, compared where the tile is at the video's own size)."""
    d = os.path.join(ann, "contact_sheets")
    qa_path = os.path.join(ann, "qa.json")
    flagged = {}
    if os.path.exists(qa_path):
        flagged = {f["clip_id"] for f in json.load(open(qa_path, encoding="utf-8"))["flagged"]}
    classes = {}
    for m in meta.values():
        classes.setdefault(m["label_dir"], []).append(m)
    compared = 0
    for label_dir, clips in sorted(classes.items()):
        index = json.load(open(os.path.join(d, f"{label_dir}.json"), encoding="utf-8"))
        tiles = index["tiles"]
        if len(tiles) != min(len(clips), 24) or index["clips"] != len(clips):
            fail(f"{label_dir}.json: {len(tiles)} tiles, {index['clips']} clips; the class has {len(clips)}")
        is_flagged = [t["clip_id"] in flagged for t in tiles]
        if is_flagged != sorted(is_flagged, reverse=True) or any(bool(t["flags"]) != f for t, f in zip(tiles, is_flagged)):
            fail(f"{label_dir}.json: flagged clips are not the first tiles, or flags differ from qa.json")
        tw, th, cols = index["tile_width"], index["tile_height"], min(index["columns"], len(tiles))
        rows = -(-len(tiles) // cols)
        sheet = decode_png(os.path.join(d, f"{label_dir}.png"))
        if sheet.shape[:2] != (rows * (th + 2) + 2, cols * (tw + 2) + 2):
            fail(f"{label_dir}.png is {sheet.shape[1]}x{sheet.shape[0]}, its {len(tiles)} tiles need another size")
        for k, t in enumerate(tiles):
            m = meta[t["video"]]
            if m["capture_resolution"] != f"{tw}x{th}":
                continue
            with av.open(os.path.join(root, t["video"])) as c:
                frame = next(f for i, f in enumerate(c.decode(video=0)) if i == t["frame"]).to_ndarray(format="rgb24")
            x0, y0 = 2 + (k % cols) * (tw + 2), 2 + (k // cols) * (th + 2)
            tile = sheet[y0:y0 + th, x0:x0 + tw]
            # Away from the label (top-left corner) and the red frame of flagged clips.
            inner = (slice(th // 4, th - 4), slice(4, tw - 4))
            diff = abs(tile[inner].astype(int) - frame[inner].astype(int)).mean()
            if diff > 3.0:
                fail(f"{label_dir}.png tile {k}: differs from frame {t['frame']} of {t['video']} by {diff:.1f} on average")
            compared += 1
    print(f"ok contact sheets: {len(classes)} classes, flagged clips first, {compared} tiles equal to the frame they name")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("dataset")
    ap.add_argument("--split-key", help="clips.jsonl field no value of which may be in two splits "
                    "(default: each clip's split_by)")
    ap.add_argument("--expect-clips", type=int)
    a = ap.parse_args()
    root = a.dataset
    ann = os.path.join(root, "annotations")
    classes = open(os.path.join(ann, "classes.txt"), encoding="utf-8").read().split("\n")
    if classes[-1] != "":
        fail("classes.txt does not end with a newline")
    classes = classes[:-1]
    if classes != sorted(classes) or len(set(classes)) != len(classes):
        fail(f"classes.txt is not sorted and unique: {classes}")
    label_map = json.load(open(os.path.join(ann, "label_map.json"), encoding="utf-8"))
    if label_map != {c: i for i, c in enumerate(classes)}:
        fail(f"label_map.json {label_map} disagrees with classes.txt")
    meta = {}
    for line in open(os.path.join(ann, "clips.jsonl"), encoding="utf-8"):
        r = json.loads(line)
        meta[r["video"]] = r

    seen = {}
    key_splits = {}
    decoded = 0
    for split in ["train", "val", "test"]:
        vids = open(os.path.join(ann, f"{split}_list_videos.txt"), encoding="utf-8").read()
        if vids and not vids.endswith("\n"):
            fail(f"{split}_list_videos.txt does not end with a newline")
        rows = list(csv.DictReader(open(os.path.join(ann, f"kinetics_{split}.csv"), encoding="utf-8", newline="")))
        with open(os.path.join(ann, f"kinetics_{split}.csv"), encoding="utf-8") as f:
            if f.readline().rstrip("\n") != "label,youtube_id,time_start,time_end,split":
                fail(f"kinetics_{split}.csv header")
        by_id = {r["youtube_id"]: r for r in rows}
        lines = vids.splitlines()
        if len(rows) != len(lines):
            fail(f"{split}: {len(lines)} list lines but {len(rows)} CSV rows")
        for line in lines:
            # MMAction2
            parts = line.strip().split(" ")
            if len(parts) != 2 or line != line.strip():
                fail(f"{split}: MMAction2 would not read {line!r} as <path> <label>")
            mm_path, mm_label = os.path.join(root, parts[0]), int(parts[1])
            # PyTorchVideo
            ptv_path, ptv_label = line.rsplit(None, 1)
            if os.path.join(root, ptv_path) != mm_path or int(ptv_label) != mm_label:
                fail(f"{split}: PyTorchVideo and MMAction2 read {line!r} differently")
            rel = parts[0]
            if rel not in meta:
                fail(f"{split}: {rel} is not in clips.jsonl")
            m = meta[rel]
            if m["split"] != split:
                fail(f"{rel}: clips.jsonl says split {m['split']}, listed in {split}")
            if classes[mm_label] != m["label"]:
                fail(f"{rel}: label id {mm_label} is {classes[mm_label]!r}, but the clip is {m['label']!r}")
            if rel in seen:
                fail(f"{rel} is listed in {seen[rel]} and {split}")
            seen[rel] = split
            n, rate = decode_count(mm_path)
            decoded += 1
            if n != m["frame_count"]:
                fail(f"{rel}: PyAV decoded {n} frames, expected {m['frame_count']}")
            if rate and abs(rate - m["fps"]) > 1e-3:
                fail(f"{rel}: {rate} fps, expected {m['fps']}")
            row = by_id.get(m["clip_id"])
            if row is None:
                fail(f"{split}: clip {m['clip_id']} is not in kinetics_{split}.csv")
            if row["label"] != m["label"] or row["split"] != split:
                fail(f"kinetics_{split}.csv row {row} disagrees with {m}")
            dur = float(row["time_end"]) - float(row["time_start"])
            if abs(dur - n / m["fps"]) > 0.0015:
                fail(f"{rel}: CSV duration {dur} s, decoded {n / m['fps']} s")
            key = group_of(m, a.split_key)
            if key is not None:
                key_splits.setdefault(key, set()).add(split)
        raw_path = os.path.join(ann, f"{split}_list_rawframes.txt")
        if os.path.exists(raw_path):
            for line in open(raw_path, encoding="utf-8").read().splitlines():
                parts = line.strip().split(" ")
                if len(parts) != 3:
                    fail(f"{split}: RawframeDataset would not read {line!r}")
                d, total, label = os.path.join(root, parts[0]), int(parts[1]), int(parts[2])
                names = sorted(os.listdir(d))
                expect = [f"img_{i:05d}.jpg" for i in range(1, total + 1)]
                if names != expect:
                    fail(f"{parts[0]}: {len(names)} frames on disk, list says {total}")
                if not 0 <= label < len(classes):
                    fail(f"{line!r}: label out of range")
    leaks = {k: s for k, s in key_splits.items() if len(s) > 1}
    if leaks:
        fail(f"groups in more than one split: {leaks}")
    if len(seen) != len(meta):
        fail(f"{len(meta)} clips in clips.jsonl, {len(seen)} listed")
    if a.expect_clips is not None and len(seen) != a.expect_clips:
        fail(f"{len(seen)} clips listed, expected {a.expect_clips}")
    anet = json.load(open(os.path.join(ann, "activitynet.json"), encoding="utf-8"))
    n_anet = 0
    for vid, v in anet["database"].items():
        for s in v["annotations"]:
            n_anet += 1
            lo, hi = s["segment"]
            if not (0 <= lo < hi <= v["duration"] + 1e-6):
                fail(f"activitynet {vid}: segment {s['segment']} outside [0, {v['duration']}]")
            if s["label"] not in classes:
                fail(f"activitynet {vid}: label {s['label']!r} not in classes.txt")
    if n_anet != len(meta):
        fail(f"activitynet.json has {n_anet} segments, clips.jsonl {len(meta)}")
    check_spans(meta, anet)
    check_qa(ann, meta)
    check_passes(root, meta)
    check_sheets(root, ann, meta)
    counts = {s: sum(1 for v in seen.values() if v == s) for s in ["train", "val", "test"]}
    print(f"ok check_trim {root}: {decoded} clips decoded with PyAV {av.__version__}, {counts}, "
          f"{len(classes)} classes, no {a.split_key or 'split_by group'} in two splits")


if __name__ == "__main__":
    main()
