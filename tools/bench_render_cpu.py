#!/usr/bin/env python3
"""CPU cost per rendered frame of two builds of the embedded renderer, measured in turn in the
same minutes, and their ratio (a shared, loaded machine moves absolute figures; alternating the
two builds run by run keeps the ratio fair).

Two measurements, each RUNS times per build (default 5), alternating the builds:
- renderer alone: `render_digest bench REPEATS` (examples/render_digest.rs: 60 shots over every
  built-in location, 14 weathers, four times of day, near and far cameras), this thread's CPU
  time per frame, at 320x240 and 640x360;
- `autoact render` end to end (capture read, frames on all cores, x264 through ffmpeg, render
  bag) of the example dataset's first capture (or the bag given by BAG), CPU time of autoact and
  ffmpeg together per frame (`getrusage` of the children), at the same two sizes.

Usage:
  python3 tools/bench_render_cpu.py BEFORE_DIR AFTER_DIR
where each DIR holds `autoact` and `render_digest` of one build (e.g. copies of
target/release/autoact and target/release/examples/render_digest). RUNS, REPEATS (default 3),
LIMIT (frames of the capture, default all) and SKIP_E2E=1 / SKIP_RENDERER=1 tune it.
Standard library only.
"""

import os
import resource
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SIZES = ["320x240", "640x360"]


def children_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def renderer_alone(build: str, repeats: int) -> dict:
    out = subprocess.run([os.path.join(build, "render_digest"), "bench", str(repeats)], check=True,
                         capture_output=True, text=True).stdout
    result = {}
    for line in out.splitlines():
        parts = line.split()
        result[parts[0]] = float(parts[3])
    return result


def end_to_end(build: str, bag: str, size: str, tmp: str, limit: str | None) -> float:
    extra = ["--limit", limit] if limit else []
    before = children_cpu_s()
    out = subprocess.run([os.path.join(build, "autoact"), "render", bag, "-o", os.path.join(tmp, "v.mp4"),
                          "--resolution", size, "--force", *extra], check=True, capture_output=True, text=True).stdout
    cpu = children_cpu_s() - before
    frames = int(out.split("rendered ")[1].split(" ")[0])
    return 1000.0 * cpu / frames


def report(title: str, samples: dict) -> None:
    print(f"\n{title}")
    print("| size | before CPU ms/frame (median, range) | after | before / after (median of per-pair ratios) |")
    print("|---|---|---|---|")
    for size in SIZES:
        b, a = samples[("before", size)], samples[("after", size)]
        ratios = [x / y for x, y in zip(b, a)]
        print(f"| {size} | {statistics.median(b):.3f} ({min(b):.3f}–{max(b):.3f}) | "
              f"{statistics.median(a):.3f} ({min(a):.3f}–{max(a):.3f}) | "
              f"{statistics.median(ratios):.3f} (runs: {', '.join(f'{r:.2f}' for r in ratios)}) |")


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    builds = {"before": sys.argv[1], "after": sys.argv[2]}
    runs = int(os.environ.get("RUNS", "5"))
    repeats = int(os.environ.get("REPEATS", "3"))
    limit = os.environ.get("LIMIT")
    print(f"load average at start: {os.getloadavg()}; {runs} runs per build, alternating")
    if not os.environ.get("SKIP_RENDERER"):
        samples = {(b, s): [] for b in builds for s in SIZES}
        for _ in range(runs):
            for name, build in builds.items():
                for size, ms in renderer_alone(build, repeats).items():
                    samples[(name, size)].append(ms)
        report("renderer alone (render_digest bench, one thread, CPU ms per frame)", samples)
    if not os.environ.get("SKIP_E2E"):
        with tempfile.TemporaryDirectory() as tmp:
            bag = os.environ.get("BAG")
            if not bag:
                cap = os.path.join(tmp, "cap")
                subprocess.run([os.path.join(builds["before"], "autoact"), "-q", "convert", "--spec",
                                os.path.join(ROOT, "examples/dataset.toml"), "-o", cap], check=True,
                               stdout=subprocess.DEVNULL)
                bag = sorted(os.path.join(cap, f) for f in os.listdir(cap) if f.endswith(".mcap"))[0]
            samples = {(b, s): [] for b in builds for s in SIZES}
            for _ in range(runs):
                for size in SIZES:
                    for name, build in builds.items():
                        samples[(name, size)].append(end_to_end(build, bag, size, tmp, limit))
            report(f"autoact render end to end ({os.path.basename(bag)}; autoact + ffmpeg CPU ms per frame)",
                   samples)
    print(f"\nload average at end: {os.getloadavg()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
