"""The hop map (reports/hop_map/, `hoopbench map`): the spec and its file, the two stages into
one runs dataset, rows as compare builds them, resume after an interruption in either stage,
the agreement table, and the command line's answers to bad input.

The maps here are tiny (3 x 2 points, pymunk at dt = 1e-3 over a 1 s window), so that each
test takes seconds; the points still cover rolls, a hop, lifts-at-start and the I = 0 column.
"""

from __future__ import annotations

import json
import math
import pickle
import signal
from concurrent.futures import Executor, Future, ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.judging.columns import COST_COLUMNS, FORCE_COLUMNS
from hoopbench.engines.judging.comparison import event_columns, floor_columns, kin_columns
from hoopbench.engines.registry import get_engine
from hoopbench.engines.settings import RunSettings
from hoopbench.models.scene import Scene
from hoopbench.reference.exact import first_flight_impact, solve_exact
from hoopbench.reference.regimes import classify
from hoopbench.reports.cli import main
from hoopbench.reports.hop_map.display import (
    DISPLAY_COLUMNS,
    DISPLAY_SAMPLES,
    thinned,
    write_display,
)
from hoopbench.reports.hop_map.spec import (
    AXES,
    DEFAULT_ENGINES,
    ENGINE_TIMESTEPS,
    MAP_FILE,
    REFERENCE,
    Axis,
    MapSpec,
    MapSpecMismatchError,
    load_spec,
)
from hoopbench.reports.hop_map.stages import (
    MAP_COLUMNS,
    _stage_two_tasks,
    classified_tasks,
    planned_tasks,
    reference_tasks,
    run_map,
    run_map_task,
)
from hoopbench.reports.hop_map.table import agreement_table, map_frame
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.runner import OutputDirNotEmptyError, RunnerError

TINY = MapSpec(nx=3, ny=2, engines=("pymunk",), timestep=1e-3, t_end=1.0, x_range=(0.5, 1.0))
"""lam 0.5, 0.75, 1 x chi 0.05, 2: rolls at chi 0.05, a hop (lam 0.5, chi 2), lifts-at-start
(lam chi > 1), and lam = 1 with eps = 0, where I = 0 and no engine can build the body (the
default lam range stops below 1: given here)."""
TINY_ARGS = [
    *("--grid", "3x2", "--engines", "pymunk", "--dt", "1e-3", "--t-end", "1"),
    *("--x-range", "0.5", "1"),
]
TIMING = [*results.TIMING_COLUMNS, *COST_COLUMNS]


def comparable(frame: pd.DataFrame) -> pd.DataFrame:
    """A map frame without the columns that differ from run to run."""
    return frame.drop(columns=[c for c in TIMING if c in frame.columns])


class InterruptAt(Executor):
    """Threads that raise SIGINT in this process at the n-th submission: the runner stops
    the sweep there as it would on Ctrl-C, deterministically."""

    def __init__(self, n: int) -> None:
        self.inner = ThreadPoolExecutor(2)
        self.n, self.count = n, 0
        self.max_workers = 2

    def submit(self, fn, /, *args, **kwargs) -> Future:
        self.count += 1
        if self.count == self.n:
            signal.raise_signal(signal.SIGINT)
        return self.inner.submit(fn, *args, **kwargs)

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self.inner.shutdown(wait, cancel_futures=cancel_futures)


def run_tiny(out: Path, **kwargs):
    with ThreadPoolExecutor(2) as pool:
        return run_map(TINY, out, executor=pool, quiet=True, **kwargs)


@pytest.fixture(scope="module")
def tiny(tmp_path_factory) -> Path:
    """The tiny map, run once for the tests that only read it."""
    out = tmp_path_factory.mktemp("tiny") / "map"
    summary = run_tiny(out)
    assert summary.completed and summary.unfinished == 0
    return out


# ------------------------------------------------------------------ the spec
def test_the_default_lam_range_stops_below_the_massless_ring():
    """lam = 1 (eps = 0) has I = 0, which no engine can build: a default map would fill a
    column with errors."""
    low, high = AXES[Axis.LAM].default_range
    assert low < high < 1.0
    assert max(MapSpec(nx=10).axis_values(Axis.LAM)) < 1.0


