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
    # three suites (731 calls) and its map (304 calls), main at 6a50fe6, 2026-11-29
    # 00:25-00:48 UTC, on the project's machine (AMD EPYC, 2 cores, no GPU) under load: 1-min
    # load average 6-11 from other work, where the wall times are 2-4 times an idle
    # machine's. A loaded or another machine scales them all by the machine factor.
    "box2d": Rates(0.025, 2.7e-05, 0.0, 0.13),
    "dart": Rates(0.0058, 6.6e-05, 0.0, 0.23),
    "drake": Rates(0.072, 9.6e-05, 0.0, 0.25),
    "mjx": Rates(35.0, 0.0, 0.00059),
    "mujoco": Rates(0.18, 9.9e-06, 4e-05, 0.56),
    "newton": Rates(12.0, 0.0, 0.00071, 3.8),
    "pybullet": Rates(0.093, 3.4e-05),
    "pymunk": Rates(0.031, 1.5e-05, 0.0, 0.096),
    "rapier": Rates(0.014, 4.8e-05, 0.0, 0.034),
    "reference": Rates(0.0098, 7.1e-06, 0.0, 0.87),
    # Run only with a GPU (left out of make report's suites without one), not measured here:
    # whole calls over their steps, on the default suite with a lightly loaded machine
    # (2026-11-28 18:55 UTC): MuJoCo Warp's RK4 (tuned) against its Euler (stock), and
    # Newton's MuJoCo solver.
    "mjwarp": Rates(0.0, 0.012),
    ("mjwarp", "stock", "default"): Rates(0.0, 0.0053),
    ("mjwarp", "tuned", "default"): Rates(0.0, 0.018),
    ("newton", "tuned", "solver=mujoco"): Rates(0.0, 0.0071),
    # The map's (make report's: 10 x 10, MuJoCo in 4 batches of 25, 1e-4 s; its runs stop
    # at their first impact, so a step of its window costs less than a suite's): 304 calls,
    # load 12. MuJoCo's 4 calls (35-56 s) over their world-steps.
    # Its classification: refitted on 200 calls with the fit's weighting floor, after the
    # relative fit (0.0022 s) let the 2 ms points outweigh the 0.2 s ones: the map's first
    # stage then said "eta 0s" with 9 s left.
    (MAP, "reference"): Rates(0.13, 0.0, 0.0, 0.17),
    (MAP, "mujoco"): Rates(0.0, 0.0, 6e-05),
    (MAP, "pybullet"): Rates(0.0, 1.1e-05, 0.0, 1.4),
    (MAP, "pymunk"): Rates(0.0, 3.7e-06, 0.0, 0.25),
    # `hoopbench report` of the three suites, the map, the shipped searches and bench (make
    # report's last step): about 50 s on 2 idle cores (note43), times the load's 3.
    REPORT: Rates(150.0, 0.0),
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
