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
import numbers
import os
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pandas as pd

from hoopbench.engines.judging.columns import EXACT_COLUMNS, TRANSITION_COLUMNS, Col
from hoopbench.engines.judging.contact import canonical_events, read_run
from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import (
    Event,
    classify,
    event_tolerance,
    number_or_none,
)
from hoopbench.engines.options import Profile, check_profile
from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.engines.run import REFERENCE_ENGINE, RunResult, RunStatus
from hoopbench.engines.settings import DEFAULT_BATCH_SIZE, DEFAULT_TIMESTEP, RunSettings
from hoopbench.models.catalogue import check_scene_name, get_scene, scene_names
from hoopbench.models.checks import check_real
from hoopbench.models.events import Events, Outcome
from hoopbench.models.scene import THETA0_LIMIT_DEG, Scene
from hoopbench.reference.exact import DEFAULT_ATOL, DEFAULT_RTOL, ExactSolution, solve_exact
from hoopbench.reports.compare import suite as suite_runs
from hoopbench.reports.compare.releases import parse_release
from hoopbench.reports.compare.settings_file import (
    SettingsFile,
    load_choice,
    pick_setting,
    split_choice,
    with_settings,
)
from hoopbench.reports.compare.suite_file import (
    DEFAULT_VARIANT,
    Announce,
    RunTask,
    Suite,
    SuiteError,
    TrajectoryChoice,
    VariantSpec,
    check_catalogue_name,
    load_suite,
    suite_path,
)
from hoopbench.reports.hop_map.spec import (
    DEFAULT_ENGINES,
    MAP_FILE,
    Axis,
    MapSpec,
    check_grid,
    default_engine_timesteps,
    load_spec,
)
from hoopbench.reports.hop_map.stages import run_map
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.report.batch_cost import is_batch_cost_folder
from hoopbench.reports.report.best_settings import is_tune_folder
from hoopbench.reports.report.build import build_report, files_to_replace
from hoopbench.reports.sweep import control_chars
from hoopbench.reports.sweep.runner import RunSummary
from hoopbench.reports.tune.heldout import MAX_HELDOUT_NEIGHBOURS, MAX_HELDOUT_PER_REGIME, validate
from hoopbench.reports.tune.search import (
    DEFAULT_TRAINING_SCENES,
    Budget,
    Runner,
    SearchResult,
    TuneSpec,
    search,
)

