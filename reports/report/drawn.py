"""The runs the trajectory figures draw: one per engine that ran a scene, at the default
timestep where it ran there, else at its finest stored one.

The batched engines (MJX, MuJoCo Warp, Newton) run the suite at 1e-3 s only, and a figure that
kept the default timestep's rows alone dropped them while its caption said "each engine's".
Each figure's caption names the engines drawn at another timestep (:func:`timestep_note`).
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

import pandas as pd

from hoopbench.engines.options import Profile
from hoopbench.engines.settings import DEFAULT_TIMESTEP
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.compare.selection import default_rows, profile_of

__all__ = ["drawn_rows", "drawn_trajectories", "read_trajectory", "timestep_note"]


def drawn_rows(runs: pd.DataFrame, scene_name: str) -> pd.DataFrame:
    """The tuned default-settings rows of ``scene_name`` with a stored trajectory, one per
    engine: its row at DEFAULT_TIMESTEP if it has one, else its row at its finest timestep."""
    if "trajectory_file" not in runs.columns:  # a hand-made table: nothing stored to draw
        return runs.iloc[0:0]
    rows = default_rows(runs)
    rows = rows[(rows["scene"] == scene_name) & (profile_of(rows) == str(Profile.TUNED))]
    stored = rows["trajectory_file"].map(lambda p: isinstance(p, str) and bool(p))
    rows = rows[stored]
    if rows.empty:
        return rows
    timestep = pd.to_numeric(rows["timestep"], errors="coerce")
    # The default first, then the finer before the coarser.
    rank = timestep.where(timestep != DEFAULT_TIMESTEP, -1.0)
    chosen = rows.assign(_rank=rank).sort_values("_rank", kind="stable")
    chosen = chosen.drop_duplicates("engine").drop(columns="_rank")
    order = list(dict.fromkeys(rows["engine"]))  # the suite's order, not the rank's
    return chosen.set_index("engine", drop=False).loc[order].reset_index(drop=True)


def drawn_trajectories(runs: pd.DataFrame, scene_name: str) -> dict[str, Trajectory]:
    """The trajectories of :func:`drawn_rows`, by engine (each file read once a process:
    :func:`read_trajectory`)."""
    return {
        str(row["engine"]): read_trajectory(row["trajectory_file"])
        for _, row in drawn_rows(runs, scene_name).iterrows()
    }


TRAJECTORIES_KEPT = 96
"""Trajectories a process keeps once read: every one a report draws (make report's: 80, at
most 2.4 MB each, 183 MB in all; a drawing process reads a scene's for its figures, the
contact forces, the page's animation and the GIF, each of them its own call)."""


def read_trajectory(path: str | Path) -> Trajectory:
    """``Trajectory.read(path)``, read once a process while the file is unchanged (its
    size and modification time) and kept (TRAJECTORIES_KEPT, the least recent dropped
    first); its arrays are read-only, as they are shared by every figure drawn of them."""
    stat = Path(path).stat()
    return _read(str(path), stat.st_mtime_ns, stat.st_size)


@lru_cache(maxsize=TRAJECTORIES_KEPT)
def _read(path: str, mtime_ns: int, size: int) -> Trajectory:
    return Trajectory.read(path).make_read_only()


def timestep_note(rows: pd.DataFrame) -> str:
    """Which timestep the drawn ``rows`` (of one scene or several) ran at: ``dt = 0.0001 s``
    when every run ran at the default, else also the others' (``dt = 0.0001 s; mjx, newton
    at 0.001 s (none stored at 0.0001 s)``)."""
    timestep = pd.to_numeric(rows["timestep"], errors="coerce")
    others = rows[timestep != DEFAULT_TIMESTEP]
    note = f"dt = {DEFAULT_TIMESTEP:g} s"
    by_step: dict[float, dict[str, None]] = {}  # rows of several scenes name an engine once
    for _, row in others.iterrows():
        by_step.setdefault(float(row["timestep"]), {})[str(row["engine"])] = None
    for step, engines in sorted(by_step.items()):
        note += f"; {', '.join(engines)} at {step:g} s (none stored at {DEFAULT_TIMESTEP:g} s)"
    return note
