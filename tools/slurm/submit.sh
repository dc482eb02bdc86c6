#!/usr/bin/env bash
# Submits a dataset build to Slurm: a job array of N `autoact generate --shard K/N` tasks
# (generate.sbatch) and a merge job that waits for all of them (merge.sbatch,
# --dependency=afterok), then prints the two job ids.
#
#   tools/slurm/submit.sh SPEC OUT_DIR N [generate options...]
#
# OUT_DIR receives parts/<K> (one per shard), logs/ (one file per task) and merged/ (the
# dataset folder, as one `autoact generate` would have made it). OUT_DIR and the spec's sources
# must be on storage every node sees. The binary is $AUTOACT (default: `autoact` on PATH);
# extra sbatch options go in $SBATCH_OPTIONS (e.g. "--partition=cpu --cpus-per-task=8").
set -euo pipefail
[ $# -ge 3 ] || { echo "usage: $0 SPEC OUT_DIR N [generate options...]" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
spec=$(realpath "$1")
out=$(realpath -m "$2")
n=$3
shift 3
[[ "$n" =~ ^[1-9][0-9]*$ ]] || { echo "N must be a positive whole number, not '$n'" >&2; exit 2; }
mkdir -p "$out/parts" "$out/logs"
read -r -a extra <<< "${SBATCH_OPTIONS:-}"
array=$(sbatch --parsable --export=ALL "${extra[@]}" --array="0-$((n - 1))" \
    --output="$out/logs/generate-%A_%a.out" \
    "$here/generate.sbatch" "$spec" "$out/parts" "$@")
array=${array%%;*}
merge=$(sbatch --parsable --export=ALL "${extra[@]}" --dependency="afterok:$array" --kill-on-invalid-dep=yes \
    --output="$out/logs/merge-%j.out" \
    "$here/merge.sbatch" "$out/parts" "$n" "$out/merged")
merge=${merge%%;*}
echo "generate array: $array (N=$n), merge: $merge; dataset: $out/merged"
echo "$array $merge" > "$out/jobs"
