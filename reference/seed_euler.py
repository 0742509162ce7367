"""The seed document's fixed-step scheme for the slipping phase (its Exercise 15), ported.

The rolling phase and the slip onset come from the exact solver. From the onset, the scheme
steps the centre of mass with constant accelerations over each step ``dt``: a normal force is
extrapolated from the previous step's change in vertical acceleration, and raised just enough
to keep the hoop centre on the floor whenever the predicted step would sink below it. It ends
when the hoop-centre clearance y - a exceeds the contact tolerance ``delta``; that step is the
"lift-off", followed by a ballistic flight to the first impact.

The scheme never re-sticks and reads "clearance > delta" as lift-off, so its hop height scales
with delta: in the seed scene the exact solution does not leave the floor at all. It is kept as
a reference for the seed's tables, not as a model of the physics.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import solve_ivp

from hoopbench.models import kinematics
from hoopbench.models.events import Events, Outcome, Phase, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference import dynamics
from hoopbench.reference.exact import (
    DEFAULT_MAX_SAMPLES,
    ExactSolution,
    WorkBudgetError,
    flight_phase,
    solve_exact,
)

__all__ = [
    "DEFAULT_MAX_STEPS",
    "ROUNDOFF_MARGIN",
    "SeedEulerResult",
    "min_step",
    "solve_seed_euler",
]

DEFAULT_MAX_STEPS = 10_000_000
"""Steps one run of the scheme may take: its arrays take 80 bytes a step (0.8 GB at most) and
a step about 4 microseconds (measured), so a run stays under a minute."""

ROUNDOFF_MARGIN = 1e3
"""How many float64 spacings the smallest quantities of a step must span (see :func:`min_step`)."""


def min_step(scene: Scene) -> float:
    """Smallest step dt, s, for which float64 round-off does not drive the scheme.

    The scheme reads the normal force off the dt^2 term of a position update,
    n = 2 [a - y - ydot dt - dt^2 free / 2] / (dt^2 D): the bracket is a difference of heights
    below 2a, so it carries a rounding error of about one float64 spacing of 2a, and n an error
    of about 2 spacing(2a) / (dt^2 D). Requiring gravity's share of a step, g dt^2 / 2, to span
    at least ROUNDOFF_MARGIN such spacings keeps that error below about 0.1 % of g (for D >= 1,
    as while the weight is ahead of the hoop centre):

        dt >= sqrt(2 ROUNDOFF_MARGIN spacing(2a) / g),

    3.0e-7 s for a 1 m hoop under 9.8 m/s^2. The step times t_slip + i dt must also stay
    ROUNDOFF_MARGIN spacings of t_end apart (dt >= ROUNDOFF_MARGIN spacing(t_end)), which
    only binds for a tiny hoop in a long window.

    Measured on the seed scene against the same scheme in 80-bit arithmetic: at dt = 3e-7 s
    the number of steps differs by 2 in 2345, at 1e-7 s by 31 in 4903, at 3e-8 s by 865 in
    11736, and below 1e-8 s the float64 run reports hops of 0.2 to 1 m that the arithmetic
    made up.
    """
    heights = float(np.spacing(2.0 * scene.a))
    times = float(np.spacing(scene.t_end))
    return max(math.sqrt(2.0 * ROUNDOFF_MARGIN * heights / scene.g), ROUNDOFF_MARGIN * times)


@dataclass(frozen=True, eq=False)
class SeedEulerResult:
    """Result of :func:`solve_seed_euler`.

    The per-step arrays have shape (n_steps + 1,): index i is the state at t_slip + i*dt, the
    last one the lift-off state (or the state where the scheme was stopped). All are empty when
    the scene never slips in its window.
    """

    scene: Scene
    events: Events
    """Events of the scheme; t_slip and the onset state are the exact solver's."""
    n_steps: int
    """Number of slipping steps taken (0 when the scene never slips)."""
    dt: float
    """Step, s."""
    delta: float
    """Contact tolerance on the hoop-centre clearance, m."""
    t: NDArray
    """Step times, s."""
    X: NDArray
    """Centre-of-mass x, m."""
    Y: NDArray
    """Centre-of-mass y, m."""
    theta: NDArray
    """rad."""
    Xdot: NDArray
    """m/s."""
    Ydot: NDArray
    """m/s."""
    thetadot: NDArray
    """rad/s."""
    n: NDArray
    """Normal force per unit mass used over step i, m/s^2; the last entry, where no step
    follows, is 0."""
    accelerations: NDArray = field(repr=False)
    """(Xddot, Yddot, thetaddot) used over step i, shape (3, n_steps + 1), SI units; last
    column zero."""
    exact: ExactSolution = field(repr=False)
    """The exact solution that supplies the rolling phase (and everything when no slip)."""

    @property
    def _stepping(self) -> bool:
        # False when the scene never slips: the exact solution is then the whole answer.
        return self.t.size > 0

    @property
    def t_final(self) -> float:
        """End of the result's window, s: the impact, the last step, or the exact t_final."""
        if not self._stepping:
            return self.exact.t_final
        ev = self.events
        return ev.t_impact if ev.t_impact is not None else float(self.t[-1])

    def sample(self, t: ArrayLike) -> Trajectory:
        """The trajectory at times t, s, in [0, t_final].

        Before the slip onset: the exact rolling solution. Between steps: the step's constant
        accelerations (which the trapezoid update integrates exactly). After lift-off: the
        ballistic flight.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if not self._stepping:
            return self.exact.sample(t)
        if t.size and (t.min() < -1e-12 or t.max() > self.t_final + 1e-9):
            raise ValueError(f"times must lie in [0, {self.t_final}] s")
        t_slip, t_last = float(self.t[0]), float(self.t[-1])
        states = np.empty((6, t.size))
        f = np.zeros(t.size)
        n = np.zeros(t.size)
        contact = np.ones(t.size, dtype=bool)

        roll = t < t_slip
        if roll.any():
            sampled = self.exact.sample(t[roll])
            states[:, roll] = np.vstack(
                [sampled.X, sampled.Y, sampled.theta, sampled.Xdot, sampled.Ydot, sampled.thetadot]
            )
            f[roll], n[roll] = sampled.friction_force, sampled.normal_force

        slip = ~roll & (t < t_last) if self.n_steps else np.zeros(t.size, dtype=bool)
        if slip.any():
            i = np.floor((t[slip] - t_slip) / self.dt + 1e-9).astype(int)
            i = np.clip(i, 0, self.n_steps - 1)
            tau = t[slip] - self.t[i]
            q = np.vstack([self.X[i], self.Y[i], self.theta[i]])
            v = np.vstack([self.Xdot[i], self.Ydot[i], self.thetadot[i]])
            acc = self.accelerations[:, i]
            states[:3, slip] = q + v * tau + 0.5 * acc * tau**2
            states[3:, slip] = v + acc * tau
            n[slip] = self.n[i]
            f[slip] = acc[0]  # Xddot = f exactly: the only horizontal force is friction

        after = ~roll & ~slip
        if after.any():
            tau = t[after] - t_last
            X, Y, th, Xd, Yd, w = (float(v[-1]) for v in self._columns())
            flying = self.events.t_lift is not None
            g = self.scene.g if flying else 0.0
            states[:, after] = np.vstack(
                [
                    X + Xd * tau,
                    Y + Yd * tau - 0.5 * g * tau**2,
                    th + w * tau,
                    np.full_like(tau, Xd),
                    Yd - g * tau,
                    np.full_like(tau, w),
                ]
            )
            contact[after] = not flying
        return Trajectory.from_state(
            self.scene,
            t=t,
            X=states[0],
            Y=states[1],
            theta=states[2],
            Xdot=states[3],
            Ydot=states[4],
            thetadot=states[5],
            normal_force=n,
            friction_force=f,
            contact=contact,
        )

    def trajectory(self, *, max_samples: int = DEFAULT_MAX_SAMPLES) -> Trajectory:
        """Rolling phase and flight sampled every dt, plus every slipping step, to t_final.

        Raises ValueError, before allocating, when that would be more than ``max_samples``
        samples.
        """
        if not self._stepping:
            return self.exact.sample_uniform(self.dt, max_samples=max_samples)
        t_slip, t_last = float(self.t[0]), float(self.t[-1])
        estimate = (
            math.ceil(t_slip / self.dt) + self.t.size + math.ceil((self.t_final - t_last) / self.dt)
        )
        if estimate > max_samples:
            raise ValueError(
                f"sampling every dt = {self.dt:g} s over t_final = {self.t_final:.6g} s makes "
                f"about {estimate:.3g} samples, more than max_samples = {max_samples}"
            )
        roll = np.arange(0.0, t_slip, self.dt)
        times = [roll[roll < t_slip], self.t]
        if self.events.t_impact is not None:
            flight = t_last + self.dt * np.arange(1, math.ceil((self.t_final - t_last) / self.dt))
            times += [flight[flight < self.t_final], np.array([self.t_final])]
        return self.sample(np.concatenate(times))

    @classmethod
    def _without_slip(cls, exact: ExactSolution, dt: float, delta: float) -> SeedEulerResult:
        """The result for a scene that never slips in its window: the exact one, no steps."""
        empty = np.empty(0)
        return cls(
            exact.scene,
            exact.events,
            0,
            dt,
            delta,
            t=empty,
            X=empty,
            Y=empty,
            theta=empty,
            Xdot=empty,
            Ydot=empty,
            thetadot=empty,
            n=empty,
            accelerations=np.empty((3, 0)),
            exact=exact,
        )

    def _columns(self) -> tuple[NDArray, ...]:
        return (self.X, self.Y, self.theta, self.Xdot, self.Ydot, self.thetadot)


def _check_positive(name: str, value: float, unit: str) -> float:
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a positive number of {unit}, got {value!r}") from None
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"{name} must be a positive number of {unit}, got {value}")
    return value


def _rolling_normal_force(scene: Scene, theta: float, thetadot: float) -> float:
    return float(dynamics.rolling_forces(scene, theta, thetadot)[1])


def _rolling_state_at(scene: Scene, exact: ExactSolution, t: float) -> tuple[float, float]:
    """(theta, thetadot) on the first rolling solution at time t, s (t may be negative).

    The first phase rolls from t = 0, so for t >= 0 this samples the exact solution; a slip
    within the first step asks for t < 0, and the rolling equation is then continued
    backwards from the initial state (the same solution, extended).
    """
    if t >= 0.0:
        state = exact.state(t)[:, 0]
        return float(state[2]), float(state[5])
    return _integrate_rolling(scene, t, exact.rtol, exact.atol)


def _integrate_rolling(scene: Scene, t: float, rtol: float, atol: float) -> tuple[float, float]:
    """(theta, thetadot) at time t, s, rolling from the scene's initial state (either way)."""
    sol = solve_ivp(
        lambda _t, y: (y[1], dynamics.rolling_thetaddot(scene, y[0], y[1])),
        (0.0, t),
        [scene.theta0, scene.thetadot0],
        method="DOP853",
        rtol=rtol,
        atol=atol,
    )
    return float(sol.y[0, -1]), float(sol.y[1, -1])


