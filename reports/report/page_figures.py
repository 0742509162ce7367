"""The page's interactive versions of three of the report's figures, from the same rows and
the same selections as the PNGs (:mod:`precision`, :mod:`stability`, :mod:`force_figures`):

- error against run time: a point's hover names its run; the legend toggles an engine (its
  group title) or one profile and settings of it, the buttons a profile;
- the stability matrix: each cell's class and the figure behind it on hover;
- the contact-force panels: n/g and |f|/(mu n) of every engine over the exact curves.

Each function returns a plotly figure as a plain dict ({data, layout}), or None when the
report has no such figure.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.score import CostClock
from hoopbench.reference.exact import solve_exact
from hoopbench.reports.compare.selection import (
    default_rows,
    engine_rows,
    reference_rows,
    run_cost_clock,
)
from hoopbench.reports.report.force_figures import CONE_YLIM, ForcePanel
from hoopbench.reports.report.page_html import rounded, text
from hoopbench.reports.report.palette import (
    FRONT_ALPHA,
    FRONT_COLOUR,
    FRONT_WIDTH,
    REFERENCE_COLOUR,
    engine_colours,
    profile_style,
)
from hoopbench.reports.report.precision import (
    COST,
    ZERO_LABEL,
    cost_label,
    error_floor,
    figure_panels,
    metric_runs,
    pareto_front,
)
from hoopbench.reports.report.stability import (
    _COLOURS,
    MatrixPanels,
    Stability,
    matrix_panels,
    present_classes,
    stability_matrix,
    timestep_label,
)

__all__ = ["force_page_figure", "precision_page_figure", "stability_page_figure"]

Figure = dict[str, Any]

_COLUMNS = 3
"""Panels per row, as in the PNG."""

_HOVER = (
    "<b>%{customdata[0]}</b> %{customdata[1]}, %{customdata[2]}<br>"
    "dt %{customdata[3]} s<br>|error| %{y:.4g} %{customdata[4]}<br>"
    "%{customdata[6]} time %{x:.4g} s, %{customdata[5]} us/step<extra></extra>"
)


def _axis_name(kind: str, k: int) -> str:
    return kind if k == 0 else f"{kind}{k + 1}"


def _point_data(group: pd.DataFrame, unit: str, clock: CostClock) -> list[list[str]]:
    per_step = pd.to_numeric(group[clock.step_column], errors="coerce")
    return [
        [
            text(row["engine"]),
            text(row["profile"]),
            text(row["variant"]),
            f"{row['timestep']:g}",
            text(unit),
            f"{step:.3g}" if pd.notna(step) else "-",
            clock.label,
        ]
        for (_, row), step in zip(group.iterrows(), per_step, strict=True)
    ]


def _family_traces(
    points: pd.DataFrame, unit: str, k: int, shown: set[str], floor: float, clock: CostClock
) -> list:
    """One line per settings family of one panel, grouped in the legend by engine: the
    engine's colour (palette.py), the profile's dash and symbol; a family's legend entry is
    the first panel's (``shown``: the families with one)."""
    traces = []
    for family, group in engine_rows(points).groupby("family", sort=True):
        group = group.sort_values(COST)
        engine = str(group["engine"].iloc[0])
        first = str(family) not in shown
        shown.add(str(family))
        colour = engine_colours([engine])[engine]
        style = profile_style(str(group["profile"].iloc[0]))
        traces.append(
            {
                "type": "scatter",
                "mode": "lines+markers",
                "x": rounded(group[COST]),
                "y": rounded(group["error"].clip(lower=floor)),  # a zero on the edge
                "customdata": _point_data(group, unit, clock),
                "hovertemplate": _HOVER,
                "name": text(family),
                "legendgroup": text(engine),
                "legendgrouptitle": {"text": text(engine)},
                "showlegend": first,
                "line": {"color": colour, "dash": style.plotly_dash},
                "marker": {"color": colour, "symbol": style.plotly_symbol},
                "meta": text(group["profile"].iloc[0]),
                "xaxis": _axis_name("x", k),
                "yaxis": _axis_name("y", k),
            }
        )
    return traces


