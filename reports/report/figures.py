"""Figures: the hoop's path (the seed's Figure 3/5 kind) and engine comparisons."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.models import kinematics
from hoopbench.models.events import Events
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import solve_exact
from hoopbench.reference.seed_euler import solve_seed_euler
from hoopbench.reports.report.palette import (
    HOOP_COLOUR,
    REFERENCE_COLOUR,
    REFERENCE_DASH,
    SPARE_COLOURS,
    WEIGHT_COLOUR,
    engine_colours,
)
from hoopbench.reports.report.plotting import pyplot, save

__all__ = ["events_figure", "hoop_figure", "paths_figure"]


def _solve(scene: Scene, method: str) -> tuple[Trajectory, Events]:
    if method == "exact":
        solution = solve_exact(scene)
        t = np.linspace(0.0, solution.t_final, 2001)
        return solution.sample(t), solution.events
    result = solve_seed_euler(scene)
    return result.trajectory(), result.events


def hoop_figure(
    scene: Scene, out: str | Path, *, method: str = "exact", n_frames: int = 40
) -> Path:
    """Centre-of-mass path with hoop centre, spoke and weight at equal time steps.

    Top: the path in the plane (the seed's Figure 3/5 kind). Bottom: hoop-centre clearance
    y - a and slip velocity against time, with the phases shaded.
    """
    plt = pyplot()
    traj, events = _solve(scene, method)
    x, y = kinematics.centre_position(scene, traj.X, traj.Y, traj.theta)
    fig, (ax, ax2) = plt.subplots(
        2, 1, figsize=(9, 6.5), gridspec_kw={"height_ratios": [2.2, 1]}, constrained_layout=True
    )
    frames = np.linspace(0, len(traj) - 1, n_frames + 1).astype(int)
    ax.axhline(0.0, color="0.3", lw=1.0)
    for i in frames:
        wx = x[i] + scene.a * np.sin(traj.theta[i])
        wy = y[i] + scene.a * np.cos(traj.theta[i])
        ax.plot([x[i], wx], [y[i], wy], color="0.6", lw=0.6)
        ax.plot(wx, wy, "o", mfc="none", mec=WEIGHT_COLOUR, ms=4.5, mew=0.8)
        ax.plot(x[i], y[i], "o", color=WEIGHT_COLOUR, ms=2)
    for i in frames[:: max(1, n_frames // 4)]:
        ax.add_patch(plt.Circle((x[i], y[i]), scene.a, fill=False, color=HOOP_COLOUR, lw=0.6))
    # The exact solution is the reference: its colour in every figure (palette.py).
    path = REFERENCE_COLOUR if method == "exact" else SPARE_COLOURS[0]
    ax.plot(traj.X, traj.Y, color=path, lw=1.5, label="centre of mass")
    ax.plot([], [], "o", mfc="none", mec=WEIGHT_COLOUR, ms=4.5, label="weight")
    ax.plot([], [], "o", color=WEIGHT_COLOUR, ms=2, label="hoop centre")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    title = scene.name or "scene"
    ax.set_title(
        f"{title} ({method}): lam={scene.lam}, chi={scene.chi:.3g}, mus={scene.mus}, "
        f"muk={scene.muk}: {events.outcome}"
    )
    ax.legend(loc="upper right", fontsize=8)

    colours = {"roll": "white", "slip": "tab:orange", "flight": "tab:cyan"}
    for phase in events.phases:
        ax2.axvspan(phase.t_start, phase.t_end, color=colours[str(phase.kind)], alpha=0.25, lw=0)
    # Round-off in y - a (1e-13 m) would fill the axis with noise when nothing lifts off.
    clearance_mm = np.where(np.abs(traj.clearance) < 1e-12, 0.0, traj.clearance) * 1e3
    ax2.plot(traj.t, clearance_mm, color="tab:blue", label="clearance y - a (mm)")
    ax2.set_ylim(min(clearance_mm.min(), 0.0) - 0.05, max(clearance_mm.max(), 1.0) * 1.05)
    ax2.set_xlabel("t (s)")
    ax2.set_ylabel("clearance (mm)", color="tab:blue")
    ax3 = ax2.twinx()
    ax3.plot(traj.t, traj.slip_velocity, color="tab:orange", lw=1.0, label="slip velocity")
    ax3.set_ylabel("slip velocity (m/s)", color="tab:orange")
    ax2.set_title("phases: white roll, orange slip, cyan flight", fontsize=9)
    Path(out).parent.mkdir(parents=True, exist_ok=True)
    return save(fig, out, dpi=110)


def events_figure(
    runs: Mapping[str, Trajectory],
    out: str | Path,
    *,
    title: str,
    t_window: tuple[float, float] | None = None,
) -> Path:
    """Hoop-centre clearance and slip velocity against time, several engines on one scene,
    around its events (``t_window``, s)."""
    plt = pyplot()
    fig, (top, bottom) = plt.subplots(
        2, 1, figsize=(9.2, 5.6), sharex=True, constrained_layout=True
    )
    colours = engine_colours(runs)
    for label, traj in runs.items():
        mask: slice | np.ndarray = slice(None)
        if t_window is not None:
            mask = (traj.t >= t_window[0]) & (traj.t <= t_window[1])
        # The reference dashed and on top, so that an engine on it shows under the dashes.
        style = {"ls": REFERENCE_DASH, "zorder": 3} if label == REFERENCE_ENGINE else {}
        colour = colours[label]
        top.plot(traj.t[mask], traj.clearance[mask] * 1e3, label=label, lw=1.2, c=colour, **style)
        bottom.plot(traj.t[mask], traj.slip_velocity[mask], label=label, lw=1.0, c=colour, **style)
    top.axhline(0.0, color="0.3", lw=0.8)
    bottom.axhline(0.0, color="0.3", lw=0.8)
    top.set_ylabel("clearance y - a (mm)")
    bottom.set_ylabel("slip velocity (m/s)")
    bottom.set_xlabel("t (s)")
    top.set_title(title)
    # Beside the panels, not on them: the curves fill the window wherever a scene's events
    # fall, and matplotlib's "best" place searched every point of every curve on each draw
    # (1.3 CPU-s over the report's eight figures, with a warning on a slow machine).
    top.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    return save(fig, out, dpi=110)


def _spokes(ax, scene: Scene, traj: Trajectory, x: NDArray, y: NDArray, i: NDArray) -> None:
    """The hoop's centre, spoke and weight at the samples ``i`` (hoop centre ``x``, ``y``, m).

    One line for the slanted spokes (broken by NaN), one a plumb or level spoke, one for the
    weights and one for the centres: not three artists a sample (75 a panel), a fifth of
    the artists to make, lay out and draw. A plumb or level spoke keeps its own line: Agg
    snaps a path to the pixel grid only when all of it is plumb or level. Every spoke now
    lies under every mark (a later spoke crossed an earlier weight's circle on top): a few
    pixels differ from drawing them sample by sample, the picture does not."""
    wx = x[i] + scene.a * np.sin(traj.theta[i])
    wy = y[i] + scene.a * np.cos(traj.theta[i])
    square = (wx == x[i]) | (wy == y[i])
    for k in np.flatnonzero(square):
        ax.plot([x[i][k], wx[k]], [y[i][k], wy[k]], color="0.6", lw=0.5)
    slant = ~square
    gap = np.full(int(slant.sum()), np.nan)
    ax.plot(
        np.column_stack([x[i][slant], wx[slant], gap]).ravel(),
        np.column_stack([y[i][slant], wy[slant], gap]).ravel(),
        color="0.6",
        lw=0.5,
    )
    ax.plot(wx, wy, "o", mfc="none", mec=WEIGHT_COLOUR, ms=3.5, mew=0.8)
    ax.plot(x[i], y[i], "o", color=WEIGHT_COLOUR, ms=1.5)


def paths_figure(
    scene: Scene,
    runs: Mapping[str, Trajectory],
    out: str | Path,
    *,
    n_frames: int = 24,
    note: str = "",
) -> Path:
    """Each engine's centre-of-mass path with its hoop centre and weight at equal time steps
    (the seed's Figure 3 kind), over the reference's path (black, dashed), one panel per
    engine; ``note`` (the runs' timesteps) ends the title."""
    plt = pyplot()
    reference = runs.get("reference")
    engines = [name for name in runs if name != REFERENCE_ENGINE] or list(runs)
    fig, axes = plt.subplots(
        len(engines), 1, figsize=(9, 2.6 * len(engines)), squeeze=False, constrained_layout=True
    )
    for ax, name in zip(axes[:, 0], engines, strict=True):
        traj = runs[name]
        if reference is not None:  # on top, dashed: an engine on it shows under the dashes
            ax.plot(reference.X, reference.Y, color=REFERENCE_COLOUR, ls=REFERENCE_DASH, lw=1.0,
                    label="reference", zorder=3)  # fmt: skip
        x, y = kinematics.centre_position(scene, traj.X, traj.Y, traj.theta)
        _spokes(ax, scene, traj, x, y, np.linspace(0, len(traj) - 1, n_frames + 1).astype(int))
        colour = engine_colours([name])[name]
        ax.plot(traj.X, traj.Y, color=colour, lw=1.2, label=f"{name}: centre of mass")
        ax.axhline(0.0, color="0.3", lw=0.8)
        ax.set_aspect("equal")
        ax.set_ylabel("y (m)")
        ax.legend(loc="upper right", fontsize=7)
    axes[-1, 0].set_xlabel("x (m)")
    axes[0, 0].set_title(
        f"{scene.name}: paths at equal time steps (circle: weight, dot: hoop centre)"
        + (f"\n{note}" if note else ""),
        fontsize=9,
    )
    return save(fig, out, dpi=100)
