"""The hop map's runs: the exact regime and every engine's verdict over a grid of scenes.

The spec (:class:`hoopbench.reports.hop_map.spec.MapSpec`, stored as ``DIR/map.toml``) gives
the points, engines and settings.

:func:`run_map` runs the map in two stages through the same runner as ``compare``
(:func:`hoopbench.reports.sweep.runner.run_tasks`: isolated workers, time limits, resume), both into
the one runs dataset ``DIR/runs/``:

1. one task per point, engine ``reference``: the exact solver classifies the scene
   (:func:`hoopbench.reference.regimes.classify`);
2. one task per (point, engine), carrying the reference's exact columns and ``t_settled``; the
   engine run stops at its first impact, or once it has rolled a full turn after the
   reference's last event, when nothing new can happen. Its row has the event, error and
   verdict columns that ``compare`` gives (the same functions build them).

Each point's exact solution over its whole window (what the engine runs are judged against:
their detection floor, RMS and force columns) is solved once, in stage 1, by the
classification's own integration (which notes where the point settles on its way instead of
stopping there, then solving the window again), and stored in a private temporary folder of
this session's; stage 2's workers read it instead of solving it again (a worker that cannot
reach the folder, or a resumed map's, solves it as before).

Its table (columns :data:`MAP_COLUMNS`) is read by :mod:`hoopbench.reports.hop_map.table`.
"""

from __future__ import annotations

import json
import os
import pickle
import sys
import tempfile
from collections import Counter
from collections.abc import Hashable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass
from datetime import UTC, datetime
from functools import partial
from pathlib import Path
from typing import Any, TextIO

from hoopbench.engines.base import n_steps_for, steps_to_stop
from hoopbench.engines.judging.columns import (
    BATCH_COLUMNS,
    CPU_COLUMNS,
    EVENT_COLUMNS,
    FLOOR_COLUMNS,
    FORCE_COLUMNS,
    KIN_COLUMNS,
    TRANSITION_COLUMNS,
    Col,
)
from hoopbench.engines.judging.comparison import (
    cost_columns,
    exact_columns,
    exact_solution,
    judged_columns,
)
from hoopbench.engines.judging.verdict import number_or_none, verdict_columns
from hoopbench.engines.options import Profile
from hoopbench.engines.registry import engine_class, get_engine
from hoopbench.engines.run import RunResult, RunStatus
from hoopbench.engines.settings import DEFAULT_BATCH_SIZE, RunSettings
from hoopbench.engines.stopping import StopRule
from hoopbench.models.events import Outcome
from hoopbench.models.scene import DegenerateSceneError, Scene
from hoopbench.reference.exact import ExactSolution, first_flight_impact
from hoopbench.reference.regimes import classify_solved, classify_whole
from hoopbench.reports.compare.costs import MAP_COSTING
from hoopbench.reports.compare.suite import (
    TIMEOUT_NOTE,
    batch_affinity,
    batch_least,
    run_timeout,
)
from hoopbench.reports.hop_map.display import write_display, write_exact_display
from hoopbench.reports.hop_map.spec import (
    MAP_FILE,
    REFERENCE,
    REFERENCE_TIMEOUT,
    MapPoint,
    MapSpec,
    MapSpecMismatchError,
    check_stored_points,
    load_spec,
)
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.control_chars import terminal_text
from hoopbench.reports.sweep.folder_files import read_folder_text
from hoopbench.reports.sweep.runner import (
    Batching,
    RunnerError,
    RunSummary,
    check_identity,
    claim_folder,
    holds_files,
    is_final_status,
    prepare_dir,
    refuse_in_a_starting_worker,
    row_or_failure,
    run_tasks,
)

__all__ = [
    "EXACT_CARRIED",
    "MAP_COLUMNS",
    "ROWS_FORMAT_VERSION",
    "MapTask",
    "classified_tasks",
    "map_batch_key",
    "map_failure_row",
    "planned_tasks",
    "reference_tasks",
    "run_map",
    "run_map_batch",
    "run_map_task",
]


