"""The fast loop, ``python -m pytest -m "not slow"`` (docs/testing.md), keeps a test of every test module.

The test modules are collected again, in this process and without running anything, by pytest
itself with the fast loop's marker expression: what it selects is what the fast loop runs.
"""

from __future__ import annotations

import pytest
from conftest import ROOT

TESTS = ROOT / "tests"


class _Selection:
    """A pytest plugin that keeps the node ids of the tests a session selects."""

    def __init__(self) -> None:
        self.nodeids: list[str] = []

    def pytest_collection_finish(self, session: pytest.Session) -> None:
        self.nodeids = [item.nodeid for item in session.items]


def selected(expression: str) -> list[str]:
    """Node ids (``tests/test_x.py::test_y[...]``) of the tests ``pytest -m EXPRESSION`` runs."""
    selection = _Selection()
    code = pytest.main(["--collect-only", "-qq", "-p", "no:cacheprovider", "-m", expression, str(TESTS)],
                       plugins=[selection])
    assert code in (pytest.ExitCode.OK, pytest.ExitCode.NO_TESTS_COLLECTED), f"collection failed: {code!r}"
    return selection.nodeids


def test_every_test_module_keeps_a_test_in_the_fast_loop():
    fast = {nodeid.split("::", 1)[0] for nodeid in selected("not slow")}
    modules = {f"tests/{path.name}" for path in TESTS.glob("test_*.py")}
    assert "tests/test_markers.py" in fast
    assert sorted(modules - fast) == [], "leave a cheap test of each unmarked (docs/testing.md)"


def test_browser_tests_are_slow_too():
    assert selected("browser and not slow") == []
    assert len(selected("browser")) >= 4  # the Chromium renders of the report and of the meshcat scene
