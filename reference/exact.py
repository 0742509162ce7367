"""Exact, event-driven hybrid solver for the weighted hoop.

Modes: rolling, slipping (sigma = +1 or -1) and flight. Each mode is integrated with
``scipy.integrate.solve_ivp`` (DOP853 by default) and its events are located by root finding on
the dense output, to the integration tolerance: slip onset (|f| = mus n), re-stick or slip
reversal (slip velocity back to zero), lift-off (n = 0), the Painlevé point (D = 0) and the
first impact after a lift-off, which ends the window.

The equations are invariant under a change of length and time units, so the solver's absolute
settings (the step cap, the absolute tolerance, the slip-velocity and phase-length thresholds)
are stated for a 1 m hoop under g = 9.8 m/s^2 and scaled with the scene's radius a and time
scale sqrt(a/g): a 1 nm hoop is solved with the same work and accuracy as a 1 m one.

The work is bounded: a scene whose window spans very many time scales sqrt(a/g) (a tiny hoop,
a huge g, a long t_end) ends with the outcome "error" and a message once ``max_steps``
integrator steps or ``max_phases`` phases are used, instead of running for hours.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, minimize_scalar

from hoopbench.models import kinematics
from hoopbench.models.events import Events, Outcome, Phase, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference import dynamics

__all__ = [
    "DEFAULT_ATOL",
    "DEFAULT_MAX_PHASES",
    "DEFAULT_MAX_SAMPLES",
    "DEFAULT_MAX_STEPS",
    "DEFAULT_RTOL",
    "EventReason",
    "ExactSolution",
    "Mode",
    "Segment",
    "WorkBudgetError",
    "flight_phase",
    "solve_exact",
]

DEFAULT_RTOL = 1e-10
"""solve_ivp relative tolerance: event times agree to ~1e-11 s with 1e-12 (tests/test_exact.py)."""
DEFAULT_ATOL = 1e-12
"""solve_ivp absolute tolerance: m, rad, m/s, rad/s for a 1 m hoop under g = 9.8 m/s^2; the
solver scales it with the scene's length a and time sqrt(a/g) (see :func:`solve_exact`)."""
DEFAULT_MAX_STEPS = 100_000
"""Integrator steps one :func:`solve_exact` call may take. The catalogue scenes need a few
hundred; at about 0.25 ms a step the budget bounds a call to tens of seconds."""
DEFAULT_MAX_PHASES = 10_000
"""Phases (mode switches) one :func:`solve_exact` call may go through."""
DEFAULT_MAX_SAMPLES = 5_000_000
"""Samples :meth:`ExactSolution.sample_uniform` may create: building a trajectory takes about
135 bytes a sample (measured), so at most about 0.7 GB."""

State = tuple[float, float, float, float, float, float]
"""(X, Y, theta, Xdot, Ydot, thetadot): centre of mass and angle, SI units."""


class Mode(Enum):
    """State of the solver's mode machine: which phase is integrated next."""

    ROLL = "roll"
    SLIP = "slip"
    FLIGHT = "flight"
    PAINLEVE = "painleve"
    """No consistent contact force (D <= 0) before anything could be integrated."""


class EventReason(Enum):
    """Why an integrated contact phase ended."""

    END = "end"
    """The window's end, t_end."""
    SLIP = "slip"
    """Rolling: static friction no longer suffices, |f| = mus n."""
    LIFT = "lift"
    """The normal force reached zero."""
    RESTICK = "restick"
    """Slipping: the slip velocity came back to zero."""
    WRONG_WAY = "wrong-way"
    """Slipping: the slip developed against the assumed direction sigma."""
    PAINLEVE = "painleve"
    """Slipping: D reached zero, no consistent contact force."""
    BUDGET = "budget"
    """The call's integrator step budget ran out."""
    SETTLED = "settled"
    """Rolling: theta advanced a full turn in this roll phase (only with stop_when_settled)."""


class WorkBudgetError(RuntimeError):
    """Solving would take more work than the caller allowed (steps, phases or samples)."""


