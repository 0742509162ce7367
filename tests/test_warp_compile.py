"""Warp's modules compiled by one process at a time (engines/warp_compile.py): the lock,
what happens when its holder dies or the system has none, and the split of a list of
modules between two processes. No Warp here: a stand-in for its ``Module._compile`` and
``load_module`` (the engines' lists are checked against their real launches in
tests/test_mjwarp.py and tests/test_newton.py). About 1 CPU-s: two short helper processes."""

from __future__ import annotations

import signal
import subprocess
import sys
import threading
from pathlib import Path
from types import SimpleNamespace

import pytest

from hoopbench.engines import warp_compile
from hoopbench.engines.warp_compile import (
    LOCKS,
    ModuleBusyError,
    load_modules,
    module_lock,
    share_compiles,
)

HOLD = """
import sys, time
from pathlib import Path
from hoopbench.engines.warp_compile import module_lock
with module_lock(Path(sys.argv[1])):
    print("held", flush=True)
    time.sleep(float(sys.argv[2]))
"""
"""A process that holds a module's lock for argv[2] seconds (says so once it holds it)."""


def _holder(module_dir: Path, seconds: float) -> subprocess.Popen[str]:
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLD, str(module_dir), str(seconds)],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert holder.stdout is not None
    assert holder.stdout.readline().strip() == "held"
    return holder


def test_a_module_another_process_compiles_is_busy_until_it_ends(tmp_path):
    module_dir = tmp_path / "wp_mujoco_warp._src.smooth_439a86e"
    holder = _holder(module_dir, 60.0)
    try:
        with pytest.raises(ModuleBusyError), module_lock(module_dir, wait=False):
            pass
    finally:
        holder.send_signal(signal.SIGKILL)  # killed mid-compile: its lock goes with it
        holder.wait()
    assert (tmp_path / LOCKS / f"{module_dir.name}.lock").exists()  # the file stays
    with module_lock(module_dir, wait=False):  # and holds no one back
        pass


def test_without_lock_support_a_module_compiles_unlocked(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "fcntl", None)  # as on Windows: import fails
    with module_lock(tmp_path / "wp_m_0000000", wait=False):
        pass
    monkeypatch.delitem(sys.modules, "fcntl")
    import fcntl

    def refused(handle: int, operation: int) -> None:
        raise OSError(37, "No locks available")  # ENOLCK, as some network file systems

    monkeypatch.setattr(fcntl, "flock", refused)
    with module_lock(tmp_path / "wp_m_0000000", wait=False):
        pass


def test_a_lock_this_process_holds_is_not_waited_for(tmp_path):
    """A compile inside a compile (a stand-in wrapped twice) would wait for itself."""
    done = threading.Event()

    def nested() -> None:
        with module_lock(tmp_path / "wp_m_0000000"), module_lock(tmp_path / "wp_m_0000000"):
            done.set()

    thread = threading.Thread(target=nested, daemon=True)
    thread.start()
    thread.join(20.0)
    assert done.is_set()


def _stand_in_warp(cache: Path, loaded: list[str]) -> SimpleNamespace:
    """Warp as load_modules sees it: ``load_module`` compiles through ``Module._compile``
    into the cache's folder of the module."""

    class Module:
        def __init__(self, name: str) -> None:
            self.name = name

        def _compile(self, device: object = None, output_dir: object = None) -> bool:
            loaded.append(self.name)
            return True

    def load_module(name: str, device: object = None, max_workers: int | None = None) -> None:
        Module(name)._compile(device, str(cache / f"wp_{name}_0000000"))

    return SimpleNamespace(Module=Module, load_module=load_module)


def test_a_module_another_process_compiles_is_loaded_after_the_others(tmp_path):
    """Two processes split a list: the one that finds a module locked goes on with the
    next and comes back for it (importable names stand in for the engine's modules)."""
    loaded: list[str] = []
    wp = _stand_in_warp(tmp_path, loaded)
    share_compiles(wp)
    holder = _holder(tmp_path / "wp_json_0000000", 1.0)
    try:
        order = load_modules(wp, "cpu", ["json", "no_such_module_here", "csv", "string"])
    finally:
        holder.wait()
    assert order == ["csv", "string", "json"]
    assert loaded == order
    assert not getattr(warp_compile._WAITS, "skip", False)


def test_compiles_are_locked_once_per_process(tmp_path):
    wp = _stand_in_warp(tmp_path, [])
    share_compiles(wp)
    wrapped = wp.Module._compile
    share_compiles(wp)
    assert wp.Module._compile is wrapped
