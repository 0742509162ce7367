"""The ``hoopbench`` command line: its JSON contract, its errors and its files."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from importlib.metadata import version

import pytest

from hoopbench.reports.cli import main

EVENT_KEYS = {
    "outcome",
    "t_slip",
    "theta_slip_deg",
    "thetadot_slip",
    "t_lift",
    "hop_height",
    "t_impact",
    "phases",
}


def run_json(capsys, *argv: str) -> dict:
    assert main([*argv, "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def test_reference_seed_json(capsys):
    out = run_json(capsys, "reference", "--scene", "seed")
    assert set(out) >= EVENT_KEYS
    assert out["outcome"] == "slips"
    assert out["theta_slip_deg"] == pytest.approx(88.5037, abs=1e-4)
    assert out["thetadot_slip"] == pytest.approx(3.26607, abs=1e-5)
    assert out["t_slip"] == pytest.approx(0.98708, abs=1e-5)
    assert out["t_lift"] is None and out["hop_height"] is None and out["t_impact"] is None
    kinds = [p["kind"] for p in out["phases"]]
    assert kinds[:3] == ["roll", "slip", "roll"]
    assert out["phases"][1]["sigma"] == 1
    assert "sigma" not in out["phases"][0]


def test_reference_explicit_parameters_match_the_scene(capsys):
    explicit = run_json(
        capsys,
        "reference",
        "--lam",
        "0.95",
        "--eps",
        "0.01",
        "--chi",
        "0.1",
        "--theta0-deg",
        "0",
        "--mus",
        "0.8",
        "--muk",
        "0.7",
    )
    named = run_json(capsys, "reference", "--scene", "seed")
    for key in ("t_slip", "theta_slip_deg", "thetadot_slip", "outcome"):
        assert explicit[key] == named[key]


def test_reference_seed_euler(capsys):
    out = run_json(
        capsys,
        "reference",
        "--method",
        "seed-euler",
        "--dt",
        "0.002",
        "--delta",
        "0.0001",
        "--scene",
        "seed",
    )
    assert out["n_steps"] == 14
    assert out["t_lift"] == pytest.approx(1.0151, abs=1e-4)
    assert out["outcome"] == "hops"
    assert out["hop_height"] > 0 and out["t_impact"] > out["t_lift"]


def test_reference_hop_scene(capsys):
    out = run_json(capsys, "reference", "--scene", "hop-top")
    assert out["outcome"] == "hops"
    assert out["phases"][-1]["kind"] == "flight"
    assert out["t_impact"] == pytest.approx(out["phases"][-1]["t_end"])


def test_readable_summary(capsys):
    assert main(["reference", "--scene", "seed"]) == 0
    text = capsys.readouterr().out
    assert "outcome        slips" in text
    assert "theta = 88.5037 deg" in text


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["reference", "--lam", "1.5", "--chi", "0.1", "--mus", "0.8"], "lam must be in [0, 1]"),
        (["reference", "--lam", "0.9", "--chi", "nan", "--mus", "0.8"], "chi must be finite"),
        (
            ["reference", "--a", "-1", "--lam", "0.9", "--chi", "0.1", "--mus", "0.8"],
            "a (hoop radius) must be > 0",
        ),
        (["reference", "--scene", "nope"], "must be a catalogue scene"),
        (["reference", "--lam", "0.9"], "missing: mus, chi or thetadot0"),
        (["reference", "--scene", "seed", "--muk", "0.9"], "muk must be <= mus"),
        (["simulate", "--engine", "ode", "--scene", "seed"], "invalid choice: 'ode'"),
        (
            ["simulate", "--engine", "mujoco", "--scene", "seed", "--set", "nope=1"],
            "unknown mujoco setting(s) nope",
        ),
        (
            ["simulate", "--engine", "mujoco", "--scene", "seed", "--set", "cone"],
            "--set takes KEY=VALUE",
        ),
        (
            ["simulate", "--engine", "pymunk", "--scene", "seed", "--geometry", "ring"],
            "geometry 'ring' is not available for pymunk",
        ),
        (
            ["simulate", "--engine", "pybullet", "--scene", "seed", "--dt", "-1"],
            "timestep must be a number > 0 s, got -1",
        ),
    ],
)
def test_bad_input_is_one_line_and_exit_2(capsys, argv, message):
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1
    assert message in lines[0]


def test_degenerate_scene_is_an_outcome(capsys):
    out = run_json(capsys, "reference", "--scene", "massless")
    assert out["outcome"] == "degenerate"
    assert out["theta_slip_deg"] == pytest.approx(math.degrees(2 * math.atan(0.8)), abs=1e-6)
    assert "degenerate" in out["message"]


def test_simulate_reference_json(capsys, tmp_path):
    csv = tmp_path / "traj.csv"
    out = run_json(
        capsys,
        "simulate",
        "--engine",
        "reference",
        "--scene",
        "seed-mu",
        "--dt",
        "1e-3",
        "--csv",
        str(csv),
    )
    assert set(out) >= EVENT_KEYS
    for key in ("engine", "engine_version", "status", "wall_time_s", "n_steps", "mu"):
        assert key in out
    assert out["engine"] == "reference" and out["status"] == "ok" and out["mu"] == 0.8
    from hoopbench.models.trajectory import COLUMNS, Trajectory

    traj = Trajectory.read(csv)
    assert len(traj) == out["n_steps"] + 1
    assert csv.read_text().splitlines()[1].split(",") == list(COLUMNS)


def test_pybullet_keeps_stdout_clean():
    """pybullet prints its build time at import: JSON on stdout must stay parseable."""
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "hoopbench.reports.cli",
            "simulate",
            "--engine",
            "pybullet",
            "--scene",
            "seed-mu",
            "--dt",
            "1e-3",
            "--json",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    out = json.loads(proc.stdout)
    assert out["engine"] == "pybullet" and out["status"] == "ok"


def test_model_mjcf_loads_in_mujoco(capsys):
    import mujoco

    assert main(["model", "--engine", "mujoco", "--scene", "seed"]) == 0
    xml = capsys.readouterr().out
    model = mujoco.MjModel.from_xml_string(xml)
    assert model.body_mass[1] == pytest.approx(1.0)


def test_model_urdf_and_pymunk(capsys):
    assert main(["model", "--engine", "pybullet", "--scene", "seed"]) == 0
    assert capsys.readouterr().out.lstrip().startswith(("<?xml", "<!--", "<robot"))
    assert main(["model", "--engine", "pymunk", "--scene", "seed"]) == 0
    spec = json.loads(capsys.readouterr().out)
    assert spec


def test_scenes_lists_the_catalogue(capsys):
    assert main(["scenes"]) == 0
    text = capsys.readouterr().out
    for name in ("seed", "seed-pi", "massless", "hop-top", "painleve"):
        assert name in text


def test_settings_lists_every_engine_default(capsys):
    from hoopbench.engines.registry import engine_class, engine_names

    out = run_json(capsys, "settings")
    assert set(out["engines"]) == set(engine_names())
    defaults = json.loads(json.dumps(engine_class("mujoco").defaults()))  # tuples as lists
    assert out["engines"]["mujoco"]["options"] == defaults
    assert out["detectors"]["slip_threshold"] == 1e-3


def _broken_map(tmp_path):
    (tmp_path / "map.toml").write_text("x = [")
    return ["map", "--out", str(tmp_path), "--resume"]


def _report_there(tmp_path):
    (tmp_path / "runs").mkdir()
    (tmp_path / "report.md").write_text("")
    return ["report", "--results", str(tmp_path)]


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            lambda tmp: ["reference", "--lam", "0.9"],
            "give --scene NAME or the scene parameters; missing: mus, chi or thetadot0",
        ),
        (
            lambda tmp: ["compare", "--suite", "quick", "--out", str(tmp), "--run-timeout", "0"],
            "--run-timeout must be > 0 s, got 0.0",
        ),
        (_broken_map, "--resume: {tmp}/map.toml: map.toml is not valid TOML"),
        (_report_there, "'{tmp}/report.md' exists; pass --force to replace it"),
        (
            lambda tmp: ["map", "--out", str(tmp), "--grid", "0x3"],
            "argument --grid: must be NXxNY, whole numbers >= 1, got '0x3'",
        ),
    ],
)
def test_api_checks_name_the_command_options(capsys, tmp_path, argv, message):
    """The command line shares the API's checks (reports/api.py) and names its own options."""
    assert main(argv(tmp_path)) == 2
    err = capsys.readouterr().err
    assert err.startswith("hoopbench: error: " + message.format(tmp=tmp_path)), err
    assert len(err.strip().splitlines()) == 1


