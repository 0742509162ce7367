"""The time a sweep has left, from what its calls are expected to cost.

A sweep's calls differ in cost by orders of magnitude (a pymunk run at dt 1e-3 takes a tenth
of a second, a MuJoCo Warp batch minutes), and they finish in no particular order: the cheap
ones first. An ETA from the count of calls finished (elapsed / done * left) is then 5-10
times off (issue 34). Here each call has a kind (from the most specific, e.g. an engine and
its settings, to the most general, the engine) and a number of steps (a batch: its longest
world's, as its worlds step together), and costs its steps times the seconds per step of its
kind: measured on the warm calls of that kind finished in this sweep, else a prior (a
shipped estimate, scaled by how much slower than it the finished calls ran here:
:func:`machine_factor`), else the next, more general kind; else measured on the kind's cold calls;
else the mean of every finished call. A call is cold when its worker had run no call of its
most specific kind before: it pays what a worker pays once per settings (MJX traces and
compiles, 4-10 times the cost of its later calls on 2 CPU cores: 71 s, then 8 s). The
calls left are then laid out on the workers in the order they are submitted (a call in flight
keeps its worker for what it has left), and the ETA is when the last one ends.

The runner knows nothing of engines: the caller gives each call's kinds, steps and the
priors (:class:`Costing`).
"""

from __future__ import annotations

import heapq
from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass

__all__ = [
    "CallCost",
    "Costing",
    "Took",
    "machine_factor",
    "remaining_seconds",
    "seconds_per_step",
]


@dataclass(frozen=True)
class CallCost:
    """What a call is expected to cost."""

    kinds: tuple[Hashable, ...]
    """From the most specific (an engine and its settings) to the most general (an engine)."""
    steps: float
    """Steps it takes: a run's, or a batch's longest world's (> 0)."""


@dataclass(frozen=True)
class Costing:
    """How the runner weighs its calls for the ETA."""

    cost: Callable[[Sequence[object]], CallCost]
    """The tasks of one call (one task, or a batch's) -> its kinds and steps."""
    prior: Mapping[Hashable, float]
    """Seconds per step of a kind before any call of it has finished here."""


@dataclass(frozen=True)
class Took:
    """A finished call and what it took."""

    call: CallCost
    seconds: float
    cold: bool = False
    """Its worker had run no call of its most specific kind before (module docstring)."""


def seconds_per_step(finished: Iterable[Took]) -> dict[Hashable, float]:
    """Kind -> seconds per step measured: the finished calls' seconds over their steps, over
    every call that has the kind at any level."""
    seconds: dict[Hashable, float] = {}
    steps: dict[Hashable, float] = {}
    for done in finished:
        call, took = done.call, done.seconds
        for kind in call.kinds:
            seconds[kind] = seconds.get(kind, 0.0) + took
            steps[kind] = steps.get(kind, 0.0) + call.steps
    return {kind: seconds[kind] / steps[kind] for kind in seconds if steps[kind] > 0}


def _expected(
    call: CallCost,
    warm: Mapping[Hashable, float],
    cold: Mapping[Hashable, float],
    prior: Mapping[Hashable, float],
) -> float | None:
    """A call's seconds: the most specific kind measured warm or with a prior, else the
    most specific measured cold; None without."""
    for kind in call.kinds:
        rate = warm.get(kind, prior.get(kind))
        if rate is not None:
            return rate * call.steps
    for kind in call.kinds:
        if kind in cold:
            return cold[kind] * call.steps
    return None


def machine_factor(finished: Sequence[Took], prior: Mapping[Hashable, float]) -> float:
    """How much slower this machine, now, runs the finished calls than the priors say: their
    seconds over the priors' (the warm calls' if any; 1 with none a prior knows). A loaded
    machine or a slower one scales the priors of the kinds not measured yet alike."""
    warm = [done for done in finished if not done.cold] or list(finished)
    said = [(done.seconds, _expected(done.call, {}, {}, prior)) for done in warm]
    known = [(took, expected) for took, expected in said if expected]
    if not known:
        return 1.0
    return sum(took for took, _ in known) / sum(expected for _, expected in known if expected)


def remaining_seconds(
    pending: Sequence[CallCost],
    running: Sequence[tuple[CallCost, float]],
    finished: Sequence[Took],
    workers: int,
    prior: Mapping[Hashable, float],
) -> float | None:
    """Seconds until the sweep ends: ``pending`` calls (in submission order) and the
    ``running`` ones (each with the seconds it has run) laid out on ``workers`` workers,
    at the costs of :func:`seconds_per_step`'s measure of the ``finished`` calls, else
    ``prior`` (module docstring). None when a call has no kind measured or known and no
    call has finished yet."""
    warm = seconds_per_step(done for done in finished if not done.cold)
    cold = seconds_per_step(finished)
    total_steps = sum(done.call.steps for done in finished)
    mean = sum(done.seconds for done in finished) / total_steps if total_steps > 0 else None
    scaled = {kind: rate * machine_factor(finished, prior) for kind, rate in prior.items()}

    def cost(call: CallCost) -> float | None:
        found = _expected(call, warm, cold, scaled)
        return found if found is not None or mean is None else mean * call.steps

    free = [0.0] * max(workers, 1)  # when each worker is next free, s from now
    for call, ran in running:
        expected = cost(call)
        if expected is None:
            return None
        # A call past its expected cost has an unknown rest: a tenth of what it has run.
        rest = expected - ran if expected > ran else 0.1 * ran
        heapq.heapreplace(free, free[0] + rest)
    for call in pending:
        expected = cost(call)
        if expected is None:
            return None
        heapq.heapreplace(free, free[0] + expected)
    return max(free)
