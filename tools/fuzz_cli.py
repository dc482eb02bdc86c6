#!/usr/bin/env python3
"""A bounded mutation run of the autoact CLI: no panic, no abort, no hang on bad input.

Takes seed inputs of every kind autoact reads, mutates them (bit flips, interesting integers
over length fields, truncation, cut chunks, deleted/duplicated/inserted ranges, non-physical
numbers in text), runs the command that reads each kind on every mutant, and checks that it
ends by itself with one of autoact's documented exit codes (0 ok, 1 error, 2 usage, 3 input
lost): never a panic (101), a signal (SIGABRT from a failed allocation, SIGSEGV, SIGBUS) or a
hang. Every run has its address space capped (default 4 GiB, `ulimit -v`) and a wall-clock
limit. Deterministic: the same --seed gives the same mutants.

Seeds: files this script synthesises (BVH written by `autoact export`, NTU and H36M text,
MMPose JSON), the checked-in sample bags (bags/, CC BY-NC 4.0, see bags/README.md), the example
spec and a built-in layout; and, when ../shared/data exists, one real file of each kind there
(read at run time, never copied into the repository).

Every failing input is written to --failures DIR with the command and its stderr, ready to
become a regression test (fuzz/regressions/<target>--<what>, replayed by tests/it/fuzzing.rs).

Usage: tools/fuzz_cli.py [--autoact target/release/autoact] [--count 10000] [--seed 1]
                         [--jobs 2] [--timeout 30] [--max-seconds 600] [--failures DIR]
Exit status: 0 when every mutant ended cleanly, 1 otherwise.
"""

import argparse
import concurrent.futures
import json
import os
import random
import resource
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DATA = REPO.parent / "shared" / "data"
OK_CODES = {0, 1, 2, 3}
INTERESTING_U64 = [0, 1, 0x7F, 0x80, 0xFF, 0xFFFF, 0x7FFFFFFF, 0xFFFFFFFF, 1 << 32,
                   (1 << 63) - 1, 1 << 63, (1 << 64) - 1]
INTERESTING_NUMBERS = [b"-1e308", b"1e308", b"nan", b"NaN", b"inf", b"-inf", b"0", b"-0",
                       b"1e-320", b"99999999999999999999", b"-1", b"4294967296", b""]


# ---------------------------------------------------------------------------------------------
# Seeds


def ntu_text(frames=6):
    lines = [str(frames)]
    for f in range(frames):
        lines.append("1")
        lines.append("72057594037931101 0 1 2 1 2 0 0.01 -0.2 2")
        lines.append("25")
        for j in range(25):
            x, y, z = 0.05 * (j % 5) - 0.1, 1.0 - 0.07 * j, 3.0 + 0.001 * f
            lines.append(f"{x:.5f} {y:.5f} {z:.5f} 250 200 960 500 0.9 0 0.1 0 2")
    return ("\n".join(lines) + "\n").encode()


def h36m_text(frames=8):
    rows = []
    for f in range(frames):
        vals = [0.0] * 99
        for k in range(6, 99):
            vals[k] = 0.05 * ((k * 7 + f) % 11 - 5)
        rows.append(",".join(f"{v:.6f}" for v in vals))
    return ("\n".join(rows) + "\n").encode()


def mmpose_json(frames=5, joints=17):
    out = []
    for f in range(frames):
        kps = [[0.1 * (j % 4), 0.05 * j, 1.7 - 0.1 * j] for j in range(joints)]
        out.append({"frame_id": f, "instances": [
            {"keypoints": kps, "keypoint_scores": [0.9] * joints, "track_id": 0}]})
    return json.dumps(out).encode()


def panoptic_json(bodies=2):
    """A CMU Panoptic scene file: centimetres, +Y down, 19 joints of (x, y, z, score)."""
    out = []
    for b in range(bodies):
        joints = []
        for j in range(19):
            joints += [20.0 * b + 3.0 * (j % 4), -170.0 + 9.0 * j, 5.0 * (j % 3), 0.4 + 0.02 * j]
        out.append({"id": b, "joints19": joints})
    return json.dumps({"version": 0.7, "univTime": 1000.0, "fpsType": "hd_29_97",
                       "bodies": out}).encode()


