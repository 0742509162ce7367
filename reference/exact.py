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
import numbers
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from enum import Enum
from functools import cached_property
from typing import Protocol, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import OdeSolution, solve_ivp
from scipy.integrate._ivp.rk import Dop853DenseOutput
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
    "MIN_RTOL",
    "EventReason",
    "ExactSolution",
    "Mode",
    "Segment",
    "WorkBudgetError",
    "first_flight_impact",
    "flight_phase",
    "solve_exact",
    "solve_exact_settled",
]

MIN_RTOL = 100 * float(np.finfo(float).eps)
"""scipy's explicit Runge-Kutta solvers raise a smaller rtol to this (2.2e-14) with a
warning: a smaller one would be recorded while another was used."""

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


class IntegrationError(RuntimeError):
    """The integrator gave up on a phase (its step fell below the spacing of floats, e.g.
    for g = 1e308): the solve ends there with ``Outcome.ERROR``."""


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

    def event(self) -> _EventFunction:
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
    together: Callable[[NDArray], tuple[NDArray, NDArray, NDArray]] | None = field(
        default=None, repr=False
    )
    """t -> (states, f, n), the numbers ``states`` and ``forces`` give, from one evaluation of
    the phase's dense output (half a sample's cost); None: the two are called in turn."""

    def evaluate(self, t: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        """The state rows and contact forces at ``t``: ``states(t)`` and ``forces(t)``."""
        if self.together is not None:
            return self.together(t)
        f, n = self.forces(t)
        return self.states(t), f, n


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
        # Per segment, then indexed: a list of every sample's kind cost 4 ms a 30,000-sample run.
        touching = np.array([s.kind is not PhaseKind.FLIGHT for s in self.segments], dtype=bool)
        return touching[self._segment_index(t)]

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
                states[:, mask], f[mask], n[mask] = seg.evaluate(tt)
        return states, f, n


FLIGHT_CHUNK = 1 << 16
"""Clearance samples evaluated at once while looking for the impact."""
FLIGHT_MAX_SAMPLES = 20_000_000
"""Clearance samples a flight may need before its impact (a few seconds of work)."""


# --------------------------------------------------------------------------- phases
class _EventFunction(Protocol):
    """A solve_ivp event: a function of (t, y) that carries the options solve_ivp reads."""

    terminal: bool
    direction: float

    def __call__(self, t: float, y: NDArray, /) -> float: ...


def _event(
    fun: Callable[[float, NDArray], float], direction: float, terminal: bool = True
) -> _EventFunction:
    event = cast(_EventFunction, fun)  # the same function, now carrying its options
    event.terminal = terminal
    event.direction = direction
    return event


@dataclass(frozen=True)
class _PhaseEnd:
    t: float
    state: State
    reason: EventReason
    turned: Segment | None = None
    """A roll phase that turned theta a full turn without ending (``_roll_phase``'s
    ``note``): the phase as a ``settle`` solve ends it, at that turn."""


@dataclass(frozen=True)
class _Solved:
    """What the phases use of a solve_ivp result, in seconds (see :func:`_integrate`)."""

    t: NDArray
    y: NDArray
    t_events: list[NDArray]
    status: int
    message: str
    sol: _Dense = field(repr=False)


@dataclass(frozen=True)
class _Dense:
    """A phase's dense output in seconds (solve_ivp's is in the scene's time unit)."""

    solution: OdeSolution
    unit: float
    """s: the scene's time unit (see :func:`_integrate`)."""

    def __call__(self, t: ArrayLike) -> NDArray:
        scaled = np.asarray(t, dtype=float) / self.unit
        steps = self._steps
        # One time is one step's polynomial either way: OdeSolution's own call has no loop
        # to save there, and is the quicker (a root finder's calls).
        if scaled.ndim != 1 or scaled.size < 2 or steps is None:
            return cast(NDArray, self.solution(scaled))
        return steps.at(scaled)

    @cached_property
    def _steps(self) -> _Dop853Steps | None:
        # Stacked once per phase, not at every call: a phase is sampled on several grids.
        return _Dop853Steps.of(self.solution)


_STEP_LOOKUP = ("ts_sorted", "side", "ascending", "n_segments")
"""The attributes OdeSolution finds a time's step by (SciPy's own; without them, as in a SciPy
that names them otherwise, its own call is used)."""


@dataclass(frozen=True)
class _Dop853Steps:
    """DOP853's dense output (solve_ivp's default, the exact solver's) with every integrator
    step's polynomial stacked, so that :meth:`at` evaluates it at all times at once, the same
    floats as ``solution(t)``: OdeSolution groups the times by step and calls each step's
    interpolant in a Python loop (300-3,000 steps a phase), most of sampling a solution
    (20-40 ms for 30,000 times, once per scene and timestep in a worker, 300,000 at 1e-5 s).
    """

    solution: OdeSolution
    t_old: NDArray
    """Each step's start, in the solution's time unit."""
    h: NDArray
    """Each step's length."""
    coefficients: NDArray
    """(powers, states, steps): each power's numbers at the times are one gather along the
    steps, and a value comes out (states, times) in C order, as OdeSolution's."""
    y_old: NDArray
    """(states, steps): each step's starting state."""

    @classmethod
    def of(cls, solution: OdeSolution) -> _Dop853Steps | None:
        """The steps of ``solution``; None where OdeSolution's own call is used (another
        interpolant, or a SciPy that finds a time's step by other names)."""
        interpolants = solution.interpolants
        if not all(hasattr(solution, name) for name in _STEP_LOOKUP) or any(
            type(i) is not Dop853DenseOutput for i in interpolants
        ):
            return None
        return cls(
            solution,
            t_old=np.array([i.t_old for i in interpolants]),
            h=np.array([i.h for i in interpolants]),
            coefficients=np.stack([i.F for i in interpolants], axis=-1),
            y_old=np.stack([i.y_old for i in interpolants], axis=-1),
        )

    def at(self, t: NDArray) -> NDArray:
        """``solution(t)``, ``t`` one-dimensional. Each time's step is the one OdeSolution
        picks, and its value is Dop853DenseOutput's arithmetic, operation for operation:
        x = (t - t_old) / h, then over the coefficients F in reverse y += f and y *= x or
        1 - x in turn, then y += y_old (tests/test_exact_samples.py)."""
        solution = self.solution
        steps = solution.n_segments
        index = np.searchsorted(solution.ts_sorted, t, side=solution.side) - 1
        index = np.clip(index, 0, steps - 1)
        if not solution.ascending:
            index = steps - 1 - index
        x = (t - self.t_old[index]) / self.h[index]
        y = np.zeros((self.y_old.shape[0], len(t)), dtype=self.y_old.dtype)
        for power, f in enumerate(self.coefficients[::-1]):
            y += f[:, index]
            if power % 2 == 0:
                y *= x
            else:
                y *= 1 - x
        y += self.y_old[:, index]
        return y


def _integrate(
    rhs: Callable,
    y0: list[float],
    t0: float,
    t_end: float,
    events: list[_EventFunction],
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

    def scaled_event(event: _EventFunction) -> _EventFunction:
        return _event(lambda s, y: event(s * unit, y), event.direction, event.terminal)

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
    return _Solved(
        t=sol.t * unit,
        y=sol.y,
        t_events=[times * unit for times in sol.t_events],
        status=sol.status,
        message=sol.message,
        sol=_Dense(sol.sol, unit),
    )


def _which_event(sol: _Solved, names: Sequence[EventReason | None]) -> EventReason:
    """The event that ended the integration: the earliest one (ties: first in ``names``).

    ``names`` lists the physical events, None for one that does not end it (non-terminal);
    the budget event that :func:`_integrate` appends is last.
    """
    if sol.status == 1:
        reasons = [*names, EventReason.BUDGET]
        fired = [
            (times[0], k)
            for k, times in enumerate(sol.t_events)
            if len(times) and reasons[k] is not None
        ]
        return cast(EventReason, reasons[min(fired)[1]])
    if sol.status < 0:
        raise IntegrationError(f"integration failed: {sol.message}")
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
    note: bool = False,
) -> tuple[Segment, _PhaseEnd]:
    """A roll phase from ``t0``: to ``t_end``, a slip or lift-off event, or the step budget's
    end; with ``settle``, to a full turn of theta too. With ``note`` (not with ``settle``),
    a full turn does not end it, but the phase as ``settle`` would end it there comes with
    its end (``_PhaseEnd.turned``)."""
    x0 = state[0] - scene.com_offset * math.sin(state[2])
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
    # ``settle`` the event list, and so every step and number, is exactly as before. Noted
    # (not terminal), it changes no step either: solve_ivp only locates its root.
    names: list[EventReason | None] = [EventReason.SLIP, EventReason.LIFT]
    events = [_event(slip, -1), _event(lift, -1)]
    if settle or note:
        names.append(EventReason.SETTLED if settle else None)
        events.append(_event(turned, 1, terminal=settle))
    sol = _integrate(rhs, [state[2], state[5]], t0, t_end, events, opts, "aw", budget)
    reason = _which_event(sol, names)
    motion = _Rolling(scene, sol.sol, x0, theta_start)
    t1 = float(sol.t[-1])
    seg = Segment(PhaseKind.ROLL, t0, t1, None, motion.states, motion.forces, motion.together)
    end = _PhaseEnd(t1, tuple(motion.states(np.array([t1]))[:, 0]), reason)
    if note and len(sol.t_events[2]):
        end = _turned_end(end, t0, sol, motion)
    return seg, end


def _turned_end(end: _PhaseEnd, t0: float, sol: _Solved, motion: _Rolling) -> _PhaseEnd:
    """``end`` with the roll phase as a ``settle`` solve ends it, at the first full turn of
    ``sol`` (a ``note`` solve's). Up to the turn that solve took the same steps, and the step
    it ended in had the same interpolant, which solve_ivp ends at the event's root: this
    phase's dense output gives its numbers at every time up to the turn (a segment's are
    read within its own span, ExactSolution._evaluate)."""
    t_turn = float(sol.t_events[2][0])
    states, forces, together = motion.states, motion.forces, motion.together
    return replace(end, turned=Segment(PhaseKind.ROLL, t0, t_turn, None, states, forces, together))


@dataclass(frozen=True)
class _Rolling:
    """A roll phase's states and contact forces from its dense output (theta, thetadot)."""

    scene: Scene
    dense: _Dense
    x0: float
    """m: X - r sin(theta) at the phase's start."""
    theta_start: float
    """rad."""

    def states(self, t: NDArray) -> NDArray:
        return self._states(*self.dense(t))

    def forces(self, t: NDArray) -> tuple[NDArray, NDArray]:
        theta, thetadot = self.dense(t)
        return dynamics.rolling_forces(self.scene, theta, thetadot)

    def together(self, t: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        theta, thetadot = self.dense(t)
        f, n = dynamics.rolling_forces(self.scene, theta, thetadot)
        return self._states(theta, thetadot), f, n

    def _states(self, theta: NDArray, thetadot: NDArray) -> NDArray:
        a, r = self.scene.a, self.scene.com_offset
        s, c = np.sin(theta), np.cos(theta)
        return np.vstack(
            [
                self.x0 + a * (theta - self.theta_start) + r * s,
                a + r * c,
                theta,
                thetadot * (a + r * c),
                -r * s * thetadot,
                thetadot,
            ]
        )


def _slip_events(
    scene: Scene, sigma: int, slip_arm: float
) -> tuple[list[EventReason], list[_EventFunction]]:
    """The slip phase's events and why each ends it, in the order that breaks ties."""

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
    return names, events


def _slip_end(
    scene: Scene, sol: _Solved, names: list[EventReason], sigma: int, units: _Units
) -> tuple[EventReason, float]:
    """Why and when the slip phase ended, correcting what its events alone would say."""
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
        reason, t1 = _restick_inside_first_step(scene, sol, sigma, units)
    else:
        t1 = float(sol.t[-1])
    if reason is EventReason.LIFT and dynamics.slip_denominator(scene, sol.y[1, -1], sigma) < 1e-6:
        # n -> 0 together with D -> 0: the Painlevé point, not a hop
        reason = EventReason.PAINLEVE
    return reason, t1


def _slip_phase(
    scene: Scene,
    t0: float,
    state: State,
    sigma: int,
    t_end: float,
    opts: _Options,
    budget: _StepBudget,
) -> tuple[Segment, _PhaseEnd]:
    def rhs(t, y):
        _, theta, Xdot, thetadot = y
        Xddot, _, thetaddot, _ = dynamics.slip_accelerations(scene, theta, thetadot, sigma)
        return (Xdot, thetadot, Xddot, thetaddot)

    names, events = _slip_events(scene, sigma, SLIP_ARM * opts.units.velocity)
    y0 = [state[0], state[2], state[3], state[5]]
    sol = _integrate(rhs, y0, t0, t_end, events, opts, "xavw", budget)
    reason, t1 = _slip_end(scene, sol, names, sigma, opts.units)
    motion = _Slipping(scene, sol.sol, sigma)
    seg = Segment(PhaseKind.SLIP, t0, t1, sigma, motion.states, motion.forces, motion.together)
    return seg, _PhaseEnd(t1, tuple(motion.states(np.array([t1]))[:, 0]), reason)


@dataclass(frozen=True)
class _Slipping:
    """A slip phase's states and contact forces from its dense output (X, theta, Xdot,
    thetadot)."""

    scene: Scene
    dense: _Dense
    sigma: int

    def states(self, t: NDArray) -> NDArray:
        return self._states(self.dense(t))

    def forces(self, t: NDArray) -> tuple[NDArray, NDArray]:
        return self._forces(self.dense(t))

    def together(self, t: NDArray) -> tuple[NDArray, NDArray, NDArray]:
        y = self.dense(t)
        return self._states(y), *self._forces(y)

    def _states(self, y: NDArray) -> NDArray:
        a, r = self.scene.a, self.scene.com_offset
        X, theta, Xdot, thetadot = y
        return np.vstack(
            [X, a + r * np.cos(theta), theta, Xdot, -r * np.sin(theta) * thetadot, thetadot]
        )

    def _forces(self, y: NDArray) -> tuple[NDArray, NDArray]:
        _, theta, _, thetadot = y
        n = dynamics.slip_normal_force(self.scene, theta, thetadot, self.sigma)
        return -self.sigma * self.scene.muk * n, n


def _restick_inside_first_step(
    scene: Scene, sol: _Solved, sigma: int, units: _Units
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


@dataclass(frozen=True)
class _FlightGrid:
    """Times after a lift-off at which a flight's clearance is sampled: node k at (k + 1) h."""

    h: float
    """s."""
    n: int
    """Nodes up to the latest possible impact."""

    def node(self, k: int) -> float:
        return float(k + 1) * self.h  # grid point k; the scan uses the same values


def _scan_for_impact(
    clear: Callable[[ArrayLike], NDArray], h: float, scanned: int
) -> tuple[int, int, float]:
    """The first of ``scanned`` nodes below the floor (-1 if none), the highest node before it
    (the first one of equal values, as a single argmax would) and its clearance.

    Chunk by chunk, so that memory stays bounded however long the flight.
    """
    i = j = -1
    best = -math.inf
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
    return i, j, best


def _hop_height(
    clear: Callable[[ArrayLike], NDArray],
    grid: _FlightGrid,
    highest: tuple[int, float],
    tau_impact: float,
    time_unit: float,
) -> float:
    """The largest sampled clearance ``highest`` (node, value), refined on its neighbourhood."""
    j, best = highest
    lo_h = grid.node(j - 1) if j > 0 else 0.0
    hi_h = grid.node(j + 1) if j + 1 < grid.n else grid.node(j)
    res = minimize_scalar(
        lambda s: -float(clear(s)),
        bounds=(lo_h, min(hi_h, tau_impact)),
        method="bounded",
        options={"xatol": 1e-13 * time_unit},
    )
    return max(best, -float(res.fun), 0.0)


def _flight_segment(scene: Scene, t0: float, state: State, t_impact: float) -> Segment:
    motion = _Flying(t0, state, scene.g)
    return Segment(PhaseKind.FLIGHT, t0, t_impact, None, motion.states, motion.forces)


@dataclass(frozen=True)
class _Flying:
    """A flight's states (ballistic, from the lift-off's) and its zero contact forces."""

    t0: float
    """s: the lift-off."""
    state: State
    g: float
    """m/s^2."""

    def states(self, t: NDArray) -> NDArray:
        X, Y, theta, Xdot, Ydot, thetadot = self.state
        g = self.g
        tau = np.asarray(t) - self.t0
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

    @staticmethod
    def forces(t: NDArray) -> tuple[NDArray, NDArray]:
        z = np.zeros_like(np.asarray(t, dtype=float))
        return z, z.copy()


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
    _, Y, _, _, Ydot, thetadot = state
    g, a, r = scene.g, scene.a, scene.com_offset
    units = _Units.of(scene)

    def clear(tau):
        return _flight_clearance(scene, state, np.asarray(tau, dtype=float))

    # y - a <= Y - a + r: once the centre of mass falls below a - r the hoop is down for sure.
    disc = Ydot**2 + 2.0 * g * (Y - (a - r))
    tau_max = (Ydot + math.sqrt(max(disc, 0.0))) / g + 1e-9 * units.time
    spin_period = 2.0 * math.pi / abs(thetadot) if thetadot != 0 else math.inf
    h = min(tau_max, spin_period) / 400.0
    grid = _FlightGrid(h, math.ceil(tau_max / h) + 1)
    scanned = min(grid.n, max_samples)
    i, j, best = _scan_for_impact(clear, h, scanned)
    if i < 0 and scanned < grid.n:
        raise WorkBudgetError(
            f"the flight from t = {t0:.6g} s does not land within max_samples = {max_samples} "
            f"clearance samples ({grid.n:.3g} reach its latest possible impact, {tau_max:.3g} s "
            f"later, at 400 a spin period of {spin_period:.3g} s)"
        )
    if i < 0:  # cannot happen: tau_max is past the fall
        raise RuntimeError("flight: no impact found")
    lo = grid.node(i - 1) if i > 0 else h * 1e-6
    tau_impact = brentq(
        clear, lo, grid.node(i), xtol=1e-15 * units.time, rtol=4 * np.finfo(float).eps
    )
    # The first node is already below the floor (i = 0): no sample above it to refine.
    height = _hop_height(clear, grid, (j, best), tau_impact, units.time) if i > 0 else 0.0
    t_impact = t0 + float(tau_impact)
    return _flight_segment(scene, t0, state, t_impact), t_impact, height


def first_flight_impact(scene: Scene) -> float | None:
    """When the exact motion first lands, s, if its first mode (:func:`_start_mode`, as
    :func:`solve_exact` chooses it) is a flight, the hoop leaving the floor at t = 0; None
    for any other start, whose first impact only the whole solution finds. The flight is
    ballistic (:func:`flight_phase`), so this integrates nothing: a cost estimate's shortcut
    (the hop map's runs stop at their first impact) before the solution is known. None too
    where the flight's scan would exceed its work budget."""
    if scene.is_degenerate:
        return None
    mode, _ = _start_mode(scene)
    if mode is not Mode.FLIGHT:
        return None
    try:
        _, t_impact, _ = flight_phase(scene, 0.0, scene.initial_state())
    except WorkBudgetError:
        return None
    return t_impact


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


def _start_mode(scene: Scene) -> tuple[Mode, int | None]:
    """The solution's first mode and slip direction (None: no slip), from its start."""
    return _rolling_start(scene) if scene.rolls_at_start else _sliding_start(scene)


def _rolling_start(scene: Scene) -> tuple[Mode, int | None]:
    """The first mode of a rolling start: roll, unless the contact forces cannot hold it."""
    f0, n0 = (float(v) for v in dynamics.rolling_forces(scene, scene.theta0, scene.thetadot0))
    if n0 < 0:
        return _leave_rolling(scene, scene.initial_state(), f0)
    if abs(f0) > scene.mus * n0 or (scene.mus == 0 and f0 != 0):
        return Mode.SLIP, _initial_slip_direction(scene, f0)
    return Mode.ROLL, None


def _sliding_start(scene: Scene) -> tuple[Mode, int | None]:
    """The first mode of a start with a slip velocity: slip, flight, or no contact force."""
    s0 = scene.centre_velocity0 - scene.a * scene.thetadot0
    sigma = 1 if s0 > 0 else -1
    if scene.is_degenerate:
        mode = Mode.SLIP
    else:
        n0 = float(dynamics.slip_normal_force(scene, scene.theta0, scene.thetadot0, sigma))
        d0 = float(dynamics.slip_denominator(scene, scene.theta0, sigma))
        mode = Mode.PAINLEVE if d0 <= 0 else (Mode.FLIGHT if n0 < 0 else Mode.SLIP)
    if scene.muk == 0:
        sigma = 0 if scene.mus == 0 else sigma
    return mode, sigma


def _checked_options(
    scene: Scene,
    rtol: float,
    atol: float,
    method: str,
    max_step: float | None,
    budgets: tuple[int, int],
) -> _Options:
    """The integrator settings; ValueError for a tolerance, step cap or budget
    (``budgets``: max_steps, max_phases) that is not a positive number."""
    for name, value in (("rtol", rtol), ("atol", atol)):
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise ValueError(f"{name} must be a positive number, got {value!r}")
        if not (value > 0 and math.isfinite(value)):
            raise ValueError(f"{name} must be a positive number, got {value}")
    if rtol < MIN_RTOL:
        raise ValueError(
            f"rtol must be >= {MIN_RTOL:.3g} (scipy raises a smaller one to it), got {rtol:g}"
        )
    units = _Units.of(scene)
    if max_step is None:
        max_step = MAX_STEP * units.time
    if not (max_step > 0):
        raise ValueError(f"max_step must be a positive number of seconds, got {max_step}")
    for name, budget in zip(("max_steps", "max_phases"), budgets, strict=True):
        if not (isinstance(budget, int) and budget > 0):
            raise ValueError(f"{name} must be a positive integer, got {budget!r}")
    return _Options(rtol, atol, method, max_step, units)


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
    opts = _checked_options(scene, rtol, atol, method, max_step, (max_steps, max_phases))
    solve = _solved(scene, opts, max_steps, max_phases, settle=stop_when_settled)
    return solve.solution()


def solve_exact_settled(
    scene: Scene,
    *,
    rtol: float = DEFAULT_RTOL,
    atol: float = DEFAULT_ATOL,
    method: str = "DOP853",
    max_step: float | None = None,
    max_steps: int = DEFAULT_MAX_STEPS,
    max_phases: int = DEFAULT_MAX_PHASES,
) -> tuple[ExactSolution, ExactSolution]:
    """``(solve_exact(scene, stop_when_settled=True), solve_exact(scene))``, bit for bit,
    from one integration of the whole window (a hop map classifies its points with the first
    and judges its engines against the second): the full turn that ends the first is noted
    on the way (an event that locates its root and ends nothing), and the first is the
    second cut there. The same object twice where nothing settled; the first solved on its
    own where the integrator failed before a turn was noted (the failed phase may have
    turned first)."""
    opts = _checked_options(scene, rtol, atol, method, max_step, (max_steps, max_phases))
    solve = _solved(scene, opts, max_steps, max_phases, note=True)
    whole = solve.solution()
    if solve.settled is not None:
        return solve.settled, whole
    if solve.undetermined:
        settled = _solved(scene, opts, max_steps, max_phases, settle=True).solution()
        return settled, whole
    return whole, whole


def _solved(
    scene: Scene,
    opts: _Options,
    max_steps: int,
    max_phases: int,
    *,
    settle: bool = False,
    note: bool = False,
) -> _Solve:
    """A solve of ``scene``, run."""
    mode, sigma = _start_mode(scene)
    solve = _Solve(
        scene,
        opts,
        _StepBudget(max_steps),
        max_phases,
        settle,
        mode=mode,
        sigma=sigma,
        state=scene.initial_state(),
        note_settled=note,
    )
    # Scales near the floats' end (g = 1e308) overflow on the way to an integrator failure,
    # which the solution then says (Outcome.ERROR): its warnings would only repeat it.
    with np.errstate(over="ignore", invalid="ignore"):
        solve.run()
    return solve


@dataclass
class _Solve:
    """One call of :func:`solve_exact`: its mode machine and what it has found so far
    (mutable: every phase moves it on)."""

    scene: Scene
    opts: _Options
    budget: _StepBudget
    max_phases: int
    settle: bool
    """Stop once a roll phase has turned theta by a full turn (``stop_when_settled``)."""
    mode: Mode
    sigma: int | None
    """Slip direction while the mode is SLIP (0 without friction); None while rolling."""
    state: State
    t: float = 0.0
    segments: list[Segment] = field(default_factory=list)
    phases: list[Phase] = field(default_factory=list)
    found: dict[str, float] = field(default_factory=dict)
    """The events found so far, by their name in :class:`Events`."""
    outcome: Outcome | None = None
    message: str = ""
    extra: dict[str, float | int | str | None] = field(default_factory=dict)
    flips: int = 0
    """Wrong-way slips in a row that ended at once: two mean neither direction holds."""
    t_settled: float | None = None
    note_settled: bool = False
    """Solve on past the first full turn of a roll phase, keeping what ``settle`` would have
    returned there (:attr:`settled`; :func:`solve_exact_settled`)."""
    settled: ExactSolution | None = None
    """With ``note_settled``: the solution a ``settle`` solve returns, once a roll phase has
    turned a full turn (``_PhaseEnd.turned``)."""
    undetermined: bool = False
    """With ``note_settled``: where a ``settle`` solve would have stopped cannot be told (a
    phase failed before a turn was noted: it may have turned first)."""

    def run(self) -> None:
        """Phase after phase, until the window ends, the hoop lands or the solve stops."""
        if self.mode is Mode.PAINLEVE:
            self.outcome = Outcome.PAINLEVE
            self.message = "D <= 0 at t = 0: no consistent contact force for this sliding start"
        if self.mode is Mode.FLIGHT:
            self.outcome = Outcome.LIFTS_AT_START
        while self.outcome is None or self.mode is Mode.FLIGHT:
            if not self._step():
                break

    def solution(self) -> ExactSolution:
        return self._solution(self.segments, self.phases, self.t_settled)

    def _solution(
        self, segments: list[Segment], phases: list[Phase], t_settled: float | None
    ) -> ExactSolution:
        """The solution with these segments, phases and settling time, and the events found
        so far (copied: a noted solve goes on finding)."""
        outcome = self.outcome
        if outcome is None:
            outcome = Outcome.SLIPS if "t_slip" in self.found else Outcome.ROLLS
        found = self.found
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
            message=self.message,
            extra=dict(self.extra),
        )
        # Nothing integrable (Painlevé or degenerate at t = 0): one frozen segment, so that
        # the solution can still be sampled at t = 0.
        segments = segments or [_frozen_segment(self.scene, self.state)]
        opts = self.opts
        return ExactSolution(self.scene, events, tuple(segments), opts.rtol, opts.atol, t_settled)

    # ------------------------------------------------------------------ one phase
    def _step(self) -> bool:
        """The next phase and the mode after it; False once the solve is over."""
        if not self._may_go_on():
            return False
        if self.mode is Mode.FLIGHT:
            self._fly()
            return False
        try:
            phase = self._roll() if self.mode is Mode.ROLL else self._slip()
        except IntegrationError as exc:  # an answer it cannot give, said as one
            self.undetermined = self.undetermined or (self.note_settled and self.settled is None)
            return self._stop(Outcome.ERROR, f"{exc} (at t = {self.t:.6g} s)")
        return phase is not None and self._after(*phase)

    def _may_go_on(self) -> bool:
        """Whether a phase may start now; if a budget ran out, the solve ends with an error.

        A flight that has started before t_end is followed to its impact: neither the window
        nor the step budget stops it.
        """
        in_contact = self.mode is not Mode.FLIGHT
        if in_contact and self.t >= self.scene.t_end:
            return False
        if len(self.segments) >= self.max_phases:
            return self._stop(Outcome.ERROR, self._over_budget(self._phases_used))
        if in_contact and self.budget.exhausted:
            return self._stop(Outcome.ERROR, self._over_budget(self._steps_used))
        return True

    def _roll(self) -> tuple[Segment, _PhaseEnd]:
        scene = self.scene
        note = self.note_settled and self.settled is None
        return _roll_phase(
            scene,
            self.t,
            self.state,
            scene.t_end,
            self.opts,
            self.budget,
            settle=self.settle,
            note=note,
        )

    def _slip(self) -> tuple[Segment, _PhaseEnd] | None:
        """The next slip phase; None (the solve ends) where sliding has no solution."""
        scene, t, state = self.scene, self.t, self.state
        if "t_slip" not in self.found:
            self.found.update(t_slip=t, theta_slip=state[2], thetadot_slip=state[5])
        if scene.is_degenerate:
            self._stop(
                Outcome.DEGENERATE,
                f"slip at t = {t:.6g} s needs I > 0; lam = {scene.lam}, eps = {scene.eps} "
                "give I = 0 (degenerate case)",
            )
            return None
        sigma = self._slip_sigma()
        if sigma and dynamics.slip_denominator(scene, state[2], sigma) <= 0:
            message = f"D <= 0 when slip starts at t = {t:.6g} s: no consistent contact force"
            self._stop(Outcome.PAINLEVE, message)
            return None
        return _slip_phase(scene, t, state, sigma, scene.t_end, self.opts, self.budget)

    def _fly(self) -> None:
        """The flight to the first impact, which ends the solve."""
        self.found["t_lift"] = self.t
        try:
            seg, t_impact, height = flight_phase(self.scene, self.t, self.state)
        except WorkBudgetError as exc:
            self._stop(Outcome.ERROR, self._over_budget(str(exc)))
            return
        self.segments.append(seg)
        self.phases.append(Phase(PhaseKind.FLIGHT, seg.t_start, seg.t_end))
        self.found.update(t_impact=t_impact, hop_height=height)
        self.outcome = self.outcome or Outcome.HOPS

    def _after(self, seg: Segment, end: _PhaseEnd) -> bool:
        """Keep a contact phase and choose the mode after it; False once the solve is over."""
        if end.turned is not None:  # as a settle solve would end here (_settled)
            phases = [*self.phases, self._settled_phase(end.turned)]
            self.settled = self._solution([*self.segments, end.turned], phases, end.turned.t_end)
        self.segments.append(seg)
        if end.reason is EventReason.SETTLED:
            self._settled(seg, end)
            return False
        min_phase = MIN_PHASE * self.opts.units.time
        if seg.t_end - seg.t_start > min_phase or end.reason is EventReason.END:
            self.phases.append(Phase(seg.kind, seg.t_start, seg.t_end, seg.sigma))
        self.t, self.state = end.t, end.state
        if end.reason is EventReason.END:
            return False
        if end.reason is EventReason.BUDGET:
            return self._stop(Outcome.ERROR, self._over_budget(self._steps_used))
        self._next_mode(seg, end)
        return True

    # ------------------------------------------------------------------ mode changes
    def _next_mode(self, seg: Segment, end: _PhaseEnd) -> None:
        """The mode after a contact phase that ended on a physical event."""
        scene, state, reason = self.scene, self.state, end.reason
        if reason is EventReason.SLIP:
            f, _ = dynamics.rolling_forces(scene, state[2], state[5])
            self.mode, self.sigma = Mode.SLIP, _initial_slip_direction(scene, float(f))
        elif reason is EventReason.LIFT and seg.kind is PhaseKind.ROLL:
            f, _ = dynamics.rolling_forces(scene, state[2], state[5])
            self.mode, self.sigma = _leave_rolling(scene, state, float(f))
        elif reason is EventReason.LIFT:
            self.mode = Mode.FLIGHT
        elif reason is EventReason.WRONG_WAY:
            self._wrong_way(seg, end)
        elif reason is EventReason.RESTICK:
            self._restick()
        elif reason is EventReason.PAINLEVE:
            t, theta_deg = self.t, math.degrees(state[2])
            self.extra.update(t_painleve=t, theta_painleve_deg=theta_deg)
            message = f"D = 0 (Painlevé) at t = {t:.6g} s, theta = {theta_deg:.4f} deg"
            self._stop(Outcome.PAINLEVE, message)

    def _wrong_way(self, seg: Segment, end: _PhaseEnd) -> None:
        # Neither direction consistent right at onset (a grazing touch of the friction
        # cone): the hoop keeps rolling.
        at_once = end.t - seg.t_start < MIN_PHASE * self.opts.units.time
        self.flips = self.flips + 1 if at_once else 0
        if self.flips >= 2:
            self.mode, self.sigma = Mode.ROLL, None
        else:
            self.mode, self.sigma = Mode.SLIP, -self._slip_sigma()

    def _restick(self) -> None:
        scene, state = self.scene, self.state
        f, n = (float(v) for v in dynamics.rolling_forces(scene, state[2], state[5]))
        if abs(f) <= scene.mus * n:
            self.mode = Mode.ROLL
            self.found.setdefault("t_restick", self.t)
        else:
            self.sigma = -self._slip_sigma()  # the slip velocity passes through zero: reverses
        # Snap the centre velocity onto s = 0 so the next phase starts consistent.
        X, Y, th, Xdot, Ydot, thd = state
        s = float(kinematics.slip_velocity(scene, Xdot, th, thd))
        self.state = (X, Y, th, Xdot - s, Ydot, thd)

    def _settled(self, seg: Segment, end: _PhaseEnd) -> None:
        self.phases.append(self._settled_phase(seg))
        self.t_settled = end.t

    def _settled_phase(self, seg: Segment) -> Phase:
        # Nothing happens any more: the phase runs to the window's end, to the very number
        # an unstopped integration ends on (solve_ivp stops exactly at t_end / unit).
        units = self.opts.units
        t_window = self.scene.t_end / units.time * units.time
        return Phase(seg.kind, seg.t_start, t_window, seg.sigma)

    # ------------------------------------------------------------------ helpers
    def _slip_sigma(self) -> int:
        # Every way into Mode.SLIP sets a direction; None belongs to rolling only.
        assert self.sigma is not None, "slip mode without a slip direction"
        return self.sigma

    def _stop(self, outcome: Outcome, message: str) -> bool:
        """End the solve with this outcome and message; returns False (the solve is over)."""
        self.outcome, self.message = outcome, message
        return False

    @property
    def _steps_used(self) -> str:
        return f"max_steps = {self.budget.max_steps} integrator steps used"

    @property
    def _phases_used(self) -> str:
        return f"max_phases = {self.max_phases} phases used"

    def _over_budget(self, what: str) -> str:
        time_scale = math.sqrt(self.scene.a / self.scene.g)
        return (
            f"work budget exceeded: {what} at t = {self.t:.6g} s; the window t_end = "
            f"{self.scene.t_end:g} s spans {self.scene.t_end / time_scale:.3g} time scales "
            f"sqrt(a/g) = {time_scale:.3g} s (shorten t_end, or raise the budget)"
        )


def _frozen_segment(scene: Scene, state: State) -> Segment:
    """A zero-length segment holding the initial state, so sampling t = 0 works."""
    frozen = _Frozen(state)
    return Segment(PhaseKind.ROLL, 0.0, 0.0, None, frozen.states, frozen.forces)


@dataclass(frozen=True)
class _Frozen:
    """The initial state at every time, and no finite contact force."""

    state: State

    def states(self, t: NDArray) -> NDArray:
        return np.tile(np.asarray(self.state, dtype=float)[:, None], (1, np.size(t)))

    @staticmethod
    def forces(t: NDArray) -> tuple[NDArray, NDArray]:
        z = np.full(np.size(t), np.nan)
        return z, z.copy()
