"""Work against precision: every run's error on each event against its stepping time, the
process's CPU time where the rows carry it (the answer's clock: the machine's load moves it
far less than the wall time, which drew and ranked these before), else the wall time.

One curve per settings family (engine, profile, variant) with the timesteps along it, the
Pareto front over all runs (no cheaper run is as accurate), and the cheapest run that meets
each stated accuracy. The reference is one point at its own solve time: its error is zero
against itself, which a log axis cannot show, so it is drawn on the panel's bottom edge
(:func:`error_floor`, a decade below the smallest error drawn) and labelled "error 0".
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.score import CostClock
from hoopbench.engines.judging.tolerances import Tier, event_tolerances
from hoopbench.reports.compare.selection import (
    default_rows,
    engine_rows,
    ok_rows,
    profile_of,
    reference_rows,
    run_cost_clock,
)
from hoopbench.reports.report.palette import (
    FRONT_ALPHA,
    FRONT_COLOUR,
    FRONT_WIDTH,
    REFERENCE_COLOUR,
    engine_colours,
    profile_style,
)
from hoopbench.reports.report.plotting import pyplot, save

__all__ = [
    "COST",
    "FLOOR",
    "METRICS",
    "ZERO_LABEL",
    "Metric",
    "cheapest_runs",
    "cost_label",
    "error_floor",
    "figure_panels",
    "metric_runs",
    "pareto_front",
    "precision_figure",
]


@dataclass(frozen=True)
class Metric:
    """An error column of the runs table, with the accuracy a user would ask for."""

    column: str
    label: str
    unit: str
    target: float
    """The accuracy of the "cheapest run within" table, in the column's unit."""
    scenes: str
    """Which scenes the metric is read on: 'slip' (exact slip) or 'hop' (exact hop)."""


_TIGHT = event_tolerances(Tier.TIGHT)

METRICS: tuple[Metric, ...] = (
    Metric("err_t_slip_ms", "slip-onset time", "ms", 1e3 * _TIGHT.t_slip, "slip"),
    Metric("err_theta_slip_deg", "slip-onset angle", "deg", 0.2, "slip"),
    Metric("err_t_lift_ms", "lift-off time", "ms", 1e3 * _TIGHT.t_lift, "hop"),
    Metric("err_hop_height_rel", "hop height", "relative", _TIGHT.hop_height_rel, "hop"),
    Metric("err_t_impact_ms", "impact time", "ms", 1e3 * _TIGHT.t_impact, "hop"),
    Metric("rms_position_m", "trajectory RMS (hoop centre)", "m", 0.01, "slip"),
)
"""The targets: the event times and the hop height are the verdict's tight tolerances (the
one table, engines/judging/tolerances.toml, 1 m hoop, before the timestep's share); 0.2 deg
is the slip angle a 2 ms onset error moves it by at the seed's spin; 1 cm is 1 % of the
hoop radius on the catalogue's 1 m hoops."""

FIGURE_SCENES = ("seed-mu", "hop-top", "hop-bottom")
"""Scenes the figure prefers, in order, for each metric."""

COST = "cost_s"
"""A panel's runs' column: each run's stepping time by the runs' clock
(:func:`~hoopbench.reports.compare.selection.run_cost_clock`), s."""

FLOOR = 1e-6
"""A panel's bottom edge when it has no error above zero (:func:`error_floor`)."""

ZERO_LABEL = "error 0"
"""Beside a point drawn on a panel's bottom edge: its error is zero, not the edge's value."""


def error_floor(errors: pd.Series) -> float:
    """A log panel's bottom edge: the power of ten a decade below its smallest error above
    zero (FLOOR if there is none). An error of zero (the reference's against itself) is drawn
    there, on the edge, labelled; no error above zero is below it."""
    positive = pd.to_numeric(errors, errors="coerce")
    positive = positive[positive > 0]
    if positive.empty:
        return FLOOR
    return float(10.0 ** (np.floor(np.log10(float(positive.min()))) - 1))


def _family(frame: pd.DataFrame) -> pd.Series:
    profile = profile_of(frame)
    return frame["engine"] + " " + profile.astype(str) + " " + frame["variant"]


def cost_label(clock: CostClock) -> str:
    """The time axis's words for runs timed by ``clock``."""
    return f"{clock.label} time of the run's stepping (s)"


def _metric_runs(runs: pd.DataFrame, metric: Metric, scene: str) -> pd.DataFrame:
    """The runs of a scene with a measured error and a time by the clock of ``runs``:
    |error| in ``error``, the time in :data:`COST`."""
    cost = pd.to_numeric(runs[run_cost_clock(runs).column], errors="coerce")
    rows = runs.assign(**{COST: cost})
    rows = rows[(rows["scene"] == scene) & rows[COST].notna()]
    rows = ok_rows(rows[rows[metric.column].notna()])
    return rows.assign(error=rows[metric.column].astype(float).abs(), family=_family(rows))


def pareto_front(points: pd.DataFrame) -> pd.DataFrame:
    """The runs no cheaper run beats: sorted by :data:`COST`, each more accurate than all
    before."""
    ordered = points.sort_values([COST, "error"])
    best = np.minimum.accumulate(ordered["error"].to_numpy())
    if not len(ordered):
        return ordered  # no engine measured this event: an empty front, its columns kept
    keep = np.r_[True, ordered["error"].to_numpy()[1:] < best[:-1]]
    return ordered[keep]


def _scenes(runs: pd.DataFrame, metric: Metric) -> list[str]:
    column = "exact_t_slip" if metric.scenes == "slip" else "exact_t_lift"
    has = runs[runs[column].notna()]["scene"]
    return list(dict.fromkeys(has))


