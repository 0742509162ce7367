"""Kinematic relations between the centre of mass and the hoop, for scalars or arrays.

The one place that converts centre-of-mass coordinates (X, Y, theta and rates) into the
quantities the detectors read: clearance, slip velocity and energy.

Clearance and slip velocity are read at the body's **lowest point**, taken on its rigid
geometry (penetration not included). A body turning clockwise at thetadot moves its material
points at depth h below the hoop centre horizontally at xdot - h*thetadot, wherever they are
along x. For the hoop's circle the lowest point is at depth a, whatever the angle, so the
clearance is y - a and the slip velocity xdot - a*thetadot. A faceted contact shape (MuJoCo's
ring of capsules, PyBullet's convex hull) is described by a :class:`Polygon`: its lowest point
is at the depth h(theta) of its lowest vertex plus its rounding, so the clearance is
y - h(theta) and the slip velocity xdot - h(theta)*thetadot. With h = a instead, a polygon
rolling over its vertices without slipping would show a slip of (y - a)*thetadot, millimetres
per second on a 32-gon. The depth is geometric, never the engine's penetration: for a soft
contact the point at the floor surface moves while the body rolls, and reading the slip there
would show one that is not happening.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from hoopbench.models.scene import Scene

__all__ = [
    "Polygon",
    "centre_position",
    "centre_velocity",
    "clearance",
    "com_position",
    "com_state",
    "com_state_ccw",
    "contact_depth",
    "contact_offset",
    "energy_per_mass",
    "reach",
    "rolling_start",
    "slip_velocity",
]


@dataclass(frozen=True, eq=False)
class Polygon:
    """A convex contact shape in the plane of the hoop: vertices, rounded by a radius.

    ``vertices`` are (u, w) pairs, m, in the body frame with the hoop centre at the origin:
    at theta = 0, u points along +x and w up, toward the weight. A body point (u, w) sits at
    (u cos theta + w sin theta, w cos theta - u sin theta) from the hoop centre. ``rounding``,
    m, is the radius of the sphere swept over the polygon (a capsule's radius, a collision
    margin): the shape is every point within ``rounding`` of the polygon.
    """

    vertices: tuple[tuple[float, float], ...]
    rounding: float = 0.0

    def __post_init__(self) -> None:
        vertices = tuple((float(u), float(w)) for u, w in self.vertices)
        if len(vertices) < 3:
            raise ValueError(f"a polygon needs at least 3 vertices, got {len(vertices)}")
        if not all(math.isfinite(u) and math.isfinite(w) for u, w in vertices):
            raise ValueError("polygon vertices must be finite")
        if not (math.isfinite(self.rounding) and self.rounding >= 0):
            raise ValueError(f"rounding must be >= 0 m, got {self.rounding}")
        object.__setattr__(self, "vertices", vertices)
        object.__setattr__(self, "rounding", float(self.rounding))

    @classmethod
    def regular(cls, n: int, radius: float, phase: float, rounding: float = 0.0) -> Polygon:
        """n vertices at ``radius`` m from the centre, the first at body angle ``phase`` rad,
        measured from +u toward +w, the others every 2 pi / n."""
        angles = phase + 2.0 * math.pi * np.arange(n) / n
        return cls(
            tuple(zip(radius * np.cos(angles), radius * np.sin(angles), strict=True)), rounding
        )

    @classmethod
    def from_points(cls, points: Iterable[tuple[float, float]], rounding: float = 0.0) -> Polygon:
        """The polygon of these body-frame points (only their lowest ever touches)."""
        return cls(tuple(points), rounding)


def _lowest_vertex(theta: ArrayLike, shape: Polygon) -> tuple[NDArray, NDArray]:
    """(depth, horizontal offset) below and beside the hoop centre of the lowest vertex, m."""
    u, w = np.asarray(shape.vertices).T
    s, c = np.sin(theta)[..., None], np.cos(theta)[..., None]
    depth = u * s - w * c
    lowest = np.argmax(depth, axis=-1)[..., None]
    offset = u * c + w * s
    return (
        np.take_along_axis(depth, lowest, axis=-1)[..., 0],
        np.take_along_axis(offset, lowest, axis=-1)[..., 0],
    )


def contact_depth(scene: Scene, theta: ArrayLike, shape: Polygon | None = None) -> NDArray:
    """Depth h(theta) of the body's lowest point below the hoop centre, m: a for the hoop's
    circle (``shape`` None), the lowest vertex plus the rounding for a polygon."""
    theta = np.asarray(theta, dtype=float)
    if shape is None:
        return np.full(theta.shape, scene.a)
    return _lowest_vertex(theta, shape)[0] + shape.rounding


def contact_offset(scene: Scene, theta: ArrayLike, shape: Polygon | None = None) -> NDArray:
    """Horizontal position of the lowest point from the hoop centre, m (+x ahead): 0 for the
    circle, the lowest vertex's for a polygon. It is dh/dtheta, the rate at which the depth
    changes as the body turns."""
    theta = np.asarray(theta, dtype=float)
    if shape is None:
        return np.zeros(theta.shape)
    return _lowest_vertex(theta, shape)[1]


def rolling_start(
    scene: Scene, shape: Polygon | None = None
) -> tuple[float, float, float, float, float, float]:
    """Hoop-centre state (x, y, theta, xdot, ydot, thetadot) at t = 0 with the lowest point of
    ``shape`` on the floor and moving as the scene's rim point does: at rest vertically, and
    horizontally at the scene's initial slip velocity (0 for a rolling start).

    For the circle this is the scene's own initial state. A polygon's lowest point is at depth
    h(theta0), and its rigid contact keeps it on the floor only if the centre moves with it:
    xdot = s0 + h*thetadot, ydot = h'(theta0)*thetadot (rotation about the lowest point).
    Placed at height a with the circle's velocities, PyBullet's hull started 1 mm deep.
    """
    X, Y, theta, Xdot, Ydot, thetadot = scene.initial_state()
    x, y = centre_position(scene, X, Y, theta)
    xdot, ydot = centre_velocity(scene, Xdot, Ydot, theta, thetadot)
    if shape is None:
        return float(x), float(y), theta, float(xdot), float(ydot), thetadot
    slip = float(xdot) - scene.a * thetadot
    depth = float(contact_depth(scene, theta, shape))
    xdot_on_floor = slip + depth * thetadot
    ydot_on_floor = float(contact_offset(scene, theta, shape)) * thetadot
    return float(x), depth, theta, float(xdot_on_floor), float(ydot_on_floor), thetadot


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


def com_state_ccw(
    scene: Scene,
    x: ArrayLike,
    y: ArrayLike,
    angle: ArrayLike,
    com_xdot: ArrayLike,
    com_ydot: ArrayLike,
    omega: ArrayLike,
) -> dict[str, NDArray]:
    """Centre-of-mass state, as :func:`com_state`'s keys, from a 2D engine's body: the hoop
    centre (x, y), m, its counter-clockwise angle, rad (theta = -angle), the centre of
    mass's velocity, m/s, and the counter-clockwise angular velocity, rad/s (pymunk, Box2D)."""
    theta = -np.asarray(angle, dtype=float)
    X, Y = com_position(scene, x, y, theta)
    return {
        "X": X,
        "Y": Y,
        "theta": theta,
        "Xdot": np.asarray(com_xdot),
        "Ydot": np.asarray(com_ydot),
        "thetadot": -np.asarray(omega),
    }


