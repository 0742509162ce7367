"""Box2D v3 (pyb2d3) adapter: what is particular to it.

Measured on pyb2d3 0.11.1 (Box2D v3.1.1), dt 1e-4, tuned profile unless said.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import engine_unavailable

from hoopbench.engines.box2d_engine import Box2DEngine, free_flight_residual
from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

pyb2d3 = pytest.importorskip("pyb2d3")

TIMESTEP = 1e-4
FLOAT32 = 2.0**-23
"""Relative resolution of Box2D's single precision."""


def simulate(scene: Scene, **settings) -> Trajectory:
    result = get_engine("box2d").simulate(scene, RunSettings(timestep=TIMESTEP, **settings))
    if result.info.status is RunStatus.UNAVAILABLE:
        engine_unavailable("box2d", result.info.message)
    assert result.info.status is RunStatus.OK, result.info.message
    assert result.trajectory is not None
    return result.trajectory


def test_mass_data_round_trip():
    """Box2D keeps the scene's mass, centre of mass and inertia about it, not the circle's."""
    scene = Scene(lam=0.6, thetadot0=1.0, mus=0.5, muk=0.5, eps=0.3, a=0.7, M=2.5)
    _world, body = Box2DEngine().build(scene)
    assert body.mass == pytest.approx(scene.M, rel=FLOAT32)
    assert body.rotational_inertia() == pytest.approx(scene.inertia_com, rel=FLOAT32)
    centre = body.local_center_of_mass()
    assert (centre.x, centre.y) == pytest.approx((0.0, scene.com_offset), rel=FLOAT32)


@pytest.mark.parametrize("mu", [0.3, 0.8, 1.7])
def test_friction_is_mu_while_slipping(mu):
    """A hoop thrown sliding (weight at 90 deg, no spin): |f|/n is mu, the sqrt(mu * mu) rule
    undone. Measured: median within 2.7e-4 relative (mu 0.3); single steps within 2.4e-3
    relative (mu 0.3), the float32 resolution of one step's velocity change (|J|/M ~ f dt
    = 1.5e-4 m/s against 2.4e-7 m/s at 2 m/s)."""
    scene = Scene(lam=0.5, thetadot0=0.0, xdot0=2.0, mus=mu, muk=mu, theta0=np.pi / 2, t_end=0.05)
    traj = simulate(scene)
    touching = traj.normal_force > 0.1 * scene.g
    assert touching.mean() > 0.9
    ratio = np.abs(traj.friction_force[touching]) / traj.normal_force[touching]
    assert np.median(ratio) == pytest.approx(mu, rel=1e-3)
    assert np.max(np.abs(ratio - mu)) < 5e-3 * mu


def test_the_force_is_exactly_zero_in_flight():
    """The float32 replay of a free step leaves exactly 0 where no contact acts (a hoop that
    leaves the floor at once): not round-off, which the contact reading would take for a
    contact (it counts any n above 1e-6 g)."""
    # lam chi > 1 with the weight on top: the hoop leaves the floor at once
    flying = Scene.from_chi(1.5, lam=0.95, eps=0.01, mus=0.8, muk=0.8, t_end=0.1)
    traj = simulate(flying)
    aloft = traj.clearance > 1e-3
    assert aloft.sum() > 100
    assert np.all(traj.normal_force[aloft] == 0.0)
    assert np.all(traj.friction_force[aloft] == 0.0)


def test_resting_hoop_feels_g():
    """At rest on the floor (weight straight below), the contact force is the scene's g."""
    scene = Scene(lam=0.5, thetadot0=0.0, mus=0.5, muk=0.5, theta0=np.pi, g=9.81, t_end=0.2)
    traj = simulate(scene)
    assert np.median(traj.normal_force) == pytest.approx(scene.g, rel=1e-5)
    assert np.max(np.abs(traj.friction_force)) < 1e-4 * scene.g


def test_free_flight_residual_replays_box2ds_velocity_update():
    """Built from Box2D's own steps of a body in free fall: the residual is exactly 0."""
    world = pyb2d3.World(gravity=(0.0, -9.8))
    body = world.create_dynamic_body(position=(0.0, 5.0))
    mass = pyb2d3.MassData()
    mass.mass, mass.center, mass.rotational_inertia = 1.3, (0.0, 0.2), 0.4
    body.mass_data = mass  # a body without mass feels no gravity
    body.linear_velocity = (0.3, 1.234567)
    rows = [(body.linear_velocity.x, body.linear_velocity.y)]
    for _ in range(200):
        world.step(TIMESTEP, 4)
        rows.append((body.linear_velocity.x, body.linear_velocity.y))
    res_x, res_y = free_flight_residual(np.array(rows), TIMESTEP, 4, float(world.gravity[1]))
    assert np.all(res_x == 0.0)
    assert np.all(res_y == 0.0)


def test_restitution_must_be_zero():
    with pytest.raises(ValueError, match=r"restitution must be 0 for Box2D, got 0\.5"):
        get_engine("box2d").check(get_scene("seed-mu"), RunSettings(restitution=0.5))


@pytest.mark.parametrize(
    ("option", "value"), [("subStepCount", 0), ("contactHertz", -1.0), ("enableSleep", 2)]
)
def test_bad_option_value_is_named(option, value):
    with pytest.raises(ValueError, match=option):
        get_engine("box2d").check(get_scene("seed-mu"), RunSettings(options={option: value}))


def test_stock_profile_is_box2ds_documented_defaults():
    """b2DefaultWorldDef (v3.1.1): contactHertz 30, contactDampingRatio 10, maxContactPushSpeed
    3 m/s, enableSleep true; b2World_Step's documented 4 substeps."""
    from hoopbench.engines.options import Profile

    stock = Box2DEngine.defaults(Profile.STOCK)
    assert stock == {
        "subStepCount": 4,
        "contactHertz": 30.0,
        "contactDampingRatio": 10.0,
        "maxContactPushSpeed": 3.0,
        "enableSleep": 1,
    }
    world = pyb2d3.World()
    definition = pyb2d3.WorldDef()
    assert definition.contact_hertz == stock["contactHertz"]
    assert definition.contact_damping_ratio == stock["contactDampingRatio"]
    assert world.sleeping_enabled
