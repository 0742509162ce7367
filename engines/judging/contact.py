"""The canonical reading of a run: its events read from the contact force, as the rigid
model's laws define them. Every verdict, table, figure and finding reads these events; the
kinematic reading (engines/judging/detectors.py, the ``kin_`` columns) is kept only to be
set beside it. docs/report.md ("The canonical reading") is written from this docstring after
this paragraph and from ContactSettings' field docstrings (``make docs``).

With W the averaging window (4 ms on the 1 m hoop) and every mean taken over the samples
whose time lies within W/2 of a sample's (a sample without contact force counts with n = f = 0):

- **in contact** while the normal force n > ``contact_level`` g;
- **flight**: a stretch without contact. A flight that lasts ``sustain`` and rises above
  ``hop_clearance`` is a **hop**; the others are chatter, counted and sized. The hop of the
  run is the highest one that starts inside the exact window; lift-off is its start, impact
  its end (the contact returns), hop height its largest clearance;
- **at the cone**: |mean f| >= (1 - ``cone_tolerance``) mu mean n; **outside the cone**:
  |mean f| > (1 + ``cone_tolerance``) mu mean n;
- **sliding against friction**: mean slip velocity s and mean f of opposite signs, |mean s|
  above ``slip_floor`` (the contact point moves, beyond round-off);
- **the slip law**: friction follows the slip law rather than the rolling constraint where
  |mean f| is at the cone (within ``cone_hold``), or where rolling cannot go on: the friction
  the rigid model's rolling constraint needs at the run's own state (theta, thetadot),
  mean F_roll, reaches the cone mu mean N_roll, or |mean f| lies nearer the cone than that
  demand (a regularised friction sliding at 0.98 mu n obeys the slip law; a soft contact
  creeping at the rolling demand, 0.95 mu n, obeys the rolling one);
- **slip**: a stretch of samples sliding against friction under the slip law, entered where
  a sample's own friction reaches the cone (within ``cone_tolerance``) or the rolling demand
  reaches it, in which |mean s| exceeds ``slip_threshold`` somewhere; its direction is
  opposite the friction;
- **creep**: |s| above the slip threshold against friction inside the cone, not under the
  slip law and outside the slip phases (a slip's edges are the slip's): never a slip
  (``creep_time``, ``creep_max_speed``, ``creep_distance``);
- **stick outside the cone**: outside the cone and not sliding above the slip threshold: a
  Coulomb violation, never a slip (``cone_stick_time``: its longest stretch);
- **chattering**: not a slip, averaged friction inside the cone, but at least
  ``chatter_share`` of the window's samples with a force have their own friction at the cone
  (friction touches the cone on alternate steps): its own mode, code ``C``;
- **roll**: in contact otherwise.

A mode (roll, slip +/-, chattering, flight inside a hop) starts at its first sample once it
gathers ``sustain`` of time before a stretch of another mode lasts ``sustain`` on its own; a
shorter stretch belongs to the mode around it. A sample without contact force outside a hop
takes the mode it interrupts. A roll or slip mode's start is refined, by at most W/2, to
where the samples' own friction changes (the centred mean sees a sharp change early).

On the exact solution sampled at any timestep this gives the exact events within the
detection floor measured in tests/test_contact_reading.py; shorter phases are absorbed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from hoopbench.engines.judging.detectors import DetectorSettings, hoop_scale
from hoopbench.models.events import Events, Outcome, Phase, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.dynamics import rolling_forces

__all__ = [
    "CHATTER_CODE",
    "ContactReading",
    "ContactSettings",
    "Flight",
    "canonical_events",
    "read_contact",
    "read_run",
]

CHATTER_CODE = "C"
"""The phase code of a chattering contact (friction at the cone on alternate steps, inside
it on average): neither a roll nor a slip."""


@dataclass(frozen=True)
class ContactSettings:
    """Thresholds of the canonical reading for a hoop of radius ``a`` under ``g``; stated for
    the 1 m hoop, carried to any other with :func:`hoop_scale` (lengths with a, speeds with
    sqrt(g a), times with sqrt(a / g))."""

    a: float = 1.0
    """Hoop radius, m, these thresholds are stated for."""
    g: float = 9.8
    """Gravity, m/s^2, these thresholds are stated for."""
    contact_level: float = 1e-6
    """In contact while n > contact_level g (dimensionless): any force above round-off. The
    exact n falls to zero at a lift-off as the square of the time left, so a higher level
    leaves early (1e-3 g read hop-top's lift-off 3.7 ms early). Every engine's force is
    exactly 0 without contact."""
    window: float = 4e-3
    """s: the averaging window W (centred). Long enough to hold several steps at dt 1e-3, so
    that friction at the cone on alternate steps averages to what the contact transmits;
    short beside the phases the exact solutions have (the shortest catalogue phase that
    counts lasts 5 ms)."""
    cone_tolerance: float = 1e-3
    """A slip starts where |mean f| >= (1 - cone_tolerance) mu mean n (dimensionless). The
    exact |f| / (mu n) rises to 1 at a slip onset at 1-2 per second, so a looser level reads
    a creeping engine's onset early by this over that rate (1e-2: 5-10 ms)."""
    cone_hold: float = 1e-2
    """Once slipping, the slip lasts while |mean f| >= (1 - cone_hold) mu mean n and the
    contact point slides against the friction (dimensionless). An exact re-stick drops far
    below it at once (to the rolling demand); a regularised friction (Drake stock) that
    sags to 0.996-0.9999 mu n while sliding stays one slip."""
    slip_floor: float = 1e-5
    """m/s: the contact point moves at all where |mean slip velocity| exceeds this (the exact
    rolling solution has |s| ~ 1e-12 m/s; DART's sticks outside the cone stay below 2e-7
    m/s)."""
    chatter_share: float = 0.25
    """A contact chatters where friction is inside the cone on average but at least this
    share of the window's samples with a force have their own friction at the cone
    (dimensionless): at the cone on alternate steps is a half; a lone saturated step among
    the 40 samples of a window at dt 1e-4 is not chattering."""
    sustain: float = 5e-3
    """s: how long a new contact mode must last to count (the detectors' restick_sustain and
    lift_sustain on the 1 m hoop)."""
    hop_clearance: float = DetectorSettings().hop_clearance
    """m: a hop rises above this clearance (the hop threshold; its one home is
    ``DetectorSettings.hop_clearance``, which the kinematic reading reads too)."""
    slip_threshold: float = DetectorSettings().slip_threshold
    """m/s: a slip must slide faster than this somewhere; sliding this fast inside the cone
    is creep."""

    def for_hoop(self, a: float, g: float) -> ContactSettings:
        """These thresholds carried to a hoop of radius ``a`` (m) under ``g`` (m/s^2)."""
        length, speed, duration = hoop_scale(a, g, self.a, self.g)
        return replace(
            self,
            a=a,
            g=g,
            window=self.window * duration,
            sustain=self.sustain * duration,
            hop_clearance=self.hop_clearance * length,
            slip_threshold=self.slip_threshold * speed,
            slip_floor=self.slip_floor * speed,
        )


@dataclass(frozen=True)
class Flight:
    """One stretch without contact force."""

    t_start: float
    """s: the first sample without contact (interpolated at n = contact_level g)."""
    t_end: float | None
    """s: where the contact returns; None if the run ends in the air."""
    max_clearance: float
    """m: the largest clearance inside it."""


@dataclass(frozen=True)
class ContactReading:
    """A run read by the canonical reading. Times in s, lengths in m, speeds in m/s; None:
    did not happen."""

    t_slip: float | None
    """First slip onset."""
    t_restick: float | None
    """First return to rolling after the first slip."""
    t_lift: float | None
    """Start of the hop (the highest flight lasting ``sustain`` above the hop threshold
    inside the exact window)."""
    t_impact: float | None
    """End of that hop: the contact returns."""
    hop_height: float | None
    """Largest clearance inside the hop."""
    phases: str
    """The modes as codes, e.g. 'R S+ R S- R', 'R S+ F' or 'R C R' (C: chattering)."""
    t_last_phase: float | None
    """Start of the last mode (the phase comparison's window-end rule reads it)."""
    flights: tuple[Flight, ...]
    """Every stretch without contact, chatter included."""
    chatter_count: int
    """Flights that are not hops (too short or too low)."""
    chatter_max_clearance: float | None
    """m: the largest clearance inside those flights (None without)."""
    creep_time: float
    """s: time in contact, not slipping, with |mean slip velocity| above the slip
    threshold."""
    creep_max_speed: float | None
    """m/s: the largest |mean slip velocity| while creeping (None without creep)."""
    creep_distance: float = 0.0
    """m: how far the contact point slides while creeping (the integral of |slip velocity|)."""
    cone_stick_time: float = 0.0
    """s: the longest stretch in contact with |mean f| outside the cone (by more than the
    cone tolerance) and no sliding above the slip threshold: a Coulomb violation."""
    chattering_time: float = 0.0
    """s: time in chattering modes (code C)."""
    modes: tuple[Phase, ...] = ()
    """The modes as phases (each ends where the next starts; the last at the hop's impact
    or the record's end)."""


@dataclass(frozen=True)
class _Means:
    """Window means of a record (every sample, with n = f = 0 where there is no force)."""

    friction: NDArray
    normal: NDArray
    slip: NDArray
    cone_share: NDArray
    """Share of the window's samples with a force whose own friction is at the cone."""
    demand: NDArray | None = None
    """|mean F_roll| / (mu mean N_roll): the rolling demand as a share of its cone (inf where
    rolling needs a pull); None without the rolling demand."""


def read_contact(
    traj: Trajectory,
    mu: float,
    settings: ContactSettings | None = None,
    *,
    window_end: float | None = None,
    rolling_demand: tuple[NDArray, NDArray] | None = None,
) -> ContactReading:
    """The canonical reading of ``traj`` with the pair's friction coefficient ``mu``.

    ``rolling_demand``: (F_roll, N_roll) per sample, m/s^2, the friction and normal force the
    rolling constraint needs at the run's own state (:func:`read_run` computes them from the
    scene); without it, only friction at the cone follows the slip law.

    ``window_end`` (s): where the exact solution's window ends (its impact, for a hop). The
    hop is the highest hop-sized flight that starts before it, and the phases end with the
    hop's impact, as the exact ones do.
    """
    cfg = settings or ContactSettings()
    t, n, f = traj.t, traj.normal_force, traj.friction_force
    touching = n > cfg.contact_level * cfg.g
    means = _means(t, n, f, traj.slip_velocity, touching, mu, cfg, rolling_demand)
    steps = _step_labels(touching, n, f, mu, cfg)
    # Where a slip may start: a sample's own friction and state under the slip law, at the
    # cone's strict tolerance.
    demand = None if rolling_demand is None else _demand_share(*rolling_demand, mu)
    reaches = touching & _slip_law(np.abs(f), mu * n, demand, cfg.cone_tolerance)
    slipping = _slipping(means, reaches, mu, cfg) & touching
    flights = _flights(t, n, traj.clearance, touching, cfg)
    hops = [fl for fl in flights if _is_hop(fl, t, cfg)]
    chatter = [fl for fl in flights if fl not in hops]
    end = math.inf if window_end is None else window_end
    hop = max((h for h in hops if h.t_start <= end), key=lambda h: h.max_clearance, default=None)
    in_hop = _inside(t, hops) & ~touching
    cone = np.abs(means.friction) >= (1.0 - cfg.cone_tolerance) * mu * means.normal
    chattering = touching & ~slipping & ~cone & (means.cone_share >= cfg.chatter_share)
    labels = _labels(touching, slipping, chattering, means.friction, in_hop)
    modes = _modes(t, labels, steps, cfg)
    if hop is not None and hop.t_end is not None:
        modes = [m for m in modes if m[1] <= hop.t_end]  # the exact model ends at the impact
    t_slip, t_restick = _slip_events(modes)
    # Creep and sticks are read where the phases are: up to the exact window's end and the
    # hop's impact (the exact model ends there; after it an engine's hoop rolls on unjudged).
    judged = t <= min(end, math.inf if hop is None or hop.t_end is None else hop.t_end)
    # A sample inside a slip phase is the slip's, whatever its own friction: the modes absorb
    # a slip's edges (a lagged friction at 0.95 mu n while n ramps up) into the slip.
    creeping = (
        judged
        & touching
        & ~slipping
        & ~_in_modes(t, modes, _SLIP_CODES)
        & (np.abs(f) < (1.0 - cfg.cone_hold) * mu * n)
        & (np.abs(traj.slip_velocity) > cfg.slip_threshold)
    )
    outside = np.abs(means.friction) > (1.0 + cfg.cone_tolerance) * mu * means.normal
    sticking = judged & touching & outside & (np.abs(means.slip) <= cfg.slip_threshold)
    step = np.diff(t, append=t[-1])
    return ContactReading(
        t_slip=t_slip,
        t_restick=t_restick,
        t_lift=None if hop is None else hop.t_start,
        t_impact=None if hop is None else hop.t_end,
        hop_height=None if hop is None else hop.max_clearance,
        phases=" ".join(code for code, _ in modes),
        t_last_phase=modes[-1][1] if modes else None,
        flights=tuple(flights),
        chatter_count=len(chatter),
        chatter_max_clearance=max((fl.max_clearance for fl in chatter), default=None),
        creep_time=float(np.sum(step[creeping])),
        creep_max_speed=float(np.max(np.abs(traj.slip_velocity[creeping])))
        if creeping.any()
        else None,
        creep_distance=float(np.sum((step * np.abs(traj.slip_velocity))[creeping])),
        cone_stick_time=max((float(np.sum(step[i:j])) for i, j in _runs(sticking)), default=0.0),
        chattering_time=_mode_time(t, modes, _CHATTER),
        modes=_phases(modes, float(t[-1]) if hop is None or hop.t_end is None else hop.t_end),
    )


def read_run(
    traj: Trajectory, scene: Scene, mu: float, *, window_end: float | None = None
) -> ContactReading:
    """The canonical reading of a run of ``scene`` with the pair's ``mu``: the thresholds
    carried to the scene's hoop and the rolling demand at the run's own states. Every
    reader of a run (the row, ``hb.run(...).events``, ``simulate``) reads it through this."""
    demand = rolling_forces(scene, traj.theta, traj.thetadot)
    settings = ContactSettings().for_hoop(scene.a, scene.g)
    return read_contact(traj, mu, settings, window_end=window_end, rolling_demand=demand)


def canonical_events(
    traj: Trajectory, reading: ContactReading, *, painleve: bool = False
) -> Events:
    """The run's events as the canonical reading gives them (``hb.run(...).events``, the
    unprefixed columns): the outcome is ``hops`` with a hop, else ``slips`` with a slip,
    else ``rolls`` (``painleve`` where the run is the reference of a Painlevé scene)."""
    if painleve:
        outcome = Outcome.PAINLEVE
    elif reading.t_lift is not None:
        outcome = Outcome.HOPS
    else:
        outcome = Outcome.SLIPS if reading.t_slip is not None else Outcome.ROLLS
    theta = thetadot = None
    if reading.t_slip is not None:
        theta = float(np.interp(reading.t_slip, traj.t, traj.theta))
        thetadot = float(np.interp(reading.t_slip, traj.t, traj.thetadot))
    return Events(
        outcome=outcome,
        t_slip=reading.t_slip,
        theta_slip=theta,
        thetadot_slip=thetadot,
        t_restick=reading.t_restick,
        t_lift=reading.t_lift,
        hop_height=reading.hop_height,
        t_impact=reading.t_impact,
        phases=reading.modes,
    )


_KINDS = {
    "F": (PhaseKind.FLIGHT, None),
    "R": (PhaseKind.ROLL, None),
    "S+": (PhaseKind.SLIP, 1),
    "S-": (PhaseKind.SLIP, -1),
    CHATTER_CODE: (PhaseKind.CHATTER, None),
}


def _spans(modes: list[Mode], last_end: float) -> list[tuple[str, float, float]]:
    """Each mode as (code, start, end): it ends where the next starts, the last at
    ``last_end``."""
    ends = [start for _, start in modes[1:]] + [last_end]
    return [(code, start, end) for (code, start), end in zip(modes, ends, strict=True)]


def _phases(modes: list[Mode], t_end: float) -> tuple[Phase, ...]:
    return tuple(
        Phase(_KINDS[code][0], start, max(end, start), _KINDS[code][1])
        for code, start, end in _spans(modes, t_end)
    )


def _means(
    t: NDArray,
    n: NDArray,
    f: NDArray,
    slip: NDArray,
    touching: NDArray,
    mu: float,
    cfg: ContactSettings,
    rolling_demand: tuple[NDArray, NDArray] | None = None,
) -> _Means:
    """Centred window means (the samples within W/2 of each sample's time)."""
    half = 0.5 * cfg.window
    lo = np.searchsorted(t, t - half - 1e-12, side="left")
    hi = np.searchsorted(t, t + half + 1e-12, side="right")
    count = (hi - lo).astype(float)

    def mean(values: NDArray) -> NDArray:
        sums = np.concatenate(([0.0], np.cumsum(values, dtype=float)))
        return (sums[hi] - sums[lo]) / count

    n_on = np.where(touching, n, 0.0)
    f_on = np.where(touching, f, 0.0)
    at_cone = touching & (np.abs(f) >= (1.0 - cfg.cone_tolerance) * mu * n)
    forced = mean(touching.astype(float))
    share = np.divide(mean(at_cone.astype(float)), forced, out=np.zeros(len(t)), where=forced > 0)
    demand = None
    if rolling_demand is not None:
        demand = _demand_share(mean(rolling_demand[0]), mean(rolling_demand[1]), mu)
    return _Means(mean(f_on), mean(n_on), mean(slip), share, demand)


def _demand_share(f_roll: NDArray, n_roll: NDArray, mu: float) -> NDArray:
    """|F_roll| / (mu N_roll), inf where rolling needs a pull (N_roll <= 0)."""
    cone = mu * n_roll
    return np.divide(np.abs(f_roll), cone, out=np.full(len(cone), np.inf), where=cone > 0.0)


def _step_labels(
    touching: NDArray, n: NDArray, f: NDArray, mu: float, cfg: ContactSettings
) -> NDArray:
    """Each sample's own label from its own friction (no window): slip + or - at the cone
    within ``cone_tolerance`` either side (outside it is no slip), roll inside it by more
    than ``cone_hold``, else none (-1)."""
    cone = mu * n
    ratio = (np.abs(f) >= (1.0 - cfg.cone_tolerance) * cone) & (
        np.abs(f) <= (1.0 + cfg.cone_tolerance) * cone
    )
    inside = np.abs(f) < (1.0 - cfg.cone_hold) * cone
    labels = np.where(touching & inside, _ROLL, -1)
    labels = np.where(touching & ratio & (f < 0), _SLIP_PLUS, labels)
    return np.where(touching & ratio & (f > 0), _SLIP_MINUS, labels)


def _slipping(means: _Means, reaches: NDArray, mu: float, cfg: ContactSettings) -> NDArray:
    """Samples in a slip: a stretch where the mean friction is at the cone within
    ``cone_hold`` and the contact point slides against it, entered at a sample whose own
    friction reaches the cone within ``cone_tolerance`` (``reaches``; beyond it too: the
    contact slides, so it is a slip, outside the cone or not), and sliding faster than the
    slip threshold somewhere after that."""
    friction = np.abs(means.friction)
    cone = mu * means.normal
    against = (means.slip * means.friction < 0.0) & (np.abs(means.slip) > cfg.slip_floor)
    hold = against & _slip_law(friction, cone, means.demand, cfg.cone_hold) & (cone > 0.0)
    enter = hold & reaches
    fast = np.abs(means.slip) > cfg.slip_threshold
    out = np.zeros(len(friction), dtype=bool)
    for start, stop in _runs(hold):
        hits = np.nonzero(enter[start:stop])[0]
        if hits.size and fast[start + int(hits[0]) : stop].any():
            out[start + int(hits[0]) : stop] = True
    return out


def _slip_law(
    friction: NDArray, cone: NDArray, demand: NDArray | None, tolerance: float
) -> NDArray:
    """Samples (window means, or a sample's own values) whose friction follows the slip law
    rather than the rolling constraint: at the cone within ``tolerance``, or (with the
    rolling demand) where rolling cannot go on (the demand at or beyond the cone) or the
    friction lies nearer the cone than the demand."""
    at_cone = friction >= (1.0 - tolerance) * cone
    if demand is None:
        return at_cone
    share = np.divide(friction, cone, out=np.zeros(len(cone)), where=cone > 0.0)
    return at_cone | (demand >= 1.0) | (share >= 0.5 * (1.0 + demand))


Mode = tuple[str, float]
"""(phase code, start time in s)."""

_FLIGHT, _ROLL, _SLIP_PLUS, _SLIP_MINUS, _CHATTER = 0, 1, 2, 3, 4
_CODES = {_FLIGHT: "F", _ROLL: "R", _SLIP_PLUS: "S+", _SLIP_MINUS: "S-", _CHATTER: CHATTER_CODE}
_SLIP_CODES = ("S+", "S-")
_STEP_LABELS = (_ROLL, _SLIP_PLUS, _SLIP_MINUS)
"""The modes a single sample's own friction can show."""


def _mode_time(t: NDArray, modes: list[Mode], label: int) -> float:
    """s spent in the modes of ``label`` (the last one lasts to the record's end)."""
    return sum(
        end - start for code, start, end in _spans(modes, float(t[-1])) if code == _CODES[label]
    )


def _in_modes(t: NDArray, modes: list[Mode], codes: tuple[str, ...]) -> NDArray:
    """Samples from the start of a mode of ``codes`` up to the next mode's start."""
    inside = np.zeros(len(t), dtype=bool)
    for code, start, end in _spans(modes, math.inf):
        if code in codes:
            inside |= (t >= start) & (t < end)
    return inside


def _inside(t: NDArray, flights: list[Flight]) -> NDArray:
    """Samples within any of ``flights``."""
    inside = np.zeros(len(t), dtype=bool)
    for flight in flights:
        end = math.inf if flight.t_end is None else flight.t_end
        inside |= (t >= flight.t_start) & (t <= end)
    return inside


def _slip_events(modes: list[Mode]) -> tuple[float | None, float | None]:
    """(first slip onset, first re-stick after it), s."""
    slips = [k for k, (code, _) in enumerate(modes) if code in _SLIP_CODES]
    if not slips:
        return None, None
    restick = [start for code, start in modes[slips[0] :] if code == _CODES[_ROLL]]
    return modes[slips[0]][1], restick[0] if restick else None


def _is_hop(flight: Flight, t: NDArray, cfg: ContactSettings) -> bool:
    end = float(t[-1]) if flight.t_end is None else flight.t_end
    lasts = end - flight.t_start >= cfg.sustain or flight.t_end is None
    return lasts and flight.max_clearance > cfg.hop_clearance


def _runs(mask: NDArray) -> list[tuple[int, int]]:
    """[start, stop) index pairs of the stretches where ``mask`` holds."""
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0], strict=True))