# Where the solver's absolute settings were tuned (the seed scene): a 1 m hoop, 9.8 m/s^2.
_TUNED_A = 1.0
_TUNED_G = 9.8


@dataclass(frozen=True)
class _Units:
    """The scene's length and time units relative to the tuned 1 m, 9.8 m/s^2 hoop.

    Both are exactly 1.0 for a = 1 m, g = 9.8 m/s^2, so those scenes are solved bit for bit
    as before the scaling was introduced.
    """

    length: float
    time: float

    @classmethod
    def of(cls, scene: Scene) -> _Units:
        return cls(scene.a / _TUNED_A, math.sqrt((scene.a / scene.g) / (_TUNED_A / _TUNED_G)))

    @property
    def velocity(self) -> float:
        return self.length / self.time


@dataclass(frozen=True)
class _Options:
    """Integrator settings shared by the phases of one solve."""

    rtol: float
    atol: float
    """In tuned units; :meth:`atol_for` scales it per state component."""
    method: str
    max_step: float
    """s, already in the scene's time unit."""
    units: _Units

    def atol_for(self, kinds: str) -> NDArray:
        """Absolute tolerances for state components: 'x' length, 'a' angle, 'v' velocity,
        'w' angular velocity."""
        u = self.units
        scale = {"x": u.length, "a": 1.0, "v": u.velocity, "w": 1.0 / u.time}
        return np.array([self.atol * scale[k] for k in kinds])


@dataclass
class _StepBudget:
    """Integrator steps left to one solve, shared by its phases (mutable: it counts)."""

    max_steps: int
    used: int = 0

    @property
    def exhausted(self) -> bool:
        return self.used >= self.max_steps

    def event(self) -> Callable:
        """A terminal event for one phase that fires at the step where the budget runs out.

        solve_ivp evaluates each event once per accepted step (and once at the start), so the
        calls count the steps. Once over budget the value is t_out - t: zero at that step's
        end, where solve_ivp's root finding then places the (terminal) event.
        """
        t_out: list[float] = []

        def budget(t, y):
            if not t_out:
                self.used += 1
                if self.used <= self.max_steps:
                    return 1.0
                t_out.append(t)
            return t_out[0] - t

        return _event(budget, -1)


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
    t_settled: float | None = None
    """s: where a ``stop_when_settled`` solve stopped, a full turn of theta into its last roll
    phase (the events still describe the whole window); None when solved to the end."""

    @property
    def t_final(self) -> float:
        """End of the solved window, s (t_end or the first impact; t_settled if set)."""
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

    def sample_uniform(self, dt: float, *, max_samples: int = DEFAULT_MAX_SAMPLES) -> Trajectory:
        """Samples every dt seconds from 0 to t_final (inclusive of 0).

        Raises ValueError for a dt that is not a positive number, longer than the scene's
        window t_end, or so short that the trajectory would hold more than ``max_samples``
        samples (checked before anything is allocated).
        """
        if not (dt > 0 and math.isfinite(dt)):
            raise ValueError(f"dt must be a positive number of seconds, got {dt}")
        if dt > self.scene.t_end:
            raise ValueError(
                f"dt = {dt:g} s is longer than the window, t_end = {self.scene.t_end:g} s"
            )
        n = math.floor(self.t_final / dt + 1e-9)
        if n + 1 > max_samples:
            raise ValueError(
                f"sampling every dt = {dt:g} s over t_final = {self.t_final:.6g} s makes "
                f"{n + 1:.3g} samples, more than max_samples = {max_samples}"
            )
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


FLIGHT_CHUNK = 1 << 16
"""Clearance samples evaluated at once while looking for the impact."""
FLIGHT_MAX_SAMPLES = 20_000_000
"""Clearance samples a flight may need before its impact (a few seconds of work)."""


# --------------------------------------------------------------------------- phases
def _event(fun: Callable, direction: float) -> Callable:
    fun.terminal = True
    fun.direction = direction
    return fun


@dataclass(frozen=True)
class _PhaseEnd:
    t: float
    state: State
    reason: EventReason


