"""Bad and extreme command-line input: a one-line error naming the value, or an honest status.

Every row is a mistake a user can make. The command must exit with status 2 within seconds,
print nothing on stdout and one line on stderr that contains the offending value (and, where
the reason matters, the reason). Nothing may run for long, use much memory, or be written.
"""

from __future__ import annotations

import errno
import json
import os
import re
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from hoopbench.reports.cli import main

SEED = ["--scene", "seed-mu"]
PARAMS = ["--lam", "0.95", "--chi", "0.1", "--mus", "0.8"]


def sim(engine: str, *args: str) -> list[str]:
    return ["simulate", "--engine", engine, *SEED, *args]


BAD: list[tuple[list[str], str]] = [
    # ----- scene parameters
    (["simulate", "--engine", "pymunk", "--lam", "1.5", "--chi", "0.1", "--mus", "0.8"], "1.5"),
    (["simulate", "--engine", "pymunk", "--lam", "-0.1", "--chi", "0.1", "--mus", "0.8"], "-0.1"),
    (["simulate", "--engine", "pymunk", "--lam", "nan", "--chi", "0.1", "--mus", "0.8"], "nan"),
    (["simulate", "--engine", "pymunk", "--lam", "abc", "--chi", "0.1", "--mus", "0.8"], "'abc'"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--eps", "-1"], "eps must be >= 0, got -1"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--mus", "-0.5"], "-0.5"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--muk", "0.9"], "muk must be <= mus"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--a", "0"], "a (hoop radius) must be > 0"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--a", "-1"], "got -1"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--g", "0"], "g must be > 0"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--M", "0"], "M (total mass) must be > 0"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--t-end", "0"], "t_end must be > 0"),
    (["simulate", "--engine", "pymunk", *PARAMS, "--t-end", "inf"], "t_end must be finite"),
    (["simulate", "--engine", "pymunk", "--lam", "0.9", "--chi", "-1", "--mus", "0.8"], "-1"),
    (["simulate", "--engine", "pymunk", *SEED, "--theta0-deg", "nan"], "theta0"),
    (["simulate", "--engine", "pymunk", *SEED, "--xdot0", "inf"], "xdot0 must be finite"),
    (["simulate", "--engine", "pymunk", "--lam", "0.9"], "missing: mus, chi or thetadot0"),
    (["simulate", "--engine", "pymunk", "--scene", "nope"], "'nope'"),
    # the error named the API's keyword ("name must be ...") instead of the option
    (["reference", "--scene", "nope"], "--scene NAME must be a catalogue scene"),
    # a value holding the option's placeholder stays the value
    (["reference", "--scene", "{option}"], "got '{option}'"),
    (["simulate", "--engine", "pymunk", *SEED, "--chi", "0.1", "--thetadot0", "1"], "--chi"),
    # ----- engine choice and common settings
    (["simulate", "--engine", "nope", *SEED], "'nope'"),
    (sim("pymunk", "--dt", "0"), "timestep must be a number > 0 s, got 0"),
    # the reference's own step fell back on its default without a word
    (["reference", "--scene", "seed", "--method", "seed-euler", "--dt", "0"], "got '0'"),
    (["reference", "--scene", "seed", "--dt", "0", "--csv", "x.csv"], "got '0'"),
    (sim("pymunk", "--dt", "-1"), "got -1"),
    (sim("pymunk", "--dt", "nan"), "got nan"),
    (sim("mujoco", "--dt", "5"), "timestep 5 s is longer than the window t_end = 3 s"),
    (sim("pymunk", "--dt", "0.1", "--t-end", "0.05"), "timestep 0.1 s is longer"),
    (sim("mujoco", "--t-end", "1e4", "--dt", "1e-5"), "needs 1e+09 steps"),
    (sim("pybullet", "--dt", "1e-9"), "needs 3e+09 steps"),
    (sim("reference", "--dt", "1e-9"), "needs 3e+09 steps"),
    (sim("pymunk", "--max-steps", "0"), "got 0"),
    (sim("pymunk", "--max-steps", "many"), "'many'"),
    (sim("pymunk", "--mu", "-1"), "mu must be a number >= 0, got -1"),
    (sim("pymunk", "--mu", "nan"), "got nan"),
    (sim("pymunk", "--restitution", "2"), "restitution must be a number in [0, 1], got 2"),
    (sim("mujoco", "--restitution", "0.5"), "restitution must be 0 for MuJoCo, got 0.5"),
    (sim("newton", "--restitution", "0.5"), "restitution must be 0 for Newton, got 0.5"),
    (sim("pybullet", "--mu", "20"), "mu must be <= 10.0 for pybullet"),
    (sim("pybullet", "--M", "1e-9"), "M must be >= 1e-08 kg for pybullet, got 1e-09"),
    # ----- geometries and engine options
    (sim("pybullet", "--geometry", "ring"), "geometry 'ring' is not available for pybullet"),
    (sim("mujoco", "--geometry", "hull"), "geometry 'hull' is not available for mujoco"),
    (sim("pymunk", "--geometry", "cylinder"), "geometry 'cylinder'"),
    (sim("mujoco", "--set", "cone=round"), "cone must be one of pyramidal, elliptic, got 'round'"),
    (sim("mujoco", "--set", "nope=1"), "unknown mujoco setting(s) nope"),
    (sim("mujoco", "--set", "cone"), "--set takes KEY=VALUE, got 'cone'"),
    (sim("mujoco", "--set", "=1"), "got '=1'"),
    (sim("mujoco", "--set", "cone=elliptic", "--set", "cone=pyramidal"), "--set cone is given"),
    (sim("mujoco", "--set", "solref=0.01"), "solref must be a pair"),
    (sim("mujoco", "--set", "solref=0.01,-1"), "solref must be (timeconst, dampratio)"),
    (sim("mujoco", "--set", "solimp=0.99,0.9,0.001"), "solimp must satisfy"),
    (sim("mujoco", "--set", "impratio=0"), "impratio must be a number > 0, got 0"),
    (sim("mujoco", "--set", "integrator=Leapfrog"), "got 'Leapfrog'"),
    (sim("mujoco", "--set", "ring_segments=2"), "ring_segments must be an integer in [3, 1024]"),
    (sim("pybullet", "--set", "numSolverIterations=2.5"), "got 2.5"),
    (sim("pybullet", "--set", "contactERP=2"), "contactERP must be a number in [0, 1], got 2"),
    (sim("pybullet", "--set", "contactStiffness=1000"), "must be given together"),
    (sim("pybullet", "--set", "enableConeFriction=2"), "enableConeFriction must be 0 or 1, got 2"),
    (sim("pymunk", "--set", "iterations=0"), "iterations must be an integer >= 1, got 0"),
    (sim("newton", "--set", "solver=vbd"), "solver must be one of xpbd, featherstone"),
    (sim("newton", "--set", "ke=0"), "ke must be a number"),
    (sim("mjwarp", "--set", "device=tpu"), "device must be one of auto, cpu, gpu"),
    (sim("mjx", "--set", "integrator=implicit"), "got 'implicit'"),
    (sim("pymunk", "--set", "collision_bias=1"), "collision_bias must be a number in [0, 1)"),
    (sim("pymunk", "--set", "collision_slop=-1"), "got -1"),
    (sim("reference", "--set", "rtol=5"), "rtol must be a number in [2.22045e-14, 0.001], got 5"),
    (sim("reference", "--set", "cone=round"), "unknown reference setting(s) cone"),
    # ----- model files: the same checks as a run
    (["model", "--engine", "reference", *SEED], "engine reference reads no model file"),
    (["model", "--engine", "box2d", *SEED], "box2d reads no model file: the world is built"),
    (["model", "--engine", "rapier", *SEED], "rapier reads no model file: the world is built"),
    (["model", "--engine", "newton", *SEED], "newton reads no model file: the worlds are built"),
    (["model", "--engine", "mjx", *SEED, "--set", "precision=float16"], "got 'float16'"),
    (["model", "--engine", "mujoco", *SEED, "--set", "cone=round"], "got 'round'"),
    (["model", "--engine", "mujoco", *SEED, "--restitution", "0.3"], "got 0.3"),
    (["model", "--engine", "pybullet", *SEED, "--mu", "11"], "got 11"),
    # ----- the reference solvers
    (["reference", *SEED, "--method", "bogus"], "'bogus'"),
    (["reference", *SEED, "--rtol", "0"], "rtol"),
    (["reference", *SEED, "--method", "seed-euler", "--delta", "-1"], "delta"),
    (["reference", *SEED, "--method", "seed-euler", "--dt", "1e-13"], "dt = 1e-13 s is below"),
    (["reference", *SEED, "--method", "seed-euler", "--dt", "5"], "dt = 5 s is longer than"),
    (["reference", *SEED, "--csv", "x.parquet", "--dt", "1e-9"], "makes 3e+09 samples"),
    # ----- compare, report and figure
    (["compare", "--suite", "quick", "--out", "new", "--jobs", "0"], "--jobs: must be >= 1, got 0"),
    (["compare", "--suite", "quick", "--out", "new", "--jobs", "-3"], "got -3"),
    (["compare", "--suite", "quick", "--out", "new", "--jobs", "40"], "got 40"),
    (["compare", "--suite", "quick", "--out", "new", "--jobs", "two"], "'two'"),
    (["compare", "--suite", "quik", "--out", "new"], "no shipped suite 'quik'"),
    (["compare", "--suite", "none.toml", "--out", "new"], "cannot read suite file 'none.toml'"),
    (["compare", "--suite", "quick", "--out", "new", "--engines", "bullet"], "bullet"),
    (["compare", "--suite", "quick", "--out", "new", "--run-timeout", "0"], "got 0"),
    (["report", "--results", "nowhere"], "--results 'nowhere' holds no results"),
    (["figure", *SEED, "--out", "hoop.jpg"], "hoop.jpg'"),
]

