"""Closed-form results for the weighted hoop, used to check the integrated solutions.

The massless-ring limit (lam = 1, eps = 0, start at the top, theta0 = 0) integrates in closed
form while it rolls; the curtate cycloid and the rolling energy curve hold for any scene while it
rolls. All functions are pure and accept scalars or NumPy arrays for the angle or time.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hoopbench.models.scene import Scene

__all__ = [
    "curtate_cycloid",
    "massless_forces",
    "massless_slip_angle",
    "massless_theta",
    "rolling_thetadot_from_energy",
]


def _check_positive(name: str, value: float, unit: str) -> float:
    value = float(value)
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"{name} must be a positive number of {unit}, got {value}")
    return value


def _check_chi(chi: float) -> float:
    chi = float(chi)
    if not (0.0 <= chi <= 1.0):
        # chi > 1 gives n(0) = g (1 - chi) < 0: the hoop leaves the floor at t = 0.
        raise ValueError(f"chi must be in [0, 1] for a rolling start, got {chi}")
    return chi


def massless_theta(t: ArrayLike, chi: float, g: float, a: float) -> NDArray:
    """theta(t), rad, rolling from the top with lam = 1, eps = 0, theta0 = 0.

    theta = 2 asin(sqrt(chi) sinh(sqrt(g/a) t / 2)), from the rolling energy with
    u = sin(theta/2): (du/dt)^2 = (g / 4a) (chi + u^2). ``t`` in s (shape (m,) or scalar),
    ``chi`` = a thetadot0^2 / g, ``g`` in m/s^2, ``a`` in m. The formula describes rolling
    only; past theta = acos(chi) the normal force would be negative. Raises ValueError where
    the argument of asin leaves [-1, 1] (the weight would pass the bottom).
    """
    chi = _check_chi(chi)
    g = _check_positive("g", g, "m/s^2")
    a = _check_positive("a", a, "m")
    arg = math.sqrt(chi) * np.sinh(math.sqrt(g / a) * np.asarray(t, dtype=float) / 2.0)
    if np.any(np.abs(arg) > 1.0):
        worst = float(np.max(np.abs(arg)))
        raise ValueError(
            f"t is outside the closed form's range: sqrt(chi) sinh(sqrt(g/a) t / 2) = {worst} > 1"
        )
    return 2.0 * np.arcsin(arg)


def massless_forces(theta: ArrayLike, chi: float, g: float) -> tuple[NDArray, NDArray]:
    """(f, n), m/s^2 per unit mass, on the massless rolling curve (lam = 1, eps = 0, theta0 = 0).

    n = g (cos theta - chi), f = g (cos theta - chi) tan(theta / 2); same order as
    :func:`hoopbench.reference.dynamics.rolling_forces`. ``theta`` in rad.
    """
    chi = _check_chi(chi)
    g = _check_positive("g", g, "m/s^2")
    theta = np.asarray(theta, dtype=float)
    n = g * (np.cos(theta) - chi)
    return n * np.tan(theta / 2.0), n


def massless_slip_angle(chi: float, mus: float) -> float:
    """Angle, rad, where rolling ends for lam = 1, eps = 0, theta0 = 0.

    f / n = tan(theta / 2), so static friction fails at 2 atan(mus), unless n and f reach zero
    together first at acos(chi): min(acos(chi), 2 atan(mus)).
    """
    chi = _check_chi(chi)
    mus = float(mus)
    if not (mus >= 0 and math.isfinite(mus)):
        raise ValueError(f"mus must be a finite number >= 0, got {mus}")
    return min(math.acos(chi), 2.0 * math.atan(mus))


def curtate_cycloid(
    theta: ArrayLike, lam: float, a: float, theta0: float = 0.0, x0: float = 0.0
) -> tuple[NDArray, NDArray]:
    """Centre of mass (X, Y), m, while rolling without slip, as a function of theta, rad.

    X = x0 + a (theta - theta0) + lam a sin(theta), Y = a (1 + lam cos(theta)); ``x0`` is the
    hoop centre's x, m, when theta = theta0.
    """
    lam = float(lam)
    if not (0.0 <= lam <= 1.0):
        raise ValueError(f"lam must be in [0, 1], got {lam}")
    a = _check_positive("a", a, "m")
    theta = np.asarray(theta, dtype=float)
    X = x0 + a * (theta - theta0) + lam * a * np.sin(theta)
    Y = a * (1.0 + lam * np.cos(theta))
    return X, Y


def rolling_thetadot_from_energy(scene: Scene, theta: ArrayLike) -> NDArray:
    """thetadot, rad/s, on the rolling energy curve of a scene that starts rolling.

    g a (1 + lam cos th) + (a^2 / 2)(2 + lam eps + 2 lam cos th) thdot^2 = E / M. The sign is that
    of thetadot0 (positive when thetadot0 = 0). Raises ValueError for a scene that starts
    sliding (its energy is not on the rolling curve) or where theta is out of energetic reach.
    """
    if not scene.rolls_at_start:
        raise ValueError("scene must start rolling (xdot0 None or a*thetadot0)")
    theta = np.asarray(theta, dtype=float)
    lam, a = scene.lam, scene.a
    kinetic = scene.energy_per_mass - scene.g * a * (1.0 + lam * np.cos(theta))
    # Round-off at a turning point must not turn into a ValueError.
    tol = 1e-12 * scene.energy_per_mass
    if np.any(kinetic < -tol):
        raise ValueError("theta is out of reach: the rolling energy is too small there")
    factor = 0.5 * a**2 * (2.0 + lam * scene.eps + 2.0 * lam * np.cos(theta))
    sign = -1.0 if scene.thetadot0 < 0 else 1.0
    return sign * np.sqrt(np.maximum(kinetic, 0.0) / factor)
