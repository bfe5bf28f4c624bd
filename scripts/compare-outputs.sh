#!/usr/bin/env bash
# Runs every shipped plan (test-plans/*.toml) with a fixed report date and
# compares the whole output directories, byte for byte, with a baseline.
# For refactors that must change no number (docs/architecture.md).
#
#   scripts/compare-outputs.sh BIN OUT            # make a baseline in OUT
#   scripts/compare-outputs.sh BIN OUT BASELINE   # compare OUT with BASELINE
#
# BIN is a ledflicker binary (e.g. target/debug/ledflicker built from the
# commit before the change). Exit codes of the runs are kept in
# OUT/exits.txt and compared too. Exits 1 when anything differs, but for
# a junit.xml that holds the same XML in another layout (said so).
#
# A plan with a light source (`[source]`, test-plans/bench-example.toml)
# runs against the SCPI instrument simulator (`BIN rig simulate`, on port
# 5025 when free so that a binary without LEDFLICKER_SOURCE_ADDRESS
# reaches it too) and its simulated camera. Its outputs hold host-clock
# step times, and its frames follow them, so only its exit code and each
# case's verdict (OUT/NAME.verdicts, from summary.csv) are compared.
set -u
if [ $# -lt 2 ]; then
  sed -n '2,12p' "$0"; exit 2
fi
bin=$(realpath "$1"); out=$2; base=${3:-}
cd "$(dirname "$0")/.."
case "$out" in /*) ;; *) out="$PWD/$out" ;; esac
rm -rf "$out"; mkdir -p "$out"
# The runs are recorded in a scratch results database, never the user's
# (a binary older than the database ignores the variable).
db_dir=$(mktemp -d); trap 'rm -rf "$db_dir"' EXIT
export LEDFLICKER_DB="$db_dir/results.sqlite"
timed=()
if grep -l '^\[source\]' test-plans/*.toml >/dev/null; then
  export LEDFLICKER_INSTRUMENT_LOG="$db_dir/instrument.log"
  for port in 5025 0; do
    "$bin" rig simulate --port "$port" --log "$LEDFLICKER_INSTRUMENT_LOG" >"$db_dir/sim.txt" 2>&1 &
    sim=$!
    for _ in $(seq 100); do
      got=$(sed -n 's/^SCPI instrument simulator on 127.0.0.1:\([0-9]*\) .*/\1/p' "$db_dir/sim.txt")
      [ -n "$got" ] || ! kill -0 "$sim" 2>/dev/null && break
      sleep 0.05
    done
    [ -n "$got" ] && break
    kill "$sim" 2>/dev/null; wait "$sim" 2>/dev/null
  done
  if [ -z "$got" ]; then echo "the instrument simulator did not start: $(cat "$db_dir/sim.txt")" >&2; exit 3; fi
  export LEDFLICKER_SOURCE_ADDRESS="127.0.0.1:$got"
  trap 'kill -INT "$sim" 2>/dev/null; wait "$sim"; rm -rf "$db_dir"' EXIT
fi
for p in test-plans/*.toml; do
  n=$(basename "$p" .toml)
  env -u SOURCE_DATE_EPOCH "$bin" plan "$p" --out "$out/$n" --date 2026-01-01 -q --threads 2 \
    >"$out/$n.stdout" 2>"$out/$n.stderr"
  echo "$n exit $?" >>"$out/exits.txt"
  if grep -q '^\[source\]' "$p"; then
    timed+=("$n")
    cut -d, -f1,5 "$out/$n/summary.csv" >"$out/$n.verdicts" 2>/dev/null
  fi
done
cat "$out/exits.txt"
[ -z "$base" ] && exit 0
excluded=()
for n in "${timed[@]}"; do excluded+=(-x "$n" -x "$n.stdout" -x "$n.stderr"); done
diffs=$(diff -r -q "${excluded[@]}" "$base" "$out")
if [ -z "$diffs" ]; then echo "IDENTICAL"; exit 0; fi
echo "$diffs"
# A junit.xml whose bytes differ may still be the same XML: the same
# elements, attributes (in any order) and text, with other indentation
# between elements, which JUnit consumers ignore (its layout is
# quick-junit's). Such a pair is reported and does not count as different.
others=$(echo "$diffs" | grep -v '^Files .*/junit\.xml and .*/junit\.xml differ$')
if [ -n "$others" ] || ! command -v python3 >/dev/null; then echo "DIFFERENT"; exit 1; fi
same_xml() {
  python3 - "$1" "$2" <<'PY'
import sys
import xml.etree.ElementTree as ET

def shape(e):
    # Text between child elements that is only layout is dropped; any
    # other text (a failure's message, system-out) is kept exactly.
    def text(t, layout):
        return None if layout and (t or "").strip() == "" else t
    kids = list(e)
    return (e.tag, sorted(e.attrib.items()), text(e.text, bool(kids)),
            [shape(k) + (text(k.tail, True),) for k in kids])

a, b = (shape(ET.parse(p).getroot()) for p in sys.argv[1:3])
sys.exit(0 if a == b else 1)
PY
}
echo "$diffs" | while read -r _ a _ b _; do
  if same_xml "$a" "$b"; then echo "  $b: same XML, other layout"; else echo "  $b: other XML"; exit 1; fi
done || { echo "DIFFERENT"; exit 1; }
echo "IDENTICAL (junit.xml: same XML, other layout)"
