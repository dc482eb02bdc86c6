#!/usr/bin/env python3
"""What a user sees when opening a capture bag in the Rerun viewer: the viewer itself, run
headless (`rerun.experimental.ViewerClient.spawn(headless=True)`: offscreen, drawn by Mesa's
software Vulkan), opens the bag, is paused at chosen instants, and screenshots are compared with
the person's joints projected by this script through the bag's own camera.

At three instants (the middle of the first scene's first clip, of the second scene and of the
last one, so a scene change and its new body are crossed):

- **through the camera**: the viewer's 2D view of the recorded pinhole (`/camera/camera_info`,
  target frame `camera_image_plane`) shows the skeleton's point clouds projected by Rerun from
  their tf frames. Every point of the clouds, placed here from `/tf_static`, `/tf`, the camera's
  `/tf` and its calibration (read with `mcap` + `mcap-ros2-support`, not with Rerun), must land
  on a drawn pixel (median ≤ 2 px, 95th percentile ≤ 4 px in the screenshot), and the drawn
  pixels must lie on the projected skeleton (95 % within 4 px): the person is where the camera
  saw it, on that scene's body.
- **the default view**: with the blueprint Rerun makes by itself, the screenshot has at least
  100 more pixels of saturated colour (the skeleton's) than the same view without the point
  clouds (the grid and the camera's frustum are grey): a user who opens the bag sees the person.

Usage: check_rerun_view.py CAPTURE.mcap [--keep DIR]   (screenshots kept in DIR when given)
Needs the Rerun venv (tools/interop/run_rerun.sh --exec python ...). Exit 0 only if all pass.
"""

from __future__ import annotations

import copy
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from PIL import Image
from rerun.experimental import ViewerClient

TIMELINE = "message_log_time"
POINTS = "/skeleton/points/"
PORT = 9879


def ns(t) -> int:
    return t.sec * 1_000_000_000 + t.nanosec


