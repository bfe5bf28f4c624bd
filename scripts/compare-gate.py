#!/usr/bin/env python3
"""The false-alarm rate and the power of `ledflicker compare` (docs/campaigns.md,
"Measured"), with the binary as a user runs it.

    scripts/compare-gate.py BIN WORKDIR [--pool N] [--trials T] [--seed S]

It runs a small noisy simulator plan (shot and read noise, 8 judged cases,
two gated metrics) with seeds 1..N into one results database (the pool),
and a variant whose exposure drifts from run to run (a per-run effect that
moves every case together). Then, on copies of the pool cut down by SQL
to the runs each trial needs:

- false alarms with repeats: the database holds R runs of one firmware
  (R = 20 and R = 120, or as many as the pool has), and two of them,
  picked at random, are compared;
- false alarms with correlated cases: the same on the drifting variant;
- false alarms with the traces only: the database holds the two runs
  compared and nothing else;
- power: R/2 runs relabelled firmware 1.0 and R/2 firmware 1.1, the gated
  KPIs of every 1.1 run worse by 2 run-to-run standard deviations (each
  case's, over the pool) in every case; `compare --latest --firmware 1.1`
  must say REGRESSION.

Each figure is printed with its count of trials. The trace noise against the
real run-to-run spread (the ratio behind TRACE_INFLATION) is printed too.
Only the Python standard library is used.
"""
import argparse
import os
import random
import shutil
import sqlite3
import statistics
import subprocess
import sys

PLAN = """format-version = 2

[plan]
id = "gate"
title = "Noisy plan for the regression gate"
seed = SEED

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
exposure-ms = EXPOSURE
frame-rate-fps = 30.0

[thresholds]
fdi-2018-min = 0.1
percent-flicker-max = 90.0
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
"""

GATED = ("fdi_2018_worst_phase", "percent_flicker_worst_phase")


def make_pool(bin_, work, name, runs, drift, rng):
    """Runs the plan with seeds 1..runs into WORK/NAME.sqlite; with drift,
    each run's exposure is 11.111 ms times (1 + drift * a standard normal)."""
    db = os.path.join(work, name + ".sqlite")
    env = dict(os.environ, LEDFLICKER_DB=db)
    for s in range(1, runs + 1):
        exposure = 11.111 * (1.0 + drift * rng.gauss(0.0, 1.0)) if drift else 11.111
        plan = os.path.join(work, f"{name}-{s}.toml")
        with open(plan, "w") as f:
            f.write(PLAN.replace("SEED", str(s)).replace("EXPOSURE", f"{exposure:.6f}"))
        out = os.path.join(work, f"{name}-{s}")
        code = subprocess.run([bin_, "plan", plan, "--out", out, "-q", "--date", "2026-01-01"],
                              env=env, capture_output=True).returncode
        if code not in (0, 1):
            sys.exit(f"plan {plan} exited {code}")
        shutil.rmtree(out)
    return db


def cut(pool, path, keep, relabel=None, shift=None):
    """A copy of POOL at PATH holding only the run ids KEEP (in that order of
    recording), firmware set by RELABEL {id: fw}, and metric values moved by
    SHIFT {(id, metric, case): delta}."""
    shutil.copy(pool, path)
    db = sqlite3.connect(path)
    db.execute("PRAGMA foreign_keys = ON")
    db.execute(f"DELETE FROM runs WHERE id NOT IN ({','.join(map(str, keep))})")
    for rid, fw in (relabel or {}).items():
        db.execute("UPDATE runs SET firmware = ? WHERE id = ?", (fw, rid))
    for (rid, metric, case), delta in (shift or {}).items():
        db.execute("UPDATE metrics SET value = value + ? WHERE run_id = ? AND metric = ? AND "
                   "idx = (SELECT idx FROM cases WHERE run_id = ? AND id = ?)",
                   (delta, rid, metric, rid, case))
    db.commit()
    db.close()


def compare(bin_, db, args):
    return subprocess.run([bin_, "compare", *args, "--db", db], capture_output=True,
                          text=True).returncode


def spread(pool):
    """(metric, case) -> (run-to-run SD, worse direction), over the pool, and
    the values per run."""
    db = sqlite3.connect(pool)
    values = {}
    for metric, case, v in db.execute(
            "SELECT m.metric, c.id, m.value FROM metrics m JOIN cases c USING (run_id, idx) "
            f"WHERE m.metric IN ({','.join('?' * len(GATED))}) AND m.value IS NOT NULL "
            "AND c.verdict != 'info'", GATED):
        values.setdefault((metric, case), []).append(v)
    db.close()
    return {k: statistics.stdev(v) for k, v in values.items() if len(v) >= 2}


