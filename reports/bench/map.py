"""Benchmark: the hop map on local worker processes and on a local Dask cluster.

Run with ``python -m hoopbench.reports.bench.map [--grid 40x40] [--engines ...] [--dt 1e-4]``.
The same map (lam x chi, default ranges and fixed values) runs four times: with the local
pool of 1 and of 2 jobs, and through ``--scheduler`` on a Dask cluster of 1 and of 2 workers
started here (a scheduler and single-threaded workers, each its own process, on 127.0.0.1,
as on several machines). It prints runs per second and the wall time of each, the CPU time
(user + sys) they cost, the speed-up of 2 over 1, and whether all four stored the same rows
(timing columns aside). "in runs s" adds up the runs' own wall times (solve or engine run,
measured in the worker): what the rest of the wall time times the workers is overhead. A
measurement, not a test: nothing here asserts a time.

Wall time is the map's alone (a cluster is up before and stopped after it); it includes the
workers' first imports on either side. CPU time is that of this process and all its
descendants (pool workers, scheduler, nannies, Dask workers) over the whole case, so a
cluster's start and stop count there; on a shared machine, other users' load shows in the
wall times but not in the CPU times.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import pandas as pd
import psutil

from hoopbench.engines.judging.columns import COST_COLUMNS
from hoopbench.engines.options import Profile
from hoopbench.engines.settings import DEFAULT_TIMESTEP
from hoopbench.reports.hop_map.spec import MapSpec, check_grid
from hoopbench.reports.hop_map.stages import run_map
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.sweep.cluster import cluster_executor, local_cluster
from hoopbench.reports.sweep.results import TIMING_COLUMNS

TIMING = (*TIMING_COLUMNS, *COST_COLUMNS)
"""Columns that differ between two runs of the same map."""


@dataclass(frozen=True)
class Case:
    """One way to run the map."""

    label: str
    n: int
    """Local jobs, or Dask workers."""
    dask: bool


CASES = (
    Case("local, 1 job", 1, False),
    Case("local, 2 jobs", 2, False),
    Case("dask, 1 worker", 1, True),
    Case("dask, 2 workers", 2, True),
)


@dataclass(frozen=True)
class Timing:
    case: Case
    runs: int
    wall_s: float
    cpu_s: float
    """user + sys of this process and its descendants, a cluster's start and stop included."""
    frame: pd.DataFrame

    @property
    def runs_per_s(self) -> float:
        return self.runs / self.wall_s


class CpuMeter:
    """user + sys seconds of this process and all its descendants (pool and cluster workers,
    which are not all our children) between enter and exit, sampled every ``interval`` s: a
    process that ends between two samples loses at most that much."""

    def __init__(self, interval: float = 0.2) -> None:
        self.interval = interval
        self.seconds = 0.0
        self._start: dict[tuple[int, float], float] = {}
        self._last: dict[tuple[int, float], float] = {}
        self._done = threading.Event()
        self._thread = threading.Thread(target=self._watch, daemon=True)

    def __enter__(self) -> CpuMeter:
        self._start = self._sample()
        self._last = dict(self._start)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._done.set()
        self._thread.join()
        self._last.update(self._sample())
        self.seconds = sum(t - self._start.get(key, 0.0) for key, t in self._last.items())

    def _watch(self) -> None:
        while not self._done.wait(self.interval):
            self._last.update(self._sample())

    @staticmethod
    def _sample() -> dict[tuple[int, float], float]:
        me = psutil.Process()
        found = {}
        for process in [me, *me.children(recursive=True)]:
            with contextlib.suppress(psutil.Error):
                times = process.cpu_times()
                found[process.pid, process.create_time()] = times.user + times.system
        return found


@contextmanager
def _executor(case: Case) -> Iterator[Any]:
    """None for the local pool; else a Dask cluster of case.n workers and its executor."""
    if not case.dask:
        yield None
        return
    with local_cluster(case.n) as cluster, cluster_executor(cluster.address) as executor:
        yield executor


