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

import gc
import math
import os
import sys
import time
import traceback
from abc import ABC
from collections.abc import Callable, Iterator, Sequence
from contextlib import AbstractContextManager, contextmanager
from dataclasses import dataclass, field
from functools import partial
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from types import ModuleType
from typing import Any, ClassVar

import numpy as np

from hoopbench.engines.judging.detectors import DetectorSettings
from hoopbench.engines.judging.judge import judge
from hoopbench.engines.options import Option, Profile, Variant, choice
from hoopbench.engines.run import Run, RunInfo, RunResult, RunStatus
from hoopbench.engines.settings import BYTES_PER_STEP, MAX_STEPS, RunSettings
from hoopbench.engines.stopping import StopMonitor, StopReason
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
    "STATE_KEYS",
    "Chunk",
    "DivergenceLimits",
    "Engine",
    "EngineUnavailableError",
    "Simulation",
    "WorldsEngine",
    "cache_folder",
    "check_divergence",
    "check_steps",
    "equilibrium_depth",
    "import_engine",
    "import_warp",
    "n_steps_for",
    "states_and_step_forces",
    "steps_in",
    "warp_device",
    "world_trajectory",
]

CHUNK_STEPS = 1000
"""Steps the loop has an adapter take between divergence checks (and per recording chunk)."""

