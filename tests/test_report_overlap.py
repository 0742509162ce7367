"""make report's sweeps overlapping on one shared pool (reports/report_runs.py run_steps,
reports/sweep/plan.py): a step's calls take the worker the step before leaves idle, a
signal stops every step resumably, and the overall line lays out the steps running
together, and what comes after them starts beside the last step's last calls. Real
WorkerPools of 2 workers and calls that wait on files, not on the clock: about 10 s of wall
time, 4 CPU-s (under load)."""

from __future__ import annotations

import os
import signal
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
from test_runner_eta import ActiveSweep

from hoopbench.reports.report_runs import Step, run_steps
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.eta import CallCost, Rates, Running
from hoopbench.reports.sweep.plan import Plan, PlannedSweep
from hoopbench.reports.sweep.runner import run_tasks

WAIT_S = 20.0
"""How long a 'wait' call waits for its file before it gives up (only a broken overlap
waits that long)."""


@dataclass(frozen=True)
class Call:
    run_id: str
    kind: str
    """'wait' (for ``path``), 'make' (``path``), 'signal' (SIGINT to ``pid``), 'ok'."""
    path: str = ""
    pid: int = 0


def call_worker(call: Call) -> dict:
    if call.kind == "wait":
        end = time.monotonic() + WAIT_S
        while not Path(call.path).exists():
            if time.monotonic() > end:
                return {"status": "error", "message": "no other step ran meanwhile"}
            time.sleep(0.02)
    elif call.kind == "make":
        Path(call.path).touch()
    elif call.kind == "signal":
        os.kill(call.pid, signal.SIGINT)
    return {"status": "ok", "message": ""}


def _steps(out: Path, names: list[str]) -> list[Step]:
    return [Step(name, ("sweep", name, "--out", str(out / name))) for name in names]


def _runner(calls: dict[str, list[Call]], out: Path, resume: bool = False):
    def run(argv: list[str]) -> int:
        name = argv[1]
        summary = run_tasks(calls[name], call_worker, out / name, jobs=2, quiet=True,
                            resume=resume)  # fmt: skip
        return summary.exit_code

    return run


def _plan(names: list[str]) -> Plan:
    return Plan("make report", [PlannedSweep(n, 1, ()) for n in names], {}, 2)


def _statuses(folder: Path) -> dict[str, str]:
    return dict(results.stored_statuses(folder))


def test_the_next_step_runs_on_the_worker_the_step_before_leaves_idle(tmp_path):
    """Step 1's first call waits for a file that only step 2's call makes: run in a row,
    it waits alone and gives up; overlapped, step 2 begins once step 1 has nothing left
    queued and runs on the other worker. Each step's rows go to its own folder."""
    flag = str(tmp_path / "made")
    calls = {
        "default": [Call("wait-0", "wait", flag), Call("ok-1", "ok")],
        "finer": [Call("make-0", "make", flag)],
        "stability": [Call("ok-0", "ok")],
    }
    names = list(calls)
    code = run_steps(_plan(names), _steps(tmp_path, names), _runner(calls, tmp_path), print)
    assert code == 0
    assert _statuses(tmp_path / "default") == {"wait-0": "ok", "ok-1": "ok"}
    assert _statuses(tmp_path / "finer") == {"make-0": "ok"}
    assert _statuses(tmp_path / "stability") == {"ok-0": "ok"}
    for name in names:
        assert (tmp_path / name / results.META_NAME).exists()


def test_what_comes_after_starts_beside_the_last_steps_last_calls(tmp_path):
    """The last step's one call waits for a file that only ``queued`` makes: called once
    that step has nothing left queued, it runs while the call does (report-runs starts the
    report's drawing processes so); called once the steps end, the call would give up."""
    flag = tmp_path / "made"
    calls = {"default": [Call("ok-0", "ok")], "finer": [Call("wait-0", "wait", str(flag))]}
    names = list(calls)
    code = run_steps(
        _plan(names), _steps(tmp_path, names), _runner(calls, tmp_path), print, flag.touch
    )
    assert code == 0
    assert _statuses(tmp_path / "finer") == {"wait-0": "ok"}


def test_a_signal_stops_every_step_running_and_each_resumes(tmp_path):
    """Step 2's first call sends SIGINT to this process while step 1's call waits: both
    stop (exit 130, as a sweep interrupted says), step 3 never begins (step 2 still had
    calls queued), and each folder begun resumes to the whole sweep."""
    flag = str(tmp_path / "made")
    calls = {
        "default": [Call("wait-0", "wait", flag), Call("ok-1", "ok")],
        "finer": [Call("signal-0", "signal", pid=os.getpid())]
        + [Call(f"wait-{k}", "wait", flag) for k in range(1, 7)],
        "stability": [Call("ok-0", "ok")],
    }
    names = list(calls)
    after: list[str] = []  # what would start once the last step has nothing queued
    run = _runner(calls, tmp_path)
    code = run_steps(_plan(names), _steps(tmp_path, names), run, print, lambda: after.append("x"))
    assert code == 128 + signal.SIGINT
    assert _statuses(tmp_path / "default").get("wait-0") is None  # stopped, not stored
    assert not (tmp_path / "stability").exists()
    assert after == []
    Path(flag).touch()
    calls["finer"][0] = Call("signal-0", "ok")
    run = _runner(calls, tmp_path, resume=True)
    assert [run(["sweep", name]) for name in names] == [0, 0, 0]
    assert set(_statuses(tmp_path / "default")) == {"wait-0", "ok-1"}
    assert len(_statuses(tmp_path / "finer")) == 7


LONG = CallCost(kinds=("mjx",), steps=1)
SHORT = CallCost(kinds=("pymunk",), steps=1)
PRIOR = {"mjx": Rates(80.0, 0.0), "pymunk": Rates(2.0, 0.0), "report": Rates(20.0, 0.0)}


def test_steps_running_together_share_the_workers_in_the_eta():
    """The finer suite's 80-s call runs on one worker with 60 s left; the stability suite
    has begun beside it with ten 2-s calls, and the map (two 2-s calls) is still to come.
    Laid out together on 2 workers: stability ends in 20 s on the other worker, the map's
    calls after it, everything by 60 s, then the report's 20 s. Run in a row, it would
    have said 60 + 20 + 2 + 20 s."""
    plan = Plan(
        "make report",
        [
            PlannedSweep("finer", 1, (LONG,)),
            PlannedSweep("stability", 10, (SHORT,) * 10),
            PlannedSweep("the hop map", 2, (SHORT,) * 2),
        ],
        PRIOR,
        2,
        after=(CallCost(kinds=("report",), steps=0),),
    )
    plan.attach(plan.begin(1), ActiveSweep(running=(Running(LONG, 20.0),)))
    plan.attach(plan.begin(10), ActiveSweep(done=3, pending=(SHORT,) * 10))
    assert plan.sweep_left(1) == pytest.approx(20.0)
    assert plan.sweep_left(0) == pytest.approx(60.0)
    assert plan.seconds_left() == pytest.approx(60.0 + 20.0)
    assert plan.text(1) == (
        "make report: step 2 of 3 (stability, with finer), runs 3/13, eta 1m20s"
    )
    assert plan.text(0).startswith("make report: step 1 of 3 (finer, with stability), ")
