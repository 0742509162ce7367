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

from collections.abc import Collection, Hashable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

from hoopbench.engines.base import cache_folder
from hoopbench.engines.registry import engine_classes
from hoopbench.reports.sweep.eta import CallCost, Costing, Rates

__all__ = [
    "CALL_COST_PRIOR",
    "COLD_CACHE_S",
    "MAP",
    "MAP_COSTING",
    "REPORT",
    "call_cost",
    "cold_caches",
    "map_call_cost",
    "priors",
    "suite_costing",
]

MAP = "map"
"""The first part of a map's kinds."""
REPORT = "report"
"""The kind of `hoopbench report` run after make report's sweeps (reports/report_runs.py)."""

CALL_COST_PRIOR: dict[Hashable, Rates] = {
    # Rates(fixed_s, step_s, world_step_s, cold_s), fitted by
    # `python -m hoopbench.reports.bench.call_costs fit` on the whole calls of make report's
    # three suites (742 calls) and its map (304 calls), main at 2026-11-29 08:09 UTC (after
    # Newton's and MuJoCo Warp's steps became Warp graphs replayed on the CPU, and MuJoCo
    # Warp and Newton's MuJoCo solver joined the suites there), on the project's machine
    # (AMD EPYC, 2 cores, no GPU), nearly idle (1-min load average 0.9 at the start), JAX's
    # and Warp's caches warm. A loaded or another machine (or cold caches) scales them by the
    # machine factor.
    "box2d": Rates(0.0089, 4.3e-06, 0.0, 0.012),
    "dart": Rates(0.018, 1e-05, 0.0, 0.012),
    "drake": Rates(0.08, 1.7e-05, 0.0, 0.12),
    "mjwarp": Rates(0.086, 0.00012, 0.0, 0.32),
    "mjx": Rates(1.3, 0.0014, 0.00015, 3.2),
    "mujoco": Rates(0.025, 2.6e-06, 7.1e-06, 0.054),
    "newton": Rates(0.14, 0.0, 5e-06, 0.36),
    "pybullet": Rates(0.016, 9.2e-06),
    "pymunk": Rates(0.012, 2.5e-06),
    "rapier": Rates(0.011, 8.2e-06, 0.0, 0.019),
    "reference": Rates(0.045, 5.1e-07, 0.0, 0.17),
    # The map's (make report's: 10 x 10, MuJoCo in 4 batches of 25, 1e-4 s; its runs stop
    # at their first impact, so a step of its window costs less than a suite's): its 304
    # calls of the same idle make report. MuJoCo's 4 calls over their world-steps.
    (MAP, "reference"): Rates(0.028, 0.0, 0.0, 0.037),
    (MAP, "mujoco"): Rates(0.0, 0.0, 6.4e-06, 1.5),
    (MAP, "pybullet"): Rates(0.0, 5.2e-06, 0.0, 0.14),
    (MAP, "pymunk"): Rates(0.0, 1.6e-06, 0.0, 0.042),
    # The report of the three suites, the map, the shipped searches and bench (make report's
    # last step, in report-runs' own process): 16 s on the same make report.
    REPORT: Rates(16.0, 0.0),
}
"""A kind's whole call (:class:`~hoopbench.reports.sweep.eta.Rates`) before any call of it
has finished here: by engine, by engine, profile and variant where those differ, by the
map's engine and the report."""


COLD_CACHE_S: dict[Hashable, float] = {
    # s more than its cold part: a make report with a new HOOPBENCH_CACHE against one with
    # warm caches, the same calls (2026-11-29 04:50 and 04:59 UTC, idle, 2 cores). A kind's
    # first call compiled its traced chunk with XLA where the warm run loaded it. Newton's
    # first call in each worker paid 7-17 s more whichever kind it was (its Warp kernels
    # serve every kind), which no kind's part can say: left out.
    ("mjx", "stock", "default"): 5.3,
    ("mjx", "tuned", "default"): 18.4,
    ("mjx", "tuned", "precision=float64"): 17.9,
    ("mjx", "tuned", "cone=pyramidal"): 10.7,
}
"""Most specific kind -> what its first call in a worker pays more while its engine's
compiled-code cache (``Engine.compiled_cache``) is empty: nothing else tells the ETA that
the caches are cold before those calls end (a cold make report's default suite: 0.58 of the
time left at 10 % of its runs with the warm priors)."""


def cold_caches() -> frozenset[str]:
    """The engines whose compiled-code cache folder holds no file yet."""
    return frozenset(
        name
        for name, cls in engine_classes().items()
        if cls.compiled_cache is not None and not _holds_a_file(cache_folder(cls.compiled_cache))
    )


def _holds_a_file(folder: Path) -> bool:
    try:
        return any(path.is_file() for path in folder.rglob("*"))
    except OSError:  # unreadable: nothing known of it, so taken as cold
        return False


def priors(cold: Collection[str] = ()) -> dict[Hashable, Rates]:
    """:data:`CALL_COST_PRIOR`, with each kind of :data:`COLD_CACHE_S` whose engine is in
    ``cold`` paying its seconds more on its cold calls."""
    found = dict(CALL_COST_PRIOR)
    for kind, more in COLD_CACHE_S.items():
        engine = kind[0] if isinstance(kind, tuple) else kind
        if engine in cold:
            rates = CALL_COST_PRIOR.get(kind, CALL_COST_PRIOR[engine])
            found[kind] = replace(rates, cold_s=rates.cold_s + more)
    return found


def suite_costing() -> Costing:
    """The Costing of a suite's runs, with this machine's caches as they are now."""
    return Costing(cost=call_cost, prior=priors(cold_caches()))


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


MAP_COSTING = Costing(cost=map_call_cost, prior=CALL_COST_PRIOR)
"""The Costing of a map's runs (both stages)."""
