"""The examples of docs/python.md and the README's Python section run as
written, against the installed package.

Each document's ```python blocks run in order in one namespace (a notebook
read top to bottom), in a folder of their own that sees the repository's
test-plans/ and tests/data/ as the repository's root does. A line
``EXPRESSION  # LITERAL`` states what the expression gives: it is checked.
"""

import ast
import os
import re

import pytest

from conftest import ROOT

BLOCK = re.compile(r"^```python\n(.*?)^```", re.S | re.M)
# `expr  # result`: an expression and, after two spaces or more, what it gives.
STATED = re.compile(r"^(?P<expr>[^#\s].*?)\s{2,}#\s*(?P<value>.+)$")


def blocks(doc):
    return BLOCK.findall((ROOT / doc).read_text())


def stated(line):
    """The expression and the literal a line states it gives, or None."""
    m = STATED.match(line)
    if not m:
        return None
    try:
        value = ast.literal_eval(m["value"])
        ast.parse(m["expr"], mode="eval")
    except (ValueError, SyntaxError):
        return None
    return m["expr"], value


def run_blocks(doc, tmp_path, monkeypatch):
    pytest.importorskip("pandas")
    pytest.importorskip("matplotlib")
    import matplotlib

    matplotlib.use("Agg")  # plots drawn, shown nowhere
    monkeypatch.chdir(tmp_path)
    for d in ("test-plans", "tests"):
        os.symlink(ROOT / d, tmp_path / d)
    code = blocks(doc)
    assert code, f"{doc} has no python block"
    namespace = {"__name__": "__docs__"}
    checked = 0
    for n, block in enumerate(code, 1):
        exec(compile(block, f"{doc}, python block {n}", "exec"), namespace)
        for line in block.splitlines():
            s = stated(line)
            if s:
                expr, value = s
                assert eval(expr, namespace) == value, f"{doc}, block {n}: {line}"
                checked += 1
    return namespace, checked


def test_the_python_guide_runs_as_written(tmp_path, monkeypatch):
    ns, checked = run_blocks("docs/python.md", tmp_path, monkeypatch)
    # The outputs it states were checked, not skipped for lack of a match.
    assert checked >= 4
    assert (tmp_path / "reports" / "daylight" / "results.json").is_file()


def test_the_readme_example_runs_as_written(tmp_path, monkeypatch):
    ns, _ = run_blocks("README.md", tmp_path, monkeypatch)
    assert ns["run"].verdict == "pass"
    assert len(ns["df"]) == sum(len(c.rois) for c in ns["run"].cases)
