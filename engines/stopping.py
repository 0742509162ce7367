"""Ending an engine run early, once the rest of its window cannot change its verdict.

A hop map runs thousands of points; most of a point's window is spent after the events that
decide it. :class:`StopRule` (``RunSettings.stop``) says when a run may end early, and
:class:`StopMonitor`, fed by an engine's chunked stepping loop with each chunk of states,
says when it does:

* **IMPACT**: after the first impact, as the judge (engines/judging/detectors.py with the
  contact-noise screen of engines/judging/event_checks.py) reads one: an excursion of the
  clearance above
  FLOOR_LEVEL that peaks above hop_clearance, with a stretch above lift_clearance lasting
  lift_sustain, ended by a sample back at FLOOR_LEVEL or below. The judge reads lift-off,
  hop height and impact from the samples up to that sample, and the contact phases before
  the lift-off only, so a trajectory ending after it is judged as the full one.
* **SETTLED**: at a time >= settle_after, once the run has rolled continuously (clearance at
  most lift_clearance, |slip velocity| below the slip and re-stick thresholds, so that the
  judge sees it rolling too) over a stretch in which theta advanced a full turn. Rolling
  conserves energy and fixes the state by theta, so the motion repeats turn after turn and
  nothing new can happen (the exact reference's t_settled, reference/regimes.py, gives
  settle_after).

The run ends at the end of the chunk in which the monitor decides (engines/base.py
CHUNK_STEPS), so a stopped trajectory runs up to one chunk past the deciding sample.
Clearance and slip velocity are those of models/kinematics.py at the body's lowest point,
with the run's contact shape (a Polygon for faceted geometries), exactly as the judge's
trajectory computes them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
from numpy.typing import NDArray

from hoopbench.engines.judging.detectors import FLOOR_LEVEL, DetectorSettings
from hoopbench.models import kinematics
from hoopbench.models.scene import Scene

__all__ = ["StopMonitor", "StopReason", "StopRule", "StopThresholds", "stop_thresholds"]


class StopReason(StrEnum):
    """Why a run ended before its window's end."""

    IMPACT = "impact"
    """The run ended shortly after its first impact."""
    SETTLED = "settled"
    """Rolled a full turn after settle_after: nothing new can happen."""


@dataclass(frozen=True)
class StopRule:
    """When a run may end before its window's end (``RunSettings.stop``)."""

    at_first_impact: bool = True
    """End shortly after the first impact (the judge's), where the window ends anyway for
    the exact reference."""
    settle_after: float | None = None
    """s; end once rolled a full turn at or after this time. None: never stop for settling."""

    def __post_init__(self) -> None:
        if not isinstance(self.at_first_impact, bool):
            raise ValueError(f"at_first_impact must be True or False, got {self.at_first_impact!r}")
        if self.settle_after is not None:
            value = self.settle_after
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"settle_after must be a number of seconds, got {value!r}")
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"settle_after must be >= 0 s, got {value}")
            object.__setattr__(self, "settle_after", float(value))

    def stop_time(self, first_impact: float | None) -> float | None:
        """When this rule ends a run that follows a known motion (the exact reference's), s,
        given the motion's first impact (None: it has none): the earliest of that impact
        (at_first_impact) and settle_after (the reference's t_settled, when that motion has
        rolled the full turn the rule waits for); None: the run steps its whole window.
        An engine's run stops where its own trajectory meets the rule (the monitor's
        samples), so this is what its steps are expected to be, not a bound."""
        impact = first_impact if self.at_first_impact else None
        times = [t for t in (impact, self.settle_after) if t is not None]
        return min(times, default=None)

    def to_dict(self) -> dict[str, bool | float | None]:
        return {"at_first_impact": self.at_first_impact, "settle_after": self.settle_after}


@dataclass(frozen=True)
class StopThresholds:
    """The detector thresholds a monitor applies, m, s and m/s."""

    floor_level: float
    """Clearance at or below which the hoop is on the floor (ends a flight), m."""
    lift_clearance: float
    """Clearance above which the hoop may be airborne, m; rolling needs at most this."""
    lift_sustain: float
    """How long the clearance must stay above lift_clearance for a lift-off, s."""
    hop_clearance: float
    """Peak clearance a flight must exceed to be a hop (not contact noise), m."""
    roll_slip: float
    """|slip velocity| below which the hoop counts as rolling, m/s."""


def stop_thresholds(scene: Scene, detectors: DetectorSettings | None = None) -> StopThresholds:
    """The thresholds the judge applies to this scene's runs, carried to its hoop
    (:meth:`DetectorSettings.for_scene`, as the judge does): the one place that reads them
    from DetectorSettings for stopping."""
    cfg = (detectors or DetectorSettings()).for_scene(scene)
    return StopThresholds(
        floor_level=FLOOR_LEVEL,
        lift_clearance=cfg.lift_clearance,
        lift_sustain=cfg.lift_sustain,
        hop_clearance=cfg.hop_clearance,
        roll_slip=min(cfg.slip_threshold, cfg.restick_threshold),
    )


