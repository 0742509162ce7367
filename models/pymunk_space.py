"""The hoop scene translated into pymunk terms: one dynamic body, one circle, one floor segment.

pymunk conventions differ from hoopbench's in two ways, both handled here:

* angles are counter-clockwise, so the body angle is ``-theta``; the centre of gravity sits at
  (0, lam*a) in body coordinates, which puts the weight straight above the hoop centre at
  body angle 0, i.e. at theta = 0;
* ``Body.position`` is the body origin (our hoop centre) while ``Body.velocity`` is the
  velocity of the centre of gravity (our centre of mass).

Mass and moment come from the scene; the circle carries no mass, because pymunk would
otherwise add a disc's moment to the body. The hoop starts START_OVERLAP deep in the floor
(its reason is given there): pymunk makes a contact only where shapes overlap. Friction
and elasticity are products of the two shapes' values in pymunk, so the floor gets 1.0 and
the hoop carries mu and the restitution: the products are then exactly mu and e.

:func:`build_space` imports pymunk lazily: this module only describes the model.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from typing import Any

from hoopbench.models import kinematics
from hoopbench.models.checks import check_real
from hoopbench.models.scene import Scene

__all__ = ["START_OVERLAP", "PymunkSpec", "build_space", "scene_to_pymunk"]

_FLOOR_MARGIN = 10.0
"""Floor beyond the farthest reachable hoop centre, in hoop radii."""

START_OVERLAP = 1e-6
"""Overlap of the hoop with the floor at the start, in units of a: the start's placement by
pymunk's real contact surface. Chipmunk makes a contact only where shapes overlap, and it
moves positions before it collides: placed exactly touching, a hoop rolling with the weight
in its upper half rises by lam a (1 - cos(thetadot dt)) cos(theta) in its first step (5 nm
on seed-mu at dt 1e-4) and has no contact for that step, then falls freely (-0.86 g dt;
-0.75 on a tilted start). Below the collision slop no bias pushes an overlap out and the
contact holds the hoop as it is, so the start keeps its contact until that per-step rise
has used the overlap up: measured at dt 1e-4, 1e-7 a lost it at step 10 of the tilted
start, 1e-6 a held all 20 steps of a 2 ms start on every tested one. On the catalogue's 1 m
hoop it is below the slop of both profiles (1e-5 m tuned, 0.1 stock), and it is 100 times
below the detectors' lift-off clearance (1e-4 a). A hoop that leaves the floor at once
(lifts-at-start: free, its lowest point accelerates upward) starts exactly touching, as it
does in MuJoCo and Drake: started deep, it would roll for the time it takes to rise out of
the overlap (0.2 ms at dt 1e-4) before its flight."""


@dataclass(frozen=True)
class PymunkSpec:
    """Plain numbers that define the pymunk model of a scene (pymunk conventions, SI units)."""

    mass: float
    """Body mass, kg."""
    moment: float
    """Moment of inertia about the centre of gravity, kg m^2."""
    center_of_gravity: tuple[float, float]
    """Centre of gravity in body coordinates (origin = hoop centre), m."""
    hoop_radius: float
    """Radius of the hoop's circle shape, m."""
    floor_a: tuple[float, float]
    """First end of the floor segment's axis, m."""
    floor_b: tuple[float, float]
    """Second end of the floor segment's axis, m."""
    floor_radius: float
    """Floor segment radius, m; the axis lies this far below y = 0, so the top surface is y = 0."""
    hoop_friction: float
    """Friction of the hoop shape, dimensionless (the pair's is hoop * floor)."""
    floor_friction: float
    """Friction of the floor shape, dimensionless."""
    hoop_elasticity: float
    """Elasticity of the hoop shape, dimensionless (the pair's is hoop * floor)."""
    floor_elasticity: float
    """Elasticity of the floor shape, dimensionless."""
    gravity: tuple[float, float]
    """Space gravity, m/s^2."""
    position: tuple[float, float]
    """Initial body position (hoop centre), m: start_overlap below touching the floor."""
    start_overlap: float
    """Overlap of the hoop with the floor at the start, m (START_OVERLAP times a)."""
    angle: float
    """Initial body angle, rad, counter-clockwise (= -theta0)."""
    velocity: tuple[float, float]
    """Initial velocity of the centre of gravity, m/s."""
    angular_velocity: float
    """Initial angular velocity, rad/s, counter-clockwise (= -thetadot0)."""

    @property
    def friction(self) -> float:
        """The pair's friction coefficient as pymunk combines it (product)."""
        return self.hoop_friction * self.floor_friction

    @property
    def elasticity(self) -> float:
        """The pair's elasticity as pymunk combines it (product)."""
        return self.hoop_elasticity * self.floor_elasticity

    def to_dict(self) -> dict[str, Any]:
        """Plain fields (tuples as lists) plus the combined friction and elasticity."""
        out = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}
        out["friction"] = self.friction
        out["elasticity"] = self.elasticity
        return out

    def to_json(self, **kwargs: Any) -> str:
        """The spec as JSON text (``json.dumps`` keyword arguments pass through)."""
        return json.dumps(self.to_dict(), **kwargs)


