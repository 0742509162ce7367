"""The hopping hoop as a Rapier user builds it (rapier3d, the Python binding), from Rapier's docs.

Rapier's Python binding is 3D (single precision). The hoop is one dynamic rigid body turning
about +z, kept in the x-y plane, on a fixed floor, every integration parameter at Rapier's
default except the timestep. Each construction follows a page of Rapier's user guide:

* world, gravity and timestep: ``PhysicsWorld`` and ``IntegrationParameters.dt``, whose other
  fields keep their defaults (4 solver iterations, 1 PGS and 1 stabilization sweep, the
  Simplified friction model, contact recycling): the integration-parameter reference,
  https://rapier.rs/c/3d-f32/struct_r3_integration_parameters.html (the fields the binding
  exposes by the same names);
* the body: ``RigidBody.dynamic()`` with its translation, rotation and velocities
  (``linvel`` is the centre of mass's), and ``enabled_rotations((False, False, True))`` so that
  it only turns about z, as in "Locking translations/rotations",
  https://rapier.rs/docs/user_guides/python/rigid_body_locking_translations_rotations .
  The z translation is left free: with rapier3d 0.36.1 a translation lock beside these
  rotation locks removes friction altogether (measured: a sliding ball keeps its speed), and
  nothing pushes along z;
* mass, centre of mass and inertia: the hoop is a ring with a point weight, which no collider
  shape has, so they are given explicitly on the collider (``ColliderBuilder
  .mass_properties``, "Collider mass properties"); a ball collider of radius a is the hoop's
  circle in the plane;
* the floor: a fixed half-space collider through the origin, normal +y (Rapier's shape for an
  infinite plane, ``ColliderBuilder.halfspace``); friction mu on both colliders with Rapier's
  default Average rule, which gives the pair mu ("Collider friction",
  https://rapier.rs/docs/user_guides/templates_injected/collider_friction); restitution left
  at Rapier's 0. The guide's examples put a large flat cuboid under things instead: measured
  on hop-top at dt 1e-4, that cuboid gives the same hop within 0.5 % (0.3094 m against
  0.3108) but its normal force drops to 0 on some rolling steps (the contact is re-made
  through another code path, in single precision), which moves hop-top's force-read slip
  onset to 0.035 s; docs/engines.md ("Rapier") has the numbers;
* forces: the normal impulse of each contact point (``ContactData.impulse``, summed over the
  substeps: https://docs.rs/rapier3d/latest/rapier3d/geometry/struct.ContactData.html) from
  ``narrow_phase.contact_pair``; the Simplified friction model exposes no friction impulse, so
  the friction is the step's horizontal momentum balance M (vx1 - vx0) / dt.

The hoop starts exactly touching the floor (Rapier's contacts are rigid in velocity). The
comparison: hoopbench's ``stock`` profile keeps the same Rapier defaults (its ``tuned`` profile
stiffens the static contact softness and takes the Coulomb friction model). The two builds
still differ in where the mass properties sit (the collider here, the body there, with a
massless collider) and in the friction rule (Average here, Max there): neither changes the
pair's values, and the states come out identical. Cost: about 1 s per 3 s scene at dt 1e-4.
"""

from __future__ import annotations

import math

import numpy as np
import rapier3d as rp

SAME_AS_HOOPBENCH = True
HOOPBENCH_SETTINGS: dict = {"profile": "stock", "options": {}}
DIFFERENCE = ""
RTOL = 0.0
"""Measured: identical states (the same engine, calls and values in single precision)."""


def _initial_state(scene: dict) -> tuple[float, ...]:
    """Hoop centre (x, y), theta, and the centre of mass's velocity and thetadot at t = 0."""
    a, theta, thetadot = scene["a"], scene["theta0"], scene["thetadot0"]
    r = scene["lam"] * a
    xdot = a * thetadot if scene.get("xdot0") is None else scene["xdot0"]
    Xdot = xdot + r * math.cos(theta) * thetadot
    Ydot = -r * math.sin(theta) * thetadot
    return 0.0, a, theta, Xdot, Ydot, thetadot