BAD += [
    # ----- values argparse used to take for options ("expected one argument")
    (sim("pymunk", "--dt", "-1e-4"), "got -0.0001"),
    (["map", "--out", "new", "--grid", "-3x4"], "got '-3x4'"),
    (["map", "--out", "new", "--grid", "\uff12x\uff12"], "got '\uff12x\uff12'"),  # full width
    # ----- one rule for the start angle, whichever command reads it
    (["reference", *SEED, "--theta0-deg", "1e6"], "theta0_deg must be a number in [-360, 360]"),
    (["map", "--out", "new", "--theta0-deg", "1e6"], "theta0_deg must be a number in [-360, 360]"),
    # ----- an empty path is no path (it used to mean the current folder, or no file)
    (["compare", "--suite", "quick", "--out", ""], "--out: must name a folder, got ''"),
    (["map", "--out", " "], "--out: must name a folder, got ' '"),
    (sim("pymunk", "--csv", ""), "got ''"),
    (["reference", *SEED, "--csv", ""], "got ''"),
    # ----- a suite's name is a shipped suite's name; a path (a / or .toml) is read as a file
    (["compare", "--suite", "../../x", "--out", "new"], "cannot read suite file '../../x'"),
    (["compare", "--suite", "..", "--out", "new"], "no shipped suite '..'"),
    # ----- integer engine options within a C int, refused before the engine sees them
    (sim("pymunk", "--set", "iterations=1e20"), "iterations must be an integer that fits a C"),
    (sim("mujoco", "--set", "iterations=1e20"), "got 1e+20"),
]

