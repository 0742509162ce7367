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
from test_report_drawing import RecordingPool
from test_stability import rows

from hoopbench.models import kinematics
from hoopbench.models.catalogue import get_scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.report import drawn, figures, markdown
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


def test_report_md_s_drawings_start_dearest_first_and_the_page_s_after_them(tmp_path):
    pool = RecordingPool(1)  # one process: each call drawn as it is submitted
    then = [(_figure, (tmp_path,)), (write_gif, (tmp_path,))]  # as the page's figures
    write_markdown(rows(), tmp_path, generated="now", pool=pool, then=then)
    assert pool.made == [
        "_force_section",
        "_seed_section",
        "_stability_matrix_section",
        "write_gif",
        "_figure",
    ]


def test_equal_costs_keep_their_order():
    jobs = [(_figure, ()), (write_gif, ()), (_figure, ()), (print, ())]
    assert dearest_first(jobs) == [1, 3, 0, 2]  # print: unmeasured, 1 s


def test_a_paths_panel_draws_every_sample_s_spoke_and_marks_in_a_few_lines(tmp_path, monkeypatch):
    """paths_figure drew three lines a sample (75 a panel, 750 on make report's figures);
    now a few a panel, with the same spokes, weights and centres."""
    drawn_figures = []
    real = figures.save
    monkeypatch.setattr(
        figures, "save", lambda fig, out, **k: drawn_figures.append(fig) or real(fig, out, **k)
    )
    scene = get_scene("hop-top")
    n = 101
    t = np.linspace(0.0, 1.0, n)
    theta = np.linspace(0.0, 3.0, n)  # plumb at the start, slanted after
    zero = np.zeros(n)
    traj = Trajectory.from_state(
        scene, t=t, X=t, Y=zero + 1.0, theta=theta, Xdot=zero, Ydot=zero, thetadot=zero,
        normal_force=zero, friction_force=zero,
    )  # fmt: skip
    figures.paths_figure(scene, {"mujoco": traj}, tmp_path / "paths.png", n_frames=24)
    (fig,) = drawn_figures
    lines = fig.axes[0].get_lines()
    assert len(lines) <= 6
    i = np.linspace(0, n - 1, 25).astype(int)
    x, y = kinematics.centre_position(scene, traj.X, traj.Y, traj.theta)
    wx, wy = x[i] + scene.a * np.sin(theta[i]), y[i] + scene.a * np.cos(theta[i])
    spokes = set()
    for line in lines:
        if line.get_color() != "0.6":
            continue
        points = np.asarray(line.get_xydata(), float)
        for part in np.split(points, np.flatnonzero(np.isnan(points[:, 0]))):
            part = part[~np.isnan(part[:, 0])]
            if len(part):
                spokes.add(tuple(np.round([*part[0], *part[-1]], 9)))
    expected = {tuple(np.round([x[k], y[k], a, b], 9)) for k, a, b in zip(i, wx, wy, strict=True)}
    assert spokes == expected
    marks = {line.get_markerfacecolor(): line for line in lines if line.get_marker() == "o"}
    np.testing.assert_allclose(marks["none"].get_xydata(), np.column_stack([wx, wy]))
    centres = [m for face, m in marks.items() if face != "none"]
    np.testing.assert_allclose(centres[0].get_xydata(), np.column_stack([x[i], y[i]]))


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
