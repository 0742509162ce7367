"""The time a sweep has left, from what its calls are expected to cost.

A sweep's calls differ in cost by orders of magnitude (a pymunk run at dt 1e-3 takes a tenth
of a second, an MJX batch a minute), and they finish in no particular order: the cheap ones
first. An ETA from the count of calls finished (elapsed / done * left) is then 5-10 times
off (issue 34).

Here each call has kinds (from the most specific, e.g. an engine and its settings, to the
most general, the engine), a number of steps (a batch: its longest world's, as its worlds
step together) and of worlds, and a prior for its most specific kind that has one
(:class:`Rates`): a fixed part that every call pays whatever its steps (a worker's imports,
model building, tracing and compiling, the exact solve, judging), a part per step and, for
a batch, a part per world-step, and what a worker's first call of the kind pays once more.
A call at 1e-4 s is mostly stepping and one at 1e-3 s mostly its fixed part: a prior per
step alone, measured on the one, is 2-5 times off on the other.

What the priors say is then scaled by what the finished calls measured: by a kind's own
factor (its finished warm calls' seconds over what the priors said of them, the most
specific kind that has any), else by the machine's (:func:`machine_factor`: the median
engine's warm calls' seconds over what the priors said of them; a loaded or slower machine
scales every kind not measured yet alike).

A cold call (its worker's first of its kind) is no sample of a kind's stepping: with cold
caches MJX's first calls of 3,000 steps were mostly compiling (2-3 times their prior), and
that factor on the finer suite's 30,000-step call made its ETA 3.1-3.3 times the time left.
So a cold call of a kind measured by cold calls only is expected at the part of its prior
that a call pays once (fixed and cold) times what the kind's cold calls took beyond their
steps at the machine's factor (:func:`once_factors`), plus its steps at the machine's
factor; a warm call of such a kind at a more general kind's factor, else the machine's.

The calls left are then laid out on the workers in the order they are submitted (a call
in flight keeps its worker for what it has left), and the ETA is when the last one ends.

The runner knows nothing of engines: the caller gives each call's kinds, steps, worlds and
the priors (:class:`Costing`).
"""

from __future__ import annotations

import heapq
import statistics
from collections import Counter
from collections.abc import Callable, Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass

__all__ = [
    "CallCost",
    "Costing",
    "Rates",
    "Took",
    "call_ends",
    "kind_factors",
    "machine_factor",
    "once_factors",
    "remaining_seconds",
]


@dataclass(frozen=True)
class CallCost:
    """What a call is expected to cost."""

    kinds: tuple[Hashable, ...]
    """From the most specific (an engine and its settings) to the most general (an engine)."""
    steps: float
    """Steps it takes: a run's, or a batch's longest world's (>= 0: a call that steps
    nothing, as the exact classification of a map's point, pays its fixed part)."""
    worlds: int = 1
    """Worlds stepped together (a batch's runs; 1 for a run alone)."""


@dataclass(frozen=True)
class Rates:
    """A kind's whole call in s: ``fixed_s + steps * (step_s + worlds * world_step_s)``, and
    ``cold_s`` more for a worker's first call of its most specific kind."""

    fixed_s: float
    """s a call pays whatever its steps (model building, the exact solve, judging)."""
    step_s: float
    """s per step (a batch: per step of all its worlds at once)."""
    world_step_s: float = 0.0
    """s per step of each world of a batch (0 for an engine that steps one world)."""
    cold_s: float = 0.0
    """s a worker's first call of the kind pays more (imports, MJX's tracing and compiling)."""

    def seconds(self, call: CallCost, cold: bool = False) -> float:
        """The call's seconds by these rates."""
        per_step = self.step_s + call.worlds * self.world_step_s
        return self.fixed_s + call.steps * per_step + (self.cold_s if cold else 0.0)


@dataclass(frozen=True)
class Costing:
    """How the runner weighs its calls for the ETA."""

    cost: Callable[[Sequence[object]], CallCost]
    """The tasks of one call (one task, or a batch's) -> its kinds, steps and worlds."""
    prior: Mapping[Hashable, Rates]
    """A kind's rates before any call of it has finished here."""


