"""Work against precision: every run's error on each event against its wall time.

One curve per settings family (engine, profile, variant) with the timesteps along it, the
Pareto front over all runs (no cheaper run is as accurate), and the cheapest run that meets
each stated accuracy. The reference is one point at its own solve time: its error is zero
against itself, drawn at the bottom of the axis.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.tolerances import Tier, event_tolerances
from hoopbench.reports.compare.selection import (
    default_rows,
    engine_rows,
    ok_rows,
    profile_of,
    reference_rows,
)
from hoopbench.reports.report.plotting import pyplot, save_figure

__all__ = [
    "FLOOR",
    "METRICS",
    "Metric",
    "cheapest_runs",
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

FLOOR = 1e-6
"""Where an error of exactly zero (the reference against itself) is drawn on log axes."""


def _family(frame: pd.DataFrame) -> pd.Series:
    profile = profile_of(frame)
    return frame["engine"] + " " + profile.astype(str) + " " + frame["variant"]


def _metric_runs(runs: pd.DataFrame, metric: Metric, scene: str) -> pd.DataFrame:
    """The runs of a scene with a measured error and a wall time, |error| in ``error``."""
    rows = runs[(runs["scene"] == scene) & runs["wall_time_s"].notna()]
    rows = ok_rows(rows[rows[metric.column].notna()])
    return rows.assign(error=rows[metric.column].astype(float).abs(), family=_family(rows))


def pareto_front(points: pd.DataFrame) -> pd.DataFrame:
    """The runs no cheaper run beats: sorted by wall time, each more accurate than all before."""
    ordered = points.sort_values(["wall_time_s", "error"])
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
            good = points[points["error"] <= metric.target].sort_values("wall_time_s")
            row: dict[str, Any] = {
                "metric": metric.label,
                "scene": scene,
                "target": f"{metric.target:g} {metric.unit}",
            }
            if len(good):
                best = good.iloc[0]
                row.update(
                    run=f"{best['family']} dt={best['timestep']:g}",
                    wall_time_s=best["wall_time_s"],
                    error=best["error"],
                )
            else:
                row.update(run="none within the target", wall_time_s=None, error=None)
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
    """The runs of one panel: those of ``scene`` with a measured error and a wall time, with
    |error| in ``error`` and the settings family (engine, profile, variant) in ``family``."""
    return _metric_runs(runs, metric, scene)


def precision_figure(runs: pd.DataFrame, out: str | Path) -> Path | None:
    """One panel per (metric, scene): error against wall time, families and the front."""
    plt = pyplot()
    from matplotlib.ticker import NullFormatter

    runs = default_rows(runs)
    panels = figure_panels(runs)
    if not panels:
        return None
    cols = 3
    nrows = -(-len(panels) // cols)
    fig, axes = plt.subplots(
        nrows, cols, figsize=(5.0 * cols, 3.8 * nrows), squeeze=False, constrained_layout=True
    )
    for ax, (metric, scene) in zip(axes.ravel(), panels, strict=False):
        points = _metric_runs(runs, metric, scene)
        engines = engine_rows(points)
        for family, group in engines.groupby("family", sort=True):
            group = group.sort_values("wall_time_s")
            ax.plot(
                group["wall_time_s"],
                group["error"].clip(lower=FLOOR),
                "o-",
                ms=3,
                lw=1,
                label=family,
            )
        reference = reference_rows(runs[runs["scene"] == scene])
        if len(reference):
            ax.plot(reference["wall_time_s"].min(), FLOOR, "k*", ms=10, label="exact reference")
        front = pareto_front(engines)
        ax.step(
            front["wall_time_s"],
            front["error"].clip(lower=FLOOR),
            "k--",
            where="post",
            lw=1.2,
            label="Pareto front",
        )
        ax.axhline(metric.target, color="grey", lw=0.8, ls=":")
        ax.set_xscale("log")
        ax.set_yscale("log")
        # A narrow range labels its minor ticks too, and they overlap: majors only.
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("wall time of the run (s)")
        ax.set_ylabel(f"|error| ({metric.unit})")
        ax.set_title(f"{scene}: {metric.label}", fontsize=9)
        ax.legend(fontsize=5, loc="best")
    for ax in axes.ravel()[len(panels) :]:
        ax.set_visible(False)
    out = Path(out)
    save_figure(fig, out, dpi=100)
    plt.close(fig)
    return out
