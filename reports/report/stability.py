"""The stability matrix: each engine x scene x timestep cell of a suite, classified.

A cell is the worst thing that happened in its run, with the figure that shows it. The
limits are stated here once; the report's table and heat map read them from this module.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path

import numpy as np
import pandas as pd

from hoopbench.engines.judging.verdict import number_or_none
from hoopbench.engines.options import Profile
from hoopbench.reports.compare.selection import default_rows, profile_of
from hoopbench.reports.report.plotting import pyplot, save

__all__ = [
    "ENERGY_GAIN_LIMIT",
    "PENETRATION_LIMIT",
    "MatrixPanels",
    "Stability",
    "classify",
    "matrix_panels",
    "present_classes",
    "stability_figure",
    "stability_matrix",
    "timestep_label",
]

ENERGY_GAIN_LIMIT = 0.01
"""Energy rise before the first slip, as a fraction of the initial energy, that counts as a
gain: rolling conserves energy, and the tuned engines stay below 1e-4 on the catalogue."""

PENETRATION_LIMIT = 0.01
"""Penetration of the floor, as a fraction of the hoop radius, that counts as deep: 1 cm on
a 1 m hoop, ten times the largest penetration of a tuned engine on the catalogue scenes."""


class Stability(StrEnum):
    """Cell classes, worst first (a run that is several things shows the first)."""

    CRASHED = "crashed"
    TIMEOUT = "timeout"
    FAILED = "failed"
    DIVERGED = "diverged"
    ENERGY_GAIN = "energy gain"
    DEEP_PENETRATION = "deep penetration"
    WRONG_OUTCOME = "wrong outcome"
    OK = "ok"


_COLOURS = {
    Stability.CRASHED: "#000000",
    Stability.TIMEOUT: "#555555",
    Stability.FAILED: "#999999",
    Stability.DIVERGED: "#b2182b",
    Stability.ENERGY_GAIN: "#ef8a62",
    Stability.DEEP_PENETRATION: "#fddbc7",
    Stability.WRONG_OUTCOME: "#f4e04d",
    Stability.OK: "#4dac26",
}


_NOT_RUN = "#ffffff"
"""A cell whose engine did not run at that timestep."""


def classify(row: pd.Series | dict) -> tuple[Stability, str]:
    """The class of one run's row and the figure behind it (a short text)."""
    status = str(row.get("status"))
    message = str(row.get("message") or "")
    if status in ("crashed", "timeout"):
        return Stability(status), message[:60]
    if status in ("error", "unavailable"):
        return Stability.FAILED, message[:60]
    if status == "diverged":
        return Stability.DIVERGED, message[:60]
    rise = number_or_none(row.get("energy_rise_before_slip"))
    if rise is not None and rise > ENERGY_GAIN_LIMIT:
        return Stability.ENERGY_GAIN, f"energy +{100 * rise:.3g} %"
    depth, a = number_or_none(row.get("max_penetration_m")), number_or_none(row.get("a"))
    if depth is not None and a and depth > PENETRATION_LIMIT * a:
        return Stability.DEEP_PENETRATION, f"{100 * depth / a:.3g} % of a"
    verdict = row.get("verdict")
    if isinstance(verdict, str) and verdict:
        # The outcome, not the phase sequence: a stable run may still miss a re-stick.
        wrong = verdict not in ("agrees", "wrong-phases")
        what = verdict
    else:  # results written before the verdict column existed
        agrees = row.get("outcome_agrees")
        wrong = agrees is not None and not pd.isna(agrees) and not bool(agrees)
        what = f"{row.get('outcome')} (exact {row.get('exact_outcome')})"
    if wrong:
        return Stability.WRONG_OUTCOME, what
    return Stability.OK, ""


