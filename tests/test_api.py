"""hoopbench as a Python library (reports/api.py): a light import, scenes, exact solutions,
one run whose row is a suite's row, suites, maps and reports, and the command line's checks."""

from __future__ import annotations

import dataclasses
import math
import re
import subprocess
import sys
import textwrap

import numpy as np
import pandas as pd
import pytest

import hoopbench as hb
from hoopbench.engines.judging.columns import COST_COLUMNS
from hoopbench.models.catalogue import get_scene
from hoopbench.reference.exact import solve_exact
from hoopbench.reports import api
from hoopbench.reports.hop_map.spec import MAP_FILE, Axis, MapSpec
from hoopbench.reports.sweep.runner import RunnerError

TINY_SUITE = """\
name = "tiny"
engines = ["reference", "pymunk"]
timesteps = [1e-3]
scenes = ["hop-top"]

[[variant]]
engine = "pymunk"
name = "it20"
options = { iterations = 20 }
"""


def test_import_is_light_until_an_attribute_is_used():
    """`import hoopbench` loads none of numpy, pandas or the engines; `hb.scene` loads the API."""
    code = textwrap.dedent(
        """
        import sys
        import hoopbench as hb
        heavy = ("numpy", "pandas", "scipy", "hoopbench.engines", "hoopbench.reports")
        print(sorted(m for m in sys.modules if m.startswith(heavy)))
        hb.scene
        print("hoopbench.reports.api" in sys.modules, "pandas" in sys.modules)
        """
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.splitlines()
    assert out == ["[]", "True True"]


def test_the_package_lists_the_api():
    assert {"scene", "exact", "run", "compare", "map", "hop_map", "report"} <= set(dir(hb))
    assert hb.map is hb.hop_map is api.hop_map
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        hb.nope  # noqa: B018 - the lookup is the test


# --------------------------------------------------------------------------- scenes
def test_scene_from_the_catalogue_and_from_parameters():
    assert hb.scene("hop-top") == get_scene("hop-top")
    assert hb.scene("seed", mus=0.9).mus == 0.9
    made = hb.scene(lam=0.9, chi=1.2, mus=0.5, theta0_deg=90)
    assert (made.lam, made.muk, made.theta0) == (0.9, 0.5, pytest.approx(math.pi / 2))
    assert made.chi == pytest.approx(1.2)
    # A catalogue scene with another a keeps its chi: the scene stays dimensionless.
    assert hb.scene("hop-top", a=2.0).chi == pytest.approx(get_scene("hop-top").chi)


@pytest.mark.parametrize(
    ("name", "params", "message"),
    [
        (
            None,
            dict(lam=0.9),
            "give a catalogue scene name or the scene parameters; missing: mus, chi or thetadot0",
        ),
        (None, dict(lam=0.9, mus=0.5, chi=1.0, thetadot0=3.0), "give chi or thetadot0, not both"),
        ("nope", {}, "name must be a catalogue scene"),
        (None, dict(lam=1.5, chi=0.1, mus=0.8), "lam must be in [0, 1], got 1.5"),
    ],
)
def test_bad_scene_names_the_value(name, params, message):
    with pytest.raises(ValueError, match=f"^{_literal(message)}"):
        hb.scene(name, **params)


def test_exact_takes_a_scene_or_its_name():
    assert hb.exact("seed").events == solve_exact(get_scene("seed")).events


# --------------------------------------------------------------------------- one run
def test_run_gives_a_trajectory_frame_and_the_suite_row():
    run = hb.run("pymunk", "hop-top", timestep=1e-3)
    assert isinstance(run.trajectory, pd.DataFrame)
    assert {"t", "X", "Y", "theta", "clearance", "energy"} <= set(run.trajectory.columns)
    assert run.trajectory["t"].iloc[0] == 0.0 and len(run.trajectory) > 100
    assert run.status == "ok" and run.events is not None
    assert run.verdict == run.row["verdict"] != "failed"
    assert run.row["engine"] == "pymunk" and run.row["variant"] == "default"
    assert run.row["exact_outcome"] == "hops"
    assert repr(run).startswith("EngineRun(pymunk on hop-top, dt=0.001 s, tuned, default: ok")
    with pytest.raises(dataclasses.FrozenInstanceError):
        run.row = {}  # type: ignore[misc]


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(engine="ode"), "unknown engine 'ode'"),
        (dict(options={"nope": 1}), "unknown pymunk setting(s) nope"),
        (dict(timestep=0), "timestep must be a number > 0 s, got 0"),
        (dict(timestep=10), "longer than"),
        (dict(profile="best"), "profile must be one of tuned, stock, got 'best'"),
        (dict(options={"iterations": 20}, variant="default"), "variant 'default' is the engine's"),
    ],
)
def test_bad_run_settings_raise_before_the_run(kwargs, message):
    kwargs = {"engine": "pymunk", "timestep": 1e-3, **kwargs}
    with pytest.raises(ValueError, match=_literal(message)):
        hb.run(kwargs.pop("engine"), "hop-top", **kwargs)


@pytest.mark.slow
def test_run_rows_are_the_rows_a_suite_stores(tmp_path):
    """The same run through hb.run and through a suite: the same run_id and the same row."""
    suite = tmp_path / "tiny.toml"
    suite.write_text(TINY_SUITE)
    stored = hb.compare(suite, tmp_path / "out", jobs=1, quiet=True).set_index("run_id")
    assert len(stored) == 3  # reference, pymunk default, pymunk it20
    runs = [
        hb.run("reference", "hop-top", timestep=1e-3),
        hb.run("pymunk", "hop-top", timestep=1e-3),
        hb.run("pymunk", "hop-top", timestep=1e-3, options={"iterations": 20}, variant="it20"),
    ]
    assert list(stored.index) == [run.row["run_id"] for run in runs]  # in the suite's order
    for run in runs:
        row = stored.loc[run.row["run_id"]]
        for key, value in run.row.items():
            if key == "run_id" or key in COST_COLUMNS:
                continue  # the index, and the clock
            assert _same(row[key], value), (run.task.label, key, row[key], value)


