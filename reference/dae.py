"""A second, independent formulation of the weighted hoop: a Lagrange-multiplier DAE.

This module is a test oracle for :mod:`hoopbench.reference.exact`. It shares nothing with it but the
scene parameters: it has its own equations, its own contact-mode logic and its own event
detection, so that agreement between the two is evidence that both are right.

Formulation. Generalised coordinates are the hoop centre and the angle, q = (x, y, theta).
The centre of mass is (x + r sin theta, y + r cos theta) with r = lam*a, so the kinetic energy

    T = 1/2 M |d/dt (x + r sin theta, y + r cos theta)|^2 + 1/2 I thetadot^2

gives the mass matrix Mq(theta) and a velocity-dependent (centripetal) term h(theta, thetadot).
Gravity gives the generalised force Q. The rim point touching the floor moves with velocity
(xdot - a thetadot, ydot), so a contact force (F_t, F_n) there does virtual work through the
generalised directions e_t = (1, 0, -a) and e_n = (0, 1, 0).

Each contact mode imposes its constraints with multipliers, solved at every instant from the
augmented (KKT) system [[Mq, B], [J, 0]] [qddot; lambda] = [Q - h; -Jdot qdot]:

* roll: J = [e_n; e_t] (y = a and xdot - a thetadot = 0), B = J^T; Jdot = 0;
* slip: J = e_n (y = a) and kinetic friction F_t = -sigma muk F_n tied to the multiplier,
  so B = e_n - sigma muk e_t: the system is not symmetric, and it is singular exactly where
  the contact compliance w (below) vanishes, the Painlevé point;
* flight: no constraint, Mq qddot = Q - h.

The state integrated in every mode is (x, y, theta, xdot, ydot, thetadot), with SciPy's DOP853
stepper. Events are this module's own: after every step the event functions are sampled on
the step's interpolant (dense enough to catch a function that dips below zero and comes back
within one step) and a sign change is refined with ``brentq``. They are slip onset
(mus n - |f| = 0), lift-off (n = 0), end of a slip (sigma s = 0, then re-stick or reversal),
the Painlevé point (the contact compliance w, the vertical acceleration of the contact per unit
normal force, reaches 0) and impact (y = a while descending). After each event the next mode
is chosen by trying the modes in turn and keeping the first whose multipliers are admissible
(:func:`_next_mode`). The run ends at ``scene.t_end`` or at the first impact.

A scene with no inertia about the centre of mass (lam = 1, eps = 0) can roll here (the rolling
KKT matrix stays regular) but is reported "degenerate" as soon as rolling is not admissible.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.integrate import DOP853
from scipy.optimize import brentq, minimize_scalar

from hoopbench.models.scene import Scene

__all__ = ["DaePhase", "DaeSolution", "solve_dae"]

_ROLL, _SLIP, _FLIGHT = "roll", "slip", "flight"
_PAINLEVE = "painleve"  # not a phase: no consistent contact mode exists

_E_N = np.array([0.0, 1.0, 0.0])
"""Generalised direction of a unit normal force at the contact (vertical, on y)."""


def _e_t(scene: Scene) -> NDArray:
    """Generalised direction of a unit tangential force at the rim contact point."""
    return np.array([1.0, 0.0, -scene.a])


@dataclass(frozen=True)
class DaePhase:
    """One contact mode of the DAE solution."""

    kind: str
    """"roll", "slip" or "flight"."""
    t_start: float
    """s."""
    t_end: float
    """s."""
    sigma: int | None = None
    """Slip direction sign(xdot - a*thetadot) for slip phases; None otherwise."""


@dataclass(frozen=True)
class _Segment:
    kind: str
    t_start: float
    t_end: float
    sigma: int | None
    dense: Callable[[NDArray], NDArray] = field(repr=False)
    """t, shape (m,) -> generalised state, shape (6, m): x, y, theta, xdot, ydot, thetadot."""


@dataclass(frozen=True)
class DaeSolution:
    """Result of :func:`solve_dae`. Times in s, angles in rad; None = did not happen."""

    scene: Scene
    outcome: str
    """"rolls", "slips", "hops", "lifts-at-start", "painleve" or "degenerate"."""
    phases: tuple[DaePhase, ...]
    """Contact modes in order."""
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
    t_impact: float | None = None
    """First impact after the lift-off, s (ends the run)."""
    hop_height: float | None = None
    """Max over the flight of the hoop-centre clearance y - a, m."""
    t_painleve: float | None = None
    """Time at which no consistent contact force exists, s."""
    message: str = ""
    """Detail for painleve and degenerate outcomes."""
    segments: tuple[_Segment, ...] = field(default=(), repr=False)
    """Dense output, one segment per phase."""

    @property
    def t_final(self) -> float:
        """End of the solved window, s."""
        return self.segments[-1].t_end if self.segments else 0.0

    @property
    def kinds(self) -> tuple[str, ...]:
        """Phase kinds in order, slips tagged with their direction ("slip+", "slip-")."""
        return tuple(
            p.kind + ("+" if p.sigma == 1 else "-" if p.sigma == -1 else "")
            if p.kind == _SLIP
            else p.kind
            for p in self.phases
        )

    def generalised_state(self, t: ArrayLike) -> NDArray:
        """(x, y, theta, xdot, ydot, thetadot) of the hoop centre, shape (6, m)."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if not self.segments:
            raise ValueError("the solution holds no integrated segment")
        if t.size and (t.min() < -1e-12 or t.max() > self.t_final + 1e-9):
            raise ValueError(f"t must lie in [0, {self.t_final}] s")
        ends = np.array([s.t_end for s in self.segments])
        index = np.minimum(np.searchsorted(ends, t, side="left"), len(self.segments) - 1)
        out = np.empty((6, t.size))
        for i, seg in enumerate(self.segments):
            mask = index == i
            if mask.any():
                out[:, mask] = seg.dense(np.clip(t[mask], seg.t_start, seg.t_end))
        return out

    def state(self, t: ArrayLike) -> NDArray:
        """(X, Y, theta, Xdot, Ydot, thetadot) of the centre of mass, shape (6, m), SI."""
        x, y, th, xd, yd, thd = self.generalised_state(t)
        r = self.scene.com_offset
        s, c = np.sin(th), np.cos(th)
        return np.vstack([x + r * s, y + r * c, th, xd + r * c * thd, yd - r * s * thd, thd])

    def forces(self, t: ArrayLike) -> tuple[NDArray, NDArray]:
        """(f, n): contact forces per unit mass from the multipliers, m/s^2, shape (m,) each."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        z = self.generalised_state(t)
        ends = np.array([s.t_end for s in self.segments])
        index = np.minimum(np.searchsorted(ends, t, side="left"), len(self.segments) - 1)
        f = np.zeros(t.size)
        n = np.zeros(t.size)
        for j in range(t.size):
            seg = self.segments[index[j]]
            if seg.kind != _FLIGHT:
                _, f[j], n[j] = _solve_mode(self.scene, z[:, j], seg.kind, seg.sigma)
        return f, n

    def event_functions(self, t: ArrayLike) -> dict[str, NDArray]:
        """The event functions watched at each time, made dimensionless; NaN where not watched.

        "slip" (mus n - |f|)/g and "lift" n/g in rolling; "stop" sigma s/sqrt(g a), "lift"
        (minus the free vertical contact acceleration)/g and "painleve" w in slips; "impact"
        (y - a)/a in flight. Each phase ends where one of its functions falls to zero; a
        function that comes close to zero without crossing marks a grazing case.
        """
        t = np.atleast_1d(np.asarray(t, dtype=float))
        z = self.generalised_state(t)
        ends = np.array([s.t_end for s in self.segments])
        index = np.minimum(np.searchsorted(ends, t, side="left"), len(self.segments) - 1)
        names = ("slip", "lift", "stop", "painleve", "impact")
        out = {name: np.full(t.size, np.nan) for name in names}
        sc = self.scene
        speed = math.sqrt(sc.g * sc.a)
        for j in range(t.size):
            seg = self.segments[index[j]]
            if seg.kind == _ROLL:
                slip, lift = _roll_monitor(sc, z[:, j]) / sc.g
                out["slip"][j], out["lift"][j] = slip, lift
            elif seg.kind == _SLIP:
                stop, lift, w = _slip_monitor(sc, z[:, j], seg.sigma)
                out["stop"][j], out["lift"][j], out["painleve"][j] = stop / speed, lift / sc.g, w
            else:
                out["impact"][j] = (z[1, j] - sc.a) / sc.a
        return out


# --------------------------------------------------------------------------- mechanics
def _mass_matrix(scene: Scene, theta: float) -> NDArray:
    """Mq(theta), kg (and kg m, kg m^2), from T = 1/2 qdot^T Mq qdot."""
    M, r = scene.M, scene.com_offset
    s, c = math.sin(theta), math.cos(theta)
    # The centre-of-mass velocity is Jc qdot with Jc = [[1, 0, r c], [0, 1, -r s]].
    return np.array(
        [
            [M, 0.0, M * r * c],
            [0.0, M, -M * r * s],
            [M * r * c, -M * r * s, M * r * r + scene.inertia_com],
        ]
    )


def _applied_minus_bias(scene: Scene, z: NDArray) -> NDArray:
    """Q - h: gravity's generalised force minus the velocity terms of d/dt dT/dqdot - dT/dq."""
    M, r, g = scene.M, scene.com_offset, scene.g
    theta, thetadot = z[2], z[5]
    s, c = math.sin(theta), math.cos(theta)
    # h = Jc^T (dJc/dt qdot) M = M (-r s thd^2, -r c thd^2, 0); gravity: -dV/dq, V = M g Y.
    h = np.array([-M * r * s * thetadot**2, -M * r * c * thetadot**2, 0.0])
    Q = np.array([0.0, -M * g, M * g * r * s])
    return Q - h


