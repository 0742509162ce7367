"""Benchmark: MuJoCo C stepped alone and in batches (``mujoco.batch``), and the hop map's
MuJoCo runs both ways.

Run with ``make bench`` or ``python -m hoopbench.reports.bench.batch [--sizes 1 64 1024]
[--steps 1000] [--grid 10x10] [--jobs 2]``. Two parts, each a measurement, not a test:
nothing here asserts a time.

* **Cost per world-step.** ``size`` worlds, the map's points (lam x chi, default ranges, on
  the smallest square grid that has them), each stepping ``--steps`` steps at dt 1e-4 with
  nothing to stop it, in one process: the batch path (``Engine.simulate_batch``, one
  ``mujoco.batch.Batch`` on one thread, as a runner worker steps it) against the same worlds
  run one by one (``Engine.simulate``), and the bare ``mj_step`` loop of one world
  (``Engine.bare_loop_time``) as the floor. us per world-step of the stepping loops (model
  building excluded) and world-steps per second; best of ``--repeat``.
* **The hop map.** The map of MuJoCo alone, on ``--grid`` with ``--jobs`` worker processes,
  run twice: every run alone (``batch_size`` 1) and in batches (the default). Its wall time
  (both stages), the CPU time of this process and its workers (``bench.map.CpuMeter``;
  other users of the machine do not inflate it, as they do the wall times), the engine
  stage's (from the last reference row to the last MuJoCo row finished), the
  sum of the MuJoCo runs' own stepping times, and whether both wrote the same rows (cost
  columns aside). A smaller grid than 40x40 is extrapolated to 40x40 by the number of
  points, and says so.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from hoopbench.engines.judging.columns import COST_COLUMNS, Col
from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import Run
from hoopbench.engines.settings import DEFAULT_BATCH_SIZE, MAX_STEPS, RunSettings
from hoopbench.models.scene import Scene
from hoopbench.reports.bench.map import CpuMeter
from hoopbench.reports.hop_map.spec import MAX_GRID, MapSpec, check_grid
from hoopbench.reports.hop_map.stages import run_map
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.sweep.results import TIMING_COLUMNS

DT = 1e-4
COST = {*TIMING_COLUMNS, *COST_COLUMNS}
"""Columns that differ between a batched and a lone run."""
FULL_MAP = 40 * 40


MAX_WORLDS = MAX_GRID**2
"""Worlds per batch at most: world_scenes takes them from a square map of at most MAX_GRID
points a side."""


def check_counts(sizes: Sequence[int], steps: int | None) -> None:
    """ValueError, one line naming the option and the value, for worlds per batch or steps
    per world that no batch can have (0 or less; more than MAX_WORLDS worlds, or more steps
    than a run may take: engines/settings.MAX_STEPS)."""
    for size in sizes:
        if not 1 <= size <= MAX_WORLDS:
            raise ValueError(f"--sizes: worlds per batch must be 1 to {MAX_WORLDS}, got {size}")
    if steps is not None and not 1 <= steps <= MAX_STEPS:
        raise ValueError(f"--steps: steps per world must be 1 to {MAX_STEPS}, got {steps}")


def world_scenes(size: int, steps: int) -> list[Scene]:
    """``size`` scenes of the map's points, each with a window of ``steps`` steps."""
    side = math.ceil(math.sqrt(size))
    points = MapSpec(nx=side, ny=side).points()
    scenes = [p.scene() for p in points if not p.scene().is_degenerate]
    while len(scenes) < size:  # degenerate points left out: repeat the others
        scenes += scenes[: size - len(scenes)]
    return [s.with_(t_end=steps * DT) for s in scenes[:size]]


def step_cost(engine_name: str, size: int, steps: int, repeat: int, alone: bool) -> dict[str, Any]:
    """us per world-step of the batch path, of single runs (if ``alone``) and of the bare
    loop, for ``size`` worlds of ``steps`` steps; best of ``repeat``."""
    engine, settings = get_engine(engine_name), RunSettings(timestep=DT)
    scenes = world_scenes(size, steps)
    batch, single = [], []
    for _ in range(repeat):
        runs = engine.simulate_batch(scenes, settings)
        if any(run.info.status != "ok" for run in runs):
            raise RuntimeError(f"a batch of {size} did not run: {runs[0].info.message}")
        batch.append(_per_step(runs))  # an engine without batches: its runs one by one
        if alone:
            single.append(_per_step([engine.simulate(scene, settings) for scene in scenes]))
    bare = min(engine.bare_loop_time(scenes[0], settings) for _ in range(repeat)) / steps
    return {
        "size": size,
        "batch_us": 1e6 * min(batch),
        "single_us": 1e6 * min(single) if single else None,
        "bare_us": 1e6 * bare,
    }


