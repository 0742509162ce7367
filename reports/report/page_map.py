"""The page's hop map: a cell per grid point, coloured by the exact regime (or, from the
buttons, one engine's verdict), whose hover gives the point's parameters, the exact regime
and hop height and each engine's verdict with its reason; a click draws that point's runs
(clearance, slip velocity, n/g against time, each engine over the exact solution) from the
thinned trajectories the map stored (:mod:`hoopbench.reports.hop_map.display`).

The cells are the PNG's (:func:`map_figures.regime_cells`, :func:`map_figures.verdict_cells`
on :func:`map_figures.map_grid`), from the same map frame.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.verdict import Verdict
from hoopbench.reference.regimes import Regime
from hoopbench.reports.compare.selection import reference_rows
from hoopbench.reports.hop_map.display import DISPLAY_SAMPLES, read_display
from hoopbench.reports.hop_map.spec import load_spec
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.report.map_figures import (
    NO_VERDICT,
    NOT_JUDGED,
    REGIME_COLOURS,
    VERDICT_COLOURS,
    MapGrid,
    engines_of,
    map_grid,
    regime_cells,
    verdict_cells,
)
from hoopbench.reports.report.page_html import figure_fragment, rounded, script_json, text
from hoopbench.reports.report.palette import REFERENCE_COLOUR, engine_colours

__all__ = ["map_cell_key", "map_fragment", "run_samples"]

_PARAMETERS = ("lam", "chi", "mu", "eps", "theta0_deg")
"""The scene parameters a cell's hover lists (the map's columns)."""
_CELL_COLUMNS = (
    "ix", "iy", "x", "y", *_PARAMETERS, Col.ENGINE, Col.RUN_ID, Col.STATUS, "verdict",
    "verdict_reason", "regime", "exact_hop_height",
)  # fmt: skip
"""What :func:`_cells` reads of a point's rows (its hover and its runs)."""

PAGE_SAMPLES = 400_000
"""Samples of all the map's runs together that the page embeds for the clicks (each sample
four numbers, about 30 bytes): a 10x10 map of three engines keeps every stored sample, and a
40x40 one about 60 per run, so that the page stays near 12 MB (plotly.js is 4.8 of it)."""
MIN_RUN_SAMPLES = 40
"""A clicked run never shows fewer samples than this, whatever the map's size."""


def run_samples(n_runs: int) -> int:
    """Samples per run the page embeds for a map of ``n_runs`` stored runs."""
    share = PAGE_SAMPLES // max(n_runs, 1)
    return max(MIN_RUN_SAMPLES, min(DISPLAY_SAMPLES, share))


def map_cell_key(ix: int, iy: int) -> str:
    """The key of a cell in the page's data (the heat map's customdata)."""
    return f"{ix},{iy}"


def _steps(colours: list[str]) -> list[list[Any]]:
    """A colour scale with a step per category: code k fills [k, k + 1) / n."""
    n = len(colours)
    scale: list[list[Any]] = []
    for k, colour in enumerate(colours):
        scale += [[k / n, colour], [(k + 1) / n, colour]]
    return scale


def _value(value: Any) -> str:
    if isinstance(value, float) and np.isnan(value):
        return "-"
    return f"{value:.4g}" if isinstance(value, float) else text(value)


def _hover(point: pd.DataFrame) -> str:
    """One point's hover: parameters, exact regime and hop height, each engine's verdict."""
    ref = reference_rows(point)
    first = point.iloc[0]
    lines = [", ".join(f"{name} {_value(first[name])}" for name in _PARAMETERS)]
    if len(ref):
        row = ref.iloc[0]
        height = row["exact_hop_height"]
        hop = f", hop {height:.4g} m" if pd.notna(height) else ""
        lines.append(f"exact: <b>{text(row['regime'])}</b>{hop}")
    judged = point[point["engine"].isin(engines_of(point))]
    # Column by column: iterrows made each row a Series of the table's 100-odd columns.
    for engine, verdict, status, reason in zip(
        judged["engine"], judged["verdict"], judged["status"], judged["verdict_reason"],
        strict=True,
    ):  # fmt: skip
        verdict = verdict if isinstance(verdict, str) else f"({status})"
        reason = reason if isinstance(reason, str) else ""
        lines.append(f"{text(engine)}: <b>{text(verdict)}</b> {text(reason)[:140]}")
    return "<br>".join(lines)


def _runs(out: Path, point: pd.DataFrame, title: str, g: float, samples: int) -> dict[str, Any]:
    """A point's runs for the click: each stored thinned trajectory (thinned again to
    ``samples``), the exact one last."""
    runs: list[dict[str, Any]] = []
    colours = engine_colours(point["engine"])  # the palette of every figure
    engines = engines_of(point)
    for run_id, engine in zip(point["run_id"], point["engine"], strict=True):
        stored = read_display(out, str(run_id))
        if stored is None:
            continue
        trajectory = stored.thinned(samples)
        exact = engine not in engines
        runs.append(
            {
                "name": "exact" if exact else text(engine),
                "exact": exact,
                "colour": REFERENCE_COLOUR if exact else colours[str(engine)],
                "t": rounded(trajectory.t),
                "c": rounded(trajectory.clearance * 1e3),
                "v": rounded(trajectory.slip_velocity),
                "n": rounded(trajectory.normal_force / g),
            }
        )
    runs.sort(key=lambda run: bool(run["exact"]))
    return {"title": title, "runs": runs}


