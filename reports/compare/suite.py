"""The comparison suite: the worker that runs one task, and the compare and report steps.

A suite file (:mod:`hoopbench.reports.compare.suite_file`) expands into tasks; the isolated runner
(:mod:`hoopbench.reports.sweep.runner`) runs :func:`run_task` for each in a worker process and
stores one tidy row per run: the run's settings, its status and cost, its detected events,
the exact events for the same scene and mu, and the errors (engine minus exact).
"""

from __future__ import annotations

import functools
import json
import math
import shutil
from collections.abc import Mapping
from concurrent.futures import Executor
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.event_checks import check_flight
from hoopbench.engines.judging.verdict import (
    Verdict,
    painleve_time,
    row_phases_agree,
    verdict_columns,
)
from hoopbench.engines.registry import engine_class, get_engine
from hoopbench.engines.run import RunResult, RunStatus
from hoopbench.models import kinematics
from hoopbench.models.events import Events
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import ExactSolution, solve_exact
from hoopbench.reference.regimes import max_slip_speed
from hoopbench.reports.compare.rows import FORMAT_VERSION, RUNS_TABLE
from hoopbench.reports.compare.suite_file import RunTask, Suite, TrajectoryChoice, load_suite
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.runner import RunSummary, run_tasks

__all__ = [
    "FORMAT_VERSION",
    "TrajectoryChoice",
    "compare",
    "event_columns",
    "exact_columns",
    "failure_row",
    "run_and_row",
    "run_task",
    "run_timeout",
]

ROW_COLUMNS = (
    "run_id",
    "scene",
    "a",
    "g",
    "engine",
    "profile",
    "variant",
    "timestep",
    "geometry",
    "options",
    "status",
    "message",
    "engine_version",
    "mu",
    "wall_time_s",
    "n_steps",
    "us_per_step",
    "exact_outcome",
    "exact_t_slip",
    "exact_theta_slip_deg",
    "exact_t_lift",
    "exact_hop_height",
    "exact_t_impact",
    "exact_t_painleve",
    "exact_phases",
    "exact_t_last_phase",
    "exact_max_slip_speed",
    "outcome",
    "t_slip",
    "t_slip_threshold",
    "theta_slip_deg",
    "t_restick",
    "t_lift",
    "hop_height",
    "t_impact",
    "err_t_slip_ms",
    "err_theta_slip_deg",
    "err_t_lift_ms",
    "err_t_impact_ms",
    "err_hop_height_rel",
    "energy_rise_before_slip",
    "energy_change_end",
    "max_penetration_m",
    "rms_position_m",
    "max_clearance",
    "consistent",
    "event_flags",
    "verdict",
    "outcome_agrees",
    "phases",
    "t_last_phase",
    "t_final",
    "phases_agree",
    "trajectory_file",
)
"""Every column of a run's row, in order; a failed run leaves most of them empty."""

TRAJECTORY_DIR = "trajectories"
"""Sub-folder of a results folder holding stored trajectories, one Parquet file per run."""


# --------------------------------------------------------------------------- one run
@functools.cache  # one exact solve per (scene, mu) per worker process, not one per run
def _exact_solution(scene: Scene, mu: float) -> ExactSolution:
    return solve_exact(scene.with_(mus=mu, muk=mu))


def _exact_events(scene: Scene, mu: float) -> Events:
    return _exact_solution(scene, mu).events


@functools.cache
def _exact_max_slip_speed(scene: Scene, mu: float) -> float | None:
    return max_slip_speed(_exact_solution(scene, mu))


def rms_position_error(trajectory: Trajectory, exact: ExactSolution) -> float | None:
    """RMS distance, m, between the run's and the exact hoop-centre positions over the common
    window (from 0 to whichever ends first: the run, or the exact solution at its impact).

    The hoop centre, not the centre of mass: it is where the contact events happen, and its
    path is the one the report draws.
    """
    t = trajectory.t[trajectory.t <= exact.t_final]
    if len(t) < 2:
        return None
    n = len(t)
    ref = exact.sample(t)
    x, y = kinematics.centre_position(
        exact.scene, trajectory.X[:n], trajectory.Y[:n], trajectory.theta[:n]
    )
    x0, y0 = kinematics.centre_position(exact.scene, ref.X, ref.Y, ref.theta)
    return float(np.sqrt(np.mean((x - x0) ** 2 + (y - y0) ** 2)))


def _error(value: float | None, reference: float | None) -> float | None:
    if value is None or reference is None:
        return None
    return value - reference


