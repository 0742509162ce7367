"""Run a sweep on a Dask cluster: the ``--scheduler`` options and an executor for run_tasks.

:func:`hoopbench.reports.sweep.runner.run_tasks` drives any ``concurrent.futures`` executor.
:class:`ClusterExecutor` is what Dask's ``Client.get_executor()`` gives, built on
``Client.submit`` so that it behaves as the runner needs:

* Calls are submitted with ``pure=False``. Dask's default (``pure=True``) names a call by
  its function and arguments, so the runner's retry of a failed call would get the failed
  call's future back at once instead of running again.
* A worker that dies while running a call is replaced by its nanny and the scheduler gives
  the call to another worker; after ``distributed.scheduler.allowed-failures`` deaths (3) the
  future fails with ``KilledWorker``, which the runner counts as a crash: one more try, then
  a ``crashed`` row. A call that kills every worker it runs on thus costs 8 worker restarts.
* Dask cannot stop a running thread, so :meth:`ClusterExecutor.kill` (the runner's answer
  to a timeout) cancels the call and ends the process of the worker running it; its nanny
  starts a new one.
* A lost scheduler cancels every future. Then :meth:`ClusterExecutor.submit` raises
  ``BrokenExecutor`` (after waiting ``timeout`` seconds for the client to reconnect), so the
  sweep stops with the rows it has and ``--resume`` finishes it later.

Rows are made on the workers and returned to this process, which writes them as the runs
finish; workers only need ``hoopbench`` (same version, with its engines) importable. Dask is
an optional dependency (``hoopbench[dask]``), imported only when a cluster is asked for.
:func:`local_cluster` starts a scheduler and workers on this machine, as separate processes
(the benchmark and the tests use it).
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import ipaddress
import json
import logging
import math
import os
import signal
import socket
import ssl
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import BrokenExecutor, Executor, Future, InvalidStateError
from concurrent.futures import wait as wait_futures
from dataclasses import dataclass
from importlib import import_module
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

from hoopbench.reports.sweep.runner import RunnerError

__all__ = [
    "DEFAULT_CONNECT_TIMEOUT",
    "ClusterError",
    "ClusterExecutor",
    "LocalCluster",
    "TlsFiles",
    "add_cluster_arguments",
    "cluster_executor",
    "executor_from_args",
    "local_cluster",
    "parse_address",
    "tls_files_from_args",
]

DEFAULT_CONNECT_TIMEOUT = 10.0
"""s: to reach the scheduler, to find a worker there, and to get a lost scheduler back."""

SCHEMES = ("tcp", "tls")
"""Address schemes we accept: Dask's plain and TLS transports (no extra packages needed)."""

INSTALL_HINT = "install hoopbench[dask] (pip install 'hoopbench[dask]')"


class ClusterError(RunnerError):
    """The cluster cannot be used: one line for the command line (exit status 2)."""


@dataclass(frozen=True)
class TlsFiles:
    """The client's side of Dask's mutual TLS (PEM files)."""

    ca_file: Path
    """The certificate authority that signed the scheduler's and workers' certificates."""
    cert: Path
    """This client's certificate (may hold its key too)."""
    key: Path | None = None
    """This client's private key, if not in ``cert``."""

    def check(self) -> None:
        """Raise ClusterError naming the first file that is not there."""
        for option, path in (("--tls-ca-file", self.ca_file), ("--tls-cert", self.cert)):
            if not path.is_file():
                raise ClusterError(f"{option} {str(path)!r}: no such file")
        if self.key is not None and not self.key.is_file():
            raise ClusterError(f"--tls-key {str(self.key)!r}: no such file")


# --------------------------------------------------------------------------- the options
def add_cluster_arguments(parser: argparse.ArgumentParser) -> None:
    """--scheduler and its timeout and TLS options, in a group of their own."""
    group = parser.add_argument_group(
        "Dask cluster", "run on a Dask cluster instead of local processes (needs hoopbench[dask])"
    )
    group.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="Dask scheduler, tcp://HOST:PORT or tls://HOST:PORT (--jobs is then ignored)",
    )
    group.add_argument(
        "--scheduler-timeout",
        type=float,
        default=DEFAULT_CONNECT_TIMEOUT,
        metavar="SECONDS",
        help=f"give up reaching the scheduler or a worker after this (default "
        f"{DEFAULT_CONNECT_TIMEOUT:g} s)",
    )
    group.add_argument("--tls-ca-file", metavar="PEM", help="tls://: the cluster's CA certificate")
    group.add_argument("--tls-cert", metavar="PEM", help="tls://: this client's certificate")
    group.add_argument("--tls-key", metavar="PEM", help="tls://: its key, if not in --tls-cert")


