"""Suite files: a comparison declared in TOML, validated whole before any run starts.

The schema (README, "Suite files"): top-level ``name``, ``engines``, ``timesteps``, ``scenes``
(catalogue names), repeatable ``[[scene]]`` tables (a scene by its parameters) and
``[[variant]]`` tables (extra settings for one engine). Every engine always runs its default
settings as the variant ``default``. A suite expands into :class:`RunTask` values, one per
run, each keyed by a stable hash of its full inputs (``run_id``), so that a resumed sweep
knows what it has already done.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tomllib
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from enum import StrEnum
from pathlib import Path
from types import MappingProxyType
from typing import Any

from hoopbench.engines.base import n_steps_for
from hoopbench.engines.options import Profile, check_profile
from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene, scene_names
from hoopbench.models.checks import check_real
from hoopbench.models.scene import THETA0_LIMIT_DEG, Scene
from hoopbench.reports.compare.releases import RELEASE_PREFIX, check_version
from hoopbench.reports.sweep.folder_files import FolderFileError, read_input_file

__all__ = [
    "MAX_SUITE_RUNS",
    "SUITES_DIR",
    "CatalogueNameError",
    "LeftOut",
    "RunTask",
    "Suite",
    "SuiteError",
    "TrajectoryChoice",
    "VariantSpec",
    "builtin_suite",
    "check_catalogue_name",
    "load_suite",
    "parse_suite",
    "suite_path",
]

SUITES_DIR = Path(__file__).resolve().parent / "suites"
"""The suite files hoopbench ships (quick, default, full, ...)."""

DEFAULT_VARIANT = "default"

STABILITY_SUITE = "stability"
"""Name of the shipped suite of stiff and extreme scenes (suites/stability.toml): its rows make
the report's stability matrix, and the answer does not read them."""

MAX_SUITE_RUNS = 100_000
"""Most runs one suite may make. Checking a run's settings costs about 0.1 ms and a run's
task and row some kB, so this is ten seconds of checks and some hundred MB held before the
first run (a million runs took two minutes and 1.1 GB, silently); the full shipped suite has
about a thousand runs, and a sweep of more is several sweeps, each resumable on its own."""

Announce = Callable[[str, int], None]
"""Told a suite's name and run count before its runs are checked."""

_TOP_KEYS = (
    "name",
    "engines",
    "timesteps",
    "engine_timesteps",
    "engine_scenes",
    "engine_versions",
    "profiles",
    "scenes",
    "scene",
    "variant",
    "sized_to_machine",
    "engine_gpu_only",
)
_SCENE_KEYS = (
    "name",
    "lam",
    "chi",
    "thetadot0",
    "mus",
    "muk",
    "eps",
    "theta0_deg",
    "g",
    "a",
    "M",
    "t_end",
    "xdot0",
)
_VARIANT_KEYS = ("engine", "name", "profile", "geometry", "options", "timesteps", "scenes")


class TrajectoryChoice(StrEnum):
    """Which runs store their trajectory: none, the default variant's runs, or all."""

    NONE = "none"
    DEFAULT = "default"
    ALL = "all"


class SuiteError(ValueError):
    """A suite file that cannot run: the message names the key and the value."""


class CatalogueNameError(SuiteError):
    """A ``[[scene]]`` named like a catalogue scene but with other parameters."""


