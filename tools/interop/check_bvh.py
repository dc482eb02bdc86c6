#!/usr/bin/env python3
"""Check BVH files `autoact export --format bvh` wrote with an independent parser, PyPI `bvh`
(0.3, 20tab/bvh-python), and forward kinematics in a few lines of numpy:

- the file parses, and its joint names (in order), joint count, frame count and frame time are
  the ones autoact meant (`X.expected.json` beside `X.bvh`, from `--write-expected-json`);
- every value line has one number per channel;
- forward kinematics of every frame (values and channel columns read by `bvh`, each joint's
  rotation the product of its rotation channels in the order listed, position channels replacing
  the offset) puts every joint within 1 mm of where autoact's own forward kinematics put it.

Usage: check_bvh.py X.bvh ...   Prints `ok bvh X.bvh: ...` or `FAIL bvh X.bvh: ...` per file and
exits 0 only if every file passes.
"""

import json
import sys
from pathlib import Path

import numpy as np
from bvh import Bvh

TOLERANCE_M = 0.001


def axis_rotations(axis, degrees):
    """(F, 3, 3) rotation matrices about one axis ('X', 'Y' or 'Z'), column-vector convention."""
    a = np.radians(np.asarray(degrees, dtype=float))
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    rows = {
        "X": [[o, z, z], [z, c, -s], [z, s, c]],
        "Y": [[c, z, s], [z, o, z], [-s, z, c]],
        "Z": [[c, -s, z], [s, c, z], [z, z, o]],
    }[axis]
    return np.moveaxis(np.array(rows), -1, 0)


def channel_count(mocap):
    """Values per frame line: the channels of every joint."""
    return sum(len(mocap.joint_channels(n)) for n in mocap.get_joints_names())


def forward_kinematics(mocap, names):
    """World positions (F, J, 3) in file units of every joint in `names`."""
    frames = mocap.nframes
    # The value lines as `bvh` split them, and each joint's first column as `bvh` counts it
    # (`get_joint_channels_index`): what its `frames_joint_channels` does, without searching the
    # joint tree again for every value of every frame (which took minutes on a capture's BVH).
    table = np.array(mocap.frames, dtype=float).reshape(frames, channel_count(mocap))
    world_r, world_p = {}, {}
    out = np.zeros((frames, len(names), 3))
    for j, name in enumerate(names):
        channels = mocap.joint_channels(name)
        first = mocap.get_joint_channels_index(name)
        values = table[:, first : first + len(channels)]
        translation = np.tile(np.array(mocap.joint_offset(name), dtype=float), (frames, 1))
        rotation = np.tile(np.eye(3), (frames, 1, 1))
        for k, channel in enumerate(channels):
            axis, kind = channel[0].upper(), channel[1:].lower()
            if kind == "position":
                translation[:, "XYZ".index(axis)] = values[:, k]
            elif kind == "rotation":
                rotation = rotation @ axis_rotations(axis, values[:, k])
            else:
                raise ValueError(f"joint {name}: unknown channel {channel}")
        parent = mocap.joint_parent(name)
        if parent is None:
            world_r[name], world_p[name] = rotation, translation
        else:
            pr, pp = world_r[parent.name], world_p[parent.name]
            world_p[name] = pp + np.einsum("fij,fj->fi", pr, translation)
            world_r[name] = pr @ rotation
        out[:, j] = world_p[name]
    return out


def check(path):
    expected_path = path.with_name(path.name[: -len(".bvh")] + ".expected.json")
    if not expected_path.exists():
        return f"no {expected_path.name} beside it"
    expected = json.loads(expected_path.read_text())
    text = path.read_text()
    mocap = Bvh(text)
    names = mocap.get_joints_names()
    if names != expected["joints"]:
        return f"joints {len(names)} {names[:5]}... differ from the expected {len(expected['joints'])} {expected['joints'][:5]}..."
    if mocap.nframes != expected["frames"] or len(mocap.frames) != expected["frames"]:
        return f"Frames: {mocap.nframes} with {len(mocap.frames)} value lines, expected {expected['frames']}"
    if abs(mocap.frame_time - expected["frame_time_secs"]) > 1e-8:
        return f"Frame Time: {mocap.frame_time}, expected {expected['frame_time_secs']}"
    width = channel_count(mocap)
    bad = [k for k, line in enumerate(mocap.frames) if len(line) != width]
    if bad:
        return f"frame {bad[0]} has {len(mocap.frames[bad[0]])} values, the channels want {width}"

    positions_file = forward_kinematics(mocap, names)
    # File axes and units → autoact's (metres, +Z up): p_autoact = Mᵀ · p_file / units.
    m = np.array(expected["bvh_from_autoact"], dtype=float)
    positions = np.einsum("ji,fkj->fki", m, positions_file) / expected["units_per_metre"]
    want = np.array(expected["positions_m"], dtype=float)
    error = np.linalg.norm(positions - want, axis=2)
    f, j = np.unravel_index(np.argmax(error), error.shape)
    worst_mm = error[f, j] * 1000.0
    if error[f, j] > TOLERANCE_M:
        return f"joint {names[j]} in frame {f} is {worst_mm:.3f} mm from autoact's (tolerance 1 mm)"
    return (
        None,
        f"{len(names)} joints, {mocap.nframes} frames, frame time {mocap.frame_time} s, "
        f"FK within {worst_mm * 1000.0:.3f} µm of autoact's",
    )


def main(paths):
    if not paths:
        print("usage: check_bvh.py X.bvh ...", file=sys.stderr)
        return 2
    failed = 0
    for p in map(Path, paths):
        try:
            result = check(p)
        except Exception as e:  # a crash in the parser is a failed check, reported per file
            result = f"{type(e).__name__}: {e}"
        if isinstance(result, tuple):
            print(f"ok bvh {p}: {result[1]}")
        else:
            print(f"FAIL bvh {p}: {result}")
            failed += 1
    print(f"check_bvh: {len(paths) - failed} of {len(paths)} files pass")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