def _panel_extras(
    runs: pd.DataFrame, points: pd.DataFrame, scene: str, k: int, floor: float, clock: CostClock
) -> list[dict]:
    """The Pareto front (palette.FRONT_COLOUR's band, under the runs) and the exact
    reference's star (error 0: on the panel's bottom edge, ``floor``) of one panel."""
    front = pareto_front(engine_rows(points))
    axes = {"xaxis": _axis_name("x", k), "yaxis": _axis_name("y", k)}
    traces = [
        {
            "type": "scatter",
            "mode": "lines",
            "line": {"shape": "hv", "color": FRONT_COLOUR, "width": FRONT_WIDTH},
            "opacity": FRONT_ALPHA,
            "x": rounded(front[COST]),
            "y": rounded(front["error"].clip(lower=floor)),
            "name": "Pareto front",
            "legendgroup": "front",
            "showlegend": k == 0,
            "hoverinfo": "skip",
            **axes,
        }
    ]
    reference = reference_rows(runs[runs["scene"] == scene])
    if len(reference):
        traces.append(
            {
                "type": "scatter",
                "mode": "markers+text",
                "marker": {"symbol": "star", "size": 12, "color": REFERENCE_COLOUR},
                "text": [ZERO_LABEL],
                "textposition": "top right",
                "cliponaxis": False,  # on the edge, whole
                "x": [float(reference[clock.column].min())],
                "y": [floor],
                "name": "exact reference (error 0: on the bottom edge)",
                "legendgroup": "reference",
                "showlegend": k == 0,
                "hovertemplate": "exact reference: solve %{x:.3g} s<extra></extra>",
                **axes,
            }
        )
    return traces


def _profile_buttons(traces: list[dict]) -> list[dict]:
    """Buttons that show every profile or one (the front and the reference always)."""
    profiles = sorted({t["meta"] for t in traces if "meta" in t})
    buttons = [{"label": "every profile", "method": "restyle", "args": ["visible", True]}]
    for profile in profiles:
        visible = [t.get("meta", profile) == profile for t in traces]
        buttons.append(
            {"label": f"{profile} only", "method": "restyle", "args": ["visible", visible]}
        )
    return buttons


