"""Figures a newcomer can read (issue 35): every engine that ran is drawn and the captions say
at which timestep, the stability matrix fits a screen with its timesteps on top, the
animation's labels clear of lines and its marks keyed (page and gif), the Pareto front in a
style of its own and the exact star on the axis edge, labelled, and every log axis two
labelled ticks apart, whatever its range (log_ticks). Synthetic rows, the exact
hop-top under each engine's name: no engine runs (about 15 s, mostly the figures' drawing).
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import matplotlib.figure
import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.engines.settings import DEFAULT_TIMESTEP
from hoopbench.models.catalogue import get_scene
from hoopbench.reference.exact import solve_exact
from hoopbench.reports.report.drawn import drawn_rows, drawn_trajectories, timestep_note
from hoopbench.reports.report.hoop_gif import key_handles
from hoopbench.reports.report.markdown import force_panels
from hoopbench.reports.report.page import _animation
from hoopbench.reports.report.page_animation import EVENTS, animation_figure, hoop_motions
from hoopbench.reports.report.page_figures import precision_page_figure, stability_page_figure
from hoopbench.reports.report.palette import FRONT_COLOUR, REFERENCE_COLOUR
from hoopbench.reports.report.plotting import plain_text
from hoopbench.reports.report.precision import ZERO_LABEL, precision_figure
from hoopbench.reports.report.stability import stability_figure, timestep_label

ONE_WORLD = ["mujoco", "pybullet", "pymunk", "drake", "box2d", "rapier", "dart"]
BATCHED = ["mjx", "mjwarp", "newton"]
"""Engines the default suite runs at 1e-3 s only (the batched ones): a figure that kept the
default timestep's rows alone drew 7 of the 10."""


@pytest.fixture(scope="module")
def suite(tmp_path_factory) -> pd.DataFrame:
    """hop-top's tuned default rows as the default suite stores them: the one-world engines
    at 1e-4 and 1e-3, the batched ones at 1e-3 only, each with a trajectory file (the exact
    hop-top, 1 ms apart), and a stock row that is not drawn."""
    folder = tmp_path_factory.mktemp("drawn")
    path = solve_exact(get_scene("hop-top")).sample_uniform(1e-3).write(folder / "t.parquet")
    rows = []
    for engine in [REFERENCE_ENGINE, *ONE_WORLD, *BATCHED]:
        steps = [1e-3] if engine in BATCHED else [1e-3, DEFAULT_TIMESTEP]  # coarse first
        for dt in steps:
            rows.append({"scene": "hop-top", "engine": engine, "variant": "default",
                         "profile": "tuned", "timestep": dt, "status": "ok",
                         "trajectory_file": str(path), "mu": 0.8})  # fmt: skip
    rows.append({**rows[1], "profile": "stock", "timestep": 5e-4})
    return pd.DataFrame(rows)


def test_every_engine_that_ran_is_drawn_at_the_default_timestep_where_it_ran_there(suite):
    rows = drawn_rows(suite, "hop-top")
    assert list(rows["engine"]) == [REFERENCE_ENGINE, *ONE_WORLD, *BATCHED]
    chosen = dict(zip(rows["engine"], rows["timestep"], strict=True))
    assert all(chosen[e] == DEFAULT_TIMESTEP for e in [REFERENCE_ENGINE, *ONE_WORLD])
    assert all(chosen[e] == 1e-3 for e in BATCHED)
    assert set(drawn_trajectories(suite, "hop-top")) == set(chosen)
    note = timestep_note(rows)
    assert note == "dt = 0.0001 s; mjx, mjwarp, newton at 0.001 s (none stored at 0.0001 s)"
    assert timestep_note(pd.concat([rows, rows])) == note  # two scenes' rows: each name once


