"""Reference figures of `ledflicker light` for tests/integration/light.rs.

Independent of the Rust code: NumPy's FFT, and the CIE TN 006:2016 SVM,
Percent Flicker and the IES Flicker Index written from their published
definitions. Run from the repository root:

    python3 tests/data/light/reference.py > tests/data/light/reference.csv

Waveforms (SOURCE.md): each sampled at `rate_hz`, `i = 0 .. samples - 1`.
The figures are computed over the first `periods` whole periods (the
fundamental known here, not estimated), the SVM also from the continuous
waveform's Fourier series where one is known in closed form. The real
lamps' periods are measured as docs/light.md says (the lag of least squared
difference, placed by a parabola), and their SVM follows its rule for
records with components of another period (the spectrum's peaks).
"""

import math
import sys

import numpy as np

POOLING = 3.7
F_MAX = 2000.0


def threshold(f):
    """CIE TN 006:2016 threshold modulation of the stroboscopic effect."""
    return 1.0 / (1.0 + math.exp(-0.00518 * (f - 306.6))) + 20.0 * math.exp(-f / 10.0)


def svm_of_components(components):
    total = sum((c / threshold(f)) ** POOLING for f, c in components if 0.0 < f <= F_MAX)
    return total ** (1.0 / POOLING)


def svm_dft(x, rate):
    """The record as one period: component k at k rate / N, C = 2 |X_k| / (N mean)."""
    n = len(x)
    spectrum = np.fft.rfft(x)
    mean = x.mean()
    comps = [(k * rate / n, 2.0 * abs(spectrum[k]) / (n * mean)) for k in range(1, (n + 1) // 2)]
    return svm_of_components(comps)


def measured_period(x, t0):
    """docs/light.md: the lag of least squared difference near one period,
    then near 2, 4, 8 ... periods within 3 samples, by a parabola."""
    n = len(x)

    def best(lo, hi):
        hi = min(hi, n - 3)
        m = min(n - (hi + 1), 1 << 16)
        lags = np.arange(lo, hi + 1)
        d = np.array([np.sum((x[l:l + m] - x[:m]) ** 2) for l in lags])
        i = int(np.argmin(d))
        if i == 0 or i == len(d) - 1:
            return None
        a, b, c = d[i - 1], d[i], d[i + 1]
        curve = a - 2 * b + c
        shift = min(max(0.5 * (a - c) / curve, -0.5), 0.5) if curve > 0 else 0.0
        return lags[i] + shift

    width = math.ceil(0.03 * t0) + 2
    lag = best(round(t0) - width, round(t0) + width)
    if lag is None:
        return t0
    period, k = lag, 1
    while 2 * k * period + 2 * period <= n:
        g = round(2 * k * period)
        lag = best(g - 3, g + 3)
        if lag is None:
            break
        k *= 2
        period = lag / k
    return period


def inharmonic_share(w, periods, rate):
    """Up to the SVM's 2 kHz: bins 1 .. with k rate / n <= 2000."""
    n = len(w)
    spectrum = np.fft.fft(w - w.mean())
    top = min(math.floor(F_MAX * n / rate) + 1, (n + 1) // 2)
    k = np.arange(1, top)
    power = np.abs(spectrum[1:top]) ** 2
    return power[k % periods != 0].sum() / power.sum()


def svm_peaks(w, rate):
    """docs/light.md: Hann-windowed spectrum; each peak with the falling bins
    beside it (2 at most each side) is one component of that power."""
    n = len(w)
    win = 0.5 - 0.5 * np.cos(2 * math.pi * np.arange(n) / n)
    power = np.abs(np.fft.fft((w - w.mean()) * win)[: (n + 1) // 2]) ** 2
    comps = []
    for k in range(1, len(power)):
        right = power[k + 1] if k + 1 < len(power) else 0.0
        if not (power[k] > power[k - 1] and power[k] >= right) or power[k] == 0:
            continue
        total = power[k]
        for step in (-1, 1):
            prev = power[k]
            for d in (1, 2):
                j = k + step * d
                if j < 1 or j >= len(power) or power[j] >= prev:
                    break
                prev = power[j]
                total += prev
        amp = math.sqrt(4 * total / (np.sum(win ** 2) * n))
        comps.append((k * rate / n, amp / w.mean()))
    return svm_of_components(comps)


def svm_square_continuous(f, duty):
    comps = []
    k = 1
    while k * f <= F_MAX:
        a = math.pi * k * duty
        comps.append((k * f, 2.0 * abs(math.sin(a)) / a))
        k += 1
    return svm_of_components(comps)


def waveform(kind, f, duty, m, rate, samples, lamp):
    i = np.arange(samples)
    if kind == "square":
        per = round(rate / f)
        on = round(duty * per)
        return ((i % per) < on).astype(float)
    if kind == "sine":
        return 1.0 + m * np.sin(2.0 * math.pi * f * i / rate)
    if kind == "triangle":
        per = round(rate / f)
        u = (i % per) / per
        return 0.2 + 0.8 * (1.0 - np.abs(2.0 * u - 1.0))
    if kind == "rectified":
        return np.abs(np.sin(2.0 * math.pi * (f / 2.0) * i / rate))
    if kind == "lamp":
        values = [float(line.split(",")[1]) for line in open(f"tests/data/lamps/{lamp}").read().split("\n")[1:] if line]
        return np.array(values[:samples])
    raise ValueError(kind)


ROWS = [
    # kind, frequency_hz, duty, modulation, rate_hz, samples, periods, lamp
    ("square", 100.0, 0.05, 1.0, 100000.0, 20437, 20, ""),
    ("square", 100.0, 0.1, 1.0, 100000.0, 20437, 20, ""),
    ("square", 100.0, 0.2, 1.0, 100000.0, 20437, 20, ""),
    ("square", 100.0, 0.5, 1.0, 100000.0, 20437, 20, ""),
    ("square", 100.0, 0.8, 1.0, 100000.0, 20437, 20, ""),
    ("square", 250.0, 0.4, 1.0, 100000.0, 10000, 25, ""),
    ("sine", 100.0, 0.5, 1.0, 100000.0, 20000, 20, ""),
    ("sine", 120.0, 0.5, 0.3, 96000.0, 20000, 25, ""),
    ("sine", 400.0, 0.5, 0.6, 100000.0, 10000, 40, ""),
    ("triangle", 150.0, 0.5, 0.0, 90000.0, 18000, 30, ""),
    ("rectified", 100.0, 0.5, 1.0, 100000.0, 20000, 20, ""),
    ("lamp", 120.0, 0.5, 0.0, 100000.0, 2500, 3, "cfl.csv"),
    ("lamp", 120.0, 0.5, 0.0, 100000.0, 2500, 3, "ge-classic-led.csv"),
]


def main():
    out = sys.stdout
    out.write("kind,frequency_hz,duty,modulation,rate_hz,samples,periods,lamp,analysed_samples,percent_flicker,flicker_index,svm,svm_continuous\n")
    for kind, f, duty, m, rate, samples, periods, lamp in ROWS:
        x = waveform(kind, f, duty, m, rate, samples, lamp)
        if kind == "lamp":
            t = measured_period(x, rate / f)
            periods = math.floor((samples + 0.5) / t)
            used = min(samples, round(periods * t))
        else:
            used = min(samples, round(periods * rate / f))
        w = x[:used]
        pf = 100.0 * (w.max() - w.min()) / (w.max() + w.min())
        fi = np.clip(w - w.mean(), 0.0, None).sum() / w.sum()
        svm = svm_dft(w, rate)
        if periods >= 3 and inharmonic_share(w, periods, rate) > 0.01:
            svm = svm_peaks(w, rate)
        if kind == "square":
            cont = svm_square_continuous(f, duty)
        elif kind == "sine":
            cont = svm_of_components([(f, m)])
        else:
            cont = float("nan")
        cont_text = "" if math.isnan(cont) else f"{cont:.9g}"
        out.write(f"{kind},{f},{duty},{m},{rate},{samples},{periods},{lamp},{used},{pf:.12g},{fi:.12g},{svm:.12g},{cont_text}\n")


main()