def _solve_mode(
    scene: Scene, z: NDArray, kind: str, sigma: int | None
) -> tuple[NDArray, float, float]:
    """(qddot, f, n) in a mode: the KKT solve. f, n are per unit mass, m/s^2."""
    Mq = _mass_matrix(scene, z[2])
    rhs = _applied_minus_bias(scene, z)
    if kind == _FLIGHT:
        return np.linalg.solve(Mq, rhs), 0.0, 0.0
    e_t = _e_t(scene)
    if kind == _ROLL:
        # Two constraint rows with constant coefficients (Jdot = 0); the contact force on the
        # hoop is -J^T lambda = M (n e_n + f e_t).
        J = np.vstack([_E_N, e_t])
        A = np.zeros((5, 5))
        A[:3, :3] = Mq
        A[:3, 3:] = J.T
        A[3:, :3] = J
        sol = np.linalg.solve(A, np.concatenate([rhs, np.zeros(2)]))
        return sol[:3], -sol[4] / scene.M, -sol[3] / scene.M
    # Slip: one row (y = a); friction follows the multiplier, so its column joins the normal's.
    muk_sigma = scene.muk * _slip_sigma(sigma)
    A = np.zeros((4, 4))
    A[:3, :3] = Mq
    A[:3, 3] = _E_N - muk_sigma * e_t
    A[3, :3] = _E_N
    sol = np.linalg.solve(A, np.concatenate([rhs, [0.0]]))
    n = -sol[3] / scene.M
    return sol[:3], -muk_sigma * n, n