def tls_files_from_args(args: argparse.Namespace) -> TlsFiles | None:
    """The TLS files named on the command line, or None; ClusterError for half a set."""
    given = {
        "--tls-ca-file": args.tls_ca_file,
        "--tls-cert": args.tls_cert,
        "--tls-key": args.tls_key,
    }
    if not any(given.values()):
        return None
    if args.scheduler is None:
        names = " and ".join(name for name, value in given.items() if value)
        raise ClusterError(f"{names}: only with --scheduler tls://HOST:PORT")
    missing = [name for name in ("--tls-ca-file", "--tls-cert") if not given[name]]
    if missing:
        raise ClusterError(f"TLS needs {' and '.join(missing)} as well")
    key = Path(args.tls_key) if args.tls_key else None
    return TlsFiles(Path(args.tls_ca_file), Path(args.tls_cert), key)


@contextlib.contextmanager
def executor_from_args(args: argparse.Namespace) -> Iterator[ClusterExecutor | None]:
    """The cluster's executor if ``--scheduler`` was given, else None (the local pool)."""
    tls = tls_files_from_args(args)
    if args.scheduler is None:
        yield None
        return
    with cluster_executor(args.scheduler, tls, args.scheduler_timeout) as executor:
        yield executor


def parse_address(address: str) -> tuple[str, str, int]:
    """(scheme, host, port) of ``[tcp|tls]://HOST:PORT``; ClusterError naming a bad one."""
    scheme, sep, rest = address.partition("://")
    if not sep:
        scheme, rest = "tcp", address
    bad = f"--scheduler {address!r}"
    if scheme not in SCHEMES:
        raise ClusterError(f"{bad}: the scheme must be tcp:// or tls://, not {scheme}://")
    host, sep, port_text = rest.rpartition(":")
    if not sep or not host:
        raise ClusterError(f"{bad}: expected {scheme}://HOST:PORT")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]  # an IPv6 literal
        with contextlib.suppress(ValueError):
            ipaddress.IPv6Address(host)
            return scheme, host, _port(port_text, bad)
        raise ClusterError(f"{bad}: {host!r} is not an IPv6 address")
    if not host.replace("-", "").replace(".", "").replace("_", "").isalnum():
        raise ClusterError(f"{bad}: {host!r} is not a host name or address")
    return scheme, host, _port(port_text, bad)


def _port(text: str, bad: str) -> int:
    if not text.isdigit() or not 0 < int(text) < 65536:
        raise ClusterError(f"{bad}: the port must be a number from 1 to 65535, not {text!r}")
    return int(text)


