#!/usr/bin/env python3
"""Render the skeleton of an animation bag to a PNG for a quick look: a film strip of FRAMES
evenly spaced instants, each drawn from the front (left half) and the side (right half), from the
`/skeleton/markers` LINE_LIST that `autoact convert` writes. Decoding goes through the independent
Python readers (`mcap` + `mcap-ros2-support`), so the picture also shows what ROS tools see.

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


def read_frames(path: Path):
    frames = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, channel, message, decoded in reader.iter_decoded_messages(topics=["/skeleton/markers"]):
            segments = []
            for marker in decoded.markers:
                pts = [(p.x, p.y, p.z) for p in marker.points]
                segments += list(zip(pts[0::2], pts[1::2]))
            frames.append((message.log_time, segments))
    if not frames:
        sys.exit(f"{path}: no /skeleton/markers messages (is it an animation bag from `autoact convert`?)")
    return frames


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
    frames = read_frames(bag)
    picks = [frames[round(i * (len(frames) - 1) / max(count - 1, 1))] for i in range(count)]
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
    print(f"wrote {out}: {count} frames of {len(frames)} from {bag}, front and side views")


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    main(Path(sys.argv[1]), Path(sys.argv[2]), int(sys.argv[3]) if len(sys.argv) == 4 else 6)
