#!/usr/bin/env bash
# Independent-reader interop checks of the MCAP files autoact writes (see README.md).
#   run.sh DIR            check every X.mcap + X.expected.json and every rosbag2 directory
#                         D (D/metadata.yaml) + D.expected.json under DIR with three readers
#   run.sh --exec CMD...  run CMD with the pinned readers' venv first on PATH, e.g.
#                         run.sh --exec python tools/interop/write_with_rosbags.py out/bag
# The pinned readers are installed once into ${AUTOACT_INTEROP_CACHE:-~/.cache/autoact-interop}.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
CACHE=${AUTOACT_INTEROP_CACHE:-${HOME:-/root}/.cache/autoact-interop}
VENV=$CACHE/venv
NPM=$CACHE/npm
export PYTHONDONTWRITEBYTECODE=1 PIP_ROOT_USER_ACTION=ignore PIP_DISABLE_PIP_VERSION_CHECK=1

usage() { echo "usage: $0 DIR | --exec CMD [ARG...]" >&2; exit 2; }

install_failed() {
  echo "interop: installing the pinned readers failed; last lines of $CACHE/install.log:" >&2
  tail -n 30 "$CACHE/install.log" >&2
  exit 1
}

# Create or update the venv and the npm project only when their pins changed.
setup() {
  mkdir -p "$CACHE"
  exec 9>"$CACHE/.lock"
  flock 9
  local py_stamp npm_stamp
  py_stamp=$( (cat "$HERE/requirements.txt"; python3 --version) | sha256sum)
  if [ "$(cat "$VENV/.autoact-stamp" 2>/dev/null)" != "$py_stamp" ]; then
    echo "interop: installing the pinned Python readers into $VENV" >&2
    if ! "$VENV/bin/python" -c '' >/dev/null 2>&1; then
      rm -rf "$VENV"
      python3 -m venv "$VENV" >>"$CACHE/install.log" 2>&1 || install_failed
    fi
    "$VENV/bin/python" -m pip install --no-input -r "$HERE/requirements.txt" \
      >>"$CACHE/install.log" 2>&1 </dev/null || install_failed
    echo "$py_stamp" >"$VENV/.autoact-stamp"
  fi
  npm_stamp=$( (cat "$HERE/package.json" "$HERE/package-lock.json"; node --version) | sha256sum)
  if [ "$(cat "$NPM/.autoact-stamp" 2>/dev/null)" != "$npm_stamp" ]; then
    echo "interop: installing the pinned npm readers into $NPM" >&2
    mkdir -p "$NPM"
    cp "$HERE/package.json" "$HERE/package-lock.json" "$NPM/"
    (cd "$NPM" && npm ci --no-audit --no-fund --loglevel=error) \
      >>"$CACHE/install.log" 2>&1 </dev/null || install_failed
    echo "$npm_stamp" >"$NPM/.autoact-stamp"
  fi
  flock -u 9
}

[ $# -ge 1 ] || usage
if [ "$1" = "--exec" ]; then
  [ $# -ge 2 ] || usage
  setup
  shift
  PATH=$VENV/bin:$PATH exec "$@"
fi
[ $# -eq 1 ] || usage
DIR=$1
[ -d "$DIR" ] || { echo "interop: $DIR is not a directory" >&2; exit 2; }
setup

# Targets: rosbag2 directories (not descended into) and the other *.mcap files.
targets=()
while IFS= read -r -d '' t; do targets+=("$t"); done < <(
  find "$DIR" \( -type d -exec test -f '{}/metadata.yaml' \; -print0 -prune \) \
    -o \( -type f -name '*.mcap' -print0 \) | sort -z)

passed=0 failed=0
# An .expected.json with nothing to check beside it is a broken contract too.
while IFS= read -r -d '' e; do
  base=${e%.expected.json}
  if [ ! -f "$base.mcap" ] && [ ! -f "$base/metadata.yaml" ]; then
    echo "FAIL contract $e: no $(basename "$base").mcap or rosbag2 directory $(basename "$base") beside it"
    failed=$((failed + 1))
  fi
done < <(find "$DIR" -type f -name '*.expected.json' -print0 | sort -z)

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

# Run one checker on all targets; count its ok/FAIL lines; a crash counts as failures.
check() {
  local name=$1 rc ok bad missing
  shift
  set +e
  "$@" "${targets[@]}" </dev/null | tee "$tmp/$name.out"
  rc=${PIPESTATUS[0]}
  set -e
  ok=$(grep -c '^ok ' "$tmp/$name.out" || true)
  bad=$(grep -c '^FAIL ' "$tmp/$name.out" || true)
  missing=$((${#targets[@]} - ok - bad))
  if [ "$missing" -gt 0 ]; then
    echo "FAIL $name: exited $rc without a result for $missing of ${#targets[@]} targets"
    bad=$((bad + missing))
  elif [ "$rc" -ne 0 ] && [ "$bad" -eq 0 ]; then
    echo "FAIL $name: exited $rc"
    bad=1
  fi
  passed=$((passed + ok))
  failed=$((failed + bad))
}

if [ ${#targets[@]} -eq 0 ]; then
  echo "FAIL interop $DIR: no *.mcap files or rosbag2 directories (a check that checks nothing fails)"
  failed=$((failed + 1))
else
  check mcap_ros2 "$VENV/bin/python" "$HERE/check_mcap_ros2.py"
  check rosbags "$VENV/bin/python" "$HERE/check_rosbags.py"
  check foxglove env AUTOACT_INTEROP_NPM="$NPM" node "$HERE/check_foxglove.mjs"
fi

echo "interop: $passed passed, $failed failed"
[ "$failed" -eq 0 ] && [ "$passed" -gt 0 ]