# --------------------------------------------------------------------------- the executor
class ClusterExecutor(Executor):
    """Calls on a Dask cluster as ``concurrent.futures`` futures.

    What ``Client.get_executor(pure=False)`` does, plus :meth:`kill` for a hung call and a
    ``BrokenExecutor`` from :meth:`submit` once the scheduler is gone for good.
    """

    def __init__(self, client: Any, address: str, timeout: float) -> None:
        self._client = client
        self._address = address
        self._timeout = timeout
        self._threads = sum(client.nthreads().values())
        self._lock = threading.Lock()
        self._calls: dict[Future, Any] = {}
        """Our future -> Dask's, until it is done; Dask drops a call nobody refers to."""
        self._shutdown = False
        self._preloaded: set[str] = set()

    @property
    def max_workers(self) -> int:
        """Worker threads on the cluster when we connected: the runner's in-flight limit."""
        return self._threads

    @property
    def client(self) -> Any:
        """The ``distributed.Client`` (for tests and the benchmark)."""
        return self._client

    def submit(self, fn: Callable[..., Any], /, *args: Any, **kwargs: Any) -> Future:
        if self._shutdown:
            raise RuntimeError("cannot submit to a ClusterExecutor after shutdown")
        self._wait_for_scheduler()
        self._preload(fn)
        remote = self._client.submit(fn, *args, pure=False, **kwargs)
        future: Future = Future()
        with self._lock:
            self._calls[future] = remote
        future.add_done_callback(functools.partial(_cancel_remote, remote))
        remote.add_done_callback(functools.partial(self._relay, future))
        return future

    def kill(self, future: Future) -> None:
        """Stop a call: cancel it, and end the process of a worker running it.

        Dask cannot stop a running thread, so a hung call would hold its worker for good; the
        worker's nanny starts a new process in about a second. Other calls on that worker
        are given to other workers (Dask counts that towards their allowed failures).
        """
        with self._lock:
            remote = self._calls.pop(future, None)
        if remote is None or remote.done():
            future.cancel()
            return
        try:
            running = self._client.processing().items()
        except Exception:  # no scheduler to ask: there is nothing more to stop
            running = {}.items()
        running_on = [worker for worker, keys in running if remote.key in keys]
        future.cancel()  # its callback cancels the Dask future
        if running_on:
            with contextlib.suppress(Exception):  # it may have gone meanwhile
                self._client.run(os._exit, 1, workers=running_on, on_error="return")

    def shutdown(self, wait: bool = True, *, cancel_futures: bool = False) -> None:
        self._shutdown = True
        with self._lock:
            pending = list(self._calls)
        if cancel_futures or not wait:
            for future in pending:
                future.cancel()
        elif pending:
            wait_futures(pending)

    def _preload(self, fn: Callable[..., Any]) -> None:
        """Have every worker, present and future, import ``fn``'s module before it takes calls
        (as the local pool does): the runner times a call from its submission."""
        module = getattr(fn, "__module__", None)
        if not module or module in self._preloaded or module in ("__main__", "__mp_main__"):
            return
        self._preloaded.add(module)
        self._client.register_plugin(_preloader(module), name=f"hoopbench-preload-{module}")

    def _wait_for_scheduler(self) -> None:
        deadline = time.monotonic() + self._timeout
        while self._client.status != "running":
            # "connecting": the client is trying to get a lost scheduler back; wait that out.
            if self._client.status != "connecting" or time.monotonic() > deadline:
                raise BrokenExecutor(f"lost the Dask scheduler at {self._address}")
            time.sleep(0.1)

    def _relay(self, future: Future, remote: Any) -> None:
        """Dask's outcome to our future (in a thread of the client's)."""
        with self._lock:
            self._calls.pop(future, None)
        with contextlib.suppress(InvalidStateError):  # we cancelled it meanwhile
            if remote.status == "finished":
                try:
                    future.set_result(remote.result())
                except Exception as exc:  # the result could not be fetched
                    future.set_exception(exc)
            elif remote.status == "cancelled":  # by us, or the scheduler was lost
                future.cancel()
                future.set_running_or_notify_cancel()  # wakes concurrent.futures.wait
            else:
                future.set_exception(remote.exception())


def _preloader(module: str) -> Any:
    """A Dask worker plugin that imports ``module`` (defined here: Dask is imported late)."""
    import distributed

    class Preload(distributed.WorkerPlugin):
        idempotent = True

        def __init__(self, module: str) -> None:
            self.module = module

        def setup(self, worker: Any) -> None:
            with contextlib.suppress(Exception):  # a call that needs it will say what is wrong
                import_module(self.module)

    return Preload(module)


def _cancel_remote(remote: Any, future: Future) -> None:
    if future.cancelled() and not remote.done():
        remote.cancel()