def _compliance(scene: Scene, z: NDArray, sigma: int) -> float:
    """w: vertical acceleration of the contact per unit normal force (per unit mass) in a slip.

    The slip KKT matrix is singular exactly when w = 0; w < 0 means pressing harder would pull
    the hoop into the floor (no consistent contact force: Painlevé).
    """
    Mq = _mass_matrix(scene, z[2])
    direction = _E_N - scene.muk * sigma * _e_t(scene)
    return float(scene.M * _E_N @ np.linalg.solve(Mq, direction))


def _slip_velocity(scene: Scene, z: NDArray) -> float:
    return float(z[3] - scene.a * z[5])


def _slip_sigma(sigma: int | None) -> int:
    assert sigma is not None  # every slip has a direction; None belongs to the other modes
    return sigma


# --------------------------------------------------------------------------- phases
_SUBSTEPS = 16
_MAX_GAP = 1e-3
"""Event functions are sampled at least _SUBSTEPS times per integrator step, and at most
_MAX_GAP seconds apart, on the step's interpolant.

Checking only at step ends (as plain ``solve_ivp`` events do) misses an event function that
dips below zero and comes back within one step; a smooth rolling phase takes steps of 0.1 s
and more, and such dips (a brief slip, a brief return to rest) are real physics.
"""


