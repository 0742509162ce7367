"""The exact reference solver behind the engine interface, sampled on the engine time grid."""

from __future__ import annotations

import math
import time
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import Engine, Simulation
from hoopbench.engines.settings import RunSettings
from hoopbench.models.scene import Scene

__all__ = ["ReferenceEngine"]


class ReferenceEngine(Engine):
    """solve_exact with mus = muk = the run's mu, sampled every ``timestep`` seconds.

    Its ``events`` come from the shared detectors, like any engine's; the exact events are
    in ``RunResult.exact_events``, so the detectors' own bias can be measured.
    """

    name = "reference"

    def _import(self) -> ModuleType:
        from hoopbench.reference import exact

        return exact

    def _version(self, module: ModuleType) -> str | None:
        from importlib.metadata import version

        return version("hoopbench")

    def _simulate(
        self, module: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> Simulation:
        mu = self.mu_for(scene, settings)
        scene = scene.with_(mus=mu, muk=mu)
        start = time.perf_counter()
        solution = module.solve_exact(scene, rtol=options["rtol"], atol=options["atol"])
        # The engine time grid, plus the window's last instant (the impact, for a hop), so
        # that the detectors see the landing.
        grid = np.arange(math.floor(solution.t_final / settings.timestep + 1e-9) + 1)
        t = np.append(grid * settings.timestep, solution.t_final)
        trajectory = solution.sample(np.unique(np.minimum(t, solution.t_final)))
        wall = time.perf_counter() - start
        return Simulation(
            trajectory=trajectory,
            n_steps=len(trajectory) - 1,
            wall_time_s=wall,
            exact_events=solution.events,
        )