def _axis(grid: MapGrid, which: str) -> dict[str, Any]:
    log = grid.x_log if which == "x" else grid.y_log
    name = grid.x_axis if which == "x" else grid.y_axis
    return {"type": "log" if log else "linear", "title": {"text": text(name)}}


def _buttons(frame: pd.DataFrame, grid: MapGrid) -> list[dict[str, Any]]:
    """Colour by the exact regime, or by one engine's verdict."""
    regimes = [REGIME_COLOURS[r] for r in Regime]
    buttons = [_colouring("exact regime", regime_cells(frame, grid), regimes)]
    verdicts = [VERDICT_COLOURS[v] for v in Verdict]
    for engine in engines_of(frame):
        cells = verdict_cells(frame, engine, grid)
        buttons.append(_colouring(f"{engine} verdict", cells, verdicts))
    return buttons


def _key_entry(name: str, colour: str, group: str, title: str) -> dict[str, Any]:
    """A legend entry and nothing drawn: an invisible point with the category's colour."""
    return {
        "type": "scatter",
        "x": [None],
        "y": [None],
        "mode": "markers",
        "marker": {"symbol": "square", "size": 13, "color": colour,
                   "line": {"color": "#999", "width": 1}},
        "name": text(name),
        "legendgroup": group,
        "legendgrouptitle": {"text": title},
        "hoverinfo": "skip",
    }  # fmt: skip


def _colour_key(frame: pd.DataFrame) -> list[dict[str, Any]]:
    """The key of every colour the cells can take: the exact regimes present (the first
    colouring) and the verdicts present (the engines' colourings), and the empty cell."""
    regimes = set(reference_rows(frame)["regime"].dropna())
    verdicts = set(frame[frame["engine"].isin(engines_of(frame))]["verdict"].dropna())
    key = [
        _key_entry(str(r), REGIME_COLOURS[r], "regime", "exact regime")
        for r in Regime
        if str(r) in regimes
    ]
    key += [
        _key_entry(str(v), VERDICT_COLOURS[v], "verdict", "engine verdict")
        for v in Verdict
        if str(v) in verdicts
    ]
    key.append(_key_entry(NO_VERDICT, NOT_JUDGED, "verdict", "engine verdict"))
    return key


def _colouring(label: str, cells: np.ndarray, colours: list[str]) -> dict[str, Any]:
    z = [rounded(row) for row in cells]
    style = {"z": [z], "colorscale": [_steps(colours)], "zmax": [len(colours)]}
    return {"label": text(label), "method": "restyle", "args": [style]}


def _cells(frame: pd.DataFrame, grid: MapGrid, out: Path) -> tuple[list, list, dict]:
    """Hover text and keys, (ny, nx), and each point's runs by key."""
    gravity = {(p.ix, p.iy): p.scene().g for p in load_spec(out).points()}
    ny, nx = grid.shape
    hover = [["" for _ in range(nx)] for _ in range(ny)]
    keys = [["" for _ in range(nx)] for _ in range(ny)]
    runs: dict[str, Any] = {}
    samples = run_samples(len(frame))
    # The columns a cell reads, not the table's hundred: a group is a copy of its columns.
    read = [name for name in _CELL_COLUMNS if name in frame.columns]
    for (ix, iy), point in frame[read].groupby(["ix", "iy"], sort=True):
        key = map_cell_key(int(ix), int(iy))
        hover[int(iy)][int(ix)] = _hover(point)
        keys[int(iy)][int(ix)] = key
        title = (
            f"{grid.x_axis} = {point.iloc[0]['x']:.4g}, {grid.y_axis} = {point.iloc[0]['y']:.4g}"
        )
        runs[key] = _runs(out, point, title, gravity[(int(ix), int(iy))], samples)
    return hover, keys, runs


def map_fragment(results_dir: str | Path, figure_id: str) -> str:
    """The interactive map of a map folder, its cells' runs and the place a click draws them."""
    results_dir = Path(results_dir)
    frame = map_frame(results_dir)
    if frame.empty:
        return ""
    grid = map_grid(frame)
    hover, keys, runs = _cells(frame, grid, results_dir)
    buttons = _buttons(frame, grid)
    heatmap = {
        "type": "heatmap",
        "x": rounded(grid.x),
        "y": rounded(grid.y),
        "text": hover,
        "customdata": keys,
        "hovertemplate": "%{text}<extra></extra>",
        "zmin": 0,
        "showscale": False,
        "xgap": 1,
        "ygap": 1,
        **{name: value[0] for name, value in buttons[0]["args"][0].items()},
    }
    layout = {
        "height": 520,
        "xaxis": _axis(grid, "x"),
        "yaxis": _axis(grid, "y"),
        "hoverlabel": {"align": "left"},
        "margin": {"t": 60},
        "updatemenus": [{"type": "buttons", "direction": "right", "buttons": buttons,
                         "x": 0, "y": 1.02, "xanchor": "left", "yanchor": "bottom"}],
    }  # fmt: skip
    extra = (
        f'<p>Click a cell for its runs.</p><div class="map-runs-title" id="{text(figure_id)}'
        f'-runs-title"></div><div id="{text(figure_id)}-runs"></div>'
        f'<script type="application/json" id="{text(figure_id)}-cells">{script_json(runs)}'
        "</script>"
    )
    layout["legend"] = {"groupclick": "togglegroup", "itemclick": False, "itemdoubleclick": False}
    data = [heatmap, *_colour_key(frame)]
    return figure_fragment(figure_id, {"data": data, "layout": layout}, kind="map", extra=extra)
