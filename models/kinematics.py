"""Kinematic relations between the centre of mass and the hoop, for scalars or arrays.

The one place that converts centre-of-mass coordinates (X, Y, theta and rates) into the
quantities the detectors read: hoop-centre clearance, slip velocity and energy.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hoopbench.models.scene import Scene

__all__ = [
    "centre_position",
    "centre_velocity",
    "clearance",
    "com_position",
    "com_state",
    "energy_per_mass",
    "reach",
    "slip_velocity",
]


def centre_position(
    scene: Scene, X: ArrayLike, Y: ArrayLike, theta: ArrayLike
) -> tuple[NDArray, NDArray]:
    """Hoop centre (x, y), m, from the centre of mass (X, Y), m, and theta, rad."""
    r = scene.com_offset
    return np.asarray(X) - r * np.sin(theta), np.asarray(Y) - r * np.cos(theta)


def centre_velocity(
    scene: Scene, Xdot: ArrayLike, Ydot: ArrayLike, theta: ArrayLike, thetadot: ArrayLike
) -> tuple[NDArray, NDArray]:
    """Hoop-centre velocity (xdot, ydot), m/s."""
    r = scene.com_offset
    thetadot = np.asarray(thetadot)
    return (
        np.asarray(Xdot) - r * np.cos(theta) * thetadot,
        np.asarray(Ydot) + r * np.sin(theta) * thetadot,
    )


def com_state(
    scene: Scene,
    x: ArrayLike,
    y: ArrayLike,
    theta: ArrayLike,
    xdot: ArrayLike,
    ydot: ArrayLike,
    thetadot: ArrayLike,
) -> dict[str, NDArray]:
    """Centre-of-mass state from the hoop centre's: keys X, Y (m), theta (rad), Xdot, Ydot
    (m/s), thetadot (rad/s), the names Trajectory.from_state takes. Engines whose joints
    carry the hoop centre (MuJoCo, PyBullet) convert with this."""
    r = scene.com_offset
    theta, thetadot = np.asarray(theta, dtype=float), np.asarray(thetadot, dtype=float)
    s, c = np.sin(theta), np.cos(theta)
    X, Y = com_position(scene, x, y, theta)
    return {
        "X": X,
        "Y": Y,
        "theta": theta,
        "Xdot": np.asarray(xdot) + r * c * thetadot,
        "Ydot": np.asarray(ydot) - r * s * thetadot,
        "thetadot": thetadot,
    }


def com_position(
    scene: Scene, x: ArrayLike, y: ArrayLike, theta: ArrayLike
) -> tuple[NDArray, NDArray]:
    """Centre of mass (X, Y), m, from the hoop centre (x, y), m, and theta, rad."""
    r = scene.com_offset
    return np.asarray(x) + r * np.sin(theta), np.asarray(y) + r * np.cos(theta)


def clearance(scene: Scene, Y: ArrayLike, theta: ArrayLike) -> NDArray:
    """Height of the hoop centre above its resting height, y - a, m (> 0 in flight)."""
    return np.asarray(Y) - scene.com_offset * np.cos(theta) - scene.a


def slip_velocity(scene: Scene, Xdot: ArrayLike, theta: ArrayLike, thetadot: ArrayLike) -> NDArray:
    """Velocity of the rim point at the floor, xdot - a*thetadot, m/s (0 when rolling)."""
    thetadot = np.asarray(thetadot)
    return np.asarray(Xdot) - scene.com_offset * np.cos(theta) * thetadot - scene.a * thetadot


def energy_per_mass(
    scene: Scene, Y: ArrayLike, Xdot: ArrayLike, Ydot: ArrayLike, thetadot: ArrayLike
) -> NDArray:
    """Mechanical energy per unit mass, J/kg, with the floor at zero potential."""
    Xdot, Ydot, thetadot = np.asarray(Xdot), np.asarray(Ydot), np.asarray(thetadot)
    return (
        scene.g * np.asarray(Y)
        + 0.5 * (Xdot**2 + Ydot**2)
        + 0.5 * scene.k * scene.a**2 * thetadot**2
    )


def reach(scene: Scene) -> float:
    """Bound on how far the hoop centre can travel in t_end from energy alone, m.

    Centre speed <= |COM speed| + lam*a*|thetadot|, each bounded by the kinetic energy. The
    engines' finite floors are sized with it, so a hoop cannot roll off one before the
    divergence check (energy rise over 50 %) stops the run.
    """
    e = max(scene.energy_per_mass, 0.0)
    v_com = math.sqrt(2.0 * e)
    spin = math.sqrt(2.0 * e / scene.k)  # a*|thetadot| bound
    # Factor 2: an engine may gain some energy before the divergence check stops it.
    return 2.0 * scene.t_end * (v_com + scene.lam * spin)
