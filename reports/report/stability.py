"""The stability matrix: each engine x scene x timestep cell of a suite, classified.

A cell is the worst thing that happened in its run, with the figure that shows it. The
limits are stated here once; the report's table and heat map read them from this module.
"""

from __future__ import annotations

from enum import StrEnum
from pathlib import Path

import pandas as pd

from hoopbench.engines.judging.verdict import number_or_none
from hoopbench.engines.options import Profile
from hoopbench.reports.compare.selection import default_rows, profile_of
from hoopbench.reports.report.plotting import pyplot, save

__all__ = [
    "ENERGY_GAIN_LIMIT",
    "PENETRATION_LIMIT",
    "Stability",
    "classify",
    "stability_figure",
    "stability_matrix",
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


def stability_figure(runs: pd.DataFrame, out: str | Path) -> Path | None:
    """A heat map of the matrix (rows scene x engine, columns timestep), coloured by class."""
    plt = pyplot()
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Patch

    table = stability_matrix(runs)
    if table.empty:
        return None
    kinds = list(Stability)
    # An engine that runs only some of the suite's timesteps (the batched ones run 1e-3)
    # leaves cells empty: drawn blank, "not run" in the legend.
    codes = table.map(
        lambda cell: kinds.index(Stability(cell.split(":")[0])) if isinstance(cell, str) else None
    ).astype(float)
    fig, ax = plt.subplots(figsize=(2.2 + 1.1 * len(table.columns), 1.0 + 0.28 * len(table)))
    cmap = ListedColormap([_COLOURS[k] for k in kinds])
    cmap.set_bad(_NOT_RUN)
    ax.imshow(
        codes.to_numpy(dtype=float), cmap=cmap, vmin=-0.5, vmax=len(kinds) - 0.5, aspect="auto"
    )
    ax.set_xticks(range(len(table.columns)), [f"{dt:g}" for dt in table.columns])
    ax.set_yticks(range(len(table)), [f"{scene} | {engine}" for scene, engine in table.index])
    ax.set_xlabel("timestep (s)")
    ax.tick_params(labelsize=7)
    values = codes.to_numpy().ravel()
    present = sorted({kinds[int(c)] for c in values if c == c}, key=kinds.index)
    handles = [Patch(color=_COLOURS[k], label=k.value) for k in present]
    if (values != values).any():
        handles.append(Patch(facecolor=_NOT_RUN, edgecolor="#999999", label="not run"))
    ax.legend(
        handles=handles,
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=7,
    )
    ax.set_title("Stability on stiff and extreme scenes (default settings)", fontsize=9)
    fig.tight_layout()
    return save(fig, out, dpi=110)
