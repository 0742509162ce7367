"""The engine interface: one class per engine declares everything about it.

An engine module subclasses :class:`Engine`, declares its import, geometries, options (each
with its default and the reason for it), settings variants and model writer, implements the
stepping hooks (the contract is in :class:`Engine`'s docstring: the loop itself is the base
class's, the same for every engine), and registers itself (``hoopbench.engines.registry``).
The registry, the CLI choices, ``hoopbench settings`` and the suites' variants are derived
from these declarations.

Stepping and judging are separate: :meth:`Engine.simulate` validates the settings, imports
the engine lazily, steps, and returns a :class:`Run` (trajectory plus what the engine
reports); ``hoopbench.engines.judging.judge.judge`` turns a run into events with the shared
detectors.
:meth:`Engine.run` does both. A failing or missing engine is a status, never an exception.
"""

from __future__ import annotations

import ctypes
import functools
import gc
import math
import os
import sys
import time
import traceback
from abc import ABC
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from types import ModuleType
from typing import Any, ClassVar

import numpy as np

from hoopbench.engines.judging.detectors import DetectorSettings
from hoopbench.engines.judging.judge import judge
from hoopbench.engines.options import Option, Profile, Variant, choice
from hoopbench.engines.run import BatchCost, Divergence, Run, RunInfo, RunResult, RunStatus
from hoopbench.engines.settings import BYTES_PER_STEP, MAX_STEPS, RunSettings
from hoopbench.engines.standalone import EXPORT_GEOMETRY, standalone_script
from hoopbench.engines.stopping import StopMonitor, StopReason, StopRule
from hoopbench.engines.warp_compile import share_compiles
from hoopbench.models import kinematics
from hoopbench.models.events import Events
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

__all__ = [
    "BYTES_PER_STEP",
    "CHUNK_STEPS",
    "DEVICE",
    "DEVICES",
    "MAX_STEPS",
    "POOL_WORKERS_VARIABLE",
    "RUN_ALONE",
    "STATE_KEYS",
    "WARP_CACHE",
    "WARP_ENABLE_BACKWARD",
    "Chunk",
    "DivergenceLimits",
    "DivergenceScreen",
    "Engine",
    "EngineUnavailableError",
    "Simulation",
    "WorldsEngine",
    "cache_folder",
    "call_repeatedly",
    "check_divergence",
    "check_steps",
    "cores_per_process",
    "equilibrium_depth",
    "import_engine",
    "import_warp",
    "n_steps_for",
    "states_and_step_forces",
    "steps_in",
    "steps_to_stop",
    "warp_device",
]

CHUNK_STEPS = 1000
"""Steps the loop has an adapter take between divergence checks (and per recording chunk)."""

RUN_ALONE = "the batch cannot step this world as its single run would"
"""What ``_batch_diverged`` says of a world that must run alone (MuJoCo's batch halts a world
on a warning where a single run steps on): the world leaves the batch and runs again by
itself, so that its row is its single run's."""

STATE_KEYS = ("X", "Y", "theta", "Xdot", "Ydot", "thetadot")
"""The centre-of-mass state's components, in the order of a batch hook's last axis (m, m,
rad, m/s, m/s, rad/s)."""


@functools.cache
def _installed_version(distribution: str, search_path: tuple[str, ...]) -> str | None:
    """The installed release of ``distribution`` as found on ``search_path`` (``sys.path``),
    None if it is not installed. Kept per path: reading a package's metadata costs 0.2-2 ms
    (MuJoCo's most), paid by every run before; a release run (``release_child``) puts its
    own folder first on the path, so it gets its own answer."""
    del search_path  # part of the cache key only: importlib.metadata reads sys.path itself
    try:
        return version(distribution)
    except PackageNotFoundError:
        return None


class EngineUnavailableError(RuntimeError):
    """Raised by an adapter's import hook when its engine cannot be used."""


def import_engine(name: str, *submodules: str) -> ModuleType:
    """Import an engine package (and submodules the adapter needs, e.g. 'mujoco.rollout');
    raise EngineUnavailableError if that fails, so the run reports 'unavailable'."""
    try:
        # __import__, as an import statement does (it also honours a patched builtins import).
        for module in (name, *submodules):
            __import__(module)
        return sys.modules[name]
    except ImportError as exc:
        raise EngineUnavailableError(f"{name} cannot be imported: {exc}") from exc


@dataclass(frozen=True)
class DivergenceLimits:
    """When a run counts as diverged. Checked on every chunk of steps."""

    energy_rise: float = 0.5
    """Largest allowed rise of energy per unit mass, as a fraction of the initial energy."""
    penetration: float = 0.05
    """Largest allowed penetration of the body's lowest point into the floor, as a fraction of
    a. The lowest point of the run's contact shape, not the hoop's circle: a ring of N
    capsules resting on a side has its centre (a - rc)(1 - cos(pi / N)) lower than the
    circle's, 7.6 % of a for N = 8, with nothing wrong."""


def check_divergence(
    scene: Scene,
    traj_state: Mapping[str, np.ndarray],
    limits: DivergenceLimits,
    shape: kinematics.Polygon | None = None,
) -> str | None:
    """A reason string if the states (arrays X, Y, theta, ...) show divergence, else None.

    ``shape``: the run's contact shape (None: the hoop's circle), whose lowest point's
    clearance (models/kinematics.py) the penetration limit bounds, as the judge reads it.
    """
    for name, values in traj_state.items():
        if not np.isfinite(values).all():
            return f"{Divergence.NON_FINITE} {name}"
    energy = kinematics.energy_per_mass(
        scene, traj_state["Y"], traj_state["Xdot"], traj_state["Ydot"], traj_state["thetadot"]
    )
    e0, most = scene.energy_per_mass, energy.max()
    if most > e0 * (1.0 + limits.energy_rise):
        return f"{Divergence.ENERGY_RISE} to {most / e0:.3g} times its initial value"
    least = kinematics.clearance(scene, traj_state["Y"], traj_state["theta"], shape).min()
    if least < -limits.penetration * scene.a:
        return f"{Divergence.PENETRATION} {-least:.3g} m exceeds {limits.penetration} a"
    return None