@dataclass(frozen=True)
class Took:
    """A finished call and what it took."""

    call: CallCost
    seconds: float
    cold: bool = False
    """Its worker had run no call of its most specific kind before (module docstring)."""


def prior_rates(call: CallCost, prior: Mapping[Hashable, Rates]) -> Rates | None:
    """The rates of the call's most specific kind that has a prior; None without."""
    return next((prior[kind] for kind in call.kinds if kind in prior), None)


def prior_seconds(
    call: CallCost, prior: Mapping[Hashable, Rates], cold: bool = False
) -> float | None:
    """The call's seconds by the prior of its most specific kind that has one; None without."""
    rates = prior_rates(call, prior)
    return None if rates is None else rates.seconds(call, cold)


def _said(finished: Iterable[Took], prior: Mapping[Hashable, Rates]) -> list[tuple[Took, float]]:
    """The finished calls a prior knows, each with what the prior said of it (> 0)."""
    pairs = [(done, prior_seconds(done.call, prior, done.cold)) for done in finished]
    return [(done, said) for done, said in pairs if said is not None and said > 0]


def _ratios(pairs: Iterable[tuple[Took, float]]) -> dict[Hashable, float]:
    """Kind -> its calls' seconds over what was said of them, over every call that has
    the kind at any level."""
    took: dict[Hashable, float] = {}
    said: dict[Hashable, float] = {}
    for done, expected in pairs:
        for kind in done.call.kinds:
            took[kind] = took.get(kind, 0.0) + done.seconds
            said[kind] = said.get(kind, 0.0) + expected
    return {kind: took[kind] / said[kind] for kind in said}


def kind_factors(
    finished: Iterable[Took], prior: Mapping[Hashable, Rates]
) -> dict[Hashable, float]:
    """Kind -> its finished warm calls' seconds over what the priors said of them, over
    every warm call that has the kind at any level (module docstring: cold calls apart)."""
    return _ratios((done, said) for done, said in _said(finished, prior) if not done.cold)


def machine_factor(finished: Sequence[Took], prior: Mapping[Hashable, Rates]) -> float:
    """How much slower this machine, now, runs the finished calls than the priors say: the
    median over their most general kinds (an engine) of each one's seconds over the
    priors' (1 with none a prior knows), the warm calls' when there are any. A loaded
    machine or a slower one scales the priors of the kinds not measured yet alike; the
    median keeps one engine whose prior is off for a suite (Drake's warm calls took 1.8
    times theirs in the default suite, the others 0.9-1.3) from scaling every other."""
    known = _said(finished, prior)
    warm = [(done, said) for done, said in known if not done.cold]
    ratios = _ratios((done, said) for done, said in (warm or known))
    engines = sorted(ratios[kind] for kind in {done.call.kinds[-1] for done, _ in warm or known})
    return float(statistics.median(engines)) if engines else 1.0


def once_factors(
    finished: Iterable[Took], prior: Mapping[Hashable, Rates], machine: float
) -> dict[Hashable, float]:
    """Most specific kind -> for its finished cold calls: what they took beyond their steps
    at the ``machine`` factor, over what their priors say a call pays once (the fixed part
    and the cold part), at least 0. A kind whose priors say nothing of such a part is left
    out. Only the most specific: with cold caches Newton's first call compiled Warp's
    kernels (16 times its once-part), which its worker's calls of other variants then did
    not pay again."""
    took: dict[Hashable, float] = {}
    once: dict[Hashable, float] = {}
    for done in finished:
        rates = prior_rates(done.call, prior)
        if not done.cold or rates is None:
            continue
        fixed = rates.fixed_s + rates.cold_s
        stepping = rates.seconds(done.call) - rates.fixed_s
        kind = done.call.kinds[0] if done.call.kinds else None
        took[kind] = took.get(kind, 0.0) + done.seconds - machine * stepping
        once[kind] = once.get(kind, 0.0) + fixed
    return {kind: max(took[kind], 0.0) / once[kind] for kind in once if once[kind] > 0}


