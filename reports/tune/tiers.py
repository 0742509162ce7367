"""Which accuracy tier each setting of a search reaches, and the cheapest setting of each
tier: what a settings file's ``[tiers]`` names (``--settings FILE#close``).

A setting reaches a tier on a set of scenes when every one of its runs there has a verdict
of the tier (engines/judging/score.tier_reached, with the verdict's own tolerance table).
The cheapest of a tier is the Pareto setting of least training cost that reaches it on the
training scenes and on the held-out ones alike: only the Pareto set runs on the held-out
scenes, so a dominated trial is never named.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import pandas as pd

from hoopbench.engines.judging.score import tier_reached
from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import TIER_NAMES

__all__ = [
    "NO_TIER",
    "TIER_COLUMNS",
    "cheapest_by_tier",
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


def _within(reached: Any, tier: str) -> bool:
    """Whether a setting that reaches ``reached`` (a tier name) is within ``tier``: a finer
    tier is within every coarser one."""
    return reached in _ORDER and _ORDER.index(reached) <= _ORDER.index(tier)


def cheapest_by_tier(front: pd.DataFrame) -> dict[str, str | None]:
    """Tier name -> the Pareto setting of least training cost within it on the training and
    the held-out scenes (None where none is; every tier None for a front.csv written before
    the tier columns)."""
    chosen: dict[str, str | None] = dict.fromkeys(_ORDER)
    if not set(TIER_COLUMNS) <= set(front.columns):
        return chosen
    pareto = front[front["kind"] == "pareto"]
    for tier in _ORDER:
        best: tuple[float, str] | None = None
        for row in pareto.to_dict("records"):
            if not all(_within(row[c], tier) for c in TIER_COLUMNS):
                continue
            cost = float(row["train_cost_us_per_s"])
            cost = cost if math.isfinite(cost) else math.inf
            if best is None or cost < best[0]:
                best = (cost, str(row["setting"]))
        chosen[tier] = None if best is None else best[1]
    return chosen
