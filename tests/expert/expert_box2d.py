"""The hopping hoop as a Box2D v3 user builds it through pyb2d3, from the documentation.

A rigid hoop of radius a (mass (1 - lam) M on its rim) carries a weight of mass lam M on
its rim; it rolls on a flat floor. Each construction follows Box2D 3.1's manual
(https://box2d.org/documentation/) as pyb2d3 0.11 spells it (pyb2d3's "Differences to Box2D
C": https://derthorsten.github.io/pyb2d3/src/differences.html; a ``b2XxxDef`` is the
keyword arguments of the factory, e.g. ``world.create_dynamic_body(position=...)``):

* The world: "Hello Box2D" (https://box2d.org/documentation/hello.html) and "Simulation",
  World Definition (the manual's docs/simulation.md,
  https://github.com/erincatto/box2d/blob/main/docs/simulation.md): gravity set, the
  other members of ``b2DefaultWorldDef()`` kept (contact hertz 30, damping ratio 10, push
  speed 3 m/s, sleep on), stepped at a fixed time step with "the recommended sub-step count
  [of] 4".
* The floor: Hello Box2D's ground box, a static body with a box (``pyb2d3.box``, C's
  ``b2MakeOffsetBox``) whose top face is y = 0. The ground body sits at the origin; Hello
  Box2D's places the body 10 m down and the box on it. That is the same floor, but in single
  precision it puts rounding of about 1e-6 m into the contact separation. Measured at dt 1e-4,
  stock settings: the run then leaves hoopbench's at step 3. Lift-off moves by
  0.1 ms and the hop by 0.1 %, but hop-top's slip onset read from the slip velocity moves from
  -97 to -32 ms, because that reading is noise-sensitive in Box2D (docs/engines.md, Box2D).
* The hoop: one dynamic body created with its position (the hoop centre), angle and angular
  velocity in its body definition, a circle shape of radius a with the default density, and
  the mass, centre of mass and rotational inertia set afterwards with ``b2Body_SetMassData``
  ("Mass Data": "you can override the mass properties after a body is constructed"; a
  circle's own inertia is a solid disc's, not a hoop's). The rotational inertia is about the
  centre of mass, as ``b2MassData`` defines it. "The body stores the linear velocity for the
  center of mass" (Position and Angle), and SetMassData does not change it: the linear
  velocity is set last, the centre's plus omega x (centre of mass - origin).
* Friction: "Shapes", Friction: the mixed friction is ``sqrtf(frictionA * frictionB)``, so
  both shapes carry mu. Restitution 0 (the default).
* The contact force: pyb2d3 binds no per-step contact data of a running world, so it is the
  step's momentum balance, (v1 - v0)/dt - g. ``b2World_Step`` collides before it solves
  (``b2Collide``, then ``b2Solve``, in Box2D's src/world.c), so the contact of a step is that
  of the state it starts from: the impulse of the step from row i is row i's.

Box2D's angles are counter-clockwise: theta (clockwise from the top) is -angle, unwrapped
(Box2D keeps a rotation, in (-pi, pi]).

Cost: about 0.4 s per 3 s scene at dt 1e-4 (30,000 steps of 4 substeps).
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pyb2d3

SUBSTEPS = 4
"""b2World_Step's subStepCount: the manual's recommended 4."""

CONTACT_HERTZ = 30.0
"""b2WorldDef.contactHertz, Hz: the default (a static pair gets twice it)."""

CONTACT_DAMPING_RATIO = 10.0
"""b2WorldDef.contactDampingRatio: the default."""

CONTACT_PUSH_SPEED = 3.0
"""b2WorldDef.maxContactPushSpeed (contactPushMaxVelocity), m/s: the default."""

ENABLE_SLEEP = True
"""b2WorldDef.enableSleep: the default (the hoop is never slow for the 0.5 s sleep needs)."""

SAME_AS_HOOPBENCH = True
HOOPBENCH_SETTINGS: dict = {"profile": "stock"}
"""hoopbench's stock profile is Box2D's defaults: the options above."""
RTOL = 0.0
"""Identical: the same calls with the same numbers (measured bit for bit, both scenes)."""
DIFFERENCE = ""


def run(scene: dict, dt: float, t_end: float) -> dict[str, np.ndarray]:
    """Step the scene (keys of hoopbench's Scene.to_dict, SI; mu = mus) for t_end s at dt."""
    g, a, M, lam, eps = scene["g"], scene["a"], scene["M"], scene["lam"], scene["eps"]
    theta0, thetadot0, mu = scene["theta0"], scene["thetadot0"], scene["mus"]
    xdot0 = a * thetadot0 if scene["xdot0"] is None else scene["xdot0"]  # hoop centre

    world = pyb2d3.World(
        gravity=(0.0, -g),
        contact_hertz=CONTACT_HERTZ,
        contact_damping_ratio=CONTACT_DAMPING_RATIO,
    )
    world.set_contact_tuning(CONTACT_HERTZ, CONTACT_DAMPING_RATIO, CONTACT_PUSH_SPEED)
    world.sleeping_enabled = ENABLE_SLEEP

    # the ground body at the origin, its box (b2MakeOffsetBox) 100 m wide, 20 m deep, top y = 0
    ground = world.create_static_body(position=(0.0, 0.0))
    material = pyb2d3.surface_material(friction=mu)
    floor = pyb2d3.box(50.0, 10.0, center=(0.0, -10.0), rotation=0.0)
    ground.create_polygon_shape(pyb2d3.shape_def(material=material), floor)

    body = world.create_dynamic_body(
        position=(0.0, a),  # the hoop centre, its lowest point on the floor
        rotation=-theta0,
        angular_velocity=-thetadot0,
    )
    body.create_circle_shape(pyb2d3.shape_def(material=material), pyb2d3.circle(radius=a))
    # the ring (1 - lam) M a^2 and the weight lam M a^2 (1 + eps) about the hoop centre,
    # then about the centre of mass lam a from it (parallel axes)
    inertia_centre = (1.0 - lam) * M * a**2 + lam * M * a**2 * (1.0 + eps)
    mass_data = pyb2d3.MassData()
    mass_data.mass = M
    mass_data.center = (0.0, lam * a)  # the weight straight above at angle 0
    mass_data.rotational_inertia = inertia_centre - M * (lam * a) ** 2
    body.mass_data = mass_data
    # Box2D keeps the body's linear velocity, now the centre of mass's: give it the centre's
    # plus omega x r, r = lam a (sin theta0, cos theta0) from the centre (in double precision)
    omega, r = -thetadot0, lam * a
    body.linear_velocity = (xdot0 - omega * r * math.cos(theta0), omega * r * math.sin(theta0))

    n = round(t_end / dt)
    rows = np.empty((n + 2, 6))
    rows[0] = _read(body)
    for i in range(1, n + 2):  # one step more: its impulse is the last row's force
        world.step(dt, SUBSTEPS)
        rows[i] = _read(body)
    gravity_y = float(world.gravity[1])
    force_x = np.diff(rows[:, 3]) / dt
    force_y = np.diff(rows[:, 4]) / dt - gravity_y
    return _com_state(rows[:-1], lam * a, dt, force_x, force_y)


def _read(body: pyb2d3.Body) -> tuple[float, ...]:
    p, v = body.position, body.linear_velocity
    return (p.x, p.y, body.angle, v.x, v.y, body.angular_velocity)


def _com_state(
    rows: np.ndarray, com_offset: float, dt: float, fx: np.ndarray, fy: np.ndarray
) -> dict[str, np.ndarray]:
    x, y, angle, vx, vy, omega = rows.T
    theta = -np.unwrap(angle)
    return {
        "t": np.arange(len(rows)) * dt,
        "X": x + com_offset * np.sin(theta),
        "Y": y + com_offset * np.cos(theta),
        "theta": theta,
        "Xdot": vx,
        "Ydot": vy,
        "thetadot": -omega,
        "normal_force": fy,
        "friction_force": fx,
    }


HOP_TOP = {
    "g": 9.8,
    "a": 1.0,
    "M": 1.0,
    "lam": 0.95,
    "eps": 0.01,
    "mus": 0.8,
    "muk": 0.8,
    "theta0": 0.0,
    "thetadot0": 2.2135943621178655,
    "xdot0": None,
    "t_end": 3.0,
}
"""hoopbench's hop-top scene (the exact solution hops 0.380 m, lifting off at 1.171 s)."""


def hop(out: dict[str, np.ndarray], scene: dict) -> tuple[float | None, float]:
    """(lift-off time, s, or None; hop height, m): the first time the hoop's lowest point is
    1e-4 a above the floor, and the highest it gets."""
    a = scene["a"]
    lowest = out["Y"] - scene["lam"] * a * np.cos(out["theta"]) - a
    above = np.flatnonzero(lowest > 1e-4 * a)
    return (float(out["t"][above[0]]) if len(above) else None, float(np.max(lowest)))


if __name__ == "__main__":
    result = run(HOP_TOP, 1e-4, HOP_TOP["t_end"])
    t_lift, height = hop(result, HOP_TOP)
    print(f"Box2D (pyb2d3): lift-off {t_lift} s, hop height {height:.4f} m")
    sys.exit(0)