def test_classified_tasks_carry_what_stage_two_reads(tiny):
    """eta_replay costs the map's engine runs by classified_tasks: the same tasks, with the
    same exact columns (so the same expected steps), as stage 2 builds from the stored
    reference rows."""
    stage_two, _ = _stage_two_tasks(TINY, tiny, str(tiny))
    stored = {t.run_id: t for t in stage_two if t.engine != REFERENCE}
    classified = classified_tasks(TINY)
    assert [t.run_id for t in classified] == list(stored)
    assert all(t.exact and t.exact == stored[t.run_id].exact for t in classified)
    assert [t.expected_steps for t in classified] == [t.expected_steps for t in stored.values()]


def test_a_point_that_leaves_the_floor_at_once_is_planned_to_stop_at_its_landing():
    """Before stage 1 the map's runs are costed without the exact columns: a point whose hoop
    leaves the floor at t = 0 is expected to stop at its ballistic landing, as its
    classification then says (the default map: 31 of 100 points, planned at 0.74 of their
    windows in all, classified at 0.57; by window, 1.0); any other point at its window."""
    spec = MapSpec(nx=4, ny=4, engines=("pymunk",))
    _, planned = planned_tasks(spec)
    classified = {t.run_id: t for t in classified_tasks(spec)}
    at_once = [t for t in planned if first_flight_impact(t.point.scene()) is not None]
    assert 0 < len(at_once) < len(planned)
    for task in planned:
        if task in at_once:
            assert task.expected_steps == classified[task.run_id].expected_steps < task.n_steps
        else:
            assert task.expected_steps == task.n_steps


def test_defaults_come_from_the_axes_table():
    spec = MapSpec()
    assert (spec.x, spec.y) == (Axis.LAM, Axis.CHI)
    assert spec.x_range == AXES[Axis.LAM].default_range
    assert spec.y_range == AXES[Axis.CHI].default_range
    assert spec.fixed_values == {a: AXES[Axis(a)].fixed for a in ("mu", "eps", "theta0_deg")}
    assert all(info.reason for info in AXES.values())
    assert set(AXES) == set(Axis)


def test_toml_round_trip(tmp_path):
    spec = MapSpec(
        x="mu",
        y="theta0_deg",
        x_range=(0.1, 1.0 / 3.0),
        y_range=(-90, 270.5),
        nx=4,
        ny=1,
        fixed={"lam": 0.95, "eps": 1e-5},
        t_end=0.7,
        engines=("pymunk", "mujoco"),
        timestep=2.5e-4,
        profile="stock",
    )
    assert MapSpec.from_toml(spec.to_toml()) == spec
    (tmp_path / MAP_FILE).write_text(spec.to_toml())
    loaded = load_spec(tmp_path)
    assert loaded == spec and loaded.fixed_values == {"lam": 0.95, "chi": 0.5, "eps": 1e-5}
    assert loaded.x_range == (0.1, 1.0 / 3.0)  # floats read back exactly


