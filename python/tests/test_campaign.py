"""history and compare on a results database, against the command line."""

import json
import os
import shutil
import subprocess

import pytest

import ledflicker
from conftest import CLI, DATE


@pytest.fixture(scope="module")
def db(tmp_path_factory):
    """Two runs of the daylight plan recorded by the package."""
    d = tmp_path_factory.mktemp("db")
    db = d / "results.sqlite"
    for k in (1, 2):
        r = ledflicker.run("daylight", out=d / f"run{k}", date=DATE, db=db)
        assert r.run_id == k
    return db


def test_history_lists_the_runs_as_the_command_line(db, cli):
    runs = ledflicker.history(db)
    ref = json.loads(cli("history", "--db", db, "--json").stdout)
    assert runs == ref
    assert [r["id"] for r in runs] == [1, 2]
    assert ledflicker.history(db, plan="no-such-plan") == []
    frame = runs.to_pandas() if hasattr(runs, "to_pandas") else None
    if frame is not None:
        assert frame["id"].tolist() == [1, 2]


def test_compare_gives_the_gates_decisions_and_the_command_lines_text(db, cli):
    c = ledflicker.compare(1, 2, db=db)
    ref = cli("compare", "1", "2", "--db", db)
    assert c.text == ref.stdout
    assert c.exit_code == ref.returncode == 0
    assert c.comparable and not c.regressed
    assert c.a["id"] == 1 and c.b["id"] == 2
    gated = [k for k in c.kpis if k["gated"]]
    assert gated and all(k["delta"] in (0.0, None) for k in gated)
    # A report directory names its run too.
    assert ledflicker.compare(c.a["report_dir"], 2, db=db).text == c.text


def test_database_errors_are_the_command_lines(tmp_path, cli):
    missing = tmp_path / "none.sqlite"
    with pytest.raises(ledflicker.LedflickerError) as e:
        ledflicker.history(missing)
    ref = cli("history", "--db", missing, check=False)
    assert e.value.message == ref.stderr.strip().removeprefix("error: ")
    assert e.value.exit_code == ref.returncode
    with pytest.raises(ledflicker.UsageError, match="since `yesterday`"):
        ledflicker.history(missing, since="yesterday")


@pytest.fixture
def data_home(tmp_path, monkeypatch):
    """A data directory of this test's own for the command line's default
    database ($XDG_DATA_HOME/ledflicker/results.sqlite), with no
    $LEDFLICKER_DB to take its place."""
    home = tmp_path / "data"
    home.mkdir()
    monkeypatch.setenv("XDG_DATA_HOME", str(home))
    monkeypatch.delenv("LEDFLICKER_DB", raising=False)
    return home


def cli_default_db(*args, data_home):
    """The command line with the same default database as the package."""
    env = dict(os.environ, XDG_DATA_HOME=str(data_home))
    env.pop("LEDFLICKER_DB", None)
    return subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True,
                          env=env, timeout=300)


@pytest.mark.parametrize("db", [None, False])
def test_a_run_without_db_is_recorded_nowhere(db, data_home, tmp_path):
    r = ledflicker.run("daylight", out=tmp_path / "r", date=DATE, db=db)
    assert r.run_id is None
    assert list(data_home.iterdir()) == []
    assert sorted(p.name for p in tmp_path.iterdir()) == ["data", "r"]


def test_db_true_records_where_the_command_line_does(data_home, tmp_path):
    r = ledflicker.run("daylight", out=tmp_path / "r", date=DATE, db=True)
    assert (data_home / "ledflicker" / "results.sqlite").is_file()
    assert r.run_id == 1
    # The command line's plan, recording by default, adds the next run to
    # the same history; its history lists both, and so does the package's.
    plan = cli_default_db("plan", "daylight", "--out", tmp_path / "c", "--date", DATE, "-q",
                          data_home=data_home)
    assert plan.returncode == 0, plan.stderr
    ref = json.loads(cli_default_db("history", "--json", data_home=data_home).stdout)
    assert [run["report_dir"] for run in ref] == [str(r.dir), str(tmp_path / "c")]
    assert ledflicker.history(db=True) == ref
    assert ledflicker.compare(1, 2, db=True).exit_code == 0


def test_a_database_inside_the_report_is_refused_before_the_run(daylight, cli, tmp_path):
    out = tmp_path / "old"
    shutil.copytree(daylight, out)
    before = (out / "results.json").read_bytes()
    with pytest.raises(ledflicker.UsageError) as e:
        ledflicker.run("daylight", out=out, date=DATE, db=out / "results.sqlite")
    ref = cli("plan", "daylight", "--out", out, "--db", out / "results.sqlite", check=False)
    assert e.value.message == ref.stderr.strip().removeprefix("error: ")
    assert e.value.exit_code == ref.returncode == 2
    assert (out / "results.json").read_bytes() == before


def test_a_database_in_a_missing_directory_is_refused_before_the_run(cli, tmp_path):
    missing = tmp_path / "no" / "results.sqlite"
    with pytest.raises(ledflicker.UsageError) as e:
        ledflicker.run("daylight", out=tmp_path / "r", db=missing)
    ref = cli("plan", "daylight", "--out", tmp_path / "c", "--db", missing, check=False)
    assert e.value.message == ref.stderr.strip().removeprefix("error: ")
    assert "does not exist" in e.value.message
    assert e.value.exit_code == ref.returncode == 2
    assert not (tmp_path / "r").exists() and not (tmp_path / "c").exists()


def test_a_database_that_is_neither_path_nor_flag_is_a_type_error(tmp_path):
    with pytest.raises(TypeError, match="db"):
        ledflicker.run("daylight", out=tmp_path / "r", db=3)
    for db in (None, False):
        with pytest.raises(TypeError, match="db"):
            ledflicker.history(db)