_ROUNDING = 1e-9
"""Relative size below which an acceleration counts as zero in the mode decisions."""

_PAINLEVE_W = 1e-6
"""Contact compliance w (dimensionless, O(1) in ordinary contact) treated as zero."""


@dataclass
class _End:
    t: float
    z: NDArray
    reason: str  # "end" or the name of the event that ended the phase


class _Dense:
    """Dense output of one phase: the stepper's per-step interpolants, t -> state (6, m)."""

    def __init__(self, t0: float) -> None:
        self.nodes = [t0]
        self.pieces: list[Callable] = []

    def add(self, t1: float, piece: Callable) -> None:
        self.nodes.append(t1)
        self.pieces.append(piece)

    def __call__(self, t: ArrayLike) -> NDArray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if not self.pieces:
            return np.zeros((6, t.size))
        index = np.clip(np.searchsorted(self.nodes, t, side="left") - 1, 0, len(self.pieces) - 1)
        out = np.empty((6, t.size))
        for i in np.unique(index):
            mask = index == i
            out[:, mask] = self.pieces[i](t[mask])
        return out


def _run(
    scene: Scene,
    kind: str,
    sigma: int | None,
    t0: float,
    z0: NDArray,
    t_stop: float,
    names: tuple[str, ...],
    monitor: Callable[[NDArray], NDArray],
    rtol: float,
    atol: float,
) -> tuple[_Segment, _End]:
    """Integrate one mode until t_stop or the first event.

    ``monitor(z)`` returns one value per event name; an event happens when its value goes from
    > 0 to <= 0 (all events here are crossings downward). Requiring a strictly positive value
    before the crossing ignores a function that starts at zero, as the slip velocity does just
    after a re-stick or a reversal, or the clearance at lift-off.
    """

    def rhs(t, z):
        qdd, _, _ = _solve_mode(scene, z, kind, sigma)
        return np.concatenate([z[3:], qdd])

    stepper = DOP853(rhs, t0, z0, t_stop, rtol=rtol, atol=atol)
    dense = _Dense(t0)
    t_prev, g_prev = t0, monitor(z0)
    while stepper.status == "running":
        message = stepper.step()
        if stepper.status == "failed":
            # The only singularity of these equations is the slip KKT matrix going singular:
            # the normal force grows like 1/w and the steps shrink toward that instant.
            z_last = np.asarray(stepper.y, dtype=float)
            if kind == _SLIP and _compliance(scene, z_last, _slip_sigma(sigma)) < 1e-3:
                return _Segment(kind, t0, stepper.t, sigma, dense), _End(
                    stepper.t, z_last, "painleve"
                )
            raise RuntimeError(f"DAE integration failed in {kind} at t = {stepper.t}: {message}")
        piece = stepper.dense_output()
        dense.add(stepper.t, piece)
        n_samples = max(_SUBSTEPS, math.ceil((stepper.t - stepper.t_old) / _MAX_GAP))
        for tau in np.linspace(stepper.t_old, stepper.t, n_samples + 1)[1:]:
            g = monitor(piece(tau))
            hits = np.nonzero((g_prev > 0) & (g <= 0))[0]
            if hits.size:
                t_event, name = _locate(monitor, piece, t_prev, tau, hits, names)
                dense.nodes[-1] = t_event
                seg = _Segment(kind, t0, t_event, sigma, dense)
                return seg, _End(t_event, np.asarray(piece(t_event), dtype=float), name)
            t_prev, g_prev = tau, g
    t1 = float(stepper.t)
    return _Segment(kind, t0, t1, sigma, dense), _End(t1, np.asarray(stepper.y, dtype=float), "end")


