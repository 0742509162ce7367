"""hoopbench as a Python library: scenes, exact solutions, engine runs, suites, maps, reports.

``import hoopbench as hb`` gives these functions as ``hb.scene``, ``hb.exact``, ``hb.run``,
``hb.compare``, ``hb.hop_map`` (also ``hb.map``) and ``hb.report``, loaded on first use. The
``hoopbench`` command is a thin layer over this module: the same checks, the same messages,
with the option names spelled as the command spells them (:class:`OptionError`).

Every option is keyword-only. A bad value raises ValueError with one line naming it, before
anything runs; a sweep's folder that cannot be used raises RunnerError (a RuntimeError).

>>> import hoopbench as hb
>>> hb.scene("hop-top").lam
0.95
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any, TypeVar

import pandas as pd

from hoopbench.engines.options import Profile, check_profile
from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.engines.run import RunResult, RunStatus
from hoopbench.engines.settings import DEFAULT_BATCH_SIZE, DEFAULT_TIMESTEP, RunSettings
from hoopbench.models.catalogue import get_scene, scene_names
from hoopbench.models.checks import check_real
from hoopbench.models.events import Events
from hoopbench.models.scene import THETA0_LIMIT_DEG, Scene
from hoopbench.reference.exact import DEFAULT_ATOL, DEFAULT_RTOL, ExactSolution, solve_exact
from hoopbench.reports.compare import suite as suite_runs
from hoopbench.reports.compare.suite_file import (
    DEFAULT_VARIANT,
    Announce,
    RunTask,
    Suite,
    TrajectoryChoice,
    VariantSpec,
    load_suite,
    suite_path,
)
from hoopbench.reports.hop_map.spec import MAP_FILE, Axis, MapSpec, check_grid, load_spec
from hoopbench.reports.hop_map.stages import run_map
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.report.build import build_report
from hoopbench.reports.sweep.runner import RunSummary

__all__ = [
    "EngineRun",
    "OptionError",
    "SuiteJob",
    "check_batch_size",
    "check_grid",
    "check_positive_int",
    "check_positive_seconds",
    "check_workers",
    "compare",
    "default_jobs",
    "engine_names",
    "exact",
    "hop_map",
    "map_spec",
    "report",
    "run",
    "run_hop_map",
    "run_suite",
    "scene",
    "scene_names",
    "suite_job",
]

REPORT_FILE = "report.md"
"""What :func:`report` writes into its folder (beside its figures)."""


# --------------------------------------------------------------------------- checks
class OptionError(ValueError):
    """A bad option: the message names it as Python does (``run_timeout must be > 0 s``);
    :meth:`spelled` names it as the caller shows it (the CLI: ``--run-timeout``)."""

    def __init__(self, option: str, template: str, *, shown: str | None = None) -> None:
        self.option = option
        """The keyword's name."""
        self.template = template
        """The message, with ``{option}`` where the option's name goes."""
        super().__init__(self.spelled(shown or option))

    def spelled(self, name: str) -> str:
        """The message with the option called ``name``."""
        return self.template.replace("{option}", name)


def _checked(option: str, check: Any, value: Any) -> Any:
    """``check(value)``, its name-free message (shared with argparse) named after ``option``."""
    try:
        return check(value)
    except ValueError as exc:
        raise OptionError(option, f"{{option}} {exc}") from None


def check_positive_int(value: int | str) -> int:
    """A whole number >= 1 (text from the command line, or an int); the ValueError's message
    leaves the name out, for the caller (or argparse) to put in front."""
    if isinstance(value, str):
        try:
            value = int(value)
        except ValueError:
            raise ValueError(f"must be a whole number, got {value!r}") from None
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"must be a whole number, got {value!r}")
    if value < 1:
        raise ValueError(f"must be >= 1, got {value}")
    return value