class DivergenceScreen:
    """:func:`check_divergence` for a batch's worlds, vectorised across them: the states of
    every world whose chunk ended are checked in one set of array operations, and only a
    world that fails is checked again by ``check_divergence`` for its reason. The energy
    and the clearance are computed by the same operations in the same order as
    models/kinematics.py's, element by element, so a world passes exactly when
    ``check_divergence`` returns None (tests/test_divergence_screen.py); the clearance is
    handed on to the world's stop monitor, which reads the same one.

    ``states``: (n, rows, 6), columns STATE_KEYS, of the worlds ``ids``."""

    def __init__(
        self,
        scenes: Sequence[Scene],
        shapes: Sequence[kinematics.Polygon | None],
        limits: DivergenceLimits,
    ) -> None:
        self.scenes, self.shapes, self.limits = list(scenes), list(shapes), limits
        # Column vectors, one row per world, broadcast over a world's rows; each factor as
        # energy_per_mass and clearance form it from the scene's floats.
        self.g = np.array([[s.g] for s in scenes])
        self.spin = np.array([[0.5 * s.k * s.a**2] for s in scenes])
        self.offset = np.array([[s.com_offset] for s in scenes])
        self.a = np.array([[s.a] for s in scenes])
        self.most_energy = np.array(
            [s.energy_per_mass * (1.0 + limits.energy_rise) for s in scenes]
        )
        self.least_clearance = np.array([-limits.penetration * s.a for s in scenes])
        self.polygons = [i for i, shape in enumerate(self.shapes) if shape is not None]

    def _of(self, ids: np.ndarray, *per_world: np.ndarray) -> tuple[np.ndarray, ...]:
        """The rows of ``ids`` of each per-world array (the arrays themselves when every
        world is checked: no copy)."""
        if len(ids) == len(self.scenes):
            return per_world
        return tuple(values[ids] for values in per_world)

    def clearance(self, ids: np.ndarray, states: np.ndarray) -> np.ndarray:
        """(n, rows), m: kinematics.clearance of each world's rows."""
        Y, theta = states[:, :, 1], states[:, :, 2]
        offset, a = self._of(ids, self.offset, self.a)
        clear = Y - offset * np.cos(theta) - a
        for i in self.polygons:
            for row in np.flatnonzero(ids == i):
                clear[row] = kinematics.clearance(
                    self.scenes[i], Y[row], theta[row], self.shapes[i]
                )
        return clear

    def reasons(
        self, ids: np.ndarray, states: np.ndarray
    ) -> tuple[list[str | None] | None, np.ndarray | None]:
        """(each world's ``check_divergence`` reason, or None when every world passes;
        the clearance, as :meth:`clearance`, or None when not screened). States other than
        float64 (an adapter's own precision) are checked world by world: the screen's
        factors are float64, where the check's Python floats would take the states' type."""
        if states.dtype != np.float64:
            return self._each(ids, states, np.zeros(len(ids), dtype=bool)), None
        finite = np.isfinite(states).all(axis=(1, 2))
        # Energy and clearance of finite rows only, as check_divergence (no warnings).
        rows = states if finite.all() else np.where(finite[:, None, None], states, 0.0)
        Y, Xdot, Ydot, thetadot = (rows[:, :, k] for k in (1, 3, 4, 5))
        g, spin = self._of(ids, self.g, self.spin)
        energy = g * Y + 0.5 * (Xdot**2 + Ydot**2) + spin * thetadot**2
        clear = self.clearance(ids, rows)
        most, least = self._of(ids, self.most_energy, self.least_clearance)
        passed = finite & (energy.max(axis=1) <= most) & (clear.min(axis=1) >= least)
        return (None if passed.all() else self._each(ids, states, passed)), clear

    def _each(self, ids: np.ndarray, states: np.ndarray, passed: np.ndarray) -> list[str | None]:
        """check_divergence's reason for every world not ``passed`` (None for the others)."""
        return [
            None
            if ok
            else check_divergence(self.scenes[i], _columns(rows), self.limits, self.shapes[i])
            for i, ok, rows in zip(ids.tolist(), passed.tolist(), states, strict=True)
        ]


def _columns(rows: np.ndarray) -> dict[str, np.ndarray]:
    """A world's states (rows, 6) as contiguous columns by STATE_KEYS, as a chunk gives them."""
    return {key: np.ascontiguousarray(rows[:, k]) for k, key in enumerate(STATE_KEYS)}


@dataclass(frozen=True)
class Chunk:
    """What an adapter's ``_advance`` returns: one chunk of a run, as the loop checks it."""

    state: dict[str, np.ndarray]
    """Centre-of-mass states: arrays X, Y, theta, Xdot, Ydot, thetadot of one length (m, rad,
    m/s, rad/s), read by check_divergence and the stop monitor. May begin with a row already
    given (the previous chunk's last state): the monitor skips rows it has seen."""
    last_step: int
    """Step index of the last row (its time is last_step * timestep): what the monitor is fed."""


@dataclass(frozen=True)
class Simulation:
    """What ``Engine._simulate`` returns."""

    trajectory: Trajectory
    n_steps: int
    wall_time_s: float
    """Wall time of the stepping loop alone (model building excluded), s."""
    cpu_time_s: float | None = None
    """The process's CPU time over the same loop (``time.process_time``: every thread of
    the process, user and system), s: unlike the wall time it does not grow when other
    processes share the cores (the reference solver's: over its solve and sampling). None:
    not measured."""
    diverged: str | None = None
    """Reason, if the run was stopped for divergence."""
    exact_events: Events | None = None
    """The reference engine's exact events (None for real engines)."""
    failed: str | None = None
    """Reason, if the engine produced a trajectory but no meaningful result (the run is an
    error row: e.g. the reference solver reached a degenerate or budget-limited end)."""
    stop_reason: StopReason | None = None
    """Why the run ended before its window's end (``RunSettings.stop``); None: it did not."""