def test_the_animation_and_the_force_figure_draw_every_engine_that_ran(suite):
    fragment = _animation(suite, "hop-top", "m")()
    caption, data = fragment.split('<div class="hoop-figure"')
    assert "mjx, mjwarp, newton at 0.001 s" in caption  # the caption says where
    figure = json.loads(re.search(r'<script type="application/json" id="m-data">(.*?)</script>',
                                  data, re.S)[1])  # fmt: skip
    labels = [d["text"][0] for d in figure["frames"][0]["data"] if "text" in d]
    names = [re.match(r"<b>(.*?)</b>", label)[1] for label in labels]
    assert names == ["exact", *ONE_WORLD, *(f"{e} (dt 0.001 s)" for e in BATCHED)]
    (panel,) = [p for p in force_panels(suite) if p.name == "hop-top"]
    assert set(panel.runs) == {*ONE_WORLD, *BATCHED}  # the exact curve is drawn on its own
    assert [panel.label(e) for e in ("mujoco", "mjx")] == ["mujoco", "mjx (dt 0.001 s)"]


def _motions(suite):
    scene = get_scene("hop-top")
    rows = drawn_rows(suite, "hop-top")
    return scene, hoop_motions(scene, drawn_trajectories(suite, "hop-top"), rows)


def test_the_animation_has_no_line_through_its_labels_and_a_key_of_its_marks(suite):
    scene, motions = _motions(suite)
    figure = animation_figure(scene, motions)
    layout = figure["layout"]
    top_of_drawing = max(float(m.y.max()) for m in motions) + scene.a  # every hoop's top
    for k in range(len(motions)):
        x, y = (f"{axis}axis{k + 1 if k else ''}" for axis in "xy")
        assert layout[x]["showgrid"] is False and layout[x]["zeroline"] is False
        assert layout[y]["showgrid"] is False and layout[y]["zeroline"] is False
        label_y = figure["frames"][-1]["data"][5 * k + 4]["y"][0]
        assert label_y > top_of_drawing  # the label hangs above every hoop
    key = {t["name"] for t in figure["data"] if t.get("legend") == "legend2"}
    assert {name for name, *_ in EVENTS} <= key and "exact path" in key
    assert {name for name, *_ in EVENTS} <= {h.get_label() for h in key_handles()}  # the gif's


def test_the_stability_matrix_fits_a_screen_with_its_timesteps_on_top(tmp_path, monkeypatch):
    """Ten scenes, eleven engines, four timesteps (the stored stability suite's shape):
    726x3251 px with the timesteps below 120 rows before issue 35."""
    rows = [
        {"scene": f"scene-{s}", "engine": e, "variant": "default", "profile": "tuned",
         "timestep": dt, "status": "ok", "verdict": "agrees", "a": 1.0}
        for s in range(10) for e in [REFERENCE_ENGINE, *ONE_WORLD, *BATCHED]
        for dt in (1e-2, 1e-3, 1e-4, 1e-5)
    ]  # fmt: skip
    frame = pd.DataFrame(rows)
    drawn = _saved(monkeypatch)
    with plain_text():
        path = stability_figure(frame, tmp_path / "s.png")
    from PIL import Image

    with Image.open(path) as image:
        width, height = image.size
    assert width <= 1400 and height <= 1000, image.size
    panels = [ax for ax in drawn[0].axes if ax.get_visible() and ax.get_title()]
    assert len(panels) == 10
    for ax in panels:
        assert ax.xaxis.get_ticks_position() == "top"
        labels = [t.get_text() for t in ax.get_xticklabels()]
        assert labels == ["0.01", "0.001", "1e-4", "1e-5"]
    page = stability_page_figure(frame)
    assert page is not None and page["layout"]["height"] <= 900
    axes = [v for k, v in page["layout"].items() if k.startswith("xaxis")]
    assert len(axes) == 10 and all(axis["side"] == "top" for axis in axes)