def com_position(
    scene: Scene, x: ArrayLike, y: ArrayLike, theta: ArrayLike
) -> tuple[NDArray, NDArray]:
    """Centre of mass (X, Y), m, from the hoop centre (x, y), m, and theta, rad."""
    r = scene.com_offset
    return np.asarray(x) + r * np.sin(theta), np.asarray(y) + r * np.cos(theta)


def clearance(
    scene: Scene, Y: ArrayLike, theta: ArrayLike, shape: Polygon | None = None
) -> NDArray:
    """Height of the body's lowest point above the floor, m (> 0 in flight, < 0 penetrating):
    y - a for the hoop's circle, y - contact_depth for a polygon."""
    depth = scene.a if shape is None else contact_depth(scene, theta, shape)
    return np.asarray(Y) - scene.com_offset * np.cos(theta) - depth


def slip_velocity(
    scene: Scene,
    Xdot: ArrayLike,
    theta: ArrayLike,
    thetadot: ArrayLike,
    shape: Polygon | None = None,
) -> NDArray:
    """Horizontal velocity of the body's lowest point, m/s (0 when rolling): xdot - a*thetadot
    for the hoop's circle, xdot - contact_depth*thetadot for a polygon."""
    thetadot = np.asarray(thetadot)
    depth = scene.a if shape is None else contact_depth(scene, theta, shape)
    return np.asarray(Xdot) - scene.com_offset * np.cos(theta) * thetadot - depth * thetadot


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