def trace_ratio(pool, sd):
    """Per gated KPI, its run-to-run SD over the mean of the sigma propagated
    from each run's trace noise (the formulas of docs/campaigns.md, "Where
    sigma comes from")."""
    db = sqlite3.connect(pool)
    sigmas = {}
    rows = db.execute(
        "SELECT c.id, m.metric, r.level_off, r.level_on, r.level_min, r.level_max, "
        "r.noise_on_dn, r.noise_off_dn, r.off_frames FROM metrics m "
        "JOIN cases c USING (run_id, idx) JOIN rois r USING (run_id, idx, roi)")
    for case, metric, off, on, lo, hi, s_on, s_off, n_off in rows:
        if (metric, case) not in sd or None in (off, on, s_on, s_off):
            continue

        def s(level):
            t = (level - off) / (on - off)
            return max(s_off ** 2 + (s_on ** 2 - s_off ** 2) * t, 0.0) ** 0.5

        if metric.startswith("percent"):
            sig = 200.0 * ((hi * s(lo)) ** 2 + (lo * s(hi)) ** 2) ** 0.5 / (hi + lo) ** 2
        else:
            sig = ((s(lo) / off) ** 2 + (lo * s_off / (max(n_off, 1) ** 0.5 * off ** 2)) ** 2) ** 0.5
        sigmas.setdefault((metric, case), []).append(sig)
    db.close()
    return {k: sd[k] / statistics.mean(v) for k, v in sigmas.items() if statistics.mean(v) > 0}


def hdr_pool(bin_, work, runs):
    """test-plans/hdr-example.toml with seeds 1..runs (HDR, noise, 36 cases)."""
    here = os.path.dirname(os.path.realpath(__file__))
    text = open(os.path.join(here, "..", "test-plans", "hdr-example.toml")).read()
    db = os.path.join(work, "hdr.sqlite")
    env = dict(os.environ, LEDFLICKER_DB=db)
    for s in range(1, runs + 1):
        plan = os.path.join(work, f"hdr-{s}.toml")
        lines = [f"seed = {s}" if l.startswith("seed = ") else l for l in text.splitlines()]
        with open(plan, "w") as f:
            f.write("\n".join(lines) + "\n")
        out = os.path.join(work, f"hdr-{s}")
        subprocess.run([bin_, "plan", plan, "--out", out, "-q", "--date", "2026-01-01"], env=env,
                       capture_output=True)
        shutil.rmtree(out, ignore_errors=True)
    return db


def rate(hits, trials):
    return f"{hits} of {trials} ({100.0 * hits / max(trials, 1):.1f} %)"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bin")
    ap.add_argument("work")
    ap.add_argument("--pool", type=int, default=120)
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--hdr-runs", type=int, default=12,
                    help="seeds of test-plans/hdr-example.toml for the trace ratio (0: none)")
    a = ap.parse_args()
    bin_ = os.path.realpath(a.bin)
    rng = random.Random(a.seed)
    shutil.rmtree(a.work, ignore_errors=True)
    os.makedirs(a.work)
    pool = make_pool(bin_, a.work, "pool", a.pool, 0.0, rng)
    drift = make_pool(bin_, a.work, "drift", min(a.pool, 40), 0.03, rng)
    scratch = os.path.join(a.work, "trial.sqlite")
    sd = spread(pool)
    print(f"pool: {a.pool} runs; drifting pool: {min(a.pool, 40)} runs; "
          f"gated KPIs: {len(sd)}")
    pools = [("pool", pool), ("drifting pool", drift)]
    if a.hdr_runs >= 2:
        pools.append(("hdr-example", hdr_pool(bin_, a.work, a.hdr_runs)))
    for name, db in pools:
        ratios = trace_ratio(db, spread(db))
        for metric in GATED:
            r = sorted(v for (m, _), v in ratios.items() if m == metric)
            if r:
                print(f"run-to-run SD / trace sigma, {metric}, {name}: median {statistics.median(r):.2f}, "
                      f"largest {r[-1]:.2f} over {len(r)} cases")

    def false_alarms(source, size, trials, label):
        ids = list(range(1, size_of(source) + 1))
        hits = 0
        for _ in range(trials):
            keep = rng.sample(ids, min(size, len(ids)))
            cut(source, scratch, sorted(keep))
            x, y = rng.sample(keep, 2)
            hits += compare(bin_, scratch, [str(x), str(y)]) == 1
        print(f"false alarms, {label}: {rate(hits, trials)}")
        return hits

    for size in sorted({min(20, a.pool), a.pool}):
        false_alarms(pool, size, a.trials, f"{size} repeats of one firmware")
    false_alarms(drift, min(a.pool, 40), a.trials,
                 f"{min(a.pool, 40)} repeats, cases correlated by a per-run exposure drift")
    false_alarms(pool, 2, a.trials, "two runs in the database (trace noise only)")

    def power(size, trials, label):
        ids = list(range(1, a.pool + 1))
        hits = 0
        for _ in range(trials):
            keep = rng.sample(ids, size)
            half = len(keep) // 2
            old, new = sorted(keep[:half]), sorted(keep[half:])
            relabel = {r: "1.1" for r in new}
            shift = {}
            for (metric, case), s in sd.items():
                worse = -1.0 if metric.startswith("fdi") else 1.0
                for r in new:
                    shift[(r, metric, case)] = worse * 2.0 * s
            cut(pool, scratch, sorted(keep), relabel, shift)
            # The newest 1.1 run must be recorded after the 1.0 runs.
            hits += compare(bin_, scratch, ["--latest", "--firmware", "1.1",
                                            str(max(old))]) == 1
        print(f"detected, 2 sd worse in every case, {label}: {rate(hits, trials)}")

    for size in sorted({min(20, a.pool), a.pool}):
        power(size, a.trials, f"{size // 2} runs of each firmware")
    power(2, a.trials, "one run of each firmware (trace noise only)")


def size_of(db):
    c = sqlite3.connect(db)
    n = c.execute("SELECT count(*) FROM runs").fetchone()[0]
    c.close()
    return n


if __name__ == "__main__":
    main()
