"""Test-only engines, registered when HOOPBENCH_ENGINE_MODULES names this module: one that
kills its worker process, one that hangs, one that passes NaN on, one that is slow.

Each is the reference engine with one fault, so that its good runs are real runs.
"""

from __future__ import annotations

import os
import time

from hoopbench.engines.base import Simulation
from hoopbench.engines.reference_engine import ReferenceEngine
from hoopbench.engines.registry import register
from hoopbench.models.trajectory import Trajectory


@register
class CrashEngine(ReferenceEngine):
    """Dies as a segfault or an out-of-memory kill would: no exception, no row."""

    name = "test-crash"

    def _simulate(self, module, scene, settings, options):
        os._exit(1)


@register
class HangEngine(ReferenceEngine):
    name = "test-hang"

    def _simulate(self, module, scene, settings, options):
        time.sleep(1000)


@register
class NanEngine(ReferenceEngine):
    """Reports success with a NaN in the middle of its trajectory."""

    name = "test-nan"

    def _simulate(self, module, scene, settings, options):
        sim = super()._simulate(module, scene, settings, options)
        frame = sim.trajectory.to_frame()
        frame.loc[len(frame) // 2, "theta"] = float("nan")
        return Simulation(
            trajectory=Trajectory.from_frame(frame),
            n_steps=sim.n_steps,
            wall_time_s=sim.wall_time_s,
        )


@register
class SlowEngine(ReferenceEngine):
    """The reference, 0.4 s slower: a sweep long enough to interrupt."""

    name = "test-slow"

    def _simulate(self, module, scene, settings, options):
        time.sleep(0.4)
        return super()._simulate(module, scene, settings, options)
