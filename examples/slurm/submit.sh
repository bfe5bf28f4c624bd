#!/usr/bin/env bash
# Submits a plan as an N-task Slurm array and a merge job that waits for
# every task to succeed (--dependency=afterok).
#   examples/slurm/submit.sh PLAN N WORKDIR
# Run it from the directory the plan path is relative to; WORKDIR must be
# on a file system every node sees. Extra sbatch options (partition,
# account, time) go in SBATCH_OPTS, e.g. SBATCH_OPTS="--partition=short".
set -euo pipefail
if [ $# -ne 3 ]; then
    echo "usage: $0 PLAN N WORKDIR" >&2
    exit 2
fi
plan=$1 n=$2 work=$3
here=$(cd "$(dirname "$0")" && pwd)
mkdir -p "$work/logs"
export PLAN=$plan SHARDS=$work/shards REPORT=$work/report
# shellcheck disable=SC2086
array=$(sbatch --parsable ${SBATCH_OPTS:-} --array=0-$((n - 1)) \
    --output="$work/logs/shard-%A-%a.out" "$here/shards.sbatch")
array=${array%%;*}
# shellcheck disable=SC2086
merge=$(sbatch --parsable ${SBATCH_OPTS:-} --dependency=afterok:"$array" \
    --output="$work/logs/merge-%j.out" "$here/merge.sbatch")
echo "array job $array ($n tasks), merge job $merge; report: $REPORT"