@dataclass(frozen=True)
class VariantSpec:
    """Settings for one engine beside its defaults."""

    engine: str
    name: str
    geometry: str = "sphere"
    options: Mapping[str, Any] = field(default_factory=dict)
    timesteps: tuple[float, ...] | None = None
    """s; None: the suite's timesteps."""
    profile: Profile = Profile.TUNED
    """The option values the variant's own options start from."""
    scenes: tuple[str, ...] | None = None
    """Names of the suite's scenes the variant runs on; None: all of them."""
    release: str | None = None
    """The engine's release the variant runs on (its own cached folder, compare/releases.py);
    None: the installed one."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))


@dataclass(frozen=True)
class RunTask:
    """One run of a suite: small and picklable, for a worker process or a cluster."""

    run_id: str
    scene: Scene
    engine: str
    variant: str
    geometry: str
    options: tuple[tuple[str, Any], ...]
    """The full, checked option values (defaults included), as sorted pairs."""
    timestep: float
    """s."""
    profile: Profile = Profile.TUNED
    trajectory_dir: str | None = None
    """Where the worker stores the run's trajectory (None: not stored)."""
    release: str | None = None
    """The engine release the run imports (compare/releases.py); None: the installed one."""

    def settings(self) -> RunSettings:
        return RunSettings(
            timestep=self.timestep,
            geometry=self.geometry,
            options=dict(self.options),
            profile=self.profile,
        )

    @property
    def label(self) -> str:
        """What the run is, for progress lines."""
        return f"{self.scene.name} {self.engine} {self.profile} {self.variant} dt={self.timestep:g}"

    @property
    def n_steps(self) -> int:
        """Steps of the run (sizes its time limit)."""
        return n_steps_for(self.scene, self.timestep)


