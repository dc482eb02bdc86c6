#!/usr/bin/env python3
"""Render the skeleton of an animation bag to a PNG for a quick look: a film strip of FRAMES
evenly spaced instants, each drawn from the front (left half) and the side (right half). The
skeleton is what RViz and Foxglove draw: the frame-locked `LINE_LIST` markers of
`/skeleton/markers`, each in its bone's tf frame, placed in the world by the `/tf_static` and `/tf`
transforms at that instant. Decoding goes through the independent Python readers (`mcap` +
`mcap-ros2-support`), so the picture also shows what ROS tools see.

Usage (from the repository root):
    tools/interop/run.sh --exec python tools/render_skeleton.py ANIM.mcap OUT.png [FRAMES]
"""

import struct
import sys
import zlib
from pathlib import Path

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

CELL = 220  # pixels per view
MARGIN = 10
TOPICS = ["/tf_static", "/tf", "/skeleton/markers"]


def rotate(q, v):
    """Vector `v` rotated by the unit quaternion `q` = (x, y, z, w)."""
    x, y, z, w = q
    # t = 2 (q_xyz × v); v' = v + w t + q_xyz × t
    tx, ty, tz = 2 * (y * v[2] - z * v[1]), 2 * (z * v[0] - x * v[2]), 2 * (x * v[1] - y * v[0])
    return (v[0] + w * tx + y * tz - z * ty, v[1] + w * ty + z * tx - x * tz, v[2] + w * tz + x * ty - y * tx)


def multiply(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def world_segments(transforms, markers):
    """The markers' segments in the world frame, given `transforms`: child frame -> (parent,
    translation, rotation)."""
    placed = {"world": ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))}

    def world_from(frame):
        if frame not in placed:
            parent, t, q = transforms[frame]
            pt, pq = world_from(parent)
            d = rotate(pq, t)
            placed[frame] = ((pt[0] + d[0], pt[1] + d[1], pt[2] + d[2]), multiply(pq, q))
        return placed[frame]

    segments = []
    for frame, points in markers.values():
        t, q = world_from(frame)
        world = [tuple(a + b for a, b in zip(t, rotate(q, p))) for p in points]
        segments += list(zip(world[0::2], world[1::2]))
    return segments


def read_frames(path: Path, count: int):
    """`count` evenly spaced instants of the bag's `/tf` stream, with the skeleton at each."""
    with open(path, "rb") as f:
        stamps = sorted({m.log_time for _, _, m in make_reader(f).iter_messages(topics=["/tf"])})
    if not stamps:
        sys.exit(f"{path}: no /tf messages (is it an animation bag from `autoact convert`?)")
    picks = {stamps[round(i * (len(stamps) - 1) / max(count - 1, 1))] for i in range(count)}
    transforms, markers, frames = {}, {}, []

    def snapshot(stamp):
        if not markers:
            sys.exit(f"{path}: no /skeleton/markers before {stamp} ns")
        try:
            frames.append((stamp, world_segments(transforms, markers)))
        except KeyError as e:
            sys.exit(f"{path}: at {stamp} ns, tf frame {e} is not connected to the world")

    pending = None
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(topics=TOPICS):
            if pending is not None and message.log_time > pending:
                snapshot(pending)
                pending = None
            if channel.topic == "/skeleton/markers":
                for m in decoded.markers:
                    pts = [(p.x, p.y, p.z) for p in m.points]
                    markers[(m.ns, m.id)] = (m.header.frame_id, pts)
                continue
            for t in decoded.transforms:
                v, r = t.transform.translation, t.transform.rotation
                transforms[t.child_frame_id] = (t.header.frame_id, (v.x, v.y, v.z), (r.x, r.y, r.z, r.w))
            if channel.topic == "/tf" and message.log_time in picks:
                pending = message.log_time
    if pending is not None:
        snapshot(pending)
    return frames, len(stamps)


def draw_line(img, w, x0, y0, x1, y1, color):
    steps = int(max(abs(x1 - x0), abs(y1 - y0))) + 1
    for i in range(steps + 1):
        t = i / steps
        x, y = int(round(x0 + (x1 - x0) * t)), int(round(y0 + (y1 - y0) * t))
        for dx in (0, 1):
            for dy in (0, 1):
                xx, yy = x + dx, y + dy
                if 0 <= xx < w and 0 <= yy < len(img) // (3 * w):
                    k = 3 * (yy * w + xx)
                    img[k:k + 3] = bytes(color)


def write_png(path: Path, w: int, h: int, rgb: bytearray) -> None:
    raw = b"".join(b"\x00" + bytes(rgb[3 * w * y:3 * w * (y + 1)]) for y in range(h))

    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    path.write_bytes(png)


def main(bag: Path, out: Path, count: int) -> None:
    picks, total = read_frames(bag, count)
    count = len(picks)
    w, h = 2 * CELL * count, CELL
    img = bytearray(b"\xff" * (3 * w * h))
    for k, (_, segments) in enumerate(picks):
        xs = [p[0] for s in segments for p in s]
        ys = [p[1] for s in segments for p in s]
        zs = [p[2] for s in segments for p in s]
        cx, cy = (min(xs) + max(xs)) / 2, (min(ys) + max(ys)) / 2
        scale = (CELL - 2 * MARGIN) / 2.0  # 2 m tall view
        for view in (0, 1):  # front: x across; side: y across
            ox = (2 * k + view) * CELL
            draw_line(img, w, ox, h - MARGIN, ox + CELL - 1, h - MARGIN, (200, 200, 200))  # ground z = 0
            for a, b in segments:
                ua = (a[0] - cx) if view == 0 else (a[1] - cy)
                ub = (b[0] - cx) if view == 0 else (b[1] - cy)
                draw_line(img, w, ox + CELL / 2 + ua * scale, h - MARGIN - a[2] * scale,
                          ox + CELL / 2 + ub * scale, h - MARGIN - b[2] * scale, (20, 110, 200))
    write_png(out, w, h, img)
    print(f"wrote {out}: {count} frames of {total} from {bag}, front and side views")


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    main(Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) == 4 else 6)