def check_positive_seconds(value: float | str) -> float:
    """A finite time step or duration > 0, s (text from the command line, or a number); the
    message leaves the name out, as check_positive_int's does."""
    try:
        seconds = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"must be a number of seconds > 0, got {value!r}") from None
    if isinstance(value, bool) or not math.isfinite(seconds) or seconds <= 0:
        raise ValueError(f"must be a number of seconds > 0, got {value!r}")
    return seconds


def check_workers(value: int | str) -> int:
    """Worker processes: 1 up to the machine's cores (more only slow a sweep down)."""
    value = check_positive_int(value)
    cores = os.cpu_count() or 1
    if value > cores:
        raise ValueError(f"must be at most {cores} (this machine's cores), got {value}")
    return value


def check_batch_size(value: int | str) -> int:
    """Runs per batch for an engine that steps many worlds at once: a whole number >= 1
    (1: every run alone)."""
    return check_positive_int(value)


def default_jobs() -> int:
    """Worker processes when none are asked for: two, or one on a one-core machine."""
    return min(2, os.cpu_count() or 1)


_E = TypeVar("_E", bound=Enum)


def _choice(option: str, enum: type[_E], value: Any) -> _E:
    try:
        return enum(value)
    except ValueError:
        allowed = ", ".join(str(member) for member in enum)
        raise OptionError(option, f"{{option}} must be one of {allowed}, got {value!r}") from None


# --------------------------------------------------------------------------- scenes
def scene(
    name: str | None = None,
    /,
    *,
    lam: float | None = None,
    eps: float | None = None,
    chi: float | None = None,
    thetadot0: float | None = None,
    theta0_deg: float | None = None,
    mus: float | None = None,
    muk: float | None = None,
    g: float | None = None,
    a: float | None = None,
    M: float | None = None,
    t_end: float | None = None,
    xdot0: float | None = None,
) -> Scene:
    """A scene: a catalogue scene (``scene("hop-top")``) with parameters over it, or
    parameters alone (``scene(lam=0.9, chi=1.2, mus=0.5)``: lam, mus and chi or thetadot0
    needed; muk defaults to mus).

    The spin is set last, from the final a and g: ``chi`` goes through Scene.from_chi, and a
    catalogue scene whose a or g is changed keeps its chi (a dimensionless scene), unless
    ``thetadot0`` gives the spin in rad/s. ``theta0_deg`` is in degrees, the rest in SI
    units (models/scene.py). ValueError names a bad or missing parameter.
    """
    if chi is not None and thetadot0 is not None:
        raise OptionError("chi", "give {option} or thetadot0, not both")
    given = dict(lam=lam, eps=eps, mus=mus, muk=muk, g=g, a=a, M=M, t_end=t_end, xdot0=xdot0)
    changes: dict[str, Any] = {key: value for key, value in given.items() if value is not None}
    if theta0_deg is not None:
        # checked in degrees, as given, by the bound the Scene and the map use
        limit = THETA0_LIMIT_DEG
        checked = check_real("theta0_deg", theta0_deg, low=-limit, high=limit, unit="deg")
        changes["theta0"] = math.radians(checked)
    if name is not None:
        return _catalogue_scene(get_scene(name), changes, chi, thetadot0)
    missing = [key for key in ("lam", "mus") if key not in changes]
    if chi is None and thetadot0 is None:
        missing.append("chi or thetadot0")
    if missing:
        raise OptionError(
            "name",
            f"give {{option}} or the scene parameters; missing: {', '.join(missing)}",
            shown="a catalogue scene name",
        )
    changes.setdefault("muk", changes["mus"])
    if chi is not None:
        return Scene.from_chi(chi, **changes)
    assert thetadot0 is not None  # else missing names "chi or thetadot0" above
    return Scene(thetadot0=thetadot0, **changes)


def _catalogue_scene(
    base: Scene, changes: dict[str, Any], chi: float | None, thetadot0: float | None
) -> Scene:
    fields = {**base.to_dict(), "why": base.why, **changes}
    fields.pop("chi")
    stored_spin = fields.pop("thetadot0")
    if thetadot0 is not None:
        return Scene(thetadot0=thetadot0, **fields)
    if chi is None and not {"a", "g"} & set(changes):
        return Scene(thetadot0=stored_spin, **fields)  # the catalogue's spin, unrounded
    return Scene.from_chi(base.chi if chi is None else chi, **fields)