def cheapest_runs(runs: pd.DataFrame) -> pd.DataFrame:
    """Per metric and scene: the cheapest engine run within the metric's target, if any."""
    engines = engine_rows(runs)
    rows = []
    for metric in METRICS:
        for scene in _scenes(engines, metric):
            points = _metric_runs(engines, metric, scene)
            good = points[points["error"] <= metric.target].sort_values([COST, "error"])
            row: dict[str, Any] = {
                "metric": metric.label,
                "scene": scene,
                "target": f"{metric.target:g} {metric.unit}",
            }
            if len(good):
                best = good.iloc[0]
                row.update(
                    run=f"{best['family']} dt={best['timestep']:g}",
                    **{COST: best[COST]},
                    error=best["error"],
                )
            else:
                row.update(run="none within the target", **{COST: None}, error=None)
            rows.append(row)
    return pd.DataFrame(rows)


def figure_panels(runs: pd.DataFrame) -> list[tuple[Metric, str]]:
    """The figure's panels, (metric, scene), of the default-settings ``runs``. One scene per
    metric keeps the figure readable (the table covers every scene): the cross-engine slip
    scene for slips, the first hop scene for hops."""
    panels = []
    for metric in METRICS:
        scenes = [s for s in _scenes(runs, metric) if len(_metric_runs(runs, metric, s))]
        preferred = [s for s in FIGURE_SCENES if s in scenes] or scenes
        panels += [(metric, preferred[0])] if preferred else []
    return panels


def metric_runs(runs: pd.DataFrame, metric: Metric, scene: str) -> pd.DataFrame:
    """The runs of one panel: those of ``scene`` with a measured error and a time, with
    |error| in ``error``, the time in :data:`COST` and the settings family (engine,
    profile, variant) in ``family``."""
    return _metric_runs(runs, metric, scene)


def precision_figure(runs: pd.DataFrame, out: str | Path) -> Path | None:
    """One panel per (metric, scene): error against the runs' time, families and the front."""
    plt = pyplot()
    runs = default_rows(runs)
    panels = figure_panels(runs)
    if not panels:
        return None
    cols = 3
    nrows = -(-len(panels) // cols)
    fig, axes = plt.subplots(
        nrows, cols, figsize=(5.0 * cols, 3.8 * nrows), squeeze=False, constrained_layout=True
    )
    colours = engine_colours(engine_rows(runs)["engine"])  # one colour an engine, every panel
    clock = run_cost_clock(runs)
    profiles: set[str] = set()
    for ax, (metric, scene) in zip(axes.ravel(), panels, strict=False):
        points = _metric_runs(runs, metric, scene)
        engines = engine_rows(points)
        floor = error_floor(engines["error"])
        profiles |= set(engines["profile"].astype(str))
        for family, group in engines.groupby("family", sort=True):
            group = group.sort_values(COST)
            style = profile_style(str(group["profile"].iloc[0]))
            ax.plot(
                group[COST],
                group["error"].clip(lower=floor),  # a zero on the edge: none is below
                color=colours[str(group["engine"].iloc[0])],
                ls=style.matplotlib_dash,
                marker=style.marker,
                ms=3,
                lw=1,
                label=family,
            )
        reference = reference_rows(runs[runs["scene"] == scene])
        if len(reference):
            _zero_point(ax, float(reference[clock.column].min()), floor)
        front = pareto_front(engines)
        ax.step(
            front[COST],
            front["error"].clip(lower=floor),
            where="post",
            color=FRONT_COLOUR,
            alpha=FRONT_ALPHA,
            lw=FRONT_WIDTH,
            solid_capstyle="butt",
            zorder=1,  # under the runs it joins
            label="Pareto front",
        )
        ax.axhline(metric.target, color="grey", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(bottom=floor)
        ax.set_xlabel(cost_label(clock))
        ax.set_ylabel(f"|error| ({metric.unit})")
        ax.set_title(f"{scene}: {metric.label}", fontsize=9)
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    fig.legend(
        handles=_legend_handles(colours, sorted(profiles)),
        loc="outside lower center",
        ncol=6,
        fontsize=8,
    )
    return save(fig, out, dpi=100)


def _zero_point(ax, time_s: float, floor: float) -> None:
    """The exact reference's star: error zero, on the panel's bottom edge (``floor``), not
    clipped by it, and labelled so (a log axis has no zero)."""
    ax.plot(time_s, floor, "*", color=REFERENCE_COLOUR, ms=11, clip_on=False, zorder=5)
    ax.annotate(ZERO_LABEL, (time_s, floor), xytext=(7, 4), textcoords="offset points",
                fontsize=7, va="bottom")  # fmt: skip


def _legend_handles(colours: dict[str, str], profiles: list[str]) -> list:
    """One legend for the figure: an entry per engine (its colour), per profile (its line
    style and marker), the reference, the front and the target."""
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=colour, lw=2, label=name) for name, colour in colours.items()]
    for profile in profiles:
        style = profile_style(profile)
        handles.append(
            Line2D([], [], color="0.35", ls=style.matplotlib_dash, marker=style.marker, ms=4,
                   label=profile)
        )  # fmt: skip
    handles += [
        Line2D(
            [],
            [],
            color=REFERENCE_COLOUR,
            marker="*",
            ls="",
            ms=9,
            label="exact reference (error 0: on the bottom edge)",
        ),
        Line2D(
            [],
            [],
            color=FRONT_COLOUR,
            alpha=FRONT_ALPHA,
            lw=FRONT_WIDTH,
            label="Pareto front (no cheaper run as accurate)",
        ),
        Line2D([], [], color="grey", ls=":", lw=0.8, label="target of the cheapest-run table"),
    ]
    return handles