def _task_columns(task: RunTask) -> dict[str, Any]:
    """The descriptive columns of a task's row (also those of a timeout or crash row)."""
    defaults = engine_class(task.engine).defaults(task.profile)
    changed = {k: v for k, v in task.options if v != defaults.get(k)}
    return {
        "run_id": task.run_id,
        "scene": task.scene.name,
        "a": task.scene.a,
        "g": task.scene.g,  # with a, carries the verdict's thresholds to the scene's hoop
        "engine": task.engine,
        "profile": str(task.profile),
        "variant": task.variant,
        "timestep": task.timestep,
        "geometry": task.geometry,
        "options": json.dumps(changed, default=list, sort_keys=True),
    }


def exact_columns(exact: Events, max_slip_speed: float | None = None) -> dict[str, Any]:
    """The ``exact_*`` columns of a row: the exact events of its scene (and mu), and the
    exact slips' largest speed, m/s (reference/regimes.py ``max_slip_speed``)."""
    return {
        "exact_outcome": str(exact.outcome),
        "exact_t_slip": exact.t_slip,
        "exact_theta_slip_deg": None
        if exact.theta_slip is None
        else math.degrees(exact.theta_slip),
        "exact_t_lift": exact.t_lift,
        "exact_hop_height": exact.hop_height,
        "exact_t_impact": exact.t_impact,
        "exact_t_painleve": painleve_time(exact),
        "exact_phases": exact.phase_code,
        "exact_t_last_phase": exact.phases[-1].t_start if exact.phases else None,
        "exact_max_slip_speed": max_slip_speed,
    }


def event_columns(
    events: Events, traj: Trajectory, scene: Scene, exact: Mapping[str, Any]
) -> dict[str, Any]:
    """A judged run's event columns and their errors against ``exact`` (the row's
    ``exact_*`` columns, :func:`exact_columns`, with None for a missing value)."""
    # The judge has no scene; the flight-time bound needs g and lam a (engines/event_checks).
    events = check_flight(events, traj, scene)
    theta_deg = None if events.theta_slip is None else math.degrees(events.theta_slip)
    before = traj.t < (events.t_slip if events.t_slip is not None else traj.t[-1])
    e0 = traj.energy[0]
    exact_hop = exact["exact_hop_height"]
    columns = {
        "outcome": str(events.outcome),
        "t_slip": events.t_slip,
        "t_slip_threshold": events.extra.get("t_slip_threshold"),
        "theta_slip_deg": theta_deg,
        "t_restick": events.t_restick,
        "t_lift": events.t_lift,
        "hop_height": events.hop_height,
        "t_impact": events.t_impact,
        "err_t_slip_ms": _ms(_error(events.t_slip, exact["exact_t_slip"])),
        "err_theta_slip_deg": _error(theta_deg, exact["exact_theta_slip_deg"]),
        "err_t_lift_ms": _ms(_error(events.t_lift, exact["exact_t_lift"])),
        "err_t_impact_ms": _ms(_error(events.t_impact, exact["exact_t_impact"])),
        "err_hop_height_rel": None
        if events.hop_height is None or not exact_hop
        else events.hop_height / exact_hop - 1.0,
        "energy_rise_before_slip": float((traj.energy[before].max() - e0) / e0)
        if before.any()
        else None,
        "energy_change_end": float((traj.energy[-1] - e0) / e0),
        "max_penetration_m": float(max(0.0, -traj.clearance.min())),
        "max_clearance": float(traj.clearance.max()),
        "consistent": not events.flags,
        "event_flags": " ".join(events.flags),
        "phases": events.phase_code,
        "t_last_phase": events.phases[-1].t_start if events.phases else None,
        "t_final": float(traj.t[-1]),
    }
    return {
        **columns,
        "phases_agree": row_phases_agree({**exact, **columns, "a": scene.a, "g": scene.g}),
    }


def _row(
    task: RunTask, result: RunResult, exact: Events, exact_slip_speed: float | None = None
) -> dict[str, Any]:
    info, events, traj = result.info, result.events, result.trajectory
    row: dict[str, Any] = {
        **_task_columns(task),
        "status": str(info.status),
        "message": info.message,
        "engine_version": info.engine_version,
        "mu": info.mu,
        "wall_time_s": info.wall_time_s,
        "n_steps": info.n_steps,
        "us_per_step": None
        if not info.n_steps or info.wall_time_s is None
        else 1e6 * info.wall_time_s / info.n_steps,
        **exact_columns(exact, exact_slip_speed),
    }
    if events is not None and traj is not None:
        row.update(event_columns(events, traj, task.scene, row))
    return {**row, **verdict_columns(row)}


def _ms(seconds: float | None) -> float | None:
    return None if seconds is None else 1e3 * seconds


def run_task(task: RunTask) -> dict[str, Any]:
    """Run one task and return its row; a failure anywhere becomes a row with status error.

    The worker function of the runner: importable, its input and output small and picklable.
    """
    try:
        return _run_task(task)
    except Exception as exc:  # one broken run must not stop a sweep
        return failure_row(task, RunStatus.ERROR, f"{type(exc).__name__}: {exc}")


