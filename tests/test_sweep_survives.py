"""A sweep outlives the death of its own processes (issue 38): the workers, the fork server
that starts them, the resource tracker, the pool's manager thread. Each is SIGKILLed (as the
OOM killer does) or made to fail mid-suite; the sweep either goes on to the uninterrupted
table, or ends within a bounded time in one line with its own exit status, its rows kept,
and ``--resume`` completes it. Every wait is bounded (subprocess timeouts): a hang fails.

Nothing here asserts a time. Cost: about 6-12 s per command-line test on 2 cores (the fork
server's imports of the engines are most of it), well under a second per in-process one.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TypeVar

import pandas as pd
import pytest
from test_compare import CLI, comparable, environment
from test_runner import Job, by_run_id, run, sweep_tasks, wait_until

from hoopbench.engines.run import RunStatus
from hoopbench.reports.sweep.results import TIMING_COLUMNS, read_runs
from hoopbench.reports.sweep.runner import (
    ExecutorBrokenError,
    PoolBrokenError,
    WorkerCrashedError,
    WorkerPool,
    run_tasks,
)

T = TypeVar("T")
LIMIT = 120
"""Seconds any command here may take before the test calls it hung."""

SLOW = """
name = "slow"
engines = ["test-slow"]
timesteps = [1e-3, 5e-4]
scenes = ["seed-mu", "hop-top", "hop-low", "hop-bottom", "slip-reversal", "low-friction"]
"""
"""12 runs of 0.4 s or more: 2.4 s or more on 2 workers, long enough to kill mid-suite."""


# ------------------------------------------------------------------ processes of a sweep
def children(pid: int) -> list[int]:
    """The child processes of ``pid``, whichever of its threads started them."""
    found: list[int] = []
    try:
        for task in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{task}/children") as f:
                found += [int(p) for p in f.read().split()]
    except OSError:
        pass
    return found


def command_line(pid: int) -> str:
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            return f.read().replace(b"\0", b" ").decode(errors="replace")
    except OSError:
        return ""


def helpers(pid: int) -> dict[str, list[int]]:
    """The sweep's processes: its fork server, resource tracker, and the workers."""
    kids = children(pid)
    fork_servers = [k for k in kids if "multiprocessing.forkserver" in command_line(k)]
    trackers = [k for k in kids if "multiprocessing.resource_tracker" in command_line(k)]
    workers = [w for f in fork_servers for w in children(f)]
    return {"forkserver": fork_servers, "tracker": trackers, "workers": workers}


def alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, pd.DataFrame]:
    """The slow suite's file and the table of its uninterrupted run."""
    folder = tmp_path_factory.mktemp("whole")
    suite = folder / "slow.toml"
    suite.write_text(SLOW)
    done = compare(suite, folder / "out")
    assert done.returncode == 0, done.stderr
    return suite, comparable(folder / "out")


def compare(suite: Path, out: Path, *args: str) -> subprocess.CompletedProcess[str]:
    command = [*CLI, "compare", "--suite", str(suite), "--out", str(out), "--quiet", "--jobs", "2"]
    return subprocess.run(
        [*command, *args],
        env=environment(),
        capture_output=True,
        text=True,
        timeout=LIMIT,
        cwd=suite.parent,
    )


def kill_mid_suite(
    command: list[str], victims: Callable[[dict[str, list[int]]], list[int]], cwd: Path
) -> tuple[subprocess.CompletedProcess[str], list[int]]:
    """Run ``command``; once its two workers run calls, SIGKILL ``victims(helpers)``; wait for
    the end (bounded). The command's outcome and the pids killed."""
    proc = subprocess.Popen(
        command, env=environment(), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        cwd=cwd,
    )  # fmt: skip
    try:
        assert wait_until(lambda: len(helpers(proc.pid)["workers"]) >= 2, timeout=LIMIT)
        time.sleep(0.6)  # the first calls are under way (0.4 s each)
        killed = victims(helpers(proc.pid))
        assert killed, helpers(proc.pid)
        for pid in killed:
            os.kill(pid, signal.SIGKILL)
        out, err = proc.communicate(timeout=LIMIT)
    finally:
        proc.kill()
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err), killed


