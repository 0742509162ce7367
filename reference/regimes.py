"""The exact reference's verdict on a scene: which regime of motion it is in (issue 11's map).

:func:`classify` solves the scene exactly (:func:`hoopbench.reference.exact.solve_exact`, whose
results it does not alter) and sorts the outcome into one :class:`Regime`. Besides the regime
it reports ``t_settled``: the time from which the exact motion is known to repeat with no
further event, so that an engine run may stop there (see :func:`settled_time`).
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from scipy.optimize import brentq

from hoopbench.models.events import Events, Outcome, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference.exact import ExactSolution, solve_exact, solve_exact_settled

__all__ = [
    "Regime",
    "RegimePoint",
    "classify",
    "classify_solved",
    "classify_whole",
    "max_slip_speed",
    "settled_time",
]


class Regime(StrEnum):
    """The regime of a scene's exact motion within its window (first match in this order:
    hops, lifts-at-start, Painlevé, degenerate, error, slip-reversal, slips, rolls)."""

    ROLLS = "rolls"
    """No slip in the window."""
    SLIPS = "slips"
    """Slips (and re-sticks any number of times), no lift-off, no reversal."""
    SLIP_REVERSAL = "slip-reversal"
    """A slip reverses direction without re-sticking; no lift-off."""
    HOPS = "hops"
    """Lifts off after t = 0."""
    LIFTS_AT_START = "lifts-at-start"
    """Normal force negative at t = 0."""
    PAINLEVE = "painleve"
    """D = 0 while slipping."""
    DEGENERATE = "degenerate"
    """Needs I > 0 and the scene has I = 0."""
    ERROR = "error"
    """The solver stopped early (work budget)."""


@dataclass(frozen=True)
class RegimePoint:
    """The exact reference's classification of one scene."""

    regime: Regime
    events: Events
    """The exact events (as solve_exact gives them)."""
    n_slips: int
    """Slip phases before any lift-off."""
    hop_height: float | None
    """m, where it hops (HOPS, LIFTS_AT_START); None otherwise, and None for a hop whose
    flight ran out of work budget before its impact (events.outcome is then 'error')."""
    t_settled: float | None
    """s: from this time on the exact motion is known to repeat with no further event (it has
    rolled a full turn of theta since its last event); None if that does not happen within
    the window."""
    solve_time_s: float
    """Wall time of the classification, s."""
    max_slip_speed: float | None = None
    """Largest |slip velocity| over the slip phases before any lift-off, m/s (None: no
    slip). A slip that stays below the detectors' slip threshold is invisible to them."""


# Outcomes that name their regime directly, whatever the phases before them were.
_BY_OUTCOME = {
    Outcome.HOPS: Regime.HOPS,
    Outcome.LIFTS_AT_START: Regime.LIFTS_AT_START,
    Outcome.PAINLEVE: Regime.PAINLEVE,
    Outcome.DEGENERATE: Regime.DEGENERATE,
    Outcome.ERROR: Regime.ERROR,
}


def _has_reversal(events: Events) -> bool:
    """A slip phase followed directly (no roll between) by a slip of the opposite sigma."""
    phases = events.phases
    return any(
        p.kind is PhaseKind.SLIP and q.kind is PhaseKind.SLIP and p.sigma and q.sigma == -p.sigma
        for p, q in itertools.pairwise(phases)
    )


def regime_of(events: Events) -> Regime:
    """The regime that exact events describe (the rules of :class:`Regime`)."""
    if events.t_lift is not None and events.outcome is not Outcome.LIFTS_AT_START:
        return Regime.HOPS  # a lift-off takes precedence (even over a later budget error)
    if events.outcome in _BY_OUTCOME:
        return _BY_OUTCOME[events.outcome]
    if _has_reversal(events):
        return Regime.SLIP_REVERSAL
    if any(p.kind is PhaseKind.SLIP for p in events.phases) or events.t_slip is not None:
        return Regime.SLIPS
    return Regime.ROLLS


def _n_slips(events: Events) -> int:
    n = 0
    for phase in events.phases:
        if phase.kind is PhaseKind.FLIGHT:
            break
        n += phase.kind is PhaseKind.SLIP
    return n


SETTLE_GRID = 64
"""Samples per turn of theta (at the phase's mean spin) scanned for the full-turn crossing."""


