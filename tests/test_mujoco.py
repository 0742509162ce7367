"""MuJoCo adapter and MJCF writer: what the cross-engine contract test cannot see.

The model file round-trips through MuJoCo with the scene's mass and inertia, the weight has no
collision geometry, the only contacts are the hoop-floor pairs, options reach the compiled
model, the recorded forces are MuJoCo's own contact forces per unit mass, and the chunked
rollout is the same computation as a plain mj_step loop.
"""

from __future__ import annotations

import builtins
import math
import subprocess
import sys
import xml.etree.ElementTree as ET

import mujoco  # a declared dependency: missing it is a failure, not a skip
import numpy as np
import pytest

from hoopbench.engines.base import CHUNK_STEPS, DivergenceLimits
from hoopbench.engines.mujoco_engine import MujocoEngine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.models.mjcf import scene_to_mjcf
from hoopbench.models.scene import DegenerateSceneError, Scene
from hoopbench.reference import dynamics

DEFAULTS = MujocoEngine.defaults()


def seed(**changes) -> Scene:
    return get_scene("seed-mu").with_(**changes)


def weighted_bottom() -> Scene:
    """Weight at the bottom, heavier body, bigger hoop: catches unit and frame slips."""
    return Scene(lam=0.7, thetadot0=2.0, eps=0.02, mus=0.6, muk=0.6, theta0=2.5, a=0.4, M=2.5)


def load(scene: Scene, **settings) -> tuple:
    xml = MujocoEngine().model_text(scene, RunSettings(**settings))
    model = mujoco.MjModel.from_xml_string(xml)
    return xml, model


def summed_contact_force(model, data) -> np.ndarray:
    """World-frame force on the hoop, summed over contacts with mj_contactForce."""
    total = np.zeros(3)
    f6 = np.zeros(6)
    for i in range(data.ncon):
        mujoco.mj_contactForce(model, data, i, f6)
        total += data.contact[i].frame.reshape(3, 3).T @ f6[:3]
    return total


# ----------------------------------------------------------------------------- MJCF file
@pytest.mark.parametrize("scene", [seed(), weighted_bottom()], ids=["seed-mu", "bottom"])
def test_mjcf_round_trip_mass_and_inertia(scene):
    _, model = load(scene)
    body = model.body("hoop").id
    assert model.nbody == 2
    assert model.body_mass[body] == scene.M
    np.testing.assert_allclose(model.body_ipos[body], [0.0, 0.0, scene.com_offset], atol=1e-15)
    np.testing.assert_allclose(model.body_pos[body], [0.0, 0.0, scene.a], atol=1e-15)
    # The hinge is about y: that moment is the scene's; the other two only pass MuJoCo's check.
    assert model.body_inertia[body][1] == pytest.approx(scene.inertia_com, rel=1e-14)
    np.testing.assert_allclose(model.body_iquat[body], [1, 0, 0, 0])
    assert model.opt.gravity[2] == -scene.g


def test_mjcf_joints_are_slide_x_slide_z_hinge_y():
    _, model = load(seed())
    kinds = [int(t) for t in model.jnt_type]
    slide, hinge = int(mujoco.mjtJoint.mjJNT_SLIDE), int(mujoco.mjtJoint.mjJNT_HINGE)
    assert kinds == [slide, slide, hinge]
    np.testing.assert_array_equal(model.jnt_axis, [[1, 0, 0], [0, 0, 1], [0, 1, 0]])
    np.testing.assert_array_equal(model.jnt_pos, np.zeros((3, 3)))


def test_positive_hinge_angle_moves_the_weight_toward_plus_x():
    """theta clockwise from the top: the centre of mass at theta = 90 deg is at +x."""
    scene = seed()
    _, model = load(scene)
    data = mujoco.MjData(model)
    data.qpos[2] = math.pi / 2
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    np.testing.assert_allclose(data.xipos[1], [scene.com_offset, 0.0, scene.a], atol=1e-12)


def test_mjcf_weight_never_collides_and_one_pair_is_possible():
    scene = seed()
    xml, model = load(scene)
    root = ET.fromstring(xml)
    weight = root.find(".//geom[@name='weight']")
    assert weight.get("contype") == "0" and weight.get("conaffinity") == "0"
    # No geom takes part in MuJoCo's own pair generation: the explicit pairs are all there is.
    assert not model.geom_contype.any()
    assert not model.geom_conaffinity.any()
    assert model.npair == 1
    hoop, floor = model.geom("hoop").id, model.geom("floor").id
    assert {model.pair_geom1[0], model.pair_geom2[0]} == {hoop, floor}
    # Friction is exactly mu in both tangent directions, none torsional or rolling.
    np.testing.assert_array_equal(model.pair_friction[0], [scene.mus, scene.mus, 0, 0, 0])
    assert model.pair_dim[0] == 3
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert data.ncon == 1
    assert {data.contact[0].geom1, data.contact[0].geom2} == {hoop, floor}


