"""``make report``'s sweeps in one process (``hoopbench report-runs``): its three suites and
its map, each into its own folder as ``hoopbench compare`` and ``hoopbench map`` run them,
with one progress line over them all (:mod:`hoopbench.reports.sweep.plan`).

Before the first starts, every sweep's calls are worked out as their runs will be batched
(the suites' runs left out without a GPU left out here too), so that the ETA covers the
sweeps not started yet from their priors, scaled by what the finished calls measured (a
suite's engines at other timesteps in the next), and the report that ``make report`` runs
after them (:data:`~hoopbench.reports.compare.costs.REPORT`'s prior).
"""

from __future__ import annotations

from collections.abc import Sequence

from hoopbench.engines.base import warp_sees_gpu
from hoopbench.reports.compare.costs import (
    CALL_COST_PRIOR,
    REPORT,
    call_cost,
    map_call_cost,
)
from hoopbench.reports.compare.suite import batch_key, batch_least, run_task_batch
from hoopbench.reports.compare.suite_file import load_suite, suite_path
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import map_batch_key, planned_tasks, run_map_batch
from hoopbench.reports.sweep.eta import CallCost
from hoopbench.reports.sweep.plan import Plan, PlannedSweep
from hoopbench.reports.sweep.runner import Batching, TaskBatch

__all__ = ["MAP_STEP", "REPORT_SUITES", "report_plan"]

REPORT_SUITES: tuple[tuple[str, tuple[str, ...]], ...] = (
    ("default", ("--trajectories", "default")),
    ("finer", ()),
    ("stability", ()),
)
"""make report's suites in order, each with its own options of ``hoopbench compare``."""
MAP_STEP = "the hop map"
"""The map's step, as the progress line names it."""


def _units(tasks: Sequence[object], batching: Batching | None, jobs: int) -> list[object]:
    return batching.units(tasks, jobs) if batching is not None else list(tasks)


def _tasks(unit: object) -> Sequence[object]:
    return unit.tasks if isinstance(unit, TaskBatch) else (unit,)


def suite_sweep(name: str, jobs: int, batch_size: int) -> PlannedSweep:
    """A shipped suite's runs and calls as ``compare`` will run them on this machine."""
    suite = load_suite(suite_path(name))
    tasks, _ = suite.for_machine(suite.tasks(None), warp_sees_gpu)
    batching = (
        Batching(run_task_batch, batch_key, batch_size, batch_least) if batch_size > 1 else None
    )
    calls = tuple(call_cost(_tasks(unit)) for unit in _units(tasks, batching, jobs))
    return PlannedSweep(name, len(tasks), calls)


def map_sweeps(spec: MapSpec, jobs: int, batch_size: int) -> list[PlannedSweep]:
    """The map's two sweeps (the exact classification of its points, then its engines')."""
    refs, engine_tasks = planned_tasks(spec)
    batching = (
        Batching(run_map_batch, map_batch_key, batch_size, batch_least) if batch_size > 1 else None
    )
    units = _units(engine_tasks, batching, jobs)
    return [
        PlannedSweep(MAP_STEP, len(refs), tuple(map_call_cost([ref]) for ref in refs)),
        PlannedSweep(MAP_STEP, len(engine_tasks), tuple(map_call_cost(_tasks(u)) for u in units)),
    ]


def report_plan(suites: Sequence[str], spec: MapSpec | None, jobs: int, batch_size: int) -> Plan:
    """The plan of make report's sweeps: ``suites`` (shipped names), then the map of
    ``spec`` if any, then the report (its prior)."""
    sweeps = [suite_sweep(name, jobs, batch_size) for name in suites]
    if spec is not None:
        sweeps += map_sweeps(spec, jobs, batch_size)
    report = CallCost(kinds=(REPORT,), steps=0)
    return Plan("make report", sweeps, CALL_COST_PRIOR, jobs, after=(report,))