STATE_KEYS = ("X", "Y", "theta", "Xdot", "Ydot", "thetadot")
"""The centre-of-mass state's components, in the order of a batch hook's last axis (m, m,
rad, m/s, m/s, rad/s)."""


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
    traj_state: dict[str, np.ndarray],
    limits: DivergenceLimits,
    shape: kinematics.Polygon | None = None,
) -> str | None:
    """A reason string if the states (arrays X, Y, theta, ...) show divergence, else None.

    ``shape``: the run's contact shape (None: the hoop's circle), whose lowest point's
    clearance (models/kinematics.py) the penetration limit bounds, as the judge reads it.
    """
    for name, values in traj_state.items():
        if not np.all(np.isfinite(values)):
            return f"non-finite {name}"
    energy = kinematics.energy_per_mass(
        scene, traj_state["Y"], traj_state["Xdot"], traj_state["Ydot"], traj_state["thetadot"]
    )
    e0 = scene.energy_per_mass
    if np.max(energy) > e0 * (1.0 + limits.energy_rise):
        return f"energy rose to {np.max(energy) / e0:.3g} times its initial value"
    clear = kinematics.clearance(scene, traj_state["Y"], traj_state["theta"], shape)
    if np.min(clear) < -limits.penetration * scene.a:
        return f"penetration {-np.min(clear):.3g} m exceeds {limits.penetration} a"
    return None


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
    and finishing step, with the checks) with the garbage collector off, and returns the
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

    def _no_hook(self, hook: str) -> NotImplementedError:
        return NotImplementedError(f"engine {self.name} does not step: it implements no {hook}")

    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        """Raise ValueError for a scene or settings the engine cannot represent."""
        return None

    def _model_text(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        note = f": {self.model_note}" if self.model_note else ""
        raise ValueError(f"engine {self.name} reads no model file{note}")

    # ----------------------------------------------------------------- public
    def version(self) -> str | None:
        try:
            return version(self.distribution)
        except PackageNotFoundError:
            return None

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

    def simulate(self, scene: Scene, settings: RunSettings | None = None) -> Run:
        """Step the scene. Bad settings raise ValueError; engine failures return a status."""
        settings = settings or RunSettings()
        options = self.check(scene, settings)
        run_info = partial(
            RunInfo,
            engine=self.name,
            mu=self.mu_for(scene, settings),
            timestep=settings.timestep,
            settings=settings.to_dict(),
        )
        try:
            module = self._import()
        except EngineUnavailableError as exc:
            info = run_info(engine_version=None, status=RunStatus.UNAVAILABLE, message=str(exc))
            return Run(None, info)
        engine_version = self.version()
        try:
            sim = self._simulate(module, scene, settings, options)
        except Exception as exc:  # an engine failure is a result, not a crash
            last = traceback.format_exception_only(type(exc), exc)[-1].strip()
            info = run_info(engine_version=engine_version, status=RunStatus.ERROR, message=last)
            return Run(None, info)
        if sim.failed:
            status, message = RunStatus.ERROR, sim.failed
        elif sim.diverged:
            status, message = RunStatus.DIVERGED, sim.diverged
        else:
            status, message = RunStatus.OK, ""
        info = run_info(
            engine_version=engine_version,
            status=status,
            message=message,
            wall_time_s=sim.wall_time_s,
            n_steps=sim.n_steps,
            stop_reason=None if sim.stop_reason is None else str(sim.stop_reason),
        )
        return Run(sim.trajectory, info, sim.exact_events)

    def run(self, scene: Scene, settings: RunSettings | None = None) -> RunResult:
        """Simulate, then judge with this engine's detectors."""
        return judge(self.simulate(scene, settings), self.detectors, scene)

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
                start = time.perf_counter()
                done, diverged, stopped = self._step_chunks(run, scene, settings)
                ended_early = diverged is not None or stopped is not None
                self._finish(run, ended_early)
                wall = time.perf_counter() - start
            trajectory = self._trajectory(run, done, ended_early)
        return Simulation(
            trajectory=trajectory,
            n_steps=len(trajectory) - 1,
            wall_time_s=wall,
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


def n_steps_for(scene: Scene, timestep: float) -> int:
    """Steps a run takes: the whole steps that fit in [0, scene.t_end] (never past it)."""
    return steps_in(scene.t_end, timestep)


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
    timestep longer than the window or a run over ``max_steps``."""
    dt = timestep
    if dt > t_end:
        raise ValueError(f"timestep {dt:g} s is longer than the window t_end = {t_end:g} s")
    n_steps = steps_in(t_end, dt)
    if n_steps > max_steps:
        gigabytes = n_steps * BYTES_PER_STEP / 1e9
        raise ValueError(
            f"the run needs {n_steps:.3g} steps (t_end {t_end:g} s / timestep {dt:g} s, "
            f"about {gigabytes:.3g} GB), over max_steps = {max_steps:.3g}: "
            "shorten t_end, raise the timestep, or raise max_steps"
        )
    return n_steps


class WorldsEngine(Engine):
    """An engine that steps many worlds in one call (MJX, MuJoCo Warp, Newton): a single
    run is a batch of one world, so an adapter implements only the batch hooks,

    ``_open_batch(module, scenes, settings, options)``, a context manager giving ``batch``
        One world per scene, each at its scene's initial state, ready to step from t = 0.
    ``_batch_advance(batch, active, steps) -> (states, forces)``
        ``steps`` steps of every world (``active``, (W,) bool, says which are read; a
        batched engine may step them all): the centre-of-mass states before the chunk and
        after each step, (W, steps + 1, 6), columns ``STATE_KEYS``, and the contact force
        on the hoop of each step, (W, steps, 2), N: normal (+Y) and friction (+X), row i
        the force of the step taken from state i (the engine's constraint force at that
        state).

    and this class gives the single-run hooks of :class:`Engine` on a batch of one: the
    window's last chunk takes one step more for the last state's force (MuJoCo's
    convention); a run that diverged or stopped early drops its last state, which has no
    force. The bare loop steps the batch of one through the same hook.
    """

    batches: ClassVar[bool] = True
    """Steps many worlds in one call: the runner groups runs of one settings into batches."""

    def _open_batch(
        self,
        module: ModuleType,
        scenes: Sequence[Scene],
        settings: RunSettings,
        options: dict[str, Any],
    ) -> AbstractContextManager[Any]:
        """One world per scene at its initial state (class docstring)."""
        raise self._no_hook("_open_batch")

    def _batch_advance(
        self, batch: Any, active: np.ndarray, steps: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """States (W, steps + 1, 6) and forces (W, steps, 2), N (class docstring)."""
        raise self._no_hook("_batch_advance")

    @contextmanager
    def _open(
        self,
        module: ModuleType,
        scene: Scene,
        settings: RunSettings,
        options: dict[str, Any],
        *,
        record: bool,
    ) -> Iterator[_OneWorld]:
        with self._open_batch(module, [scene], settings, options) as batch:
            yield _OneWorld(batch, scene, settings.timestep, n_steps_for(scene, settings.timestep))

    def _advance(self, run: _OneWorld, done: int, steps: int, last: bool) -> Chunk:
        states, forces = self._batch_advance(run.batch, _ONE, steps + (1 if last else 0))
        run.states[done : done + steps + 1] = states[0, : steps + 1]
        run.forces[done : done + len(forces[0])] = forces[0]
        chunk = states[0, : steps + 1]
        return Chunk(dict(zip(STATE_KEYS, chunk.T, strict=True)), done + steps)

    def _trajectory(self, run: _OneWorld, done: int, ended_early: bool) -> Trajectory:
        n = done if ended_early else done + 1
        return world_trajectory(run.scene, run.timestep, run.states[:n], run.forces[:n])

    def _diverged(self, run: _OneWorld) -> str | None:
        return None

    def _contact_shape(self, run: _OneWorld) -> kinematics.Polygon | None:
        return None

    def _step_bare(self, run: _OneWorld, steps: int) -> None:
        """The batch hook in chunks: these engines record states as they step (on a device,
        reading nothing back would leave their cost unmeasured)."""
        done = 0
        while done < steps:
            chunk = min(CHUNK_STEPS, steps - done)
            self._batch_advance(run.batch, _ONE, chunk)
            done += chunk


_ONE = np.ones(1, dtype=bool)
"""The ``active`` mask of a batch of one world."""


@dataclass
class _OneWorld:
    """A single run of a :class:`WorldsEngine`: its batch of one and what it recorded."""

    batch: Any
    scene: Scene
    timestep: float
    n_steps: int
    states: np.ndarray = field(init=False)
    """(n_steps + 1, 6): the centre-of-mass state of every row."""
    forces: np.ndarray = field(init=False)
    """(n_steps + 1, 2), N: the force of the step taken from each row."""

    def __post_init__(self) -> None:
        self.states = np.empty((self.n_steps + 1, len(STATE_KEYS)))
        self.forces = np.empty((self.n_steps + 1, 2))


def world_trajectory(
    scene: Scene, timestep: float, states: np.ndarray, forces: np.ndarray
) -> Trajectory:
    """One world's trajectory from its states (n, 6), columns ``STATE_KEYS``, and forces
    (n, 2), N (normal, friction), row i the force of the step from state i."""
    n = len(states)
    return Trajectory.from_state(
        scene,
        t=np.arange(n) * timestep,
        **dict(zip(STATE_KEYS, states.T, strict=True)),
        normal_force=forces[:, 0] / scene.M,
        friction_force=forces[:, 1] / scene.M,
    )


DEVICES: tuple[str, ...] = ("auto", "cpu", "gpu")
"""Where a batched engine runs. auto: a GPU if the engine sees one, else the CPU."""

DEVICE = Option(
    "device",
    "auto",
    choice(*DEVICES),
    "the engine's own choice: a GPU where there is one, else the CPU (the CI and the "
    "measurements here have no GPU: every figure is the CPU's)",
)
"""The ``device`` option of the batched engines (MJX, MuJoCo Warp, Newton)."""


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


def import_warp() -> ModuleType:
    """NVIDIA Warp, quiet (its start-up banner would go to stdout, which ``--json`` output
    owns) and with its kernel cache under :func:`cache_folder`; EngineUnavailableError if
    it cannot be imported."""
    wp = import_engine("warp")
    if not wp.config.kernel_cache_dir:
        wp.config.kernel_cache_dir = str(cache_folder("warp"))
    wp.config.quiet = True
    wp.config.log_level = max(wp.config.log_level, wp.LOG_WARNING)  # no per-module timings
    return wp