@dataclass(frozen=True)
class Suite:
    """A validated suite."""

    name: str
    engines: tuple[str, ...]
    timesteps: tuple[float, ...]
    scenes: tuple[Scene, ...]
    variants: tuple[VariantSpec, ...] = ()
    profiles: tuple[Profile, ...] = (Profile.TUNED,)
    """Each engine's defaults run once per profile (variant ``default``)."""
    engine_timesteps: Mapping[str, tuple[float, ...]] = field(default_factory=dict)
    """An engine's own timesteps (s), in place of the suite's for its runs without their
    own: an engine too slow to run at every timestep of the suite (``[engine_timesteps]``)."""

    engine_scenes: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    """An engine's own scenes (names of the suite's), in place of all of them: an engine
    too slow to run every scene (``[engine_scenes]``)."""

    sized_to_machine: bool = False
    """Whether the runs that pay off only on a GPU (``Engine.gpu_only_reason``, and the
    suite's own ``[engine_gpu_only]``) run only where the engine sees one
    (``sized_to_machine = true``: the suites of ``make report``); else, as in the full suite,
    every run runs everywhere."""

    def for_machine(
        self, tasks: Sequence[RunTask], gpu: Callable[[str], bool] | None = None
    ) -> tuple[list[RunTask], tuple[LeftOut, ...]]:
        """The tasks this machine runs, and what it leaves out: a suite sized to the machine
        leaves out the runs that pay off only on a GPU where ``gpu(engine)`` (by default the
        engine's own ``sees_gpu``; asked only of an engine with such runs) says there is
        none. Nothing of a run it keeps changes."""
        only = {task.run_id: reason for task in tasks if (reason := self._gpu_only(task))}
        sees = gpu or (lambda engine: engine_class(engine).sees_gpu())
        asked = dict.fromkeys(task.engine for task in tasks if task.run_id in only)
        blind = {engine for engine in asked if not sees(engine)}
        left = [task for task in tasks if task.run_id in only and task.engine in blind]
        counts = Counter((task.engine, task.variant) for task in left)
        why = {(task.engine, task.variant): only[task.run_id] for task in left}
        gone = {task.run_id for task in left}
        kept = [task for task in tasks if task.run_id not in gone]
        return kept, tuple(LeftOut(e, v, n, why[e, v]) for (e, v), n in counts.items())

    def _gpu_only(self, task: RunTask) -> str | None:
        """Why this run pays off only on a GPU in this suite, or None (and always None in a
        suite not sized to the machine)."""
        if not self.sized_to_machine:
            return None
        own = self.engine_gpu_only.get(task.engine)
        return own or engine_class(task.engine).gpu_only_reason(dict(task.options))

    engine_versions: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    """Releases an engine runs on, in place of the installed one (``[engine_versions]``,
    ``compare --engine-version``): its defaults on each, as the variant ``release=VERSION``;
    its ``[[variant]]`` tables are not run (an option may not exist on an older release)."""

    engine_gpu_only: Mapping[str, str] = field(default_factory=dict)
    """Engines whose runs in this suite pay off only on a GPU, and why (``[engine_gpu_only]``,
    engine = "reason"): in a suite sized to the machine they run only where the engine sees
    one, as an engine's own ``gpu_only`` runs do everywhere."""

    def _timesteps_of(self, variant: VariantSpec) -> tuple[float, ...]:
        return variant.timesteps or self.engine_timesteps.get(variant.engine) or self.timesteps

    def _variants_of(self, scene: Scene, engine: str) -> list[VariantSpec]:
        """The variants one engine runs on one scene: its defaults (one per distinct
        profile), then the suite's own."""
        only = self.engine_scenes.get(engine)
        if only is not None and scene.name not in only:
            return []
        releases = self.engine_versions.get(engine)
        if releases:
            return [
                VariantSpec(engine, f"{RELEASE_PREFIX}{r}", profile=p, release=r)
                for r in releases
                for p in _distinct_profiles(engine, self.profiles)
            ]
        defaults = [
            VariantSpec(engine, DEFAULT_VARIANT, profile=p)
            for p in _distinct_profiles(engine, self.profiles)
        ]
        mine = [
            v
            for v in self.variants
            if v.engine == engine and (v.scenes is None or scene.name in v.scenes)
        ]
        return [*defaults, *mine]

    @property
    def run_count(self) -> int:
        """How many runs :meth:`tasks` makes, counted without making them."""
        return sum(
            len(self._timesteps_of(variant))
            for scene in self.scenes
            for engine in self.engines
            for variant in self._variants_of(scene, engine)
        )

    def tasks(self, trajectory_dir: str | None = None) -> list[RunTask]:
        """Every run, in a stable order: scene, engine, variant (default first), timestep."""
        tasks = []
        for scene in self.scenes:
            for engine in self.engines:
                for variant in self._variants_of(scene, engine):
                    for dt in self._timesteps_of(variant):
                        tasks.append(_task(scene, variant, dt, trajectory_dir))
        return tasks

    def with_engines(self, engines: Sequence[str]) -> Suite:
        """The suite restricted to some of its engines (``compare --engines``)."""
        unknown = [e for e in engines if e not in self.engines]
        if unknown:
            raise SuiteError(
                f"engine(s) {', '.join(unknown)} not in suite {self.name!r} "
                f"(it has {', '.join(self.engines)})"
            )
        variants = tuple(v for v in self.variants if v.engine in engines)
        own = {e: dt for e, dt in self.engine_timesteps.items() if e in engines}
        scenes = {e: names for e, names in self.engine_scenes.items() if e in engines}
        releases = {e: r for e, r in self.engine_versions.items() if e in engines}
        gpu_only = {e: why for e, why in self.engine_gpu_only.items() if e in engines}
        return Suite(
            self.name,
            tuple(engines),
            self.timesteps,
            self.scenes,
            variants,
            self.profiles,
            own,
            scenes,
            self.sized_to_machine,
            releases,
            gpu_only,
        )

    def with_releases(self, releases: Sequence[tuple[str, str]]) -> Suite:
        """The suite with ``compare --engine-version`` releases (engine, version): they
        replace the suite's own releases of that engine, and an engine not in the suite
        joins it."""
        given: dict[str, list[str]] = {}
        for engine, version in releases:
            if version in given.setdefault(engine, []):
                raise SuiteError(f"--engine-version: {engine}=={version} is given twice")
            given[engine].append(version)
        engines = (*self.engines, *(e for e in given if e not in self.engines))
        own = {**self.engine_versions, **{e: tuple(v) for e, v in given.items()}}
        return replace(self, engines=engines, engine_versions=own)