def _check_inputs(scene: Scene, dt: float, delta: float) -> tuple[float, float]:
    """dt and delta as floats, or ValueError naming the value and what is wrong with it."""
    dt = _check_positive("dt", dt, "seconds")
    delta = _check_positive("delta", delta, "metres")
    if dt > scene.t_end:
        raise ValueError(f"dt = {dt:g} s is longer than the window, t_end = {scene.t_end:g} s")
    dt_min = min_step(scene)
    if dt < dt_min:
        raise ValueError(
            f"dt = {dt:g} s is below {dt_min:.3g} s, where float64 round-off would drive the "
            f"scheme's normal force (a = {scene.a:g} m, g = {scene.g:g} m/s^2; see min_step)"
        )
    delta_min = ROUNDOFF_MARGIN * float(np.spacing(2.0 * scene.a))
    if delta < delta_min:
        raise ValueError(
            f"delta = {delta:g} m is below {delta_min:.3g} m, where float64 round-off in the "
            f"clearance of a hoop of radius a = {scene.a:g} m would decide the lift-off"
        )
    if delta > scene.a:
        raise ValueError(
            f"delta = {delta:g} m is larger than the hoop radius a = {scene.a:g} m: not a "
            "contact tolerance"
        )
    return dt, delta


def solve_seed_euler(
    scene: Scene,
    *,
    dt: float = 0.002,
    delta: float = 1e-4,
    rtol: float = 1e-12,
    atol: float = 1e-12,
    max_steps: int = DEFAULT_MAX_STEPS,
) -> SeedEulerResult:
    """Run the seed's improved-Euler slipping scheme on a scene.

    ``dt`` is the step, s; ``delta`` the contact tolerance on the hoop-centre clearance, m
    (the seed's tables give delta/a with a = 1); ``rtol``/``atol`` the exact solver's tolerances
    for the rolling phase and the slip onset.

    The slip direction is the exact one at the onset (+1 in the seed scene, the only direction
    the seed treats). Outcomes: "hops" when the clearance exceeds delta (then the flight to the
    first impact follows); "slips" when t_end comes first; "painleve" if the scheme meets
    D <= 0; "error" if the flight after the lift-off needs too much work to find its impact.
    A scene that never slips in its window returns the exact events unchanged with
    n_steps = 0.

    Raises ValueError, naming the value, for a dt or delta that is not a positive number; a dt
    longer than t_end or below :func:`min_step` (float64 round-off would drive the scheme); a
    delta below ROUNDOFF_MARGIN float64 spacings of the heights or above the radius a; a
    window that would take more than ``max_steps`` steps from the slip onset to t_end (checked
    before stepping, so a run is never killed for memory); or a scene that starts sliding (the
    scheme starts from a rolling phase). DegenerateSceneError when I = 0. The exact solver's
    own work budget applies to the rolling phase (outcome "error" when it runs out first).
    """
    dt, delta = _check_inputs(scene, dt, delta)
    if not (isinstance(max_steps, int) and max_steps > 0):
        raise ValueError(f"max_steps must be a positive integer, got {max_steps!r}")
    scene.require_inertia("the seed's slipping scheme")
    exact = _solved(scene, rtol, atol)
    if exact.events.t_slip is None:
        return SeedEulerResult._without_slip(exact, dt, delta)
    if not scene.rolls_at_start:
        raise ValueError(
            "scene starts sliding (xdot0 differs from a*thetadot0): the seed scheme starts "
            "from a rolling phase"
        )
    onset = _Onset.of(exact, float(exact.events.t_slip), dt)
    window_steps = math.ceil((scene.t_end - onset.t) / dt)
    if window_steps > max_steps:
        raise ValueError(
            f"dt = {dt:g} s would take up to {window_steps:.3g} steps from the slip onset at "
            f"t = {onset.t:.6g} s to t_end = {scene.t_end:g} s, more than max_steps = {max_steps}"
        )
    steps = _step_scheme(scene, onset, dt, delta, window_steps)
    return _seed_result(exact, onset, steps, dt, delta)


