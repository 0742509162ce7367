"""What a suite's runs are expected to cost, for the progress lines' ETA
(:mod:`hoopbench.reports.sweep.eta`).

A call (one run, or a batch of one batching engine and one settings) costs its steps times
the seconds per step of its kind: its engine, profile and variant, else its engine. The
runner measures those on the calls that finish; until an engine has a finished call, its
figure is :data:`STEP_COST_PRIOR`'s.
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from typing import Any

from hoopbench.reports.sweep.eta import CallCost, Costing

__all__ = ["COSTING", "STEP_COST_PRIOR", "call_cost"]

STEP_COST_PRIOR: dict[Hashable, float] = {
    "box2d": 7.4e-06,
    "dart": 1.6e-05,
    "drake": 4.3e-05,
    "mjwarp": 0.012,
    "mjx": 0.0024,
    "mujoco": 1.8e-05,
    "newton": 0.0017,
    "pybullet": 1.4e-05,
    "pymunk": 6.3e-06,
    "rapier": 1.2e-05,
    "reference": 1.7e-05,
    # The settings whose calls cost over twice their engine's: MuJoCo Warp's RK4 (tuned)
    # against its Euler (stock), and Newton's MuJoCo solver.
    ("mjwarp", "stock", "default"): 0.0053,
    ("mjwarp", "tuned", "default"): 0.018,
    ("newton", "tuned", "solver=mujoco"): 0.0071,
}
"""s per step of a call (a batch: per step of its longest world), by engine (and by engine,
profile and variant where that differs): whole calls (model building, compiling, stepping,
the exact solve and judging), their sum over their steps. Measured on the default suite of
`make report` on the project's 2-core machine without a GPU (2026-11-28 18:55 UTC, main at
ee8a481's parent: 486 runs, 446 calls, 222 s wall on a lightly loaded machine; the same
suite took 656 s under load at 16:42). On another machine, or under load, these are off by
a constant factor until the engine's first call finishes; the sweep's own measure then
takes over."""


def call_cost(tasks: Sequence[Any]) -> CallCost:
    """A call's kinds (engine, profile and variant; then engine) and steps (a batch's worlds
    step together: its longest world's)."""
    first = tasks[0]
    engine = first.engine
    specific = (engine, str(getattr(first, "profile", "")), getattr(first, "variant", ""))
    return CallCost(kinds=(specific, engine), steps=max(task.n_steps for task in tasks))


COSTING = Costing(cost=call_cost, prior=STEP_COST_PRIOR)
"""The Costing of a suite's runs (compare) and of a map's (its engine stage)."""
