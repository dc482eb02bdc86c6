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

It starts DDS, so run it only inside a network namespace (tools/dds/netns.sh):
  tools/dds/netns.sh tools/interop/run.sh --exec python tools/dds/publish_cyclone.py -n 50 -r 100
"""

import argparse
import json
import os
import sys
import time
from dataclasses import asdict, dataclass

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


TOPICS = [
    ("/skeleton", "autoact_msgs/msg/Skeleton3D", Skeleton3D_, skeleton),
    ("/skeleton/markers", "visualization_msgs/msg/MarkerArray", MarkerArray_, markers),
]


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
    ap.add_argument("--skeletons-from", metavar="BAG",
                    help="publish the Skeleton3D messages of this pose bag on /skeleton (only), "
                         "a real pose stream instead of the synthetic test vectors")
    args = ap.parse_args()
    topics = TOPICS
    if args.skeletons_from:
        frames = skeletons_from(args.skeletons_from)
        args.count = min(args.count, len(frames))
        topics = [("/skeleton", "autoact_msgs/msg/Skeleton3D", Skeleton3D_, lambda k: frames[k])]
    if not 0 < args.count <= 100_000 or not 0 < args.rate <= 10_000:
        ap.error("need 0 < count <= 100000 and 0 < rate <= 10000 (bounded load)")

    qos = Qos(Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1)),
              Policy.Durability.Volatile,
              Policy.History.KeepLast(100))
    t0 = time.monotonic()  # discovery time is measured from participant creation
    dp = DomainParticipant(args.domain)
    writers = [(ros, typ, DataWriter(dp, Topic(dp, "rt/" + ros.lstrip("/"), cls, qos=qos), qos=qos), make)
               for ros, typ, cls, make in topics]

    while not all(w.get_publication_matched_status().current_count > 0 for _, _, w, _ in writers):
        if time.monotonic() - t0 > args.match_timeout:
            print(f"publish_cyclone: no reader matched within {args.match_timeout} s", file=sys.stderr)
            return 1
        time.sleep(0.005)
    matched = time.monotonic() - t0
    time.sleep(0.2)

    published = []
    period = 1.0 / args.rate
    start = time.monotonic()
    for k in range(args.count):
        for ros, typ, w, make in writers:
            msg = make(k)
            w.write(msg)
            published.append({"topic": ros, "type": typ, "index": k, "content": asdict(msg)})
        delay = start + (k + 1) * period - time.monotonic()
        if delay > 0:
            time.sleep(delay)
    # Let reliable resends finish before the participant goes away.
    time.sleep(min(max(args.linger, 0.0), 60.0))
    print(json.dumps({"published": len(published), "reader_match_s": round(matched, 3),
                      "publish_s": round(time.monotonic() - start, 3)}), file=sys.stderr)
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump({"messages": published}, f, ensure_ascii=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
