"""Checks the judge makes on detected events: is a lift-off a hop at all, and is a hop possible?

The detectors (:mod:`hoopbench.engines.judging.detectors`) read events off a trajectory with
thresholds. Two questions they do not ask are asked here, for every engine and the reference
alike, by :func:`checked_events`, which the judge calls in their place:

1. **Contact noise is not a hop.** A lift-off whose clearance never exceeds
   ``DetectorSettings.hop_clearance`` (1 mm; its reason is given there) is contact noise:
   MuJoCo's sliding soft contact, for one, kicks the hoop 0.1-0.3 mm up for 8-30 ms. Such
   a flight is treated as contact (its clearance is read as 0 by the detectors; the stored
   trajectory is untouched) and the events are detected again, so the slips after the blip,
   and a real hop later in the window, are still found. The message names the blip, and
   the runs table keeps the largest clearance as ``max_clearance``.

2. **A hop must be possible for its flight time.** In flight no contact force acts: the
   centre of mass is ballistic (Y'' = -g) and the spin w = thetadot is constant. The
   hoop-centre clearance c = Y - r cos(theta) - a, with r = lam a, then has
   c'' = -g + r w^2 cos(theta), so -(g + r w^2) <= c'' <= -(g - r w^2). A completed flight
   has c = 0 at lift-off and at impact, a time T apart. A function that is 0 at both ends
   of [0, T] with c'' >= -L lies below L tau (T - tau) / 2 (their difference is convex and
   0 at both ends), and one with c'' <= -m lies above m tau (T - tau) / 2. The hop height h,
   the largest clearance, is therefore bounded by (:func:`flight_height_bounds`)

       max(0, g - r w^2) T^2 / 8  <=  h  <=  (g + r w^2) T^2 / 8.

   Without spin this is the ballistic rule h = g T^2 / 8; the spin term is the weight
   swinging the centre about the centre of mass. w is the largest |thetadot| the trajectory
   shows during the flight. Slack (:func:`flight_height_limits`): T is known to about one
   sample at each end (the lift-off is extrapolated back, the impact interpolated), so the
   upper bound uses T + 2 dt and the lower T - 2 dt (dt: the median sample spacing); both
   are widened by FLIGHT_REL_SLACK and by lift_clearance (the clearance at the detected
   ends is zero only to within it). What fails: a hoop lifted by a position correction
   rather than a velocity (a jump of the clearance, then a fall: h = g T^2 / 2, four times
   the bound), or one held up by a contact at a positive clearance (a "flight" far longer
   than its height allows). An impact before its lift-off, or without one, fails too.

A hop that fails (2) is flagged (``Events.flags``, codes of :class:`EventFlag`) and its
numbers (t_lift, hop_height, t_impact) are withheld, None, with a message saying why. Its
outcome stays ``hops``: the hoop did leave the floor by more than the threshold; only its
numbers cannot be trusted. The bound needs g and lam a, so (2) runs only when the scene is
known; the impact-before-lift-off check and (1) need nothing but the trajectory.
"""

from __future__ import annotations

import math
from dataclasses import replace
from enum import StrEnum

import numpy as np

from hoopbench.engines.judging.detectors import FLOOR_LEVEL, DetectorSettings, detect_events
from hoopbench.models.events import Events
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

__all__ = [
    "FLIGHT_REL_SLACK",
    "EventFlag",
    "check_flight",
    "checked_events",
    "flight_height_bounds",
    "flight_height_limits",
    "screen_contact_noise",
]

FLIGHT_REL_SLACK = 0.1
"""Relative slack on both flight-height bounds: the sampled maximum of the clearance, and an
engine's own small departures from a torque-free flight (damping, solver drift), must not
flag a real hop. The bounds themselves are loose for a spinning hoop (the centre's extreme
accelerations are not reached together), so a real failure is far outside them."""


class EventFlag(StrEnum):
    """Why a hop's numbers were withheld."""

    HOP_TOO_HIGH = "hop-too-high"
    """Higher than any flight of its duration can rise, even with the spin's help."""
    HOP_TOO_LOW = "hop-too-low"
    """Too low for its duration: something held the hoop up (only checked where the spin
    cannot pull the centre down faster than g, r w^2 < g)."""
    IMPACT_BEFORE_LIFT = "impact-before-lift-off"
    """An impact at or before the lift-off, or without one."""


def flight_height_bounds(
    duration: float, spin: float, g: float, com_offset: float
) -> tuple[float, float]:
    """(lower, upper) bound, m, of the largest hoop-centre clearance of a flight that leaves
    and meets the floor ``duration`` s apart, spinning at most at ``spin`` rad/s, for a hoop
    whose centre of mass is ``com_offset`` = lam a from its centre (module docstring).
    No slack."""
    swing = com_offset * spin**2
    t2 = duration**2 / 8.0
    return max(0.0, g - swing) * t2, (g + swing) * t2