@dataclass(frozen=True)
class LeftOut:
    """Runs of one engine's variant that a suite sized to the machine left out on a machine
    without a GPU (:meth:`Suite.for_machine`), and why they pay off only on one."""

    engine: str
    variant: str
    runs: int
    reason: str

    @property
    def label(self) -> str:
        """'mjwarp' for an engine's defaults, 'newton solver=mujoco' for a variant."""
        return self.engine if self.variant == DEFAULT_VARIANT else f"{self.engine} {self.variant}"

    def to_dict(self) -> dict[str, Any]:
        """The results folder's meta.json entry (the report reads it back: from_dict)."""
        return {
            "engine": self.engine,
            "variant": self.variant,
            "runs": self.runs,
            "reason": self.reason,
        }

    @classmethod
    def from_dict(cls, value: Any) -> LeftOut | None:
        """A stored entry, or None where it is not one (a hand-edited meta.json)."""
        if not isinstance(value, Mapping):
            return None
        engine, variant, runs, reason = (
            value.get(k) for k in ("engine", "variant", "runs", "reason")
        )
        if not (isinstance(engine, str) and isinstance(variant, str) and isinstance(reason, str)):
            return None
        if not isinstance(runs, int) or isinstance(runs, bool) or runs < 1:
            return None
        return cls(engine, variant, runs, reason)


def _distinct_profiles(engine: str, profiles: tuple[Profile, ...]) -> list[Profile]:
    """The profiles whose option values differ: an engine whose stock values are hoopbench's
    own (the reference) runs once, as tuned."""
    cls = engine_class(engine)
    same = cls.defaults(Profile.STOCK) == cls.defaults(Profile.TUNED)
    if same and Profile.TUNED in profiles:
        return [Profile.TUNED]
    return list(profiles)


def _task(scene: Scene, variant: VariantSpec, dt: float, trajectory_dir: str | None) -> RunTask:
    settings = RunSettings(
        timestep=dt, geometry=variant.geometry, options=variant.options, profile=variant.profile
    )
    options = engine_class(variant.engine).resolve(settings)
    inputs = {
        "scene": scene.to_dict(),
        "engine": variant.engine,
        "variant": variant.name,
        "profile": str(variant.profile),
        "geometry": variant.geometry,
        "options": options,
        "timestep": dt,
    }
    text = json.dumps(inputs, sort_keys=True, default=list, allow_nan=False)
    run_id = hashlib.sha256(text.encode()).hexdigest()[:16]
    return RunTask(
        run_id=run_id,
        scene=scene,
        engine=variant.engine,
        variant=variant.name,
        geometry=variant.geometry,
        options=tuple(sorted(options.items())),
        timestep=dt,
        profile=variant.profile,
        trajectory_dir=trajectory_dir,
        release=variant.release,
    )


# --------------------------------------------------------------------------- parsing
def load_suite(path: str | Path, announce: Announce | None = None) -> Suite:
    """Read and validate a suite file; SuiteError names the file, the key and the value.
    ``announce(name, runs)`` is called before the runs are checked (parse_suite)."""
    path = Path(path)
    try:
        text = read_input_file(path).decode("utf-8")
    except OSError as exc:
        raise SuiteError(f"cannot read suite file {str(path)!r}: {exc.strerror}") from None
    except FolderFileError as exc:  # a FIFO, a device, a folder, a file past the cap
        raise SuiteError(f"cannot read suite file {exc}") from None
    except UnicodeDecodeError as exc:  # TOML is UTF-8: say which file and where
        raise SuiteError(
            f"suite file {str(path)!r} is not UTF-8 text (byte {exc.start}: {exc.reason})"
        ) from None
    try:
        data = tomllib.loads(text)
    except ValueError as exc:  # not TOML, or an integer past int()'s 4300 digits
        raise SuiteError(f"{path.name}: not valid TOML: {exc}") from None
    except RecursionError:  # tomllib parses nested arrays recursively
        raise SuiteError(f"{path.name}: not a suite: its arrays or tables nest too deep") from None
    try:
        return parse_suite(data, announce)
    except SuiteError as exc:  # its kind kept: the report refuses a CatalogueNameError
        raise type(exc)(f"{path.name}: {exc}") from None