def _runs(mask: NDArray) -> tuple[NDArray, NDArray]:
    """(starts, stops) of the runs of True in mask: mask[starts[i]:stops[i]] is all True."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], mask.astype(np.int8), [0]))))
    return edges[::2], edges[1::2]


class StopMonitor:
    """Decides, chunk by chunk, whether a run may end (see the module docstring).

    An engine calls :meth:`feed` after each chunk of steps with the chunk's centre-of-mass
    states and the step index of its last row; rows already seen (a chunk that repeats the
    previous chunk's last state) are skipped. Once it returns a reason, the run ends.
    """

    def __init__(
        self,
        scene: Scene,
        rule: StopRule,
        timestep: float,
        *,
        detectors: DetectorSettings | None = None,
        shape: kinematics.Polygon | None = None,
    ) -> None:
        self.scene, self.rule, self.timestep, self.shape = scene, rule, timestep, shape
        self.limits = stop_thresholds(scene, detectors)
        self.reason: StopReason | None = None
        self._seen = -1  # step index of the last row fed
        # An excursion above the floor still open at the last chunk's end: its samples.
        self._open_t = np.empty(0)
        self._open_clear = np.empty(0)
        # The rolling stretch still open at the last chunk's end: theta at its start.
        self._roll_theta0: float | None = None

    @classmethod
    def for_run(
        cls,
        scene: Scene,
        rule: StopRule | None,
        timestep: float,
        *,
        detectors: DetectorSettings | None = None,
        shape: kinematics.Polygon | None = None,
    ) -> StopMonitor | None:
        """A monitor for a run with this rule; None when the run has none (it runs its window)."""
        if rule is None:
            return None
        return cls(scene, rule, timestep, detectors=detectors, shape=shape)

    def feed(
        self, states: Mapping[str, NDArray], last_step: int, clear: NDArray | None = None
    ) -> StopReason | None:
        """Take a chunk of states (arrays X, Y, theta, Xdot, Ydot, thetadot, the same length,
        the last row at step ``last_step``); the reason to stop now, or None. ``clear``: the
        chunk's clearance, m, row by row, if the caller has it (a batch's divergence screen
        computes it the same way), else computed here."""
        if self.reason is not None:
            return self.reason
        theta = np.asarray(states["theta"], dtype=float)
        steps = np.arange(last_step - len(theta) + 1, last_step + 1)
        new = steps > self._seen
        if not new.any():
            return None
        self._seen = last_step
        theta = theta[new]
        t = steps[new] * self.timestep
        if clear is None:
            clear = kinematics.clearance(
                self.scene, np.asarray(states["Y"])[new], theta, self.shape
            )
        else:
            clear = np.asarray(clear)[new]
        if self.rule.at_first_impact and self._impact(t, clear):
            self.reason = StopReason.IMPACT
        elif self.rule.settle_after is not None:
            slip = kinematics.slip_velocity(
                self.scene,
                np.asarray(states["Xdot"])[new],
                theta,
                np.asarray(states["thetadot"])[new],
                self.shape,
            )
            if self._settled(t, clear, theta, slip):
                self.reason = StopReason.SETTLED
        return self.reason

    # ----------------------------------------------------------------- impact
    def _impact(self, t: NDArray, clear: NDArray) -> bool:
        """Did a hop (as the judge reads one) end in these samples or the open excursion?"""
        t = np.concatenate((self._open_t, t))
        clear = np.concatenate((self._open_clear, clear))
        starts, stops = _runs(clear > self.limits.floor_level)
        if not starts.size:
            self._open_t, self._open_clear = np.empty(0), np.empty(0)
            return False
        # Every excursion's peak at once (from its start to the next one's: the samples
        # between are on the floor, below it): only one above hop_clearance can be a hop,
        # and an engine whose contact flickers has hundreds of one-step excursions a chunk
        # (a loop over them was most of the monitor's time: pymunk at 1e-4 s, 0.24 ms a chunk).
        closed = stops < len(clear)
        peaks = np.maximum.reduceat(clear, starts)
        for k in np.flatnonzero(closed & (peaks > self.limits.hop_clearance)):
            if self._is_hop(t[starts[k] : stops[k]], clear[starts[k] : stops[k]]):
                return True
        if closed[-1]:
            self._open_t, self._open_clear = np.empty(0), np.empty(0)
        else:  # still in the air: look again with the next chunk
            self._open_t, self._open_clear = t[starts[-1] :], clear[starts[-1] :]
        return False

    def _is_hop(self, t: NDArray, clear: NDArray) -> bool:
        """A completed excursion the judge calls a hop: above hop_clearance at its peak and
        above lift_clearance for lift_sustain."""
        if clear.max() <= self.limits.hop_clearance:
            return False  # contact noise
        starts, stops = _runs(clear > self.limits.lift_clearance)
        return bool(np.any(t[stops - 1] - t[starts] >= self.limits.lift_sustain))

    # ----------------------------------------------------------------- settled
    def _settled(self, t: NDArray, clear: NDArray, theta: NDArray, slip: NDArray) -> bool:
        """Has a rolling stretch advanced theta a full turn, at a time >= settle_after?"""
        rolling = (clear <= self.limits.lift_clearance) & (np.abs(slip) < self.limits.roll_slip)
        was_rolling = self._roll_theta0 is not None
        begins = rolling & ~np.concatenate(([was_rolling], rolling[:-1]))
        first = np.maximum.accumulate(np.where(begins, np.arange(len(t)), -1))
        theta0 = np.where(first >= 0, theta[np.maximum(first, 0)], self._roll_theta0 or 0.0)
        self._roll_theta0 = float(theta0[-1]) if rolling[-1] else None
        turned = rolling & (np.abs(theta - theta0) >= 2.0 * math.pi)
        return bool(np.any(turned & (t >= self.rule.settle_after)))