def test_mjcf_pair_friction_is_the_run_mu_not_the_scene_mu():
    _, model = load(seed(), mu=0.35)
    np.testing.assert_array_equal(model.pair_friction[0], [0.35, 0.35, 0, 0, 0])


def test_mjcf_header_names_scene_and_settings():
    xml, _ = load(seed(), timestep=2e-4)
    header = xml.split("-->")[0]
    assert header.startswith("<!--")
    assert "scene 'seed-mu'" in header
    assert "lam=0.95" in header
    assert "mu=0.8, timestep=0.0002 s" in header
    assert "solref=0.0005 1.0" in header
    assert "integrator=RK4" in header


def test_mjcf_module_does_not_import_mujoco():
    code = "import sys, models.mjcf; sys.exit('mujoco' in sys.modules)"
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


@pytest.mark.parametrize(
    ("options", "read_back"),
    [
        ({"cone": "pyramidal"}, lambda m: m.opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL),
        ({"cone": "elliptic"}, lambda m: m.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC),
        ({"integrator": "Euler"}, lambda m: m.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER),
        (
            {"integrator": "implicitfast"},
            lambda m: m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
        ),
        ({"integrator": "RK4"}, lambda m: m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4),
        ({"impratio": 7.5}, lambda m: m.opt.impratio == 7.5),
        ({"noslip_iterations": 3}, lambda m: m.opt.noslip_iterations == 3),
        ({"tolerance": 1e-8}, lambda m: m.opt.tolerance == 1e-8),
        ({"iterations": 77}, lambda m: m.opt.iterations == 77),
        ({"solref": (0.003, 1.2)}, lambda m: list(m.pair_solref[0]) == [0.003, 1.2]),
        ({"solref": (-2e4, -30.0)}, lambda m: list(m.pair_solref[0]) == [-2e4, -30.0]),
        (
            {"solreffriction": (0.05, 1.0)},
            lambda m: list(m.pair_solreffriction[0]) == [0.05, 1.0],
        ),
        (
            {"solimp": (0.9, 0.95, 0.002, 0.4, 3.0)},
            lambda m: list(m.pair_solimp[0]) == [0.9, 0.95, 0.002, 0.4, 3.0],
        ),
    ],
    ids=lambda v: str(v) if isinstance(v, dict) else "",
)
def test_options_reach_the_model(options, read_back):
    _, model = load(seed(), options=options)
    assert read_back(model)


def test_defaults_and_timestep_reach_the_model():
    _, model = load(seed(), timestep=3e-4)
    assert model.opt.timestep == 3e-4
    assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4
    assert model.opt.impratio == DEFAULTS["impratio"]
    assert list(model.pair_solref[0]) == list(DEFAULTS["solref"])
    assert list(model.pair_solreffriction[0]) == list(DEFAULTS["solreffriction"])


@pytest.mark.parametrize("n", [3, 12, 32])
def test_ring_has_one_pair_per_capsule_and_starts_on_a_vertex(n):
    scene = weighted_bottom()
    _, model = load(scene, geometry="ring", options={"ring_segments": n})
    assert model.npair == n
    floor = model.geom("floor").id
    assert all(floor in (g1, g2) for g1, g2 in zip(model.pair_geom1, model.pair_geom2, strict=True))
    data = mujoco.MjData(model)
    data.qpos[2] = scene.theta0
    mujoco.mj_forward(model, data)
    # A vertex at the bottom: the lowest point of the ring just touches the floor.
    lowest = []
    for g in model.pair_geom1:
        radius, half = model.geom_size[g][:2]
        axis = data.geom_xmat[g].reshape(3, 3)[:, 2]
        lowest.append(data.geom_xpos[g][2] - half * abs(axis[2]) - radius)
    assert min(lowest) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"options": {"cone": "round"}}, "cone must be one of pyramidal, elliptic, got 'round'"),
        ({"options": {"integrator": "Leapfrog"}}, "integrator must be one of"),
        ({"options": {"solref": (0.01,)}}, "solref must be a pair"),
        ({"options": {"solref": (0.01, -1.0)}}, "solref must be .timeconst, dampratio."),
        ({"options": {"solreffriction": (0.0, 1.0)}}, "solreffriction must be .0, 0."),
        ({"options": {"solimp": (0.99, 0.9, 0.001)}}, "solimp must satisfy"),
        ({"options": {"impratio": 0}}, "impratio must be a number > 0, got 0"),
        (
            {"options": {"ring_segments": 2}},
            "ring_segments must be an integer in \\[3, 1024\\], got 2",
        ),
        ({"options": {"iterations": 2.5}}, "iterations must be an integer >= 1"),
        ({"restitution": 0.3}, "restitution must be 0 for MuJoCo, got 0.3"),
        ({"geometry": "hull"}, "geometry 'hull' is not available for mujoco"),
    ],
)
def test_bad_settings_raise_value_error(change, message):
    with pytest.raises(ValueError, match=message):
        MujocoEngine().run(seed(), RunSettings(**change))


