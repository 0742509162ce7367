"""Sweeps on a real Dask cluster (issue 11): a scheduler and two single-threaded workers,
each a process of its own on 127.0.0.1, started once for the module and always stopped.

The cluster's runs must give the local runs' rows (timing columns aside), and a worker that
dies or hangs must cost no run: its run is retried, or stored as crashed or timeout. The
workers see the fault engines of tests/fault_engines.py through HOOPBENCH_ENGINE_MODULES, and
the scheduler gives up on a call at the first death of its worker (KilledWorker) instead of
Dask's fourth, so that the runner's own retry is what is tested, and quickly.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import pandas as pd
import pytest

import hoopbench as hb
from hoopbench.engines.judging.columns import COST_COLUMNS
from hoopbench.reports.compare.suite import compare as run_suite
from hoopbench.reports.compare.suite import runs_frame
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import run_map
from hoopbench.reports.hop_map.table import map_frame
from hoopbench.reports.sweep.cluster import (
    ClusterError,
    TlsFiles,
    add_cluster_arguments,
    cluster_executor,
    local_cluster,
    parse_address,
    tls_files_from_args,
)
from hoopbench.reports.sweep.results import TIMING_COLUMNS, read_runs

distributed = pytest.importorskip("distributed")

TESTS = Path(__file__).resolve().parent
CLI = [sys.executable, "-m", "hoopbench.reports.cli"]
TIMING = {*TIMING_COLUMNS, *COST_COLUMNS}
LIMIT = 120  # s: no subprocess may hang the test run

TINY = """
name = "tiny"
engines = ["pymunk"]
timesteps = [1e-3]
scenes = ["seed-mu", "hop-bottom"]
"""


def environment() -> dict[str, str]:
    env = dict(os.environ)
    env["HOOPBENCH_ENGINE_MODULES"] = "fault_engines"
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(TESTS), env.get("PYTHONPATH")]))
    env["DASK_DISTRIBUTED__SCHEDULER__ALLOWED_FAILURES"] = "0"
    return env


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    logs = tmp_path_factory.mktemp("dask-logs")
    with local_cluster(2, env=environment(), timeout=60, log_dir=logs) as running:
        yield running


@pytest.fixture
def client(cluster):
    """Our own view of the cluster, with both workers up (a test may have killed one)."""
    with distributed.Client(cluster.address, timeout=10, set_as_default=False) as view:
        view.wait_for_workers(2, timeout=30)
        yield view


def hoopbench(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*CLI, *args],
        env=environment(),
        capture_output=True,
        text=True,
        timeout=LIMIT,
        cwd=cwd,
    )


def compare(suite: str, tmp_path: Path, out: str, *args: str) -> subprocess.CompletedProcess:
    path = tmp_path / "suite.toml"
    path.write_text(suite)
    return hoopbench(
        "compare", "--suite", str(path), "--out", str(tmp_path / out), "--quiet", *args,
        cwd=tmp_path,
    )  # fmt: skip


def comparable(frame: pd.DataFrame, key: str = "run_id") -> pd.DataFrame:
    keep = [c for c in frame.columns if c not in TIMING]
    return frame[keep].sort_values(key).reset_index(drop=True)


def suite_of(engines: list[str], scenes: list[str], timesteps: str = "[1e-3]") -> str:
    return f"name = 'faults'\nengines = {engines}\ntimesteps = {timesteps}\nscenes = {scenes}\n"


# --------------------------------------------------------------------------- same rows
@pytest.mark.slow
def test_compare_on_the_cluster_gives_the_local_rows(tmp_path, cluster):
    suite = tmp_path / "tiny.toml"
    suite.write_text(TINY)
    with cluster_executor(cluster.address) as executor:
        remote = run_suite(suite, tmp_path / "remote", executor=executor, quiet=True)
    local = run_suite(suite, tmp_path / "local", jobs=2, quiet=True)
    assert remote.counts == local.counts
    rows = read_runs(tmp_path / "remote")
    assert len(rows) == 2 and set(rows["status"]) == {"ok"}
    pd.testing.assert_frame_equal(comparable(rows), comparable(read_runs(tmp_path / "local")))


@pytest.mark.slow
def test_a_map_on_the_cluster_gives_the_local_rows(tmp_path, cluster):
    """The issue's "done when": a map through --scheduler equals the local one row for row."""
    spec = MapSpec(nx=3, ny=3, engines=("pymunk", "mujoco"), timestep=1e-3)
    with cluster_executor(cluster.address, timeout=10) as executor:
        remote = run_map(spec, tmp_path / "remote", executor=executor, quiet=True)
    local = run_map(spec, tmp_path / "local", jobs=2, quiet=True)
    assert remote.counts == local.counts
    frame = map_frame(tmp_path / "remote")
    assert len(frame) == 9 * 3  # the reference and two engines at every point
    pd.testing.assert_frame_equal(comparable(frame), comparable(map_frame(tmp_path / "local")))