def test_short_timestep_labels():
    assert [timestep_label(dt) for dt in (1e-2, 1e-3, 1e-4, 5e-4, 2.5e-5)] == [
        "0.01", "0.001", "1e-4", "5e-4", "2.5e-5"
    ]  # fmt: skip


def _precision_rows() -> pd.DataFrame:
    rows = [{"scene": "seed-mu", "engine": REFERENCE_ENGINE, "profile": "tuned",
             "variant": "default", "timestep": 1e-4, "status": "ok", "wall_time_s": 0.05,
             "us_per_step": 1.0, "exact_t_slip": 0.98, "exact_t_lift": None,
             "err_t_slip_ms": 0.0, "err_theta_slip_deg": 0.0, "rms_position_m": 0.0}]  # fmt: skip
    for k, engine in enumerate(ONE_WORLD):
        for dt in (1e-3, 1e-4):
            rows.append({**rows[0], "engine": engine, "timestep": dt,
                         "wall_time_s": (k + 1) * 1e-6 / dt, "err_t_slip_ms": 0.3 * (k + 1),
                         "err_theta_slip_deg": 0.03 * (k + 1),
                         "rms_position_m": 2e-3 * (k + 1) * dt / 1e-4})  # fmt: skip
    return pd.DataFrame(rows)


def test_the_pareto_front_is_not_drawn_as_the_exact_reference_and_the_star_sits_on_the_edge(
    tmp_path, monkeypatch
):
    drawn = _saved(monkeypatch)
    rows = _precision_rows()
    with plain_text():
        precision_figure(rows, tmp_path / "p.png")
    panels = [ax for ax in drawn[0].axes if ax.get_visible()]
    assert panels
    for ax in panels:
        lines = {str(line.get_label()): line for line in ax.get_lines()}
        front = lines["Pareto front"]
        assert front.get_linestyle() == "-" and front.get_color() == FRONT_COLOUR
        (star,) = [line for line in ax.get_lines() if line.get_marker() == "*"]
        bottom = ax.get_ylim()[0]
        assert star.get_ydata()[0] == bottom  # on the edge, not at a made-up error
        engines = np.concatenate(
            [line.get_ydata() for line in ax.get_lines() if line.get_marker() in ("o", "s")]
        )
        assert bottom < engines.min()  # below every real error
        assert ZERO_LABEL in [text.get_text() for text in ax.texts]
    page = precision_page_figure(rows)
    assert page is not None
    fronts = [t for t in page["data"] if t.get("name") == "Pareto front"]
    stars = [t for t in page["data"] if t.get("marker", {}).get("symbol") == "star"]
    assert fronts and stars
    for trace in fronts:
        assert "dash" not in trace["line"] and trace["line"]["color"] != REFERENCE_COLOUR
    for trace in stars:
        axis = page["layout"][trace["yaxis"].replace("y", "yaxis", 1)]
        assert np.log10(trace["y"][0]) == pytest.approx(axis["range"][0])
        assert trace["text"] == [ZERO_LABEL]


def test_no_figure_places_a_legend_by_searching_its_data(suite, tmp_path, monkeypatch):
    """The events, force and seed-delta figures place their legends where they are told:
    matplotlib's "best" searched every sample of every curve on each draw (about 2.3 CPU-s
    of the report step, and a warning on a slow machine)."""
    from matplotlib.legend import Legend

    from hoopbench.reports.report.figures import events_figure
    from hoopbench.reports.report.force_figures import force_figure
    from hoopbench.reports.report.seed_reproduction import delta_figure

    def searched(*args, **kwargs):
        raise AssertionError('a legend placed at loc="best"')

    monkeypatch.setattr(Legend, "_find_best_position", searched)
    events_figure(drawn_trajectories(suite, "hop-top"), tmp_path / "e.png", title="hop-top")
    force_figure([p for p in force_panels(suite) if p.name == "hop-top"], tmp_path / "f.png")
    delta_figure(tmp_path / "d.png")