def _crossing(t: NDArray, y: NDArray, i: int, level: float) -> float:
    """Time at which y crosses ``level`` between samples i - 1 and i (linear)."""
    if i == 0 or y[i] == y[i - 1]:
        return float(t[i])
    frac = (level - y[i - 1]) / (y[i] - y[i - 1])
    return float(t[i - 1] + min(max(frac, 0.0), 1.0) * (t[i] - t[i - 1]))


def _flights(
    t: NDArray, n: NDArray, clearance: NDArray, touching: NDArray, cfg: ContactSettings
) -> list[Flight]:
    level = cfg.contact_level * cfg.g
    out = []
    for start, stop in _runs(~touching):
        t_start = _crossing(t, n, int(start), level)
        t_end = None if stop == len(t) else _crossing(t, n, int(stop), level)
        if t_end is None:
            t_end = _landing(t, clearance, int(start))
        peak = float(np.max(clearance[start:stop]))
        out.append(Flight(t_start, t_end, peak))
    return out


def _landing(t: NDArray, clearance: NDArray, start: int) -> float | None:
    """Where a flight that ends the record lands, s, if it lands within its last step: the
    exact solution ends at its impact, its last sample at most a step before it. None: the
    record ends in the air."""
    if len(t) - start < 2:
        return None
    dt = float(t[-1] - t[-2])
    rate = float(clearance[-1] - clearance[-2]) / dt
    if clearance[-1] <= 0.0 < clearance[-2]:
        return _crossing(t, clearance, len(t) - 1, 0.0)
    if rate < 0.0 and 0.0 < clearance[-1] <= -rate * dt:
        return float(t[-1]) + float(clearance[-1]) / -rate
    return None


