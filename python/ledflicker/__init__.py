"""ledflicker: LED flicker conformance tests for automotive cameras, in Python.

The same engine as the ``ledflicker`` command line, called as a library:

- :func:`run` runs a test plan into a report directory and returns a
  :class:`Run` (verdict, cases, every ROI's metrics, the report's files);
- :func:`read` reads a report directory back, checked as ``import`` and
  ``verify`` check it;
- :func:`fdi_2018`, :func:`percent_flicker`, :func:`fmi`, :func:`fdi_p2020`,
  :func:`mmp` measure a luma trace (numpy) with its segments;
- :func:`light` analyses a light source's waveform as ``ledflicker light``;
- :func:`simulate` gives the ideal camera's ON fractions;
- :func:`segments` finds the ON, OFF and PWM segments of a recorded trace;
- :func:`history` and :func:`compare` read the results database.

Errors are :class:`LedflickerError` (and subclasses) with the command line's
``message``, ``hint`` and ``exit_code``. See docs/python.md.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Dict, Iterator, List, Optional, Tuple, Union

import numpy as np

from . import _ledflicker as _native
from ._ledflicker import (
    LEFT_OUT,
    OFF,
    ON,
    PWM,
    LedflickerError,
    PlanError,
    ReportError,
    UsageError,
)

__version__ = _native.VERSION

__all__ = [
    "run", "read", "Run", "Case", "Metric", "fdi_2018", "percent_flicker",
    "fmi", "fdi_p2020", "mmp", "light", "simulate", "segments", "Segments",
    "history", "compare", "Comparison", "LedflickerError", "PlanError",
    "UsageError", "ReportError", "ON", "OFF", "PWM", "LEFT_OUT",
]

PathLike = Union[str, "os.PathLike[str]"]
#: A results database: a file, a ``postgres://`` URL, or True for the one
#: ``ledflicker plan`` records in ($LEDFLICKER_DB, else
#: ``~/.local/share/ledflicker/results.sqlite``; docs/campaigns.md).
Database = Union[PathLike, bool]

#: The files of a report directory that :attr:`Run.files` names when present.
REPORT_FILES = ("results.json", "report.html", "report.pdf", "junit.xml", "summary.csv")


@dataclass(frozen=True)
class Metric:
    """A metric's value, or why it has none.

    ``value`` is a finite float or None; ``unbounded`` is True when the value
    is +infinity (a dark OFF reference); ``reason`` says why there is no
    value, or notes a caveat (e.g. saturation).
    """

    value: Optional[float]
    unbounded: bool = False
    reason: Optional[str] = None

    def __float__(self) -> float:
        if self.value is not None:
            return self.value
        return float("inf") if self.unbounded else float("nan")


def _metric(t: Tuple[Optional[float], bool, Optional[str]]) -> Metric:
    return Metric(*t)


@dataclass(frozen=True)
class Case:
    """One case of a run: its id, conditions, verdict and its ROIs'
    metrics, as results.json holds them (``data`` is the whole object)."""

    data: Dict[str, Any]

    @property
    def id(self) -> str:
        """The case's id, e.g. "2000lux-90hz-10pct"."""
        return self.data["id"]

    @property
    def verdict(self) -> str:
        """"pass", "fail" or "info" (not judged)."""
        return self.data["verdict"]

    @property
    def rois(self) -> List[Dict[str, Any]]:
        """Each ROI's name, kind, levels and metrics, as results.json holds them."""
        return self.data.get("rois", [])

    def __getitem__(self, key: str) -> Any:
        return self.data[key]


# The metrics of a ROI in results.json that a frame row carries: a number
# (or None), one column each.
def _flatten(prefix: str, value: Any, row: Dict[str, Any]) -> None:
    if isinstance(value, dict):
        if set(value) >= {"value", "unbounded"}:
            row[prefix] = value["value"]
            return
        for k, v in value.items():
            _flatten(f"{prefix}.{k}" if prefix else k, v, row)
    elif isinstance(value, (int, float, str, bool)) or value is None:
        row[prefix] = value


