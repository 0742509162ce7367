"""The suite runner survives what an overnight sweep meets: workers that crash, hang or raise,
odd rows, readers mid-sweep, interrupts, resumes. The workers below are real processes doing
the real failure (os._exit, sleep(1000), raise), not mocks of the pool.

Nothing here asserts a time; the sleeps only make a sweep last long enough to be read or
interrupted while it runs.
"""

from __future__ import annotations

import io
import math
import os
import signal
import subprocess
import sys
import threading
import time
import uuid
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.base import POOL_WORKERS_VARIABLE, cores_per_process
from hoopbench.engines.run import RunStatus
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep import runner as runner_module
from hoopbench.reports.sweep.results import TIMING_COLUMNS, read_runs
from hoopbench.reports.sweep.runner import (
    LOCK_NAME,
    ExecutorBrokenError,
    FolderInUseError,
    OutputDirNotEmptyError,
    RemoteTracebackError,
    RunSummary,
    WorkerCrashedError,
    WorkerKilledError,
    WorkerPool,
    _Progress,
    claim_folder,
    run_tasks,
)

TESTS = Path(__file__).resolve().parent


# ------------------------------------------------------------------ tasks and workers
@dataclass(frozen=True)
class Job:
    run_id: str
    kind: str = "ok"
    """ok, crash, crash-once, hang, raise, nan, diverged, sleep, flaky."""
    seconds: float = 0.0
    scratch: str = ""
    """A folder for marker files: calls.log (one line per call), pids/ (one file per worker)."""


def job_worker(job: Job) -> dict:
    scratch = Path(job.scratch) if job.scratch else None
    if scratch is not None:
        (scratch / "pids").mkdir(exist_ok=True)
        (scratch / "pids" / str(os.getpid())).touch()
        with open(scratch / "calls.log", "a") as log:
            log.write(job.run_id + "\n")
    healthy = scratch is not None and (scratch / "healthy").exists()
    if job.kind == "crash" or (job.kind == "flaky-crash" and not healthy):
        os._exit(1)
    if job.kind == "crash-once":
        marker = scratch / f"{job.run_id}.crashed"
        if not marker.exists():
            marker.touch()
            os._exit(1)
    if job.kind == "hang" or (job.kind == "flaky-hang" and not healthy):
        time.sleep(1000)
    if job.kind == "raise":
        raise ValueError(f"boom in {job.run_id}")
    time.sleep(job.seconds)
    index = int(job.run_id.rsplit("-", 1)[-1]) if job.run_id[-1].isdigit() else 0
    row = {
        "status": "diverged" if job.kind == "diverged" else "ok",
        "message": "energy rose" if job.kind == "diverged" else "",
        "kind": job.kind,
        "label": f"label-{job.run_id}",
        "value": math.sin(index),
        "n": index,
    }
    if job.kind == "nan":
        row.update(value=float("nan"), big=float("inf"), small=-np.inf, none=None)
        row.update(np_nan=np.float64("nan"), settings={"cone": "pyramidal", "mu": float("nan")})
    return row


def job_failure_row(job: Job, status: RunStatus, message: str) -> dict:
    return {"kind": job.kind, "label": f"label-{job.run_id}"}


def sweep_tasks(scratch: str = "") -> list[Job]:
    """The sweep of the interrupt test: long enough to be interrupted, with a diverged and
    a NaN row among the ordinary ones."""
    jobs = [Job(f"run-{i:02d}", "sleep", 0.15, scratch) for i in range(24)]
    jobs[5] = Job("run-05", "diverged", 0.15, scratch)
    jobs[11] = Job("run-11", "nan", 0.15, scratch)
    return jobs


def run(tasks, out, **kwargs) -> RunSummary:
    kwargs.setdefault("jobs", 2)
    kwargs.setdefault("quiet", True)
    kwargs.setdefault("failure_row", job_failure_row)
    return run_tasks(tasks, job_worker, out, **kwargs)


def calls(scratch: Path) -> list[str]:
    log = scratch / "calls.log"
    return log.read_text().split() if log.exists() else []


