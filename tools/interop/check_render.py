#!/usr/bin/env python3
"""Check a render bag (`autoact render`) with independent readers: every message decodes with
mcap-ros2-support; /render/video says as many frames as the video has (ffprobe) and as many
as there are /render/annotations, whose frame indices run 0..N-1 at increasing stamps; every
annotation has 2 coordinates and one visibility per keypoint; /render/camera/h264 (if present)
holds one Annex B access unit per frame, starting with a start code; /render/camera/image/h264
(if present, sensor_msgs/CompressedImage for Rerun) holds the same units, stamps and frame, format
h264.

Usage: check_render.py RENDER_BAG VIDEO
"""

import json
import subprocess
import sys

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


def main() -> int:
    bag, video = sys.argv[1], sys.argv[2]
    infos, notes, units, images = [], [], [], []
    with open(bag, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, ros in reader.iter_decoded_messages(log_time_order=True):
            if channel.topic == "/render/video":
                infos.append(ros)
            elif channel.topic == "/render/annotations":
                notes.append((message.log_time, ros))
            elif channel.topic == "/render/camera/h264":
                units.append(ros)
            elif channel.topic == "/render/camera/image/h264":
                images.append(ros)
    probe = json.loads(subprocess.run(
        ["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
         "stream=nb_read_frames,width,height", "-of", "json", video],
        check=True, capture_output=True, text=True).stdout)["streams"][0]
    problems = []
    if len(infos) != 1:
        problems.append(f"{len(infos)} /render/video messages, expected 1")
    info = infos[0]
    frames = int(probe["nb_read_frames"])
    if info.frame_count != frames or len(notes) != frames:
        problems.append(f"frame_count {info.frame_count}, ffprobe {frames}, annotations {len(notes)}")
    if (info.width, info.height) != (probe["width"], probe["height"]):
        problems.append(f"size {info.width}x{info.height} vs ffprobe {probe['width']}x{probe['height']}")
    last = -1
    for k, (stamp, n) in enumerate(notes):
        if n.frame_index != k or stamp <= last:
            problems.append(f"annotation {k}: index {n.frame_index}, stamp {stamp} after {last}")
            break
        last = stamp
        names = len(n.keypoint_names)
        if len(n.keypoints_2d) != 2 * names or len(n.visibility) != names or len(n.keypoints_3d) != names:
            problems.append(f"annotation {k}: {names} names, {len(n.keypoints_2d)} coordinates")
            break
        # The rig's landmarks (face, feet, hands), which trim's COCO-17 and NTU-25 labels read.
        marks = list(n.landmark_names)
        if (len(n.landmarks_2d) != 2 * len(marks) or len(n.landmark_visibility) != len(marks)
                or len(n.landmarks_3d) != len(marks)
                or not {"nose", "l_eye", "r_eye", "l_ear", "r_ear"} <= set(marks)):
            problems.append(f"annotation {k}: landmarks {len(marks)} names, {len(n.landmarks_2d)} coordinates")
            break
    if units:
        if len(units) != frames:
            problems.append(f"{len(units)} H.264 units for {frames} frames")
        if any(not bytes(u.data).startswith((b"\x00\x00\x00\x01", b"\x00\x00\x01")) or u.format != "h264" for u in units):
            problems.append("an H.264 unit does not start with an Annex B start code")
    if images:
        if len(images) != frames:
            problems.append(f"{len(images)} H.264 CompressedImages for {frames} frames")
        if units and any(
            (bytes(i.data), i.format, i.header.frame_id, i.header.stamp.sec, i.header.stamp.nanosec)
            != (bytes(u.data), u.format, u.frame_id, u.timestamp.sec, u.timestamp.nanosec)
            for i, u in zip(images, units)
        ):
            problems.append("a CompressedImage is not the CompressedVideo unit of its frame")
        if any(i.format != "h264" for i in images):
            problems.append("a CompressedImage's format is not h264")
    for p in problems:
        print(f"FAIL {bag}: {p}")
    if not problems:
        print(f"ok {bag}: {frames} frames, {len(notes)} annotations, {len(units)} H.264 units, decoded by mcap-ros2-support")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
