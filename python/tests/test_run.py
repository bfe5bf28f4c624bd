"""ledflicker.run and ledflicker.read against the command line."""

import json
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import ledflicker
from conftest import DATE, ROOT, load


def test_the_report_files_are_the_command_lines(daylight, tmp_path):
    r = ledflicker.run("daylight", out=tmp_path / "py", date=DATE, threads=1)
    for name in ("report.html", "junit.xml", "summary.csv"):
        assert (r.dir / name).read_bytes() == (daylight / name).read_bytes(), name
    traces = sorted(p.name for p in (daylight / "traces").iterdir())
    assert traces == sorted(p.name for p in (r.dir / "traces").iterdir())
    for name in traces:
        assert (r.dir / "traces" / name).read_bytes() == (daylight / "traces" / name).read_bytes()


def test_a_plan_given_as_toml_text_gives_the_same_figures(daylight, tmp_path):
    text = (ROOT / "test-plans" / "daylight.toml").read_text()
    r = ledflicker.run(text, out=tmp_path / "text", date=DATE)
    ref = load(daylight / "results.json")
    assert [c["rois"] for c in r.results["cases"]] == [c["rois"] for c in ref["cases"]]
    assert r.verdict == ref["verdict"]


def test_the_frame_has_one_row_per_case_and_roi_with_every_kpi(daylight):
    run = ledflicker.read(daylight)
    rows = run.cases_frame()
    ref = load(daylight / "results.json")
    assert len(rows) == sum(len(c["rois"]) for c in ref["cases"])
    first = ref["cases"][0]
    assert rows[0]["id"] == first["id"]
    assert rows[0]["roi"] == first["rois"][0]["name"]
    for kpi, metric in first["rois"][0]["metrics"].items():
        value = metric["value"] if isinstance(metric, dict) and "value" in metric else metric
        if not isinstance(value, dict):
            assert rows[0][f"metrics.{kpi}"] == value, kpi
    pd = pytest.importorskip("pandas")
    frame = run.to_pandas()
    assert isinstance(frame, pd.DataFrame)
    assert len(frame) == len(rows)
    assert frame["metrics.percent_flicker"].tolist() == [r["metrics.percent_flicker"] for r in rows]


def test_progress_reaches_the_callback_case_by_case(tmp_path):
    events = []
    r = ledflicker.run("daylight", out=tmp_path / "p", date=DATE, progress=events.append)
    run = [e for e in events if e["stage"] == "run"]
    assert run[0]["event"] == "started" and run[0]["total"] == len(r.cases)
    finished = [e for e in run if e["event"] == "case-finished"]
    assert len(finished) == len(r.cases)
    assert [e["done"] for e in finished] == list(range(1, len(r.cases) + 1))
    report = [e["event"] for e in events if e["stage"] == "report"]
    assert report[0] == "analysing" and report[-1] == "written"


def test_an_exception_in_the_callback_stops_the_run_and_is_raised(tmp_path):
    class Stop(Exception):
        pass

    def progress(e):
        if e["event"] == "case-finished":
            raise Stop("enough")

    with pytest.raises(Stop):
        ledflicker.run("daylight", out=tmp_path / "s", date=DATE, progress=progress)
    assert not (tmp_path / "s" / "results.json").exists()
    # The engine is ready for the next run.
    assert ledflicker.run("daylight", out=tmp_path / "s", date=DATE).status == "pass"


INVALID = """\
[meta]
id = "two-errors"
title = "two errors"

[grid]
frequencies-hz = [-5.0]
duty-cycles = [0.5]
light-lux = [40.0]
no-such-key = 1
"""


def test_an_invalid_plan_raises_one_exception_listing_every_error_with_its_line(cli, tmp_path):
    with pytest.raises(ledflicker.PlanError) as e:
        ledflicker.run(INVALID, out=tmp_path / "x")
    err = e.value
    assert err.exit_code == 2
    assert len(err.errors) >= 2
    assert all(d["line"] for d in err.errors if d["key"].startswith("grid"))
    # The message is the command line's, for the same text.
    plan = tmp_path / "plan.toml"
    plan.write_text(INVALID)
    ref = cli("plan", plan, "--out", tmp_path / "y", "--no-db", check=False)
    assert ref.returncode == 2
    own = err.message.replace(str(Path(err.message.split("`")[1])), "PLAN")
    theirs = ref.stderr.strip().removeprefix("error: ").replace(str(plan), "PLAN")
    assert own == theirs
    assert str(err) == err.message


def test_a_missing_plan_says_where_it_looked_with_the_hint(cli):
    with pytest.raises(ledflicker.PlanError) as e:
        ledflicker.run("no-such-plan")
    ref = cli("plan", "no-such-plan", "--no-db", check=False)
    assert e.value.message == ref.stderr.strip().removeprefix("error: ")
    assert e.value.hint.startswith("give a path to a .toml file")


