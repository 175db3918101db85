"""The test suite's time budget: the ``long`` tests left out of ``pytest``, and the 2 s guard.

A pytest plugin (imported by ``conftest.py``):

- ``pytest`` (the README's command) leaves out the tests marked ``long`` (each over the budget);
  ``pytest --all`` runs them too, as CI does (``.ci/run``), and so does a ``-m`` that names them
  (``pytest -m long``). Every ``long`` test is ``slow`` too: the fast loop leaves it out.
- Every test that is not ``long`` must stay within :data:`BUDGET_S` seconds of CPU time (its own
  process's and that of the programs it runs and waits for: Klipper, ``python -m deltacal``): one
  over it fails, naming its file, with the seconds it took. CPU time, not the clock's: a loaded
  machine (other workers, other jobs) slows a test's clock, not its CPU time. The time spent in
  fixtures shared by several tests (module or session scope) is not a test's own; ``--durations``
  shows it.
"""

from __future__ import annotations

import os

import pytest

#: A test's own CPU time at most, outside the ``long`` ones [s].
BUDGET_S = 2.0
_START = pytest.StashKey[tuple[float, float]]()
_LEFT = pytest.StashKey[int]()
#: CPU time spent so far setting up fixtures shared by several tests [s].
_shared = [0.0]


def cpu_seconds() -> float:
    """This process's CPU time and its waited-for children's [s]."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("deltacal")
    group.addoption("--all", action="store_true", dest="run_long",
                    help="run the tests marked long too (CI runs everything: pytest --all)")
    group.addoption("--cpu-budget", type=float, default=BUDGET_S, metavar="SECONDS",
                    help=f"fail a test not long over this CPU time (default {BUDGET_S:g}; 0: no check)")


def _runs_long(config: pytest.Config) -> bool:
    return bool(config.getoption("run_long")) or "long" in (config.getoption("markexpr") or "")


def pytest_configure(config: pytest.Config) -> None:
    """Register the budget's hooks for the whole session: a conftest's hooks reach only the nodes under its
    folder, and a session-scoped fixture is set up for the session (above ``tests/``)."""
    if not config.pluginmanager.has_plugin("deltacal-budget"):
        config.pluginmanager.register(Budget(), "deltacal-budget")


def _named(item: pytest.Item, named: list[list[str]]) -> bool:
    """Whether the command line names this test itself (``tests/test_x.py::test_y``): it runs, long or not."""
    path, _, test = item.nodeid.partition("::")
    return any(path.endswith(file.lstrip("./")) and (test == name or test.startswith(name + "["))
               for file, name in named)


class Budget:
    """The budget's hooks (registered by :func:`pytest_configure`)."""

    @pytest.hookimpl(tryfirst=True)
    def pytest_collection_modifyitems(self, config: pytest.Config, items: list[pytest.Item]) -> None:
        for item in items:
            if item.get_closest_marker("long") and not item.get_closest_marker("slow"):
                item.add_marker(pytest.mark.slow)
        if _runs_long(config):
            return
        named = [arg.replace("\\", "/").split("::", 1) for arg in config.args if "::" in arg]
        left = [item for item in items if item.get_closest_marker("long") and not _named(item, named)]
        if left:
            out = set(map(id, left))
            items[:] = [item for item in items if id(item) not in out]
            config.hook.pytest_deselected(items=left)
            config.stash[_LEFT] = len(left)

    def pytest_report_header(self, config: pytest.Config) -> str:
        if _runs_long(config):
            return "long tests: run (--all)"
        return "long tests: left out (CI runs them: pytest --all)"

    def pytest_terminal_summary(self, terminalreporter, exitstatus: int, config: pytest.Config) -> None:
        if _runs_long(config):
            return
        left = config.stash.get(_LEFT, 0)
        if left:
            terminalreporter.write_line(f"{left} long tests left out (each over {BUDGET_S:g} s of CPU): "
                                        "pytest --all runs them, as CI does")
        elif getattr(config.option, "numprocesses", None):  # the workers collect: their count is theirs
            terminalreporter.write_line(f"the long tests were left out (each over {BUDGET_S:g} s of CPU): "
                                        "pytest --all runs them, as CI does")

    @pytest.hookimpl(hookwrapper=True)
    def pytest_fixture_setup(self, fixturedef, request):
        start = cpu_seconds()
        yield
        if fixturedef.scope != "function":
            _shared[0] += cpu_seconds() - start

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_setup(self, item: pytest.Item):
        item.stash[_START] = (cpu_seconds(), _shared[0])
        yield

    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_makereport(self, item: pytest.Item, call):
        outcome = yield
        report = outcome.get_result()
        if call.when != "call" or _START not in item.stash:
            return
        start, shared = item.stash[_START]
        own = cpu_seconds() - start - (_shared[0] - shared)
        item.user_properties.append(("cpu_s", round(own, 3)))  # kept by --junitxml (its teardown report)
        budget = item.config.getoption("cpu_budget")
        if budget and own > budget and report.passed and not item.get_closest_marker("long"):
            report.outcome = "failed"
            report.longrepr = (f"{item.nodeid}: {own:.2f} s of CPU, over the {budget:g} s budget of a test "
                               "outside the long ones: make it cheaper, or mark it @pytest.mark.long "
                               "(docs/testing.md)")