def _labels(
    touching: NDArray, slipping: NDArray, chattering: NDArray, f: NDArray, in_hop: NDArray
) -> NDArray:
    """Per sample: flight (inside a hop), roll, slip + or - (the slip opposes the mean
    friction ``f``), chattering. A sample without contact force outside a hop (chatter, or a
    force that drops out for a step while the hoop stays on the floor) reads as the mode it
    interrupts: it is counted with the chatter, not as a phase."""
    labels = np.where(touching, _ROLL, -1)
    labels = np.where(chattering, _CHATTER, labels)
    labels = np.where(slipping & (f < 0), _SLIP_PLUS, labels)
    labels = np.where(slipping & (f > 0), _SLIP_MINUS, labels)
    labels = np.where(in_hop, _FLIGHT, labels)
    known = np.nonzero(labels >= 0)[0]
    if known.size == 0:
        return np.full(len(labels), _FLIGHT, dtype=int)  # no contact at all: one flight
    # Each neutral sample takes the label before it (the first known one at the start).
    fill = np.maximum.accumulate(np.where(labels >= 0, np.arange(len(labels)), -1))
    fill = np.where(fill < 0, known[0], fill)
    return labels[fill]


Run = tuple[int, float, float]
"""(label, start time, end time in s; the last run ends at infinity)."""


