#!/usr/bin/env bash
# The lab in the loop without hardware (docs/lab.md): runs
# test-plans/bench-example.toml against the SCPI instrument simulator
# (`ledflicker rig simulate`, at a free port) and its simulated camera
# (examples/lab/sim-recorder.sh), then prints the instrument's log.
#
#   scripts/lab-sim.sh BIN OUT    # BIN: a ledflicker binary; OUT: a new folder
#
# OUT gets the report (report/), the instrument's log (instrument.log)
# and the simulator's output. The plan reaches the simulator through
# LEDFLICKER_SOURCE_ADDRESS, the camera its log through
# LEDFLICKER_INSTRUMENT_LOG. Exits with the plan's exit code (0 all
# pass, 1 a case failed, as the example has a failing case). The
# integration tests `lab_bench_*` check the same.
set -u
if [ $# -lt 2 ]; then
  sed -n '2,14p' "$0"; exit 2
fi
bin=$(realpath "$1"); out=$2
cd "$(dirname "$0")/.."
mkdir -p "$out" && out=$(realpath "$out")
log="$out/instrument.log"; rm -f "$log"
"$bin" rig simulate --port 0 --log "$log" >"$out/simulator.txt" 2>&1 &
sim=$!
trap 'kill -INT "$sim" 2>/dev/null; wait "$sim"' EXIT
port=""
for _ in $(seq 100); do
  port=$(sed -n 's/^SCPI instrument simulator on 127.0.0.1:\([0-9]*\) .*/\1/p' "$out/simulator.txt")
  [ -n "$port" ] && break
  sleep 0.05
done
if [ -z "$port" ]; then
  echo "the instrument simulator did not start: $(cat "$out/simulator.txt")" >&2; exit 3
fi
LEDFLICKER_SOURCE_ADDRESS="127.0.0.1:$port" LEDFLICKER_INSTRUMENT_LOG="$log" \
  "$bin" plan test-plans/bench-example.toml --out "$out/report" -q
code=$?
echo "--- instrument log ($log)"
cat "$log"
exit "$code"
