"""What a run gives back: its status, its information, and its trajectory before and after
judging. Shared by the engines, the judge and the sweeps, so it depends on nothing above models.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

from hoopbench.models.events import Events
from hoopbench.models.trajectory import Trajectory

__all__ = [
    "REFERENCE_ENGINE",
    "BatchCost",
    "Divergence",
    "Run",
    "RunInfo",
    "RunResult",
    "RunStatus",
]

REFERENCE_ENGINE = "reference"
"""The engine name of the exact reference's runs and rows (engines/reference_engine.py)."""


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


class Divergence(StrEnum):
    """Why a run was stopped as diverged, where the harness knows it: each value begins the
    message of its status (``message`` of a diverged row), so a stored row tells its cause.
    An engine's own reason (MuJoCo's reset of a bad state, Rapier's quarantined body) has
    none of these beginnings."""

    NON_FINITE = "non-finite"
    """A state or force is NaN or infinite."""
    ENERGY_RISE = "energy rose"
    """The energy rose past DivergenceLimits.energy_rise (engines/base.py)."""
    PENETRATION = "penetration"
    """The hoop sank into the floor past DivergenceLimits.penetration: a contact too soft or
    too slow to push it out, not necessarily an unstable one."""
    OUT_OF_PLANE = "the free body left the x-z plane"
    """PyBullet's free body, no longer of the planar model."""

    @classmethod
    def of(cls, message: object) -> Divergence | None:
        """The cause a diverged row's message begins with, or None (an engine's own)."""
        text = str(message or "")
        return next((cause for cause in cls if text.startswith(cause)), None)


@dataclass(frozen=True)
class BatchCost:
    """What the batch a run was stepped in cost, the same for every run of it
    (``Engine.simulate_batch``)."""

    size: int
    """Worlds stepped together in the batch."""
    wall_time_s: float
    """Wall time of stepping the whole batch (model building excluded), s."""
    world_steps: int
    """Steps taken, summed over the batch's worlds (each world's ``n_steps``)."""
    cpu_time_s: float | None = None
    """The process's CPU time over the same stepping, s (None: not measured)."""

    @property
    def s_per_world_step(self) -> float | None:
        """s per world-step: the batch's wall time over its world-steps."""
        return self.wall_time_s / self.world_steps if self.world_steps else None

    @property
    def cpu_s_per_world_step(self) -> float | None:
        """CPU s per world-step: the batch's CPU time over its world-steps."""
        if self.cpu_time_s is None or not self.world_steps:
            return None
        return self.cpu_time_s / self.world_steps

    @property
    def world_steps_per_s(self) -> float | None:
        """Throughput, world-steps per second."""
        return self.world_steps / self.wall_time_s if self.wall_time_s > 0 else None

    def to_dict(self) -> dict[str, Any]:
        return {
            "batch_size": self.size,
            "batch_wall_time_s": self.wall_time_s,
            "batch_world_steps": self.world_steps,
            "batch_cpu_time_s": self.cpu_time_s,
        }


@dataclass(frozen=True)
class RunInfo:
    engine: str
    engine_version: str | None
    status: RunStatus
    message: str = ""
    wall_time_s: float | None = None
    """Wall time of the stepping, s."""
    cpu_time_s: float | None = None
    """The process's CPU time over the stepping, s (``Simulation.cpu_time_s``)."""
    n_steps: int | None = None
    mu: float | None = None
    """The pair's friction coefficient actually used."""
    timestep: float | None = None
    """s."""
    settings: dict[str, Any] = field(default_factory=dict)
    stop_reason: str | None = None
    """A StopReason value if the run ended early by its stop rule; None: the window's end
    (or a failure). ``n_steps`` counts the steps recorded either way."""
    batch: BatchCost | None = None
    """The batch the run was stepped in (None: stepped alone). ``wall_time_s`` and
    ``cpu_time_s`` are then the run's shares of the batch's, in proportion to its steps."""

    def to_dict(self) -> dict[str, Any]:
        out = {
            "engine": self.engine,
            "engine_version": self.engine_version,
            "status": str(self.status),
            "message": self.message,
            "wall_time_s": self.wall_time_s,
            "cpu_time_s": self.cpu_time_s,
            "n_steps": self.n_steps,
            "mu": self.mu,
            "timestep": self.timestep,
            "settings": self.settings,
        }
        if self.stop_reason is not None:  # absent otherwise: output as before stop rules
            out["stop_reason"] = self.stop_reason
        if self.batch is not None:  # absent otherwise: output as before batches
            out.update(self.batch.to_dict())
        return out


@dataclass(frozen=True)
class Run:
    """A simulated run before judging: trajectory (None if it failed first) and run info."""

    trajectory: Trajectory | None
    info: RunInfo
    exact_events: Events | None = None
    """For the reference engine: the exact events of the solved scene."""


@dataclass(frozen=True)
class RunResult:
    """A judged run: trajectory, the events the shared detectors found, and run info."""

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
        out.update({k: info[k] for k in ("wall_time_s", "cpu_time_s", "n_steps", "mu", "timestep")})
        if info["message"]:
            out["status_message"] = info["message"]
        out["settings"] = info["settings"]
        return out
