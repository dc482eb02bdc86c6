#!/usr/bin/env python3
"""Independent ROS 2 publisher for testing `autoact record`'s DDS layer: Cyclone DDS (PyPI
`cyclonedds`, pinned in tools/interop/requirements.txt), no ROS 2 install, no Rust code involved.

Publishes N messages at R Hz on each of
  rt/skeleton          autoact_msgs::msg::dds_::Skeleton3D_        (ROS /skeleton)
  rt/skeleton/markers  visualization_msgs::msg::dds_::MarkerArray_ (ROS /skeleton/markers)
with contents that are a pure function of the frame index k (see skeleton() / markers()), so a
checker can compare every received message with --json OUT (what was published, in order).

QoS: reliable, volatile, keep-last 100 (the ROS 2 default publisher profile, deeper). It waits
until both writers have matched a reader, then 0.2 s more: a volatile reader that our writer has
matched may not have matched us yet and would miss the first samples (the late-joiner gotcha).

Load and fault options (tools/dds/load.sh, tools/dds/check_record.sh):
  --topics LIST        which of skeleton, markers, malformed to publish (default skeleton,markers;
                       "" for none). `malformed` is a type with Skeleton3D's DDS type name but
                       only header and layout, on the skeleton topic: a recorder subscribing to
                       it as Skeleton3D must reject every sample. Run it in its own process
                       (one participant cannot hold two layouts under one type name).
  --skeleton-topic T   the skeleton topic (default /skeleton)
  --wholebody          133-joint skeletons (layout coco-wholebody-133, names from
                       src/skeleton/layouts/coco-wholebody-133.toml). They are serialized once, 64 pose
                       variants, and each frame k is variant k % 64 with its stamp and track_id
                       patched in: a Python process cannot serialize 133 joints faster than
                       ~500/s, and the point is to load the recorder, not the publisher.
  --image WxH@HZ       also rt/camera/image_raw (sensor_msgs::msg::dds_::Image_, rgb8, byte i of
                       frame k is (i + k) % 256), as many frames as fit the skeleton run (or -n);
                       its CDR is built by hand (checked against cyclonedds' on a small image)
  --first K            frame indices K..K+N-1 (a second run continues the first's numbering)
  --counts OUT         write {topic: {"type", "published"}} to OUT (cheaper than --json)

It starts DDS, so run it only inside a network namespace (tools/dds/netns.sh):
  tools/dds/netns.sh tools/interop/run.sh --exec python tools/dds/publish_cyclone.py -n 50 -r 100
"""

import argparse
import heapq
import json
import os
import struct
import sys
import time
import tomllib
from dataclasses import asdict, dataclass
from pathlib import Path

from cyclonedds._clayer import ddspy_write

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types as t
from cyclonedds.pub import DataWriter
from cyclonedds.topic import Topic
from cyclonedds.util import duration

# ---- ROS 2 types under their DDS names (fields exactly as in schemas/) --------------------------


