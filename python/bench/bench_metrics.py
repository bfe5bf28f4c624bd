"""The cost of a package call on a 10^6-sample numpy array against the
Rust call it wraps (docs/python.md, "Speed").

    python python/bench/bench_metrics.py [--reps N]

For `percent_flicker` and `light`: the median wall time of N calls from
Python (the array checked in place, the figures handed back) and of N
calls of the Rust function on a Rust-owned copy of the same array, timed
inside the extension (`_ledflicker.rust_call_seconds`), and their ratio.
The two alternate, three calls of each in turn, so that a busy machine
slows both alike; `paired` is the median of the ratios of each pair of
turns.
"""

import argparse
import statistics
import time

import numpy as np

import ledflicker
from ledflicker import _ledflicker as native


# Calls in a row of each side, whose median is one sample: the Rust side
# copies the arrays before its calls, so its first call would meet cold
# memory that the Python calls, in a row, do not.
BLOCK = 3


def medians(name, call, t, x, reps):
    """Median seconds of the Python call and of the Rust call, alternated
    block by block."""
    py, rs = [], []
    for _ in range(reps):
        block = []
        for _ in range(BLOCK):
            start = time.perf_counter()
            call()
            block.append(time.perf_counter() - start)
        py.append(statistics.median(block))
        rs.append(native.rust_call_seconds(name, t, x, BLOCK))
    pairs = statistics.median(p / r for p, r in zip(py, rs))
    return statistics.median(py), statistics.median(rs), pairs


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--samples", type=int, default=1_000_000)
    a = ap.parse_args()
    rate = 100_000.0
    t = np.arange(a.samples) / rate
    rng = np.random.default_rng(7)
    x = np.where((t * 137.0) % 1.0 < 0.3, 1.0, 0.05) + rng.normal(0, 0.002, a.samples)
    calls = {
        "percent_flicker": lambda: ledflicker.percent_flicker(x),
        "light": lambda: ledflicker.light(t, x),
    }
    print(f"{a.samples} samples, median of {a.reps} turns of {BLOCK} calls each")
    print(f"{'call':<16}{'python (ms)':>12}{'rust (ms)':>12}{'ratio':>8}{'paired':>8}")
    for name, call in calls.items():
        call()  # warm
        py, rs, paired = medians(name, call, t, x, a.reps)
        print(f"{name:<16}{py * 1e3:>12.3f}{rs * 1e3:>12.3f}{py / rs:>8.3f}{paired:>8.3f}")


if __name__ == "__main__":
    main()
