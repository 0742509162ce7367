"""``make report``'s sweeps in one process (``hoopbench report-runs``): its three suites and
its map, each into its own folder as ``hoopbench compare`` and ``hoopbench map`` run them,
with one progress line over them all (:mod:`hoopbench.reports.sweep.plan`).

They overlap on one shared :class:`~hoopbench.reports.sweep.runner.WorkerPool`
(:func:`run_steps`): each step runs in a thread of its own, and begins once the step before
it has nothing left queued, so its calls take the worker that the earlier step's tail would
leave idle (the finer suite is one 80-s MJX call: run in a row, the other worker waited for
it about a minute). Which worker runs a call does not change its row.

Before the first starts, every sweep's calls are worked out as their runs will be batched
(the suites' runs left out without a GPU left out here too), so that the ETA covers the
sweeps not started yet from their priors, scaled by what the finished calls measured (a
suite's engines at other timesteps in the next), and the report that ``make report`` runs
after them (:data:`~hoopbench.reports.compare.costs.REPORT`'s prior).
"""

from __future__ import annotations

import contextvars
import signal
import threading
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

from hoopbench.reports.compare.costs import (
    REPORT,
    call_cost,
    cold_caches,
    map_call_cost,
    priors,
)
from hoopbench.reports.compare.suite import (
    batch_affinity,
    batch_key,
    batch_least,
    run_task_batch,
)
from hoopbench.reports.compare.suite_file import STABILITY_SUITE, load_suite, suite_path
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import (
    MapTask,
    map_batch_key,
    planned_tasks,
    run_map_batch,
    run_map_task,
)
from hoopbench.reports.sweep.eta import CallCost
from hoopbench.reports.sweep.plan import Plan, PlannedSweep, current_lane, current_plan
from hoopbench.reports.sweep.runner import (
    IN_FLIGHT_PER_WORKER,
    Batching,
    StopFlag,
    TaskBatch,
    WorkerPool,
)

__all__ = ["MAP_STEP", "REPORT_SUITES", "Step", "report_plan", "run_steps"]

REPORT_SUITES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("default", ("--trajectories", "default")),
    ("finer", ()),
    (STABILITY_SUITE, ()),
)
"""make report's suites in order, each with its own options of ``hoopbench compare``."""
MAP_STEP = "the hop map"
"""The map's step, as the progress line names it."""


def _units(tasks: Sequence[object], batching: Batching | None, jobs: int) -> list[object]:
    return batching.units(tasks, jobs) if batching is not None else list(tasks)


def _tasks(unit: object) -> Sequence[object]:
    return unit.tasks if isinstance(unit, TaskBatch) else (unit,)


def _cost(unit: object, cost: Callable[[Sequence[object]], CallCost]) -> CallCost:
    """A call's cost as the runner works it out: keeping to one worker where it has an
    affinity key (the shared pool is a WorkerPool)."""
    call = cost(_tasks(unit))
    return replace(call, affinity=unit.affinity) if isinstance(unit, TaskBatch) else call


def suite_sweep(name: str, jobs: int, batch_size: int) -> PlannedSweep:
    """A shipped suite's runs and calls as ``compare`` will run them on this machine."""
    suite = load_suite(suite_path(name))
    tasks, _ = suite.for_machine(suite.tasks(None))
    batching = (
        Batching(run_task_batch, batch_key, batch_size, batch_least, batch_affinity)
        if batch_size > 1
        else None
    )
    calls = tuple(_cost(unit, call_cost) for unit in _units(tasks, batching, jobs))
    return PlannedSweep(name, len(tasks), calls)


def map_sweeps(
    spec: MapSpec, jobs: int, batch_size: int, engine_tasks: Sequence[MapTask] | None = None
) -> list[PlannedSweep]:
    """The map's two sweeps (the exact classification of its points, then its engines':
    ``engine_tasks`` if given, e.g. those of ``stages.classified_tasks``, else as planned
    before the classification, each costed by its window)."""
    refs, planned = planned_tasks(spec)
    engine_tasks = planned if engine_tasks is None else engine_tasks
    batching = (
        Batching(run_map_batch, map_batch_key, batch_size, batch_least, batch_affinity)
        if batch_size > 1
        else None
    )
    units = _units(engine_tasks, batching, jobs)
    return [
        PlannedSweep(MAP_STEP, len(refs), tuple(map_call_cost([ref]) for ref in refs)),
        PlannedSweep(MAP_STEP, len(engine_tasks), tuple(_cost(u, map_call_cost) for u in units)),
    ]