def shipped_suites() -> tuple[str, ...]:
    """The names of the suite files hoopbench ships, sorted."""
    return tuple(sorted(p.stem for p in SUITES_DIR.glob("*.toml")))


def builtin_suite(name: str) -> Path:
    """The path of a shipped suite file by its name (one of :func:`shipped_suites`, and
    nothing else: a name never reaches outside the suites folder)."""
    if name not in shipped_suites():
        raise SuiteError(
            f"no shipped suite {name!r}; shipped: {', '.join(shipped_suites())} "
            "(a suite file's path holds a / or ends in .toml)"
        )
    return SUITES_DIR / f"{name}.toml"


def suite_path(text: str) -> Path:
    """The suite file that ``--suite TEXT`` means. A path holds a ``/`` or ends in ``.toml``
    and is read as it is (``./mine`` for a file without the suffix); anything else is the
    name of a shipped suite. One rule, so that a name is never read as a file nor a path
    looked up among the shipped suites."""
    if "/" in text or os.sep in text or text.endswith(".toml"):
        return Path(text)
    return builtin_suite(text)


def parse_suite(data: Mapping[str, Any], announce: Announce | None = None) -> Suite:
    """A Suite from the parsed TOML; every run's settings are checked by its engine, after
    ``announce(name, runs)`` (a large suite takes seconds to check)."""
    _no_unknown_keys(data, _TOP_KEYS, "suite")
    name = data.get("name")
    if not isinstance(name, str) or not name.strip():
        raise SuiteError(f"name must be a non-empty string, got {name!r}")
    engines = _engines(data.get("engines", list(engine_names())))
    timesteps = _timesteps(data.get("timesteps"), "timesteps")
    scenes = [*_catalogue_scenes(data.get("scenes", [])), *_param_scenes(data.get("scene", []))]
    if not scenes:
        raise SuiteError("the suite has no scenes: give scenes = [...] or [[scene]] tables")
    names = [s.name for s in scenes]
    repeated = sorted({n for n in names if names.count(n) > 1})
    if repeated:
        raise SuiteError(f"scene name(s) {', '.join(repeated)} given twice")
    variants = _variants(data.get("variant", []), engines, names)
    profiles = _profiles(data.get("profiles", ["tuned"]), "profiles")
    own = _engine_timesteps(data.get("engine_timesteps", {}), engines)
    only = _engine_scenes(data.get("engine_scenes", {}), engines, names)
    sized = data.get("sized_to_machine", False)
    if not isinstance(sized, bool):
        raise SuiteError(f"sized_to_machine must be true or false, got {sized!r}")
    releases = _engine_versions(data.get("engine_versions", {}), engines)
    gpu_only = _engine_gpu_only(data.get("engine_gpu_only", {}), engines)
    if gpu_only and not sized:
        raise SuiteError("engine_gpu_only needs sized_to_machine = true (else every run runs)")
    suite = Suite(
        name,
        engines,
        timesteps,
        tuple(scenes),
        variants,
        profiles,
        own,
        only,
        sized,
        releases,
        gpu_only,
    )
    count = suite.run_count
    if count > MAX_SUITE_RUNS:
        raise SuiteError(
            f"the suite makes {count:,} runs, more than {MAX_SUITE_RUNS:,}: split it into "
            "several suites (each its own results folder)"
        )
    if announce is not None:
        announce(suite.name, count)
    _check_runs(suite)
    return suite


def _no_unknown_keys(table: Mapping[str, Any], allowed: Sequence[str], where: str) -> None:
    if not isinstance(table, Mapping):
        raise SuiteError(f"{where} must be a table, got {table!r}")
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise SuiteError(
            f"unknown key(s) {', '.join(unknown)} in {where}; allowed: {', '.join(allowed)}"
        )


