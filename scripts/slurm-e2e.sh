#!/usr/bin/env bash
# End-to-end test of sharded runs on a real Slurm (issue 15, docs/scale-out.md).
#
# As root: installs a single-node Slurm from the Debian packages (slurmctld,
# slurmd, slurm-client, munge) when missing, starts munged, slurmctld and
# slurmd on a private configuration under a temporary directory, submits
# the daylight plan as a 4-task array with examples/slurm/shards.sbatch and
# the merge as a job that depends on it (--dependency=afterok, with
# examples/slurm/merge.sbatch), waits for both (sbatch --wait), runs the
# same plan on this machine alone, and compares results.json, report.html
# and report.pdf byte for byte (cmp). It stops the daemons it started, by
# their pids, on every exit. It fails, never skips, when Slurm cannot start.
#
#   scripts/slurm-e2e.sh [PLAN]      (default: daylight)
#
# LEDFLICKER: the binary to test [default: target/debug/ledflicker, built
# if missing].
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
plan=${1:-daylight}
shards=4
export SOURCE_DATE_EPOCH=1795392000 # 2026-11-23, for both reports
bin=${LEDFLICKER:-target/debug/ledflicker}
start=$(date +%s)

fail() {
    echo "slurm-e2e: FAIL: $*" >&2
    exit 1
}
step() { echo "--- slurm-e2e: $* ($(($(date +%s) - start)) s)"; }

[ "$(id -u)" = 0 ] || fail "run as root: it installs and starts Slurm"
if [ ! -x "$bin" ]; then
    step "building $bin"
    cargo build
fi
bin=$(realpath "$bin")

missing=()
for cmd in slurmctld slurmd sbatch munged mungekey; do
    command -v "$cmd" >/dev/null || missing+=("$cmd")
done
if [ ${#missing[@]} -gt 0 ]; then
    step "installing slurmctld slurmd slurm-client munge (missing: ${missing[*]})"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq || fail "apt-get update failed"
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null ||
        fail "cannot install the Slurm packages"
fi

work=$(mktemp -d /tmp/ledflicker-slurm-e2e.XXXXXX)
chmod 0755 "$work"
# The runs record into a database of their own, never the user's.
export LEDFLICKER_DB=$work/results.sqlite
pids=()
cleanup() {
    local pid
    for pid in "${pids[@]}"; do
        kill "$pid" 2>/dev/null || true
    done
    for pid in "${pids[@]}"; do
        wait "$pid" 2>/dev/null || true
    done
    rm -rf "$work"
}
trap cleanup EXIT

step "starting munged, slurmctld and slurmd in $work"
mkdir -p "$work/munge" "$work/state" "$work/spool" "$work/logs"
chmod 0700 "$work/munge"
mungekey --create --keyfile="$work/munge/munge.key" || fail "mungekey failed"
munged --foreground --force --socket="$work/munge/munge.socket" \
    --key-file="$work/munge/munge.key" --pid-file="$work/munge/munged.pid" \
    --log-file="$work/munge/munged.log" --seed-file="$work/munge/munged.seed" &
pids+=($!)
host=$(hostname -s)
node=$(slurmd -C | head -n 1)
case "$node" in
NodeName=*) ;;
*) fail "slurmd -C printed no node line: $node" ;;
esac
export SLURM_CONF=$work/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=ledflicker-e2e
SlurmctldHost=$host
SlurmUser=root
SlurmdUser=root
SlurmctldPort=16817
SlurmdPort=16818
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
JobCompType=jobcomp/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
$node State=UNKNOWN
PartitionName=e2e Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
for _ in $(seq 50); do
    [ -S "$work/munge/munge.socket" ] && break
    sleep 0.1
done
[ -S "$work/munge/munge.socket" ] || fail "munged did not start: $(cat "$work/munge/munged.log" 2>/dev/null)"
slurmctld -D -i -f "$SLURM_CONF" >"$work/logs/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" >"$work/logs/slurmd.out" 2>&1 &
pids+=($!)
state=""
for _ in $(seq 60); do
    state=$(sinfo -h -n "$host" -o %t 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 1
done
if [ "$state" != idle ]; then
    tail -n 20 "$work/slurmctld.log" "$work/slurmd.log" "$work/logs/"*.out >&2 || true
    fail "the Slurm node did not become idle (state: '${state:-none}')"
fi
sinfo

step "submitting $plan as a $shards-task array and a dependent merge job"
export PLAN=$plan SHARDS=$work/shards REPORT=$work/merged LEDFLICKER=$bin
array=$(sbatch --parsable --array=0-$((shards - 1)) --cpus-per-task=1 \
    --output="$work/logs/shard-%A-%a.out" examples/slurm/shards.sbatch)
array=${array%%;*}
set +e
sbatch --wait --dependency=afterok:"$array" --cpus-per-task=2 \
    --output="$work/logs/merge-%j.out" examples/slurm/merge.sbatch
merge_code=$?
set -e
step "array job $array: task states"
scontrol -o show job "$array" | grep -o 'JobId=[0-9]* ArrayJobId=[0-9]* ArrayTaskId=[0-9]*\|JobState=[A-Z]*\|ExitCode=[0-9:]*' |
    paste -d ' ' - - - || true
for log in "$work"/logs/shard-*.out; do
    echo "== $(basename "$log")"
    cat "$log"
done
for log in "$work"/logs/merge-*.out; do
    echo "== $(basename "$log")"
    cat "$log"
done
ran=$(ls -d "$work"/shards/shard-* 2>/dev/null | wc -l)
[ "$ran" = "$shards" ] || fail "$ran shard directories, expected $shards"
case $merge_code in
0 | 1 | 4) ;;
*) fail "the merge job failed (exit $merge_code)" ;;
esac

step "the same plan on this machine alone"
set +e
"$bin" plan "$plan" --quiet --out "$work/single"
single_code=$?
set -e
[ "$single_code" = "$merge_code" ] || fail "single run exit $single_code, merge job exit $merge_code"

step "comparing the merged report with the single run"
for f in results.json report.html report.pdf; do
    cmp "$work/single/$f" "$work/merged/$f" || fail "$f differs"
    echo "cmp $f: identical ($(stat -c %s "$work/merged/$f") bytes, sha256 $(sha256sum "$work/merged/$f" | cut -c1-16))"
done
step "PASS: $shards array tasks, the merge, and results.json, report.html, report.pdf identical to the single run"