def run_case(spec: MapSpec, case: Case) -> Timing:
    with tempfile.TemporaryDirectory(prefix="hoopbench-bench-map-") as tmp, CpuMeter() as cpu:
        out = Path(tmp) / "map"
        with _executor(case) as executor:
            start = time.perf_counter()
            summary = run_map(spec, out, jobs=case.n, executor=executor, quiet=True)
            wall = time.perf_counter() - start
        frame = map_frame(out)
    return Timing(case, summary.total, wall, cpu.seconds, frame)


def differing_columns(a: pd.DataFrame, b: pd.DataFrame) -> dict[str, int]:
    """Column -> rows where two maps differ, matched by run_id, timing columns aside."""
    keep = sorted((set(a.columns) | set(b.columns)) - set(TIMING))
    a, b = (f.reindex(columns=keep).set_index("run_id").sort_index() for f in (a, b))
    if not a.index.equals(b.index):
        return {"run_id": len(a.index.symmetric_difference(b.index))}
    differs = (a != b) & ~(a.isna() & b.isna())
    counts = differs.sum()
    return {str(column): int(n) for column, n in counts.items() if n}


def _grid(text: str) -> tuple[int, int]:
    try:
        return check_grid(text)  # the map's own check, as `hoopbench map --grid` has it
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


ENGINES = ("mujoco", "pybullet", "pymunk")
"""The engines measured by default: the map's engines of the figures in docs/map.md and
cluster.md (the map's default list has the batched engines too since; --engines for them)."""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grid", type=_grid, default=(40, 40), help="NXxNY (default 40x40)")
    parser.add_argument(
        "--engines",
        nargs="+",
        default=list(ENGINES),
        help=f"engines (default {' '.join(ENGINES)})",
    )
    parser.add_argument(
        "--dt", type=float, default=DEFAULT_TIMESTEP, help=f"timestep, s ({DEFAULT_TIMESTEP:g})"
    )
    parser.add_argument("--profile", choices=[p.value for p in Profile], default="tuned")
    args = parser.parse_args(argv)
    nx, ny = args.grid
    try:
        spec = MapSpec(
            nx=nx, ny=ny, engines=tuple(args.engines), timestep=args.dt, profile=args.profile
        )
    except ValueError as exc:
        parser.error(str(exc))
    print(
        f"hop map {nx}x{ny} ({spec.x} x {spec.y}), {', '.join(spec.engines)}, dt {spec.timestep:g}"
        f" s, {spec.profile}: {nx * ny} reference and {nx * ny * len(spec.engines)} engine runs",
        flush=True,
    )
    print(
        f"{'case':16} {'runs':>6} {'wall s':>8} {'runs/s':>8} {'cpu s':>8} {'in runs s':>10}",
        flush=True,
    )
    # A 1x1 map first, not timed: the first case would otherwise pay for cold file caches.
    run_case(replace(spec, nx=1, ny=1), CASES[0])
    timings: list[Timing] = []
    for case in CASES:
        timing = run_case(spec, case)
        timings.append(timing)
        print(
            f"{case.label:16} {timing.runs:>6} {timing.wall_s:>8.1f} {timing.runs_per_s:>8.1f} "
            f"{timing.cpu_s:>8.1f} {timing.frame['wall_time_s'].sum():>10.1f}",
            flush=True,
        )
    wall = {(t.case.dask, t.case.n): t.wall_s for t in timings}
    local, dask = (wall[d, 1] / wall[d, 2] for d in (False, True))
    print(f"speed-up of 2 over 1: local {local:.2f}x, dask {dask:.2f}x")
    same = True
    for timing in timings[1:]:
        differing = differing_columns(timings[0].frame, timing.frame)
        if differing:
            same = False
            print(f"rows of {timing.case.label!r} differ from {CASES[0].label!r}: {differing}")
    print(f"rows identical in all four (timing columns aside): {'yes' if same else 'NO'}")
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())
