"""The hopping hoop in DART (dartpy 6.20), built as DART's own tutorials build a rigid body.

Written from DART's documentation and Python examples, not from hoopbench's adapter:

- the skeleton and its body: the collisions tutorial, ``python/tutorials/02_collisions``
  (https://github.com/dartsim/dart/tree/main/python/tutorials/02_collisions, lesson 1:
  ``Skeleton.createFreeJointAndBodyNodePair``, a ``ShapeNode`` with collision and dynamics
  aspects, ``dart.dynamics.Inertia`` set with ``BodyNode.setInertia``, restitution through
  ``DynamicsAspect.setRestitutionCoeff``); the ground as the dominoes tutorial's
  ``create_floor`` (``python/tutorials/03_dominoes``: a ``BoxShape`` on a ``WeldJoint``, its
  top face at z = 0), here also ``Skeleton.setMobile(False)``;
- the initial motion: ``FreeJoint.setTransform``, ``setLinearVelocity`` and
  ``setAngularVelocity`` (dartpy 6.20's ``dynamics.FreeJoint`` binding and its docstrings);
- the world and its contact solver: ``dart.simulation.World``, ``World.setTimeStep``,
  ``World.step`` and ``World.getLastCollisionResult`` (each ``Contact.force`` is the contact
  impulse over the step, world frame); the friction-cone solver
  ``dart.constraint.NsgsFrictionSolver`` set with ``BoxedLcpConstraintSolver.setBoxedLcpSolver``
  after ``setSecondaryBoxedLcpSolver(None)`` (dartpy 6.20's constraint bindings), as in
  hoopbench's tuned profile: DART's default Dantzig solver lets a rolling hoop slip at 32 deg
  (``run(..., solver="dantzig")`` measures it).

The hoop's circle is a sphere of radius a (the plane's section of it is the circle), its body
a free joint, the weight's mass in the body's inertia (centre of mass lam a from the centre,
moment M a^2 (1 - lam^2 + lam eps) about it). State read from the body: ``getCOM``,
``getCOMLinearVelocity``, the rotation about +y and ``getAngularVelocity``. x right, z up;
theta is the rotation about +y, which turns the top toward +x: clockwise seen from -y, as the
scene's theta. Cost: hop-top's 3 s at dt 1e-4, 0.9 s of CPU (1.4-2 s on the shared machine).

Run as a script, it prints hop-top's hop height and lift-off time.
"""

from __future__ import annotations

import math

import dartpy as dart
import numpy as np

SAME_AS_HOOPBENCH = True
HOOPBENCH_SETTINGS: dict = {"profile": "tuned", "options": {"collision_detector": "fcl"}}
DIFFERENCE = ""
RTOL = 1e-5
"""Largest difference allowed from hoopbench's run (a PlanarJoint read from a URDF, started
1e-9 a deep, NSGS), over each state relative to its scale (tests/test_expert_builds.py).
Measured at dt 1e-4: 4.9e-6 on hop-top, 6.2e-7 on seed-mu (the free joint's rounding: this
module with ``joint_type="planar"`` gives 1.8e-8 and 2.1e-8, and started 1e-9 a deep as the
adapter 1.4e-15 and 2.5e-15)."""

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
"""hop-top: chi = a thetadot0^2 / g = 0.5, rolling start."""


def _hoop(scene: dict, shape: str, joint_type: str) -> tuple:
    """The hoop skeleton: one free body, its shape node and inertia (tutorial lesson 1); or,
    for ``joint_type`` "planar", the body on a PlanarJoint in the z-x plane."""
    a, mass, lam, eps = scene["a"], scene["M"], scene["lam"], scene["eps"]
    hoop = dart.dynamics.Skeleton("hoop")
    if joint_type == "planar":
        joint, body = hoop.createPlanarJointAndBodyNodePair()
        joint.setZXPlane()  # positions: z, x, the rotation about +y
    else:
        joint, body = hoop.createFreeJointAndBodyNodePair()
    if shape == "sphere":
        geometry = dart.dynamics.SphereShape(a)
    else:  # a thin disc, its axis along y (the cylinder's axis is its local z)
        geometry = dart.dynamics.CylinderShape(a, 0.01 * a)
    node = body.createShapeNode(geometry)
    if shape == "cylinder":
        node.setRelativeRotation(dart.math.eulerXYZToMatrix([math.pi / 2, 0.0, 0.0]))
    node.createCollisionAspect()
    node.createDynamicsAspect()
    node.getDynamicsAspect().setFrictionCoeff(scene["mus"])
    node.getDynamicsAspect().setRestitutionCoeff(0.0)  # the rigid model's plastic impact
    moment = mass * a**2 * (1.0 - lam**2 + lam * eps)
    body.setInertia(dart.dynamics.Inertia(mass, [0.0, 0.0, lam * a], moment * np.eye(3)))
    return hoop, joint, body


