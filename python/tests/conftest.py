"""Shared fixtures: the repository, and the command line as the reference.

The package is tested against the ``ledflicker`` binary of the same
checkout (``target/release/ledflicker``, or $LEDFLICKER_CLI): every figure
the package gives must be the one the command line writes.
"""

import json
import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CLI = Path(os.environ.get("LEDFLICKER_CLI", ROOT / "target" / "release" / "ledflicker"))
DATE = "2026-01-02"


def cli_env(**extra):
    """The environment the reference runs in: no results database of the
    user's is touched (LEDFLICKER_DB empty, and plans run with --no-db)."""
    return dict(os.environ, LEDFLICKER_DB="", HOME=os.environ.get("HOME", "/tmp"), **extra)


@pytest.fixture(scope="session")
def cli():
    assert CLI.is_file(), f"the reference binary {CLI} is missing: cargo build --release"

    def run(*args, check=True, cwd=None):
        p = subprocess.run([str(CLI), *map(str, args)], capture_output=True, text=True,
                           cwd=cwd, env=cli_env())
        if check and p.returncode not in (0, 1, 6):
            raise AssertionError(f"ledflicker {' '.join(map(str, args))}: {p.returncode}\n{p.stderr}")
        return p

    return run


@pytest.fixture(scope="session")
def daylight(tmp_path_factory, cli):
    """The daylight plan run by the command line, once: its directory."""
    out = tmp_path_factory.mktemp("cli") / "daylight"
    cli("plan", "daylight", "--out", out, "--date", DATE, "-q", "--no-db")
    return out


def load(path):
    return json.loads(Path(path).read_text())