def _log_axes(fig: matplotlib.figure.Figure) -> list:
    """The log axes of ``fig`` that show tick labels (label_outer hides the inner panels')."""
    return [
        axis
        for ax in fig.axes
        if ax.get_visible()
        for axis in (ax.xaxis, ax.yaxis)
        if axis.get_scale() == "log" and any(_shown(t) for t in axis.get_major_ticks())
    ]


def _shown(tick) -> list:
    """The labels of ``tick`` that are drawn: left or bottom, right or top (a colour bar's)."""
    return [label for label in (tick.label1, tick.label2) if label.get_visible()]


def _labelled_in_view(axis) -> list:
    """The tick labels, major and minor, ``axis`` drew inside its view, non-empty (after
    save, as drawn)."""
    low, high = sorted(axis.get_view_interval())
    major, minor = axis.get_majorticklocs(), axis.get_minorticklocs()
    ticks = [*zip(axis.get_major_ticks(len(major)), major, strict=True),
             *zip(axis.get_minor_ticks(len(minor)), minor, strict=True)]  # fmt: skip
    return [
        label
        for tick, loc in ticks
        if low <= loc <= high
        for label in _shown(tick)
        if label.get_text().strip()
    ]


def _assert_readable(fig: matplotlib.figure.Figure) -> None:
    """Each log axis of ``fig`` shows two labelled ticks in view, their labels apart."""
    axes = _log_axes(fig)
    assert axes
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)  # save closed the figure: drawn again, as laid out
    canvas.draw()
    renderer = canvas.get_renderer()
    for axis in axes:
        labels = _labelled_in_view(axis)
        texts = [label.get_text() for label in labels]
        assert len(labels) >= 2, (axis.axes.get_title(), axis.get_view_interval(), texts)
        boxes = [label.get_window_extent(renderer) for label in labels]
        for k, box in enumerate(boxes):
            assert not any(box.overlaps(other) for other in boxes[k + 1 :]), texts


def _saved(monkeypatch) -> list[matplotlib.figure.Figure]:
    drawn: list[matplotlib.figure.Figure] = []
    original = matplotlib.figure.Figure.savefig
    monkeypatch.setattr(
        matplotlib.figure.Figure,
        "savefig",
        lambda self, *a, **k: drawn.append(self) or original(self, *a, **k),
    )
    return drawn


def test_error_against_time_labels_two_ticks_on_every_log_axis_under_a_decade(
    tmp_path, monkeypatch
):
    """The quick suite's seed-mu panels: CPU times 0.135-0.66 s, no power of ten in view, and
    no number on the time axis before (minor labels off, majors only)."""
    rows = _precision_rows()
    rows["cpu_time_s"] = np.geomspace(0.135, 0.66, len(rows))
    rows["cpu_us_per_step"] = rows["cpu_time_s"] * 1e3
    rows.loc[rows["engine"] != REFERENCE_ENGINE, "err_t_slip_ms"] = np.linspace(2.1, 6.5, 14)
    drawn = _saved(monkeypatch)
    with plain_text():
        precision_figure(rows, tmp_path / "p.png")
    _assert_readable(drawn[0])


@pytest.mark.parametrize(
    "low, high",
    [(0.135, 0.66), (0.08, 0.6), (2.5, 9.0), (6.0, 9.5), (0.55, 0.58), (1.001, 1.002),
     (3e-7, 4e-6), (1e-9, 1e3)],
)  # fmt: skip
def test_every_saved_log_axis_labels_two_ticks_apart_whatever_its_range(
    low, high, tmp_path, monkeypatch
):
    """plotting.save's rule for any figure: both axes log over [low, high], a narrow panel."""
    from hoopbench.reports.report.plotting import pyplot, save

    drawn = _saved(monkeypatch)
    fig, ax = pyplot().subplots(figsize=(3.0, 2.5), constrained_layout=True)
    ax.plot([low, high], [low, high], "o")
    ax.set_xscale("log")
    ax.set_yscale("log")
    with plain_text():
        save(fig, tmp_path / "f.png", dpi=100)
    _assert_readable(drawn[0])


