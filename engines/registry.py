"""Engines by name: each engine module registers its class with :func:`register`.

The engine modules of this package (``*_engine.py``) are found and imported on first use.
Importing one is cheap: an engine's own library is imported only when a run uses it.

Engines from elsewhere, in two ways, both loaded at discovery (the registry's first use):

* plugins: an installed distribution declares its engine in the entry-point group
  ``hoopbench.engines`` (``tiny = "tiny_hoop.engine:TinyEngine"``; an entry point may also
  name a module that registers its engines itself), as pytest and Gymnasium plugins do. A
  plugin that cannot load stops discovery with one line naming it and its distribution;
  ``HOOPBENCH_DISABLE_PLUGINS=1`` skips them all;
* the environment variable ``HOOPBENCH_ENGINE_MODULES`` lists more modules to import
  (comma-separated, importable names), each registering its engines.

Every process discovers them, suite workers included, so an engine of your own (or the
tests' engines that crash, hang or return NaN) runs in ``hoopbench compare`` too.
"""

from __future__ import annotations

import os
import pkgutil
import threading
from importlib import import_module
from importlib.metadata import EntryPoint, entry_points
from types import MappingProxyType, ModuleType
from typing import TypeVar

from hoopbench.engines.base import Engine
from hoopbench.engines.run import REFERENCE_ENGINE

__all__ = [
    "engine_class",
    "engine_classes",
    "engine_names",
    "get_engine",
    "register",
    "unregister",
]

ENGINE_MODULES_VARIABLE = "HOOPBENCH_ENGINE_MODULES"
PLUGIN_GROUP = "hoopbench.engines"
"""The entry-point group of engine plugins."""
DISABLE_PLUGINS_VARIABLE = "HOOPBENCH_DISABLE_PLUGINS"
"""Set (to anything but empty or 0): no plugin is loaded, e.g. to get past a broken one."""

_ENGINES: dict[str, type[Engine]] = {}
_discovered = False
_discovery_error: str | None = None
"""Why discovery failed: raised again by every later use, so that a broken plugin is never
dropped silently after its first error."""

E = TypeVar("E", bound=type[Engine])


def _check_name(name: object) -> None:
    """An engine's name is shown in --help, progress lines, file and column names: a
    non-empty printable string without spaces (no escape sequence reaches a terminal)."""
    if (
        not isinstance(name, str)
        or not name
        or not name.isprintable()
        or name != "".join(name.split())
    ):
        raise ValueError(f"engine name {name!r} must be a non-empty printable name without spaces")


def register(cls: E) -> E:
    """Class decorator: make the engine known by its ``name``."""
    name = cls.name
    _check_name(name)
    if name in _ENGINES and _ENGINES[name] is not cls:
        raise ValueError(f"engine name {name!r} is registered twice")
    _ENGINES[name] = cls
    return cls


def unregister(name: str) -> None:
    """Forget an engine (tests register engines of their own and remove them again)."""
    _ENGINES.pop(name, None)


_discovery_lock = threading.Lock()
"""Discovery runs once: a second thread's first use waits for it (it used to find the flag
set and the registry still empty: "unknown engine 'reference'; known: ")."""


def _discover() -> None:
    global _discovered, _discovery_error
    with _discovery_lock:
        if not _discovered:
            try:
                _load_engines()
            except ValueError as exc:
                _discovery_error = str(exc)
            _discovered = True
    if _discovery_error is not None:
        raise ValueError(_discovery_error)


def _load_engines() -> None:
    package = import_module("hoopbench.engines")
    for module in pkgutil.iter_modules(package.__path__):
        if module.name.endswith("_engine"):
            import_module(f"hoopbench.engines.{module.name}")
    if os.environ.get(DISABLE_PLUGINS_VARIABLE, "") in ("", "0"):
        for entry in entry_points(group=PLUGIN_GROUP):
            _load_plugin(entry)
    for name in os.environ.get(ENGINE_MODULES_VARIABLE, "").split(","):
        if name.strip():
            try:
                import_module(name.strip())
            except Exception as exc:  # a module's import may raise anything: name it, in one line
                raise ValueError(
                    f"{ENGINE_MODULES_VARIABLE}: cannot import engine module {name.strip()!r}: "
                    f"{exc if isinstance(exc, ImportError) else _first_line(exc)}"
                ) from None
            except (SystemExit, KeyboardInterrupt) as exc:
                where = f"{ENGINE_MODULES_VARIABLE}: engine module {name.strip()!r}"
                raise ValueError(_exited(where, exc)) from None


def _exited(where: str, exc: SystemExit | KeyboardInterrupt) -> str:
    """The line for a module that called sys.exit, or was interrupted, while it was imported:
    hoopbench would otherwise end there, with that code and not a word (exit 0 for
    sys.exit(0)), or as if the user had pressed Ctrl-C. Which of the user's Ctrl-C and the
    module's own KeyboardInterrupt it was cannot be told apart here: the line says both."""
    what = (
        f"called sys.exit({exc.code!r})"
        if isinstance(exc, SystemExit)
        else "was interrupted (a Ctrl-C, or the module raised KeyboardInterrupt)"
    )
    return (
        f"{where} {what} while it was imported: it is not loaded "
        f"(uninstall it, or set {DISABLE_PLUGINS_VARIABLE}=1 for a plugin)"
    )


def _first_line(exc: Exception) -> str:
    """``Kind: first line`` of an error a module raised on import."""
    first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"{type(exc).__name__}: {first}"


def _load_plugin(entry: EntryPoint) -> None:
    """Load one entry point: an Engine class (registered here) or a module that registers
    its engines on import. ValueError: one line naming the plugin, whatever went wrong."""
    dist = entry.dist.name if entry.dist is not None else "an unknown distribution"
    where = f"engine plugin {entry.name!r} ({entry.value}) of {dist}"
    try:
        loaded = entry.load()
    except (SystemExit, KeyboardInterrupt) as exc:
        raise ValueError(_exited(where, exc)) from None
    except Exception as exc:  # a plugin's import may raise anything: name it, in one line
        raise ValueError(
            f"{where} cannot be loaded: {_first_line(exc)} "
            f"(uninstall it, or set {DISABLE_PLUGINS_VARIABLE}=1)"
        ) from None
    if isinstance(loaded, type) and issubclass(loaded, Engine):
        if getattr(loaded, "name", None) != entry.name:
            raise ValueError(
                f"{where}: its class is named {getattr(loaded, 'name', None)!r}, not {entry.name!r}"
            )
        try:
            register(loaded)
        except ValueError as exc:  # another engine, built in or a plugin, has its name
            raise ValueError(f"{where}: {exc}") from None
    elif not isinstance(loaded, ModuleType):
        raise ValueError(f"{where} is neither an Engine class nor a module")


def engine_classes() -> MappingProxyType[str, type[Engine]]:
    """Every registered engine, the reference first, then by name."""
    _discover()
    order = sorted(_ENGINES, key=lambda name: (name != REFERENCE_ENGINE, name))
    return MappingProxyType({name: _ENGINES[name] for name in order})


def engine_names() -> tuple[str, ...]:
    return tuple(engine_classes())


def engine_class(name: str) -> type[Engine]:
    """The engine class by name; ValueError naming the known engines for an unknown one."""
    classes = engine_classes()
    if name not in classes:
        raise ValueError(f"unknown engine {name!r}; known: {', '.join(classes)}")
    return classes[name]


def get_engine(name: str, **kwargs) -> Engine:
    """An engine instance by name (kwargs: detectors, limits)."""
    return engine_class(name)(**kwargs)