def make_seeds(autoact, work):
    """Returns [(kind, name, bytes)]."""
    seeds = []
    bags = REPO / "bags"
    for name in ["bandai_wave.pose.mcap", "bandai_walk.pose.mcap"]:
        seeds.append(("pose_mcap", name, (bags / name).read_bytes()))
    for name in ["bandai_wave.anim.mcap"]:
        seeds.append(("anim_mcap", name, (bags / name).read_bytes()))
    exported = work / "export.bvh"
    subprocess.run([autoact, "-q", "export", str(bags / "bandai_wave.anim.mcap"), "-o",
                    str(exported), "--format", "bvh", "--force"], check=True)
    text = exported.read_bytes()
    # Keep mutants small: the hierarchy and the first 20 frames.
    head, _, motion = text.partition(b"MOTION")
    motion_lines = motion.strip().split(b"\n")
    frames = motion_lines[2:22]
    short = head + b"MOTION\nFrames: %d\n" % len(frames) + motion_lines[1] + b"\n" + b"\n".join(frames) + b"\n"
    seeds.append(("bvh", "autoact53.bvh", short))
    seeds.append(("ntu", "S001C001P001R001A001.skeleton", ntu_text()))
    seeds.append(("h36m", "S1_walking_1.txt", h36m_text()))
    seeds.append(("mmpose_json", "poses.json", mmpose_json()))
    seeds.append(("panoptic_json", "body3DScene_00000001.json", panoptic_json()))
    spec = (REPO / "examples" / "dataset.toml").read_bytes()
    # The mutants live elsewhere: the spec's sources are named by absolute paths.
    spec = spec.replace(b'"../bags/', b'"' + str(REPO / "bags").encode() + b"/")
    seeds.append(("spec", "dataset.toml", spec))
    seeds.append(("layout", "h36m-17.toml",
                  (REPO / "src" / "skeleton" / "layouts" / "h36m-17.toml").read_bytes()))
    if DATA.is_dir():
        real = [("bvh", "bvh/bandai_namco/dataset-1_run_normal_001.bvh"),
                ("bvh", "bvh/xia_style/angry_13_000.bvh"),
                ("ntu", "ntu/S001C001P001R001A001.skeleton"),
                ("zed_mat", "zed_body34/rzy_run1_HD1080_SN35745898_19-44-15.mat"),
                ("utd_mat", "utd_mhad_kinect1/a1_s1_t2_skeleton.mat"),
                ("panoptic_json", "panoptic/160906_band1_body3DScene_00000168.json")]
        for kind, rel in real:
            path = DATA / rel
            if path.is_file():
                seeds.append((kind, path.name, path.read_bytes()))
    return seeds


# ---------------------------------------------------------------------------------------------
# Mutations


def is_text(data):
    return b"\0" not in data[:4096]


def mutate(data, rng, kind):
    data = bytearray(data)
    n = len(data)
    if n == 0:
        return bytes(rng.randbytes(rng.randint(1, 64)))
    ops = ["flip", "byte", "u64", "truncate", "delete", "duplicate", "insert"]
    if is_text(data):
        ops += ["number", "number", "line"]
    if kind.endswith("mcap"):
        ops += ["u64", "u64", "chunk_cut"]
    for _ in range(rng.choice([1, 1, 1, 2, 3])):
        op = rng.choice(ops)
        n = len(data)
        if n == 0:
            break
        at = rng.randrange(n)
        if op == "flip":
            for _ in range(rng.randint(1, 8)):
                k = rng.randrange(n)
                data[k] ^= 1 << rng.randrange(8)
        elif op == "byte":
            data[at] = rng.choice([0, 0xFF, 0x7F, 0x80, 0x0A, 0x20, rng.randrange(256)])
        elif op == "u64":
            v = rng.choice(INTERESTING_U64 + [n, n + 1, n * 2])
            width = rng.choice([4, 8])
            packed = struct.pack("<Q", v & ((1 << 64) - 1))[:width]
            data[at:at + width] = packed
        elif op == "truncate":
            del data[at:]
        elif op == "chunk_cut":
            # Cut right before a record that starts with the chunk opcode (0x06).
            cuts = [k for k in range(8, n) if data[k] == 0x06]
            if cuts:
                del data[rng.choice(cuts):]
        elif op == "delete":
            del data[at:at + rng.randint(1, 256)]
        elif op == "duplicate":
            piece = data[at:at + rng.randint(1, 256)]
            k = rng.randrange(len(data) + 1)
            data[k:k] = piece
        elif op == "insert":
            k = rng.randrange(n + 1)
            data[k:k] = rng.randbytes(rng.randint(1, 32))
        elif op == "number":
            # Replace one number token by a non-physical or odd one.
            start = at
            while start < n and not (chr(data[start]).isdigit() or data[start] in b"-."):
                start += 1
            end = start
            while end < n and (chr(data[end]).isalnum() or data[end] in b"-.+"):
                end += 1
            if start < n:
                data[start:end] = rng.choice(INTERESTING_NUMBERS)
        elif op == "line":
            lines = bytes(data).split(b"\n")
            k = rng.randrange(len(lines))
            choice = rng.randrange(3)
            if choice == 0:
                del lines[k]
            elif choice == 1:
                lines.insert(k, lines[rng.randrange(len(lines))])
            else:
                lines[k] = lines[k] * rng.randint(2, 50)
            data = bytearray(b"\n".join(lines))
    return bytes(data)