def report_plan(
    suites: Sequence[str],
    spec: MapSpec | None,
    jobs: int,
    batch_size: int,
    map_tasks: Sequence[MapTask] | None = None,
) -> Plan:
    """The plan of make report's sweeps: ``suites`` (shipped names), then the map of
    ``spec`` if any (its engine tasks ``map_tasks``: :func:`map_sweeps`), then the report
    (its prior). Their batches are the runner's: sized for its calls in flight
    (runner.IN_FLIGHT_PER_WORKER a worker)."""
    in_flight = IN_FLIGHT_PER_WORKER * jobs
    sweeps = [suite_sweep(name, in_flight, batch_size) for name in suites]
    if spec is not None:
        sweeps += map_sweeps(spec, in_flight, batch_size, map_tasks)
    report = CallCost(kinds=(REPORT,), steps=0)
    return Plan("make report", sweeps, priors(cold_caches()), jobs, after=(report,))


@dataclass(frozen=True)
class Step:
    """A step of make report: one command and the plan's sweeps it runs."""

    what: str
    """Its start line's words: 'suite 2 of 3 (finer)'."""
    argv: tuple[str, ...]
    """``hoopbench`` 's arguments that run it (with ``--out``)."""
    sweeps: int = 1
    """The plan's sweeps it runs (the map: its two stages)."""


PRELOAD = (run_task_batch.__module__, run_map_task.__module__)
"""What each worker of the shared pool imports before its first call (as each command's
own pool imports its worker's module)."""


def run_steps(
    plan: Plan,
    steps: Sequence[Step],
    run: Callable[[list[str]], int],
    say: Callable[[str], None],
    queued: Callable[[], object] | None = None,
) -> int:
    """Run ``steps`` (``run(argv)`` each, e.g. the CLI's main) under ``plan``, overlapping on
    one shared pool of ``plan.workers`` workers: each in its own thread, begun once the step
    before has nothing left queued. SIGINT and SIGTERM stop every step (each says how to
    resume it); a step that fails keeps the steps not begun from beginning. ``queued``, if
    given, is called (in a thread of its own) once the last step has nothing left queued,
    unless a step failed or a signal came first: what comes after the steps may start then,
    beside their last calls. The first failed step's exit code, else 0."""
    plan.stop = StopFlag()
    plan.pool = WorkerPool(plan.workers, preload=PRELOAD)
    codes = [0] * len(steps)
    threads: list[threading.Thread] = []
    first = 0
    for k, step in enumerate(steps):
        lane = deque(range(first, first + step.sweeps))
        context = contextvars.copy_context()
        context.run(current_plan.set, plan)
        context.run(current_lane.set, lane)
        target = _step_runner(plan, step, first, lane, run, say, codes, k)
        threads.append(threading.Thread(target=context.run, args=(target,), name=step.what))
        first += step.sweeps
    if queued is not None:
        threads.append(threading.Thread(target=_when_queued, args=(plan, first, queued)))
    handlers = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        for sig in handlers:
            signal.signal(sig, plan.stop)
        for thread in threads:
            thread.start()
        for thread in threads:
            while thread.is_alive():
                thread.join(0.2)  # the main thread stays free for the signal handlers
    finally:
        for sig, previous in handlers.items():
            signal.signal(sig, signal.SIG_DFL if previous is None else previous)
        pool, plan.pool = plan.pool, None
        pool.shutdown(wait=True)
    return next((code for code in codes if code), 0)


def _when_queued(plan: Plan, sweeps: int, queued: Callable[[], object]) -> None:
    """``queued()`` once the plan's last sweep (of ``sweeps``) has nothing left queued, unless
    a step failed or a signal came first."""
    if plan.wait_turn(sweeps):
        queued()


def _step_runner(
    plan: Plan,
    step: Step,
    first: int,
    lane: deque[int],
    run: Callable[[list[str]], int],
    say: Callable[[str], None],
    codes: list[int],
    k: int,
) -> Callable[[], None]:
    """The body of step ``k``'s thread: its turn, its command, its exit code into ``codes``."""

    def body() -> None:
        try:
            if not plan.wait_turn(first):
                return  # a step before failed, or a signal came: this one never began
            argv = list(step.argv)
            say(f"make report: {step.what} -> {argv[argv.index('--out') + 1]}")
            codes[k] = run(argv)
        except BaseException:
            codes[k] = codes[k] or 1
            raise
        finally:
            if codes[k]:
                plan.failed = True
            while lane:  # sweeps it did not run: the next step need not wait for them
                plan.drained(lane.popleft())
            plan.drained(first + step.sweeps - 1)

    return body
