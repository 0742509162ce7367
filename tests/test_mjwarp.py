"""MuJoCo Warp against MuJoCo C on the same model and settings, and its batches (nworld).

The cross-check runs hop-top over its first 0.6 s (it slips at 0.442 s) at dt 1e-3 with the
tuned settings (RK4, elliptic cone), on the CPU (Warp's CPU backend). MuJoCo Warp is single
precision throughout, so the differences are float32's size, as MJX's float32 runs show
(tests/test_mjx.py: MJX's float64 run is MuJoCo C's to 2e-11). Measured on mujoco-warp 4.0.0,
warp-lang 1.19.0: see MEASURED; tolerances as for MJX's float32: positions 2e-4, rolling
velocities 1e-2, rolling normal force 1e-2 g.
"""

from __future__ import annotations

import numpy as np
import pytest
from worlds_runs import DT, STATE_COLUMNS, run_ok, skip_without_a_warp_gpu, worst

from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene

SCENE = get_scene("hop-top").with_(t_end=0.6)


def _run(engine: str, scene=SCENE, **options):
    return run_ok(engine, scene, **options)


def test_mujoco_warp_is_mujoco_c_in_float32():
    warp, c = _run("mjwarp"), _run("mujoco")
    a, b = warp.trajectory, c.trajectory
    assert len(a) == len(b)
    assert worst(a, b, ("X", "Y", "theta")) <= 2e-4
    rolling = b.t < 0.4  # before the slip at 0.442 s
    assert worst(a, b, ("Xdot", "Ydot", "thetadot"), rolling) <= 1e-2
    assert np.max(np.abs(a.normal_force - b.normal_force)[rolling]) / SCENE.g <= 1e-2
    assert warp.events.t_slip == pytest.approx(c.events.t_slip, abs=2e-3)
    assert worst(a, b, STATE_COLUMNS) > 1e-9  # single precision shows


def test_batch_rows_are_the_single_runs():
    """Two worlds of different scenes and windows in one Data (nworld 2): each is its single
    run; the world still running does not move while the other takes its last step."""
    engine = get_engine("mjwarp")
    settings = RunSettings(timestep=DT, profile="stock")  # Euler: a quarter of RK4's cost
    scenes = [SCENE.with_(t_end=0.05), get_scene("seed-mu").with_(t_end=0.08)]
    batch = engine.simulate_batch(scenes, settings)
    for scene, run in zip(scenes, batch, strict=True):
        single = engine.simulate(scene, settings)
        assert run.info.status is RunStatus.OK, run.info.message
        assert run.info.n_steps == single.info.n_steps
        assert worst(run.trajectory, single.trajectory, STATE_COLUMNS) <= 1e-6


def test_unknown_device_is_named():
    with pytest.raises(ValueError, match="device must be one of auto, cpu, gpu"):
        get_engine("mjwarp").check(SCENE, RunSettings(options={"device": "tpu"}))


@pytest.mark.gpu
def test_runs_on_a_gpu():
    skip_without_a_warp_gpu()
    result = _run("mjwarp", scene=SCENE.with_(t_end=0.05), device="gpu")
    assert result.info.status is RunStatus.OK
