#!/usr/bin/env python3
"""MCAP throughput of autoact against the Python `mcap` writer/reader on the same messages,
measured in the same run, and `autoact convert` end to end on a long pose bag.

Usage (from the repository root, after `cargo build --release --examples`):
    tools/interop/run.sh --exec python tools/bench_mcap.py [FRAMES]

FRAMES (default 100000) H36M-17 skeletons of a walking, waving body are synthesised by
`examples/bench_mcap.rs`. Each side encodes them as autoact_msgs/msg/Skeleton3D (CDR) and writes
one zstd-chunked MCAP; then each reads its file back and decodes every message. Times are
medians of three runs (five for convert); rates are in MB/s of CDR payload and ratios are
autoact / Python. The machine is shared: compare ratios, not absolute numbers.

`convert` runs on synthetic bags at 50 and 30 fps and, where `../shared/data` is present, on real
Human3.6M motion (S1 walking, 3,476 frames at 50 fps, played back and forth to FRAMES frames).
The whole-body case (issue 25) converts FRAMES COCO-WholeBody-133 skeletons of real mocap: the
checked-in Bandai-Namco wave (`bags/bandai_wave.pose.mcap`: body, feet) played back and forth,
with moving synthetic hands held in the real forearms and face points in the real head
(`bench_mcap wholebody`), all 133 points present and all 53 bones moving; it runs with the
default zstd output and again uncompressed, to show what the output's compression costs.
It runs on one thread. Its rate is given per second of wall time and per second of CPU
time (user + system, from the child's resource usage): on a shared machine the process waits for a
core now and then, and the CPU rate is what one core delivers.
"""

import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent / "interop"))
import pose_bag  # noqa: E402  (definition text of Skeleton3D, the rosbag2 way)

from mcap.reader import make_reader  # noqa: E402
from mcap_ros2.decoder import DecoderFactory  # noqa: E402
from mcap_ros2.writer import Writer  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
BENCH = ROOT / "target/release/examples/bench_mcap"
AUTOACT = ROOT / "target/release/autoact"
REAL_CLIP = ROOT.parent / "shared/data/h36m_expmap/S1_walking_1.txt"
WHOLE_BODY_CLIP = ROOT / "bags/bandai_wave.pose.mcap"
JOINTS = ["root", "right_hip", "right_knee", "right_foot", "left_hip", "left_knee", "left_foot", "spine",
          "thorax", "neck_base", "head", "left_shoulder", "left_elbow", "left_wrist", "right_shoulder",
          "right_elbow", "right_wrist"]


def child_cpu_s():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def medians(runs, f):
    """Median wall seconds and median CPU seconds of child processes (user + system) of `runs`
    calls of `f`."""
    wall, cpu = [], []
    for _ in range(runs):
        c, t = child_cpu_s(), time.perf_counter()
        f()
        wall.append(time.perf_counter() - t)
        cpu.append(child_cpu_s() - c)
    return statistics.median(wall), statistics.median(cpu)


def run(*args):
    return subprocess.run([str(a) for a in args], check=True, capture_output=True, text=True).stdout


def main(frames: int) -> None:
    for exe in (BENCH, AUTOACT):
        if not exe.exists():
            sys.exit(f"{exe} is missing: run `cargo build --release --examples` first")
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        # autoact: write and read.
        _, w_s, size, payload = run(BENCH, "write", frames, tmp / "rust.mcap").split()
        _, r_s, _, _ = run(BENCH, "read", tmp / "rust.mcap").split()
        rust_w, rust_r, payload = float(w_s), float(r_s), int(payload)

        # Python: the same skeletons.
        run(BENCH, "json", frames, tmp / "frames.jsonl")
        msgs = []
        for line in (tmp / "frames.jsonl").read_text().splitlines():
            f = json.loads(line)
            t = f["stamp"]
            msgs.append((t, {
                "header": {"stamp": {"sec": t // 1_000_000_000, "nanosec": t % 1_000_000_000}, "frame_id": "world"},
                "layout": "h36m-17", "track_id": 0, "joint_names": JOINTS,
                "positions": [{"x": p[0], "y": p[1], "z": p[2]} for p in f["positions"]],
                "confidence": f["confidence"],
            }))

        def py_write():
            with open(tmp / "py.mcap", "wb") as out:
                w = Writer(out, chunk_size=256 * 1024)
                schema = w.register_msgdef(pose_bag.TYPE, pose_bag.definition())
                for i, (t, m) in enumerate(msgs):
                    w.write_message("/skeleton", schema, m, log_time=t, publish_time=t, sequence=i)
                w.finish()

        def py_read():
            with open(tmp / "py.mcap", "rb") as f:
                n = 0
                for _, _, _, m in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
                    n += len(m.positions)
            assert n == frames * len(JOINTS), n

        py_w, _ = medians(3, py_write)
        py_r, _ = medians(3, py_read)
        mb = payload / 1e6
        print(f"messages: {frames} H36M-17 skeletons, {mb:.1f} MB of CDR payload")
        print(f"write  autoact {mb / rust_w:8.1f} MB/s   python mcap {mb / py_w:6.1f} MB/s   ratio {py_w / rust_w:6.1f}x")
        print(f"read   autoact {mb / rust_r:8.1f} MB/s   python mcap {mb / py_r:6.1f} MB/s   ratio {py_r / rust_r:6.1f}x")

        # convert end to end, at H36M's native 50 fps and at equal rates (30 fps in and out).
        def convert(bag, what, *flags):
            wall, cpu = medians(5, lambda: run(AUTOACT, "convert", "-q", "--force", bag, "-o", tmp / "anim.mcap", *flags))
            print(f"convert {frames} frames {what} -> 30 fps: {wall:.2f} s wall, {cpu:.2f} s CPU;"
                  f" {frames / wall:,.0f} input frames/s (wall), {frames / cpu:,.0f} per CPU second")

        for fps in (50, 30):
            bag = tmp / f"long{fps}.mcap"
            run(BENCH, "write", frames, bag, fps)
            convert(bag, f"at {fps} fps")
        # Real motion, where ../shared/data has it (research-only data: read here, never kept):
        # a Human3.6M clip at its own 50 fps, cut to H36M-17 and played back and forth.
        if REAL_CLIP.exists():
            run(AUTOACT, "import", "-q", REAL_CLIP, "-o", tmp / "real.pose.mcap")
            run(BENCH, "loop", tmp / "real.pose.mcap", frames, tmp / "real.mcap")
            convert(tmp / "real.mcap", f"of real H36M motion ({REAL_CLIP.stem}) at 50 fps")
        else:
            print(f"convert on real motion: skipped, {REAL_CLIP} is not here")
        run(BENCH, "wholebody", WHOLE_BODY_CLIP, frames, tmp / "wholebody.mcap")
        what = "of whole-body (133 keypoints: real mocap body, moving hands) at 30 fps"
        convert(tmp / "wholebody.mcap", what)
        convert(tmp / "wholebody.mcap", what + ", output uncompressed", "--compression", "none")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 100_000)
