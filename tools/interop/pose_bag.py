"""The small pose bag that write_with_mcap_ros2.py and write_with_rosbags.py write: the
Skeleton3D schema text (from the repository's schemas/ folder), 60 frames of a standing person
whose arms swing, and the .expected.json the checkers (and autoact) verify it with."""

import json
import math
import os
from pathlib import Path

from interop_common import norm_type, parse_msgdef

SCHEMAS = Path(os.environ.get("AUTOACT_SCHEMAS") or Path(__file__).resolve().parents[2] / "schemas")
TYPE = "autoact_msgs/msg/Skeleton3D"
TOPIC = "/skeleton"
FRAMES, RATE_HZ, START_S = 60, 30, 1_700_000_000
JOINTS = ["root", "right_hip", "right_knee", "right_foot", "left_hip", "left_knee", "left_foot",
          "spine", "thorax", "neck_base", "head", "left_shoulder", "left_elbow", "left_wrist",
          "right_shoulder", "right_elbow", "right_wrist"]


def msg_text(typ: str) -> str:
    package, name = norm_type(typ).split("/")
    path = SCHEMAS / package / "msg" / f"{name}.msg"
    if not path.is_file():
        raise SystemExit(f"error: no definition of {typ} at {path} (set AUTOACT_SCHEMAS to another schemas folder)")
    return path.read_text()


def definition(root: str = TYPE) -> str:
    """The root .msg text, then each dependency (depth first, once) the rosbag2 way."""
    text, done = msg_text(root), {norm_type(root)}

    def deps(typ: str, body: str) -> list[str]:
        return [base for _, base, _ in parse_msgdef(typ, body)[norm_type(typ)] if "/" in base]

    out, stack = [text.rstrip("\n")], deps(root, text)[::-1]
    while stack:
        typ = stack.pop()
        if typ in done:
            continue
        done.add(typ)
        body = msg_text(typ)
        out.append("=" * 80 + f"\nMSG: {typ}\n" + body.rstrip("\n"))
        stack += deps(typ, body)[::-1]
    return "\n".join(out) + "\n"


def joint_positions(t: float) -> list[tuple[float, float, float]]:
    """A standing person (metres, +Z up, facing +Y, +X is the body's right), arms swinging."""
    p = {"root": (0.0, 0.0, 0.90), "spine": (0.0, 0.0, 1.12), "thorax": (0.0, 0.0, 1.36),
         "neck_base": (0.0, 0.01, 1.46), "head": (0.0, 0.03, 1.62)}
    swing = 0.35 * math.sin(2 * math.pi * 0.5 * t)  # radians, one swing every 2 s
    for side, x, sign in (("right", 1.0, -1.0), ("left", -1.0, 1.0)):
        p[f"{side}_hip"] = (0.12 * x, 0.0, 0.88)
        p[f"{side}_knee"] = (0.12 * x, 0.01, 0.48)
        p[f"{side}_foot"] = (0.12 * x, -0.02, 0.07)
        shoulder = (0.18 * x, 0.0, 1.40)
        a, b = sign * swing, sign * swing + 0.25  # upper arm, forearm angle from straight down
        elbow = (shoulder[0], shoulder[1] + 0.28 * math.sin(a), shoulder[2] - 0.28 * math.cos(a))
        wrist = (elbow[0], elbow[1] + 0.26 * math.sin(b), elbow[2] - 0.26 * math.cos(b))
        p[f"{side}_shoulder"], p[f"{side}_elbow"], p[f"{side}_wrist"] = shoulder, elbow, wrist
    return [p[j] for j in JOINTS]


def frames():
    """(time in ns, the Skeleton3D as a dict in the .expected.json form) for every frame."""
    for i in range(FRAMES):
        t_ns = START_S * 1_000_000_000 + i * 1_000_000_000 // RATE_HZ
        yield t_ns, {
            "header": {"stamp": {"sec": t_ns // 1_000_000_000, "nanosec": t_ns % 1_000_000_000},
                       "frame_id": "world"},
            "layout": "h36m-17",
            "track_id": 0,
            "joint_names": list(JOINTS),
            "positions": [{"x": x, "y": y, "z": z} for x, y, z in joint_positions(i / RATE_HZ)],
            "confidence": [1.0] * len(JOINTS),
        }


def expected_path(out: Path) -> Path:
    return out.parent / f"{out.name.removesuffix('.mcap')}.expected.json"


def write_expected(out: Path, messages: list[dict], metadata: list[dict]) -> Path:
    """messages: [{topic, schema, log_time, publish_time, message}] in file order."""
    def nan_to_null(v):
        if isinstance(v, float) and math.isnan(v):
            return None
        if isinstance(v, dict):
            return {k: nan_to_null(x) for k, x in v.items()}
        if isinstance(v, list):
            return [nan_to_null(x) for x in v]
        return v
    path = expected_path(out)
    doc = {"messages": nan_to_null(messages), "metadata": metadata}
    path.write_text(json.dumps(doc, allow_nan=False, indent=1) + "\n")
    return path
