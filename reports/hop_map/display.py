"""What a hop map keeps of each run's motion for the report's page: a thinned copy.

A map's rows hold the events alone; clicking a cell of the page's map draws that point's runs
(clearance, slip velocity and contact force against time, each engine over the exact
solution), so the map stores, beside its rows, each run's trajectory thinned to at most
:data:`DISPLAY_SAMPLES` samples (``DIR/display/<run_id>.parquet``). They are for the eye
only: every number of the rows is computed from the full run before it is thinned, and the
comparison suites' ``trajectories/`` keep every sample.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import ExactSolution

__all__ = [
    "DISPLAY_DIR",
    "DISPLAY_SAMPLES",
    "display_path",
    "read_display",
    "thinned",
    "write_display",
    "write_exact_display",
]

DISPLAY_DIR = "display"
"""Sub-folder of a map folder holding the thinned trajectories, one Parquet file per run."""

DISPLAY_SAMPLES = 400
"""Samples kept per run: 5 ms apart over a 2 s window, finer than a page's pixels, and about
12 kB per file."""


def thinned(trajectory: Trajectory, samples: int = DISPLAY_SAMPLES) -> Trajectory:
    """At most ``samples`` rows of ``trajectory``, evenly spread, first and last kept."""
    n = len(trajectory)
    if n <= samples:
        return trajectory
    keep = np.unique(np.linspace(0, n - 1, samples).round().astype(int))
    return Trajectory.from_frame(trajectory.to_frame().iloc[keep].reset_index(drop=True))


def display_path(out: str | Path, run_id: str) -> Path:
    """Where a map run's thinned trajectory is stored."""
    return Path(out) / DISPLAY_DIR / f"{run_id}.parquet"


def write_display(trajectory: Trajectory, out: str | Path, run_id: str) -> Path:
    """Store the thinned copy of a run (the folder made if needed)."""
    path = display_path(out, run_id)
    path.parent.mkdir(parents=True, exist_ok=True)
    return thinned(trajectory).write(path)


def write_exact_display(solution: ExactSolution, out: str | Path, run_id: str) -> Path:
    """Store the exact solution sampled evenly over its window."""
    t = np.linspace(0.0, solution.t_final, DISPLAY_SAMPLES)
    return write_display(solution.sample(t), out, run_id)


def read_display(out: str | Path, run_id: str) -> Trajectory | None:
    """A run's thinned trajectory, or None when the map did not store one (an older map, a
    failed run)."""
    path = display_path(out, run_id)
    return Trajectory.read(path) if path.is_file() else None
