"""The runs table's layout versions, and the migration of a table stored in an older one.

A compare results folder records its version in meta.json (``runs_format_version``);
:func:`hoopbench.reports.compare.suite.runs_frame` reads every folder through
:data:`RUNS_TABLE`, so an old table is patched here and nowhere else.
"""

from __future__ import annotations

from collections.abc import Iterable

import pandas as pd

from hoopbench.engines.judging.columns import (
    BATCH_COLUMNS,
    CPU_COLUMNS,
    EVENT_COLUMNS,
    FLOOR_COLUMNS,
    FORCE_COLUMNS,
    KIN_COLUMNS,
    RENAMED_FROM_CONTACT,
    RENAMED_TO_KIN,
    TRANSITION_COLUMNS,
    Col,
)
from hoopbench.engines.judging.verdict import number_or_none, row_phases_agree, verdict_columns
from hoopbench.engines.options import Profile
from hoopbench.models.events import Outcome
from hoopbench.models.formats import FileFormat
from hoopbench.reports.sweep import results

__all__ = [
    "FORMAT_VERSION",
    "ONE_READING_VERSION",
    "RUNS_TABLE",
    "before_one_reading",
    "one_reading",
    "with_batch_columns",
    "with_transition_columns",
]

FORMAT_VERSION = 9
"""Version of the runs table layout (1: runs.parquet and runs.json, before the runs/ dataset;
2: run_id and the runner's bookkeeping columns; 3: the verdict, max_clearance, consistent,
event_flags and exact_t_painleve columns; 4: g, and the last phases' start times and the run's
last sample time, t_last_phase, exact_t_last_phase and t_final, for the phase comparison at
the window's end, and exact_max_slip_speed; 5: the contact reading's columns,
CONTACT_COLUMNS, and the verdict's flags and reason; 6: the contact force against the exact
one, FORCE_COLUMNS; 7, issue 24: one reading, the unprefixed event columns are the canonical
(contact) reading, the clearance reading is kin_*, the detection floor floor_*, and the
verdict has one meaning: :func:`one_reading`; 8, issue 27: the batch's cost, BATCH_COLUMNS,
:func:`with_batch_columns`; 9, issue 33: every transition timed, the phases' start times and
the verdict's worst transition, :func:`with_transition_columns`, and the reading from the laws:
chattering as columns, not a phase C, and the effective friction coefficient; with issue 34,
the process's CPU time over the stepping, CPU_COLUMNS). Columns also
arrived between bumps (profile and a late in 2, rms_position_m with 3, g late in 3,
exact_max_slip_speed early in 4): a table may lack one its version lists, and reads it
empty."""

ONE_READING_VERSION = 7
"""The first format with one reading (issue 24): a folder stored before it is read migrated
but cannot be resumed, since its old rows and new ones would name their columns apart."""

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
    5: (*RENAMED_FROM_CONTACT, Col.VERDICT_FLAGS, Col.VERDICT_REASON),
    6: FORCE_COLUMNS,
    8: BATCH_COLUMNS,  # filled for older runs: each was a batch of one
    9: (
        Col.PHASE_TIMES,
        Col.FLOOR_PHASE_TIMES,
        Col.EXACT_PHASE_TIMES,
        *TRANSITION_COLUMNS,
        Col.CHATTER_CONE_SHARE,
        Col.CHATTERS,
        Col.MU_EFFECTIVE,
        Col.MU_EFFECTIVE_RATIO,
        *CPU_COLUMNS,  # issue 34: a run's CPU time, empty for runs stored without it
    ),
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


def _outcome(row: pd.Series) -> str | None:
    if not isinstance(row.get(Col.PHASES), str):
        return None
    if row.get(Col.KIN_OUTCOME) == str(Outcome.PAINLEVE):
        return str(Outcome.PAINLEVE)
    if number_or_none(row.get(Col.T_LIFT)) is not None:
        return str(Outcome.HOPS)
    slips = number_or_none(row.get(Col.T_SLIP)) is not None
    return str(Outcome.SLIPS if slips else Outcome.ROLLS)


def before_one_reading(columns: Iterable[str]) -> bool:
    """Whether a table with these columns was stored before one reading (format 7): it has
    no kin_* columns (an older migration may have added empty contact_* ones)."""
    return Col.KIN_PHASES not in set(columns)


