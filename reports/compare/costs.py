"""What a suite's runs and a map's are expected to cost, for the progress lines' ETA
(:mod:`hoopbench.reports.sweep.eta`).

A call (one run, or a batch of one batching engine and one settings) costs a fixed part, a
part per step (a batch: per step of its longest world) and, for a batch, a part per
world-step (:class:`~hoopbench.reports.sweep.eta.Rates`), by its kind: its engine, profile
and variant, else its engine. A batch's world-steps are its worlds' steps as its engine
pays them (:func:`batch_world_steps`, the one rule for what a call is expected to take and
what a finished one took): MuJoCo steps each world to its own end, so its worlds' steps
summed; an engine that steps all of a call's worlds until the last ends, its longest
world's times its worlds. A map's runs stop at their first impact and classify their
point without stepping: their kinds are the map's own (``("map", engine)``), and an engine
run's steps are those to where its stop rule ends it on the exact motion
(:func:`map_call_cost`; a MuJoCo batch of the map's points, each stopped at its own, was
costed as its longest world's steps times its worlds until 2026-11-29, when the map's ETA
at 75 % of its runs read 1.26-1.31 times the time left). The runner
scales these by what the finished calls measured; until an engine has a finished call,
they are :data:`CALL_COST_PRIOR`'s scaled by the machine's factor.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Hashable, Mapping, Sequence
from dataclasses import replace
from numbers import Real
from pathlib import Path
from typing import Any

from hoopbench.engines.base import cache_folder
from hoopbench.engines.judging.columns import Col
from hoopbench.engines.registry import engine_class, engine_classes
from hoopbench.engines.warp_compile import LOCKS
from hoopbench.reports.sweep.eta import CallCost, Costing, Rates

__all__ = [
    "CALL_COST_PRIOR",
    "COLD_CACHE_S",
    "MAP",
    "MAP_COSTING",
    "REPORT",
    "batch_world_steps",
    "call_cost",
    "cold_caches",
    "map_call_cost",
    "priors",
    "suite_costing",
    "taken_world_steps",
]

MAP = "map"
"""The first part of a map's kinds."""
REPORT = "report"
"""The kind of `hoopbench report` run after make report's sweeps (reports/report_runs.py)."""

CALL_COST_PRIOR: dict[Hashable, Rates] = {
    # Rates(fixed_s, step_s, world_step_s, cold_s, first_s), fitted by
    # `python -m hoopbench.reports.bench.call_costs fit` on the whole calls of make report's
    # three suites (742 calls) and its map (304 calls), main at 2026-11-29 11:13 UTC (after
    # MJX's XLA pool of one thread per worker, the judge's phase jumps and Warp's shared
    # compiles), on the project's machine (AMD EPYC, 2 cores, no GPU), nearly idle (1-min
    # load average 2.3 at the start, falling), JAX's and Warp's caches warm. A loaded or
    # another machine (or cold caches) scales them by the machine factor.
    "box2d": Rates(0.014, 3.9e-06, 0.0, 1.5e-05, 0.012),
    "dart": Rates(0.014, 9.6e-06, 0.0, 0.0, 0.12),
    "drake": Rates(0.074, 1.7e-05, 0.0, 0.11, 0.3),
    "mjwarp": Rates(0.12, 9.8e-05, 0.0, 0.39, 0.046),
    "mjx": Rates(1.4, 0.0013, 0.00012, 2.1),
    "mujoco": Rates(0.028, 2.6e-06, 6.5e-06, 0.063, 0.057),
    "newton": Rates(0.088, 4.9e-05, 0.0, 0.1, 3.3),
    "pybullet": Rates(0.017, 8.8e-06, 0.0, 0.0, 0.034),
    "pymunk": Rates(0.011, 2.3e-06, 0.0, 0.0011, 0.028),
    "rapier": Rates(0.01, 7.7e-06, 0.0, 0.0015, 0.011),
    "reference": Rates(0.041, 4.5e-07, 0.0, 0.21),
    # The map's (make report's: 10 x 10, MuJoCo in 4 batches of 25, 1e-4 s), its engine
    # runs' by the steps they take to their stop (map_call_cost): the 300 engine calls of
    # make report's map run alone (2026-11-29 19:36 UTC, this costing), fitted
    # on each call's CPU s (the machine was shared: load 3-5), on the project's other machine
    # (Intel Xeon 2.1 GHz, 2 cores), then divided by that machine's factor against these
    # priors, 1.85 (eta.machine_factor, the median engine's, of the warm make report's
    # calls in CPU s on it, 17:52 UTC), to stand with the others. MuJoCo's
    # 4 calls over their world-steps (batch_world_steps: its worlds' own steps summed,
    # 478k, 423k, 488k and 363k as their rows took them, where longest x worlds said 750k
    # each and 5.9e-06), refitted on the CPU s of both such map runs (19:35 and 19:44 UTC,
    # 8 calls). The classification's: the idle make report's.
    (MAP, "mujoco"): Rates(0.0, 0.0, 1.1e-05, 0.3),
    (MAP, "pybullet"): Rates(0.016, 8.1e-06, 0.0, 0.051),
    (MAP, "pymunk"): Rates(0.007, 2.2e-06, 0.0, 0.0092),
    (MAP, "reference"): Rates(0.028, 0.0, 0.0, 0.04),
    # The report of the three suites, the map, the shipped searches and bench (make report's
    # last step, in report-runs' own process): 13 s on the same make report.
    REPORT: Rates(13.0, 0.0),
}
"""A kind's whole call (:class:`~hoopbench.reports.sweep.eta.Rates`) before any call of it
has finished here: by engine, by engine, profile and variant where those differ, by the
map's engine and the report."""


