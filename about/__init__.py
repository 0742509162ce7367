"""hoopbench: cross-validates physics engines against an exact solver on the hopping hoop.

The project's folders install as sub-packages: ``hoopbench.models`` (the scene and result
types), ``hoopbench.reference`` (the exact and seed solvers), ``hoopbench.engines`` (one
adapter per engine, shared detectors) and ``hoopbench.reports`` (suites, report, CLI).
"""

__version__ = "0.2.0"

__all__ = ["__version__"]