class Engine(ABC):
    """Base class of the engines. A subclass declares the class attributes below, implements
    the stepping hooks (and ``_model_text`` if the engine reads a model file), and is
    registered with ``hoopbench.engines.registry.register``.

    The stepping loop is this class's, the same for every engine (``_simulate``): it takes
    ``n_steps_for(scene, settings.timestep)`` steps in chunks of at most ``CHUNK_STEPS``;
    after each chunk it checks divergence (the engine's own reason, then ``check_divergence``)
    and feeds the run's ``StopMonitor`` (``settings.stop``; the monitor skips rows it has
    seen), and ends at the first chunk that diverges or stops; it times the stepping (chunks
    and finishing step, with the checks), by the wall clock and by the process's CPU time,
    with the garbage collector off, and returns the
    ``Simulation`` (``n_steps``: the trajectory's rows less one). :meth:`bare_loop_time` is
    the class's too. An adapter implements only these hooks. They act on a per-run object of
    the adapter's own (``run``: the model and what it has recorded), as the engine instance
    may serve several runs:

    ``_open(module, scene, settings, options, *, record)``, a context manager giving ``run``
        Build the model at the scene's initial state, ready to step from t = 0, and release
        what it holds (a client, files, handlers) on exit. ``record=False`` is for
        :meth:`bare_loop_time`: nothing will be recorded or read, so an adapter may leave
        out its loggers and buffers.
    ``_advance(run, done, steps, last) -> Chunk``
        Take ``steps`` steps from step ``done``, record them, and return the chunk's
        centre-of-mass states with the step index of its last row. ``last``: the chunk
        reaches the window's end (an engine that needs one step more for the last row's
        force may take it here; it is not counted in ``n_steps``).
    ``_trajectory(run, done, ended_early) -> Trajectory``
        What was recorded over ``done`` steps (``ended_early``: the run diverged or was
        stopped), states and contact forces per unit mass, each row's force by the engine's
        own timing convention (``Trajectory.from_state``). Its rows set ``n_steps``.
    ``_step_bare(run, steps)``
        Step a ``record=False`` model ``steps`` times, the engine's cheapest way, reading
        nothing: the yardstick :meth:`bare_loop_time` times.
    ``_diverged(run) -> str | None``, optional
        The engine's own reason to call the run diverged after a chunk (MuJoCo resets its
        state instead of producing NaN; its warning counters tell). Default None.
    ``_contact_shape(run) -> Polygon | None``, optional
        The run's contact shape, which the divergence check and the monitor read the lowest
        point of. Default None: the hoop's circle.
    ``_finish(run, ended_early)``, optional
        Timed, after the last chunk, whether the run ended early or not: e.g. one more step
        that gives the last row its force.

    An exception in a hook makes the run an error row with the exception's message; the
    context of ``_open`` is left as usual. An engine that does not step (the exact
    reference) overrides ``_simulate`` instead and has no bare loop.

    **Batches.** :meth:`simulate_batch` runs many worlds (scenes) with one settings (engine,
    profile, variant, timestep) in one call and returns one ``Run`` per world, the same as
    :meth:`simulate` would. By default it loops over single runs. An engine that steps many
    worlds at once declares ``batches = True`` and implements the batch hooks; the loop is
    again the base class's (``_simulate_batch``): every world takes its own window's steps
    in the same chunks as a single run (chunk ends at multiples of ``CHUNK_STEPS`` and at its
    window's end), is checked for divergence and fed to its own ``StopMonitor`` at each of
    its chunk ends, and stops being stepped and recorded once it diverges, stops or reaches
    its window's end; the batch ends when every world has. ``W`` is the batch's world count,
    world ``i`` is ``scenes[i]``:

    ``_open_batch(module, scenes, settings, options)``, a context manager giving ``batch``
        Build one world per scene, each at its scene's initial state, ready to step from
        t = 0; release what they hold on exit.
    ``_batch_state(batch) -> (W, 6)``
        Every world's centre-of-mass state now, columns ``STATE_KEYS`` (m, rad, m/s, rad/s,
        the frame of ``kinematics.com_state``).
    ``_batch_step(batch, active)``
        One step of the worlds where ``active`` (bool, (W,)) is True. An engine may step the
        others too (a GPU steps all worlds): their results are not read.
    ``_batch_force(batch) -> (W, 2)``
        Every world's contact force on the hoop over the step just taken, N: normal (+Y, up)
        and friction (+X), the engine's own (row i of a trajectory holds the force of the
        step taken from state i, as ``states_and_step_forces``).
    ``_batch_advance(batch, active, steps) -> (states (W, steps + 1, 6), forces (W, steps, 2))``,
        optional. ``steps`` steps of the active worlds: the states before the chunk and
        after each step, and each step's force. The default calls the three hooks above
        per step; an engine that can take many steps in one call (MuJoCo's rollout)
        overrides it. Rows of inactive worlds are ignored.
    ``_batch_diverged(batch, active) -> [str | None] * W``, optional
        The engine's own divergence reasons after a chunk (as ``_diverged``), or
        ``RUN_ALONE`` for a world the batch cannot step as its single run would: it leaves
        the batch and runs again alone. Default None.
    ``_batch_shapes(batch) -> [Polygon | None] * W``, optional
        Each world's contact shape (as ``_contact_shape``). Default None: circles.

    A world that reaches its window's end takes one more step for its last state's force
    (not counted in ``n_steps``); a world that diverged or stopped early does not, and its
    last state, which has no force, is dropped (the timing of MuJoCo's single runs). An
    exception in a batch hook makes every run of the batch an error row. The batch's cost
    (``BatchCost``: worlds, wall time, world-steps) goes to every run's ``RunInfo.batch``.
    """

    name: ClassVar[str]
    """Engine name on the command line and in the runs table."""
    distribution: ClassVar[str]
    """Installed distribution whose version a run records (importlib.metadata)."""
    modules: ClassVar[tuple[str, ...]] = ()
    """Modules a run imports (the first is the engine package); none are imported before."""
    geometries: ClassVar[tuple[str, ...]] = ("sphere",)
    """Contact geometries; the first is the default. sphere: the hoop's exact circle."""
    options: ClassVar[tuple[Option, ...]] = ()
    """The engine's own knobs, real names, with hoopbench's defaults and their reasons."""
    variants: ClassVar[tuple[Variant, ...]] = ()
    """Settings a suite runs beside the defaults, to show what one knob does."""
    model_format: ClassVar[str | None] = None
    """What ``hoopbench model`` writes for this engine (None: nothing)."""
    model_note: ClassVar[str | None] = None
    """For an engine without a model file: how it builds its model instead, the one line
    ``hoopbench model`` gives."""
    batches: ClassVar[bool] = False
    """True: the engine steps many worlds in one call (the batch hooks), and the runner
    groups a suite's or a map's runs of one settings into batches for it."""
    steps_worlds_apart: ClassVar[bool] = False
    """A batching engine that steps only the worlds still running (MuJoCo: a rollout of the
    active worlds), so that a batch costs its worlds' own steps summed, each to its own end
    (a map's point stops at its own stop rule). False: each call steps all of its worlds
    until its last one ends (MJX's vmap of a call of 8 worlds, MuJoCo Warp's and Newton's
    device step of every world), a batch's cost its longest world's steps times its worlds.
    The ETA's costing reads it (reports/compare/costs.py, batch_world_steps)."""
    worlds_per_call: ClassVar[int] = 1
    """Worlds a batching engine's call costs the same for, whatever the batch's size (MJX pads
    every call to it; a Newton step on a CPU is its kernel launches): the runner splits no
    settings' runs into batches smaller than this, as a smaller batch costs as much as a
    full one."""
    last_force_in_chunk: ClassVar[bool] = False
    """A batching engine whose ``_batch_advance`` may take the one more step of the worlds'
    last force in the same call as their last chunk, when every world still stepped ends its
    window there (a batch of one settings on one scene window, the suites' case): one call
    less per batch. The step's state is not recorded, its force only for the worlds that
    reach their window's end, as with a call of its own. MuJoCo sets it: a 100-step world
    paid about a third of its stepping again for that second call. An engine that compiles
    its call per step count keeps False (a count more to compile)."""
    step_cost_bound: ClassVar[float] = 5e-4
    """The most a step of a run may cost on a loaded CPU (s): a suite's or a map's time limit
    allows it for every step of the run. 0.5 ms is 50 times the dearest step of the engines
    that step one world in C or Rust (about 10 us: MuJoCo RK4, PyBullet)."""
    compiled_cache: ClassVar[str | None] = None
    """The folder under :func:`cache_folder` where the engine keeps the code it compiles
    between processes (None: it compiles nothing). While it holds nothing, a worker's first
    call of the engine or the machine's first call of a kind compiles (the ETA's priors
    know which: reports/compare/costs.py, COLD_CACHE_S)."""
    gpu_only: ClassVar[str | None] = None
    """Why the engine's runs pay off only on a GPU (None: they pay off on a CPU too): a suite
    sized to the machine (``sized_to_machine``) runs them only where a GPU is present, and
    leaves them to the suites that run everything (full) otherwise, saying so. MuJoCo Warp
    declares it; an engine with only one such setting says it in :meth:`gpu_only_reason`
    instead (Newton, for its MuJoCo solver: MuJoCo Warp inside Newton)."""

    def __init__(
        self,
        detectors: DetectorSettings | None = None,
        limits: DivergenceLimits | None = None,
    ) -> None:
        self.detectors = detectors or DetectorSettings()
        self.limits = limits or DivergenceLimits()

    # ----------------------------------------------------------------- declarations
    @classmethod
    def defaults(cls, profile: Profile = Profile.TUNED) -> dict[str, Any]:
        """Option name -> its value in the profile (tuned: hoopbench's default)."""
        return {option.name: option.value(profile) for option in cls.options}

    @classmethod
    def resolve(cls, settings: RunSettings) -> dict[str, Any]:
        """The full, checked option dict of a run: defaults overlaid with settings.options.

        ValueError names an unknown geometry or option, or a bad value and what is allowed.
        """
        if settings.geometry not in cls.geometries:
            raise ValueError(
                f"geometry {settings.geometry!r} is not available for {cls.name}; "
                f"choose one of {', '.join(cls.geometries)}"
            )
        declared = {option.name: option for option in cls.options}
        unknown = sorted(set(settings.options) - set(declared))
        if unknown:
            known = ", ".join(declared) or "none"
            raise ValueError(f"unknown {cls.name} setting(s) {', '.join(unknown)}; known: {known}")
        values = {**cls.defaults(settings.profile), **settings.options}
        return {name: declared[name].check(name, value) for name, value in values.items()}

    gpu_finder: ClassVar[str] = "NVIDIA Warp"
    """What finds the GPU the engine's runs pick by default (:meth:`sees_gpu`), for the
    report's sentence on runs left out for want of one."""

    @classmethod
    def sees_gpu(cls) -> bool:
        """Whether the device the engine's runs pick by default is a GPU on this machine: the
        question a suite sized to the machine asks of an engine with runs that pay off only
        on one. NVIDIA Warp's CUDA device (:func:`warp_sees_gpu`) unless the engine says
        otherwise (MJX: JAX's)."""
        return warp_sees_gpu()

    @classmethod
    def gpu_only_reason(cls, options: Mapping[str, Any]) -> str | None:
        """Why runs with these full option values (:meth:`resolve`'s) pay off only on a GPU,
        or None: the engine's ``gpu_only`` unless it overrides this for one setting."""
        return cls.gpu_only

    # ----------------------------------------------------------------- hooks
    def _import(self) -> ModuleType:
        """Import the engine; EngineUnavailableError if it cannot be used."""
        return import_engine(*self.modules)

    def _open(
        self,
        module: ModuleType,
        scene: Scene,
        settings: RunSettings,
        options: dict[str, Any],
        *,
        record: bool,
    ) -> AbstractContextManager[Any]:
        """The run's model at its initial state (class docstring)."""
        raise self._no_hook("_open")

    def _advance(self, run: Any, done: int, steps: int, last: bool) -> Chunk:
        """Take and record ``steps`` steps from step ``done`` (class docstring)."""
        raise self._no_hook("_advance")

    def _trajectory(self, run: Any, done: int, ended_early: bool) -> Trajectory:
        """The recorded trajectory after ``done`` steps (class docstring)."""
        raise self._no_hook("_trajectory")

    def _step_bare(self, run: Any, steps: int) -> None:
        """Step a bare model ``steps`` times, reading nothing (class docstring)."""
        raise self._no_hook("_step_bare")

    def _diverged(self, run: Any) -> str | None:
        """The engine's own divergence reason after a chunk, or None."""
        return None

    def _contact_shape(self, run: Any) -> kinematics.Polygon | None:
        """The run's contact shape (None: the hoop's circle)."""
        return None

    def _finish(self, run: Any, ended_early: bool) -> None:
        """Anything timed after the last chunk (e.g. a step for the last force)."""
        return None

    # ----------------------------------------------------------------- batch hooks
    def _open_batch(
        self,
        module: ModuleType,
        scenes: Sequence[Scene],
        settings: RunSettings,
        options: dict[str, Any],
    ) -> AbstractContextManager[Any]:
        """One world per scene at its initial state (class docstring, Batches)."""
        raise self._no_hook("_open_batch")

    def _batch_state(self, batch: Any) -> np.ndarray:
        """(W, 6): every world's centre-of-mass state now, columns STATE_KEYS."""
        raise self._no_hook("_batch_state")

    def _batch_step(self, batch: Any, active: np.ndarray) -> None:
        """One step of the active worlds ((W,) bool)."""
        raise self._no_hook("_batch_step")

    def _batch_force(self, batch: Any) -> np.ndarray:
        """(W, 2): every world's (normal, friction) contact force of the last step, N."""
        raise self._no_hook("_batch_force")

    def _batch_advance(
        self, batch: Any, active: np.ndarray, steps: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """``steps`` steps of the active worlds: states (W, steps + 1, 6), the one before
        the chunk first, and forces (W, steps, 2), N, of each step."""
        states = [self._batch_state(batch)]
        forces = []
        for _ in range(steps):
            self._batch_step(batch, active)
            states.append(self._batch_state(batch))
            forces.append(self._batch_force(batch))
        return np.stack(states, axis=1), np.stack(forces, axis=1)

    def _batch_diverged(self, batch: Any, active: np.ndarray) -> Sequence[str | None]:
        """The engine's own divergence reason per world after a chunk, or None."""
        return [None] * len(active)

    def _batch_shapes(self, batch: Any) -> Sequence[kinematics.Polygon | None] | None:
        """Each world's contact shape; None (the default): every world's is the circle."""
        return None

    def _no_hook(self, hook: str) -> NotImplementedError:
        return NotImplementedError(f"engine {self.name} does not step: it implements no {hook}")

    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        """Raise ValueError for a scene or settings the engine cannot represent."""
        return None

    def _model_text(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        note = f": {self.model_note}" if self.model_note else ""
        raise ValueError(f"engine {self.name} reads no model file{note}")

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        """The engine's part of a standalone script (engines/standalone.py): its imports and a
        function ``simulate()`` returning the run's states and forces per unit mass."""
        raise ValueError(f"engine {self.name} has no standalone export")

    # ----------------------------------------------------------------- public
    def version(self) -> str | None:
        return _installed_version(self.distribution, tuple(sys.path))

    def mu_for(self, scene: Scene, settings: RunSettings) -> float:
        """The friction coefficient a run uses: settings.mu, else the scene's static mus."""
        return scene.mus if settings.mu is None else settings.mu

    def check(self, scene: Scene, settings: RunSettings) -> dict[str, Any]:
        """Everything about a run that can be checked before it starts; the options dict.

        ValueError for a bad option, a timestep longer than the window, or a run that needs
        more steps than settings.max_steps (the message gives the estimate).
        """
        options = self.resolve(settings)
        check_window(scene, settings)
        self._check(scene, settings, options)
        return options

    def model_text(self, scene: Scene, settings: RunSettings | None = None) -> str:
        """The engine's native model of the scene, as a run with these settings loads it."""
        settings = settings or RunSettings()
        return self._model_text(scene, settings, self.check(scene, settings))

    @classmethod
    def exports(cls) -> bool:
        """True if the engine writes standalone scripts (implements ``_script``)."""
        return cls._script is not Engine._script

    def export_script(
        self, scene: Scene, settings: RunSettings | None = None, *, command: list[str] | None = None
    ) -> str:
        """A standalone Python script that reproduces :meth:`simulate`'s run of ``scene`` with
        the engine's own API alone and writes its trajectory as CSV (engines/standalone.py).

        ValueError for settings :meth:`check` refuses, a geometry other than the hoop's
        circle, or an engine without an export. ``command``: the command line, for the
        script's header."""
        settings = settings or RunSettings()
        options = self.check(scene, settings)
        if settings.geometry != EXPORT_GEOMETRY:
            raise ValueError(
                f"export writes only the default geometry ({EXPORT_GEOMETRY}), got "
                f"geometry {settings.geometry!r}"
            )
        return standalone_script(
            engine=self.name,
            release=self.version(),
            scene=scene,
            timestep=settings.timestep,
            n_steps=n_steps_for(scene, settings.timestep),
            mu=self.mu_for(scene, settings),
            restitution=settings.restitution,
            settings={**settings.to_dict(), **options},
            engine_part=self._script(scene, settings, options),
            command=command,
        )

    def simulate(self, scene: Scene, settings: RunSettings | None = None) -> Run:
        """Step the scene. Bad settings raise ValueError; engine failures return a status."""
        settings = settings or RunSettings()
        options = self.check(scene, settings)
        try:
            module = self._import()
        except EngineUnavailableError as exc:
            return self._failed_run(scene, settings, RunStatus.UNAVAILABLE, str(exc), None)
        try:
            sim = self._simulate(module, scene, settings, options)
        except Exception as exc:  # an engine failure is a result, not a crash
            text = _last_line(exc)
            return self._failed_run(scene, settings, RunStatus.ERROR, text, self.version())
        return self._finished_run(scene, settings, sim)

    def simulate_batch(
        self,
        scenes: Sequence[Scene],
        settings: RunSettings | None = None,
        *,
        stops: Sequence[StopRule | None] | None = None,
    ) -> list[Run]:
        """Step many scenes (worlds) with one settings: one Run per scene, in order, as
        :meth:`simulate` gives it. ``stops``: each world's own stop rule in place of
        ``settings.stop`` (a hop map's runs stop after their own settling time). An engine
        that declares ``batches`` steps the worlds together (class docstring, Batches); any
        other runs them one by one. Bad settings, or a scene a run could not take, raise
        ValueError before anything is stepped."""
        settings = settings or RunSettings()
        scenes = list(scenes)
        if stops is not None and len(stops) != len(scenes):
            raise ValueError(f"{len(stops)} stop rules for {len(scenes)} scenes")
        each = [
            settings if stops is None else settings.with_(stop=stop)
            for stop in stops or [None] * len(scenes)
        ]
        options = [self.check(scene, s) for scene, s in zip(scenes, each, strict=True)]
        if not self.batches:
            return [self.simulate(scene, s) for scene, s in zip(scenes, each, strict=True)]
        if not scenes:
            return []
        try:
            module = self._import()
        except EngineUnavailableError as exc:
            status, text = RunStatus.UNAVAILABLE, str(exc)
            return [
                self._failed_run(scene, s, status, text, None)
                for scene, s in zip(scenes, each, strict=True)
            ]
        try:
            sims, cost = self._simulate_batch(module, scenes, each, options[0])
        except Exception as exc:  # an engine failure is a result, not a crash
            status, text, found = RunStatus.ERROR, _last_line(exc), self.version()
            return [
                self._failed_run(scene, s, status, text, found)
                for scene, s in zip(scenes, each, strict=True)
            ]
        return [
            self.simulate(scene, s)
            if sim.diverged == RUN_ALONE
            else self._finished_run(scene, s, sim, cost)
            for scene, s, sim in zip(scenes, each, sims, strict=True)
        ]

    def _run_info(self, scene: Scene, settings: RunSettings, **fields: Any) -> RunInfo:
        return RunInfo(
            engine=self.name,
            mu=self.mu_for(scene, settings),
            timestep=settings.timestep,
            settings=settings.to_dict(),
            **fields,
        )

    def _failed_run(
        self,
        scene: Scene,
        settings: RunSettings,
        status: RunStatus,
        message: str,
        engine_version: str | None,
    ) -> Run:
        """A run that produced nothing: unavailable (no version) or an engine error."""
        info = self._run_info(
            scene, settings, engine_version=engine_version, status=status, message=message
        )
        return Run(None, info)

    def _finished_run(
        self,
        scene: Scene,
        settings: RunSettings,
        sim: Simulation,
        batch: BatchCost | None = None,
    ) -> Run:
        """The Run of a simulation that returned, with its status."""
        if sim.failed:
            status, message = RunStatus.ERROR, sim.failed
        elif sim.diverged:
            status, message = RunStatus.DIVERGED, sim.diverged
        else:
            status, message = RunStatus.OK, ""
        info = self._run_info(
            scene,
            settings,
            engine_version=self.version(),
            status=status,
            message=message,
            wall_time_s=sim.wall_time_s,
            cpu_time_s=sim.cpu_time_s,
            n_steps=sim.n_steps,
            stop_reason=None if sim.stop_reason is None else str(sim.stop_reason),
            batch=batch,
        )
        return Run(sim.trajectory, info, sim.exact_events)

    def run(self, scene: Scene, settings: RunSettings | None = None) -> RunResult:
        """Simulate, then judge with this engine's detectors."""
        return judge(self.simulate(scene, settings), self.detectors, scene)

    def run_batch(
        self,
        scenes: Sequence[Scene],
        settings: RunSettings | None = None,
        *,
        stops: Sequence[StopRule | None] | None = None,
    ) -> list[RunResult]:
        """Simulate a batch (:meth:`simulate_batch`), then judge each run."""
        scenes = list(scenes)
        runs = self.simulate_batch(scenes, settings, stops=stops)
        return [judge(run, self.detectors, scene) for run, scene in zip(runs, scenes, strict=True)]

    def bare_loop_time(self, scene: Scene, settings: RunSettings | None = None) -> float:
        """Wall time, s, of stepping the run's model as many times as a run would, reading
        and recording nothing, with the garbage collector off: the engine's own cost, the
        yardstick for a run's ``wall_time_s``, measured alike for every engine.

        ValueError for bad settings (as :meth:`check`), EngineUnavailableError if the engine
        cannot be imported, NotImplementedError for an engine that does not step.
        """
        settings = settings or RunSettings()
        options = self.check(scene, settings)
        module = self._import()
        n_steps = n_steps_for(scene, settings.timestep)
        with self._open(module, scene, settings, options, record=False) as run, _collector_paused():
            start = time.perf_counter()
            self._step_bare(run, n_steps)
            return time.perf_counter() - start

    # ----------------------------------------------------------------- the loop
    def _simulate(
        self, module: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> Simulation:
        """Step the scene from t = 0 for ``n_steps_for(scene, settings.timestep)`` steps, or
        until it diverges or its monitor stops it: the loop of the class docstring."""
        with self._open(module, scene, settings, options, record=True) as run:
            with _collector_paused():
                start, cpu_start = time.perf_counter(), time.process_time()
                done, diverged, stopped = self._step_chunks(run, scene, settings)
                ended_early = diverged is not None or stopped is not None
                self._finish(run, ended_early)
                wall = time.perf_counter() - start
                cpu = time.process_time() - cpu_start
            trajectory = self._trajectory(run, done, ended_early)
        return Simulation(
            trajectory=trajectory,
            n_steps=len(trajectory) - 1,
            wall_time_s=wall,
            cpu_time_s=cpu,
            diverged=diverged,
            stop_reason=stopped,
        )

    def _step_chunks(
        self, run: Any, scene: Scene, settings: RunSettings
    ) -> tuple[int, str | None, StopReason | None]:
        """Advance chunk by chunk to the window's end, a divergence or the monitor's stop:
        (steps taken, divergence reason or None, stop reason or None)."""
        n_steps = n_steps_for(scene, settings.timestep)
        shape = self._contact_shape(run)
        monitor = StopMonitor.for_run(
            scene, settings.stop, settings.timestep, detectors=self.detectors, shape=shape
        )
        done = 0
        while done < n_steps:
            steps = min(CHUNK_STEPS, n_steps - done)
            chunk = self._advance(run, done, steps, done + steps == n_steps)
            done += steps
            diverged = self._diverged(run) or check_divergence(
                scene, chunk.state, self.limits, shape
            )
            if diverged:
                return done, diverged, None
            stopped = monitor.feed(chunk.state, chunk.last_step) if monitor else None
            if stopped:
                return done, None, stopped
        return done, None, None

    def _simulate_batch(
        self,
        module: ModuleType,
        scenes: Sequence[Scene],
        settings: Sequence[RunSettings],
        options: dict[str, Any],
    ) -> tuple[list[Simulation], BatchCost]:
        """Step every world of the batch from t = 0 until it reaches its window's end,
        diverges or is stopped: the loop of the class docstring (Batches). ``settings``:
        each world's, the same but for their stop rules."""
        with self._open_batch(module, scenes, settings[0], options) as batch:
            shapes = self._batch_shapes(batch)
            worlds = _Worlds(scenes, settings, shapes, self.detectors, self.limits)
            with _collector_paused():
                start, cpu_start = time.perf_counter(), time.process_time()
                while (active := worlds.active).any():
                    steps = worlds.chunk_steps()
                    # The last force's step in this call: every world still stepped ends here.
                    extra = int(self.last_force_in_chunk and worlds.all_end_after(steps))
                    states, forces = self._batch_advance(batch, active, steps + extra)
                    worlds.record(states[:, : steps + 1], forces[:, :steps])
                    ends = worlds.at_chunk_end()
                    finishing = worlds.judge_chunk(ends, self._batch_diverged(batch, active))
                    if finishing.any():  # the last state's force: one step more
                        if not extra:
                            _, forces = self._batch_advance(batch, finishing, 1)
                        worlds.finish(finishing, forces[:, -1])
                wall = time.perf_counter() - start
                cpu = time.process_time() - cpu_start
        return worlds.simulations(wall, cpu)


class _Worlds:
    """The per-world bookkeeping of a batch: what each world has recorded, whether it is
    still stepped, and how it ended. All active worlds have taken the same steps. A chunk is
    kept as the adapter gave it, one block for all its worlds, and checked across them at
    once (DivergenceScreen); only a world with a monitor, a reason or an end is handled
    alone."""

    def __init__(
        self,
        scenes: Sequence[Scene],
        settings: Sequence[RunSettings],
        shapes: Sequence[kinematics.Polygon | None] | None,
        detectors: DetectorSettings,
        limits: DivergenceLimits,
    ) -> None:
        self.scenes, self.timestep = list(scenes), settings[0].timestep
        self.shapes = list(shapes) if shapes is not None else [None] * len(self.scenes)
        self.n_steps = np.array([n_steps_for(s, self.timestep) for s in self.scenes])
        self.monitors = [
            StopMonitor.for_run(s, rule.stop, self.timestep, detectors=detectors, shape=p)
            for s, rule, p in zip(self.scenes, settings, self.shapes, strict=True)
        ]
        self.watched = np.array([monitor is not None for monitor in self.monitors])
        self.any_watched = bool(self.watched.any())
        self.screen = DivergenceScreen(self.scenes, self.shapes, limits)
        self.active = np.ones(len(self.scenes), dtype=bool)
        self.done = 0
        # Per chunk: the worlds stepped (ids), their states (n, steps + 1, 6) and forces
        # (n, steps, 2); a chunk's first state row restates the previous chunk's last one.
        self.chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
        self.last_force: dict[int, np.ndarray] = {}
        self.diverged: list[str | None] = [None] * len(self.scenes)
        self.stopped: list[StopReason | None] = [None] * len(self.scenes)
        self._windows()

    def _windows(self) -> None:
        """The active worlds' indices, and their first and last window ends, steps (Python
        ints, read each chunk; 0 when none is active)."""
        self.stepped = np.flatnonzero(self.active)
        ends = self.n_steps[self.stepped]
        self.first_end, self.last_end = (int(ends.min()), int(ends.max())) if len(ends) else (0, 0)

    def chunk_steps(self) -> int:
        """Steps to the next chunk end of any active world (a multiple of CHUNK_STEPS or a
        window's end), as a single run chunks its window."""
        return min(CHUNK_STEPS - self.done % CHUNK_STEPS, self.first_end - self.done)

    def all_end_after(self, steps: int) -> bool:
        """Whether every active world reaches its window's end after ``steps`` more steps."""
        return self.first_end == self.last_end == self.done + steps

    def record(self, states: np.ndarray, forces: np.ndarray) -> None:
        """Keep the active worlds' chunk: states (W, steps + 1, 6), forces (W, steps, 2)."""
        ids = self.stepped
        if len(ids) == len(self.active):  # copies: an adapter may reuse its buffers
            self.chunks.append((ids, np.array(states), np.array(forces)))
        else:
            self.chunks.append((ids, states[ids], forces[ids]))
        self.done += forces.shape[1]

    def at_chunk_end(self) -> np.ndarray:
        """(W,) bool: the active worlds whose chunk ends here."""
        if self.done % CHUNK_STEPS == 0:
            return self.active.copy()
        return self.active & (self.n_steps == self.done)

    def judge_chunk(self, ends: np.ndarray, reasons: Sequence[str | None]) -> np.ndarray:
        """Check the worlds whose chunk ended, as a single run does (the engine's reason,
        divergence, the monitor); retire those that end. (W,) bool: the worlds that reached
        their window's end, which need one more step for their last force."""
        stepped, states, _ = self.chunks[-1]
        ids = np.flatnonzero(ends)
        rows = states if len(ids) == len(stepped) else states[np.searchsorted(stepped, ids)]
        checked, clear = self.screen.reasons(ids, rows)
        finishing = ends & (self.n_steps <= self.done)
        ended = finishing.copy()
        # Worlds with a reason or a monitor, one by one; the others pass or finish.
        alone: Sequence[int] = ()
        if checked is not None or any(reasons):
            alone = range(len(ids))
        elif self.any_watched:
            alone = np.flatnonzero(self.watched[ids]).tolist()
        for row in alone:
            i = int(ids[row])
            diverged = reasons[i] or (checked[row] if checked is not None else None)
            monitor = self.monitors[i]
            if diverged:
                self.diverged[i] = diverged
            elif monitor and (
                stopped := monitor.feed(
                    _columns(rows[row]), self.done, None if clear is None else clear[row]
                )
            ):
                self.stopped[i] = stopped
            else:
                continue
            finishing[i], ended[i] = False, True
        if ended.any():
            self.active &= ~ended
            self._windows()
        return finishing

    def finish(self, finishing: np.ndarray, forces: np.ndarray) -> None:
        """The force (W, 2) of the step from each finishing world's last state."""
        for i in np.flatnonzero(finishing).tolist():
            self.last_force[i] = np.array(forces[i : i + 1])

    def simulations(self, wall: float, cpu: float) -> tuple[list[Simulation], BatchCost]:
        """Each world's Simulation (its wall and CPU times: its shares of the batch's, by
        steps), and the batch's cost."""
        trajectories = [self._trajectory(i) for i in range(len(self.scenes))]
        steps = np.array([len(t) - 1 for t in trajectories])
        total = int(steps.sum())
        cost = BatchCost(size=len(self.scenes), wall_time_s=wall, world_steps=total, cpu_time_s=cpu)
        sims = [
            Simulation(
                trajectory=trajectory,
                n_steps=int(n),
                wall_time_s=wall * n / total if total else 0.0,
                cpu_time_s=cpu * n / total if total else 0.0,
                diverged=self.diverged[i],
                stop_reason=self.stopped[i],
            )
            for i, (trajectory, n) in enumerate(zip(trajectories, steps, strict=True))
        ]
        return sims, cost

    def _trajectory(self, i: int) -> Trajectory:
        """World i's trajectory: every state that has a force (Trajectory.from_state)."""
        scene = self.scenes[i]
        state_blocks: list[np.ndarray] = []
        force_blocks: list[np.ndarray] = []
        for ids, states, forces in self.chunks:
            row = int(np.searchsorted(ids, i))
            if row < len(ids) and ids[row] == i:
                if state_blocks:  # the chunk's first row restates the previous one's last
                    state_blocks[-1] = state_blocks[-1][:-1]
                state_blocks.append(states[row])
                force_blocks.append(forces[row])
        if i in self.last_force:
            force_blocks.append(self.last_force[i])
        states = np.concatenate(state_blocks)
        forces = np.concatenate(force_blocks) / scene.M
        n = len(forces)  # an early end has no force for its last state: dropped
        columns = {key: np.ascontiguousarray(states[:n, k]) for k, key in enumerate(STATE_KEYS)}
        return Trajectory.from_steps(
            scene,
            self.timestep,
            columns,
            normal_force=np.ascontiguousarray(forces[:, 0]),
            friction_force=np.ascontiguousarray(forces[:, 1]),
            shape=self.shapes[i],
        )


def _last_line(exc: BaseException) -> str:
    """An exception's one-line text, as a run's error message gives it."""
    return traceback.format_exception_only(type(exc), exc)[-1].strip()


@contextmanager
def _collector_paused() -> Iterator[None]:
    """The garbage collector off, as it was on exit: a stepping loop makes many short-lived
    floats and no cycles, and a collection's rescans would be timed as the engine's cost."""
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()


def equilibrium_depth(
    vertical_acceleration: Callable[[float], float],
    a: float,
    *,
    first: float,
    xtol: float,
    maxiter: int = 100,
) -> float:
    """Penetration, m, at which a soft contact holds the hoop centre with zero vertical
    acceleration; 0 if the hoop, exactly touching, would leave the floor, or if no
    equilibrium lies within 1 % of the radius (then it starts touching).

    ``vertical_acceleration(depth)`` rises monotonically as the hoop sinks, so a doubling
    bracket from ``first * a`` and Brent's method find its zero.
    """
    if vertical_acceleration(0.0) >= 0.0:
        return 0.0
    lo, hi = 0.0, first * a
    while vertical_acceleration(hi) < 0.0:
        lo, hi = hi, 2.0 * hi
        if hi > 1e-2 * a:
            return 0.0
    from scipy.optimize import brentq

    return float(brentq(vertical_acceleration, lo, hi, xtol=xtol, rtol=1e-12, maxiter=maxiter))


def states_and_step_forces(
    first: np.ndarray, blocks: Sequence[np.ndarray], last: Sequence[float]
) -> tuple[np.ndarray, np.ndarray]:
    """A run's recorded states, and beside each the force of the step taken from it: the
    row convention of every adapter that reads its force after each step.

    ``first``: the initial state (one row, or a row's values); ``blocks``: the rows recorded
    after each step, the state the step reached and then that step's force (or impulse);
    ``last``: the force of the step ``_finish`` took from the last state. Row i of the
    forces is the force that took the state from row i to row i + 1.
    """
    first = np.atleast_2d(first)
    width = first.shape[1] + len(last)
    rows = np.concatenate(blocks) if len(blocks) else np.empty((0, width))
    states = np.concatenate([first, rows[:, : first.shape[1]]])
    forces = np.concatenate([rows[:, first.shape[1] :], np.atleast_2d(last)])
    return states, forces


def call_repeatedly(step: Callable[..., object], times: int, *args: object) -> None:
    """``step(*args)``, ``times`` times: the bare loop (``_step_bare``) of an engine stepped
    one call per step from Python."""
    for _ in range(times):
        step(*args)


def n_steps_for(scene: Scene, timestep: float) -> int:
    """Steps a run takes: the whole steps that fit in [0, scene.t_end] (never past it)."""
    return steps_in(scene.t_end, timestep)


def steps_to_stop(scene: Scene, timestep: float, t_stop: float | None) -> int:
    """Steps a run takes whose StopMonitor decides at ``t_stop`` (s; None: it never does):
    to the end of that chunk, as the stepping loop feeds the monitor a chunk at a time and
    chunks end at multiples of CHUNK_STEPS (``_step_chunks``, a batch's loop alike); at most
    the window's steps."""
    window = n_steps_for(scene, timestep)
    if t_stop is None:
        return window
    chunks = max(1, math.ceil(t_stop / timestep / CHUNK_STEPS))  # the deciding step's chunk
    return min(window, chunks * CHUNK_STEPS)


def steps_in(t_end: float, timestep: float) -> int:
    """The whole steps of ``timestep`` (s) that fit in [0, t_end] (s); the guard keeps a
    window that is a whole number of steps from losing its last one to round-off."""
    return math.floor(t_end / timestep * (1.0 + 1e-12))


def check_window(scene: Scene, settings: RunSettings) -> None:
    """ValueError for a timestep longer than the window or a run over settings.max_steps."""
    check_steps(scene.t_end, settings.timestep, settings.max_steps)


def check_steps(t_end: float, timestep: float, max_steps: int) -> int:
    """The steps of a run over [0, t_end] (s) at ``timestep`` (s): the one check of a run's
    window, for a run and for a sweep's settings before any run starts. ValueError for a
    timestep longer than the window or a run over ``max_steps`` (a step so small that the
    count is past any float, 1e-320 s, included)."""
    dt = timestep
    if dt > t_end:
        raise ValueError(f"timestep {dt:g} s is longer than the window t_end = {t_end:g} s")
    steps = t_end / dt  # inf for a subnormal step: compared as a float, never made an int
    if steps > max_steps and (not math.isfinite(steps) or steps_in(t_end, dt) > max_steps):
        size = (
            f"{steps:.3g} steps (t_end {t_end:g} s / timestep {dt:g} s, "
            f"about {steps * BYTES_PER_STEP / 1e9:.3g} GB)"
            if math.isfinite(steps)
            else f"more steps than a float counts (t_end {t_end:g} s / timestep {dt:g} s)"
        )
        raise ValueError(
            f"the run needs {size}, over max_steps = {max_steps:.3g}: "
            "shorten t_end, raise the timestep, or raise max_steps"
        )
    return steps_in(t_end, dt)


class WorldsEngine(Engine):
    """An engine that steps many worlds in one call (MJX, MuJoCo Warp, Newton): it
    implements ``_open_batch`` and ``_batch_advance`` (the class docstring of
    :class:`Engine`, Batches), and a single run is the batch loop on one world, so that a
    lone run's row is its batched row (the same loop, the same chunks). The bare loop steps
    a batch of one through ``_batch_advance`` in chunks: these engines record states as
    they step (on a device, reading nothing back would leave the cost unmeasured)."""

    batches: ClassVar[bool] = True

    def _simulate(
        self, module: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> Simulation:
        sims, _ = self._simulate_batch(module, [scene], [settings], options)
        return sims[0]

    @contextmanager
    def _open(
        self,
        module: ModuleType,
        scene: Scene,
        settings: RunSettings,
        options: dict[str, Any],
        *,
        record: bool,
    ) -> Iterator[Any]:
        with self._open_batch(module, [scene], settings, options) as batch:
            yield batch

    def _step_bare(self, run: Any, steps: int) -> None:
        done = 0
        while done < steps:
            chunk = min(CHUNK_STEPS, steps - done)
            self._batch_advance(run, _ONE_WORLD, chunk)
            done += chunk


_ONE_WORLD = np.ones(1, dtype=bool)
"""The ``active`` mask of a batch of one world."""


DEVICES: tuple[str, ...] = ("auto", "cpu", "gpu")
"""Where a batched engine runs. auto: a GPU if the engine sees one, else the CPU."""

DEVICE = Option(
    "device",
    "auto",
    choice(*DEVICES),
    "the engine's own choice: a GPU where there is one, else the CPU (the CI and the "
    "measurements here have no GPU: every figure is the CPU's)",
    outside_search="where the worlds run: it changes the cost, and the events only by round-off",
)
"""The ``device`` option of the batched engines (MJX, MuJoCo Warp, Newton)."""


POOL_WORKERS_VARIABLE = "HOOPBENCH_POOL_WORKERS"
"""Set in each worker of a pool of processes (reports/sweep/runner.py) to the pool's size: the
workers share the machine's cores, and an engine with a thread pool of its own sizes it to its
process's share (:func:`cores_per_process`)."""


def cores_per_process() -> int:
    """This process's share of the machine's cores: all of them for a process alone, ``cores //
    workers`` (at least 1) for a worker of a pool, where more threads than cores would only hand
    work between threads that the other workers' calls are waiting for."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    try:
        workers = max(1, int(os.environ.get(POOL_WORKERS_VARIABLE, "1")))
    except ValueError:
        workers = 1
    return max(1, (cores or 1) // workers)


WARP_CACHE = "warp"
"""NVIDIA Warp's kernel cache, under :func:`cache_folder` (Newton's and MuJoCo Warp's)."""

# hoopbench never takes a gradient, and Warp otherwise generates and compiles every kernel's
# adjoint beside it: off, a cold Newton call compiles in about half the CPU time, with the
# same forward code (trajectories bit for bit; docs/engines.md, Compile caches).
WARP_ENABLE_BACKWARD = False
"""``wp.config.enable_backward`` for MuJoCo Warp and Newton, in the adapters (set by
:func:`import_warp`) and in their exported scripts: Warp's own documented option for users
who need no gradients (no backward kernels generated or compiled). A Warp module takes it
when it is created, at its package's import, so it is set before the engine is imported."""


def cache_folder(engine: str) -> Path:
    """Where an engine keeps its compiled code between processes: ``$HOOPBENCH_CACHE/<engine>``,
    else the user's cache folder (``$XDG_CACHE_HOME`` or ~/.cache) ``/hoopbench/<engine>``."""
    root = os.environ.get("HOOPBENCH_CACHE")
    if root:
        return Path(root) / engine
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "hoopbench" / engine


def warp_device(wp: ModuleType, choice: str) -> str:
    """NVIDIA Warp's device for a run (MuJoCo Warp, Newton): ``cuda:0`` for auto when Warp
    sees a GPU, else ``cpu``; RuntimeError for gpu without one (the run's error row)."""
    gpus = wp.get_cuda_device_count()
    if choice == "cpu" or (choice == "auto" and gpus == 0):
        return "cpu"
    if gpus == 0:
        raise RuntimeError("device gpu: NVIDIA Warp sees no CUDA device")
    return "cuda:0"


_CUDA_DRIVERS = ("libcuda.so", "libcuda.so.1", "nvcuda.dll")
"""The CUDA driver library, as NVIDIA Warp loads it first (its cuda_util.cpp): without it
Warp sees no GPU."""


def warp_sees_gpu() -> bool:
    """Whether NVIDIA Warp, which steps MuJoCo Warp and Newton, sees a CUDA device: the GPU
    their ``device`` auto picks (:func:`warp_device`). Without the CUDA driver library there
    is none, said without importing Warp (seconds, and a warning line on stderr)."""
    if not any(_loads(name) for name in _CUDA_DRIVERS):
        return False
    try:
        wp = import_warp()
    except EngineUnavailableError:
        return False
    return bool(wp.get_cuda_device_count() > 0)


def _loads(library: str) -> bool:
    try:
        ctypes.CDLL(library)
    except OSError:
        return False
    return True


def import_warp() -> ModuleType:
    """NVIDIA Warp, quiet (its start-up banner would go to stdout, which ``--json`` output
    owns), with its kernel cache under :func:`cache_folder`, no backward kernels
    (:data:`WARP_ENABLE_BACKWARD`) and each module compiled by one process at a time
    (engines/warp_compile.py); EngineUnavailableError if it cannot be imported."""
    wp = import_engine("warp")
    wp.config.enable_backward = WARP_ENABLE_BACKWARD  # before the engine's package is imported
    if not wp.config.kernel_cache_dir:
        wp.config.kernel_cache_dir = str(cache_folder(WARP_CACHE))
    wp.config.quiet = True
    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)  # no per-module timings
    share_compiles(wp)  # one process compiles a module, the others load it (warp_compile)
    return wp