VICTIMS: dict[str, Callable[[dict[str, list[int]]], list[int]]] = {
    "fork server and workers": lambda found: found["forkserver"] + found["workers"],
    "fork server": lambda found: found["forkserver"],
    "resource tracker and workers": lambda found: found["tracker"] + found["workers"],
}
"""Killing the workers alone is tests/test_runner.py's (a crashing worker); with them the
resource tracker, which multiprocessing relaunches at the next worker start with a warning."""


# ------------------------------------------------------------------ compare, killed
@pytest.mark.slow
@pytest.mark.parametrize("victim", list(VICTIMS))
def test_a_suite_whose_processes_are_killed_goes_on_to_the_uninterrupted_table(
    tmp_path, uninterrupted, victim
):
    """Before issue 38, killing the fork server (with or without its workers) left the pool's
    manager thread dead of a ConnectionRefusedError or EOFError traceback and the sweep
    waiting for ever. Now a new fork server starts; a call whose worker died is retried."""
    suite, whole = uninterrupted
    out = tmp_path / "out"
    command = [*CLI, "compare", "--suite", str(suite), "--out", str(out), "--quiet"]
    done, killed = kill_mid_suite([*command, "--jobs", "2"], VICTIMS[victim], tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""  # no traceback, no warning: --quiet says nothing
    rows = read_runs(out)
    assert set(rows["status"]) == {"ok"}, rows[["run_id", "status", "message"]]
    pd.testing.assert_frame_equal(comparable(out), whole)
    # An orphaned worker of a dead fork server is stopped, not left running its call.
    assert wait_until(lambda: not any(alive(pid) for pid in killed), timeout=10)
    assert (rows["attempts"] == 2).sum() <= 2  # only the calls running when killed


# ------------------------------------------------------------------ a pool that cannot go on
NO_FORK_SERVER = """
import sys
from hoopbench.reports.sweep.runner import WorkerPool
from hoopbench.reports.cli import main

WorkerPool.START_RETRY_DELAYS = (0.05, 0.05)
started = WorkerPool._start_worker
count = 0

def start_two_then_fail(self):
    # The first pool's two workers start; then no fork server can be reached, ever.
    global count
    count += 1
    if count > 2:
        raise ConnectionRefusedError(111, "Connection refused")
    started(self)

if __name__ == "__main__":  # the fork server imports this file too (as __mp_main__)
    WorkerPool._start_worker = start_two_then_fail
    sys.exit(main(sys.argv[1:]))
"""


@pytest.mark.slow
def test_a_pool_that_cannot_start_workers_ends_in_one_line_and_resume_completes(
    tmp_path, uninterrupted
):
    """Workers killed while no new one can start (a stand-in for a fork server that cannot be
    restarted): the sweep tries MAX_POOL_RENEWALS new pools, then stops in one line, exit
    status 75, with its rows kept and the resume command; the resume completes the table."""
    suite, whole = uninterrupted
    out = tmp_path / "out"
    script = tmp_path / "no_fork_server.py"
    script.write_text(NO_FORK_SERVER)
    command = [sys.executable, str(script), "compare", "--suite", str(suite), "--out", str(out)]
    done, _ = kill_mid_suite(
        [*command, "--quiet", "--jobs", "2"], lambda found: found["workers"], tmp_path
    )
    assert done.returncode == 75, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1, done.stderr
    assert lines[0].startswith(
        "hoopbench: stopped: the executor is broken (PoolBrokenError: cannot start a worker "
        "process (3 tries): ConnectionRefusedError: [Errno 111] Connection refused)"
    ), lines
    resume = f"hoopbench compare --suite {suite} --out {out} --resume"
    assert lines[0].endswith(f"kept in {out}/runs; resume with: {resume}"), lines
    assert not (out / "runs.csv").exists()  # written only when the suite ends
    resumed = compare(suite, out, "--resume")
    assert resumed.returncode == 0, resumed.stderr
    pd.testing.assert_frame_equal(comparable(out), whole)


# ------------------------------------------------------------------ the manager thread
@pytest.fixture
def thread_deaths(monkeypatch) -> list[BaseException]:
    """Exceptions that ended a thread unheard (threading.excepthook's, recorded)."""
    seen: list[BaseException] = []
    monkeypatch.setattr(threading, "excepthook", lambda args: seen.append(args.exc_value))
    return seen


def bounded(call: Callable[[], T], seconds: float = 60) -> T:
    """``call()``, failing the test if it has not returned after ``seconds``: a hang."""
    outcome: dict[str, Any] = {}

    def target() -> None:
        try:
            outcome["value"] = call()
        except BaseException as exc:
            outcome["error"] = exc

    thread = threading.Thread(target=target, daemon=True)
    thread.start()
    thread.join(seconds)
    assert not thread.is_alive(), f"no end after {seconds} s: the sweep hangs"
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


def fail_the_manager_once(monkeypatch, after: int = 3) -> None:
    """The pool's manager raises once, in its first round after ``after`` calls' outcomes:
    a bug, or a failure of the system under it."""
    collect = WorkerPool._collect
    seen = {"outcomes": 0, "failed": False}

    def failing(self, ready):
        if seen["outcomes"] >= after and not seen["failed"]:
            seen["failed"] = True
            raise RuntimeError("the manager's own failure")
        outcomes = collect(self, ready)
        seen["outcomes"] += len(outcomes)
        return outcomes

    monkeypatch.setattr(WorkerPool, "_collect", failing)


def test_a_failed_manager_fails_its_futures_and_submit_instead_of_dying_unheard(
    monkeypatch, thread_deaths
):
    fail_the_manager_once(monkeypatch, after=0)
    with WorkerPool(2) as pool:
        first = pool.submit(time.sleep, 0.2)
        error = first.exception(timeout=30)  # bounded: the future does not stay pending
        assert isinstance(error, PoolBrokenError), error
        assert "the manager's own failure" in str(error)
        with pytest.raises(PoolBrokenError):
            pool.submit(time.sleep, 0)
    assert thread_deaths == []


def test_a_sweeps_own_broken_pool_is_replaced_and_the_sweep_completes(
    tmp_path, monkeypatch, thread_deaths
):
    fail_the_manager_once(monkeypatch)
    summary = bounded(lambda: run(sweep_tasks(), tmp_path / "out"))
    assert summary.completed
    assert [n for n in summary.notes if "the worker pool broke" in n], summary.notes
    rows = by_run_id(tmp_path / "out")
    assert len(rows) == len(sweep_tasks())
    assert {row["status"] for row in rows.values()} <= {"ok", "diverged"}
    reference = tmp_path / "reference"
    monkeypatch.undo()
    run(sweep_tasks(), reference)
    comparable_rows = [
        read_runs(f).drop(columns=list(TIMING_COLUMNS)).sort_values("run_id").reset_index(drop=True)
        for f in (tmp_path / "out", reference)
    ]
    pd.testing.assert_frame_equal(*comparable_rows)
    assert thread_deaths == []


def test_a_callers_broken_pool_stops_the_sweep_with_its_rows_kept(
    tmp_path, monkeypatch, thread_deaths
):
    """A pool the caller owns (tune's, kept across trials) is not replaced here: the sweep
    stops with ExecutorBrokenError, every finished row kept, none stored as failed."""
    fail_the_manager_once(monkeypatch, after=6)
    with WorkerPool(2) as pool, pytest.raises(ExecutorBrokenError, match="manager failed"):
        bounded(lambda: run(sweep_tasks(), tmp_path / "out", executor=pool))
    rows = read_runs(tmp_path / "out")
    assert 0 < len(rows) < len(sweep_tasks())
    assert set(rows["status"]) <= {"ok", "diverged"}
    monkeypatch.undo()
    summary = run(sweep_tasks(), tmp_path / "out", resume=True)
    assert summary.completed and len(read_runs(tmp_path / "out")) == len(sweep_tasks())
    assert thread_deaths == []


def test_a_worker_lost_with_its_fork_server_is_stopped_and_its_call_fails_as_crashed():
    with WorkerPool(1) as pool:
        future = pool.submit(time.sleep, 30)
        assert wait_until(lambda: future.running() and pool.pids, timeout=30)
        worker = pool.pids[0]
        fork_server = _parent_of(worker)
        os.kill(fork_server, signal.SIGKILL)
        error = future.exception(timeout=30)
        assert isinstance(error, WorkerCrashedError), error
        assert "lost with the fork server" in str(error)
        assert wait_until(lambda: not alive(worker), timeout=10)
        assert pool.submit(sum, [1, 2]).result(timeout=60) == 3  # a new fork server


def _parent_of(pid: int) -> int:
    with open(f"/proc/{pid}/stat") as f:
        return int(f.read().rsplit(")", 1)[1].split()[1])


# ------------------------------------------------------------------ a time limit, twice
@dataclass(frozen=True)
class SlowOnce:
    """A run slower than its time limit the first time only: a machine busy for a moment."""

    run_id: str
    scratch: str


def slow_once_worker(task: SlowOnce) -> dict[str, Any]:
    marker = Path(task.scratch) / f"{task.run_id}.tried"
    if not marker.exists():
        marker.touch()
        time.sleep(30)
    return {"status": "ok", "message": ""}


def test_a_run_the_time_limit_ended_is_tried_once_more_and_then_stored_as_a_timeout(tmp_path):
    """Issue 34: a time limit may end a run because the machine was loaded, so the run is tried
    once more with the same limit; a run that passes it twice is a timeout, and says so."""
    (tmp_path / "scratch").mkdir()
    once = SlowOnce("slow-once", str(tmp_path / "scratch"))
    summary = bounded(
        lambda: run_tasks([once], slow_once_worker, tmp_path / "a", timeout=1.0, quiet=True)
    )
    row = by_run_id(tmp_path / "a")["slow-once"]
    assert (row["status"], row["attempts"]) == ("ok", 2), row
    assert summary.counts == {RunStatus.OK: 1}

    summary = bounded(lambda: run([Job("hangs", "hang")], tmp_path / "b", timeout=1.0))
    row = by_run_id(tmp_path / "b")["hangs"]
    assert (row["status"], row["attempts"]) == ("timeout", 2), row
    assert "in either of two tries" in row["message"]
    assert "retried once with the same limit" in row["message"]


# ------------------------------------------------------------------ map, killed
MAP = ["map", "--grid", "3x2", "--engines", "test-slow", "--t-end", "1", "--quiet"]
"""6 points, each the exact solver's and test-slow's run (0.4 s or more): the map's two
stages on the same pool as a suite's."""


@pytest.mark.slow
def test_a_map_whose_fork_server_and_workers_are_killed_goes_on_to_the_uninterrupted_table(
    tmp_path,
):
    """`hoopbench map` runs on the same pool: killing its fork server and workers mid-map
    ends in the map the uninterrupted run stores (before issue 38: a hang)."""
    whole = subprocess.run(
        [*CLI, *MAP, "--out", str(tmp_path / "whole"), "--jobs", "2"],
        env=environment(), capture_output=True, text=True, timeout=LIMIT, cwd=tmp_path,
    )  # fmt: skip
    assert whole.returncode == 0, whole.stderr
    out = tmp_path / "out"
    command = [*CLI, *MAP, "--out", str(out), "--jobs", "2"]
    done, killed = kill_mid_suite(command, VICTIMS["fork server and workers"], tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stderr == ""
    rows = read_runs(out)
    assert set(rows["status"]) == {"ok"}, rows[["run_id", "status", "message"]]
    pd.testing.assert_frame_equal(comparable(out), comparable(tmp_path / "whole"))
    assert wait_until(lambda: not any(alive(pid) for pid in killed), timeout=10)


# ------------------------------------------------------------------ tune, killed
TUNE = ["tune", "--engine", "pymunk", "--trials", "3", "--scenes", "seed-mu", "hop-top"]
TUNE += ["--heldout-per-regime", "1", "--heldout-neighbours", "0", "--quiet", "--jobs", "2"]
"""A small search (its baselines, 3 trials, 2 scenes, then its held-out runs), on the same
pool as a suite's."""


@pytest.mark.slow
def test_a_search_whose_fork_server_and_workers_are_killed_finishes(tmp_path):
    """`hoopbench tune` with its fork server and workers SIGKILLed mid-search ends as an
    uninterrupted search does: exit 0, only its closing line on stderr, every trial's run
    ended as there, front.csv and settings.toml written, each trial's training error the
    uninterrupted one's."""
    from hoopbench.reports.tune.search import FRONT_NAME, SETTINGS_NAME, TRIALS_DIR

    whole = subprocess.run(
        [*CLI, *TUNE, "--out", str(tmp_path / "whole")],
        env=environment(), capture_output=True, text=True, timeout=LIMIT, cwd=tmp_path,
    )  # fmt: skip
    assert whole.returncode == 0, whole.stderr
    out = tmp_path / "out"
    done, killed = kill_mid_suite(
        [*CLI, *TUNE, "--out", str(out)], VICTIMS["fork server and workers"], tmp_path
    )
    assert done.returncode == 0, done.stderr
    assert done.stderr.splitlines() == [f"hoopbench: settings -> {out / SETTINGS_NAME}"]
    statuses = [
        read_runs(folder / TRIALS_DIR).set_index("run_id")["status"].sort_index()
        for folder in (out, tmp_path / "whole")
    ]
    pd.testing.assert_series_equal(*statuses)  # no run lost to the kill (a trial may diverge)
    assert (out / FRONT_NAME).is_file() and (out / SETTINGS_NAME).is_file()
    errors = [
        pd.read_csv(folder / "trials.csv").set_index("trial")["train_error"]
        for folder in (out, tmp_path / "whole")
    ]
    pd.testing.assert_series_equal(*errors)
    assert wait_until(lambda: not any(alive(pid) for pid in killed), timeout=10)


def test_a_call_whose_worker_died_as_it_was_sent_goes_to_another_worker(monkeypatch, thread_deaths):
    """A worker SIGKILLed just before its call is sent (the fork server and its workers
    killed, as the OOM killer does): the send fails, the call goes back on the queue already
    running, and the manager set it running a second time: "Future in unexpected state",
    the pool broken and the sweep stopped (seen once in tune's kill test in a clean-clone
    run). Now the call runs on a new worker."""
    killed: list[int] = []
    original = WorkerPool._dispatch

    def kill_then_dispatch(self: WorkerPool) -> list:
        for worker in self._workers:
            if worker.ready and worker.future is None and self._pending and not killed:
                os.kill(worker.pid, signal.SIGKILL)
                killed.append(worker.pid)
                worker.process.join(5)  # dead: the send below fails on its pipe
        return original(self)

    monkeypatch.setattr(WorkerPool, "_dispatch", kill_then_dispatch)
    with WorkerPool(1) as pool:
        future = pool.submit(abs, -3)
        assert bounded(lambda: future.result(timeout=30)) == 3
    assert killed and thread_deaths == []