def stability_matrix(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per (scene, engine), one column per timestep: 'class: figure' cells.

    Only each engine's default settings count (the variant 'default'), stock and tuned
    profiles as separate rows when both ran.
    """
    runs = default_rows(runs)
    if runs.empty:
        return pd.DataFrame()
    profile = profile_of(runs)
    cells = runs.assign(
        cell=[_cell(*classify(row)) for _, row in runs.iterrows()],
        engine=[
            e if p == Profile.TUNED else f"{e} ({p})"
            for e, p in zip(runs["engine"], profile, strict=True)
        ],
    )
    table = cells.pivot_table(
        index=["scene", "engine"], columns="timestep", values="cell", aggfunc="first"
    )
    scenes = list(dict.fromkeys(runs["scene"]))
    engines = list(dict.fromkeys(cells["engine"]))
    order = [(s, e) for s in scenes for e in engines if (s, e) in table.index]
    table = table.reindex(order)
    return table[sorted(table.columns, reverse=True)]


def _cell(kind: Stability, figure: str) -> str:
    return kind.value if not figure else f"{kind.value}: {figure}"


def timestep_label(dt: float) -> str:
    """A timestep as a column label short enough for a cell: 0.01, 0.001, 1e-4, 2.5e-5 (s)."""
    if dt >= 1e-3:
        return f"{dt:g}"
    mantissa, exponent = f"{dt:.6e}".split("e")
    return f"{mantissa.rstrip('0').rstrip('.')}e{int(exponent)}"


@dataclass(frozen=True)
class MatrixPanels:
    """The matrix as small multiples, the PNG's and the page's: a panel per scene, each with
    the same rows (every engine of the matrix, in its order) and columns (timesteps, coarse
    to fine), so that a row or a column reads the same across panels."""

    scenes: tuple[str, ...]
    engines: tuple[str, ...]
    timesteps: tuple[float, ...]
    codes: Mapping[str, np.ndarray]
    """Per scene, (engines x timesteps) index into list(Stability); NaN where not run."""
    cells: Mapping[str, tuple[tuple[str, ...], ...]]
    """Per scene, each cell's text ('class: figure'; '' where not run)."""
    columns: int
    """Panels per row."""


PANEL_CELLS_PER_ROW = 20
"""Timestep columns across the figure (all panels of a row): four timesteps, five panels."""


def matrix_panels(table: pd.DataFrame) -> MatrixPanels:
    """The panels of a :func:`stability_matrix` table (non-empty)."""
    kinds = list(Stability)
    scenes = tuple(dict.fromkeys(str(s) for s, _ in table.index))
    engines = tuple(dict.fromkeys(str(e) for _, e in table.index))
    timesteps = tuple(float(dt) for dt in table.columns)
    codes: dict[str, np.ndarray] = {}
    cells: dict[str, tuple[tuple[str, ...], ...]] = {}
    for scene in scenes:
        rows = table.xs(scene, level=0).reindex(list(engines))
        text = rows.astype(object).where(rows.notna(), "")
        cells[scene] = tuple(tuple(str(c) for c in row) for row in text.to_numpy())
        codes[scene] = np.array(
            [[kinds.index(Stability(c.split(":")[0])) if c else np.nan for c in row]
             for row in cells[scene]],
            dtype=float,
        )  # fmt: skip
    columns = max(1, min(len(scenes), PANEL_CELLS_PER_ROW // max(1, len(timesteps))))
    return MatrixPanels(scenes, engines, timesteps, codes, cells, columns)


def present_classes(panels: MatrixPanels) -> tuple[list[Stability], bool]:
    """The classes the panels show, worst first, and whether a cell is blank (not run)."""
    kinds = list(Stability)
    values = np.concatenate([c.ravel() for c in panels.codes.values()])
    present = sorted({kinds[int(c)] for c in values if c == c}, key=kinds.index)
    return present, bool(np.isnan(values).any())


def stability_figure(runs: pd.DataFrame, out: str | Path) -> Path | None:
    """The matrix (:func:`matrix_panels`) as a heat map per scene, coloured by class, each
    panel's timesteps on top, the engines on the left of each row of panels."""
    plt = pyplot()
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    table = stability_matrix(runs)
    if table.empty:
        return None
    panels = matrix_panels(table)
    kinds = list(Stability)
    n_rows = -(-len(panels.scenes) // panels.columns)
    cell_w, cell_h = 0.34, 0.2  # inches
    width = 1.3 + panels.columns * (cell_w * len(panels.timesteps) + 0.15) + 1.7
    panel_h = cell_h * len(panels.engines)
    height = 0.5 + n_rows * (panel_h + 0.75)
    fig, axes = plt.subplots(
        n_rows, panels.columns, figsize=(width, height), squeeze=False, sharey=True
    )
    fig.subplots_adjust(
        left=1.3 / width,
        right=1.0 - 1.7 / width,
        top=1.0 - 0.95 / height,
        bottom=0.15 / height,
        wspace=0.15 / (cell_w * len(panels.timesteps)),
        hspace=0.75 / panel_h,
    )
    cmap = ListedColormap([_COLOURS[k] for k in kinds]).with_extremes(bad=_NOT_RUN)
    labels = [timestep_label(dt) for dt in panels.timesteps]
    for ax, scene in zip(axes.ravel(), panels.scenes, strict=False):
        ax.imshow(
            np.ma.masked_invalid(panels.codes[scene]), cmap=cmap, vmin=-0.5,
            vmax=len(kinds) - 0.5, aspect="auto",
        )  # fmt: skip
        # The timesteps on top of every panel: a column reads on screen without scrolling.
        ax.xaxis.tick_top()
        ax.set_xticks(range(len(labels)), labels, fontsize=7)
        ax.set_yticks(range(len(panels.engines)), panels.engines, fontsize=7)
        ax.tick_params(length=0)
        ax.set_xticks(np.arange(len(labels) + 1) - 0.5, minor=True)
        ax.set_yticks(np.arange(len(panels.engines) + 1) - 0.5, minor=True)
        ax.grid(which="minor", color="white", lw=0.8)
        ax.tick_params(which="minor", length=0)
        ax.set_title(scene, fontsize=9, pad=14)
    for ax in axes.ravel()[len(panels.scenes) :]:
        ax.set_visible(False)
    present, blank = present_classes(panels)
    handles = [Patch(color=_COLOURS[k], label=k.value) for k in present]
    if blank:
        handles.append(Patch(facecolor=_NOT_RUN, edgecolor="#999999", label="not run"))
    fig.legend(handles=handles, loc="upper right", fontsize=8, frameon=False)
    fig.suptitle(
        "Stability on stiff and extreme scenes (default settings): a panel per scene, "
        "timestep (s) across the top",
        fontsize=10,
        x=1.3 / width,
        ha="left",
    )
    return save(fig, out, dpi=110)
