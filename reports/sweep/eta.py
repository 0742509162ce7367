"""The time a sweep has left, from what its calls are expected to cost.

A sweep's calls differ in cost by orders of magnitude (a pymunk run at dt 1e-3 takes a tenth
of a second, an MJX batch a minute), and they finish in no particular order: the cheap ones
first. An ETA from the count of calls finished (elapsed / done * left) is then 5-10 times
off (issue 34).

Here each call has kinds (from the most specific, e.g. an engine and its settings, to the
most general, the engine), a number of steps (a batch: its longest world's), of worlds and
of world-steps (a batch's worlds' steps as its engine pays them, the caller's rule: summed
where each world stops at its own end, else its longest world's times its worlds), and a
prior for its most specific kind that has one (:class:`Rates`): a fixed part that every
call pays whatever its steps (a worker's imports, model building, tracing and compiling,
the exact solve, judging), a part per step and, for a batch, a part per world-step, and
what a worker's first call of the kind pays once more.
A call at 1e-4 s is mostly stepping and one at 1e-3 s mostly its fixed part: a prior per
step alone, measured on the one, is 2-5 times off on the other.

What the priors say is then scaled by what the finished calls measured: by a kind's own
factor (its finished warm calls' seconds over what the priors said of them, the most
specific kind that has any), else by the machine's (:func:`machine_factor`: the median
engine's warm calls' seconds over what the priors said of them; a loaded or slower machine
scales every kind not measured yet alike). A kind's own factor counts :data:`KIND_CREDIBLE_S`
(a second, the progress lines' interval) of said seconds more at the machine's factor: a
kind whose calls have said less than about a second is measured on a few calls, whose cost
spreads far more than the machine's speed does (the map's classification: points that
solve their window, 60-80 ms, came first, then points that return at once, 2-4 ms; its
factor from the first 41 of 100 points said 1.6 s left of a 3.6-s step where 0.95 s were,
1.66 times the time left, while the machine's factor said 0.81 s). A kind measured on many
seconds is its own.

Some calls pay once what the others do not (:class:`Rates`): a worker's first call of a
kind (cold: imports, MJX's tracing), a worker's first call of an engine whichever kind it
is (first: Warp's kernels, compiled by each worker into an empty cache), and the machine's
first call of a kind on any worker (new: MJX's XLA program, compiled once into the cache
every worker reads). The calls left are laid out with each of these where it falls (the
first pending calls of a kind or an engine, one per worker that has not run it, or one in
all for calls that keep to the worker that has run one, :attr:`CallCost.affine`: a batched
engine's; the first of a kind no worker has run), and what a first or new call pays more
is taken at the machine's factor: it is a compile, not a sample of the kind (nor, below,
of its cold calls).

A cold call (its worker's first of its kind) is no sample of a kind's stepping: with cold
caches MJX's first calls of 3,000 steps were mostly compiling (2-3 times their prior), and
that factor on the finer suite's 30,000-step call made its ETA 3.1-3.3 times the time left.
So a cold call of a kind measured by cold calls only is expected at the part of its prior
that a call pays once (fixed and cold) times what the kind's cold calls took beyond their
steps at the machine's factor (:func:`once_factors`), plus its steps at the machine's
factor; a warm call of such a kind at a more general kind's factor, else the machine's.

An engine measured by cold calls alone (with warm caches: the priors say all they pay)
may run faster here than the median engine: MJX's compiled stepping ran 1.56 times its
EPYC prior on the Intel Xeon where the median engine ran 1.9-2.0, and its four cold calls
of the default suite 1.55 times theirs; the finer suite's 30,000-step call, its first warm
one, at the machine's factor read 1.2 times the time left throughout. A cold call pays
what its prior does not know only more, never less, so an engine's cold calls that took
less than their priors at the machine's factor scale its warm calls
(:func:`cold_engine_factors`); more says nothing of its stepping.

The calls left are then handed out in the order they are submitted, as the pool hands them
(a call in flight keeps its worker for what it has left): the worker free first takes the
first call that is its own, a batched engine's only on a worker that holds its affinity key
(has run one of its calls, running one now or not: :func:`key_holders`; or that no worker
holds it yet) unless nothing else is left, and the ETA is when the last one ends. A cold make
report's map classification (100 points, 6 s on one worker) read 2.6-14 times the time left
while the layout knew only the running calls' engines: the worker that held MJX's key ran a
MuJoCo call, so the layout handed MJX's next 5.6-s call to the points' worker.

The runner knows nothing of engines: the caller gives each call's kinds, steps, worlds and
the priors (:class:`Costing`).
"""