@pytest.mark.slow
def test_a_search_on_the_cluster_gives_the_local_rows(tmp_path, cluster):
    """hoopbench tune --scheduler: every trial's and held-out run on the cluster, the rows a
    local search gives (one trial, so that the Pareto set does not hang on timings)."""
    pytest.importorskip("optuna")
    tune = ["tune", "--engine", "pymunk", "--scenes", "hop-bottom", "--trials", "1"]
    tune += ["--heldout-per-regime", "0", "--quiet", "--scheduler", cluster.address]
    done = hoopbench(*tune, "--out", str(tmp_path / "remote"), cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    hb.tune("pymunk", tmp_path / "local", scenes=["hop-bottom"], trials=1,
            heldout_per_regime=0, quiet=True)  # fmt: skip
    for folder in ("trials", "heldout"):
        remote = runs_frame(tmp_path / "remote" / folder)
        assert len(remote) == 3 and set(remote["status"]) == {"ok"}
        local = runs_frame(tmp_path / "local" / folder)
        pd.testing.assert_frame_equal(comparable(remote), comparable(local))


# --------------------------------------------------------------------------- faults
@pytest.mark.slow
def test_a_worker_killed_mid_run_costs_no_run(tmp_path, cluster, client):
    scenes = ["seed-mu", "hop-top", "hop-low", "hop-bottom", "slip-reversal", "low-friction"]
    suite = tmp_path / "suite.toml"
    suite.write_text(suite_of(["test-slow"], scenes))
    out = tmp_path / "out"
    command = ["compare", "--suite", str(suite), "--out", str(out), "--quiet"]
    proc = subprocess.Popen(
        [*CLI, *command, "--scheduler", cluster.address],
        env=environment(),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=tmp_path,
    )
    try:
        pids = client.run(os.getpid)
        victim = None
        deadline = time.monotonic() + 60
        while victim is None and time.monotonic() < deadline and proc.poll() is None:
            busy = [w for w, keys in client.processing().items() if keys]
            victim = busy[0] if busy else None
            time.sleep(0.02)
        assert victim is not None, "no run was seen on a worker"
        os.kill(pids[victim], signal.SIGKILL)
        _, err = proc.communicate(timeout=LIMIT)
    finally:
        proc.kill()
    assert proc.returncode == 0, err
    rows = read_runs(out)
    assert sorted(rows["scene"]) == sorted(scenes)  # one row each: none lost, none twice
    assert set(rows["status"]) == {"ok"}, rows[["scene", "status", "message"]]
    assert (rows["attempts"] == 2).any()  # the killed worker's run, retried


@pytest.mark.slow
def test_a_run_that_kills_every_worker_is_retried_once_then_crashed(tmp_path, cluster, client):
    done = compare(suite_of(["reference", "test-crash"], ["seed-mu"]), tmp_path, "out",
                   "--scheduler", cluster.address)  # fmt: skip
    assert done.returncode == 0, done.stderr
    rows = read_runs(tmp_path / "out").set_index("engine")
    assert rows.loc["reference", "status"] == "ok"
    assert rows.loc["test-crash", "status"] == "crashed"
    assert rows.loc["test-crash", "attempts"] == 2
    assert "KilledWorker" in rows.loc["test-crash", "message"]


@pytest.mark.slow
def test_a_hung_run_times_out_and_frees_its_worker(tmp_path, cluster, client):
    """Both workers get a run that sleeps 1000 s: unless a timed-out run's worker is ended,
    the reference runs behind them time out too."""
    suite = suite_of(["test-hang", "reference"], ["seed-mu", "hop-bottom"])
    done = compare(suite, tmp_path, "out", "--scheduler", cluster.address, "--run-timeout", "8")
    assert done.returncode == 0, done.stderr
    rows = read_runs(tmp_path / "out")
    status = rows.groupby("engine")["status"].agg(sorted).to_dict()
    assert status == {"test-hang": ["timeout", "timeout"], "reference": ["ok", "ok"]}


@pytest.mark.slow
def test_a_lost_scheduler_stops_the_sweep_in_one_line_and_keeps_its_rows(tmp_path):
    """A cluster of its own: this test kills the scheduler."""
    scenes = ["seed-mu", "hop-top", "hop-low", "hop-bottom", "slip-reversal", "low-friction"]
    suite = tmp_path / "suite.toml"
    suite.write_text(suite_of(["test-slow"], scenes, "[1e-3, 5e-4]"))  # 12 runs, 5 s or more
    out = tmp_path / "out"
    with local_cluster(1, env=environment(), log_dir=tmp_path / "logs") as doomed:
        proc = subprocess.Popen(
            [*CLI, "compare", "--suite", str(suite), "--out", str(out), "--quiet",
             "--scheduler", doomed.address, "--scheduler-timeout", "2"],
            env=environment(), stderr=subprocess.PIPE, text=True, cwd=tmp_path,
        )  # fmt: skip
        try:
            deadline = time.monotonic() + 60
            while not list((out / "runs").glob("part-*.parquet")) and time.monotonic() < deadline:
                time.sleep(0.05)  # the first rows are on disk: the sweep is under way
            os.killpg(doomed.scheduler.pid, signal.SIGKILL)
            _, err = proc.communicate(timeout=LIMIT)
        finally:
            proc.kill()
    assert proc.returncode == 75  # the machinery's failure, not bad input (issue 38)
    resume = f"hoopbench compare --suite {suite} --out {out} --resume"
    assert err.strip().splitlines() == [
        "hoopbench: stopped: the executor is broken (BrokenExecutor: lost the Dask scheduler "
        f"at {doomed.address}); the runs stored before are kept in {out}/runs; resume with: "
        f"{resume}"
    ]
    rows = read_runs(out)
    assert 0 < len(rows) < 2 * len(scenes)
    assert set(rows["status"]) == {"ok"}  # the runs the loss cut short are not stored as failed


# --------------------------------------------------------------------------- bad clusters
def test_no_scheduler_there_is_one_line_and_exit_2(tmp_path):
    done = compare(TINY, tmp_path, "out", "--scheduler", "tcp://127.0.0.1:1")
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        "hoopbench: error: cannot reach a Dask scheduler at tcp://127.0.0.1:1: Connection refused"
    ]
    assert not (tmp_path / "out").exists()


