"""Engines behind one interface, with the shared detectors and run settings.

Engine libraries (mujoco, pybullet, pymunk) are imported only when a run uses them.
"""

from hoopbench.engines.judging.detectors import DetectorSettings, detect_events
from hoopbench.engines.judging.judge import judge
from hoopbench.engines.registry import engine_class, engine_names, get_engine
from hoopbench.engines.run import Run, RunInfo, RunResult, RunStatus
from hoopbench.engines.settings import RunSettings

__all__ = [
    "DetectorSettings",
    "Run",
    "RunInfo",
    "RunResult",
    "RunSettings",
    "RunStatus",
    "detect_events",
    "engine_class",
    "engine_names",
    "get_engine",
    "judge",
]
