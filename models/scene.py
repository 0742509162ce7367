"""The one description of the weighted hoop and its scene.

Conventions (used everywhere in hoopbench):

* the plane is x (direction of rolling) and y (up); the floor is y = 0;
* ``theta`` is the angle of the weight from the upward vertical through the hoop centre,
  positive clockwise, so rolling toward +x increases it; theta = 0 puts the weight on top;
* the hoop centre starts at (0, a), on the floor;
* SI units throughout; degrees only at the edges (CLI, reports).

Every derived quantity (inertia, centre-of-mass offset, energy, initial velocities) is
computed here and nowhere else.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TypedDict, Unpack

from hoopbench.models.checks import check_finite

__all__ = ["MAX_TURNS", "THETA0_LIMIT_DEG", "DegenerateSceneError", "Scene"]

THETA0_LIMIT_DEG = 360.0
"""Largest start angle either way, deg: one turn (beyond it is the same start again, so a
larger value is a mistake, most often radians given as degrees). The one bound for every
way in: the command line, the API, suite files and the map's axis."""


class DegenerateSceneError(ValueError):
    """A phase needs a positive moment of inertia about the centre of mass, and it is zero."""


MAX_TURNS = 1e7
"""Most turns of the hoop in the window at its initial spin (|thetadot0| t_end / 2 pi): a run
resolves a turn in a step at the very least, and no run takes more than ten million steps
(engines/settings.MAX_STEPS). A larger spin is one no run can follow, and its derived
quantities (chi, the energy, the solver's thetadot^3) overflow a float: refused by name."""


def _turns(thetadot0: float, t_end: float) -> float:
    return abs(thetadot0) * t_end / (2 * math.pi)


def _check_range(name: str, value: float, low: float, high: float, allowed: str) -> None:
    if not (low <= value <= high):
        raise ValueError(f"{name} must be {allowed}, got {value}")


class _Settings(TypedDict, total=False):
    """Scene fields a constructor takes by keyword besides the initial spin (see Scene)."""

    lam: float
    mus: float
    muk: float
    eps: float
    theta0: float
    g: float
    a: float
    M: float
    t_end: float
    xdot0: float | None
    name: str
    why: str


class _Changes(_Settings, total=False):
    """Scene fields :meth:`Scene.with_` may change: the settings and the initial spin."""

    thetadot0: float


