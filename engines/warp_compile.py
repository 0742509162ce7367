"""NVIDIA Warp's kernels compiled once per machine, not once per worker (MuJoCo Warp, Newton).

Warp compiles a module (every kernel of one Python module, or one ``module="unique"``
kernel) on its first launch in a process and keeps the binary in its kernel cache
(``wp.config.kernel_cache_dir``), where a later process finds it. Two processes that start
on an empty cache at once (``make report``'s two workers, one on the stock settings and
one on the tuned, which share all but a few of their modules) both compile every module:
Warp writes each build into a folder of its own and renames it into the cache, so this is
safe, only paid twice (MuJoCo Warp about 27 CPU-s a process, Newton about 17:
docs/engines.md, Compiled kernels).

Two things here share the work:

- **One compiles, the others load.** While :func:`share_compiles` is installed, a module's
  compile (Warp's ``Module._compile``, which first looks for the binary in the cache and
  returns if it is there) runs under an exclusive lock on a file of the cache's ``locks``
  folder named after the module's cache folder (its name and hash). A second process that
  needs the module waits for the first to finish, then finds the binary and loads it. The
  lock is ``flock``'s: the system releases it when its holder exits, killed mid-compile
  too, so no lock outlives its process; where there is no ``fcntl`` (Windows) or the file
  system refuses the lock (some network file systems), the module compiles unlocked, as
  Warp alone does.
- **Each compiles a different module.** :func:`load_modules` loads a list of an engine's
  modules before its first step (``wp.load_module``, Warp's call to load a module ahead of
  its launches); a module another process is compiling is skipped and loaded after the
  others, so two processes that start together split the list between them instead of
  one waiting for the other.

The compiled code is Warp's own, with its own options: only who compiles it changes, so
the rows cannot.
"""

from __future__ import annotations

import functools
import importlib
import os
import threading
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType
from typing import Any

__all__ = ["LOCKS", "ModuleBusyError", "load_modules", "module_lock", "share_compiles"]

LOCKS = "locks"
"""The kernel cache's folder of lock files, one per module compiled under a lock."""

_WAITS = threading.local()
"""``skip``: True while :func:`load_modules` goes through its list the first time (a module
another process is compiling raises :class:`ModuleBusyError` instead of waiting)."""


_HELD: set[Path] = set()
"""The lock files this process holds."""


class ModuleBusyError(Exception):
    """Another process holds the module's compile lock (only while skipping busy ones)."""


@contextmanager
def module_lock(module_dir: Path, *, wait: bool = True) -> Iterator[None]:
    """Hold the compile lock of the Warp module whose cache folder is ``module_dir``:
    wait for it, or raise :class:`ModuleBusyError` at once if another process holds it and
    ``wait`` is False. Without lock support it holds nothing (module doc)."""
    path = module_dir.parent / LOCKS / f"{module_dir.name}.lock"
    try:
        import fcntl
    except ImportError:  # Windows: no flock
        yield
        return
    if path in _HELD:  # this process holds it already (flock would wait for itself)
        yield
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:  # a read-only or full cache: Warp reports its own error
        yield
        return
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            raise ModuleBusyError(module_dir.name) from None
        except OSError:  # ENOLCK and the like: no lock on this file system
            pass
        _HELD.add(path)
        try:
            yield
        finally:
            _HELD.discard(path)
    finally:
        os.close(handle)  # closing the file releases its flock


def share_compiles(wp: ModuleType) -> None:
    """Compile each of Warp's modules under its lock (module doc), from now on in this
    process; once per process (a second call changes nothing)."""
    module_class = wp.Module
    if getattr(module_class, "_shares_compiles", False):
        return
    if not callable(getattr(module_class, "_compile", None)):  # another Warp: as Warp does
        return
    module_class._compile = _locked(module_class._compile)
    module_class._shares_compiles = True


def _locked(compile_: Callable[..., bool]) -> Callable[..., bool]:
    @functools.wraps(compile_)
    def locked(
        self: Any, device: Any = None, output_dir: Any = None, *args: Any, **kw: Any
    ) -> bool:
        if output_dir is None:  # an ahead-of-time build to a folder of the caller's
            return compile_(self, device, output_dir, *args, **kw)
        with module_lock(Path(output_dir), wait=not getattr(_WAITS, "skip", False)):
            return compile_(self, device, output_dir, *args, **kw)

    return locked


def load_modules(wp: ModuleType, device: Any, names: Sequence[str]) -> list[str]:
    """Load the named Warp modules on ``device`` (compiled or read from the cache), the
    ones another process is compiling last (module doc). A module is imported first (as the
    engine would import it on its first step); a name that cannot be (another version of
    the engine) is left out. Returns the names in the order they were loaded."""
    if not callable(getattr(wp, "load_module", None)):  # another Warp: loaded at launch
        return []
    known = [name for name in names if _imported(name)]
    later, done = [], []
    _WAITS.skip = True
    try:
        for name in known:
            try:
                wp.load_module(name, device=device, max_workers=1)
            except ModuleBusyError:
                later.append(name)
            else:
                done.append(name)
    finally:
        _WAITS.skip = False
    for name in later:
        wp.load_module(name, device=device, max_workers=1)
        done.append(name)
    return done


def _imported(name: str) -> bool:
    try:
        importlib.import_module(name)
    except ImportError:
        return False
    return True
