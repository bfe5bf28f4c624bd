"""The native half of ledflicker (Rust, PyO3). Use the functions of
``ledflicker`` itself; these are what they call."""

from typing import Any, Callable, Dict, Optional, Tuple, Union

import numpy as np
import numpy.typing as npt

ON: int
OFF: int
PWM: int
LEFT_OUT: int
VERSION: str

class LedflickerError(Exception):
    """An error of the engine: the command line's ``message`` (all it
    prints after ``error: ``, its hint lines included), the first hint
    alone as ``hint`` (or None) and ``exit_code``."""

    message: str
    hint: Optional[str]
    exit_code: int
    errors: list[Dict[str, Any]]

class PlanError(LedflickerError):
    """The plan cannot be found, read or validated; ``errors`` lists every
    problem: ``key``, ``line``, ``column``, ``message``, ``hint``, ``text``.
    A TOML syntax error stops the reading, so it is the one entry (its
    ``key`` None). A plan given as TOML text is named ``<plan text>``."""

class UsageError(LedflickerError):
    """An argument, file or input of the caller's is wrong: every error
    whose exit code is 2 but a plan's (a missing database directory, an
    unknown run, arrays ``light`` cannot read)."""

class ReportError(LedflickerError):
    """A report directory cannot be written or read."""

MetricTuple = Tuple[Optional[float], bool, Optional[str]]

def run_plan(
    plan: str,
    out: Optional[str] = None,
    threads: Optional[int] = None,
    date: Optional[str] = None,
    db: Union[str, bool, None] = None,
    force: bool = False,
    detail: str = "standard",
    progress: Optional[Callable[[Dict[str, Any]], None]] = None,
) -> Dict[str, Any]:
    """Runs a plan into its report directory: ``results_json`` (the text of
    results.json), ``dir``, ``status``, ``exit_code``, ``warnings``, ``run_id``.
    ``db``: the results database to record the run in (a path or a
    postgres:// URL), True for the command line's default one
    ($LEDFLICKER_DB, else ~/.local/share/ledflicker/results.sqlite), None or
    False for none."""

def read_report(dir: str) -> Tuple[str, str]:
    """results.json's text of a checked report directory, and its signature
    state ("unsigned" or "intact")."""

def flicker_2018(
    luma: npt.NDArray[np.float64], segments: Optional[npt.NDArray[np.uint8]] = None
) -> Tuple[MetricTuple, MetricTuple]:
    """(FDI 2018, Percent Flicker) of a ROI trace."""

def p2020_kpis(
    luma: npt.NDArray[np.float64],
    segments: Optional[npt.NDArray[np.uint8]] = None,
    contrast_threshold: float = 0.1,
    mmp_delta: float = 0.1,
    mmp_reference: str = "pwm-mean",
) -> Dict[str, Any]:
    """The P2020 KPIs: ``fmi``, ``fdi``, ``mmp``, ``x_off``, ``x_ref``."""

def light_json(
    t: npt.NDArray[np.float64],
    x: npt.NDArray[np.float64],
    bandwidth_hz: Optional[float] = 10000.0,
    dark: float = 0.0,
) -> str:
    """``ledflicker light --json``'s figures as JSON text."""

def rust_call_seconds(
    kind: str, t: npt.NDArray[np.float64], x: npt.NDArray[np.float64], reps: int
) -> float:
    """Median seconds of the Rust call behind ``kind`` (benchmark reference)."""

def simulate(
    frequency_hz: float,
    duty: float,
    exposure_ms: float,
    fps: float,
    frames: int = 30,
    shutter: str = "global",
    line_time_us: float = 0.0,
    pwm_delay_ms: float = 0.0,
    rows: Tuple[int, int] = (0, 1),
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """(time_s, on_fraction) of the ideal camera's frames."""

def detect_segments(
    t: npt.NDArray[np.float64],
    luma: npt.NDArray[np.float64],
    on_s: float = 2.0,
    off_s: float = 2.0,
    pwm_s: float = 60.0,
    settle_s: float = ...,
    full_scale_dn: float = 255.0,
) -> Tuple[npt.NDArray[np.uint8], str]:
    """Segment codes per frame, and what was found as JSON text."""

def history_json(
    db: Optional[str],
    camera: Optional[str] = None,
    serial: Optional[str] = None,
    firmware: Optional[str] = None,
    plan: Optional[str] = None,
    since: Optional[str] = None,
    until: Optional[str] = None,
    verdict: Optional[str] = None,
) -> str:
    """``ledflicker history --json``'s array as JSON text; ``db`` None reads
    the command line's default database."""

def compare_runs(
    db: Optional[str],
    a: str,
    b: str,
    accept_changes: bool = False,
    min_change: Optional[Dict[str, float]] = None,
) -> Dict[str, Any]:
    """The comparison of two recorded runs; ``db`` None reads the command
    line's default database."""