BAD_SPECS = [
    (dict(x="foo"), "x must be one of lam, chi, mu, eps, theta0_deg, got 'foo'"),
    (dict(x="chi", y="chi"), "x and y are both chi"),
    (dict(nx=0), "nx must be an integer in [1, 999], got 0"),
    (dict(ny=2.5), "ny must be an integer in [1, 999], got 2.5"),
    (dict(nx=999, ny=999, engines=()), "the map makes 998,001 runs (999 x 999 points, the"),
    (dict(nx=300, ny=300), "more than 100,000: use a coarser grid or fewer engines"),
    (dict(x_range=(0.5, 1.5)), "x_range of lam must be a number in [0, 1], got 1.5"),
    (dict(y_range=(1.0, 0.5)), "y_range of chi must have low < high, got [1, 0.5]"),
    (dict(y_range=(1.0, 1.0)), "low < high"),
    (dict(x_range=(0.5,)), "x_range must be two numbers (low, high), got (0.5,)"),
    (dict(x_range=(0.5, math.nan)), "got nan"),
    (dict(fixed={"lam": 0.9}), "lam = 0.9 is fixed, but lam is the x axis"),
    (dict(fixed={"g": 9.8}), "fixed parameter must be one of lam, chi, mu, eps, theta0_deg"),
    (dict(fixed={"mu": -0.1}), "mu must be a number >= 0, got -0.1"),
    (dict(fixed={"theta0_deg": 400}), "theta0_deg must be a number in [-360, 360] deg"),
    (dict(t_end=0), "t_end must be a number > 0 s, got 0"),
    (dict(timestep=0), "timestep must be a number > 0 s, got 0"),
    (dict(timestep=5.0), "timestep 5 s is longer than the window t_end = 3 s"),
    (dict(timestep=1e-9), "the run needs 3e+09 steps"),
    (dict(engines=("nope",)), "unknown engine 'nope' for a map"),
    (dict(engines=("reference",)), "unknown engine 'reference' for a map"),
    (dict(engines="pymunk"), "engines must be a list of engine names, got 'pymunk'"),
    (dict(engines=("pymunk", "pymunk")), "engine 'pymunk' is given twice"),
    (dict(profile="best"), "profile must be one of tuned, stock, got 'best'"),
    (
        dict(engines=("pymunk",), engine_timesteps={"mjx": 1e-3}),
        "engine_timesteps gives 'mjx' a step, but 'mjx' is not one of the map's engines",
    ),
    (dict(engine_timesteps={"mjx": 0}), "engine_timesteps[mjx] must be a number > 0 s, got 0"),
    (dict(engine_timesteps={"mjx": 5.0}), "engine_timesteps[mjx]: timestep 5 s is longer than the"),
    (dict(engine_timesteps=[1e-3]), "engine_timesteps must map engine names to steps"),
]


@pytest.mark.parametrize(("kwargs", "message"), BAD_SPECS)
def test_a_bad_spec_is_refused_by_name(kwargs, message):
    with pytest.raises(ValueError) as info:
        MapSpec(**kwargs)
    assert message in str(info.value)


def test_the_default_map_runs_the_batched_engines_at_their_own_step():
    """MJX and Newton are in the default map at the suites' 1e-3 s (at 1e-4 s they cost too
    much: docs/map.md, Cost); the others at the map's timestep; MuJoCo Warp keeps its own
    step when given."""
    spec = MapSpec()
    assert spec.engines == DEFAULT_ENGINES == ("mujoco", "pybullet", "pymunk", "mjx", "newton")
    assert dict(spec.engine_timesteps) == {"mjx": 1e-3, "newton": 1e-3}
    assert dict(ENGINE_TIMESTEPS) == {"mjx": 1e-3, "mjwarp": 1e-3, "newton": 1e-3}
    assert [spec.timestep_of(e) for e in spec.engines] == [1e-4] * 3 + [1e-3] * 2
    assert MapSpec(engines=("mjwarp",)).timestep_of("mjwarp") == 1e-3
    # only the map's engines keep their own step; --dt moves the others alone
    spec = MapSpec(engines=("mujoco", "newton"), timestep=2e-4)
    assert spec.engine_timesteps == (("newton", 1e-3),)
    assert (spec.timestep_of("mujoco"), spec.timestep_of("newton")) == (2e-4, 1e-3)
    # given steps replace the default ones: none at all runs every engine at `timestep`
    assert MapSpec(engines=("mjx",), engine_timesteps={}).timestep_of("mjx") == 1e-4


def test_engine_steps_round_trip_and_old_files_have_none(tmp_path):
    spec = MapSpec(engines=("pymunk", "mjx"), engine_timesteps={"pymunk": 5e-4, "mjx": 2e-3})
    text = spec.to_toml()
    assert "[engine_timesteps]" in text and MapSpec.from_toml(text) == spec
    assert spec.engine_timesteps == (("mjx", 2e-3), ("pymunk", 5e-4))
    # a map.toml written before engines had own steps ran every engine at its timestep
    old = text.split("\n[engine_timesteps]")[0]
    loaded = MapSpec.from_toml(old)
    assert loaded.engine_timesteps == () and loaded.timestep_of("mjx") == 1e-4