# ---------------------------------------------------------------------------------------------
# Running


def command(kind, path, out):
    if kind == "pose_mcap":
        return [["convert", path, "-o", out, "--force"], ["info", path]]
    if kind == "anim_mcap":
        return [["export", path, "-o", out + ".bvh", "--format", "bvh", "--force"],
                ["info", path]]
    if kind == "bvh":
        return [["import", path, "-o", out, "--force"]]
    if kind == "ntu":
        return [["import", path, "-o", out, "--force"]]
    if kind == "h36m":
        return [["import", path, "-o", out, "--force", "--format", "h36m-expmap"]]
    if kind in ("zed_mat", "utd_mat"):
        # Auto-detected by their variables, as a user's .mat file is.
        return [["import", path, "-o", out, "--force"]]
    if kind == "mmpose_json":
        return [["import", path, "-o", out, "--force", "--layout", "coco-17", "--fps", "30"]]
    if kind == "panoptic_json":
        return [["import", path, "-o", out, "--force", "--format", "panoptic-json"]]
    if kind == "spec":
        return [["plan", path, "--format", "csv"]]
    if kind == "layout":
        return [["rig", "--layout", path]]
    raise ValueError(kind)


def limit(address_space_bytes, cpu_seconds):
    def apply():
        resource.setrlimit(resource.RLIMIT_AS, (address_space_bytes, address_space_bytes))
        resource.setrlimit(resource.RLIMIT_CPU, (cpu_seconds, cpu_seconds))
        resource.setrlimit(resource.RLIMIT_CORE, (0, 0))
    return apply


def run_one(job):
    autoact, kind, name, data, index, work, timeout, address_space = job
    folder = Path(work) / f"m{index}"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_bytes(data)
    out = str(folder / "out.mcap")
    results = []
    try:
        for args in command(kind, str(path), out):
            full = [autoact, "-q"] + args
            try:
                p = subprocess.run(full, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                   stderr=subprocess.PIPE, timeout=timeout,
                                   preexec_fn=limit(address_space, timeout))
                code = p.returncode
                stderr = p.stderr[-4000:].decode("utf-8", "replace")
            except subprocess.TimeoutExpired as e:
                code = "hang"
                stderr = (e.stderr or b"")[-4000:].decode("utf-8", "replace")
            results.append((args[0], code, stderr))
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    return index, kind, name, data, results


def check_seeds(args, seeds, work):
    """Every seed, unmutated, must be read cleanly (exit 0): else the run tests nothing."""
    for i, (kind, name, data) in enumerate(seeds):
        _, _, _, _, results = run_one((args.autoact, kind, name, data, f"seed{i}", str(work),
                                       args.timeout, int(args.address_space_gib * (1 << 30))))
        for command_name, code, stderr in results:
            if code != 0:
                sys.exit(f"fuzz_cli: seed {name} ({kind}) fails {command_name} unmutated: "
                         f"{describe(code)}\n{stderr}")


