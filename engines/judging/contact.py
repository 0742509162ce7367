"""The canonical reading of a run: its events read from the contact force, as the rigid
model's laws define them. Every verdict, table, figure and finding reads these events; the
kinematic reading (engines/judging/detectors.py, the ``kin_`` columns) is kept only to be
set beside it. docs/report.md ("The canonical reading") is written from this docstring after
this paragraph and from ContactSettings' field docstrings (``make docs``).

With W the averaging window (4 ms on the 1 m hoop) and every mean taken over the samples
whose time lies within W/2 of a sample's (a sample without contact force counts with n = f = 0,
and so does its rolling demand):

- **in contact** while the normal force n > ``contact_level`` g; a sample **with a contact
  force** has n above that level or |f| above ``friction_level`` (a friction without a
  normal force still acts on the hoop: a contact outside the cone). The phases, creep and
  sticks are read over the samples with a contact force, the flights from the normal force
  alone;
- **flight**: a stretch without contact (its start and end interpolated where n crosses the
  contact level). A flight that lasts ``sustain`` and rises above ``hop_clearance`` is a
  **hop**; the others are chatter, counted and sized. The hop of the run is the highest one
  that starts no later than the exact window's end (the exact impact); lift-off is its
  start, impact its end (the contact returns), hop height its largest clearance;
- **the rolling demand**: the friction F_roll and normal force N_roll the rigid model's
  rolling constraint needs at the run's own state (theta, thetadot). Rolling cannot go on
  where |F_roll| >= mu N_roll (or N_roll <= 0). An engine's friction may follow the demand
  of the state a step away (a step's force acts over the step it is taken from), so each
  comparison with the demand allows its change over one step;
- **sliding against friction**: mean slip velocity s and mean f of opposite signs, |mean s|
  above ``slip_floor`` (the contact point moves, beyond round-off);
- **the slip law**: the friction cannot give what rolling needs, or the slide is fast: |mean
  f| at or beyond the cone (within ``cone_hold``), rolling cannot go on, |mean f| short of
  the demand along it by more than ``demand_tolerance`` of the cone mu mean n (a friction
  law that saturates below mu, as DART stock's does at 0.56-0.87 mu n), or |mean s| above
  ``creep_speed`` (fast sliding is never creep). A friction away from the demand on the
  other side (above it) keeps a slide going (it brakes it), but starts none; and a slip
  goes on where the demand passes the level of its friction while the rim slides on (short
  of it, then above it, the friction's share of the cone held within
  ``demand_tolerance``): the friction lies near the demand there without following it;
- **slip**: a stretch sliding against friction under the slip law, one way (a reversal is a
  new slip), in which |mean s| exceeds ``slip_threshold`` somewhere after its entry. It is
  entered where the window's friction is at the cone, rolling cannot go on, or the slide is
  fast, or where the friction is short of the demand once |mean s| exceeds the slip
  threshold (a soft friction lags a demand that ramps up: short of it while the rim barely
  moves is no slip) and the slide grows from there by more than the slip threshold before
  the friction reaches the cone (a friction that saturates short of the demand lets the
  slide run away; one that lags the demand leaves the rim creeping at its speed, and the
  slip starts at the cone), at a sample whose own contact cannot roll or slides fast. Its
  direction is opposite the friction: S+ where mean f < 0;
- **creep**: outside the slips, in contact before the exact lift-off (after it the exact hoop
  has no contact to creep on), |s| above the slip threshold and at most ``creep_speed``
  against a friction inside the cone by more than ``cone_hold``: sliding while the friction
  follows the rolling demand, never a slip (``creep_time``, ``creep_max_speed``,
  ``creep_distance``);
- **stick outside the cone**: |mean f| > (1 + ``cone_tolerance``) mu mean n and |mean s|
  not above the slip threshold: a Coulomb violation, never a slip (``cone_stick_time``: its
  longest stretch);
- **chattering**: outside the slips, |mean f| inside the cone by more than
  ``cone_tolerance`` while at least ``chatter_share`` of the window's samples with a force
  have their own friction at the cone (friction touches the cone on alternate steps): a
  property of the phase it happens in, never a phase (``chattering_time``, and
  ``chatter_cone_share``: the share of those samples at the cone);
- **roll**: with a contact force otherwise;
- **effective friction coefficient**: the median |f| / n over the slip phases' samples that
  slide faster than the slip threshold (``mu_effective``; over mu, 1 for Coulomb friction).

A mode (roll, slip +/-, flight inside a hop; a flight wins over a slip, a slip over a roll)
starts at its first sample once it gathers ``sustain`` of time before a stretch of another
mode lasts ``sustain`` on its own; a shorter stretch belongs to the mode around it. A sample
without contact force outside a hop takes the mode it interrupts. A roll or slip mode's
start (not the first mode's, nor one right after a flight) is refined, by at most W/2, to
where the samples' own contact changes: back over the samples just before it whose own
label is already the new mode's, else forward over those whose own label is not yet; never
to or before the previous mode's start. A sample's own label is a slip where its friction is
at the cone within ``cone_tolerance`` either side, beyond it while sliding, or short of the
demand by ``cone_tolerance`` of the cone, or it slides faster than ``creep_speed`` (one onset
rule with the slip's); a roll where its friction is inside the cone by ``cone_hold`` and it
is no slip.

On the exact solution sampled at any timestep this gives the exact events within the
detection floor measured in tests/test_contact_reading.py; shorter phases are absorbed.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from functools import cached_property
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from hoopbench.engines.judging.detectors import DetectorSettings, hoop_scale
from hoopbench.models.events import Events, Outcome, Phase, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.dynamics import rolling_forces

__all__ = [
    "ContactReading",
    "ContactSettings",
    "Flight",
    "canonical_events",
    "contact_masks",
    "read_contact",
    "read_run",
]


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
    """A sample's own friction is at the cone within this share of it, either side
    (dimensionless): where a slip's first sample may lie, and the chattering and
    outside-the-cone levels. The exact |f| / (mu n) rises to 1 at a slip onset at 1-2 per
    second, so a looser level reads a creeping engine's onset early by this over that rate
    (1e-2: 5-10 ms)."""
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
    """m/s: a slip must slide faster than this somewhere; sliding this fast inside the cone,
    at the rolling demand, is creep."""
    demand_tolerance: float = 3e-2
    """Friction follows the rolling demand while |mean f - mean F_roll| <= demand_tolerance mu
    mean n (dimensionless, a share of the cone). While an engine rolls, its friction stays
    within 2 % of the cone of the demand at its own state in 95 % of its windows (every engine
    of the default suite, measured on stored runs); MuJoCo's soft friction creeps at up to
    3 % above it on a near-slip roll (0.966-0.984 mu n against 0.94-0.96)."""
    creep_speed: float = 0.1 * math.sqrt(9.8)
    """m/s: sliding faster than this is never creep, whatever the friction: a tenth of the
    hoop's speed scale sqrt(g a) (0.31 m/s on the 1 m hoop). Creep is slow beside the motion
    it rides on, as rolling contact mechanics calls a slip of a few per cent of the rolling
    speed creepage and a tenth full sliding; an engine's rolling contact that the position
    update drags (Box2D, PyBullet's free base: lam a thetadot^2 |sin theta| dt) reaches 0.08
    m/s at dt 1e-3 with thetadot 9 rad/s, inside the bound."""

    @property
    def friction_level(self) -> float:
        """m/s^2: a friction without a normal force is a contact force above this, the
        friction that changes the rim's slide by ``slip_threshold`` within one window (0.25
        m/s^2 on the 1 m hoop): a smaller one moves nothing the reading can see. Below it lie
        the float32 engines' momentum-balance quanta with no normal force (Box2D at dt 1e-5:
        0.024-0.048 m/s^2, one velocity rounding over a step; Newton in flight: up to 0.006);
        above it DART stock's friction without a normal force (0.3 to 61 m/s^2 in make
        report's runs)."""
        return self.slip_threshold / self.window

    def for_scene(self, scene: Scene) -> ContactSettings:
        """These thresholds carried to the scene's hoop (:meth:`for_hoop` with its a and g),
        as ``DetectorSettings.for_scene``."""
        return self.for_hoop(scene.a, scene.g)

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
            creep_speed=self.creep_speed * speed,
        )


