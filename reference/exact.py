"""Exact, event-driven hybrid solver for the weighted hoop.

Modes: rolling, slipping (sigma = +1 or -1) and flight. Each mode is integrated with
``scipy.integrate.solve_ivp`` (DOP853 by default) and its events are located by root finding on
the dense output, to the integration tolerance: slip onset (|f| = mus n), re-stick or slip
reversal (slip velocity back to zero), lift-off (n = 0), the Painlevé point (D = 0) and the
first impact after a lift-off, which ends the window.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from hoopbench.models import kinematics
from hoopbench.models.events import Events, Outcome, Phase, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference import dynamics

__all__ = ["ExactSolution", "Segment", "flight_phase", "solve_exact"]

State = tuple[float, float, float, float, float, float]
"""(X, Y, theta, Xdot, Ydot, thetadot): centre of mass and angle, SI units."""


@dataclass(frozen=True)
class Segment:
    """One phase of the exact solution with its dense output."""

    kind: PhaseKind
    t_start: float
    """s."""
    t_end: float
    """s."""
    sigma: int | None
    """Slip direction for slip phases (0 when there is no friction at all)."""
    states: Callable[[NDArray], NDArray] = field(repr=False)
    """t, shape (m,) -> state rows, shape (6, m): X, Y, theta, Xdot, Ydot, thetadot."""
    forces: Callable[[NDArray], tuple[NDArray, NDArray]] = field(repr=False)
    """t, shape (m,) -> (f, n) per unit mass, m/s^2."""


@dataclass(frozen=True)
class ExactSolution:
    """Result of :func:`solve_exact`: the events and a dense trajectory."""

    scene: Scene
    events: Events
    segments: tuple[Segment, ...]
    rtol: float
    atol: float

    @property
    def t_final(self) -> float:
        """End of the solved window, s (t_end or the first impact)."""
        return self.segments[-1].t_end if self.segments else 0.0

    def state(self, t: ArrayLike) -> NDArray:
        """State rows (6, m) at times t (s) within [0, t_final]."""
        return self._evaluate(np.atleast_1d(np.asarray(t, dtype=float)))[0]

    def sample(self, t: ArrayLike) -> Trajectory:
        """The normalised trajectory at the requested times, s (clipped to the window)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        states, f, n = self._evaluate(t)
        X, Y, theta, Xdot, Ydot, thetadot = states
        return Trajectory.from_state(
            self.scene,
            t=t,
            X=X,
            Y=Y,
            theta=theta,
            Xdot=Xdot,
            Ydot=Ydot,
            thetadot=thetadot,
            normal_force=n,
            friction_force=f,
            contact=self._in_contact(t),
        )

    def sample_uniform(self, dt: float) -> Trajectory:
        """Samples every dt seconds from 0 to t_final (inclusive of 0)."""
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"dt must be a positive number of seconds, got {dt}")
        n = math.floor(self.t_final / dt + 1e-9)
        return self.sample(np.minimum(np.arange(n + 1) * dt, self.t_final))

    def _segment_index(self, t: NDArray) -> NDArray:
        ends = np.array([s.t_end for s in self.segments])
        return np.minimum(np.searchsorted(ends, t, side="left"), len(self.segments) - 1)

    def _in_contact(self, t: NDArray) -> NDArray:
        kinds = [self.segments[i].kind for i in self._segment_index(t)]
        return np.array([k is not PhaseKind.FLIGHT for k in kinds], dtype=bool)

    def _evaluate(self, t: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        if t.size and (t.min() < -1e-12 or t.max() > self.t_final + 1e-9):
            raise ValueError(f"times must lie in [0, {self.t_final}] s")
        states = np.empty((6, t.size))
        f = np.empty(t.size)
        n = np.empty(t.size)
        index = self._segment_index(t)
        for i, seg in enumerate(self.segments):
            mask = index == i
            if mask.any():
                tt = np.clip(t[mask], seg.t_start, seg.t_end)
                states[:, mask] = seg.states(tt)
                f[mask], n[mask] = seg.forces(tt)
        return states, f, n


# --------------------------------------------------------------------------- phases
def _event(fun: Callable, direction: float) -> Callable:
    fun.terminal = True
    fun.direction = direction
    return fun


@dataclass
class _PhaseEnd:
    t: float
    state: State
    reason: str  # "end", "slip", "lift", "restick", "painleve"


def _integrate(rhs, y0, t0, t_end, events, rtol, atol, method, max_step):
    # solve_ivp looks for event sign changes only at step ends; the step cap keeps an event
    # function from dipping below zero and back inside one long, smooth rolling step.
    return solve_ivp(
        rhs,
        (t0, t_end),
        y0,
        method=method,
        rtol=rtol,
        atol=atol,
        events=events,
        dense_output=True,
        max_step=max_step,
    )


def _which_event(sol, names: list[str]) -> str:
    """The event that ended the integration: the earliest one (ties: first in ``names``)."""
    if sol.status == 1:
        fired = [(times[0], k) for k, times in enumerate(sol.t_events) if len(times)]
        return names[min(fired)[1]]
    if sol.status < 0:
        raise RuntimeError(f"integration failed: {sol.message}")
    return "end"


def _roll_phase(scene: Scene, t0: float, state: State, t_end: float, opts) -> tuple:
    a, r = scene.a, scene.com_offset
    x0 = state[0] - r * math.sin(state[2])
    theta_start = state[2]

    def rhs(t, y):
        return (y[1], dynamics.rolling_thetaddot(scene, y[0], y[1]))

    def slip(t, y):
        f, n = dynamics.rolling_forces(scene, y[0], y[1])
        return scene.mus * n - abs(f)

    def lift(t, y):
        return dynamics.rolling_forces(scene, y[0], y[1])[1]

    sol = _integrate(
        rhs,
        [state[2], state[5]],
        t0,
        t_end,
        [_event(slip, -1), _event(lift, -1)],
        *opts,
    )
    reason = _which_event(sol, ["slip", "lift"])
    dense = sol.sol

    def states(t):
        theta, thetadot = dense(t)
        s, c = np.sin(theta), np.cos(theta)
        return np.vstack(
            [
                x0 + a * (theta - theta_start) + r * s,
                a + r * c,
                theta,
                thetadot * (a + r * c),
                -r * s * thetadot,
                thetadot,
            ]
        )

    def forces(t):
        theta, thetadot = dense(t)
        return dynamics.rolling_forces(scene, theta, thetadot)

    t1 = float(sol.t[-1])
    seg = Segment(PhaseKind.ROLL, t0, t1, None, states, forces)
    return seg, _PhaseEnd(t1, tuple(states(np.array([t1]))[:, 0]), reason)


def _slip_phase(scene: Scene, t0: float, state: State, sigma: int, t_end: float, opts) -> tuple:
    a, r = scene.a, scene.com_offset

    def rhs(t, y):
        _, theta, Xdot, thetadot = y
        Xddot, _, thetaddot, _ = dynamics.slip_accelerations(scene, theta, thetadot, sigma)
        return (Xdot, thetadot, Xddot, thetaddot)

    def directed_slip(y) -> float:
        return sigma * float(kinematics.slip_velocity(scene, y[2], y[1], y[3]))

    # The re-stick event is armed only once the slip has really started (sigma*s > SLIP_ARM):
    # with mus = muk the slip velocity leaves zero with zero slope, and an event function that
    # starts at zero would fire at the phase start and make the modes chatter.
    armed = [False]

    def restick(t, y):
        value = directed_slip(y)
        if not armed[0]:
            if value <= SLIP_ARM:
                return 1.0
            armed[0] = True
        return value

    def wrong_way(t, y):
        # The slip develops against sigma: the onset direction was not consistent.
        return directed_slip(y) + SLIP_ARM

    def lift(t, y):
        return dynamics.slip_normal_force(scene, y[1], y[3], sigma)

    def painleve(t, y):
        return dynamics.slip_denominator(scene, y[1], sigma)

    names = ["lift", "painleve"]
    events = [_event(lift, -1), _event(painleve, -1)]
    if sigma != 0:
        names[:0] = ["restick", "wrong-way"]
        events[:0] = [_event(restick, -1), _event(wrong_way, -1)]
    sol = _integrate(rhs, [state[0], state[2], state[3], state[5]], t0, t_end, events, *opts)
    try:
        reason = _which_event(sol, names)
    except RuntimeError:
        # The step size collapses as D -> 0+ (n and thetaddot blow up): that is Painlevé.
        theta_last = sol.y[1, -1]
        if dynamics.slip_denominator(scene, theta_last, sigma) < 1e-3:
            reason = "painleve"
        else:
            raise
    if reason == "wrong-way":
        reason, sol_t1 = _restick_inside_first_step(scene, sol, sigma)
    else:
        sol_t1 = float(sol.t[-1])
    if reason == "lift" and dynamics.slip_denominator(scene, sol.y[1, -1], sigma) < 1e-6:
        reason = "painleve"  # n -> 0 together with D -> 0: the Painlevé point, not a hop
    dense = sol.sol

    def states(t):
        X, theta, Xdot, thetadot = dense(t)
        return np.vstack(
            [X, a + r * np.cos(theta), theta, Xdot, -r * np.sin(theta) * thetadot, thetadot]
        )

    def forces(t):
        _, theta, _, thetadot = dense(t)
        n = dynamics.slip_normal_force(scene, theta, thetadot, sigma)
        return -sigma * scene.muk * n, n

    t1 = sol_t1
    seg = Segment(PhaseKind.SLIP, t0, t1, sigma, states, forces)
    return seg, _PhaseEnd(t1, tuple(states(np.array([t1]))[:, 0]), reason)


def _restick_inside_first_step(scene: Scene, sol, sigma: int) -> tuple[str, float]:
    """After a "wrong-way" event: did the slip go the right way and come back first?

    The re-stick event is armed at step ends only; when one step holds the whole slip, the
    slip velocity's return through zero shows up as a wrong-way crossing. Look at the dense
    output: if sigma*s rose above SLIP_ARM before, the slip ended where it came back to zero.
    """
    t0, t1 = float(sol.t[0]), float(sol.t[-1])
    grid = np.linspace(t0, t1, 401)

    def directed(t):
        _, theta, Xdot, thetadot = sol.sol(t)
        return sigma * kinematics.slip_velocity(scene, Xdot, theta, thetadot)

    values = directed(grid)
    peak = int(np.argmax(values))
    if values[peak] <= SLIP_ARM:
        return "wrong-way", t1
    after = np.nonzero(values[peak:] <= 0.0)[0]
    k = peak + int(after[0])
    t_re = brentq(lambda t: float(directed(t)), grid[k - 1], grid[k], xtol=1e-15)
    return "restick", float(t_re)


def _flight_clearance(scene: Scene, state: State, tau: NDArray) -> NDArray:
    _, Y, theta, _, Ydot, thetadot = state
    Yt = Y + Ydot * tau - 0.5 * scene.g * tau**2
    return kinematics.clearance(scene, Yt, theta + thetadot * tau)


def flight_phase(scene: Scene, t0: float, state: State) -> tuple[Segment, float, float]:
    """Ballistic phase from a lift-off; returns the segment, the impact time and hop height."""
    X, Y, theta, Xdot, Ydot, thetadot = state
    g, a, r = scene.g, scene.a, scene.com_offset

    def clear(tau):
        return _flight_clearance(scene, state, np.asarray(tau, dtype=float))

    # y - a <= Y - a + r: once the centre of mass falls below a - r the hoop is down for sure.
    disc = Ydot**2 + 2.0 * g * (Y - (a - r))
    tau_max = (Ydot + math.sqrt(max(disc, 0.0))) / g + 1e-9
    spin_period = 2.0 * math.pi / abs(thetadot) if thetadot != 0 else math.inf
    h = min(tau_max, spin_period) / 400.0
    grid = np.arange(1, math.ceil(tau_max / h) + 2) * h
    c = clear(grid)
    below = np.nonzero(c < 0.0)[0]
    if below.size == 0:  # cannot happen: tau_max is past the fall
        raise RuntimeError("flight: no impact found")
    i = below[0]
    lo = grid[i - 1] if i > 0 else h * 1e-6
    tau_impact = brentq(clear, lo, grid[i], xtol=1e-15, rtol=4 * np.finfo(float).eps)
    # Hop height: the largest sampled clearance, refined on its neighbourhood.
    inside = grid[:i]
    height = 0.0
    if inside.size:
        j = int(np.argmax(c[:i]))
        lo_h = grid[j - 1] if j > 0 else 0.0
        hi_h = grid[j + 1] if j + 1 < grid.size else grid[j]
        res = minimize_scalar(
            lambda s: -float(clear(s)),
            bounds=(lo_h, min(hi_h, tau_impact)),
            method="bounded",
            options={"xatol": 1e-13},
        )
        height = max(float(c[j]), -float(res.fun), 0.0)

    def states(t):
        tau = np.asarray(t) - t0
        return np.vstack(
            [
                X + Xdot * tau,
                Y + Ydot * tau - 0.5 * g * tau**2,
                theta + thetadot * tau,
                np.full_like(tau, Xdot),
                Ydot - g * tau,
                np.full_like(tau, thetadot),
            ]
        )

    def forces(t):
        z = np.zeros_like(np.asarray(t, dtype=float))
        return z, z.copy()

    t_impact = t0 + float(tau_impact)
    return Segment(PhaseKind.FLIGHT, t0, t_impact, None, states, forces), t_impact, height


# --------------------------------------------------------------------------- driver
SLIP_ARM = 1e-9
"""|slip velocity| (m/s) a slip must reach before its re-stick event is armed."""
MIN_PHASE = 1e-9
"""Phases shorter than this (s) are transition artefacts (a slip reversal that re-sticks at
once): they stay in the dense solution but are left out of the reported phase list."""


def _initial_slip_direction(scene: Scene, f: float) -> int:
    if scene.mus == 0.0:
        return 0
    return -1 if f > 0 else 1


def _leave_rolling(scene: Scene, state: State, f_roll: float) -> tuple[str, int | None]:
    """Mode after rolling needs n <= 0: flight if the free hoop centre rises, else slip.

    Flight is consistent only if the hoop centre, free of contact forces, does not accelerate
    into the floor; otherwise the hoop must keep contact and slide.
    """
    theta, thetadot = state[2], state[5]
    free = float(dynamics.free_centre_acceleration(scene, theta, thetadot))
    rising = -scene.lam * scene.a * math.sin(theta) * thetadot**3  # d(free)/dt in flight
    if free > 0 or (free == 0 and rising > 0):
        return "flight", None
    return "slip", _initial_slip_direction(scene, f_roll)


def solve_exact(
    scene: Scene,
    *,
    rtol: float = 1e-10,
    atol: float = 1e-12,
    method: str = "DOP853",
    max_step: float = 1e-2,
    max_phases: int = 10_000,
) -> ExactSolution:
    """Solve the scene from t = 0 to its t_end or the first impact, whichever comes first.

    A flight that starts before t_end is followed to its impact even past t_end.
    ``rtol`` and ``atol`` are the integrator's tolerances; events are located by root finding
    on the dense output (machine precision on that interpolant). ``max_step`` (s) bounds the
    integration steps so that an event function cannot cross zero and back unseen.
    """
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (value > 0 and math.isfinite(value)):
            raise ValueError(f"{name} must be a positive number, got {value}")
    if not (max_step > 0):
        raise ValueError(f"max_step must be a positive number of seconds, got {max_step}")
    opts = (rtol, atol, method, max_step)
    t, state = 0.0, scene.initial_state()
    segments: list[Segment] = []
    phases: list[Phase] = []
    found: dict[str, float] = {}
    outcome: Outcome | None = None
    message = ""
    extra: dict[str, float | None] = {}
    flips = 0

    # Which mode does the hoop start in?
    s0 = scene.centre_velocity0 - scene.a * scene.thetadot0
    if scene.rolls_at_start:
        f0, n0 = (float(v) for v in dynamics.rolling_forces(scene, scene.theta0, scene.thetadot0))
        if n0 < 0:
            mode, sigma = _leave_rolling(scene, scene.initial_state(), f0)
        elif abs(f0) > scene.mus * n0 or (scene.mus == 0 and f0 != 0):
            mode, sigma = "slip", _initial_slip_direction(scene, f0)
        else:
            mode, sigma = "roll", None
    else:
        sigma = 1 if s0 > 0 else -1
        if scene.is_degenerate:
            mode = "slip"
        else:
            n0 = float(dynamics.slip_normal_force(scene, scene.theta0, scene.thetadot0, sigma))
            d0 = float(dynamics.slip_denominator(scene, scene.theta0, sigma))
            mode = "painleve" if d0 <= 0 else ("flight" if n0 < 0 else "slip")
        if scene.muk == 0:
            sigma = 0 if scene.mus == 0 else sigma

    def first_slip(t_now: float, st: State) -> None:
        if "t_slip" not in found:
            found["t_slip"] = t_now
            found["theta_slip"] = st[2]
            found["thetadot_slip"] = st[5]

    if mode == "painleve":
        outcome = Outcome.PAINLEVE
        message = "D <= 0 at t = 0: no consistent contact force for this sliding start"
    if mode == "flight":
        outcome = Outcome.LIFTS_AT_START
    while outcome is None or mode == "flight":
        if mode != "flight" and t >= scene.t_end:
            break
        if len(segments) >= max_phases:
            raise RuntimeError(f"more than {max_phases} phases: chattering between modes?")
        if mode == "roll":
            seg, end = _roll_phase(scene, t, state, scene.t_end, opts)
        elif mode == "slip":
            first_slip(t, state)
            if scene.is_degenerate:
                outcome = Outcome.DEGENERATE
                message = (
                    f"slip at t = {t:.6g} s needs I > 0; lam = {scene.lam}, eps = {scene.eps} "
                    "give I = 0 (degenerate case)"
                )
                break
            if sigma and dynamics.slip_denominator(scene, state[2], sigma) <= 0:
                outcome = Outcome.PAINLEVE
                message = f"D <= 0 when slip starts at t = {t:.6g} s: no consistent contact force"
                break
            seg, end = _slip_phase(scene, t, state, sigma, scene.t_end, opts)
        else:  # flight
            seg, t_impact, height = flight_phase(scene, t, state)
            segments.append(seg)
            phases.append(Phase(PhaseKind.FLIGHT, seg.t_start, seg.t_end))
            found["t_lift"] = t
            found["t_impact"] = t_impact
            found["hop_height"] = height
            outcome = outcome or Outcome.HOPS
            break
        segments.append(seg)
        if seg.t_end - seg.t_start > MIN_PHASE or end.reason == "end":
            phases.append(Phase(seg.kind, seg.t_start, seg.t_end, seg.sigma))
        t, state = end.t, end.state
        if end.reason == "end":
            break
        if end.reason == "slip":
            f, _ = dynamics.rolling_forces(scene, state[2], state[5])
            mode, sigma = "slip", _initial_slip_direction(scene, float(f))
        elif end.reason == "lift" and seg.kind is PhaseKind.ROLL:
            f, _ = dynamics.rolling_forces(scene, state[2], state[5])
            mode, sigma = _leave_rolling(scene, state, float(f))
        elif end.reason == "lift":
            mode = "flight"
        elif end.reason == "wrong-way":
            # Neither direction consistent right at onset (a grazing touch of the friction
            # cone): the hoop keeps rolling.
            flips = flips + 1 if end.t - seg.t_start < 1e-9 else 0
            mode, sigma = ("roll", None) if flips >= 2 else ("slip", -sigma)
        elif end.reason == "restick":
            f, n = (float(v) for v in dynamics.rolling_forces(scene, state[2], state[5]))
            if abs(f) <= scene.mus * n:
                mode = "roll"
                found.setdefault("t_restick", t)
            else:
                sigma = -sigma  # the slip velocity passes through zero: slip reverses
            # Snap the centre velocity onto s = 0 so the next phase starts consistent.
            X, Y, th, Xdot, Ydot, thd = state
            s = float(kinematics.slip_velocity(scene, Xdot, th, thd))
            state = (X, Y, th, Xdot - s, Ydot, thd)
        elif end.reason == "painleve":
            outcome = Outcome.PAINLEVE
            extra["t_painleve"] = t
            extra["theta_painleve_deg"] = math.degrees(state[2])
            message = f"D = 0 (Painlevé) at t = {t:.6g} s, theta = {math.degrees(state[2]):.4f} deg"

    if outcome is None:
        outcome = Outcome.SLIPS if "t_slip" in found else Outcome.ROLLS
    events = Events(
        outcome=outcome,
        t_slip=found.get("t_slip"),
        theta_slip=found.get("theta_slip"),
        thetadot_slip=found.get("thetadot_slip"),
        t_restick=found.get("t_restick"),
        t_lift=found.get("t_lift"),
        hop_height=found.get("hop_height"),
        t_impact=found.get("t_impact"),
        phases=tuple(phases),
        message=message,
        extra=extra,
    )
    if not segments:  # nothing integrable (Painlevé or degenerate at t = 0)
        segments.append(_frozen_segment(scene, state))
    return ExactSolution(scene, events, tuple(segments), rtol, atol)


def _frozen_segment(scene: Scene, state: State) -> Segment:
    """A zero-length segment holding the initial state, so sampling t = 0 works."""

    def states(t):
        return np.tile(np.asarray(state, dtype=float)[:, None], (1, np.size(t)))

    def forces(t):
        z = np.full(np.size(t), np.nan)
        return z, z.copy()

    return Segment(PhaseKind.ROLL, 0.0, 0.0, None, states, forces)