def one_reading(frame: pd.DataFrame) -> pd.DataFrame:
    """Issue 24's migration of a runs table (a suite's, version 6, or a map's, version 3) to
    one reading: its unprefixed event columns (the clearance reading) become ``kin_*``, its
    ``contact_*`` columns (the contact reading, stored with the rules of its time) the
    unprefixed ones, with the outcome and the relative hop-height error derived from them;
    the columns that came with issue 24 (the detection floor, the cone-stick and
    chattering times, the slip angle by the contact force) read empty; and the verdict is
    judged again by today's rules, tolerances and tiers. Rows stored without a contact
    reading (before version 5) keep empty event columns and their stored verdict."""
    if not before_one_reading(frame.columns):
        # A folder without meta.json counts as version 2, yet its rows may be this
        # hoopbench's (a sweep still running, or interrupted): they need no renaming.
        frame = frame.drop(columns=[c for c in RENAMED_FROM_CONTACT if c in frame.columns])
        return results.with_columns(frame, (*EVENT_COLUMNS, *KIN_COLUMNS, *FLOOR_COLUMNS))
    frame = frame.rename(columns={**RENAMED_TO_KIN, **RENAMED_FROM_CONTACT})
    needed = (
        *EVENT_COLUMNS,
        *KIN_COLUMNS,
        *FLOOR_COLUMNS,
        *TRANSITION_COLUMNS,
        Col.EXACT_HOP_HEIGHT,
    )
    frame = results.with_columns(frame, needed)
    if frame.empty:
        return frame
    hop = pd.to_numeric(frame[Col.HOP_HEIGHT], errors="coerce")
    exact_hop = pd.to_numeric(frame[Col.EXACT_HOP_HEIGHT], errors="coerce")
    error = (hop / exact_hop.where(exact_hop > 0)) - 1.0
    frame[Col.ERR_HOP_HEIGHT_REL] = error.astype(object).where(error.notna(), None)
    frame[Col.OUTCOME] = frame.apply(_outcome, axis=1)
    read = frame[Col.PHASES].map(lambda v: isinstance(v, str))
    for index in frame.index[read]:
        row = frame.loc[index].to_dict()
        frame.at[index, Col.PHASES_AGREE] = row_phases_agree(row)
        for column, value in verdict_columns(row).items():
            frame.at[index, column] = value
    return frame


def _to_7(frame: pd.DataFrame) -> pd.DataFrame:
    """One reading (:func:`one_reading`)."""
    return one_reading(frame)


def with_batch_columns(frame: pd.DataFrame) -> pd.DataFrame:
    """Issue 27's migration of a runs table (a suite's, version 7, or a map's, version 4):
    BATCH_COLUMNS, its runs stepped alone, each a batch of one at its own cost (empty for a
    run that did not step). A row that has them (stored by this hoopbench into a resumed
    folder, or into one without meta.json) keeps its own."""
    frame = results.with_columns(frame, (*BATCH_COLUMNS, Col.N_STEPS, Col.WALL_TIME_S))
    steps = pd.to_numeric(frame[Col.N_STEPS], errors="coerce")
    wall = pd.to_numeric(frame[Col.WALL_TIME_S], errors="coerce")
    ran = (steps > 0) & (wall > 0) & frame[Col.BATCH_SIZE].isna()
    return frame.assign(
        **{
            Col.BATCH_SIZE: frame[Col.BATCH_SIZE].where(~ran, 1),
            Col.US_PER_WORLD_STEP: frame[Col.US_PER_WORLD_STEP].where(~ran, 1e6 * wall / steps),
            Col.WORLD_STEPS_PER_S: frame[Col.WORLD_STEPS_PER_S].where(~ran, steps / wall),
        }
    )


def with_transition_columns(frame: pd.DataFrame) -> pd.DataFrame:
    """Issue 33's migration of a runs table (a suite's, version 8, or a map's, version 5): the
    phases' start times and the worst transition read empty, and the stored verdict stays:
    judged before every transition was timed, it timed the first slip onset, the lift-off
    and the impact alone (engines/judging/verdict.py, ``verdict_columns``)."""
    return results.with_columns(frame, _ADDED_IN[9])


RUNS_TABLE = FileFormat(
    "runs table",
    FORMAT_VERSION,
    oldest=2,
    migrations={
        2: _to_3,
        3: _to_4,
        4: _to_5,
        5: _to_6,
        6: _to_7,
        7: with_batch_columns,
        8: with_transition_columns,
    },
)
"""A compare folder's runs table; a folder that records no version counts as 2, the first
runs/ dataset (version 1 folders have no runs/ and are not read)."""