@dataclass
class Run:
    """A finished run: its report directory, verdict and cases.

    ``results`` is results.json as a dict (figures bit for bit those of the
    file); ``status`` is "pass", "fail" or "not-judged" and ``exit_code``
    what ``ledflicker plan`` would have returned.
    """

    results: Dict[str, Any]
    dir: Path
    status: str
    exit_code: int
    warnings: str = ""
    run_id: Optional[int] = None
    signature: str = "unsigned"
    _cases: Optional[List[Case]] = field(default=None, repr=False)

    @property
    def verdict(self) -> str:
        """The plan's verdict: "pass", "fail" or "info"."""
        return self.results["verdict"]

    @property
    def cases(self) -> List[Case]:
        """The cases, in plan order."""
        if self._cases is None:
            self._cases = [Case(c) for c in self.results["cases"]]
        return self._cases

    @property
    def files(self) -> Dict[str, Path]:
        """The report's files that exist, by name (results.json, report.html,
        report.pdf, junit.xml, summary.csv)."""
        return {n: self.dir / n for n in REPORT_FILES if (self.dir / n).is_file()}

    def __iter__(self) -> Iterator[Case]:
        return iter(self.cases)

    def __len__(self) -> int:
        return len(self.cases)

    def cases_frame(self) -> List[Dict[str, Any]]:
        """One row per case and ROI: the case's id, verdict and conditions
        (every number or text of the case but its ROIs), then every KPI of
        the ROI (a metric's value, None when undefined), as plain dicts."""
        rows = []
        for case in self.results["cases"]:
            base: Dict[str, Any] = {}
            for k, v in case.items():
                if k != "rois":
                    _flatten(k, v, base)
            for roi in case.get("rois", []) or [{}]:
                row = dict(base)
                for k, v in roi.items():
                    # The ROI's name and kind, beside the case's id.
                    _flatten({"name": "roi", "kind": "roi_kind"}.get(k, k), v, row)
                rows.append(row)
        return rows

    def to_pandas(self):
        """:meth:`cases_frame` as a pandas DataFrame (pandas is optional:
        ``pip install pandas``)."""
        try:
            import pandas as pd
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError(
                "to_pandas needs pandas (pip install pandas); cases_frame() gives the same rows as dicts"
            ) from e
        return pd.DataFrame(self.cases_frame())


def run(
    plan: Union[str, PathLike],
    out: Optional[PathLike] = None,
    threads: Optional[int] = None,
    date: Optional[str] = None,
    db: Optional[Database] = None,
    force: bool = False,
    detail: str = "standard",
    progress: Optional[Callable[[Dict[str, Any]], None]] = None,
) -> Run:
    """Runs a test plan and writes its report directory, as ``ledflicker plan``.

    plan: a plan file, a built-in plan's name (e.g. "daylight"), or the TOML
        text of a plan (any text with a newline).
    out: the report directory [default: reports/<plan id>/].
    threads: worker threads [default: one per core]; results do not depend on it.
    date: the report date YYYY-MM-DD [default: $SOURCE_DATE_EPOCH, else today].
    db: the results database the run is recorded in: a file or a
        postgres:// URL (as ``plan --db``), True for the one ``ledflicker
        plan`` records in by default ($LEDFLICKER_DB, else
        ~/.local/share/ledflicker/results.sqlite), None (or False) for none.
        A file inside ``out``, or in a directory that does not exist, is
        refused before the run.
    force: replace a signed report in ``out``.
    detail: "summary", "standard" or "full", as ``--detail``.
    progress: called on this thread with a dict (``stage`` "run" or
        "report", ``event``, ``done``, ``total``) as the run goes; an
        exception it raises stops the run and is raised.

    The engine works without the GIL. Ctrl-C stops the run between cases,
    leaves the old report as it was and raises KeyboardInterrupt. An invalid
    plan raises :class:`PlanError` listing every error with its line.
    """
    if isinstance(plan, os.PathLike):
        plan = os.fspath(plan)
    done = _native.run_plan(
        plan,
        out=None if out is None else os.fspath(out),
        threads=threads,
        date=date,
        db=db if db is None or isinstance(db, bool) else _database(db),
        force=force,
        detail=detail,
        progress=progress,
    )
    if done["warnings"]:
        import warnings

        warnings.warn(done["warnings"].rstrip(), stacklevel=2)
    return Run(
        results=json.loads(done["results_json"]),
        dir=Path(done["dir"]),
        status=done["status"],
        exit_code=done["exit_code"],
        warnings=done["warnings"],
        run_id=done["run_id"],
    )


_STATUS = {"pass": ("pass", 0), "fail": ("fail", 1), "info": ("not-judged", 6)}