@functools.lru_cache(maxsize=4)
def _solved(scene: Scene, rtol: float, atol: float) -> ExactSolution:
    """``solve_exact(scene)``, solved once a process while kept: the scheme starts from the
    exact rolling phase, the same for every dt and delta (the report's seed tables and figure
    run the scheme at 16 of them, and those 16 exact solves were nearly all of its work)."""
    return solve_exact(scene, rtol=rtol, atol=atol)


@dataclass(frozen=True)
class _Onset:
    """Where the scheme starts: the exact slip onset."""

    t: float
    """s."""
    sigma: int
    """Slip direction, the exact one (+1 if the exact slip has none)."""
    state: tuple[float, float, float, float, float, float]
    """(X, Y, theta, Xdot, Ydot, thetadot) at t, SI units."""
    n: float
    """Rolling normal force per unit mass at t, m/s^2."""
    ay_prev: float
    """Vertical acceleration of the centre of mass one step dt before t, m/s^2."""

    @classmethod
    def of(cls, exact: ExactSolution, t_slip: float, dt: float) -> _Onset:
        scene = exact.scene
        slip_phase = next(p for p in exact.events.phases if p.kind is PhaseKind.SLIP)
        sigma = slip_phase.sigma if slip_phase.sigma else 1
        X, Y, th, Xd, Yd, w = (float(v) for v in exact.state(t_slip)[:, 0])
        n = _rolling_normal_force(scene, th, w)
        before = _rolling_state_at(scene, exact, t_slip - dt)
        ay_prev = _rolling_normal_force(scene, *before) - scene.g
        return cls(t_slip, sigma, (X, Y, th, Xd, Yd, w), n, ay_prev)