def _takes_over(runs: list[Run], k: int, sustain: float) -> bool:
    """Whether run k's label becomes the mode: it gathers ``sustain`` of time (its own runs,
    interrupted or not) before any run of another label lasts ``sustain`` on its own."""
    label, held = runs[k][0], 0.0
    for other, start, end in runs[k:]:
        if other == label:
            held += end - start
            if held >= sustain:
                return True
        elif end - start >= sustain:
            return False
    return held > 0.0  # the record ends first: a mode at the window's end counts


def _modes(t: NDArray, labels: NDArray, steps: NDArray, cfg: ContactSettings) -> list[Mode]:
    """The modes from the per-sample labels: the mode changes at the first run of a label
    that takes over (:func:`_takes_over`); the first mode starts at t[0]. A later mode's
    start moves back, by at most W/2, over the samples just before it whose own (per-step)
    label is already the mode's (``steps``): the window's mean lags a sharp change by up
    to W/2, a sample's own friction does not."""
    edges = np.nonzero(np.diff(labels))[0] + 1
    starts = np.concatenate(([0], edges)).astype(int)
    stops = np.concatenate((edges, [len(t)])).astype(int)
    runs = [
        (int(labels[i]), float(t[i]), float(t[j]) if j < len(t) else math.inf)
        for i, j in zip(starts, stops, strict=True)
    ]
    modes: list[tuple[int, int]] = []
    for k, (label, _, _) in enumerate(runs):
        if modes and modes[-1][0] == label:
            continue
        if _takes_over(runs, k, cfg.sustain):
            first = int(starts[k])
            if modes:
                first = _refined_start(t, steps, modes, label, first, cfg.window / 2)
            modes.append((label, first if modes else 0))
    return [(_CODES[label], float(t[i])) for label, i in modes]


def _refined_start(
    t: NDArray, steps: NDArray, modes: list[tuple[int, int]], label: int, first: int, reach: float
) -> int:
    """Where the mode of ``label`` starts, from ``first`` (where the window's mean starts it),
    within ``reach`` s: back over the samples whose own label is already ``label``, else
    forward over those whose own label is not yet ``label`` (the centred mean sees a sharp
    change up to W/2 before it happens). Never at or before the previous mode's start."""
    previous, start = modes[-1]
    if label not in _STEP_LABELS or previous == _FLIGHT:
        return first  # flights start and end where the force does; chattering has no step
    lowest = max(start + 1, int(np.searchsorted(t, t[first] - reach - 1e-12)))
    i = first
    while i > lowest and steps[i - 1] == label:
        i -= 1
    if i < first or steps[first] == label:
        return i
    highest = int(np.searchsorted(t, t[first] + reach + 1e-12))
    while i < min(highest, len(t) - 1) and steps[i] != label:
        i += 1
    return i
