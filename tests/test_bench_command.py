"""`hoopbench bench` (make bench): its argument errors and a tiny run; nothing asserts a time."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from hoopbench.reports.cli import main

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["--sizes", "0"], "--sizes: must be >= 1, got 0"),
        (["--steps", "-5"], "--steps: must be >= 1, got -5"),
        (["--repeat", "1.5"], "--repeat"),
        (["--grid", "3"], "--grid: must be NXxNY"),
        (["--parts", "everything"], "'everything'"),
        (["--engines", "warp"], "--engines: unknown engine 'warp'"),
        (["--engines", "pymunk", "--parts", "batched"], "--engines pymunk: no part"),
        (["--scene", "hop-nowhere"], "--scene: unknown scene 'hop-nowhere'"),
        (["--dt", "0"], "--dt: must be a number of seconds > 0, got '0'"),
    ],
)
def test_bad_input_is_one_line_naming_the_value_and_exit_2(capsys, argv, named):
    assert main(["bench", *argv]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("hoopbench: error: "), captured.err
    assert named in lines[0]
    assert captured.out == ""  # refused before anything was measured


def test_a_tiny_run_writes_the_reports_batch_costs_and_keeps_them(tmp_path, capsys):
    argv = ["bench", "--parts", "batched", "--engines", "mujoco", "--sizes", "1", "2"]
    argv += ["--steps", "5", "--out", str(tmp_path)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "== bench: batched" in out and f"written: {tmp_path / 'batch_cost.csv'}" in out
    table = pd.read_csv(tmp_path / "batch_cost.csv")
    assert list(table["engine"]) == ["mujoco", "mujoco"]
    assert list(table["batch_size"]) == [1, 2]
    assert (table["steps_per_world"] == 5).all() and (table["us_per_world_step"] > 0).all()
    # A second run keeps the first's file unless told to replace it.
    assert main(argv) == 2
    assert "batch_cost.csv' exists; pass --force" in capsys.readouterr().err
    assert main([*argv, "--force"]) == 0


def test_a_part_without_the_engines_asked_for_is_skipped_and_said(capsys):
    argv = ["bench", "--parts", "overhead", "batched", "--engines", "pymunk"]
    assert main([*argv, "--repeat", "1", "--dt", "1e-3", "--scene", "seed-mu"]) == 0
    captured = capsys.readouterr()
    assert "bench: batched: skipped" in captured.err
    assert re.search(r"^pymunk\s+3000\s", captured.out, re.M), captured.out


def test_make_bench_is_the_command():
    makefile = (ROOT / "Makefile").read_text()
    recipe = makefile.split("\nbench:", 1)[1].split("\n\n", 1)[0]
    assert "hoopbench bench --out $(BENCH_OUT) --force" in recipe
    assert "python -m" not in recipe