@dataclass(frozen=True, eq=False)
class _Steps:
    """What the slipping steps gave: states and forces per step, and why they stopped."""

    n_steps: int
    cols: NDArray
    """(X, Y, theta, Xdot, Ydot, thetadot) after each step, shape (6, n_steps + 1)."""
    per_step: NDArray
    """(n, Xddot, Yddot, thetaddot) used over each step, shape (4, n_steps + 1)."""
    outcome: Outcome
    message: str


def _step_scheme(scene: Scene, onset: _Onset, dt: float, delta: float, window_steps: int) -> _Steps:
    """The seed's improved-Euler steps from the slip onset, until the clearance exceeds delta,
    the window ends or D <= 0. One loop with local variables: a step costs microseconds."""
    g, a, lam, k, muk = scene.g, scene.a, scene.lam, scene.k, scene.muk
    sigma, t_slip = onset.sigma, onset.t
    X, Y, th, Xd, Yd, w = onset.state
    n, ay_prev = onset.n, onset.ay_prev
    # Preallocated (np.empty/np.zeros only commit the pages that get written): per-step
    # Python tuples would take ~450 bytes a step.
    cols = np.empty((6, window_steps + 1))
    per_step = np.zeros((4, window_steps + 1))  # (n, Xddot, Yddot, thetaddot) per step
    cols[:, 0] = (X, Y, th, Xd, Yd, w)
    n_steps = 0
    message = ""
    while True:
        y = Y - lam * a * math.cos(th)
        if y - a > delta:
            outcome = Outcome.HOPS
            break
        if n_steps >= window_steps:
            outcome = Outcome.SLIPS
            message = (
                f"the seed scheme kept the clearance <= delta = {delta:g} m for "
                f"{n_steps} steps, to t = {t_slip + n_steps * dt:.6g} s, and stopped at "
                f"t_end = {scene.t_end:g} s: no lift-off"
            )
            break
        s, c = math.sin(th), math.cos(th)
        torque = lam * s + sigma * muk * (1.0 + lam * c)
        D = 1.0 + lam * s * torque / k
        if D <= 0.0:
            outcome = Outcome.PAINLEVE
            message = (
                f"the seed scheme met D = {D:.3g} <= 0 (Painlevé) at t = "
                f"{t_slip + n_steps * dt:.6g} s, theta = {math.degrees(th):.4f} deg"
            )
            break
        ydot = Yd + lam * a * s * w
        free = -g + lam * a * c * w * w
        yddot_predicted = n * D + free
        if y + ydot * dt + 0.5 * yddot_predicted * dt * dt < a:
            # Just enough push to land the hoop centre on the floor at the end of the step
            # (the seed prints this line with the sign flipped, which would zero n).
            n = max(0.0, 2.0 * (a - y - ydot * dt - 0.5 * dt * dt * free) / (dt * dt * D))
        aX, aY, alpha = -sigma * muk * n, n - g, n * torque / (k * a)
        per_step[:, n_steps] = (n, aX, aY, alpha)
        Xd1, Yd1, w1 = Xd + aX * dt, Yd + aY * dt, w + alpha * dt
        X += 0.5 * dt * (Xd + Xd1)
        Y += 0.5 * dt * (Yd + Yd1)
        th += 0.5 * dt * (w + w1)
        Xd, Yd, w = Xd1, Yd1, w1
        n_steps += 1
        cols[:, n_steps] = (X, Y, th, Xd, Yd, w)
        n = max(0.0, n + (aY - ay_prev))
        ay_prev = aY
    # Copies, so that the unused tail of the preallocated arrays is released.
    cols = cols[:, : n_steps + 1].copy()
    per_step = per_step[:, : n_steps + 1].copy()
    return _Steps(n_steps, cols, per_step, outcome, message)


