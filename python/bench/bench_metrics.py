"""The cost of a package call on a 10^6-sample numpy array against the
Rust call it wraps (docs/python.md, "Speed").

    python python/bench/bench_metrics.py [--reps N]

For `percent_flicker` and `light`: the median wall time of N calls from
Python (the array checked in place, the figures handed back) and of N
calls of the Rust function on a Rust-owned copy of the same array, timed
inside the extension (`_ledflicker.rust_call_seconds`), and their ratio.
The two alternate, call by call, so that a busy machine slows both alike.
"""

import argparse
import statistics
import time

import numpy as np

import ledflicker
from ledflicker import _ledflicker as native


def medians(name, call, t, x, reps):
    """Median seconds of the Python call and of the Rust call, alternated."""
    py, rs = [], []
    for _ in range(reps):
        start = time.perf_counter()
        call()
        py.append(time.perf_counter() - start)
        rs.append(native.rust_call_seconds(name, t, x, 1))
    return statistics.median(py), statistics.median(rs)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--reps", type=int, default=21)
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
    print(f"{a.samples} samples, median of {a.reps} calls")
    print(f"{'call':<16}{'python (ms)':>12}{'rust (ms)':>12}{'ratio':>8}")
    for name, call in calls.items():
        call()  # warm
        py, rs = medians(name, call, t, x, a.reps)
        print(f"{name:<16}{py * 1e3:>12.3f}{rs * 1e3:>12.3f}{py / rs:>8.3f}")


if __name__ == "__main__":
    main()
