#!/usr/bin/env python3
"""Check `autoact render --engine blender` against the embedded engine on the same capture frames:

1. the two render bags' /render/annotations are identical, message for message (the labels come
   from the capture's skeleton and camera, not from the engine);
2. at least 95 % of the joints they mark visible fall on Blender's person mask (the pixel under
   the joint or one of its 8 neighbours; the same test the embedded renderer passes in
   tests/it/render.rs);
3. Blender's depth pass agrees with the embedded renderer's where both show the person (median
   difference under 5 cm: both are z-depth in millimetres along the optical axis).

Usage: check_blender_render.py EMBEDDED.render.mcap BLENDER.render.mcap BLENDER.mask BLENDER.depth \\
           EMBEDDED.mask EMBEDDED.depth

The PNG passes are read by the small decoder below (zlib + PNG's row filters), independent of
autoact's `png` crate.
"""

import os
import struct
import sys
import zlib

import numpy as np
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

VISIBLE = 2
MIN_SHARE = 0.95
MAX_MEDIAN_DEPTH_MM = 50


def read_png_grey(path):
    """An 8- or 16-bit greyscale, non-interlaced PNG as a 2-D numpy array."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise SystemExit(f"{path}: not a PNG")
    pos, idat = 8, b""
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        body = data[pos + 8 : pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            if colour != 0 or interlace != 0 or depth not in (8, 16):
                raise SystemExit(f"{path}: colour type {colour}, depth {depth}, interlace {interlace}")
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    bpp = depth // 8
    stride = width * bpp
    raw = zlib.decompress(idat)
    out = np.zeros((height, stride), dtype=np.int32)
    prev = np.zeros(stride, dtype=np.int32)
    for y in range(height):
        line = raw[y * (stride + 1) : (y + 1) * (stride + 1)]
        kind, row = line[0], np.frombuffer(line[1:], dtype=np.uint8).astype(np.int32)
        cur = np.zeros(stride, dtype=np.int32)
        for x in range(stride):
            a = cur[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if kind == 0:
                p = 0
            elif kind == 1:
                p = a
            elif kind == 2:
                p = b
            elif kind == 3:
                p = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (row[x] + p) & 0xFF
        out[y] = cur
        prev = cur
    if bpp == 2:
        return (out[:, 0::2] << 8) | out[:, 1::2]
    return out


def as_plain(value):
    """A decoded ROS message as nested lists and dicts, for comparing."""
    if isinstance(value, (list, tuple)):
        return [as_plain(v) for v in value]
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    if hasattr(value, "__slots__"):
        return {k: as_plain(getattr(value, k)) for k in value.__slots__}
    if hasattr(value, "__dict__"):
        return {k: as_plain(v) for k, v in vars(value).items()}
    return value


def annotations(bag):
    out = []
    with open(bag, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, ros in reader.iter_decoded_messages(log_time_order=True):
            if channel.topic == "/render/annotations":
                out.append((message.log_time, ros))
    return out


def first_difference(a, b, path=""):
    if type(a) is not type(b):
        return f"{path}: {a!r} vs {b!r}"
    if isinstance(a, dict):
        for k in a:
            d = first_difference(a[k], b.get(k), f"{path}.{k}")
            if d:
                return d
        return None
    if isinstance(a, list):
        if len(a) != len(b):
            return f"{path}: {len(a)} vs {len(b)} items"
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_difference(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    return None if a == b or (a != a and b != b) else f"{path}: {a!r} vs {b!r}"


def main() -> int:
    embedded_bag, blender_bag, mask_dir, depth_dir, e_mask_dir, e_depth_dir = sys.argv[1:7]
    embedded, blender = annotations(embedded_bag), annotations(blender_bag)
    problems = []
    if not embedded or len(embedded) != len(blender):
        problems.append(f"{len(embedded)} embedded annotations, {len(blender)} Blender ones")
    for k, ((te, e), (tb, b)) in enumerate(zip(embedded, blender)):
        if te != tb:
            problems.append(f"frame {k}: log time {te} vs {tb}")
            break
        d = first_difference(as_plain(e), as_plain(b), f"frame {k}")
        if d:
            problems.append(f"annotations differ: {d}")
            break
    visible = on_mask = 0
    depth_diffs = []
    for k, (_, note) in enumerate(blender):
        name = f"frame_{k:06d}.png"
        mask = read_png_grey(os.path.join(mask_dir, name))
        h, w = mask.shape
        xy = np.array(note.keypoints_2d, dtype=np.float64).reshape(-1, 2) + 0.5  # ROS → continuous
        for (x, y), v in zip(xy, note.visibility):
            if v != VISIBLE:
                continue
            visible += 1
            x0, y0 = int(np.floor(x)), int(np.floor(y))
            window = mask[max(y0 - 1, 0) : min(y0 + 2, h), max(x0 - 1, 0) : min(x0 + 2, w)]
            on_mask += int((window == 1).any())
        depth = read_png_grey(os.path.join(depth_dir, name))
        e_depth = read_png_grey(os.path.join(e_depth_dir, name))
        e_mask = read_png_grey(os.path.join(e_mask_dir, name))
        both = (mask == 1) & (e_mask == 1) & (depth > 0) & (e_depth > 0)
        depth_diffs.extend(np.abs(depth[both] - e_depth[both]).tolist())
    share = on_mask / visible if visible else 0.0
    print(f"{on_mask}/{visible} = {share:.3f} of the visible joints on Blender's person mask "
          f"over {len(blender)} frames")
    if visible == 0 or share < MIN_SHARE:
        problems.append(f"only {share:.3f} of {visible} visible joints on Blender's silhouette (< {MIN_SHARE})")
    median = float(np.median(depth_diffs)) if depth_diffs else float("inf")
    print(f"depth: median |Blender − embedded| {median:.1f} mm over {len(depth_diffs)} person pixels")
    if median > MAX_MEDIAN_DEPTH_MM:
        problems.append(f"Blender's depth differs from the embedded renderer's by a median {median:.1f} mm")
    if problems:
        for p in problems:
            print(f"FAIL {p}")
        return 1
    print(f"ok: {len(blender)} frames, annotations identical to the embedded engine's")
    return 0


if __name__ == "__main__":
    sys.exit(main())