from __future__ import annotations

import statistics
from collections import Counter
from collections.abc import Callable, Collection, Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, replace

__all__ = [
    "KIND_CREDIBLE_S",
    "CallCost",
    "Costing",
    "Key",
    "Rates",
    "Took",
    "call_ends",
    "call_firsts",
    "cold_engine_factors",
    "key_holders",
    "kind_factors",
    "machine_factor",
    "once_factors",
    "own_call",
    "ran",
    "remaining_seconds",
    "warm_counts",
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
    world_steps: float | None = None
    """Its worlds' steps as its engine pays them (the caller's rule: a MuJoCo batch stops
    stepping each world at its own end, so its worlds' steps summed); None: ``steps``
    times ``worlds``, every world stepping to the longest's end (:attr:`paid_world_steps`)."""
    affinity: Hashable | None = None
    """The pool's affinity key of its calls (the runner's ``Batching.affinity``), else None:
    its calls keep to the worker that holds the key (that has run a call of it), and what a
    worker's first call of its kind or engine pays is laid out as paid on one worker, not
    on each. The key, not the engine: the map's MuJoCo batches, costed as their own kind
    (('map', 'mujoco')), hold the same key as the suites' ('mujoco')."""

    @property
    def affine(self) -> bool:
        """Whether its calls keep to the worker that holds their key (:attr:`affinity`)."""
        return self.affinity is not None

    @property
    def paid_world_steps(self) -> float:
        """:attr:`world_steps`, else ``steps`` times ``worlds`` (a calls file recorded
        before world-steps were: report-runs --calls)."""
        return self.steps * self.worlds if self.world_steps is None else self.world_steps


@dataclass(frozen=True)
class Rates:
    """A kind's whole call in s: ``fixed_s + steps * step_s + world_steps * world_step_s``
    (:attr:`CallCost.paid_world_steps`), and ``cold_s`` more for a worker's first call of
    its most specific kind."""

    fixed_s: float
    """s a call pays whatever its steps (model building, the exact solve, judging)."""
    step_s: float
    """s per step (a batch: per step of all its worlds at once)."""
    world_step_s: float = 0.0
    """s per world-step of a batch (:attr:`CallCost.paid_world_steps`; 0 for an engine that
    steps one world)."""
    cold_s: float = 0.0
    """s a worker's first call of the kind pays more (imports, MJX's tracing and compiling)."""
    first_s: float = 0.0
    """s a worker's first call of the engine (the most general kind), whichever kind it is,
    pays more: what every kind of the engine shares (Warp's kernels, compiled into an empty
    cache by each worker that runs the engine)."""
    new_s: float = 0.0
    """s the machine's first call of the kind (on any worker) pays more: a compile that
    lands in a cache every worker reads (MJX's XLA program of the kind)."""

    def seconds(
        self, call: CallCost, cold: bool = False, first: bool = False, new: bool = False
    ) -> float:
        """The call's seconds by these rates (``first`` and ``new`` calls are also cold)."""
        return self.per_call(call, cold) + self.once(first, new)

    def per_call(self, call: CallCost, cold: bool = False) -> float:
        """The call's seconds but what a worker's first call of the engine and the machine's
        first call of the kind pay more."""
        stepping = call.steps * self.step_s + call.paid_world_steps * self.world_step_s
        return self.fixed_s + stepping + (self.cold_s if cold else 0.0)

    def once(self, first: bool, new: bool) -> float:
        """What a worker's first call of the engine (``first``) and the machine's first call
        of the kind (``new``) pay more."""
        return (self.first_s if first else 0.0) + (self.new_s if new else 0.0)


@dataclass(frozen=True)
class Costing:
    """How the runner weighs its calls for the ETA."""

    cost: Callable[[Sequence[object]], CallCost]
    """The tasks of one call (one task, or a batch's) -> its kinds, steps and worlds."""
    prior: Mapping[Hashable, Rates]
    """A kind's rates before any call of it has finished here."""
    taken: Callable[[Sequence[object], Sequence[object]], float | None] | None = None
    """The tasks of a finished call and its rows (one per task) -> the world-steps it took
    (None: not known), by the same rule as ``cost``'s; None: not measured."""


@dataclass(frozen=True)
class Took:
    """A finished call and what it took."""

    call: CallCost
    seconds: float
    cold: bool = False
    """Its worker had run no call of its most specific kind before (module docstring)."""
    first: bool = False
    """Its worker had run no call of its engine (most general kind) before: also cold."""
    new: bool = False
    """No worker had run a call of its most specific kind before: also cold."""
    worker: Hashable = None
    """Which worker ran it (a WorkerPool's: its pid), where known."""
    started: float | None = None
    """time.monotonic() when it started, where known."""
    cpu_s: float | None = None
    """CPU s its worker spent on it, where known (:attr:`PoolFuture.cpu_s`)."""
    world_steps: float | None = None
    """The world-steps it took, as its rows say them (:attr:`Costing.taken`), where known:
    what the priors are fitted on (report-runs --calls); the ETA reads ``call``'s."""


def prior_rates(call: CallCost, prior: Mapping[Hashable, Rates]) -> Rates | None:
    """The rates of the call's most specific kind that has a prior; None without."""
    return next((prior[kind] for kind in call.kinds if kind in prior), None)


def prior_seconds(
    call: CallCost,
    prior: Mapping[Hashable, Rates],
    cold: bool = False,
    first: bool = False,
    new: bool = False,
) -> float | None:
    """The call's seconds by the prior of its most specific kind that has one; None without."""
    rates = prior_rates(call, prior)
    return None if rates is None else rates.seconds(call, cold, first, new)


def _said(finished: Iterable[Took], prior: Mapping[Hashable, Rates]) -> list[tuple[Took, float]]:
    """The finished calls a prior knows, each with what the prior said of it (> 0)."""
    pairs = [
        (done, prior_seconds(done.call, prior, done.cold, done.first, done.new))
        for done in finished
    ]
    return [(done, said) for done, said in pairs if said is not None and said > 0]


def _ratios(
    pairs: Iterable[tuple[Took, float]], machine: float = 1.0, credible_s: float = 0.0
) -> dict[Hashable, float]:
    """Kind -> its calls' seconds over what was said of them, over every call that has
    the kind at any level, ``credible_s`` more said seconds taken at ``machine``."""
    took: dict[Hashable, float] = {}
    said: dict[Hashable, float] = {}
    for done, expected in pairs:
        for kind in done.call.kinds:
            took[kind] = took.get(kind, 0.0) + done.seconds
            said[kind] = said.get(kind, 0.0) + expected
    return {kind: (took[kind] + credible_s * machine) / (said[kind] + credible_s) for kind in said}


KIND_CREDIBLE_S = 1.0
"""s of a kind's calls (as its priors say them) that count as much as what its finished
calls measured: a kind's factor is its calls' seconds and this many more at the machine's
factor, over what the priors said of them and this many more (module docstring)."""


def kind_factors(
    finished: Iterable[Took], prior: Mapping[Hashable, Rates], machine: float = 1.0
) -> dict[Hashable, float]:
    """Kind -> its finished warm calls' seconds over what the priors said of them, over
    every warm call that has the kind at any level (module docstring: cold calls apart),
    with :data:`KIND_CREDIBLE_S` more said seconds taken at the ``machine`` factor."""
    pairs = [(done, said) for done, said in _said(finished, prior) if not done.cold]
    return _ratios(pairs, machine, KIND_CREDIBLE_S)


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
    out. Only the most specific, and only calls whose priors say no compile (a worker's
    first call of the engine, the machine's first of the kind: :meth:`Rates.once`): with
    cold caches MuJoCo Warp's first call in a worker compiled Warp's kernels (80 times its
    once-part, when the priors knew no compile), which that kind's
    first call in the other worker, whose kernels were compiled, then did not pay (0.3 s:
    this factor had said 32 s, the default suite's ETA 2.0 times the time left)."""
    took: dict[Hashable, float] = {}
    once: dict[Hashable, float] = {}
    for done in finished:
        rates = prior_rates(done.call, prior)
        if not done.cold or rates is None or rates.once(done.first, done.new) > 0:
            continue
        fixed = rates.fixed_s + rates.cold_s
        stepping = rates.seconds(done.call) - rates.fixed_s
        kind = done.call.kinds[0] if done.call.kinds else None
        took[kind] = took.get(kind, 0.0) + done.seconds - machine * stepping
        once[kind] = once.get(kind, 0.0) + fixed
    return {kind: max(took[kind], 0.0) / once[kind] for kind in once if once[kind] > 0}


def cold_engine_factors(
    finished: Iterable[Took], prior: Mapping[Hashable, Rates], machine: float
) -> dict[Hashable, float]:
    """Engine (most general kind) -> for its finished cold calls whose priors say no
    compile into an empty cache (:meth:`Rates.once` 0: their priors say all they pay,
    their cold part included): their seconds over what their priors said of them, with
    :data:`KIND_CREDIBLE_S` more at the ``machine`` factor, where that is below the
    machine's. A cold call pays what its prior does not know only more, never less (a
    compile the priors took as done, as MJX's 3,000-step calls paid 20 s beyond theirs
    with cold caches the priors did not know of), so its factor above the machine's says
    nothing of its engine's stepping; below it, the engine runs faster here than the
    median engine: MJX's compiled stepping ran 1.56 times its EPYC prior on the Intel
    Xeon where the median engine ran 1.9-2.0, its cold calls 1.55, and the finer suite's
    30,000-step call, its first warm one, was expected at the machine's factor: 1.2
    times the time left throughout."""
    pairs = [
        (replace(done, call=replace(done.call, kinds=done.call.kinds[-1:])), said)
        for done, said in _said(finished, prior)
        if done.cold and done.call.kinds and not _compiles(done, prior)
    ]
    factors = _ratios(pairs, machine, KIND_CREDIBLE_S)
    return {engine: factor for engine, factor in factors.items() if factor < machine}


def _compiles(done: Took, prior: Mapping[Hashable, Rates]) -> bool:
    """Whether the priors say the call compiles into an empty cache (:meth:`Rates.once`)."""
    rates = prior_rates(done.call, prior)
    return rates is None or rates.once(done.first, done.new) > 0


@dataclass(frozen=True)
class Running:
    """A call in flight that has started."""

    call: CallCost
    ran: float
    """s it has run."""
    cold: bool = False
    first: bool = False
    new: bool = False
    worker: Hashable = None
    """Which worker runs it (a WorkerPool's: its pid), where known: the calls laid out after
    it queue on that worker, which holds the affinity keys it has run (:func:`key_holders`)."""


class _Estimate:
    """Each call's expected seconds, from the priors scaled by the finished calls."""

    def __init__(self, finished: Sequence[Took], prior: Mapping[Hashable, Rates]) -> None:
        self.prior = prior
        self.machine = machine_factor(finished, prior)
        self.factors = kind_factors(finished, prior, self.machine)
        self.once = once_factors(finished, prior, self.machine)
        self.engines = cold_engine_factors(finished, prior, self.machine)
        steps = sum(done.call.steps for done in finished)
        # A call no prior knows: every finished call's mean seconds per step, else per call.
        self.per_step = sum(d.seconds for d in finished) / steps if steps > 0 else None
        self.per_call = sum(d.seconds for d in finished) / len(finished) if finished else None

    def seconds(
        self, call: CallCost, cold: bool, first: bool = False, new: bool = False
    ) -> float | None:
        rates = prior_rates(call, self.prior)
        if rates is None:
            if call.steps > 0 and self.per_step is not None:
                return self.per_step * call.steps
            return self.per_call
        # A compile into an empty cache is the machine's, not the kind's (module docstring).
        once = rates.once(first, new) * self.machine
        for kind in call.kinds:  # the most specific kind measured
            if kind in self.factors:
                return rates.per_call(call, cold) * self.factors[kind] + once
            if cold and kind in self.once:  # measured by cold calls only (module docstring)
                fixed = rates.fixed_s + rates.cold_s
                stepping = rates.per_call(call) - rates.fixed_s
                return fixed * self.once[kind] + stepping * self.machine + once
        # A warm call of an engine measured by cold calls alone, where they say it runs
        # faster here than the median engine (cold_engine_factors); a cold call's own
        # compile is the kind's, not the engine's (MJX's ran 0.9-2.0 times their priors).
        factor = self.machine if cold else self.engines.get(_engine(call), self.machine)
        return rates.per_call(call, cold) * factor + once


_last_estimate: tuple[Sequence[Took], int, Took | None, Mapping[Hashable, Rates], _Estimate] | None
_last_estimate = None
"""The last :class:`_Estimate` made, with the ``finished`` and ``prior`` it was made from
(held, so that their ids cannot be reused) and how long ``finished`` was then."""


def _estimate(finished: Sequence[Took], prior: Mapping[Hashable, Rates]) -> _Estimate:
    """``_Estimate(finished, prior)``, made once for the same ``finished`` (an append-only
    list: the same object, length and last call) and the same ``prior`` object: a progress
    line of ``make report`` costs its calls twice over the same finished calls (their
    layout, Plan.etas, and the report after them; three times when the sweep's ETA and the
    plan's were laid out apart), and making the estimate went through all of them each time
    (4.6 of the parent's 26 CPU-s on a loaded run)."""
    global _last_estimate
    last = finished[-1] if finished else None
    kept = _last_estimate
    if (
        kept is not None
        and kept[0] is finished
        and kept[1] == len(finished)
        and kept[2] is last
        and kept[3] is prior
    ):
        return kept[4]
    made = _Estimate(finished, prior)
    _last_estimate = (finished, len(finished), last, prior, made)
    return made


def remaining_seconds(
    pending: Sequence[CallCost],
    running: Sequence[Running],
    finished: Sequence[Took],
    workers: int,
    prior: Mapping[Hashable, Rates],
    warm: Mapping[Hashable, int] | None = None,
    holders: Mapping[Hashable, Collection[Hashable]] | None = None,
) -> float | None:
    """Seconds until the sweep ends: ``pending`` calls (in submission order) and the
    ``running`` ones laid out on ``workers`` workers, each at its expected seconds (module
    docstring). ``warm``: kind (at every level, :func:`warm_counts`) -> workers that have
    run a call of it; the first pending calls of a most specific kind, one per worker that
    has not, are cold, those of an engine (the most general kind) first, and the first of a
    kind no worker has run new (:class:`Took`). ``holders``: affinity key -> the workers that
    hold it (:func:`key_holders`), which the calls of that key keep to. None when
    a call has no prior and no call has finished yet."""
    ends = call_ends(pending, running, finished, workers, prior, warm, holders)
    return None if ends is None else max([0.0, *ends[0], *ends[1]])


def call_ends(
    pending: Sequence[CallCost],
    running: Sequence[Running],
    finished: Sequence[Took],
    workers: int,
    prior: Mapping[Hashable, Rates],
    warm: Mapping[Hashable, int] | None = None,
    holders: Mapping[Hashable, Collection[Hashable]] | None = None,
) -> tuple[list[float], list[float]] | None:
    """When each of the ``running`` calls and each of the ``pending`` ones is expected to
    end, s from now, laid out as :func:`remaining_seconds` lays them (sweeps that share the
    workers: which call of which ends when)."""
    estimate = _estimate(finished, prior)
    workers = max(workers, 1)
    cold_left = Counter({kind: workers - n for kind, n in (warm or {}).items()})
    affine_left = Counter({kind: 1 - n for kind, n in (warm or {}).items()})
    seen = {kind for kind, n in (warm or {}).items() if n > 0}
    free = [0.0] * workers  # when each worker is next free, s from now
    slots = _slots(running, holders or {}, workers)
    # An affinity key -> the workers that hold it: those that have run one of its
    # calls, not only those running one now (the pool's worker.keys).
    owners = {
        key: {slots[w] for w in ran_by if w in slots} for key, ran_by in (holders or {}).items()
    }
    running_ends: list[float] = []
    for run in running:
        expected = estimate.seconds(run.call, run.cold, run.first, run.new)
        if expected is None:
            return None
        # A call past its expected cost has an unknown rest: a tenth of what it has run.
        rest = expected - run.ran if expected > run.ran else 0.1 * run.ran
        worker = slots.get(run.worker, free.index(min(free)))
        free[worker] += rest
        running_ends.append(free[worker])
        if run.call.affine:
            owners.setdefault(run.call.affinity, set()).add(worker)
    expected_pending: list[float] = []
    for call in pending:
        kind = call.kinds[0] if call.kinds else None
        # A kind's first pending calls, one per worker that has not run it (one in all for
        # calls that keep to one worker).
        left, spread = (affine_left, 1) if call.affine else (cold_left, workers)
        cold = _first_of(kind, left, spread)
        # The engine's: its first pending calls, one per worker that has not run it.
        first = _first_of(call.kinds[-1], left, spread) if len(call.kinds) > 1 else cold
        new = kind not in seen
        seen.add(kind)
        expected = estimate.seconds(call, cold, first and cold, new and cold)
        if expected is None:
            return None
        expected_pending.append(expected)
    return running_ends, _laid_out(pending, expected_pending, free, owners)


def _engine(call: CallCost) -> Hashable:
    return call.kinds[-1] if call.kinds else None


def _slots(
    running: Sequence[Running], holders: Mapping[Hashable, Collection[Hashable]], workers: int
) -> dict[Hashable, int]:
    """Worker -> its place (0 .. ``workers`` - 1) in the layout: first the workers of the
    running calls, then the others that hold a key. A worker past ``workers`` is left out
    (one that died and was replaced: the pool heeds only its live workers' keys)."""
    known = [run.worker for run in running if run.worker is not None]
    known += sorted((w for ran_by in holders.values() for w in ran_by), key=repr)
    slots: dict[Hashable, int] = {}
    for worker in known:
        if worker not in slots and len(slots) < workers:
            slots[worker] = len(slots)
    return slots


def _laid_out(
    pending: Sequence[CallCost],
    expected: Sequence[float],
    free: list[float],
    owners: dict[Hashable, set[int]],
) -> list[float]:
    """When each pending call ends, handed out as the pool hands them (WorkerPool.submit_keyed):
    the worker free first takes the first pending call that is its own (one that keeps to no
    worker, or whose affinity key it holds, or that no worker holds yet), else the first
    pending call (it would not idle). So a batched engine's calls queue on its worker while
    the others' calls go to the other workers."""
    ends = [0.0] * len(pending)
    left = list(range(len(pending)))
    while left:
        worker = free.index(min(free))
        pick = next((j for j, i in enumerate(left) if own_call(pending[i], worker, owners)), 0)
        i = left.pop(pick)
        if pending[i].affine:
            owners.setdefault(pending[i].affinity, set()).add(worker)
        free[worker] += expected[i]
        ends[i] = free[worker]
    return ends


def own_call(call: CallCost, worker: Hashable, owners: Mapping[Hashable, Collection]) -> bool:
    """Whether ``worker`` takes ``call`` before any other queued call, as the pool hands
    them (WorkerPool.submit_keyed): one that keeps to no worker, or whose affinity key it
    holds, or whose key no worker holds yet (``owners``: affinity key -> the workers that
    hold it, :func:`key_holders`)."""
    runners = owners.get(call.affinity) if call.affine else None
    return not runners or worker in runners


def _first_of(kind: Hashable, cold_left: Counter[Hashable], workers: int) -> bool:
    """Whether the next pending call of ``kind`` is the first of it on a worker (of
    ``workers``, ``cold_left[kind]`` of which have not run it), counting it as run."""
    if kind not in cold_left:
        cold_left[kind] = workers
    cold_left[kind] -= 1
    return cold_left[kind] >= 0


def call_firsts(
    call: CallCost, worker: Hashable, warm: Collection[tuple[Hashable, Hashable]]
) -> tuple[bool, bool, bool]:
    """(cold, first, new) of ``call`` on ``worker`` (:class:`Took`), after the calls whose
    (worker, kind) at every level of their kinds are ``warm`` (:func:`ran`)."""
    kind = call.kinds[0] if call.kinds else None
    engine = _engine(call)
    cold = (worker, kind) not in warm
    first = (worker, engine) not in warm
    new = all(other != kind for _, other in warm)
    return cold, first and cold, new and cold


@dataclass(frozen=True)
class Key:
    """The affinity key a worker holds once it has run an affine call (the pool's
    ``worker.keys``, :meth:`WorkerPool.submit_keyed`): the call's :attr:`CallCost.affinity`."""

    name: Hashable


def ran(call: CallCost, worker: Hashable) -> set[tuple[Hashable, Hashable]]:
    """(worker, kind) at every level of ``call``'s kinds: what a worker that has run it is
    warm for (:func:`call_firsts`); and (worker, :class:`Key`) for an affine call."""
    pairs = {(worker, kind) for kind in call.kinds} if call.kinds else {(worker, None)}
    return pairs | ({(worker, Key(call.affinity))} if call.affine else set())


def key_holders(warm: Iterable[tuple[Hashable, Hashable]]) -> dict[Hashable, set[Hashable]]:
    """Affinity key -> the workers that hold it, from what they ran (:func:`ran`):
    ``call_ends``' ``holders``, and the replay's pool."""
    holders: dict[Hashable, set[Hashable]] = {}
    for worker, kind in warm:
        if isinstance(kind, Key):
            holders.setdefault(kind.name, set()).add(worker)
    return holders


def warm_counts(warm: Iterable[tuple[Hashable, Hashable]]) -> Counter[Hashable]:
    """Kind (at any level) -> workers that have run a call of it: ``call_ends``' ``warm``."""
    return Counter(kind for _, kind in warm)
