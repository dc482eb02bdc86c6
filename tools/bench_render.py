#!/usr/bin/env python3
"""End-to-end render benchmark: `autoact render` (render + H.264 encode + render bag) of the
example dataset's first capture session at 320x240 and 640x360, RUNS times each (default 3).

Prints, per resolution, the median wall-clock frames/s and its ratio to real time (the capture's
30 fps), the median CPU time per frame of autoact and ffmpeg together (steadier than wall time
on a shared machine) and what that CPU time allows on the machine's cores, and the peak resident
memory of the largest process. Targets: >= 300 frames/s at 320x240, >= 120 at 640x360, <= 1 GiB.

Usage: python3 tools/bench_render.py [AUTOACT_BINARY] (default target/release/autoact; build it
with `cargo build --release` first). Standard library only.

ENGINE=blender benchmarks `--engine blender` instead (tools/setup-blender.sh first; LIMIT frames
of the session, default 5, one Blender process per run, its start-up and scene set-up included;
the CPU time then includes Blender's, and the targets do not apply).
"""

import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGETS = {"320x240": 300.0, "640x360": 120.0}
MEMORY_LIMIT_KB = 1024 * 1024


def main() -> int:
    autoact = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "target/release/autoact")
    runs = int(os.environ.get("RUNS", "3"))
    engine = os.environ.get("ENGINE", "embedded")
    extra = [] if engine == "embedded" else ["--engine", engine, "--limit", os.environ.get("LIMIT", "5")]
    cores = os.cpu_count() or 1
    with tempfile.TemporaryDirectory() as tmp:
        cap = os.path.join(tmp, "cap")
        subprocess.run([autoact, "-q", "convert", "--spec", os.path.join(ROOT, "examples/dataset.toml"), "-o", cap],
                       check=True, stdout=subprocess.DEVNULL)
        bag = sorted(os.path.join(cap, f) for f in os.listdir(cap) if f.endswith(".mcap"))[0]
        failed = False
        print(f"bag: {os.path.basename(bag)}; engine {engine}; {runs} runs per resolution; {cores} cores")
        print("| resolution | frames | wall frames/s (median) | x real time | CPU ms/frame (median) | CPU allows on "
              f"{cores} cores | peak RSS | target |")
        print("|---|---|---|---|---|---|---|---|")
        for res, target in TARGETS.items():
            walls, cpus, frames = [], [], 0
            peak_kb = 0
            for _ in range(runs):
                before = resource.getrusage(resource.RUSAGE_CHILDREN)
                t0 = time.perf_counter()
                out = subprocess.run([autoact, "render", bag, "-o", os.path.join(tmp, "v.mp4"), "--resolution", res,
                                      "--force", *extra], check=True, capture_output=True, text=True).stdout
                wall = time.perf_counter() - t0
                after = resource.getrusage(resource.RUSAGE_CHILDREN)
                frames = int(out.split("rendered ")[1].split(" ")[0])
                walls.append(frames / wall)
                cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
                cpus.append(1000.0 * cpu / frames)
                peak_kb = max(peak_kb, after.ru_maxrss)
            fps, cpu_ms = statistics.median(walls), statistics.median(cpus)
            if engine == "embedded":
                ok = fps >= target and peak_kb <= MEMORY_LIMIT_KB
                failed |= not ok
                verdict = f">= {target:.0f} frames/s {'met' if ok else 'NOT met'}"
            else:
                verdict = "–"
            print(f"| {res} | {frames} | {fps:.2f} | {fps / 30.0:.2f}x | {cpu_ms:.1f} | {cores * 1000.0 / cpu_ms:.2f} "
                  f"frames/s | {peak_kb / 1024:.0f} MiB | {verdict} |")
        return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
