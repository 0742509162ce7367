"""The exact reference solver behind the engine interface, sampled on the engine time grid."""

from __future__ import annotations

import time
from types import ModuleType
from typing import Any

from engines.base import Engine, Simulation
from engines.settings import RunSettings
from models.scene import Scene

__all__ = ["ReferenceEngine"]


class ReferenceEngine(Engine):
    """solve_exact with mus = muk = the run's mu, sampled every ``timestep`` seconds.

    Its ``events`` come from the shared detectors, like any engine's; the exact events are
    in ``RunResult.exact_events``, so the detectors' own bias can be measured.
    """

    name = "reference"

    def _import(self) -> ModuleType:
        from reference import exact

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
        trajectory = solution.sample_uniform(settings.timestep)
        wall = time.perf_counter() - start
        return Simulation(
            trajectory=trajectory,
            n_steps=len(trajectory) - 1,
            wall_time_s=wall,
            exact_events=solution.events,
        )
