#!/usr/bin/env python3
"""Check MCAP files / rosbag2 directories against their .expected.json with `rosbags` AnyReader
(it builds the message types from each file's ros2msg schema text itself).
Usage: check_rosbags.py FILE.mcap|ROSBAG2_DIR ...

rosbags rejects a header profile other than 'ros2' on its own. It exposes neither publish_time
nor MCAP metadata records, so those two are checked by the other readers only.

For a rosbag2 directory it also checks metadata.yaml's format: version 9 must give every topic
the RIHS01 type_description_hash rosbags computes from the topic's ros2msg schema text and name
the ROS distribution; version 5 (Humble) must have neither field."""

from pathlib import Path

from rosbags.highlevel import AnyReader
from rosbags.interfaces import MessageDefinitionFormat
from rosbags.typesys import Stores, get_typestore, get_types_from_msg

from interop_common import Mismatch, parse_msgdef, run, to_plain


def read(target: Path):
    messages = []
    with AnyReader([target]) as reader:
        defs = {}
        for c in reader.connections:
            if c.msgdef.format != MessageDefinitionFormat.MSG:
                raise Mismatch(f"topic {c.topic}: schema encoding is {c.msgdef.format.name}, not ros2msg")
            if c.ext.serialization_format != "cdr":
                raise Mismatch(f"topic {c.topic}: message encoding is {c.ext.serialization_format!r}, not 'cdr'")
            defs[c.id] = parse_msgdef(c.msgtype, c.msgdef.data)
        for c, log_time, raw in reader.messages():
            messages.append({"topic": c.topic, "schema": c.msgtype, "log_time": log_time,
                             "publish_time": None, "message": to_plain(reader.deserialize(raw, c.msgtype)),
                             "defs": defs[c.id]})
        if reader.message_count != len(messages):
            where = "metadata.yaml" if target.is_dir() else "the summary"
            raise Mismatch(f"{where} says {reader.message_count} messages, read {len(messages)}")
        if target.is_dir():
            check_metadata_yaml(target, reader.connections)
    return messages, None


def rihs01(msgtype: str, schema_text: str) -> str:
    """rosbags' type description hash of msgtype, from the schema text alone."""
    store = get_typestore(Stores.EMPTY)
    store.register(get_types_from_msg(schema_text, msgtype))
    return store.hash_rihs01(msgtype)


def check_metadata_yaml(bag: Path, connections) -> None:
    from ruamel.yaml import YAML  # pinned with rosbags
    info = YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    version = info.get("version")
    topics = {t["topic_metadata"]["name"]: t["topic_metadata"] for t in info["topics_with_message_count"]}
    if version == 5:
        for key in ("custom_data", "ros_distro"):
            if key in info:
                raise Mismatch(f"metadata.yaml version 5 (Humble) has {key}, which came with version 6 or later")
        for name, meta in topics.items():
            if "type_description_hash" in meta:
                raise Mismatch(f"metadata.yaml version 5: topic {name} has a type_description_hash (version 7 or later)")
            if meta.get("offered_qos_profiles") != "":
                raise Mismatch(f"metadata.yaml version 5: topic {name} offered_qos_profiles is not a YAML string")
        return
    if version != 9:
        raise Mismatch(f"metadata.yaml version is {version!r}, not 5 or 9")
    if not info.get("ros_distro") or info["ros_distro"] == "autoact":
        raise Mismatch(f"metadata.yaml ros_distro is {info.get('ros_distro')!r}, not a ROS distribution")
    checked = 0
    for c in connections:
        want = rihs01(c.msgtype, c.msgdef.data)
        got = topics[c.topic].get("type_description_hash")
        if got != want:
            raise Mismatch(f"metadata.yaml: topic {c.topic} ({c.msgtype}) type_description_hash is {got!r}, "
                           f"rosbags computes {want!r} from its schema")
        checked += 1
    if checked != len(topics):
        raise Mismatch(f"metadata.yaml lists {len(topics)} topics, the bag has {checked}")


if __name__ == "__main__":
    run("rosbags", read, log_time_order=True)
