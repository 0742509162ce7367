"""Engines by name: each engine module registers its class with :func:`register`.

The engine modules of this package (``*_engine.py``) are found and imported on first use.
Importing one is cheap: an engine's own library is imported only when a run uses it.

Engines from elsewhere: the environment variable ``HOOPBENCH_ENGINE_MODULES`` lists more
modules to import at discovery (comma-separated, importable names), each registering its
engines. Every process reads it, suite workers included, so an engine of your own (or the
tests' engines that crash, hang or return NaN) runs in ``hoopbench compare`` too.
"""

from __future__ import annotations

import os
import pkgutil
from importlib import import_module
from types import MappingProxyType
from typing import TypeVar

from hoopbench.engines.base import Engine

__all__ = [
    "engine_class",
    "engine_classes",
    "engine_names",
    "get_engine",
    "register",
    "unregister",
]

ENGINE_MODULES_VARIABLE = "HOOPBENCH_ENGINE_MODULES"

_ENGINES: dict[str, type[Engine]] = {}
_discovered = False

E = TypeVar("E", bound=type[Engine])


def register(cls: E) -> E:
    """Class decorator: make the engine known by its ``name``."""
    name = cls.name
    if name in _ENGINES and _ENGINES[name] is not cls:
        raise ValueError(f"engine name {name!r} is registered twice")
    _ENGINES[name] = cls
    return cls


def unregister(name: str) -> None:
    """Forget an engine (tests register engines of their own and remove them again)."""
    _ENGINES.pop(name, None)


def _discover() -> None:
    global _discovered
    if _discovered:
        return
    _discovered = True
    package = import_module("hoopbench.engines")
    for module in pkgutil.iter_modules(package.__path__):
        if module.name.endswith("_engine"):
            import_module(f"hoopbench.engines.{module.name}")
    for name in os.environ.get(ENGINE_MODULES_VARIABLE, "").split(","):
        if name.strip():
            try:
                import_module(name.strip())
            except ImportError as exc:
                raise ValueError(
                    f"{ENGINE_MODULES_VARIABLE}: cannot import engine module {name.strip()!r}: "
                    f"{exc}"
                ) from None


def engine_classes() -> MappingProxyType[str, type[Engine]]:
    """Every registered engine, the reference first, then by name."""
    _discover()
    order = sorted(_ENGINES, key=lambda name: (name != "reference", name))
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