# --------------------------------------------------------------------------- points, tasks
ROWS_FORMAT_VERSION = 6
"""Version of the map's runs table (meta.json; map.toml has its own, FORMAT_VERSION): 2 adds
the contact reading's columns and the verdict's flags and reason, 3 the contact force
against the exact one (FORCE_COLUMNS), as a suite's rows have them; 4 one reading (issue 24:
reports/compare/rows.one_reading); 5 the batch's cost (issue 27: BATCH_COLUMNS,
reports/compare/rows.with_batch_columns); 6 every transition timed (issue 33:
reports/compare/rows.with_transition_columns) and, with issue 34, the process's CPU time
(CPU_COLUMNS: a table stored before reads them empty)."""

ONE_READING_MAP_VERSION = 4
"""The first map table format with one reading: a map folder stored before it is read
migrated but cannot be resumed (as a suite's, reports/compare/rows.ONE_READING_VERSION)."""

EXACT_CARRIED = (
    Col.REGIME,
    Col.N_SLIPS,
    Col.EXACT_OUTCOME,
    Col.EXACT_HOP_HEIGHT,
    Col.EXACT_T_SLIP,
    Col.EXACT_T_LIFT,
    Col.EXACT_T_IMPACT,
    Col.EXACT_PHASES,
    Col.EXACT_THETA_SLIP_DEG,
    Col.EXACT_T_PAINLEVE,
    Col.EXACT_T_SETTLED,
    Col.EXACT_T_LAST_PHASE,
    Col.EXACT_MAX_SLIP_SPEED,
)
"""The reference row's columns an engine task carries and its row repeats."""


@dataclass(frozen=True)
class MapTask:
    """One run of a map: small and picklable, for a worker process or a Dask worker."""

    run_id: str
    point: MapPoint
    engine: str
    """An engine name, or REFERENCE for the exact classification."""
    timestep: float | None = None
    """s (engines only)."""
    profile: Profile | None = None
    """Engines only."""
    exact: tuple[tuple[str, Any], ...] = ()
    """The reference row's EXACT_CARRIED columns (engines only; empty if it failed)."""
    display_dir: str | None = None
    """The map folder, where the run's thinned trajectory goes (hop_map/display.py); None:
    none is kept."""
    exact_dir: str | None = None
    """This session's private folder of exact solutions (:func:`run_map`'s): the reference
    task stores its point's there, and the point's engine tasks judge against it instead of
    solving it again; None, or a folder this worker cannot reach (another machine's): each
    worker solves it."""

    @property
    def label(self) -> str:
        """What the run is, for progress lines."""
        p = self.point
        return f"{p.x_axis}={p.x:.4g} {p.y_axis}={p.y:.4g} {self.engine}"

    @property
    def n_steps(self) -> int:
        """Steps of the whole window (sizes the time limit; an early stop only shortens it)."""
        return 0 if self.timestep is None else n_steps_for(self.point.scene(), self.timestep)

    @property
    def expected_steps(self) -> int:
        """Steps the run is expected to take (its cost, for the ETA): where its own stop rule
        (:func:`_task_stop`) ends a run that follows the exact motion, from the exact columns
        it carries (first impact, t_settled). Where it carries none (planned before stage 1,
        or its reference failed), a point whose hoop leaves the floor at once stops at its
        ballistic landing (:func:`first_flight_impact`, no integration: 31 of the default
        map's 100 points, within a tenth of their window) and any other steps its whole
        window: the default map's runs so planned take 0.74 of their windows where their
        classification says 0.57 (all planned by window: 1.0)."""
        exact = dict(self.exact)
        if self.timestep is None:
            return self.n_steps  # 0 for a reference task
        scene = self.point.scene()
        if Col.EXACT_T_IMPACT in exact:
            t_impact = exact[Col.EXACT_T_IMPACT]
        else:
            t_impact = first_flight_impact(scene)
            if t_impact is None:
                return self.n_steps
        return steps_to_stop(scene, self.timestep, _task_stop(self).stop_time(t_impact))


