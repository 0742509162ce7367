"""What the batched engines' tests (test_mjx.py, test_mjwarp.py, test_newton.py) share: a
run that must come back ok (a skip when its optional engine is missing) and the largest
difference between two trajectories."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import engine_unavailable

from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunResult, RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

DT = 1e-3
"""The batched engines' timestep in the suites and these tests (s)."""
STATE_COLUMNS = ("X", "Y", "theta", "Xdot", "Ydot", "thetadot")


def run_ok(engine: str, scene: Scene, **options: object) -> RunResult:
    """``engine``'s tuned run of ``scene`` at :data:`DT` with ``options``, asserted ok."""
    result = get_engine(engine).run(scene, RunSettings(timestep=DT, options=options))
    if result.info.status is RunStatus.UNAVAILABLE:
        engine_unavailable(engine, result.info.message)
    assert result.info.status is RunStatus.OK, result.info.message
    return result


def worst(
    a: Trajectory, b: Trajectory, columns: tuple[str, ...] = STATE_COLUMNS, rows=slice(None)
) -> float:
    """The largest |a - b| over ``columns`` and ``rows`` of two trajectories."""
    return max(float(np.max(np.abs(getattr(a, c) - getattr(b, c))[rows])) for c in columns)


def skip_without_a_warp_gpu() -> None:
    """A skip for a ``gpu`` test of MuJoCo Warp or Newton where Warp sees no CUDA device (CI
    has none; without Warp, the module's other tests fail under CI)."""
    try:
        import warp as wp
    except ImportError as exc:
        pytest.skip(f"no GPU: {exc}")
    if wp.get_cuda_device_count() == 0:
        pytest.skip("no GPU for Warp")
