"""What the batched engines' tests (test_mjx.py, test_mjwarp.py, test_newton.py) share: a
run that must come back ok (a skip when its optional engine is missing), the largest
difference between two trajectories, the runs of a batch that are not their lone runs
bit for bit, and the Warp modules a run launches."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
from conftest import engine_unavailable

from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunResult, RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import COLUMNS, Trajectory

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


def same_run(a: RunResult, b: RunResult) -> str | None:
    """None if two runs are the same bit for bit (status, message, steps, ending, every
    trajectory column), else the first difference."""
    for field in ("status", "message", "n_steps", "stop_reason"):
        if getattr(a.info, field) != getattr(b.info, field):
            return f"{field}: {getattr(a.info, field)} != {getattr(b.info, field)}"
    if a.trajectory is None or b.trajectory is None:
        return None if a.trajectory is b.trajectory else "one run has no trajectory"
    for name in COLUMNS:
        x, y = getattr(a.trajectory, name), getattr(b.trajectory, name)
        if not np.array_equal(x, y, equal_nan=True):
            return f"{name}: first difference at row {np.flatnonzero(x != y)[0]}"
    return None


def batched_differences(
    engine: str, scenes: Sequence[Scene], settings: RunSettings, orders: Sequence[Sequence[int]]
) -> list[str]:
    """Each scene run alone, then in one call per order (indices into ``scenes``): every
    batched run that is not its lone run bit for bit, named (scene, call, difference)."""
    runner = get_engine(engine)
    alone = [runner.simulate(scene, settings) for scene in scenes]
    if alone[0].info.status is RunStatus.UNAVAILABLE:
        engine_unavailable(engine, alone[0].info.message)
    return [
        f"{scenes[i].name} (call {k} of {len(order)} worlds): {found}"
        for k, order in enumerate(orders)
        for run, i in zip(
            runner.simulate_batch([scenes[i] for i in order], settings), order, strict=True
        )
        if (found := same_run(run, alone[i]))
    ]


def launched_warp_modules(monkeypatch: pytest.MonkeyPatch, engine: str) -> set[str]:
    """The names of the Warp modules whose kernels ``wp.launch`` launches from now on in
    this test (the set fills as runs launch; MuJoCo Warp and Newton launch through it); a
    skip when ``engine``'s Warp is missing."""
    try:
        import warp as wp
    except ImportError as exc:
        engine_unavailable(engine, str(exc))

    launched: set[str] = set()
    launch = wp.launch

    def recording(kernel, *args, **kwargs):
        launched.add(kernel.module.name)
        return launch(kernel, *args, **kwargs)

    monkeypatch.setattr(wp, "launch", recording)
    return launched