def reference_tasks(
    spec: MapSpec, display_dir: str | None = None, exact_dir: str | None = None
) -> list[MapTask]:
    """Stage 1: one classification per point."""
    return [
        MapTask(f"{p.name}-{REFERENCE}", p, REFERENCE, display_dir=display_dir, exact_dir=exact_dir)
        for p in spec.points()
    ]


def _engine_task(
    spec: MapSpec,
    point: MapPoint,
    engine: str,
    exact: Mapping[str, Any],
    display_dir: str | None,
    exact_dir: str | None = None,
) -> MapTask:
    carried = tuple((c, exact[c]) for c in EXACT_CARRIED if c in exact)
    return MapTask(
        f"{point.name}-{engine}",
        point,
        engine,
        spec.timestep_of(engine),
        spec.profile,
        carried,
        display_dir,
        exact_dir,
    )


def _stored_exact(row: Mapping[str, Any]) -> dict[str, Any]:
    """A stored reference row's carried columns, NaN read back as None."""
    out: dict[str, Any] = {}
    for column in EXACT_CARRIED:
        value = row.get(column)
        out[column] = value if isinstance(value, str) else number_or_none(value)
    if out[Col.N_SLIPS] is not None:
        out[Col.N_SLIPS] = int(out[Col.N_SLIPS])
    return out


# --------------------------------------------------------------------------- rows
MAP_COLUMNS = (
    Col.RUN_ID,
    Col.IX,
    Col.IY,
    Col.X_AXIS,
    Col.Y_AXIS,
    Col.X,
    Col.Y,
    Col.LAM,
    Col.CHI,
    Col.MU,
    Col.EPS,
    Col.THETA0_DEG,
    Col.T_END,
    Col.ENGINE,
    Col.PROFILE,
    Col.TIMESTEP,
    Col.STATUS,
    Col.MESSAGE,
    Col.ENGINE_VERSION,
    Col.WALL_TIME_S,
    Col.N_STEPS,
    Col.SIM_TIME_S,
    Col.STOP_REASON,
    *BATCH_COLUMNS,
    *CPU_COLUMNS,
    *EXACT_CARRIED,
    *EVENT_COLUMNS,
    Col.MAX_CLEARANCE,
    Col.VERDICT,
    Col.OUTCOME_AGREES,
    Col.VERDICT_FLAGS,
    Col.VERDICT_REASON,
    *TRANSITION_COLUMNS,
    Col.HOP_HEIGHT_ERROR,
    Col.ENERGY_RISE_BEFORE_SLIP,
    Col.ENERGY_CHANGE_END,
    Col.MAX_PENETRATION_M,
    Col.T_FINAL,
    *FLOOR_COLUMNS,
    *KIN_COLUMNS,
    Col.RMS_POSITION_M,
    *FORCE_COLUMNS,
)
"""Every column of a map row, in order. Reference rows leave the engine's columns empty;
wall_time_s is the classification's time there. sim_time_s: simulated time, s (the run may
stop early: stop_reason). hop_height_error: engine minus exact hop height, m, only where both
hop. Times s, lengths m, angles deg."""

_HOPS = (str(Outcome.HOPS), str(Outcome.LIFTS_AT_START))


def _task_columns(task: MapTask) -> dict[str, Any]:
    """The descriptive columns of a task's row (also those of a timeout or crash row)."""
    return {
        Col.RUN_ID: task.run_id,
        **task.point.columns(),
        Col.ENGINE: task.engine,
        Col.PROFILE: None if task.profile is None else str(task.profile),
        Col.TIMESTEP: task.timestep,
    }


def _ordered(row: Mapping[str, Any]) -> dict[str, Any]:
    return {column: row.get(column) for column in MAP_COLUMNS}


