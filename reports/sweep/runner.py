"""Run a sweep of independent tasks so that it can be left running overnight.

The suite is thousands of engine runs, each in code we do not control: an engine may hang,
segfault, or eat the machine's memory. A plain ``ProcessPoolExecutor`` turns one dead worker
into a broken pool that fails every run still queued, and it cannot stop one hung call. So:

* :class:`WorkerPool` is a ``concurrent.futures.Executor`` whose workers run one call at a
  time and are reused (a process start with the engines' imports costs about a second). It
  can kill the worker of one future (:meth:`WorkerPool.kill`, for timeouts), and when a worker
  dies it fails that future with :class:`WorkerCrashedError` and starts another worker; the
  rest of the sweep goes on. Workers come from a fork server (forking a parent that runs
  threads is unsafe) and exit on their own if the parent dies, even by SIGKILL.
* :func:`run_tasks` drives any executor-like backend (``submit`` returning futures; e.g.
  Dask's ``Client.get_executor()``). It keeps only rows, a few futures and counters, so its
  memory does not grow with the sweep; rows go to disk every couple of seconds
  (:mod:`hoopbench.reports.sweep.results`), so an interrupted or killed sweep loses only the runs
  in progress, and ``resume=True`` runs what is missing. A run past its time limit is tried
  once more with the same limit (a loaded machine ends runs too) and then becomes a
  ``timeout`` row, a run whose worker died twice a ``crashed`` row; both are retried by a
  resumed sweep. SIGINT and SIGTERM stop the sweep cleanly and are reported in the summary,
  so that the command line can exit 130 or 143 and say how to resume.

Why not a library's pool (pebble 5.2.3 and loky 3.7.0 tried against tests/test_runner.py and
the bench): loky fails every call in flight when one worker dies, and can neither stop one
call nor say which worker runs it. pebble passes the fault tests only with glue on its private
classes: it gives no start time or worker pid for a call, its hung workers outlive a
SIGKILLed parent, and a worker that exits 0 mid-call leaves the call pending for ever. It
also costs about 40 microseconds more per run.

The runner knows nothing of engines: a task is any picklable object with a ``run_id``
string, a worker any importable function ``task -> row dict`` (small and picklable) that
catches its own exceptions and sets ``status`` (a :class:`RunStatus` value) in its row.

Batches (:class:`Batching`): tasks that share a key (for hoopbench, one batching engine and
one settings) are grouped, up to a batch size (smaller when there are too few tasks to give
every call in flight a batch), into one call of a batch worker ``tasks ->
rows``, so that a simulator stepping many worlds at once pays its start-up once. A batch is
one call in every respect: one worker process, one time limit (the sum of its tasks'), one
retry after a crash, and every task of it gets a row (its own, or the batch's timeout,
crash or error row; ``attempts`` and ``elapsed_s`` are the batch's); a resumed sweep groups
the tasks still to run afresh. On a :class:`WorkerPool`, the batches of one affinity key
(:attr:`Batching.affinity`; for hoopbench, the engine) keep to the worker that has run one
while the other workers take the calls queued behind them, and are submitted past the
calls-in-flight limit so that those other calls are there (:meth:`WorkerPool.submit_keyed`).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import math
import multiprocessing
import multiprocessing.connection
import os
import pickle
import signal
import socket
import stat
import sys
import threading
import time
import traceback
import warnings
from collections import Counter, deque
from collections.abc import Callable, Hashable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Executor, Future, InvalidStateError
from concurrent.futures import wait as wait_futures
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from importlib import import_module
from multiprocessing.context import BaseContext
from pathlib import Path
from typing import Any, Protocol, TextIO, TypeVar

# tqdm for the progress bar: small, no dependencies, and it shows done/total, rate and ETA
# on a terminal; off a terminal it is disabled and we print plain, throttled lines instead.
from tqdm import tqdm

from hoopbench.engines.base import POOL_WORKERS_VARIABLE
from hoopbench.engines.run import RunStatus
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.control_chars import terminal_text
from hoopbench.reports.sweep.eta import (
    CallCost,
    Costing,
    Rates,
    Running,
    Took,
    call_firsts,
    key_holders,
    ran,
    remaining_seconds,
    warm_counts,
)
from hoopbench.reports.sweep.folder_files import read_folder_text
from hoopbench.reports.sweep.plan import Plan, current_plan, duration_text

__all__ = [
    "IDENTITY_NAME",
    "IN_FLIGHT_PER_WORKER",
    "LOCK_NAME",
    "Batching",
    "Costing",
    "ExecutorBrokenError",
    "FolderInUseError",
    "OtherSweepError",
    "OutputDirNotEmptyError",
    "PoolBrokenError",
    "PoolFuture",
    "RunSummary",
    "RunnerError",
    "StopFlag",
    "Task",
    "TaskBatch",
    "WorkerCrashedError",
    "WorkerKilledError",
    "WorkerPool",
    "check_dir",
    "check_identity",
    "claim_folder",
    "holds_files",
    "is_final_status",
    "prepare_dir",
    "refuse_in_a_starting_worker",
    "row_or_failure",
    "run_tasks",
    "sweep_lock",
]


# =========================================================================== the worker pool
class WorkerCrashedError(RuntimeError):
    """The worker process died while running the call (segfault, os._exit, SIGKILL, OOM)."""

    def __init__(self, message: str, exitcode: int | None = None) -> None:
        super().__init__(message)
        self.exitcode = exitcode


class WorkerKilledError(RuntimeError):
    """The call's worker was killed on request (:meth:`WorkerPool.kill`, ``kill_workers``)."""


class PoolBrokenError(BrokenExecutor):
    """The pool runs no more calls: it could not start a worker process (its fork server
    cannot be restarted), or its manager thread failed. Every call queued or running fails
    with it, and :meth:`WorkerPool.submit` raises it: the thread does not die unheard."""


class RemoteTracebackError(Exception):
    """The traceback of an exception raised in a worker, as text (set as its __cause__)."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class PoolFuture(Future):
    """A Future that also tells when its call started on a worker, on which, and the CPU
    time that worker spent on it."""

    def __init__(self, key: Hashable | None = None) -> None:
        super().__init__()
        self.key = key
        """The call's affinity key (:meth:`WorkerPool.submit_keyed`), else None."""
        self.started_at: float | None = None
        """time.monotonic() when the call was handed to an idle, started worker."""
        self.worker_pid: int | None = None
        self.cpu_s: float | None = None
        """CPU s (user and system, all its threads) its worker spent from the call's start
        to its reply, where the system tells (Linux's /proc), else None."""
        self._cpu_at_start: float | None = None


def _cpu_seconds(pid: int | None) -> float | None:
    """The CPU s (user and system) process ``pid`` has spent so far, from Linux's
    /proc/PID/stat; None elsewhere or when it cannot be read."""
    if pid is None:
        return None
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat_file:
            text = stat_file.read()
        # The name field may hold spaces and parentheses: the fields follow its last ')'.
        fields = text[text.rindex(b")") + 2 :].split()
        return (int(fields[11]) + int(fields[12])) / _CLOCK_TICKS
    except (OSError, ValueError, IndexError):
        return None


_CLOCK_TICKS = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100


_STOP = b""
"""Sent to a worker instead of a call: exit."""

_LOST_WITH_THE_FORK_SERVER = 255
"""The exit code multiprocessing gives a fork server's child when the fork server, which
reports its children's exit codes, died: the worker's own fate is unknown (it may run on)."""

# A resource tracker that died (SIGKILL, the OOM killer) is relaunched by multiprocessing at
# the next worker start with this warning on stderr. The tracker only unlinks named
# semaphores and shared memory that a dead process leaked; the pool's workers make none
# (their pipes are not tracked), so the relaunch loses nothing and a sweep's stderr stays clean.
warnings.filterwarnings(
    "ignore", message="resource_tracker: process died unexpectedly", category=UserWarning
)


def _watch_parent(lifeline: multiprocessing.connection.Connection) -> None:
    """In a worker: exit as soon as the parent is gone (its end of the lifeline closes)."""
    with contextlib.suppress(EOFError, OSError):
        lifeline.recv_bytes()
    os._exit(1)


def _worker_main(
    conn: multiprocessing.connection.Connection,
    lifeline: multiprocessing.connection.Connection,
    lifeline_parent_end: multiprocessing.connection.Connection,
    preload: Sequence[str],
    workers: int = 1,
) -> None:
    """A worker process: run calls one at a time until told to stop or orphaned; ``workers``,
    the pool's size, is left in the environment for engines that size thread pools."""
    os.environ[POOL_WORKERS_VARIABLE] = str(workers)
    # Ctrl-C reaches the whole process group; the parent decides what stops and when.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    lifeline_parent_end.close()  # only a forked child has it open; the parent must hold the last
    threading.Thread(target=_watch_parent, args=(lifeline,), daemon=True).start()
    for name in preload:  # before "ready": import time does not count against a time limit
        with contextlib.suppress(Exception):
            import_module(name)
    if not _reply(conn, pickle.dumps(os.getpid())):
        return
    while True:
        try:
            data = conn.recv_bytes()
        except (EOFError, OSError):
            return
        if data == _STOP:
            return
        try:
            fn, args, kwargs = pickle.loads(data)
            reply: tuple[bool, Any, str | None] = (True, fn(*args, **kwargs), None)
        except BaseException as exc:
            reply = (False, exc, traceback.format_exc())
        try:
            payload = pickle.dumps(reply)
        except Exception as exc:
            what = "result" if reply[0] else f"exception {reply[1]!r}"
            error = RuntimeError(f"the call's {what} cannot be pickled: {exc!r}")
            payload = pickle.dumps((False, error, reply[2]))
        if not _reply(conn, payload):
            return


def _reply(conn: multiprocessing.connection.Connection, payload: bytes) -> bool:
    """Send to the parent; False if it is gone (killed: its end of the pipe closed), when the
    worker ends quietly instead of printing a BrokenPipeError's traceback."""
    try:
        conn.send_bytes(payload)
    except OSError:  # BrokenPipeError, ConnectionResetError: no one to tell
        return False
    return True


