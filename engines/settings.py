"""The settings common to every engine run: timestep, friction, restitution, geometry.

Engine-specific knobs are declared by each engine (its ``options``); a run carries the ones
it changes in ``RunSettings.options`` and the engine checks them (``Engine.resolve``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

from hoopbench.engines.options import Profile
from hoopbench.engines.stopping import StopRule
from hoopbench.models.checks import check_integer, check_real

__all__ = [
    "BYTES_PER_STEP",
    "DEFAULT_BATCH_SIZE",
    "DEFAULT_TIMESTEP",
    "MAX_STEPS",
    "RunSettings",
    "parse_option_value",
]

DEFAULT_TIMESTEP = 1e-4
"""Engine step, s. At 1e-3 pymunk slips 34 deg instead of 88.5 and MuJoCo reports false hops;
1e-4 is the largest step at which every engine's slip onset is within a few ms (README)."""


MAX_STEPS = 10_000_000
"""Default limit on the steps of one run (``RunSettings.max_steps`` overrides it): about
2 minutes of MuJoCo RK4 and 3 GB of recorded states, so a mistyped --dt or --t-end is
refused at once instead of running for hours or being killed for memory."""

DEFAULT_BATCH_SIZE = 64
"""Runs per batch for an engine that steps many worlds at once (``Engine.batches``), when a
suite or a map is not told: enough that a batched simulator's cost per call is spread thin
(MuJoCo's batch: reports/bench/batch.py), few enough that a batch's recordings (about
BYTES_PER_STEP per step and world, 9 MB for a 3 s window at 1e-4 s) stay small beside a
worker's memory."""

BYTES_PER_STEP = 300
"""Memory of one recorded step, bytes, for the estimate in the error: the trajectory's 13
float columns plus the engines' own state buffers (MuJoCo's full physics state is the
largest), rounded up."""


@dataclass(frozen=True)
class RunSettings:
    """How to run a scene in an engine. The engine checks ``geometry`` and ``options``."""

    timestep: float = DEFAULT_TIMESTEP
    """Engine step (and the reference's sampling step), s."""
    mu: float | None = None
    """The pair's friction coefficient (static = kinetic); None means the scene's mus."""
    restitution: float = 0.0
    """Coefficient of restitution of the hoop-floor pair, dimensionless, in [0, 1]."""
    geometry: str = "sphere"
    """Contact geometry, one of the engine's ``geometries``."""
    options: Mapping[str, Any] = field(default_factory=dict)
    """Engine-specific knobs (real engine names); missing ones take the engine's defaults."""
    max_steps: int = MAX_STEPS
    """A run needing more steps than this is refused before it starts."""
    profile: Profile = Profile.TUNED
    """Option values the run starts from: hoopbench's (tuned) or the engine's own (stock)."""
    stop: StopRule | None = None
    """When the run may end before the window's end (engines/stopping.py); None: it runs
    the whole window."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "max_steps", check_integer("max_steps", self.max_steps, low=1))
        timestep = check_real("timestep", self.timestep, low=0.0, low_open=True, unit="s")
        object.__setattr__(self, "timestep", timestep)
        if self.mu is not None:
            object.__setattr__(self, "mu", check_real("mu", self.mu, low=0.0))
        restitution = check_real("restitution", self.restitution, low=0.0, high=1.0)
        object.__setattr__(self, "restitution", restitution)
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))
        try:
            object.__setattr__(self, "profile", Profile(self.profile))
        except ValueError:
            allowed = ", ".join(p.value for p in Profile)
            raise ValueError(f"profile must be one of {allowed}, got {self.profile!r}") from None
        if self.stop is not None and not isinstance(self.stop, StopRule):
            raise ValueError(f"stop must be a StopRule or None, got {self.stop!r}")

    def with_(self, **changes: Any) -> RunSettings:
        return replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The settings as plain values; ``stop`` only when set, so that the rows and run ids
        of runs without one are as before it existed."""
        out = {
            "timestep": self.timestep,
            "mu": self.mu,
            "restitution": self.restitution,
            "geometry": self.geometry,
            "profile": str(self.profile),
            **{k: _plain(v) for k, v in self.options.items()},
        }
        if self.stop is not None:
            out["stop"] = self.stop.to_dict()
        return out


def _plain(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


def parse_option_value(text: str) -> Any:
    """Parse a KEY=VALUE value from the command line: number, tuple 'a,b', None, or string."""
    text = text.strip()
    if text.lower() in ("none", "null"):
        return None
    if "," in text:
        return tuple(parse_option_value(part) for part in text.split(","))
    for convert in (int, float):
        try:
            return convert(text)
        except ValueError:
            pass
    return text
