"""One number for how well a set of runs agrees with the exact solution, and one for what it
costs: the two objectives of a search over an engine's settings (``hoopbench tune``).

The error of a run is read off its verdict with the shared tolerance table (tolerances.py,
verdict.py), continuous so that a search can tell "nearly close" from "far off":

- each judged event's error over its LOOSE tolerance (as the verdict sets it: carried to the
  hoop and timestep, plus the row's detection floor), the largest of them: at most 1 means
  every event is within the loose tier (``close`` or ``agrees``); every transition the
  verdict timed counts (its worst, ``max_transition_ratio``: a re-stick 30 ms early is 3);
- at least FLAG_SCORE when the verdict flags a failure no event error measures (wrong phases,
  creep, a stick outside the Coulomb cone);
- SCORE_CAP, the worst, for an event missed or invented (false or missed hop or slip), a run
  that diverged or gave nothing (failed, timeout, crashed), and any ratio above it.

The error of a set of runs is the mean of theirs (each scene weighs the same); its cost is
the time of the runs' stepping per simulated second, in microseconds, by one clock
(CostClock): the process's CPU time, which the machine's load moves far less, or the wall
time. docs/tune.md explains both.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from enum import StrEnum
from typing import Any, TypeVar

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import (
    TIER_VERDICTS,
    Event,
    Verdict,
    event_error_ratio,
    number_or_none,
)

__all__ = [
    "COST_NOISE_FACTOR",
    "FLAG_SCORE",
    "SCORE_CAP",
    "CostClock",
    "cheapest_of_most",
    "cost_us_per_s",
    "costs_equal",
    "error_score",
    "row_error",
    "scenes_within",
    "tier_reached",
    "within_tier",
]

T = TypeVar("T")

SCORE_CAP = 10.0
"""The worst error of a run: ten loose tolerances, or an event missed, invented, or no run."""

FLAG_SCORE = 2.0
"""The least error of a run whose verdict flags a failure no event error measures: twice the
loose tolerance, so such a run is never within a tier."""

_WORST = frozenset(
    {
        Verdict.DIVERGED,
        Verdict.FAILED,
        Verdict.FALSE_HOP,
        Verdict.MISSED_HOP,
        Verdict.FALSE_SLIP,
        Verdict.MISSED_SLIP,
    }
)
_UNMEASURED = frozenset({Verdict.WRONG_PHASES, Verdict.CREEPS, Verdict.CONE_VIOLATION})


def _flags(row: Mapping[str, Any]) -> set[str]:
    text = row.get(Col.VERDICT_FLAGS)
    flags = set(text.split()) if isinstance(text, str) else set()
    verdict = row.get(Col.VERDICT)
    if isinstance(verdict, str):
        flags.add(verdict)
    return flags


def row_error(row: Mapping[str, Any]) -> float:
    """The error of one judged run (a runs-table row), from 0 to SCORE_CAP."""
    if row.get(Col.STATUS) != "ok":
        return SCORE_CAP
    flags = _flags(row)
    if not flags or flags & {str(v) for v in _WORST}:
        return SCORE_CAP  # no verdict (unjudged), or an outcome nothing can time
    ratios = [event_error_ratio(row, event, Tier.LOOSE) for event in Event]
    ratios.append(number_or_none(row.get(Col.MAX_TRANSITION_RATIO)))
    error = max((r for r in ratios if r is not None), default=0.0)
    if flags & {str(v) for v in _UNMEASURED}:
        error = max(error, FLAG_SCORE)
    return min(error, SCORE_CAP)


def error_score(rows: Iterable[Mapping[str, Any]]) -> float:
    """The mean error of a set of runs (one per scene); SCORE_CAP for no runs."""
    errors = [row_error(row) for row in rows]
    return sum(errors) / len(errors) if errors else SCORE_CAP


def within_tier(row: Mapping[str, Any], tier: Tier) -> bool:
    """Whether a run's verdict is one the tier admits (TIER_VERDICTS)."""
    verdict = row.get(Col.VERDICT)
    return isinstance(verdict, str) and verdict in {str(v) for v in TIER_VERDICTS[tier]}


def scenes_within(rows: Iterable[Mapping[str, Any]], tier: Tier) -> int:
    """How many of a setting's runs (one per scene) are within the tier."""
    return sum(within_tier(row, tier) for row in rows)


def tier_reached(rows: Iterable[Mapping[str, Any]]) -> Tier | None:
    """The finest accuracy tier every run is within (its verdict one of the tier's:
    TIER_VERDICTS); None when some run is within none, or there are no runs."""
    rows = list(rows)
    if not rows:
        return None
    for tier in Tier:  # finest first: the tolerance table's order
        if all(within_tier(row, tier) for row in rows):
            return tier
    return None