def _contact_impulse(world, hoop, floor) -> float:
    """Normal impulse, N s, of the step just taken, summed over the pair's contact points."""
    pair = world.narrow_phase.contact_pair(hoop, floor)
    if pair is None:
        return 0.0
    return sum(point.impulse for manifold in pair.manifolds for point in manifold.points)


def run(scene: dict, dt: float, t_end: float) -> dict[str, np.ndarray]:
    """Step the scene for t_end s; one row per step from t = 0 (module docstring)."""
    g, a, M, lam, eps, mu = (scene[k] for k in ("g", "a", "M", "lam", "eps", "mus"))
    r = lam * a
    inertia = M * a * a * (1.0 - lam * lam + lam * eps)  # about the centre of mass
    world = rp.PhysicsWorld(gravity=(0.0, -g, 0.0))
    world.integration_parameters.dt = dt

    x, y, theta, Xdot, Ydot, thetadot = _initial_state(scene)
    body = (
        rp.RigidBody.dynamic()
        .translation((x, y, 0.0))
        .rotation((0.0, 0.0, -theta))  # counter-clockwise about +z: the angle is -theta
        .linvel((Xdot, Ydot, 0.0))
        .angvel((0.0, 0.0, -thetadot))
        .enabled_rotations((False, False, True))
    )
    mass = rp.MassProperties(
        local_com=(0.0, r, 0.0), mass=M, principal_inertia=(inertia, inertia, inertia)
    )
    hoop_collider = rp.Collider.ball(a).mass_properties(mass).friction(mu)
    handle = world.add_body(body, [hoop_collider])
    floor = world.add_collider(rp.Collider.halfspace((0.0, 1.0, 0.0)).friction(mu))
    hoop_body = world.rigid_bodies[handle]
    hoop = hoop_body.colliders[0]

    n = round(t_end / dt)
    rows = np.empty((n + 1, 7))
    rows[0] = (x, y, math.sin(-theta / 2), math.cos(-theta / 2), Xdot, Ydot, -thetadot)
    impulse = np.empty(n + 1)
    for i in range(1, n + 2):
        world.step()
        impulse[i - 1] = _contact_impulse(world, hoop, floor)  # of the step from row i - 1
        if i <= n:
            p, q = hoop_body.translation, hoop_body.rotation
            v, w = hoop_body.linvel, hoop_body.angvel
            rows[i] = (p.x, p.y, q.k, q.w, v.x, v.y, w.z)
    vx_after = hoop_body.linvel.x

    theta = -np.unwrap(2.0 * np.arctan2(rows[:, 2], rows[:, 3]))
    friction_impulse = M * np.diff(np.append(rows[:, 4], vx_after))
    return {
        "t": np.arange(n + 1) * dt,
        "X": rows[:, 0] + r * np.sin(theta),
        "Y": rows[:, 1] + r * np.cos(theta),
        "theta": theta,
        "Xdot": rows[:, 4],
        "Ydot": rows[:, 5],
        "thetadot": -rows[:, 6],
        "normal_force": impulse / (M * dt),
        "friction_force": friction_impulse / (M * dt),
    }


def _hop_top() -> dict:
    """hop-top's parameters (hoopbench's catalogue): chi 0.5, mu 0.8, lam 0.95."""
    g, a = 9.8, 1.0
    return {
        "g": g, "a": a, "M": 1.0, "lam": 0.95, "eps": 0.01, "mus": 0.8, "muk": 0.8,
        "theta0": 0.0, "thetadot0": math.sqrt(0.5 * g / a), "xdot0": None, "t_end": 3.0,
    }  # fmt: skip


if __name__ == "__main__":
    scene = _hop_top()
    out = run(scene, 1e-4, scene["t_end"])
    clearance = out["Y"] - scene["lam"] * scene["a"] * np.cos(out["theta"]) - scene["a"]
    lifted = np.flatnonzero(clearance > 1e-4)
    t_lift = out["t"][lifted[0]] if len(lifted) else float("nan")
    print(f"hop height {clearance.max():.4f} m (exact 0.3800), lift-off near t = {t_lift:.4f} s")
