"""Suite files: the schema, validation before any run, and stable run ids."""

from __future__ import annotations

import math

import pytest

from hoopbench.reports.compare.suite_file import (
    SUITES_DIR,
    SuiteError,
    builtin_suite,
    load_suite,
    parse_suite,
)

GOOD = """
name = "my-suite"
engines = ["reference", "mujoco", "pymunk"]
timesteps = [1e-3, 1e-4]
scenes = ["seed-mu", "hop-top"]

[[scene]]
name = "my-hop"
lam = 0.8
chi = 1.0
mus = 0.8
muk = 0.8
theta0_deg = 10

[[scene]]
name = "spun"
lam = 0.5
thetadot0 = 2.0
mus = 0.5
t_end = 1.0

[[variant]]
engine = "mujoco"
name = "pyramidal"
geometry = "sphere"
options = { cone = "pyramidal", solref = [0.02, 1.0] }
timesteps = [1e-4]
"""


def write(tmp_path, text: str):
    path = tmp_path / "suite.toml"
    path.write_text(text)
    return path


def test_a_suite_file_expands_into_its_runs(tmp_path):
    suite = load_suite(write(tmp_path, GOOD))
    assert suite.name == "my-suite"
    assert [s.name for s in suite.scenes] == ["seed-mu", "hop-top", "my-hop", "spun"]
    my_hop = suite.scenes[2]
    assert my_hop.chi == pytest.approx(1.0) and my_hop.theta0 == pytest.approx(math.radians(10))
    assert suite.scenes[3].muk == 0.5 and suite.scenes[3].t_end == 1.0
    tasks = suite.tasks()
    # 4 scenes x (3 engines x 2 timesteps + 1 variant x 1 timestep)
    assert len(tasks) == 4 * (3 * 2 + 1)
    pyramidal = [t for t in tasks if t.variant == "pyramidal"]
    assert {t.timestep for t in pyramidal} == {1e-4}
    assert dict(pyramidal[0].options)["cone"] == "pyramidal"
    assert dict(pyramidal[0].options)["solref"] == (0.02, 1.0)
    assert all(t.variant == "default" for t in tasks if t.engine != "mujoco")


def test_run_ids_are_stable_and_follow_the_inputs(tmp_path):
    first = {t.run_id for t in load_suite(write(tmp_path, GOOD)).tasks()}
    again = {t.run_id for t in load_suite(write(tmp_path, GOOD)).tasks()}
    assert first == again and len(first) == 28
    changed = {
        t.run_id
        for t in load_suite(write(tmp_path, GOOD.replace("lam = 0.8", "lam = 0.81"))).tasks()
    }
    assert len(first - changed) == 7  # the runs of my-hop, and only those
    # Options that spell out a default are the same run as leaving them out.
    spelled = GOOD.replace('cone = "pyramidal", ', 'cone = "pyramidal", impratio = 100.0, ')
    assert {t.run_id for t in load_suite(write(tmp_path, spelled)).tasks()} == first


def test_every_engine_is_the_default_when_engines_is_omitted(tmp_path):
    from hoopbench.engines.registry import engine_names

    suite = load_suite(write(tmp_path, 'name = "x"\ntimesteps = [1e-3]\nscenes = ["seed-mu"]\n'))
    assert suite.engines == engine_names()


H = 'name = "x"\ntimesteps = [1e-3]\n'
SEED = 'scenes = ["seed-mu"]\n'
HS = H + SEED
V = '[[variant]]\nengine = "mujoco"\nname = "v"\n'
S = '[[scene]]\nname = "s"\n'

