#!/usr/bin/env bash
# Loads an autoact dataset with MMAction2 1.2.0's own PoseDataset (PoseC3D 2-D and ST-GCN 3-D
# pipelines) and VideoDataset, every split (check_mmaction.py).
#   run_mmaction.sh DATASET_DIR
# The packages go once into ${AUTOACT_CI_CACHE:-~/.cache/autoact-ci}/mmaction-venv (about 5 GB,
# 4 minutes on a fresh machine), reinstalled only when requirements-mmaction.txt changes.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
CACHE=${AUTOACT_CI_CACHE:-${HOME:-/root}/.cache/autoact-ci}
VENV=$CACHE/mmaction-venv
MMACTION=mmaction2==1.2.0
export PYTHONDONTWRITEBYTECODE=1 PIP_ROOT_USER_ACTION=ignore PIP_DISABLE_PIP_VERSION_CHECK=1

[ $# -eq 1 ] || { echo "usage: $0 DATASET_DIR" >&2; exit 2; }

mkdir -p "$CACHE"
exec 9>"$CACHE/.mmaction-lock"
flock 9
stamp=$( (cat "$HERE/requirements-mmaction.txt"; echo "$MMACTION"; python3 --version) | sha256sum)
if [ "$(cat "$VENV/.autoact-stamp" 2>/dev/null)" != "$stamp" ]; then
  echo "interop: installing MMAction2 and torch into $VENV (once; about 5 GB)" >&2
  log=$CACHE/mmaction-install.log
  {
    rm -rf "$VENV" &&
      python3 -m venv "$VENV" &&
      "$VENV/bin/python" -m pip install --no-input -r "$HERE/requirements-mmaction.txt" &&
      "$VENV/bin/python" -m pip install --no-input --no-deps "$MMACTION"
  } >"$log" 2>&1 </dev/null || {
    echo "interop: installing MMAction2 failed; last lines of $log:" >&2
    tail -n 30 "$log" >&2
    exit 1
  }
  echo "$stamp" >"$VENV/.autoact-stamp"
fi
flock -u 9

exec "$VENV/bin/python" -W ignore "$HERE/check_mmaction.py" "$1"