@dataclass(frozen=True)
class Running:
    """A call in flight that has started."""

    call: CallCost
    ran: float
    """s it has run."""
    cold: bool = False


class _Estimate:
    """Each call's expected seconds, from the priors scaled by the finished calls."""

    def __init__(self, finished: Sequence[Took], prior: Mapping[Hashable, Rates]) -> None:
        self.prior = prior
        self.factors = kind_factors(finished, prior)
        self.machine = machine_factor(finished, prior)
        self.once = once_factors(finished, prior, self.machine)
        steps = sum(done.call.steps for done in finished)
        # A call no prior knows: every finished call's mean seconds per step, else per call.
        self.per_step = sum(d.seconds for d in finished) / steps if steps > 0 else None
        self.per_call = sum(d.seconds for d in finished) / len(finished) if finished else None

    def seconds(self, call: CallCost, cold: bool) -> float | None:
        rates = prior_rates(call, self.prior)
        if rates is None:
            if call.steps > 0 and self.per_step is not None:
                return self.per_step * call.steps
            return self.per_call
        for kind in call.kinds:  # the most specific kind measured
            if kind in self.factors:
                return rates.seconds(call, cold) * self.factors[kind]
            if cold and kind in self.once:  # measured by cold calls only (module docstring)
                once = rates.fixed_s + rates.cold_s
                stepping = rates.seconds(call) - rates.fixed_s
                return once * self.once[kind] + stepping * self.machine
        return rates.seconds(call, cold) * self.machine


def remaining_seconds(
    pending: Sequence[CallCost],
    running: Sequence[Running],
    finished: Sequence[Took],
    workers: int,
    prior: Mapping[Hashable, Rates],
    warm: Mapping[Hashable, int] | None = None,
) -> float | None:
    """Seconds until the sweep ends: ``pending`` calls (in submission order) and the
    ``running`` ones laid out on ``workers`` workers, each at its expected seconds (module
    docstring). ``warm``: most specific kind -> workers that have run a call of it; the
    first pending calls of a kind, one per worker that has not, are cold. None when a call
    has no prior and no call has finished yet."""
    ends = call_ends(pending, running, finished, workers, prior, warm)
    return None if ends is None else max([0.0, *ends[0], *ends[1]])


def call_ends(
    pending: Sequence[CallCost],
    running: Sequence[Running],
    finished: Sequence[Took],
    workers: int,
    prior: Mapping[Hashable, Rates],
    warm: Mapping[Hashable, int] | None = None,
) -> tuple[list[float], list[float]] | None:
    """When each of the ``running`` calls and each of the ``pending`` ones is expected to
    end, s from now, laid out as :func:`remaining_seconds` lays them (sweeps that share the
    workers: which call of which ends when)."""
    estimate = _Estimate(finished, prior)
    workers = max(workers, 1)
    cold_left = Counter({kind: workers - n for kind, n in (warm or {}).items()})
    free = [0.0] * workers  # when each worker is next free, s from now
    running_ends: list[float] = []
    for run in running:
        expected = estimate.seconds(run.call, run.cold)
        if expected is None:
            return None
        # A call past its expected cost has an unknown rest: a tenth of what it has run.
        rest = expected - run.ran if expected > run.ran else 0.1 * run.ran
        running_ends.append(free[0] + rest)
        heapq.heapreplace(free, running_ends[-1])
    pending_ends: list[float] = []
    for call in pending:
        kind = call.kinds[0] if call.kinds else None
        if kind not in cold_left:
            cold_left[kind] = workers
        cold = cold_left[kind] > 0
        cold_left[kind] -= 1
        expected = estimate.seconds(call, cold)
        if expected is None:
            return None
        pending_ends.append(free[0] + expected)
        heapq.heapreplace(free, pending_ends[-1])
    return running_ends, pending_ends