def alive(pid: int) -> bool:
    """True if the process runs (a zombie, dead but not yet reaped, counts as gone)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (FileNotFoundError, ProcessLookupError):
        return False


def wait_until(predicate, timeout: float = 20.0, step: float = 0.05) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return predicate()


def by_run_id(out: Path) -> dict[str, dict]:
    return {row["run_id"]: row for row in read_runs(out).to_dict("records")}


@pytest.fixture
def scratch(tmp_path: Path) -> Path:
    folder = tmp_path / "scratch"
    folder.mkdir()
    return folder


# ------------------------------------------------------------------ failures of a run
def test_a_worker_that_always_crashes_gives_a_crashed_row_after_one_retry(tmp_path, scratch):
    tasks = [Job(f"ok-{i}", scratch=str(scratch)) for i in range(4)]
    tasks.insert(1, Job("dies", "crash", scratch=str(scratch)))
    summary = run(tasks, tmp_path / "out")
    rows = by_run_id(tmp_path / "out")
    assert rows["dies"]["status"] == "crashed"
    assert rows["dies"]["attempts"] == 2
    assert "exit code 1" in rows["dies"]["message"]
    assert rows["dies"]["label"] == "label-dies"  # the caller's failure_row columns
    assert calls(scratch).count("dies") == 2  # tried, retried once, given up
    assert all(rows[f"ok-{i}"]["status"] == "ok" for i in range(4))
    assert summary.counts == {RunStatus.OK: 4, RunStatus.CRASHED: 1}


def test_a_worker_that_crashes_once_is_ok_on_the_retry(tmp_path, scratch):
    tasks = [Job("once", "crash-once", scratch=str(scratch)), Job("ok-1", scratch=str(scratch))]
    run(tasks, tmp_path / "out")
    rows = by_run_id(tmp_path / "out")
    assert rows["once"]["status"] == "ok"
    assert rows["once"]["attempts"] == 2
    assert rows["ok-1"]["status"] == "ok"


def test_a_hung_run_times_out_its_worker_is_killed_and_the_sweep_finishes(tmp_path, scratch):
    tasks = [Job("hangs", "hang", scratch=str(scratch))]
    tasks += [Job(f"ok-{i}", "sleep", 0.05, str(scratch)) for i in range(4)]
    limits = lambda job: 1.0 if job.kind == "hang" else 30  # noqa: E731
    # In a thread, so that a runner ignoring the limit fails here instead of hanging pytest
    # (off the main thread the runner leaves the signal handlers alone).
    outcome: list[RunSummary] = []
    sweep = threading.Thread(
        target=lambda: outcome.append(run(tasks, tmp_path / "out", timeout=limits)), daemon=True
    )
    sweep.start()
    sweep.join(timeout=30)
    assert outcome, "the sweep did not finish"
    summary = outcome[0]
    rows = by_run_id(tmp_path / "out")
    assert rows["hangs"]["status"] == "timeout"
    assert rows["hangs"]["label"] == "label-hangs"
    assert "1 s" in rows["hangs"]["message"]
    assert summary.counts == {RunStatus.OK: 4, RunStatus.TIMEOUT: 1}
    assert calls(scratch).count("hangs") == 2  # retried once: the limit may be the machine's
    pids = [int(p.name) for p in (scratch / "pids").iterdir()]
    assert wait_until(lambda: not any(alive(pid) for pid in pids), timeout=5)


def test_a_worker_that_raises_gives_an_error_row(tmp_path):
    summary = run([Job("raises", "raise"), Job("ok-1")], tmp_path / "out")
    rows = by_run_id(tmp_path / "out")
    assert rows["raises"]["status"] == "error"
    assert "ValueError: boom in raises" in rows["raises"]["message"]
    assert rows["raises"]["label"] == "label-raises"
    assert rows["ok-1"]["status"] == "ok"
    assert summary.completed and summary.exit_code == 0


def test_nan_infinities_none_and_nested_values_pass_through(tmp_path):
    run([Job("odd", "nan"), Job("plain-3")], tmp_path / "out")
    odd = by_run_id(tmp_path / "out")["odd"]
    assert odd["status"] == "ok"
    assert math.isnan(odd["value"]) and math.isnan(odd["np_nan"])
    assert odd["big"] == math.inf and odd["small"] == -math.inf
    assert odd["none"] is None or math.isnan(odd["none"])
    assert '"cone": "pyramidal"' in odd["settings"]  # nested values are stored as JSON
    csv = pd.read_csv(tmp_path / "out" / "runs.csv")
    assert list(csv["run_id"]) == ["odd", "plain-3"]  # task order, header on line 1
    assert math.isnan(csv.loc[0, "value"]) and csv.loc[0, "big"] == math.inf


# ------------------------------------------------------------------ the results directory
def test_the_dataset_reads_mid_sweep_while_columns_appear_and_widen(tmp_path):
    """pandas.read_parquet(DIR/runs) works at every moment: parts appear whole, and a column
    that first appears (or widens from int to float) in a later part is not lost."""
    out = tmp_path / "out"
    tasks = [Job(f"run-{i:02d}", "sleep", 0.1) for i in range(14)]
    tasks[6] = Job("run-06", "nan", 0.1)  # brings new columns, after parts without them
    seen: list[int] = []
    errors: list[BaseException] = []
    stop = threading.Event()

    def reader() -> None:
        while not stop.is_set():
            if (out / "runs").is_dir():
                try:
                    seen.append(len(pd.read_parquet(out / "runs")))
                except BaseException as exc:
                    errors.append(exc)
            time.sleep(0.01)

    thread = threading.Thread(target=reader)
    thread.start()
    try:
        run(tasks, out, flush_interval=0.1)
    finally:
        stop.set()
        thread.join()
    assert not errors, errors[0]
    assert any(0 < n < len(tasks) for n in seen), seen  # read while the sweep was running
    assert seen == sorted(seen)
    final = pd.read_parquet(out / "runs")
    assert len(final) == len(tasks)
    assert {"big", "settings", "np_nan"} <= set(final.columns)


def test_parts_with_new_columns_and_conflicting_types_read_as_one_table(tmp_path):
    writer = results.RunsWriter(tmp_path / "runs")
    writer.add({"run_id": "a", "status": "ok", "x": 1, "s": 2.5})
    writer.flush()
    writer.add({"run_id": "b", "status": "ok", "x": 1.5, "s": "text", "late": [1, 2]})
    writer.flush()
    frame = pd.read_parquet(tmp_path / "runs")  # plain pandas: the schema file sorts first
    assert list(frame["run_id"]) == ["a", "b"]
    assert list(frame["x"]) == [1.0, 1.5]
    assert list(frame["s"]) == ["2.5", "text"]
    assert frame["late"].isna().iloc[0] and frame["late"].iloc[1] == "[1, 2]"


def test_a_reader_never_meets_half_a_file_and_a_failed_write_stops_the_sweep(tmp_path, monkeypatch):
    """Every write is paused half-way for a reader to look at the dataset, as a reader in
    another process might; from the third part on, writes fail (disk full): the error stops
    the sweep, the workers end, and what was written before still reads."""
    out = tmp_path / "out"
    real_write = results.pq.write_table
    reads: list[int | BaseException] = []
    parts: list[str] = []

    def write_with_a_reader_half_way(table, where, *args, **kwargs):
        Path(where).write_bytes(b"PAR1 half a file")
        if (out / "runs").is_dir():  # before, the folder is being made under a hidden name
            try:
                reads.append(len(pd.read_parquet(out / "runs")))
            except Exception as exc:
                reads.append(exc)
        if "part-" in Path(where).name:
            parts.append(Path(where).name)
            if len(parts) >= 3:  # the disk stays full: the final flush fails too
                raise OSError(28, "No space left on device")
        return real_write(table, where, *args, **kwargs)

    monkeypatch.setattr(results.pq, "write_table", write_with_a_reader_half_way)
    scratch = tmp_path / "scratch"
    scratch.mkdir()
    tasks = [Job(f"r-{i}", "sleep", 0.05, str(scratch)) for i in range(12)]
    with pytest.raises(OSError, match="No space left"):
        run(tasks, out, flush_rows=2)
    assert len(parts) >= 3 and all(isinstance(n, int) for n in reads), reads
    assert len(pd.read_parquet(out / "runs")) == 4  # the two parts written before
    pids = [int(p.name) for p in (scratch / "pids").iterdir()]
    assert wait_until(lambda: not any(alive(pid) for pid in pids), timeout=5)


def test_read_runs_keeps_the_latest_row_of_each_run(tmp_path):
    writer = results.RunsWriter(tmp_path / "runs")
    writer.add({"run_id": "a", "status": "timeout", "message": "first"})
    writer.add({"run_id": "b", "status": "ok"})
    writer.flush()
    again = results.RunsWriter(tmp_path / "runs")  # a resumed session: seq goes on
    again.add({"run_id": "a", "status": "ok", "message": "second"})
    again.flush()
    latest = read_runs(tmp_path)
    assert list(latest["run_id"]) == ["b", "a"]
    assert pd.isna(latest["message"][0]) and latest["message"][1] == "second"
    assert len(read_runs(tmp_path, latest=False)) == 3


# ------------------------------------------------------------------ resume
def test_resume_skips_final_rows_and_retries_timeout_and_crashed(tmp_path, scratch):
    out = tmp_path / "out"
    s = str(scratch)
    tasks = [
        Job("ok-1", scratch=s),
        Job("diverges", "diverged", scratch=s),
        Job("raises", "raise", scratch=s),
        Job("hangs", "flaky-hang", scratch=s),
        Job("dies", "flaky-crash", scratch=s),
        Job("ok-2", scratch=s),
    ]
    first = run(tasks, out, timeout=1.0)
    assert first.counts == {
        RunStatus.OK: 2,
        RunStatus.DIVERGED: 1,
        RunStatus.ERROR: 1,
        RunStatus.TIMEOUT: 1,
        RunStatus.CRASHED: 1,
    }
    (scratch / "healthy").touch()
    (scratch / "calls.log").unlink()
    (out / "runs" / ".part-left-over.parquet.4242.tmp").write_bytes(b"half")
    stream = io.StringIO()
    second = run(tasks, out, timeout=1.0, resume=True, quiet=False, stream=stream)
    assert sorted(calls(scratch)) == ["dies", "hangs"]
    assert second.skipped == 4
    assert second.counts == {RunStatus.OK: 2}
    leftover = [line for line in stream.getvalue().splitlines() if "leftover" in line]
    assert len(leftover) == 1 and ".part-left-over" in leftover[0]
    rows = by_run_id(out)
    assert {k: v["status"] for k, v in rows.items()} == {
        "ok-1": "ok",
        "diverges": "diverged",
        "raises": "error",
        "hangs": "ok",
        "dies": "ok",
        "ok-2": "ok",
    }
    assert len(read_runs(out, latest=False)) == 8  # the first tries stay, superseded
    csv = pd.read_csv(out / "runs.csv")
    assert list(csv["run_id"]) == [t.run_id for t in tasks]
    assert list(csv["status"]) == [rows[t.run_id]["status"] for t in tasks]
    meta = pd.read_json(out / "meta.json", typ="series")
    assert meta["resumed"] and meta["status_counts"] == {"diverged": 1, "error": 1, "ok": 4}


def test_resuming_a_complete_sweep_does_nothing_and_says_so(tmp_path, scratch):
    out = tmp_path / "out"
    tasks = [Job(f"ok-{i}", scratch=str(scratch)) for i in range(3)]
    run(tasks, out)
    stored = [p for p in out.rglob("*") if p.name != LOCK_NAME]  # every sweep takes the lock
    before = {p: p.stat().st_mtime_ns for p in stored}
    (scratch / "calls.log").unlink()
    stream = io.StringIO()
    summary = run(tasks, out, resume=True, quiet=False, stream=stream)
    assert summary.total == 0 and summary.skipped == 3 and summary.completed
    assert calls(scratch) == []
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.name != LOCK_NAME} == before
    assert "nothing to run" in stream.getvalue()
    assert len(stream.getvalue().splitlines()) == 1


def test_a_non_empty_directory_is_refused_without_resume(tmp_path, scratch):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(OutputDirNotEmptyError, match="not empty") as info:
        run([Job("ok-1", scratch=str(scratch))], out)
    assert "\n" not in str(info.value)
    assert calls(scratch) == []
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt"]


# ------------------------------------------------------------------ interrupts
def test_a_signal_after_the_last_run_goes_to_the_handler_it_restores(
    tmp_path, scratch, monkeypatch
):
    """A SIGTERM that comes while a sweep whose runs have all ended flushes its rows stops
    nothing of it (it ran to its end), and is passed on to the handler the sweep restores:
    a caller between sweeps (tune's next trial) hears it. It was dropped."""
    heard: list[int] = []
    previous = signal.signal(signal.SIGTERM, lambda signum, frame: heard.append(signum))
    close = runner_module._Sweep.close

    def close_with_a_signal(self, failed):
        os.kill(os.getpid(), signal.SIGTERM)
        close(self, failed)

    monkeypatch.setattr(runner_module._Sweep, "close", close_with_a_signal)
    try:
        summary = run([Job(f"ok-{i}", scratch=str(scratch)) for i in range(2)], tmp_path / "out")
    finally:
        signal.signal(signal.SIGTERM, previous)
    assert summary.interrupted is None and summary.total == 2
    assert heard == [signal.SIGTERM]


def test_sigterm_stops_the_sweep_keeps_finished_rows_and_restores_handlers(tmp_path, scratch):
    out = tmp_path / "out"
    tasks = [Job(f"run-{i:02d}", "sleep", 0.1, str(scratch)) for i in range(40)]
    previous = signal.getsignal(signal.SIGTERM)

    errors: list[BaseException] = []

    def terminate_after_some_rows() -> None:
        try:  # the dataset is readable from the moment its folder exists
            wait_until(lambda: (out / "runs").is_dir() and len(read_runs(out)) >= 3)
        except BaseException as exc:
            errors.append(exc)
        finally:
            os.kill(os.getpid(), signal.SIGTERM)

    killer = threading.Thread(target=terminate_after_some_rows)
    killer.start()
    summary = run(tasks, out, flush_interval=0.1)
    killer.join()
    assert not errors, errors[0]
    assert summary.interrupted is signal.SIGTERM and summary.exit_code == 143
    assert signal.getsignal(signal.SIGTERM) is previous
    stored = read_runs(out)
    assert len(stored) == summary.total < len(tasks)  # every finished row, flushed
    assert summary.unfinished == len(tasks) - summary.total
    assert not (out / "runs.csv").exists()  # written only when a sweep ends
    pids = [int(p.name) for p in (scratch / "pids").iterdir()]
    assert pids and not any(alive(pid) for pid in pids)


SWEEP_SCRIPT = """
import sys
sys.path.insert(0, {tests!r})
from test_runner import Job, job_failure_row, job_worker, sweep_tasks
from hoopbench.reports.sweep.runner import run_tasks

def main():
    out, resume = sys.argv[1], "--resume" in sys.argv
    tasks = sweep_tasks()
    if "--hang" in sys.argv:  # a hung call first, and a folder to tell the worker pids
        tasks = [Job("hangs", "hang", scratch=sys.argv[-1]), *sweep_tasks(sys.argv[-1])]
    summary = run_tasks(tasks, job_worker, out, failure_row=job_failure_row,
                        jobs=2, resume=resume, flush_interval=0.1)
    if summary.interrupted:
        print(f"interrupted by {{summary.interrupted.name}}; resume with --resume", file=sys.stderr)
    return summary.exit_code

if __name__ == "__main__":
    sys.exit(main())
"""


def start_sweep(tmp_path: Path, *args: str) -> tuple[subprocess.Popen, str]:
    """The sweep script in a subprocess, its environment marked to find its descendants."""
    script = tmp_path / "sweep.py"
    script.write_text(SWEEP_SCRIPT.format(tests=str(TESTS)))
    name, value = "HOOPBENCH_TEST_MARK", str(uuid.uuid4())
    proc = subprocess.Popen(
        [sys.executable, str(script), *args],
        env={**os.environ, name: value},
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    return proc, f"{name}={value}"


def processes_with(marker: str) -> list[int]:
    """Live processes whose environment holds marker: the script and all its descendants."""
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                if marker.encode() in (entry / "environ").read_bytes() and alive(int(entry.name)):
                    found.append(int(entry.name))
            except OSError:
                pass
    return found


UNGUARDED_SCRIPT = """
import sys
sys.path.insert(0, {tests!r})
from test_runner import job_failure_row, job_worker, sweep_tasks
from hoopbench.reports.sweep.runner import run_tasks
summary = run_tasks(sweep_tasks()[:2], job_worker, sys.argv[1], failure_row=job_failure_row, jobs=1)
print(summary.counts)
"""


def test_a_script_without_a_main_guard_is_told_so_and_does_not_hang(tmp_path):
    """The workers import the parent's main script; one that starts a sweep at import would
    start a pool inside a worker, which Python refuses where no one hears, and the sweep hung
    (seen: 12 minutes). Now each worker says why it cannot start, and the runs are crashed."""
    script = tmp_path / "unguarded.py"
    script.write_text(UNGUARDED_SCRIPT.format(tests=str(TESTS)))
    done = subprocess.run(
        [sys.executable, str(script), str(tmp_path / "out")],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert "put the script's code under  if __name__ == '__main__':" in done.stderr
    assert set(read_runs(tmp_path / "out")["status"]) == {"crashed"}


def test_sigint_in_a_real_sweep_then_resume_gives_the_uninterrupted_rows(tmp_path):
    out = tmp_path / "interrupted"
    proc, marker = start_sweep(tmp_path, str(out))
    try:
        assert wait_until(lambda: (out / "runs").is_dir() and len(read_runs(out)) >= 4)
        proc.send_signal(signal.SIGINT)
        _, stderr = proc.communicate(timeout=30)
    finally:
        proc.kill()
    assert proc.returncode == 130, stderr
    assert "interrupted by SIGINT; resume with --resume" in stderr
    assert wait_until(lambda: not processes_with(marker), timeout=5), processes_with(marker)
    partial = len(read_runs(out))
    assert 4 <= partial < len(sweep_tasks())

    proc, _ = start_sweep(tmp_path, str(out), "--resume")
    _, stderr = proc.communicate(timeout=60)
    assert proc.returncode == 0, stderr
    reference = tmp_path / "reference"
    run(sweep_tasks(), reference)  # the same sweep, uninterrupted (here, in this process)

    def comparable(folder: Path) -> pd.DataFrame:
        frame = read_runs(folder).drop(columns=list(TIMING_COLUMNS))
        return frame.sort_values("run_id").reset_index(drop=True)

    pd.testing.assert_frame_equal(comparable(out), comparable(reference))
    resumed_csv = pd.read_csv(out / "runs.csv").drop(columns=list(TIMING_COLUMNS))
    reference_csv = pd.read_csv(reference / "runs.csv").drop(columns=list(TIMING_COLUMNS))
    pd.testing.assert_frame_equal(resumed_csv, reference_csv)


def test_a_parent_killed_outright_leaves_no_worker_behind(tmp_path, scratch):
    """SIGKILL leaves the runner no chance to clean up: the workers notice on their own,
    the one stuck in a hung call included."""
    proc, marker = start_sweep(tmp_path, str(tmp_path / "out"), "--hang", str(scratch))
    try:
        assert wait_until(lambda: "hangs" in calls(scratch) and len(calls(scratch)) >= 3)
        proc.kill()
        proc.communicate(timeout=30)
        gone = wait_until(lambda: not processes_with(marker), timeout=5)
        assert gone, processes_with(marker)
    finally:
        for pid in processes_with(marker):
            os.kill(pid, signal.SIGKILL)


# ------------------------------------------------------------------ progress
class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_on_a_terminal_lines_elsewhere_nothing_when_quiet(tmp_path):
    tasks = [Job("raises", "raise"), *[Job(f"ok-{i}") for i in range(3)]]
    terminal = FakeTerminal()
    run(tasks, tmp_path / "a", quiet=False, stream=terminal)
    assert "4/4" in terminal.getvalue() and "1 failed (error 1)" in terminal.getvalue()
    assert "\r" in terminal.getvalue()  # a bar redrawn in place
    log = io.StringIO()
    run(tasks, tmp_path / "b", quiet=False, stream=log)
    lines = log.getvalue().splitlines()
    assert lines and all(line.startswith("[") for line in lines) and "\r" not in log.getvalue()
    assert lines[-1].startswith("[4/4]") and "eta" in lines[-1]
    quiet = io.StringIO()
    run(tasks, tmp_path / "c", quiet=True, stream=quiet)
    assert quiet.getvalue() == ""


class _PlanSaying:
    """A plan whose layout says 2 min for this sweep and 5 min for all."""

    def etas(self, index: int) -> tuple[float, float]:
        return 120.0, 300.0

    def text(self, index: int, with_eta: bool = True, left: float | None = None) -> str:
        return f"make report: step 1 of 1, eta {left:.0f}s"


def test_a_bar_on_a_plan_shows_the_plans_etas_not_tqdms():
    """On a terminal, a sweep of make report shows the ETA of the plan's layout of its calls
    and the plan's overall one, with no estimate function of its own."""
    terminal = FakeTerminal()
    progress = _Progress(10, terminal, quiet=False)
    progress.plan = _PlanSaying()
    progress.use_plan_estimate()
    progress.update("a run", RunStatus.OK)
    progress.close()
    assert "eta 2m00s; make report: step 1 of 1, eta 300s" in terminal.getvalue()


# ------------------------------------------------------------------ backends
def test_a_foreign_process_pool_crash_counts_raise_as_crash_and_broken_pool_stops(tmp_path):
    """With a concurrent.futures pool, an exception from the future is a crash (retried once,
    then 'crashed'); a pool broken by a dead worker stops the sweep with a one-line error."""
    with ProcessPoolExecutor(max_workers=2) as pool:
        summary = run([Job("raises", "raise"), Job("ok-1")], tmp_path / "a", executor=pool)
    rows = by_run_id(tmp_path / "a")
    assert rows["raises"]["status"] == "crashed" and rows["raises"]["attempts"] == 2
    assert "ValueError: boom in raises" in rows["raises"]["message"]
    assert rows["ok-1"]["status"] == "ok" and summary.completed

    with ProcessPoolExecutor(max_workers=1) as pool, pytest.raises(ExecutorBrokenError):
        run([Job("dies", "crash")], tmp_path / "b", executor=pool)


def test_progress_counts_a_diverged_run_as_a_result_not_a_failure(tmp_path):
    """A diverged run is judged like any other (its verdict is diverged): the progress line
    says so apart from the runs that gave no result."""
    tasks = [Job("diverges", "diverged"), Job("raises", "raise"), Job("ok-1")]
    log = io.StringIO()
    run(tasks, tmp_path / "out", quiet=False, stream=log)
    last = log.getvalue().splitlines()[-1]
    assert "1 failed (error 1); 1 diverged" in last, last
    log = io.StringIO()
    run([Job("diverges", "diverged"), Job("ok-1")], tmp_path / "other", quiet=False, stream=log)
    assert "no failures; 1 diverged" in log.getvalue().splitlines()[-1]


def test_a_foreign_thread_pool_times_out_by_abandoning_the_call(tmp_path):
    with ThreadPoolExecutor(max_workers=2) as pool:
        tasks = [Job("slow", "sleep", 2.0), *[Job(f"ok-{i}") for i in range(3)]]
        summary = run(tasks, tmp_path / "out", executor=pool, timeout=0.5)
    rows = by_run_id(tmp_path / "out")
    assert rows["slow"]["status"] == "timeout" and rows["slow"]["label"] == "label-slow"
    assert summary.counts == {RunStatus.OK: 3, RunStatus.TIMEOUT: 1}


def test_a_worker_knows_the_pool_size_and_its_share_of_the_cores():
    """Engines with a thread pool (MJX's XLA) size it to the worker's share of the cores."""
    with WorkerPool(3) as pool:
        seen = pool.submit(os.getenv, POOL_WORKERS_VARIABLE).result(timeout=30)
        share = pool.submit(cores_per_process).result(timeout=30)
    assert seen == "3"
    cores = len(os.sched_getaffinity(0))
    assert share == max(1, cores // 3)
    assert cores_per_process() == cores  # this process is no pool's worker


def test_worker_pool_is_an_executor_that_kills_one_call_and_replaces_dead_workers():
    with WorkerPool(2) as pool:
        assert pool.submit(pow, 2, 10).result(timeout=30) == 1024
        error = pool.submit(job_worker, Job("raises", "raise")).exception(timeout=30)
        assert isinstance(error, ValueError)
        assert isinstance(error.__cause__, RemoteTracebackError)
        assert "job_worker" in str(error.__cause__)
        crashed = pool.submit(job_worker, Job("dies", "crash")).exception(timeout=30)
        assert isinstance(crashed, WorkerCrashedError) and crashed.exitcode == 1
        hung = pool.submit(job_worker, Job("hangs", "hang"))
        assert wait_until(hung.running)
        assert wait_until(lambda: hung.worker_pid is not None)
        pid = hung.worker_pid
        assert pool.kill(hung)
        assert isinstance(hung.exception(timeout=30), WorkerKilledError)
        assert wait_until(lambda: not alive(pid), timeout=5)
        assert pool.submit(pow, 3, 2).result(timeout=30) == 9  # a new worker took over
        pids = pool.pids
    assert pids and not any(alive(p) for p in pids)


def wait_for_file(path: str) -> int:
    """A call that holds its worker until ``path`` exists; its worker's pid."""
    while not os.path.exists(path):
        time.sleep(0.01)
    return os.getpid()


def sleep_pid(seconds: float) -> int:
    time.sleep(seconds)
    return os.getpid()


def burn_pid(seconds: float) -> int:
    """Spend ``seconds`` of this process's CPU time."""
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass
    return os.getpid()


def hold_workers(pool: WorkerPool, gate: Path, wait: Callable[[str], int] = wait_for_file) -> None:
    """Every worker of ``pool`` started and busy (in ``wait``) until ``gate`` exists: the
    calls submitted meanwhile are all queued when the workers come free together."""
    held = [pool.submit(wait, str(gate)) for _ in range(pool.max_workers)]
    assert wait_until(lambda: all(f.worker_pid is not None for f in held), timeout=60)


def test_calls_of_a_key_keep_to_one_worker_while_the_other_takes_the_rest(tmp_path):
    """A key's calls (a batched engine's) run where the first of them ran, while the other
    worker takes the calls queued behind them (0.7 s of sleeps, about 2 s of CPU)."""
    with WorkerPool(2) as pool:
        hold_workers(pool, tmp_path / "go")
        keyed = [pool.submit_keyed("mjx", sleep_pid, 0.1) for _ in range(4)]
        plain = [pool.submit(sleep_pid, 0.1) for _ in range(6)]
        (tmp_path / "go").touch()
        keyed_pids = {f.result(timeout=30) for f in keyed}
        first_plain = plain[0].result(timeout=30)
        assert all(f.result(timeout=30) for f in plain)
    assert len(keyed_pids) == 1
    assert first_plain not in keyed_pids  # taken while the key's calls waited for theirs


def test_a_worker_with_no_call_of_its_own_takes_anothers_key_rather_than_idle(tmp_path):
    """Affinity is a preference: a worker idles only when nothing is queued. With only one
    key's calls queued and its worker busy, the other worker runs them."""
    with WorkerPool(2) as pool:
        hold_workers(pool, tmp_path / "go")
        long = pool.submit_keyed("mjx", sleep_pid, 2.0)
        short = [pool.submit_keyed("mjx", sleep_pid, 0.0) for _ in range(3)]
        (tmp_path / "go").touch()
        assert all(f.result(timeout=30) != long.worker_pid for f in short)
        assert long.result(timeout=30)
        assert long.started_at is not None
        assert all(f.started_at is not None and f.started_at < long.started_at + 1.5 for f in short)


def test_a_call_knows_the_cpu_time_its_worker_spent_on_it():
    """PoolFuture.cpu_s, where /proc tells: a call that spins, not one that sleeps
    (about 0.8 s of CPU)."""
    with WorkerPool(1) as pool:
        burning = pool.submit(burn_pid, 0.3)
        burning.result(timeout=30)
        sleeping = pool.submit(sleep_pid, 0.3)
        sleeping.result(timeout=30)
    if not os.path.exists(f"/proc/{os.getpid()}/stat"):
        assert burning.cpu_s is None
        return
    assert burning.cpu_s is not None and 0.25 <= burning.cpu_s < 1.0
    assert sleeping.cpu_s is not None and sleeping.cpu_s < 0.1


# ------------------------------------------------------------------ one sweep per folder
def test_a_second_sweep_on_a_locked_folder_is_refused_and_a_killed_sweeps_lock_taken_over(
    tmp_path, scratch
):
    """Two processes on one folder: the second (fresh or resumed) is refused naming the first's
    pid, and runs nothing; once the first is SIGKILLed, its lock is taken over."""
    out = tmp_path / "out"
    proc, marker = start_sweep(tmp_path, str(out), "--hang", str(scratch))
    try:
        assert wait_until(lambda: "hangs" in calls(scratch) and len(calls(scratch)) >= 3)
        before = len(calls(scratch))
        for resume in (True, False):
            with pytest.raises(
                FolderInUseError, match=f"in use by another sweep \\(pid {proc.pid} "
            ):
                run(sweep_tasks(str(scratch)), out, resume=resume)
        proc.kill()
        proc.communicate(timeout=30)
        assert wait_until(lambda: not processes_with(marker), timeout=5)
        assert len(calls(scratch)) >= before  # (the refused sweeps added no call of their own)
    finally:
        for pid in processes_with(marker):
            os.kill(pid, signal.SIGKILL)
    said = io.StringIO()
    summary = run(sweep_tasks(), out, resume=True, quiet=False, stream=said)
    assert summary.completed
    assert f"taking over the lock of a sweep that ended without releasing it (pid {proc.pid} " in (
        said.getvalue()
    )
    assert (out / LOCK_NAME).read_text() == ""  # released: the next one takes it silently


def test_two_sweeps_at_once_in_a_new_folder_one_is_refused_and_nothing_is_left(tmp_path):
    """The second sweep into a new folder while the first holds it (here a thread of this
    process, which flock tells apart as another open file): one line, no traceback, no
    temporary dataset folder left behind (it was an ENOTEMPTY race in RunsWriter)."""
    out = tmp_path / "new"
    holding, release = threading.Event(), threading.Event()

    def first() -> None:
        with claim_folder(out, resume=False):
            holding.set()
            release.wait(30)

    thread = threading.Thread(target=first)
    thread.start()
    try:
        assert holding.wait(30)
        with pytest.raises(FolderInUseError, match=f"pid {os.getpid()} "):
            run(sweep_tasks()[:2], out)
    finally:
        release.set()
        thread.join()
    assert sorted(p.name for p in out.iterdir()) == [LOCK_NAME]
    assert run(sweep_tasks()[:2], out).completed  # then free, and empty but for the lock


def test_a_sweep_started_from_a_script_on_stdin_runs(tmp_path):
    """``python - <<EOF``: multiprocessing had every worker run '<cwd>/<stdin>' as the main
    script, a FileNotFoundError traceback per worker and every row crashed."""
    script = SWEEP_SCRIPT.format(tests=str(TESTS)).replace(
        'if __name__ == "__main__":\n    sys.exit(main())', "main()"
    )
    done = subprocess.run(
        [sys.executable, "-", str(tmp_path / "out")],
        input=script,
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr, done.stderr
    assert set(read_runs(tmp_path / "out")["status"]) == {"ok", "diverged"}