@dataclass(frozen=True)
class Flight:
    """One stretch without a normal force (a friction may still act: :func:`_forced`)."""

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
    """The modes as codes, e.g. 'R S+ R S- R' or 'R S+ F'."""
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
    """s: time the contact chatters outside the slips (friction at the cone on some steps,
    inside it on average): a property of the phase it happens in, not a phase."""
    chatter_cone_share: float | None = None
    """Share of the chattering time's samples whose own friction is at the cone (None
    without chattering)."""
    chatters: bool = False
    """The flag: the contact chatters for at least ``sustain`` in all."""
    slip_friction_ratio: float | None = None
    """The engine's effective sliding friction coefficient over the pair's mu: the median
    |f| / (mu n) over the samples of its slip phases that slide faster than the slip
    threshold (1 for Coulomb friction at the cone; None without a slip)."""
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
    touched: NDArray
    """The window holds a sample with a contact force (its mean normal force may still be 0:
    a friction without a normal force, :func:`_forced`)."""
    demand: _Demand | None = None
    """The window means of the rolling demand; None without it."""


@dataclass(frozen=True)
class _Demand:
    """The rolling demand at the run's own states: the friction and normal force per unit mass
    (m/s^2) the rigid model's rolling constraint needs (window means, or a sample's own)."""

    friction: NDArray
    """F_roll, signed as the friction force (+x)."""
    normal: NDArray
    """N_roll."""
    step_change: NDArray
    """|change of F_roll| over one step, the larger either side: a step's force acts over the
    step it is taken from, so an engine's friction may follow the demand of the state a step
    away (Rapier's and Box2D's rolling friction lag it by one step: 3 % of the cone on a
    slip reversal's roll at dt 1e-3)."""

    @classmethod
    def at(cls, friction: NDArray, normal: NDArray) -> _Demand:
        """The demand of each sample's own state."""
        change = np.abs(np.diff(friction))
        step = np.maximum(np.append(change, 0.0), np.insert(change, 0, 0.0))
        return cls(friction, normal, np.where(np.isfinite(step), step, np.inf))

    def impossible(self, mu: float) -> NDArray:
        """Where rolling cannot go on: the demand at or beyond its cone, |F_roll| >= mu N_roll
        (a pull, N_roll <= 0, included)."""
        return np.abs(self.friction) >= mu * self.normal