def _reference_row(task: MapTask) -> dict[str, Any]:
    scene = task.point.scene()
    if task.exact_dir is not None:
        point, solution, whole = classify_whole(scene)
        _store_solution(task, _judging_solution(scene, whole))
    else:
        point, solution = classify_solved(scene)
    if task.display_dir is not None:
        write_exact_display(solution, task.display_dir, task.run_id)
    return _ordered(
        {
            **_task_columns(task),
            Col.STATUS: str(RunStatus.OK),
            Col.MESSAGE: point.events.message,
            Col.WALL_TIME_S: point.solve_time_s,
            Col.REGIME: str(point.regime),
            Col.N_SLIPS: point.n_slips,
            **exact_columns(point.events, point.max_slip_speed),
            Col.EXACT_T_SETTLED: point.t_settled,
        }
    )


EXACT_SUFFIX = ".exact.pickle"
"""A stored exact solution's file in a task's exact_dir: the point's name, then this."""


def _judging_solution(scene: Scene, whole: ExactSolution) -> ExactSolution:
    """The solution an engine run at ``scene`` is judged against, ``exact_solution(scene,
    scene.mus)`` (kept in this worker from now on), given ``solve_exact(scene)``, the whole
    window the classification solved on its way (``classify_whole``: a settled point's is
    not solved a second time). That one is it where mus = muk; otherwise it is solved here."""
    mu = scene.mus
    if whole.t_settled is None and whole.scene == scene.with_(mus=mu, muk=mu):
        exact_solution.keep(scene, mu, whole)
        return whole
    return exact_solution(scene, mu)


def _solution_path(task: MapTask) -> Path | None:
    if task.exact_dir is None:
        return None
    return Path(task.exact_dir) / f"{task.point.name}{EXACT_SUFFIX}"


def _store_solution(task: MapTask, solution: ExactSolution) -> None:
    """Store the point's judging solution for its engine tasks; a worker that cannot write
    it (no such folder on its machine) leaves it to them."""
    path = _solution_path(task)
    if path is None:
        return
    part = path.with_name(path.name + ".part")
    try:
        part.write_bytes(pickle.dumps(solution, protocol=pickle.HIGHEST_PROTOCOL))
        os.replace(part, path)  # a reader sees the whole file or none
    except OSError:
        part.unlink(missing_ok=True)


def _point_solution(task: MapTask, scene: Scene) -> ExactSolution:
    """``exact_solution(scene, scene.mus)``: kept by this worker, else read from what the
    point's reference task stored (this session's own private folder, written by this
    hoopbench: nothing else is unpickled), else solved."""
    mu = scene.mus
    path = _solution_path(task)
    if path is not None and not exact_solution.holds(scene, mu):
        try:
            stored = pickle.loads(path.read_bytes())
        except (OSError, EOFError, pickle.UnpicklingError):
            stored = None
        if isinstance(stored, ExactSolution) and stored.scene == scene.with_(mus=mu, muk=mu):
            exact_solution.keep(scene, mu, stored)
    return exact_solution(scene, mu)


def _task_stop(task: MapTask) -> StopRule:
    """An engine run's stop rule (its settings'): it ends shortly after its first impact,
    where the exact window ends too, or once it has rolled a full turn after the
    reference's last event (the t_settled it carries), when nothing new can happen."""
    return StopRule(at_first_impact=True, settle_after=dict(task.exact).get(Col.EXACT_T_SETTLED))


def _engine_row(task: MapTask) -> dict[str, Any]:
    not_run = _not_run_row(task)
    if not_run is not None:
        return not_run
    scene, settings = task.point.scene(), _task_settings(task)
    return _judged_row(task, get_engine(task.engine).run(scene, settings), settings)


def _task_settings(task: MapTask) -> RunSettings:
    """An engine run's settings: its timestep and profile, and :func:`_task_stop`; mu is the
    scene's (mus = muk)."""
    if task.timestep is None or task.profile is None:  # a reference task's: not an engine's
        raise ValueError(f"{task.run_id}: an engine run needs a timestep and a profile")
    return RunSettings(timestep=task.timestep, profile=task.profile, stop=_task_stop(task))


