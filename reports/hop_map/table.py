"""Reading a map folder: the latest row of every run, and agreement per engine and regime."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.columns import FORCE_COLUMNS, RENAMED_FROM_CONTACT, Col
from hoopbench.models.formats import FileFormat
from hoopbench.reference.regimes import Regime
from hoopbench.reports.compare.rows import (
    one_reading,
    with_batch_columns,
    with_transition_columns,
)
from hoopbench.reports.compare.selection import engine_rows
from hoopbench.reports.hop_map.spec import REFERENCE, check_stored_points, load_spec
from hoopbench.reports.hop_map.stages import MAP_COLUMNS, ROWS_FORMAT_VERSION
from hoopbench.reports.sweep import results

# --------------------------------------------------------------------------- reading
__all__ = [
    "ALL_REGIMES",
    "MAP_TABLE",
    "agreement_table",
    "map_frame",
]


def _to_2(frame: pd.DataFrame) -> pd.DataFrame:
    """Maps run before the contact reading have its columns empty."""
    return results.with_columns(
        frame, (*RENAMED_FROM_CONTACT, Col.VERDICT_FLAGS, Col.VERDICT_REASON)
    )


def _to_3(frame: pd.DataFrame) -> pd.DataFrame:
    """Maps run before the force columns have them empty."""
    return results.with_columns(frame, (Col.RMS_POSITION_M, *FORCE_COLUMNS))


def _to_4(frame: pd.DataFrame) -> pd.DataFrame:
    """One reading (reports/compare/rows.one_reading), and the hop-height error from it."""
    frame = one_reading(frame)
    if frame.empty:
        return frame
    frame = results.with_columns(frame, (Col.VERDICT, Col.HOP_HEIGHT, Col.EXACT_HOP_HEIGHT))
    both = frame[Col.VERDICT].notna() & frame[Col.HOP_HEIGHT].notna()
    error = pd.to_numeric(frame[Col.HOP_HEIGHT], errors="coerce") - pd.to_numeric(
        frame[Col.EXACT_HOP_HEIGHT], errors="coerce"
    )
    frame[Col.HOP_HEIGHT_ERROR] = error.where(both)
    return frame


MAP_TABLE = FileFormat(
    "hop map runs table",
    ROWS_FORMAT_VERSION,
    oldest=1,
    migrations={
        1: _to_2,
        2: _to_3,
        3: _to_4,
        4: with_batch_columns,
        5: with_transition_columns,
    },
)
"""A map folder's runs table (its version in meta.json, as a compare folder's)."""


def map_frame(out: str | Path) -> pd.DataFrame:
    """The latest row of every run of a map folder, one per (point, engine), the reference
    included: MAP_COLUMNS first (missing ones empty), then the runner's bookkeeping; in map
    order (x, y, then the reference and the engines as the spec lists them). A table in a
    newer format is refused (FormatVersionError)."""
    out = Path(out)
    frame = results.with_columns(results.read_table(out, MAP_TABLE), MAP_COLUMNS)
    frame = frame[[*MAP_COLUMNS, *(c for c in frame.columns if c not in MAP_COLUMNS)]]
    try:
        spec = load_spec(out)
    except FileNotFoundError:  # rows without their spec: the report refuses them by name
        engines: tuple[str, ...] = (REFERENCE,)
    else:
        check_stored_points(spec, frame, str(out / results.RUNS_NAME))
        engines = (REFERENCE, *spec.engines)
    rank = {name: k for k, name in enumerate(engines)}
    key = frame["engine"].map(lambda e: rank.get(e, len(rank)))
    order = np.lexsort((frame["engine"].astype(str), key, frame["iy"], frame["ix"]))
    return frame.iloc[order].reset_index(drop=True)


# --------------------------------------------------------------------------- tables
ALL_REGIMES = "all"
"""The regime label of an engine's overall row in the agreement table."""


def agreement_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Agreement with the reference per engine, overall and per exact regime.

    One row per (engine, regime) with ``points`` (engine rows), ``judged`` (those with a
    verdict: the rest have no exact answer, e.g. degenerate), ``outcome_agrees`` (count of
    outcome_agrees, the outcome class with the hop's size and timing) and ``agrees`` (count of
    verdict 'agrees': the outcome and the phase sequence), each with its percentage of
    ``judged`` (NaN where nothing was judged). Regimes in Regime's order, the overall row
    (regime 'all') first.
    """
    runs = engine_rows(frame)
    regimes = [str(r) for r in Regime if (runs["regime"] == str(r)).any()]
    engines = list(dict.fromkeys(runs["engine"]))
    rows = []
    for engine in engines:
        mine = runs[runs["engine"] == engine]
        for regime in (ALL_REGIMES, *regimes):
            part = mine if regime == ALL_REGIMES else mine[mine["regime"] == regime]
            rows.append({"engine": engine, "regime": regime, **_agreement(part)})
    columns = ["engine", "regime", "points", "judged", "outcome_agrees", "outcome_agrees_pct"]
    return pd.DataFrame(rows, columns=[*columns, "agrees", "agrees_pct"])


def _agreement(part: pd.DataFrame) -> dict[str, Any]:
    judged = int(part["verdict"].notna().sum())
    outcome = int(part["outcome_agrees"].eq(True).sum())
    agrees = int(part["verdict"].eq("agrees").sum())
    return {
        "points": len(part),
        "judged": judged,
        "outcome_agrees": outcome,
        "outcome_agrees_pct": 100.0 * outcome / judged if judged else math.nan,
        "agrees": agrees,
        "agrees_pct": 100.0 * agrees / judged if judged else math.nan,
    }