def _as_scene(value: Scene | str) -> Scene:
    """A Scene, or a catalogue name for one."""
    return value if isinstance(value, Scene) else get_scene(value)


def exact(
    scene: Scene | str, *, rtol: float = DEFAULT_RTOL, atol: float = DEFAULT_ATOL
) -> ExactSolution:
    """The exact solution of a scene (or a catalogue scene by name): its ``events`` and a
    dense trajectory (``sample(t)``, ``sample_uniform(dt)``; ``.to_frame()`` on either gives
    a DataFrame). Tolerances as reference/exact.py ``solve_exact``."""
    return solve_exact(_as_scene(scene), rtol=rtol, atol=atol)


# --------------------------------------------------------------------------- one run
@dataclass(frozen=True, repr=False, eq=False)  # eq: a DataFrame has no truth value
class EngineRun:
    """One engine run judged against the exact solution: what a suite stores, and more.

    ``row`` is the row a suite stores for the same run (``hb.compare``'s table has one per
    run); ``trajectory`` the run's samples as a DataFrame (None when the run failed first).
    """

    task: RunTask
    """The run as a suite task: its run_id, scene, engine, variant, options and timestep."""
    result: RunResult = field(repr=False)
    """The judged run: trajectory, detected events, run info."""
    row: dict[str, Any] = field(repr=False)
    """Its row: settings, status, cost, detected and exact events, errors, verdict."""
    trajectory: pd.DataFrame | None = field(repr=False)
    """t, X, Y, theta, their rates, clearance, slip velocity, forces, contact, energy."""

    def __repr__(self) -> str:
        task = self.task
        return (
            f"EngineRun({task.engine} on {task.scene.name or 'a scene'}, "
            f"dt={task.timestep:g} s, {task.profile}, {task.variant}: {self.status}, "
            f"verdict {self.verdict})"
        )

    @property
    def status(self) -> RunStatus:
        return self.result.info.status

    @property
    def events(self) -> Events | None:
        """The events the shared detectors found (None when the run failed first)."""
        return self.result.events

    @property
    def verdict(self) -> str:
        """agrees, early-slip, ... or failed (engines/judging/verdict.py)."""
        return str(self.row["verdict"])


def run(
    engine: str,
    scene: Scene | str,
    *,
    timestep: float = DEFAULT_TIMESTEP,
    profile: Profile | str = Profile.TUNED,
    geometry: str = "sphere",
    options: Mapping[str, Any] | None = None,
    variant: str | None = None,
) -> EngineRun:
    """Run a scene (or a catalogue scene by name) in an engine and judge it against the exact
    solution, as a suite run is judged: ``row`` is exactly what ``hb.compare`` stores.

    ``options`` are the engine's own settings (``hoopbench settings`` lists them) over the
    ``profile``'s values; ``variant`` names the row's variant (default: ``default`` without
    options or another geometry, ``custom`` with them; a suite's variant name gives that
    suite run's run_id). The engine's failures are statuses in the result; bad settings
    raise ValueError before the run.
    """
    task = _run_task(engine, _as_scene(scene), timestep, profile, geometry, options, variant)
    result, row = suite_runs.run_and_row(task)
    frame = None if result.trajectory is None else result.trajectory.to_frame()
    return EngineRun(task=task, result=result, row=row, trajectory=frame)