def _not_run_row(task: MapTask) -> dict[str, Any] | None:
    """The row of a point no engine can run (a degenerate scene), or None."""
    scene = task.point.scene()
    if not scene.is_degenerate:
        return None
    # No engine builds a body without inertia (each would fail the same way), and no
    # engine answer means nothing to judge: a row saying so, with no verdict.
    message = "not run: degenerate scene"
    try:
        scene.require_inertia("an engine's rigid body")
    except DegenerateSceneError as exc:
        message = f"not run: {exc}"
    row = {**_carried(task), Col.STATUS: str(RunStatus.ERROR), Col.MESSAGE: message}
    return _ordered(row)


def _carried(task: MapTask) -> dict[str, Any]:
    """The task's columns and the exact ones its reference row gave."""
    exact = {column: None for column in EXACT_CARRIED} | dict(task.exact)
    return {**_task_columns(task), **exact}


def _judged_row(task: MapTask, result: RunResult, settings: RunSettings) -> dict[str, Any]:
    """The row of an engine run: its status and cost, its events judged against the exact
    ones, and its display file written."""
    scene, info = task.point.scene(), result.info
    row = _carried(task)
    row.update(
        status=str(info.status),
        message=info.message,
        engine_version=info.engine_version,
        wall_time_s=info.wall_time_s,
        n_steps=info.n_steps,
        sim_time_s=None if info.n_steps is None else info.n_steps * settings.timestep,
        stop_reason=info.stop_reason,
    )
    row.update(cost_columns(info))
    # The exact solution over the whole window: the floor, RMS and force columns sample it.
    solution = _point_solution(task, scene) if result.trajectory is not None else None
    row.update(judged_columns(row, result, scene, solution))
    row[Col.HOP_HEIGHT_ERROR] = _hop_height_error(row)
    if task.display_dir is not None and result.trajectory is not None:
        write_display(result.trajectory, task.display_dir, task.run_id)
    return _ordered(row)


def map_batch_key(task: MapTask) -> Hashable | None:
    """Engine runs of one engine that steps many worlds at once, one profile and one
    timestep share batches (each point keeps its own stop rule); others go alone (None)."""
    if task.engine == REFERENCE or not engine_class(task.engine).batches:
        return None
    return (task.engine, str(task.profile), task.timestep)


def run_map_batch(tasks: list[MapTask]) -> list[dict[str, Any]]:
    """The batch worker: the tasks' points in one engine call (``Engine.run_batch``), each
    with its own stop rule; their rows in order, as :func:`run_map_task` gives them. If the
    engine refuses the batch (a bad scene raises before anything steps), each task runs
    alone for its own row."""
    rows = [_not_run_row(task) for task in tasks]
    todo = [task for task, row in zip(tasks, rows, strict=True) if row is None]
    settings = [_task_settings(task) for task in todo]
    try:
        judged = get_engine(tasks[0].engine).run_batch(
            [task.point.scene() for task in todo] if todo else [],
            settings[0] if settings else None,
            stops=[s.stop for s in settings],
        )
    except Exception:
        return [run_map_task(task) for task in tasks]
    found = iter(zip(todo, judged, settings, strict=True))
    out = []
    for row in rows:
        if row is None:
            task, result, each = next(found)
            judged_row = partial(_judged_row, result=result, settings=each)
            row = row_or_failure(judged_row, task, map_failure_row)
        out.append(row)
    return out


def _hop_height_error(row: Mapping[str, Any]) -> float | None:
    """Engine minus exact hop height, m, where both hop (the canonical reading's hop is above
    the hop threshold) and the run is judged (an exact hop below the threshold is not:
    engines/judging/verdict.py)."""
    height, exact = (
        number_or_none(row.get(Col.HOP_HEIGHT)),
        number_or_none(row[Col.EXACT_HOP_HEIGHT]),
    )
    if height is None or exact is None or row[Col.EXACT_OUTCOME] not in _HOPS:
        return None
    if row.get(Col.VERDICT) is None:
        return None
    return height - exact


def run_map_task(task: MapTask) -> dict[str, Any]:
    """The worker: one map row; an exception anywhere becomes a row with status error."""
    return row_or_failure(_map_row, task, map_failure_row)


def _map_row(task: MapTask) -> dict[str, Any]:
    return _reference_row(task) if task.engine == REFERENCE else _engine_row(task)


