"""Benchmark: how close a finished hop map came to its engines' bare-stepping floor.

Run with ``python -m hoopbench.reports.bench.floor MAPDIR [--per-group 12] [--cores 2]``.

Every engine row of the map stored how many steps it took (``n_steps``: its window, or less
when it stopped early) and how long its stepping loop ran (``wall_time_s``: stepping,
recording every state, the divergence and stop checks). This benchmark samples up to
``--per-group`` rows of each (engine, regime, stop reason) group and times the engine's
bare loop (``Engine.bare_loop_time``: the same model stepped as many times, nothing read
or recorded) for each, so the group's floor is its steps times the sampled bare cost per
step. It prints, per group and in total, the runs' own time against that floor, then:

* **floor on the cores**: the floor plus the exact classification, spread over ``--cores``;
  what the map could take if building, recording, judging and writing cost nothing;
* **stopping bound**: the same for the steps that no stopping rule can leave out, by the
  issue's rule (a run ends at its first impact, or once the reference's last event is long
  past and the engine rolls): hops and lifts-at-start up to their impact, as run; slips up
  to the exact's last phase change (or the run's end, if sooner); rolling points nothing.

A measurement, not a test: nothing here asserts a time. Timing runs in this process, one
at a time; run it on an otherwise idle machine.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from hoopbench.engines.base import n_steps_for
from hoopbench.engines.registry import get_engine
from hoopbench.engines.settings import RunSettings
from hoopbench.models.scene import Scene
from hoopbench.reference.regimes import Regime
from hoopbench.reports.compare import selection
from hoopbench.reports.hop_map.spec import REFERENCE, MapPoint, MapSpec, load_spec
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.sweep import results

FULL = "full"
"""The stop label of a run that ran its whole window."""

GROUP = ["engine", "regime", "stop"]
"""What a run's bare cost per step is taken to depend on: its model and what it does."""

MUST_RUN_REGIMES = tuple(str(r) for r in (Regime.HOPS, Regime.LIFTS_AT_START, Regime.SLIPS))
"""Regimes whose runs the stopping bound keeps (rolling points could stop at once)."""


@dataclass(frozen=True)
class Floor:
    """A map's engine time set against its bare-stepping floor, s (CPU of one core)."""

    groups: pd.DataFrame
    """Per GROUP: runs, steps, run_s (the runs' own time), bare_us (per step), floor_s."""
    reference_s: float
    """The exact classification of every point."""
    bound_s: float
    """Bare stepping of the steps no stopping rule can leave out (module docstring)."""


def engine_rows(frame: pd.DataFrame) -> pd.DataFrame:
    """The map's engine rows that ran (status ok, steps taken), with their stop label."""
    rows = selection.ok_rows(selection.engine_rows(frame))
    rows = rows[rows["n_steps"].fillna(0) > 0].copy()
    rows["stop"] = rows["stop_reason"].fillna(FULL).astype(str)
    rows["n_steps"] = rows["n_steps"].astype(int)
    return rows


def sample(rows: pd.DataFrame, per_group: int, seed: int) -> pd.DataFrame:
    """Up to ``per_group`` rows of each GROUP, drawn reproducibly."""
    parts = [
        part.sample(min(per_group, len(part)), random_state=seed)
        for _, part in rows.groupby(GROUP, sort=True)
    ]
    return pd.concat(parts) if parts else rows.iloc[:0]


def floor_scene(point: MapPoint, n_steps: int, timestep: float) -> Scene:
    """The point's scene with a window of exactly ``n_steps`` steps."""
    scene = replace(point.scene(), t_end=n_steps * timestep)
    if n_steps_for(scene, timestep) != n_steps:
        raise ValueError(f"{point.name}: a window of {n_steps} steps does not round-trip")
    return scene


def bare_seconds(spec: MapSpec, rows: pd.DataFrame) -> np.ndarray:
    """Each row's bare loop time, s: its engine, its point's scene, its number of steps."""
    points = {(p.ix, p.iy): p for p in spec.points()}
    out = np.empty(len(rows))
    for k, row in enumerate(rows.itertuples(index=False)):
        timestep = spec.timestep_of(row.engine)
        settings = RunSettings(timestep=timestep, profile=spec.profile)
        scene = floor_scene(points[row.ix, row.iy], row.n_steps, timestep)
        out[k] = get_engine(row.engine).bare_loop_time(scene, settings)
    return out


