"""A suite's and a map's runs of a batching engine (MuJoCo) go in batches and write the rows
they write one by one, but for the cost columns; older tables read with a batch of one."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.judging.columns import COST_COLUMNS, Col
from hoopbench.reports.compare.rows import with_batch_columns
from hoopbench.reports.compare.suite import compare, runs_frame
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import run_map
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.sweep.results import TIMING_COLUMNS

SUITE = """
name = "batched"
engines = ["mujoco", "pymunk"]
timesteps = [1e-3]
scenes = ["seed-mu", "hop-top", "hop-bottom"]
"""
COST = {*TIMING_COLUMNS, *COST_COLUMNS}
"""Columns that differ between a batched and a lone run of the same task."""


def _same_but_cost(one: pd.DataFrame, other: pd.DataFrame) -> None:
    keep = sorted(c for c in one.columns if c not in COST)
    assert sorted(c for c in other.columns if c not in COST) == keep
    a = one[keep].sort_values(Col.RUN_ID).reset_index(drop=True)
    b = other[keep].sort_values(Col.RUN_ID).reset_index(drop=True)
    pd.testing.assert_frame_equal(a, b)


def test_a_suite_batches_mujoco_and_writes_the_same_rows(tmp_path):
    suite = tmp_path / "batched.toml"
    suite.write_text(SUITE)
    with ThreadPoolExecutor(2) as pool:
        compare(suite, tmp_path / "batched", executor=pool, quiet=True, batch_size=2)
        compare(suite, tmp_path / "alone", executor=pool, quiet=True, batch_size=1)
    batched, alone = runs_frame(tmp_path / "batched"), runs_frame(tmp_path / "alone")
    _same_but_cost(batched, alone)
    mujoco = batched[batched[Col.ENGINE] == "mujoco"].sort_values(Col.RUN_ID)
    assert sorted(mujoco[Col.BATCH_SIZE]) == [1, 2, 2]  # three runs, batches of two
    assert set(batched.loc[batched[Col.ENGINE] == "pymunk", Col.BATCH_SIZE]) == {1}
    assert set(alone[Col.BATCH_SIZE]) == {1}
    # A batch's cost is the same in each of its rows; a run's own share is by its steps.
    pair = mujoco[mujoco[Col.BATCH_SIZE] == 2]
    assert pair[Col.US_PER_WORLD_STEP].nunique() == 1
    assert np.allclose(pair[Col.WORLD_STEPS_PER_S] * pair[Col.US_PER_WORLD_STEP], 1e6)
    lone = alone.iloc[0]
    assert lone[Col.US_PER_WORLD_STEP] == pytest.approx(lone[Col.US_PER_STEP])


def test_a_map_batches_mujoco_and_writes_the_same_rows(tmp_path):
    """Points that settle at their own times (each its own stop rule) and a hop's impact."""
    spec = MapSpec(
        nx=3,
        ny=2,
        engines=("mujoco",),
        timestep=1e-3,
        t_end=4.0,
        x_range=(0.05, 0.3),
        y_range=(0.5, 0.9),
    )
    with ThreadPoolExecutor(1) as pool:  # one call at a time: all six points in one batch
        run_map(spec, tmp_path / "batched", executor=pool, quiet=True, batch_size=6)
    with ThreadPoolExecutor(2) as pool:
        run_map(spec, tmp_path / "alone", executor=pool, quiet=True, batch_size=1)
    batched, alone = map_frame(tmp_path / "batched"), map_frame(tmp_path / "alone")
    _same_but_cost(batched, alone)
    ran = batched[(batched[Col.ENGINE] == "mujoco") & batched[Col.N_STEPS].notna()]
    assert sorted(ran[Col.BATCH_SIZE]) == [6] * 6
    assert sorted(ran[Col.N_STEPS]) == [1999] * 2 + [2999] * 4  # stopped as each settled
    displays = sorted(p.relative_to(tmp_path / "alone") for p in (tmp_path / "alone").rglob("*"))
    displays = [p for p in displays if "display" in str(p) and p.suffix]
    assert displays
    for path in displays:  # the page's curves, the same bytes
        assert (tmp_path / "batched" / path).read_bytes() == (
            tmp_path / "alone" / path
        ).read_bytes()


def test_a_table_from_before_batches_reads_each_run_as_a_batch_of_one():
    old = pd.DataFrame(
        {
            Col.RUN_ID: ["a", "b", "c"],
            Col.WALL_TIME_S: [0.5, None, 2.0],
            Col.N_STEPS: [1000, None, 4000],
        }
    )
    new = with_batch_columns(old)
    assert new[Col.BATCH_SIZE].tolist()[::2] == [1, 1] and pd.isna(new[Col.BATCH_SIZE][1])
    assert new[Col.US_PER_WORLD_STEP].tolist()[::2] == [500.0, 500.0]
    assert new[Col.WORLD_STEPS_PER_S].tolist()[::2] == [2000.0, 2000.0]


def test_the_command_line_refuses_a_bad_batch_size(tmp_path, capsys):
    from hoopbench.reports.cli import main

    for bad in ("0", "-3", "two"):
        code = main(
            ["compare", "--suite", "quick", "--out", str(tmp_path / "x"), "--batch-size", bad]
        )
        assert code == 2
        err = capsys.readouterr().err
        assert "--batch-size" in err and "Traceback" not in err
    assert not Path(tmp_path / "x").exists()
