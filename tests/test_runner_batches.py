"""The runner's batches (reports/sweep/runner.py, Batching): tasks of one key run as one call
of a batch worker, and a batch keeps what a call has: isolation, one time limit, one retry
after a crash, a row for every task, resume. Real worker processes, as tests/test_runner.py.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path

import pytest
from test_runner import (
    Job,
    by_run_id,
    calls,
    hold_workers,
    job_failure_row,
    job_worker,
    wait_for_file,
    wait_until,
)

from hoopbench.engines.base import Engine
from hoopbench.engines.mjx_engine import WORLDS_PER_CALL
from hoopbench.engines.registry import engine_class
from hoopbench.engines.run import RunStatus
from hoopbench.reports.compare.suite import batch_least
from hoopbench.reports.sweep.runner import Batching, RunSummary, TaskBatch, WorkerPool, run_tasks


@pytest.fixture
def scratch(tmp_path: Path) -> Path:
    folder = tmp_path / "scratch"
    folder.mkdir()
    return folder


def job_batch_worker(jobs: list[Job]) -> list[dict]:
    """The batch worker: each job's row as job_worker gives it (a crash or hang in one job
    is the whole call's), with the batch's run ids logged as one call."""
    if jobs and jobs[0].scratch:
        with open(Path(jobs[0].scratch) / "batches.log", "a") as log:
            log.write(",".join(job.run_id for job in jobs) + "\n")
    return [job_worker(job) for job in jobs]


def job_key(job: Job) -> str | None:
    """Jobs whose run id starts with 'b' batch together by their second letter."""
    return job.run_id[:2] if job.run_id.startswith("b") else None


def batches(folder: Path) -> list[list[str]]:
    log = folder / "batches.log"
    return [line.split(",") for line in log.read_text().split()] if log.exists() else []


def run(tasks, out, size: int = 3, **kwargs) -> RunSummary:
    kwargs.setdefault("jobs", 2)
    kwargs.setdefault("max_in_flight", 1)  # one call at a time: batches of the full size
    kwargs.setdefault("quiet", True)
    kwargs.setdefault("failure_row", job_failure_row)
    batching = Batching(job_batch_worker, job_key, size)
    return run_tasks(tasks, job_worker, out, batching=batching, **kwargs)


def test_tasks_group_by_key_up_to_the_size_in_order():
    jobs = [Job(name) for name in ("bx-1", "a-1", "by-1", "bx-2", "bx-3", "bx-4", "a-2", "by-2")]
    units = Batching(job_batch_worker, job_key, 3).units(jobs)
    assert [u.run_id if isinstance(u, Job) else [t.run_id for t in u.tasks] for u in units] == [
        ["bx-1", "bx-2", "bx-3"],
        "a-1",
        ["by-1", "by-2"],
        ["bx-4"],
        "a-2",
    ]
    assert isinstance(units[0], TaskBatch) and units[0].run_id == "bx-1"
    # With four calls in flight, four tasks of one key make four batches, not two: no
    # worker waits while another steps a full batch.
    spread = Batching(job_batch_worker, job_key, 3).units(jobs, parallel=4)
    sizes = [len(u.tasks) if isinstance(u, TaskBatch) else 0 for u in spread]
    assert sizes == [1, 0, 1, 1, 1, 1, 0, 1]
    with pytest.raises(ValueError, match="batch size"):
        Batching(job_batch_worker, job_key, 0)


def test_a_key_is_not_cut_below_its_least_batch():
    """An engine that pads every call to a fixed number of worlds (MJX: 8) gains nothing
    from smaller batches: its tasks are not spread below that, but still up to the size."""
    jobs = [Job(name) for name in ("bx-1", "a-1", "bx-2", "bx-3", "bx-4", "bx-5", "a-2")]

    def least(key):
        return 3 if key == "bx" else 1

    units = Batching(job_batch_worker, job_key, 4, least).units(jobs, parallel=4)
    sizes = [len(u.tasks) if isinstance(u, TaskBatch) else 0 for u in units]
    assert sizes == [3, 0, 2, 0]  # without the least: [2, 0, 2, 1, 0]
    assert Engine.worlds_per_call == 1
    assert engine_class("mjx").worlds_per_call == WORLDS_PER_CALL
    assert batch_least(("mjx", "{}")) == WORLDS_PER_CALL
    assert batch_least(("mujoco", "{}")) == 1


def test_a_batched_sweep_writes_the_rows_of_an_unbatched_one(tmp_path, scratch):
    s = str(scratch)
    tasks = [Job(f"bx-{i}", scratch=s) for i in range(5)] + [Job("a-1", scratch=s)]
    tasks.append(Job("bx-diverges", "diverged", scratch=s))
    summary = run(tasks, tmp_path / "batched")
    run_tasks(tasks, job_worker, tmp_path / "alone", failure_row=job_failure_row, quiet=True)
    batched, alone = by_run_id(tmp_path / "batched"), by_run_id(tmp_path / "alone")
    kept = ("status", "message", "kind", "label", "value", "n", "attempts")
    assert {k: [row[c] for c in kept] for k, row in batched.items()} == {
        k: [row[c] for c in kept] for k, row in alone.items()
    }
    # Grouped in order, but not always logged in order: a keyed batch may pass the in-flight
    # limit, and an idle worker takes it (WorkerPool.submit_keyed), so on loaded cores the
    # second batch has ended first (a clean-clone CI, 2026-11-30).
    assert sorted(batches(scratch)) == [["bx-0", "bx-1", "bx-2"], ["bx-3", "bx-4", "bx-diverges"]]
    assert summary.counts == {RunStatus.OK: 6, RunStatus.DIVERGED: 1}


def test_a_batch_that_crashes_is_retried_once_as_a_batch(tmp_path, scratch):
    s = str(scratch)
    tasks = [Job("bx-1", scratch=s), Job("bx-once", "crash-once", scratch=s), Job("a", scratch=s)]
    tasks += [Job("by-1", scratch=s), Job("by-dies", "crash", scratch=s)]
    summary = run(tasks, tmp_path / "out")
    rows = by_run_id(tmp_path / "out")
    assert [rows[k]["status"] for k in ("bx-1", "bx-once", "a")] == ["ok", "ok", "ok"]
    assert rows["bx-1"]["attempts"] == rows["bx-once"]["attempts"] == 2
    # A task that always kills its worker takes its batch with it: every task crashed.
    assert [rows[k]["status"] for k in ("by-1", "by-dies")] == ["crashed", "crashed"]
    assert rows["by-1"]["label"] == "label-by-1"  # each task's own failure row
    assert rows["by-1"]["message"].endswith("(in a batch of 2 runs)")  # said so
    assert calls(scratch).count("by-1") == 2
    assert summary.counts == {RunStatus.OK: 3, RunStatus.CRASHED: 2}


def test_a_batch_has_the_sum_of_its_tasks_time_limits(tmp_path, scratch):
    s = str(scratch)
    tasks = [Job("bx-hangs", "hang", scratch=s), Job("bx-2", scratch=s), Job("a", scratch=s)]
    outcome: list[RunSummary] = []
    sweep = threading.Thread(
        target=lambda: outcome.append(run(tasks, tmp_path / "out", timeout=0.75)), daemon=True
    )
    sweep.start()
    sweep.join(timeout=30)
    assert outcome, "the sweep did not finish"
    rows = by_run_id(tmp_path / "out")
    assert [rows[k]["status"] for k in ("bx-hangs", "bx-2", "a")] == ["timeout", "timeout", "ok"]
    assert "1.5 s" in rows["bx-2"]["message"]
    assert outcome[0].counts == {RunStatus.OK: 1, RunStatus.TIMEOUT: 2}


def test_a_resumed_sweep_batches_what_is_left(tmp_path, scratch):
    s = str(scratch)
    tasks = [Job(f"bx-{i}", scratch=s) for i in range(2)]
    tasks += [Job("bx-flaky", "flaky-crash", scratch=s), Job("bx-3", scratch=s)]
    run(tasks, tmp_path / "out")
    assert by_run_id(tmp_path / "out")["bx-0"]["status"] == "crashed"
    (scratch / "healthy").touch()
    (scratch / "batches.log").unlink()
    second = run(tasks, tmp_path / "out", resume=True)
    assert batches(scratch) == [["bx-0", "bx-1", "bx-flaky"]]  # bx-3 was stored: skipped
    assert second.skipped == 1 and second.counts == {RunStatus.OK: 3}


def wait_here(path: str) -> int:
    """test_runner's wait_for_file, from this module: its worker imports it meanwhile."""
    return wait_for_file(path)


