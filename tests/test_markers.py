"""The fast loop, ``python -m pytest -m "not slow"`` (docs/testing.md), keeps a test of every test module.

The test modules are collected again, in this process and without running anything, by pytest
itself with the fast loop's marker expression: what it selects is what the fast loop runs.
"""

from __future__ import annotations

import pytest
from conftest import ROOT

TESTS = ROOT / "tests"


class _Selection:
    """A pytest plugin that keeps the tests a session selects and those its ``-m`` leaves out."""

    def __init__(self) -> None:
        self.selected: list[pytest.Item] = []
        self.deselected: list[pytest.Item] = []

    def pytest_deselected(self, items: list[pytest.Item]) -> None:
        self.deselected += items

    def pytest_collection_finish(self, session: pytest.Session) -> None:
        self.selected = list(session.items)


@pytest.fixture(scope="module")
def fast_loop() -> _Selection:
    """The tests ``python -m pytest -m "not slow"`` runs and leaves out, collected only."""
    selection = _Selection()
    code = pytest.main(["--collect-only", "-qq", "-p", "no:cacheprovider", "-n0", "-m", "not slow",
                        str(TESTS)], plugins=[selection])
    assert code == pytest.ExitCode.OK, f"collection failed: {code!r}"
    return selection


def module(item: pytest.Item) -> str:
    return item.nodeid.split("::", 1)[0]


def test_every_test_module_keeps_a_test_in_the_fast_loop(fast_loop):
    fast = {module(item) for item in fast_loop.selected}
    modules = {f"tests/{path.name}" for path in TESTS.glob("test_*.py")}
    assert "tests/test_markers.py" in fast and fast <= modules
    assert sorted(modules - fast) == [], "leave a cheap test of each unmarked (docs/testing.md)"


def test_browser_tests_are_slow_too(fast_loop):
    assert [item.nodeid for item in fast_loop.selected if item.get_closest_marker("browser")] == []
    browser = [item for item in fast_loop.deselected if item.get_closest_marker("browser")]
    assert len(browser) >= 4  # the Chromium renders of the report and of the meshcat scene
