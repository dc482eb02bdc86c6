#!/usr/bin/env bash
# Makes the Python venv that `autoact render --engine blender` runs: PyPI `bpy` (Blender as a
# Python module, ~400 MB wheel, ~1 GB venv) pinned for the Python found. Safe to re-run: an
# existing venv whose `import bpy` works is reused. Prints the venv's python on the last line.
#
#   tools/setup-blender.sh                 # venv in ${AUTOACT_BLENDER_VENV:-~/.cache/autoact-ci/blender-venv}
#   autoact render CAPTURE --engine blender --blender-python "$(tools/setup-blender.sh | tail -n1)"
#
# bpy wheels exist for one CPython minor each: 3.13 gets bpy 5.2.3, 3.11 gets 5.0.1 (the newest
# for 3.11). The first of python3.13, pyenv's 3.13.x, python3.11, pyenv's 3.11.x is used;
# AUTOACT_BLENDER_BASE_PYTHON picks another interpreter (3.11 or 3.13).
set -euo pipefail
VENV=${AUTOACT_BLENDER_VENV:-${HOME:-/root}/.cache/autoact-ci/blender-venv}
export PIP_ROOT_USER_ACTION=ignore PIP_DISABLE_PIP_VERSION_CHECK=1

if version=$("$VENV/bin/python" -c 'import bpy; print("bpy", bpy.app.version_string)' 2>/dev/null); then
    echo "setup-blender: reusing $VENV ($(echo "$version" | tail -n1))" >&2
    echo "$VENV/bin/python"
    exit 0
fi

find_python() {
    if [ -n "${AUTOACT_BLENDER_BASE_PYTHON:-}" ]; then echo "$AUTOACT_BLENDER_BASE_PYTHON"; return; fi
    local root=${PYENV_ROOT:-${HOME:-/root}/.pyenv} minor candidate
    for minor in 3.13 3.11; do
        # pyenv's shims exist for every installed version but fail unless it is selected: ask it.
        for candidate in "$(command -v "python$minor" 2>/dev/null)" "$root"/versions/"$minor".*/bin/python"$minor"; do
            if [ -n "$candidate" ] && [ -x "$candidate" ] && "$candidate" -c '' >/dev/null 2>&1; then
                echo "$candidate"; return
            fi
        done
    done
    if command -v python3 >/dev/null; then echo python3; fi
}
base=$(find_python)
[ -n "$base" ] || { echo "setup-blender: no Python found (bpy needs CPython 3.11 or 3.13)" >&2; exit 1; }
minor=$("$base" -c 'import sys; print(f"{sys.version_info[0]}.{sys.version_info[1]}")')
case "$minor" in
    3.13) pin="bpy==5.2.3" ;;
    3.11) pin="bpy==5.0.1" ;;
    *) echo "setup-blender: $base is Python $minor; bpy wheels exist for 3.11 (bpy 5.0.1) and 3.13 (bpy 5.2.x): set AUTOACT_BLENDER_BASE_PYTHON" >&2; exit 1 ;;
esac
echo "setup-blender: $pin for Python $minor ($base) into $VENV" >&2
mkdir -p "$(dirname "$VENV")"
exec 9>"$VENV.lock"
flock 9
rm -rf "$VENV"
"$base" -m venv "$VENV"
"$VENV/bin/python" -m pip install --no-input -q "$pin" </dev/null >&2
"$VENV/bin/python" -c 'import bpy; print("setup-blender: bpy", bpy.app.version_string)' >&2
echo "$VENV/bin/python"