def _ground(mu: float) -> object:
    """A static box whose top face is z = 0 (the dominoes tutorial's create_floor)."""
    ground = dart.dynamics.Skeleton("ground")
    _, body = ground.createWeldJointAndBodyNodePair()
    node = body.createShapeNode(dart.dynamics.BoxShape([100.0, 100.0, 1.0]))
    node.setRelativeTranslation([0.0, 0.0, -0.5])
    node.createCollisionAspect()
    node.createDynamicsAspect()
    node.getDynamicsAspect().setFrictionCoeff(mu)  # DART takes the smaller of the pair
    ground.setMobile(False)
    return ground


def _start(scene: dict, joint: object, joint_type: str) -> None:
    """Centre at height a above the contact, the weight at theta0, rolling (or xdot0)."""
    a, theta0, thetadot0 = scene["a"], scene["theta0"], scene["thetadot0"]
    xdot = a * thetadot0 if scene.get("xdot0") is None else scene["xdot0"]
    if joint_type == "planar":
        joint.setPositions([a, 0.0, theta0])
        joint.setVelocities([0.0, xdot, thetadot0])
        return
    pose = np.eye(4)
    pose[:3, :3] = dart.math.eulerXYZToMatrix([0.0, theta0, 0.0])
    pose[:3, 3] = [0.0, 0.0, a]
    transform = dart.math.Isometry3()
    transform.set_matrix(pose)
    joint.setTransform(transform)
    joint.setLinearVelocity([xdot, 0.0, 0.0])  # of the body origin, the hoop centre
    joint.setAngularVelocity([0.0, thetadot0, 0.0])


def _up_force(result: object) -> float:
    """Normal force on the hoop, N: each contact's force acts on the object its normal
    points into; on the flat ground the hoop's is the one pointing up."""
    return sum(abs(contact.force[2]) for contact in result.getContacts())


def _friction(result: object) -> float:
    """Friction on the hoop along x, N (the sign of the upward force's x part)."""
    total = 0.0
    for contact in result.getContacts():
        fx, _, fz = contact.force
        total += fx if fz > 0.0 else -fx
    return total


def run(
    scene: dict,
    dt: float,
    t_end: float,
    *,
    joint_type: str = "free",
    shape: str = "sphere",
    solver: str = "nsgs",
) -> dict[str, np.ndarray]:
    """Step the scene; rows every dt from 0: centre-of-mass state, theta clockwise from the
    top, and the contact force per unit mass of the step taken from each row's state. The
    keywords choose the alternatives measured beside the build: a PlanarJoint, a thin disc
    (``shape="cylinder"``), DART's default solver (``solver="dantzig"``)."""
    hoop, joint, body = _hoop(scene, shape, joint_type)
    _start(scene, joint, joint_type)
    world = dart.simulation.World()
    world.setGravity([0.0, 0.0, -scene["g"]])
    world.setTimeStep(dt)
    world.addSkeleton(_ground(scene["mus"]))
    world.addSkeleton(hoop)
    contact_solver = world.getConstraintSolver()
    if solver == "nsgs":
        contact_solver.setSecondaryBoxedLcpSolver(None)
        contact_solver.setBoxedLcpSolver(dart.constraint.NsgsFrictionSolver())
    n = round(t_end / dt)
    rows = np.empty((n + 1, 8))
    for i in range(n + 1):
        com, velocity = body.getCOM(), body.getCOMLinearVelocity()
        rotation = body.getWorldTransform().rotation()
        theta = math.atan2(rotation[0, 2], rotation[2, 2])
        thetadot = body.getAngularVelocity()[1]
        world.step()  # then the contact force of the step taken from this state
        result = world.getLastCollisionResult()
        rows[i] = (
            com[0],
            com[2],
            theta,
            velocity[0],
            velocity[2],
            thetadot,
            _up_force(result) / scene["M"],
            _friction(result) / scene["M"],
        )
    X, Y, theta, Xdot, Ydot, thetadot, normal, friction = rows.T
    return {
        "t": np.arange(n + 1) * dt,
        "X": X,
        "Y": Y,
        "theta": np.unwrap(theta),
        "Xdot": Xdot,
        "Ydot": Ydot,
        "thetadot": thetadot,
        "normal_force": normal,
        "friction_force": friction,
    }


def _hop(out: dict[str, np.ndarray], scene: dict) -> tuple[float, float]:
    """(hop height of the lowest point, m; lift-off time, s) read from the contact force."""
    lowest = out["Y"] - scene["lam"] * scene["a"] * np.cos(out["theta"]) - scene["a"]
    off = np.flatnonzero((out["normal_force"] == 0.0) & (out["t"] > 0.1))
    return float(np.max(lowest)), float(out["t"][off[0]]) if len(off) else math.nan


if __name__ == "__main__":
    result = run(HOP_TOP, 1e-4, HOP_TOP["t_end"])
    height, lift = _hop(result, HOP_TOP)
    print(f"hop-top, DART NSGS, dt 1e-4: hop height {height:.4f} m, lift-off {lift:.4f} s")
