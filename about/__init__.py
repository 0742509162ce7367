"""hoopbench: cross-validates physics engines against an exact solver on the hopping hoop.

As a library (``hoopbench.reports.api``; README, "Python API")::

    import hoopbench as hb

    scene = hb.scene("hop-top")                     # or hb.scene(lam=0.9, chi=1.2, mus=0.5)
    solution = hb.exact(scene)                      # events and a dense trajectory
    run = hb.run("mujoco", scene, timestep=1e-3)    # .trajectory, .row, .verdict, .events
    text = hb.export("mujoco", scene, timestep=1e-3)  # the same run as a standalone script
    runs = hb.compare("quick", "out/quick")         # a suite's runs table
    points = hb.map("out/map", grid=(3, 3))         # the hop map's table
    path = hb.report(["out/quick"])                 # report.md

Importing ``hoopbench`` is light: the functions load on first use (PEP 562), and with them
numpy, pandas and the engines' adapters.

The project's folders install as sub-packages: ``hoopbench.models`` (the scene and result
types), ``hoopbench.reference`` (the exact and seed solvers), ``hoopbench.engines`` (one
adapter per engine, shared detectors) and ``hoopbench.reports`` (suites, maps, report, API,
CLI).
"""

from __future__ import annotations

from typing import Any

__version__ = "0.2.0"

_API = {
    "scene": "scene",
    "scene_names": "scene_names",
    "engine_names": "engine_names",
    "exact": "exact",
    "run": "run",
    "run_settings": "run_settings",
    "judgement": "judgement",
    "export": "export",
    "compare": "compare",
    "hop_map": "hop_map",
    "map": "hop_map",
    "report": "report",
    "tune": "tune",
    "EngineRun": "EngineRun",
    "OptionError": "OptionError",
}
"""Attribute of ``hoopbench`` -> its name in hoopbench.reports.api."""

__all__ = ["__version__", *_API]


def __getattr__(name: str) -> Any:
    """The API's functions, imported on first use: `import hoopbench` alone stays light."""
    if name not in _API:
        raise AttributeError(f"module 'hoopbench' has no attribute {name!r}")
    import hoopbench.reports.api as api

    value = getattr(api, _API[name])
    globals()[name] = value  # the next lookup finds it without this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_API})