def _engines(value: Any) -> tuple[str, ...]:
    if not isinstance(value, list) or not value or not all(isinstance(e, str) for e in value):
        raise SuiteError(f"engines must be a non-empty list of engine names, got {value!r}")
    known = engine_names()
    for engine in value:
        if engine not in known:
            raise SuiteError(f"engines: unknown engine {engine!r}; known: {', '.join(known)}")
    if len(set(value)) != len(value):
        raise SuiteError(f"engines: an engine is listed twice in {value!r}")
    return tuple(value)


def _engine_timesteps(value: Any, engines: Sequence[str]) -> dict[str, tuple[float, ...]]:
    """``[engine_timesteps]``: engine name -> its own list of timesteps, s."""
    if not isinstance(value, Mapping):
        raise SuiteError(f"engine_timesteps must be a table (engine = [timesteps]), got {value!r}")
    for engine in value:
        if engine not in engines:
            raise SuiteError(
                f"engine_timesteps: {engine!r} is not one of the suite's engines "
                f"({', '.join(engines)})"
            )
    return {e: _timesteps(dt, f"engine_timesteps.{e}") for e, dt in value.items()}


def _engine_scenes(
    value: Any, engines: Sequence[str], scenes: Sequence[str]
) -> dict[str, tuple[str, ...]]:
    """``[engine_scenes]``: engine name -> the suite's scenes it runs (all, if not given)."""
    if not isinstance(value, Mapping):
        raise SuiteError(f"engine_scenes must be a table (engine = [scene names]), got {value!r}")
    out = {}
    for engine, names in value.items():
        if engine not in engines:
            raise SuiteError(
                f"engine_scenes: {engine!r} is not one of the suite's engines "
                f"({', '.join(engines)})"
            )
        where = f"engine_scenes.{engine}"
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            raise SuiteError(f"{where} must be a non-empty list of scene names, got {names!r}")
        unknown = [n for n in names if n not in scenes]
        if unknown:
            raise SuiteError(f"{where}: {', '.join(unknown)} not among the suite's scenes")
        out[engine] = tuple(names)
    return out


def _engine_gpu_only(value: Any, engines: Sequence[str]) -> dict[str, str]:
    """``[engine_gpu_only]``: engine name -> why its runs in the suite pay off only on a GPU."""
    if not isinstance(value, Mapping):
        raise SuiteError(f'engine_gpu_only must be a table (engine = "reason"), got {value!r}')
    for engine, reason in value.items():
        where = f"engine_gpu_only.{engine}"
        if engine not in engines:
            raise SuiteError(
                f"{where}: {engine!r} is not one of the suite's engines ({', '.join(engines)})"
            )
        if not isinstance(reason, str) or not reason.strip():
            raise SuiteError(f"{where} must be a non-empty reason, got {reason!r}")
    return dict(value)