@dataclass(eq=False)
class _Worker:
    process: multiprocessing.process.BaseProcess
    conn: multiprocessing.connection.Connection
    pid: int | None = None
    ready: bool = False
    future: PoolFuture | None = None
    killed: bool = False
    conn_open: bool = True
    keys: set[Hashable] = field(default_factory=set)
    """The affinity keys of the calls this process has run (:meth:`WorkerPool.submit_keyed`)."""
    idle_since: float = 0.0
    """time.monotonic() when it last came free (or ready)."""


def _default_context() -> BaseContext:
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")


_main_guard = threading.Lock()


@contextlib.contextmanager
def _main_without_a_missing_file() -> Iterator[None]:
    """While a worker (or the fork server) starts: hide ``__main__.__file__`` if it names no
    file. A script read from stdin (``python - <<EOF``) or given with ``-c`` has '<stdin>' or
    no file, and multiprocessing would have every new process run '<cwd>/<stdin>' as the main
    script: a FileNotFoundError traceback per worker and every run crashed. Without it the
    workers start as from an interactive session (the worker function must then be
    importable, as hoopbench's are)."""
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if main is None or path is None or os.path.isfile(path):
        yield
        return
    with _main_guard:
        del main.__file__
        try:
            yield
        finally:
            main.__file__ = path


def refuse_in_a_starting_worker() -> None:
    """RuntimeError if this process is a worker still importing its parent's main script.

    Workers import the main script; one that starts a sweep at import (no ``if __name__ ==
    '__main__':``) would start it again in every worker. Python refuses the new pool's
    processes in its manager thread, where no one hears it, and the parent's sweep waited
    for ever. Sweeps call this first, so each worker says why it cannot start instead.
    """
    if in_a_starting_worker():
        raise RuntimeError(MAIN_GUARD)


MAIN_GUARD = (
    "a hoopbench worker is importing the main script, which starts a sweep again: "
    "put the script's code under  if __name__ == '__main__':"
)
"""Why a worker cannot start: the advice of docs/cli.md."""


def in_a_starting_worker() -> bool:
    """Whether this process is a worker still importing its parent's main script."""
    return bool(getattr(multiprocessing.current_process(), "_inheriting", False))


def _claimed(future: Future[Any]) -> bool:
    """Whether a queued call's future is running (now, or still: a call whose send failed
    goes back to the queue already running, and setting it running again raised "Future in
    unexpected state" in the manager); False if it was cancelled."""
    return future.running() or future.set_running_or_notify_cancel()