__all__ = [
    "EngineRun",
    "OptionError",
    "SuiteJob",
    "check_batch_size",
    "check_count",
    "check_grid",
    "check_positive_int",
    "check_positive_seconds",
    "check_workers",
    "compare",
    "default_jobs",
    "engine_names",
    "exact",
    "export",
    "hop_map",
    "judgement",
    "map_spec",
    "report",
    "results_folders",
    "run",
    "run_hop_map",
    "run_settings",
    "run_suite",
    "run_tune",
    "scene",
    "scene_names",
    "setting_from_file",
    "suite_job",
    "tune",
    "tune_job",
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
        """The message with the option called ``name`` (the first ``{option}`` only: the
        templates name the option before the value, and a value may hold that text)."""
        return self.template.replace("{option}", name, 1)


def _checked(option: str, check: Any, value: Any) -> Any:
    """``check(value)``, its name-free message (shared with argparse) named after ``option``."""
    try:
        return check(value)
    except ValueError as exc:
        raise OptionError(option, f"{{option}} {exc}") from None


def _whole(value: int | str) -> int:
    """A whole number (text from the command line, or an int: numpy's too, never a bool)."""
    if isinstance(value, str):
        try:
            value = int(value)
        except ValueError:
            raise ValueError(f"must be a whole number, got {value!r}") from None
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ValueError(f"must be a whole number, got {value!r}")
    return int(value)


def check_positive_int(value: int | str) -> int:
    """A whole number >= 1 (text from the command line, or an int); the ValueError's message
    leaves the name out, for the caller (or argparse) to put in front."""
    value = _whole(value)
    if value < 1:
        raise ValueError(f"must be >= 1, got {value}")
    return value


def check_count(value: int | str) -> int:
    """A whole number >= 0, as :func:`check_positive_int` reads it."""
    value = _whole(value)
    if value < 0:
        raise ValueError(f"must be >= 0, got {value}")
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


def _check_flag(option: str, value: Any) -> bool:
    """A yes/no option: True or False (numpy's too), never a string ("no" is truthy)."""
    if not isinstance(value, bool | np.bool_):
        raise OptionError(option, f"{{option}} must be True or False, got {value!r}")
    return bool(value)


def _check_out(option: str, value: Any) -> Path:
    """A folder to write into: '' would be the current folder, which no one means."""
    if not isinstance(value, str | os.PathLike) or not str(value).strip():
        raise OptionError(option, f"{{option}} must name a folder, got {value!r}")
    return Path(value)


def _check_executor(value: Any) -> None:
    """None, or an executor-like backend (``submit`` returning futures): checked before the
    folder is made (it failed with an AttributeError after sweep.json was written)."""
    if value is not None and not callable(getattr(value, "submit", None)):
        raise OptionError(
            "executor",
            f"{{option}} must be an executor (with submit(), as Dask's Client.get_executor() "
            f"or a concurrent.futures pool), got {value!r}",
        )


def _check_names(option: str, value: Any) -> list[str] | None:
    """A list of names (a string would be read letter by letter)."""
    if value is None:
        return None
    if isinstance(value, str) or not isinstance(value, Sequence):
        raise OptionError(option, f"{{option}} must be a list of names, got {value!r}")
    if not all(isinstance(name, str) for name in value):
        raise OptionError(option, f"{{option}} must be a list of names, got {value!r}")
    return list(value)


def _check_folders(option: str, value: Any) -> list[Path]:
    """A folder, or a list of them."""
    items = [value] if isinstance(value, str | os.PathLike) else value
    if not isinstance(items, Sequence) or not all(
        isinstance(item, str | os.PathLike) for item in items
    ):
        raise OptionError(option, f"{{option}} must be a folder or a list of them, got {value!r}")
    return [Path(item) for item in items]


def _check_pair(option: str, value: Any) -> tuple[Any, ...] | None:
    """None, or two values (low, high); what they must be, the map's spec says."""
    if value is None:
        return None
    if isinstance(value, str) or not isinstance(value, Sequence) or len(value) != 2:
        raise OptionError(option, f"{{option}} must be a pair (low, high), got {value!r}")
    return tuple(value)


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
        base = get_scene(_checked("name", check_scene_name, name))  # named as the caller names it
        return _catalogue_scene(base, changes, chi, thetadot0)
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
        """The run's events by the canonical reading (engines/judging/contact.py), as the
        verdict and every table read them: the row's unprefixed columns (None when the run
        failed first)."""
        result = self.result
        if result.events is None or result.trajectory is None:
            return None
        scene, mu = self.task.scene, self.row.get(Col.MU)
        reading = read_run(
            result.trajectory,
            scene,
            scene.mus if mu is None else float(mu),
            window_end=number_or_none(self.row.get(Col.EXACT_T_IMPACT)),
        )
        painleve = result.events.outcome is Outcome.PAINLEVE
        return canonical_events(result.trajectory, reading, painleve=painleve)

    @property
    def kin_events(self) -> Events | None:
        """The events the shared detectors read off the clearance and slip velocity (the
        kinematic reading, the row's kin_* columns), to compare; None when the run failed."""
        return self.result.events

    @property
    def verdict(self) -> str:
        """agrees, early-slip, ... or failed (engines/judging/verdict.py)."""
        return str(self.row["verdict"])

    @property
    def judgement(self) -> dict[str, Any]:
        """What the verdict says of the run, JSON-ready (:func:`judgement`): what
        ``hoopbench simulate`` prints."""
        return judgement(self.row)


JUDGEMENT_COLUMNS: tuple[str, ...] = (
    Col.VERDICT,
    Col.OUTCOME_AGREES,
    Col.VERDICT_FLAGS,
    Col.VERDICT_REASON,
    Col.EVENT_FLAGS,
    *EXACT_COLUMNS,
    Col.ERR_T_SLIP_MS,
    Col.ERR_THETA_SLIP_DEG,
    Col.ERR_T_LIFT_MS,
    Col.ERR_T_IMPACT_MS,
    Col.ERR_HOP_HEIGHT_REL,
    Col.PHASES_AGREE,
    *TRANSITION_COLUMNS,
)
"""The columns of a run's row that judge it (their meanings: engines/judging/columns.py)."""


def judgement(row: Mapping[str, Any]) -> dict[str, Any]:
    """A judged row's verdict, flags, exact events and errors (JUDGEMENT_COLUMNS, values as
    the row holds them, a missing one None), and ``events``: every event the verdict
    compared with the exact one, in the order it did, each
    ``{event, error, unit, tight, loose, within}`` (run minus exact; ``unit`` ms for a time,
    ``relative`` for the hop height; ``tight`` and ``loose`` the tolerances the verdict
    applied, the row's detection floor included; ``within``: ``tight``, ``loose`` or
    ``neither``)."""
    fields = {column: _json_value(row.get(column)) for column in JUDGEMENT_COLUMNS}
    timed = [
        _event_error(event.name, 1e3 * event.error, "ms", 1e3 * event.tight, 1e3 * event.loose)
        for event in classify(row).timed
    ]
    hop = number_or_none(row.get(Col.ERR_HOP_HEIGHT_REL))
    if hop is not None:
        tight, loose = (event_tolerance(row, Event.HOP_HEIGHT, tier) for tier in Tier)
        timed.append(_event_error(str(Event.HOP_HEIGHT), hop, "relative", tight, loose))
    return {**fields, "events": timed}


def _event_error(name: str, error: float, unit: str, tight: float, loose: float) -> dict:
    within = "tight" if abs(error) <= tight else "loose" if abs(error) <= loose else "neither"
    return {
        "event": name,
        "error": error,
        "unit": unit,
        "tight": tight,
        "loose": loose,
        "within": within,
    }


def _json_value(value: Any) -> Any:
    """A row's value as JSON writes it: NaN and pandas' NA as None, numpy's as Python's."""
    if value is None or isinstance(value, str | bool):
        return value
    if hasattr(value, "item"):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def run(
    engine: str,
    scene: Scene | str,
    *,
    timestep: float = DEFAULT_TIMESTEP,
    profile: Profile | str = Profile.TUNED,
    geometry: str = "sphere",
    options: Mapping[str, Any] | None = None,
    variant: str | None = None,
    settings: str | Path | None = None,
) -> EngineRun:
    """Run a scene (or a catalogue scene by name) in an engine and judge it against the exact
    solution, as a suite run is judged: ``row`` is exactly what ``hb.compare`` stores.

    ``options`` are the engine's own settings (``hoopbench settings`` lists them) over the
    ``profile``'s values; ``variant`` names the row's variant (default: ``default`` without
    options or another geometry, ``custom`` with them; a suite's variant name gives that
    suite run's run_id). ``settings``: a settings file of ``hoopbench tune`` (``FILE`` for its
    first setting, ``FILE#NAME`` for another), whose timestep, profile and options the run
    takes (then ``timestep``, ``profile`` and ``options`` must stay unset); its name is the
    variant. The engine's failures are statuses in the result; bad settings raise ValueError
    before the run.
    """
    if settings is not None:
        chosen = _setting_instead(engine, settings, timestep, profile, options)
        timestep, profile, options = chosen.timestep, chosen.profile, chosen.options
        variant = chosen.name if variant is None else variant
    task = _run_task(engine, _as_scene(scene), timestep, profile, geometry, options, variant)
    return _engine_run(task, None)


def run_settings(engine: str, scene: Scene, settings: RunSettings) -> EngineRun:
    """``hoopbench simulate``'s run: ``scene`` in ``engine`` with any RunSettings (a pair
    friction, restitution and step limit too), judged as :func:`run` judges (its row, its
    ``judgement``) against the exact solution of the run's friction. The scene is taken as
    given, a catalogue name with other parameters too (nothing is stored under its name).
    The exact solution has no restitution: a run with some is judged against a hoop that
    does not bounce (``judgement`` says what differs; the CLI says so)."""
    engine_class(engine)().check(scene, settings)
    task = _run_task(
        engine,
        scene,
        settings.timestep,
        settings.profile,
        settings.geometry,
        dict(settings.options),
        None,
        check_name=False,
    )
    return _engine_run(task, settings)


def _engine_run(task: RunTask, settings: RunSettings | None) -> EngineRun:
    result, row = suite_runs.run_and_row(task, settings)
    frame = None if result.trajectory is None else result.trajectory.to_frame()
    return EngineRun(task=task, result=result, row=row, trajectory=frame)


def export(
    engine: str,
    scene: Scene | str,
    *,
    timestep: float = DEFAULT_TIMESTEP,
    profile: Profile | str = Profile.TUNED,
    options: Mapping[str, Any] | None = None,
    settings: str | Path | None = None,
    command: list[str] | None = None,
) -> str:
    """A standalone Python script that reproduces :func:`run`'s run of ``scene`` in
    ``engine`` with the engine's own API alone (no hoopbench import) and writes its
    trajectory, as ``hoopbench simulate --csv`` does, to the CSV path given as its first
    argument: what to attach to an engine's bug tracker (engines/standalone.py).

    Arguments as :func:`run`'s (``settings``: a ``FILE#NAME`` of ``hoopbench tune``);
    ``command``: the command line, for the script's header. ValueError for bad settings or
    an engine without an export."""
    if settings is not None:
        chosen = _setting_instead(engine, settings, timestep, profile, options)
        timestep, profile, options = chosen.timestep, chosen.profile, chosen.options
    if options is not None and not isinstance(options, Mapping):
        raise OptionError("options", f"{{option}} must be a mapping of settings, got {options!r}")
    run_settings = RunSettings(
        timestep=timestep, options=options or {}, profile=check_profile("profile", profile)
    )
    return engine_class(engine)().export_script(_as_scene(scene), run_settings, command=command)


def _setting_instead(
    engine: str,
    settings: str | Path,
    timestep: float,
    profile: Profile | str,
    options: Mapping[str, Any] | None,
) -> Any:
    """The setting ``settings`` names, which takes the place of the timestep, profile and
    options: OptionError if any of them was given too."""
    if options or timestep != DEFAULT_TIMESTEP or str(profile) != str(Profile.TUNED):
        raise OptionError(
            "settings", "{option} gives the timestep, profile and options: set none of them"
        )
    return setting_from_file(engine, settings)


def setting_from_file(engine: str, text: str | Path) -> Any:
    """The setting a ``FILE`` or ``FILE#NAME`` names, for ``engine`` (ValueError otherwise)."""
    loaded, name = load_choice(text)
    if loaded.engine != engine:
        path = split_choice(text)[0]
        raise OptionError("settings", f"{{option}} {path!r} is for {loaded.engine}, not {engine}")
    return pick_setting(loaded, name)


def _run_task(
    engine: str,
    scene: Scene,
    timestep: float,
    profile: Profile | str,
    geometry: str,
    options: Mapping[str, Any] | None,
    variant: str | None,
    *,
    check_name: bool = True,
) -> RunTask:
    """The run as a one-task suite builds it, so that its run_id and row are a suite's
    (``check_name``: refuse a catalogue scene's name with other parameters, as a suite
    does)."""
    if options is not None and not isinstance(options, Mapping):
        raise OptionError("options", f"{{option}} must be a mapping of settings, got {options!r}")
    if check_name:
        check_catalogue_name(scene, "scene")  # as a suite file's [[scene]]: one meaning per name
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
    settings: tuple[SettingsFile, str | None] | None = None
    """The ``--settings FILE[#NAME]`` whose settings the suite holds as variants: the file
    and the NAME (part of the results folder's identity)."""


def suite_job(
    suite: str | Path,
    *,
    run_timeout: float | None = None,
    engines: Sequence[str] | None = None,
    trajectories: TrajectoryChoice | str = TrajectoryChoice.NONE,
    announce: Announce | None = None,
    settings: str | Path | None = None,
    engine_versions: Sequence[str] = (),
) -> SuiteJob:
    """Check a suite and its options. ``suite``: a suite file (.toml) or the name of a
    shipped one (quick, default, ...). SuiteError (a ValueError) names a bad file's key.
    ``announce(name, runs)`` is told the run count before the runs are checked. ``settings``:
    a settings file of ``hoopbench tune``, each of its settings a variant of its engine
    (``FILE#NAME``: only the setting NAME, or the cheapest of a tier: ``FILE#close``).
    ``engine_versions``: ``ENGINE==VERSION`` texts, releases that engine runs on in place of
    the installed one (compare/releases.py)."""
    # a Path is a file; text follows the command line's rule (suite_file.suite_path)
    path = suite if isinstance(suite, Path) else suite_path(str(suite))
    names = _check_names("engines", engines)
    if run_timeout is not None and (
        isinstance(run_timeout, bool)
        or not isinstance(run_timeout, numbers.Real)
        or not run_timeout > 0
    ):
        raise OptionError("run_timeout", f"{{option}} must be > 0 s, got {run_timeout!r}")
    if names is not None and not names:  # [] would be read as "every engine"
        raise OptionError("engines", "{option} must name at least one engine, got []")
    loaded = load_suite(path, announce)  # the whole file is checked before anything runs
    if names:
        loaded = loaded.with_engines(names)
    chosen = None if settings is None else load_choice(settings)
    if chosen is not None:
        loaded = with_settings(loaded, *chosen)
    if engine_versions:
        try:
            given = [parse_release(text) for text in engine_versions]
        except ValueError as exc:
            raise SuiteError(str(exc)) from None
        loaded = loaded.with_releases([(r.engine, r.version) for r in given])
    choice = _choice("trajectories", TrajectoryChoice, trajectories)
    return SuiteJob(path, loaded, run_timeout, choice, chosen)


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
    out = _check_out("out", out)
    resume, quiet = _check_flag("resume", resume), _check_flag("quiet", quiet)
    workers = default_jobs() if jobs is None else _checked("jobs", check_workers, jobs)
    batch_size = _checked("batch_size", check_batch_size, batch_size)
    _check_executor(executor)
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
        settings=job.settings,
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
    engine_timesteps: Mapping[str, float] | None = None,
) -> MapSpec:
    """The map's spec from the options (None: the default). On ``resume``, options not given
    come from the map stored in ``out`` (the run refuses a spec that differs from it).
    ``engine_timesteps`` (engine -> s) go over the engines' own steps (the default ones,
    ``hop_map.spec.ENGINE_TIMESTEPS``, or the stored ones on ``resume``)."""
    out, resume = _check_out("out", out), _check_flag("resume", resume)
    given: dict[str, Any] = {
        key: value
        for key, value in (
            ("x", x),
            ("y", y),
            ("x_range", _check_pair("x_range", x_range)),
            ("y_range", _check_pair("y_range", y_range)),
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
    if fixed is not None and not isinstance(fixed, Mapping):
        raise OptionError("fixed", f"{{option}} must be a mapping of parameters, got {fixed!r}")
    fixed = dict(fixed or {})
    if engine_timesteps is not None and not isinstance(engine_timesteps, Mapping):
        raise OptionError(
            "engine_timesteps",
            f"{{option}} must map engine names to steps, got {engine_timesteps!r}",
        )
    own = dict(engine_timesteps or {})
    stored_file = Path(out) / MAP_FILE
    stored = stored_file.exists() or stored_file.is_symlink()
    if resume and not stored and not (out.is_dir() and any(out.iterdir())):
        # a new default map, silently, is not what a resume asks for (a folder holding other
        # files is refused by the run, which says what it holds)
        what = "does not exist" if not out.exists() else "is empty"
        raise OptionError(
            "resume", f"{{option}}: {str(out)!r} {what}: there is no hop map to resume"
        )
    if not (resume and stored):
        if own:
            names = given.get("engines", DEFAULT_ENGINES)
            names = () if isinstance(names, str) else names  # MapSpec names that error
            given["engine_timesteps"] = {**default_engine_timesteps(names), **own}
        return MapSpec(**given, fixed=fixed)
    try:
        base = load_spec(out).to_dict()
    except ValueError as exc:
        raise OptionError("resume", f"{{option}}: {stored_file}: {exc}") from None
    return _resumed_spec(base, given, fixed, own)


def _resumed_spec(
    base: dict[str, Any], given: dict[str, Any], fixed: dict[str, Any], own: dict[str, float]
) -> MapSpec:
    """The stored spec with the given options over it: a new axis takes its own default
    range, the stored fixed values of parameters that are now axes go, and the engines' own
    steps ``own`` go over the stored ones."""
    base.pop("format_version")
    stored_fixed = base.pop("fixed")
    base["engine_timesteps"] = {**base["engine_timesteps"], **own}
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
    out = _check_out("out", out)
    resume, quiet = _check_flag("resume", resume), _check_flag("quiet", quiet)
    workers = default_jobs() if jobs is None else _checked("jobs", check_workers, jobs)
    batch_size = _checked("batch_size", check_batch_size, batch_size)
    _check_executor(executor)
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
    engine_timesteps: Mapping[str, float] | None = None,
    jobs: int | None = None,
    quiet: bool = False,
    executor: Executor | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
) -> pd.DataFrame:
    """The hop map into the folder ``out``: the exact regime and every engine's verdict over
    a grid of scenes, as ``hoopbench map``; its table, one row per (point, engine).

    Axes ``x`` and ``y`` (lam, chi, mu, eps, theta0_deg; default lam and chi), their ranges,
    ``grid`` ((nx, ny) or ``"10x10"``), ``fixed`` values of the other parameters, the window
    ``t_end``, the ``engines`` (empty: the exact regimes alone), their ``timestep`` (the
    batched engines have their own, 1e-3 s, unless ``engine_timesteps`` gives one) and
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
        engine_timesteps=engine_timesteps,
    )
    summary = run_hop_map(
        spec, out, jobs=jobs, resume=resume, quiet=quiet, executor=executor, batch_size=batch_size
    )
    _raise_if_interrupted(summary)
    return map_frame(out)


# --------------------------------------------------------------------------- report
def results_folders(option: str, value: Any) -> list[Path]:
    """The folders a report reads (of ``compare``, ``hop_map``, ``tune`` or bench), each
    holding results and none named twice (its runs would be counted twice); OptionError
    naming ``option`` otherwise. make report checks its searches with it before its sweeps."""
    folders = _check_folders(option, value)
    for folder in folders:
        if not (
            (folder / "runs").is_dir() or is_tune_folder(folder) or is_batch_cost_folder(folder)
        ):
            raise OptionError(
                option,
                f"{{option}} {str(folder)!r} holds no results (no runs/ folder): "
                "run hoopbench compare first",
            )
    for k, folder in enumerate(folders):
        same = [f for f in folders[:k] if f.resolve() == folder.resolve()]
        if same:
            raise OptionError(option, f"{{option}} names the folder {str(same[0])!r} twice")
    return folders


def report(
    results: str | Path | Sequence[str | Path],
    out: str | Path | None = None,
    *,
    force: bool = False,
    say: Callable[[str], None] | None = None,
) -> Path:
    """report.md and its figures from result folders (of ``compare``, ``hop_map`` or
    ``tune``; no simulation), into ``out`` (default: the first folder); the path of report.md.

    An existing report.md is replaced only with ``force=True``. ``say`` hears what the
    report is doing, a line a step (the command line prints them on stderr).
    """
    folders = results_folders("results", results)
    if not folders:
        raise OptionError("results", "{option} must name at least one results folder")
    target = _check_out("out", out) if out is not None else folders[0]
    force = _check_flag("force", force)
    if target.exists() and not target.is_dir():
        raise OptionError("out", f"{{option}} {str(target)!r} is a file, not a folder")
    for folder in folders:  # its own files (runs/, trajectories/) are no place for a report
        if target.resolve() != folder.resolve() and target.resolve().is_relative_to(
            folder.resolve()
        ):
            raise OptionError(
                "out",
                f"{{option}} {str(target)!r} is inside the results folder {str(folder)!r}: "
                "choose a folder outside it (or the results folder itself)",
            )
    held = [] if force else files_to_replace(target, folders)
    if held:
        more = f" (and {len(held) - 1} more file(s) the report writes)" if len(held) > 1 else ""
        raise OptionError(
            "force",
            f"{str(held[0])!r} exists; pass {{option}} to replace it{more}",
            shown="force=True",
        )
    return build_report(folders, target, force=force, say=say)


# --------------------------------------------------------------------------- tune
@dataclass(frozen=True)
class TuneJob:
    """A search with its options, every one checked: nothing runs before this exists."""

    spec: TuneSpec
    budget: Budget


def tune_job(
    engine: str,
    *,
    scenes: Sequence[Scene | str] | None = None,
    trials: int | None = None,
    timeout: float | None = None,
    seed: int = 0,
    heldout_seed: int | None = None,
    heldout_per_regime: int = 1,
    heldout_neighbours: int = 1,
    run_timeout: float | None = None,
) -> TuneJob:
    """Check a search's options (see :func:`tune`)."""
    if engine not in engine_names() or engine == REFERENCE_ENGINE:
        names = ", ".join(n for n in engine_names() if n != REFERENCE_ENGINE)
        raise OptionError("engine", f"{{option}} must be one of {names}, got {engine!r}")
    if trials is None and timeout is None:
        raise OptionError("trials", "a search needs a budget: {option} (in all) or a timeout (s)")
    if scenes is not None and (isinstance(scenes, str) or not isinstance(scenes, Sequence)):
        raise OptionError("scenes", f"{{option}} must be a list of scenes, got {scenes!r}")
    try:  # [] is refused below, not read as "the default scenes"
        chosen = tuple(
            _as_scene(s) for s in (DEFAULT_TRAINING_SCENES if scenes is None else scenes)
        )
    except ValueError as exc:
        raise OptionError("scenes", f"{{option}}: {exc}") from None
    if not chosen:
        raise OptionError("scenes", "{option} must name at least one scene, got []")
    named = [s.name for s in chosen if s.name]  # unnamed scenes: TuneSpec compares them whole
    twice = sorted({name for name in named if named.count(name) > 1})
    if twice:  # refused here, before the folder is made
        raise OptionError("scenes", f"{{option}} names {', '.join(twice)} more than once")
    budget = Budget(
        trials=None if trials is None else _checked("trials", check_positive_int, trials),
        timeout_s=None if timeout is None else _checked("timeout", check_positive_seconds, timeout),
        run_timeout_s=None
        if run_timeout is None
        else _checked("run_timeout", check_positive_seconds, run_timeout),
    )
    whole = numbers.Integral  # numpy's integers too (a seed drawn by numpy is one)
    if isinstance(seed, bool) or not isinstance(seed, whole) or not 0 <= seed < 2**32:
        # the sampler's seed (numpy's): refused here, before the folder is made
        raise OptionError("seed", f"{{option}} must be a whole number in [0, 2**32), got {seed!r}")
    seed = int(seed)
    held = TuneSpec.heldout_seed if heldout_seed is None else heldout_seed
    if isinstance(held, bool) or not isinstance(held, whole) or held < 0 or held == seed:
        raise OptionError(
            "heldout_seed",
            f"{{option}} must be a whole number >= 0 other than the seed, got {held!r}",
        )
    per_regime = _at_most(
        "heldout_per_regime",
        _checked("heldout_per_regime", check_count, heldout_per_regime),
        MAX_HELDOUT_PER_REGIME,
        "random scenes of each regime, drawn after the search",
    )
    near = _at_most(
        "heldout_neighbours",
        _checked("heldout_neighbours", check_count, heldout_neighbours),
        MAX_HELDOUT_NEIGHBOURS,
        "neighbours of each training scene, drawn after the search",
    )
    if per_regime == near == 0:
        raise OptionError(
            "heldout_per_regime", "{option} and the neighbours cannot both be 0: no held-out scene"
        )
    return TuneJob(TuneSpec(engine, chosen, seed, int(held), per_regime, near), budget)


def _at_most(option: str, value: int, cap: int, what: str) -> int:
    """``value`` if at most ``cap``; else OptionError, before anything is drawn or written."""
    if value > cap:
        raise OptionError(option, f"{{option}} must be at most {cap} ({what}), got {value}")
    return value


def run_tune(
    job: TuneJob,
    out: str | Path,
    *,
    resume: bool = False,
    jobs: int | None = None,
    quiet: bool = False,
    executor: Executor | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
) -> tuple[SearchResult, pd.DataFrame | None]:
    """Run a checked search into ``out``: the search and its front table (None if a signal
    stopped it before the held-out runs ended). ``executor``: a Dask cluster's (``jobs`` is
    then ignored); ``batch_size``: runs per batch for an engine that steps many worlds."""
    out = _check_out("out", out)
    resume, quiet = _check_flag("resume", resume), _check_flag("quiet", quiet)
    workers = default_jobs() if jobs is None else _checked("jobs", check_workers, jobs)
    batch_size = _checked("batch_size", check_batch_size, batch_size)
    _check_executor(executor)
    say = None if quiet else control_chars.say
    front: list[pd.DataFrame | None] = [None]

    def then(result: SearchResult, runner: Runner) -> None:
        front[0] = validate(job.spec, result, Path(out), runner, job.budget)

    result = search(
        job.spec,
        out,
        job.budget,
        resume=resume,
        jobs=workers,
        executor=executor,
        batch_size=batch_size,
        say=say,
        then=then,
    )
    return result, front[0]


def tune(
    engine: str,
    out: str | Path,
    *,
    scenes: Sequence[Scene | str] | None = None,
    trials: int | None = None,
    timeout: float | None = None,
    seed: int = 0,
    heldout_seed: int | None = None,
    heldout_per_regime: int = 1,
    heldout_neighbours: int = 1,
    resume: bool = False,
    jobs: int | None = None,
    run_timeout: float | None = None,
    quiet: bool = False,
    executor: Executor | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
) -> pd.DataFrame:
    """Search an engine's settings (error against cost) into the folder ``out`` and return
    its front: the Pareto set and ``stock`` and ``tuned``, each with its training and held-out
    error and the accuracy tier it reaches on each (docs/tune.md). ``trials`` (in all, a
    resumed search's included) or ``timeout`` (s for this session) is the budget; ``scenes``
    the training scenes (default: the catalogue's scenes with events); ``heldout_seed`` draws
    the held-out scenes:
    ``heldout_per_regime`` random scenes of each regime and ``heldout_neighbours`` neighbours
    of each training scene. ``executor`` runs the runs elsewhere (a Dask cluster's, as in
    :func:`compare`); ``batch_size`` is runs per batch for an engine that steps many worlds
    at once. Needs Optuna (the ``tune`` extra). KeyboardInterrupt if a signal stopped it
    (``resume=True`` goes on).
    """
    job = tune_job(
        engine,
        scenes=scenes,
        trials=trials,
        timeout=timeout,
        seed=seed,
        heldout_seed=heldout_seed,
        heldout_per_regime=heldout_per_regime,
        heldout_neighbours=heldout_neighbours,
        run_timeout=run_timeout,
    )
    result, front = run_tune(
        job,
        out,
        resume=resume,
        jobs=jobs,
        quiet=quiet,
        executor=executor,
        batch_size=batch_size,
    )
    if result.interrupted or front is None:
        raise KeyboardInterrupt(f"interrupted: resume with hb.tune(..., resume=True) in {out}")
    return front