def test_given_engine_steps_go_over_the_default_ones(tmp_path):
    import hoopbench.reports.api as api

    spec = api.map_spec(tmp_path / "new", engine_timesteps={"mjx": 2e-4})
    assert dict(spec.engine_timesteps) == {"mjx": 2e-4, "newton": 1e-3}
    spec = api.map_spec(tmp_path / "new", engines=["pymunk"], engine_timesteps={"pymunk": 5e-4})
    assert spec.engine_timesteps == (("pymunk", 5e-4),)


def test_an_engine_with_its_own_step_runs_at_it(tmp_path):
    """Rows and tasks carry each engine's own step: the map's runs, not just its file."""
    spec = MapSpec(
        nx=1, ny=2, engines=("pymunk", "pybullet"), timestep=1e-3, t_end=0.5,
        engine_timesteps={"pybullet": 5e-4},
    )  # fmt: skip
    with ThreadPoolExecutor(2) as pool:
        assert run_map(spec, tmp_path / "m", executor=pool, quiet=True).completed
    frame = map_frame(tmp_path / "m")
    steps = frame[frame["engine"] != REFERENCE].groupby("engine")["timestep"].unique()
    assert steps.map(list).to_dict() == {"pybullet": [5e-4], "pymunk": [1e-3]}
    assert (frame.loc[frame["engine"] == "pybullet", "n_steps"] > 500).all()


def test_a_bad_map_file_is_refused():
    text = MapSpec().to_toml()
    with pytest.raises(ValueError, match="unknown map key"):
        MapSpec.from_toml(text.replace("nx =", "n_x ="))
    with pytest.raises(ValueError, match="format_version 99 is not 1"):
        MapSpec.from_toml(text.replace("format_version = 1", "format_version = 99"))
    with pytest.raises(ValueError, match="not valid TOML"):
        MapSpec.from_toml("x = ")


def test_points_and_their_scenes():
    spec = MapSpec(
        x="theta0_deg", y="mu", x_range=(0, 180), y_range=(0.2, 0.6), nx=3, ny=2, fixed={"chi": 1}
    )
    points = spec.points()
    assert [(p.ix, p.iy) for p in points] == [(i, j) for i in range(3) for j in range(2)]
    assert [p.x for p in points[::2]] == [0.0, 90.0, 180.0]  # both ends included
    assert [p.y for p in points[:2]] == [0.2, 0.6]
    scene = points[-1].scene()
    assert scene == Scene.from_chi(1.0, lam=0.8, mus=0.6, muk=0.6, theta0=math.pi, t_end=3.0)
    ids = [t.run_id for t in reference_tasks(spec)]
    assert ids[:2] == ["r000-000-reference", "r000-001-reference"]
    assert ids == sorted(ids) and len(set(ids)) == len(ids)


def test_tasks_are_small_and_pickle():
    task = reference_tasks(TINY)[0]
    assert pickle.loads(pickle.dumps(task)) == task
    assert len(pickle.dumps(task)) < 2000
    assert pickle.loads(pickle.dumps(run_map_task)) is run_map_task  # importable by name


def test_a_display_file_is_the_bytes_pandas_writes_of_its_curves(tmp_path):
    """write_display writes with pyarrow alone, a schema made once: the file must still be
    what pandas' to_parquet writes of the thinned curves (its metadata included)."""
    solution = solve_exact(Scene.from_chi(2.0, lam=0.5, mus=0.8, muk=0.8, t_end=1.0))
    trajectory = solution.sample(np.linspace(0.0, solution.t_final, 1000))
    path = write_display(trajectory, tmp_path, "run")
    kept = thinned(trajectory)
    frame = pd.DataFrame({c: getattr(kept, c).astype(np.float32) for c in DISPLAY_COLUMNS})
    frame.to_parquet(tmp_path / "pandas.parquet", index=False)
    assert path.read_bytes() == (tmp_path / "pandas.parquet").read_bytes()
    assert len(pd.read_parquet(path)) == DISPLAY_SAMPLES


