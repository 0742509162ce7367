"""Engine adapters behind one interface, with the shared detectors and run settings.

Engine modules (mujoco, pybullet, pymunk) are imported only when a run uses them.
"""

from hoopbench.engines.base import RunInfo, RunResult, RunStatus
from hoopbench.engines.detectors import DetectorSettings, detect_events
from hoopbench.engines.registry import ENGINE_NAMES, get_engine
from hoopbench.engines.settings import ENGINE_OPTIONS, RunSettings

__all__ = [
    "ENGINE_NAMES",
    "ENGINE_OPTIONS",
    "DetectorSettings",
    "RunInfo",
    "RunResult",
    "RunSettings",
    "RunStatus",
    "detect_events",
    "get_engine",
]