def read_contact(
    traj: Trajectory,
    mu: float,
    settings: ContactSettings | None = None,
    *,
    window_end: float | None = None,
    rolling_demand: tuple[NDArray, NDArray] | None = None,
    exact_lift: float | None = None,
) -> ContactReading:
    """The canonical reading of ``traj`` with the pair's friction coefficient ``mu``.

    ``rolling_demand``: (F_roll, N_roll) per sample, m/s^2, the friction and normal force the
    rolling constraint needs at the run's own state (:func:`read_run` computes them from the
    scene); without it, only friction at the cone follows the slip law.

    ``window_end`` (s): where the exact solution's window ends (its impact, for a hop). The
    hop is the highest hop-sized flight that starts before it, and the phases end with the
    hop's impact, as the exact ones do. ``exact_lift`` (s): the exact solution's lift-off;
    creep is counted only before it (after it the exact hoop has no contact to creep on).
    """
    cfg = settings or ContactSettings()
    t, n = traj.t, traj.normal_force
    touching, forced = contact_masks(traj, cfg)
    own = _own(traj, rolling_demand)
    means = _means(t, n, traj.friction_force, traj.slip_velocity, forced, mu, cfg, own.demand)
    slipping = _slipping(means, own, forced, mu, cfg) & forced
    flights = _flights(t, n, traj.clearance, touching, cfg)
    is_hop = [_is_hop(fl, t, cfg) for fl in flights]
    hops = [fl for fl, hop in zip(flights, is_hop, strict=True) if hop]
    end = math.inf if window_end is None else window_end
    hop = max((h for h in hops if h.t_start <= end), key=lambda h: h.max_clearance, default=None)
    labels = _labels(forced, slipping, means.friction, _inside(t, hops) & ~touching)
    modes = _modes(t, labels, _step_labels(own, forced, mu, cfg), cfg)
    hop_end = math.inf if hop is None or hop.t_end is None else hop.t_end
    modes = [m for m in modes if m[1] <= hop_end]  # the exact model ends at the impact
    # Creep, chattering and sticks are read where the phases are: up to the exact window's
    # end and the hop's impact (after it an engine's hoop rolls on unjudged).
    judged = forced & (t <= min(end, hop_end))
    rest = _Rest(t, judged & ~slipping & ~_in_modes(t, modes, _SLIP_CODES))
    creep = rest.creep(traj, means, mu, cfg, exact_lift)
    chattering = _chattering(means, mu, cfg) & rest.mask
    chattering_time = rest.time(chattering)
    # The flights that are not hops (a flight equal to a hop is one: hop or not is read from
    # its own values), without comparing each with every hop (pymunk: 2,000 flights a run).
    chatter = [fl for fl, hop in zip(flights, is_hop, strict=True) if not hop]
    t_slip, t_restick = _slip_events(modes)
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
        creep_time=rest.time(creep),
        creep_max_speed=float(np.max(np.abs(traj.slip_velocity[creep]))) if creep.any() else None,
        creep_distance=rest.time(creep, np.abs(traj.slip_velocity)),
        cone_stick_time=rest.longest(_outside_cone(means, mu, cfg) & judged),
        chattering_time=chattering_time,
        chatters=chattering_time >= cfg.sustain,
        chatter_cone_share=_cone_share(own, chattering, mu, cfg),
        slip_friction_ratio=_slip_friction_ratio(own, modes, t, touching, mu, cfg),
        modes=_phases(modes, float(t[-1]) if hop_end == math.inf else hop_end),
    )