# ------------------------------------------------------------------ the rows
def test_the_map_has_a_row_per_point_and_engine(tiny):
    frame = map_frame(tiny)
    assert list(frame.columns[: len(MAP_COLUMNS)]) == list(MAP_COLUMNS)
    assert len(frame) == 12 and frame["run_id"].is_unique
    assert list(frame["engine"]) == [REFERENCE, "pymunk"] * 6
    assert list(frame["run_id"][:2]) == ["r000-000-reference", "r000-000-pymunk"]
    assert set(frame["regime"]) == {"rolls", "hops", "lifts-at-start"}
    refs = frame[frame["engine"] == REFERENCE]
    assert (refs["status"] == "ok").all() and refs["outcome"].isna().all()
    csv = pd.read_csv(tiny / results.CSV_NAME)
    assert sorted(csv["run_id"]) == sorted(frame["run_id"])  # both stages in runs.csv
    assert list(csv["run_id"][:2]) == ["r000-000-reference", "r000-000-pymunk"]
    meta = json.loads((tiny / results.META_NAME).read_text())
    assert meta["runs"] == 12 and meta["resumed"] is False
    session = meta["session"]
    assert {k: session[k] for k in ("ran", "skipped")} == {"ran": 12, "skipped": 0}
    for load in (session["load_average_start"], session["load_average_end"]):  # 1, 5, 15 min
        assert len(load) == 3 and all(x >= 0 for x in load)
    assert MapSpec.from_dict(meta["map"]) == TINY


def test_the_reference_row_is_the_classification(tiny):
    frame = map_frame(tiny)
    for row in frame[frame["engine"] == REFERENCE].to_dict("records"):
        point = next(p for p in TINY.points() if (p.ix, p.iy) == (row["ix"], row["iy"]))
        exact = classify(point.scene())
        assert row["regime"] == exact.regime, row["run_id"]
        assert row["n_slips"] == exact.n_slips
        assert row["exact_outcome"] == exact.events.outcome
        assert row["exact_phases"] == exact.events.phase_code
        t_lift = row["exact_t_lift"]
        assert (exact.events.t_lift is None) == (t_lift is None or math.isnan(t_lift))


TINY_VERDICTS = {
    "r000-000-pymunk": ("agrees", True),  # rolls, as the exact solution does
    "r000-001-pymunk": ("close", True),  # see below
    "r001-000-pymunk": ("agrees", True),  # rolls by its contact force: see below
    "r001-001-pymunk": ("agrees", True),  # leaves the floor at once, as the exact does
}
"""(verdict, outcome_agrees) of the tiny map's judged rows, read off their events and
contact forces by hand. The hop at lam 0.5, chi 2 lifts off 0.92 s into the 1 s window and
is cut there (3 mm high) while the exact hop, 0.17 m, lands at 1.53 s: its lift-off, 3.9 ms
late, is within the loose tolerance (close, not tight) and its height cannot be told (it was
'missed-hop' when a cut flight was judged as a finished one). At lam 0.5, chi 0.05 pymunk's
slip velocity spikes again and again, each spike on a step without contact force: no slip by
the contact (it was 'false-slip')."""


def test_an_engine_row_carries_its_verdict_and_its_points_exact_answer(tiny):
    frame = map_frame(tiny)
    runs = frame[(frame["engine"] != REFERENCE) & (frame["lam"] < 1)]
    assert (runs["status"] == "ok").all()
    stored = {row["run_id"]: (row["verdict"], row["outcome_agrees"]) for _, row in runs.iterrows()}
    reasons = {row["run_id"]: row["verdict_reason"] for _, row in runs.iterrows()}
    assert stored == TINY_VERDICTS, reasons
    for row in runs.to_dict("records"):
        point = next(p for p in TINY.points() if (p.ix, p.iy) == (row["ix"], row["iy"]))
        exact = classify(point.scene()).events
        assert (row["exact_outcome"], row["exact_phases"]) == (exact.outcome, exact.phase_code)
    assert set(runs["stop_reason"].dropna()) <= {"impact", "settled"}
    landed = runs[runs["t_impact"].notna()]
    assert len(landed) >= 1 and (landed["stop_reason"] == "impact").all()