def _locate(
    monitor: Callable[[NDArray], NDArray],
    piece: Callable,
    lo: float,
    hi: float,
    hits: NDArray,
    names: tuple[str, ...],
) -> tuple[float, str]:
    """Earliest root in [lo, hi] of the monitored functions that changed sign there."""
    roots = []
    for j in hits:
        root = brentq(lambda s, j=j: monitor(piece(s))[j], lo, hi, xtol=1e-15)
        roots.append((root, names[j]))
    t_event, name = min(roots)
    if name == "lift" and "painleve" in names:
        # Approaching w = 0 the normal force spins the hoop so hard that the free vertical
        # acceleration is driven to zero with w (n tends to 0/0), so the lift-off test can flip
        # a hair before w does. A "lift-off" where w is negligible is the Painlevé point.
        w = monitor(piece(t_event))[names.index("painleve")]
        if w < _PAINLEVE_W:
            name = "painleve"
    return t_event, name


_ROLL_EVENTS = ("slip", "lift")
_SLIP_EVENTS = ("stop", "lift", "painleve")


def _roll_monitor(scene: Scene, z: NDArray) -> NDArray:
    """Rolling ends when static friction no longer suffices (slip) or n changes sign (lift)."""
    _, f, n = _solve_mode(scene, z, _ROLL, None)
    return np.array([scene.mus * n - abs(f), n])


def _slip_monitor(scene: Scene, z: NDArray, sigma: int) -> NDArray:
    """A slip ends when sigma s reaches 0 (stop), n reaches 0 (lift) or w reaches 0 (Painlevé).

    The floor pushes (n > 0) while the unconstrained vertical acceleration of the contact
    points into the floor; n = -that / w, so watching the numerator and w separately keeps the
    lift-off test smooth where n itself has a pole (w = 0).
    """
    accel_free = float(_solve_mode(scene, z, _FLIGHT, None)[0][1])
    return np.array([sigma * _slip_velocity(scene, z), -accel_free, _compliance(scene, z, sigma)])


def _roll(scene, t0, z0, t_stop, rtol, atol):
    def monitor(z):
        return _roll_monitor(scene, z)

    return _run(scene, _ROLL, None, t0, z0, t_stop, _ROLL_EVENTS, monitor, rtol, atol)


def _slip(scene, t0, z0, sigma, t_stop, rtol, atol):
    def monitor(z):
        return _slip_monitor(scene, z, sigma)

    return _run(scene, _SLIP, sigma, t0, z0, t_stop, _SLIP_EVENTS, monitor, rtol, atol)


def _flight(scene, t0, z0, rtol, atol) -> tuple[_Segment, float, float]:
    """Free flight to the first descent through y = a; returns (segment, t_impact, height)."""

    def monitor(z):
        return np.array([z[1] - scene.a])

    # The centre of mass is back below a - r, hence the hoop on the floor, well within this.
    Y0 = z0[1] + scene.com_offset * math.cos(z0[2])
    Ydot0 = z0[4] - scene.com_offset * math.sin(z0[2]) * z0[5]
    drop = Y0 - (scene.a - scene.com_offset)
    horizon = (Ydot0 + math.sqrt(Ydot0**2 + 2 * scene.g * max(drop, 0.0))) / scene.g + 1.0
    seg, end = _run(scene, _FLIGHT, None, t0, z0, t0 + horizon, ("impact",), monitor, rtol, atol)
    if end.reason != "impact":
        raise RuntimeError("DAE flight: no impact found")
    return seg, end.t, _max_clearance(scene, seg)


def _max_clearance(scene: Scene, seg: _Segment) -> float:
    grid = np.linspace(seg.t_start, seg.t_end, 2001)
    clear = seg.dense(grid)[1] - scene.a
    j = int(np.argmax(clear))
    lo, hi = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
    if hi <= lo:
        return max(float(clear[j]), 0.0)
    res = minimize_scalar(
        lambda t: -(float(seg.dense(np.array([t]))[1, 0]) - scene.a),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-13},
    )
    return max(float(clear[j]), -float(res.fun), 0.0)