BAD += [
    # ----- issue 26: derived quantities past a float, sizes no run can meet
    (["reference", "--scene", "seed", "--thetadot0", "1e200"], "thetadot0 = 1e+200 rad/s turns"),
    (["reference", "--lam", "0.9", "--mus", "0.8", "--chi", "1e300"], "chi = 1e+300 (with a = 1"),
    (sim("mujoco", "--geometry", "ring", "--set", "ring_segments=100000000"), "in [3, 1024]"),
    (sim("pymunk", "--set", "iterations=" + "9" * 400), "got 999999999999... (400 digits)"),
    (sim("reference", "--set", "rtol=1e-300"), "rtol must be a number in [2.22045e-14, 0.001]"),
    (["reference", *SEED, "--rtol", "1e-300"], "rtol must be >= 2.22e-14 (scipy raises"),
    # ----- issue 26: what the command line read, not what float() made of it
    (sim("pymunk", "--dt", "1e-400"), "'1e-400' is too small for a float (it would be read"),
    (["simulate", "--engine", "pymunk", "--lam", "-nan", "--chi", "0.1", "--mus", "0.8"], "nan"),
    # ----- a pasted file or runaway expansion as a value: its start, end and length, one line
    (sim("mujoco", "--set", "cone=" + "x" * 500), f"'{'x' * 100}...{'x' * 40}' (500 characters)"),
    (sim("mujoco", "--dt", "1" * 200 + "x"), f"'{'1' * 100}...{'1' * 39}x' (201 characters)"),
    (["reference", "--scene", "y" * 201], f"got '{'y' * 100}...{'y' * 40}' (201 characters)"),
]


@pytest.fixture
def deadline() -> Iterator[None]:
    """Fail, instead of hanging, if one command takes more than a few seconds."""

    def expire(signum, frame):
        raise TimeoutError("the command did not answer within 20 s")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(20)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


def test_the_table_is_large_enough():
    assert len(BAD) >= 60