def _same(a, b) -> bool:
    missing = [x is None or (isinstance(x, float) and math.isnan(x)) for x in (a, b)]
    if any(missing):
        return all(missing)
    return a == b


# --------------------------------------------------------------------------- suites
@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(run_timeout=0), "run_timeout must be > 0 s, got 0"),
        (dict(jobs=0), "jobs must be >= 1, got 0"),
        (dict(jobs=10_000), "jobs must be at most"),
        (dict(trajectories="some"), "trajectories must be one of none, default, all, got 'some'"),
        (dict(engines=["drake"]), "engine(s) drake not in suite 'quick'"),
        (dict(suite="nope"), "no shipped suite 'nope'"),
    ],
)
def test_bad_compare_options_raise_before_anything_runs(tmp_path, kwargs, message):
    out = tmp_path / "out"
    kwargs = {"suite": "quick", **kwargs}
    with pytest.raises(ValueError, match=_literal(message)):
        hb.compare(kwargs.pop("suite"), out, **kwargs)
    assert not out.exists()


def test_the_runs_table_is_in_the_suite_order(tmp_path):
    suite = tmp_path / "tiny.toml"
    suite.write_text(TINY_SUITE)
    ids = [task.run_id for task in api.suite_job(suite).suite.tasks()]
    stored = pd.DataFrame({"run_id": ["elsewhere", *reversed(ids)]})  # as the runs finished
    ordered = api._in_suite_order(stored, api.suite_job(suite).suite)
    assert list(ordered["run_id"]) == [*ids, "elsewhere"]


def test_compare_refuses_a_folder_that_holds_files(tmp_path):
    (tmp_path / "note.txt").write_text("mine")
    with pytest.raises(RunnerError, match="is not empty"):
        hb.compare("quick", tmp_path, quiet=True)


# --------------------------------------------------------------------------- hop map
def test_map_spec_on_resume_takes_the_stored_map(tmp_path):
    stored = MapSpec(x=Axis.LAM, y=Axis.MU, nx=3, ny=2, engines=("pymunk",), timestep=1e-3)
    (tmp_path / MAP_FILE).write_text(stored.to_toml())
    assert api.map_spec(tmp_path, resume=True) == stored
    assert api.map_spec(tmp_path, resume=True, grid="4x2").nx == 4
    # Another y axis takes its own range, and mu (no longer an axis) its default value.
    moved = api.map_spec(tmp_path, resume=True, y="chi")
    assert (moved.y, moved.y_range, moved.fixed_values["mu"]) == ("chi", (0.05, 2.0), 0.8)
    assert api.map_spec(tmp_path, grid=(4, 2)) == MapSpec(nx=4, ny=2)  # a new map: no stored one
    assert api.check_grid((np.int64(3), 2)) == (3, 2) == api.check_grid("3X2")


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (dict(grid="0x3"), "grid must be NXxNY, whole numbers >= 1, got '0x3'"),
        (dict(grid=(3, 2.5)), "grid must be NXxNY, whole numbers >= 1, got (3, 2.5)"),
        (dict(x="g"), "x must be one of lam, chi, mu, eps, theta0_deg, got 'g'"),
        (dict(engines="pymunk"), "engines must be a list of engine names, got 'pymunk'"),
        (dict(fixed={"mu": -1}), "mu must be a number >= 0, got -1"),
        (dict(jobs=0), "jobs must be >= 1, got 0"),
    ],
)
def test_bad_map_options_raise_before_anything_runs(tmp_path, kwargs, message):
    out = tmp_path / "map"
    with pytest.raises(ValueError, match=_literal(message)):
        hb.map(out, **kwargs)
    assert not out.exists()


def test_a_broken_stored_map_names_the_file(tmp_path):
    (tmp_path / MAP_FILE).write_text("x = [")
    with pytest.raises(api.OptionError, match=f"^resume: {_literal(str(tmp_path / MAP_FILE))}: "):
        hb.map(tmp_path, resume=True)


@pytest.mark.slow
def test_a_tiny_map_its_resume_and_its_report(tmp_path):
    out = tmp_path / "map"
    options = dict(grid=(2, 1), x_range=(0.7, 0.9), engines=["pymunk"], timestep=1e-3, jobs=1)
    table = hb.map(out, **options, quiet=True)
    assert list(table["engine"]) == ["reference", "pymunk"] * 2
    assert set(table["status"]) == {"ok"}
    again = hb.map(out, resume=True, quiet=True)  # nothing left: the same table
    pd.testing.assert_frame_equal(again, table)
    path = hb.report(out)
    assert path == out / "report.md" and "## Hop map" in path.read_text()
    with pytest.raises(ValueError, match=r"report\.md' exists; pass force=True to replace it"):
        hb.report(out)
    assert hb.report(out, force=True) == path


def test_report_needs_results(tmp_path):
    with pytest.raises(ValueError, match=r"^results '.*nowhere' holds no results \(no runs/"):
        hb.report(tmp_path / "nowhere")
    (tmp_path / "runs").mkdir()
    (tmp_path / "file").write_text("")
    with pytest.raises(ValueError, match=r"^out '.*file' is a file, not a folder"):
        hb.report(tmp_path, tmp_path / "file")


def _literal(text: str) -> str:
    """A message as a regular expression that matches it literally."""
    return re.escape(text)