class WorkerPool(Executor):
    """A process pool whose workers run one call at a time and can be killed one by one.

    ``submit(fn, *args)`` returns a :class:`PoolFuture`. If the worker running a call dies,
    its future fails with :class:`WorkerCrashedError`; ``kill(future)`` kills the worker of a
    running call (its future fails with :class:`WorkerKilledError`) or cancels a queued one.
    Dead workers are replaced as calls need them. ``preload`` modules are imported by each
    worker (and by the fork server, when it is started by this pool) before it takes calls.

    The pool outlives its helpers: a fork server that dies (its workers' calls fail with
    WorkerCrashedError, the workers are stopped) is started anew at the next worker start,
    which is tried again after ``START_RETRY_DELAYS``; when every try fails, or the manager
    thread fails for any reason, the pool breaks (:class:`PoolBrokenError`, module
    docstring) instead of leaving its futures pending for ever.
    """

    STEAL_AFTER_S = 0.2
    """s a worker stays idle before it takes a queued call of a key another worker has run
    (:meth:`submit_keyed`): the caller refills the queue with calls of no key as calls end,
    and a worker that took another key's call in that moment would pay what the key costs
    once per process (a batched engine's imports and compiled programs: seconds) for
    nothing."""

    START_RETRY_DELAYS: tuple[float, ...] = (0.2, 1.0, 3.0)
    """Seconds before each new try to start a worker after a failed start; the failure after
    the last breaks the pool. A SIGKILLed fork server refuses connections for a moment before
    multiprocessing sees it dead and starts another (ConnectionRefusedError), or dies
    mid-start (EOFError)."""

    def __init__(
        self,
        max_workers: int | None = None,
        *,
        mp_context: BaseContext | None = None,
        preload: Sequence[str] = (),
    ) -> None:
        self._max_workers = max_workers or os.cpu_count() or 1
        if self._max_workers < 1:
            raise ValueError("max_workers must be at least 1")
        refuse_in_a_starting_worker()
        self._ctx = mp_context or _default_context()
        self._preload = tuple(preload)
        if self._ctx.get_start_method() == "forkserver":
            # The fork server imports these once, so that every worker, replacements
            # included, starts in milliseconds instead of repeating a second of imports.
            # Effective only if this process's fork server is not running yet. '__main__'
            # stays, as in the default, although Python 3.11 does not pass it on to the server.
            self._ctx.set_forkserver_preload(["__main__", __name__, *self._preload])
        self._lock = threading.RLock()
        self._pending: deque[tuple[PoolFuture, bytes]] = deque()
        self._workers: list[_Worker] = []
        self._shutdown = False
        self._startup_failures = 0
        self._start_errors = 0
        """Consecutive failures to start a worker process (the fork server lost)."""
        self._retry_at: float | None = None
        """When to try starting a worker again after a failure (time.monotonic())."""
        self._broken: PoolBrokenError | None = None
        self._wake_at: float | None = None
        """When the manager must wake without news: a deferred worker start."""
        self._thread: threading.Thread | None = None
        self._closed = False
        self._wake_r, self._wake_w = os.pipe()
        os.set_blocking(self._wake_w, False)
        self._lifeline_r, self._lifeline_w = self._ctx.Pipe(duplex=False)

    # ------------------------------------------------------------------ public API
    @property
    def max_workers(self) -> int:
        return self._max_workers

    @property
    def preload(self) -> tuple[str, ...]:
        """The modules each worker imports before it takes calls."""
        return self._preload

    @property
    def pids(self) -> list[int]:
        """Process ids of the live workers."""
        with self._lock:
            return [w.process.pid for w in self._workers if w.process.pid is not None]

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> PoolFuture:
        return self.submit_keyed(None, fn, *args, **kwargs)

    def submit_keyed(
        self, key: Hashable | None, fn: Callable[..., Any], /, *args: Any, **kwargs: Any
    ) -> PoolFuture:
        """:meth:`submit` a call with an affinity ``key`` (None: none): an idle worker takes
        the first queued call that has no key, or a key it has run, or a key no other live
        worker has run; only when no queued call is such, for :attr:`STEAL_AFTER_S`, does it
        take the first queued call (no worker idles while calls wait). So the calls of a key
        run in the process that has paid what the key costs once per process (an engine's
        imports, compiled programs loaded) while other calls keep the other workers busy."""
        data = pickle.dumps((fn, args, kwargs))  # an unpicklable call fails here, not later
        future = PoolFuture(key)
        with self._lock:
            if self._broken is not None:
                raise self._broken
            if self._shutdown:
                raise RuntimeError("cannot submit to a WorkerPool after shutdown")
            self._pending.append((future, data))
            if self._thread is None:
                self._thread = threading.Thread(
                    target=self._manage, name="WorkerPool manager", daemon=True
                )
                self._thread.start()
        self._wake()
        return future

    def kill(self, future: Future) -> bool:
        """Kill the worker running ``future`` (or cancel it if still queued).

        Returns False if the future is not this pool's or has already finished.
        """
        with self._lock:
            for i, (queued, _) in enumerate(self._pending):
                if queued is future:
                    del self._pending[i]
                    return future.cancel()
            worker = next((w for w in self._workers if w.future is future), None)
            if worker is None:
                return False
            worker.future = None
            worker.killed = True
            worker.process.kill()
        future.set_exception(WorkerKilledError(f"worker {worker.pid} killed on request"))
        self._wake()
        return True

    def kill_workers(self) -> None:
        """Kill every worker now, cancel queued calls, fail running ones; then shut down."""
        failed: list[PoolFuture] = []
        with self._lock:
            self._shutdown = True
            cancelled = [f for f, _ in self._pending]
            self._pending.clear()
            for worker in self._workers:
                if worker.future is not None:
                    failed.append(worker.future)
                    worker.future = None
                worker.killed = True
                worker.process.kill()
        for future in cancelled:
            future.cancel()
        for future in failed:
            future.set_exception(WorkerKilledError("worker killed: the pool was shut down"))
        self._wake()
        self._join()

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        with self._lock:
            self._shutdown = True
            cancelled = [f for f, _ in self._pending] if cancel_futures else []
            if cancel_futures:
                self._pending.clear()
        for future in cancelled:
            future.cancel()
        self._wake()
        if wait:
            self._join()

    # ------------------------------------------------------------------ internals
    def _join(self) -> None:
        thread = self._thread
        if thread is not None and thread is not threading.current_thread():
            thread.join()
        if thread is None:
            self._close()

    def _close(self) -> None:
        with self._lock:
            if self._closed:
                return
            self._closed = True
            # Closing our end of the lifeline ends any worker still alive.
            for conn in (self._lifeline_r, self._lifeline_w):
                conn.close()
            for fd in (self._wake_r, self._wake_w):
                os.close(fd)

    def _wake(self) -> None:
        with self._lock:  # never write to a closed (and maybe reused) descriptor
            if not self._closed:
                with contextlib.suppress(BlockingIOError):  # full: already awake
                    os.write(self._wake_w, b"x")

    def _start_worker(self) -> None:
        conn, child_conn = self._ctx.Pipe(duplex=True)
        # Every context has Process; typeshed declares it on the concrete contexts only.
        process = self._ctx.Process(  # type: ignore[attr-defined]
            target=_worker_main,
            args=(
                child_conn,
                self._lifeline_r,
                self._lifeline_w,
                self._preload,
                self._max_workers,
            ),
            name="hoopbench-worker",
            daemon=True,
        )
        try:
            with _main_without_a_missing_file():
                process.start()
        except BaseException:
            conn.close()
            raise
        finally:
            child_conn.close()
        self._workers.append(_Worker(process=process, conn=conn))

    def _start_worker_or_later(self) -> bool:
        """Start a worker (lock held); False if none started: a failed start is tried again
        after the next of START_RETRY_DELAYS, and the failure after the last raises
        PoolBrokenError."""
        now = time.monotonic()
        if self._retry_at is not None and now < self._retry_at:
            return False
        try:
            self._start_worker()
        except Exception as exc:
            tries = self._start_errors + 1
            if self._start_errors >= len(self.START_RETRY_DELAYS):
                raise PoolBrokenError(
                    f"cannot start a worker process ({tries} tries): {_exception_text(exc)}"
                ) from exc
            self._retry_at = now + self.START_RETRY_DELAYS[self._start_errors]
            self._start_errors = tries
            return False
        self._start_errors = 0
        self._retry_at = None
        return True

    def _dispatch(self) -> list[PoolFuture]:
        """Hand queued calls to idle workers and start workers as needed (lock held).
        Returns the futures found cancelled, to be dropped. Each idle worker first takes its
        own (:meth:`submit_keyed`); then any idle worker left takes the first call queued."""
        dropped: list[PoolFuture] = []
        now = time.monotonic()
        steal_at: float | None = None
        for steal in (False, True):
            for worker in self._workers:
                if not self._pending:
                    break
                if not worker.ready or worker.future is not None or worker.killed:
                    continue
                if steal and now < worker.idle_since + self.STEAL_AFTER_S:
                    steal_at = min(steal_at or math.inf, worker.idle_since + self.STEAL_AFTER_S)
                    continue
                self._hand(worker, steal, dropped)
        starting = sum(1 for w in self._workers if not w.ready and not w.killed)
        missing = min(len(self._pending) - starting, self._max_workers - len(self._workers))
        self._wake_at = steal_at  # the manager wakes to let an idle worker take another's
        for _ in range(max(0, missing)):
            if not self._start_worker_or_later():
                wake = [t for t in (steal_at, self._retry_at) if t is not None]
                self._wake_at = min(wake) if wake else None  # and to try again
                break
        return dropped

    def _hand(self, worker: _Worker, steal: bool, dropped: list[PoolFuture]) -> None:
        """Send ``worker`` (idle) the first queued call that is its own, or (``steal``) the
        first queued call; cancelled ones met on the way go to ``dropped`` (lock held)."""
        while True:
            index = 0 if steal else self._own_call(worker)
            if index is None or index >= len(self._pending):
                return
            future, data = self._pending[index]
            del self._pending[index]
            if not _claimed(future):
                dropped.append(future)
                continue
            try:
                worker.conn.send_bytes(data)
            except OSError:  # died between calls: its sentinel will tell; call goes back
                self._pending.insert(index, (future, data))
                worker.killed = True
                return
            future.started_at = time.monotonic()
            future.worker_pid = worker.pid
            future._cpu_at_start = _cpu_seconds(worker.pid)
            worker.future = future
            if future.key is not None:
                worker.keys.add(future.key)
            return

    def _own_call(self, worker: _Worker) -> int | None:
        """The index of the first queued call that ``worker`` should take before any other
        (:meth:`submit_keyed`), else None (lock held)."""
        others = {key for w in self._workers if w is not worker and not w.killed for key in w.keys}
        for index, (future, _) in enumerate(self._pending):
            key = future.key
            if key is None or key in worker.keys or key not in others:
                return index
        return None

    def _receive(self, worker: _Worker) -> tuple[PoolFuture, Any, bool] | None:
        """Read one message from a worker: ready, or a call's outcome to set on its future."""
        try:
            data = worker.conn.recv_bytes()
        except (EOFError, OSError):
            worker.conn_open = False
            return None
        worker.idle_since = time.monotonic()
        if not worker.ready:
            worker.pid = pickle.loads(data)
            worker.ready = True
            self._startup_failures = 0
            return None
        future, worker.future = worker.future, None
        if future is None:  # killed meanwhile: the future already has its exception
            return None
        cpu = _cpu_seconds(worker.pid)
        if cpu is not None and future._cpu_at_start is not None:
            future.cpu_s = cpu - future._cpu_at_start
        try:
            ok, value, tb = pickle.loads(data)
        except Exception as exc:
            ok, value, tb = (
                False,
                RuntimeError(f"cannot unpickle the call's outcome: {exc!r}"),
                None,
            )
        if not ok and tb and isinstance(value, BaseException):
            value.__cause__ = RemoteTracebackError(tb)
        return future, value, ok

    def _reap(self, worker: _Worker) -> list[tuple[PoolFuture, Any, bool]]:
        """A worker's process ended: settle its call, forget it (lock held)."""
        outcomes = []
        while worker.conn_open and worker.conn.poll():  # a reply sent just before dying
            outcome = self._receive(worker)
            if outcome:
                outcomes.append(outcome)
        worker.process.join(timeout=1)
        code = worker.process.exitcode
        lost = self._lost_with_the_fork_server(worker)
        if worker.future is not None:
            message = f"worker {worker.pid} died while running the call (exit code {code})"
            if lost:
                message = f"worker {worker.pid} lost with the fork server (stopped)"
            elif code is not None and code < 0:
                with contextlib.suppress(ValueError):
                    message += f", {signal.Signals(-code).name}"
            outcomes.append((worker.future, WorkerCrashedError(message, code), False))
            worker.future = None
        if not worker.ready and not worker.killed and not lost:
            self._startup_failures += 1
            if self._startup_failures >= 3:  # workers die on start-up: fail the queue
                while self._pending:
                    future, _ = self._pending.popleft()
                    if _claimed(future):
                        error = WorkerCrashedError(
                            f"worker processes die at start-up ({code}; a script that starts "
                            "a sweep keeps its code under  if __name__ == '__main__':)"
                        )
                        outcomes.append((future, error, False))
        self._workers.remove(worker)
        worker.conn.close()
        with contextlib.suppress(ValueError):
            worker.process.close()
        return outcomes

    def _lost_with_the_fork_server(self, worker: _Worker) -> bool:
        """Whether the worker ended as its fork server died; then it is SIGKILLed: orphaned,
        it may still run its call and hold a core (a hung call until this process ends)."""
        lost = worker.process.exitcode == _LOST_WITH_THE_FORK_SERVER
        if not lost or self._ctx.get_start_method() != "forkserver":
            return False
        if worker.process.pid is not None:
            with contextlib.suppress(OSError):
                os.kill(worker.process.pid, signal.SIGKILL)
        return True

    def _manage(self) -> None:
        try:
            self._manage_loop()
        except BaseException as exc:  # a thread that died would leave its futures pending
            self._break(exc)
        finally:
            self._stop_workers()
            self._close()

    def _break(self, exc: BaseException) -> None:
        """The manager cannot go on: every call queued or running fails with PoolBrokenError
        (the cause chained), and submit raises it."""
        broken = exc if isinstance(exc, PoolBrokenError) else None
        if broken is None:
            broken = PoolBrokenError(f"the worker pool's manager failed: {_exception_text(exc)}")
            broken.__cause__ = exc
        with self._lock:
            self._broken = broken
            self._shutdown = True
            queued = [f for f, _ in self._pending]
            self._pending.clear()
            running = [w.future for w in self._workers if w.future is not None]
            for worker in self._workers:
                worker.future = None
                worker.killed = True
                worker.process.kill()
        for future in queued:
            if not _claimed(future):
                continue
            future.set_exception(broken)
        for future in running:
            with contextlib.suppress(InvalidStateError):  # killed or cancelled meanwhile
                future.set_exception(broken)

    def _manage_loop(self) -> None:
        while True:
            with self._lock:
                self._dispatch()
                busy = any(w.future is not None for w in self._workers)
                if self._shutdown and not self._pending and not busy:
                    return
                waitables = self._waitables()
                wake_at = self._wake_at
            timeout = None if wake_at is None else max(0.0, wake_at - time.monotonic())
            ready = multiprocessing.connection.wait(waitables, timeout)
            with self._lock:
                outcomes = self._collect(ready)
            # Outside the lock: a done-callback may submit again.
            for future, value, ok in outcomes:
                if future.done():
                    continue
                if ok:
                    future.set_result(value)
                else:
                    future.set_exception(value)

    def _waitables(self) -> list[Any]:
        """What the manager waits on: the wake pipe, each worker's sentinel and pipe (lock held)."""
        waitables: list[Any] = [self._wake_r]
        for w in self._workers:
            waitables.append(w.process.sentinel)
            if w.conn_open:
                waitables.append(w.conn)
        return waitables

    def _collect(self, ready: list[Any]) -> list[tuple[PoolFuture, Any, bool]]:
        """Messages and deaths of the ready workers: outcomes to set on futures (lock held)."""
        outcomes: list[tuple[PoolFuture, Any, bool]] = []
        if self._wake_r in ready:
            with contextlib.suppress(BlockingIOError, OSError):
                os.read(self._wake_r, 4096)
        for w in list(self._workers):
            if w.conn_open and w.conn in ready:
                outcome = self._receive(w)
                if outcome:
                    outcomes.append(outcome)
        for w in list(self._workers):
            if w.process.sentinel in ready:
                outcomes.extend(self._reap(w))
        return outcomes

    def _stop_workers(self) -> None:
        with self._lock:
            workers, self._workers = list(self._workers), []
        for w in workers:
            if w.ready and not w.killed:
                with contextlib.suppress(OSError):
                    w.conn.send_bytes(_STOP)
            else:
                w.process.kill()
        deadline = time.monotonic() + 5
        for w in workers:
            w.process.join(timeout=max(0.0, deadline - time.monotonic()))
            if w.process.exitcode is None:
                w.process.kill()
                w.process.join(timeout=5)
            w.conn.close()