def _per_step(runs: list[Run]) -> float:
    """s per world-step of runs: their stepping wall time (a batch's, once) over their steps."""
    cost = runs[0].info.batch
    if cost is not None:
        return cost.wall_time_s / cost.world_steps
    wall = sum(run.info.wall_time_s or 0.0 for run in runs)
    return wall / sum(run.info.n_steps or 0 for run in runs)


def map_cost(grid: tuple[int, int], jobs: int, batch_size: int, out: Path) -> dict[str, Any]:
    """The MuJoCo hop map on ``grid``: wall times and the runs' own stepping time."""
    spec = MapSpec(nx=grid[0], ny=grid[1], engines=("mujoco",))
    with CpuMeter() as meter:
        start = time.perf_counter()
        summary = run_map(spec, out, jobs=jobs, quiet=True, batch_size=batch_size)
        wall = time.perf_counter() - start
    cpu = meter.seconds
    frame = map_frame(out)
    engine = frame[frame[Col.ENGINE] == "mujoco"]
    finished = pd.to_datetime(engine["finished_at"])
    reference_done = pd.to_datetime(frame.loc[frame[Col.ENGINE] != "mujoco", "finished_at"])
    return {
        "batch_size": batch_size,
        "wall_s": wall,
        "cpu_s": cpu,
        "engine_stage_s": (finished.max() - reference_done.max()).total_seconds(),
        "stepping_s": float(engine[Col.WALL_TIME_S].sum()),
        "runs": len(engine),
        "statuses": dict(summary.counts),
        "frame": frame,
    }


def _same_rows(one: pd.DataFrame, other: pd.DataFrame) -> bool:
    keep = [c for c in one.columns if c not in COST]
    a = one[keep].sort_values(Col.RUN_ID).reset_index(drop=True)
    b = other[keep].sort_values(Col.RUN_ID).reset_index(drop=True)
    return bool(a.equals(b))


def print_step_costs(
    engine: str, sizes: list[int], steps: int, repeat: int, alone_up_to: int
) -> None:
    print(f"{engine}, us per world-step, {steps} steps per world at dt {DT:g} s, best of {repeat}")
    print(f"{'worlds':>7}{'batch':>9}{'alone':>9}{'bare':>9}{'batch world-steps/s':>22}")
    for size in sizes:
        row = step_cost(engine, size, steps, repeat, alone=size <= alone_up_to)
        single = "-" if row["single_us"] is None else f"{row['single_us']:.2f}"
        print(
            f"{size:>7}{row['batch_us']:>9.2f}{single:>9}{row['bare_us']:>9.2f}"
            f"{1e6 / row['batch_us']:>22,.0f}",
            flush=True,
        )


def print_map_costs(grid: tuple[int, int], jobs: int) -> None:
    points = grid[0] * grid[1]
    print(f"\nhop map of MuJoCo alone, {grid[0]}x{grid[1]}, {jobs} jobs, dt {DT:g} s (defaults)")
    print(
        f"{'batch size':>11}{'wall s':>9}{'CPU s':>9}{'engine stage s':>16}{'stepping s':>12}"
        f"{'runs':>6}"
    )
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for size in (1, DEFAULT_BATCH_SIZE):
            row = map_cost(grid, jobs, size, Path(tmp) / f"map-{size}")
            rows.append(row)
            print(
                f"{size:>11}{row['wall_s']:>9.1f}{row['cpu_s']:>9.1f}"
                f"{row['engine_stage_s']:>16.1f}{row['stepping_s']:>12.1f}{row['runs']:>6}",
                flush=True,
            )
    print(f"same rows (cost columns aside): {_same_rows(rows[0]['frame'], rows[1]['frame'])}")
    if points != FULL_MAP:
        scale = FULL_MAP / points
        print(f"extrapolated to 40x40 ({scale:g} times the points): wall, CPU, engine stage")
        for row in rows:
            print(
                f"{row['batch_size']:>11}{scale * row['wall_s']:>9.0f}{scale * row['cpu_s']:>9.0f}"
                f"{scale * row['engine_stage_s']:>16.0f} s"
            )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--engine", default="mujoco", help="the engine of the first part")
    parser.add_argument("--sizes", type=int, nargs="*", default=[1, 64, 1024])
    parser.add_argument("--steps", type=int, default=1000, help="steps per world")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument(
        "--alone-up-to", type=int, default=1024, help="single runs only up to this many worlds"
    )
    parser.add_argument("--grid", default="10x10", help="the hop map's grid; 0x0: no map")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args(argv)
    print_step_costs(args.engine, args.sizes, args.steps, args.repeat, args.alone_up_to)
    if args.grid not in ("0x0", "0"):
        print_map_costs(check_grid(args.grid), args.jobs)
    return 0


if __name__ == "__main__":
    sys.exit(main())