def test_degenerate_scene_cannot_be_written():
    with pytest.raises(DegenerateSceneError, match="a MuJoCo model needs a positive moment"):
        scene_to_mjcf(get_scene("massless"), mu=0.8, timestep=1e-4, options=DEFAULTS)
    result = MujocoEngine().run(get_scene("massless").with_(t_end=0.1))
    assert result.info.status is RunStatus.ERROR
    assert "positive moment of inertia" in result.info.message


# ----------------------------------------------------------------------------- adapter
def test_missing_mujoco_is_reported_unavailable(monkeypatch):
    real_import = builtins.__import__

    def no_mujoco(name, *args, **kwargs):
        if name == "mujoco" or name.startswith("mujoco."):
            raise ImportError("No module named 'mujoco'")
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_mujoco)
    result = MujocoEngine().run(seed(t_end=0.01))
    assert result.info.status is RunStatus.UNAVAILABLE
    assert result.info.message == "mujoco cannot be imported: No module named 'mujoco'"
    assert result.trajectory is None


@pytest.mark.parametrize("scene", [seed(), weighted_bottom()], ids=["seed-mu", "bottom"])
def test_first_sample_is_the_scene_initial_state(scene):
    traj = MujocoEngine().run(scene.with_(t_end=0.01)).trajectory
    X, Y, theta, Xdot, Ydot, thetadot = scene.initial_state()
    assert traj.t[0] == 0.0
    assert traj.X[0] == pytest.approx(X, abs=1e-15)
    assert traj.theta[0] == theta
    assert traj.Xdot[0] == pytest.approx(Xdot, rel=1e-15)
    assert traj.Ydot[0] == pytest.approx(Ydot, rel=1e-15, abs=1e-15)
    assert traj.thetadot[0] == thetadot
    # Started at the contact's equilibrium penetration, a fraction of a micrometre deep...
    assert -1e-6 < traj.clearance[0] < 0
    assert traj.Y[0] == pytest.approx(Y, abs=1e-6)
    # ...where the forces per unit mass are the rigid rolling ones, whatever M is (up to the
    # soft friction's creep, 3e-4 of f here).
    f, n = dynamics.rolling_forces(scene, theta, thetadot)
    assert traj.normal_force[0] == pytest.approx(n, rel=1e-4)
    assert traj.friction_force[0] == pytest.approx(f, rel=1e-3, abs=1e-6)


@pytest.mark.parametrize("geometry", ["sphere", "cylinder", "ring"])
def test_recorded_forces_are_mujoco_contact_forces_per_unit_mass(geometry):
    """The netforce sensor equals mj_contactForce summed over contacts (ring, cylinder: many)."""
    scene = weighted_bottom()
    settings = RunSettings(geometry=geometry)
    engine = MujocoEngine()
    model, data = engine._build(mujoco, scene, settings, engine.check(scene, settings))
    for _ in range(5):
        mujoco.mj_step(model, data, nstep=400)
        mujoco.mj_forward(model, data)
        assert data.ncon >= (2 if geometry == "cylinder" else 1)
        np.testing.assert_allclose(
            data.sensordata[1:4], summed_contact_force(model, data), rtol=1e-12, atol=1e-12
        )
    traj = engine.run(scene.with_(t_end=0.2), settings).trajectory
    model, data = engine._build(mujoco, scene, settings, engine.check(scene, settings))
    for _ in range(1000):
        mujoco.mj_step(model, data)
    mujoco.mj_forward(model, data)
    fx, _, fz = summed_contact_force(model, data) / scene.M
    assert traj.friction_force[1000] == pytest.approx(fx, rel=1e-12, abs=1e-12)
    assert traj.normal_force[1000] == pytest.approx(fz, rel=1e-12)


