"""The comparison suite: the worker that runs one task, and the compare and report steps.

A suite file (:mod:`hoopbench.reports.compare.suite_file`) expands into tasks; the isolated runner
(:mod:`hoopbench.reports.sweep.runner`) runs :func:`run_task` for each in a worker process (or
:func:`run_task_batch` for a batch of them, for an engine that steps many worlds at once) and
stores one tidy row per run: the run's settings, its status and cost, its detected events,
the exact events for the same scene and mu, and the errors (engine minus exact).
"""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Hashable, Sequence
from concurrent.futures import Executor
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Any, Protocol

import pandas as pd

from hoopbench.engines.base import Engine
from hoopbench.engines.judging.columns import (
    BATCH_COLUMNS,
    CPU_COLUMNS,
    EVENT_COLUMNS,
    EXACT_COLUMNS,
    FLOOR_COLUMNS,
    FORCE_COLUMNS,
    KIN_COLUMNS,
    TRANSITION_COLUMNS,
    Col,
)
from hoopbench.engines.judging.comparison import (
    cost_columns,
    exact_solution,
    judged_columns,
    scene_exact_columns,
)
from hoopbench.engines.judging.verdict import (
    Verdict,
)
from hoopbench.engines.registry import engine_class, get_engine
from hoopbench.engines.run import RunResult, RunStatus
from hoopbench.engines.settings import DEFAULT_BATCH_SIZE, RunSettings
from hoopbench.reports.compare.costs import suite_costing
from hoopbench.reports.compare.releases import (
    Release,
    ReleaseUnusableError,
    probe,
    run_in_release,
    with_env_note,
)
from hoopbench.reports.compare.rows import (
    FORMAT_VERSION,
    ONE_READING_VERSION,
    RUNS_TABLE,
    before_one_reading,
)
from hoopbench.reports.compare.settings_file import (
    SettingsFile,
    settings_identity,
    settings_meta,
    settings_mismatch,
)
from hoopbench.reports.compare.suite_file import (
    DEFAULT_VARIANT,
    LeftOut,
    RunTask,
    Suite,
    TrajectoryChoice,
    load_suite,
)
from hoopbench.reports.sweep import control_chars, results
from hoopbench.reports.sweep.runner import (
    Batching,
    RunnerError,
    RunSummary,
    claim_folder,
    row_or_failure,
    run_tasks,
)

__all__ = [
    "FORMAT_VERSION",
    "LEFT_OUT_KEY",
    "TIMEOUT_NOTE",
    "TrajectoryChoice",
    "batch_key",
    "batch_least",
    "compare",
    "failure_row",
    "left_out_text",
    "run_and_row",
    "run_task",
    "run_task_batch",
    "run_timeout",
]

ROW_COLUMNS = (
    Col.RUN_ID,
    Col.SCENE,
    Col.A,
    Col.G,
    Col.ENGINE,
    Col.PROFILE,
    Col.VARIANT,
    Col.TIMESTEP,
    Col.GEOMETRY,
    Col.OPTIONS,
    Col.STATUS,
    Col.MESSAGE,
    Col.ENGINE_VERSION,
    Col.MU,
    Col.WALL_TIME_S,
    Col.N_STEPS,
    Col.US_PER_STEP,
    *BATCH_COLUMNS,
    *CPU_COLUMNS,
    *EXACT_COLUMNS,
    *EVENT_COLUMNS,
    Col.ENERGY_RISE_BEFORE_SLIP,
    Col.ENERGY_CHANGE_END,
    Col.MAX_PENETRATION_M,
    Col.RMS_POSITION_M,
    Col.MAX_CLEARANCE,
    Col.T_FINAL,
    Col.VERDICT,
    Col.OUTCOME_AGREES,
    Col.VERDICT_FLAGS,
    Col.VERDICT_REASON,
    *TRANSITION_COLUMNS,
    *FLOOR_COLUMNS,
    *FORCE_COLUMNS,
    *KIN_COLUMNS,
    Col.TRAJECTORY_FILE,
)
"""Every column of a run's row, in order; a failed run leaves most of them empty."""

TRAJECTORY_DIR = "trajectories"
"""Sub-folder of a results folder holding stored trajectories, one Parquet file per run."""