@dataclass(frozen=True)
class _Solved:
    """What the phases use of a solve_ivp result, in seconds (see :func:`_integrate`)."""

    t: NDArray
    y: NDArray
    t_events: list[NDArray]
    status: int
    message: str
    sol: Callable[[ArrayLike], NDArray] = field(repr=False)


def _integrate(
    rhs: Callable,
    y0: list[float],
    t0: float,
    t_end: float,
    events: list[Callable],
    opts: _Options,
    atol_kinds: str,
    budget: _StepBudget,
) -> _Solved:
    """solve_ivp in the scene's time unit, with the budget's event appended.

    solve_ivp locates events to an absolute time tolerance (4 machine epsilons of its time
    variable): integrating in units of sqrt(a/g) (relative to the tuned hoop) makes that
    tolerance relative to the scene's time scale. For a = 1 m, g = 9.8 m/s^2 the unit is
    exactly 1.0 and every number is as in seconds.
    """
    unit = opts.units.time

    def scaled_rhs(s, y):
        return [unit * v for v in rhs(s * unit, y)]

    def scaled_event(event: Callable) -> Callable:
        return _event(lambda s, y: event(s * unit, y), event.direction)

    # solve_ivp looks for event sign changes only at step ends; the step cap keeps an event
    # function from dipping below zero and back inside one long, smooth rolling step.
    # The budget event comes last, so that a physical event in the same step wins ties.
    sol = solve_ivp(
        scaled_rhs,
        (t0 / unit, t_end / unit),
        y0,
        method=opts.method,
        rtol=opts.rtol,
        atol=opts.atol_for(atol_kinds),
        events=[scaled_event(e) for e in [*events, budget.event()]],
        dense_output=True,
        max_step=opts.max_step / unit,
    )
    dense = sol.sol
    return _Solved(
        t=sol.t * unit,
        y=sol.y,
        t_events=[times * unit for times in sol.t_events],
        status=sol.status,
        message=sol.message,
        sol=lambda t: dense(np.asarray(t, dtype=float) / unit),
    )


def _which_event(sol, names: list[EventReason]) -> EventReason:
    """The event that ended the integration: the earliest one (ties: first in ``names``).

    ``names`` lists the physical events; the budget event that :func:`_integrate` appends is
    last.
    """
    if sol.status == 1:
        fired = [(times[0], k) for k, times in enumerate(sol.t_events) if len(times)]
        return [*names, EventReason.BUDGET][min(fired)[1]]
    if sol.status < 0:
        raise RuntimeError(f"integration failed: {sol.message}")
    return EventReason.END


def _roll_phase(
    scene: Scene,
    t0: float,
    state: State,
    t_end: float,
    opts: _Options,
    budget: _StepBudget,
    *,
    settle: bool = False,
) -> tuple[Segment, _PhaseEnd]:
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

    def turned(t, y):
        return abs(y[0] - theta_start) - 2.0 * math.pi

    # The full-turn event comes after the physical ones, so that they win ties; without
    # ``settle`` the event list, and so every step and number, is exactly as before.
    names = [EventReason.SLIP, EventReason.LIFT]
    events = [_event(slip, -1), _event(lift, -1)]
    if settle:
        names.append(EventReason.SETTLED)
        events.append(_event(turned, 1))
    sol = _integrate(rhs, [state[2], state[5]], t0, t_end, events, opts, "aw", budget)
    reason = _which_event(sol, names)
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


