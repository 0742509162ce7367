"""Which accuracy tier each setting of a search reaches, on how many scenes it is within
each, and the cheapest setting of each tier: what a settings file's ``[tiers]`` names
(``--settings FILE#close``).

A setting reaches a tier on a set of scenes when every one of its runs there has a verdict
of the tier (engines/judging/score.tier_reached, with the verdict's own tolerance table).
The cheapest of a tier follows the report's answer's rule (score.cheapest_of_most): of the
Pareto settings, those within the tier on the most scenes, training and held-out together
(all of them, where one is), and of those the one of least training cost. Only the Pareto set
runs on the held-out scenes, so a dominated trial is never named.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import pandas as pd

from hoopbench.engines.judging.score import cheapest_of_most, scenes_within, tier_reached
from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import TIER_NAMES
from hoopbench.reports.compare.settings_file import TierChoice

__all__ = [
    "NO_TIER",
    "SCENES_COLUMN",
    "TIER_COLUMNS",
    "TierChoice",
    "cheapest_by_tier",
    "count_column",
    "count_columns",
    "tier_columns",
    "tier_name",
]

NO_TIER = "none"
"""A setting some of whose runs are within no tier (also a settings file's "none")."""

TIER_COLUMNS = ("train_tier", "heldout_tier")
"""front.csv's columns: the tier (its name: TIER_NAMES, or NO_TIER) each setting reaches on
the training scenes and on the held-out ones."""

_ORDER = [str(TIER_NAMES[tier]) for tier in Tier]
"""Tier names, finest first (the tolerance table's order)."""

SCENES_COLUMN = "n_scenes"
"""front.csv's column: how many scenes (training and held-out) a setting ran."""


def count_column(tier: str) -> str:
    """front.csv's column of how many of a setting's scenes are within ``tier`` (its name:
    ``agrees_scenes``, ``close_scenes``)."""
    return f"{tier}_scenes"


def tier_name(rows: Iterable[Mapping[str, Any]]) -> str:
    """The name of the finest tier every run is within, or NO_TIER."""
    tier = tier_reached(rows)
    return NO_TIER if tier is None else str(TIER_NAMES[tier])


def tier_columns(
    train_rows: Sequence[Mapping[str, Any]], heldout_rows: Sequence[Mapping[str, Any]]
) -> dict[str, str]:
    """A setting's front.csv tier columns from its runs."""
    train, heldout = TIER_COLUMNS
    return {train: tier_name(train_rows), heldout: tier_name(heldout_rows)}


def count_columns(
    train_rows: Sequence[Mapping[str, Any]], heldout_rows: Sequence[Mapping[str, Any]]
) -> dict[str, int]:
    """A setting's front.csv scene counts: per tier, how many of its runs (one per scene,
    training and held-out together) are within it, and how many it ran."""
    rows = [*train_rows, *heldout_rows]
    counts = {count_column(str(TIER_NAMES[tier])): scenes_within(rows, tier) for tier in Tier}
    return {**counts, SCENES_COLUMN: len(rows)}


def _cost(value: Any) -> float | None:
    cost = pd.to_numeric(value, errors="coerce")
    return None if pd.isna(cost) or not math.isfinite(float(cost)) else float(cost)


def cheapest_by_tier(front: pd.DataFrame) -> dict[str, TierChoice | None]:
    """Tier name -> the cheapest (training cost) of the Pareto settings within it on the most
    scenes, training and held-out together (score.cheapest_of_most); None where no setting
    has a scene within it, and every tier None for a front.csv written before the scene
    counts."""
    chosen: dict[str, TierChoice | None] = dict.fromkeys(_ORDER)
    counts = [count_column(tier) for tier in _ORDER]
    if not {*counts, SCENES_COLUMN} <= set(front.columns):
        return chosen
    pareto = front[front["kind"] == "pareto"].to_dict("records")
    for tier, column in zip(_ORDER, counts, strict=True):
        candidates = (
            (
                TierChoice(str(row["setting"]), int(row[column]), int(row[SCENES_COLUMN])),
                int(row[column]),
                _cost(row["train_cost_us_per_s"]),
            )
            for row in pareto
        )
        chosen[tier] = cheapest_of_most(candidates)
    return chosen
