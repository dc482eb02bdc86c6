#!/usr/bin/env python3
"""Check autoact's SuperSmoother (src/dsi/supersmoother.rs) against the PyPI `supersmoother` 0.4
package (J. VanderPlas), called as the GTAutoAct paper's code did:
`SuperSmoother().fit(t, y).predict(t)` with `t = np.linspace(0, n, n)`, and
`SuperSmoother(alpha=A)` for bass enhancement.

Usage (from the repository root, with the pinned venv):
    tools/interop/run.sh --exec python tools/check_supersmoother.py [--autoact-example PATH]

PATH is a built `supersmoother_io` example; by default it is run through
`cargo run --release --quiet --example supersmoother_io`.

Series: seeded synthetic signals (sine, step, chirp, heteroscedastic noise, pure noise) of
100 to 10,000 samples, some with bass 0, 3 and 8, and a line whose noise stops before its end
(negative smoothed residuals: huge bass factors); and rotation channels (Euler angles in degrees)
of real motion capture, read from ../shared/data/bvh/{bandai_namco,xia_style}/*.bvh (30 and
120 fps; research data, read in place and never copied), without and with bass 3. Without ../shared/data that part is
skipped. A series passes when max |ours - package| <= 1e-6 * max |package|. The package divides
by zero below about 100 samples, so only longer series are compared.

Prints one line per series and a final `supersmoother: N/M series agree to 1e-6`; exits 0 only
when every compared series agrees."""

import argparse
import subprocess
import sys
from pathlib import Path

import numpy as np
from supersmoother import SuperSmoother

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT.parent / "shared" / "data"
TOLERANCE = 1e-6
SEED = 20240607
MIN_SAMPLES = 100
JOINTS_PER_FILE = 6


def synthetic_cases():
    """(name, series, alpha) for the seeded synthetic signals."""
    rng = np.random.default_rng(SEED)
    cases = []
    for n in (100, 137, 500, 2000, 10000):
        x = np.arange(n) / n
        signals = {
            "sine+noise": np.sin(2 * np.pi * 3 * x) + 0.3 * rng.standard_normal(n),
            "step+noise": np.where(x < 0.5, 0.0, 1.0) + 0.1 * rng.standard_normal(n),
            "chirp": np.sin(2 * np.pi * (2 * x + 12 * x * x)) + 0.05 * rng.standard_normal(n),
            "heteroscedastic": np.sin(2 * np.pi * x) + (0.05 + 0.6 * x) * rng.standard_normal(n),
            "noise": rng.standard_normal(n),
        }
        for name, y in signals.items():
            cases.append((f"{name}", y, None))
            if name in ("sine+noise", "heteroscedastic") and n in (137, 2000):
                for alpha in (0.0, 3.0, 8.0):
                    cases.append((f"{name} bass={alpha:g}", y, alpha))
    # Noise that stops 20 samples before the end of a line: the smoothed residuals (the woofer's
    # too) go negative there, and the package's bass factor reaches ~4e4.
    n = 200
    i = np.arange(n)
    quiet_tail = 0.01 * i + np.where(i < n - 20, (i * 37 % 11) / 5.0 - 1.0, 0.0)
    for alpha in (None, 0.0, 3.0, 8.0):
        cases.append(("quiet tail" + ("" if alpha is None else f" bass={alpha:g}"), quiet_tail, alpha))
    return cases


def read_bvh(path):
    """(joint names, their channel names, frame time in s, motion as frames x channels)."""
    tokens = path.read_text().split()
    joints, channels = [], []
    i = 0
    while tokens[i] != "MOTION":
        if tokens[i] in ("ROOT", "JOINT"):
            joints.append(tokens[i + 1])
            channels.append([])
            i += 2
        elif tokens[i] == "CHANNELS":
            count = int(tokens[i + 1])
            channels[-1] = tokens[i + 2:i + 2 + count]
            i += 2 + count
        else:
            i += 1
    frames = int(tokens[tokens.index("Frames:", i) + 1])
    j = tokens.index("Time:", i) + 1
    frame_time = float(tokens[j])
    values = np.array(tokens[j + 1:], dtype=float)
    width = sum(len(c) for c in channels)
    if values.size != frames * width:
        raise ValueError(f"{path}: {values.size} motion values, expected {frames} x {width}")
    return joints, channels, frame_time, values.reshape(frames, width)