def test_an_engine_row_carries_its_contact_force_against_the_exact_one(tiny):
    """Map rows have the suite's force columns (issue 17's force truth), computed against
    the point's exact solution: a run whose exact motion starts on the floor has a finite RMS
    force error; one that lifts off at t = 0 has no contact phase to compare."""
    frame = map_frame(tiny)
    runs = frame[(frame["engine"] != REFERENCE) & (frame["status"] == "ok")]
    for column in (*FORCE_COLUMNS, "rms_position_m"):
        assert column in frame.columns, column
    in_contact = runs["exact_phases"].str[0] != "F"
    assert in_contact.sum() >= 3 and (~in_contact).sum() >= 1
    assert np.isfinite(runs["force_rms_n_g"][in_contact].astype(float)).all()
    assert runs["force_rms_n_g"][~in_contact].isna().all()
    assert runs["rms_position_m"].notna().all()


def test_a_scene_without_inertia_gets_a_row_and_no_verdict(tiny):
    frame = map_frame(tiny)
    runs = frame[(frame["engine"] != REFERENCE) & (frame["lam"] == 1)]
    assert len(runs) == 2
    assert (runs["status"] == "error").all()
    assert runs["message"].str.startswith("not run: ").all()
    assert runs["message"].str.contains("I = 0").all()
    assert runs["verdict"].isna().all() and runs["outcome_agrees"].isna().all()


def test_the_hop_height_error_is_engine_minus_exact_where_both_hop(tiny):
    frame = map_frame(tiny)
    runs = frame[frame["engine"] != REFERENCE]
    both = runs["outcome"].isin(["hops", "lifts-at-start"]) & runs["exact_outcome"].isin(
        ["hops", "lifts-at-start"]
    )
    assert both.sum() >= 2
    expected = runs["hop_height"] - runs["exact_hop_height"]
    np.testing.assert_allclose(runs["hop_height_error"][both], expected[both], rtol=1e-12)
    assert runs["hop_height_error"][~both].isna().all()


def test_no_hop_height_error_where_the_run_is_not_judged():
    """An exact hop below the hop threshold (lam chi just above 1) has no verdict, and its
    hop-height ratio (up to 7e5 on a 40x40 map) must not reach the figures and findings."""
    from hoopbench.reports.hop_map.stages import _hop_height_error

    row = {
        "outcome": "hops",
        "hop_height": 1.5,
        "max_clearance": 1.5,
        "exact_outcome": "lifts-at-start",
        "exact_hop_height": 7e-5,
        "verdict": None,
    }
    assert _hop_height_error(row) is None
    assert _hop_height_error({**row, "verdict": "missed-hop"}) == pytest.approx(1.5 - 7e-5)


def test_every_event_column_of_compare_is_a_map_column():
    scene = Scene.from_chi(2.0, lam=0.5, mus=0.8, muk=0.8, t_end=1.0)
    result = get_engine("pymunk").run(scene, RunSettings(timestep=1e-3))
    exact = dict.fromkeys(c for c in MAP_COLUMNS if c.startswith("exact_"))
    columns = event_columns(result.trajectory, scene, scene.mus, exact)
    columns |= kin_columns(result.events, exact) | floor_columns(scene, scene.mus, 1e-3)
    assert set(columns) <= set(MAP_COLUMNS), set(columns) - set(MAP_COLUMNS)


