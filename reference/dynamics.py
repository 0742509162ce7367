"""Equations of motion of the weighted hoop in each contact mode: pure functions.

Forces are per unit mass (accelerations). ``sigma`` is the slip direction
sign(xdot - a*thetadot); kinetic friction is f = -sigma*muk*n. All functions accept scalars
or NumPy arrays for theta and thetadot.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hoopbench.models.scene import Scene

__all__ = [
    "free_centre_acceleration",
    "rolling_forces",
    "rolling_thetaddot",
    "slip_accelerations",
    "slip_denominator",
    "slip_normal_force",
    "slip_torque_factor",
]


def rolling_thetaddot(scene: Scene, theta: ArrayLike, thetadot: ArrayLike) -> NDArray:
    """Angular acceleration while rolling without slip, rad/s^2 (any theta0)."""
    return _rolling_thetaddot(scene, np.sin(theta), np.cos(theta), np.asarray(thetadot) ** 2)


def _rolling_thetaddot(scene: Scene, s: NDArray, c: NDArray, w2: NDArray) -> NDArray:
    """:func:`rolling_thetaddot` from sin(theta), cos(theta) and thetadot^2, taken once by
    :func:`rolling_forces` for both (a run's reading computes them for every sample)."""
    lam = scene.lam
    return lam * s * (scene.g / scene.a + w2) / (2.0 + lam * scene.eps + 2.0 * lam * c)


def rolling_forces(scene: Scene, theta: ArrayLike, thetadot: ArrayLike) -> tuple[NDArray, NDArray]:
    """(f, n): friction and normal force per unit mass, m/s^2, that keep rolling going."""
    lam, a = scene.lam, scene.a
    s, c = np.sin(theta), np.cos(theta)
    w2 = np.asarray(thetadot) ** 2
    alpha = _rolling_thetaddot(scene, s, c, w2)
    f = a * ((1.0 + lam * c) * alpha - lam * s * w2)
    n = scene.g - a * lam * (s * alpha + c * w2)
    return f, n


def slip_torque_factor(scene: Scene, theta: ArrayLike, sigma: int) -> NDArray:
    """lam sin(theta) + sigma muk (1 + lam cos(theta)): torque per unit n, over a."""
    lam = scene.lam
    return lam * np.sin(theta) + sigma * scene.muk * (1.0 + lam * np.cos(theta))


def slip_denominator(scene: Scene, theta: ArrayLike, sigma: int) -> NDArray:
    """D = 1 + lam sin(theta) [lam sin(theta) + sigma muk (1 + lam cos(theta))] / k.

    n = (g - lam a cos(theta) thetadot^2) / D while slipping; D = 0 is the Painlevé point.
    """
    scene.require_inertia("the slipping phase")
    return 1.0 + scene.lam * np.sin(theta) * slip_torque_factor(scene, theta, sigma) / scene.k


def slip_normal_force(scene: Scene, theta: ArrayLike, thetadot: ArrayLike, sigma: int) -> NDArray:
    """Normal force per unit mass while slipping in direction sigma, m/s^2."""
    numerator = scene.g - scene.lam * scene.a * np.cos(theta) * np.asarray(thetadot) ** 2
    # D = 0 is the Painlevé point: n is infinite there by the physics, not by a bug.
    with np.errstate(divide="ignore", invalid="ignore"):
        return numerator / slip_denominator(scene, theta, sigma)


def slip_accelerations(
    scene: Scene, theta: ArrayLike, thetadot: ArrayLike, sigma: int
) -> tuple[NDArray, NDArray, NDArray, NDArray]:
    """(Xddot, Yddot, thetaddot, n) while slipping on the floor, SI units."""
    n = slip_normal_force(scene, theta, thetadot, sigma)
    Xddot = -sigma * scene.muk * n
    Yddot = n - scene.g
    thetaddot = n * slip_torque_factor(scene, theta, sigma) / (scene.k * scene.a)
    return Xddot, Yddot, thetaddot, n


def free_centre_acceleration(scene: Scene, theta: ArrayLike, thetadot: ArrayLike) -> NDArray:
    """Vertical acceleration of the hoop centre with no contact force, m/s^2.

    -g + lam a cos(theta) thetadot^2: positive means the floor would have to pull.
    """
    return -scene.g + scene.lam * scene.a * np.cos(theta) * np.asarray(thetadot) ** 2