def describe(code):
    if code == "hang":
        return "hang"
    if isinstance(code, int) and code < 0:
        return f"signal {signal.Signals(-code).name}"
    if code == 101:
        return "panic (exit 101)"
    return f"exit {code}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--autoact", default=str(REPO / "target" / "release" / "autoact"))
    ap.add_argument("--count", type=int, default=10000, help="mutants to run")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=int, default=30, help="seconds per run (wall and CPU)")
    ap.add_argument("--address-space-gib", type=float, default=4.0)
    ap.add_argument("--max-seconds", type=float, default=None,
                    help="stop starting mutants after this long (the count run so far is reported)")
    ap.add_argument("--failures", default=None, help="folder for failing inputs")
    args = ap.parse_args()

    rng = random.Random(args.seed)
    work = Path(tempfile.mkdtemp(prefix="autoact-fuzz-cli-"))
    started = time.monotonic()
    try:
        seeds = make_seeds(args.autoact, work)
        print(f"fuzz_cli: {len(seeds)} seeds: "
              + ", ".join(sorted({k for k, _, _ in seeds})), file=sys.stderr)
        jobs = []
        for i in range(args.count):
            kind, name, data = seeds[i % len(seeds)]
            jobs.append((args.autoact, kind, name, mutate(data, rng, kind), i, str(work),
                         args.timeout, int(args.address_space_gib * (1 << 30))))
        check_seeds(args, seeds, work)
        failures = []
        done = 0
        per_kind = {}
        codes = {}
        with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
            pending = set()
            it = iter(jobs)
            stopped_early = False
            while True:
                while len(pending) < args.jobs * 2:
                    if args.max_seconds and time.monotonic() - started > args.max_seconds:
                        stopped_early = True
                        break
                    job = next(it, None)
                    if job is None:
                        break
                    pending.add(pool.submit(run_one, job))
                if not pending:
                    break
                finished, pending = concurrent.futures.wait(
                    pending, return_when=concurrent.futures.FIRST_COMPLETED)
                for f in finished:
                    index, kind, name, data, results = f.result()
                    done += 1
                    per_kind[kind] = per_kind.get(kind, 0) + 1
                    for command_name, code, stderr in results:
                        codes[code] = codes.get(code, 0) + 1
                        if code in OK_CODES:
                            continue
                        failures.append((index, kind, name, data, command_name, code, stderr))
                        print(f"FAIL mutant {index} ({kind}, {command_name}): {describe(code)}\n"
                              f"{stderr.strip()[-1500:]}", file=sys.stderr)
                    if done % 1000 == 0:
                        print(f"fuzz_cli: {done} mutants, {len(failures)} failures, "
                              f"{time.monotonic() - started:.0f} s", file=sys.stderr)
                if stopped_early and not pending:
                    break
        if args.failures and failures:
            out = Path(args.failures)
            out.mkdir(parents=True, exist_ok=True)
            for index, kind, name, data, command_name, code, stderr in failures:
                stem = f"{kind}-{index}"
                (out / f"{stem}-{name}").write_bytes(data)
                (out / f"{stem}.txt").write_text(
                    f"{command_name}: {describe(code)}\n{stderr}\n")
        elapsed = time.monotonic() - started
        kinds = ", ".join(f"{k} {v}" for k, v in sorted(per_kind.items()))
        hangs = sum(1 for f in failures if f[5] == "hang")
        panics = sum(1 for f in failures if f[5] == 101)
        signals = sum(1 for f in failures if isinstance(f[5], int) and f[5] < 0)
        print(f"fuzz_cli: seed {args.seed}: {done} mutants ({kinds}) in {elapsed:.0f} s: "
              f"{panics} panics, {signals} signals (aborts, crashes), {hangs} hangs, "
              f"{len(failures) - panics - signals - hangs} other exit codes")
        print("fuzz_cli: exit codes: " + ", ".join(
            f"{describe(c)} ×{n}" for c, n in sorted(codes.items(), key=lambda x: str(x[0]))))
        if done < args.count:
            print(f"fuzz_cli: stopped after {done} of {args.count} mutants (--max-seconds)")
        return 1 if failures else 0
    finally:
        shutil.rmtree(work, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