@pytest.mark.parametrize(("argv", "names"), BAD, ids=[" ".join(a)[:120] for a, _ in BAD])
def test_bad_input_is_one_line_naming_the_value(argv, names, capsys, deadline, tmp_path):
    argv = [str(tmp_path / a) if a.endswith((".jpg", ".parquet")) else a for a in argv]
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("hoopbench: ")
    assert names in lines[0]
    assert "Traceback" not in captured.err


# --------------------------------------------------------------------------- output paths
def test_missing_output_folder_is_refused_before_the_run(tmp_path, capsys, deadline):
    target = tmp_path / "missing" / "run.csv"
    assert main(sim("pymunk", "--csv", str(target))) == 2
    err = capsys.readouterr().err
    assert f"folder '{target.parent}'" in err and "does not exist" in err
    assert not target.parent.exists()


def test_existing_output_file_is_kept_without_force(tmp_path, capsys, deadline):
    target = tmp_path / "run.csv"
    target.write_text("precious\n")
    assert main(sim("pymunk", "--t-end", "0.01", "--csv", str(target))) == 2
    assert "pass --force" in capsys.readouterr().err
    assert target.read_text() == "precious\n"
    assert main(sim("pymunk", "--t-end", "0.01", "--csv", str(target), "--force")) == 0
    assert target.read_text() != "precious\n"


