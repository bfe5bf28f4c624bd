#!/usr/bin/env python3
"""The numpy peer of `ledflicker bench`'s exact-core row.

A vectorised closed form of the PWM integral, written the way array
simulators of LED flicker (ISET-LFM style) write it: the integral of a unit
square wave from 0 to t is F(t) = floor(t f) D / f + min(frac(t f), D) / f,
and one exposure collects F(t_end) - F(t_start). It runs over the same grid
as the bench: 12 frequencies x 6 duty cycles x 1,920 frames x 2 rows of a
rolling shutter (14.565 us per line), 5 ms exposures at 30 fps.

Prints one line, `integrals_per_s=<median>`, and the median time; the bench
reads the first. Timings are medians of several repetitions, single
threaded (numpy's elementwise kernels do not use threads).
"""
import sys
import time

try:
    import numpy as np
except ImportError:  # the bench says "numpy not found" and goes on
    print("numpy not found", file=sys.stderr)
    sys.exit(3)

FREQS = np.array([50, 60, 75, 90, 100, 120, 150, 200, 300, 400, 600, 1000], dtype=np.float64)
DUTIES = np.array([0.05, 0.1, 0.2, 0.3, 0.5, 0.8], dtype=np.float64)
FRAMES = 1920
ROWS = np.array([399, 400], dtype=np.float64)
FPS = 30.0
LINE_S = 14.565e-6
EXPOSURE_S = 5e-3
DELAY_S = 1.234e-4


def on_fraction():
    f = FREQS[:, None, None, None]
    d = DUTIES[None, :, None, None]
    k = np.arange(FRAMES, dtype=np.float64)[None, None, :, None]
    r = ROWS[None, None, None, :]
    t0 = k / FPS + r * LINE_S - DELAY_S
    t1 = t0 + EXPOSURE_S

    def integral(t):
        u = t * f
        n = np.floor(u)
        return (n * d + np.minimum(u - n, d)) / f

    return (integral(t1) - integral(t0)) / EXPOSURE_S


def main():
    reps = int(sys.argv[1]) if len(sys.argv) > 1 else 9
    out = on_fraction()
    n = out.size
    times = []
    for _ in range(reps):
        start = time.perf_counter()
        on_fraction()
        times.append(time.perf_counter() - start)
    median = sorted(times)[len(times) // 2]
    print(f"integrals_per_s={n / median:.6e}")
    print(f"median_s={median:.6e} integrals={n} numpy={np.__version__}")


if __name__ == "__main__":
    main()