# --------------------------------------------------------------------------- one run
def _task_columns(task: RunTask) -> dict[str, Any]:
    """The descriptive columns of a task's row (also those of a timeout or crash row)."""
    defaults = engine_class(task.engine).defaults(task.profile)
    changed = {k: v for k, v in task.options if v != defaults.get(k)}
    return {
        Col.RUN_ID: task.run_id,
        Col.SCENE: task.scene.name,
        Col.A: task.scene.a,
        Col.G: task.scene.g,  # with a, carries the verdict's thresholds to the scene's hoop
        Col.ENGINE: task.engine,
        Col.PROFILE: str(task.profile),
        Col.VARIANT: task.variant,
        Col.TIMESTEP: task.timestep,
        Col.GEOMETRY: task.geometry,
        Col.OPTIONS: json.dumps(changed, default=list, sort_keys=True),
    }


def _row(task: RunTask, result: RunResult) -> dict[str, Any]:
    info = result.info
    mu = info.mu if info.mu is not None else task.scene.mus
    row: dict[str, Any] = {
        **_task_columns(task),
        Col.STATUS: str(info.status),
        Col.MESSAGE: info.message,
        Col.ENGINE_VERSION: info.engine_version,
        Col.MU: info.mu,
        Col.WALL_TIME_S: info.wall_time_s,
        Col.N_STEPS: info.n_steps,
        Col.US_PER_STEP: None
        if not info.n_steps or info.wall_time_s is None
        else 1e6 * info.wall_time_s / info.n_steps,
        **cost_columns(info),
        **scene_exact_columns(task.scene, mu),
    }
    exact = exact_solution(task.scene, mu)
    return {**row, **judged_columns(row, result, task.scene, exact)}


def run_task(task: RunTask) -> dict[str, Any]:
    """Run one task and return its row; a failure anywhere becomes a row with status error.

    The worker function of the runner: importable, its input and output small and picklable.
    A run of another engine release than the installed one goes to a child process that
    imports that release (compare/releases.py).
    """
    if task.release is not None:
        return row_or_failure(_run_in_release, task, failure_row)
    return row_or_failure(_run_task, task, failure_row)


def _run_in_release(task: RunTask) -> dict[str, Any]:
    assert task.release is not None
    (row,) = run_in_release(Release(task.engine, task.release), [task])
    return row


def _run_task(task: RunTask) -> dict[str, Any]:
    return _stored(task, *run_and_row(task))


def batch_key(task: RunTask) -> Hashable | None:
    """Runs of one engine that steps many worlds at once and of one settings share batches
    (the runner's Batching key); any other run goes alone (None)."""
    if not engine_class(task.engine).batches or task.release is not None:
        return None
    return (task.engine, json.dumps(task.settings().to_dict(), sort_keys=True, default=repr))


def batch_least(key: Hashable) -> int:
    """The fewest runs a batch of ``key`` (:func:`batch_key`'s, or the map's: the engine
    first) is cut to: the engine's ``worlds_per_call``."""
    assert isinstance(key, tuple)
    return engine_class(key[0]).worlds_per_call


def batch_affinity(key: Hashable) -> Hashable:
    """The affinity key of a batch of ``key`` (:func:`batch_key`'s, or the map's: the engine
    first): its engine. An engine that batches pays its imports, kernel loads and compiled
    programs once per process, whatever the settings, so its batches keep to the worker that
    has run one (the runner's Batching affinity)."""
    assert isinstance(key, tuple)
    return key[0]


def run_task_batch(tasks: list[RunTask]) -> list[dict[str, Any]]:
    """The batch worker: the tasks' scenes in one engine call (``Engine.run_batch``), their
    rows in order, each as :func:`run_task` would give it. If the engine refuses the batch
    (a bad scene raises before anything steps), each task runs alone for its own row."""
    try:
        engine = get_engine(tasks[0].engine)
        judged = engine.run_batch([task.scene for task in tasks], tasks[0].settings())
    except Exception:
        return [run_task(task) for task in tasks]
    return [
        row_or_failure(partial(_stored_row, result=result), task, failure_row)
        for task, result in zip(tasks, judged, strict=True)
    ]


def _stored_row(task: RunTask, result: RunResult) -> dict[str, Any]:
    return _stored(task, result, _row(task, result))


def _stored(task: RunTask, result: RunResult, row: dict[str, Any]) -> dict[str, Any]:
    """The row, with the run's trajectory stored if the task asks for it."""
    if task.trajectory_dir and result.trajectory is not None:
        name = f"{task.run_id}.parquet"
        path = Path(task.trajectory_dir) / name
        path.parent.mkdir(parents=True, exist_ok=True)
        trajectory = result.trajectory
        results.atomic_write(path, lambda tmp: trajectory.write(tmp, suffix=".parquet"))
        row[Col.TRAJECTORY_FILE] = f"{TRAJECTORY_DIR}/{name}"
    return row