def quat(q) -> np.ndarray:
    x, y, z, w = q.x, q.y, q.z, q.w
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def instants(path: Path) -> list[int]:
    """Stamps of the middle of the first clip of the first, second and last scene."""
    scenes, segments = [], []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages(topics=["/scene", "/segments"]):
            (scenes if channel.topic == "/scene" else segments).append(msg)
    starts = sorted(ns(s.header.stamp) for s in scenes)
    picked = []
    for i in sorted({0, min(1, len(starts) - 1), len(starts) - 1}):
        first = min((s for s in segments if ns(s.start) >= starts[i]), key=lambda s: ns(s.start))
        picked.append((ns(first.content_start) + ns(first.content_end)) // 2)
    return picked


def projected(path: Path, stamp: int) -> tuple[np.ndarray, tuple[int, int]]:
    """The skeleton's cloud points at `stamp` in image pixels, and the image size."""
    parent, clouds, k, size = {}, {}, None, None
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, msg in reader.iter_decoded_messages(log_time_order=True):
            if message.log_time > stamp:
                break
            if channel.topic in ("/tf", "/tf_static"):
                for t in msg.transforms:
                    p = t.transform.translation
                    parent[t.child_frame_id] = (t.header.frame_id, quat(t.transform.rotation), np.array([p.x, p.y, p.z]))
            elif channel.topic.startswith(POINTS):
                xyz = np.frombuffer(bytes(msg.data), dtype="<f4").reshape(-1, msg.point_step // 4)[:, :3]
                clouds[channel.topic] = (msg.header.frame_id, xyz.astype(float))
            elif channel.topic == "/camera/camera_info":
                k, size = np.array(msg.k).reshape(3, 3), (msg.width, msg.height)

    def world(frame):
        if frame == "world":
            return np.eye(3), np.zeros(3)
        up, r, p = parent[frame]
        wr, wp = world(up)
        return wr @ r, wp + wr @ p

    cr, cp = world("camera")
    out = []
    for frame, xyz in clouds.values():
        r, p = world(frame)
        cam = (xyz @ r.T + p - cp) @ cr  # world → camera: R^T (x - c)
        uv = cam @ k.T
        out.append(uv[:, :2] / uv[:, 2:3])
    return np.concatenate(out), size


def drawn(png: Path) -> np.ndarray:
    """(x, y) of the pixels that differ from the view's background."""
    a = np.asarray(Image.open(png).convert("RGB")).astype(int)
    background = np.median(a.reshape(-1, 3), axis=0)
    ys, xs = np.nonzero(np.abs(a - background).sum(axis=2) > 60)
    return np.stack([xs, ys], axis=1).astype(float), a.shape[1], a.shape[0]


def coloured(png: Path) -> int:
    """How many pixels of the screenshot are saturated colours."""
    a = np.asarray(Image.open(png).convert("RGB")).astype(int)
    return int(((a.max(axis=2) - a.min(axis=2)) > 60).sum())


def nearest(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """For each point of `a`, the distance to the nearest point of `b`."""
    out = np.empty(len(a))
    for i in range(0, len(a), 512):
        d = np.linalg.norm(a[i : i + 512, None, :] - b[None, :, :], axis=2)
        out[i : i + 512] = d.min(axis=1)
    return out


def view_of(blueprint: dict) -> str:
    views = [k for k in blueprint if k.startswith("/view/") and k.count("/") == 2]
    if len(views) != 1:
        raise AssertionError(f"the default blueprint has {len(views)} views, expected one")
    return views[0]


def screenshot(viewer: ViewerClient, blueprint: dict, store: str, view: str, png: Path) -> None:
    viewer.set_blueprint(blueprint, store_id=store)
    time.sleep(1.5)
    viewer.save_screenshot(str(png), view_id=view.rsplit("/", 1)[1])


def check(bag: Path, keep: Path) -> list[str]:
    lines = []
    os.environ.setdefault("RUST_LOG", "error")  # the viewer's own log: errors only
    with ViewerClient.spawn(headless=True, port=PORT, hide_welcome_screen=True) as viewer:
        store = viewer.open(str(bag)).store_ids[0]
        # The blueprint Rerun makes by itself for the bag, before this script changes it.
        time.sleep(1.0)
        default = viewer.get_blueprint(store_id=store).blueprint
        view = view_of(default)
        default["/time_panel"]["TimePanelBlueprint"]["play_state"] = "Paused"
        for stamp in instants(bag):
            viewer.set_time(TIMELINE, timestamp=np.datetime64(stamp, "ns"), play_state="paused")
            time.sleep(1.0)
            # The default view, with and without the skeleton.
            with_person, without = keep / f"{stamp}_default.png", keep / f"{stamp}_default_empty.png"
            screenshot(viewer, default, store, view, with_person)
            empty = copy.deepcopy(default)
            query = empty[view + "/ViewContents"]["ViewContents"]["query"]
            query = [query] if isinstance(query, str) else list(query)
            empty[view + "/ViewContents"]["ViewContents"]["query"] = [*query, f"- {POINTS}**"]
            screenshot(viewer, empty, store, view, without)
            # The viewer may frame the view anew without the points: count coloured pixels (the
            # skeleton's colours are saturated; the grid and the camera's frustum are grey).
            changed = coloured(with_person) - coloured(without)
            if changed < 100:
                raise AssertionError(f"{stamp} ns: the default view shows no person ({changed} pixels are the skeleton's)")
            # Through the recorded camera.
            truth, (w, h) = projected(bag, stamp)
            through = copy.deepcopy(default)
            through[view]["ViewBlueprint"]["class_identifier"] = "2D"
            through[view]["ViewBlueprint"]["space_origin"] = "/camera/camera_info"
            through[view + "/ViewContents"]["ViewContents"]["query"] = [f"+ {POINTS}**"]
            through[view + "/SpatialInformation"] = {"SpatialInformation": {"target_frame": "camera_image_plane"}}
            png = keep / f"{stamp}_camera.png"
            screenshot(viewer, through, store, view, png)
            pixels, sw, sh = drawn(png)
            if len(pixels) < 50:
                raise AssertionError(f"{stamp} ns: the camera's view shows no person ({len(pixels)} pixels drawn)")
            scale = min(sw / w, sh / h)
            expected = truth * scale + np.array([(sw - scale * w) / 2, (sh - scale * h) / 2])
            to_drawn, to_truth = nearest(expected, pixels), nearest(pixels, expected)
            median, p95, off = np.median(to_drawn), np.percentile(to_drawn, 95), np.mean(to_truth > 4.0)
            if median > 2.0 or p95 > 4.0 or off > 0.05:
                raise AssertionError(
                    f"{stamp} ns: projected joints are {median:.1f} px (median), {p95:.1f} px (95th pct.) from the drawn person, {off:.0%} of its pixels off the skeleton"
                )
            lines.append(
                f"{stamp} ns: default view {changed} person pixels; through the camera {len(expected)} points within {median:.1f} px median, {p95:.1f} px 95th pct."
            )
    return lines


def main(args: list[str]) -> int:
    if not args or args[0].startswith("-"):
        print(__doc__.strip().splitlines()[-2], file=sys.stderr)
        return 2
    bag = Path(args[0])
    keep_dir = Path(args[args.index("--keep") + 1]) if "--keep" in args else None
    with tempfile.TemporaryDirectory() as tmp:
        keep = keep_dir or Path(tmp)
        keep.mkdir(parents=True, exist_ok=True)
        try:
            for line in check(bag, keep):
                print(f"ok rerun view {bag.name}: {line}")
        except AssertionError as e:
            print(f"FAIL rerun view {bag}: {e}")
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
