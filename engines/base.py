"""The engine interface: run(scene, settings) -> RunResult(trajectory, events, info).

Every adapter subclasses :class:`Engine` and implements one hook, ``_simulate``. The public
``run`` validates the settings, imports the engine lazily, times nothing but the stepping
(the adapter reports that time), turns any failure into a status instead of an exception,
and applies the shared detectors. A failing or missing engine never stops a sweep.
"""

from __future__ import annotations

import math
import sys
import traceback
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from enum import StrEnum
from types import ModuleType
from typing import Any, ClassVar

import numpy as np

from hoopbench.engines.detectors import DetectorSettings, detect_events
from hoopbench.engines.settings import RunSettings
from hoopbench.models import kinematics
from hoopbench.models.events import Events
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

__all__ = [
    "DivergenceLimits",
    "Engine",
    "EngineUnavailableError",
    "RunInfo",
    "RunResult",
    "RunStatus",
    "Simulation",
    "check_divergence",
    "import_engine",
    "n_steps_for",
]


class RunStatus(StrEnum):
    OK = "ok"
    DIVERGED = "diverged"
    """NaN, runaway energy or deep penetration: detected, the run stopped early."""
    ERROR = "error"
    """The engine raised; the message says what."""
    UNAVAILABLE = "unavailable"
    """The engine is not installed or cannot be imported."""
    TIMEOUT = "timeout"
    """The suite runner stopped the run at its time limit (set by the runner, not by an engine)."""
    CRASHED = "crashed"
    """The worker process running it died twice (segfault, killed for memory, os._exit)."""

    @property
    def is_final(self) -> bool:
        """True for statuses a resumed suite keeps; timeout and crashed are tried again."""
        return self not in (RunStatus.TIMEOUT, RunStatus.CRASHED)


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
    """Largest allowed penetration of the hoop into the floor, as a fraction of a."""


def check_divergence(
    scene: Scene, traj_state: dict[str, np.ndarray], limits: DivergenceLimits
) -> str | None:
    """A reason string if the states (arrays X, Y, theta, ...) show divergence, else None."""
    for name, values in traj_state.items():
        if not np.all(np.isfinite(values)):
            return f"non-finite {name}"
    energy = kinematics.energy_per_mass(
        scene, traj_state["Y"], traj_state["Xdot"], traj_state["Ydot"], traj_state["thetadot"]
    )
    e0 = scene.energy_per_mass
    if np.max(energy) > e0 * (1.0 + limits.energy_rise):
        return f"energy rose to {np.max(energy) / e0:.3g} times its initial value"
    clear = kinematics.clearance(scene, traj_state["Y"], traj_state["theta"])
    if np.min(clear) < -limits.penetration * scene.a:
        return f"penetration {-np.min(clear):.3g} m exceeds {limits.penetration} a"
    return None


@dataclass(frozen=True)
class Simulation:
    """What an adapter's ``_simulate`` returns."""

    trajectory: Trajectory
    n_steps: int
    wall_time_s: float
    """Wall time of the stepping loop alone (model building excluded), s."""
    diverged: str | None = None
    """Reason, if the run was stopped for divergence."""
    exact_events: Events | None = None
    """The reference engine's exact events (None for real engines)."""


@dataclass(frozen=True)
class RunInfo:
    engine: str
    engine_version: str | None
    status: RunStatus
    message: str = ""
    wall_time_s: float | None = None
    """Wall time of the stepping, s."""
    n_steps: int | None = None
    mu: float | None = None
    """The pair's friction coefficient actually used."""
    timestep: float | None = None
    """s."""
    settings: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {
            "engine": self.engine,
            "engine_version": self.engine_version,
            "status": str(self.status),
            "message": self.message,
            "wall_time_s": self.wall_time_s,
            "n_steps": self.n_steps,
            "mu": self.mu,
            "timestep": self.timestep,
            "settings": self.settings,
        }


@dataclass(frozen=True)
class RunResult:
    """A run's trajectory (None if it failed before producing one), events and info."""

    trajectory: Trajectory | None
    events: Events | None
    info: RunInfo
    exact_events: Events | None = None
    """For the reference engine: the exact events, beside the detected ones."""

    @property
    def ok(self) -> bool:
        return self.info.status is RunStatus.OK

    def to_dict(self) -> dict[str, Any]:
        """Events fields (as ``hoopbench reference --json``) plus the run info."""
        out: dict[str, Any] = {} if self.events is None else self.events.to_dict()
        info = self.info.to_dict()
        out.update({k: info[k] for k in ("engine", "engine_version", "status")})
        out.update({k: info[k] for k in ("wall_time_s", "n_steps", "mu", "timestep")})
        if info["message"]:
            out["status_message"] = info["message"]
        out["settings"] = info["settings"]
        return out


class Engine(ABC):
    """Base class of the adapters. Subclasses set ``name`` and implement the hooks."""

    name: ClassVar[str]

    def __init__(
        self,
        detectors: DetectorSettings | None = None,
        limits: DivergenceLimits | None = None,
    ) -> None:
        self.detectors = detectors or DetectorSettings()
        self.limits = limits or DivergenceLimits()

    # ----------------------------------------------------------------- hooks
    @abstractmethod
    def _import(self) -> ModuleType:
        """Import the engine module; raise EngineUnavailableError if it cannot be used."""

    @abstractmethod
    def _simulate(
        self, module: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> Simulation:
        """Run the scene from t = 0 to scene.t_end with the engine's stepping."""

    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        """Raise ValueError for option values the engine cannot use (default: accept all)."""
        return None

    def _version(self, module: ModuleType) -> str | None:
        return getattr(module, "__version__", None)

    # ----------------------------------------------------------------- public
    def mu_for(self, scene: Scene, settings: RunSettings) -> float:
        """The friction coefficient a run uses: settings.mu, else the scene's static mus."""
        return scene.mus if settings.mu is None else settings.mu

    def run(self, scene: Scene, settings: RunSettings | None = None) -> RunResult:
        """Run the scene. Bad settings raise ValueError; engine failures return a status."""
        settings = settings or RunSettings()
        options = settings.resolve(self.name)  # raises ValueError for unknown names
        self._check(scene, settings, options)
        mu = self.mu_for(scene, settings)
        base = dict(
            engine=self.name, mu=mu, timestep=settings.timestep, settings=settings.to_dict()
        )
        try:
            module = self._import()
        except EngineUnavailableError as exc:
            info = RunInfo(
                engine_version=None, status=RunStatus.UNAVAILABLE, message=str(exc), **base
            )
            return RunResult(None, None, info)
        version = self._version(module)
        try:
            sim = self._simulate(module, scene, settings, options)
            events = detect_events(sim.trajectory, self.detectors)
        except Exception as exc:  # an engine failure is a result, not a crash
            last = traceback.format_exception_only(type(exc), exc)[-1].strip()
            info = RunInfo(engine_version=version, status=RunStatus.ERROR, message=last, **base)
            return RunResult(None, None, info)
        status = RunStatus.DIVERGED if sim.diverged else RunStatus.OK
        info = RunInfo(
            engine_version=version,
            status=status,
            message=sim.diverged or "",
            wall_time_s=sim.wall_time_s,
            n_steps=sim.n_steps,
            **base,
        )
        return RunResult(sim.trajectory, events, info, sim.exact_events)


def n_steps_for(scene: Scene, timestep: float) -> int:
    """Steps needed to cover [0, scene.t_end] with this timestep."""
    return math.ceil(scene.t_end / timestep - 1e-9)