def run_and_row(
    task: RunTask, settings: RunSettings | None = None
) -> tuple[RunResult, dict[str, Any]]:
    """Run one task and judge it against the exact solution: the judged run and its row
    (nothing stored). Engine failures are statuses in both; bad settings raise ValueError.
    ``settings``: the task's with what a suite does not vary over them (a pair friction, a
    step limit: ``hoopbench simulate``'s ``--mu``, ``--max-steps``); the exact solution is
    the one of the run's friction (its ``mu``)."""
    result = get_engine(task.engine).run(task.scene, settings or task.settings())
    return result, _row(task, result)


LEFT_OUT_KEY = "left_out_without_gpu"
"""meta.json's list of the runs a suite sized to the machine left out for want of a GPU
(LeftOut.to_dict each): the report says so (Platform and runs)."""


def left_out_text(left_out: Sequence[LeftOut]) -> str:
    """One sentence: what a machine without a GPU left out of a suite, and why."""
    runs = sum(item.runs for item in left_out)
    parts = "; ".join(
        f"{item.label} ({item.runs} run{'s' if item.runs != 1 else ''}): {item.reason}"
        for item in left_out
    )
    many = runs != 1
    finders = sorted({_gpu_finder(item.engine) for item in left_out})
    seen = f"{' and '.join(finders)} {'sees' if len(finders) == 1 else 'see'} none"
    return (
        f"no GPU here ({seen}), so {runs} run{'s' if many else ''} that "
        f"{'pay' if many else 'pays'} off only on a GPU {'were' if many else 'was'} left out, "
        f"to the full suite: {parts}."
    )


def _gpu_finder(engine: str) -> str:
    """What finds an engine's GPU (Engine.gpu_finder); NVIDIA Warp's for an engine this
    hoopbench does not know (a stored meta.json of a plugin's runs)."""
    try:
        return engine_class(engine).gpu_finder
    except ValueError:
        return Engine.gpu_finder


TIMEOUT_NOTE = "the sweep's time limit: the machine's failure, not the engine's; not judged"
"""A timeout row's verdict_reason, in place of a verdict (issue 34): a run the time limit
ended says nothing of the engine, only that this machine, at its load, did not finish it in
time."""


def failure_row(task: RunTask, status: RunStatus, message: str) -> dict[str, Any]:
    """The row of a run that produced nothing (timeout, crash, an exception): verdict
    ``failed``, but for a timeout, which has none (its verdict_reason says why: TIMEOUT_NOTE):
    the summaries that count verdicts leave it out instead of counting it as the engine
    getting the scene wrong."""
    if status is RunStatus.TIMEOUT:
        return {
            **_task_columns(task),
            Col.STATUS: str(status),
            Col.MESSAGE: message,
            Col.VERDICT_REASON: TIMEOUT_NOTE,
        }
    return {
        **_task_columns(task),
        Col.STATUS: str(status),
        Col.MESSAGE: message,
        Col.VERDICT: str(Verdict.FAILED),
        Col.OUTCOME_AGREES: False,
    }


class StepCounted(Protocol):
    """A task that knows its engine and the steps of its whole window: a suite's RunTask, a
    map's MapTask."""

    @property
    def engine(self) -> str: ...

    @property
    def n_steps(self) -> int: ...


def _stored_before_one_reading(out: Path) -> bool:
    """Whether the runs stored in ``out`` name their columns as before format 7."""
    try:
        stored = results.read_runs(out)
    except (OSError, ValueError):
        return False
    return len(stored) > 0 and before_one_reading(stored.columns)


