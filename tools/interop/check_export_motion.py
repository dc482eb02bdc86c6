#!/usr/bin/env python3
"""Check that exports of a capture bag move every joint where the bag does, on every frame of
every scene, with readers independent of autoact:

- the bag: `/tf_static` and `/tf` read with the Python `mcap` reader and `mcap-ros2-support`,
  replayed in log-time order and composed as a tf viewer composes them; at every `/tf` message
  of the character (the one with frame `root`, in a capture bag `scene<i>/root`) every bone
  frame's origin in `world` is the truth;
- a BVH: parsed by PyPI `bvh`, joints placed by check_bvh.py's numpy forward kinematics, mapped
  back to autoact's axes and metres; its frames sit at the stamps its `X.expected.json` lists
  (`--write-expected-json`), which must be the bag's frames from `timeline_first_frame` on;
- a GLB: the binary container read here (JSON chunk, BIN chunk, float accessors), the skin's
  joint nodes composed from their rest translations and the animation's keyframes; its frames are
  the bag's frames from `scenes[0].extras.autoact.timeline_first_frame` on.

Every joint of every frame must be within 0.1 mm of the bag's, and together the files must cover
every frame of the bag.

Usage: check_export_motion.py CAPTURE.mcap FILE_OR_DIR...   Exits 0 only if everything passes.
"""

import json
import struct
import sys
from pathlib import Path

import numpy as np
from bvh import Bvh
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from check_bvh import forward_kinematics

TOLERANCE_M = 0.0001


def quat_matrix(x, y, z, w):
    n = np.sqrt(x * x + y * y + z * z + w * w)
    x, y, z, w = x / n, y / n, z / n, w / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def bag_positions(path):
    """Stamps (sorted) of the character's /tf messages, and per stamp {frame: world position}."""
    parent = {}
    out = {}
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages(
            topics=["/tf", "/tf_static"], log_time_order=True
        ):
            for t in msg.transforms:
                r, p = t.transform.rotation, t.transform.translation
                parent[t.child_frame_id] = (
                    t.header.frame_id,
                    quat_matrix(r.x, r.y, r.z, r.w),
                    np.array([p.x, p.y, p.z]),
                )
            # The character's /tf: its root frame is `root`, or in a capture bag `scene<i>/root`
            # (each scene's body has frames of its own); joints are named without that prefix.
            roots = [t.child_frame_id for t in msg.transforms if t.child_frame_id.split("/")[-1] == "root"]
            if channel.topic != "/tf" or not roots:
                continue
            prefix = roots[0][: -len("root")]
            stamp = msg.transforms[0].header.stamp.sec * 1_000_000_000 + msg.transforms[0].header.stamp.nanosec
            world = {"world": (np.eye(3), np.zeros(3))}

            def place(frame):
                if frame not in world:
                    up, r, p = parent[frame]
                    wr, wp = place(up)
                    world[frame] = (wr @ r, wp + wr @ p)
                return world[frame]

            out[stamp] = {
                name[len(prefix) :]: place(name)[1] for name in parent if name.startswith(prefix) and name != "camera"
            }
    return sorted(out), out


def bvh_positions(path):
    """(names, positions (F, J, 3) in autoact metres, stamps) of a BVH and its expected JSON."""
    expected = json.loads(path.with_name(path.name[: -len(".bvh")] + ".expected.json").read_text())
    mocap = Bvh(path.read_text())
    names = mocap.get_joints_names()
    m = np.array(expected["bvh_from_autoact"], dtype=float)
    positions = np.einsum("ji,fkj->fki", m, forward_kinematics(mocap, names)) / expected["units_per_metre"]
    return names, positions, expected["timeline_first_frame"], expected["stamps_ns"]


