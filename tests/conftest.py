"""Test-wide rules: under CI a skipped test fails the session.

A test may skip only for want of an optional extra (an engine of OPTIONAL_ENGINES, dask), or,
marked ``gpu``, for want of a GPU; the engines and libraries hoopbench depends on are imported
plainly, so that a broken install fails. CI installs the test extra, which holds every
optional extra: there any skip but a gpu test's means a test that did not run, and the
session fails with one line naming the skipped tests.
"""

from __future__ import annotations

import os
from typing import NoReturn

import pytest

pytest_plugins = ["pytester"]  # tests/test_skips_under_ci.py runs pytest on made-up tests

OPTIONAL_ENGINES = frozenset({"drake", "rapier", "box2d", "dart", "mjx", "mjwarp", "newton"})
"""Engines of an optional extra: a test may skip when one is unavailable, never for another."""
GPU_MARK = "gpu"
"""The marker of a test that needs a GPU: the one kind of test that may skip under CI."""
CI_VARIABLE = "CI"
"""Set, to anything but the empty string, by CI services (GitHub Actions sets CI=true)."""


def engine_unavailable(engine: str, message: str | None) -> NoReturn:
    """For a test whose engine run came back unavailable: a skip for an optional extra's
    engine, a failure for a hard dependency (MuJoCo, PyBullet, pymunk): a broken install must
    not pass as skipped tests."""
    if engine in OPTIONAL_ENGINES:
        pytest.skip(f"{engine} unavailable: {message}")
    pytest.fail(f"{engine} is a hard dependency, and unavailable: {message}")


class SkipsFailUnderCI:
    """Collects every skipped test and collection; fails the session under CI if any."""

    def __init__(self) -> None:
        self.skipped: list[str] = []

    def pytest_collectreport(self, report: pytest.CollectReport) -> None:
        if report.skipped:  # a module-level skip: pytest.importorskip at import
            self.skipped.append(report.nodeid)

    def pytest_runtest_logreport(self, report: pytest.TestReport) -> None:
        # An expected failure (xfail) is reported as skipped too, with wasxfail set. A test
        # marked gpu may skip for want of a GPU: CI has none (it runs everything on the CPU).
        if report.skipped and not hasattr(report, "wasxfail") and GPU_MARK not in report.keywords:
            self.skipped.append(report.nodeid)

    def failing(self) -> bool:
        return bool(os.environ.get(CI_VARIABLE)) and bool(self.skipped)

    def pytest_sessionfinish(self, session: pytest.Session) -> None:
        # Other statuses (failures, an interrupt, a usage error) say more and stay.
        passing = (pytest.ExitCode.OK, pytest.ExitCode.NO_TESTS_COLLECTED)
        if self.failing() and session.exitstatus in passing:
            session.exitstatus = pytest.ExitCode.TESTS_FAILED

    def pytest_terminal_summary(self, terminalreporter: pytest.TerminalReporter) -> None:
        if self.failing():
            names = ", ".join(self.skipped)
            terminalreporter.write_line(
                f"{CI_VARIABLE} is set and {len(self.skipped)} test(s) skipped: {names}", red=True
            )


def pytest_configure(config: pytest.Config) -> None:
    config.pluginmanager.register(SkipsFailUnderCI(), "hoopbench-skips-fail-under-ci")
