"""Where the two readings of a run disagree: its events by the clearance and slip velocity
(the ``kin_*`` columns) against its events by the canonical reading (the unprefixed ones,
engines/judging/contact.py).

Everything else in the report reads the canonical reading (docs/report.md says why); this
table, the one place the ``kin_*`` columns are shown, lists every default-settings run where
the other reading would tell a different story, so that no reader has to take the choice on
trust.
"""

from __future__ import annotations

import math
from typing import Any

import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.verdict import number_or_none
from hoopbench.engines.settings import DEFAULT_TIMESTEP
from hoopbench.reports.compare.selection import default_rows, engine_rows, profile_of

__all__ = ["READING_RESOLUTION_MS", "reading_differences"]

READING_RESOLUTION_MS = 1.0
"""ms: two readings of an event closer than this agree. The detectors read the exact
solution's events within 0.1 ms (tests/test_report.py) and the contact reading within
0.5 ms (tests/test_contact_reading.py) at dt 1e-4: a larger difference is the engine's."""

_EVENTS = (
    ("slip onset", Col.KIN_ERR_T_SLIP_MS, Col.ERR_T_SLIP_MS),
    ("lift-off", Col.KIN_ERR_T_LIFT_MS, Col.ERR_T_LIFT_MS),
    ("impact", Col.KIN_ERR_T_IMPACT_MS, Col.ERR_T_IMPACT_MS),
)
"""(event, its error by the clearance or slip velocity, by the canonical reading), ms."""


def reading_differences(runs: pd.DataFrame) -> pd.DataFrame:
    """One row per (run, event) where the readings differ by more than the resolution, or
    one reading has the event and the other not, and per run whose phase codes differ:
    default settings at the default timestep, engines only (rows without both readings are
    left out)."""
    rows = default_rows(engine_rows(runs))
    both = rows[Col.PHASES].notna() & rows[Col.KIN_PHASES].notna()
    rows = rows[(rows[Col.TIMESTEP] == DEFAULT_TIMESTEP) & both]
    rows = rows.assign(profile=profile_of(rows))
    out: list[dict[str, Any]] = []
    for _, row in rows.iterrows():
        out += _event_differences(row)
        if row[Col.KIN_PHASES] != row[Col.PHASES]:
            out.append(_entry(row, "phases", row[Col.KIN_PHASES], row[Col.PHASES]))
    columns = ["scene", "engine", "profile", "event", "kinematic", "contact"]
    return pd.DataFrame(out, columns=columns)


def _event_differences(row: pd.Series) -> list[dict[str, Any]]:
    out = []
    for event, kinematic, contact in _EVENTS:
        a, b = number_or_none(row.get(kinematic)), number_or_none(row.get(contact))
        if a is None and b is None:
            continue
        if a is None or b is None or abs(a - b) > READING_RESOLUTION_MS:
            out.append(_entry(row, event, _ms(a), _ms(b)))
    return out


def _entry(row: pd.Series, event: str, kinematic: Any, contact: Any) -> dict[str, Any]:
    return {
        "scene": row[Col.SCENE],
        "engine": row[Col.ENGINE],
        "profile": row[Col.PROFILE],
        "event": event,
        "kinematic": kinematic,
        "contact": contact,
    }


def _ms(value: float | None) -> str:
    return "none" if value is None or math.isnan(value) else f"{value:+.3g} ms"