def _seed_result(
    exact: ExactSolution, onset: _Onset, steps: _Steps, dt: float, delta: float
) -> SeedEulerResult:
    """The result: the steps' events, with the flight to the impact after a lift-off."""
    scene, ev0, t_slip = exact.scene, exact.events, onset.t
    n_steps, cols, per_step = steps.n_steps, steps.cols, steps.per_step
    outcome, message = steps.outcome, steps.message
    t = t_slip + dt * np.arange(n_steps + 1)
    t_end_steps = float(t[-1])
    clearance = kinematics.clearance(scene, cols[1], cols[2])
    phases = [Phase(PhaseKind.ROLL, 0.0, t_slip)] if t_slip > 0.0 else []
    phases.append(Phase(PhaseKind.SLIP, t_slip, t_end_steps, onset.sigma))
    t_lift = hop_height = t_impact = None
    if outcome is Outcome.HOPS:
        t_lift = t_end_steps
        try:
            _, t_impact, flight_height = flight_phase(scene, t_end_steps, tuple(cols[:, -1]))
        except WorkBudgetError as exc:
            outcome, message = Outcome.ERROR, f"the seed scheme lifted off, but {exc}"
        else:
            hop_height = max(float(clearance.max()), flight_height)
            phases.append(Phase(PhaseKind.FLIGHT, t_lift, t_impact))
    events = Events(
        outcome=outcome,
        t_slip=t_slip,
        theta_slip=ev0.theta_slip,
        thetadot_slip=ev0.thetadot_slip,
        t_lift=t_lift,
        hop_height=hop_height,
        t_impact=t_impact,
        phases=tuple(phases),
        message=message,
        extra={"n_steps": n_steps, "dt": dt, "delta": delta},
    )
    X, Y, theta, Xdot, Ydot, thetadot = cols
    return SeedEulerResult(
        scene,
        events,
        n_steps,
        dt,
        delta,
        t,
        X,
        Y,
        theta,
        Xdot,
        Ydot,
        thetadot,
        n=per_step[0],
        accelerations=per_step[1:],
        exact=exact,
    )
