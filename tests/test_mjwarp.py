"""MuJoCo Warp against MuJoCo C on the same model and settings, and its batches (nworld).

The cross-check runs hop-top over its first 0.6 s (it slips at 0.442 s) at dt 1e-3 with the
tuned settings (RK4, elliptic cone), on the CPU (Warp's CPU backend). MuJoCo Warp is single
precision throughout, so the differences are float32's size, as MJX's float32 runs show
(tests/test_mjx.py: MJX's float64 run is MuJoCo C's to 2e-11). Measured on mujoco-warp 4.0.0,
warp-lang 1.19.0: see MEASURED; tolerances as for MJX's float32: positions 2e-4, rolling
velocities 1e-2, rolling normal force 1e-2 g.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import pytest
from worlds_runs import (
    DT,
    STATE_COLUMNS,
    batched_differences,
    launched_warp_modules,
    run_ok,
    same_run,
    skip_without_a_warp_gpu,
    worst,
)

from hoopbench.engines import mjwarp_engine
from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene, scene_names

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


def _catalogue() -> list:
    """Every catalogue scene MuJoCo's model takes (not massless: its hoop has no moment of
    inertia about the centre of mass)."""
    return [get_scene(name) for name in scene_names() if name != "massless"]


ORDERS = ([3, 1], range(8), range(8, 10), [9, 4, 0, 8, 3, 7, 1, 2, 6, 5])
"""Calls of the alone-against-batched tests: a pair, eight then the other two, all ten in
another order (indices into ``_catalogue()``)."""


@pytest.mark.slow
@pytest.mark.parametrize("profile", ["stock", "tuned"])
def test_a_row_is_the_same_alone_and_in_any_batch_over_whole_windows(profile):
    """Every catalogue scene MuJoCo takes, stock (Euler) and tuned (RK4), over its whole
    window (3 s) at dt 1e-3, alone and in calls of 2, 8, 2 and 10 worlds: the same run bit
    for bit, each step a captured graph replayed (Warp's CPU graph: launched from Python,
    a tuned 3-s run would cost 90 s). Cost: 6 CPU-s stock, 10 tuned, 2 loaded cores,
    2026-11-29."""
    settings = RunSettings(timestep=DT, profile=profile)
    assert not batched_differences("mjwarp", _catalogue(), settings, ORDERS)


@pytest.mark.parametrize("profile", ["stock", "tuned"])
def test_captured_steps_are_the_steps_launched(monkeypatch, profile):
    """Each step is a graph captured once per kept objects and replayed (Warp's CPU graph
    here, a CUDA graph on a GPU): the same runs bit for bit as its kernels launched one by
    one from Python, Euler and RK4, a world held while the other runs on (the shorter
    window) included. About 2.5 CPU-s for both."""
    engine = get_engine("mjwarp")
    settings = RunSettings(timestep=DT, profile=profile)
    scenes = [SCENE.with_(t_end=0.03), get_scene("seed-mu").with_(t_end=0.05)]
    captured = engine.simulate_batch(scenes, settings)
    monkeypatch.setattr(mjwarp_engine, "CAPTURE_STEPS", False)
    launched = engine.simulate_batch(scenes, settings)
    for a, b in zip(launched, captured, strict=True):
        assert a.info.status is RunStatus.OK, a.info.message
        assert same_run(a, b) is None, same_run(a, b)


def test_a_second_call_builds_nothing_and_steps_as_the_first():
    """Per process a call keeps its stacked model, Data and buffers per device, options,
    timestep and worlds: a second call of the same builds none of them again and writes its
    worlds' integration state into the kept Data (a call of other worlds in between, and
    the kept Data left at the first call's end): its runs are the first call's bit for
    bit."""
    engine = get_engine("mjwarp")
    settings = RunSettings(timestep=DT, profile="stock")
    scenes = [SCENE.with_(t_end=0.05), get_scene("painleve").with_(t_end=0.05)]
    mjwarp_engine._KEPT.clear()
    first = engine.simulate_batch(scenes, settings)
    engine.simulate_batch(
        [get_scene(n).with_(t_end=0.05) for n in ("seed", "hop-bottom")], settings
    )
    second = engine.simulate_batch(scenes, settings)
    assert [kept.calls for kept in mjwarp_engine._KEPT.values()] == [1, 2]
    for a, b in zip(first, second, strict=True):
        assert a.info.status is RunStatus.OK, a.info.message
        assert same_run(a, b) is None, same_run(a, b)


def test_unknown_device_is_named():
    with pytest.raises(ValueError, match="device must be one of auto, cpu, gpu"):
        get_engine("mjwarp").check(SCENE, RunSettings(options={"device": "tpu"}))


@pytest.mark.gpu
def test_runs_on_a_gpu():
    skip_without_a_warp_gpu()
    result = _run("mjwarp", scene=SCENE.with_(t_end=0.05), device="gpu")
    assert result.info.status is RunStatus.OK


@pytest.mark.gpu
def test_a_row_is_the_same_alone_and_in_any_batch_on_a_gpu():
    """As the CPU test above, tuned, on a GPU, where each step is a CUDA graph captured once
    per kept objects."""
    skip_without_a_warp_gpu()
    settings = RunSettings(timestep=DT, options={"device": "gpu"})
    assert not batched_differences("mjwarp", _catalogue(), settings, ORDERS)


def test_the_modules_loaded_before_the_first_step_are_ones_it_launches(monkeypatch):
    """The modules the adapter loads ahead of a new build's first step, where two cold
    processes split them (``WARP_MODULES``, engines/warp_compile.py), all exist and are all
    launched by a stock and a tuned run: none compiled for nothing. Steps launched from
    Python (a captured graph launches nothing), kept objects built anew: 0.01 s windows."""
    monkeypatch.setattr(mjwarp_engine, "CAPTURE_STEPS", False)
    monkeypatch.setattr(mjwarp_engine, "_KEPT", OrderedDict())
    launched = launched_warp_modules(monkeypatch, "mjwarp")
    engine = get_engine("mjwarp")
    for profile in ("stock", "tuned"):
        run = engine.simulate(SCENE.with_(t_end=0.01), RunSettings(timestep=DT, profile=profile))
        assert run.info.status is RunStatus.OK, run.info.message
    assert set(mjwarp_engine.WARP_MODULES) <= launched