@dataclass(frozen=True)
class _Rest:
    """The judged samples outside the slips (``mask``), where creep, chattering and sticks
    outside the cone are read."""

    t: NDArray
    mask: NDArray

    @cached_property
    def step(self) -> NDArray:
        """Each sample's step to the next (0 for the last): the weight of its time."""
        return np.diff(self.t, append=self.t[-1])

    def time(self, where: NDArray, rate: NDArray | None = None) -> float:
        """s spent where ``where`` holds (with ``rate``: its integral there)."""
        return float(np.sum((self.step if rate is None else self.step * rate)[where]))

    def longest(self, where: NDArray) -> float:
        """s: the longest stretch where ``where`` holds."""
        return max((float(np.sum(self.step[i:j])) for i, j in _runs(where)), default=0.0)

    def creep(
        self,
        traj: Trajectory,
        means: _Means,
        mu: float,
        cfg: ContactSettings,
        exact_lift: float | None,
    ) -> NDArray:
        """Creep: outside the slips, in contact before the exact lift-off, the contact point
        slides faster than the slip threshold and slower than ``creep_speed`` against a
        friction inside the cone (a slip's edges are the slip's)."""
        speed = np.abs(traj.slip_velocity)
        f, n = traj.friction_force, traj.normal_force
        before = self.t < (math.inf if exact_lift is None else exact_lift)
        return (
            self.mask
            & before
            & (np.abs(f) < (1.0 - cfg.cone_hold) * mu * n)
            & (speed > cfg.slip_threshold)
            & (speed <= cfg.creep_speed)
        )


def _outside_cone(means: _Means, mu: float, cfg: ContactSettings) -> NDArray:
    """A stick outside the cone: |mean f| beyond it by more than ``cone_tolerance`` without
    sliding above the slip threshold."""
    outside = np.abs(means.friction) > (1.0 + cfg.cone_tolerance) * mu * means.normal
    return outside & (np.abs(means.slip) <= cfg.slip_threshold)


def _chattering(means: _Means, mu: float, cfg: ContactSettings) -> NDArray:
    """Chattering windows: the mean friction inside the cone, at least ``chatter_share`` of
    the samples with a force at the cone."""
    cone = np.abs(means.friction) >= (1.0 - cfg.cone_tolerance) * mu * means.normal
    return ~cone & (means.cone_share >= cfg.chatter_share)


def _cone_share(own: _Contact, where: NDArray, mu: float, cfg: ContactSettings) -> float | None:
    """The share of the samples in ``where`` whose own friction is at the cone (None
    without any)."""
    if not where.any():
        return None
    at_cone = np.abs(own.friction) >= (1.0 - cfg.cone_tolerance) * mu * own.normal
    return float(np.mean(at_cone[where]))


def _slip_friction_ratio(
    own: _Contact, modes: list[Mode], t: NDArray, touching: NDArray, mu: float, cfg: ContactSettings
) -> float | None:
    """The engine's effective sliding friction over mu: the median of |f| / (mu n) over the
    samples of its slip phases that slide faster than the slip threshold (None without)."""
    sliding = _in_modes(t, modes, _SLIP_CODES) & touching & own.sliding(cfg.slip_threshold)
    if not sliding.any():
        return None
    return float(np.median(np.abs(own.friction[sliding]) / (mu * own.normal[sliding])))