# --------------------------------------------------------------------------- driver
def _initial_state(scene: Scene) -> NDArray:
    """Hoop centre at (0, a), spinning at thetadot0, centre velocity xdot0 (or rolling)."""
    xdot = scene.a * scene.thetadot0 if scene.xdot0 is None else scene.xdot0
    return np.array([0.0, scene.a, scene.theta0, xdot, 0.0, scene.thetadot0])


def _sign(v: float) -> int:
    return 1 if v > 0 else -1


def _next_mode(scene: Scene, z: NDArray, *, allow_roll: bool) -> tuple[str, int | None]:
    """The contact mode a hoop on the floor in state z continues in, by Coulomb's law.

    Each mode is tried and kept only if its multipliers are admissible: rolling needs n >= 0
    and |f| <= mus n; slipping in direction sigma needs w > 0, n > 0 and, from rest, a slip
    acceleration that does not point against sigma; flight needs the free contact acceleration
    to point away from the floor. If none is admissible no contact force is consistent: Painlevé.
    """
    s = _slip_velocity(scene, z)
    if s != 0.0:
        candidates = [_sign(s)]
    else:
        _, f, n = _solve_mode(scene, z, _ROLL, None)
        if allow_roll and n >= 0 and abs(f) <= scene.mus * n:
            return _ROLL, None
        candidates = [-_sign(f), _sign(f)]
    if scene.inertia_com <= 0:
        return _SLIP, candidates[0]  # the driver reports the degenerate case
    for sigma in candidates:
        w = _compliance(scene, z, sigma)
        if w <= 0:
            continue
        qdd, _, n = _solve_mode(scene, z, _SLIP, sigma)
        slip_accel = qdd[0] - scene.a * qdd[2]
        # With muk = mus the kinetic force at onset equals the static one that just failed, so
        # the slip starts with zero acceleration: accept that up to rounding.
        if n > 0 and (s != 0.0 or sigma * slip_accel > -_ROUNDING * scene.g):
            return _SLIP, sigma
    if s != 0.0 and _compliance(scene, z, candidates[0]) <= 0:
        return _PAINLEVE, candidates[0]
    if _solve_mode(scene, z, _FLIGHT, None)[0][1] >= 0:
        return _FLIGHT, None
    return _PAINLEVE, candidates[0]


def solve_dae(scene: Scene, *, rtol: float = 1e-10, atol: float = 1e-12) -> DaeSolution:
    """Solve the scene with the multiplier formulation from t = 0 to t_end or first impact.

    As in the exact solver, a flight that starts before t_end is followed to its impact.
    """
    for name, value in (("rtol", rtol), ("atol", atol)):
        if not (value > 0 and math.isfinite(value)):
            raise ValueError(f"{name} must be a positive number, got {value}")
    solve = _DaeSolve(scene, rtol, atol, z=_initial_state(scene))
    solve.run()
    return solve.solution()