COLD_CACHE_S: dict[Hashable, float] = {
    # s more: make report with a new HOOPBENCH_CACHE against make report with warm caches,
    # the same calls (2026-11-29 11:08 and 11:13 UTC, idle, 2 cores; /tmp/mr12 against
    # /tmp/mr13; `python -m hoopbench.reports.bench.call_costs compile COLD WARM` prints
    # them call by call), where the compile is paid:
    # - an engine: its first call in each worker, whichever kind it is. Both workers start
    #   the engine at once and share its Warp modules' compiles (engines/warp_compile.py):
    #   MuJoCo Warp's first calls took 27.1 and 15.4 s more than warm, Newton's 8.3 and
    #   10.9 more.
    "mjwarp": 21.2,
    "newton": 9.6,
    # - a kind: its first call on the machine, on any worker (the compile lands in the
    #   cache the other workers read): MJX's XLA program of the kind (the stability
    #   suite's tuned call on the other worker took 0.95 s more, the finer one 1.2),
    #   Newton's solvers' own kernels (each solver ran one call).
    # MJX's four, measured again where the others could not be (no EPYC): on the Intel Xeon,
    # two cold make reports against the warm one after each (2026-11-29 and -30), each
    # kind's seconds more over that warm run's machine factor (eta.machine_factor against
    # these priors: 1.66 and 1.90), averaged. The EPYC's figures (6.9, 21.9, 20.6, 11.6)
    # had been measured while MJX's finer call ran too: at the machine's factor they said
    # 2.5 times the Xeon's compiles, and the default suite's ETA at a tenth of its runs was
    # 1.56-1.67 times the time left on two cold runs (1.09 and 1.11 replayed with these).
    ("mjx", "stock", "default"): 3.7,
    ("mjx", "tuned", "default"): 6.7,
    ("mjx", "tuned", "precision=float64"): 8.0,
    ("mjx", "tuned", "cone=pyramidal"): 7.6,
    ("newton", "tuned", "solver=semi_implicit"): 2.1,
    ("newton", "tuned", "solver=featherstone"): 4.0,
    ("newton", "tuned", "solver=mujoco"): 6.7,
}
"""An engine, or a most specific kind -> what its calls pay more while its engine's
compiled-code cache (``Engine.compiled_cache``) is empty: an engine's on its first call in
each worker (``Rates.first_s``), a kind's on its first call on the machine
(``Rates.new_s``). Nothing else tells the ETA that the caches are cold before those calls
end (a cold make report's default suite: 0.57 of the time left at 10 % of its runs with
the warm priors and only MJX's kinds here)."""


def cold_caches() -> frozenset[str]:
    """The engines whose compiled-code cache folder holds no file yet."""
    return frozenset(
        name
        for name, cls in engine_classes().items()
        if cls.compiled_cache is not None and not _holds_a_file(cache_folder(cls.compiled_cache))
    )