@contextlib.contextmanager
def cluster_executor(
    address: str, security: TlsFiles | None = None, timeout: float = DEFAULT_CONNECT_TIMEOUT
) -> Iterator[ClusterExecutor]:
    """Connect to the Dask scheduler at ``address`` and yield an executor for run_tasks.

    Raises :class:`ClusterError` (one line) if Dask is not installed, the address is
    malformed, the TLS files are missing or do not match the address's scheme, the scheduler
    cannot be reached within ``timeout`` seconds, no worker is there within ``timeout``, or a
    worker cannot import this version of hoopbench. The client is closed on exit; the
    scheduler and workers keep running.
    """
    if not 0 < timeout < math.inf:
        raise ClusterError(f"--scheduler-timeout must be a number of seconds > 0, got {timeout}")
    scheme, host, port = parse_address(address)
    address = f"{scheme}://[{host}]:{port}" if ":" in host else f"{scheme}://{host}:{port}"
    distributed = _import_distributed()
    dask_security = _security(distributed, scheme, security, address)
    context = _client_tls_context(dask_security)  # a bad file first: the network may be fine
    _check_reachable(host, port, timeout, address)
    _check_greeting(host, port, timeout, address, context)
    try:
        client = distributed.Client(
            address, security=dask_security, timeout=timeout, set_as_default=False
        )
    except Exception as exc:  # OSError, TimeoutError, ssl errors: all say "not usable"
        text = " ".join(str(exc).split())  # one line
        hint = " (a TLS scheduler needs tls:// and the --tls-* options)" if scheme == "tcp" else ""
        raise ClusterError(
            f"cannot connect to the Dask scheduler at {address}: {text}{hint}"
        ) from None
    with _quiet_client_log():
        try:
            _check_workers(client, address, timeout)
            yield ClusterExecutor(client, address, timeout)
        finally:
            with contextlib.suppress(Exception):
                client.close(timeout=timeout)


@contextlib.contextmanager
def _quiet_client_log() -> Iterator[None]:
    """The client's own log lines off stderr: a lost scheduler is our one-line error."""
    log = logging.getLogger("distributed.client")
    level = log.level
    log.setLevel(logging.CRITICAL)
    try:
        yield
    finally:
        log.setLevel(level)


def _import_distributed() -> Any:
    try:
        import distributed
    except ImportError:
        raise ClusterError(f"--scheduler needs Dask: {INSTALL_HINT}") from None
    return distributed


def _security(distributed: Any, scheme: str, tls: TlsFiles | None, address: str) -> Any:
    """Dask's Security for the scheme: TLS files from us, or else from Dask's configuration."""
    if scheme == "tcp":
        if tls is not None:
            raise ClusterError(f"--tls-* options need a tls:// scheduler address, not {address}")
        return None
    if tls is None:
        configured = distributed.Security(require_encryption=True)
        if configured.tls_ca_file and configured.tls_client_cert:
            return configured
        raise ClusterError(
            f"{address} needs --tls-ca-file and --tls-cert (or the client's files in "
            "Dask's configuration, distributed.comm.tls)"
        )
    tls.check()
    return distributed.Security(
        tls_ca_file=str(tls.ca_file),
        tls_client_cert=str(tls.cert),
        tls_client_key=None if tls.key is None else str(tls.key),
        require_encryption=True,
    )


def _check_reachable(host: str, port: int, timeout: float, address: str) -> None:
    """A plain TCP connection first: 'refused' or 'unknown host' at once, not after a timeout
    of Dask's retries."""
    try:
        with socket.create_connection((host, port), timeout=timeout):
            pass
    except socket.gaierror:
        raise ClusterError(f"--scheduler {address}: unknown host {host!r}") from None
    except TimeoutError:
        raise ClusterError(
            f"no Dask scheduler answered at {address} within {timeout:g} s"
        ) from None
    except OSError as exc:
        reason = exc.strerror or type(exc).__name__
        raise ClusterError(f"cannot reach a Dask scheduler at {address}: {reason}") from None


MAX_GREETING_BYTES = 1 << 20
"""A Dask scheduler's first message (its handshake: a few versions and flags) is far smaller;
a larger length is another protocol's first bytes read as Dask's 8-byte length."""


def _client_tls_context(security: Any) -> ssl.SSLContext | None:
    """The SSL context Dask's client would use, built from the TLS files now: a file that is
    not a certificate or key is named as such (it was 'Connection refused')."""
    if security is None:
        return None
    try:
        context = security.get_connection_args("client")["ssl_context"]
    except (ssl.SSLError, OSError, ValueError) as exc:
        reason = " ".join(str(exc).split()) or type(exc).__name__
        raise ClusterError(
            f"--tls-cert {security.tls_client_cert!r} (key {security.tls_client_key!r}, CA "
            f"{security.tls_ca_file!r}): not a usable PEM certificate and key: {reason}"
        ) from None
    return context if isinstance(context, ssl.SSLContext) else None