def flight_height_limits(
    duration: float,
    spin: float,
    g: float,
    com_offset: float,
    step: float,
    settings: DetectorSettings | None = None,
) -> tuple[float, float]:
    """The bounds of :func:`flight_height_bounds` with the slack stated in the module
    docstring: T -/+ 2 ``step``, FLIGHT_REL_SLACK, and lift_clearance."""
    cfg = settings or DetectorSettings()
    low, _ = flight_height_bounds(max(duration - 2.0 * step, 0.0), spin, g, com_offset)
    _, high = flight_height_bounds(duration + 2.0 * step, spin, g, com_offset)
    return (
        (1.0 - FLIGHT_REL_SLACK) * low - cfg.lift_clearance,
        (1.0 + FLIGHT_REL_SLACK) * high + cfg.lift_clearance,
    )


def _noted(events: Events, note: str) -> str:
    return f"{events.message}; {note}" if events.message else note


def _withheld(events: Events, flag: EventFlag, why: str) -> Events:
    """The events with the hop's numbers removed, the flag added and the reason noted."""
    return replace(
        events,
        t_lift=None,
        hop_height=None,
        t_impact=None,
        flags=(*events.flags, str(flag)),
        message=_noted(events, f"{flag}: {why}; lift-off, hop height and impact withheld"),
    )


def _quiet_clearance(clearance: np.ndarray, level: float) -> np.ndarray:
    """The clearance with every excursion above the floor that never exceeds ``level`` set to
    0: contact noise read as contact. Excursions above it are left untouched."""
    above = clearance > FLOOR_LEVEL
    if not above.any():
        return clearance
    edges = np.flatnonzero(np.diff(np.concatenate(([0], above.astype(np.int8), [0]))))
    starts, stops = edges[::2], edges[1::2]
    peaks = np.maximum.reduceat(clearance, starts)
    noise = np.zeros(len(clearance) + 1, dtype=np.int64)
    quiet = peaks <= level
    np.add.at(noise, starts[quiet], 1)
    np.add.at(noise, stops[quiet], -1)
    return np.where(np.cumsum(noise[:-1]) > 0, 0.0, clearance)


def screen_contact_noise(
    trajectory: Trajectory, events: Events, settings: DetectorSettings | None = None
) -> Events:
    """The events with a lift-off below hop_clearance read as contact noise (module docstring,
    check 1): detected again on the clearance with such flights set to 0. Events whose
    lift-off, if any, exceeds the threshold come back unchanged."""
    cfg = settings or DetectorSettings()
    if events.t_lift is None or events.hop_height is None:
        return events
    if events.hop_height > cfg.hop_clearance:
        return events
    quiet = _quiet_clearance(trajectory.clearance, cfg.hop_clearance)
    again = detect_events(replace(trajectory, clearance=quiet), cfg)
    note = (
        f"a lift-off at t = {events.t_lift:.6g} s peaking at {1e3 * events.hop_height:.3g} mm "
        f"is below the {1e3 * cfg.hop_clearance:g} mm hop threshold: contact noise, not a hop"
    )
    return replace(again, message=_noted(again, note), flags=(*again.flags, *events.flags))


def check_flight(
    events: Events,
    trajectory: Trajectory,
    scene: Scene | None = None,
    settings: DetectorSettings | None = None,
) -> Events:
    """The events with an impossible hop flagged and its numbers withheld (module docstring,
    check 2). Without a scene only the order of lift-off and impact is checked. Idempotent:
    withheld numbers are not checked again."""
    t_lift, t_impact, height = events.t_lift, events.t_impact, events.hop_height
    if t_impact is not None and (t_lift is None or t_impact <= t_lift):
        lift = "no lift-off" if t_lift is None else f"lift-off at {t_lift:.6g} s"
        return _withheld(
            events, EventFlag.IMPACT_BEFORE_LIFT, f"impact at {t_impact:.6g} s with {lift}"
        )
    if scene is None or t_lift is None or t_impact is None or height is None:
        return events  # no scene, or no completed flight: nothing to bound
    settings = (settings or DetectorSettings()).for_scene(scene)
    t = trajectory.t
    duration = t_impact - t_lift
    inside = (t >= t_lift) & (t <= t_impact)
    ends = np.interp([t_lift, t_impact], t, trajectory.thetadot)
    spin = float(np.max(np.abs(np.concatenate((ends, trajectory.thetadot[inside])))))
    step = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
    low, high = flight_height_limits(duration, spin, scene.g, scene.com_offset, step, settings)
    numbers = (
        f"a {1e3 * height:.4g} mm hop in a {1e3 * duration:.4g} ms flight "
        f"(spin up to {spin:.4g} rad/s) must stay within {1e3 * max(low, 0.0):.4g}-"
        f"{1e3 * high:.4g} mm"
    )
    if not math.isfinite(height) or height > high:
        return _withheld(events, EventFlag.HOP_TOO_HIGH, numbers)
    if height < low:
        return _withheld(events, EventFlag.HOP_TOO_LOW, numbers)
    return events


def checked_events(
    trajectory: Trajectory,
    settings: DetectorSettings | None = None,
    scene: Scene | None = None,
) -> Events:
    """The shared detectors' events, then both checks: contact noise screened out, an
    impossible hop flagged and withheld (the flight bound only with a scene). With a scene,
    the thresholds are carried to its hoop (:meth:`DetectorSettings.for_scene`)."""
    cfg = settings or DetectorSettings()
    cfg = cfg if scene is None else cfg.for_scene(scene)
    events = screen_contact_noise(trajectory, detect_events(trajectory, cfg), cfg)
    return check_flight(events, trajectory, scene, cfg)
