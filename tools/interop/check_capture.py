#!/usr/bin/env python3
"""Check capture bags (`autoact convert --spec`) with the Python `mcap` reader and the
`mcap-ros2-support` decoder, as Foxglove-style tools see them:

- the TF tree: `world` is the only root; `camera` and `root` hang off it; every bone frame's chain
  reaches `world` through the rig's own parents (names as `autoact rig` prints them);
- `/camera/pose` is in `world`, `/camera/camera_info` in `camera` with a calibrated K;
- every `/segments` clip has a unique id, a label, and start ≤ content_start < content_end ≤ end;
  clips never overlap on the timeline; every `/scene` names a drawn weather and location.

Usage: check_capture.py RIG.json CAPTURE.mcap ...   (RIG.json from `autoact rig --format json`)
Exits 0 only if every file passes.
"""

import json
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def check(path, parents):
    tf_parent = {}
    segments, scenes, camera_frames, info_frames, k0 = [], [], set(), set(), []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages(log_time_order=True):
            topic = channel.topic
            if topic in ("/tf", "/tf_static"):
                for t in msg.transforms:
                    old = tf_parent.setdefault(t.child_frame_id, t.header.frame_id)
                    if old != t.header.frame_id:
                        return f"{t.child_frame_id} has two parents: {old} and {t.header.frame_id}"
            elif topic == "/segments":
                segments.append(msg)
            elif topic == "/scene":
                scenes.append(msg)
            elif topic == "/camera/pose":
                camera_frames.add(msg.header.frame_id)
            elif topic == "/camera/camera_info":
                info_frames.add(msg.header.frame_id)
                k0.append(msg.k[0])
    if tf_parent.get("camera") != "world":
        return f"camera's parent is {tf_parent.get('camera')!r}, not 'world'"
    if tf_parent.get("root") != "world":
        return f"root's parent is {tf_parent.get('root')!r}, not 'world'"
    for child, parent in tf_parent.items():
        if child == "camera":
            continue
        if child not in parents:
            return f"TF frame {child!r} is not a bone of the rig"
        expected = parents[child] or "world"
        if parent != expected:
            return f"TF frame {child!r} hangs off {parent!r}, the rig says {expected!r}"
        seen, at = set(), child
        while at != "world":
            if at in seen or at not in tf_parent:
                return f"TF frame {child!r} does not reach 'world'"
            seen.add(at)
            at = tf_parent[at]
    if camera_frames != {"world"}:
        return f"/camera/pose frames {camera_frames}, expected {{'world'}}"
    if info_frames != {"camera"} or not k0 or min(k0) <= 0:
        return f"/camera/camera_info frames {info_frames}, K[0] min {min(k0) if k0 else None}"
    if not segments or not scenes:
        return f"{len(segments)} segments and {len(scenes)} scenes"
    ids = [s.id for s in segments]
    if len(set(ids)) != len(ids):
        return "segment ids repeat"

    def ns(t):
        return t.sec * 1_000_000_000 + t.nanosec

    last_end = -1
    for s in sorted(segments, key=lambda s: ns(s.start)):
        a, b, c, d = ns(s.start), ns(s.content_start), ns(s.content_end), ns(s.end)
        if not (a <= b < c <= d):
            return f"segment {s.id}: times out of order"
        if a < last_end:
            return f"segment {s.id} overlaps the one before"
        if not s.action:
            return f"segment {s.id} has no label"
        last_end = d
    for s in scenes:
        if not s.weather or not s.location:
            return f"scene {s.scene_id} has no weather or location"
    return f"ok: {len(segments)} clips, {len(scenes)} scenes, {len(tf_parent)} TF frames"


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    rig = json.load(open(sys.argv[1]))
    bones = rig["bones"]
    parents = {b["name"]: b["parent"] for b in bones}
    failed = 0
    for path in sys.argv[2:]:
        verdict = check(path, parents)
        ok = verdict.startswith("ok")
        failed += not ok
        print(f"{'ok' if ok else 'FAIL'} capture {path}: {verdict}")
    print(f"capture: {len(sys.argv) - 2 - failed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
