"""Benchmark: what the isolated suite runner costs against a plain ProcessPoolExecutor.

Run with ``python -m hoopbench.reports.bench.runner [--cheap N] [--cpu N] [--cpu-seconds S]``.
The runner buys isolation (one call per worker at a time, killable, replaced when it dies),
a results dataset written as runs finish, and resume; this prints its price on the same
tasks: rows per second with 1 and 2 jobs for a trivial worker (the per-run overhead shows
alone) and for a CPU-bound one (closer to engine runs; target: at most 5 % slower), and the
parent's peak RSS for a 2,000-task sweep against a 200-task one (it should stay flat: the
parent holds rows, not results). A measurement, not a test: nothing here asserts a time.
"""

from __future__ import annotations

import argparse
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from hoopbench.reports.compare.suite import run_task
from hoopbench.reports.compare.suite_file import builtin_suite, load_suite
from hoopbench.reports.sweep.runner import Task, run_tasks


@dataclass(frozen=True)
class BenchTask:
    run_id: str
    seconds: float = 0.0
    """CPU time the cpu worker burns."""


def cheap_worker(task: BenchTask) -> dict[str, Any]:
    return {"status": "ok", "message": "", "value": len(task.run_id)}


def cpu_worker(task: BenchTask) -> dict[str, Any]:
    end = time.thread_time() + task.seconds
    total = 0
    while time.thread_time() < end:
        total += sum(i * i for i in range(1000))
    return {"status": "ok", "message": "", "value": total % 97}


def _tasks(n: int, seconds: float = 0.0) -> list[BenchTask]:
    return [BenchTask(f"t{i:06d}", seconds) for i in range(n)]


def time_runner(worker: Callable, tasks: Sequence[Task], jobs: int) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        summary = run_tasks(tasks, worker, Path(tmp) / "out", jobs=jobs, quiet=True)
        wall = time.perf_counter() - start
    assert summary.total == len(tasks)
    return wall


def time_plain_pool(worker: Callable, tasks: Sequence[Task], jobs: int) -> float:
    start = time.perf_counter()
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        rows = list(pool.map(worker, tasks))
    wall = time.perf_counter() - start
    assert len(rows) == len(tasks)
    return wall


def peak_rss_mb(n_tasks: int) -> float:
    """The parent's peak RSS for an n-task cheap sweep, measured in a fresh interpreter."""
    code = (
        "import resource, tempfile, pathlib;"
        "from hoopbench.reports.bench.runner import _tasks, cheap_worker;"
        "from hoopbench.reports.sweep.runner import run_tasks;"
        "tmp = tempfile.mkdtemp();"
        f"run_tasks(_tasks({n_tasks}), cheap_worker, pathlib.Path(tmp) / 'out', jobs=2,"
        " quiet=True);"
        "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return int(out.stdout.split()[-1]) / 1024  # kB on Linux


def bench_suite(name: str, repeat: int) -> int:
    """The real worker on a real suite: the isolated runner against a plain process pool
    (today's runner before isolation), alternating so that load drift hits both."""
    tasks = load_suite(builtin_suite(name)).tasks()
    print(f"suite {name}: {len(tasks)} runs, 2 jobs, best of {repeat}")
    ours, plain = [], []
    for _ in range(repeat):
        plain.append(time_plain_pool(run_task, tasks, 2))
        ours.append(time_runner(run_task, tasks, 2))
    best_ours, best_plain = min(ours), min(plain)
    print(f"isolated runner: {best_ours:.1f} s ({len(tasks) / best_ours:.1f} rows/s)")
    print(f"plain pool:      {best_plain:.1f} s ({len(tasks) / best_plain:.1f} rows/s)")
    print(f"overhead: {100 * (best_ours / best_plain - 1):+.1f} %")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cheap", type=int, default=2000, help="tasks of the trivial worker")
    parser.add_argument("--cpu", type=int, default=60, help="tasks of the CPU-bound worker")
    parser.add_argument("--cpu-seconds", type=float, default=0.1, help="CPU time per task")
    parser.add_argument(
        "--suite",
        help="instead: a shipped suite (e.g. default), isolated runner against a plain pool",
    )
    parser.add_argument("--repeat", type=int, default=2, help="repeats of the suite timing")
    args = parser.parse_args(argv)
    if args.suite:
        return bench_suite(args.suite, args.repeat)

    start = time.perf_counter()
    time_runner(cheap_worker, _tasks(2), 1)
    print(
        f"first sweep of this process (starts the fork server): "
        f"{time.perf_counter() - start:.2f} s; the figures below come after it"
    )
    print(
        f"{'worker':6} {'jobs':>4} {'tasks':>6} {'runner rows/s':>14} {'plain rows/s':>13} "
        f"{'runner s':>9} {'plain s':>8} {'overhead':>9}"
    )
    cases = [("cheap", cheap_worker, _tasks(args.cheap))]
    cases.append(("cpu", cpu_worker, _tasks(args.cpu, args.cpu_seconds)))
    for name, worker, tasks in cases:
        for jobs in (1, 2):
            ours = time_runner(worker, tasks, jobs)
            plain = time_plain_pool(worker, tasks, jobs)
            print(
                f"{name:6} {jobs:>4} {len(tasks):>6} {len(tasks) / ours:>14.1f} "
                f"{len(tasks) / plain:>13.1f} {ours:>9.2f} {plain:>8.2f} "
                f"{100 * (ours / plain - 1):>8.1f}%"
            )
    small, large = peak_rss_mb(200), peak_rss_mb(2000)
    print(f"parent peak RSS: {small:.1f} MB for 200 tasks, {large:.1f} MB for 2000 tasks")
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"(this benchmark process: {own:.1f} MB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