def settled_time(solution: ExactSolution) -> float | None:
    """When the exact motion has rolled a full turn of theta since its last event, s.

    Only a window that ends in a roll phase (begun at the last event, or at t = 0) can
    settle. While rolling, energy is conserved and the constraint fixes the state by theta:
    thetadot**2, the contact forces and therefore every event function (slip onset
    |f| = mus n, lift-off n = 0) are functions of theta mod 2 pi. Once theta has advanced a
    full turn with no event, every value of theta mod 2 pi has been visited without one, so
    the motion repeats turn after turn and no new event can occur. A roll that rocks back
    and forth (thetadot changes sign) never completes the turn and returns None, as does a
    window too short for the turn. A solve that stopped at that turn
    (``stop_when_settled``) knows the time already.
    """
    if solution.t_settled is not None:
        return solution.t_settled
    if solution.events.outcome not in (Outcome.ROLLS, Outcome.SLIPS):
        return None
    last = solution.segments[-1]
    if last.kind is not PhaseKind.ROLL or last.t_end <= last.t_start:
        return None
    theta0 = float(last.states(np.array([last.t_start]))[2, 0])

    def turned(t: float) -> float:
        return abs(float(last.states(np.array([t]))[2, 0]) - theta0) - 2.0 * math.pi

    # Rolling, theta is monotonic (or rocks within less than a turn), so one crossing at
    # most; the grid only brackets it for the root finder.
    theta_end = float(last.states(np.array([last.t_end]))[2, 0])
    turns = abs(theta_end - theta0) / (2.0 * math.pi)
    grid = np.linspace(last.t_start, last.t_end, math.ceil((turns + 1) * SETTLE_GRID) + 1)
    advance = np.abs(last.states(grid)[2] - theta0) - 2.0 * math.pi
    reached = np.nonzero(advance >= 0.0)[0]
    if not reached.size:
        return None
    k = int(reached[0])
    if advance[k] == 0.0 or k == 0:
        return float(grid[k])
    return float(brentq(turned, grid[k - 1], grid[k], xtol=1e-12))


def max_slip_speed(solution: ExactSolution, samples_per_phase: int = 201) -> float | None:
    """Largest |slip velocity|, m/s, over the exact slip phases before any lift-off (None
    without one), from ``samples_per_phase`` samples of each.

    The slip speed rises from zero at the onset and falls back at a re-stick, so its largest
    value lies inside the phase; a few hundred samples find it to far better than the factor
    that matters here, whether it crosses a detector threshold of 1 mm/s. Some slips never do
    (0.05 mm/s at lam 0.54, chi 1.25, mu 0.8: 17 ms slips twice a turn), and no engine's
    detected phases can show them.
    """
    speeds = []
    for phase in solution.events.phases:
        if phase.kind is PhaseKind.FLIGHT:
            break
        end = min(phase.t_end, solution.t_final)
        if phase.kind is not PhaseKind.SLIP or end <= phase.t_start:
            continue
        t = np.linspace(phase.t_start, end, samples_per_phase)
        speeds.append(float(np.max(np.abs(solution.sample(t).slip_velocity))))
    return max(speeds) if speeds else None


def classify(scene: Scene, *, stop_when_settled: bool = True) -> RegimePoint:
    """Solve the scene exactly and classify its motion (see :class:`Regime`).

    The solve stops once the motion has settled (``stop_when_settled``; the events are the
    same as without, see :func:`~hoopbench.reference.exact.solve_exact`): a point needs no
    more than its regime and events.
    """
    return classify_solved(scene, stop_when_settled=stop_when_settled)[0]


def classify_solved(
    scene: Scene, *, stop_when_settled: bool = True
) -> tuple[RegimePoint, ExactSolution]:
    """:func:`classify`, and the exact solution it classified (a hop map keeps a sampled
    copy of it for the report's page)."""
    start = time.perf_counter()
    solution = solve_exact(scene, stop_when_settled=stop_when_settled)
    return _classified(solution, start), solution


def classify_whole(scene: Scene) -> tuple[RegimePoint, ExactSolution, ExactSolution]:
    """:func:`classify_solved` (stopped when settled) and the solution of the whole window,
    ``solve_exact(scene)``, from one integration
    (:func:`~hoopbench.reference.exact.solve_exact_settled`): the point, the solution it
    classified and the whole one (a hop map judges its engines against it). The point's
    solve time is that of both."""
    start = time.perf_counter()
    settled, whole = solve_exact_settled(scene)
    return _classified(settled, start), settled, whole


def _classified(solution: ExactSolution, start: float) -> RegimePoint:
    """The point of a solution solved since ``start`` (time.perf_counter())."""
    events = solution.events
    regime = regime_of(events)
    hops = regime in (Regime.HOPS, Regime.LIFTS_AT_START)
    return RegimePoint(
        regime=regime,
        events=events,
        n_slips=_n_slips(events),
        hop_height=events.hop_height if hops else None,
        t_settled=settled_time(solution),
        solve_time_s=time.perf_counter() - start,
        max_slip_speed=max_slip_speed(solution),
    )
