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


def world(scene: Scene, mu: float | None = None, **options):
    """(world, body, hoop collider, floor collider) as a run builds them."""
    engine = RapierEngine()
    settings = RunSettings(timestep=TIMESTEP, mu=mu, options=options)
    return engine._world(rp, scene, settings, engine.check(scene, settings))


def friction_axis() -> tuple[float, float]:
    """World +x in the tangent basis of a ball-on-floor contact (Rapier builds the basis from
    the normal alone): a probe ball slides along +x for one step under the Coulomb model, and
    the friction on it points along -x."""
    w = rp.PhysicsWorld(gravity=(0.0, -10.0, 0.0))
    w.integration_parameters.dt = 1e-3
    w.integration_parameters.friction_model = rp.FrictionModel.COULOMB
    builder = rp.RigidBody.dynamic().translation((0.0, 1.0, 0.0)).linvel((1.0, 0.0, 0.0))
    body = w.add_body(builder, [rp.Collider.ball(1.0).friction(0.5)])
    floor = w.add_collider(rp.Collider.halfspace((0.0, 1.0, 0.0)).friction(0.5))
    w.step()
    pair = w.narrow_phase.contact_pair(w.rigid_bodies[body].colliders[0], floor)
    t1, t2 = pair.manifolds[0].points[0].tangent_impulse
    return -t1 / np.hypot(t1, t2), -t2 / np.hypot(t1, t2)


def solver_forces(scene: Scene, steps: int, mu: float | None = None, **options):
    """The solver's own record of each step's contact, as a run's rows would hold it (row i:
    the step from state i), per unit mass, m/s^2: the contact points' normal impulses summed
    over the substeps (``ContactData.impulse``), their friction impulses along +x (Coulomb
    model only: ``tangent_impulse``; NaN under Simplified, which exposes none), and whether
    the pair had any contact point, each over ``steps`` steps."""
    w, _, hoop, floor = world(scene, mu, **options)
    coulomb = w.integration_parameters.friction_model == rp.FrictionModel.COULOMB
    axis = friction_axis() if coulomb else (np.nan, np.nan)
    normal, friction, touching = np.zeros(steps), np.zeros(steps), np.zeros(steps, bool)
    for i in range(steps):
        w.step()
        pair = w.narrow_phase.contact_pair(hoop, floor)
        for point in (p for m in (pair.manifolds if pair else ()) for p in m.points):
            touching[i] = True
            t1, t2 = point.tangent_impulse
            normal[i] += point.impulse
            friction[i] += axis[0] * t1 + axis[1] * t2
    scale = scene.M * TIMESTEP
    return normal / scale, friction / scale, touching


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
    # the solver's impulses: the run's momentum-balance forces carry f32 velocity round-off
    normal, friction, _ = solver_forces(get_scene("seed-mu"), len(traj), mu)
    events = solve_exact(get_scene("seed-mu").with_(mus=mu, muk=mu)).events
    slip = next(p for p in events.phases if p.kind.name == "SLIP")
    window = (traj.t > slip.t_start + 0.03) & (traj.t < slip.t_end - 0.03)
    window &= normal > 0.2 * 9.8
    assert window.sum() > 100
    ratio = np.abs(friction[window]) / normal[window]
    # Measured: the median equals mu to 1e-7 (f32), every sample within 1e-5 relative.
    assert np.median(ratio) == pytest.approx(mu, rel=1e-6)
    assert ratio == pytest.approx(mu, rel=1e-4)


@pytest.mark.parametrize("friction_model", ["coulomb", "simplified"])
@pytest.mark.parametrize("scene_name", ["seed-mu", "hop-top"])
def test_forces_are_the_solvers_impulses(scene_name, friction_model):
    """The run's forces (each step's momentum balance, free flight replayed in float32) are
    the solver's own impulses of the same step, to the f32 round-off of the velocities (an ulp
    of 3 m/s over dt is 2.4e-3 g), friction too where Coulomb exposes it; and exactly 0 in
    every step in which the pair had no contact point (a float64 free flight would leave
    6e-4 g there)."""
    scene = get_scene(scene_name)
    settings = RunSettings(timestep=TIMESTEP, options={"friction_model": friction_model})
    traj = get_engine("rapier").run(scene, settings).trajectory
    normal, friction, touching = solver_forces(scene, len(traj), friction_model=friction_model)
    noise = 2.5e-3  # g; measured up to 2.1e-3 (every catalogue scene, both profiles, dt 1e-4)
    assert np.max(np.abs(traj.normal_force - normal)) / scene.g < noise
    if friction_model == "coulomb":
        assert np.max(np.abs(traj.friction_force - friction)) / scene.g < noise
    if scene_name == "hop-top":
        assert (~touching).any()  # its flight
    assert np.all(traj.normal_force[~touching] == 0.0)
    assert np.all(traj.friction_force[~touching] == 0.0)