def test_without_dask_the_error_says_what_to_install(tmp_path):
    blocker = tmp_path / "block"
    blocker.mkdir()
    (blocker / "distributed.py").write_text("raise ImportError('no Dask here')\n")
    env = environment()
    env["PYTHONPATH"] = os.pathsep.join([str(blocker), env["PYTHONPATH"]])
    path = tmp_path / "suite.toml"
    path.write_text(TINY)
    done = subprocess.run(
        [*CLI, "compare", "--suite", str(path), "--out", "out", "--scheduler", "tcp://h:8786"],
        env=env, capture_output=True, text=True, timeout=LIMIT, cwd=tmp_path,
    )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.strip() == (
        "hoopbench: error: --scheduler needs Dask: install hoopbench[dask] "
        "(pip install 'hoopbench[dask]')"
    )


@pytest.mark.parametrize(
    ("address", "expected"),
    [
        ("tcp://10.0.0.5:8786", ("tcp", "10.0.0.5", 8786)),
        ("node-1.lan:8786", ("tcp", "node-1.lan", 8786)),
        ("tls://[::1]:8786", ("tls", "::1", 8786)),
    ],
)
def test_good_addresses(address, expected):
    assert parse_address(address) == expected


@pytest.mark.parametrize(
    ("address", "message"),
    [
        ("http://host:8786", "the scheme must be tcp:// or tls://, not http://"),
        ("tcp://host", "expected tcp://HOST:PORT"),
        ("tcp://:8786", "expected tcp://HOST:PORT"),
        ("tcp://host:0", "the port must be a number from 1 to 65535, not '0'"),
        ("tcp://host:http", "the port must be a number from 1 to 65535, not 'http'"),
        ("tcp://a b:8786", "'a b' is not a host name or address"),
        ("tls://[nope]:8786", "'nope' is not an IPv6 address"),
    ],
)
def test_bad_addresses_are_named(address, message):
    with pytest.raises(ClusterError) as caught:
        parse_address(address)
    assert str(caught.value) == f"--scheduler {address!r}: {message}"