def _holds_a_file(folder: Path) -> bool:
    """Whether a compiled-code cache holds compiled code: a file outside Warp's compile locks
    (engines/warp_compile.py), which a cold run killed mid-compile leaves with nothing else."""
    try:
        return any(
            path.is_file() and LOCKS not in path.relative_to(folder).parts
            for path in folder.rglob("*")
        )
    except OSError:  # unreadable: nothing known of it, so taken as cold
        return False


def priors(cold: Collection[str] = ()) -> dict[Hashable, Rates]:
    """:data:`CALL_COST_PRIOR`, with what :data:`COLD_CACHE_S` says of each engine in
    ``cold`` and of its kinds: an engine's on the first call of it in a worker (on every
    kind of it that has a prior), a kind's on its first call on the machine."""
    found = dict(CALL_COST_PRIOR)
    said = {kind: more for kind, more in COLD_CACHE_S.items() if _engine(kind) in cold}
    for kind, more in said.items():  # the kinds' first: they take their engine's rates
        if kind != _engine(kind):
            rates = found.get(kind, CALL_COST_PRIOR[_engine(kind)])
            found[kind] = replace(rates, new_s=rates.new_s + more)
    for engine, more in said.items():
        if engine == _engine(engine):
            for kind, rates in found.items():
                if _engine(kind) == engine:
                    found[kind] = replace(rates, first_s=rates.first_s + more)
    return found


def _engine(kind: Hashable) -> Hashable:
    """A suite's kind's engine: its first part (the kind itself for an engine)."""
    return kind[0] if isinstance(kind, tuple) else kind


def suite_costing() -> Costing:
    """The Costing of a suite's runs, with this machine's caches as they are now."""
    return Costing(cost=call_cost, prior=priors(cold_caches()), taken=taken_world_steps)


def batch_world_steps(engine: str, steps: Sequence[float]) -> float:
    """A call's world-steps as ``engine`` pays them, from each of its worlds' steps: their
    sum where the engine steps only the worlds still running (``Engine.steps_worlds_apart``:
    MuJoCo's batch, each world to its own end), else its longest world's times its worlds
    (every world steps until the last one ends). A call of one world: its steps."""
    if len(steps) <= 1:
        return float(sum(steps))
    if engine_class(engine).steps_worlds_apart:
        return float(sum(steps))
    return float(max(steps)) * len(steps)


def call_cost(tasks: Sequence[Any]) -> CallCost:
    """A call's kinds (engine, profile and variant; then engine), steps (a batch: its
    longest world's), worlds and world-steps (:func:`batch_world_steps` of its worlds'
    windows)."""
    first = tasks[0]
    engine = first.engine
    specific = (engine, str(getattr(first, "profile", "")), getattr(first, "variant", ""))
    each = [task.n_steps for task in tasks]
    return CallCost(
        kinds=(specific, engine),
        steps=max(each),
        worlds=len(tasks),
        world_steps=batch_world_steps(engine, each),
    )


def map_call_cost(tasks: Sequence[Any]) -> CallCost:
    """A map call's kinds (map, engine, profile and timestep; then map and engine), steps
    (those its runs are expected to take, ``MapTask.expected_steps``: to where their stop
    rule ends them on the exact motion; a batch's longest), worlds and world-steps
    (:func:`batch_world_steps` of its worlds' expected steps: a MuJoCo batch's summed)."""
    first = tasks[0]
    engine = first.engine
    specific = (MAP, engine, str(first.profile), first.timestep)
    each = [task.expected_steps for task in tasks]
    return CallCost(
        kinds=(specific, (MAP, engine)),
        steps=max(each),
        worlds=len(tasks),
        world_steps=batch_world_steps(engine, each),
    )


def taken_world_steps(tasks: Sequence[Any], rows: Sequence[Any]) -> float | None:
    """The world-steps a finished call took (:func:`batch_world_steps` of the steps its
    rows record, ``Col.N_STEPS``: a batched run's share of its ``BatchCost.world_steps``);
    None where a row records none (a run that failed before stepping, the classification
    of a map's point)."""
    each = [row.get(Col.N_STEPS) if isinstance(row, Mapping) else None for row in rows]
    steps = [float(n) for n in each if isinstance(n, Real) and math.isfinite(n)]
    if not steps or len(steps) != len(tasks):
        return None
    return batch_world_steps(tasks[0].engine, steps)


MAP_COSTING = Costing(cost=map_call_cost, prior=CALL_COST_PRIOR, taken=taken_world_steps)
"""The Costing of a map's runs (both stages)."""