def real_cases():
    """(name, series) for rotation channels of a few joints of each clip, or None without data."""
    if not DATA.is_dir():
        return None
    cases = []
    for folder in ("bandai_namco", "xia_style"):
        for path in sorted((DATA / "bvh" / folder).glob("*.bvh")):
            joints, channels, frame_time, motion = read_bvh(path)
            if motion.shape[0] < MIN_SAMPLES:
                continue
            starts = np.cumsum([0] + [len(c) for c in channels])
            rotating = [j for j, c in enumerate(channels) if any(n.endswith("rotation") for n in c)]
            picks = sorted({rotating[k] for k in np.linspace(0, len(rotating) - 1, JOINTS_PER_FILE).round().astype(int)})
            for j in picks:
                for c, name in enumerate(channels[j]):
                    if not name.endswith("rotation"):
                        continue
                    y = motion[:, starts[j] + c]
                    if np.ptp(y) == 0:
                        continue
                    fps = round(1 / frame_time)
                    cases.append((f"{folder}/{path.stem} {joints[j]}.{name} ({fps} fps)", y))
    return cases


def reference(y, alpha):
    n = len(y)
    t = np.linspace(0, n, n)
    model = SuperSmoother() if alpha is None else SuperSmoother(alpha=alpha)
    return model.fit(t, y).predict(t)


def ours(example, series, alpha):
    """Smooth every series in one run of the example (one series per line)."""
    flags = [] if alpha is None else ["--bass", repr(alpha)]
    if example:
        command = [example, *flags]
    else:
        command = ["cargo", "run", "--release", "--quiet", "--example", "supersmoother_io", "--", *flags]
    text = "".join(" ".join(repr(float(v)) for v in y) + "\n" for y in series)
    done = subprocess.run(command, input=text, capture_output=True, text=True, cwd=ROOT)
    if done.returncode != 0:
        sys.exit(f"check_supersmoother: {' '.join(command)} failed ({done.returncode}):\n{done.stderr}")
    lines = done.stdout.splitlines()
    if len(lines) != len(series):
        sys.exit(f"check_supersmoother: {len(series)} series in, {len(lines)} lines out")
    return [np.array(line.split(), dtype=float) for line in lines]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--autoact-example", metavar="PATH",
                        help="a built supersmoother_io example (default: cargo run it)")
    args = parser.parse_args()

    cases = synthetic_cases()
    real = real_cases()
    if real is None:
        print(f"note: {DATA} is absent: real joint-angle curves skipped")
    else:
        cases += [(name, y, None) for name, y in real]
        # Bass on real curves too: their smoothed residuals often dip below zero at the ends,
        # where the package's bass factor is a negative ratio to the power 10 - alpha.
        cases += [(f"{name} bass=3", y, 3.0) for name, y in real]

    results = []  # (case, n, relative error or None, verdict)
    by_alpha = {}
    for k, (_, y, alpha) in enumerate(cases):
        by_alpha.setdefault(alpha, []).append(k)
    mine = [None] * len(cases)
    for alpha, ks in by_alpha.items():
        for k, out in zip(ks, ours(args.autoact_example, [cases[k][1] for k in ks], alpha)):
            mine[k] = out

    for (name, y, alpha), out in zip(cases, mine):
        try:
            theirs = reference(y, alpha)
        except ValueError as e:
            results.append((name, len(y), None, f"skip (package: {e})"))
            continue
        if not np.all(np.isfinite(theirs)):
            results.append((name, len(y), None, "skip (package output not finite)"))
            continue
        if out.shape != theirs.shape:
            results.append((name, len(y), None, f"FAIL ({out.shape[0]} values out)"))
            continue
        scale = np.max(np.abs(theirs))
        error = np.max(np.abs(out - theirs)) / scale if scale > 0 else np.max(np.abs(out))
        results.append((name, len(y), error, "pass" if error <= TOLERANCE else "FAIL"))

    width = max(len(r[0]) for r in results)
    print(f"{'case':<{width}}  {'n':>6}  {'max|ours-theirs|/max|theirs|':>28}  verdict")
    for name, n, error, verdict in results:
        shown = "-" if error is None else f"{error:.3e}"
        print(f"{name:<{width}}  {n:>6}  {shown:>28}  {verdict}")
    compared = [r for r in results if not r[3].startswith("skip")]
    agreed = sum(r[3] == "pass" for r in compared)
    if len(compared) < len(results):
        print(f"note: {len(results) - len(compared)} series skipped where the package fails")
    print(f"supersmoother: {agreed}/{len(compared)} series agree to 1e-6")
    return 0 if compared and agreed == len(compared) else 1


if __name__ == "__main__":
    sys.exit(main())