def _slip_phase(
    scene: Scene,
    t0: float,
    state: State,
    sigma: int,
    t_end: float,
    opts: _Options,
    budget: _StepBudget,
) -> tuple[Segment, _PhaseEnd]:
    a, r = scene.a, scene.com_offset
    slip_arm = SLIP_ARM * opts.units.velocity

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
            if value <= slip_arm:
                return 1.0
            armed[0] = True
        return value

    def wrong_way(t, y):
        # The slip develops against sigma: the onset direction was not consistent.
        return directed_slip(y) + slip_arm

    def lift(t, y):
        return dynamics.slip_normal_force(scene, y[1], y[3], sigma)

    def painleve(t, y):
        return dynamics.slip_denominator(scene, y[1], sigma)

    names = [EventReason.LIFT, EventReason.PAINLEVE]
    events = [_event(lift, -1), _event(painleve, -1)]
    if sigma != 0:
        names[:0] = [EventReason.RESTICK, EventReason.WRONG_WAY]
        events[:0] = [_event(restick, -1), _event(wrong_way, -1)]
    y0 = [state[0], state[2], state[3], state[5]]
    sol = _integrate(rhs, y0, t0, t_end, events, opts, "xavw", budget)
    try:
        reason = _which_event(sol, names)
    except RuntimeError:
        # The step size collapses as D -> 0+ (n and thetaddot blow up): that is Painlevé.
        theta_last = sol.y[1, -1]
        if dynamics.slip_denominator(scene, theta_last, sigma) < 1e-3:
            reason = EventReason.PAINLEVE
        else:
            raise
    if reason is EventReason.WRONG_WAY:
        reason, sol_t1 = _restick_inside_first_step(scene, sol, sigma, opts.units)
    else:
        sol_t1 = float(sol.t[-1])
    if reason is EventReason.LIFT and dynamics.slip_denominator(scene, sol.y[1, -1], sigma) < 1e-6:
        # n -> 0 together with D -> 0: the Painlevé point, not a hop
        reason = EventReason.PAINLEVE
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


def _restick_inside_first_step(
    scene: Scene, sol, sigma: int, units: _Units
) -> tuple[EventReason, float]:
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
    if values[peak] <= SLIP_ARM * units.velocity:
        return EventReason.WRONG_WAY, t1
    after = np.nonzero(values[peak:] <= 0.0)[0]
    k = peak + int(after[0])
    t_re = brentq(lambda t: float(directed(t)), grid[k - 1], grid[k], xtol=1e-15 * units.time)
    return EventReason.RESTICK, float(t_re)


def _flight_clearance(scene: Scene, state: State, tau: NDArray) -> NDArray:
    _, Y, theta, _, Ydot, thetadot = state
    Yt = Y + Ydot * tau - 0.5 * scene.g * tau**2
    return kinematics.clearance(scene, Yt, theta + thetadot * tau)