def _args(*argv: str):
    import argparse

    parser = argparse.ArgumentParser()
    add_cluster_arguments(parser)
    return parser.parse_args(argv)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--tls-cert", "c.pem"], "--tls-cert: only with --scheduler tls://HOST:PORT"),
        (["--scheduler", "tls://h:1", "--tls-cert", "c.pem"], "TLS needs --tls-ca-file as well"),
    ],
)
def test_half_a_tls_setup_is_refused(argv, message):
    with pytest.raises(ClusterError, match=message):
        tls_files_from_args(_args(*argv))


def test_tls_files_must_exist_and_match_the_scheme(tmp_path):
    ca = tmp_path / "ca.pem"
    ca.write_text("")
    tls = tls_files_from_args(
        _args("--scheduler", "tls://127.0.0.1:1", "--tls-ca-file", str(ca), "--tls-cert", "no.pem")
    )
    missing = re.escape("--tls-cert 'no.pem': no such file")
    with pytest.raises(ClusterError, match=missing), cluster_executor("tls://127.0.0.1:1", tls):
        pass
    tcp = "need a tls:// scheduler address"
    with pytest.raises(ClusterError, match=tcp), cluster_executor("tcp://127.0.0.1:1", tls):
        pass


# --------------------------------------------------------------------------- TLS
def _openssl(*args: str, cwd: Path) -> None:
    subprocess.run(["openssl", *args], cwd=cwd, check=True, capture_output=True, timeout=60)


def make_certificates(folder: Path) -> TlsFiles:
    """A throwaway CA and one certificate it signed, for every process of the cluster."""
    _openssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1", "-subj", "/CN=ca",
             "-keyout", "ca.key", "-out", "ca.pem", cwd=folder)  # fmt: skip
    _openssl("req", "-newkey", "rsa:2048", "-nodes", "-subj", "/CN=node",
             "-keyout", "node.key", "-out", "node.csr", cwd=folder)  # fmt: skip
    _openssl("x509", "-req", "-in", "node.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
             "-CAcreateserial", "-days", "1", "-out", "node.pem", cwd=folder)  # fmt: skip
    return TlsFiles(folder / "ca.pem", folder / "node.pem", folder / "node.key")


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("openssl") is None, reason="needs the openssl command")
def test_a_tls_cluster_takes_our_certificates_and_nothing_less(tmp_path):
    tls = make_certificates(tmp_path)
    with local_cluster(1, env=environment(), tls=tls, log_dir=tmp_path / "logs") as running:
        assert running.address.startswith("tls://")
        with cluster_executor(running.address, tls, timeout=10) as executor:
            assert executor.submit(pow, 2, 10).result(timeout=30) == 1024
        plain = running.address.replace("tls://", "tcp://")
        refused = "sends nothing .*; a TLS one needs tls:// and the --tls-\\* options"
        with pytest.raises(ClusterError, match=refused), cluster_executor(plain, timeout=3):
            pass
        (tmp_path / "other").mkdir()
        stranger = replace(make_certificates(tmp_path / "other"), ca_file=tls.ca_file)
        stranger_executor = cluster_executor(running.address, stranger, timeout=3)
        stranger_refused = r"TLS with tls://\S+ failed: \S"
        with pytest.raises(ClusterError, match=stranger_refused), stranger_executor:
            pass


def test_tls_to_a_plain_scheduler_is_refused_with_a_reason(tmp_path, cluster):
    """It used to be refused with an empty reason."""
    tls = make_certificates(tmp_path)
    address = cluster.address.replace("tcp://", "tls://")
    wrong = "TLS with tls://\\S+ failed: WRONG_VERSION_NUMBER \\(a plain scheduler needs tcp://\\)"
    with pytest.raises(ClusterError, match=wrong), cluster_executor(address, tls, timeout=3):
        pass