def read_run(
    traj: Trajectory,
    scene: Scene,
    mu: float,
    *,
    window_end: float | None = None,
    exact_lift: float | None = None,
) -> ContactReading:
    """The canonical reading of a run of ``scene`` with the pair's ``mu``: the thresholds
    carried to the scene's hoop and the rolling demand at the run's own states. Every
    reader of a run (the row, ``hb.run(...).events``, ``simulate``) reads it through this."""
    demand = rolling_forces(scene, traj.theta, traj.thetadot)
    settings = ContactSettings().for_scene(scene)
    return read_contact(
        traj, mu, settings, window_end=window_end, rolling_demand=demand, exact_lift=exact_lift
    )


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
    forced: NDArray,
    mu: float,
    cfg: ContactSettings,
    own_demand: _Demand | None = None,
) -> _Means:
    """Centred window means (the samples within W/2 of each sample's time); ``own_demand``:
    each sample's own rolling demand (:meth:`_Demand.at`), averaged alike."""
    half = 0.5 * cfg.window
    lo = _searched(t, t - half - 1e-12, "left")
    hi = _searched(t, t + half + 1e-12, "right")
    count = (hi - lo).astype(float)

    def mean(values: NDArray) -> NDArray:
        sums = np.zeros(len(values) + 1)
        np.cumsum(values, dtype=float, out=sums[1:])  # summed in place: no copy behind a 0
        return (sums[hi] - sums[lo]) / count

    n_on = np.where(forced, n, 0.0)
    f_on = np.where(forced, f, 0.0)
    at_cone = forced & (np.abs(f) >= (1.0 - cfg.cone_tolerance) * mu * n)
    with_force = mean(forced.astype(float))
    share = np.divide(
        mean(at_cone.astype(float)), with_force, out=np.zeros(len(t)), where=with_force > 0
    )
    demand = None
    if own_demand is not None:
        # Averaged as the forces are, over the samples with a force: an intermittent contact
        # (one step in thirty) transmits the demand of those steps alone.
        own = own_demand
        demand = _Demand(
            *(mean(np.where(forced, x, 0.0)) for x in (own.friction, own.normal, own.step_change))
        )
    return _Means(mean(f_on), mean(n_on), mean(slip), share, with_force > 0, demand)


def _searched(t: NDArray, keys: NDArray, side: Literal["left", "right"]) -> NDArray:
    """``np.searchsorted(t, keys, side)``, the same indices, for keys that are ``t`` shifted by
    a constant: on an even grid the index of key i is i plus one shift. That guess is checked
    against its neighbours for every key (with -inf and +inf beyond the ends, the one index
    searchsorted returns on increasing ``t``: left, t[r-1] < key <= t[r]; right, t[r-1] <= key
    < t[r]) and searched for where it fails (an uneven step, the grid's ends, a NaN). A binary
    search per key was a sixth of reading a run."""
    n = len(t)
    if n < 2 or len(keys) != n or not bool(np.all(t[1:] >= t[:-1])):
        return np.searchsorted(t, keys, side=side)
    mid = n // 2
    shift = int(np.searchsorted(t, keys[mid : mid + 1], side=side)[0]) - mid
    pad = abs(shift) + 1
    padded = np.concatenate((np.full(pad, -np.inf), t, np.full(pad, np.inf)))
    below = padded[pad - 1 + shift : pad - 1 + shift + n]  # t[r - 1] at r = i + shift
    above = padded[pad + shift : pad + shift + n]  # t[r]
    left = side == "left"
    found = ((below < keys) if left else (below <= keys)) & (
        (keys <= above) if left else (keys < above)
    )
    index = np.arange(n) + shift
    missed = np.nonzero(~found)[0]
    index[missed] = np.searchsorted(t, keys[missed], side=side)
    return index


@dataclass(frozen=True)
class _Contact:
    """A record's contact, as window means or as each sample's own values: friction (signed,
    +x) and normal force per unit mass (m/s^2), slip velocity (m/s) and the rolling demand."""

    friction: NDArray
    normal: NDArray
    slip: NDArray
    demand: _Demand | None

    def sliding(self, floor: float) -> NDArray:
        """The contact point slides against the friction, faster than ``floor`` (m/s)."""
        return (self.slip * self.friction < 0.0) & (np.abs(self.slip) > floor)

    def cannot_roll(self, mu: float, cone_tolerance: float, deficit: float) -> NDArray:
        """The friction cannot give what rolling needs: it is at or beyond the cone (within
        ``cone_tolerance``), rolling cannot go on at the state, or the friction falls short of
        the rolling demand, along it, by more than ``deficit`` of the cone (a friction law that
        saturates below mu)."""
        cone = mu * self.normal
        out = np.abs(self.friction) >= (1.0 - cone_tolerance) * cone
        if self.demand is not None:
            # An infinite deficit (no limit) on a zero cone is NaN: no shortfall exceeds it.
            with np.errstate(invalid="ignore"):
                short = self.shortfall() > deficit * cone + self.demand.step_change
            out |= self.demand.impossible(mu) | short
        return out

    def shortfall(self) -> NDArray:
        """How far the friction falls short of the rolling demand, along it, m/s^2 (< 0:
        beyond it). Needs the demand."""
        assert self.demand is not None
        need = self.demand.friction
        with np.errstate(invalid="ignore"):  # an infinite demand is impossible() already
            return np.sign(need) * (need - self.friction)

    def off_demand(self, mu: float, tolerance: float) -> NDArray:
        """The friction departs from the rolling demand, either side, by more than
        ``tolerance`` of the cone (none without the demand)."""
        if self.demand is None:
            return np.zeros(len(self.friction), dtype=bool)
        slack = self.demand.step_change
        return np.abs(self.friction - self.demand.friction) > tolerance * mu * self.normal + slack