def test_simulate_gives_the_canonical_reading_and_the_kinematic_one_to_compare(capsys):
    """pymunk at dt 1e-3 loses its contact force on single steps while rolling, and the slip
    velocity spikes on them: the kinematic reading (``kin``) reads dozens of slips, the
    canonical one (the top level, as the verdict reads it) the exact sequence."""
    out = run_json(capsys, "simulate", "--scene", "seed-mu", "--engine", "pymunk", "--dt", "1e-3")
    kinematic = " ".join(p["kind"] for p in out["kin"]["phases"])
    assert kinematic.count("slip") > 10
    assert " ".join(p["kind"] for p in out["phases"]) == "roll slip roll slip roll"
    assert out["reading"]["chatter_count"] > 50
    assert out["t_slip"] == pytest.approx(0.98708, abs=2e-3)


def test_simulate_judges_as_hb_run_does_in_json_and_in_text(capsys):
    """`simulate` prints the verdict, its flags, the exact events and each event's error:
    the same judgement as hb.run's for the same run (issue 35). pymunk on hop-top at dt
    1e-4 (0.1 s a run, two runs and a third in text) hops too high, lifts off early and
    lands late."""
    import hoopbench.reports.api as hb

    argv = ("simulate", "--scene", "hop-top", "--engine", "pymunk", "--dt", "1e-4")
    judged = run_json(capsys, *argv)["judgement"]
    assert judged == hb.run("pymunk", "hop-top", timestep=1e-4).judgement
    assert judged["verdict"] == "hop-too-high"
    assert judged["verdict_flags"].split() == ["hop-too-high", "early-lift-off", "late-impact"]
    assert judged["exact_hop_height"] == pytest.approx(0.380, abs=1e-3)
    events = {event["event"]: event for event in judged["events"]}
    assert set(events) >= {"slip onset", "lift-off", "impact", "hop height"}
    assert events["lift-off"]["within"] == "neither" and events["lift-off"]["unit"] == "ms"
    assert events["lift-off"]["error"] == pytest.approx(judged["err_t_lift_ms"])
    assert events["slip onset"]["within"] == "tight"
    assert events["hop height"]["error"] == pytest.approx(judged["err_hop_height_rel"])
    # The tolerance table's 2 % and 5 %, plus the row's detection floor (3e-8).
    hop = events["hop height"]
    assert (hop["tight"], hop["loose"]) == pytest.approx((0.02, 0.05), abs=1e-6)
    # Between the tolerances (a row's error set by hand): within loose, not tight.
    row = hb.run("pymunk", "hop-top", timestep=1e-4).row | {"err_hop_height_rel": -0.03}
    hop = hb.judgement(row)["events"][-1]
    assert (hop["event"], hop["error"], hop["within"]) == ("hop height", -0.03, "loose")
    assert main(list(argv)) == 0
    text = capsys.readouterr().out
    assert "verdict        hop-too-high: hop " in text
    assert "flags          hop-too-high early-lift-off late-impact" in text
    assert "exact          hops: slip onset t = 0.442027 s" in text
    assert "  lift-off       -120 ms (" in text and "): neither" in text
    assert "  hop height     +28.7 % (" in text


def test_version(capsys):
    with pytest.raises(SystemExit) as stop:
        main(["--version"])
    assert stop.value.code == 0
    assert capsys.readouterr().out.strip() == f"hoopbench {version('hoopbench')}"
