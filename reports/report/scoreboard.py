"""The scoreboard: one line per engine and profile, how often it gets each thing right.

Read from the default-variant runs of the comparison suites at the default timestep (the
same rows as the findings' sentences). Each share is "k/n (p %)": k runs right out of the n
runs that can be right:

* outcome right, phases right: of the judged runs (a verdict), those with ``outcome_agrees``,
  ``phases_agree``;
* slip within 1 ms, by the contact force and by the slip velocity: of the judged runs whose
  exact solution slips, those with ``|err_contact_t_slip_ms|`` (``|err_t_slip_ms|``) <= 1;
* hop height within 5 %: of the judged runs whose exact solution hops, those whose hop
  height is within 5 % of the exact one: the contact reading's hop height where the row has
  a contact reading, the clearance reading's otherwise (rows stored before it);
* lift-off within 10 ms: of the same runs, ``|err_contact_t_lift_ms|`` <= 10 (the clearance
  reading's ``err_t_lift_ms`` for a row without a contact reading);
* median normal-force RMS: the median of ``force_rms_n_g`` over the judged runs that have
  one, a column only when the table has it.

A run without the event (a missed hop, a failed run) counts in n and not in k.
"""

from __future__ import annotations

import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.reports.compare.selection import profile_of
from hoopbench.reports.report.escaping import escape_cell

__all__ = [
    "FORCE_RMS",
    "HOP_HEIGHT_WITHIN",
    "LIFT_WITHIN_MS",
    "SLIP_WITHIN_MS",
    "contact_hop_error",
    "scoreboard",
    "scoreboard_markdown",
]

SLIP_WITHIN_MS = 1.0
LIFT_WITHIN_MS = 10.0
HOP_HEIGHT_WITHIN = 0.05
FORCE_RMS = "force_rms_n_g"
"""Column of the contact-force comparison (RMS of (n - n_exact)/g); shown when present."""

_HEADERS = {
    "engine": "engine",
    "profile": "profile",
    "outcome": "outcome right",
    "phases": "phases right",
    "slip_contact": f"slip within {SLIP_WITHIN_MS:g} ms, contact force",
    "slip_velocity": f"slip within {SLIP_WITHIN_MS:g} ms, slip velocity",
    "hop_height": f"hop height within {100 * HOP_HEIGHT_WITHIN:g} %",
    "lift": f"lift-off within {LIFT_WITHIN_MS:g} ms, contact force",
    "force_rms": "median normal-force RMS, g",
}


def _column(rows: pd.DataFrame, name: str) -> pd.Series:
    """The column as floats; all empty where the table has no such column."""
    if name not in rows.columns:
        return pd.Series(float("nan"), index=rows.index)
    return pd.to_numeric(rows[name], errors="coerce")


def _has_contact_reading(rows: pd.DataFrame) -> pd.Series:
    if Col.CONTACT_PHASES not in rows.columns:
        return pd.Series(False, index=rows.index)
    return rows[Col.CONTACT_PHASES].notna()


def contact_hop_error(rows: pd.DataFrame) -> pd.Series:
    """Each row's relative hop-height error, engine / exact - 1: the contact reading's hop
    height where the row has a contact reading, the clearance reading's (``err_hop_height_rel``)
    otherwise; empty where the run has no hop (or the exact solution none)."""
    by_contact = _column(rows, Col.CONTACT_HOP_HEIGHT) / _column(rows, Col.EXACT_HOP_HEIGHT) - 1
    return by_contact.where(_has_contact_reading(rows), _column(rows, Col.ERR_HOP_HEIGHT_REL))


def _contact_lift_error(rows: pd.DataFrame) -> pd.Series:
    by_contact = _column(rows, Col.ERR_CONTACT_T_LIFT_MS)
    return by_contact.where(_has_contact_reading(rows), _column(rows, Col.ERR_T_LIFT_MS))


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


def _line(rows: pd.DataFrame) -> dict[str, str]:
    judged = rows[Col.VERDICT].notna() if Col.VERDICT in rows.columns else rows.index != rows.index
    slips = judged & _column(rows, Col.EXACT_T_SLIP).notna()
    hops = judged & _column(rows, Col.EXACT_HOP_HEIGHT).notna()
    line = {
        "outcome": _share(_is_true(rows, Col.OUTCOME_AGREES), judged),
        "phases": _share(_is_true(rows, Col.PHASES_AGREE), judged),
        "slip_contact": _share(
            _column(rows, Col.ERR_CONTACT_T_SLIP_MS).abs() <= SLIP_WITHIN_MS, slips
        ),
        "slip_velocity": _share(_column(rows, Col.ERR_T_SLIP_MS).abs() <= SLIP_WITHIN_MS, slips),
        "hop_height": _share(contact_hop_error(rows).abs() <= HOP_HEIGHT_WITHIN, hops),
        "lift": _share(_contact_lift_error(rows).abs() <= LIFT_WITHIN_MS, hops),
    }
    if FORCE_RMS in rows.columns:
        rms = _column(rows, FORCE_RMS)[judged].dropna()
        line["force_rms"] = f"{rms.median():.3g}" if len(rms) else "-"
    return line


def scoreboard(rows: pd.DataFrame, profiles: list[str], engines: list[str]) -> pd.DataFrame:
    """One line per profile and engine (in the given orders) of ``rows``, which are the runs
    to count: the shares of the module's docstring, as
    text. Engines or profiles without rows have no line."""
    lines = []
    profile_column = profile_of(rows)
    for profile in profiles:
        for engine in engines:
            mine = rows[(rows[Col.ENGINE] == engine) & (profile_column == profile)]
            if len(mine):
                lines.append({"engine": engine, "profile": profile, **_line(mine)})
    return pd.DataFrame(lines, columns=[c for c in _HEADERS if any(c in ln for ln in lines)])


def scoreboard_markdown(board: pd.DataFrame) -> str:
    """The scoreboard as a Markdown table; empty text for an empty one."""
    if board.empty:
        return ""
    headers = [_HEADERS[c] for c in board.columns]
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    lines += ["| " + " | ".join(map(escape_cell, line)) + " |" for line in board.to_numpy()]
    return "\n".join(lines)
