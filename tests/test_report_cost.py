"""What the report step does once and in which order (issue 34, the report step's cost):
each trajectory file read once a process, the findings made once a report, and the drawings
started dearest first so that the two drawing processes end together.

Cost: about 2 s (a stability-only report drawn in this process, small trajectory files).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from test_stability import rows

from hoopbench.models.catalogue import get_scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.report import drawn, markdown
from hoopbench.reports.report import findings as findings_module
from hoopbench.reports.report.drawn import read_trajectory
from hoopbench.reports.report.markdown import FigurePool, dearest_first, write_markdown


def _trajectory(n: int) -> Trajectory:
    t = np.linspace(0.0, 1.0, n)
    zero = np.zeros(n)
    return Trajectory.from_state(
        get_scene("hop-top"), t=t, X=t, Y=zero + 1.0, theta=zero, Xdot=zero + 1.0,
        Ydot=zero, thetadot=zero, normal_force=zero + 9.81, friction_force=zero,
    )  # fmt: skip


@pytest.fixture
def reads(monkeypatch) -> list[str]:
    """The trajectory files read from disk (not from the process's copy)."""
    drawn._read.cache_clear()
    read: list[str] = []
    original = Trajectory.read.__func__  # type: ignore[attr-defined]

    def counted(cls, path):
        read.append(str(path))
        return original(cls, path)

    monkeypatch.setattr(Trajectory, "read", classmethod(counted))
    yield read
    drawn._read.cache_clear()


def test_a_trajectory_file_is_read_once_a_process_while_it_is_unchanged(tmp_path, reads):
    path = _trajectory(5).write(tmp_path / "run.parquet")
    first = read_trajectory(path)
    assert read_trajectory(str(path)) is first
    assert reads == [str(path)]
    np.testing.assert_array_equal(first.X, np.linspace(0.0, 1.0, 5))
    with pytest.raises(ValueError, match="read-only"):  # shared by every figure: never changed
        first.X[0] = 1.0
    _trajectory(7).write(path)  # another run written over it: read again
    stat = path.stat()
    os.utime(path, ns=(stat.st_atime_ns, stat.st_mtime_ns + 1))
    assert len(read_trajectory(path)) == 7
    assert reads == [str(path)] * 2


def test_the_report_makes_its_findings_once(tmp_path, monkeypatch):
    """findings() takes seconds on make report's rows: the key findings and the "All
    findings" section share one call."""
    made: list[int] = []
    original = findings_module.findings

    def counted(runs):
        made.append(len(runs))
        return original(runs)

    monkeypatch.setattr(findings_module, "findings", counted)
    monkeypatch.setattr(markdown, "findings", counted)
    write_markdown(rows(), tmp_path, generated="now", pool=FigurePool(1))
    assert made == [len(rows())]


# Drawing calls named as the report's: their expected costs order them (DRAWING_CPU_S).
def write_gif(out: Path) -> Path:
    return Path(out).joinpath("hop-top.gif")


def _figure(out: Path) -> Path:
    return Path(out).joinpath("best-settings.png")


class _InOrder(FigurePool):
    """One process: each call drawn here as it is submitted, its name noted."""

    def __init__(self) -> None:
        super().__init__(1)
        self.made: list[str] = []

    def submit(self, function, *args):
        self.made.append(function.__name__)
        return super().submit(function, *args)


def test_the_drawings_start_dearest_first_the_report_s_own_among_them(tmp_path):
    pool = _InOrder()
    drawings = [(_figure, (tmp_path,)), (write_gif, (tmp_path,))]
    write_markdown(rows(), tmp_path, generated="now", pool=pool, drawings=drawings)
    assert pool.made == [
        "write_gif",
        "_force_section",
        "_seed_section",
        "_stability_matrix_section",
        "_figure",
    ]


def test_equal_costs_keep_their_order():
    jobs = [(_figure, ()), (write_gif, ()), (_figure, ()), (print, ())]
    assert dearest_first(jobs) == [1, 3, 0, 2]  # print: unmeasured, 1 s


def test_a_page_figure_costs_what_its_maker_costs():
    def _figure_html(figure_id, make, *args):
        return make(*args)

    def precision_page_figure():
        return None

    def best_settings_page_figure():
        return None

    jobs = [
        (_figure_html, ("a", best_settings_page_figure)),
        (_figure_html, ("b", precision_page_figure)),
    ]
    assert dearest_first(jobs) == [1, 0]