def scene_to_pymunk(scene: Scene, *, mu: float, restitution: float = 0.0) -> PymunkSpec:
    """The pymunk model of ``scene`` with pair friction ``mu`` and elasticity ``restitution``.

    Raises DegenerateSceneError for I = 0 (pymunk needs a positive moment) and ValueError for
    a negative or non-finite mu, or a restitution outside [0, 1].
    """
    scene.require_inertia("a pymunk body")
    mu = check_real("mu", mu, low=0.0)
    restitution = check_real("restitution", restitution, low=0.0, high=1.0)
    a = scene.a
    X, Y, theta, Xdot, Ydot, thetadot = scene.initial_state()
    x, y = kinematics.centre_position(scene, X, Y, theta)
    half = _FLOOR_MARGIN * a + kinematics.reach(scene)
    # Free of the floor, the lowest point's acceleration is -g + lam a thetadot^2 cos(theta)
    # (ballistic centre of mass, constant spin); at >= 0 no contact force acts at the start.
    leaves = -scene.g + scene.com_offset * thetadot**2 * math.cos(theta) >= 0.0
    overlap = 0.0 if leaves else START_OVERLAP * a
    # A thick floor cannot be tunnelled through; its top surface is exactly y = 0.
    floor_radius = a
    return PymunkSpec(
        mass=scene.M,
        moment=scene.inertia_com,
        center_of_gravity=(0.0, scene.com_offset),
        hoop_radius=a,
        floor_a=(-half, -floor_radius),
        floor_b=(half, -floor_radius),
        floor_radius=floor_radius,
        hoop_friction=mu,
        floor_friction=1.0,
        hoop_elasticity=restitution,
        floor_elasticity=1.0,
        gravity=(0.0, -scene.g),
        position=(float(x), float(y) - overlap),
        start_overlap=overlap,
        angle=-theta,
        velocity=(Xdot, Ydot),
        angular_velocity=-thetadot,
    )


def build_space(
    spec: PymunkSpec,
    *,
    iterations: int,
    collision_slop: float,
    collision_bias: float | None = None,
) -> tuple[Any, Any, Any]:
    """A pymunk Space holding the spec's hoop and floor: (space, body, hoop_shape).

    ``collision_bias`` None keeps pymunk's default. No damping (Space.damping = 1).
    The option values are the pymunk engine's, already checked (hoopbench.engines.pymunk_engine).
    """
    import pymunk

    space = pymunk.Space()
    space.gravity = spec.gravity
    space.damping = 1.0
    space.iterations = int(iterations)
    space.collision_slop = float(collision_slop)
    if collision_bias is not None:
        space.collision_bias = float(collision_bias)

    body = pymunk.Body(spec.mass, spec.moment)
    # Order matters: the angle setter rotates about the centre of gravity and the position
    # setter places the body origin through the current transform.
    body.center_of_gravity = spec.center_of_gravity
    body.angle = spec.angle
    body.position = spec.position
    body.velocity = spec.velocity
    body.angular_velocity = spec.angular_velocity
    hoop = pymunk.Circle(body, spec.hoop_radius)  # no mass: the body keeps the scene's values
    hoop.friction = spec.hoop_friction
    hoop.elasticity = spec.hoop_elasticity

    floor = pymunk.Segment(space.static_body, spec.floor_a, spec.floor_b, spec.floor_radius)
    floor.friction = spec.floor_friction
    floor.elasticity = spec.floor_elasticity
    space.add(body, hoop, floor)
    return space, body, hoop
