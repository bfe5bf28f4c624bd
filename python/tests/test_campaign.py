"""history and compare on a results database, against the command line."""

import json

import pytest

import ledflicker
from conftest import DATE


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
