"""The seed reproduced: its printed numbers beside the exact solver and the seed's own scheme.

The seed's small hop is an artefact of its contact tolerance delta: the scheme's hop height
falls with delta, and the exact solver finds no lift-off at all. This module computes the
tables and the figure that show it; the report prints them (a few tenths of a second).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from hoopbench.models.scene import Scene
from hoopbench.reference.exact import solve_exact
from hoopbench.reference.seed_euler import solve_seed_euler
from hoopbench.reference.seed_published import (
    SEED_DELTA_TABLE,
    SEED_DT_TABLE,
    SEED_PARAMETERS,
    SEED_T_SLIP,
)
from hoopbench.reports.report.plotting import pyplot, save

__all__ = ["delta_figure", "delta_table", "onset_table", "seed_scene", "timestep_table"]

DELTAS = tuple(float(d) for d in np.logspace(-5, -1.5, 8))
"""Contact tolerances of the figure, m: from well below to above the seed's range."""


def seed_scene() -> Scene:
    p = SEED_PARAMETERS
    return Scene.from_chi(
        p["chi"], name="seed", lam=p["lam"], eps=p["eps"], mus=p["mus"], muk=p["muk"]
    )


def onset_table() -> pd.DataFrame:
    """Slip onset, lift-off and outcome: the seed's print, the exact solver."""
    exact = solve_exact(seed_scene()).events
    assert exact.theta_slip is not None  # the seed scene slips
    return pd.DataFrame(
        [
            {"source": "seed (printed)", "t_slip": SEED_T_SLIP, "outcome": "hops (small)"},
            {
                "source": "exact reference",
                "t_slip": exact.t_slip,
                "theta_slip_deg": math.degrees(exact.theta_slip),
                "thetadot_slip": exact.thetadot_slip,
                "outcome": str(exact.outcome),
                "phases": exact.phase_code,
            },
        ]
    )


def timestep_table() -> pd.DataFrame:
    """The seed's timestep table (delta = 1e-4): its steps and lift-off against this port's."""
    rows = []
    for dt, (steps, t_hop) in SEED_DT_TABLE.items():
        ours = solve_seed_euler(seed_scene(), dt=dt, delta=1e-4)
        rows.append(
            {
                "dt": dt,
                "seed steps": steps,
                "steps": ours.n_steps,
                "seed t_hop": t_hop,
                "t_hop": ours.events.t_lift,
            }
        )
    return pd.DataFrame(rows)


def delta_table() -> pd.DataFrame:
    """The seed's delta table (dt = 0.002): its steps and hop heights against this port's."""
    rows = []
    for delta, printed in SEED_DELTA_TABLE.items():
        ours = solve_seed_euler(seed_scene(), dt=0.002, delta=delta)
        rows.append(
            {
                "delta": delta,
                "seed steps": printed["steps"],
                "steps": ours.n_steps,
                "seed hop": printed["hop"],
                "hop": ours.events.hop_height,
            }
        )
    return pd.DataFrame(rows)


def delta_figure(out: str | Path) -> Path:
    """Hop height against delta (log axes): the scheme's, the seed's prints, the exact none."""
    plt = pyplot()
    heights = [solve_seed_euler(seed_scene(), dt=0.002, delta=d).events.hop_height for d in DELTAS]
    fig, ax = plt.subplots(figsize=(5.5, 4.0), constrained_layout=True)
    ax.plot(DELTAS, [h or np.nan for h in heights], "o-", ms=3, label="seed scheme, dt = 2 ms")
    printed = list(SEED_DELTA_TABLE.items())
    ax.plot([d for d, _ in printed], [p["hop"] for _, p in printed], "rs", label="seed (printed)")
    ax.plot(DELTAS, DELTAS, "k:", lw=0.8, label="hop = delta")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("contact tolerance delta (m)")
    ax.set_ylabel("hop height (m)")
    ax.set_title("The seed's hop is set by delta; the exact solver finds none", fontsize=9)
    ax.legend(fontsize=7, loc="upper left")  # the hop grows with delta: that corner is empty
    return save(fig, out, dpi=110)