def flight_phase(
    scene: Scene, t0: float, state: State, *, max_samples: int | None = None
) -> tuple[Segment, float, float]:
    """Ballistic phase from a lift-off; returns the segment, the impact time and hop height.

    The clearance is scanned on a grid of 400 points per spin period (or per fall time, if
    that is shorter) up to the first impact, in chunks, so memory stays bounded; more than
    ``max_samples`` grid points before the impact (an extreme spin in a long flight; default
    :data:`FLIGHT_MAX_SAMPLES`) raise :class:`WorkBudgetError`.
    """
    if max_samples is None:
        max_samples = FLIGHT_MAX_SAMPLES
    X, Y, theta, Xdot, Ydot, thetadot = state
    g, a, r = scene.g, scene.a, scene.com_offset
    units = _Units.of(scene)

    def clear(tau):
        return _flight_clearance(scene, state, np.asarray(tau, dtype=float))

    # y - a <= Y - a + r: once the centre of mass falls below a - r the hoop is down for sure.
    disc = Ydot**2 + 2.0 * g * (Y - (a - r))
    tau_max = (Ydot + math.sqrt(max(disc, 0.0))) / g + 1e-9 * units.time
    spin_period = 2.0 * math.pi / abs(thetadot) if thetadot != 0 else math.inf
    h = min(tau_max, spin_period) / 400.0
    n_grid = math.ceil(tau_max / h) + 1

    def node(k: int) -> float:
        return float(k + 1) * h  # grid point k; the scan below uses the same values

    # Scan chunk by chunk for the first sample below the floor, keeping the highest sample
    # before it (the first one of equal values, as a single argmax would).
    i = j = -1
    best = -math.inf
    scanned = min(n_grid, max_samples)
    for start in range(0, scanned, FLIGHT_CHUNK):
        c = clear(np.arange(start + 1, min(start + FLIGHT_CHUNK, scanned) + 1) * h)
        below = np.nonzero(c < 0.0)[0]
        stop = int(below[0]) if below.size else c.size
        if stop > 0:
            k = int(np.argmax(c[:stop]))
            if c[k] > best:
                best, j = float(c[k]), start + k
        if below.size:
            i = start + stop
            break
    if i < 0 and scanned < n_grid:
        raise WorkBudgetError(
            f"the flight from t = {t0:.6g} s does not land within max_samples = {max_samples} "
            f"clearance samples ({n_grid:.3g} reach its latest possible impact, {tau_max:.3g} s "
            f"later, at 400 a spin period of {spin_period:.3g} s)"
        )
    if i < 0:  # cannot happen: tau_max is past the fall
        raise RuntimeError("flight: no impact found")
    lo = node(i - 1) if i > 0 else h * 1e-6
    tau_impact = brentq(clear, lo, node(i), xtol=1e-15 * units.time, rtol=4 * np.finfo(float).eps)
    # Hop height: the largest sampled clearance, refined on its neighbourhood.
    height = 0.0
    if i > 0:
        lo_h = node(j - 1) if j > 0 else 0.0
        hi_h = node(j + 1) if j + 1 < n_grid else node(j)
        res = minimize_scalar(
            lambda s: -float(clear(s)),
            bounds=(lo_h, min(hi_h, tau_impact)),
            method="bounded",
            options={"xatol": 1e-13 * units.time},
        )
        height = max(best, -float(res.fun), 0.0)

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
"""|slip velocity| (m/s for a 1 m hoop under 9.8 m/s^2, scaled with the scene's velocity unit)
a slip must reach before its re-stick event is armed."""
MIN_PHASE = 1e-9
"""Phases shorter than this (s for a 1 m hoop under 9.8 m/s^2, scaled with sqrt(a/g)) are
transition artefacts (a slip reversal that re-sticks at once): they stay in the dense solution
but are left out of the reported phase list."""
MAX_STEP = 1e-2
"""Default cap on an integration step (s for a 1 m hoop under 9.8 m/s^2, about 1/30 of its
time scale sqrt(a/g); scaled with sqrt(a/g))."""


def _initial_slip_direction(scene: Scene, f: float) -> int:
    if scene.mus == 0.0:
        return 0
    return -1 if f > 0 else 1


def _leave_rolling(scene: Scene, state: State, f_roll: float) -> tuple[Mode, int | None]:
    """Mode after rolling needs n <= 0: flight if the free hoop centre rises, else slip.

    Flight is consistent only if the hoop centre, free of contact forces, does not accelerate
    into the floor; otherwise the hoop must keep contact and slide.
    """
    theta, thetadot = state[2], state[5]
    free = float(dynamics.free_centre_acceleration(scene, theta, thetadot))
    rising = -scene.lam * scene.a * math.sin(theta) * thetadot**3  # d(free)/dt in flight
    if free > 0 or (free == 0 and rising > 0):
        return Mode.FLIGHT, None
    return Mode.SLIP, _initial_slip_direction(scene, f_roll)