def read(report_dir: PathLike) -> Run:
    """Reads a report directory written by ``ledflicker plan`` or :func:`run`.

    Its verdicts must follow from its own values and limits (as ``import``
    checks), and a signed report must be intact (as ``verify`` checks);
    otherwise :class:`UsageError` is raised.
    """
    text, signature = _native.read_report(os.fspath(report_dir))
    results = json.loads(text)
    status, code = _STATUS.get(results.get("verdict"), ("fail", 1))
    return Run(results=results, dir=Path(report_dir), status=status, exit_code=code,
               signature=signature)


def _segments(segments: Any) -> Any:
    """Segments as given, or a sequence of "on"/"off"/"pwm" as codes."""
    if segments is None or isinstance(segments, np.ndarray):
        return segments
    names = {"on": ON, "off": OFF, "pwm": PWM, None: LEFT_OUT}
    try:
        return np.fromiter((names[s] for s in segments), dtype=np.uint8)
    except KeyError as e:
        raise ValueError(f"segments: {e.args[0]!r} is not 'on', 'off', 'pwm' or None") from None


def fdi_2018(luma: np.ndarray, segments: Any) -> Metric:
    """Deegan 2018 Flicker Detection Index, Eq. (3): ``(min x - L_OFF) / L_OFF``
    over the PWM samples, ``L_OFF`` the mean of the OFF samples.

    luma: float64 1-D array, the ROI's mean luma per frame (DN).
    segments: uint8 array of ON, OFF, PWM (or LEFT_OUT) per frame, or a
        sequence of "on"/"off"/"pwm".
    """
    return _metric(_native.flicker_2018(luma, _segments(segments))[0])


def percent_flicker(luma: np.ndarray, segments: Any = None) -> Metric:
    """Percent Flicker, Deegan 2018 Eq. (4) and IEEE 1789:
    ``100 (max - min) / (max + min)`` over the PWM samples (every sample
    when ``segments`` is None)."""
    return _metric(_native.flicker_2018(luma, _segments(segments))[1])


def _p2020(luma: np.ndarray, segments: Any, **options: Any) -> Dict[str, Any]:
    return _native.p2020_kpis(luma, _segments(segments), **options)


def fmi(luma: np.ndarray, segments: Any = None) -> Metric:
    """IEEE P2020 Flicker Modulation Index ``(max - min) / (max + min)`` of
    the PWM samples, 0..1."""
    return _metric(_p2020(luma, segments)["fmi"])


def fdi_p2020(luma: np.ndarray, segments: Any, contrast_threshold: float = 0.1) -> Metric:
    """IEEE P2020 Flicker Detection Index: the share of PWM frames with
    ``(x - x_off) / x_off > contrast_threshold``."""
    return _metric(_p2020(luma, segments, contrast_threshold=contrast_threshold)["fdi"])


def mmp(luma: np.ndarray, segments: Any = None, mmp_delta: float = 0.1,
        mmp_reference: str = "pwm-mean") -> Metric:
    """IEEE P2020 Modulation Mitigation Probability: the share of PWM frames
    strictly within ``x_ref (1 -/+ mmp_delta)``; ``x_ref`` the PWM mean
    ("pwm-mean") or the steady-ON level ("on-level")."""
    k = _p2020(luma, segments, mmp_delta=mmp_delta, mmp_reference=mmp_reference)
    return _metric(k["mmp"])


def light(t: np.ndarray, x: np.ndarray, bandwidth_hz: Optional[float] = 10000.0,
          dark: float = 0.0) -> Dict[str, Any]:
    """The figures of ``ledflicker light --json`` for the waveform ``x``
    (the light's level, 0 for dark) sampled at the times ``t`` (seconds,
    evenly spaced): IEEE 1789 risk, fundamental, Percent Flicker, Flicker
    Index, SVM, PstLM. ``bandwidth_hz`` None reads the raw samples."""
    return json.loads(_native.light_json(t, x, bandwidth_hz=bandwidth_hz, dark=dark))


def simulate(frequency_hz: float, duty: float, exposure_ms: float, fps: float,
             frames: int = 30, shutter: str = "global", line_time_us: float = 0.0,
             pwm_delay_ms: float = 0.0, rows: Tuple[int, int] = (0, 1)
             ) -> Tuple[np.ndarray, np.ndarray]:
    """The ideal camera's frames for one PWM condition, as ``ledflicker
    simulate``: ``(time_s, on_fraction)`` arrays, one entry per frame."""
    return _native.simulate(frequency_hz, duty, exposure_ms, fps, frames=frames,
                            shutter=shutter, line_time_us=line_time_us,
                            pwm_delay_ms=pwm_delay_ms, rows=rows)


