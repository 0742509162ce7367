"""The plotting backend's one home (reports/report/plotting.py): pyplot only when a figure is
drawn, on MPLBACKEND's backend if set, else Agg. Each check runs in a fresh interpreter, where
nothing has imported matplotlib yet."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import pytest


def _python(code: str, **env: str) -> list[str]:
    environ = {k: v for k, v in os.environ.items() if k != "MPLBACKEND"} | env
    return subprocess.run(
        [sys.executable, "-c", textwrap.dedent(code)],
        capture_output=True,
        text=True,
        check=True,
        env=environ,
    ).stdout.splitlines()


def test_the_api_and_the_report_import_no_pyplot():
    """The command line imports the API, and the API the report: pyplot costs ~0.2 s."""
    out = _python(
        """
        import sys
        import hoopbench.reports.api, hoopbench.reports.report.build
        print("matplotlib.pyplot" in sys.modules)
        """
    )
    assert out == ["False"]


@pytest.mark.parametrize(("env", "backend"), [({}, "agg"), ({"MPLBACKEND": "svg"}, "svg")])
def test_the_first_figure_chooses_the_backend(env, backend):
    out = _python(
        """
        import sys
        import matplotlib
        from hoopbench.reports.report.plotting import pyplot
        print("matplotlib.pyplot" in sys.modules)
        plt = pyplot()
        print(plt is sys.modules["matplotlib.pyplot"], matplotlib.get_backend().lower())
        print(pyplot() is plt)
        """,
        **env,
    )
    assert out == ["False", f"True {backend}", "True"]
