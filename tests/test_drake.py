"""Drake adapter: the SDFormat round trip, conventions, forces, Drake's defaults that the adapter
overrides (gravity, contact model, combination rules), options, and the recorded findings.

Drake is an optional extra (``hoopbench[drake]``), installed with the test extra: a missing
pydrake here is a failure, not a skip.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pydrake  # the test extra installs drake: missing it is a failure, not a skip
import pytest
from pydrake.multibody.plant import (
    CalcContactFrictionFromSurfaceProperties,
    ContactModel,
    DiscreteContactApproximation,
)

from hoopbench.engines.drake_engine import (
    APPROXIMATIONS,
    DrakeEngine,
    contact_parameters,
)
from hoopbench.engines.options import Profile
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.models.scene import DegenerateSceneError, Scene
from hoopbench.models.sdformat import GEOMETRY_NAMES, scene_to_sdformat
from hoopbench.reference import dynamics

DT = 1e-4


def seed_mu(**changes) -> Scene:
    return get_scene("seed-mu").with_(**changes)


def sliding(theta_deg: float, mu: float = 0.8, t_end: float = 0.02) -> Scene:
    """The hoop thrown backwards, sliding at 2 m/s with no spin: it slips from the start."""
    return Scene(
        lam=0.95,
        eps=0.01,
        mus=mu,
        muk=mu,
        thetadot0=0.0,
        theta0=math.radians(theta_deg),
        xdot0=-2.0,
        t_end=t_end,
    )


def proximity(model, name: str):
    """The proximity properties of the collision geometry ``name`` in a built model."""
    plant = model.plant
    inspector = plant.EvalSceneGraphInspector(model.plant_context)
    (geometry,) = plant.GetCollisionGeometriesForBody(plant.GetBodyByName(name))
    return inspector.GetProximityProperties(geometry)


# --------------------------------------------------------------------------- model
@pytest.mark.parametrize("mu", [0.0, 0.3, 0.8, 1.7])
def test_sdformat_round_trip(mu):
    """Mass, centre of mass and inertia from the scene, read back from the parsed plant; the
    contact values per geometry are those whose combination is the pair's wanted value."""
    scene = Scene.from_chi(0.3, lam=0.8, eps=0.02, mus=mu, muk=mu, theta0=1.1, M=2.5, a=0.4)
    options = {"penetration_allowance": 3e-6, "relaxation_time": 0.004}
    model = DrakeEngine().build(scene, RunSettings(options=options), record=False)
    plant = model.plant
    hoop = plant.GetBodyByName("hoop")
    inertia = hoop.default_spatial_inertia()
    assert hoop.default_mass() == scene.M
    # In the hoop link frame (x forward, y up at theta = 0, z the axle): COM toward the weight.
    np.testing.assert_allclose(inertia.get_com(), [0.0, scene.com_offset, 0.0], atol=1e-15)
    about_com = inertia.Shift(inertia.get_com()).CalcRotationalInertia().CopyToFullMatrix3()
    assert about_com[2, 2] == pytest.approx(scene.inertia_com, rel=1e-12)
    assert abs(about_com[0, 1]) + abs(about_com[0, 2]) + abs(about_com[1, 2]) < 1e-15
    assert plant.num_positions() == plant.num_velocities() == 3  # planar: x, y, theta
    np.testing.assert_array_equal(plant.gravity_field().gravity_vector(), [0, 0, -scene.g])

    stiffness, dissipation = contact_parameters(scene, 3e-6)
    assert stiffness == pytest.approx(scene.M * scene.g / 3e-6, rel=1e-15)
    props = [proximity(model, name) for name in GEOMETRY_NAMES]
    frictions = [p.GetProperty("material", "coulomb_friction") for p in props]
    for p, friction in zip(props, frictions, strict=True):
        # Stiffness combines in series: each geometry has twice the pair's.
        assert p.GetProperty("material", "point_contact_stiffness") == 2 * stiffness
        assert p.GetProperty("material", "hunt_crossley_dissipation") == dissipation
        # SAP's relaxation times add up: each geometry has half the pair's.
        assert p.GetProperty("material", "relaxation_time") == 0.002
        assert friction.static_friction() == friction.dynamic_friction() == mu
    combined = CalcContactFrictionFromSurfaceProperties(*frictions)
    assert combined.dynamic_friction() == pytest.approx(mu, rel=1e-15, abs=0)


