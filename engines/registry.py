"""Engines by name."""

from __future__ import annotations

from importlib import import_module

from hoopbench.engines.base import Engine

__all__ = ["ENGINE_NAMES", "get_engine"]

_ADAPTERS = {
    "reference": ("hoopbench.engines.reference_engine", "ReferenceEngine"),
    "mujoco": ("hoopbench.engines.mujoco_engine", "MujocoEngine"),
    "pybullet": ("hoopbench.engines.pybullet_engine", "PybulletEngine"),
    "pymunk": ("hoopbench.engines.pymunk_engine", "PymunkEngine"),
}

ENGINE_NAMES: tuple[str, ...] = tuple(_ADAPTERS)


def get_engine(name: str, **kwargs) -> Engine:
    """An adapter instance by name; ValueError naming the known engines for an unknown one."""
    try:
        module_name, class_name = _ADAPTERS[name]
    except KeyError:
        raise ValueError(f"unknown engine {name!r}; known: {', '.join(ENGINE_NAMES)}") from None
    return getattr(import_module(module_name), class_name)(**kwargs)
