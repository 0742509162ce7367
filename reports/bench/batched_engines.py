"""Benchmark: the batched simulators' cost per world-step (MJX, MuJoCo Warp, Newton, beside
MuJoCo C through ``mujoco.batch``), at batch sizes 1, 64 and 1,024 by default.

Run with ``make bench`` or ``python -m hoopbench.reports.bench.batched_engines [--sizes 1 64
1024] [--steps 100] [--engines mjx mjwarp newton] [--out DIR]``. A measurement, not a test:
nothing here asserts a time. With ``--out DIR`` the figures also go to ``DIR/batch_cost.csv``
(a new file; ``--force`` replaces it), which ``hoopbench report --results DIR`` shows as the
section "Cost per world-step by batch size" (reports/report/batch_cost.py).

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
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.registry import engine_class, get_engine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.reports.bench.batch import check_counts, world_scenes
from hoopbench.reports.report.batch_cost import (
    BATCH_COST_FILE,
    DEVICE,
    MEASURED_AT,
    SETTING,
    STEPS_PER_WORLD,
    write_batch_cost,
)
from hoopbench.reports.sweep.control_chars import terminal_text

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


def _label(engine: str, options: dict[str, Any]) -> str:
    """'mjx precision=float64'."""
    return engine + "".join(f" {k}={v}" for k, v in options.items())


def _row(engine: str, options: dict[str, Any], size: int, steps: int, us: float) -> dict:
    settings = RunSettings(timestep=DT, options=options)
    return {
        Col.ENGINE: engine,
        SETTING: _label(engine, options),
        Col.ENGINE_VERSION: get_engine(engine).version(),
        Col.TIMESTEP: DT,
        STEPS_PER_WORLD: steps,
        DEVICE: engine_class(engine).resolve(settings).get("device", "cpu"),  # MuJoCo C: cpu
        Col.BATCH_SIZE: size,
        Col.US_PER_WORLD_STEP: us,
        Col.WORLD_STEPS_PER_S: 1e6 / us if us == us else float("nan"),
    }


def measure(
    cases: Sequence[tuple[str, dict[str, Any]]], sizes: Sequence[int], steps: int
) -> pd.DataFrame:
    """One row per case and size (BATCH_COST_COLUMNS), printed as they come; a batch that
    failed has no cost (NaN) and its reason on stderr."""
    print(f"us per world-step, tuned, dt {DT:g} s, {steps} steps per world, the CPU")
    print(f"{'engine':<30}" + "".join(f"{size:>12}" for size in sizes))
    rows = []
    started = datetime.now(UTC).isoformat(timespec="seconds")
    for engine, options in cases:
        cells = []
        for size in sizes:
            try:
                us = cost_per_world_step(engine, options, size, steps)
            except RuntimeError as exc:
                print(f"{_label(engine, options)}: {exc}", file=sys.stderr)
                us = float("nan")
            cells.append(f"{us:>12.1f}" if us == us else f"{'failed':>12}")
            rows.append({**_row(engine, options, size, steps, us), MEASURED_AT: started})
        print(f"{_label(engine, options):<30}" + "".join(cells), flush=True)
    return pd.DataFrame(rows)


def _check(args: argparse.Namespace) -> None:
    """ValueError, one line naming the option and the value, before anything is measured
    (a bad --out used to fail after the measurements, losing them)."""
    check_counts(args.sizes, args.steps)
    measured = list(dict.fromkeys(engine for engine, _ in CASES))
    for engine in args.engines or ():
        if engine not in measured:
            raise ValueError(f"--engines: {engine!r} is not measured here ({', '.join(measured)})")
    if args.out is not None:
        if args.out.exists() and not args.out.is_dir():
            raise ValueError(f"--out {str(args.out)!r} is a file, not a folder")
        if (args.out / BATCH_COST_FILE).exists() and not args.force:
            raise ValueError(
                f"{str(args.out / BATCH_COST_FILE)!r} exists; pass --force to replace it"
            )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="+", default=[1, 64, 1024])
    parser.add_argument("--steps", type=int, default=100)
    parser.add_argument("--engines", nargs="+", default=None, help="only these engines")
    parser.add_argument("--out", type=Path, help=f"folder for {BATCH_COST_FILE} (the report's)")
    parser.add_argument(
        "--force", action="store_true", help=f"replace an existing {BATCH_COST_FILE}"
    )
    args = parser.parse_args(argv)
    try:
        _check(args)
    except ValueError as exc:
        print(f"{parser.prog}: error: {terminal_text(exc)}", file=sys.stderr)
        return 2
    cases = [c for c in CASES if args.engines is None or c[0] in args.engines]
    frame = measure(cases, args.sizes, args.steps)
    if args.out is not None:
        print(f"written: {write_batch_cost(frame, args.out)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
