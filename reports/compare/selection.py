"""Which rows of a runs table (a suite's or a map's) a table, figure or finding reads: the
engines' rows, the exact reference's, the runs at their profile's default settings.

One statement of each selection, so that every section agrees on what "the engines" are.
"""

from __future__ import annotations

import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.score import CostClock
from hoopbench.engines.options import Profile
from hoopbench.engines.run import REFERENCE_ENGINE, RunStatus
from hoopbench.reports.compare.suite_file import DEFAULT_VARIANT

__all__ = [
    "default_rows",
    "engine_names_of",
    "engine_rows",
    "ok_rows",
    "profile_of",
    "reference_rows",
    "run_cost_clock",
    "step_cost_column",
]


def engine_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """The rows of real engines: every row but the exact reference's."""
    return frame[frame[Col.ENGINE] != REFERENCE_ENGINE]


def reference_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """The exact reference's rows."""
    return frame[frame[Col.ENGINE] == REFERENCE_ENGINE]


def engine_names_of(frame: pd.DataFrame) -> list[str]:
    """The real engines of a table, in the order they first appear."""
    return [str(e) for e in dict.fromkeys(frame[Col.ENGINE]) if e != REFERENCE_ENGINE]


def default_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """The runs at their profile's values (variant ``default``): no knob changed."""
    return frame[frame[Col.VARIANT] == DEFAULT_VARIANT]


def ok_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """The runs whose status is ok."""
    return frame[frame[Col.STATUS] == str(RunStatus.OK)]


def profile_of(frame: pd.DataFrame) -> pd.Series:
    """Each row's profile; tuned where a hand-made frame has none (a stored table is migrated
    to carry one: reports/compare/rows.py)."""
    if Col.PROFILE not in frame.columns:
        return pd.Series(str(Profile.TUNED), index=frame.index)
    return frame[Col.PROFILE].fillna(str(Profile.TUNED))


def step_cost_column(frame: pd.DataFrame) -> Col:
    """The column a summary ranks runs by cost with: the process's CPU time per step
    (Col.CPU_US_PER_STEP, which the machine's load moves far less than the wall time) where
    the rows carry it, else the wall time per step (Col.US_PER_STEP: a table stored before
    issue 34)."""
    return Col(run_cost_clock(frame).step_column)


def run_cost_clock(frame: pd.DataFrame) -> CostClock:
    """The clock runs' costs are read by: the process's CPU time where the rows carry it
    (Col.CPU_US_PER_STEP measured), else the wall time (a table stored before issue 34)."""
    if Col.CPU_US_PER_STEP not in frame.columns:
        return CostClock.WALL
    measured = pd.to_numeric(frame[Col.CPU_US_PER_STEP], errors="coerce").notna().any()
    return CostClock.CPU if measured else CostClock.WALL