def group_floor(rows: pd.DataFrame, sampled: pd.DataFrame, bare_s: np.ndarray) -> pd.DataFrame:
    """Per GROUP: runs, steps, run_s, bare_us and floor_s = steps * bare_us (a ratio
    estimate: the sampled rows' bare time over their steps)."""
    timed = sampled.assign(bare_s=bare_s).groupby(GROUP)[["bare_s", "n_steps"]].sum()
    per_step = (timed["bare_s"] / timed["n_steps"]).rename("bare_per_step")
    table = rows.groupby(GROUP).agg(
        runs=("n_steps", "size"), steps=("n_steps", "sum"), run_s=("wall_time_s", "sum")
    )
    table = table.join(per_step)
    table["floor_s"] = table["steps"] * table["bare_per_step"]
    table["bare_us"] = 1e6 * table.pop("bare_per_step")
    return table.reset_index()


def must_run_steps(rows: pd.DataFrame, timestep: float | pd.Series) -> pd.Series:
    """Steps no stopping rule can leave out (module docstring), per row (``timestep``: the
    map's, or each row's)."""
    steps = rows["n_steps"].where(rows["regime"].isin(MUST_RUN_REGIMES), 0)
    slips = rows["regime"] == str(Regime.SLIPS)
    # The step at or after the last event; an event on a step up to round-off is that step.
    last = np.ceil(rows["exact_t_last_phase"].fillna(0.0) / timestep * (1 - 1e-12))
    return steps.where(~slips, np.minimum(rows["n_steps"], last)).astype(int)


def stopping_bound(rows: pd.DataFrame, groups: pd.DataFrame, timestep: float | pd.Series) -> float:
    """Bare seconds of the must-run steps, at each row's group's bare cost per step."""
    cost = groups.set_index(GROUP)["bare_us"] * 1e-6
    per_step = rows.set_index(GROUP).index.map(cost.to_dict()).to_numpy(dtype=float)
    return float(np.nansum(must_run_steps(rows, timestep).to_numpy() * per_step))


def measure(out: Path, per_group: int, seed: int) -> Floor:
    spec = load_spec(out)
    frame = map_frame(out)
    rows = engine_rows(frame)
    picked = sample(rows, per_group, seed)
    groups = group_floor(rows, picked, bare_seconds(spec, picked))
    reference = frame.loc[frame["engine"] == REFERENCE, "wall_time_s"].fillna(0.0).sum()
    steps = rows["engine"].map(spec.timestep_of)  # an engine may have its own step
    return Floor(groups, float(reference), stopping_bound(rows, groups, steps))


def report(floor: Floor, cores: int, map_wall_s: float | None) -> str:
    g = floor.groups
    lines = [
        f"{'engine':10}{'regime':16}{'stop':9}{'runs':>6}{'steps M':>9}{'run s':>9}"
        f"{'floor s':>9}{'ratio':>7}{'bare us':>9}"
    ]
    for r in g.itertuples(index=False):
        lines.append(
            f"{r.engine:10}{r.regime:16}{r.stop:9}{r.runs:>6}{r.steps / 1e6:>9.2f}"
            f"{r.run_s:>9.1f}{r.floor_s:>9.1f}{r.run_s / r.floor_s:>7.2f}{r.bare_us:>9.2f}"
        )
    run_s, floor_s = g["run_s"].sum(), g["floor_s"].sum()
    lines.append(
        f"{'all engines':35}{g['runs'].sum():>6}{g['steps'].sum() / 1e6:>9.2f}"
        f"{run_s:>9.1f}{floor_s:>9.1f}{run_s / floor_s:>7.2f}"
    )
    minutes = (floor_s + floor.reference_s) / cores / 60
    bound = (floor.bound_s + floor.reference_s) / cores / 60
    lines += [
        f"exact classification: {floor.reference_s:.1f} s",
        f"floor on {cores} cores (engines bare + classification): {minutes:.1f} min",
        f"stopping bound on {cores} cores (must-run steps bare + classification): {bound:.1f} min",
    ]
    if map_wall_s is not None:
        lines.append(
            f"the map took {map_wall_s / 60:.1f} min: {map_wall_s / 60 / minutes:.2f} x its floor"
        )
    return "\n".join(lines)


def _map_wall(out: Path) -> float | None:
    try:
        return float(json.loads((out / results.META_NAME).read_text())["wall_time_s"])
    except (OSError, ValueError, KeyError, TypeError):
        return None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mapdir", type=Path, help="a finished `hoopbench map` folder")
    parser.add_argument("--per-group", type=int, default=12, help="rows timed per group (12)")
    parser.add_argument("--cores", type=int, default=os.cpu_count() or 1, help="cores (all)")
    parser.add_argument("--seed", type=int, default=0, help="sampling seed (0)")
    args = parser.parse_args(argv)
    if args.per_group < 1 or args.cores < 1:
        parser.error(f"--per-group and --cores must be >= 1, got {args.per_group}, {args.cores}")
    try:
        floor = measure(args.mapdir, args.per_group, args.seed)
    except (OSError, ValueError) as exc:
        print(f"bench_floor: {args.mapdir}: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    print(report(floor, args.cores, _map_wall(args.mapdir)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