@dataclass
class _DaeSolve:
    """One call of :func:`solve_dae`: its contact modes and what it has found so far
    (mutable: every phase moves it on)."""

    scene: Scene
    rtol: float
    atol: float
    z: NDArray
    t: float = 0.0
    mode: str = _ROLL
    sigma: int | None = None
    segments: list[_Segment] = field(default_factory=list)
    phases: list[DaePhase] = field(default_factory=list)
    found: dict[str, float] = field(default_factory=dict)
    """The events found so far, by their name in :class:`DaeSolution`."""
    outcome: str | None = None
    message: str = ""

    def run(self) -> None:
        """Phase after phase, until the window ends, the hoop lands or the solve stops."""
        self.mode, self.sigma = _next_mode(self.scene, self.z, allow_roll=True)
        if self.mode == _FLIGHT:
            self.outcome = "lifts-at-start"
        while self.outcome is None or self.mode == _FLIGHT:
            if not self._step():
                break

    def solution(self) -> DaeSolution:
        outcome = self.outcome
        if outcome is None:
            outcome = "slips" if "t_slip" in self.found else "rolls"
        segments = self.segments
        if not segments:
            frozen = self.z.copy()
            segments = [
                _Segment(
                    _ROLL, 0.0, 0.0, None, lambda tt: np.tile(frozen[:, None], (1, np.size(tt)))
                )
            ]
        found = self.found
        return DaeSolution(
            scene=self.scene,
            outcome=outcome,
            phases=tuple(self.phases),
            t_slip=found.get("t_slip"),
            theta_slip=found.get("theta_slip"),
            thetadot_slip=found.get("thetadot_slip"),
            t_restick=found.get("t_restick"),
            t_lift=found.get("t_lift"),
            t_impact=found.get("t_impact"),
            hop_height=found.get("hop_height"),
            t_painleve=found.get("t_painleve"),
            message=self.message,
            segments=tuple(segments),
        )

    def _step(self) -> bool:
        """The next phase and the mode after it; False once the solve is over."""
        t = self.t
        if self.mode == _PAINLEVE:
            self.outcome = "painleve"
            self.found["t_painleve"] = t
            self.message = f"no consistent contact force (Painlevé) at t = {t:.6g} s"
            return False
        if self.mode != _FLIGHT and t >= self.scene.t_end:
            return False
        if len(self.phases) > 1000:
            raise RuntimeError("DAE: more than 1000 phases")
        if self.mode == _FLIGHT:
            self._fly()
            return False
        phase = self._contact_phase()
        return phase is not None and self._after(*phase)

    def _fly(self) -> None:
        t = self.t
        seg, t_impact, height = _flight(self.scene, t, self.z, self.rtol, self.atol)
        self.segments.append(seg)
        self.phases.append(DaePhase(_FLIGHT, t, t_impact))
        self.found.update(t_lift=t, t_impact=t_impact, hop_height=height)
        self.outcome = self.outcome or "hops"

    def _contact_phase(self) -> tuple[_Segment, _End] | None:
        """The next roll or slip phase; None (the solve ends) for a slip with no inertia."""
        scene, t, z = self.scene, self.t, self.z
        if self.mode != _SLIP:
            return _roll(scene, t, z, scene.t_end, self.rtol, self.atol)
        if "t_slip" not in self.found:
            self.found.update(t_slip=t, theta_slip=float(z[2]), thetadot_slip=float(z[5]))
        if scene.inertia_com <= 0:
            self.outcome = "degenerate"
            self.message = f"slip at t = {t:.6g} s needs a positive moment of inertia"
            return None
        return _slip(scene, t, z, self.sigma, scene.t_end, self.rtol, self.atol)

    def _after(self, seg: _Segment, end: _End) -> bool:
        """Keep a contact phase and choose the mode after it; False once the solve is over."""
        mode = self.mode
        self.segments.append(seg)
        self.phases.append(DaePhase(mode, self.t, end.t, self.sigma if mode == _SLIP else None))
        self.t, self.z = end.t, end.z
        if end.reason == "end":
            return False
        if end.reason in ("slip", "stop"):
            # The contact point is at rest here: remove the rounding left in xdot - a thetadot
            # so that the next mode starts exactly on its constraint.
            self.z = self.z.copy()
            self.z[3] = self.scene.a * self.z[5]
        self._next(end.reason)
        return True

    def _next(self, reason: str) -> None:
        """The mode after a contact phase that ended on an event."""
        scene, z = self.scene, self.z
        if reason == "slip":
            # Static friction just failed, so rolling is not an option at this instant.
            self.mode, self.sigma = _next_mode(scene, z, allow_roll=False)
        elif reason == "stop":
            self.mode, self.sigma = _next_mode(scene, z, allow_roll=True)
            if self.mode == _ROLL:
                self.found.setdefault("t_restick", self.t)
        elif reason == "lift" and self.phases[-1].kind == _ROLL:
            self.mode, self.sigma = _next_mode(scene, z, allow_roll=False)
        elif reason == "lift":
            self.mode, self.sigma = _FLIGHT, None
        else:  # painleve
            self.mode = _PAINLEVE