def _run_task(task: RunTask) -> dict[str, Any]:
    result, row = run_and_row(task)
    if task.trajectory_dir and result.trajectory is not None:
        name = f"{task.run_id}.parquet"
        path = Path(task.trajectory_dir) / name
        path.parent.mkdir(parents=True, exist_ok=True)
        trajectory = result.trajectory
        results.atomic_write(path, lambda tmp: trajectory.write(tmp, suffix=".parquet"))
        row["trajectory_file"] = f"{TRAJECTORY_DIR}/{name}"
    return row


def run_and_row(task: RunTask) -> tuple[RunResult, dict[str, Any]]:
    """Run one task and judge it against the exact solution: the judged run and its row
    (nothing stored). Engine failures are statuses in both; bad settings raise ValueError."""
    result = get_engine(task.engine).run(task.scene, task.settings())
    mu = result.info.mu if result.info.mu is not None else task.scene.mus
    row = _row(task, result, _exact_events(task.scene, mu), _exact_max_slip_speed(task.scene, mu))
    if result.trajectory is not None and result.events is not None:
        row["rms_position_m"] = rms_position_error(
            result.trajectory, _exact_solution(task.scene, mu)
        )
    return result, row


def failure_row(task: RunTask, status: RunStatus, message: str) -> dict[str, Any]:
    """The row of a run that produced nothing (timeout, crash, an exception)."""
    return {
        **_task_columns(task),
        "status": str(status),
        "message": message,
        "verdict": str(Verdict.FAILED),
        "outcome_agrees": False,
    }


def run_timeout(task: RunTask) -> float:
    """Seconds a run may take before it becomes a timeout row: generous, from its size.

    The slowest engine here costs about 10 us a step (MuJoCo RK4, PyBullet); 0.5 ms a step
    is 50 times that, plus a minute for imports, model building and the exact solve.
    """
    return 60.0 + 5e-4 * task.n_steps


# --------------------------------------------------------------------------- compare
def compare(
    suite_file: str | Path,
    out: str | Path,
    *,
    jobs: int = 2,
    resume: bool = False,
    run_timeout_s: float | None = None,
    engines: list[str] | None = None,
    quiet: bool = False,
    trajectories: str = TrajectoryChoice.NONE,
    executor: Executor | None = None,
    suite: Suite | None = None,
) -> RunSummary:
    """Run a suite file into ``out`` (see the README's results layout).

    Raises SuiteError for a bad suite file, OutputDirNotEmptyError for a folder that holds
    files when ``resume`` is false, and FormatVersionError for resuming a folder a newer
    hoopbench wrote; all before any run starts.
    """
    suite = suite or load_suite(suite_file)
    if engines:
        suite = suite.with_engines(engines)
    out = Path(out)
    traj_dir = out / TRAJECTORY_DIR
    tasks = suite.tasks(str(traj_dir) if trajectories != TrajectoryChoice.NONE else None)
    if trajectories == TrajectoryChoice.DEFAULT:
        tasks = [t if t.variant == "default" else _without_trajectory(t) for t in tasks]
    timeout = run_timeout if run_timeout_s is None else run_timeout_s
    # A resumed folder keeps an older version (its old rows are still there); a newer one stops.
    version = results.resumed_format_version(out, RUNS_TABLE) if resume else FORMAT_VERSION
    meta = {
        "suite": suite.name,
        "suite_file": Path(suite_file).name,
        results.FORMAT_KEY: version,
        "units": {"times": "s", "angles": "deg", "lengths": "m", "*_ms": "ms"},
        "engine_versions": _engine_versions(suite.engines),
    }
    summary = run_tasks(
        tasks,
        run_task,
        out,
        failure_row=failure_row,
        timeout=timeout,
        jobs=jobs,
        executor=executor,
        resume=resume,
        meta=meta,
        quiet=quiet,
    )
    copy = out / "suite.toml"
    if Path(suite_file).is_file() and not copy.exists():
        results.atomic_write(copy, lambda tmp: shutil.copyfile(suite_file, tmp))
    return summary


def _without_trajectory(task: RunTask) -> RunTask:
    return replace(task, trajectory_dir=None)


def _engine_versions(engines: tuple[str, ...]) -> dict[str, str | None]:
    return {name: engine_class(name)().version() for name in engines}


def runs_frame(results_dir: str | Path) -> pd.DataFrame:
    """The latest row of every run of a results folder in the current layout (an older table
    migrated, a newer one refused: rows.RUNS_TABLE), with every row column (a sweep in which
    every run failed has no event columns of its own)."""
    return results.with_columns(results.read_table(results_dir, RUNS_TABLE), ROW_COLUMNS)
