#!/usr/bin/env bash
# Installs what autoact needs beyond the Rust toolchain: ffmpeg and ffprobe (for `autoact render`
# and its tests), from the distribution's package manager when they are missing. Safe to re-run.
set -euo pipefail
if command -v ffmpeg >/dev/null && command -v ffprobe >/dev/null; then
    echo "ffmpeg: $(ffmpeg -hide_banner -version | head -n1)"
    exit 0
fi
sudo=""
if [ "$(id -u)" -ne 0 ]; then
    command -v sudo >/dev/null || { echo "ffmpeg is missing and there is no sudo: install ffmpeg as root" >&2; exit 1; }
    sudo="sudo"
fi
if command -v apt-get >/dev/null; then
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends ffmpeg >/dev/null
elif command -v dnf >/dev/null; then
    $sudo dnf install -y ffmpeg
elif command -v brew >/dev/null; then
    brew install ffmpeg
else
    echo "ffmpeg is missing and no known package manager was found: install ffmpeg (with ffprobe)" >&2
    exit 1
fi
echo "ffmpeg: $(ffmpeg -hide_banner -version | head -n1)"
