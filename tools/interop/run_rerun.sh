#!/usr/bin/env bash
# What Rerun makes of autoact's bags (check_rerun.py), with the pinned Rerun SDK.
#   run_rerun.sh BAG.mcap...      check the bags with tools/interop/check_rerun.py
#   run_rerun.sh --exec CMD...    run CMD with the Rerun venv first on PATH (e.g. `rerun bag.mcap`)
# The SDK goes once into ${AUTOACT_INTEROP_CACHE:-~/.cache/autoact-interop}/rerun-venv, apart from
# run.sh's venv: it is about 800 MB (pyarrow, the viewer), which the other checks do not need.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
CACHE=${AUTOACT_INTEROP_CACHE:-${HOME:-/root}/.cache/autoact-interop}
VENV=$CACHE/rerun-venv
export PYTHONDONTWRITEBYTECODE=1 PIP_ROOT_USER_ACTION=ignore PIP_DISABLE_PIP_VERSION_CHECK=1

[ $# -ge 1 ] || { echo "usage: $0 BAG.mcap... | --exec CMD [ARG...]" >&2; exit 2; }

mkdir -p "$CACHE"
exec 9>"$CACHE/.rerun-lock"
flock 9
stamp=$( (cat "$HERE/requirements-rerun.txt"; python3 --version) | sha256sum)
if [ "$(cat "$VENV/.autoact-stamp" 2>/dev/null)" != "$stamp" ]; then
  echo "interop: installing the pinned Rerun SDK into $VENV" >&2
  if ! "$VENV/bin/python" -c '' >/dev/null 2>&1; then
    rm -rf "$VENV"
    python3 -m venv "$VENV" >>"$CACHE/rerun-install.log" 2>&1
  fi
  if ! "$VENV/bin/python" -m pip install --no-input -r "$HERE/requirements-rerun.txt" \
    >>"$CACHE/rerun-install.log" 2>&1 </dev/null; then
    echo "interop: installing the Rerun SDK failed; last lines of $CACHE/rerun-install.log:" >&2
    tail -n 30 "$CACHE/rerun-install.log" >&2
    exit 1
  fi
  echo "$stamp" >"$VENV/.autoact-stamp"
fi
flock -u 9

if [ "$1" = "--exec" ]; then
  shift
  PATH=$VENV/bin:$PATH exec "$@"
fi
exec "$VENV/bin/python" "$HERE/check_rerun.py" "$@"