def map_failure_row(task: MapTask, status: RunStatus, message: str) -> dict[str, Any]:
    """The row of a run that produced nothing (timeout, crash, an exception): an engine's is
    ``failed``, but for a timeout, which has no verdict (as in a suite, ``failure_row``): the
    sweep's time limit is the machine's failure, not the engine's, and the map's agreement
    counts only judged points."""
    row = {**_task_columns(task), **dict(task.exact), Col.STATUS: str(status), Col.MESSAGE: message}
    if task.engine != REFERENCE:
        if status is RunStatus.TIMEOUT:
            row[Col.VERDICT_REASON] = TIMEOUT_NOTE
        else:
            row.update(verdict_columns(row))
    return _ordered(row)


def _timeout(task: MapTask) -> float:
    # An engine run gets compare's limit for its whole window: stopping early only shortens it.
    return REFERENCE_TIMEOUT if task.engine == REFERENCE else run_timeout(task)


# --------------------------------------------------------------------------- running
MAP_IDENTITY = {"kind": "map"}
"""A map folder's sweep.json (runner.IDENTITY_NAME); which map it is, map.toml says."""


def _prepare(out: Path, spec: MapSpec, resume: bool) -> None:
    """Check the folder (and a stored spec on resume); write map.toml if it is not there."""
    path = out / MAP_FILE
    if resume and (path.exists() or path.is_symlink()):
        stored = load_spec(out)
        if stored != spec:
            differ = "; ".join(spec.differences(stored))
            raise MapSpecMismatchError(
                f"{path} holds another map ({differ}): resume it with its own settings, "
                "or choose a new folder"
            )
        if (out / results.RUNS_NAME).is_dir():  # rows of another grid would be skipped as done
            rows = results.read_runs(out, columns=["ix", "iy", "x", "y"])
            try:
                check_stored_points(spec, rows, str(out / results.RUNS_NAME))
            except ValueError as exc:
                raise MapSpecMismatchError(f"{exc}: not resumed") from None
        return
    prepare_dir(out, resume=False)  # the runner's checks: not a file, empty
    results.atomic_write(path, lambda tmp: tmp.write_text(spec.to_toml(), encoding="utf-8"))


def planned_tasks(spec: MapSpec) -> tuple[list[MapTask], list[MapTask]]:
    """The map's tasks as planned before it starts, for their costs: stage 1's, and stage
    2's as if every point's reference were final (stage 2 leaves out those that are not)."""
    refs = reference_tasks(spec)
    engine_tasks = [
        _engine_task(spec, ref.point, engine, {}, None) for ref in refs for engine in spec.engines
    ]
    return refs, engine_tasks


def classified_tasks(spec: MapSpec) -> list[MapTask]:
    """Stage 2's engine tasks, each with the exact columns its point's classification gives
    (as stage 2 reads them from the stored reference rows), the points classified here one
    after another: the calls the runner costs stage 2 by, for a replay of its ETA
    (reports/bench/eta_replay.py), which :func:`planned_tasks` can only cost by window."""
    tasks: list[MapTask] = []
    for ref in reference_tasks(spec):
        row = run_map_task(ref)
        exact = _stored_exact(row) if row[Col.STATUS] == RunStatus.OK else {}
        tasks += [_engine_task(spec, ref.point, engine, exact, None) for engine in spec.engines]
    return tasks


def _stage_two_tasks(spec: MapSpec, out: Path, exact_dir: str) -> tuple[list[MapTask], int]:
    """Engine tasks of the points whose reference row is final, each point's reference task
    before them (stored: skipped, but it puts runs.csv in map order); and how many of those
    reference tasks there are."""
    stored = results.read_runs(out)
    refs = {
        row[Col.RUN_ID]: row for row in stored.to_dict("records") if row[Col.ENGINE] == REFERENCE
    }
    tasks: list[MapTask] = []
    n_refs = 0
    for ref in reference_tasks(spec, str(out), exact_dir):
        row = refs.get(ref.run_id)
        if row is None or not is_final_status(row[Col.STATUS]):
            continue  # timed out or crashed: a resumed map tries it again, then its engines
        tasks.append(ref)
        n_refs += 1
        exact = _stored_exact(row) if row[Col.STATUS] == RunStatus.OK else {}
        tasks += [
            _engine_task(spec, ref.point, engine, exact, str(out), exact_dir)
            for engine in spec.engines
        ]
    return tasks, n_refs