def _own(traj: Trajectory, rolling_demand: tuple[NDArray, NDArray] | None) -> _Contact:
    """Each sample's own contact (no window)."""
    demand = None if rolling_demand is None else _Demand.at(*rolling_demand)
    return _Contact(traj.friction_force, traj.normal_force, traj.slip_velocity, demand)


def _averaged(means: _Means) -> _Contact:
    return _Contact(means.friction, means.normal, means.slip, means.demand)


def _under_slip_law(own: _Contact, forced: NDArray, mu: float, cfg: ContactSettings) -> NDArray:
    """Samples whose own contact follows the slip law at the strict tolerances (the friction at
    the cone within ``cone_tolerance`` either side, beyond it while sliding, or short of the
    rolling demand by more than ``cone_tolerance`` of the cone; or the contact sliding against
    it faster than ``creep_speed``): where a slip's first sample may lie.
    At the cone their own sliding is not asked: a slip starts from rest, its slip velocity
    growing as the square of the time since (the window's mean must slide); beyond the cone
    without sliding is a stick outside it, no slip."""
    law = own.cannot_roll(mu, cfg.cone_tolerance, cfg.cone_tolerance)
    beyond = np.abs(own.friction) > (1.0 + cfg.cone_tolerance) * mu * own.normal
    fast = own.sliding(cfg.creep_speed)
    return forced & ((law & ~(beyond & ~own.sliding(cfg.slip_floor))) | fast)


def _step_labels(own: _Contact, forced: NDArray, mu: float, cfg: ContactSettings) -> NDArray:
    """Each sample's own label (no window): slip + or - where it slides under the slip law
    (:func:`_under_slip_law`; the slip opposes the friction), roll where its friction is
    inside the cone by more than ``cone_hold`` and it does not, else none (-1)."""
    slipping = _under_slip_law(own, forced, mu, cfg)
    inside = np.abs(own.friction) < (1.0 - cfg.cone_hold) * mu * own.normal
    labels = np.where(forced & inside & ~slipping, _ROLL, -1)
    labels = np.where(slipping & (own.friction < 0), _SLIP_PLUS, labels)
    return np.where(slipping & (own.friction > 0), _SLIP_MINUS, labels)


def _slipping(
    means: _Means, own: _Contact, forced: NDArray, mu: float, cfg: ContactSettings
) -> NDArray:
    """Samples in a slip. A slip is a stretch where the window means slide against the
    friction under the slip law (:func:`_holds`), that slides faster than the slip threshold
    somewhere after its entry. It is entered at the stretch's first sample whose own contact
    slides and cannot roll (at the cone within ``cone_tolerance`` or beyond it, or short of
    the rolling demand by ``demand_tolerance``) or slides faster than ``creep_speed``, short
    of the demand only where the slide then grows (:func:`_entry`); the modes then move its
    start back over the samples just before it that slide under the slip law themselves
    (:func:`_refined_start`)."""
    fast = np.abs(means.slip) > cfg.slip_threshold
    averaged = _averaged(means)
    # The window means' law at cone_hold and demand_tolerance: read by the slip law and by
    # the entry's short demand alike, made once.
    cannot_roll = averaged.cannot_roll(mu, cfg.cone_hold, cfg.demand_tolerance)
    hold = _holds(means, mu, cfg, cannot_roll)  # a step without force inside a slip is the slip's
    demand_short = own.cannot_roll(mu, cfg.cone_tolerance, cfg.demand_tolerance)
    fast_own = np.abs(own.slip) > cfg.creep_speed
    # Only friction that cannot give the demand starts a slip, in the window's mean and in the
    # sample's own; friction above the demand only brakes a slide already going. Short of the
    # demand inside the cone starts one only once the rim slides beyond the slip threshold, and
    # the slide grows (_entry): a soft friction lags a demand that ramps up (MuJoCo stock: 4-8
    # % of the cone below it, the rim creeping at 0.1-0.4 mm/s, in the 7 ms before its
    # friction reaches the cone).
    at_cone = averaged.cannot_roll(mu, cfg.cone_hold, math.inf)
    # A chattering window's mean friction is no law's level (at the cone on some steps, the
    # demand on others): PyBullet's cylinder, creeping at 1.0-1.1 mm/s, sits 4 % short of the
    # demand on average for 5 ms before its slip, its slide flat.
    steady = means.cone_share < cfg.chatter_share
    short = cannot_roll & fast & steady
    firm = at_cone | (np.abs(means.slip) > cfg.creep_speed)
    enter = hold & (firm | short) & forced & (demand_short | fast_own)
    out = np.zeros(len(forced), dtype=bool)
    # A slip slides one way: a reversal is a new slip, entered anew (at the cone on the other
    # side, as the exact reversal is).
    for start, stop in _runs(hold & (means.friction < 0)) + _runs(hold & (means.friction > 0)):
        entry = _entry(enter[start:stop], firm[start:stop], np.abs(means.slip[start:stop]), cfg)
        if entry is None or not fast[start + entry : stop].any():
            continue
        out[start + entry : stop] = True
    return _through_crossings(out, hold, means, mu, cfg)