def test_compare_refuses_a_non_empty_folder(tmp_path, capsys, deadline):
    (tmp_path / "runs.csv").write_text("old\n")
    assert main(["compare", "--suite", "quick", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert str(tmp_path) in err and len(err.strip().splitlines()) == 1
    assert (tmp_path / "runs.csv").read_text() == "old\n"


# --------------------------------------------------------------------------- honest results
def run_json(capsys, *argv: str) -> tuple[int, dict]:
    code = main([*argv, "--json"])
    return code, json.loads(capsys.readouterr().out)


def test_parameters_combine_with_the_final_radius(capsys, deadline):
    """--scene seed --a 2 --chi 0.1 is chi 0.1 with a = 2, not the catalogue's spin."""
    code, out = run_json(capsys, "reference", "--scene", "seed", "--a", "2", "--chi", "0.2")
    assert code == 0
    assert out["scene"]["a"] == 2.0
    assert out["scene"]["chi"] == pytest.approx(0.2, rel=1e-12)
    code, out = run_json(capsys, "reference", "--scene", "seed", "--g", "3.0")
    assert out["scene"]["chi"] == pytest.approx(0.1, rel=1e-12)  # the scene stays itself


def test_zero_inertia_is_an_error_row_not_a_roll(capsys, deadline):
    """lam = 1, eps = 0: the reference reaches a slip it cannot follow (I = 0)."""
    code, out = run_json(
        capsys, "simulate", "--engine", "reference", "--lam", "1", "--chi", "0.1", "--mus", "0.8"
    )
    assert code == 1
    assert out["status"] == "error"
    assert "degenerate" in out["status_message"]


def test_a_window_that_is_not_a_multiple_of_the_step_does_not_overrun(capsys, deadline):
    code, out = run_json(capsys, *sim("pymunk", "--dt", "1e-3", "--t-end", "0.0025"))
    assert code == 0
    assert out["n_steps"] == 2  # t = 0, 1 ms, 2 ms: never past t_end
    assert out["phases"][-1]["t_end"] <= 0.0025


def test_tiny_pybullet_mass_at_the_limit_is_honest(capsys, deadline):
    code, out = run_json(capsys, *sim("pybullet", "--M", "1e-8", "--t-end", "1.2"))
    assert code == 0 and out["status"] == "ok"
    assert out["outcome"] == "slips"
    assert out["t_slip"] == pytest.approx(0.9872, abs=2e-3)


# --------------------------------------------------------------------------- files given as input
def one_line(capsys) -> str:
    """The command's single stderr line (nothing on stdout, no traceback)."""
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("hoopbench: ") and "Traceback" not in captured.err
    return lines[0]


BAD_SUITE_FILES: list[tuple[bytes, str]] = [
    # tomllib recursed to a RecursionError traceback
    (b'name = "x"\nscenes = ' + b"[" * 5000 + b"]" * 5000 + b"\n", "nest too deep"),
    # the codec's error named no file
    (b'name = "\xff"\n', "is not UTF-8 text"),
    # a [[scene]] named like a catalogue scene ran, and the report drew the catalogue's path
    (
        b'name = "x"\nengines = ["reference"]\ntimesteps = [1e-3]\n'
        b'[[scene]]\nname = "hop-top"\nlam = 0.9\nchi = 0.5\nmus = 0.8\n',
        "the catalogue's scene of that name has other parameters (lam 0.9 (catalogue: 0.95)",
    ),
]


@pytest.mark.parametrize(("content", "names"), BAD_SUITE_FILES, ids=["nested", "utf8", "clash"])
def test_a_bad_suite_file_is_one_line_naming_it(content, names, tmp_path, capsys, deadline):
    suite = tmp_path / "bad.toml"
    suite.write_bytes(content)
    assert main(["compare", "--suite", str(suite), "--out", str(tmp_path / "out")]) == 2
    line = one_line(capsys)
    assert "bad.toml" in line and names in line
    assert not (tmp_path / "out").exists()


def test_a_catalogue_name_over_a_longer_window_is_the_same_scene(tmp_path):
    """The stability suite's painleve is the catalogue's over 1.5 s: still allowed."""
    from hoopbench.reports.compare.suite_file import builtin_suite, load_suite

    (painleve,) = [s for s in load_suite(builtin_suite("stability")).scenes if s.name == "painleve"]
    assert painleve.t_end == 1.5


def test_a_spin_no_run_can_follow_is_refused_by_the_name_given(capsys, deadline):
    """g = 1e308 overflowed the integrator (a RuntimeError traceback, later an error status
    after seconds of work): the spin it makes, 1.5e153 turns in the window, is now refused
    before anything runs, by the values given."""
    assert main(["reference", "--scene", "seed", "--g", "1e308", "--json"]) == 2
    assert "g = 1e+308 m/s^2) spins the hoop 1.51e+153 times" in one_line(capsys)


# --------------------------------------------------------------------------- results from elsewhere
NASTY_NAMES = (
    "x/../../../ESCAPED",
    "<script>alert(1)</script>",
    "a|b",
    "line\nbreak",
    "hop<img src=x onerror=alert(1)>",
    "x$\\frac$y",  # matplotlib's mathtext stopped the report on it
)
"""Scene names a results folder from someone else may hold."""


@pytest.fixture(scope="module")
def nasty_results(tmp_path_factory):
    """A results folder whose scene names are paths and markup: the reference and pymunk at the
    report's timestep, trajectories kept (so that the report draws a figure per scene)."""
    from hoopbench.reports.compare.suite import compare

    root = tmp_path_factory.mktemp("nasty")
    scenes = "".join(
        f"[[scene]]\nname = {json.dumps(name)}\nlam = 0.9\nchi = {0.1 + 0.1 * k}\n"
        "mus = 0.8\nt_end = 0.6\n"
        for k, name in enumerate(NASTY_NAMES)
    )
    suite = root / "nasty.toml"
    suite.write_text(
        f'name = "nasty"\nengines = ["reference", "pymunk"]\ntimesteps = [1e-4]\n{scenes}'
    )
    out = root / "deep" / "a" / "b" / "c" / "results"
    out.parent.mkdir(parents=True)
    assert compare(suite, out, jobs=1, quiet=True, trajectories="default").completed
    return out


def unescaped_pipes(line: str) -> int:
    """The cell separators of a Markdown table row: pipes not escaped by a backslash."""
    return len(re.findall(r"(?<!\\)(?:\\\\)*\|", line))


@pytest.mark.slow  # the report draws a figure per scene: about 10 s
def test_scene_names_from_a_results_folder_are_neither_paths_nor_markup(nasty_results):
    root = nasty_results.parents[3]
    report = nasty_results.parent / "report"
    (report / "events_x").mkdir(parents=True)  # where the old name led: out of the folder
    before = {p for p in root.rglob("*") if p.is_file()}
    assert main(["report", "--results", str(nasty_results), "--out", str(report)]) == 0
    written = {p for p in root.rglob("*") if p.is_file()} - before
    assert written and all(p.parent == report for p in written), sorted(written)
    assert len({p.name for p in report.glob("events_*.png")}) == len(NASTY_NAMES)
    text = (report / "report.md").read_text()
    assert "<script" not in text and "<img" not in text and "ESCAPED.png" not in text
    assert "&lt;script&gt;alert(1)&lt;/script&gt;" in text and "a\\|b" in text
    table: list[str] = []
    for line in [*text.splitlines(), ""]:
        if line.startswith("|"):
            table.append(line)
            continue
        if table:  # every row of a table has as many cells as its header
            assert {unescaped_pipes(row) for row in table} == {unescaped_pipes(table[0])}, table
        table = []


def test_escaping_turns_markup_into_text():
    from hoopbench.reports.report.escaping import escape_cell, escape_html, file_stem

    assert escape_cell("a|b\nc") == "a\\|b c"
    assert escape_cell("<img onerror=x>") == "&lt;img onerror=x&gt;"
    assert escape_cell("`*_x_*` [l](u) \\|") == "\\`\\*\\_x\\_\\*\\` \\[l\\](u) \\\\\\|"
    assert escape_cell("collision_bias") == "collision_bias"  # inside a word: no emphasis
    assert escape_html('<a href="x">') == "&lt;a href=&quot;x&quot;&gt;"
    assert file_stem("hop-top") == "hop-top"
    stems = {file_stem(n) for n in ("../x", "..\\x", "/x", "x", "X", "a b", "a-b", "a.b")}
    assert len(stems) == 8
    assert all(re.fullmatch(r"[A-Za-z0-9_-]+(\.[0-9a-f]{16})?", s) for s in stems)


def copy_of(results, tmp_path):
    import shutil

    return Path(shutil.copytree(results, tmp_path / "copy"))


def _empty_runs(folder):
    for part in (folder / "runs").glob("part-*"):
        part.unlink()


def _no_run_id(folder):
    import pandas as pd

    for part in (folder / "runs").glob("*.parquet"):
        pd.read_parquet(part).drop(columns="run_id").to_parquet(part)


def _catalogue_clash(folder):
    text = (folder / "suite.toml").read_text()
    (folder / "suite.toml").write_text(text.replace('"a|b"', '"hop-top"'))


MALFORMED = [
    # an empty report, exit 0
    (_empty_runs, "runs holds no runs"),
    (_no_run_id, "no run_id"),
    # the report drew the catalogue's hop-top for a scene of other parameters
    (_catalogue_clash, "the catalogue's scene of that name has other parameters"),
]


@pytest.mark.parametrize(("spoil", "names"), MALFORMED, ids=[f.__name__ for f, _ in MALFORMED])
def test_a_malformed_results_folder_is_one_line(spoil, names, nasty_results, tmp_path, capsys):
    folder = copy_of(nasty_results, tmp_path)
    spoil(folder)
    assert main(["report", "--results", str(folder), "--out", str(tmp_path / "r")]) == 2
    line = one_line(capsys)
    assert str(folder) in line and names in line
    assert not (tmp_path / "r" / "report.md").exists()


def test_the_same_runs_twice_are_refused(nasty_results, tmp_path, capsys):
    """--results R R counted every run twice; so did a copy of R beside it."""
    again = ["report", "--results", str(nasty_results), str(nasty_results) + "/."]
    assert main([*again, "--out", str(tmp_path / "r")]) == 2
    assert "names the folder" in one_line(capsys)
    folder = copy_of(nasty_results, tmp_path)
    assert main(["report", "--results", str(nasty_results), str(folder), "--out", "r"]) == 2
    assert f"hold {2 * len(NASTY_NAMES)} of the same runs" in one_line(capsys)


@pytest.fixture(scope="module")
def small_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("map") / "m"
    argv = ["map", "--grid", "2x2", "--engines", "pymunk", "--dt", "1e-3", "--t-end", "0.5"]
    assert main([*argv, "--out", str(out), "--quiet"]) == 0
    return out


def test_a_map_folder_without_its_spec_is_one_line(small_map, tmp_path, capsys):
    folder = copy_of(small_map, tmp_path)
    (folder / "map.toml").unlink()  # a KeyError traceback
    assert main(["report", "--results", str(folder), "--out", str(tmp_path / "r")]) == 2
    assert f"{folder / 'map.toml'} is missing" in one_line(capsys)
    (folder / "map.toml").write_text(
        (small_map / "map.toml").read_text().replace('engines = ["pymunk"]', "engines = 3")
    )
    assert main(["report", "--results", str(folder), "--out", str(tmp_path / "r")]) == 2
    assert "map.toml: engines must be a list, got 3" in one_line(capsys)  # a TypeError


# --------------------------------------------------------------------------- write errors
def full_disk(path) -> OSError:
    return OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


def test_a_full_disk_at_the_end_of_a_sweep_keeps_its_rows(monkeypatch, tmp_path, capsys):
    from hoopbench.reports.sweep import results

    suite = tmp_path / "s.toml"
    suite.write_text('name = "s"\nengines = ["reference"]\ntimesteps = [1e-3]\nscenes = ["seed"]\n')
    write_csv = results.write_csv
    monkeypatch.setattr(
        results, "write_csv", lambda frame, path: (_ for _ in ()).throw(full_disk(path))
    )
    out = tmp_path / "out"
    assert main(["compare", "--suite", str(suite), "--out", str(out), "--quiet"]) == 2
    line = one_line(capsys)
    assert f"cannot write '{out / 'runs.csv'}': No space left on device" in line
    assert "the runs stored before are kept" in line and "--resume" in line
    assert len(results.read_runs(out)) == 1  # the row is stored
    monkeypatch.setattr(results, "write_csv", write_csv)
    assert main(["compare", "--suite", str(suite), "--out", str(out), "--resume", "--quiet"]) == 0


def test_a_read_only_out_is_one_line(monkeypatch, tmp_path, capsys):
    """Simulated (CI may run as root, where a chmod does not stop a write)."""
    from pathlib import Path as RealPath

    target = tmp_path / "ro"
    mkdir = RealPath.mkdir

    def refuse(self, *args, **kwargs):
        if self == target:
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(self))
        return mkdir(self, *args, **kwargs)

    monkeypatch.setattr(RealPath, "mkdir", refuse)
    assert main(["compare", "--suite", "quick", "--out", str(target), "--quiet"]) == 2
    line = one_line(capsys)
    assert f"cannot write '{target}': Read-only file system; nothing was run" in line


def test_report_into_a_folder_it_cannot_write(monkeypatch, nasty_results, tmp_path, capsys):
    from pathlib import Path as RealPath

    target = tmp_path / "locked"
    mkdir = RealPath.mkdir

    def refuse(self, *args, **kwargs):
        if self == target:
            raise PermissionError(errno.EACCES, os.strerror(errno.EACCES), str(self))
        return mkdir(self, *args, **kwargs)

    monkeypatch.setattr(RealPath, "mkdir", refuse)
    assert main(["report", "--results", str(nasty_results), "--out", str(target)]) == 2
    line = one_line(capsys)
    assert f"cannot write '{target}': Permission denied" in line and "unchanged" in line


def test_a_full_disk_when_a_resumed_map_draws(monkeypatch, small_map, tmp_path, capsys):
    from hoopbench.reports.report import map_section

    folder = copy_of(small_map, tmp_path)

    def full(frame, out, prefix="map", **_):
        raise full_disk(Path(out) / f"{prefix}_regimes.png")

    monkeypatch.setattr(map_section, "write_map_figures", full)
    assert main(["map", "--out", str(folder), "--resume", "--quiet"]) == 2
    line = one_line(capsys)
    assert f"cannot write '{folder / 'map_regimes.png'}': No space left on device" in line
    assert "every run is stored" in line


@pytest.mark.parametrize("what", ["missing", "folder"])
def test_findings_update_needs_a_file(what, nasty_results, tmp_path, capsys):
    target = tmp_path / "README.md"
    if what == "folder":
        target.mkdir()
    assert main(["findings", "--results", str(nasty_results), "--update", str(target)]) == 2
    line = one_line(capsys)
    assert (
        str(target) in line and ("does not exist" if what == "missing" else "is a folder") in line
    )


def test_a_full_disk_keeps_the_readme(monkeypatch, nasty_results, tmp_path, capsys):
    from hoopbench.reports.report import findings

    readme = tmp_path / "README.md"
    body = f"x\n{findings.README_BEGIN}\nold\n{findings.README_END}\n"
    readme.write_text(body)
    monkeypatch.setattr(
        findings, "atomic_write", lambda path, write: (_ for _ in ()).throw(full_disk(path))
    )
    assert main(["findings", "--results", str(nasty_results), "--update", str(readme)]) == 2
    assert "is unchanged" in one_line(capsys)
    assert readme.read_text() == body


def test_a_worker_whose_parent_is_gone_ends_quietly():
    """A worker's reply to a killed parent raised BrokenPipeError, a traceback on stderr."""
    import multiprocessing

    from hoopbench.reports.sweep.runner import _reply

    mine, theirs = multiprocessing.Pipe()
    theirs.close()
    assert _reply(mine, b"row") is False


def test_output_into_a_closed_pipe_is_quiet(tmp_path):
    """`hoopbench scenes | head -0`: the reader is gone before the first write."""
    import subprocess
    import sys

    child = subprocess.Popen(
        [sys.executable, "-m", "hoopbench.reports.cli", "scenes"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert child.stdout is not None and child.stderr is not None
    child.stdout.close()  # long before the child has imported hoopbench and written
    err = child.stderr.read().decode()
    assert child.wait(timeout=60) == 141
    assert err == ""


# --------------------------------------------------------------------------- resuming
TINY = 'name = "tiny"\nengines = ["reference"]\ntimesteps = [1e-3]\nscenes = ["seed"]\n'


def test_a_resume_into_another_kind_of_sweep_or_another_suite_is_refused(tmp_path, capsys):
    """A resume used to append one suite's rows to a map or another suite's folder (and
    replace its meta.json). Now one line names what the folder holds; nothing changes."""
    suite = tmp_path / "tiny.toml"
    suite.write_text(TINY)
    suite_out, map_out = tmp_path / "suite", tmp_path / "map"
    assert main(["compare", "--suite", str(suite), "--out", str(suite_out), "--quiet"]) == 0
    assert main(["map", "--out", str(map_out), "--grid", "1x1", "--engines", "--quiet"]) == 0
    capsys.readouterr()
    before = {p: p.stat().st_mtime_ns for d in (suite_out, map_out) for p in d.rglob("*")}
    refused = [
        (["compare", "--suite", str(suite), "--out", str(map_out)], "holds a hop map, not suite"),
        (["compare", "--suite", "quick", "--out", str(suite_out)], "holds suite 'tiny', not suite"),
        (["map", "--out", str(suite_out)], "holds suite 'tiny', not a hop map"),
    ]
    for argv, message in refused:
        assert main([*argv, "--resume"]) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and message in err, err
    suite.write_text(TINY.replace('"seed"', '"seed", "seed-mu"'))  # the same name, edited
    assert main(["compare", "--suite", str(suite), "--out", str(suite_out), "--resume"]) == 2
    assert "from another suite file (suite_sha256 differ)" in capsys.readouterr().err
    after = {p: p.stat().st_mtime_ns for d in (suite_out, map_out) for p in d.rglob("*")}
    assert after == before


# --------------------------------------------------------------------------- large suites
def many_runs_suite(path, scenes: int, timesteps: int) -> str:
    """A suite of scenes x timesteps runs of the reference engine, written to ``path``."""
    steps = ", ".join(f"{1e-3 * (1 + i / 1000):.6g}" for i in range(timesteps))
    text = f'name = "many"\nengines = ["reference"]\ntimesteps = [{steps}]\n'
    for k in range(scenes):
        text += f'[[scene]]\nname = "s{k}"\nlam = {0.5 + k / 1e5}\nchi = 0.5\nmus = 0.8\n'
    path.write_text(text)
    return str(path)


def test_a_suite_over_the_limit_is_refused_with_its_count_before_it_is_expanded(
    tmp_path, capsys, deadline
):
    """A million runs used to be expanded and checked silently for two minutes (1.1 GB)."""
    suite = many_runs_suite(tmp_path / "many.toml", 1000, 1000)
    assert main(["compare", "--suite", suite, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "hoopbench: error: many.toml: the suite makes 1,000,000 runs, more than 100,000: "
        "split it into several suites (each its own results folder)"
    ]
    assert not (tmp_path / "out").exists()


def test_ctrl_c_while_a_large_suite_is_checked_is_one_line(tmp_path):
    """The run count first, then Ctrl-C in the checks: one line and exit 130 (a traceback)."""
    suite = many_runs_suite(tmp_path / "many.toml", 100, 1000)  # 100,000 runs: seconds of checks
    proc = subprocess.Popen(
        [sys.executable, "-m", "hoopbench.reports.cli", "compare", "--suite", suite,
         "--out", str(tmp_path / "out")],
        stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        first = proc.stderr.readline()
        assert first == "hoopbench: suite many: 100,000 runs; checking each run's settings first\n"
        proc.send_signal(signal.SIGINT)
        _, rest = proc.communicate(timeout=60)
    finally:
        proc.kill()
    assert proc.returncode == 130, rest
    assert rest.strip().splitlines() == ["hoopbench: interrupted (Ctrl-C) before anything ran"]
    assert not (tmp_path / "out").exists()


def test_a_library_error_of_several_lines_is_one_line(monkeypatch, capsys):
    """A library's ValueError may start with a newline and draw a caret diagram (matplotlib's
    mathtext did): the command still prints one line holding the message."""
    from hoopbench.reports import cli

    def broken(args):
        raise ValueError("\n\\frac\n     ^\nParseSyntaxException: Expected \\frac{num}{den}")

    monkeypatch.setattr(cli, "_cmd_settings", broken)
    assert main(["settings"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "ParseSyntaxException" in err[0], err
