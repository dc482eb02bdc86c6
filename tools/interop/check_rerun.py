#!/usr/bin/env python3
"""What Rerun makes of autoact's bags: each MCAP file is read with the Rerun SDK's own MCAP
importer (`rerun.chunk.McapReader`, the code behind `rerun file.mcap`), and the archetypes it
produces are checked.

- A bag with `/animation` (animation or capture bag): every skeleton marker has a point cloud
  entity `/skeleton/points/<frame>` holding `Points3D` positions and a `CoordinateFrame` naming
  that frame (so the viewer places it by the transforms; in a capture bag, each scene's
  `scene<i>/<frame>` in turn); every such frame reaches `world` through
  the `Transform3D` parent/child frames Rerun decoded from `/tf` and `/tf_static`; and at least one
  of them turns over time (the figure moves).
- A capture bag (`/camera/camera_info`): a `Pinhole` whose parent frame is `camera`, so the
  camera's frustum follows `/tf`.
- A render bag (`/render/video`): `/render/camera/image/h264` is a `VideoStream` with one sample
  per annotated frame, codec H.264 (render with `--embed-video=rerun` or `=both`).

Usage: check_rerun.py BAG.mcap...   One line per file, `ok rerun ...` or `FAIL rerun ...`; exit
status 1 if any failed. Needs `rerun-sdk` (tools/interop/run_rerun.sh installs the pinned one).
"""

from __future__ import annotations

import sys
from collections import defaultdict

import rerun as rr

POINTS_PREFIX = "/skeleton/points/"
VIDEO_ENTITY = "/render/camera/image/h264"
MARKERS = "visualization_msgs.msg.MarkerArray:message"
H264 = rr.VideoCodec.H264.value


def load(path: str) -> dict[str, dict[str, list]]:
    """Entity path → component → its values, row by row over every chunk (None where a row lacks
    it)."""
    entities: dict[str, dict[str, list]] = defaultdict(lambda: defaultdict(list))
    for chunk in rr.chunk.McapReader(path).stream():
        batch = chunk.to_record_batch()
        columns = entities[chunk.entity_path]
        for name in batch.schema.names:
            if ":" in name and not name.startswith(("rerun.", "Mcap")):
                columns[name].extend(batch.column(name).to_pylist())
    return entities


def values(entity: dict[str, list], component: str) -> list:
    """Every instance of `component` over all rows."""
    return [v for row in entity.get(component, []) if row for v in row]


def without_scene(frame: str) -> str:
    """A tf frame name without a capture bag's `scene<i>/` prefix."""
    head, _, rest = frame.partition("/")
    return rest if rest and head.startswith("scene") and head[5:].isdigit() else frame


def check_skeleton(entities: dict[str, dict[str, list]]) -> str:
    marker_frames = {
        m["header"]["frame_id"]
        for array in values(entities.get("/skeleton/markers", {}), MARKERS)
        for m in array["markers"]
    }
    clouds = {e[len(POINTS_PREFIX) :]: c for e, c in entities.items() if e.startswith(POINTS_PREFIX)}
    if not marker_frames:
        raise AssertionError("no skeleton markers")
    if set(clouds) != {without_scene(f) for f in marker_frames}:
        raise AssertionError(
            f"point clouds {sorted(clouds)} are not the markers' frames {sorted(marker_frames)}"
        )
    parent: dict[str, str] = {}
    turns: dict[str, set] = defaultdict(set)
    for topic in ("/tf_static", "/tf"):
        tf = entities.get(topic, {})
        for child, par, q in zip(
            tf.get("Transform3D:child_frame", []),
            tf.get("Transform3D:parent_frame", []),
            tf.get("Transform3D:quaternion", []),
        ):
            for c, p, r in zip(child or [], par or [], q or []):
                parent[c] = p
                turns[c].add(tuple(round(x, 6) for x in r))
    points = 0
    for frame, cloud in clouds.items():
        positions = values(cloud, "Points3D:positions")
        if not positions:
            raise AssertionError(f"{POINTS_PREFIX}{frame}: no Points3D positions")
        points = max(points, len(positions))
        # A capture bag's cloud moves to each new scene's body (`scene<i>/<frame>`).
        named = set(values(cloud, "CoordinateFrame:frame"))
        if not named or any(without_scene(n) != frame or n not in marker_frames for n in named):
            raise AssertionError(f"{POINTS_PREFIX}{frame}: coordinate frames {sorted(named)}")
        for at in named:
            start, hops = at, 0
            while at != "world":
                if at not in parent or hops > len(parent):
                    raise AssertionError(f"frame {start}: its chain stops at {at}, not world")
                at, hops = parent[at], hops + 1
    moving = [f for f in marker_frames if len(turns.get(f, ())) > 1]
    if not moving:
        raise AssertionError("no point cloud frame turns over time")
    return f"{len(clouds)} point clouds in {len(marker_frames)} tf frames that reach world, {len(moving)} turning"


def check_pinhole(entities: dict[str, dict[str, list]]) -> str:
    info = entities["/camera/camera_info"]
    k = values(info, "Pinhole:image_from_camera")
    parents = set(values(info, "Pinhole:parent_frame"))
    if not k or parents != {"camera"}:
        raise AssertionError(f"/camera/camera_info: no Pinhole in frame camera (parents {sorted(parents)})")
    return f"camera pinhole in frame camera ({len(k)} rows)"


def check_render(entities: dict[str, dict[str, list]]) -> str:
    video = entities.get(VIDEO_ENTITY)
    if video is None:
        raise AssertionError(f"no {VIDEO_ENTITY} (render with --embed-video=rerun or =both)")
    samples = [s for s in video.get("VideoStream:sample", []) if s]
    codecs = set(values(video, "VideoStream:codec"))
    annotated = len(entities.get("/render/annotations", {}).get(
        "autoact_msgs.msg.FrameAnnotation:message", []))
    if codecs != {H264}:
        raise AssertionError(f"{VIDEO_ENTITY}: codec {sorted(codecs)}, not H.264")
    if len(samples) != annotated or not samples:
        raise AssertionError(f"{VIDEO_ENTITY}: {len(samples)} video samples for {annotated} frames")
    return f"{len(samples)} H.264 video samples"


def main(paths: list[str]) -> int:
    if not paths:
        print(__doc__, file=sys.stderr)
        return 2
    failed = 0
    for path in paths:
        try:
            entities = load(path)
            checks = []
            if "/animation" in entities:
                checks.append(check_skeleton(entities))
            if "/camera/camera_info" in entities:
                checks.append(check_pinhole(entities))
            if "/render/video" in entities:
                checks.append(check_render(entities))
            if not checks:
                raise AssertionError("neither an animation, capture nor render bag")
            print(f"ok rerun {path}: {'; '.join(checks)}")
        except Exception as e:  # noqa: BLE001 (one line per file, whatever went wrong)
            failed += 1
            print(f"FAIL rerun {path}: {e}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
