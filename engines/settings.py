"""Contact settings for a run: common knobs, and every engine's own knobs with their defaults.

This is the one place where engine-specific defaults are written down; the adapters read
them from here, the CLI validates against them and the README table is made from them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Any

__all__ = ["ENGINE_OPTIONS", "GEOMETRIES", "RunSettings", "parse_option_value"]

GEOMETRIES: Mapping[str, tuple[str, ...]] = MappingProxyType(
    {
        "reference": ("sphere",),
        "mujoco": ("sphere", "cylinder", "ring"),
        "pybullet": ("sphere", "cylinder", "hull"),
        "pymunk": ("sphere",),
    }
)
"""Contact geometries each engine supports. sphere: exact circle in the plane; cylinder: the
engine's cylinder primitive (PyBullet: implicit cylinder); hull: PyBullet's default convex hull
of a URDF cylinder; ring: MuJoCo hoop made of N capsules (option ring_segments)."""

ENGINE_OPTIONS: Mapping[str, Mapping[str, Any]] = MappingProxyType(
    {
        "reference": MappingProxyType(
            {
                "rtol": 1e-10,  # solve_ivp relative tolerance
                "atol": 1e-12,  # solve_ivp absolute tolerance
            }
        ),
        "mujoco": MappingProxyType(
            {
                # Chosen on seed-mu and the hop scenes at timestep 1e-4 (measurements in the
                # module doc of engines/mujoco_engine.py). A sliding MuJoCo contact pushes the
                # bodies apart (convex contact model): at solref 0.002 the hoop chattered up to
                # 0.2 mm while slipping and the detectors saw false hops. A soft friction
                # reference (solreffriction) removes most of it; impratio 100 keeps the rolling
                # creep small.
                "solref": (0.0005, 1.0),  # (timeconst s, dampratio); refsafe clamps to 2*timestep
                # Friction rows of elliptic cones only; (0, 0) means "same as solref".
                "solreffriction": (0.015, 1.0),
                "solimp": (0.95, 0.99, 0.001, 0.5, 2.0),
                "cone": "elliptic",  # pyramidal, solref 0.02 slipped at 26 deg, not 88.5
                "impratio": 100.0,  # elliptic cones only: friction 100x harder than normal
                "noslip_iterations": 0,  # no measurable effect here
                # Euler | implicit | implicitfast | RK4 | discrete. RK4 costs ~4x per step, but
                # the one-step integrators lost the hop-top/hop-low hops to contact chatter.
                "integrator": "RK4",
                "tolerance": 1e-10,
                "iterations": 100,
                "ring_segments": 32,  # capsules in the ring geometry
            }
        ),
        "pybullet": MappingProxyType(
            {
                "numSolverIterations": 50,
                "contactERP": 0.2,
                "frictionERP": 0.2,
                "contactStiffness": None,  # None: rigid contact (ERP-based)
                "contactDamping": None,
                "enableConeFriction": 1,
                "frictionAnchor": 0,
                # m; pybullet's own 1e-5 lets a contact sink that deep with no force, so the
                # hoop fell freely for the first 1.4 ms; 0 made the contact flicker (distance
                # +1e-16 -> no force for a step), which slipped 10 ms early at dt 1e-3.
                "contactSlop": 1e-8,
            }
        ),
        "pymunk": MappingProxyType(
            {
                "iterations": 50,
                "collision_slop": 1e-5,  # m; pymunk's default 0.1 is far too large here
                # Fraction of overlap left after 1 s (None: pymunk's 0.9**60, made for 60 Hz
                # games). 1e-40 removes overlap with an 11 ms time constant; the default's
                # 0.16 s let the rolling hoop-bottom scene sink 0.2 mm and lift off 12 ms late.
                "collision_bias": 1e-40,
            }
        ),
    }
)
"""Engine-specific knobs with their real names and hoopbench's defaults."""


def _check_positive(name: str, value: float) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a positive finite number, got {value}")
    return value


@dataclass(frozen=True)
class RunSettings:
    """How to run a scene in an engine. Unknown option names are rejected by :meth:`resolve`."""

    timestep: float = 1e-4
    """Engine step (and the reference's sampling step), s."""
    mu: float | None = None
    """The pair's friction coefficient (static = kinetic); None means the scene's mus."""
    restitution: float = 0.0
    """Coefficient of restitution of the hoop-floor pair, dimensionless, in [0, 1]."""
    geometry: str = "sphere"
    """Contact geometry, one of GEOMETRIES[engine]."""
    options: Mapping[str, Any] = field(default_factory=dict)
    """Engine-specific knobs (real engine names); missing ones take ENGINE_OPTIONS defaults."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "timestep", _check_positive("timestep", self.timestep))
        if self.mu is not None:
            mu = float(self.mu)
            if not (math.isfinite(mu) and mu >= 0):
                raise ValueError(f"mu must be a finite number >= 0, got {self.mu}")
            object.__setattr__(self, "mu", mu)
        r = float(self.restitution)
        if not (math.isfinite(r) and 0.0 <= r <= 1.0):
            raise ValueError(f"restitution must be in [0, 1], got {self.restitution}")
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))

    def with_(self, **changes: Any) -> RunSettings:
        return replace(self, **changes)

    def resolve(self, engine: str) -> dict[str, Any]:
        """The engine's full option dict: defaults overlaid with these options.

        Raises ValueError for an unknown engine, geometry or option name.
        """
        if engine not in ENGINE_OPTIONS:
            raise ValueError(f"unknown engine {engine!r}; known: {', '.join(ENGINE_OPTIONS)}")
        if self.geometry not in GEOMETRIES[engine]:
            raise ValueError(
                f"geometry {self.geometry!r} is not available for {engine}; "
                f"choose one of {', '.join(GEOMETRIES[engine])}"
            )
        defaults = ENGINE_OPTIONS[engine]
        unknown = sorted(set(self.options) - set(defaults))
        if unknown:
            raise ValueError(
                f"unknown {engine} setting(s) {', '.join(unknown)}; "
                f"known: {', '.join(sorted(defaults))}"
            )
        return {**defaults, **self.options}

    def to_dict(self) -> dict[str, Any]:
        return {
            "timestep": self.timestep,
            "mu": self.mu,
            "restitution": self.restitution,
            "geometry": self.geometry,
            **{k: _plain(v) for k, v in self.options.items()},
        }


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
