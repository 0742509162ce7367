"""The floor benchmark (reports/bench/floor.py): its arithmetic by hand, and a run on a tiny map.

The benchmark prints times and asserts none; these tests check what it computes from them:
the per-group floor (steps times the sampled bare cost per step), the steps the stopping
bound keeps, that each sampled bare loop steps exactly as often as its run did, and that a
folder without a map is one line and exit status 2.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.base import n_steps_for
from hoopbench.reports.bench import floor as bench_floor
from hoopbench.reports.bench.floor import (
    Floor,
    engine_rows,
    floor_scene,
    group_floor,
    must_run_steps,
    report,
    stopping_bound,
)
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import run_map

TINY = MapSpec(nx=2, ny=2, engines=("pymunk",), timestep=1e-3, t_end=1.0)


def _rows(**columns) -> pd.DataFrame:
    base = {"engine": "e", "regime": "rolls", "stop": "full", "wall_time_s": 1.0}
    n = len(columns["n_steps"])
    return pd.DataFrame({**{k: [v] * n for k, v in base.items()}, **columns})


def test_a_group_floor_is_its_steps_at_the_sampled_cost_per_step():
    rows = _rows(n_steps=[100, 300, 600], wall_time_s=[0.002, 0.006, 0.012])
    sampled = rows.iloc[[0, 2]]
    # 0.001 s for 100 steps and 0.004 s for 600: 5/700 ms a step, over 1000 steps.
    table = group_floor(rows, sampled, np.array([0.001, 0.004]))
    (row,) = table.itertuples(index=False)
    assert row.runs == 3 and row.steps == 1000
    assert row.run_s == pytest.approx(0.020)
    assert row.bare_us == pytest.approx(1e6 * 0.005 / 700)
    assert row.floor_s == pytest.approx(1000 * 0.005 / 700)


def test_groups_keep_their_own_cost():
    rows = pd.concat(
        [_rows(n_steps=[100], engine=["a"]), _rows(n_steps=[100], engine=["b"])],
        ignore_index=True,
    )
    table = group_floor(rows, rows, np.array([0.001, 0.003])).set_index("engine")
    assert table.loc["a", "floor_s"] == pytest.approx(0.001)
    assert table.loc["b", "floor_s"] == pytest.approx(0.003)


def test_the_stopping_bound_keeps_hops_to_impact_slips_to_their_last_event_and_no_rolls():
    rows = _rows(
        n_steps=[5000, 30000, 30000, 3000, 30000, 12000],
        regime=["hops", "slips", "slips", "slips", "slips", "rolls"],
        exact_t_last_phase=[0.2, 2.00001, 1.0, 1.0, 0.0007000000000000001, 0.0],
    )
    steps = must_run_steps(rows, 1e-4)
    # A slip's last event at 2.00001 s needs the step after it (20001), one at 7e-4 s up to
    # round-off (7.000000000000001 steps) the 7th; a run that ended sooner than the exact's
    # last event (3000 steps) keeps only its own steps.
    assert steps.tolist() == [5000, 20001, 10000, 3000, 7, 0]
    groups = group_floor(rows, rows, 1e-5 * rows["n_steps"].to_numpy())
    expected = 1e-5 * (5000 + 20001 + 10000 + 3000 + 7)
    assert stopping_bound(rows, groups, 1e-4) == pytest.approx(expected)


def test_failed_and_reference_rows_are_not_engine_rows():
    frame = pd.DataFrame(
        {
            "engine": ["reference", "e", "e", "e"],
            "status": ["ok", "ok", "error", "ok"],
            "n_steps": [None, 10, 10, 0],  # the error stepped, then its detectors failed
            "stop_reason": [None, "impact", None, None],
        }
    )
    rows = engine_rows(frame)
    assert len(rows) == 1 and rows["stop"].tolist() == ["impact"]


@pytest.mark.parametrize("n_steps", [1, 7, 999, 1000, 12345])
def test_a_floor_scene_steps_exactly_as_the_run_did(n_steps):
    point = TINY.points()[0]
    assert n_steps_for(floor_scene(point, n_steps, 1e-4), 1e-4) == n_steps


def test_the_report_names_the_floor_and_the_bound():
    groups = group_floor(_rows(n_steps=[1000]), _rows(n_steps=[1000]), np.array([0.5]))
    text = report(Floor(groups, reference_s=0.5, bound_s=0.25), cores=2, map_wall_s=60.0)
    assert "floor on 2 cores (engines bare + classification): 0.0 min" in text
    assert "the map took 1.0 min: 120.00 x its floor" in text


def test_a_tiny_map_is_measured(tmp_path, capsys):
    out = tmp_path / "map"
    with ThreadPoolExecutor(2) as pool:
        assert run_map(TINY, out, executor=pool, quiet=True).completed
    assert bench_floor.main([str(out), "--per-group", "1", "--cores", "2"]) == 0
    text = capsys.readouterr().out
    assert "pymunk" in text and "stopping bound on 2 cores" in text


def test_a_folder_without_a_map_is_one_line_and_exit_2(tmp_path, capsys):
    assert bench_floor.main([str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and str(tmp_path) in err
