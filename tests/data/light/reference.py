"""Reference figures of `ledflicker light` for tests/integration/light.rs.

Independent of the Rust code: NumPy's FFT, and the CIE TN 006:2016 SVM,
Percent Flicker and the IES Flicker Index written from their published
definitions. Run from the repository root:

    python3 tests/data/light/reference.py > tests/data/light/reference.csv

Waveforms (SOURCE.md): each sampled at `rate_hz`, `i = 0 .. samples - 1`.
The figures are computed over the first `periods` whole periods (the
fundamental known here, not estimated), the SVM also from the continuous
waveform's Fourier series where one is known in closed form.
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
        used = min(samples, round(periods * rate / f))
        w = x[:used]
        pf = 100.0 * (w.max() - w.min()) / (w.max() + w.min())
        fi = np.clip(w - w.mean(), 0.0, None).sum() / w.sum()
        svm = svm_dft(w, rate)
        if kind == "square":
            cont = svm_square_continuous(f, duty)
        elif kind == "sine":
            cont = svm_of_components([(f, m)])
        else:
            cont = float("nan")
        cont_text = "" if math.isnan(cont) else f"{cont:.9g}"
        out.write(f"{kind},{f},{duty},{m},{rate},{samples},{periods},{lamp},{used},{pf:.12g},{fi:.12g},{svm:.12g},{cont_text}\n")


main()