def _say(text: str, quiet: bool, stream: TextIO | None) -> None:
    if not quiet:
        print(terminal_text(text), file=stream or sys.stderr, flush=True)


def run_map(
    spec: MapSpec,
    out: str | Path,
    *,
    jobs: int = 2,
    executor: Executor | None = None,
    resume: bool = False,
    quiet: bool = False,
    stream: TextIO | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
) -> RunSummary:
    """Run the map into ``out`` (two stages, one runs dataset; see the module docstring).
    The runs of an engine that steps many worlds at once go in batches of ``batch_size``
    (1: every run alone).

    ``executor``: any ``concurrent.futures.Executor`` (e.g. Dask's ``Client.get_executor()``);
    None: the runner's local pool of ``jobs`` processes. Raises OutputDirNotEmptyError for a
    folder that holds files when ``resume`` is false, MapSpecMismatchError when it holds
    another map; both before anything runs. The summary covers both stages.
    """
    refuse_in_a_starting_worker()
    out = Path(out)
    if resume and out.is_dir():  # before the lock file is made
        check_identity(out, MAP_IDENTITY)
    spec_file = out / MAP_FILE
    if resume and holds_files(out) and not (spec_file.exists() or spec_file.is_symlink()):
        raise RunnerError(f"{out} holds no {MAP_FILE}: it is not a hop map folder to resume")
    stored = results.recorded_format_version(out) if resume and out.is_dir() else None
    if isinstance(stored, int) and stored < ONE_READING_MAP_VERSION:
        raise RunnerError(
            f"{out} holds map table format {stored}, from before one reading (format "
            f"{ONE_READING_MAP_VERSION}): its rows and this hoopbench's cannot share a table; "
            "run the map into a new folder (the old one reads as before)"
        )
    say = None if quiet else (lambda text: _say(text, quiet, stream))
    with (
        claim_folder(out, resume, MAP_IDENTITY, say),
        tempfile.TemporaryDirectory(prefix="hoopbench-map-exact-") as exact_dir,
    ):
        return _run_map(
            spec,
            out,
            exact_dir,
            jobs=jobs,
            executor=executor,
            resume=resume,
            quiet=quiet,
            stream=stream,
            batch_size=batch_size,
        )


def _run_map(
    spec: MapSpec,
    out: Path,
    exact_dir: str,
    *,
    jobs: int,
    executor: Executor | None,
    resume: bool,
    quiet: bool,
    stream: TextIO | None,
    batch_size: int,
) -> RunSummary:
    version = _recorded_version(out, resume)
    _prepare(out, spec, resume)
    started_at = datetime.now(UTC)
    load_start = results.load_average()
    meta = {"map": spec.to_dict(), results.FORMAT_KEY: version}
    common: dict[str, Any] = dict(  # run_tasks' keywords, the same for both stages
        failure_row=map_failure_row,
        timeout=_timeout,
        jobs=jobs,
        executor=executor,
        resume=True,  # the folder holds map.toml; resume=False would refuse it
        meta=meta,
        quiet=quiet,
        stream=stream,
        costing=MAP_COSTING,
    )
    # Stage 1 stores each point's exact solution in exact_dir for stage 2 (its engines'
    # judging), which would otherwise solve it again in every worker that runs the point.
    refs = reference_tasks(spec, str(out), exact_dir)
    first = _stage_one(refs, out, common, quiet, stream)
    if first.interrupted is not None:
        return _summary(spec, out, [first], 0)
    tasks, n_refs = _stage_two_tasks(spec, out, exact_dir)
    engines = ", ".join(spec.engines) or "none"
    _say(f"hop map, stage 2 of 2: {len(tasks) - n_refs} engine runs ({engines})", quiet, stream)
    finished = _is_finished(spec, out, tasks)
    if not finished:
        # Stage 1's runs.csv and meta.json (or a stale pair) go: they are written again at the
        # end of stage 2 with every row, as a map's must be, and never stand for it meanwhile.
        for name in (results.CSV_NAME, results.META_NAME):
            (out / name).unlink(missing_ok=True)
    batching = (
        Batching(run_map_batch, map_batch_key, batch_size, batch_least, batch_affinity)
        if batch_size > 1
        else None
    )
    second = run_tasks(tasks, run_map_task, out, batching=batching, **common)
    summary = _summary(spec, out, [first, second], n_refs)
    if second.interrupted is None and not finished:
        _complete_meta(out, started_at, resume, summary, load_start)
    return summary