def _entry(enter: NDArray, firm: NDArray, speed: NDArray, cfg: ContactSettings) -> int | None:
    """Where a stretch under the slip law enters its slip (an index into it), or None: its
    first entry where the window's friction is at the cone, rolling cannot go on or the slide
    is faster than ``creep_speed`` (``firm``), or an earlier one short of the rolling
    demand inside the cone from which the slide (``speed``: |mean s|, m/s) grows by more than
    the slip threshold before that. A friction that saturates short of the demand lets the
    slide run away; one that lags a demand ramping up while the rim creeps leaves the slide
    at its creeping speed (Box2D stock at dt 1e-3 held its friction at 4-6 % of the cone for
    6 ms while the demand ramped to 24 %, its rim creeping on at 3.8-4.5 mm/s: no slip)."""
    hits = np.nonzero(enter)[0]
    if not hits.size:
        return None
    firm_hits = hits[firm[hits]]
    until = int(firm_hits[0]) if firm_hits.size else len(enter)
    early = hits[hits < until]
    if early.size:
        # The fastest slide from each early entry up to ``until``: the running maximum, read
        # backwards from there.
        ahead = np.maximum.accumulate(speed[early[0] : until][::-1])[::-1]
        grows = ahead[early - early[0]] - speed[early] > cfg.slip_threshold
        if grows.any():
            return int(early[np.argmax(grows)])
    return until if firm_hits.size else None


def _through_crossings(
    slipping: NDArray, hold: NDArray, windows: _Means, mu: float, cfg: ContactSettings
) -> NDArray:
    """``slipping`` on from a slip through each stretch where the rolling demand passes the
    level of its friction while the rim slides on one way (short of the demand at the
    slip's end, above it where the slide next holds the slip law, each by more than
    ``demand_tolerance`` of the cone; its share of the cone held within that tolerance
    across the stretch), and through the braking after it. A friction that
    saturates below mu (DART stock's) slides the rim while the demand exceeds it and brakes
    it once the demand has fallen below it; in between, it lies within the tolerance of the
    demand without following it (it stays at its level while the demand sweeps past), and
    the rim slides on at its fastest: one slip, not a slip, a creep and no re-stick. Only a
    slip goes on so: the stretches it joins start none."""
    means = _averaged(windows)
    if means.demand is None:
        return slipping
    band = cfg.demand_tolerance * mu * means.normal + means.demand.step_change
    along = means.shortfall()
    short, above = along > band, along < -band
    with np.errstate(divide="ignore", invalid="ignore"):
        share = means.friction / (mu * means.normal)
    out = slipping.copy()
    sliding = means.sliding(cfg.slip_floor) & windows.touched
    for sign in (-1.0, 1.0):
        for start, stop in _runs(sliding & (np.sign(means.friction) == sign)):
            pieces = [(start + a, start + b) for a, b in _runs(hold[start:stop])]
            for (_, end), (begin, after) in itertools.pairwise(pieces):
                crossed = short[end - 1] and above[begin]
                # The demand passes through the band around the friction's level: the
                # friction's share of the cone, which a law that saturates holds while n
                # changes, held within the tolerance. Not a friction that flickers across a
                # still demand (Newton's float32 noise) or one catching up with it.
                held = abs(share[begin] - share[end - 1]) < cfg.demand_tolerance
                if out[end - 1] and crossed and held:
                    out[end:after] = True
    return out


def _holds(means: _Means, mu: float, cfg: ContactSettings, cannot_roll: NDArray) -> NDArray:
    """Window means under the slip law: sliding against the friction, and the friction at or
    beyond the cone (within ``cone_hold``), unable to give the rolling demand (``cannot_roll``:
    the means' ``_Contact.cannot_roll`` at ``cone_hold`` and ``demand_tolerance``) or away from
    it (either side, by more than ``demand_tolerance`` of the cone: a friction that saturates
    below mu, or one above the demand that brakes a slide), or the slide faster than
    ``creep_speed`` (fast sliding is never creep)."""
    averaged = _averaged(means)
    law = (
        cannot_roll
        | averaged.off_demand(mu, cfg.demand_tolerance)
        | (np.abs(means.slip) > cfg.creep_speed)
    )
    return averaged.sliding(cfg.slip_floor) & law & means.touched


