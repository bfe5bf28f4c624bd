#!/usr/bin/env bash
# The false-alarm rate and the power of `ledflicker compare`'s regression
# gate (docs/campaigns.md, "Measured"), on a small noisy simulator plan
# (shot and read noise, 8 judged cases) run with RUNS seeds (default 21).
#
#   scripts/campaign-gate.sh BIN WORKDIR [RUNS]
#
# False alarms: run 1 against each of runs 2..RUNS (nothing changed: only
# the noise differs). Power: the same pairs with run s's gated KPI
# (fdi_2018_worst_phase) lowered by 2 x its run-to-run standard deviation
# over the RUNS seeds, in one case and in all 8 cases at once. The
# database holds every run, so `compare` takes each KPI's sigma from its
# spread over the other runs (docs/campaigns.md).
set -eu
if [ $# -lt 2 ] || [ $# -gt 3 ]; then sed -n '2,14p' "$0"; exit 2; fi
bin=$(realpath "$1"); work=$2; runs=${3:-21}
pairs=$((runs - 1))
rm -rf "$work"; mkdir -p "$work"; cd "$work"
export LEDFLICKER_DB="$PWD/gate.sqlite"
cat >noisy.toml <<'PLAN'
format-version = 2

[plan]
id = "small"
title = "Small test plan"
seed = 7

[sequence]
on-s = 0.5
off-s = 0.5
pwm-s = 4.0

[light]
levels-lux = [2000.0]

[grid]
frequencies-hz = [100.0, 150.0, 200.0, 300.0]
duty-cycles = [0.2, 0.5]

[dut]
backend = "simulator"
supplier = "Test"
model = "EX-1"
serial = "S-7"
firmware = "1.0"

[dut.camera]
shutter = "rolling"
sensor-rows = 12
sensor-columns = 16
line-time-us = 14.565
exposure-ms = 11.111
frame-rate-fps = 30.0

[thresholds]
fdi-2018-min = 0.1
mitigation-min-hz = 90.0

[[roi]]
name = "led"
x-px = 2
y-px = 4
width-px = 8
height-px = 2

[dut.camera.sensor]
sensitivity-e-per-cd-m2-s = 40.0
full-well-e = 4000.0
read-noise-e = 3.0
shot-noise = true
adc-bits = 12
PLAN
for s in $(seq 1 "$runs"); do
  sed "s/^seed = 7/seed = $s/" noisy.toml >"s$s.toml"
  "$bin" plan "s$s.toml" --out "r$s" -q --date 2026-01-01 >/dev/null || [ $? -eq 1 ]
done
alarms=0
for s in $(seq 2 "$runs"); do
  code=0; "$bin" compare r1 "r$s" >"c$s.txt" || code=$?
  [ "$code" -eq 1 ] && alarms=$((alarms + 1))
done
echo "false alarms: $alarms of $pairs comparisons without a change"
python3 - "$bin" "$runs" <<'PY'
import shutil, sqlite3, statistics, subprocess, sys
bin = sys.argv[1]
runs = int(sys.argv[2])
metric = "fdi_2018_worst_phase"
base = sqlite3.connect("gate.sqlite")
values = {}
for case, v in base.execute(
        "SELECT c.id, m.value FROM metrics m JOIN cases c USING (run_id, idx) WHERE m.metric = ?",
        (metric,)):
    values.setdefault(case, []).append(v)
base.close()
sd = {case: statistics.stdev(v) for case, v in values.items()}
for label, cases in [("one case (2000lux-150hz-50pct)", ["2000lux-150hz-50pct"]),
                     ("all 8 cases", sorted(sd))]:
    shutil.copy("gate.sqlite", "power.sqlite")
    db = sqlite3.connect("power.sqlite")
    for s in range(2, runs + 1):
        for case in cases:
            db.execute(
                "UPDATE metrics SET value = value - ? WHERE run_id = ? AND metric = ? AND "
                "idx = (SELECT idx FROM cases WHERE run_id = ? AND id = ?)",
                (2 * sd[case], s, metric, s, case))
    db.commit(); db.close()
    hits = sum(subprocess.run([bin, "compare", "1", str(s), "--db", "power.sqlite"],
                              capture_output=True).returncode == 1 for s in range(2, runs + 1))
    print(f"2-sigma worsening in {label}: detected in {hits} of {runs - 1} comparisons")
PY