def _recorded_version(out: Path, resume: bool) -> int:
    """The map table version meta.json records: a resumed folder keeps an older one (its old
    rows are still there; the migrations bring them up and leave the new rows alone), as a
    resumed suite's does (results.resumed_format_version)."""
    stored = results.recorded_format_version(out) if resume else None
    if isinstance(stored, int) and not isinstance(stored, bool) and stored < ROWS_FORMAT_VERSION:
        return stored
    return ROWS_FORMAT_VERSION


def _is_finished(spec: MapSpec, out: Path, tasks: Sequence[MapTask]) -> bool:
    """Every run of the map stored with a final status, and its runs.csv and meta.json
    there: a resume has nothing to run, and those files (of the run that finished the map,
    with its wall time) stay as they are."""
    if not all((out / name).is_file() for name in (results.CSV_NAME, results.META_NAME)):
        return False
    stored = results.stored_statuses(out)
    return len(tasks) == spec.run_count and all(
        is_final_status(stored.get(t.run_id)) for t in tasks
    )


def _stage_one(
    refs: list[MapTask],
    out: Path,
    common: Mapping[str, Any],
    quiet: bool,
    stream: TextIO | None,
) -> RunSummary:
    """Stage 1, or nothing when every classification is stored (a resume in stage 2)."""
    stored = results.stored_statuses(out)
    if refs and all(is_final_status(stored.get(t.run_id)) for t in refs):
        return RunSummary(out, {}, 0.0, None, len(refs), 0)
    _say(f"hop map, stage 1 of 2: the exact reference at {len(refs)} points", quiet, stream)
    return run_tasks(refs, run_map_task, out, **common)


def _summary(spec: MapSpec, out: Path, stages: Sequence[RunSummary], n_refs: int) -> RunSummary:
    counts: Counter[RunStatus] = Counter()
    for stage in stages:
        counts.update(stage.counts)
    stored = results.stored_statuses(out) if (out / results.RUNS_NAME).is_dir() else {}
    return RunSummary(
        out_dir=out,
        counts=dict(counts),
        wall_time_s=sum(s.wall_time_s for s in stages),
        interrupted=next((s.interrupted for s in stages if s.interrupted is not None), None),
        # stage 2 lists the stored reference tasks only to order runs.csv
        skipped=sum(s.skipped for s in stages) - n_refs,
        unfinished=spec.run_count - len(stored),
        notes=tuple(note for s in stages for note in s.notes),
    )


def _complete_meta(
    out: Path,
    started_at: datetime,
    resume: bool,
    summary: RunSummary,
    load_start: list[float] | None,
) -> None:
    """meta.json of both stages (the runner wrote stage 2's, and always resumes here), with
    the load average at the map's start (``load_start``) and end."""
    path = out / results.META_NAME
    meta = json.loads(read_folder_text(out, results.META_NAME) or "{}")
    meta.update(
        started_at=started_at.isoformat(),
        wall_time_s=round(summary.wall_time_s, 3),
        resumed=resume,
        session={
            "ran": summary.total,
            "skipped": summary.skipped,
            "load_average_start": load_start,
            "load_average_end": results.load_average(),
        },
    )
    results.write_meta(meta, path)
