"""The hoop scene translated into Box2D v3 terms: one dynamic body, one circle, one floor box.

Box2D's conventions differ from hoopbench's as pymunk's do, and are handled the same way:

* angles are counter-clockwise, so the body rotation is ``-theta``; the centre of mass sits
  at (0, lam*a) in body coordinates, straight above the hoop centre at theta = 0;
* the body's position is its origin (our hoop centre), its linear velocity that of the
  centre of mass (our centre of mass).

Mass, centre of mass and rotational inertia come from the scene (``b2Body_SetMassData``,
whose rotational inertia is the one about the centre of mass: Box2D's own mass update
centres a shape's inertia before it stores it); the circle carries no density, so no shape
adds a disc's inertia. The pair's friction is ``b2DefaultFrictionCallback``'s
``sqrtf(frictionA * frictionB)``: both shapes carry mu, and the square root of mu squared is
mu exactly (a correctly rounded square root of a correctly rounded square). Box2D stores it
in single precision, like everything else: float32(mu), within 6e-8 relative of mu.

The floor is a static box whose top face is y = 0 in its body's frame: Box2D's circle-polygon
manifold measures the separation from a face's own vertices, so the top face at y = 0 gives
the hoop's clearance without the round-off of a far-away segment end (a segment's closest
point is interpolated from its ends, about 1e-6 m off at 15 m in single precision).

:func:`build_world` imports pyb2d3 lazily: this module only describes the model.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass
from typing import Any

from hoopbench.models import kinematics
from hoopbench.models.checks import check_real
from hoopbench.models.scene import Scene

__all__ = ["Box2DSpec", "build_world", "check_restitution", "scene_to_box2d"]

_FLOOR_MARGIN = 10.0
"""Floor beyond the farthest reachable hoop centre, in hoop radii."""


def check_restitution(restitution: float) -> None:
    """ValueError unless restitution is 0 (why: in the message)."""
    value = check_real("restitution", restitution, low=0.0, high=1.0)
    if value != 0.0:
        raise ValueError(
            f"restitution must be 0 for Box2D, got {restitution}: Box2D applies restitution "
            "only to impacts faster than its restitutionThreshold (1 m/s by default) and after "
            "the solve, a rule of its own that no other engine here shares"
        )


@dataclass(frozen=True)
class Box2DSpec:
    """Plain numbers that define the Box2D model of a scene (Box2D conventions, SI units)."""

    mass: float
    """Body mass, kg."""
    rotational_inertia: float
    """Rotational inertia about the centre of mass, kg m^2."""
    center: tuple[float, float]
    """Centre of mass in body coordinates (origin = hoop centre), m."""
    hoop_radius: float
    """Radius of the hoop's circle shape, m."""
    floor_half_width: float
    """Half the floor box's width, m."""
    floor_half_height: float
    """Half the floor box's height, m; the box lies below y = 0."""
    hoop_friction: float
    """Friction of the hoop shape, dimensionless (the pair's is sqrt(hoop * floor))."""
    floor_friction: float
    """Friction of the floor shape, dimensionless."""
    gravity: tuple[float, float]
    """World gravity, m/s^2."""
    position: tuple[float, float]
    """Initial body origin (hoop centre), m."""
    angle: float
    """Initial body angle, rad, counter-clockwise (= -theta0)."""
    linear_velocity: tuple[float, float]
    """Initial velocity of the centre of mass, m/s."""
    angular_velocity: float
    """Initial angular velocity, rad/s, counter-clockwise (= -thetadot0)."""

    @property
    def friction(self) -> float:
        """The pair's friction coefficient as Box2D combines it (geometric mean)."""
        return math.sqrt(self.hoop_friction * self.floor_friction)

    def to_dict(self) -> dict[str, Any]:
        """Plain fields (tuples as lists) plus the combined friction."""
        out = {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(self).items()}
        out["friction"] = self.friction
        return out

    def to_json(self, **kwargs: Any) -> str:
        """The spec as JSON text (``json.dumps`` keyword arguments pass through)."""
        return json.dumps(self.to_dict(), **kwargs)


def scene_to_box2d(scene: Scene, *, mu: float, depth: float = 0.0) -> Box2DSpec:
    """The Box2D model of ``scene`` with pair friction ``mu``, its hoop ``depth`` m into the
    floor at the start (0: exactly touching).

    Raises DegenerateSceneError for I = 0 (Box2D would take the body as unable to rotate) and
    ValueError for a negative or non-finite mu or depth.
    """
    scene.require_inertia("a Box2D body")
    mu = check_real("mu", mu, low=0.0)
    depth = check_real("depth", depth, low=0.0, unit="m")
    a = scene.a
    X, Y, theta, Xdot, Ydot, thetadot = scene.initial_state()
    x, y = kinematics.centre_position(scene, X, Y, theta)
    return Box2DSpec(
        mass=scene.M,
        rotational_inertia=scene.inertia_com,
        center=(0.0, scene.com_offset),
        hoop_radius=a,
        floor_half_width=_FLOOR_MARGIN * a + kinematics.reach(scene),
        floor_half_height=a,
        hoop_friction=mu,
        floor_friction=mu,
        gravity=(0.0, -scene.g),
        position=(float(x), float(y) - depth),
        angle=-theta,
        linear_velocity=(Xdot, Ydot),
        angular_velocity=-thetadot,
    )


@dataclass(frozen=True)
class WorldTuning:
    """The world-wide settings a run gives Box2D (the engine's options, already checked)."""

    contact_hertz: float
    """contactHertz, Hz: stiffness of the soft contact (a static pair gets twice it)."""
    contact_damping_ratio: float
    """contactDampingRatio, dimensionless."""
    max_contact_push_speed: float
    """maxContactPushSpeed, m/s: the fastest an overlap is pushed out."""
    enable_sleep: bool
    """enableSleep: whether a slow body may be put to sleep."""


def build_world(spec: Box2DSpec, tuning: WorldTuning) -> tuple[Any, Any]:
    """A pyb2d3 World holding the spec's hoop and floor: (world, hoop body)."""
    import pyb2d3

    world = pyb2d3.World(
        gravity=spec.gravity,
        contact_hertz=tuning.contact_hertz,
        contact_damping_ratio=tuning.contact_damping_ratio,
    )
    world.set_contact_tuning(
        tuning.contact_hertz, tuning.contact_damping_ratio, tuning.max_contact_push_speed
    )
    world.sleeping_enabled = tuning.enable_sleep
    floor = world.create_static_body(position=(0.0, 0.0))
    half_h = spec.floor_half_height
    floor.create_polygon_shape(
        pyb2d3.shape_def(material=pyb2d3.surface_material(friction=spec.floor_friction)),
        pyb2d3.box(spec.floor_half_width, half_h, center=(0.0, -half_h), rotation=0.0),
    )
    body = world.create_dynamic_body(position=spec.position, rotation=spec.angle)
    body.create_circle_shape(
        pyb2d3.shape_def(
            density=0.0, material=pyb2d3.surface_material(friction=spec.hoop_friction)
        ),
        pyb2d3.circle(radius=spec.hoop_radius),
    )
    # After the shape: a shape's creation recomputes the body's mass from the shapes.
    mass = pyb2d3.MassData()
    mass.mass = spec.mass
    mass.center = spec.center
    mass.rotational_inertia = spec.rotational_inertia
    body.mass_data = mass
    body.linear_velocity = spec.linear_velocity
    body.angular_velocity = spec.angular_velocity
    return world, body