BAD = [
    (HS + 'enignes = ["mujoco"]\n', "unknown key(s) enignes"),
    ("timesteps = [1e-3]\n" + SEED, "name must be a non-empty string"),
    ('name = "x"\n' + SEED, "timesteps must be a non-empty list"),
    ('name = "x"\ntimesteps = [0]\n' + SEED, "got 0"),
    ('name = "x"\ntimesteps = [-1e-3]\n' + SEED, "got -0.001"),
    ('name = "x"\ntimesteps = ["fast"]\n' + SEED, "got 'fast'"),
    ('name = "x"\ntimesteps = [5.0]\n' + SEED, "timestep 5 s is longer than the window"),
    ('name = "x"\ntimesteps = [1e-9]\n' + SEED, "needs 3e+09 steps"),
    (H + 'scenes = ["sead"]\n', "unknown catalogue scene 'sead'"),
    (H, "the suite has no scenes"),
    (HS + 'engines = ["bullet"]\n', "unknown engine 'bullet'"),
    (H + 'scenes = ["seed-mu", "seed-mu"]\n', "seed-mu given twice"),
    (H + S + "lam = 1.5\nchi = 0.1\nmus = 0.8\n", "[[scene]] 's': lam must be in [0, 1], got 1.5"),
    (H + S + "lam = 0.9\nmus = 0.8\n", "missing exactly one of chi, thetadot0"),
    (H + S + "lam = 0.9\nchi = 0.1\nmus = 0.8\nspin = 3\n", "unknown key(s) spin"),
    (H + S + 'lam = "heavy"\nchi = 0.1\nmus = 0.8\n', "lam must be a number, got 'heavy'"),
    (H + "[[scene]]\nlam = 0.9\nchi = 0.1\nmus = 0.8\n", "name must be a non-empty string"),
    (HS + 'engines = ["pymunk"]\n' + V, "engine must be one of the suite's (pymunk)"),
    (HS + '[[variant]]\nengine = "mujoco"\nname = "default"\n', "got 'default'"),
    (HS + '[[variant]]\nengine = "mujoco"\nname = ["v"]\n', "got ['v']"),
    (
        H + S + "lam = 0.9\nchi = 0.1\nmus = 0.8\ntheta0_deg = 1e6\n",
        "[-360, 360] deg, got 1000000.0",
    ),
    (HS + V + 'options = { cone = "round" }\n', "cone must be one of pyramidal, elliptic"),
    (HS + V + 'options = { cnoe = "pyramidal" }\n', "unknown mujoco setting(s) cnoe"),
    (HS + V + 'geometry = "hull"\n', "geometry 'hull' is not available for mujoco"),
    (HS + V + "colour = 1\n", "unknown key(s) colour"),
    (HS + V + V, "mujoco variant 'v' is given twice"),
    (HS + V + "timesteps = [0]\n", "got 0"),
    (HS + V + "restitution = 0.5\n", "unknown key(s) restitution"),
    (HS + V + 'scenes = ["seed"]\n', "scenes: 'seed' not in the suite (it has seed-mu)"),
    (HS + V + "scenes = []\n", "scenes must be a non-empty list of scene names"),
    (
        H + 'engines = ["pybullet"]\n' + S + "lam = 0.9\nchi = 0.1\nmus = 0.8\nM = 1e-12\n",
        "M must be >= 1e-08 kg",
    ),
    ('name = "x\ntimesteps = [1e-3]\n', "not valid TOML"),
]


@pytest.mark.parametrize(("text", "message"), BAD, ids=[m for _, m in BAD])
def test_a_bad_suite_file_is_one_error_naming_the_key_and_value(tmp_path, text, message):
    with pytest.raises(SuiteError) as caught:
        load_suite(write(tmp_path, text))
    text = str(caught.value)
    assert message in text
    assert text.startswith("suite.toml: ")
    assert "\n" not in text


def test_a_missing_suite_file_is_named(tmp_path):
    with pytest.raises(SuiteError, match=r"cannot read suite file .*nope\.toml"):
        load_suite(tmp_path / "nope.toml")


@pytest.mark.parametrize("name", sorted(p.stem for p in SUITES_DIR.glob("*.toml")))
def test_the_shipped_suites_are_valid(name):
    suite = load_suite(builtin_suite(name))
    assert suite.tasks()


def test_unknown_shipped_suite():
    with pytest.raises(
        SuiteError,
        match=r"no shipped suite .quik.; shipped: default, finer, full, precision, quick, "
        r"releases, stability",
    ):
        builtin_suite("quik")


def test_parse_accepts_the_parsed_toml_directly():
    suite = parse_suite(
        {"name": "d", "timesteps": [1e-3], "scenes": ["hop-top"], "engines": ["pymunk"]}
    )
    assert [t.engine for t in suite.tasks()] == ["pymunk"]


def test_a_variant_runs_on_its_scenes_only(tmp_path):
    text = GOOD + 'scenes = ["hop-top", "spun"]\n'
    tasks = [t for t in load_suite(write(tmp_path, text)).tasks() if t.variant == "pyramidal"]
    assert sorted(t.scene.name for t in tasks) == ["hop-top", "spun"]


def test_an_engine_may_have_its_own_timesteps_and_scenes():
    """[engine_timesteps] and [engine_scenes]: the batched engines run at one timestep and,
    MuJoCo Warp, on some scenes (docs/report.md); the other engines keep the suite's."""
    data = {
        "name": "own",
        "engines": ["pymunk", "mujoco"],
        "timesteps": [1e-3, 1e-4],
        "scenes": ["seed-mu", "hop-top"],
        "engine_timesteps": {"pymunk": [1e-3]},
        "engine_scenes": {"pymunk": ["hop-top"]},
    }
    tasks = parse_suite(data).tasks()
    pymunk = {(t.scene.name, t.timestep) for t in tasks if t.engine == "pymunk"}
    mujoco = {(t.scene.name, t.timestep) for t in tasks if t.engine == "mujoco"}
    assert pymunk == {("hop-top", 1e-3)}
    assert mujoco == {(s, dt) for s in ("seed-mu", "hop-top") for dt in (1e-3, 1e-4)}
    assert parse_suite(data).run_count == len(tasks)
    with pytest.raises(SuiteError, match="engine_timesteps: 'dart' is not one of the suite's"):
        parse_suite({**data, "engine_timesteps": {"dart": [1e-3]}})
    with pytest.raises(SuiteError, match=r"engine_scenes.pymunk: seed not among the suite's"):
        parse_suite({**data, "engine_scenes": {"pymunk": ["seed"]}})