@dataclass(frozen=True)
class Scene:
    """A weighted hoop on a flat floor, at its initial state.

    The initial spin is ``thetadot0``; use :meth:`from_chi` or :meth:`from_energy` to give it
    as the spin parameter chi = a*thetadot0**2/g or as the energy per unit mass.
    """

    lam: float
    """Mass fraction of the weight on the rim, dimensionless, in [0, 1]."""
    thetadot0: float
    """Initial angular velocity, rad/s, clockwise positive (rolling toward +x)."""
    mus: float
    """Static friction coefficient, dimensionless, >= 0."""
    muk: float
    """Kinetic friction coefficient, dimensionless, 0 <= muk <= mus."""
    eps: float = 0.0
    """The weight's own inertia, dimensionless: I = M a^2 (1 - lam^2 + lam*eps); >= 0."""
    theta0: float = 0.0
    """Initial angle of the weight from the upward vertical, rad, clockwise positive."""
    g: float = 9.8
    """Gravitational acceleration, m/s^2, > 0."""
    a: float = 1.0
    """Hoop radius, m, > 0."""
    M: float = 1.0
    """Total mass (ring plus weight), kg, > 0."""
    t_end: float = 3.0
    """End of the simulated window, s, > 0 (the window also ends at the first impact)."""
    xdot0: float | None = None
    """Initial velocity of the hoop centre, m/s; None means rolling: a*thetadot0."""
    name: str = field(default="", compare=False)
    """Catalogue name, if any."""
    why: str = field(default="", compare=False)
    """Why the scene is in the catalogue."""

    def __post_init__(self) -> None:
        for name in ("lam", "thetadot0", "mus", "muk", "eps", "theta0", "g", "a", "M", "t_end"):
            object.__setattr__(self, name, check_finite(name, getattr(self, name)))
        if self.xdot0 is not None:
            object.__setattr__(self, "xdot0", check_finite("xdot0", self.xdot0))
        limit = math.radians(THETA0_LIMIT_DEG)
        _check_range("theta0", self.theta0, -limit, limit, "within one turn, [-2 pi, 2 pi] rad")
        self._check_dimensions()
        self._check_coefficients()
        turns = _turns(self.thetadot0, self.t_end)
        if not turns <= MAX_TURNS:
            raise ValueError(
                f"thetadot0 = {self.thetadot0:g} rad/s turns the hoop {turns:.3g} times in the "
                f"window t_end = {self.t_end:g} s, more than {MAX_TURNS:.0e}: no run can follow it"
            )

    def _check_dimensions(self) -> None:
        if self.a <= 0:
            raise ValueError(f"a (hoop radius) must be > 0 m, got {self.a}")
        if self.g <= 0:
            raise ValueError(f"g must be > 0 m/s^2, got {self.g}")
        if self.M <= 0:
            raise ValueError(f"M (total mass) must be > 0 kg, got {self.M}")
        if self.t_end <= 0:
            raise ValueError(f"t_end must be > 0 s, got {self.t_end}")

    def _check_coefficients(self) -> None:
        _check_range("lam", self.lam, 0.0, 1.0, "in [0, 1]")
        if self.eps < 0:
            raise ValueError(f"eps must be >= 0, got {self.eps}")
        if self.mus < 0:
            raise ValueError(f"mus must be >= 0, got {self.mus}")
        if self.muk < 0:
            raise ValueError(f"muk must be >= 0, got {self.muk}")
        if self.muk > self.mus:
            raise ValueError(f"muk must be <= mus (= {self.mus}), got {self.muk}")

    # ----------------------------------------------------------------- constructors
    @classmethod
    def from_chi(cls, chi: float, **kwargs: Unpack[_Settings]) -> Scene:
        """A scene whose initial spin is given by chi = a*thetadot0**2/g (>= 0)."""
        chi = check_finite("chi", chi)
        if chi < 0:
            raise ValueError(f"chi must be >= 0, got {chi}")
        g = check_finite("g", kwargs.get("g", 9.8))
        a = check_finite("a", kwargs.get("a", 1.0))
        if a <= 0 or g <= 0:
            return cls(thetadot0=0.0, **kwargs)  # let __post_init__ name the bad field
        thetadot0 = math.sqrt(chi * g / a)  # inf past a float: refused below, by chi's name
        t_end = check_finite("t_end", kwargs.get("t_end", 3.0))
        if t_end > 0 and not _turns(thetadot0, t_end) <= MAX_TURNS:
            raise ValueError(
                f"chi = {chi:g} (with a = {a:g} m, g = {g:g} m/s^2) spins the hoop "
                f"{_turns(thetadot0, t_end):.3g} times in the window t_end = {t_end:g} s, more "
                f"than {MAX_TURNS:.0e}: no run can follow it"
            )
        return cls(thetadot0=thetadot0, **kwargs)

    @classmethod
    def from_energy(cls, energy_per_mass: float, **kwargs: Unpack[_Settings]) -> Scene:
        """A rolling scene whose initial spin gives this energy per unit mass (J/kg).

        Raises ValueError when the energy is below the potential energy at theta0: the hoop
        cannot start there.
        """
        energy_per_mass = check_finite("energy_per_mass", energy_per_mass)
        probe = cls(thetadot0=0.0, **kwargs)
        if probe.xdot0 is not None:
            raise ValueError("from_energy builds a rolling start; do not pass xdot0")
        potential = probe.g * probe.a * (1.0 + probe.lam * math.cos(probe.theta0))
        kinetic = energy_per_mass - potential
        if kinetic < 0:
            raise ValueError(
                f"energy_per_mass {energy_per_mass} J/kg is below the potential energy "
                f"{potential} J/kg at theta0: the hoop cannot roll from this start"
            )
        factor = 0.5 * probe.a**2 * probe.rolling_inertia_factor(probe.theta0)
        return replace(probe, thetadot0=math.sqrt(kinetic / factor))

    def with_(self, **changes: Unpack[_Changes]) -> Scene:
        """A copy with some fields changed (validated again)."""
        return replace(self, **changes)

    # ----------------------------------------------------------------- derived quantities
    @property
    def k(self) -> float:
        """Inertia about the centre of mass over M a^2: 1 - lam^2 + lam*eps, dimensionless."""
        return 1.0 - self.lam**2 + self.lam * self.eps

    @property
    def inertia_com(self) -> float:
        """Moment of inertia about the centre of mass, kg m^2."""
        return self.M * self.a**2 * self.k

    @property
    def com_offset(self) -> float:
        """Distance from the hoop centre to the centre of mass, m (along the weight)."""
        return self.lam * self.a

    @property
    def is_degenerate(self) -> bool:
        """True when I = 0 (lam = 1, eps = 0): slipping and torque balance are undefined."""
        return self.k <= 0.0

    @property
    def chi(self) -> float:
        """Spin parameter a*thetadot0**2/g, dimensionless."""
        return self.a * self.thetadot0**2 / self.g

    @property
    def rolls_at_start(self) -> bool:
        """True when the centre starts with the rolling velocity a*thetadot0."""
        return self.xdot0 is None or self.xdot0 == self.a * self.thetadot0

    @property
    def centre_velocity0(self) -> float:
        """Initial horizontal velocity of the hoop centre, m/s."""
        return self.a * self.thetadot0 if self.xdot0 is None else self.xdot0

    def rolling_inertia_factor(self, theta: float) -> float:
        """2 + lam*eps + 2*lam*cos(theta): rolling kinetic energy is (a^2/2) * this * thetadot^2."""
        return 2.0 + self.lam * self.eps + 2.0 * self.lam * math.cos(theta)

    def require_inertia(self, what: str) -> None:
        """Raise DegenerateSceneError if ``what`` needs I > 0 and I = 0."""
        if self.is_degenerate:
            raise DegenerateSceneError(
                f"{what} needs a positive moment of inertia about the centre of mass; "
                f"lam = {self.lam}, eps = {self.eps} give I = 0 (degenerate case)"
            )

    def initial_state(self) -> tuple[float, float, float, float, float, float]:
        """(X, Y, theta, Xdot, Ydot, thetadot) at t = 0: centre of mass, SI units."""
        s, c = math.sin(self.theta0), math.cos(self.theta0)
        r = self.com_offset
        X = r * s
        Y = self.a + r * c
        Xdot = self.centre_velocity0 + r * c * self.thetadot0
        Ydot = -r * s * self.thetadot0
        return (X, Y, self.theta0, Xdot, Ydot, self.thetadot0)

    @property
    def energy_per_mass(self) -> float:
        """Initial mechanical energy per unit mass, J/kg (floor at zero potential)."""
        _X, Y, _, Xdot, Ydot, thetadot = self.initial_state()
        return self.g * Y + 0.5 * (Xdot**2 + Ydot**2) + 0.5 * self.k * self.a**2 * thetadot**2

    def to_dict(self) -> dict[str, float | str | None]:
        """Plain fields, SI units, for JSON and tables."""
        return {
            "name": self.name,
            "g": self.g,
            "a": self.a,
            "M": self.M,
            "lam": self.lam,
            "eps": self.eps,
            "mus": self.mus,
            "muk": self.muk,
            "theta0": self.theta0,
            "thetadot0": self.thetadot0,
            "chi": self.chi,
            "xdot0": self.xdot0,
            "t_end": self.t_end,
        }