# =========================================================================== the runner
class Task(Protocol):
    """What the runner needs of a task: a unique id. It must also pickle."""

    @property
    def run_id(self) -> str: ...


Row = dict[str, Any]
Worker = Callable[[Any], Mapping[str, Any]]
FailureRow = Callable[[Any, RunStatus, str], Mapping[str, Any]]
BatchWorker = Callable[[list[Any]], Sequence[Mapping[str, Any]]]


@dataclass(frozen=True)
class Batching:
    """How :func:`run_tasks` groups tasks into batches."""

    worker: BatchWorker
    """An importable module-level function: tasks -> their rows, in order (as ``worker``
    for one task; it catches its own exceptions)."""
    key: Callable[[Any], Hashable | None]
    """Tasks with equal keys may share a batch; None: the task runs alone. Called here."""
    size: int
    """Tasks per batch at most (>= 1)."""
    least: Callable[[Hashable], int] = lambda key: 1
    """The fewest tasks of a key that a batch is cut to when the key's tasks are spread
    over the calls in flight (an engine that pads every call to a fixed number of worlds
    gains nothing from smaller batches). Called here."""
    affinity: Callable[[Hashable], Hashable | None] = lambda key: key
    """A batch key -> the affinity key of its batches (None: none): on a :class:`WorkerPool`
    the batches of one affinity key run in the worker that has run one, while other calls
    keep the other workers busy (:meth:`WorkerPool.submit_keyed`), so that what a batch
    pays once per process (a simulator's imports and compiled programs) is paid in few
    processes. By default each batch key is its own. Called here."""

    def __post_init__(self) -> None:
        if isinstance(self.size, bool) or not isinstance(self.size, int) or self.size < 1:
            raise ValueError(f"batch size must be a whole number >= 1, got {self.size!r}")

    def units(self, tasks: Sequence[Any], parallel: int = 1) -> list[Any]:
        """The tasks as calls: each task alone, or a TaskBatch of up to ``size`` tasks of one
        key, in the order of their first tasks. A key's tasks make at least ``parallel``
        batches where they can (smaller ones), so that a few batches do not leave workers
        idle while one of them steps the rest."""
        keys = [self.key(task) for task in tasks]
        counts = Counter(key for key in keys if key is not None)
        sizes = {
            key: min(self.size, max(self.least(key), -(-n // max(parallel, 1))))
            for key, n in counts.items()
        }
        units: list[Any] = []
        open_batches: dict[Hashable, list[Any]] = {}
        for task, key in zip(tasks, keys, strict=True):
            if key is None:
                units.append(task)
                continue
            members = open_batches.get(key)
            if members is None:
                members = open_batches[key] = []
                units.append((members, self.affinity(key)))
            members.append(task)
            if len(members) == sizes[key]:
                del open_batches[key]
        return [TaskBatch(tuple(u[0]), u[1]) if isinstance(u, tuple) else u for u in units]


@dataclass(frozen=True)
class TaskBatch:
    """Tasks run in one call of a batch worker."""

    tasks: tuple[Any, ...]
    affinity: Hashable | None = None
    """Its affinity key (:attr:`Batching.affinity`), else None."""

    @property
    def run_id(self) -> str:
        return self.tasks[0].run_id

    @property
    def label(self) -> str:
        first = getattr(self.tasks[0], "label", self.run_id)
        return f"{first} (batch of {len(self.tasks)})"


def _tasks_of(unit: Any) -> tuple[Any, ...]:
    return unit.tasks if isinstance(unit, TaskBatch) else (unit,)


class RunnerError(RuntimeError):
    """A sweep cannot start or go on; the message is one line for the command line."""


class OutputDirNotEmptyError(RunnerError):
    """The results directory holds files and ``resume`` was not asked for."""


class ExecutorBrokenError(RunnerError):
    """The executor runs no more calls: a foreign one refuses new work (a ProcessPoolExecutor
    after a worker died, a Dask cluster whose scheduler is lost), or our own WorkerPool
    broke more than MAX_POOL_RENEWALS times. The rows stored so far are kept; the message is
    one line, and the command line exits with EXIT_STATUS and says how to resume."""

    EXIT_STATUS = 75
    """EX_TEMPFAIL of sysexits.h: a failure of the machinery, worth trying again (resume)."""


MAX_POOL_RENEWALS = 2
"""New WorkerPools one sweep starts in place of its own broken one before it gives up."""


@dataclass(frozen=True)
class RunSummary:
    """How a sweep ended."""

    out_dir: Path
    counts: dict[RunStatus, int]
    """Rows written by this session, per status."""
    wall_time_s: float
    interrupted: signal.Signals | None
    """The signal that stopped the sweep, None if it ran to its end."""
    skipped: int
    """Runs not run because a final row was already stored (resume)."""
    unfinished: int
    """Runs left for a resumed sweep because of an interruption."""
    notes: tuple[str, ...] = field(default=())
    """One-line remarks also printed unless quiet (leftover temporary files, nothing to do)."""

    @property
    def total(self) -> int:
        return sum(self.counts.values())

    @property
    def completed(self) -> bool:
        return self.interrupted is None

    @property
    def exit_code(self) -> int:
        """0, or 128 + the signal number (130 for SIGINT, 143 for SIGTERM)."""
        return 0 if self.interrupted is None else 128 + int(self.interrupted)


class _Progress:
    """A tqdm bar on a terminal; throttled plain lines elsewhere; nothing when quiet."""

    def __init__(self, total: int, stream: TextIO, quiet: bool, min_interval: float = 1.0):
        self.total = total
        self.stream = stream
        self.quiet = quiet
        self.done = 0
        self.failures = Counter[RunStatus]()
        self.start = time.monotonic()
        self.min_interval = min_interval
        self.last_line = -float("inf")
        self.estimate: Callable[[], float | None] | None = None
        """Seconds left from the calls' expected costs (run_tasks sets it given a Costing);
        without it, or while it knows no cost, the ETA assumes every run costs the same."""
        self.plan: Plan | None = None
        """The sweeps run in a row that this one is part of: its line ends with theirs."""
        self.plan_index = 0
        """Which of the plan's sweeps this is."""
        self.plan_etas = False
        """Whether its ETA is the plan's layout of it (:meth:`use_plan_estimate`)."""
        isatty = getattr(stream, "isatty", None)
        self.bar = None
        if not quiet and total and isatty is not None and isatty():
            self.bar = tqdm(total=total, file=stream, unit="run", dynamic_ncols=True)

    def use_estimate(self, estimate: Callable[[], float | None]) -> None:
        """The ETA from ``estimate`` (seconds left); the bar then shows it, not tqdm's own."""
        self.estimate = estimate
        self._bar_shows_eta()

    def use_plan_estimate(self) -> None:
        """The ETA from the plan's layout of the calls (:attr:`plan`, set first): a line's
        ETA and its plan's from one layout (Plan.etas)."""
        assert self.plan is not None
        self.plan_etas = True
        self._bar_shows_eta()

    @property
    def costed(self) -> bool:
        """Whether the ETA comes from the calls' expected costs (the plan's or
        :attr:`estimate`), not from the count of runs."""
        return self.plan_etas or self.estimate is not None

    def _bar_shows_eta(self) -> None:
        """The bar's ETA is the costed one, in its postfix: not tqdm's own."""
        if self.bar is not None:
            self.bar.bar_format = "{l_bar}{bar}| {n_fmt}/{total_fmt} [{elapsed}{postfix}]"

    def seconds_left(self, elapsed: float) -> float:
        """The time left: from the calls' expected costs when known, else by count."""
        return self._lefts(elapsed)[0]

    def _lefts(self, elapsed: float) -> tuple[float, float | None]:
        """(:meth:`seconds_left`, the plan's seconds left when worked out with it, else
        None): on a plan, both from one layout of the calls."""
        seconds = whole = None
        with contextlib.suppress(Exception):  # a cost model's bug must not stop a sweep
            if self.plan_etas and self.plan is not None:
                seconds, whole = self.plan.etas(self.plan_index)
            elif self.estimate is not None:
                seconds = self.estimate()
        left = self.total - self.done
        if not left:
            return 0.0, whole
        return (elapsed / self.done * left if seconds is None else seconds), whole

    def eta(self, elapsed: float) -> str:
        return _duration(self.seconds_left(elapsed))

    def _plan_text(self, whole: float | None) -> str:
        """'; make report: step 2 of 4 (finer), runs 500/1244, eta 3m10s', or '' (``whole``:
        the plan's seconds left if worked out, :meth:`_lefts`)."""
        if self.plan is None:
            return ""
        text = ""
        with contextlib.suppress(Exception):  # a cost model's bug must not stop a sweep
            text = f"; {self.plan.text(self.plan_index, left=whole)}"
        return text

    def note(self, text: str) -> None:
        if self.quiet:
            return
        text = terminal_text(text)  # it may quote a folder's files or names
        if self.bar is not None:
            self.bar.write(text, file=self.stream)
        else:
            print(text, file=self.stream, flush=True)

    def _failures_text(self) -> str:
        """'no failures', '2 failed (error 1, timeout 1)'; diverged runs apart: a run that
        diverged is a result about the engine (it is judged), not a run that failed."""
        failed = {s: n for s, n in self.failures.items() if s is not RunStatus.DIVERGED}
        diverged = self.failures[RunStatus.DIVERGED]
        text = "no failures"
        if failed:
            parts = ", ".join(f"{s.value} {n}" for s, n in sorted(failed.items()))
            text = f"{sum(failed.values())} failed ({parts})"
        return text + (f"; {diverged} diverged" if diverged else "")

    def update(self, label: str, status: RunStatus) -> None:
        self.done += 1
        if status is not RunStatus.OK:
            self.failures[status] += 1
        if self.quiet:
            return
        if self.bar is not None:
            self.bar.update(1)
            if self.costed:  # tqdm's own ETA is the count's
                left, whole = self._lefts(time.monotonic() - self.start)
                text = f"{self._failures_text()}, eta {_duration(left)}{self._plan_text(whole)}"
                self.bar.set_postfix_str(text, refresh=False)
            elif status is not RunStatus.OK:
                self.bar.set_postfix_str(self._failures_text(), refresh=False)
            return
        now = time.monotonic()
        last = self.done == self.total
        if status is RunStatus.OK and not last and now - self.last_line < self.min_interval:
            return
        self.last_line = now
        elapsed = now - self.start
        left, whole = self._lefts(elapsed)
        print(
            f"[{self.done}/{self.total}] {terminal_text(label)}: {status.value}; "
            f"{self._failures_text()}; elapsed {_duration(elapsed)}, eta {_duration(left)}"
            f"{self._plan_text(whole)}",
            file=self.stream,
            flush=True,
        )

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


_duration = duration_text


class StopFlag:
    """The first SIGINT or SIGTERM that came (its handler), else None."""

    def __init__(self) -> None:
        self.signal: signal.Signals | None = None

    def __call__(self, signum: int, frame: object) -> None:
        if self.signal is None:
            self.signal = signal.Signals(signum)


@contextlib.contextmanager
def _stop_on_signals(enabled: bool) -> Iterator[StopFlag]:
    """SIGINT and SIGTERM set the flag for the duration; the previous handlers come back."""
    flag = StopFlag()
    installed: dict[signal.Signals, Any] = {}
    if enabled and threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            installed[sig] = signal.getsignal(sig)
            signal.signal(sig, flag)
    try:
        yield flag
    finally:
        for sig, previous in installed.items():
            signal.signal(sig, signal.SIG_DFL if previous is None else previous)


@dataclass
class _Attempt:
    task: Any
    """A task, or a TaskBatch."""
    number: int
    """1 for the first try, then one more for each retry: at most one after a crash and one
    after a timeout."""
    limit: float | None
    submitted_at: float
    crashed_before: bool = False
    """An earlier try's worker died."""
    timed_out_before: bool = False
    """The time limit ended an earlier try."""

    def of(self, task: Any) -> _Attempt:
        """The same attempt, for one task of its batch."""
        return replace(self, task=task)

    def retry(self, *, crashed: bool = False, timed_out: bool = False) -> _Attempt:
        """The next try, after this one crashed or timed out."""
        return _Attempt(
            self.task,
            self.number + 1,
            None,
            0.0,
            self.crashed_before or crashed,
            self.timed_out_before or timed_out,
        )


class _Sweep:
    """The state of one call of run_tasks."""

    def __init__(
        self,
        worker: Worker,
        writer: results.RunsWriter,
        progress: _Progress,
        failure_row: FailureRow | None,
        timeout: float | Callable[[Any], float | None] | None,
        flush_interval: float,
        flush_rows: int,
    ) -> None:
        self.worker = worker
        self.writer = writer
        self.progress = progress
        self.failure_row = failure_row
        self.timeout = timeout
        self.flush_interval = flush_interval
        self.flush_rows = flush_rows
        self.counts = Counter[RunStatus]()
        self.last_flush = time.monotonic()

    def limit(self, unit: Any) -> float | None:
        """A call's time limit, s: a batch's is the sum of its tasks' (None if any has none)."""
        limits = [self._task_limit(task) for task in _tasks_of(unit)]
        known = [limit for limit in limits if limit is not None]
        return float(sum(known)) if len(known) == len(limits) else None

    def _task_limit(self, task: Any) -> float | None:
        limit = self.timeout(task) if callable(self.timeout) else self.timeout
        return None if limit is None or limit <= 0 else float(limit)

    def record_value(self, attempt: _Attempt, value: Any, started: float | None) -> None:
        """A call's result: a task's row, or a batch's rows, one per task."""
        if not isinstance(attempt.task, TaskBatch):
            self.record(attempt, self.worker_row(attempt.task, value), started)
            return
        tasks = attempt.task.tasks
        if not isinstance(value, Sequence) or len(value) != len(tasks):
            text = f"batch worker returned {type(value).__name__}, not {len(tasks)} rows"
            self.record_failure(attempt, RunStatus.ERROR, text, started)
            return
        for task, row in zip(tasks, value, strict=True):
            self.record(attempt.of(task), self.worker_row(task, row), started)

    def record_failure(
        self, attempt: _Attempt, status: RunStatus, message: str, started: float | None
    ) -> None:
        """The runner's row for every task of a call that produced none."""
        for task in _tasks_of(attempt.task):
            self.record(attempt.of(task), self.failed_row(task, status, message), started)

    def record(self, attempt: _Attempt, row: Mapping[str, Any], started: float | None) -> None:
        now = time.monotonic()
        full: Row = dict(row)
        full["run_id"] = attempt.task.run_id
        full["attempts"] = attempt.number
        full["elapsed_s"] = now - (attempt.submitted_at if started is None else started)
        full["finished_at"] = datetime.now(UTC)
        self.writer.add(full)
        status = RunStatus(full["status"])
        self.counts[status] += 1
        # A task may say what it is (scene, engine, ...); the run_id alone tells a user little.
        self.progress.update(getattr(attempt.task, "label", attempt.task.run_id), status)
        self.maybe_flush()

    def maybe_flush(self, force: bool = False) -> None:
        due = time.monotonic() - self.last_flush >= self.flush_interval
        if self.writer.buffered and (force or due or self.writer.buffered >= self.flush_rows):
            self.writer.flush()
            self.last_flush = time.monotonic()

    def close(self, failed: bool) -> None:
        """Write the rows still buffered and close the progress bar. A write error is raised
        unless the sweep has failed already: the first error is the one to report."""
        try:
            self.maybe_flush(force=True)
        except Exception:
            if not failed:
                raise
        self.progress.close()

    def worker_row(self, task: Any, value: Any) -> Row:
        """The worker's row, with run_id, a valid status and a message."""
        if not isinstance(value, Mapping):
            kind = type(value).__name__
            return self.failed_row(task, RunStatus.ERROR, f"worker returned {kind}, not a row")
        row = dict(value)
        found: Any = row.get("status")  # whatever the worker put there: checked here
        try:
            row["status"] = RunStatus(found)
        except ValueError:
            text = f"worker row has no valid status ({found!r}); {row.get('message') or ''}"
            row["status"], row["message"] = RunStatus.ERROR, text.rstrip("; ")
        message = row.get("message")
        row["message"] = "" if message is None else str(message)
        return row

    def failed_row(self, task: Any, status: RunStatus, message: str) -> Row:
        """A row made by the runner: the caller's descriptive columns, status and message."""
        row: Row = {}
        if self.failure_row is not None:
            try:
                row = dict(self.failure_row(task, status, message))
            except Exception as exc:
                message = f"{message} (failure_row raised {type(exc).__name__}: {exc})"
        row.update(status=status, message=message)
        return row


def _exception_text(exc: BaseException) -> str:
    text = f"{type(exc).__name__}: {exc}"
    return text if len(text) <= 500 else text[:497] + "..."


T = TypeVar("T")


def row_or_failure(
    work: Callable[[T], dict[str, Any]],
    task: T,
    failure_row: Callable[[T, RunStatus, str], dict[str, Any]],
) -> dict[str, Any]:
    """``work(task)``, the row of one task; an exception anywhere becomes the task's failure
    row with status error, naming the exception: one broken run must not stop a sweep."""
    try:
        return work(task)
    except Exception as exc:
        return failure_row(task, RunStatus.ERROR, f"{type(exc).__name__}: {exc}")


def is_final_status(status: str | None) -> bool:
    """Whether a stored row's status is final (a resumed sweep skips the run)."""
    try:
        return status is not None and RunStatus(status).is_final
    except ValueError:
        return False


LOCK_NAME = ".sweep.lock"
"""The lock file of a results folder. The sweep that holds it (fcntl.flock, for the whole
sweep) writes its pid and host into it and empties it when done, so a lock file that is
free but not empty was left by a sweep that was killed: the next one takes it over. The file
stays (removing it would let a third sweep lock a new file while a second holds the old)."""
IDENTITY_NAME = "sweep.json"
"""What a results folder holds (its kind: a suite or a map; for a suite its name and the
sha256 of its file), written when its first sweep starts: a resume checks it."""
_BOOKKEEPING = (LOCK_NAME, IDENTITY_NAME)


class FolderInUseError(RunnerError):
    """Another sweep (another process, or another thread here) holds the folder's lock."""


class OtherSweepError(RunnerError):
    """A resume into a folder that holds another kind of sweep, or another suite."""


def holds_files(out: Path, ignore: Sequence[str] = ()) -> bool:
    """Whether the folder holds anything besides the runner's bookkeeping and ``ignore``."""
    skip = {*_BOOKKEEPING, *ignore}
    return out.is_dir() and any(p.name not in skip for p in out.iterdir())


def check_dir(out: Path, resume: bool) -> None:
    """RunnerError if the results folder is a file, or holds files without ``resume``;
    nothing is written."""
    if out.exists() and not out.is_dir():
        raise RunnerError(f"{out} exists and is not a directory")
    if not resume and holds_files(out):
        raise OutputDirNotEmptyError(
            f"{out} is not empty: resume the sweep stored there, or choose a new directory"
        )


def prepare_dir(out: Path, resume: bool) -> None:
    """Make the results folder; RunnerError if it is a file, or holds files without
    ``resume``."""
    check_dir(out, resume)
    out.mkdir(parents=True, exist_ok=True)


_held: dict[tuple[Path, int], int] = {}
"""(folder, thread) -> depth of the locks this process holds: a map's two stages, or a suite
around run_tasks, take the lock they already hold."""
_held_guard = threading.Lock()


def _holder(fd: int) -> str:
    text = os.pread(fd, 200, 0).decode("utf-8", "replace").strip()
    return " ".join(text.split()) or "pid unknown"


@contextlib.contextmanager
def sweep_lock(out: Path, say: Callable[[str], None] | None = None) -> Iterator[None]:
    """Hold the folder's lock (LOCK_NAME) for a sweep; FolderInUseError naming the holder's
    pid if another sweep holds it. Makes the folder. Re-entrant in one thread.

    The OS's own lock (flock) rather than a library's: the kernel releases it when its
    process dies, even by SIGKILL, so a stale lock needs no guessing from pids or ages, and
    it costs no dependency (filelock opens its file with O_TRUNC, which would wipe the
    holder's pid before telling us it is held). It works on local disks and on NFS (Linux
    emulates flock with NFS byte-range locks).
    """
    key = (out.resolve(), threading.get_ident())
    with _held_guard:
        nested = key in _held
        _held[key] = _held.get(key, 0) + 1
    try:
        if nested:
            yield
            return
        with _locked_file(out, say):
            yield
    finally:
        with _held_guard:
            _held[key] -= 1
            if not _held[key]:
                del _held[key]


def _open_lock(out: Path, create: bool) -> int | None:
    """The folder's lock file, opened for writing: a regular file inside the folder, never
    through a link (a lock linked to a file elsewhere would be emptied) and without blocking
    (a FIFO); RunnerError naming it otherwise. None if it is not there and not ``create``."""
    path = out / LOCK_NAME
    flags = os.O_RDWR | os.O_NOFOLLOW | os.O_NONBLOCK | (os.O_CREAT if create else 0)
    try:
        fd = os.open(path, flags, 0o644)
    except FileNotFoundError:
        if create:
            raise
        return None
    except OSError as exc:
        if exc.errno != errno.ELOOP:
            raise
        raise RunnerError(
            f"{path} is a link: hoopbench locks a folder only with a file of its own inside it "
            "(nothing was written); remove the link"
        ) from None
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        raise RunnerError(
            f"{path} is not a regular file: hoopbench locks a folder only with a file of its "
            "own inside it (nothing was written); remove it"
        )
    return fd


@contextlib.contextmanager
def _locked_file(out: Path, say: Callable[[str], None] | None) -> Iterator[None]:
    out.mkdir(parents=True, exist_ok=True)
    fd = _open_lock(out, create=True)
    assert fd is not None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderInUseError(_in_use(out, fd)) from None
        left = os.pread(fd, 1, 0)
        if left and say is not None:
            say(
                f"{out}: taking over the lock of a sweep that ended without releasing it "
                f"({_holder(fd)})"
            )
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"pid {os.getpid()} on {socket.gethostname()}\n".encode(), 0)
        try:
            yield
        finally:
            os.ftruncate(fd, 0)
    finally:
        os.close(fd)  # releases the lock


def _refuse_if_locked(out: Path) -> None:
    """FolderInUseError if a sweep holds the folder's lock; nothing is written."""
    try:
        fd = _open_lock(out, create=False)
    except OSError:
        return
    if fd is None:
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        raise FolderInUseError(_in_use(out, fd)) from None
    finally:
        os.close(fd)


def _in_use(out: Path, fd: int) -> str:
    return (
        f"{out} is in use by another sweep ({_holder(fd)}): wait for it to end, "
        "or choose another folder"
    )


def _stored_identity(out: Path) -> dict[str, Any] | None:
    """The folder's sweep.json; else what an older folder's meta.json tells (kind, suite);
    None when neither says."""
    for name in (IDENTITY_NAME, results.META_NAME):
        try:
            stored = json.loads(read_folder_text(out, name) or "null")
        except (OSError, ValueError):
            continue
        if not isinstance(stored, dict):
            continue
        if name == IDENTITY_NAME:
            return stored
        kind = "map" if "map" in stored else "suite"
        return {"kind": kind, "suite": stored.get("suite")} if kind == "suite" else {"kind": kind}
    return None


def _describe(identity: Mapping[str, Any]) -> str:
    if identity.get("kind") != "suite":
        return "a hop map" if identity.get("kind") == "map" else f"a {identity.get('kind')}"
    return f"suite {identity.get('suite')!r}"


Explain = Callable[[Mapping[str, Any], Mapping[str, Any]], str | None]
"""(stored identity, this sweep's) -> what differs in the caller's words, or None: the
generic words."""


def check_identity(out: Path, identity: Mapping[str, Any], explain: Explain | None = None) -> None:
    """OtherSweepError if ``out`` holds another kind of sweep or another suite than
    ``identity`` says (the keys both record are compared); ``explain`` words a difference
    the caller knows better (compare's settings file)."""
    stored = _stored_identity(out)
    if stored is None:
        return
    differ = [k for k in identity if k in stored and stored[k] != identity[k]]
    if not differ:
        return
    said = None if explain is None or "kind" in differ else explain(stored, identity)
    if said is not None:
        raise OtherSweepError(f"{out} {said}")
    if "kind" in differ or "suite" in differ:
        what = f"holds {_describe(stored)}, not {_describe(identity)}"
    else:
        what = f"holds {_describe(stored)} from another suite file ({', '.join(differ)} differ)"
    raise OtherSweepError(
        f"{out} {what}: resume it with its own command and file, or choose a new folder"
    )


@contextlib.contextmanager
def claim_folder(
    out: Path,
    resume: bool,
    identity: Mapping[str, Any] | None = None,
    say: Callable[[str], None] | None = None,
    explain: Explain | None = None,
) -> Iterator[None]:
    """The folder, for one whole sweep: checked, locked (sweep_lock), checked again under the
    lock (a sweep started at the same instant may have filled it), and its identity written
    (a new sweep) or compared (a resume; ``explain``: check_identity's). Nothing is written
    for a refused folder that did not exist or held files."""
    if in_a_starting_worker():  # one line from each worker, not a traceback of "in use"
        raise SystemExit(f"hoopbench: {MAIN_GUARD}")
    try:
        check_dir(out, resume)
    except OutputDirNotEmptyError:
        _refuse_if_locked(out)  # "in use" says more than "not empty"
        raise
    if resume and identity is not None and out.is_dir():
        check_identity(out, identity, explain)
    with sweep_lock(out, say):
        check_dir(out, resume)
        if identity is not None:
            if resume:
                check_identity(out, identity, explain)
            if not (out / IDENTITY_NAME).exists() and not holds_files(out):
                text = json.dumps(dict(identity), indent=2) + "\n"
                results.atomic_write(out / IDENTITY_NAME, lambda tmp: tmp.write_text(text))
        yield


def _finalize(
    out: Path,
    task_order: Sequence[str],
    meta: Mapping[str, Any] | None,
    started_at: datetime,
    wall_start: float,
    resumed: bool,
    session: Mapping[str, Any],
) -> None:
    """runs.csv and meta.json from the latest row of every run."""
    frame = results.read_runs(out)
    rank = {run_id: i for i, run_id in enumerate(task_order)}
    order = frame["run_id"].map(lambda r: rank.get(r, len(rank)))
    frame = frame.iloc[order.argsort(kind="stable")].reset_index(drop=True)
    results.write_csv(frame, out / results.CSV_NAME)
    counts = {str(s): int(n) for s, n in frame["status"].value_counts().sort_index().items()}
    ended = datetime.now(UTC)
    full = dict(meta or {})
    full.update(results.environment_meta())
    full.update(
        started_at=started_at.isoformat(),
        ended_at=ended.isoformat(),
        wall_time_s=round(time.monotonic() - wall_start, 3),
        resumed=resumed,
        runs=len(frame),
        status_counts=counts,
        session=dict(session, load_average_end=results.load_average()),
    )
    results.write_meta(full, out / results.META_NAME)


def _check_run_ids(tasks: Sequence[Any]) -> None:
    """TypeError for a task without a run_id string, ValueError for a run_id seen twice."""
    seen: set[str] = set()
    for task in tasks:
        run_id = getattr(task, "run_id", None)
        if not isinstance(run_id, str) or not run_id:
            raise TypeError(f"task {task!r} has no run_id string")
        if run_id in seen:
            raise ValueError(f"run_id {run_id!r} appears twice")
        seen.add(run_id)


def _resumed_statuses(out: Path, note: Callable[[str], None]) -> dict[str, str]:
    """The latest stored status of every run; leftover temporary files are named, not read."""
    leftovers = results.leftover_temp_files(out)
    if leftovers:
        names = ", ".join(str(p.relative_to(out)) for p in leftovers)
        note(f"resume: ignoring {len(leftovers)} leftover temporary file(s): {names}")
    return results.stored_statuses(out)


IN_FLIGHT_PER_WORKER = 2
"""Calls (of no affinity key) a sweep submits to its WorkerPool at once, per worker: one
queued in the pool for each running, ready the moment a worker is free."""


def _pool_for(
    worker: Worker, executor: Executor | None, jobs: int | None, max_in_flight: int | None
) -> tuple[Executor, int]:
    """The executor that runs the calls (a new WorkerPool without ``executor``, or the
    running plan's shared one) and how many calls may be submitted at once."""
    plan = current_plan.get()
    if executor is None and plan is not None and isinstance(plan.pool, WorkerPool):
        return plan.pool, max_in_flight or IN_FLIGHT_PER_WORKER * plan.pool.max_workers
    if executor is None:
        module = getattr(worker, "__module__", None)
        preload = [module] if module and module not in ("__main__", "__mp_main__") else []
        local = WorkerPool(jobs, preload=preload)
        return local, max_in_flight or IN_FLIGHT_PER_WORKER * local.max_workers
    # A public max_workers (WorkerPool, the Dask cluster's threads) or the stdlib pools'.
    guess = getattr(executor, "max_workers", None) or getattr(executor, "_max_workers", None)
    return executor, max_in_flight or guess or jobs or os.cpu_count() or 1


class _Calls:
    """The calls of one sweep: attempts waiting, futures in flight, and the executor."""

    def __init__(
        self,
        sweep: _Sweep,
        pool: Executor,
        owned: bool,
        todo: Sequence[Any],
        limit: int,
        batch_worker: BatchWorker | None = None,
        note: Callable[[str], None] | None = None,
    ) -> None:
        self.sweep = sweep
        self.pool = pool
        self.owned = owned
        """Whether this sweep made the pool (then it also shuts it down, or replaces it)."""
        self.note = note
        """Says a one-line remark (a pool replaced) to the user and the summary."""
        self.broken: BaseException | None = None
        """Why the executor broke (a call's future failed with BrokenExecutor), until handled."""
        self.renewals = 0
        """Pools this sweep started in place of a broken one of its own."""
        self.batch_worker = batch_worker
        self.queue: deque[_Attempt] = deque(_Attempt(t, 1, None, 0.0) for t in todo)
        self.in_flight: dict[Future, _Attempt] = {}
        self.limit = limit
        """Calls submitted at once, at most."""
        self.costing: Costing | None = None
        """Set (with ``workers``) to estimate the time left (:meth:`remaining`)."""
        self.workers = limit
        """Calls that run at once (the pool's workers)."""
        self.finished: list[Took] = []
        """Each finished call's kinds, steps and the seconds it took (with a Costing)."""
        self._costs: dict[int, CallCost] = {}
        self.prior: Mapping[Hashable, Rates] = {}
        """The Costing's priors (and a plan's: its other sweeps' kinds scale the machine)."""
        self._warm: set[tuple[Hashable, Hashable]] = set()
        """(worker pid, kind) at every level of the calls run: a worker's next is warm."""
        self.plan: Plan | None = None
        """The plan whose shared pool this sweep's calls run on, else None (its own)."""
        self.plan_index = 0
        """Which of the plan's sweeps this is."""

    def _cost(self, unit: Any) -> CallCost:
        """A call's kinds and steps (the Costing's), worked out once per call."""
        assert self.costing is not None
        found = self._costs.get(id(unit))
        if found is None:
            found = replace(self.costing.cost(_tasks_of(unit)), affinity=self._affinity(unit))
            self._costs[id(unit)] = found
        return found

    def _took(
        self, future: Future, attempt: _Attempt, start: float | None, value: Any = None
    ) -> None:
        """A call has ended after running since ``start``: a sample of its kind's cost,
        cold if its worker (known on a local pool) had run none of its kind before, with
        the world-steps its result ``value`` (a row, or a batch's rows) says it took."""
        if self.costing is None or start is None:
            return
        try:
            call = self._cost(attempt.task)
            taken = self._taken(attempt.task, value)
        except Exception:  # a cost model's bug must not stop a sweep: the ETA counts runs
            return
        worker = getattr(future, "worker_pid", None)
        cold, first, new = call_firsts(call, worker, self._warm)
        self._warm |= ran(call, worker)
        seconds = time.monotonic() - start
        cpu = getattr(future, "cpu_s", None)
        self.finished.append(Took(call, seconds, cold, first, new, worker, start, cpu, taken))

    def _taken(self, unit: Any, value: Any) -> float | None:
        """The world-steps a finished call took (the Costing's ``taken``), None unknown."""
        measure = None if self.costing is None else self.costing.taken
        if measure is None or value is None:
            return None
        rows = value if isinstance(unit, TaskBatch) else [value]
        if not isinstance(rows, Sequence):  # a batch worker's bad value: its own row says so
            return None
        return measure(_tasks_of(unit), rows)

    def remaining(self) -> float | None:
        """Seconds left (eta.remaining_seconds): the calls in flight that have started, then
        the others in the order they are submitted. None without a Costing."""
        left = self.left()
        if left is None:
            return None
        running, pending, warm = left
        return remaining_seconds(
            pending,
            running,
            self.finished,
            self.workers,
            self.prior,
            warm_counts(warm),
            key_holders(warm),
        )

    def left(self) -> tuple[list[Running], list[CallCost], set[tuple[Hashable, Hashable]]] | None:
        """The calls in flight that have started, the others in the order they are
        submitted, and (worker, kind) at every level of the calls run (eta.ran; those
        running count); None without a Costing."""
        if self.costing is None:
            return None
        now = time.monotonic()
        running, waiting = [], []
        warm = set(self._warm)  # list(), set(): another sweep's thread may read these
        for future, attempt in list(self.in_flight.items()):
            start = self._started(future, attempt)
            call = self._cost(attempt.task)
            if start is None:
                waiting.append(call)
                continue
            worker = getattr(future, "worker_pid", None)
            cold, first, new = call_firsts(call, worker, self._warm)
            warm |= ran(call, worker)  # its worker is warm for the calls after it
            running.append(Running(call, now - start, cold, first, new, worker))
        pending = waiting + [self._cost(attempt.task) for attempt in list(self.queue)]
        return running, pending, warm

    @property
    def done(self) -> int:
        """Runs done (as its progress counts them)."""
        return self.sweep.progress.done

    @property
    def unfinished(self) -> int:
        """Tasks not run: those of the calls in flight or waiting."""
        attempts = [*self.in_flight.values(), *self.queue]
        return sum(len(_tasks_of(attempt.task)) for attempt in attempts)

    def run(self, flag: StopFlag, tick: float) -> None:
        """Submit, collect and time out calls until all are done or a signal arrives."""
        while True:
            self._submit(flag)
            if flag.signal is not None or (not self.queue and not self.in_flight):
                return
            done, _ = wait_futures(list(self.in_flight), timeout=tick, return_when=FIRST_COMPLETED)
            for future in done:
                self._settle(future, self.in_flight.pop(future), stopping=False)
            if self.broken is not None:
                self._renew_pool()
            self._stop_overdue()
            self.sweep.maybe_flush()

    def _renew_pool(self) -> None:
        """The executor broke: a new WorkerPool in place of our own broken one, the calls it
        lost queued again as they were (a broken pool is not the run's fault); else
        ExecutorBrokenError. The finished rows are kept either way."""
        exc, self.broken = self.broken, None
        assert exc is not None
        old = self.pool
        shared = self.plan is not None and self.plan.pool is not None
        if not (self.owned or shared) or not isinstance(old, WorkerPool):
            raise ExecutorBrokenError(f"the executor is broken ({_exception_text(exc)})") from exc
        if self.renewals >= MAX_POOL_RENEWALS:
            raise ExecutorBrokenError(f"the executor is broken ({_exception_text(exc)})") from exc
        for future, attempt in list(self.in_flight.items()):
            del self.in_flight[future]
            if future.done() and not future.cancelled() and future.exception() is None:
                self._settle(future, attempt, stopping=False)
            else:
                self.queue.appendleft(attempt)
        self.pool = self._new_pool(old)
        self.renewals += 1
        if self.note is not None:
            self.note(f"the worker pool broke ({_exception_text(exc)}); started a new one")

    def _new_pool(self, old: WorkerPool) -> WorkerPool:
        """A new pool in place of ``old``, broken; on a plan's shared pool, the one another
        sweep already started in its place, else a new one that every sweep then uses."""
        if self.plan is None or self.plan.pool is None:
            old.kill_workers()
            return WorkerPool(old.max_workers, preload=old.preload)
        with self.plan.lock:
            if self.plan.pool is old:
                old.kill_workers()
                self.plan.pool = WorkerPool(old.max_workers, preload=old.preload)
            new: WorkerPool = self.plan.pool
            return new

    def stop(self) -> None:
        """Done, interrupted or failed: stop the calls still running, keep every finished row."""
        pool = self.pool
        if isinstance(pool, WorkerPool) and self.owned:
            if self.in_flight or self.queue:
                pool.kill_workers()
            else:
                pool.shutdown(wait=True)
        elif isinstance(pool, WorkerPool):  # the caller's pool: only our calls end
            for future in self.in_flight:
                pool.kill(future)
        else:
            for future in self.in_flight:
                future.cancel()
        for future, attempt in list(self.in_flight.items()):
            if future.done() and not future.cancelled() and future.exception() is None:
                self._settle(future, attempt, stopping=True)
                del self.in_flight[future]

    def _submit(self, flag: StopFlag) -> None:
        while self.queue and flag.signal is None:
            if self._affinity(self.queue[0].task) is None and self._open() >= self.limit:
                break
            attempt = self.queue.popleft()
            attempt.limit = self.sweep.limit(attempt.task)
            attempt.submitted_at = time.monotonic()
            try:
                future = self._submit_one(attempt.task)
            except BrokenExecutor as exc:
                self.queue.appendleft(attempt)
                self.broken = exc
                self._renew_pool()
                continue
            self.in_flight[future] = attempt
        if not self.queue and self.plan is not None:
            self.plan.drained(self.plan_index)  # the next sweep's calls queue behind these

    def _affinity(self, unit: Any) -> Hashable | None:
        """The call's affinity key where the pool heeds it (a WorkerPool's), else None."""
        if not isinstance(self.pool, WorkerPool) or self.batch_worker is None:
            return None
        return unit.affinity if isinstance(unit, TaskBatch) else None

    def _open(self) -> int:
        """Calls in flight without an affinity key: those count against ``limit``. A call
        with one is submitted past it, so that the pool sees the calls of a key that wait
        for their worker beside ``limit`` calls that any worker may take (the calls of a
        key come together: a sweep's batches are where their first tasks are)."""
        return sum(1 for a in self.in_flight.values() if self._affinity(a.task) is None)

    def _submit_one(self, unit: Any) -> Future:
        """Submit a task to the worker, or a batch to the batch worker (with its affinity
        key on a WorkerPool)."""
        if isinstance(unit, TaskBatch) and self.batch_worker is not None:
            key = self._affinity(unit)
            if key is not None:
                assert isinstance(self.pool, WorkerPool)
                return self.pool.submit_keyed(key, self.batch_worker, list(unit.tasks))
            return self.pool.submit(self.batch_worker, list(unit.tasks))
        return self.pool.submit(self.sweep.worker, unit)

    def _stop_overdue(self) -> None:
        """Calls past their time limit: stopped, and a timeout row for each."""
        now = time.monotonic()
        for future, attempt in list(self.in_flight.items()):
            start = self._started(future, attempt)
            if attempt.limit is None or start is None or now - start < attempt.limit:
                continue
            del self.in_flight[future]
            kill = getattr(self.pool, "kill", None)  # WorkerPool, the Dask ClusterExecutor
            if kill is not None:
                kill(future)
            else:
                future.cancel()  # a running call cannot be cancelled: abandoned
            self._took(future, attempt, start)
            if not attempt.timed_out_before:
                # A time limit ends a run on a loaded machine as well as a slow run: the
                # machine's failure until the same limit ends it again (issue 34).
                self.queue.appendleft(attempt.retry(timed_out=True))
                continue
            text = (
                f"no result after {attempt.limit:g} s in either of two tries (a time limit "
                "may be the machine's: retried once with the same limit); stopped"
            )
            self.sweep.record_failure(attempt, RunStatus.TIMEOUT, text, start)

    @staticmethod
    def _started(future: Future, attempt: _Attempt) -> float | None:
        """When the call's clock started: on a worker (local pool), or at submission."""
        return future.started_at if isinstance(future, PoolFuture) else attempt.submitted_at

    def _crash(self, attempt: _Attempt, text: str) -> None:
        if not attempt.crashed_before:
            # Also after a timeout: on a Dask cluster the retry may land on the worker being
            # restarted for another call's timeout.
            self.queue.appendleft(attempt.retry(crashed=True))
            return
        message = f"worker died twice: {text}"
        if isinstance(attempt.task, TaskBatch):  # every world of it gets this row
            message += f" (in a batch of {len(attempt.task.tasks)} runs)"
        self.sweep.record_failure(attempt, RunStatus.CRASHED, message, None)

    def _settle(self, future: Future, attempt: _Attempt, stopping: bool) -> None:
        """A finished future: its row, a retry, or (stopping) nothing unless it has a row."""
        if future.cancelled():
            if not stopping:
                self._crash(attempt, "the call was cancelled")
            return
        exc = future.exception()
        if exc is None:
            value = future.result()
            self._took(future, attempt, self._started(future, attempt), value)
            self.sweep.record_value(attempt, value, self._started(future, attempt))
        elif stopping:
            return
        elif isinstance(exc, BrokenExecutor):  # the executor's failure, not the run's
            self.queue.appendleft(attempt)
            self.broken = self.broken or exc
        elif isinstance(self.pool, WorkerPool) and not isinstance(
            exc, WorkerCrashedError | WorkerKilledError
        ):
            # The worker function itself raised: a bug of the worker, not a dead process.
            text = f"worker raised {_exception_text(exc)}"
            self.sweep.record_failure(
                attempt, RunStatus.ERROR, text, self._started(future, attempt)
            )
        else:
            self._crash(attempt, _exception_text(exc))


def run_tasks(
    tasks: Iterable[Any],
    worker: Worker,
    out_dir: str | os.PathLike[str],
    *,
    failure_row: FailureRow | None = None,
    timeout: float | Callable[[Any], float | None] | None = None,
    jobs: int | None = None,
    executor: Executor | None = None,
    max_in_flight: int | None = None,
    resume: bool = False,
    meta: Mapping[str, Any] | None = None,
    quiet: bool = False,
    stream: TextIO | None = None,
    flush_interval: float = 2.0,
    flush_rows: int = 500,
    handle_signals: bool = True,
    batching: Batching | None = None,
    costing: Costing | None = None,
) -> RunSummary:
    """Run ``worker(task)`` for every task and store the rows in ``out_dir``.

    ``batching``: tasks of one key run as batches (:class:`Batching`, module docstring).
    ``costing``: what each call is expected to cost, for the progress lines' ETA
    (:mod:`hoopbench.reports.sweep.eta`); without it the ETA assumes equal runs.

    ``worker`` must be an importable module-level function returning a small row dict with a
    ``status`` (:class:`RunStatus` value) and ideally a ``message``; ``failure_row(task,
    status, message)`` gives the descriptive columns of rows the runner makes itself
    (timeout, crashed, error). ``timeout`` is seconds per task, or a function of the task.

    Without ``executor``, a :class:`WorkerPool` of ``jobs`` workers (default: CPU count) runs
    the tasks: a hung call's worker is killed and the call tried once more, a dead worker's
    call is retried once. A foreign executor (``concurrent.futures`` or Dask's
    ``Client.get_executor()``) is not shut down here; a timed-out call goes to its
    ``kill(future)`` if it has one (the Dask ``ClusterExecutor`` of
    :mod:`hoopbench.reports.sweep.cluster`), else is cancelled if possible and otherwise
    abandoned (it keeps its worker); an exception from a future counts as a
    crash. Its calls are timed from submission, with at most ``max_in_flight`` (default: its
    ``max_workers``, ``_max_workers``, ``jobs`` or the CPU count) submitted at once.

    Raises :class:`OutputDirNotEmptyError` if ``out_dir`` holds files and ``resume`` is
    false; with ``resume``, runs whose latest row has a final status are skipped.
    """
    refuse_in_a_starting_worker()
    wall_start = time.monotonic()
    started_at = datetime.now(UTC)
    tasks = list(tasks)
    _check_run_ids(tasks)
    out = Path(out_dir)
    text_stream = sys.stderr if stream is None else stream
    say = None if quiet else (lambda text: print(terminal_text(text), file=text_stream, flush=True))
    # The whole sweep holds the folder: a second one, or a resume, waits for none of it.
    with claim_folder(out, resume, None, say):
        notes: list[str] = []

        def note(text: str) -> None:
            notes.append(text)
            if not quiet:
                print(terminal_text(text), file=text_stream, flush=True)

        stored = _resumed_statuses(out, note) if resume else {}
        todo = [t for t in tasks if not is_final_status(stored.get(t.run_id))]
        skipped = len(tasks) - len(todo)
        session: dict[str, Any] = {
            "ran": len(todo),
            "skipped": skipped,
            "load_average_start": results.load_average(),
        }
        task_order = [t.run_id for t in tasks]
        if resume and not todo and tasks:
            note(f"resume: nothing to run, all {len(tasks)} runs are stored with a final status")
            _join_plan(None, None)  # the plan's next sweep, if any, has nothing left
            missing = [n for n in (results.CSV_NAME, results.META_NAME) if not (out / n).exists()]
            if missing:
                _finalize(out, task_order, meta, started_at, wall_start, True, session)
                note(f"resume: wrote the missing {' and '.join(missing)}")
            return RunSummary(
                out, {}, time.monotonic() - wall_start, None, skipped, 0, tuple(notes)
            )

        writer = results.RunsWriter(out / results.RUNS_NAME)
        pool, in_flight_limit = _pool_for(worker, executor, jobs, max_in_flight)
        progress = _Progress(len(todo), text_stream, quiet)
        sweep = _Sweep(worker, writer, progress, failure_row, timeout, flush_interval, flush_rows)
        units = batching.units(todo, in_flight_limit) if batching is not None else todo
        batch_worker = batching.worker if batching is not None else None

        def remark(text: str) -> None:  # mid-sweep: printed above the progress bar
            notes.append(text)
            progress.note(text)

        owned = executor is None and pool is not getattr(current_plan.get(), "pool", None)
        calls = _Calls(sweep, pool, owned, units, in_flight_limit, batch_worker, remark)
        if costing is not None:
            calls.costing = costing
            calls.prior = costing.prior
            calls.workers = getattr(pool, "max_workers", None) or in_flight_limit
            progress.use_estimate(calls.remaining)
        _join_plan(calls, progress)
        stopped_by = _drive(calls, handle_signals, tick=0.1 if timeout is not None else 0.25)
        if stopped_by is None:
            _finalize(out, task_order, meta, started_at, wall_start, resume, session)
        return RunSummary(
            out_dir=out,
            counts=dict(sweep.counts),
            wall_time_s=time.monotonic() - wall_start,
            interrupted=stopped_by,
            skipped=skipped,
            unfinished=calls.unfinished,
            notes=tuple(notes),
        )


def _join_plan(calls: _Calls | None, progress: _Progress | None) -> None:
    """With a plan running (plan.current_plan), this sweep is one of it: its calls add to
    the plan's finished ones (and learn from them), its lines end with the plan's, its ETA
    is the plan's layout of it. Without calls, the sweep has nothing to run."""
    plan = current_plan.get()
    if plan is None:
        return
    if calls is None or progress is None:
        plan.end(plan.begin(0), 0)
        return
    index = plan.begin(progress.total)
    calls.finished = plan.finished
    calls._warm = plan.warm  # a shared pool's workers stay warm from sweep to sweep
    calls.prior = {**plan.prior, **calls.prior}
    if plan.pool is not None and calls.pool is plan.pool:
        calls.plan, calls.plan_index = plan, index
        calls.workers = plan.workers
    progress.plan, progress.plan_index = plan, index
    plan.attach(index, calls)
    if calls.costing is not None:
        progress.use_plan_estimate()


def _drive(calls: _Calls, handle_signals: bool, tick: float) -> signal.Signals | None:
    """Run the calls; the signal that stopped them, or None if they all ran."""
    # The handlers stay while the workers are stopped and the rows flushed: a second Ctrl-C
    # must not cut that short.
    plan = calls.sweep.progress.plan
    with _stop_on_signals(handle_signals) as own_flag:
        # Sweeps in other threads than the main one: its handlers set the plan's flag.
        flag = plan.stop if plan is not None and plan.stop is not None else own_flag
        failed = True
        try:
            calls.run(flag, tick)
            stopped_by = flag.signal
            failed = False
        finally:
            calls.stop()
            calls.sweep.close(failed)
            if plan is not None:
                plan.end(calls.sweep.progress.plan_index, calls.sweep.progress.done)
    if stopped_by is None and own_flag.signal is not None:
        # The signal came once every call had run, while the workers stopped and the rows were
        # flushed: it stopped nothing here, so the handler just restored gets it. Dropped, a
        # search between two trials' sweeps went on to its next trial (tune's Ctrl-C test,
        # timed out in CI with 2 cores loaded: the flush is when such a sweep spends longest).
        signal.raise_signal(own_flag.signal)
    return stopped_by
