"""Figures that tell the truth: log axes labelled with numbers, not raw math text, and one
colour per engine, the same in every figure, PNG (matplotlib) and page (plotly) alike
(reports/report/palette.py)."""

from __future__ import annotations

from collections import defaultdict

import matplotlib.figure
import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.models.catalogue import get_scene
from hoopbench.reference.exact import solve_exact
from hoopbench.reports.report import seed_reproduction
from hoopbench.reports.report.figures import events_figure
from hoopbench.reports.report.force_figures import ForcePanel, force_figure
from hoopbench.reports.report.page_animation import animation_figure, hoop_motions
from hoopbench.reports.report.page_figures import force_page_figure, precision_page_figure
from hoopbench.reports.report.palette import (
    ENGINE_COLOURS,
    REFERENCE_COLOUR,
    engine_colours,
)
from hoopbench.reports.report.plotting import plain_text, plain_tick_label, pyplot, save
from hoopbench.reports.report.precision import precision_figure

ENGINES = ["mujoco", "pybullet", "pymunk", "drake", "box2d", "rapier", "dart"]


@pytest.fixture
def saved(monkeypatch):
    """Every figure saved while the test runs, drawn first (so its tick labels exist)."""
    figures: list[matplotlib.figure.Figure] = []
    original = matplotlib.figure.Figure.savefig

    def savefig(self, *args, **kwargs):
        figures.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", savefig)
    return figures


def _tick_labels(fig: matplotlib.figure.Figure) -> list[str]:
    return [
        label.get_text()
        for ax in fig.axes
        for axis in (ax.xaxis, ax.yaxis)
        for label in [*axis.get_majorticklabels(), *axis.get_minorticklabels()]
    ]


def test_math_tick_labels_become_plain_numbers():
    assert plain_tick_label("$\\mathdefault{10^{2}}$") == "10²"
    assert plain_tick_label("$\\mathdefault{2\\times10^{-6}}$") == "2×10⁻⁶"
    assert plain_tick_label("$\\mathdefault{-10^{0}}$") == "-10⁰"
    assert plain_tick_label("0.5") == "0.5"
    assert plain_tick_label("x$y") == "x$y"  # a name is drawn as written


def test_log_axes_under_plain_text_have_no_dollar_in_a_tick_label(saved, tmp_path):
    """plain_text() turns math text off, and matplotlib writes log ticks as math: without
    plotting.save every label of these axes read $\\mathdefault{10^{2}}$."""
    plt = pyplot()
    with plain_text():
        fig, (log, symlog, narrow) = plt.subplots(1, 3)
        log.loglog([1e-6, 1e2], [1e-3, 1e3])
        symlog.plot([-100, 100], [0, 1])
        symlog.set_xscale("symlog")
        narrow.semilogy([0, 1], [2e-6, 7e-6])  # minor ticks labelled too
        mesh = log.pcolormesh(np.array([[1e-3, 1e2]]), norm="log")
        fig.colorbar(mesh, ax=log)  # a log colour bar
        save(fig, tmp_path / "log.png", dpi=50)
        seed_reproduction.delta_figure(tmp_path / "seed_delta.png")  # the report's own
    assert len(saved) == 2
    for fig in saved:
        labels = [label for label in _tick_labels(fig) if label]
        assert labels
        assert not [label for label in labels if "$" in label], labels
    assert any("10" in label and "⁻" in label for label in _tick_labels(saved[0]))


# --------------------------------------------------------------------------- the palette
def test_the_shipped_engines_have_distinct_colours_and_the_reference_its_own():
    shipped = {
        name
        for name in engine_names()
        if engine_class(name).__module__.startswith("hoopbench.engines.")
        and name != REFERENCE_ENGINE
    }  # a test's own engines (tests/fault_engines.py) take spare colours
    assert set(ENGINE_COLOURS) == shipped
    colours = engine_colours([REFERENCE_ENGINE, *ENGINES])
    assert len(set(colours.values())) == len(colours)
    assert colours[REFERENCE_ENGINE] == REFERENCE_COLOUR