def _run_task(
    engine: str,
    scene: Scene,
    timestep: float,
    profile: Profile | str,
    geometry: str,
    options: Mapping[str, Any] | None,
    variant: str | None,
) -> RunTask:
    """The run as a one-task suite builds it, so that its run_id and row are a suite's."""
    settings = RunSettings(
        timestep=timestep,
        geometry=geometry,
        options=options or {},
        profile=check_profile("profile", profile),
    )
    engine_class(engine)().check(scene, settings)  # what a suite file is checked for
    plain = not settings.options and settings.geometry == "sphere"
    name = variant if variant is not None else (DEFAULT_VARIANT if plain else "custom")
    if not isinstance(name, str) or not name.strip():
        raise OptionError("variant", f"{{option}} must be a non-empty string, got {name!r}")
    if name == DEFAULT_VARIANT and not plain:
        raise OptionError(
            "variant", "{option} 'default' is the engine's default settings: name another"
        )
    spec = VariantSpec(
        engine, name, settings.geometry, settings.options, (settings.timestep,), settings.profile
    )
    suite = Suite("api", (engine,), (settings.timestep,), (scene,), (spec,), (settings.profile,))
    return suite.tasks()[-1]  # the variant's task comes last


# --------------------------------------------------------------------------- suites
@dataclass(frozen=True)
class SuiteJob:
    """A suite with its options, every one checked: nothing runs before this exists."""

    path: Path
    """The suite file (a shipped one, or the caller's)."""
    suite: Suite
    """The validated suite, restricted to the chosen engines."""
    run_timeout: float | None
    """s per run; None: the suite's own limit per run (60 s + 0.5 ms per step)."""
    trajectories: TrajectoryChoice


def suite_job(
    suite: str | Path,
    *,
    run_timeout: float | None = None,
    engines: Sequence[str] | None = None,
    trajectories: TrajectoryChoice | str = TrajectoryChoice.NONE,
    announce: Announce | None = None,
) -> SuiteJob:
    """Check a suite and its options. ``suite``: a suite file (.toml) or the name of a
    shipped one (quick, default, ...). SuiteError (a ValueError) names a bad file's key.
    ``announce(name, runs)`` is told the run count before the runs are checked."""
    # a Path is a file; text follows the command line's rule (suite_file.suite_path)
    path = suite if isinstance(suite, Path) else suite_path(str(suite))
    loaded = load_suite(path, announce)  # the whole file is checked before anything runs
    if engines:
        loaded = loaded.with_engines(list(engines))
    if run_timeout is not None and not (run_timeout > 0):
        raise OptionError("run_timeout", f"{{option}} must be > 0 s, got {run_timeout}")
    choice = _choice("trajectories", TrajectoryChoice, trajectories)
    return SuiteJob(path, loaded, run_timeout, choice)


def run_suite(
    job: SuiteJob,
    out: str | Path,
    *,
    jobs: int | None = None,
    resume: bool = False,
    quiet: bool = False,
    executor: Executor | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
) -> RunSummary:
    """Run a checked suite into ``out`` and return how the sweep ended (the command line
    reports it); :func:`compare` is this with the runs table as its answer."""
    workers = default_jobs() if jobs is None else _checked("jobs", check_workers, jobs)
    batch_size = _checked("batch_size", check_batch_size, batch_size)
    return suite_runs.compare(
        job.path,
        out,
        jobs=workers,
        resume=resume,
        run_timeout_s=job.run_timeout,
        quiet=quiet,
        trajectories=job.trajectories,
        suite=job.suite,
        executor=executor,
        batch_size=batch_size,
    )


def compare(
    suite: str | Path,
    out: str | Path,
    *,
    jobs: int | None = None,
    resume: bool = False,
    run_timeout: float | None = None,
    engines: Sequence[str] | None = None,
    trajectories: TrajectoryChoice | str = TrajectoryChoice.NONE,
    quiet: bool = False,
    executor: Executor | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
) -> pd.DataFrame:
    """Run a suite (a .toml file or a shipped suite's name) into the folder ``out``, or
    finish it there (``resume=True``), and return its runs table: one row per run, in the
    suite's order.

    As ``hoopbench compare``: ``jobs`` worker processes (default 2), ``run_timeout`` s per
    run, only some ``engines`` of the suite, ``trajectories`` stored for none, the default
    runs or all; ``executor`` another backend (a Dask cluster's); ``batch_size`` runs per
    batch for an engine that steps many worlds at once. Raises RunnerError for a
    folder that holds files without ``resume``, KeyboardInterrupt if a signal stopped it.
    """
    job = suite_job(suite, run_timeout=run_timeout, engines=engines, trajectories=trajectories)
    summary = run_suite(
        job, out, jobs=jobs, resume=resume, quiet=quiet, executor=executor, batch_size=batch_size
    )
    _raise_if_interrupted(summary)
    return _in_suite_order(suite_runs.runs_frame(out), job.suite)


