"""The exact reference solver behind the engine interface, sampled on the engine time grid."""

from __future__ import annotations

import time
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import Engine, Simulation, n_steps_for
from hoopbench.engines.options import Option, number
from hoopbench.engines.registry import register
from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.engines.settings import RunSettings
from hoopbench.models.events import Outcome
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference import exact
from hoopbench.reference.exact import DEFAULT_ATOL, DEFAULT_RTOL, MIN_RTOL

__all__ = ["ReferenceEngine"]

_NO_RESULT = (Outcome.DEGENERATE,)
"""Exact outcomes that are not a trajectory to compare with: the solver stopped where the
model has no answer, and a sampled 'rolls' before that point would look like a result."""


@register
class ReferenceEngine(Engine):
    """solve_exact with mus = muk = the run's mu, sampled every ``timestep`` seconds.

    Its events come from the shared detectors, like any engine's; the exact events are in
    ``RunResult.exact_events``, so the detectors' own bias can be measured.
    """

    name = REFERENCE_ENGINE
    distribution = "hoopbench"
    options = (
        Option(
            "rtol",
            DEFAULT_RTOL,
            number(low=MIN_RTOL, high=1e-3),
            "event times converge to ~1e-11 s between 1e-10 and 1e-12 (tests/test_exact.py)",
            outside_search="the exact solver's own accuracy: the reference is not searched",
        ),
        Option(
            "atol",
            DEFAULT_ATOL,
            number(low=0.0, high=1e-3, low_open=True),
            "state errors of ~1e-12 m, far below every engine's penetration",
            outside_search="the exact solver's own accuracy: the reference is not searched",
        ),
    )

    def _import(self) -> ModuleType:
        return exact

    def _simulate(
        self, module: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> Simulation:
        mu = self.mu_for(scene, settings)
        scene = scene.with_(mus=mu, muk=mu)
        start, cpu_start = time.perf_counter(), time.process_time()
        solution = module.solve_exact(scene, rtol=options["rtol"], atol=options["atol"])
        # The engine time grid, plus the window's last instant (the impact, for a hop), so
        # that the detectors see the landing.
        dt = settings.timestep
        n = min(n_steps_for(scene, dt), int(solution.t_final / dt * (1.0 + 1e-12)))
        t = np.append(np.arange(n + 1) * dt, solution.t_final)
        trajectory = solution.sample(np.unique(np.minimum(t, solution.t_final)))
        # At a Painlevé point (D = 0) no finite contact force exists: the window ends there,
        # and its last instant, whose force is infinite, is not a sample of the motion.
        finite = np.isfinite(trajectory.normal_force) & np.isfinite(trajectory.friction_force)
        if not finite[-1] and finite[:-1].all() and len(finite) > 2:
            trajectory = Trajectory.from_frame(trajectory.to_frame().iloc[:-1])
        wall = time.perf_counter() - start
        cpu = time.process_time() - cpu_start
        events = solution.events
        failed = None
        if events.outcome in _NO_RESULT or str(events.outcome) == "error":
            failed = f"exact solver: {events.outcome}: {events.message}".rstrip(": ")
        return Simulation(
            trajectory=trajectory,
            n_steps=len(trajectory) - 1,
            wall_time_s=wall,
            cpu_time_s=cpu,
            exact_events=events,
            failed=failed,
        )
