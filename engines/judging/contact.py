"""The events read from the contact force: the second reading of every run.

The kinematic detectors (:mod:`hoopbench.engines.judging.detectors`) read a run through its
clearance and slip velocity. That reading is blind to what the engine's contact does: a hoop
resting 9 mm deep has a clearance that crosses zero long after its contact force ends, a
single-sample slip spike with no normal force is no slip, and a soft contact's creep (slip
velocity while friction is far below the cone) is no Coulomb slip. This module reads the same
run through its contact force, as the rigid model defines the events:

- **in contact** while the normal force n exceeds ``contact_level`` g;
- **flight**: every stretch without contact is recorded with its duration and the largest
  clearance inside it. A flight that lasts ``sustain`` and rises above the hop threshold is a
  **hop**; the others are **chatter**, counted and sized;
- **lift-off** is the start of the first hop, **impact** its end (the contact returns);
- **slip**: friction saturated, |f| >= (1 - ``saturation``) mu n, while in contact; the slip
  direction is opposite the friction force. **Roll**: in contact with friction inside the cone.
  A change of mode counts once it lasts ``sustain``; a stretch shorter than that belongs to
  the phase around it (pymunk loses its contact force on single steps while rolling);
- **creep**: in contact, friction inside the cone, and the slip velocity above the
  detectors' slip threshold: a soft contact's creep, sized, never a slip.

On the exact solution both readings give the exact events (tests/test_contact_reading.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from hoopbench.engines.judging.detectors import DetectorSettings, hoop_scale
from hoopbench.models.events import PhaseKind
from hoopbench.models.trajectory import Trajectory

__all__ = ["ContactReading", "ContactSettings", "Flight", "read_contact"]


@dataclass(frozen=True)
class ContactSettings:
    """Thresholds of the contact reading for a hoop of radius ``a`` under ``g``; stated for
    the 1 m hoop, carried to any other as the detectors' are (:func:`hoop_scale`)."""

    a: float = 1.0
    """Hoop radius, m, these thresholds are stated for."""
    g: float = 9.8
    """Gravity, m/s^2, these thresholds are stated for."""
    contact_level: float = 1e-6
    """In contact while n > contact_level g (dimensionless): any force at all, above round-off.
    The exact n falls to zero at a lift-off as the square of the time left, so a higher level
    leaves early: 1e-3 g read hop-top's lift-off 3.7 ms early, 1e-6 g reads it within a
    sample at dt 1e-4. Every engine's force is exactly 0 without contact."""
    saturation: float = 1e-3
    """Friction counts as saturated when |f| >= (1 - saturation) mu n (dimensionless): the
    tolerance of the issue's check (|f|/n >= 0.999 mu). The exact |f| / (mu n) crosses 1 at a
    slip onset at about 1-2 per second, so the reading calls it about 0.5 ms early."""
    saturation_exit: float = 1e-2
    """Once slipping, friction may sag to (1 - saturation_exit) mu n without a re-stick
    (dimensionless): Drake's regularised friction (stock stiction tolerance) holds
    0.996-0.9999 mu n while slipping at 2-50 mm/s, which the entry tolerance alone reads as
    a roll every other millisecond. An exact re-stick drops far below either level at once."""
    sliding_saturation: float = 5e-2
    """While the rim slides against its friction (|slip velocity| above the slip threshold,
    friction opposing it), friction within this fraction of the cone counts as saturated too
    (dimensionless). Drake's stock friction slides at up to 0.8 m/s with |f| at 0.98-0.995 mu
    n: a slip by every reading a person would make, which the cone's tolerance alone misses
    (measured on unseen scenes). Rolling (no slip velocity) never meets it, so the exact
    onsets are read as before."""
    sustain: float = 5e-3
    """s: how long a new contact mode must last to count (the detectors' restick_sustain and
    lift_sustain on the 1 m hoop); it scales with sqrt(a / g)."""
    takeover_share: float = 0.5
    """A new mode must also hold at least this share of the samples with a contact force in
    the ``sustain`` after its first sample (dimensionless). Soft contacts (Rapier, Box2D)
    chatter before a slip: the force drops out every few steps and friction touches the cone
    on a lone step every few ms. Summed across the steps without force, those lone steps
    read as a slip 10-21 ms early, with friction at the cone on 8-48 % of the contact samples
    after it. MuJoCo's slip onset, at the cone on all but a step here and there, reads as
    before."""
    hop_clearance: float = DetectorSettings().hop_clearance
    """m: the hop threshold (the detectors' one home, DetectorSettings.hop_clearance)."""
    slip_threshold: float = DetectorSettings().slip_threshold
    """m/s: the slip speed above which a roll with unsaturated friction is creep."""

    def for_hoop(self, a: float, g: float) -> ContactSettings:
        """These thresholds carried to a hoop of radius ``a`` (m) under ``g`` (m/s^2)."""
        length, speed, duration = hoop_scale(a, g, self.a, self.g)
        return replace(
            self,
            a=a,
            g=g,
            sustain=self.sustain * duration,
            hop_clearance=self.hop_clearance * length,
            slip_threshold=self.slip_threshold * speed,
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
    """A run read through its contact force. Times in s, lengths in m, speeds in m/s; None:
    did not happen."""

    t_slip: float | None
    """First slip onset: friction saturates, sustained."""
    t_restick: float | None
    """First return to rolling after the first slip."""
    t_lift: float | None
    """Start of the first hop (a flight lasting ``sustain`` above the hop threshold)."""
    t_impact: float | None
    """End of that hop: the contact returns."""
    hop_height: float | None
    """Largest clearance inside the first hop."""
    phases: str
    """The contact modes as codes, e.g. 'R S+ R S- R' or 'R S+ F'."""
    t_last_phase: float | None
    """Start of the last contact mode (the phase comparison's window-end rule reads it)."""
    flights: tuple[Flight, ...]
    """Every stretch without contact, chatter included."""
    chatter_count: int
    """Flights that are not hops (too short or too low)."""
    chatter_max_clearance: float | None
    """m: the largest clearance inside chatter (None without chatter)."""
    creep_time: float
    """s: time rolling (in a roll mode, in contact, friction inside the cone) with |slip
    velocity| above the slip threshold."""
    creep_max_speed: float | None
    """m/s: the largest |slip velocity| while creeping (None without creep)."""


def read_contact(
    traj: Trajectory,
    mu: float,
    settings: ContactSettings | None = None,
    *,
    window_end: float | None = None,
) -> ContactReading:
    """The contact reading of ``traj`` with the pair's friction coefficient ``mu``.

    ``window_end`` (s): where the exact solution's window ends (its impact, for a hop). The
    hop is the highest hop-sized flight that starts before it (a chatter flight that comes
    first is not the hop), and the phases end with the hop's impact, as the exact ones do.
    """
    cfg = settings or ContactSettings()
    t, n, f = traj.t, traj.normal_force, traj.friction_force
    touching = n > cfg.contact_level * cfg.g
    sliding = (np.abs(traj.slip_velocity) > cfg.slip_threshold) & (f * traj.slip_velocity < 0)
    saturated = _saturated(touching, np.abs(f), mu * n, sliding, cfg)
    flights = _flights(t, n, traj.clearance, touching, cfg)
    hops = [fl for fl in flights if _is_hop(fl, t, cfg)]
    chatter = [fl for fl in flights if fl not in hops]
    end = math.inf if window_end is None else window_end
    hop = max((h for h in hops if h.t_start <= end), key=lambda h: h.max_clearance, default=None)
    in_hop = _inside(t, hops) & ~touching
    labels = _labels(touching, saturated, f, in_hop)
    modes = _modes(t, labels, touching | in_hop, cfg)
    if hop is not None and hop.t_end is not None:
        modes = [m for m in modes if m[1] <= hop.t_end]  # the exact model ends at the impact
    t_slip, t_restick = _slip_events(modes)
    rolling = touching & ~saturated & _in_mode(t, modes, PhaseKind.ROLL)
    creep_time, creep_max_speed = _creep(t, traj.slip_velocity, rolling, cfg.slip_threshold)
    return ContactReading(
        t_slip=t_slip,
        t_restick=t_restick,
        t_lift=None if hop is None else hop.t_start,
        t_impact=None if hop is None else hop.t_end,
        hop_height=None if hop is None else hop.max_clearance,
        phases=" ".join(_code(kind, sigma) for kind, _, sigma in modes),
        t_last_phase=modes[-1][1] if modes else None,
        flights=tuple(flights),
        chatter_count=len(chatter),
        chatter_max_clearance=max((fl.max_clearance for fl in chatter), default=None),
        creep_time=creep_time,
        creep_max_speed=creep_max_speed,
    )


def _saturated(
    touching: NDArray, friction: NDArray, cone: NDArray, sliding: NDArray, cfg: ContactSettings
) -> NDArray:
    """Samples at the friction cone, with hysteresis: a stretch of contact samples at the
    loose level (1 - saturation_exit, or 1 - sliding_saturation while sliding) is saturated
    from its first sample at the strict level (1 - saturation, or the sliding level) on.
    Samples without contact force neither start nor end a stretch."""
    idx = np.nonzero(touching)[0]
    ratio = friction[idx] / cone[idx]
    slides = sliding[idx] & (ratio >= 1.0 - cfg.sliding_saturation)
    loose = (ratio >= 1.0 - cfg.saturation_exit) | slides
    strict = (ratio >= 1.0 - cfg.saturation) | slides
    saturated = np.zeros(len(touching), dtype=bool)
    for start, stop in _runs(loose):
        hits = np.nonzero(strict[start:stop])[0]
        if hits.size:
            saturated[idx[start + int(hits[0]) : stop]] = True
    return saturated


def _in_mode(t: NDArray, modes: list[Mode], kind: PhaseKind) -> NDArray:
    """Samples inside the modes of ``kind`` (a mode lasts until the next one starts)."""
    inside = np.zeros(len(t), dtype=bool)
    ends = [m[1] for m in modes[1:]] + [math.inf]
    for (mode, start, _), end in zip(modes, ends, strict=True):
        if mode is kind:
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
    slips = [k for k, (kind, _, _) in enumerate(modes) if kind is PhaseKind.SLIP]
    if not slips:
        return None, None
    restick = [m[1] for m in modes[slips[0] :] if m[0] is PhaseKind.ROLL]
    return modes[slips[0]][1], restick[0] if restick else None


def _creep(
    t: NDArray, slip_velocity: NDArray, unsaturated: NDArray, threshold: float
) -> tuple[float, float | None]:
    """(time creeping, s; largest |slip velocity| while creeping, m/s or None)."""
    creeping = unsaturated & (np.abs(slip_velocity) > threshold)
    time = float(np.sum(np.diff(t, append=t[-1])[creeping]))
    return time, float(np.max(np.abs(slip_velocity[creeping]))) if creeping.any() else None


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


Mode = tuple[PhaseKind, float, int | None]
"""(kind, start time in s, slip direction or None)."""


def _labels(touching: NDArray, saturated: NDArray, f: NDArray, in_hop: NDArray) -> NDArray:
    """Per sample: 0 flight (inside a hop), 1 roll, 2 slip +, 3 slip - (the slip opposes the
    friction). A sample without contact force outside a hop (chatter, or a force that drops
    out for a step while the hoop stays on the floor) reads as the mode it interrupts: it is
    counted with the chatter, not as a phase."""
    labels = np.where(touching, 1, -1)
    labels = np.where(saturated & (f < 0), 2, labels)
    labels = np.where(saturated & (f > 0), 3, labels)
    labels = np.where(in_hop, 0, labels)
    known = np.nonzero(labels >= 0)[0]
    if known.size == 0:
        return np.zeros(len(labels), dtype=int)  # no contact at all: one flight
    # Each neutral sample takes the label before it (the first known one at the start).
    fill = np.maximum.accumulate(np.where(labels >= 0, np.arange(len(labels)), -1))
    fill = np.where(fill < 0, known[0], fill)
    return labels[fill]


_KINDS = {
    0: (PhaseKind.FLIGHT, None),
    1: (PhaseKind.ROLL, None),
    2: (PhaseKind.SLIP, 1),
    3: (PhaseKind.SLIP, -1),
}


Run = tuple[int, float, float]
"""(label, start time, end time in s; the last run ends at infinity)."""


def _label_runs(t: NDArray, labels: NDArray) -> list[tuple[int, int, int]]:
    """(label, first sample, sample after the last) of each run of equal labels."""
    edges = np.nonzero(np.diff(labels))[0] + 1
    starts = np.concatenate(([0], edges))
    stops = np.concatenate((edges, [len(t)]))
    return [(int(labels[i]), int(i), int(j)) for i, j in zip(starts, stops, strict=True)]


def _holds_from(t: NDArray, labels: NDArray, own: NDArray, i: int, cfg: ContactSettings) -> bool:
    """Whether the label of sample i holds at least ``takeover_share`` of the samples with a
    label of their own (``own``: not borrowed by a sample without force) in the ``sustain``
    after it; with none there (a contact whose force acts on one step in fifty), it does."""
    stop = int(np.searchsorted(t, t[i] + cfg.sustain))
    window = own[i:stop]
    if not window.any():
        return True
    return bool(np.mean(labels[i:stop][window] == labels[i]) >= cfg.takeover_share)


def _takes_over(runs: list[Run], k: int, sustain: float) -> bool:
    """Whether run k's label becomes the mode: it gathers ``sustain`` of time (its own runs,
    interrupted or not) before any run of another label lasts ``sustain`` on its own. So a
    slip whose friction leaves the cone for a step here and there (MuJoCo's contact bounces
    at a slip onset) starts at its first saturated sample, and a single saturated step
    inside a roll is no slip."""
    label, held = runs[k][0], 0.0
    for other, start, end in runs[k:]:
        if other == label:
            held += end - start
            if held >= sustain:
                return True
        elif end - start >= sustain:
            return False
    return held > 0.0  # the record ends first: a mode at the window's end counts


def _modes(t: NDArray, labels: NDArray, own: NDArray, cfg: ContactSettings) -> list[Mode]:
    """The contact modes from the per-sample labels (:func:`_labels`): the mode changes at
    the first run of a label that holds the samples after it (:func:`_holds_from`: lone
    saturated steps in a chattering contact are no slip) and takes over
    (:func:`_takes_over`); the first mode starts at t[0]."""
    bounds = _label_runs(t, labels)
    runs = [(label, float(t[i]), float(t[j]) if j < len(t) else math.inf) for label, i, j in bounds]
    modes: list[tuple[int, float]] = []
    for k, (label, first, _) in enumerate(bounds):
        if modes and modes[-1][0] == label:
            continue
        if _holds_from(t, labels, own, first, cfg) and _takes_over(runs, k, cfg.sustain):
            modes.append((label, runs[k][1] if modes else float(t[0])))
    return [(_KINDS[label][0], start, _KINDS[label][1]) for label, start in modes]


def _code(kind: PhaseKind, sigma: int | None) -> str:
    letter = {PhaseKind.ROLL: "R", PhaseKind.SLIP: "S", PhaseKind.FLIGHT: "F"}[kind]
    return letter + {1: "+", -1: "-"}.get(sigma or 0, "")
