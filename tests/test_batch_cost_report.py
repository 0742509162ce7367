"""The batched engines' cost per world-step by batch size in the report: the bench's file
(reports/bench/batched_engines.py --out), its table and the report's section
(reports/report/batch_cost.py), and bad files refused by name. Hand-made figures: no engine
is stepped here."""

from __future__ import annotations

import math

import pandas as pd
import pytest

from hoopbench.engines.judging.columns import Col
from hoopbench.reports.bench.batched_engines import main as bench_main
from hoopbench.reports.cli import main
from hoopbench.reports.report.batch_cost import (
    BATCH_COST_COLUMNS,
    BATCH_COST_FILE,
    batch_cost_section,
    batch_cost_table,
    is_batch_cost_folder,
    read_batch_cost,
    write_batch_cost,
)

COSTS = {  # setting -> us per world-step at 1, 64, 1024 worlds
    "mujoco": (502.0, 132.0, 80.0),
    "mjx precision=float64": (1446.0, 202.0, 174.0),
    "newton": (1801.0, 27.0, float("nan")),  # the 1,024 batch failed
}


def bench_frame() -> pd.DataFrame:
    rows = []
    for setting, costs in COSTS.items():
        for size, us in zip((1, 64, 1024), costs, strict=True):
            rows.append(
                {
                    Col.ENGINE: setting.split()[0],
                    "setting": setting,
                    Col.ENGINE_VERSION: "1.0",
                    Col.TIMESTEP: 1e-3,
                    "steps_per_world": 100,
                    "device": "cpu",
                    Col.BATCH_SIZE: size,
                    Col.US_PER_WORLD_STEP: us,
                    Col.WORLD_STEPS_PER_S: 1e6 / us,
                    "measured_at": "2026-11-26T13:00:00+00:00",
                }
            )
    return pd.DataFrame(rows)[list(BATCH_COST_COLUMNS)]


@pytest.fixture
def bench_dir(tmp_path):
    folder = tmp_path / "bench"
    write_batch_cost(bench_frame(), folder)
    return folder


def test_the_table_has_a_column_per_batch_size_and_the_gain(bench_dir):
    assert is_batch_cost_folder(bench_dir)
    table = batch_cost_table(read_batch_cost(bench_dir))
    assert list(table.index) == list(COSTS)  # the file's order
    assert list(table.columns) == [1, 64, 1024, "gain"]
    assert table.loc["mjx precision=float64", 64] == 202.0
    assert table.loc["mujoco", "gain"] == pytest.approx(502 / 80)
    assert math.isnan(table.loc["newton", 1024]) and math.isnan(table.loc["newton", "gain"])


def test_the_section_shows_every_figure(bench_dir):
    text = batch_cost_section([bench_dir])
    assert text.startswith("## Cost per world-step by batch size\n")
    assert "| engine, settings | 1 world | 64 worlds | 1,024 worlds | 1 / 1,024 |" in text
    # Seconds per simulated second of one world: us per world-step x 1e-6 / dt (1 ms).
    assert "| mujoco | 0.502 | 0.132 | 0.08 | 6.28x |" in text
    assert "| mjx precision=float64 | 1.45 | 0.202 | 0.174 | 8.31x |" in text
    assert "| newton | 1.8 | 0.027 | - | - |" in text
    assert "read, not measured, by this report" in text
    assert "dt 0.001 s, 100 steps per world, device cpu, measured from 2026-11-26T13" in text


def test_the_report_of_a_bench_folder_has_the_section(bench_dir, tmp_path, capsys):
    out = tmp_path / "report"
    assert main(["report", "--results", str(bench_dir), "--out", str(out)]) == 0
    text = (out / "report.md").read_text()
    assert "## Cost per world-step by batch size" in text and "| mujoco | 0.502 |" in text


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        (lambda f: f.drop(columns=[Col.BATCH_SIZE]), "has no column(s) batch_size"),
        (lambda f: f.iloc[:0], "holds no rows"),
        (lambda f: f.assign(us_per_world_step=-1.0), "us_per_world_step must be a number > 0"),
        (
            lambda f: f.assign(batch_size="many"),
            "batch_size must be a whole number > 0, got 'many'",
        ),
        # issue 36: inf passed "> 0" and ended in int()'s OverflowError; 0.4 in a pandas error
        (lambda f: f.assign(batch_size=math.inf), "batch_size must be a whole number > 0, got inf"),
        (lambda f: f.assign(batch_size=0.4), "batch_size must be a whole number > 0, got 0.4"),
        (lambda f: f.assign(steps_per_world=1.5), "steps_per_world must be a whole number > 0"),
        (lambda f: f.assign(us_per_world_step=math.inf), "us_per_world_step must be a number > 0"),
    ],
)
def test_a_bad_file_is_refused_by_name(tmp_path, change, needle):
    folder = tmp_path / "bad"
    folder.mkdir()
    change(bench_frame()).to_csv(folder / BATCH_COST_FILE, index=False)
    with pytest.raises(ValueError) as info:
        read_batch_cost(folder)
    assert str(folder / BATCH_COST_FILE) in str(info.value) and needle in str(info.value)


def test_the_bench_never_replaces_its_file_unasked(bench_dir, capsys):
    before = (bench_dir / BATCH_COST_FILE).read_text()
    # refused before anything is measured (it named no engine, "none", before issue 36)
    assert bench_main(["--engines", "mujoco", "--out", str(bench_dir)]) == 2
    assert "exists; pass --force" in capsys.readouterr().err
    assert (bench_dir / BATCH_COST_FILE).read_text() == before
