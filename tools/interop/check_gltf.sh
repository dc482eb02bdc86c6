#!/usr/bin/env bash
# Validates glTF/GLB files with the Khronos glTF-Validator (npm gltf-validator, pinned in
# gltf/package.json and gltf/package-lock.json): 0 errors required, warnings are printed.
#   check_gltf.sh FILE_OR_DIR...   every .gltf/.glb given, or found under the folders given
# The validator is installed once into ${AUTOACT_INTEROP_CACHE:-~/.cache/autoact-interop}/gltf,
# like run.sh's readers. A check that finds no file fails.
set -euo pipefail

HERE=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
CACHE=${AUTOACT_INTEROP_CACHE:-${HOME:-/root}/.cache/autoact-interop}
NPM=$CACHE/gltf

[ $# -ge 1 ] || { echo "usage: $0 FILE_OR_DIR..." >&2; exit 2; }

mkdir -p "$CACHE"
exec 9>"$CACHE/.lock-gltf"
flock 9
stamp=$( (cat "$HERE/gltf/package.json" "$HERE/gltf/package-lock.json"; node --version) | sha256sum)
if [ "$(cat "$NPM/.autoact-stamp" 2>/dev/null)" != "$stamp" ]; then
  echo "check_gltf: installing the pinned gltf-validator into $NPM" >&2
  mkdir -p "$NPM"
  cp "$HERE/gltf/package.json" "$HERE/gltf/package-lock.json" "$NPM/"
  if ! (cd "$NPM" && npm ci --no-audit --no-fund --loglevel=error) >"$NPM/install.log" 2>&1 </dev/null; then
    echo "check_gltf: installing gltf-validator failed; last lines of $NPM/install.log:" >&2
    tail -n 30 "$NPM/install.log" >&2
    exit 1
  fi
  echo "$stamp" >"$NPM/.autoact-stamp"
fi
flock -u 9

files=()
for arg in "$@"; do
  if [ -d "$arg" ]; then
    while IFS= read -r -d '' f; do files+=("$f"); done < <(
      find "$arg" -type f \( -name '*.gltf' -o -name '*.glb' \) -print0 | sort -z)
  else
    files+=("$arg")
  fi
done
if [ ${#files[@]} -eq 0 ]; then
  echo "FAIL check_gltf: no .gltf or .glb files in $* (a check that checks nothing fails)"
  exit 1
fi
NODE_PATH=$NPM/node_modules exec node "$HERE/gltf/validate.js" "${files[@]}"