def test_chunked_rollout_equals_a_plain_step_loop():
    """Same states and forces, bit for bit, across chunk boundaries and the extra last step."""
    scene = weighted_bottom().with_(t_end=0.25)
    engine = MujocoEngine()
    traj = engine.run(scene).trajectory
    n = len(traj)
    assert n == 2501 > 2 * CHUNK_STEPS
    model, data = engine._build(mujoco, scene, RunSettings(), engine.check(scene, RunSettings()))
    qpos, force = [data.qpos.copy()], []
    for _ in range(n):
        mujoco.mj_step(model, data)  # sensors are evaluated before the step integrates
        qpos.append(data.qpos.copy())
        force.append(data.sensordata[3] / scene.M)
    qpos = np.array(qpos[:n])
    np.testing.assert_array_equal(traj.theta, qpos[:, 2])
    np.testing.assert_array_equal(traj.normal_force, force)
    np.testing.assert_allclose(traj.X, qpos[:, 0] + scene.com_offset * np.sin(qpos[:, 2]))


@pytest.mark.parametrize(("geometry", "bump"), [("cylinder", 1e-4), ("ring", None)])
def test_other_geometries_roll(geometry, bump):
    scene = seed(t_end=0.4)
    n_seg = DEFAULTS["ring_segments"]
    result = MujocoEngine().run(scene, RunSettings(geometry=geometry))
    assert result.info.status is RunStatus.OK, result.info.message
    traj = result.trajectory
    assert np.all(np.diff(traj.theta) > 0)
    if bump is not None:
        assert np.all(traj.contact)
        assert np.max(np.abs(traj.clearance)) < bump
    else:
        # A polygon rolls from vertex to vertex: its centre rides up and down by
        # a (1 - cos(pi/N)) while its lowest point, whose height is the clearance, stays on
        # the floor (within the 30 um bounces at vertex impacts). The contact breaks for
        # single steps: the soft contact chatters on a pivot (docs/engines.md).
        assert traj.contact.mean() > 0.8
        assert np.max(np.abs(traj.clearance)) < 1e-4
        centre = traj.Y - scene.com_offset * np.cos(traj.theta)
        ride = scene.a * (1 - math.cos(math.pi / n_seg))
        assert np.max(centre) < scene.a + 1e-4
        assert np.max(centre) - np.min(centre) > 0.5 * ride


def test_divergence_stops_at_a_chunk_with_a_consistent_partial_trajectory():
    scene = seed(t_end=0.3)
    full = MujocoEngine().run(scene).trajectory
    # Any penetration at all counts as divergence here: the first chunk trips it.
    strict = MujocoEngine(limits=DivergenceLimits(penetration=1e-12))
    result = strict.run(scene)
    assert result.info.status is RunStatus.DIVERGED
    assert result.info.message.startswith("penetration")
    traj = result.trajectory
    assert len(traj) == CHUNK_STEPS == result.info.n_steps + 1
    np.testing.assert_array_equal(traj.normal_force, full.normal_force[:CHUNK_STEPS])
    np.testing.assert_array_equal(traj.theta, full.theta[:CHUNK_STEPS])


def test_bare_loop_times_the_same_number_of_steps():
    scene = seed(t_end=0.05)
    engine = MujocoEngine()
    assert engine.bare_loop_time(scene) > 0
    with pytest.raises(ValueError, match="cone must be one of"):
        engine.bare_loop_time(scene, RunSettings(options={"cone": "round"}))


def test_engine_reset_is_reported_as_divergence_without_a_log_file(tmp_path, monkeypatch):
    """MuJoCo resets a blown-up state instead of returning NaN; the adapter says so."""
    monkeypatch.chdir(tmp_path)
    before = mujoco.get_mju_user_warning()
    settings = RunSettings(timestep=1e-2, options={"solref": (-1e12, -1.0), "integrator": "Euler"})
    result = MujocoEngine().run(seed(t_end=1.0), settings)
    assert result.info.status is RunStatus.DIVERGED
    assert result.info.message.startswith("MuJoCo mjWARN_BADQACC, the engine reset its state")
    assert "huge value in QACC" in result.info.message
    assert mujoco.get_mju_user_warning() is before
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()