def solve_exact(
    scene: Scene,
    *,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    method: str = "DOP853",
    max_step: float | None = None,
    max_steps: int = DEFAULT_MAX_STEPS,
    max_phases: int = DEFAULT_MAX_PHASES,
    stop_when_settled: bool = False,
) -> ExactSolution:
    """Solve the scene from t = 0 to its t_end or the first impact, whichever comes first.

    A flight that starts before t_end is followed to its impact even past t_end.
    ``rtol`` and ``atol`` are the integrator's tolerances; events are located by root finding
    on the dense output (machine precision on that interpolant). ``atol`` is stated for a 1 m
    hoop under g = 9.8 m/s^2 (m, rad, m/s, rad/s) and scaled with the scene's units (lengths
    with a, times with sqrt(a/g)), so that any scene is solved to the same relative accuracy.
    ``max_step`` (s) bounds the integration steps so that an event function cannot cross zero
    and back unseen; by default :data:`MAX_STEP` scaled with sqrt(a/g).

    The work is bounded by ``max_steps`` integrator steps (counted over all phases) and
    ``max_phases`` phases. When either runs out, or a flight would need too many samples to
    find its impact, the solution ends there with ``Outcome.ERROR`` and a message that says
    why; the events found until then are kept.

    ``stop_when_settled`` (default off) ends the integration once a roll phase has advanced
    theta by a full turn: while rolling, energy is conserved and the state is a function of
    theta mod 2 pi, so the motion then repeats with no further event. The events are those
    of the whole window (the last roll phase is reported up to t_end), but the dense solution
    ends at that turn, :attr:`ExactSolution.t_settled`.
    """
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (value > 0 and math.isfinite(value)):
            raise ValueError(f"{name} must be a positive number, got {value}")
    units = _Units.of(scene)
    if max_step is None:
        max_step = MAX_STEP * units.time
    if not (max_step > 0):
        raise ValueError(f"max_step must be a positive number of seconds, got {max_step}")
    for name, value in (("max_steps", max_steps), ("max_phases", max_phases)):
        if not (isinstance(value, int) and value > 0):
            raise ValueError(f"{name} must be a positive integer, got {value!r}")
    opts = _Options(rtol, atol, method, max_step, units)
    budget = _StepBudget(max_steps)
    t, state = 0.0, scene.initial_state()
    segments: list[Segment] = []
    phases: list[Phase] = []
    found: dict[str, float] = {}
    outcome: Outcome | None = None
    message = ""
    extra: dict[str, float | None] = {}
    flips = 0
    t_settled: float | None = None

    def over_budget(what: str) -> str:
        time_scale = math.sqrt(scene.a / scene.g)
        return (
            f"work budget exceeded: {what} at t = {t:.6g} s; the window t_end = "
            f"{scene.t_end:g} s spans {scene.t_end / time_scale:.3g} time scales sqrt(a/g) = "
            f"{time_scale:.3g} s (shorten t_end, or raise the budget)"
        )

    # Which mode does the hoop start in?
    s0 = scene.centre_velocity0 - scene.a * scene.thetadot0
    if scene.rolls_at_start:
        f0, n0 = (float(v) for v in dynamics.rolling_forces(scene, scene.theta0, scene.thetadot0))
        if n0 < 0:
            mode, sigma = _leave_rolling(scene, scene.initial_state(), f0)
        elif abs(f0) > scene.mus * n0 or (scene.mus == 0 and f0 != 0):
            mode, sigma = Mode.SLIP, _initial_slip_direction(scene, f0)
        else:
            mode, sigma = Mode.ROLL, None
    else:
        sigma = 1 if s0 > 0 else -1
        if scene.is_degenerate:
            mode = Mode.SLIP
        else:
            n0 = float(dynamics.slip_normal_force(scene, scene.theta0, scene.thetadot0, sigma))
            d0 = float(dynamics.slip_denominator(scene, scene.theta0, sigma))
            mode = Mode.PAINLEVE if d0 <= 0 else (Mode.FLIGHT if n0 < 0 else Mode.SLIP)
        if scene.muk == 0:
            sigma = 0 if scene.mus == 0 else sigma

    def first_slip(t_now: float, st: State) -> None:
        if "t_slip" not in found:
            found["t_slip"] = t_now
            found["theta_slip"] = st[2]
            found["thetadot_slip"] = st[5]

    if mode is Mode.PAINLEVE:
        outcome = Outcome.PAINLEVE
        message = "D <= 0 at t = 0: no consistent contact force for this sliding start"
    if mode is Mode.FLIGHT:
        outcome = Outcome.LIFTS_AT_START
    while outcome is None or mode is Mode.FLIGHT:
        if mode is not Mode.FLIGHT and t >= scene.t_end:
            break
        if len(segments) >= max_phases:
            outcome = Outcome.ERROR
            message = over_budget(f"max_phases = {max_phases} phases used")
            break
        if mode is not Mode.FLIGHT and budget.exhausted:
            outcome = Outcome.ERROR
            message = over_budget(f"max_steps = {max_steps} integrator steps used")
            break
        if mode is Mode.ROLL:
            seg, end = _roll_phase(
                scene, t, state, scene.t_end, opts, budget, settle=stop_when_settled
            )
        elif mode is Mode.SLIP:
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
            seg, end = _slip_phase(scene, t, state, sigma, scene.t_end, opts, budget)
        else:  # flight
            try:
                seg, t_impact, height = flight_phase(scene, t, state)
            except WorkBudgetError as exc:
                found["t_lift"] = t
                outcome = Outcome.ERROR
                message = over_budget(str(exc))
                break
            segments.append(seg)
            phases.append(Phase(PhaseKind.FLIGHT, seg.t_start, seg.t_end))
            found["t_lift"] = t
            found["t_impact"] = t_impact
            found["hop_height"] = height
            outcome = outcome or Outcome.HOPS
            break
        segments.append(seg)
        if end.reason is EventReason.SETTLED:
            # Nothing happens any more: the phase runs to the window's end, to the very number
            # an unstopped integration ends on (solve_ivp stops exactly at t_end / unit).
            t_window = scene.t_end / units.time * units.time
            phases.append(Phase(seg.kind, seg.t_start, t_window, seg.sigma))
            t_settled = end.t
            break
        if seg.t_end - seg.t_start > MIN_PHASE * units.time or end.reason is EventReason.END:
            phases.append(Phase(seg.kind, seg.t_start, seg.t_end, seg.sigma))
        t, state = end.t, end.state
        if end.reason is EventReason.END:
            break
        if end.reason is EventReason.BUDGET:
            outcome = Outcome.ERROR
            message = over_budget(f"max_steps = {max_steps} integrator steps used")
            break
        if end.reason is EventReason.SLIP:
            f, _ = dynamics.rolling_forces(scene, state[2], state[5])
            mode, sigma = Mode.SLIP, _initial_slip_direction(scene, float(f))
        elif end.reason is EventReason.LIFT and seg.kind is PhaseKind.ROLL:
            f, _ = dynamics.rolling_forces(scene, state[2], state[5])
            mode, sigma = _leave_rolling(scene, state, float(f))
        elif end.reason is EventReason.LIFT:
            mode = Mode.FLIGHT
        elif end.reason is EventReason.WRONG_WAY:
            # Neither direction consistent right at onset (a grazing touch of the friction
            # cone): the hoop keeps rolling.
            flips = flips + 1 if end.t - seg.t_start < MIN_PHASE * units.time else 0
            mode, sigma = (Mode.ROLL, None) if flips >= 2 else (Mode.SLIP, -sigma)
        elif end.reason is EventReason.RESTICK:
            f, n = (float(v) for v in dynamics.rolling_forces(scene, state[2], state[5]))
            if abs(f) <= scene.mus * n:
                mode = Mode.ROLL
                found.setdefault("t_restick", t)
            else:
                sigma = -sigma  # the slip velocity passes through zero: slip reverses
            # Snap the centre velocity onto s = 0 so the next phase starts consistent.
            X, Y, th, Xdot, Ydot, thd = state
            s = float(kinematics.slip_velocity(scene, Xdot, th, thd))
            state = (X, Y, th, Xdot - s, Ydot, thd)
        elif end.reason is EventReason.PAINLEVE:
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
    return ExactSolution(scene, events, tuple(segments), rtol, atol, t_settled)


def _frozen_segment(scene: Scene, state: State) -> Segment:
    """A zero-length segment holding the initial state, so sampling t = 0 works."""

    def states(t):
        return np.tile(np.asarray(state, dtype=float)[:, None], (1, np.size(t)))

    def forces(t):
        z = np.full(np.size(t), np.nan)
        return z, z.copy()

    return Segment(PhaseKind.ROLL, 0.0, 0.0, None, states, forces)