def _check_greeting(
    host: str, port: int, timeout: float, address: str, context: ssl.SSLContext | None
) -> None:
    """Read the scheduler's greeting (a Dask server writes its handshake first) within the
    timeout: a port that accepts and says nothing, an HTTP server, or a plain scheduler
    asked for TLS would otherwise hold Dask's client past any timeout, or make it read
    another protocol's bytes as a frame length."""
    deadline = time.monotonic() + timeout
    try:
        with socket.create_connection((host, port), timeout=timeout) as raw:
            if context is None:
                _read_greeting(raw, deadline, address)
            else:
                with context.wrap_socket(raw, server_hostname=host) as tls:
                    _read_greeting(tls, deadline, address)
    except TimeoutError:
        raise ClusterError(
            f"no Dask scheduler answered at {address} within {timeout:g} s: something "
            "accepts connections there but sends nothing (a Dask scheduler speaks first"
            + ("; a TLS one needs tls:// and the --tls-* options)" if context is None else ")")
        ) from None
    except ssl.SSLError as exc:
        reason = exc.reason or " ".join(str(exc).split()) or type(exc).__name__
        hint = " (a plain scheduler needs tcp://)" if "VERSION" in str(reason).upper() else ""
        raise ClusterError(f"TLS with {address} failed: {reason}{hint}") from None
    except OSError as exc:
        reason = exc.strerror or " ".join(str(exc).split()) or type(exc).__name__
        raise ClusterError(
            f"{address} closed the connection before any Dask greeting: {reason}"
        ) from None


def _read_greeting(sock: socket.socket, deadline: float, address: str) -> None:
    """The greeting's 8-byte length, then the whole greeting, by the deadline: a peer that
    sends a length and then nothing is timed out here (Dask's client waited for it past any
    timeout)."""
    header = _read_exactly(sock, 8, deadline)
    (length,) = struct.unpack("<Q", header)
    if length > MAX_GREETING_BYTES:
        raise ClusterError(f"{address} is not a Dask scheduler: its first bytes are {header!r}")
    _read_exactly(sock, length, deadline)


def _read_exactly(sock: socket.socket, n: int, deadline: float) -> bytes:
    data = b""
    while len(data) < n:
        left = deadline - time.monotonic()
        if left <= 0:
            raise TimeoutError
        sock.settimeout(left)
        chunk = sock.recv(n - len(data))
        if not chunk:
            raise ConnectionResetError(0, "it closed the connection")
        data += chunk
    return data


def _check_workers(client: Any, address: str, timeout: float) -> None:
    """At least one worker, and every worker imports the hoopbench we run."""
    try:
        client.wait_for_workers(1, timeout=timeout)
    except Exception:
        raise ClusterError(
            f"the Dask scheduler at {address} has no workers (waited {timeout:g} s): start "
            f"some with 'dask worker {address} --nthreads 1'"
        ) from None
    ours = version("hoopbench")
    found = client.run(version, "hoopbench", on_error="return")
    for worker, theirs in sorted(found.items()):
        if isinstance(theirs, PackageNotFoundError):
            raise ClusterError(f"Dask worker {worker} has no hoopbench: {INSTALL_HINT} there")
        if isinstance(theirs, BaseException):
            raise ClusterError(f"Dask worker {worker} cannot report its hoopbench: {theirs}")
        if theirs != ours:
            raise ClusterError(
                f"Dask worker {worker} has hoopbench {theirs}, this client {ours}: install "
                "the same version on every worker"
            )


# --------------------------------------------------------------------------- a local cluster
ORPHAN_IDLE_S = 300.0
"""s: a local cluster's scheduler with no work for this long stops (its client was killed)."""
ORPHAN_DEATH_S = 30.0
"""s: a local cluster's worker without its scheduler for this long stops."""


@dataclass(frozen=True)
class LocalCluster:
    """A scheduler and its workers running on this machine, each a process group of its own."""

    address: str
    scheduler: subprocess.Popen
    workers: tuple[subprocess.Popen, ...]
    log_dir: Path
    """scheduler.log and worker-N.log."""


