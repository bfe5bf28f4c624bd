"""The metrics on numpy arrays, against the command line's figures."""

import csv
import json

import numpy as np
import pytest

import ledflicker
from conftest import load


def trace_of(report, case):
    """A case's trace CSV: the segments and each ROI's luma, as arrays."""
    with open(report / "traces" / f"{case}.csv") as f:
        rows = list(csv.DictReader(f))
    segments = [r["segment"] for r in rows]
    rois = [k for k in rows[0] if k not in ("frame", "time_s", "segment")]
    t = np.array([float(r["time_s"]) for r in rows])
    return t, segments, {k: np.array([float(r[k]) for r in rows]) for k in rois}


def test_the_metrics_of_every_case_are_the_reports_bit_for_bit(daylight):
    results = load(daylight / "results.json")
    checked = 0
    for case in results["cases"]:
        _, segments, luma = trace_of(daylight, case["id"])
        codes = ledflicker._segments(segments)
        for roi in case["rois"]:
            x, m = luma[roi["name"]], roi["metrics"]
            assert ledflicker.fdi_2018(x, codes).value == m["fdi_2018"]
            assert ledflicker.percent_flicker(x, segments).value == m["percent_flicker"]
            assert ledflicker.fmi(x, codes).value == m["fmi"]
            assert ledflicker.fdi_p2020(x, codes).value == m["fdi_p2020"]
            assert ledflicker.mmp(x, codes).value == m["mmp"]
            checked += 1
    assert checked == sum(len(c["rois"]) for c in results["cases"])


def test_metrics_read_a_strided_array_as_a_contiguous_one():
    x = np.linspace(1.0, 3.0, 101)
    assert ledflicker.percent_flicker(x[::2]).value == ledflicker.percent_flicker(x[::2].copy()).value
    assert ledflicker.percent_flicker(np.array([1.0, 3.0])).value == 50.0


def test_a_dark_off_reference_is_unbounded_not_infinite():
    x = np.array([0.0, 0.0, 5.0, 6.0])
    m = ledflicker.fdi_2018(x, ["off", "off", "pwm", "pwm"])
    assert m.value is None and m.unbounded and "unbounded" in m.reason
    assert float(m) == float("inf")


@pytest.mark.parametrize("bad, error, words", [
    (np.arange(10, dtype=np.int32), TypeError, "luma must be of dtype float64, got int32"),
    (np.ones((3, 4)), ValueError, "luma must be a 1-D array, got 2 dimensions (shape [3, 4])"),
    (np.array([1.0, np.nan, 2.0]), ValueError, "luma[1] is NaN"),
    (np.array([1.0, np.inf]), ValueError, "luma[1] is inf"),
    ([1.0, 2.0], TypeError, "luma must be a 1-D numpy array of float64, got list"),
])
def test_bad_arrays_raise_clear_exceptions(bad, error, words):
    with pytest.raises(error) as e:
        ledflicker.percent_flicker(bad)
    assert words in str(e.value)


def test_segments_of_another_length_or_code_are_refused():
    x = np.ones(4)
    with pytest.raises(ValueError, match="segments has 3 samples but luma has 4"):
        ledflicker.fmi(x, np.array([2, 2, 2], dtype=np.uint8))
    with pytest.raises(ValueError, match=r"segments\[1\] is 7"):
        ledflicker.fmi(x, np.array([2, 7, 2, 2], dtype=np.uint8))
    with pytest.raises(ValueError, match="'dim' is not 'on'"):
        ledflicker.fmi(x, ["pwm", "dim", "pwm", "pwm"])
    with pytest.raises(ValueError, match="no PWM samples"):
        ledflicker.fmi(x, ["on"] * 4)


def waveform(n=4000, rate=20000.0, f=137.0, duty=0.3):
    t = np.arange(n) / rate
    x = np.where((t * f) % 1.0 < duty, 1.0, 0.05)
    return t, x


def test_light_gives_the_fields_of_light_json(cli, tmp_path):
    t, x = waveform()
    path = tmp_path / "w.csv"
    with open(path, "w") as f:
        f.write("time,level\n")
        for a, b in zip(t, x):
            f.write(f"{float(a)!r},{float(b)!r}\n")
    ref = json.loads(cli("light", path, "--json").stdout)
    got = ledflicker.light(t, x)
    for k in ("file", "time_column", "intensity_column"):
        ref.pop(k)
    assert got == ref
    raw = json.loads(cli("light", path, "--json", "--bandwidth", "none").stdout)
    assert ledflicker.light(t, x, bandwidth_hz=None)["percent_flicker"] == raw["percent_flicker"]


def test_light_refuses_arrays_it_cannot_read():
    t, x = waveform()
    with pytest.raises(ValueError, match="t has 4000 samples but x has 3999"):
        ledflicker.light(t, x[:-1])
    t2 = t.copy()
    t2[100] = t2[99]
    with pytest.raises(ledflicker.LedflickerError) as e:
        ledflicker.light(t2, x)
    assert "sample 101" in e.value.message and e.value.exit_code == 2
    with pytest.raises(ledflicker.UsageError, match="no light"):
        ledflicker.light(t, np.zeros_like(x))
    with pytest.raises(ValueError, match="bandwidth_hz"):
        ledflicker.light(t, x, bandwidth_hz=-1.0)


def test_simulate_gives_the_command_lines_trace(cli):
    args = dict(frequency_hz=90.0, duty=0.25, exposure_ms=1.0, fps=30.0, frames=40,
                shutter="rolling", line_time_us=14.5)
    t, s = ledflicker.simulate(**args, rows=(399, 401))
    out = cli("simulate", "--frequency-hz", "90", "--duty", "0.25", "--exposure-ms", "1",
              "--fps", "30", "--frames", "40", "--shutter", "rolling", "--line-time-us",
              "14.5", "--rows", "399:401").stdout.splitlines()
    assert out[0] == "frame,time_s,on_fraction"
    ref = [tuple(map(float, line.split(",")[1:])) for line in out[1:]]
    assert list(zip(t.tolist(), s.tolist())) == ref
    with pytest.raises(ledflicker.UsageError, match="--fps must be at least"):
        ledflicker.simulate(90.0, 0.25, 1.0, 0.0)


def test_segments_finds_the_sequence_of_a_trace():
    fps = 30.0
    t = np.arange(int(10 * fps)) / fps
    luma = np.where(t < 2, 120.0, np.where(t < 4, 10.0, np.where((t * 7) % 1 < 0.5, 200.0, 40.0)))
    s = ledflicker.segments(t, luma, on_s=2.0, off_s=2.0, pwm_s=6.0)
    codes = s.codes
    assert codes.dtype == np.uint8 and len(codes) == len(t)
    assert set(codes[: int(1.5 * fps)]) <= {ledflicker.ON, ledflicker.LEFT_OUT}
    assert ledflicker.ON in codes and ledflicker.OFF in codes and ledflicker.PWM in codes
    assert codes[int(3 * fps)] == ledflicker.OFF and codes[-1] == ledflicker.PWM
    assert s.found["method"] == "detected"
    # The codes go straight into the metrics.
    assert ledflicker.fdi_2018(luma, codes).value == pytest.approx(3.0)
    with pytest.raises(ValueError, match="t has 300 frames but luma has 299"):
        ledflicker.segments(t, luma[:-1])