# ------------------------------------------------------------------ folder and resume
@pytest.mark.parametrize(("n", "stage"), [(3, 1), (9, 2)])
def test_a_resumed_map_equals_the_uninterrupted_one(tiny, tmp_path, n, stage):
    out = tmp_path / "map"
    executor = InterruptAt(n)
    try:
        cut = run_map(TINY, out, executor=executor, quiet=True)
    finally:
        executor.shutdown()
    assert cut.interrupted is signal.SIGINT and cut.unfinished > 0
    stored = results.read_runs(out)
    assert not (out / results.CSV_NAME).exists()  # written only when the map is done
    engines_stored = (stored["engine"] != REFERENCE).sum()
    if stage == 1:
        assert engines_stored == 0 and len(stored) < 6
    else:
        assert (stored["engine"] == REFERENCE).sum() == 6 and 0 < engines_stored < 6
    before = dict(zip(stored["run_id"], stored["seq"], strict=True))

    done = run_tiny(out, resume=True)
    assert done.completed and done.unfinished == 0 and done.skipped == len(before)
    every = results.read_runs(out, latest=False)
    assert every["run_id"].is_unique  # no stored run was run again
    assert all(every.set_index("run_id")["seq"][k] == v for k, v in before.items())
    pd.testing.assert_frame_equal(comparable(map_frame(out)), comparable(map_frame(tiny)))
    csv = pd.read_csv(out / results.CSV_NAME)
    assert len(csv) == 12
    meta = json.loads((out / results.META_NAME).read_text())
    assert meta["resumed"] is True and meta["runs"] == 12

    again = run_tiny(out, resume=True)
    assert again.total == 0 and again.skipped == 12
    assert len(results.read_runs(out, latest=False)) == 12


def test_resuming_a_finished_map_leaves_its_files_alone(tiny, tmp_path):
    out = tmp_path / "map"
    assert run_tiny(out).completed
    files = {name: (out / name).read_bytes() for name in (results.CSV_NAME, results.META_NAME)}
    again = run_tiny(out, resume=True)
    assert again.total == 0 and again.skipped == 12
    assert not any("wrote the missing" in note for note in again.notes)
    assert {name: (out / name).read_bytes() for name in files} == files  # wall time kept
    (out / results.CSV_NAME).unlink()  # a file gone is written again, and said so
    again = run_tiny(out, resume=True)
    assert any("wrote the missing runs.csv" in note for note in again.notes)
    assert len(pd.read_csv(out / results.CSV_NAME)) == 12


def test_a_folder_is_never_overwritten(tiny, tmp_path):
    with pytest.raises(OutputDirNotEmptyError, match="is not empty"):
        run_map(TINY, tiny, quiet=True)
    other = MapSpec(nx=4, ny=2, engines=("pymunk",), timestep=1e-3, t_end=1.0)
    with pytest.raises(MapSpecMismatchError, match=r"nx 4 \(stored: 3\)"):
        run_map(other, tiny, resume=True, quiet=True)
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(RunnerError, match=r"holds no map\.toml"):
        run_map(TINY, tmp_path, resume=True, quiet=True)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


# ------------------------------------------------------------------ agreement table
def test_agreement_table_counts_by_hand():
    rows = [
        # engine, regime, verdict, outcome_agrees
        ("reference", "hops", None, None),
        ("a", "hops", "agrees", True),
        ("a", "hops", "missed-hop", False),
        ("a", "rolls", "wrong-phases", True),
        ("a", "rolls", "false-slip", False),
        ("a", "rolls", "agrees", True),
        ("a", "degenerate", None, None),
        ("b", "hops", "failed", False),
        ("b", "rolls", "agrees", True),
    ]
    frame = pd.DataFrame(rows, columns=["engine", "regime", "verdict", "outcome_agrees"])
    table = agreement_table(frame).set_index(["engine", "regime"])
    assert list(table.index) == [
        ("a", "all"),
        ("a", "rolls"),
        ("a", "hops"),
        ("a", "degenerate"),
        ("b", "all"),
        ("b", "rolls"),
        ("b", "hops"),
        ("b", "degenerate"),
    ]
    a = table.loc[("a", "all")]
    assert (a["points"], a["judged"], a["outcome_agrees"], a["agrees"]) == (6, 5, 3, 2)
    assert a["outcome_agrees_pct"] == pytest.approx(60.0)
    assert a["agrees_pct"] == pytest.approx(40.0)
    rolls = table.loc[("a", "rolls")]
    assert (rolls["judged"], rolls["outcome_agrees"], rolls["agrees"]) == (3, 2, 1)
    assert rolls["outcome_agrees_pct"] == pytest.approx(200 / 3)
    degenerate = table.loc[("a", "degenerate")]
    assert (degenerate["points"], degenerate["judged"]) == (1, 0)
    assert math.isnan(degenerate["agrees_pct"])
    b = table.loc[("b", "hops")]
    assert (b["points"], b["judged"], b["outcome_agrees"], b["agrees_pct"]) == (1, 1, 0, 0.0)
    assert table.loc[("b", "degenerate"), "points"] == 0