Mode = tuple[str, float]
"""(phase code, start time in s)."""

_FLIGHT, _ROLL, _SLIP_PLUS, _SLIP_MINUS = 0, 1, 2, 3
_CODES = {_FLIGHT: "F", _ROLL: "R", _SLIP_PLUS: "S+", _SLIP_MINUS: "S-"}
_SLIP_CODES = ("S+", "S-")
_STEP_LABELS = (_ROLL, _SLIP_PLUS, _SLIP_MINUS)
"""The modes a single sample's own friction can show."""


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


def _crossings(t: NDArray, y: NDArray, i: NDArray, level: float) -> NDArray:
    """:func:`_crossing` at each index of ``i``, the same arithmetic element by element."""
    prev = np.maximum(i - 1, 0)
    flat = (i == 0) | (y[i] == y[prev])
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = (level - y[prev]) / np.where(flat, 1.0, y[i] - y[prev])
    # Python's min(max(frac, 0), 1) keeps a NaN, as np.minimum(np.maximum(...)) does.
    inside = t[prev] + np.minimum(np.maximum(frac, 0.0), 1.0) * (t[i] - t[prev])
    return np.where(flat, t[i], inside)


def contact_masks(traj: Trajectory, settings: ContactSettings) -> tuple[NDArray, NDArray]:
    """The samples in contact (n above the contact level) and those with a contact force
    (:func:`_forced`: in contact, or a friction above ``friction_level``), as the canonical
    reading reads them (module doc); the force columns read the second too."""
    touching = traj.normal_force > settings.contact_level * settings.g
    return touching, _forced(touching, traj.friction_force, settings)


def _forced(touching: NDArray, f: NDArray, cfg: ContactSettings) -> NDArray:
    """The samples with a contact force: ``touching`` (n above the contact level) or a
    friction above ``friction_level``. A friction acts on the hoop with or without a normal
    force: DART stock (random-10 of the truth draw 9,301,130, dt 1e-3) slides 0.16 s at up to
    430 mm/s on the floor with n at 1e-17 and a friction of 0.3-1.2 m/s^2 that its momentum
    balance confirms (dXdot/dt within 10 %, as on its steps with n); read as samples without
    force, that stretch took the mode it interrupts, a roll. The flights stay the normal
    force's (a hop's lift-off is where the floor stops pushing)."""
    return touching | (np.abs(f) > cfg.friction_level)


def _flights(
    t: NDArray, n: NDArray, clearance: NDArray, touching: NDArray, cfg: ContactSettings
) -> list[Flight]:
    # Whole arrays at once: an engine whose contact force flickers has a few thousand
    # one-step "flights" a run, and a loop over them was most of reading a run (pymunk at
    # 1e-4 s: 1,976 a run, 12 of 18 ms).
    level = cfg.contact_level * cfg.g
    edges = np.diff(np.concatenate(([0], (~touching).astype(np.int8), [0])))
    starts, stops = np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]
    if not starts.size:
        return []
    ends_inside = stops < len(t)
    t_start = _crossings(t, n, starts, level).tolist()
    t_end: list[float | None] = _crossings(t, n, np.minimum(stops, len(t) - 1), level).tolist()
    if not ends_inside[-1]:  # only the last flight can reach the record's end
        t_end[-1] = _landing(t, clearance, int(starts[-1]))
    # Each flight's peak: the maximum over [start, stop), stretches that never touch.
    bounds = np.stack((starts, stops), axis=1).ravel()
    peaks = np.maximum.reduceat(clearance, bounds[:-1] if not ends_inside[-1] else bounds)
    return [Flight(a, b, c) for a, b, c in zip(t_start, t_end, peaks[::2].tolist(), strict=True)]


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


def _labels(forced: NDArray, slipping: NDArray, f: NDArray, in_hop: NDArray) -> NDArray:
    """Per sample: flight (inside a hop), roll, slip + or - (the slip opposes the mean
    friction ``f``). A sample without contact force outside a hop (chatter, or a force that
    drops out for a step while the hoop stays on the floor) reads as the mode it interrupts:
    it is counted with the chatter, not as a phase."""
    labels = np.where(forced, _ROLL, -1)
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
        return first  # flights start and end where the force does
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
