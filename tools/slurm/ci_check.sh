#!/usr/bin/env bash
# A real one-node Slurm cluster, inside this run and torn down after it: Debian's slurm-wlm and
# munge (installed with apt-get when missing; needs root), a private munged, slurmctld and slurmd
# on localhost with every state file under a temporary folder. Submits the demo spec as a 4-shard
# job array plus the dependent merge job (tools/slurm/submit.sh), waits (bounded), and checks the
# merged dataset is byte-identical to one `autoact generate` of the same spec (every file: lists,
# annotations, manifest, plan, journal and the clips themselves), then prints the shards' total
# CPU time against the single run's.
#
#   tools/slurm/ci_check.sh [AUTOACT_BINARY]     (default: target/release/autoact)
set -euo pipefail
cd "$(dirname "$0")/../.."
autoact=$(realpath "${1:-target/release/autoact}")
[ -x "$autoact" ] || { echo "no autoact binary at $autoact (cargo build --release)" >&2; exit 1; }
spec=examples/dataset.toml
shards=4
options=(--resolution 320x240)
timeout_s=${SLURM_CI_TIMEOUT_S:-900}

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v sbatch >/dev/null \
    || ! command -v munged >/dev/null; then
    [ "$(id -u)" = 0 ] || { echo "slurm-wlm and munge are missing and this is not root" >&2; exit 1; }
    echo "installing slurm-wlm and munge (apt-get)"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends slurm-wlm munge >/dev/null
fi
slurmctld -V

tmp=$(mktemp -d /tmp/autoact-slurm.XXXXXX)
chmod 755 "$tmp"
started_pids=()
teardown() {
    local status=$?
    if [ -n "${SLURM_CONF:-}" ] && [ -f "$SLURM_CONF" ]; then
        scancel --quiet --user=root 2>/dev/null || true
        scontrol shutdown 2>/dev/null || true
    fi
    # Only the daemons started here, by the ids in their pid files.
    for pidfile in "$tmp/slurmd.pid" "$tmp/slurmctld.pid" "$tmp/munged.pid"; do
        [ -f "$pidfile" ] || continue
        local pid
        pid=$(cat "$pidfile")
        # slurmctld and slurmd end on `scontrol shutdown`; munged is only ever killed.
        if [ "$pidfile" != "$tmp/munged.pid" ]; then
            for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        fi
        kill "$pid" 2>/dev/null || true
        # Wait for the exit: a daemon still writing its seed file or removing its
        # socket makes the folder's removal below fail ("Directory not empty").
        for _ in $(seq 100); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    done
    if [ "$status" -ne 0 ]; then
        for log in "$tmp"/slurmctld.log "$tmp"/slurmd.log "$tmp"/out/logs/*; do
            [ -f "$log" ] && { echo "--- $log (last lines)"; tail -n 20 "$log"; }
        done
    fi
    # The check's verdict is $status; a leftover temporary folder is only reported.
    rm -rf "$tmp" 2>/dev/null || { sleep 1; rm -rf "$tmp" 2>/dev/null; } \
        || echo "warning: could not remove $tmp" >&2
    exit "$status"
}
trap teardown EXIT

# munge: a private key, socket and daemon (any system munged is left alone).
mkdir -m 700 "$tmp/munge"
dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$tmp/munge/munge.key"
munged --force --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/munge.socket" \
    --pid-file="$tmp/munged.pid" --log-file="$tmp/munge/munged.log" --seed-file="$tmp/munge/munged.seed"

host=$(hostname -s)
cpus=$(nproc)
mkdir -p "$tmp/state" "$tmp/spool"
export SLURM_CONF="$tmp/slurm.conf"
cat > "$SLURM_CONF" <<CONF
ClusterName=autoactci
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge/munge.socket
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
JobAcctGatherType=jobacct_gather/none
MpiDefault=none
ReturnToService=2
MinJobAge=3600
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=ci Nodes=$host Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
CONF
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
    sinfo -h -o '%T' 2>/dev/null | grep -Eq '^(idle|mixed|allocated)' && break
    sleep 1
done
sinfo

# The cluster run: every shard is one single-CPU task, so up to $cpus shards run at once.
export AUTOACT="$autoact"
SBATCH_OPTIONS="--cpus-per-task=1" tools/slurm/submit.sh "$spec" "$tmp/out" "$shards" "${options[@]}"
read -r array merge < "$tmp/out/jobs"
waited=0
while squeue -h -j "$array,$merge" 2>/dev/null | grep -q .; do
    [ "$waited" -lt "$timeout_s" ] || { echo "the Slurm jobs did not finish within $timeout_s s" >&2; squeue; exit 1; }
    sleep 5
    waited=$((waited + 5))
done
state=$(scontrol show job "$merge" | grep -o 'JobState=[A-Z_]*' | head -n 1)
[ "$state" = "JobState=COMPLETED" ] || { echo "merge job $merge: $state" >&2; exit 1; }
for k in $(seq 0 $((shards - 1))); do
    s=$(scontrol show job "${array}_$k" | grep -o 'JobState=[A-Z_]*' | head -n 1)
    [ "$s" = "JobState=COMPLETED" ] || { echo "shard $k (job ${array}_$k): $s" >&2; exit 1; }
done
echo "ok: the $shards-shard array and the merge job completed after about $waited s"

# One machine, the same spec and options.
TIMEFORMAT='autoact-cpu-seconds: %U %S'
{ time "$autoact" -q generate "$spec" -o "$tmp/single" "${options[@]}" >/dev/null; } 2> "$tmp/single.time"
diff -r --exclude='.autoact-*.lock' "$tmp/single" "$tmp/out/merged"
echo "ok: the merged dataset is byte-identical to one generate run (every file, clips included)"

cpu_of() { awk '/^autoact-cpu-seconds:/ { s += $2 + $3 } END { printf "%.2f", s }' "$@"; }
shards_cpu=$(cpu_of "$tmp"/out/logs/generate-*.out)
merge_cpu=$(cpu_of "$tmp"/out/logs/merge-*.out)
single_cpu=$(cpu_of "$tmp/single.time")
ratio=$(awk -v a="$shards_cpu" -v b="$single_cpu" 'BEGIN { printf "%.3f", (b > 0 ? a / b : 0) }')
echo "CPU: $shards shards ${shards_cpu} s in all (merge ${merge_cpu} s), one machine ${single_cpu} s: ratio ${ratio} (issue 22 wants <= 1.15)"
awk -v r="$ratio" 'BEGIN { exit !(r <= 1.15) }' || { echo "the shards' CPU is more than 1.15x the single run's" >&2; exit 1; }