def job_batch_worker_pids(jobs: list[Job]) -> list[dict]:
    """job_batch_worker, each row with its worker's pid."""
    return [{**row, "pid": os.getpid()} for row in job_batch_worker(jobs)]


def test_a_keys_batches_keep_to_one_worker_and_the_other_runs_the_rest(tmp_path, scratch):
    """The batches of one affinity key run in the worker that ran the first, though they are
    more than the calls in flight: the runner submits them past its limit, so that the pool
    has other calls for the other worker (about 1.5 s of sleeps, 3 s of CPU)."""
    s = str(scratch)
    tasks = [Job(f"bx-{i}", "sleep", 0.1, s) for i in range(6)]
    tasks += [Job(f"a-{i}", "sleep", 0.1, s) for i in range(12)]
    batching = Batching(job_batch_worker_pids, job_key, 1, affinity=lambda key: "x-engine")
    with WorkerPool(2) as pool:
        # Both workers free at once (this module imported), every call queued.
        hold_workers(pool, scratch / "go", wait_here)

        # The workers come free once the 6 batches and the 2 calls in flight are queued
        # (or after 20 s: a runner that holds the batches back fails below, not hangs).
        def open_when_queued() -> None:
            wait_until(lambda: len(pool._pending) >= 8)
            (scratch / "go").touch()

        opener = threading.Thread(target=open_when_queued)
        opener.start()
        summary = run_tasks(
            tasks, job_worker, tmp_path / "out", executor=pool, batching=batching, quiet=True
        )
    opener.join()
    assert summary.counts == {RunStatus.OK: 18}
    rows = by_run_id(tmp_path / "out")
    assert len({rows[f"bx-{i}"]["pid"] for i in range(6)}) == 1
    assert [line for line in batches(scratch)] == [[f"bx-{i}"] for i in range(6)]