# ------------------------------------------------------------------ command line
def test_the_command_line_runs_a_map_and_resumes_it(tiny, tmp_path, capsys):
    out = tmp_path / "cli"
    assert main(["map", *TINY_ARGS, "--out", str(out), "--jobs", "1", "--quiet"]) == 0
    printed = capsys.readouterr().out.split()
    assert str(out / "map.md") in printed
    assert load_spec(out) == TINY
    pd.testing.assert_frame_equal(comparable(map_frame(out)), comparable(map_frame(tiny)))

    assert main(["map", "--out", str(out), "--resume", "--quiet"]) == 0  # options from map.toml
    assert len(results.read_runs(out, latest=False)) == 12

    assert main(["map", "--out", str(out), "--resume", "--grid", "4x2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("hoopbench: error: ") and "nx 4 (stored: 3)" in err
    assert "\n" not in err


BAD_CLI = [
    (["--x", "foo"], "'foo'"),
    (["--grid", "0x3"], "'0x3'"),
    (["--grid", "3"], "'3'"),
    (["--grid", "axb"], "'axb'"),
    (["--x", "chi"], "x and y are both chi"),
    (["--x", "mu", "--y", "mu"], "x and y are both mu"),
    (["--x-range", "0.5", "1.5"], "1.5"),
    (["--x-range", "-0.5", "1"], "-0.5"),
    (["--y-range", "2", "1"], "[2, 1]"),
    (["--x", "theta0_deg", "--x-range", "0", "720"], "720"),
    (["--lam", "0.9"], "lam = 0.9 is fixed, but lam is the x axis"),
    (["--mu", "-1"], "-1"),
    (["--eps", "nan"], "nan"),
    (["--t-end", "0"], "t_end must be a number > 0 s, got 0"),
    (["--dt", "0"], "timestep must be a number > 0 s, got 0"),
    (["--dt", "5"], "timestep 5 s is longer than the window"),
    (["--engines", "nope"], "'nope'"),
    (["--engines", "reference"], "'reference'"),
    (["--engines", "pymunk", "pymunk"], "'pymunk' is given twice"),
    (["--profile", "best"], "'best'"),
    (["--engine-dt", "mjx"], "must be ENGINE=DT, got 'mjx'"),
    (["--engine-dt", "mjx=fast"], "not a number: 'fast'"),
    (["--engine-dt", "mjx=-1"], "engine_timesteps[mjx] must be a number > 0 s, got -1"),
    (["--engines", "pymunk", "--engine-dt", "mjx=1e-3"], "'mjx' is not one of the map's"),
    (["--jobs", "0"], "got 0"),
]


@pytest.mark.parametrize(("args", "needle"), BAD_CLI)
def test_bad_command_line_input_is_one_line(tmp_path, capsys, args, needle):
    out = tmp_path / "out"
    assert main(["map", *args, "--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err.strip()
    assert "\n" not in err and err.startswith("hoopbench: error: ")
    assert needle in err
    assert not out.exists()  # nothing written


def test_an_existing_folder_needs_resume(tmp_path, capsys):
    (tmp_path / "old.csv").write_text("a\n")
    assert main(["map", *TINY_ARGS, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == (
        f"hoopbench: error: {tmp_path} is not empty: resume the sweep stored there, or choose "
        "a new directory"
    )
    assert main(["map", *TINY_ARGS, "--out", str(tmp_path), "--resume"]) == 2
    assert "holds no map.toml" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.csv"]
