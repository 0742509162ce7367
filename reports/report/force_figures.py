"""The contact-force figure: each engine's n/g and |f|/(mu n) against time over the exact ones.

One PNG, a column per scene (seed-mu and hop-top in the report), two rows: the normal force
per unit mass over g, and the friction's share of the Coulomb cone, |f|/(mu n) (1 on the cone:
slipping; below 1: rolling; above 1: outside the cone). The exact curves are the reference
solver's for the scene and the runs' mu.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import solve_exact
from hoopbench.reports.report.palette import REFERENCE_COLOUR, REFERENCE_DASH, engine_colours
from hoopbench.reports.report.plotting import pyplot, save

__all__ = ["ForcePanel", "force_figure"]

CONE_YLIM = (0.0, 1.6)
"""|f|/(mu n) shown from 0 to 1.6: the cone is 1, and a re-stick impulse would flatten the rest."""


@dataclass(frozen=True)
class ForcePanel:
    """One scene's column of the figure: the scene, the runs' mu, each engine's trajectory."""

    name: str
    scene: Scene
    mu: float
    runs: Mapping[str, Trajectory]
    timesteps: Mapping[str, float] = field(default_factory=dict)
    """s, by engine: the runs drawn at another timestep than the default (the legend says)."""

    def label(self, engine: str) -> str:
        """An engine's legend entry: its name, and its timestep where it is not the default."""
        dt = self.timesteps.get(engine)
        return engine if dt is None else f"{engine} (dt {dt:g} s)"


def _cone_share(n: NDArray, f: NDArray, mu: float) -> NDArray:
    """|f|/(mu n) where there is a normal force, NaN elsewhere (a gap in the curve)."""
    share = np.full(len(n), np.nan)
    touching = n > 0
    share[touching] = np.abs(f[touching]) / (mu * n[touching])
    return share


def _draw_panel(top, bottom, panel: ForcePanel) -> None:
    solution = solve_exact(panel.scene.with_(mus=panel.mu, muk=panel.mu))
    g = panel.scene.g
    exact = solution.sample(np.linspace(0.0, solution.t_final, 4001))
    t_end = solution.t_final
    colours = engine_colours(panel.runs)
    for label, traj in panel.runs.items():
        keep = traj.t <= t_end
        t, n, f = traj.t[keep], traj.normal_force[keep], traj.friction_force[keep]
        name = panel.label(label)
        top.plot(t, n / g, label=name, lw=0.8, alpha=0.8, color=colours[label])
        share = _cone_share(n, f, panel.mu)
        bottom.plot(t, share, label=name, lw=0.8, alpha=0.8, color=colours[label])
    exact_style = {"color": REFERENCE_COLOUR, "ls": REFERENCE_DASH}
    top.plot(exact.t, exact.normal_force / g, **exact_style, lw=1.2, label="exact")
    bottom.plot(
        exact.t,
        _cone_share(exact.normal_force, exact.friction_force, panel.mu),
        **exact_style,
        lw=1.2,
        label="exact",
    )
    peak = float(np.nanmax(exact.normal_force / g))
    top.set_yscale("symlog", linthresh=2.0)  # the 1 g of rolling and the re-stick's peak
    top.set_ylim(-0.5, 1.5 * peak + 1.0)
    bottom.set_ylim(*CONE_YLIM)
    bottom.axhline(1.0, color="0.4", lw=0.6)
    top.set_title(f"{panel.name} (mu = {panel.mu:g})")
    top.set_ylabel("n / g")
    bottom.set_ylabel("|f| / (mu n)")
    bottom.set_xlabel("t (s)")


def force_figure(panels: list[ForcePanel], out: str | Path) -> Path:
    """The figure (module doc), one column per panel, to ``out``."""
    plt = pyplot()
    fig, axes = plt.subplots(
        2,
        len(panels),
        figsize=(6.5 * len(panels), 6.4),
        squeeze=False,
        sharex="col",
        constrained_layout=True,
    )
    for column, panel in enumerate(panels):
        _draw_panel(axes[0, column], axes[1, column], panel)
    # One legend below the panels, not on them: the forces fill each panel's window, and
    # matplotlib's "best" place searched every sample on each draw (about 1 CPU-s).
    entries: dict[str, Any] = {}
    for ax in axes[0]:
        for handle, label in zip(*ax.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    fig.legend(entries.values(), entries.keys(), loc="outside lower center", ncol=6, fontsize=8)
    return save(fig, out, dpi=110)