@dataclass(frozen=True)
class Segments:
    """The segments found in a trace: ``codes`` (uint8, ON/OFF/PWM or
    LEFT_OUT per frame, to pass to the metrics) and ``found`` (the frames,
    times and levels of each segment, as a captured case's results.json
    ``segments`` holds them)."""

    codes: np.ndarray
    found: Dict[str, Any]


def segments(t: np.ndarray, luma: np.ndarray, on_s: float = 2.0, off_s: float = 2.0,
             pwm_s: float = 60.0, settle_s: Optional[float] = None,
             full_scale_dn: float = 255.0) -> Segments:
    """Finds the ON, OFF and PWM segments of a recorded trace (frame times
    ``t`` in seconds, the LED ROI's ``luma``) following the sequence
    ``on_s``, ``off_s``, ``pwm_s`` (``on_s`` 0: a dark baseline, then PWM),
    as a captured plan does."""
    kw = {} if settle_s is None else {"settle_s": settle_s}
    codes, found = _native.detect_segments(t, luma, on_s=on_s, off_s=off_s, pwm_s=pwm_s,
                                           full_scale_dn=full_scale_dn, **kw)
    return Segments(codes=codes, found=json.loads(found))


class _Rows(list):
    """A list of dicts with :meth:`to_pandas`."""

    def to_pandas(self):
        import pandas as pd

        return pd.DataFrame(list(self))


def _database(db: Database) -> Optional[str]:
    """A database to read: its path or URL, or None for the command line's
    default (``db=True``)."""
    if db is True:
        return None
    if not isinstance(db, (str, os.PathLike)):
        raise TypeError("db: a results database (a path or a postgres:// URL), "
                        f"or True for the command line's default; got {db!r}")
    return os.fspath(db)


def history(db: Database, camera: Optional[str] = None, serial: Optional[str] = None,
            firmware: Optional[str] = None, plan: Optional[str] = None,
            since: Optional[str] = None, until: Optional[str] = None,
            verdict: Optional[str] = None) -> List[Dict[str, Any]]:
    """The runs of the results database ``db`` the filters select, oldest
    first, as ``ledflicker history --json`` lists them: a list of dicts
    with ``to_pandas()``. ``db`` is a file, a postgres:// URL, or True for
    the command line's default database (as ``history`` without ``--db``)."""
    return _Rows(json.loads(_native.history_json(
        _database(db), camera=camera, serial=serial, firmware=firmware, plan=plan,
        since=since, until=until, verdict=verdict)))


@dataclass
class Comparison:
    """Two recorded runs compared by the noise-aware gate.

    ``a`` and ``b`` are the runs (as :func:`history` lists them);
    ``comparable`` (with ``why`` and ``hint`` when not); ``kpis`` every KPI
    with its change, sigma, gate and decision; ``regressed_cases``;
    ``text`` what ``ledflicker compare`` prints, reasons included;
    ``exit_code`` what it returns.
    """

    a: Dict[str, Any]
    b: Dict[str, Any]
    comparable: bool
    why: Optional[str]
    hint: Optional[str]
    regressed_cases: List[str]
    unmatched: List[str]
    kpis: List[Dict[str, Any]]
    text: str
    exit_code: int

    @property
    def regressed(self) -> bool:
        """Some case regressed beyond the gate."""
        return bool(self.regressed_cases)

    def kpis_frame(self):
        """The KPIs as a pandas DataFrame."""
        return _Rows(self.kpis).to_pandas()


def compare(a: Union[int, PathLike], b: Union[int, PathLike], db: Database,
            accept_changes: bool = False,
            min_change: Optional[Dict[str, float]] = None) -> Comparison:
    """Compares the recorded runs ``a`` (the baseline) and ``b``: run ids or
    recorded report directories of the database ``db`` (a file, a
    postgres:// URL, or True for the command line's default), as
    ``ledflicker compare A B``."""
    d = _native.compare_runs(_database(db), str(a) if isinstance(a, int) else os.fspath(a),
                             str(b) if isinstance(b, int) else os.fspath(b),
                             accept_changes=accept_changes, min_change=min_change)
    ra, rb = json.loads(d["runs_json"])
    return Comparison(a=ra, b=rb, comparable=d["comparable"], why=d["why"], hint=d["hint"],
                      regressed_cases=list(d["regressed_cases"]), unmatched=list(d["unmatched"]),
                      kpis=list(d["kpis"]), text=d["text"], exit_code=d["exit_code"])
