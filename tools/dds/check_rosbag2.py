#!/usr/bin/env python3
"""Reads a rosbag2 directory with `rosbags` (independent of autoact) and checks that it holds as
many messages as were published (PUB.json from publish_cyclone.py), across all its split files.

Usage: check_rosbag2.py DIR PUB.json   (exits 1 if the counts differ or rosbags cannot read it)
"""

import json
import sys
from pathlib import Path

from rosbags.rosbag2 import Reader


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    want = len(json.load(open(sys.argv[2]))["messages"])
    with Reader(sys.argv[1]) as reader:
        got = sum(1 for _ in reader.messages())
        declared = reader.message_count
    files = len(list(Path(sys.argv[1]).glob("*.mcap")))
    print(f"rosbags read {got} of {want} messages ({declared} in metadata.yaml) from {files} files")
    return 0 if got == want == declared else 1


if __name__ == "__main__":
    sys.exit(main())