def _in_suite_order(frame: pd.DataFrame, suite: Suite) -> pd.DataFrame:
    """Rows are stored as runs finish; a table reads best in the suite's own order (rows of
    runs the suite no longer has, from an earlier session in the folder, last)."""
    rank = {task.run_id: k for k, task in enumerate(suite.tasks())}
    order = frame["run_id"].map(lambda run_id: rank.get(run_id, len(rank)))
    return frame.iloc[order.argsort(kind="stable")].reset_index(drop=True)


def _raise_if_interrupted(summary: RunSummary) -> None:
    """A sweep stopped by Ctrl-C (a notebook's interrupt) or SIGTERM: stop the caller too."""
    if summary.interrupted is not None:
        raise KeyboardInterrupt(
            f"interrupted by {summary.interrupted.name}: {summary.total} run(s) stored in "
            f"{summary.out_dir}, {summary.unfinished} left; resume=True finishes them"
        )


# --------------------------------------------------------------------------- hop map
def map_spec(
    out: str | Path,
    *,
    resume: bool = False,
    x: Axis | str | None = None,
    y: Axis | str | None = None,
    x_range: Sequence[float] | None = None,
    y_range: Sequence[float] | None = None,
    grid: str | Sequence[int] | None = None,
    fixed: Mapping[str, float] | None = None,
    t_end: float | None = None,
    engines: Sequence[str] | None = None,
    timestep: float | None = None,
    profile: Profile | str | None = None,
) -> MapSpec:
    """The map's spec from the options (None: the default). On ``resume``, options not given
    come from the map stored in ``out`` (the run refuses a spec that differs from it)."""
    given: dict[str, Any] = {
        key: value
        for key, value in (
            ("x", x),
            ("y", y),
            ("x_range", None if x_range is None else tuple(x_range)),
            ("y_range", None if y_range is None else tuple(y_range)),
            ("t_end", t_end),
            ("engines", None if engines is None or isinstance(engines, str) else tuple(engines)),
            ("timestep", timestep),
            ("profile", profile),
        )
        if value is not None
    }
    if isinstance(engines, str):
        given["engines"] = engines  # MapSpec names it: a list of names, not one string
    if grid is not None:
        given["nx"], given["ny"] = _checked("grid", check_grid, grid)
    fixed = dict(fixed or {})
    stored_file = Path(out) / MAP_FILE
    if not (resume and stored_file.is_file()):
        return MapSpec(**given, fixed=fixed)
    try:
        base = load_spec(out).to_dict()
    except ValueError as exc:
        raise OptionError("resume", f"{{option}}: {stored_file}: {exc}") from None
    return _resumed_spec(base, given, fixed)


def _resumed_spec(base: dict[str, Any], given: dict[str, Any], fixed: dict[str, Any]) -> MapSpec:
    """The stored spec with the given options over it: a new axis takes its own default
    range, and the stored fixed values of parameters that are now axes go."""
    base.pop("format_version")
    stored_fixed = base.pop("fixed")
    merged = {**base, **given}
    for axis, range_key in (("x", "x_range"), ("y", "y_range")):
        if merged[axis] != base[axis] and range_key not in given:
            merged[range_key] = None  # another parameter: its own default range
    axes = (merged["x"], merged["y"])
    old_fixed = {name: value for name, value in stored_fixed.items() if name not in axes}
    return MapSpec(**merged, fixed={**old_fixed, **fixed})