@contextlib.contextmanager
def local_cluster(
    n_workers: int = 2,
    *,
    env: Mapping[str, str] | None = None,
    timeout: float = 60.0,
    log_dir: str | os.PathLike[str] | None = None,
    tls: TlsFiles | None = None,
) -> Iterator[LocalCluster]:
    """Start ``dask scheduler`` and ``n_workers`` single-threaded ``dask worker`` processes
    on 127.0.0.1, as one would on several machines; stop them all on exit, whatever happens.

    ``env`` replaces the processes' environment. With ``tls``, every process speaks TLS with
    that certificate (Dask allows one for all roles). Raises ClusterError if Dask is missing or
    the cluster is not up within ``timeout`` seconds (with the end of the failing log). If
    this process is killed before it can stop them, the scheduler ends itself after
    ORPHAN_IDLE_S seconds without work and its workers ORPHAN_DEATH_S seconds later.
    """
    _import_distributed()
    with tempfile.TemporaryDirectory(prefix="hoopbench-dask-") as tmp:
        logs = Path(log_dir) if log_dir is not None else Path(tmp)
        logs.mkdir(parents=True, exist_ok=True)
        file = Path(tmp) / "scheduler.json"
        deadline = time.monotonic() + timeout
        started: list[subprocess.Popen] = []
        try:
            command = ["scheduler", "--host", "127.0.0.1", "--port", "0", *_tls_args(tls)]
            command += ["--scheduler-file", str(file), "--idle-timeout", f"{ORPHAN_IDLE_S:g}"]
            scheduler = _spawn(command, logs / "scheduler.log", env)
            started.append(scheduler)
            address = _scheduler_address(file, scheduler, logs / "scheduler.log", deadline)
            for i in range(n_workers):
                command = ["worker", address, "--host", "127.0.0.1", "--nthreads", "1"]
                command += ["--death-timeout", f"{ORPHAN_DEATH_S:g}", *_tls_args(tls)]
                started.append(_spawn(command, logs / f"worker-{i}.log", env))
            security = _security(_import_distributed(), "tls" if tls else "tcp", tls, address)
            _wait_for_workers(address, n_workers, deadline, started[1:], logs, security)
            yield LocalCluster(address, scheduler, tuple(started[1:]), logs)
        finally:
            for process in reversed(started):
                _stop(process)


def _tls_args(tls: TlsFiles | None) -> list[str]:
    if tls is None:
        return []
    args = ["--protocol", "tls", "--tls-ca-file", str(tls.ca_file), "--tls-cert", str(tls.cert)]
    return args if tls.key is None else [*args, "--tls-key", str(tls.key)]


def _spawn(args: list[str], log: Path, env: Mapping[str, str] | None) -> subprocess.Popen:
    with log.open("wb") as out:
        return subprocess.Popen(
            [sys.executable, "-m", "dask", *args, "--no-dashboard"],
            stdin=subprocess.DEVNULL,
            stdout=out,
            stderr=subprocess.STDOUT,
            env=None if env is None else dict(env),
            start_new_session=True,  # its own process group: the nanny's children end with it
        )


def _scheduler_address(file: Path, scheduler: subprocess.Popen, log: Path, deadline: float) -> str:
    while time.monotonic() < deadline:
        if scheduler.poll() is not None:
            raise ClusterError(f"the Dask scheduler exited: {_tail(log)}")
        with contextlib.suppress(OSError, ValueError, KeyError):
            return str(json.loads(file.read_text())["address"])
        time.sleep(0.1)
    raise ClusterError(f"the Dask scheduler did not start in time: {_tail(log)}")


def _wait_for_workers(
    address: str,
    n: int,
    deadline: float,
    workers: list[subprocess.Popen],
    logs: Path,
    security: Any,
) -> None:
    distributed = _import_distributed()
    with distributed.Client(address, security=security, timeout=10, set_as_default=False) as client:
        while len(client.scheduler_info(n_workers=-1)["workers"]) < n:
            for i, process in enumerate(workers):
                if process.poll() is not None:
                    raise ClusterError(f"Dask worker {i} exited: {_tail(logs / f'worker-{i}.log')}")
            if time.monotonic() > deadline:
                raise ClusterError(f"fewer than {n} Dask workers joined in time")
            time.sleep(0.1)


def _tail(log: Path) -> str:
    lines = log.read_text(errors="replace").strip().splitlines() if log.is_file() else []
    return lines[-1] if lines else "(no output)"


def _stop(process: subprocess.Popen) -> None:
    """SIGTERM to the process group, SIGKILL if it is still there after 5 s."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, sig)
        try:
            process.wait(timeout=5)
            break
        except subprocess.TimeoutExpired:
            continue
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(process.pid, signal.SIGKILL)  # the group's stragglers (resource tracker)