COST_NOISE_FACTOR = 2.0
"""Two costs within this factor of each other are one cost: the spread of a measured cost
between two runs of the same thing on one machine. Measured by the CPU time the answer ranks
by (Col.CPU_US_PER_STEP), between three ``make report`` runs alone on the project's 2-core
machine (Intel Xeon at 2.1 GHz under KVM, 2026-11-29 and 30, the same engine adapters;
each engine setting's median CPU us/step over its scenes, 1,557 pairs of settings of one
engine): one setting's cost against another's of the same engine moved by a factor of 1.20
in the median, 1.61 at the 90th percentile, 1.76 at the 95th, 2.06 at the 99th and 2.88 at
worst. 2 covers 98.5 % of those pairs, 1.5 (the factor before, from the wall times of two
reports on an AMD EPYC) 85 %. Under KVM a worker's CPU time moves with what else runs on the
host and on the other core (their shared L3 cache, the host's scheduling): a short call moves
most (Newton's one call of 8 worlds, 3,000 steps, 18-28 ms: 5.9 to 9.2 us a step). With 1.5
the answer's cheapest settings differed between two of those reports in 1 of 20 choices by
the clock alone (Newton tight: stock against tuned, 9.24 against 5.99 us a step, then 5.94
against 7.29); with 2 and the answer's tie rule, in none of the 20 over eight reports on
that machine (2026-11-29 and 30; MJX's finer rows, left to a GPU in four of them, aside)."""


def costs_equal(a: float, b: float) -> bool:
    """Whether two costs (> 0) are within the noise of each other (COST_NOISE_FACTOR)."""
    if not (math.isfinite(a) and math.isfinite(b)):
        return a == b
    return max(a, b) <= COST_NOISE_FACTOR * min(a, b)


def cheapest_of_most(
    candidates: Iterable[tuple[T, int, float | None]],
    tie_key: Callable[[T], Any] | None = None,
) -> T | None:
    """The cheapest setting of an accuracy tier, the one rule of every summary that names
    one (the report's answer, a settings file's [tiers]): of the candidates (setting, how
    many of its scenes are within the tier, its cost), those within it on the most scenes
    (all of them, where one is), and of those the cheapest. A cost not measured (None, nan)
    comes last. None when no candidate has a scene within the tier.

    Without ``tie_key`` a tie in cost keeps the first. With it, the costs within the noise
    of the cheapest (at most COST_NOISE_FACTOR times it) count as equal and the least
    ``tie_key`` of those is chosen: a stable rule instead of the clock, so that two runs on
    one machine, or one under load, name the same setting."""
    best: list[tuple[int, float, T]] = []
    for item, within, cost in candidates:
        if within <= 0:
            continue
        price = math.inf if cost is None or not math.isfinite(cost) else cost
        if best and within < best[0][0]:
            continue
        if best and within > best[0][0]:
            best = []
        best.append((within, price, item))
    if not best:
        return None
    cheapest = min(price for _, price, _ in best)
    if tie_key is None:
        return next(item for _, price, item in best if price == cheapest)
    equal = [item for _, price, item in best if costs_equal(price, cheapest)]
    return min(equal, key=tie_key)


class CostClock(StrEnum):
    """Whose time a cost is: a search records its clock (``hoopbench tune``'s tune.json)."""

    CPU = "cpu"
    """The process's CPU time over the stepping (Col.CPU_TIME_S)."""
    WALL = "wall"
    """The wall time over the stepping (Col.WALL_TIME_S): it grows with the machine's load."""

    @property
    def column(self) -> str:
        """The runs-table column of the stepping's time by this clock, s."""
        return Col.CPU_TIME_S if self is CostClock.CPU else Col.WALL_TIME_S

    @property
    def step_column(self) -> str:
        """The runs-table column of the stepping's time by this clock per step, us."""
        return Col.CPU_US_PER_STEP if self is CostClock.CPU else Col.US_PER_STEP

    @property
    def label(self) -> str:
        """As the report says it: "CPU" or "wall" (the answer's Answer.clock words)."""
        return "CPU" if self is CostClock.CPU else "wall"


def cost_us_per_s(rows: Iterable[Mapping[str, Any]], clock: CostClock) -> float | None:
    """The runs' stepping time by ``clock`` per simulated second, us; None if no run was
    timed by it."""
    spent = simulated = 0.0
    for row in rows:
        time_s = number_or_none(row.get(clock.column))
        steps = number_or_none(row.get(Col.N_STEPS))
        step = number_or_none(row.get(Col.TIMESTEP))
        if time_s is None or not steps or not step:
            continue
        spent += time_s
        simulated += steps * step
    if simulated <= 0 or not math.isfinite(spent):
        return None
    return 1e6 * spent / simulated
