"""`hoopbench compare` end to end, as a user runs it: faults cost one row, Ctrl-C and resume
give the table of an uninterrupted run.

The faulty engines live in tests/fault_engines.py and reach the worker processes through
HOOPBENCH_ENGINE_MODULES, so each test runs the command in a subprocess of its own.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
import pytest

from hoopbench.engines.judging.columns import COST_COLUMNS
from hoopbench.reports.compare.suite import TIMEOUT_NOTE, run_timeout
from hoopbench.reports.sweep.results import TIMING_COLUMNS, read_runs

TESTS = Path(__file__).resolve().parent
CLI = [sys.executable, "-m", "hoopbench.reports.cli"]
TIMING = {*TIMING_COLUMNS, *COST_COLUMNS}

FAULTS = """
name = "faults"
engines = ["reference", "test-crash", "test-hang", "test-nan"]
timesteps = [1e-3]
scenes = ["seed-mu"]
"""

SLOW = """
name = "slow"
engines = ["test-slow"]
timesteps = [1e-3, 5e-4]
scenes = ["seed-mu", "hop-top", "hop-low", "hop-bottom", "slip-reversal", "low-friction"]
"""


def environment() -> dict[str, str]:
    env = dict(os.environ)
    env["HOOPBENCH_ENGINE_MODULES"] = "fault_engines"
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(TESTS), env.get("PYTHONPATH")]))
    return env


def compare(
    suite: Path, out: Path, *args: str, timeout: float = 120
) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*CLI, "compare", "--suite", str(suite), "--out", str(out), "--quiet", *args],
        env=environment(),
        capture_output=True,
        text=True,
        timeout=timeout,
        cwd=suite.parent,
    )


def comparable(folder: Path) -> pd.DataFrame:
    frame = read_runs(folder)
    keep = [c for c in frame.columns if c not in TIMING]
    return frame[keep].sort_values("run_id").reset_index(drop=True)


def test_a_crash_a_hang_and_a_nan_each_cost_one_row(tmp_path):
    suite = tmp_path / "faults.toml"
    suite.write_text(FAULTS)
    done = compare(suite, tmp_path / "out", "--run-timeout", "4")
    assert done.returncode == 0, done.stderr
    rows = read_runs(tmp_path / "out").set_index("engine")
    assert rows.loc["reference", "status"] == "ok"
    assert rows.loc["test-crash", "status"] == "crashed"
    assert rows.loc["test-crash", "attempts"] == 2  # retried once
    assert rows.loc["test-hang", "status"] == "timeout"
    assert rows.loc["test-hang", "attempts"] == 2  # the limit may be the machine's: retried
    # The time limit is the machine's: no verdict, and the row says so (issue 34).
    assert pd.isna(rows.loc["test-hang", "verdict"])
    assert rows.loc["test-hang", "verdict_reason"] == TIMEOUT_NOTE
    assert rows.loc["test-crash", "verdict"] == "failed"
    assert rows.loc["test-nan", "status"] == "diverged"
    assert rows.loc["test-nan", "message"] == "non-finite theta"
    csv = pd.read_csv(tmp_path / "out" / "runs.csv")
    assert sorted(csv["status"]) == ["crashed", "diverged", "ok", "timeout"]


def test_ctrl_c_then_resume_gives_the_uninterrupted_table(tmp_path):
    suite = tmp_path / "slow.toml"
    suite.write_text(SLOW)
    whole = compare(suite, tmp_path / "whole")
    assert whole.returncode == 0, whole.stderr

    out = tmp_path / "cut"
    proc = subprocess.Popen(
        [*CLI, "compare", "--suite", str(suite), "--out", str(out), "--quiet"],
        env=environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
    )
    deadline = time.monotonic() + 60
    while not list((out / "runs").glob("part-*.parquet")) and time.monotonic() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert "interrupted by SIGINT" in err and "--resume" in err
    stored = len(read_runs(out))
    assert 0 < stored < 12, "the interrupt should land mid-sweep"
    assert not (out / "runs.csv").exists()  # written only when the suite ends

    resumed = compare(suite, out, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    pd.testing.assert_frame_equal(comparable(out), comparable(tmp_path / "whole"))
    again = compare(suite, out, "--resume")
    assert again.returncode == 0 and len(read_runs(out)) == 12


@pytest.mark.parametrize("name", ["HOOPBENCH_ENGINE_MODULES"])
def test_an_unimportable_engine_module_is_one_line(tmp_path, name):
    env = {**environment(), name: "no_such_engines"}
    done = subprocess.run([*CLI, "settings"], env=env, capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert done.stderr.strip() == (
        "hoopbench: error: HOOPBENCH_ENGINE_MODULES: cannot import engine module "
        "'no_such_engines': No module named 'no_such_engines'"
    )


@pytest.mark.parametrize(("engine", "lone_step_s"), [("mjx", 3.7e-3), ("mjwarp", 34e-3)])
def test_a_batched_engines_time_limit_covers_its_measured_steps(engine, lone_step_s):
    """A world alone costs 3.7 ms (MJX float32) and 34 ms (MuJoCo Warp) a step on the CPU
    (docs/engines.md): a run's time limit beyond its minute of start-up covers three times
    that. With 0.5 ms a step for every engine, MuJoCo Warp's seed-mu and hop-top rows of the
    default suite were timeouts."""
    task = SimpleNamespace(engine=engine, n_steps=1500)
    assert run_timeout(task) - 60.0 >= 3 * lone_step_s * task.n_steps