def _engine_versions(value: Any, engines: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """``[engine_versions]``: engine name -> the releases it runs on (compare/releases.py)."""
    if not isinstance(value, Mapping):
        raise SuiteError(f"engine_versions must be a table (engine = [versions]), got {value!r}")
    out = {}
    for engine, versions in value.items():
        where = f"engine_versions.{engine}"
        if engine not in engines:
            raise SuiteError(
                f"{where}: {engine!r} is not one of the suite's engines ({', '.join(engines)})"
            )
        if not isinstance(versions, list) or not versions:
            raise SuiteError(f"{where} must be a non-empty list of versions, got {versions!r}")
        if len(set(map(str, versions))) != len(versions):
            raise SuiteError(f"{where}: a version is listed twice in {versions!r}")
        try:
            out[engine] = tuple(check_version(engine, v, where).version for v in versions)
        except ValueError as exc:
            raise SuiteError(str(exc)) from None
    return out


def _timesteps(value: Any, key: str) -> tuple[float, ...]:
    if not isinstance(value, list) or not value:
        raise SuiteError(f"{key} must be a non-empty list of timesteps in s, got {value!r}")
    for dt in value:
        ok = isinstance(dt, int | float) and not isinstance(dt, bool)
        if not ok or not (math.isfinite(dt) and dt > 0):
            raise SuiteError(f"{key}: each timestep must be a number > 0 s, got {dt!r}")
    if len(set(value)) != len(value):
        raise SuiteError(f"{key}: a timestep is listed twice in {value!r}")
    return tuple(float(dt) for dt in value)


def _profiles(value: Any, key: str) -> tuple[Profile, ...]:
    items = value if isinstance(value, list) else [value]
    try:
        profiles = tuple(check_profile(key, p) for p in items if isinstance(p, str))
    except ValueError:
        profiles = ()
    if not items or len(profiles) != len(items):
        allowed = ", ".join(p.value for p in Profile)
        raise SuiteError(f"{key} must be one or more of {allowed}, got {value!r}")
    if len(set(items)) != len(items):
        raise SuiteError(f"{key}: a profile is listed twice in {value!r}")
    return profiles


def _catalogue_scenes(value: Any) -> list[Scene]:
    if not isinstance(value, list) or not all(isinstance(s, str) for s in value):
        raise SuiteError(f"scenes must be a list of catalogue names, got {value!r}")
    for name in value:
        if name not in scene_names():
            raise SuiteError(
                f"scenes: unknown catalogue scene {name!r}; known: {', '.join(scene_names())}"
            )
    return [get_scene(name) for name in value]


def _param_scenes(value: Any) -> list[Scene]:
    if not isinstance(value, list):
        raise SuiteError(f"[[scene]] must be a list of tables, got {value!r}")
    return [_param_scene(table, k) for k, table in enumerate(value, 1)]


def _param_scene(table: Any, k: int) -> Scene:
    where = f"[[scene]] number {k}"
    _no_unknown_keys(table, _SCENE_KEYS, where)
    name = table.get("name")
    if not isinstance(name, str) or not name.strip():
        raise SuiteError(f"{where}: name must be a non-empty string, got {name!r}")
    where = f"[[scene]] {name!r}"
    missing = [key for key in ("lam", "mus") if key not in table]
    if ("chi" in table) == ("thetadot0" in table):
        missing.append("exactly one of chi, thetadot0")
    if missing:
        raise SuiteError(f"{where}: missing {', '.join(missing)}")
    params = {k: v for k, v in table.items() if k not in ("name", "chi", "theta0_deg")}
    for key, value in table.items():
        if key != "name" and (isinstance(value, bool) or not isinstance(value, int | float)):
            raise SuiteError(f"{where}: {key} must be a number, got {value!r}")
    params.setdefault("muk", params["mus"])
    try:
        if "theta0_deg" in table:
            limit = THETA0_LIMIT_DEG
            deg = check_real("theta0_deg", table["theta0_deg"], low=-limit, high=limit, unit="deg")
            params["theta0"] = math.radians(deg)
        scene = (
            Scene.from_chi(table["chi"], name=name, **params)
            if "chi" in table
            else Scene(name=name, **params)
        )
    except ValueError as exc:
        raise SuiteError(f"{where}: {exc}") from None
    check_catalogue_name(scene, where)
    return scene


_OWN_WINDOW = ("name", "t_end")
"""What a [[scene]] named like a catalogue scene may change: its window."""


def _same(mine: Any, theirs: Any) -> bool:
    if isinstance(mine, float) and isinstance(theirs, float):
        return math.isclose(mine, theirs, rel_tol=1e-12)
    return bool(mine == theirs)


def check_catalogue_name(scene: Scene, where: str) -> None:
    """A [[scene]] may take a catalogue scene's name only with its parameters (another window
    allowed, as the stability suite's painleve): rows are keyed by scene name, and the report
    draws a catalogue scene's exact path and forces by that name. Refusing here, rather than
    reading each row's parameters in the report, keeps one meaning per name in every table."""
    if scene.name not in scene_names():
        return
    mine, theirs = scene.to_dict(), get_scene(scene.name).to_dict()
    differ = [
        f"{key} {mine[key]} (catalogue: {theirs[key]})"
        for key in mine
        if key not in _OWN_WINDOW and not _same(mine[key], theirs[key])
    ]
    if differ:
        raise CatalogueNameError(
            f"{where}: the catalogue's scene of that name has other parameters "
            f"({', '.join(differ)}): give this scene another name"
        )


def _variants(value: Any, engines: Sequence[str], scenes: Sequence[str]) -> tuple[VariantSpec, ...]:
    if not isinstance(value, list):
        raise SuiteError(f"[[variant]] must be a list of tables, got {value!r}")
    variants: list[VariantSpec] = []
    for k, table in enumerate(value, 1):
        where = f"[[variant]] number {k}"
        _no_unknown_keys(table, _VARIANT_KEYS, where)
        engine, name = table.get("engine"), table.get("name")
        if engine not in engines:
            raise SuiteError(
                f"{where}: engine must be one of the suite's ({', '.join(engines)}), got {engine!r}"
            )
        if not isinstance(name, str) or not name.strip() or name == DEFAULT_VARIANT:
            raise SuiteError(
                f"{where}: name must be a non-empty string other than {DEFAULT_VARIANT!r}, "
                f"got {name!r}"
            )
        if any(v.engine == engine and v.name == name for v in variants):
            raise SuiteError(f"{where}: {engine} variant {name!r} is given twice")
        where = f"[[variant]] {engine} {name!r}"
        geometry = table.get("geometry", "sphere")
        options = table.get("options", {})
        if not isinstance(options, Mapping):
            raise SuiteError(f"{where}: options must be a table, got {options!r}")
        options = {k: tuple(v) if isinstance(v, list) else v for k, v in options.items()}
        timesteps = table.get("timesteps")
        if timesteps is not None:
            timesteps = _timesteps(timesteps, f"{where}: timesteps")
        profile_value = table.get("profile", "tuned")
        if not isinstance(profile_value, str):  # one variant is one profile
            allowed = ", ".join(p.value for p in Profile)
            raise SuiteError(
                f"{where}: profile must be one of {allowed} (a variant has one; the suite's "
                f"profiles key lists several), got {profile_value!r}"
            )
        (profile,) = _profiles(profile_value, f"{where}: profile")
        only = _variant_scenes(table.get("scenes"), scenes, where)
        try:
            settings = RunSettings(geometry=geometry, options=options, profile=profile)
            engine_class(engine).resolve(settings)
        except ValueError as exc:
            raise SuiteError(f"{where}: {exc}") from None
        variants.append(VariantSpec(engine, name, geometry, options, timesteps, profile, only))
    return tuple(variants)


def _variant_scenes(value: Any, scenes: Sequence[str], where: str) -> tuple[str, ...] | None:
    """A variant's ``scenes``: None (all), or a non-empty list of the suite's scene names."""
    if value is None:
        return None
    if not isinstance(value, list) or not value or not all(isinstance(s, str) for s in value):
        raise SuiteError(f"{where}: scenes must be a non-empty list of scene names, got {value!r}")
    unknown = [s for s in value if s not in scenes]
    if unknown:
        raise SuiteError(
            f"{where}: scenes: {', '.join(map(repr, unknown))} not in the suite "
            f"(it has {', '.join(scenes)})"
        )
    return tuple(value)


def _check_runs(suite: Suite) -> None:
    """Every run's own checks (window, step budget, what the engine can represent) now,
    so that a sweep never stops on its thousandth run for a typo in the file."""
    for task in suite.tasks():
        engine = engine_class(task.engine)()
        try:
            engine.check(task.scene, task.settings())
        except ValueError as exc:
            raise SuiteError(
                f"scene {task.scene.name!r}, {task.engine} {task.variant}, "
                f"timestep {task.timestep:g} s: {exc}"
            ) from None