def glb_positions(path):
    """(names, positions (F, J, 3), first capture frame, None) of a GLB: joints by its own FK."""
    data = path.read_bytes()
    if data[:4] != b"glTF":
        raise ValueError("not a GLB")
    json_len = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20 : 20 + json_len])
    bin_start = 20 + json_len + 8
    blob = data[bin_start:]

    def accessor(i):
        a = doc["accessors"][i]
        if a["componentType"] != 5126:
            raise ValueError(f"accessor {i} is not float32")
        view = doc["bufferViews"][a["bufferView"]]
        width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[a["type"]]
        start = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        values = np.frombuffer(blob, dtype="<f4", count=a["count"] * width, offset=start)
        return values.astype(float).reshape(a["count"], width)

    joints = doc["skins"][0]["joints"]
    nodes = doc["nodes"]
    parent_of = {c: i for i, n in enumerate(nodes) for c in n.get("children", [])}
    animation = doc["animations"][0]
    keys = {}
    frames = None
    for channel in animation["channels"]:
        sampler = animation["samplers"][channel["sampler"]]
        frames = len(accessor(sampler["input"]))
        keys[(channel["target"]["node"], channel["target"]["path"])] = accessor(sampler["output"])
    names = [nodes[j]["name"] for j in joints]
    positions = np.zeros((frames, len(joints), 3))
    for k in range(frames):
        world = {}
        for slot, j in enumerate(joints):  # parents come before children in the skin
            t = keys.get((j, "translation"))
            t = t[k] if t is not None else np.array(nodes[j].get("translation", [0, 0, 0]), dtype=float)
            q = keys.get((j, "rotation"))
            q = q[k] if q is not None else np.array(nodes[j].get("rotation", [0, 0, 0, 1]), dtype=float)
            r = quat_matrix(*q)
            up = parent_of.get(j)
            if up in world:
                wr, wp = world[up]
                world[j] = (wr @ r, wp + wr @ t)
            else:  # the root joint: its values are in autoact's frame under autoact_world
                world[j] = (r, t)
            positions[k, slot] = world[j][1]
    first = doc["scenes"][0]["extras"]["autoact"]["timeline_first_frame"]
    return names, positions, first, None


def check(path, stamps, truth, covered):
    reader = bvh_positions if path.suffix == ".bvh" else glb_positions
    names, positions, first, file_stamps = reader(path)
    frames = positions.shape[0]
    if first + frames > len(stamps):
        return f"frames {first}..{first + frames} run past the bag's {len(stamps)}"
    at = stamps[first : first + frames]
    if file_stamps is not None and list(file_stamps) != at:
        return "the expected JSON's stamps are not the bag's frames from timeline_first_frame on"
    want = np.array([[truth[s][n] for n in names] for s in at])
    error = np.linalg.norm(positions - want, axis=2)
    f, j = np.unravel_index(np.argmax(error), error.shape)
    if error[f, j] > TOLERANCE_M:
        return f"joint {names[j]} in frame {f} (capture frame {first + f}) is {error[f, j] * 1000:.3f} mm from the bag's (tolerance 0.1 mm)"
    covered.update(range(first, first + frames))
    return None, f"{len(names)} joints, capture frames {first}..{first + frames}, within {error[f, j] * 1e6:.2f} µm of the bag's /tf"


def main(args):
    if len(args) < 2:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    bag = Path(args[0])
    files = []
    for a in map(Path, args[1:]):
        files += sorted(p for p in a.rglob("*") if p.suffix in (".bvh", ".glb")) if a.is_dir() else [a]
    stamps, truth = bag_positions(bag)
    failed = 0
    by_kind = {}
    for p in files:
        covered = by_kind.setdefault(p.suffix, set())
        try:
            result = check(p, stamps, truth, covered)
        except Exception as e:  # a crash is a failed check, reported per file
            result = f"{type(e).__name__}: {e}"
        if isinstance(result, tuple):
            print(f"ok export motion {p}: {result[1]}")
        else:
            print(f"FAIL export motion {p}: {result}")
            failed += 1
    for kind, covered in sorted(by_kind.items()):
        if len(covered) != len(stamps):
            print(f"FAIL export motion: the {kind} files cover {len(covered)} of the bag's {len(stamps)} frames")
            failed += 1
    if not files:
        print("FAIL export motion: no .bvh or .glb file given")
        failed += 1
    print(f"check_export_motion: {len(files)} files against {len(stamps)} frames of {bag.name}, {failed} failure(s)")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