@dataclass
class Time_(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: t.int32
    nanosec: t.uint32


@dataclass
class Duration_(IdlStruct, typename="builtin_interfaces::msg::dds_::Duration_"):
    sec: t.int32
    nanosec: t.uint32


@dataclass
class Header_(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time_
    frame_id: str


@dataclass
class ColorRGBA_(IdlStruct, typename="std_msgs::msg::dds_::ColorRGBA_"):
    r: t.float32
    g: t.float32
    b: t.float32
    a: t.float32


@dataclass
class Point_(IdlStruct, typename="geometry_msgs::msg::dds_::Point_"):
    x: t.float64
    y: t.float64
    z: t.float64


@dataclass
class Vector3_(IdlStruct, typename="geometry_msgs::msg::dds_::Vector3_"):
    x: t.float64
    y: t.float64
    z: t.float64


@dataclass
class Quaternion_(IdlStruct, typename="geometry_msgs::msg::dds_::Quaternion_"):
    x: t.float64
    y: t.float64
    z: t.float64
    w: t.float64


@dataclass
class Pose_(IdlStruct, typename="geometry_msgs::msg::dds_::Pose_"):
    position: Point_
    orientation: Quaternion_


@dataclass
class CompressedImage_(IdlStruct, typename="sensor_msgs::msg::dds_::CompressedImage_"):
    header: Header_
    format: str
    data: t.sequence[t.uint8]


@dataclass
class UVCoordinate_(IdlStruct, typename="visualization_msgs::msg::dds_::UVCoordinate_"):
    u: t.float32
    v: t.float32


@dataclass
class MeshFile_(IdlStruct, typename="visualization_msgs::msg::dds_::MeshFile_"):
    filename: str
    data: t.sequence[t.uint8]


@dataclass
class Marker_(IdlStruct, typename="visualization_msgs::msg::dds_::Marker_"):
    header: Header_
    ns: str
    id: t.int32
    type: t.int32
    action: t.int32
    pose: Pose_
    scale: Vector3_
    color: ColorRGBA_
    lifetime: Duration_
    frame_locked: bool
    points: t.sequence[Point_]
    colors: t.sequence[ColorRGBA_]
    texture_resource: str
    texture: CompressedImage_
    uv_coordinates: t.sequence[UVCoordinate_]
    text: str
    mesh_resource: str
    mesh_file: MeshFile_
    mesh_use_embedded_materials: bool


@dataclass
class MarkerArray_(IdlStruct, typename="visualization_msgs::msg::dds_::MarkerArray_"):
    markers: t.sequence[Marker_]


@dataclass
class Skeleton3D_(IdlStruct, typename="autoact_msgs::msg::dds_::Skeleton3D_"):
    header: Header_
    layout: str
    track_id: t.uint64
    joint_names: t.sequence[str]
    positions: t.sequence[Point_]
    confidence: t.sequence[t.float32]


@dataclass
class Image_(IdlStruct, typename="sensor_msgs::msg::dds_::Image_"):
    header: Header_
    height: t.uint32
    width: t.uint32
    encoding: str
    is_bigendian: t.uint8
    step: t.uint32
    data: t.sequence[t.uint8]


@dataclass
class MalformedSkeleton3D_(IdlStruct, typename="autoact_msgs::msg::dds_::Skeleton3D_"):
    """Skeleton3D's DDS type name, a different layout: what a misconfigured node might send."""
    header: Header_
    layout: str


# ---- deterministic contents (all float32 values are exact binary fractions) ---------------------

JOINTS = ["pelvis", "spine", "neck", "head", "l_hand", "r_hand"]


def stamp(k: int) -> Time_:
    return Time_(sec=1_700_000_000 + k // 100, nanosec=(k % 100) * 10_000_000)


def skeleton(k: int) -> Skeleton3D_:
    n = 2 + k % 5  # 2..6 joints: variable-length sequences
    return Skeleton3D_(
        header=Header_(stamp=stamp(k), frame_id="world"),
        layout="h36m-17" if k % 2 == 0 else "",
        track_id=(1 << 40) + k,
        joint_names=JOINTS[:n],
        positions=[Point_(x=0.01 * k + j, y=-0.5 * k + 0.25 * j, z=1e-3 * k * j) for j in range(n)],
        confidence=[(j + 1) / 8 + (k % 4) / 64 for j in range(n)],
    )


def marker(k: int, i: int) -> Marker_:
    return Marker_(
        header=Header_(stamp=stamp(k), frame_id=f"world{i}"),
        ns="skeleton",
        id=k * 10 + i,
        type=[5, 7, 9, 10][(k + i) % 4],  # LINE_LIST, SPHERE_LIST, TEXT_VIEW_FACING, MESH_RESOURCE
        action=0,
        pose=Pose_(position=Point_(x=float(k), y=-float(i), z=0.125 * k),
                   orientation=Quaternion_(x=0.0, y=0.0, z=0.0, w=1.0)),
        scale=Vector3_(x=0.05, y=0.05 * (i + 1), z=0.1),
        color=ColorRGBA_(r=1.0, g=(k % 8) / 8, b=0.25, a=0.5),
        lifetime=Duration_(sec=i, nanosec=k * 1000),
        frame_locked=(k + i) % 2 == 1,
        points=[Point_(x=p + 0.5 * k, y=-float(p), z=float(p * i)) for p in range(k % 4)],
        colors=[ColorRGBA_(r=p / 4, g=0.0, b=1.0, a=1.0) for p in range(k % 4)],
        texture_resource="" if k % 3 else f"file:///tex{k}.png",
        texture=CompressedImage_(header=Header_(stamp=stamp(k), frame_id="cam"), format="png",
                                 data=[(k + b) % 256 for b in range(k % 7)]),
        uv_coordinates=[UVCoordinate_(u=u / 16, v=1 - u / 16) for u in range(k % 3)],
        text=f"person {k} marker {i} ✓",
        mesh_resource="package://autoact/mesh.dae" if i == 1 else "",
        mesh_file=MeshFile_(filename=f"m{k}.stl" if i else "", data=[(3 * k + b) % 256 for b in range(i * 3)]),
        mesh_use_embedded_materials=i == 1,
    )


def markers(k: int) -> MarkerArray_:
    return MarkerArray_(markers=[marker(k, i) for i in range(1 + k % 3)])


def malformed(k: int) -> MalformedSkeleton3D_:
    return MalformedSkeleton3D_(header=Header_(stamp=stamp(k), frame_id="world"), layout="h36m-17")


WHOLEBODY = tomllib.loads((Path(__file__).resolve().parents[2] / "src" / "skeleton" / "layouts" /
                           "coco-wholebody-133.toml").read_text())["joints"]
VARIANTS = 64


def wholebody(k: int) -> Skeleton3D_:
    """Frame k of the 133-joint stream: pose variant k % 64, stamp(k), track_id 2^40 + k."""
    v = k % VARIANTS
    return Skeleton3D_(
        header=Header_(stamp=stamp(k), frame_id="world"),
        layout="coco-wholebody-133",
        track_id=(1 << 40) + k,
        joint_names=list(WHOLEBODY),
        positions=[Point_(x=0.01 * v + 0.001 * j, y=0.5 - 0.002 * j, z=1.0 + 1e-3 * v * (j % 7))
                   for j in range(len(WHOLEBODY))],
        confidence=[((j + v) % 8) / 8 for j in range(len(WHOLEBODY))],
    )


class Preserialized:
    """wholebody(k) as CDR without serializing 133 joints per frame: the 64 variants are
    serialized once and stamp and track_id patched in (their offsets found by serializing
    sentinel values), which is byte for byte what serializing wholebody(k) gives."""

    def __init__(self):
        def ser(m):
            return bytearray(m.serialize())
        self.templates = [ser(wholebody(v)) for v in range(VARIANTS)]
        probe = wholebody(0)
        probe.header.stamp = Time_(sec=0x0A0B0C0D, nanosec=0x01020304)
        probe.track_id = 0x1122334455667788
        b = bytes(ser(probe))
        self.sec_at = b.index((0x0A0B0C0D).to_bytes(4, "little"))
        self.ns_at = b.index((0x01020304).to_bytes(4, "little"))
        self.id_at = b.index((0x1122334455667788).to_bytes(8, "little"))
        assert bytes(self.cdr(1234)) == wholebody(1234).serialize(), "patched CDR differs"

    def cdr(self, k: int) -> bytearray:
        out = bytearray(self.templates[k % VARIANTS])
        st = stamp(k)
        out[self.sec_at:self.sec_at + 4] = st.sec.to_bytes(4, "little", signed=True)
        out[self.ns_at:self.ns_at + 4] = st.nanosec.to_bytes(4, "little")
        out[self.id_at:self.id_at + 8] = ((1 << 40) + k).to_bytes(8, "little")
        return out


def image_maker(width: int, height: int):
    """(frame k -> Image_, frame k -> its CDR). The CDR is built by hand: cyclonedds serializes a
    uint8 sequence element by element (900k Python calls per 640x480 rgb8 frame); the hand-built bytes are
    checked against its serializer on a small image below."""
    size = width * height * 3
    pattern = bytes(range(256)) * (size // 256 + 2)

    def pixels(k: int) -> bytes:
        return pattern[k % 256:k % 256 + size]

    def image(k: int) -> Image_:
        return Image_(header=Header_(stamp=stamp(k), frame_id="camera_optical"), height=height,
                      width=width, encoding="rgb8", is_bigendian=0, step=width * 3, data=pixels(k))

    def cstr(s: str, out: bytearray):
        out.extend(b"\0" * (-(len(out) - 4) % 4))
        b = s.encode() + b"\0"
        out.extend(struct.pack("<I", len(b)) + b)

    def cdr(k: int) -> bytearray:
        st = stamp(k)
        out = bytearray(b"\0\x01\0\0" + struct.pack("<iI", st.sec, st.nanosec))
        cstr("camera_optical", out)
        out.extend(b"\0" * (-(len(out) - 4) % 4))
        out.extend(struct.pack("<II", height, width))
        cstr("rgb8", out)
        out.append(0)
        out.extend(b"\0" * (-(len(out) - 4) % 4))
        out.extend(struct.pack("<II", width * 3, size))
        out.extend(pixels(k))
        return out
    return image, cdr


def check_image_cdr():
    image, cdr = image_maker(3, 2)
    m = image(7)
    m.data = list(m.data)
    assert bytes(cdr(7)) == m.serialize(), "hand-built Image CDR differs from cyclonedds'"


def skeletons_from(path):
    """The Skeleton3D messages of a pose bag, as this publisher's dataclasses."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    out = []
    with open(path, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, _, _, m in reader.iter_decoded_messages(log_time_order=True):
            if schema.name != "autoact_msgs/msg/Skeleton3D":
                continue
            out.append(Skeleton3D_(
                header=Header_(stamp=Time_(sec=m.header.stamp.sec, nanosec=m.header.stamp.nanosec),
                               frame_id=m.header.frame_id),
                layout=m.layout, track_id=m.track_id, joint_names=list(m.joint_names),
                positions=[Point_(x=p.x, y=p.y, z=p.z) for p in m.positions],
                confidence=[float(c) for c in m.confidence]))
    return out


def parse_image(spec: str):
    """`WxH@HZ` -> (W, H, HZ)."""
    try:
        size, hz = spec.split("@")
        w, h = (int(v) for v in size.lower().split("x"))
        hz = float(hz)
    except ValueError as e:
        raise argparse.ArgumentTypeError(f"expected WxH@HZ, e.g. 640x480@30, not {spec!r}") from e
    if not (0 < w <= 8192 and 0 < h <= 8192 and 0 < hz <= 1000):
        raise argparse.ArgumentTypeError(f"image {spec!r} out of range")
    return w, h, hz


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-n", "--count", type=int, default=50, help="messages per topic (default 50)")
    ap.add_argument("-r", "--rate", type=float, default=100.0, help="Hz (default 100)")
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID") or 0),
                    help="DDS domain (default: ROS_DOMAIN_ID or 0)")
    ap.add_argument("--match-timeout", type=float, default=10.0,
                    help="seconds to wait for a reader on every topic (default 10)")
    ap.add_argument("--linger", type=float, default=0.5,
                    help="seconds to stay up after the last write, for reliable resends (default 0.5)")
    ap.add_argument("--json", metavar="OUT", help="write what was published to OUT")
    ap.add_argument("--counts", metavar="OUT", help="write per-topic counts of what was published to OUT")
    ap.add_argument("--skeletons-from", metavar="BAG",
                    help="publish the Skeleton3D messages of this pose bag on /skeleton (only), "
                         "a real pose stream instead of the synthetic test vectors")
    ap.add_argument("--topics", default="skeleton,markers",
                    help="comma-separated: skeleton, markers, malformed (default skeleton,markers)")
    ap.add_argument("--skeleton-topic", default="/skeleton", help="ROS topic of skeletons (default /skeleton)")
    ap.add_argument("--wholebody", action="store_true", help="133-joint coco-wholebody-133 skeletons")
    ap.add_argument("--image", type=parse_image, metavar="WxH@HZ", help="also publish rt/camera/image_raw")
    ap.add_argument("--first", type=int, default=0, help="first frame index (default 0)")
    ap.add_argument("--depth", type=int, default=100,
                    help="keep-last history depth of every writer: what reliable repair can resend (default 100)")
    ap.add_argument("--best-effort", action="store_true",
                    help="offer best-effort reliability (sensor-data QoS) instead of reliable")
    args = ap.parse_args()
    kinds = [k for k in args.topics.split(",") if k]
    if set(kinds) - {"skeleton", "markers", "malformed"}:
        ap.error(f"unknown --topics {args.topics!r}")
    if not 0 < args.count <= 200_000 or not 0 < args.rate <= 10_000 or not 0 <= args.first <= 10**9:
        ap.error("need 0 < count <= 200000, 0 < rate <= 10000 and 0 <= first <= 1e9 (bounded load)")

    # (ROS topic, ROS type, IDL class, frame k -> sample, frame k -> CDR or None, count, period)
    streams = []
    skel = args.skeleton_topic
    if args.skeletons_from:
        frames = skeletons_from(args.skeletons_from)
        args.count = min(args.count, len(frames))
        streams.append((skel, "autoact_msgs/msg/Skeleton3D", Skeleton3D_, lambda k: frames[k], None))
    else:
        if "skeleton" in kinds and args.wholebody:
            pre = Preserialized()
            streams.append((skel, "autoact_msgs/msg/Skeleton3D", Skeleton3D_, wholebody, pre.cdr))
        elif "skeleton" in kinds:
            streams.append((skel, "autoact_msgs/msg/Skeleton3D", Skeleton3D_, skeleton, None))
        if "markers" in kinds:
            streams.append((skel + "/markers", "visualization_msgs/msg/MarkerArray", MarkerArray_, markers, None))
        if "malformed" in kinds:
            streams.append((skel, "autoact_msgs/msg/Skeleton3D", MalformedSkeleton3D_, malformed, None))
    streams = [s + (args.count, 1.0 / args.rate) for s in streams]
    if args.image:
        w, h, hz = args.image
        n = max(1, round(args.count / args.rate * hz)) if streams else args.count
        check_image_cdr()
        streams.append(("/camera/image_raw", "sensor_msgs/msg/Image", Image_, *image_maker(w, h), n, 1.0 / hz))
    if not streams:
        ap.error("nothing to publish")

    reliability = (Policy.Reliability.BestEffort if args.best_effort
                   else Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1)))
    qos = Qos(reliability,
              Policy.Durability.Volatile,
              Policy.History.KeepLast(args.depth))
    t0 = time.monotonic()  # discovery time is measured from participant creation
    dp = DomainParticipant(args.domain)
    writers = [DataWriter(dp, Topic(dp, "rt/" + s[0].lstrip("/"), s[2], qos=qos), qos=qos) for s in streams]

    while not all(w.get_publication_matched_status().current_count > 0 for w in writers):
        if time.monotonic() - t0 > args.match_timeout:
            print(f"publish_cyclone: no reader matched within {args.match_timeout} s", file=sys.stderr)
            return 1
        time.sleep(0.005)
    matched = time.monotonic() - t0
    time.sleep(0.2)

    published = []
    counts = {s[0]: {"type": s[1], "published": 0} for s in streams}
    # Every stream on its own clock: a heap of (due time, stream, frame number).
    start = time.monotonic()
    due = [(start, i, 0) for i in range(len(streams))]
    heapq.heapify(due)
    while due:
        when, i, j = heapq.heappop(due)
        delay = when - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        ros, typ, _, make, fast, count, period = streams[i]
        k = args.first + j
        if fast is not None:
            cdr = fast(k)
            cdr.extend(b"\0" * (-len(cdr) % 4))
            if ddspy_write(writers[i]._ref, bytes(cdr)) < 0:
                print(f"publish_cyclone: write failed on {ros}", file=sys.stderr)
                return 1
        else:
            msg = make(k)
            writers[i].write(msg)
            if args.json:
                published.append({"topic": ros, "type": typ, "index": k, "content": asdict(msg)})
        counts[ros]["published"] += 1
        if j + 1 < count:
            heapq.heappush(due, (start + (j + 1) * period, i, j + 1))
    publish_s = time.monotonic() - start
    # Let reliable resends finish before the participant goes away.
    time.sleep(min(max(args.linger, 0.0), 60.0))
    total = sum(c["published"] for c in counts.values())
    print(json.dumps({"published": total, "reader_match_s": round(matched, 3),
                      "publish_s": round(publish_s, 3),
                      "rate_hz": {ros: round(c["published"] / max(publish_s, 1e-9), 1)
                                  for ros, c in counts.items()}}), file=sys.stderr)
    if args.json:
        if any(s[4] is not None for s in streams):
            published = [{"topic": s[0], "type": s[1], "index": args.first + j,
                          "content": asdict(s[3](args.first + j))}
                         for s in streams if s[4] is not None for j in range(s[5])] + published
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump({"messages": published}, f, ensure_ascii=False,
                      default=lambda v: list(v) if isinstance(v, (bytes, bytearray)) else str(v))
    if args.counts:
        with open(args.counts, "w", encoding="utf-8") as f:
            json.dump({"topics": counts, "publish_s": round(publish_s, 3)}, f)
    return 0


if __name__ == "__main__":
    sys.exit(main())