def test_model_text_needs_no_drake():
    """``hoopbench model --engine drake`` writes SDFormat in a process where pydrake cannot be
    imported (models/ never imports an engine; the engine module imports pydrake lazily)."""
    code = (
        "import sys; sys.modules['pydrake'] = None\n"
        "from hoopbench.reports.cli import main\n"
        "sys.exit(main(['model', '--engine', 'drake', '--scene', 'seed-mu']))\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith('<?xml version="1.0"?>')
    assert '<drake:joint name="planar" type="planar">' in done.stdout
    assert "<mass>1.0</mass>" in done.stdout


def test_model_text_loads_in_drakes_parser():
    from pydrake.multibody.parsing import Parser
    from pydrake.multibody.plant import MultibodyPlant

    plant = MultibodyPlant(time_step=DT)
    Parser(plant).AddModelsFromString(DrakeEngine().model_text(seed_mu()), "sdf")
    plant.Finalize()
    assert plant.num_positions() == 3
    assert plant.GetJointByName("planar").type_name() == "planar"


def test_writer_rejects_bad_input():
    with pytest.raises(ValueError, match="mu must be"):
        scene_to_sdformat(seed_mu(), mu=-0.1, stiffness=1.0, dissipation=0.0)
    with pytest.raises(ValueError, match="stiffness must be"):
        scene_to_sdformat(seed_mu(), mu=0.8, stiffness=0.0, dissipation=0.0)
    with pytest.raises(ValueError, match=r"restitution must be 0 for Drake, got 0\.5"):
        scene_to_sdformat(seed_mu(), mu=0.8, stiffness=1.0, dissipation=0.0, restitution=0.5)
    with pytest.raises(DegenerateSceneError):
        scene_to_sdformat(get_scene("massless"), mu=0.8, stiffness=1.0, dissipation=0.0)


@pytest.mark.parametrize("theta_deg", [0.0, 37.0, 90.0, 180.0, 250.0])
def test_initial_state_in_drakes_frame(theta_deg):
    """theta clockwise from the top: Drake's centre of mass and its velocity are the scene's."""
    scene = Scene.from_chi(0.4, lam=0.6, eps=0.1, mus=0.5, muk=0.5, theta0=math.radians(theta_deg))
    model = DrakeEngine().build(scene, record=False)
    plant, context = model.plant, model.plant_context
    X, Y, _theta, Xdot, Ydot, _thetadot = scene.initial_state()
    com = plant.CalcCenterOfMassPositionInWorld(context)
    depth = -plant.GetPositions(context)[1]  # the equilibrium penetration of the start
    assert 0 <= depth < 1e-5
    np.testing.assert_allclose(com, [X, 0.0, Y - depth], atol=1e-14)
    vcom = plant.CalcCenterOfMassTranslationalVelocityInWorld(context)
    np.testing.assert_allclose(vcom, [Xdot, 0.0, Ydot], atol=1e-14)


# --------------------------------------------------------------------------- Drake's defaults
def test_hoop_at_rest_feels_the_scenes_g_and_sinks_the_penetration_allowance():
    """Weight at the bottom, no spin: normal force g (the scene's 9.8, not Drake's 9.81), no
    friction, and the static penetration is penetration_allowance: the stiffness written per
    geometry (2 k) combines in series to the wanted k = M g / penetration_allowance."""
    scene = Scene(lam=0.95, eps=0.01, thetadot0=0.0, theta0=math.pi, mus=0.8, muk=0.8, t_end=0.2)
    allowance = DrakeEngine.defaults()["penetration_allowance"]
    traj = DrakeEngine().run(scene, RunSettings(timestep=DT)).trajectory
    np.testing.assert_allclose(traj.normal_force, scene.g, rtol=1e-9)
    assert np.max(np.abs(traj.friction_force)) < 1e-9
    np.testing.assert_allclose(traj.clearance, -allowance, rtol=1e-6)
    assert np.max(np.abs(traj.X)) < 1e-12


def test_stock_contact_values_are_scene_graphs_defaults():
    """The stock profile writes no stiffness, dissipation or relaxation time: Drake 1.51's
    SceneGraph then gives every geometry its default proximity properties (point stiffness
    1e6 N/m, Hunt-Crossley dissipation 50 s/m, relaxation time 0.1 s), and the plant's
    penetration_allowance estimate never acts. The pair is 5e5 N/m (in series) and 0.2 s."""
    from pydrake.geometry import SceneGraphConfig

    defaults = SceneGraphConfig().default_proximity_properties
    settings = RunSettings(profile=Profile.STOCK)
    assert "point_contact_stiffness" not in DrakeEngine().model_text(seed_mu(), settings)
    model = DrakeEngine().build(seed_mu(), settings, record=False)
    for name in GEOMETRY_NAMES:
        props = proximity(model, name)
        stiffness = props.GetProperty("material", "point_contact_stiffness")
        assert stiffness == defaults.point_stiffness == 1e6
        dissipation = props.GetProperty("material", "hunt_crossley_dissipation")
        assert dissipation == defaults.hunt_crossley_dissipation == 50.0
        assert props.GetProperty("material", "relaxation_time") == defaults.relaxation_time
        assert defaults.relaxation_time == 0.1


@pytest.mark.parametrize("approximation", APPROXIMATIONS)
@pytest.mark.parametrize("mu", [0.3, 0.8, 1.7])
def test_friction_coefficient_while_slipping_is_mu(approximation, mu):
    """Measured |f|/n of a sliding hoop (weight at 180 deg, sliding at 2 m/s, 50 ms) is the
    run's mu for every approximation: Drake's 2 mu1 mu2 / (mu1 + mu2) is undone. SAP and
    similar kick a stiff sliding contact off the floor (the last test); with a softer contact
    (penetration_allowance 1e-3 m) they keep it for long enough to measure."""
    scene = sliding(180.0, mu=mu, t_end=0.05)
    options = {"discrete_contact_approximation": approximation}
    if approximation in ("sap", "similar"):
        options["penetration_allowance"] = 1e-3
    traj = DrakeEngine().run(scene, RunSettings(options=options)).trajectory
    acting = traj.normal_force > 0.05 * scene.g
    assert acting.sum() >= 50
    assert np.all(np.abs(traj.slip_velocity[acting]) > 0.5)
    ratio = np.abs(traj.friction_force[acting]) / traj.normal_force[acting]
    np.testing.assert_allclose(ratio, mu, rtol=1e-3)


def test_zero_friction_gives_no_friction_force():
    traj = DrakeEngine().run(sliding(200.0, mu=0.0)).trajectory
    assert traj.normal_force.min() > 0
    assert np.all(traj.friction_force == 0.0)


# --------------------------------------------------------------------------- forces
def test_forces_match_drakes_contact_results():
    """Row i's force is the contact force Drake applied over the step from state i, as its
    ContactResults report it (summed on the hoop, world frame, per unit mass), through rolling,
    slipping and flight: hop-bottom lifts off at 0.31 s."""
    scene = get_scene("hop-bottom").with_(t_end=0.4)
    engine = DrakeEngine()
    traj = engine.run(scene, RunSettings(timestep=DT)).trajectory

    model = engine.build(scene, RunSettings(timestep=DT), record=False)
    plant, context, simulator = model.plant, model.plant_context, model.simulator
    port = plant.get_contact_results_output_port()
    hoop = plant.GetBodyByName("hoop").index()
    expected = np.zeros((len(traj), 2))
    simulator.Initialize()
    for i in range(len(traj)):
        simulator.AdvanceTo((i + 0.5) * DT)  # past the update at t_i: the step from state i
        results = port.Eval(context)
        for k in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(k)
            sign = 1.0 if info.bodyB_index() == hoop else -1.0  # the force is on body B
            force = sign * info.contact_force()
            expected[i] += (force[0] / scene.M, force[2] / scene.M)
    np.testing.assert_allclose(traj.friction_force, expected[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(traj.normal_force, expected[:, 1], rtol=0, atol=1e-9)
    flying = traj.t > 0.34
    assert np.all(traj.normal_force[flying] == 0.0) and not np.any(traj.contact[flying])


def test_first_sample_is_the_rolling_equilibrium():
    """The soft contact starts at the penetration that holds the centre: the first forces are
    the exact rolling ones, with no ringing."""
    scene = seed_mu(t_end=0.05)
    traj = DrakeEngine().run(scene).trajectory
    _f0, n0 = dynamics.rolling_forces(scene, scene.theta0, scene.thetadot0)
    assert traj.normal_force[0] == pytest.approx(float(n0), rel=1e-9)
    _f, n = dynamics.rolling_forces(scene, traj.theta, traj.thetadot)
    np.testing.assert_allclose(traj.normal_force, n, rtol=1e-4)
    assert traj.clearance[0] < 0


# --------------------------------------------------------------------------- options
def test_options_reach_the_plant():
    engine = DrakeEngine()
    options = {
        "discrete_contact_approximation": "similar",
        "contact_model": "hydroelastic_with_fallback",
        "penetration_allowance": 2e-5,
        "stiction_tolerance": 3e-4,
        "sap_near_rigid_threshold": 0.5,
    }
    model = engine.build(seed_mu(), RunSettings(options=options), record=False)
    plant = model.plant
    assert plant.get_discrete_contact_approximation() == DiscreteContactApproximation.kSimilar
    assert plant.get_contact_model() == ContactModel.kHydroelasticWithFallback
    assert plant.time_step() == DT
    assert plant.get_sap_near_rigid_threshold() == 0.5
    stiffness = proximity(model, "hoop").GetProperty("material", "point_contact_stiffness")
    assert stiffness == 2 * seed_mu().M * seed_mu().g / 2e-5
    assert not proximity(model, "hoop").HasProperty("material", "relaxation_time") or (
        proximity(model, "hoop").GetProperty("material", "relaxation_time") == 0.0
    )

    model = engine.build(seed_mu(), RunSettings(), record=False)
    defaults = DrakeEngine.defaults()
    plant = model.plant
    assert plant.get_contact_model() == ContactModel.kPoint
    approximation = defaults["discrete_contact_approximation"]
    assert plant.get_discrete_contact_approximation().name == "k" + approximation.title()

    model = engine.build(seed_mu(), RunSettings(options={"time_step": 0}), record=False)
    assert model.plant.time_step() == 0.0 and not model.discrete
    from pydrake.systems.analysis import ExtractSimulatorConfig

    scheme = ExtractSimulatorConfig(model.simulator).integration_scheme
    assert scheme == defaults["integration_scheme"]


def test_stock_profile_is_drakes_defaults():
    """The stock values are Drake's own: MultibodyPlantConfig's and SimulatorConfig's."""
    from pydrake.multibody.plant import MultibodyPlantConfig
    from pydrake.systems.analysis import SimulatorConfig

    config = MultibodyPlantConfig()
    stock = DrakeEngine.defaults(Profile.STOCK)
    assert stock["discrete_contact_approximation"] == config.discrete_contact_approximation
    assert stock["contact_model"] == config.contact_model
    assert stock["penetration_allowance"] is None  # not written: SceneGraph's defaults act
    assert stock["stiction_tolerance"] == config.stiction_tolerance
    assert stock["sap_near_rigid_threshold"] == config.sap_near_rigid_threshold
    assert stock["relaxation_time"] is None  # not written: Drake's 0.1 s per geometry
    assert stock["integration_scheme"] == SimulatorConfig().integration_scheme
    assert stock["accuracy"] == SimulatorConfig().accuracy


def test_options_change_the_run():
    scene = seed_mu(t_end=0.3)
    a = DrakeEngine().run(scene, RunSettings(options={"stiction_tolerance": 1e-3})).trajectory
    b = DrakeEngine().run(scene).trajectory
    assert not np.array_equal(a.slip_velocity, b.slip_velocity)


def test_run_reports_mu_and_settings():
    result = DrakeEngine().run(get_scene("seed"), RunSettings(timestep=1e-3, mu=0.6))
    assert result.ok, result.info.message
    assert result.info.mu == 0.6
    assert result.info.engine_version == "1.51.1"  # the pin in pyproject.toml
    assert result.info.n_steps == 3000
    np.testing.assert_allclose(result.trajectory.t, 1e-3 * np.arange(3001), rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (
            {"discrete_contact_approximation": "cenic"},
            "discrete_contact_approximation must be one of tamsi, sap, similar, lagged, "
            "got 'cenic'",
        ),
        ({"time_step": 1e-3}, r"time_step must be None \(.*\) or 0 \(.*\), got 0.001"),
        ({"time_step": True}, "time_step must be None .* got True"),
        ({"contact_model": "hydroelastic"}, "contact_model must be one of point, .* got"),
        ({"penetration_allowance": 0.0}, r"penetration_allowance must be a number > 0 m, got 0\.0"),
        ({"penetration_allowance": math.nan}, "penetration_allowance must be"),
        ({"stiction_tolerance": -1e-5}, r"stiction_tolerance must be a number > 0 m/s, got -1e-05"),
        ({"relaxation_time": -0.1}, r"relaxation_time must be a number >= 0 s, got -0\.1"),
        ({"sap_near_rigid_threshold": "big"}, "sap_near_rigid_threshold must be"),
        ({"integration_scheme": "euler"}, "integration_scheme must be one of .* got 'euler'"),
        ({"accuracy": 0.0}, r"accuracy must be a number in \(0, 1\], got 0\.0"),
        ({"stiction_tolerence": 1e-5}, "unknown drake setting"),
    ],
)
def test_bad_option_is_an_error(options, message):
    with pytest.raises(ValueError, match=message) as info:
        DrakeEngine().run(seed_mu(t_end=0.01), RunSettings(options=options))
    assert "\n" not in str(info.value)


def test_restitution_is_refused():
    with pytest.raises(ValueError, match=r"restitution must be 0 for Drake, got 0\.3"):
        DrakeEngine().run(seed_mu(t_end=0.01), RunSettings(restitution=0.3))


def test_missing_drake_is_unavailable(monkeypatch):
    monkeypatch.setitem(sys.modules, "pydrake", None)  # import pydrake now raises ImportError
    result = DrakeEngine().run(seed_mu(t_end=0.01))
    assert result.info.status is RunStatus.UNAVAILABLE
    assert result.info.message.startswith("pydrake cannot be imported")
    assert result.trajectory is None


def test_degenerate_scene_is_an_error_result():
    result = DrakeEngine().run(get_scene("massless"))
    assert result.info.status is RunStatus.ERROR
    assert "moment of inertia" in result.info.message


def test_stdout_stays_clean_and_drakes_warnings_are_kept_off():
    """The JSON on stdout parses, and Drake's build-time warnings (TAMSI's deprecation, half
    spaces in deformable contact) do not reach stderr. A process of its own: pytest's log
    capture would hide them, and Drake warns once per process."""
    args = ["simulate", "--engine", "drake", "--scene", "seed-mu", "--t-end", "0.02", "--json"]
    args += ["--set", "discrete_contact_approximation=tamsi"]
    code = f"import sys\nfrom hoopbench.reports.cli import main\nsys.exit(main({args!r}))\n"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout)["status"] == "ok"
    assert "drake" not in done.stderr.lower(), done.stderr


def test_bare_loop_steps_the_same_model():
    """bare_loop_time (the yardstick of reports/bench/overhead.py) runs and rejects bad
    options like run(); the overhead ratio itself is measured by the benchmark, not here."""
    engine = DrakeEngine()
    assert engine.bare_loop_time(seed_mu(t_end=0.05), RunSettings(timestep=DT)) > 0
    with pytest.raises(ValueError, match="stiction_tolerance must be"):
        engine.bare_loop_time(seed_mu(), RunSettings(options={"stiction_tolerance": 0}))


# --------------------------------------------------------------------------- the pin
def test_pinned_drake_has_every_exposed_approximation():
    """TAMSI is deprecated in Drake (removal on or after 2026-09-01): the pin keeps a version
    that has every approximation the adapter exposes. If this fails, Drake changed."""
    members = {name.lower() for name in DiscreteContactApproximation.__members__}
    assert {f"k{name}" for name in APPROXIMATIONS} <= members
    assert pydrake.__file__  # the installed package, not a stub


# --------------------------------------------------------------------------- findings
@pytest.mark.parametrize(
    ("approximation", "relaxation_time", "timestep", "lifts"),
    [
        ("tamsi", 0.0, 1e-4, False),
        ("lagged", 0.0, 1e-4, False),
        ("sap", None, 1e-4, True),
        ("sap", None, 2.5e-5, True),
        ("sap", 0.0, 1e-4, True),
        ("sap", 0.0, 2.5e-5, False),
        ("similar", 0.0, 1e-4, True),
    ],
)
def test_sliding_hoop_glides_off_the_floor_with_sap_and_similar(
    approximation, relaxation_time, timestep, lifts
):
    """A recorded finding about Drake 1.51.1, not a wish. A hoop sliding at 2 m/s (weight at
    90 deg, exact normal force 0.43 g throughout) with hoopbench's stiff contact
    (penetration_allowance 1e-6 m): the first SAP or similar step kicks it off the floor.
    With Drake's relaxation time (0.1 s per geometry) it climbs 38 mm in 20 ms at dt 1e-4 and
    as much at 2.5e-5 (a setting, not a timestep effect); with relaxation time 0 it climbs
    4.2 mm at 1e-4 and 0.03 mm at 2.5e-5 (the O(dt) 'gliding' Drake documents for SAP and
    similar); similar climbs 34 mm. TAMSI and lagged stay on the floor. If this fails, Drake
    changed: revisit docs/engines.md ("Drake")."""
    scene = sliding(90.0)
    exact_n = float(dynamics.slip_normal_force(scene, scene.theta0, 0.0, -1))
    assert exact_n > 0.4 * scene.g
    options = {"discrete_contact_approximation": approximation, "relaxation_time": relaxation_time}
    traj = DrakeEngine().run(scene, RunSettings(timestep=timestep, options=options)).trajectory
    lift = traj.clearance.max()
    assert (lift > 1e-3) == lifts, lift
    if not lifts:
        assert lift < 1e-4


# --------------------------------------------------------------------------- TAMSI at 5e-4
_TAMSI_LANDING = """
import numpy as np
from pydrake.geometry import AddContactMaterial, HalfSpace, ProximityProperties, Sphere
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import AddMultibodyPlant, CoulombFriction, MultibodyPlantConfig
from pydrake.multibody.tree import FixedOffsetFrame, PlanarJoint, RotationalInertia, SpatialInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder

DT, K = {dt!r}, 9.8e6  # s; N/m, the pair's: M g over the tuned 1e-6 m allowance
builder = DiagramBuilder()
config = MultibodyPlantConfig(
    time_step=DT, contact_model="point", discrete_contact_approximation="tamsi",
    stiction_tolerance=1e-5,
)
plant, _ = AddMultibodyPlant(config, builder)
# hop-top: a 1 kg hoop of radius 1 m, its centre of mass 0.95 m from the centre, 0.107 kg m^2
inertia = SpatialInertia.MakeFromCentralInertia(
    1.0, [0, 0.95, 0], RotationalInertia(0.107, 0.107, 0.107)
)
hoop = plant.AddRigidBody("hoop", inertia)
props = ProximityProperties()
# per geometry 2 K (in series: K), critically damped as Drake's own rule gives
AddContactMaterial(dissipation=np.sqrt(1 / K) / (9.8 / K), point_stiffness=2 * K,
                   friction=CoulombFriction(0.8, 0.8), properties=props)
plant.RegisterCollisionGeometry(hoop, RigidTransform(), Sphere(1.0), "hoop", props)
plant.RegisterCollisionGeometry(plant.world_body(), RigidTransform(), HalfSpace(), "floor", props)
plane = plant.AddFrame(FixedOffsetFrame(
    "plane", plant.world_frame(), RigidTransform(RollPitchYaw(np.pi / 2, 0, 0), [0, 0, 1.0])
))
plant.AddJoint(PlanarJoint("planar", plane, hoop.body_frame(), damping=[0, 0, 0]))
plant.mutable_gravity_field().set_gravity_vector([0, 0, -9.8])
plant.Finalize()
simulator = Simulator(builder.Build())
context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
plant.SetPositions(context, [0.0, -5.25e-7, 0.0])  # rolling, weight on top, 0.525 um deep
plant.SetVelocities(context, [2.2135943621178655, 0.0, -2.2135943621178655])
simulator.Initialize()
try:
    simulator.AdvanceTo(3.0)
    print("ran")
except RuntimeError as exc:
    print(str(exc).split(" with ")[0])
"""
"""hop-top as a pydrake user writes it from Drake's docs (no SDFormat, no hoopbench), with
hoopbench's tuned contact (TAMSI, 1e-6 m allowance) and its start state: only pydrake."""


def test_tamsi_fails_on_hop_tops_landing_at_5e_4_in_drake_alone():
    """The default suite's one Drake error row (hop-top, tuned, 5e-4 s) is TAMSI's: the same
    plant built with pydrake alone stops at the same time with the same error, on the landing
    after the hop; at 4e-4 s it runs (docs/engines.md, Drake). ~4 s (two processes)."""
    messages = {}
    for dt in (5e-4, 4e-4):
        done = subprocess.run(
            [sys.executable, "-c", _TAMSI_LANDING.format(dt=dt)],
            capture_output=True,
            text=True,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr
        messages[dt] = done.stdout.strip()
    stop = "failed to converge at simulation time = 1.6805"
    assert stop in messages[5e-4] and messages[4e-4] == "ran"
    run = DrakeEngine().run(get_scene("hop-top"), RunSettings(timestep=5e-4))
    assert run.info.status is RunStatus.ERROR and stop in run.info.message