def run_timeout(task: StepCounted) -> float:
    """Seconds a run may take before it becomes a timeout row: generous, from its size.

    A minute for imports, model building, compiling and the exact solve, and the engine's
    ``step_cost_bound`` for each step (0.5 ms unless the engine says more: the batched
    engines launch their kernels from Python, 3-40 ms a step for a world alone on the CPU).
    """
    return 60.0 + engine_class(task.engine).step_cost_bound * task.n_steps


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
    batch_size: int = DEFAULT_BATCH_SIZE,
    settings: tuple[SettingsFile, str | None] | None = None,
) -> RunSummary:
    """Run a suite file into ``out`` (see the README's results layout). The runs of an
    engine that steps many worlds at once go in batches of ``batch_size`` (docs/engines.md,
    Batches); ``batch_size`` 1 runs every run alone. ``settings``: the ``--settings`` file
    (and the NAME of ``FILE#NAME``) whose settings ``suite`` holds as variants: part of the
    folder's identity, so that a resume with another file, or none, is refused.

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
    tasks, left_out = suite.for_machine(tasks)
    if trajectories == TrajectoryChoice.DEFAULT:
        tasks = [t if t.variant == DEFAULT_VARIANT else _without_trajectory(t) for t in tasks]
    say = None if quiet else control_chars.say
    if say is not None and left_out:
        say(f"{suite.name}: {left_out_text(left_out)}")
    tasks, releases = _usable_releases(tasks, say)
    timeout = run_timeout if run_timeout_s is None else run_timeout_s
    # A resumed folder keeps an older version (its old rows are still there); a newer one stops.
    version = results.resumed_format_version(out, RUNS_TABLE) if resume else FORMAT_VERSION
    if resume and version < ONE_READING_VERSION and _stored_before_one_reading(out):
        raise RunnerError(
            f"{out} holds runs table format {version}, from before one reading (format "
            f"{ONE_READING_VERSION}): its rows and this hoopbench's cannot share a table; "
            "run the suite into a new folder (the old one reads as before)"
        )
    meta = {
        "suite": suite.name,
        "suite_file": Path(suite_file).name,
        results.FORMAT_KEY: version,
        "units": {"times": "s", "angles": "deg", "lengths": "m", "*_ms": "ms"},
        "engine_versions": _engine_versions(suite.engines),
        **settings_meta(*(settings or (None,))),
        **({LEFT_OUT_KEY: [item.to_dict() for item in left_out]} if left_out else {}),
        **({RELEASES_KEY: releases} if releases else {}),
    }
    identity = suite_identity(suite, suite_file) | settings_identity(*(settings or (None,)))
    if suite.engine_versions:  # another set of releases is another sweep
        identity[RELEASES_KEY] = {e: list(v) for e, v in sorted(suite.engine_versions.items())}
    with claim_folder(out, resume, identity, say, settings_mismatch):
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
            batching=Batching(run_task_batch, batch_key, batch_size, batch_least, batch_affinity)
            if batch_size > 1
            else None,
            costing=suite_costing(),
        )
        copy = out / "suite.toml"
        if Path(suite_file).is_file() and not copy.exists():
            results.atomic_write(copy, lambda tmp: shutil.copyfile(suite_file, tmp))
    return summary


RELEASES_KEY = "engine_releases"
"""sweep.json's key: each release asked for (ENGINE==VERSION) and what became of it: the
version imported, or the one line saying why it could not run."""


def _usable_releases(
    tasks: list[RunTask], say: Any
) -> tuple[list[RunTask], dict[str, dict[str, str]]]:
    """Install (once) and probe each release the tasks ask for; the tasks of the releases
    that can run, and what became of each release. An unusable release is one line on
    stderr (always: it is the answer to what was asked) and its runs are left out; the
    others run."""
    firsts: dict[Release, RunTask] = {}
    for task in tasks:
        if task.release is not None:
            firsts.setdefault(Release(task.engine, task.release), task)
    status: dict[str, dict[str, str]] = {}
    bad = set()
    for release, first in firsts.items():
        try:
            found = probe(release, first)
        except ReleaseUnusableError as exc:
            bad.add(release)
            status[release.spec] = {"status": "unusable", "message": str(exc)}
            control_chars.say(f"hoopbench: {exc}")
            continue
        status[release.spec] = {"status": "ok", "version": found}
        if say is not None:
            say(f"hoopbench: {with_env_note(release)}")
    kept = [t for t in tasks if t.release is None or Release(t.engine, t.release) not in bad]
    return kept, status


def suite_identity(suite: Suite, suite_file: str | Path) -> dict[str, Any]:
    """What a results folder of this suite records (runner.IDENTITY_NAME): a resume with
    another suite, or another version of its file, would mix two suites' rows."""
    try:
        digest: str | None = hashlib.sha256(Path(suite_file).read_bytes()).hexdigest()
    except OSError:
        digest = None
    return {"kind": "suite", "suite": suite.name, "suite_sha256": digest}


def _without_trajectory(task: RunTask) -> RunTask:
    return replace(task, trajectory_dir=None)


def _engine_versions(engines: tuple[str, ...]) -> dict[str, str | None]:
    return {name: engine_class(name)().version() for name in engines}


def runs_frame(results_dir: str | Path) -> pd.DataFrame:
    """The latest row of every run of a results folder in the current layout (an older table
    migrated, a newer one refused: rows.RUNS_TABLE), with every row column (a sweep in which
    every run failed has no event columns of its own)."""
    return results.with_columns(results.read_table(results_dir, RUNS_TABLE), ROW_COLUMNS)