_POWERS = "⁻⁰¹²³⁴⁵⁶⁷⁸⁹"
_SUPERSCRIPTS = str.maketrans(_POWERS, "-0123456789")


def _value(label: str) -> float:
    """The number a drawn tick label writes: ``0.575``, ``10⁻⁶``, ``3×10⁻⁶``."""
    if not any(c in _POWERS for c in label):
        return float(label)
    mantissa, _, power = label.partition("10")
    return float(mantissa.rstrip("×") or 1) * 10.0 ** int(power.translate(_SUPERSCRIPTS))


@pytest.mark.parametrize(
    "low, high",
    [(0.5, 4.0), (0.7, 1.5), (2.0, 40.0), (0.55, 0.58), (0.135, 0.66), (3e-7, 4e-6),
     (1e-9, 1e3), (0.2, 30.0)],
)  # fmt: skip
def test_a_log_axis_writes_its_ticks_in_one_notation_each_as_its_value(
    low, high, tmp_path, monkeypatch
):
    """An axis from 0.5 to 4 read ``10⁰`` beside ``3``, and one from 0.55 to 0.58 labelled its
    tick at 0.575 ``5.8×10⁻¹``: every label in view is now its tick's value, and plain
    numbers and powers of ten are not mixed on one axis."""
    from hoopbench.reports.report.plotting import pyplot, save

    drawn = _saved(monkeypatch)
    fig, ax = pyplot().subplots(figsize=(3.0, 2.5), constrained_layout=True)
    ax.plot([low, high], [low, high], "o")
    ax.set_xscale("log")
    with plain_text():
        save(fig, tmp_path / "f.png", dpi=100)
    axis = drawn[0].axes[0].xaxis
    view_low, view_high = sorted(axis.get_view_interval())
    locs = axis.get_majorticklocs()
    shown = [(loc, tick.label1.get_text())
             for tick, loc in zip(axis.get_major_ticks(len(locs)), locs, strict=True)
             if view_low <= loc <= view_high]  # fmt: skip
    texts = [text for _, text in shown]
    assert len(shown) >= 2, texts
    for loc, text in shown:
        assert _value(text) == pytest.approx(loc, rel=1e-9), texts
    powers = {any(c in _POWERS for c in text) for text in texts}
    assert len(powers) == 1, texts


def test_a_shipped_search_figure_labels_two_ticks_on_its_held_out_cost_axis(tmp_path, monkeypatch):
    """newton's held-out costs span 0.16-6 s per simulated s: one power of ten in view, which
    was its only label; its figure is laid out by tight_layout before save (the rule first)."""
    from hoopbench.reports.report.best_settings import _figure, best_settings

    drawn = _saved(monkeypatch)
    searches = Path(__file__).resolve().parents[1] / "reports" / "tune" / "searches"
    (best,) = best_settings([searches / "newton"])
    with plain_text():
        _figure(best, tmp_path / "b.png")
    _assert_readable(drawn[0])


def test_a_log_colour_bar_under_a_decade_labels_two_ticks(tmp_path, monkeypatch):
    """The map's hop heights take a log colour bar (map_figures): 0.02-0.05 m held no power
    of ten."""
    from matplotlib.colors import LogNorm

    from hoopbench.reports.report.plotting import pyplot, save

    drawn = _saved(monkeypatch)
    fig, ax = pyplot().subplots(figsize=(4.0, 3.0), layout="constrained")
    mesh = ax.pcolormesh(np.geomspace(0.02, 0.05, 12).reshape(3, 4), norm=LogNorm(0.02, 0.05))
    fig.colorbar(mesh, ax=ax)
    with plain_text():
        save(fig, tmp_path / "c.png", dpi=100)
    _assert_readable(drawn[0])
