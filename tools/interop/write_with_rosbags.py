#!/usr/bin/env python3
"""Write the small pose bag (see pose_bag.py) with rosbags' rosbag2 Writer (MCAP storage,
version 9), plus OUT.expected.json beside it.
Usage: write_with_rosbags.py OUT_DIR   (a rosbag2 directory: OUT_DIR/metadata.yaml + OUT_DIR/*.mcap)
       write_with_rosbags.py OUT.mcap  (just the MCAP file that rosbags writes inside the bag)"""

import shutil
import sys
import tempfile
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

import pose_bag


def write_bag(bag: Path) -> list[dict]:
    msgdef = pose_bag.definition()
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(msgdef, pose_bag.TYPE))
    T = store.types
    Skeleton3D, Header, Time, Point = (T[pose_bag.TYPE], T["std_msgs/msg/Header"],
                                       T["builtin_interfaces/msg/Time"], T["geometry_msgs/msg/Point"])
    expected = []
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection(pose_bag.TOPIC, pose_bag.TYPE, msgdef=msgdef,
                                     rihs01=store.hash_rihs01(pose_bag.TYPE))
        for t_ns, m in pose_bag.frames():
            stamp = m["header"]["stamp"]
            msg = Skeleton3D(
                header=Header(stamp=Time(sec=stamp["sec"], nanosec=stamp["nanosec"]),
                              frame_id=m["header"]["frame_id"]),
                layout=m["layout"], track_id=m["track_id"], joint_names=m["joint_names"],
                positions=[Point(**p) for p in m["positions"]],
                confidence=np.array(m["confidence"], dtype=np.float32))
            writer.write(conn, t_ns, store.serialize_cdr(msg, pose_bag.TYPE))  # publish_time = log_time
            expected.append({"topic": pose_bag.TOPIC, "schema": pose_bag.TYPE, "log_time": t_ns,
                             "publish_time": t_ns, "message": m})
    return expected


def main(out: Path) -> None:
    if out.exists():
        sys.exit(f"error: {out} exists already")
    if out.suffix == ".mcap":  # write a bag in a scratch directory, keep only its MCAP file
        with tempfile.TemporaryDirectory(dir=out.parent) as tmp:
            bag = Path(tmp) / out.stem
            expected = write_bag(bag)
            (mcap,) = bag.glob("*.mcap")
            shutil.move(mcap, out)
    else:
        expected = write_bag(out)
    # rosbags also writes a 'rosbag2' metadata record (metadata.yaml); the checkers skip it unless listed
    print(f"wrote {out} ({len(expected)} messages) and {pose_bag.write_expected(out, expected, [])}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__.split("\n", 2)[2])
    main(Path(sys.argv[1]))
