"""The process that runs an engine release: ``python -m hoopbench.reports.compare.release_child
FOLDER ENGINE VERSION OUT MODE`` with the pickled RunTasks on stdin (releases.run_in_release).

It puts the release's folder first on ``sys.path`` before anything imports the engine, and
keeps the engine package's submodules to that folder: MuJoCo 3.x extends its package path
(pkgutil), and without the cut ``import mujoco.batch`` on a 3.x release found the main
environment's 4.0 module and failed inside it (measured). The rows go to OUT (pickled), not
stdout, which engines print on (PyBullet's build line). MODE ``probe`` steps the first task's
scene for a few steps only (its row: status, message, the version imported); ``run`` gives
each task's row as the suite's worker does.
"""

from __future__ import annotations

import ctypes
import importlib
import os
import pickle
import signal
import sys
from dataclasses import replace
from pathlib import Path
from typing import Any

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.registry import engine_class, get_engine
from hoopbench.reports.compare.suite import run_task
from hoopbench.reports.compare.suite_file import RunTask
from hoopbench.reports.sweep import results

PROBE_STEPS = 20
"""Steps of a probe run: enough to build the model, step it and read its contact force."""


def _die_with_parent() -> None:
    """Linux: this process is killed with the worker that started it (a sweep's time limit
    kills the worker by SIGKILL, which a child would otherwise outlive)."""
    try:
        libc = ctypes.CDLL("libc.so.6", use_errno=True)
    except OSError:
        return
    pr_set_pdeathsig = 1
    libc.prctl(pr_set_pdeathsig, signal.SIGKILL)


def use_release(folder: Path, engine: str) -> None:
    """Make ``import ENGINE`` load the release in ``folder`` (module docstring)."""
    modules = engine_class(engine).modules
    loaded = [m for m in modules if m in sys.modules]
    if loaded:
        raise RuntimeError(f"{', '.join(loaded)} imported before the release's folder was set")
    sys.path.insert(0, str(folder))
    importlib.invalidate_caches()
    try:
        package = importlib.import_module(modules[0])
    except Exception:  # the run reports it as the engine being unavailable, in one line
        return
    path = getattr(package, "__path__", None)
    if path is not None:
        path[:] = [p for p in path if Path(p).resolve().is_relative_to(folder.resolve())]


def _probe_row(task: RunTask) -> dict[str, Any]:
    """A few steps of the task's scene: does the adapter build, step and read this release?"""
    scene = replace(task.scene, t_end=PROBE_STEPS * task.timestep)
    run = get_engine(task.engine).simulate(scene, task.settings())
    info = run.info
    return {
        Col.STATUS.value: str(info.status),
        Col.MESSAGE.value: info.message,
        Col.ENGINE_VERSION.value: info.engine_version,
    }


def main(argv: list[str]) -> int:
    folder, engine, _version, out, mode = argv
    _die_with_parent()
    tasks: list[RunTask] = pickle.loads(sys.stdin.buffer.read())
    use_release(Path(folder), engine)
    if mode == "probe":
        rows = [_probe_row(tasks[0])]
    else:
        rows = [run_task(replace(task, release=None)) for task in tasks]
    data = pickle.dumps(rows)
    results.atomic_write(Path(out), lambda tmp: Path(tmp).write_bytes(data))
    return 0


if __name__ == "__main__":
    sys.stdout = sys.stderr  # an engine's prints must not mix with anything a caller reads
    os.environ.setdefault("PYTHONWARNINGS", "ignore")
    sys.exit(main(sys.argv[1:]))
