"""``hoopbench bench`` (and ``make bench``): the benchmarks of reports/bench/ in one command.

Four parts, each a measurement, not a test (nothing asserts a time), run in this order:

* ``overhead``: each adapter's run against a bare stepping loop of its engine
  (:mod:`hoopbench.reports.bench.overhead`);
* ``batch``: MuJoCo C stepped alone and in batches (:mod:`hoopbench.reports.bench.batch`);
* ``map``: the hop map of MuJoCo alone, every run alone and in batches (the same module);
* ``batched``: the batched simulators' cost per world-step
  (:mod:`hoopbench.reports.bench.batched_engines`), written to ``--out``'s batch_cost.csv,
  which ``make report`` shows.

The plan is checked whole before anything runs (:func:`check_plan`), so that a bad value
costs no minutes of measuring first.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from hoopbench.engines.registry import engine_names
from hoopbench.models.catalogue import scene_names
from hoopbench.reports.bench import batch, batched_engines, overhead
from hoopbench.reports.report.batch_cost import BATCH_COST_FILE, write_batch_cost

__all__ = ["PARTS", "BenchPlan", "check_plan", "part_engines", "run_bench"]

PARTS = ("overhead", "batch", "map", "batched")
"""The parts, in the order they run."""

_PART_ENGINES: dict[str, tuple[str, ...]] = {
    "overhead": overhead.ENGINES,
    "batch": ("mujoco",),
    "map": ("mujoco",),
    "batched": tuple(dict.fromkeys(engine for engine, _ in batched_engines.CASES)),
}
"""The engines each part measures (all of them unless --engines narrows it)."""


@dataclass(frozen=True)
class BenchPlan:
    """What ``hoopbench bench`` measures; the defaults are ``make bench``'s."""

    parts: tuple[str, ...] = PARTS
    engines: tuple[str, ...] | None = None
    """Only these engines (None: each part's own)."""
    sizes: tuple[int, ...] = (1, 64, 1024)
    """Worlds per batch (the batch and batched parts)."""
    steps: int | None = None
    """Steps per world (None: 1000 for the batch part at dt 1e-4, 100 for the batched one)."""
    repeat: int = 3
    """Best of this many (the overhead and batch parts)."""
    grid: tuple[int, int] = (10, 10)
    """The hop map's grid (the map part), extrapolated to 40x40."""
    jobs: int = 2
    """Worker processes of the hop map."""
    scene: str = "seed-mu"
    """The overhead part's scene."""
    dt: float = 1e-4
    """The overhead part's timestep, s."""
    out: Path | None = None
    """Folder for batch_cost.csv (the batched part); None: printed only."""
    force: bool = False
    """Replace an existing batch_cost.csv."""


def part_engines(part: str, engines: Sequence[str] | None) -> tuple[str, ...]:
    """The engines a part measures: its own, those of ``engines`` only if given."""
    own = _PART_ENGINES[part]
    return own if engines is None else tuple(e for e in own if e in engines)


def check_plan(plan: BenchPlan) -> None:
    """ValueError, one line naming the value, for a plan that cannot run as asked."""
    unknown = [p for p in plan.parts if p not in PARTS]
    if unknown or not plan.parts:
        raise ValueError(f"--parts: unknown part {unknown[0]!r} (parts: {', '.join(PARTS)})"
                         if unknown else "--parts: name at least one part")  # fmt: skip
    for engine in plan.engines or ():
        if engine not in engine_names():
            raise ValueError(f"--engines: unknown engine {engine!r} ({', '.join(engine_names())})")
    if plan.engines is not None and not any(part_engines(p, plan.engines) for p in plan.parts):
        measured = sorted({e for p in plan.parts for e in _PART_ENGINES[p]})
        raise ValueError(
            f"--engines {' '.join(plan.engines)}: no part asked for measures them "
            f"(--parts {' '.join(plan.parts)} measure {', '.join(measured)})"
        )
    batch.check_counts(plan.sizes, plan.steps)
    if plan.scene not in scene_names():
        raise ValueError(f"--scene: unknown scene {plan.scene!r} ({', '.join(scene_names())})")
    if plan.out is not None and "batched" in plan.parts:
        if plan.out.exists() and not plan.out.is_dir():
            raise ValueError(f"--out {str(plan.out)!r} is a file, not a folder")
        if (plan.out / BATCH_COST_FILE).exists() and not plan.force:
            raise ValueError(
                f"{str(plan.out / BATCH_COST_FILE)!r} exists; pass --force to replace it"
            )


def run_bench(plan: BenchPlan) -> Path | None:
    """Run the plan's parts (checked first: :func:`check_plan`), their tables on stdout and
    what is skipped on stderr; the batch_cost.csv written, if any."""
    check_plan(plan)
    written = None
    for part in plan.parts:
        engines = part_engines(part, plan.engines)
        if not engines:
            print(f"bench: {part}: skipped, it measures none of --engines", file=sys.stderr)
            continue
        print(f"\n== bench: {part}", flush=True)
        if part == "overhead":
            overhead.print_overheads(engines, plan.scene, plan.dt, plan.repeat)
        elif part == "batch":
            steps = plan.steps or 1000
            batch.print_step_costs(engines[0], list(plan.sizes), steps, plan.repeat, 1024)
        elif part == "map":
            batch.print_map_costs(plan.grid, plan.jobs)
        else:
            cases = [c for c in batched_engines.CASES if c[0] in engines]
            frame = batched_engines.measure(cases, plan.sizes, plan.steps or 100)
            if plan.out is not None:
                written = write_batch_cost(frame, plan.out)
                print(f"written: {written}", flush=True)
    return written