def test_an_unknown_engine_never_takes_a_colour_of_the_same_figure():
    names = [*ENGINES, *(f"plugin-{k}" for k in range(12))]
    colours = engine_colours(names)
    assert len(set(colours.values())) == len(names)
    # the same name, the same colour, whichever figure it is in
    assert engine_colours(["plugin-3", "mujoco"])["mujoco"] == colours["mujoco"]


def _trajectories() -> dict:
    """The exact hop-top sampled at 1 ms under every engine's name (their colours are
    what the figures are tested for, not their data)."""
    traj = solve_exact(get_scene("hop-top")).sample_uniform(1e-3)
    return {name: traj for name in [REFERENCE_ENGINE, *ENGINES]}


def _precision_rows() -> pd.DataFrame:
    rows = []
    for k, engine in enumerate([REFERENCE_ENGINE, *ENGINES]):
        for profile in ("stock", "tuned"):
            for dt in (1e-3, 1e-4):
                rows.append(
                    {"scene": "seed-mu", "engine": engine, "profile": profile,
                     "variant": "default", "timestep": dt, "status": "ok",
                     "wall_time_s": (k + 1) * 1e-2 / dt * 1e-4, "us_per_step": 10.0,
                     "exact_t_slip": 0.98, "exact_t_lift": None, "err_t_slip_ms": 0.1 * (k + 1),
                     "err_theta_slip_deg": 0.01 * (k + 1), "rms_position_m": 1e-3 * (k + 1)}
                )  # fmt: skip
    return pd.DataFrame(rows)


def _png_colours(figures) -> dict[str, set[str]]:
    """Per figure, engine -> the colours of the lines whose label names it."""
    from matplotlib.colors import to_hex

    per_figure = []
    for fig in figures:
        found: dict[str, set[str]] = defaultdict(set)
        for ax in fig.axes:
            for line in ax.get_lines():
                label = str(line.get_label()).split(":")[0].split(" ")[0]
                if label in ENGINES or label in (REFERENCE_ENGINE, "exact"):
                    found[label].add(to_hex(line.get_color()))
        per_figure.append(found)
    return per_figure


def _page_colours(figure: dict) -> dict[str, set[str]]:
    found: dict[str, set[str]] = defaultdict(set)
    for trace in figure["data"]:
        name = str(trace.get("legendgroup") or trace.get("name") or "").split(" ")[0]
        colour = (trace.get("line") or {}).get("color") or (trace.get("marker") or {}).get("color")
        if name in ENGINES and isinstance(colour, str):
            found[name].add(colour.lower())
    return found


def test_an_engine_has_one_colour_in_every_figure_png_and_page(saved, tmp_path):
    trajectories = _trajectories()
    scene = get_scene("hop-top")
    panel = ForcePanel("hop-top", scene, scene.mus, {e: trajectories[e] for e in ENGINES})
    rows = _precision_rows()
    with plain_text():
        events_figure(trajectories, tmp_path / "events.png", title="t")
        force_figure([panel], tmp_path / "forces.png")
        precision_figure(rows, tmp_path / "precision.png")
    motion_rows = pd.DataFrame([{"engine": e} for e in ENGINES])
    page = [
        precision_page_figure(rows),
        force_page_figure([panel]),
        animation_figure(scene, hoop_motions(scene, trajectories, motion_rows)),
    ]
    figures = [*_png_colours(saved), *(_page_colours(f) for f in page if f)]
    assert len(figures) == 6
    seen: dict[str, set[str]] = defaultdict(set)
    for found in figures:
        assert set(ENGINES) <= set(found), sorted(found)
        for engine in ENGINES:
            assert len(found[engine]) == 1, (engine, found[engine])  # one colour a figure
            seen[engine] |= found[engine]
        colours = [next(iter(found[e])) for e in ENGINES]
        assert len(set(colours)) == len(colours), found  # never shared in one figure
    for engine in ENGINES:
        assert seen[engine] == {ENGINE_COLOURS[engine]}, (engine, seen[engine])