def test_a_garbage_certificate_is_named_as_such(tmp_path):
    """It was reported as 'Connection refused'."""
    for name in ("ca.pem", "node.pem"):
        (tmp_path / name).write_text("not a certificate\n")
    tls = TlsFiles(tmp_path / "ca.pem", tmp_path / "node.pem")
    garbage = "not a usable PEM certificate and key"
    with pytest.raises(ClusterError, match=garbage), cluster_executor("tls://127.0.0.1:1", tls):
        pass


@contextlib.contextmanager
def a_server(answer: bytes | None) -> Iterator[int]:
    """A local server thread that accepts connections and says nothing (answer None) or, once
    it has read something, answers it (an HTTP server): not a Dask scheduler."""
    server = socket.create_server(("127.0.0.1", 0))
    stop = threading.Event()

    def serve() -> None:
        kept = []
        server.settimeout(0.1)
        while not stop.is_set():
            try:
                conn, _ = server.accept()
            except TimeoutError:
                continue
            kept.append(conn)
            if answer is not None:
                conn.settimeout(5)
                with contextlib.suppress(OSError):
                    conn.recv(1000)
                    conn.sendall(answer)
        for conn in kept:
            conn.close()

    thread = threading.Thread(target=serve, daemon=True)
    thread.start()
    try:
        yield server.getsockname()[1]
    finally:
        stop.set()
        thread.join()
        server.close()


HTTP_400 = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n"


@pytest.mark.parametrize("answer", [None, HTTP_400], ids=["silent", "http"])
def test_a_port_that_is_not_a_scheduler_ends_within_the_timeout(answer, tmp_path):
    """It used not to end after 150 s despite --scheduler-timeout 3 (silent), or to read an
    HTTP answer as a frame length of 3 EiB and print a traceback (http)."""
    with a_server(answer) as port:
        address = f"tcp://127.0.0.1:{port}"
        with (
            pytest.raises(
                ClusterError, match=f"no Dask scheduler answered at {address} within 1 s"
            ),
            cluster_executor(address, timeout=1.0),
        ):
            pass
        done = subprocess.run(
            [*CLI, "compare", "--suite", "quick", "--out", str(tmp_path / "out"),
             "--scheduler", address, "--scheduler-timeout", "1"],
            capture_output=True, text=True, timeout=LIMIT, env=environment(),
        )  # fmt: skip
    assert done.returncode == 2
    assert done.stderr.strip().splitlines() == [
        f"hoopbench: error: no Dask scheduler answered at {address} within 1 s: something "
        "accepts connections there but sends nothing (a Dask scheduler speaks first; a TLS "
        "one needs tls:// and the --tls-* options)"
    ]
    assert not (tmp_path / "out").exists()


def test_a_peer_that_sends_a_frame_length_and_then_nothing_ends_within_the_timeout():
    """A valid greeting length (1000 bytes), then silence: Dask's client waited past 90 s
    despite --scheduler-timeout 3 (issue 26)."""
    server = socket.create_server(("127.0.0.1", 0))
    kept: list[socket.socket] = []

    def serve() -> None:
        with contextlib.suppress(OSError):
            while True:
                conn, _ = server.accept()
                kept.append(conn)
                conn.sendall((1000).to_bytes(8, "little"))

    threading.Thread(target=serve, daemon=True).start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    start = time.monotonic()
    try:
        with (
            pytest.raises(ClusterError, match=f"no Dask scheduler answered at {address}"),
            cluster_executor(address, timeout=1.0),
        ):
            pass
    finally:
        server.close()
        for conn in kept:
            conn.close()
    assert time.monotonic() - start < 10


@pytest.mark.parametrize("timeout", [0.0, -1.0, math.nan, math.inf])
def test_a_timeout_must_be_a_positive_number(timeout):
    message = f"--scheduler-timeout must be a number of seconds > 0, got {timeout}"
    executor = cluster_executor("tcp://127.0.0.1:1", timeout=timeout)
    with pytest.raises(ClusterError, match=re.escape(message)), executor:
        pass
