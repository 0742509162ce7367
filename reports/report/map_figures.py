"""Figures of a hop map (issue 11): the reference's regimes, each engine's disagreements, and
its hop-height error, drawn from a map frame (:func:`hoopbench.reports.hop_map.map_frame`).

Each figure function takes the frame and a path, writes one PNG there and returns the path;
none reads a file. Its ``key`` (map_section.figure_key: what it was drawn from) is kept in the
PNG as the text entry :data:`FIGURE_KEY`, so that a report copies the map folder's figure of
the same data rather than drawing it again. The cells to colour come from small pure functions
(:func:`regime_cells`, :func:`verdict_cells`, :func:`hop_ratio_cells`) that return arrays of
shape (ny, nx), row iy and column ix, NaN where nothing is drawn; the figures draw exactly
those arrays, so tests check the data and not the pixels.

The grid is regular in index (columns ix, iy) with centres x, y; cells are drawn on their
edges (midway between neighbouring centres, half a step beyond the ends), so a 40x40 map
reads as a map and a 1xN map as a strip. A geometric axis (constant ratio, e.g. chi spaced
in log) is drawn on a log scale with geometric midpoints.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from hoopbench.engines.judging.tolerances import Tier, event_tolerances
from hoopbench.engines.judging.verdict import Verdict
from hoopbench.reference.regimes import Regime
from hoopbench.reports.compare.selection import engine_names_of, reference_rows
from hoopbench.reports.report.plotting import pyplot, save

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "DPI",
    "FIGURE_KEY",
    "HOP_REGIMES",
    "PANEL_SIZE",
    "REGIME_COLOURS",
    "VERDICT_COLOURS",
    "MapGrid",
    "engines_of",
    "figure_pixels",
    "hop_error_figure",
    "hop_ratio_cells",
    "map_grid",
    "regime_cells",
    "regime_figure",
    "verdict_cells",
    "verdict_figure",
]

HOP_REGIMES = (Regime.HOPS, Regime.LIFTS_AT_START)
"""The regimes with a hop height (RegimePoint.hop_height)."""

# Okabe and Ito's colour-blind-safe palette, plus greys for the regimes that are no answer.
REGIME_COLOURS: dict[Regime, str] = {
    Regime.ROLLS: "#56B4E9",  # sky blue
    Regime.SLIPS: "#009E73",  # bluish green
    Regime.SLIP_REVERSAL: "#F0E442",  # yellow
    Regime.HOPS: "#D55E00",  # vermillion
    Regime.LIFTS_AT_START: "#CC79A7",  # reddish purple
    Regime.PAINLEVE: "#0072B2",  # blue
    Regime.DEGENERATE: "#999999",  # grey
    Regime.ERROR: "#000000",  # black
}
"""One colour per regime, the same in every figure (Okabe-Ito, colour-blind safe)."""

VERDICT_COLOURS: dict[Verdict, str] = {
    Verdict.AGREES: "#E4E4E4",  # faint: the points that need no attention
    Verdict.CLOSE: "#BDBDBD",  # a darker grey: right, within the loose tolerances
    Verdict.FALSE_HOP: "#D55E00",
    Verdict.MISSED_HOP: "#E69F00",
    Verdict.MISSED_SLIP: "#0072B2",
    Verdict.FALSE_SLIP: "#56B4E9",
    # the hop family: oranges and browns, a dark purple for the last of them
    Verdict.HOP_TOO_LOW: "#543005",  # dark: far from the regime "hops" vermillion
    Verdict.HOP_TOO_HIGH: "#BF812D",
    Verdict.EARLY_LIFT_OFF: "#DFC27D",
    Verdict.LATE_LIFT_OFF: "#7F3B08",
    Verdict.EARLY_IMPACT: "#F6E8C3",
    Verdict.LATE_IMPACT: "#3D1F4F",
    Verdict.EARLY_SLIP: "#009E73",  # the slip-onset pair: greens
    Verdict.LATE_SLIP: "#66C2A4",
    Verdict.WRONG_PHASES: "#F0E442",
    Verdict.EARLY_TRANSITION: "#35978F",  # a later transition: teals, beside the slip onset
    Verdict.LATE_TRANSITION: "#01665E",
    Verdict.CREEPS: "#1B7837",  # a dark green: sliding, as the slip family
    Verdict.CONE_VIOLATION: "#762A83",
    Verdict.DIVERGED: "#000000",
    Verdict.FAILED: "#CC79A7",
}
"""One colour per verdict (every member of Verdict; the categorical map reads them in
Verdict's order, whatever the order here): Okabe-Ito, with browns for the hop's size and
times (and a dark purple: a seventh brown would be too near another), greens for the slip
onset and teals for the later transitions; ``agrees`` faint grey, ``close`` a darker one.
Any two differ by CIE76 delta E 15 or more (the two greys by 14), and ``hop-too-low`` is
over 50 from the regime ``hops`` the page's key lists beside it
(tests/test_map_figures.py)."""

NOT_JUDGED = "#FFFFFF"
"""Cells with no verdict: the reference has no answer (degenerate, error), or the engine
could not run the scene (I = 0)."""
NO_VERDICT = "no verdict"
"""The legend's name for a cell without a verdict (NOT_JUDGED)."""
_NO_HOP = "#F0F0F0"
"""Cells of the hop-height panel where the reference does not hop."""
_NOT_COMPARED = "#8C8C8C"
"""Hop-error cells where the reference hops and the engine does not (or did not run): a
mid grey, unlike any colour of the diverging scale (whose centre, ratio 1, is near white)."""

PANEL_SIZE = (4.6, 4.0)
"""Inches (width, height) of one panel, its colour bar or legend included."""
DPI = 100
_MAX_COLUMNS = 3
"""Panels per row in the per-engine figures."""
_LEGEND_HEIGHT = 0.9
"""Inches added below the panels for a figure legend."""

_AXIS_LABELS = {
    "lam": r"weight fraction $\lambda$ (-)",
    "chi": r"spin $\chi = a\,\dot\theta_0^2/g$ (-)",
    "mu": r"friction $\mu = \mu_s = \mu_k$ (-)",
    "eps": r"weight inertia $\epsilon$ (-)",
    "theta0_deg": r"start angle $\theta_0$ (deg)",
}
"""Axis labels with units, by map axis name (theta0 is the only one in degrees)."""


# --------------------------------------------------------------------------- the grid
@dataclass(frozen=True)
class MapGrid:
    """The map's cells: centres and edges along each axis, in the axis's own units."""

    x_axis: str
    y_axis: str
    x: np.ndarray
    """Cell centres, shape (nx,), index ix."""
    y: np.ndarray
    """Cell centres, shape (ny,), index iy."""
    x_edges: np.ndarray
    """Cell edges, shape (nx + 1,)."""
    y_edges: np.ndarray
    """Cell edges, shape (ny + 1,)."""
    x_log: bool
    """Whether x is spaced geometrically (drawn on a log scale)."""
    y_log: bool

    @property
    def shape(self) -> tuple[int, int]:
        """(ny, nx): the shape of every cell array."""
        return len(self.y), len(self.x)


def _is_geometric(values: np.ndarray) -> bool:
    if len(values) < 3 or np.any(values <= 0):
        return False
    steps, ratios = np.diff(values), values[1:] / values[:-1]
    return bool(
        np.ptp(ratios) < 1e-6 * ratios.mean() and np.ptp(steps) > 1e-6 * np.abs(steps).max()
    )


def _centres(index: pd.Series, values: pd.Series) -> np.ndarray:
    """Centre of every index 0..max; an index with no row (a partial map) interpolated."""
    known = pd.DataFrame({"i": index.astype(int), "v": values.astype(float)}).groupby("i")["v"]
    known = known.first()
    n = int(known.index.max()) + 1
    if len(known) == n:
        return known.to_numpy()
    return np.interp(np.arange(n), known.index.to_numpy(), known.to_numpy())


def _edges(centres: np.ndarray, log: bool) -> np.ndarray:
    if len(centres) == 1:
        c = centres[0]
        half = 0.05 * abs(c) if c != 0 else 0.5
        return np.array([c - half, c + half])
    v = np.log(centres) if log else centres
    mid = (v[1:] + v[:-1]) / 2
    edges = np.concatenate([[2 * v[0] - mid[0]], mid, [2 * v[-1] - mid[-1]]])
    return np.exp(edges) if log else edges


def map_grid(frame: pd.DataFrame) -> MapGrid:
    """The grid of a map frame (its columns x_axis, y_axis, ix, iy, x, y)."""
    if frame.empty:
        raise ValueError("map frame has no rows: nothing to draw")
    x, y = _centres(frame["ix"], frame["x"]), _centres(frame["iy"], frame["y"])
    x_log, y_log = _is_geometric(x), _is_geometric(y)
    return MapGrid(
        x_axis=str(frame["x_axis"].iloc[0]),
        y_axis=str(frame["y_axis"].iloc[0]),
        x=x,
        y=y,
        x_edges=_edges(x, x_log),
        y_edges=_edges(y, y_log),
        x_log=x_log,
        y_log=y_log,
    )


def _grid_values(rows: pd.DataFrame, values: pd.Series | np.ndarray, grid: MapGrid) -> np.ndarray:
    """An (ny, nx) float array: ``values`` at the rows' cells, NaN elsewhere."""
    cells = np.full(grid.shape, np.nan)
    cells[rows["iy"].astype(int).to_numpy(), rows["ix"].astype(int).to_numpy()] = np.asarray(
        values, dtype=float
    )
    return cells


def engines_of(frame: pd.DataFrame) -> list[str]:
    """The engines of a map frame, in order of appearance, the reference left out."""
    return engine_names_of(frame)


def _reference(frame: pd.DataFrame) -> pd.DataFrame:
    return reference_rows(frame)


# --------------------------------------------------------------------------- cells to colour
def regime_cells(frame: pd.DataFrame, grid: MapGrid) -> np.ndarray:
    """(ny, nx): the index in ``list(Regime)`` of each cell's reference regime, NaN where the
    reference has no row or no regime."""
    rows = _reference(frame)
    order = {str(r): k for k, r in enumerate(Regime)}
    codes = rows["regime"].map(lambda r: order.get(r, np.nan) if isinstance(r, str) else np.nan)
    return _grid_values(rows, codes, grid)


def exact_hop_cells(frame: pd.DataFrame, grid: MapGrid) -> np.ndarray:
    """(ny, nx): the reference's hop height, m, where it hops; NaN elsewhere."""
    rows = _reference(frame)
    hops = rows[rows["regime"].isin([str(r) for r in HOP_REGIMES])]
    heights = pd.to_numeric(hops["exact_hop_height"], errors="coerce")
    hops, heights = hops[heights > 0], heights[heights > 0]
    return _grid_values(hops, heights, grid)


def verdict_cells(frame: pd.DataFrame, engine: str, grid: MapGrid) -> np.ndarray:
    """(ny, nx): the index in ``list(Verdict)`` of the engine's verdict at each cell, NaN
    where it has no row or no verdict (no exact answer). ``agrees`` is index 0: the figure
    draws it faint and every other index in its verdict's colour."""
    rows = frame[frame["engine"] == engine]
    order = {str(v): k for k, v in enumerate(Verdict)}
    codes = rows["verdict"].map(lambda v: order.get(v, np.nan) if isinstance(v, str) else np.nan)
    return _grid_values(rows, codes, grid)


def _judged_cells(frame: pd.DataFrame, engine: str, grid: MapGrid) -> np.ndarray:
    """(ny, nx): 1 where the engine has a row, NaN elsewhere."""
    rows = frame[frame["engine"] == engine]
    return _grid_values(rows, np.ones(len(rows)), grid)


def hop_ratio_cells(frame: pd.DataFrame, engine: str, grid: MapGrid) -> np.ndarray:
    """(ny, nx): engine hop height / exact hop height where both hop (the row's
    hop_height_error is set), NaN elsewhere."""
    rows = frame[frame["engine"] == engine]
    error = pd.to_numeric(rows["hop_height_error"], errors="coerce")
    exact = pd.to_numeric(rows["exact_hop_height"], errors="coerce")
    both = error.notna() & (exact > 0)
    return _grid_values(rows[both], 1.0 + error[both] / exact[both], grid)


# --------------------------------------------------------------------------- drawing
def figure_pixels(n_panels: int, *, columns: int = _MAX_COLUMNS, legend: bool = False) -> tuple:
    """(width, height) in pixels of a figure of ``n_panels`` panels."""
    ncols = min(n_panels, columns)
    nrows = math.ceil(n_panels / ncols)
    width, height = ncols * PANEL_SIZE[0], nrows * PANEL_SIZE[1] + (_LEGEND_HEIGHT if legend else 0)
    return round(width * DPI), round(height * DPI)


def _panels(n: int, *, legend: bool) -> tuple[Figure, np.ndarray]:
    ncols = min(n, _MAX_COLUMNS)
    nrows = math.ceil(n / ncols)
    width, height = figure_pixels(n, legend=legend)
    fig, axes = pyplot().subplots(
        nrows,
        ncols,
        figsize=(width / DPI, height / DPI),
        sharex=True,
        sharey=True,
        squeeze=False,
        layout="constrained",
    )
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    return fig, axes.flat[:n]


def _label(axis: str) -> str:
    return _AXIS_LABELS.get(axis, axis)


def _set_axes(ax: Axes, grid: MapGrid) -> None:
    ax.set_facecolor("white")
    ax.set_xscale("log" if grid.x_log else "linear")
    ax.set_yscale("log" if grid.y_log else "linear")
    ax.set_xlim(grid.x_edges[0], grid.x_edges[-1])
    ax.set_ylim(grid.y_edges[0], grid.y_edges[-1])
    if len(grid.x) == 1:  # a strip: the one value is the only tick that means anything
        ax.set_xticks(grid.x)
    if len(grid.y) == 1:
        ax.set_yticks(grid.y)
    ax.set_xlabel(_label(grid.x_axis), parse_math=True)
    ax.set_ylabel(_label(grid.y_axis), parse_math=True)
    ax.label_outer()


def _mesh(ax: Axes, grid: MapGrid, cells: np.ndarray, **kwargs):
    return ax.pcolormesh(
        grid.x_edges, grid.y_edges, np.ma.masked_invalid(cells), shading="flat", **kwargs
    )


def _fill(ax: Axes, grid: MapGrid, where: np.ndarray, colour: str) -> None:
    """One colour on the cells where ``where`` (shape (ny, nx), bool) holds."""
    from matplotlib.colors import ListedColormap

    _mesh(ax, grid, np.where(where, 0.0, np.nan), cmap=ListedColormap([colour]))


def _categorical(ax: Axes, grid: MapGrid, cells: np.ndarray, colours: list[str]) -> None:
    """Cells holding indices into ``colours``."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    n = len(colours)
    _mesh(
        ax, grid, cells, cmap=ListedColormap(colours), norm=BoundaryNorm(np.arange(n + 1) - 0.5, n)
    )


FIGURE_KEY = "hoopbench map figure"
"""The PNG text entry holding what a map figure was drawn from (map_section.figure_key)."""


def _save(fig: Figure, path: str | Path, key: str | None) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    return save(fig, path, dpi=DPI, metadata=None if key is None else {FIGURE_KEY: key})


def _message(ax: Axes, text: str) -> None:
    ax.text(0.5, 0.5, text, transform=ax.transAxes, ha="center", va="center", fontsize=9)


def regime_figure(frame: pd.DataFrame, path: str | Path, key: str | None = None) -> Path:
    """The reference's regime map (left, one colour per regime, a legend of those present)
    and its hop height where it hops (right, log colour scale: hop heights on a map span
    decades, from a millimetre to the hoop's size)."""
    from matplotlib.colors import LogNorm
    from matplotlib.patches import Patch

    grid = map_grid(frame)
    fig, (left, right) = _panels(2, legend=True)
    regimes = regime_cells(frame, grid)
    _categorical(left, grid, regimes, [REGIME_COLOURS[r] for r in Regime])
    present = [r for k, r in enumerate(Regime) if np.any(regimes == k)]
    left.set_title("exact reference: regime", fontsize=10)
    heights = exact_hop_cells(frame, grid)
    if np.isfinite(heights).any():
        low, high = np.nanmin(heights), np.nanmax(heights)
        if high <= low * 1.01:  # one height: a decade around it keeps LogNorm defined
            low, high = low / 3.0, high * 3.0
        _fill(right, grid, np.isfinite(regimes), _NO_HOP)
        mesh = _mesh(right, grid, heights, cmap="viridis", norm=LogNorm(low, high))
        fig.colorbar(mesh, ax=right, label="exact hop height (m)")
    else:
        _message(right, "no hop on this map")
    right.set_title("exact hop height where it hops (grey: no hop)", fontsize=10)
    for ax in (left, right):
        _set_axes(ax, grid)
    handles = [Patch(color=REGIME_COLOURS[r], label=str(r)) for r in present]
    if handles:
        fig.legend(
            handles=handles, loc="outside lower center", ncols=min(len(handles), 4), fontsize=8
        )
    return _save(fig, path, key)


def _engine_label(frame: pd.DataFrame, engine: str) -> str:
    """The engine's name, with its timestep where the map's engines run at different ones
    (a map's batched engines have their own: spec.ENGINE_TIMESTEPS)."""
    steps = pd.to_numeric(frame.loc[frame["engine"].isin(engines_of(frame)), "timestep"])
    mine = pd.to_numeric(frame.loc[frame["engine"] == engine, "timestep"]).dropna().unique()
    if steps.nunique() < 2 or len(mine) != 1:
        return engine
    return f"{engine} (dt {mine[0]:g} s)"


def _agreement_title(label: str, cells: np.ndarray) -> str:
    judged = np.isfinite(cells)
    agree = int(np.sum(cells == list(Verdict).index(Verdict.AGREES)))
    n = int(judged.sum())
    rate = f"{100 * agree / n:.0f} %" if n else "-"
    return f"{label}: agrees on {rate} ({agree}/{n})"


def verdict_figure(frame: pd.DataFrame, path: str | Path, key: str | None = None) -> Path:
    """Per engine (one panel each, shared axes) the points where its verdict is not
    ``agrees``, coloured by verdict; agreeing points faint, points without an exact answer
    white. Each title gives the share of judged points whose verdict is ``agrees``."""
    from matplotlib.patches import Patch

    grid = map_grid(frame)
    engines = engines_of(frame)
    if not engines:
        raise ValueError("map frame has no engine rows: no verdicts to draw")
    fig, axes = _panels(len(engines), legend=True)
    present: set[Verdict] = set()
    for ax, engine in zip(axes, engines, strict=True):
        cells = verdict_cells(frame, engine, grid)
        ran = _judged_cells(frame, engine, grid)
        _fill(ax, grid, np.isfinite(ran), NOT_JUDGED)  # under the verdicts
        _categorical(ax, grid, cells, [VERDICT_COLOURS[v] for v in Verdict])
        present |= {v for k, v in enumerate(Verdict) if np.any(cells == k)}
        ax.set_title(_agreement_title(_engine_label(frame, engine), cells), fontsize=10)
        _set_axes(ax, grid)
    handles = [Patch(color=VERDICT_COLOURS[v], label=str(v)) for v in Verdict if v in present]
    no_verdict = "no verdict (no exact answer, too small to see, or not run)"
    handles.append(Patch(facecolor=NOT_JUDGED, edgecolor="0.6", label=no_verdict))
    fig.legend(handles=handles, loc="outside lower center", ncols=min(len(handles), 5), fontsize=8)
    return _save(fig, path, key)


_RATIO_LIMIT = 3.0
"""The colour scale's end, in factors of 2 (x8): beyond, the colour saturates."""


def hop_error_figure(frame: pd.DataFrame, path: str | Path, key: str | None = None) -> Path:
    """Per engine, its hop height over the exact one where both hop, on a log2 colour scale
    centred on 1 (a ratio, not engine - exact: hop heights across a map span decades, and
    equal colours mean equal factors whatever the height; the lines mark the loose
    tolerance of the verdict's table). Dark grey: the reference hops, the engine does not
    (or did not run); white: the reference does not hop."""
    from matplotlib.colors import Normalize

    grid = map_grid(frame)
    engines = engines_of(frame)
    if not engines:
        raise ValueError("map frame has no engine rows: no hop heights to draw")
    hops = np.isfinite(exact_hop_cells(frame, grid))
    fig, axes = _panels(len(engines), legend=False)
    norm = Normalize(-_RATIO_LIMIT, _RATIO_LIMIT)
    mesh = None
    for ax, engine in zip(axes, engines, strict=True):
        ratio = hop_ratio_cells(frame, engine, grid)
        _fill(ax, grid, hops, _NOT_COMPARED)
        mesh = _mesh(ax, grid, np.log2(ratio), cmap="RdBu_r", norm=norm)
        n = int(np.isfinite(ratio).sum())
        label = _engine_label(frame, engine)
        wrap = "\n" if label != engine else " "  # a step in the label: too long for one line
        title = f"{label}: hops at {n} of {int(hops.sum())} exact hops{wrap}(grey: no hop)"
        ax.set_title(title, fontsize=10)
        if not hops.any():
            _message(ax, "no hop on this map")
        _set_axes(ax, grid)
    assert mesh is not None  # one per engine, and there is one at least
    ticks = np.arange(-_RATIO_LIMIT, _RATIO_LIMIT + 1)
    bar = fig.colorbar(mesh, ax=list(axes), ticks=ticks, extend="both")
    bar.set_ticklabels([f"{2.0**t:g}" if t >= 0 else f"1/{2.0**-t:g}" for t in ticks])
    loose = event_tolerances(Tier.LOOSE).hop_height_rel
    for factor in (1 + loose, 1 - loose):  # the verdict's hop-size rule (loose)
        bar.ax.axhline(math.log2(factor), color="k", lw=1.0)
    # Two lines: on one, the label was longer than the bar and ran off the figure's edge.
    bar.set_label(f"engine / exact hop height\n(lines: loose tolerance, {100 * loose:g} %)")
    return _save(fig, path, key)
