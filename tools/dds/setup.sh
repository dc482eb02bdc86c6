# Sourced by the tools/dds check scripts (after `set -euo pipefail` and HERE/ROOT): builds the
# release binary as AUTOACT (unless AUTOACT is set), makes sure the pinned venv is installed (outside any network
# namespace: the namespaces have no network), and sets OUT to KEEP or a temporary directory
# removed on exit.
# AUTOACT=path/to/autoact in the environment tests that binary instead (no build).
cd "$ROOT"
if [ -z "${AUTOACT:-}" ]; then
  cargo build --release --quiet
  AUTOACT=$ROOT/target/release/autoact
fi
tools/interop/run.sh --exec python -c 'import cyclonedds, mcap, mcap_ros2'
OUT=${KEEP:-$(mktemp -d)}
mkdir -p "$OUT"
[ -n "${KEEP:-}" ] || trap 'rm -rf "$OUT"' EXIT
