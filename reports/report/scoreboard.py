"""The scoreboard: one line per engine and profile, how often it gets each thing right.

Read from the default-variant runs of the comparison suites at the default timestep (the
same rows as the findings' sentences), all by the canonical reading and with the verdict's
one tolerance table (engines/judging/tolerances.toml). Each share is "k/n (p %)": k runs
right out of the n runs that can be right:

* outcome right, phases right: of the judged runs (a verdict), those with ``outcome_agrees``,
  ``phases_agree``;
* agrees, agrees or close: of the judged runs, those whose verdict is in the tight tier
  (``agrees``: every event within the tight tolerances) and in the loose one;
* slip onset, hop height, lift-off, impact within tight: of the judged runs whose exact
  solution has the event, those whose error is within the event's tight tolerance as the
  verdict sets it (``verdict.event_within``);
* median normal-force RMS: the median of ``force_rms_n_g`` over the judged runs that have
  one, a column only when the table has it.

A run without the event (a missed hop, a failed run) counts in n and not in k.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import LOOSE_TIER, TIGHT_TIER, Event, event_within
from hoopbench.reports.compare.selection import profile_of
from hoopbench.reports.report.escaping import escape_cell

__all__ = ["FORCE_RMS", "scoreboard", "scoreboard_markdown"]

FORCE_RMS = "force_rms_n_g"
"""Column of the contact-force comparison (RMS of (n - n_exact)/g); shown when present."""

_HEADERS = {
    "engine": "engine",
    "profile": "profile",
    "outcome": "outcome right",
    "phases": "phases right",
    "agrees": "agrees (tight)",
    "close": "agrees or close (loose)",
    "slip": "slip onset within tight",
    "hop_height": "hop height within tight",
    "lift": "lift-off within tight",
    "impact": "impact within tight",
    "force_rms": "median normal-force RMS, g",
}


def _column(rows: pd.DataFrame, name: str) -> pd.Series:
    """The column as floats; all empty where the table has no such column."""
    if name not in rows.columns:
        return pd.Series(float("nan"), index=rows.index)
    return pd.to_numeric(rows[name], errors="coerce")


def _share(hits: pd.Series, among: pd.Series) -> str:
    """'k/n (p %)': the rows where ``hits`` among those where ``among``; '-' for none."""
    total = int(among.sum())
    if total == 0:
        return "-"
    k = int((hits & among).sum())
    return f"{k}/{total} ({100 * k / total:.0f} %)"


def _is_true(rows: pd.DataFrame, name: str) -> pd.Series:
    if name not in rows.columns:
        return pd.Series(False, index=rows.index)
    return rows[name].map(lambda v: v is True or v == True)  # noqa: E712 - NaN is not True


def _within(rows: pd.DataFrame, records: Sequence[Mapping], event: Event) -> pd.Series:
    """Whether each row's event is within its tight tolerance; ``records``: the rows as
    mappings (made once for every event and line: it is most of the scoreboard's cost)."""
    return pd.Series(
        [event_within(row, event, Tier.TIGHT) is True for row in records],
        index=rows.index,
        dtype=bool,
    )


def _in_tier(rows: pd.DataFrame, tier: frozenset) -> pd.Series:
    if Col.VERDICT not in rows.columns:
        return pd.Series(False, index=rows.index)
    return rows[Col.VERDICT].isin([str(v) for v in tier])


def _line(rows: pd.DataFrame, records: Sequence[Mapping]) -> dict[str, str]:
    judged = rows[Col.VERDICT].notna() if Col.VERDICT in rows.columns else rows.index != rows.index
    slips = judged & _column(rows, Col.EXACT_T_SLIP).notna()
    hops = judged & _column(rows, Col.EXACT_HOP_HEIGHT).notna()
    impacts = judged & _column(rows, Col.EXACT_T_IMPACT).notna()
    line = {
        "outcome": _share(_is_true(rows, Col.OUTCOME_AGREES), judged),
        "phases": _share(_is_true(rows, Col.PHASES_AGREE), judged),
        "agrees": _share(_in_tier(rows, TIGHT_TIER), judged),
        "close": _share(_in_tier(rows, LOOSE_TIER), judged),
        "slip": _share(_within(rows, records, Event.SLIP_ONSET), slips),
        "hop_height": _share(_within(rows, records, Event.HOP_HEIGHT), hops),
        "lift": _share(_within(rows, records, Event.LIFT_OFF), hops),
        "impact": _share(_within(rows, records, Event.IMPACT), impacts),
    }
    if FORCE_RMS in rows.columns:
        rms = _column(rows, FORCE_RMS)[judged].dropna()
        line["force_rms"] = f"{rms.median():.3g}" if len(rms) else "-"
    return line


def scoreboard(rows: pd.DataFrame, profiles: list[str], engines: list[str]) -> pd.DataFrame:
    """One line per profile and engine (in the given orders) of ``rows``, which are the runs
    to count: the shares of the module's docstring, as text. Engines or profiles without
    rows have no line."""
    lines = []
    profile_column = profile_of(rows)
    records = rows.to_dict("records")
    for profile in profiles:
        for engine in engines:
            mask = ((rows[Col.ENGINE] == engine) & (profile_column == profile)).to_numpy()
            if mask.any():
                mine = [records[k] for k in np.flatnonzero(mask)]
                lines.append({"engine": engine, "profile": profile, **_line(rows[mask], mine)})
    return pd.DataFrame(lines, columns=[c for c in _HEADERS if any(c in ln for ln in lines)])


def scoreboard_markdown(board: pd.DataFrame) -> str:
    """The scoreboard as a Markdown table; empty text for an empty one."""
    if board.empty:
        return ""
    headers = [_HEADERS[c] for c in board.columns]
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(map(escape_cell, line)) + " |" for line in board.to_numpy()]
    return "\n".join(lines)
