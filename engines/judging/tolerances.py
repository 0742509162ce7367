"""The one tolerance table (engines/judging/tolerances.toml): tight and loose, per event,
carried to a row's hoop and timestep. The verdict, the Findings, the scoreboard and the
regression tests read it here."""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from enum import StrEnum
from functools import cache
from importlib.resources import files
from typing import Any

__all__ = ["EventTolerances", "Tier", "event_tolerances", "tolerances"]


class Tier(StrEnum):
    """The two tolerance tiers: within TIGHT every event agrees, within LOOSE it is close."""

    TIGHT = "tight"
    LOOSE = "loose"


@cache
def tolerances() -> dict[str, Any]:
    """The parsed tolerances file (read once)."""
    text = files("hoopbench.engines.judging").joinpath("tolerances.toml").read_text()
    return tomllib.loads(text)


@dataclass(frozen=True)
class EventTolerances:
    """One tier's tolerances carried to a hoop and a timestep (before a row's own detection
    floor is added)."""

    t_slip: float
    """s."""
    t_lift: float
    """s."""
    t_impact: float
    """s."""
    hop_height_rel: float
    """Dimensionless: |hop height / exact - 1|."""
    creep_distance: float = 0.0
    """m: how far the rim may slide while the reading has it rolling (creep), where the
    exact solution slides not at all."""


def event_tolerances(
    tier: Tier, duration: float = 1.0, timestep: float = 0.0, length: float = 1.0
) -> EventTolerances:
    """``tier``'s tolerances for a hoop whose times scale by ``duration`` (sqrt(a / g) over
    the 1 m hoop's) and lengths by ``length`` (a over 1 m) at ``timestep`` (s; 0 where
    unknown)."""
    table = tolerances()[str(tier)]
    extra = table["steps"] * timestep
    return EventTolerances(
        t_slip=table["t_slip_s"] * duration + extra,
        t_lift=table["t_lift_s"] * duration + extra,
        t_impact=table["t_impact_s"] * duration + extra,
        hop_height_rel=table["hop_height_rel"],
        creep_distance=table["creep_distance_m"] * length,
    )
