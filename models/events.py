"""The events record: what happened in a run, and when."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any

__all__ = ["Events", "Outcome", "Phase", "PhaseKind"]


class Outcome(StrEnum):
    """How a run ended (within its window)."""

    ROLLS = "rolls"
    """No slip in the window."""
    SLIPS = "slips"
    """Slip, possibly re-sticking, no lift-off."""
    HOPS = "hops"
    """Lift-off in the window."""
    LIFTS_AT_START = "lifts-at-start"
    """The normal force is negative at t = 0: the hoop leaves the floor at once."""
    PAINLEVE = "painleve"
    """No consistent contact force exists (D = 0 while slipping)."""
    DEGENERATE = "degenerate"
    """A phase needs I > 0 and the scene has I = 0."""
    ERROR = "error"
    """The run stopped before the end of its window (e.g. a work budget ran out); the
    message says why, and the events found until then are kept."""


class PhaseKind(StrEnum):
    ROLL = "roll"
    SLIP = "slip"
    FLIGHT = "flight"


@dataclass(frozen=True)
class Phase:
    """One contact mode over a time interval."""

    kind: PhaseKind
    t_start: float
    """s."""
    t_end: float
    """s."""
    sigma: int | None = None
    """Slip direction sign(xdot - a*thetadot), +1 or -1, for slip phases; None otherwise."""

    @property
    def code(self) -> str:
        """Short label: R (roll), S+ / S- (slip with its sigma), F (flight)."""
        letter = {
            PhaseKind.ROLL: "R",
            PhaseKind.SLIP: "S",
            PhaseKind.FLIGHT: "F",
        }[self.kind]
        return letter + {1: "+", -1: "-"}.get(self.sigma or 0, "")

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kind": str(self.kind),
            "t_start": self.t_start,
            "t_end": self.t_end,
        }
        if self.kind is PhaseKind.SLIP:
            out["sigma"] = self.sigma
        return out


def _opt(x: float | None) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


@dataclass(frozen=True)
class Events:
    """Events of one run. Times in s, angles in rad, lengths in m; None = did not occur."""

    outcome: Outcome
    t_slip: float | None = None
    """First slip onset, s."""
    theta_slip: float | None = None
    """theta at the first slip onset, rad."""
    thetadot_slip: float | None = None
    """thetadot at the first slip onset, rad/s."""
    t_restick: float | None = None
    """First return to rolling after the first slip, s."""
    t_lift: float | None = None
    """Lift-off time, s."""
    hop_height: float | None = None
    """Max clearance y - a over [0, t_impact], m (None without a lift-off)."""
    t_impact: float | None = None
    """First impact after lift-off, s."""
    phases: tuple[Phase, ...] = ()
    """Contact modes in order (the reference knows them exactly; engines leave it empty)."""
    message: str = ""
    """Free-text detail (why a run is degenerate, where Painlevé was reached, ...)."""
    extra: dict[str, float | int | str | None] = field(default_factory=dict, compare=False)
    """Method-specific numbers (n_steps of the seed scheme, Painlevé time, ...)."""
    flags: tuple[str, ...] = ()
    """Why events failed a self-consistency check (codes of engines.event_checks.EventFlag,
    e.g. 'hop-too-high'); the numbers in question are withheld (None), and ``message`` says
    why. Empty: consistent."""

    @property
    def phase_code(self) -> str:
        """The phase sequence as short labels, e.g. 'R S+ R S- F'."""
        return " ".join(p.code for p in self.phases)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict; theta_slip also in degrees (theta_slip_deg)."""
        out: dict[str, Any] = {
            "outcome": str(self.outcome),
            "t_slip": _opt(self.t_slip),
            "theta_slip_deg": None if self.theta_slip is None else math.degrees(self.theta_slip),
            "thetadot_slip": _opt(self.thetadot_slip),
            "t_restick": _opt(self.t_restick),
            "t_lift": _opt(self.t_lift),
            "hop_height": _opt(self.hop_height),
            "t_impact": _opt(self.t_impact),
            "phases": [p.to_dict() for p in self.phases],
        }
        if self.message:
            out["message"] = self.message
        if self.flags:
            out["flags"] = list(self.flags)
        out.update(self.extra)
        return out
