"""Benchmark: the batched simulators' cost per world-step (MJX, MuJoCo Warp, Newton, beside
MuJoCo C through ``mujoco.batch``), at batch sizes 1, 64 and 1,024 by default.

Run with ``make bench`` or ``python -m hoopbench.reports.bench.batched_engines [--sizes 1 64
1024] [--steps 100] [--engines mjx mjwarp newton]``. A measurement, not a test: nothing here
asserts a time.

Each batch is ``size`` worlds, the hop map's points (reports/bench/batch.py's
``world_scenes``), each stepping ``--steps`` steps at dt 1e-3 with the tuned settings, run
through ``Engine.simulate_batch`` in this process: the stepping loop's wall time over the
world-steps (model building, the device transfer and the compile excluded: the adapters
compile before the loop), as a suite's batch pays it. The device is the engine's default
(``device`` auto): the CPU where there is no GPU, which the figures say.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.reports.bench.batch import world_scenes

DT = 1e-3
CASES: tuple[tuple[str, dict[str, Any]], ...] = (
    ("mujoco", {}),
    ("mjx", {}),
    ("mjx", {"precision": "float64"}),
    ("mjwarp", {}),
    ("newton", {}),
    ("newton", {"solver": "featherstone"}),
    ("newton", {"solver": "semi_implicit"}),
    ("newton", {"solver": "mujoco"}),
)
"""(engine, options) measured, the tuned profile's otherwise."""


def cost_per_world_step(engine: str, options: dict[str, Any], size: int, steps: int) -> float:
    """us per world-step of one batch of ``size`` worlds of ``steps`` steps each."""
    scenes = [s.with_(t_end=steps * DT) for s in world_scenes(size, steps)]
    runs = get_engine(engine).simulate_batch(scenes, RunSettings(timestep=DT, options=options))
    bad = [run for run in runs if run.info.status is not RunStatus.OK]
    cost = runs[0].info.batch
    if cost is None or len(bad) == len(runs):
        raise RuntimeError(f"{engine} batch of {size}: {runs[0].info.message}")
    return 1e6 * cost.wall_time_s / cost.world_steps


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 64, 1024])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--engines", nargs="+", default=None, help="only these engines")
    args = parser.parse_args(argv)
    cases = [c for c in CASES if args.engines is None or c[0] in args.engines]
    print(f"us per world-step, tuned, dt {DT:g} s, {args.steps} steps per world, the CPU")
    print(f"{'engine':<30}" + "".join(f"{size:>12}" for size in args.sizes))
    for engine, options in cases:
        label = engine + "".join(f" {k}={v}" for k, v in options.items())
        cells = []
        for size in args.sizes:
            try:
                cells.append(f"{cost_per_world_step(engine, options, size, args.steps):>12.1f}")
            except RuntimeError as exc:
                print(f"{label}: {exc}", file=sys.stderr)
                cells.append(f"{'failed':>12}")
        print(f"{label:<30}" + "".join(cells), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
