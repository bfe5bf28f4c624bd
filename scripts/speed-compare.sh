#!/usr/bin/env bash
# Wall time and peak RSS of two ledflicker binaries on the shipped daylight
# and P2020 sample plans, run alternately (so both see the same load), as
# medians over REPS runs each. Used for the before/after figures of the
# README's "Speed" section; `ledflicker bench --end-to-end` gives one
# binary's figures beside the OpenCV reference.
#
#   scripts/speed-compare.sh BEFORE_BIN AFTER_BIN [REPS]
set -euo pipefail
before=${1:?usage: scripts/speed-compare.sh BEFORE_BIN AFTER_BIN [REPS]}
after=${2:?usage: scripts/speed-compare.sh BEFORE_BIN AFTER_BIN [REPS]}
reps=${3:-5}
root=$(cd "$(dirname "$0")/.." && pwd)
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
command -v /usr/bin/time >/dev/null || { echo "needs /usr/bin/time (apt-get install time)" >&2; exit 2; }

median() { sort -g | awk '{v[NR]=$1} END {print v[int((NR+1)/2)]}'; }

for plan in daylight p2020-samples; do
    : >"$scratch/before.txt"
    : >"$scratch/after.txt"
    for _ in $(seq "$reps"); do
        for which in before after; do
            bin=$before
            [ "$which" = after ] && bin=$after
            rm -rf "$scratch/out"
            # Exit 0 (pass) and 1 (some case failed) are both finished runs;
            # time(1) prints its figures on the last line of its file.
            /usr/bin/time -f "%e %M" -o "$scratch/t" \
                "$bin" plan "$root/test-plans/$plan.toml" -q --out "$scratch/out" >/dev/null 2>&1 || [ $? -eq 1 ]
            tail -n 1 "$scratch/t" >>"$scratch/$which.txt"
        done
    done
    for which in before after; do
        wall=$(cut -d' ' -f1 "$scratch/$which.txt" | median)
        rss=$(cut -d' ' -f2 "$scratch/$which.txt" | median)
        printf '%-14s %-6s wall median %6.3f s   peak RSS median %5d MB   (%d runs)\n' \
            "$plan" "$which" "$wall" "$((rss / 1024))" "$reps"
    done
done
echo "load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)"
