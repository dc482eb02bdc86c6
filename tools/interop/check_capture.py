#!/usr/bin/env python3
"""Check capture bags (`autoact convert --spec`) with the Python `mcap` reader and the
`mcap-ros2-support` decoder, as Foxglove-style tools see them:

- the TF tree: `world` is the only root; `camera` and each scene's `scene<i>/root` hang off it;
  every bone frame `scene<i>/<bone>` reaches `world` through the rig's own parents (names as
  `autoact rig` prints them), and scene `i`'s frames first appear at the `i`-th `/scene` start;
- no viewer can blend two scenes' bodies: a viewer that interpolates transforms over time
  (Foxglove's and Lichtblick's preloaded TF, tf2's buffer) blends a frame's translation between
  the samples either side of the time it draws; every bone frame's samples on `/tf` and
  `/tf_static`, over the whole bag, must carry one and the same translation (its rest offset),
  so that blend is zero everywhere, across every scene change included;
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


def split_scene(frame):
    """(scene index, bone name) of `scene<i>/<bone>`; (None, frame) for any other frame."""
    head, _, bone = frame.partition("/")
    if bone and head.startswith("scene") and head[5:].isdigit():
        return int(head[5:]), bone
    return None, frame


def stamp_ns(t):
    return t.sec * 1_000_000_000 + t.nanosec


def check(path, parents):
    tf_parent = {}
    first_seen = {}
    offsets = {}
    segments, scenes, camera_frames, info_frames, k0 = [], [], set(), set(), []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages(log_time_order=True):
            topic = channel.topic
            if topic in ("/tf", "/tf_static"):
                for t in msg.transforms:
                    child = t.child_frame_id
                    old = tf_parent.setdefault(child, t.header.frame_id)
                    if old != t.header.frame_id:
                        return f"{child} has two parents: {old} and {t.header.frame_id}"
                    first_seen.setdefault(child, stamp_ns(t.header.stamp))
                    if split_scene(child)[1] not in ("root", "camera"):
                        v = t.transform.translation
                        offsets.setdefault(child, []).append((v.x, v.y, v.z))
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
    starts = sorted(stamp_ns(s.header.stamp) for s in scenes)
    roots = [c for c in tf_parent if split_scene(c)[1] == "root"]
    if len(roots) != len(starts) or any(tf_parent[r] != "world" for r in roots):
        return f"{len(roots)} root frames for {len(starts)} scenes, parents {sorted({tf_parent[r] for r in roots})}"
    for child, parent in tf_parent.items():
        if child == "camera":
            continue
        scene, bone = split_scene(child)
        if scene is None or scene >= len(starts):
            return f"TF frame {child!r} is not scene<i>/<bone> for one of the {len(starts)} scenes"
        if first_seen[child] != starts[scene]:
            return f"TF frame {child!r} first appears at {first_seen[child]} ns, scene {scene} starts at {starts[scene]} ns"
        if bone not in parents:
            return f"TF frame {child!r} is not a bone of the rig"
        expected = f"scene{scene}/{parents[bone]}" if parents[bone] else "world"
        if parent != expected:
            return f"TF frame {child!r} hangs off {parent!r}, the rig says {expected!r}"
        seen, at = set(), child
        while at != "world":
            if at in seen or at not in tf_parent:
                return f"TF frame {child!r} does not reach 'world'"
            seen.add(at)
            at = tf_parent[at]
    # What an interpolating viewer blends: the change of a frame's translation between samples.
    blend_m, worst = 0.0, None
    for child, values in offsets.items():
        for a, b in zip(values, values[1:]):
            d = sum((x - y) ** 2 for x, y in zip(a, b)) ** 0.5
            if d > blend_m:
                blend_m, worst = d, child
    if blend_m > 0.0:
        return f"TF frame {worst!r} changes its offset by {blend_m * 1000:.1f} mm: an interpolating viewer blends it"
    if camera_frames != {"world"}:
        return f"/camera/pose frames {camera_frames}, expected {{'world'}}"
    if info_frames != {"camera"} or not k0 or min(k0) <= 0:
        return f"/camera/camera_info frames {info_frames}, K[0] min {min(k0) if k0 else None}"
    if not segments or not scenes:
        return f"{len(segments)} segments and {len(scenes)} scenes"
    ids = [s.id for s in segments]
    if len(set(ids)) != len(ids):
        return "segment ids repeat"

    last_end = -1
    for s in sorted(segments, key=lambda s: stamp_ns(s.start)):
        a, b, c, d = stamp_ns(s.start), stamp_ns(s.content_start), stamp_ns(s.content_end), stamp_ns(s.end)
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
    return f"ok: {len(segments)} clips, {len(scenes)} scenes, {len(tf_parent)} TF frames, no offset blends across scene changes"


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
