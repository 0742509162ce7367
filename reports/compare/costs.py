"""What a suite's runs and a map's are expected to cost, for the progress lines' ETA
(:mod:`hoopbench.reports.sweep.eta`).

A call (one run, or a batch of one batching engine and one settings) costs a fixed part, a
part per step (a batch: per step of its longest world) and, for a batch, a part per
world-step (:class:`~hoopbench.reports.sweep.eta.Rates`), by its kind: its engine, profile
and variant, else its engine. A map's runs stop at their first impact and classify their
point without stepping: their kinds are the map's own (``("map", engine)``). The runner
scales these by what the finished calls measured; until an engine has a finished call,
they are :data:`CALL_COST_PRIOR`'s scaled by the machine's factor.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import Any

from hoopbench.reports.sweep.eta import CallCost, Costing, Rates

__all__ = [
    "CALL_COST_PRIOR",
    "COSTING",
    "MAP",
    "MAP_COSTING",
    "REPORT",
    "call_cost",
    "map_call_cost",
]

MAP = "map"
"""The first part of a map's kinds."""
REPORT = "report"
"""The kind of `hoopbench report` run after make report's sweeps (reports/report_runs.py)."""

CALL_COST_PRIOR: dict[Hashable, Rates] = {
    # Rates(fixed_s, step_s, world_step_s, cold_s), fitted by
    # `python -m hoopbench.reports.bench.call_costs fit` on the whole calls of make report's
    # three suites (731 calls) and its map (304 calls), main at 2026-11-29 01:45 UTC (after
    # issue 34's MJX, Newton, worker and report changes), on the project's machine (AMD EPYC,
    # 2 cores, no GPU), idle (1-min load average 0.7 at the start), JAX's and Warp's caches
    # warm. A loaded or another machine (or cold caches) scales them by the machine factor.
    "box2d": Rates(0.011, 4.1e-06, 0.0, 0.003),
    "dart": Rates(0.015, 9.3e-06, 0.0, 0.011),
    "drake": Rates(0.082, 1.6e-05, 0.0, 0.08),
    "mjx": Rates(4.0, 0.0015, 0.00014),
    "mujoco": Rates(0.037, 6.4e-07, 7.9e-06, 0.1),
    "newton": Rates(1.1, 0.0, 0.00012, 0.74),
    "pybullet": Rates(0.018, 9.1e-06, 0.0, 0.0045),
    "pymunk": Rates(0.013, 2.6e-06),
    "rapier": Rates(0.0088, 8e-06),
    "reference": Rates(0.057, 8.9e-07, 0.0, 0.096),
    # Run only with a GPU (left out of make report's suites without one), not measured here:
    # whole calls over their steps, on the default suite with a lightly loaded machine
    # (2026-11-28 18:55 UTC): MuJoCo Warp's RK4 (tuned) against its Euler (stock), and
    # Newton's MuJoCo solver.
    "mjwarp": Rates(0.0, 0.012),
    ("mjwarp", "stock", "default"): Rates(0.0, 0.0053),
    ("mjwarp", "tuned", "default"): Rates(0.0, 0.018),
    ("newton", "tuned", "solver=mujoco"): Rates(0.0, 0.0071),
    # The map's (make report's: 10 x 10, MuJoCo in 4 batches of 25, 1e-4 s; its runs stop
    # at their first impact, so a step of its window costs less than a suite's): its 304
    # calls of the same idle make report. MuJoCo's 4 calls over their world-steps.
    (MAP, "reference"): Rates(0.022, 0.0, 0.0, 0.03),
    (MAP, "mujoco"): Rates(0.0, 0.0, 7.6e-06, 2.2),
    (MAP, "pybullet"): Rates(0.0, 6.1e-06, 0.0, 0.21),
    (MAP, "pymunk"): Rates(0.0, 1.9e-06, 0.0, 0.011),
    # `hoopbench report` of the three suites, the map, the shipped searches and bench (make
    # report's last step): 22 s on the same idle make report.
    REPORT: Rates(22.0, 0.0),
}
"""A kind's whole call (:class:`~hoopbench.reports.sweep.eta.Rates`) before any call of it
has finished here: by engine, by engine, profile and variant where those differ, by the
map's engine and the report."""


def call_cost(tasks: Sequence[Any]) -> CallCost:
    """A call's kinds (engine, profile and variant; then engine), steps (a batch's worlds
    step together: its longest world's) and worlds."""
    first = tasks[0]
    engine = first.engine
    specific = (engine, str(getattr(first, "profile", "")), getattr(first, "variant", ""))
    steps = max(task.n_steps for task in tasks)
    return CallCost(kinds=(specific, engine), steps=steps, worlds=len(tasks))


def map_call_cost(tasks: Sequence[Any]) -> CallCost:
    """A map call's kinds (map, engine, profile and timestep; then map and engine), steps
    (its window's: an early stop only shortens it) and worlds."""
    first = tasks[0]
    engine = first.engine
    specific = (MAP, engine, str(first.profile), first.timestep)
    steps = max(task.n_steps for task in tasks)
    return CallCost(kinds=(specific, (MAP, engine)), steps=steps, worlds=len(tasks))


COSTING = Costing(cost=call_cost, prior=CALL_COST_PRIOR)
"""The Costing of a suite's runs (compare)."""
MAP_COSTING = Costing(cost=map_call_cost, prior=CALL_COST_PRIOR)
"""The Costing of a map's runs (both stages)."""
