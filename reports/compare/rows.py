"""The runs table's layout versions, and the migration of a table stored in an older one.

A compare results folder records its version in meta.json (``runs_format_version``);
:func:`hoopbench.reports.compare.suite.runs_frame` reads every folder through
:data:`RUNS_TABLE`, so an old table is patched here and nowhere else.
"""

from __future__ import annotations

import pandas as pd

from hoopbench.engines.judging.columns import BATCH_COLUMNS, CONTACT_COLUMNS, FORCE_COLUMNS, Col
from hoopbench.engines.options import Profile
from hoopbench.models.formats import FileFormat
from hoopbench.reports.sweep import results

__all__ = ["FORMAT_VERSION", "RUNS_TABLE", "with_batch_columns"]

FORMAT_VERSION = 7
"""Version of the runs table layout (1: runs.parquet and runs.json, before the runs/ dataset;
2: run_id and the runner's bookkeeping columns; 3: the verdict, max_clearance, consistent,
event_flags and exact_t_painleve columns; 4: g, and the last phases' start times and the run's
last sample time, t_last_phase, exact_t_last_phase and t_final, for the phase comparison at
the window's end, and exact_max_slip_speed; 5: the contact reading's columns,
CONTACT_COLUMNS, and the verdict's flags and reason; 6: the contact force against the exact
one, FORCE_COLUMNS; 7: the batch's cost, BATCH_COLUMNS). Columns also arrived between bumps
(profile and a late in 2, rms_position_m with 3, g late in 3, exact_max_slip_speed early in
4): a table may lack one its version lists, and reads it empty."""

_ADDED_IN = {
    3: (
        "exact_t_painleve",
        "rms_position_m",
        "max_clearance",
        "consistent",
        "event_flags",
        "verdict",
    ),
    4: ("g", "exact_t_last_phase", "t_last_phase", "t_final", "exact_max_slip_speed"),
    5: (*CONTACT_COLUMNS, Col.VERDICT_FLAGS, Col.VERDICT_REASON),
    6: FORCE_COLUMNS,
    7: BATCH_COLUMNS,  # filled for older runs: each was a batch of one
}
"""The columns each version added (or, for g and exact_max_slip_speed, came with it): an
older table's rows have them empty."""


def _to_3(frame: pd.DataFrame) -> pd.DataFrame:
    """Rows from before profiles (early in version 2) ran hoopbench's own option values, the
    tuned profile; the verdict columns stay empty (the report falls back on outcome_agrees)."""
    frame = results.with_columns(frame, ("profile", *_ADDED_IN[3]))
    return frame.assign(profile=frame["profile"].fillna(str(Profile.TUNED)))


def _to_4(frame: pd.DataFrame) -> pd.DataFrame:
    """The window-end times and g stay empty: the stored verdicts were judged without them."""
    return results.with_columns(frame, _ADDED_IN[4])


def _to_5(frame: pd.DataFrame) -> pd.DataFrame:
    """Runs judged before the contact reading have its columns empty."""
    return results.with_columns(frame, _ADDED_IN[5])


def _to_6(frame: pd.DataFrame) -> pd.DataFrame:
    """Runs judged before the contact-force columns have them empty."""
    return results.with_columns(frame, _ADDED_IN[6])


def with_batch_columns(frame: pd.DataFrame) -> pd.DataFrame:
    """A table from before batches, with BATCH_COLUMNS: its runs were stepped alone, each a
    batch of one at its own cost (empty for a run that did not step)."""
    frame = results.with_columns(frame, (*BATCH_COLUMNS, Col.N_STEPS, Col.WALL_TIME_S))
    steps = pd.to_numeric(frame[Col.N_STEPS], errors="coerce")
    wall = pd.to_numeric(frame[Col.WALL_TIME_S], errors="coerce")
    ran = (steps > 0) & (wall > 0)
    return frame.assign(
        **{
            Col.BATCH_SIZE: frame[Col.BATCH_SIZE].where(~ran, 1),
            Col.US_PER_WORLD_STEP: frame[Col.US_PER_WORLD_STEP].where(~ran, 1e6 * wall / steps),
            Col.WORLD_STEPS_PER_S: frame[Col.WORLD_STEPS_PER_S].where(~ran, steps / wall),
        }
    )


RUNS_TABLE = FileFormat(
    "runs table",
    FORMAT_VERSION,
    oldest=2,
    migrations={2: _to_3, 3: _to_4, 4: _to_5, 5: _to_6, 6: with_batch_columns},
)
"""A compare folder's runs table; a folder that records no version counts as 2, the first
runs/ dataset (version 1 folders have no runs/ and are not read)."""
