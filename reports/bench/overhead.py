"""Benchmark: an adapter's full run against a bare stepping loop of the same engine and model.

Run with ``make bench`` or
``python -m hoopbench.reports.bench.overhead [--scene NAME] [--repeat N]``.
Prints, per engine, the best-of-N wall time of a run's stepping loop (recording every step,
reading contact forces, checking divergence), of a bare loop of the same number of steps
(``Engine.bare_loop_time``: the same model stepped with nothing read, measured alike for
every engine; both with the garbage collector off), their ratio (target: at most 1.2) and
the cost per step.
This is a measurement, not a test: nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from typing import Any

from hoopbench.engines.registry import get_engine
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.reports.sweep.control_chars import terminal_text

ENGINES = ("mujoco", "pybullet", "pymunk", "drake", "rapier", "box2d", "dart")


def measure(engine_name: str, scene_name: str, timestep: float, repeat: int) -> dict[str, Any]:
    engine = get_engine(engine_name)
    scene = get_scene(scene_name)
    settings = RunSettings(timestep=timestep)
    full: list[float] = []
    total: list[float] = []
    bare: list[float] = []
    n_steps = 0
    for _ in range(repeat):
        start = time.perf_counter()
        result = engine.run(scene, settings)
        total.append(time.perf_counter() - start)
        if not result.ok:
            return {
                "engine": engine_name,
                "status": str(result.info.status),
                "message": result.info.message,
            }
        wall_time_s, steps = result.info.wall_time_s, result.info.n_steps
        if wall_time_s is None or steps is None:  # Engine.simulate sets both for an ok run
            raise RuntimeError(f"{engine_name}: an ok run without wall_time_s or n_steps")
        full.append(wall_time_s)
        n_steps = steps
        bare.append(engine.bare_loop_time(scene, settings))
    return {
        "engine": engine_name,
        "status": "ok",
        "n_steps": n_steps,
        "run_s": min(full),
        "run_total_s": min(total),
        "bare_s": min(bare),
        "ratio": min(full) / min(bare),
        "us_per_step": 1e6 * min(full) / n_steps,
        "bare_us_per_step": 1e6 * min(bare) / n_steps,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="seed-mu")
    parser.add_argument("--dt", type=float, default=1e-4)
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--engines", nargs="*", default=list(ENGINES))
    args = parser.parse_args(argv)
    print_overheads(args.engines, args.scene, args.dt, args.repeat)
    return 0


def print_overheads(engines: Sequence[str], scene: str, dt: float, repeat: int) -> None:
    """The table of :func:`measure`, one engine a line as it comes."""
    print(f"scene {scene}, dt {dt:g} s, best of {repeat}")
    header = (
        f"{'engine':<10}{'steps':>8}{'run s':>9}{'bare s':>9}{'ratio':>7}"
        f"{'us/step':>9}{'bare us':>9}{'total s':>9}"
    )
    print(header)
    for name in engines:
        row = measure(name, scene, dt, repeat)
        if row["status"] != "ok":
            print(f"{name:<10} {row['status']}: {terminal_text(row['message'])}", flush=True)
            continue
        print(
            f"{name:<10}{row['n_steps']:>8}{row['run_s']:>9.3f}{row['bare_s']:>9.3f}"
            f"{row['ratio']:>7.2f}{row['us_per_step']:>9.2f}{row['bare_us_per_step']:>9.2f}"
            f"{row['run_total_s']:>9.3f}",
            flush=True,
        )
    print(
        "ratio = adapter stepping (recording, forces, divergence checks) / bare loop; "
        "total = whole run() including model building and event detection"
    )


if __name__ == "__main__":
    sys.exit(main())