def precision_page_figure(runs: pd.DataFrame) -> Figure | None:
    """Error against run time (the report's error_vs_time.png), one panel per (event, scene)."""
    runs = default_rows(runs)
    panels = figure_panels(runs)
    if not panels:
        return None
    rows = -(-len(panels) // _COLUMNS)
    traces: list[dict] = []
    layout: dict[str, Any] = {
        "height": 330 * rows + 80,
        "grid": {"rows": rows, "columns": _COLUMNS, "pattern": "independent"},
        "legend": {"groupclick": "toggleitem", "font": {"size": 10}},
        "margin": {"t": 60},
        "annotations": [],
        "shapes": [],
    }
    shown: set[str] = set()
    clock = run_cost_clock(runs)
    for k, (metric, scene) in enumerate(panels):
        points = metric_runs(runs, metric, scene)
        floor = error_floor(engine_rows(points)["error"])
        # the front first: drawn under the runs
        traces += _panel_extras(runs, points, scene, k, floor, clock)
        traces += _family_traces(points, metric.unit, k, shown, floor, clock)
        x, y = _axis_name("xaxis", k), _axis_name("yaxis", k)
        # powers of ten, as the PNG's axes (plotly's default writes 1µ for 1e-6)
        log = {"type": "log", "exponentformat": "power"}
        layout[x] = {**log, "title": {"text": cost_label(clock)}}
        top = max(float(points["error"].max()), metric.target, floor) * 3.0
        layout[y] = {**log, "title": {"text": f"|error| ({metric.unit})"},
                     "range": [float(np.log10(floor)), float(np.log10(top))]}  # fmt: skip
        layout["annotations"].append(_panel_title(f"{scene}: {metric.label}", k))
        layout["shapes"].append(_target_line(metric.target, k))
    layout["updatemenus"] = [
        {"type": "buttons", "direction": "right", "x": 0, "y": 1.08, "yanchor": "bottom",
         "xanchor": "left", "buttons": _profile_buttons(traces)}
    ]  # fmt: skip
    for trace in traces:
        trace.pop("meta", None)
    return {"data": traces, "layout": layout}


def _panel_title(title: str, k: int) -> dict:
    return {
        "text": text(title),
        "xref": f"{_axis_name('x', k)} domain",
        "yref": f"{_axis_name('y', k)} domain",
        "x": 0.5,
        "y": 1.0,
        "yanchor": "bottom",
        "showarrow": False,
        "font": {"size": 12},
    }


def _target_line(target: float, k: int) -> dict:
    """The metric's target, dotted across the panel."""
    return {
        "type": "line",
        "xref": f"{_axis_name('x', k)} domain",
        "yref": _axis_name("y", k),
        "x0": 0,
        "x1": 1,
        "y0": target,
        "y1": target,
        "line": {"dash": "dot", "color": "grey", "width": 1},
    }


# --------------------------------------------------------------------------- stability
_STABILITY_CELL_PX = (46, 21)
"""A matrix cell on the page, (width, height) in pixels."""
_STABILITY_TOP_PX = 58
"""Above each panel: its scene, then its timesteps."""


def stability_page_figure(runs: pd.DataFrame) -> Figure | None:
    """The stability matrix (stability.png): the same panels, a heat map per scene, each
    cell coloured by its class, with its text (class: figure) on hover; the timesteps on top
    of every panel, the engines on the left of each row of panels."""
    table = stability_matrix(runs)
    if table.empty:
        return None
    panels = matrix_panels(table)
    kinds = list(Stability)
    n = len(kinds)
    scale = []
    for k, kind in enumerate(kinds):  # a step per class: code k fills [k, k + 1) / n
        scale += [[k / n, _COLOURS[kind]], [(k + 1) / n, _COLOURS[kind]]]
    n_rows = -(-len(panels.scenes) // panels.columns)
    cell_w, cell_h = _STABILITY_CELL_PX
    panel_w = cell_w * len(panels.timesteps)
    panel_h = cell_h * len(panels.engines)
    gap_w, row_px = 18, panel_h + _STABILITY_TOP_PX
    plot_w = panels.columns * panel_w + (panels.columns - 1) * gap_w
    plot_h = n_rows * row_px
    engines = [text(e) for e in panels.engines]
    steps = [timestep_label(dt) for dt in panels.timesteps]
    data: list[dict] = []
    layout: dict[str, Any] = {
        # the page's width: the panels' fractions stretch the cells to it
        "height": plot_h + 40,
        "margin": {"t": 30, "b": 10, "l": 110, "r": 20},
        "legend": {
            "x": 1.0,
            "y": 1,
            "xanchor": "left",
            "yanchor": "top",
            "title": {"text": "class"},
        },
        "annotations": [],
        "plot_bgcolor": "white",
    }
    for k, scene in enumerate(panels.scenes):
        row, column = divmod(k, panels.columns)
        x0 = column * (panel_w + gap_w) / plot_w
        top = 1.0 - (row * row_px + _STABILITY_TOP_PX) / plot_h
        x, y = _axis_name("x", k), _axis_name("y", k)
        codes = panels.codes[scene]
        data.append(
            {
                "type": "heatmap",
                "z": [[None if c != c else int(c) for c in line] for line in codes],
                "x": steps,
                "y": engines,
                "text": [[text(c) or "not run" for c in line] for line in panels.cells[scene]],
                "hovertemplate": f"{text(scene)} | %{{y}}<br>dt %{{x}} s<br><b>%{{text}}</b>"
                "<extra></extra>",
                "colorscale": scale,
                "zmin": 0,
                "zmax": n,
                "showscale": False,
                "xgap": 1,
                "ygap": 1,
                "xaxis": x,
                "yaxis": y,
            }
        )
        layout[_axis_name("xaxis", k)] = {
            "type": "category",
            "side": "top",  # every panel's timesteps above it: no column unlabelled on screen
            "domain": [x0, x0 + panel_w / plot_w],
            "anchor": y,
            "tickfont": {"size": 11},
            "ticks": "",
            "showgrid": False,
        }
        layout[_axis_name("yaxis", k)] = {
            "type": "category",
            "autorange": "reversed",
            "domain": [top - panel_h / plot_h, top],
            "anchor": x,
            "showticklabels": column == 0,
            "ticks": "",
            "tickfont": {"size": 11},
            "showgrid": False,
        }
        layout["annotations"].append(
            {"text": f"<b>{text(scene)}</b>", "xref": "paper", "yref": "paper",
             "x": x0 + panel_w / plot_w / 2, "y": top + 24 / plot_h, "yanchor": "bottom",
             "showarrow": False, "font": {"size": 12}}
        )  # fmt: skip
    return {"data": [*data, *_stability_key(panels)], "layout": layout}


def _stability_key(panels: MatrixPanels) -> list[dict]:
    """A legend of the classes present and of a blank cell: invisible points, one each."""
    present, blank = present_classes(panels)
    colours = [(kind.value, _COLOURS[kind]) for kind in present]
    if blank:
        colours.append(("not run", "#ffffff"))
    edge = {"color": "#999", "width": 1}
    return [
        {
            "type": "scatter",
            "x": [None],
            "y": [None],
            "mode": "markers",
            "marker": {"symbol": "square", "size": 12, "color": colour, "line": edge},
            "name": name,
            "hoverinfo": "skip",
        }
        for name, colour in colours
    ]


# --------------------------------------------------------------------------- contact forces
_FORCE_SAMPLES = 1500
"""Samples per engine curve on the page: each bucket keeps its lowest and highest n, so a
one-sample spike of the contact force (chatter, a re-stick impulse) stays in the figure."""


def envelope(values: np.ndarray, samples: int = _FORCE_SAMPLES) -> np.ndarray:
    """Indices that keep ``values``' extremes: the first and last, and each of
    ``samples // 2`` buckets' lowest and highest sample, in order."""
    n = len(values)
    if n <= samples:
        return np.arange(n)
    edges = np.linspace(0, n, samples // 2 + 1).astype(int)
    keep = [0, n - 1]
    clean = np.where(np.isfinite(values), values, 0.0)
    for lo, hi in itertools.pairwise(edges):
        if hi > lo:
            keep += [lo + int(np.argmin(clean[lo:hi])), lo + int(np.argmax(clean[lo:hi]))]
    return np.unique(keep)


def _cone(n: np.ndarray, f: np.ndarray, mu: float) -> np.ndarray:
    share = np.full(len(n), np.nan)
    touching = n > 0
    share[touching] = np.abs(f[touching]) / (mu * n[touching])
    return share


def _force_traces(panel: ForcePanel, column: int, columns: int, colours: dict[str, str]) -> list:
    """One scene's curves: n/g in the top row's panel ``column``, |f|/(mu n) below it (the
    grid numbers its axes row by row)."""
    solution = solve_exact(panel.scene.with_(mus=panel.mu, muk=panel.mu))
    g = panel.scene.g
    exact = solution.sample(np.linspace(0.0, solution.t_final, 2001))
    curves = [(name, traj, False) for name, traj in panel.runs.items()] + [("exact", exact, True)]
    top = {"xaxis": _axis_name("x", column), "yaxis": _axis_name("y", column)}
    bottom = {
        "xaxis": _axis_name("x", column + columns),
        "yaxis": _axis_name("y", column + columns),
    }
    traces = []
    for name, traj, is_exact in curves:
        keep = traj.t <= solution.t_final
        t, n, f = traj.t[keep], traj.normal_force[keep], traj.friction_force[keep]
        index = envelope(n)
        line = {"dash": "dash", "color": REFERENCE_COLOUR} if is_exact else {"color": colours[name]}
        common: dict[str, Any] = {
            "type": "scatter",
            "mode": "lines",
            "line": line,
            "name": text(name if is_exact else panel.label(name)),
        }
        common |= {"legendgroup": text(name), "x": rounded(t[index])}
        traces.append({**common, **top, "y": rounded(n[index] / g), "showlegend": column == 0})
        share = _cone(n[index], f[index], panel.mu)
        traces.append({**common, **bottom, "y": rounded(share), "showlegend": False})
    return traces


N_YLIM = (-0.5, 4.0)
"""n/g shown at first from -0.5 to 4: rolling's 1 g and its chatter; the re-stick's exact peak
(34 g on seed-mu, 43 g on hop-top) is off the top until the axis is zoomed out (a linear axis:
plotly has no symmetric-log one)."""


def force_page_figure(panels: list[ForcePanel]) -> Figure | None:
    """The contact-force panels (contact_forces.png): a column per scene, n/g over
    |f|/(mu n), each engine over the exact curves (dashed)."""
    if not panels:
        return None
    names = list(dict.fromkeys(name for panel in panels for name in panel.runs))
    colours = engine_colours(names)
    columns = len(panels)
    traces = [t for k, p in enumerate(panels) for t in _force_traces(p, k, columns, colours)]
    layout: dict[str, Any] = {
        "height": 640,
        "grid": {"rows": 2, "columns": len(panels), "pattern": "independent"},
        "annotations": [],
        "margin": {"t": 50},
    }
    for k, panel in enumerate(panels):
        layout[_axis_name("yaxis", k)] = {"title": {"text": "n / g"}, "range": list(N_YLIM)}
        layout[_axis_name("yaxis", k + columns)] = {
            "title": {"text": "|f| / (mu n)"},
            "range": list(CONE_YLIM),
        }
        layout[_axis_name("xaxis", k + columns)] = {
            "title": {"text": "t (s)"},
            "matches": _axis_name("x", k),
        }
        layout["annotations"].append(_panel_title(f"{panel.name} (mu = {panel.mu:g})", k))
    return {"data": traces, "layout": layout}