@pytest.mark.parametrize("kwargs, words", [
    ({"threads": 0}, "threads must be at least 1"),
    ({"threads": -1}, "threads must be at least 1"),
    ({"date": "2026-13-01"}, "2026-13-01"),
    ({"detail": "all"}, "detail `all`"),
])
def test_bad_arguments_raise_usage_errors(kwargs, words, tmp_path):
    with pytest.raises(ledflicker.UsageError) as e:
        ledflicker.run("daylight", out=tmp_path / "u", **kwargs)
    assert words in e.value.message
    assert e.value.exit_code == 2


def test_a_toml_syntax_error_in_plan_text_is_located_and_named_as_text(tmp_path):
    with pytest.raises(ledflicker.PlanError) as e:
        ledflicker.run("format-version = 2\n[plan\nid = 'x'\n", out=tmp_path / "s")
    # The text is named as text, not by a file the package wrote it to.
    assert "<plan text>" in e.value.message and "/tmp" not in e.value.message
    [err] = e.value.errors
    assert (err["line"], err["column"]) == (2, 6), err
    assert err["key"] is None and err["message"]


def test_read_gives_the_runs_figures(daylight):
    r = ledflicker.read(daylight)
    assert r.results == load(daylight / "results.json")
    assert r.signature == "unsigned"
    assert r.status == "pass" and r.exit_code == 0


@pytest.fixture
def copy(daylight, tmp_path):
    dst = tmp_path / "copy"
    shutil.copytree(daylight, dst)
    return dst


def test_a_truncated_results_json_is_refused(copy):
    p = copy / "results.json"
    p.write_bytes(p.read_bytes()[:1000])
    with pytest.raises(ledflicker.UsageError) as e:
        ledflicker.read(copy)
    assert "results.json" in e.value.message


def test_a_directory_without_results_is_refused_with_a_hint(tmp_path):
    with pytest.raises(ledflicker.UsageError) as e:
        ledflicker.read(tmp_path)
    assert "written by `ledflicker plan`" in e.value.hint


def test_an_edited_verdict_is_refused(copy):
    p = copy / "results.json"
    r = json.loads(p.read_text())
    failing = next(c for c in r["cases"] if c["verdict"] == "pass")
    failing["verdict"] = "fail"
    p.write_text(json.dumps(r))
    with pytest.raises(ledflicker.UsageError) as e:
        ledflicker.read(copy)
    assert "do not follow" in e.value.message


def test_a_signed_report_with_a_changed_file_is_refused(cli, daylight, tmp_path):
    key = tmp_path / "k.key"
    cli("keygen", "--out", key, "--signer", "Test Engineer, QA")
    signed = tmp_path / "signed"
    cli("plan", "daylight", "--out", signed, "--date", DATE, "-q", "--no-db",
        "--sign-key", key, "--signer", "Test Engineer, QA")
    assert ledflicker.read(signed).signature == "intact"
    html = signed / "report.html"
    html.write_bytes(html.read_bytes() + b" ")
    with pytest.raises(ledflicker.UsageError) as e:
        ledflicker.read(signed)
    assert "does not match" in e.value.message


CTRL_C = """
import sys, time, ledflicker
out, started = sys.argv[1], time.time()
def progress(e):
    if e["event"] == "case-finished" and e["done"] == 1:
        print("running", flush=True)
try:
    ledflicker.run("grid-192", out=out, date="2026-01-02", threads=1, progress=progress)
    print("finished")
except KeyboardInterrupt as e:
    print("interrupted", repr(e.__cause__), flush=True)
# The engine runs again after a stop.
r = ledflicker.run("daylight", out=out + "-again", date="2026-01-02")
print("again", r.status, flush=True)
"""


def test_ctrl_c_stops_the_run_between_cases_and_keeps_the_old_report(tmp_path, daylight):
    out = tmp_path / "grid"
    shutil.copytree(daylight, out)  # an old report the stop must leave as it was
    before = (out / "results.json").read_bytes()
    script = tmp_path / "ctrl_c.py"
    script.write_text(CTRL_C)
    p = subprocess.Popen([sys.executable, str(script), str(out)], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "running"
    started = time.monotonic()
    p.send_signal(signal.SIGINT)
    rest, err = p.communicate(timeout=120)
    lines = rest.splitlines()
    assert lines[0].startswith("interrupted"), (rest, err)
    assert "SIGINT" in lines[0]
    assert time.monotonic() - started < 30
    assert lines[-1] == "again pass"
    assert p.returncode == 0, err
    assert (out / "results.json").read_bytes() == before
    assert not any(n.name.startswith(".") and "staging" in n.name for n in out.parent.iterdir())


def test_the_gil_is_released_while_the_engine_works(tmp_path):
    import threading

    ticks = []
    done = threading.Event()

    def tick():
        while not done.is_set():
            ticks.append(time.monotonic())
            time.sleep(0.005)

    t = threading.Thread(target=tick)
    t.start()
    try:
        start = time.monotonic()
        ledflicker.run("daylight", out=tmp_path / "g", date=DATE)
        elapsed = time.monotonic() - start
    finally:
        done.set()
        t.join()
    # A thread that needs the GIL ticks all through the run (held by the
    # engine, it would not tick at all); a busy machine may slow it down.
    assert len(ticks) > 0.1 * elapsed / 0.005
