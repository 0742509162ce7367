"""What a hop map keeps of each run's motion for the report's page: a thinned copy.

A map's rows hold the events alone; clicking a cell of the page's map draws that point's runs
(clearance, slip velocity and contact force against time, each engine over the exact
solution), so the map stores, beside its rows, each run's trajectory thinned to at most
:data:`DISPLAY_SAMPLES` samples (``DIR/display/<run_id>.parquet``). They are for the eye
only: every number of the rows is computed from the full run before it is thinned, and the
comparison suites' ``trajectories/`` keep every sample. So a file holds only what the page
draws (:data:`DISPLAY_COLUMNS`), in single precision: about 7 kB a run, where the whole
trajectory in double precision took 50 kB (267 MB for a 40x40 map of three engines).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import ExactSolution
from hoopbench.reports.sweep.folder_files import MAX_DATA_BYTES, folder_file

__all__ = [
    "DISPLAY_COLUMNS",
    "DISPLAY_DIR",
    "DISPLAY_SAMPLES",
    "DisplayRun",
    "display_path",
    "read_display",
    "thinned",
    "write_display",
    "write_exact_display",
]

DISPLAY_DIR = "display"
"""Sub-folder of a map folder holding the thinned trajectories, one Parquet file per run."""

DISPLAY_SAMPLES = 400
"""Samples kept per run: 5 ms apart over a 2 s window, finer than a page's pixels."""

DISPLAY_COLUMNS = ("t", "clearance", "slip_velocity", "normal_force")
"""What the page draws of a run (s, m, m/s, m/s^2 per unit mass), and all a file keeps."""


@dataclass(frozen=True)
class DisplayRun:
    """A run's thinned curves as the page draws them (float32: for the eye only)."""

    t: NDArray
    """s"""
    clearance: NDArray
    """m"""
    slip_velocity: NDArray
    """m/s"""
    normal_force: NDArray
    """m/s^2: the contact's normal force per unit mass."""

    def __len__(self) -> int:
        return len(self.t)

    def thinned(self, samples: int) -> DisplayRun:
        """At most ``samples`` of these, evenly spread, first and last kept."""
        keep = _kept(len(self), samples)
        return DisplayRun(*(getattr(self, name)[keep] for name in DISPLAY_COLUMNS))


def _kept(n: int, samples: int) -> NDArray:
    if n <= samples:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, samples).round().astype(int))


def thinned(trajectory: Trajectory, samples: int = DISPLAY_SAMPLES) -> Trajectory:
    """At most ``samples`` rows of ``trajectory``, evenly spread, first and last kept."""
    if len(trajectory) <= samples:
        return trajectory
    keep = _kept(len(trajectory), samples)
    # The kept rows of each column (a table of every sample first cost 2 of a run's 3 ms).
    return trajectory.rows(keep)


def display_path(out: str | Path, run_id: str) -> Path:
    """Where a map run's thinned trajectory is stored."""
    return Path(out) / DISPLAY_DIR / f"{run_id}.parquet"


@functools.cache
def _display_schema() -> pa.Schema:
    """The schema pandas' ``to_parquet`` gives a frame of the display columns (float32, no
    index), with its pandas metadata: made once, so that a run's file is the same bytes as
    that frame's without a DataFrame a run (2.4 to 1.0 ms a file, make report's 400)."""
    template = pd.DataFrame({name: np.zeros(1, np.float32) for name in DISPLAY_COLUMNS})
    return pa.Table.from_pandas(template, preserve_index=False).schema


def write_display(trajectory: Trajectory, out: str | Path, run_id: str) -> Path:
    """Store the thinned curves of a run (the folder made if needed)."""
    path = display_path(out, run_id)
    path.parent.mkdir(parents=True, exist_ok=True)
    kept = thinned(trajectory)
    columns = {name: getattr(kept, name).astype(np.float32) for name in DISPLAY_COLUMNS}
    pq.write_table(pa.table(columns, schema=_display_schema()), path)
    return path


def write_exact_display(solution: ExactSolution, out: str | Path, run_id: str) -> Path:
    """Store the exact solution sampled evenly over its window."""
    t = np.linspace(0.0, solution.t_final, DISPLAY_SAMPLES)
    return write_display(solution.sample(t), out, run_id)


def read_display(out: str | Path, run_id: str) -> DisplayRun | None:
    """A run's thinned curves, or None when the map did not store them (an older map, a
    failed run). A file of the first maps with the page, a whole thinned trajectory, reads
    the same."""
    path = folder_file(out, Path(DISPLAY_DIR) / f"{run_id}.parquet", MAX_DATA_BYTES)
    if path is None:
        return None
    # Arrow's table, not pandas': a page reads every run of a map (400 for make report's),
    # and the DataFrame between took half of each read. One file's reader, not read_table's
    # dataset: the same table for a third of the CPU time (0.08 against 0.22 s for 400).
    with pq.ParquetFile(path) as stored:
        table = stored.read(columns=list(DISPLAY_COLUMNS))
    return DisplayRun(*(table.column(name).to_numpy() for name in DISPLAY_COLUMNS))
