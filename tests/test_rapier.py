"""Rapier (rapier3d): the hoop as the adapter builds it, read back from the engine.

The adapter's model is checked against the engine's own state: mass properties, the locked
axes, the pair's friction during a slip, and the recorded forces against each step's momentum
(engines/rapier_engine.py explains the model). rapier3d is an optional extra: without it
these tests skip, except under CI (tests/conftest.py).
"""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest

from hoopbench.engines.rapier_engine import RapierEngine
from hoopbench.engines.registry import get_engine
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.models.scene import Scene
from hoopbench.reference.exact import solve_exact

rp = pytest.importorskip("rapier3d")

TIMESTEP = 1e-4
F32 = 2e-7
"""Relative round-off of a 32-bit float, with a little room."""


def world(scene: Scene, **options):
    """(world, body, hoop collider, floor collider) as a run builds them."""
    engine = RapierEngine()
    settings = RunSettings(timestep=TIMESTEP, options=options)
    return engine._world(rp, scene, settings, engine.check(scene, settings))


@cache
def trajectory(scene_name: str, mu: float | None = None):
    result = get_engine("rapier").run(get_scene(scene_name), RunSettings(timestep=TIMESTEP, mu=mu))
    assert result.ok, result.info.message
    return result.trajectory


def test_mass_properties_are_the_scenes():
    """Mass, centre of mass and inertia are the scene's, not the ball collider's."""
    scene = get_scene("hop-top").with_(M=2.5, a=0.7)
    w, body, hoop, _ = world(scene)
    w.step()  # Rapier computes a body's mass properties from its parts in a step
    b = w.rigid_bodies[body]
    assert w.colliders[hoop].mass == 0.0
    assert b.mass == pytest.approx(scene.M, rel=F32)
    com = b.local_center_of_mass
    assert (com.x, com.y, com.z) == pytest.approx((0.0, scene.com_offset, 0.0), rel=F32)
    inertia = b.mass_properties.principal_inertia
    assert inertia.z == pytest.approx(scene.inertia_com, rel=F32)


def test_locked_axes_stay_locked():
    """Through hop-top's slips, flight and impact the body stays in its plane: no rotation
    about x or y, and z (not locked, see the module doc of the adapter) below 1e-9 m."""
    scene = get_scene("hop-top")
    w, body, _, _ = world(scene)
    b = w.rigid_bodies[body]
    largest = 0.0
    for _ in range(int(scene.t_end / TIMESTEP)):
        w.step()
        q, omega = b.rotation, b.angvel
        assert (q.i, q.j, omega.x, omega.y) == (0.0, 0.0, 0.0, 0.0)
        largest = max(largest, abs(b.translation.z), abs(b.linvel.z))
    assert largest < 1e-6


def test_locking_z_with_x_rotation_stops_friction():
    """Why z is not locked (rapier3d 0.36.1): with a translation lock and a lock of the
    rotation about the direction of motion, a ball sliding on the floor keeps its speed and
    never spins. Measured for every such pair of locks and every plane. When this fails, the
    engine has been fixed and the adapter may lock z too."""
    locks = rp.LockedAxes
    speeds = {}
    for name, lock in (
        ("plane", locks.ROTATION_LOCKED_X | locks.ROTATION_LOCKED_Y),
        ("with z", locks.TRANSLATION_LOCKED_Z | locks.ROTATION_LOCKED_X | locks.ROTATION_LOCKED_Y),
    ):
        w = rp.PhysicsWorld(gravity=(0.0, -9.8, 0.0))
        w.integration_parameters.dt = 1e-3
        builder = rp.RigidBody.dynamic().translation((0.0, 1.0, 0.0)).linvel((2.0, 0.0, 0.0))
        body = w.add_body(builder.locked_axes(lock), [rp.Collider.ball(1.0).friction(0.5)])
        w.add_collider(rp.Collider.halfspace((0.0, 1.0, 0.0)).friction(0.5))
        for _ in range(100):
            w.step()
        speeds[name] = w.rigid_bodies[body].linvel.x
    assert speeds["plane"] < 1.9  # friction slowed it
    assert speeds["with z"] == 2.0


@pytest.mark.parametrize("mu", [0.3, 0.8, 1.7])
def test_friction_is_mu_while_slipping(mu):
    """|f|/n during the exact first slip of seed-mu (30 ms in from either end) is the run's
    mu: the Max rule with mu on both colliders gives the pair mu (Rapier's default Average
    would too; a floor left at Rapier's 0.5 would not)."""
    traj = trajectory("seed-mu", mu)
    events = solve_exact(get_scene("seed-mu").with_(mus=mu, muk=mu)).events
    slip = next(p for p in events.phases if p.kind.name == "SLIP")
    window = (traj.t > slip.t_start + 0.03) & (traj.t < slip.t_end - 0.03)
    window &= traj.normal_force > 0.2 * 9.8
    assert window.sum() > 100
    ratio = np.abs(traj.friction_force[window]) / traj.normal_force[window]
    # Measured: the median equals mu to 1e-7 (f32), every sample within 1e-5 relative.
    assert np.median(ratio) == pytest.approx(mu, rel=1e-6)
    assert ratio == pytest.approx(mu, rel=1e-4)


@pytest.mark.parametrize("friction_model", ["coulomb", "simplified"])
def test_forces_are_each_steps_momentum_change(friction_model):
    """Row i's forces are the impulses of the step from state i: M (v_(i+1) - v_i) / dt less
    gravity, to the round-off of the f32 velocities (an ulp of 3 m/s over dt is 2.4e-3 g).
    Coulomb reads the friction from the contact point's tangent impulse (the probed axis),
    Simplified from this very balance: there only the normal force is a check."""
    scene = get_scene("seed-mu").with_(t_end=1.2)
    settings = RunSettings(timestep=TIMESTEP, options={"friction_model": friction_model})
    result = get_engine("rapier").run(scene, settings)
    traj = result.trajectory
    noise = 3e-3  # g; measured 1.4e-3 (n, coulomb), a few ulps of the f32 velocities
    n = np.diff(traj.Ydot) / TIMESTEP + scene.g
    f = np.diff(traj.Xdot) / TIMESTEP
    assert np.max(np.abs(traj.normal_force[:-1] - n)) / scene.g < noise
    assert np.max(np.abs(traj.friction_force[:-1] - f)) / scene.g < noise
