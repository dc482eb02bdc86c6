# Sourced by the tools/dds check scripts (after `set -euo pipefail` and HERE/ROOT): builds the
# release binary as AUTOACT, makes sure the pinned venv is installed (outside any network
# namespace: the namespaces have no network), and sets OUT to KEEP or a temporary directory
# removed on exit.
cd "$ROOT"
cargo build --release --quiet
AUTOACT=$ROOT/target/release/autoact
tools/interop/run.sh --exec python -c 'import cyclonedds, mcap, mcap_ros2'
OUT=${KEEP:-$(mktemp -d)}
mkdir -p "$OUT"
[ -n "${KEEP:-}" ] || trap 'rm -rf "$OUT"' EXIT
