"""Stock and tuned profiles: the engine's own defaults against hoopbench's."""

from __future__ import annotations

import pytest

from hoopbench.engines.options import SAME, Profile, check_profile
from hoopbench.engines.registry import engine_class, engine_names, get_engine
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.reports.compare.suite_file import SuiteError, parse_suite
from hoopbench.reports.hop_map.spec import MapSpec

# The engines' own documented defaults, written out here independently of the declarations.
STOCK = {
    "mujoco": {"solref": (0.02, 1.0), "cone": "pyramidal", "impratio": 1.0, "integrator": "Euler"},
    # PyBullet's server: contact ERP 0.08 (m_erp2 in PhysicsServerCommandProcessor.cpp)
    "pybullet": {"contactSlop": 1e-5, "numSolverIterations": 50, "contactERP": 0.08},
    "pymunk": {"iterations": 10, "collision_slop": 0.1, "collision_bias": None},
    # MJX and MuJoCo Warp read MuJoCo's MJCF: MuJoCo's own defaults
    "mjx": {"solref": (0.02, 1.0), "cone": "pyramidal", "impratio": 1.0, "integrator": "Euler"},
    "mjwarp": {"solref": (0.02, 1.0), "cone": "pyramidal", "integrator": "Euler"},
    # Newton's ShapeConfig and the solver of its examples; None: each solver's own damping
    "newton": {
        "solver": "xpbd",
        "ke": 2.5e3,
        "kd": 100.0,
        "kf": 1000.0,
        "mu_rolling": 1e-4,
        "mu_torsional": 5e-3,
        "angular_damping": None,
        "iterations": 2,
    },
}


@pytest.mark.parametrize("engine", sorted(STOCK))
def test_stock_profile_is_the_engines_own_defaults(engine):
    stock = engine_class(engine).defaults(Profile.STOCK)
    for name, value in STOCK[engine].items():
        assert stock[name] == value, name
    tuned = engine_class(engine).defaults(Profile.TUNED)
    assert stock != tuned


@pytest.mark.parametrize("engine", engine_names())
def test_every_option_states_its_stock_value_or_keeps_it(engine):
    for option in engine_class(engine).options:
        assert option.stock is SAME or option.check(option.name, option.stock) == option.stock


def test_the_stock_profile_reaches_the_model():
    scene = get_scene("seed-mu")
    xml = get_engine("mujoco").model_text(scene, RunSettings(profile="stock"))
    assert 'cone="pyramidal"' in xml and 'integrator="Euler"' in xml
    tuned = get_engine("mujoco").model_text(scene, RunSettings())
    assert 'cone="elliptic"' in tuned


def test_a_bad_profile_is_named():
    with pytest.raises(ValueError, match="profile must be one of tuned, stock, got 'factory'"):
        RunSettings(profile="factory")


def test_suites_run_each_engines_defaults_once_per_profile():
    data = {"name": "p", "engines": ["pymunk"], "timesteps": [1e-3], "scenes": ["seed-mu"]}
    one = parse_suite(data).tasks()
    both = parse_suite({**data, "profiles": ["stock", "tuned"]}).tasks()
    assert [t.profile for t in one] == [Profile.TUNED]
    assert [t.profile for t in both] == [Profile.STOCK, Profile.TUNED]
    assert both[1].run_id == one[0].run_id  # the tuned run is the same run
    assert both[0].run_id != one[0].run_id
    assert dict(both[0].options)["iterations"] == 10
    # The reference has no stock values of its own: it runs once.
    reference = parse_suite({**data, "engines": ["reference"], "profiles": ["stock", "tuned"]})
    assert [t.profile for t in reference.tasks()] == [Profile.TUNED]
    with pytest.raises(SuiteError, match="profiles must be one or more of tuned, stock"):
        parse_suite({**data, "profiles": ["factory"]})


@pytest.mark.parametrize("value", ["Tuned", "fast", 1, None, ["tuned"]])
def test_one_profile_check_names_the_value(value):
    """engines/options.check_profile is the one check the suites and the map call."""
    with pytest.raises(ValueError) as err:
        check_profile("profile", value)
    assert str(err.value) == f"profile must be one of tuned, stock, got {value!r}"
    with pytest.raises(ValueError, match="profile must be one of tuned, stock, got"):
        MapSpec(profile=value)


def test_a_profile_check_gives_the_enum():
    assert check_profile("p", "stock") is Profile.STOCK
    assert check_profile("p", Profile.TUNED) is Profile.TUNED