def run_hop_map(
    spec: MapSpec,
    out: str | Path,
    *,
    jobs: int | None = None,
    resume: bool = False,
    quiet: bool = False,
    executor: Executor | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
) -> RunSummary:
    """Run (or finish, ``resume``) a map into ``out`` and return how it ended (the command
    line reports it); :func:`hop_map` is this with the map's table as its answer."""
    workers = default_jobs() if jobs is None else _checked("jobs", check_workers, jobs)
    batch_size = _checked("batch_size", check_batch_size, batch_size)
    return run_map(
        spec,
        out,
        jobs=workers,
        executor=executor,
        resume=resume,
        quiet=quiet,
        batch_size=batch_size,
    )


def hop_map(
    out: str | Path,
    *,
    resume: bool = False,
    x: Axis | str | None = None,
    y: Axis | str | None = None,
    x_range: Sequence[float] | None = None,
    y_range: Sequence[float] | None = None,
    grid: str | Sequence[int] | None = None,
    fixed: Mapping[str, float] | None = None,
    t_end: float | None = None,
    engines: Sequence[str] | None = None,
    timestep: float | None = None,
    profile: Profile | str | None = None,
    jobs: int | None = None,
    quiet: bool = False,
    executor: Executor | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
) -> pd.DataFrame:
    """The hop map into the folder ``out``: the exact regime and every engine's verdict over
    a grid of scenes, as ``hoopbench map``; its table, one row per (point, engine).

    Axes ``x`` and ``y`` (lam, chi, mu, eps, theta0_deg; default lam and chi), their ranges,
    ``grid`` ((nx, ny) or ``"10x10"``), ``fixed`` values of the other parameters, the window
    ``t_end``, the ``engines`` (empty: the exact regimes alone), their ``timestep`` and
    ``profile``. ``resume=True`` finishes the map stored in ``out``, its options coming from
    its map.toml unless given. Raises RunnerError for a folder that cannot take the map,
    KeyboardInterrupt if a signal stopped it.
    """
    spec = map_spec(
        out,
        resume=resume,
        x=x,
        y=y,
        x_range=x_range,
        y_range=y_range,
        grid=grid,
        fixed=fixed,
        t_end=t_end,
        engines=engines,
        timestep=timestep,
        profile=profile,
    )
    summary = run_hop_map(
        spec, out, jobs=jobs, resume=resume, quiet=quiet, executor=executor, batch_size=batch_size
    )
    _raise_if_interrupted(summary)
    return map_frame(out)


# --------------------------------------------------------------------------- report
def report(
    results: str | Path | Sequence[str | Path],
    out: str | Path | None = None,
    *,
    force: bool = False,
) -> Path:
    """report.md and its figures from result folders (of ``compare`` or ``hop_map``; no
    simulation), into ``out`` (default: the first folder); the path of report.md.

    An existing report.md is replaced only with ``force=True``.
    """
    folders = [Path(results)] if isinstance(results, str | Path) else [Path(f) for f in results]
    if not folders:
        raise OptionError("results", "{option} must name at least one results folder")
    for folder in folders:
        if not (folder / "runs").is_dir():
            raise OptionError(
                "results",
                f"{{option}} {str(folder)!r} holds no results (no runs/ folder): "
                "run hoopbench compare first",
            )
    for k, folder in enumerate(folders):  # its runs would be counted twice
        same = [f for f in folders[:k] if f.resolve() == folder.resolve()]
        if same:
            raise OptionError("results", f"{{option}} names the folder {str(same[0])!r} twice")
    target = Path(out) if out is not None else folders[0]
    if target.exists() and not target.is_dir():
        raise OptionError("out", f"{{option}} {str(target)!r} is a file, not a folder")
    if (target / REPORT_FILE).exists() and not force:
        raise OptionError(
            "force",
            f"{str(target / REPORT_FILE)!r} exists; pass {{option}} to replace it",
            shown="force=True",
        )
    return build_report(folders, target)
