"""The stepping loop that Engine runs for every engine (engines/base.py), through a fake
adapter that records how its hooks are called: chunking, the divergence stop, the stop
monitor's feed, the garbage collector, and the bare-loop yardstick."""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np
import pytest

import hoopbench.engines.base as base
from hoopbench.engines.base import CHUNK_STEPS, Chunk, Engine, n_steps_for
from hoopbench.engines.registry import engine_class, get_engine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.engines.stopping import StopReason, StopRule
from hoopbench.models.kinematics import Polygon
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

DT = 1e-4
SCENE = Scene.from_chi(1.0, lam=0.5, eps=0.0, mus=0.8, muk=0.8, t_end=2.5 * CHUNK_STEPS * DT)
"""A window of two and a half chunks."""
STEPPING = ("mujoco", "pybullet", "pymunk", "drake")
COLUMNS = ("X", "Y", "theta", "Xdot", "Ydot", "thetadot")


@dataclass
class FakeRun:
    """What the fake adapter saw: hook calls in order, and the collector's state in each."""

    record: bool
    calls: list[tuple[Any, ...]] = field(default_factory=list)
    gc_enabled: list[bool] = field(default_factory=list)
    closed: bool = False

    def saw(self, *call: Any) -> None:
        self.calls.append(call)
        self.gc_enabled.append(gc.isenabled())


class FakeEngine(Engine):
    """Holds the scene's initial state still. ``bad_from``: the chunk whose states turn NaN;
    ``own_reason``: what its _diverged hook says from that chunk on."""

    name = "test-fake-loop"
    distribution = "hoopbench"

    def __init__(
        self, bad_from: int | None = None, own_reason: str | None = None, fail: bool = False
    ) -> None:
        super().__init__()
        self.bad_from, self.own_reason, self.fail = bad_from, own_reason, fail
        self.runs: list[FakeRun] = []
        self.shape = Polygon(((0.0, -SCENE.a), (SCENE.a, 0.0), (0.0, SCENE.a), (-SCENE.a, 0.0)))

    def _import(self) -> ModuleType:
        return np

    @contextmanager
    def _open(self, module, scene, settings, options, *, record) -> Iterator[FakeRun]:
        run = FakeRun(record)
        self.runs.append(run)
        try:
            yield run
        finally:
            run.closed = True

    def _bad(self, run: FakeRun) -> bool:
        chunks = sum(call[0] == "advance" for call in run.calls)
        return self.bad_from is not None and chunks > self.bad_from

    def _advance(self, run: FakeRun, done: int, steps: int, last: bool) -> Chunk:
        run.saw("advance", done, steps, last)
        if self.fail:
            raise RuntimeError("fake engine failed")
        values = np.array(SCENE.initial_state())
        if self._bad(run):
            values[2] = np.nan
        return Chunk({k: np.full(steps, v) for k, v in zip(COLUMNS, values, strict=True)}, 7)

    def _diverged(self, run: FakeRun) -> str | None:
        return self.own_reason if self._bad(run) else None

    def _contact_shape(self, run: FakeRun) -> Polygon:
        return self.shape

    def _finish(self, run: FakeRun, ended_early: bool) -> None:
        run.saw("finish", ended_early)

    def _trajectory(self, run: FakeRun, done: int, ended_early: bool) -> Trajectory:
        run.saw("trajectory", done, ended_early)
        n = done + 1
        state = dict(zip(COLUMNS, SCENE.initial_state(), strict=True))
        return Trajectory.from_state(
            SCENE,
            t=DT * np.arange(n),
            **{k: np.full(n, v) for k, v in state.items()},
            normal_force=np.ones(n),
            friction_force=np.zeros(n),
        )

    def _step_bare(self, run: FakeRun, steps: int) -> None:
        run.saw("bare", steps)


@pytest.fixture
def gc_on() -> Iterator[None]:
    """The collector on for the test, and as it was afterwards."""
    was = gc.isenabled()
    gc.enable()
    yield
    if not was:
        gc.disable()


def test_the_loop_steps_the_window_in_chunks(gc_on):
    engine = FakeEngine()
    run = engine.simulate(SCENE, RunSettings(timestep=DT))
    assert n_steps_for(SCENE, DT) == 2500
    assert run.info.status is RunStatus.OK, run.info.message
    assert run.info.n_steps == 2500 and len(run.trajectory) == 2501
    assert run.info.stop_reason is None
    [fake] = engine.runs
    assert fake.record and fake.closed
    assert fake.calls == [
        ("advance", 0, 1000, False),
        ("advance", 1000, 1000, False),
        ("advance", 2000, 500, True),
        ("finish", False),
        ("trajectory", 2500, False),
    ]
    # Off while stepping, on again for building the trajectory.
    assert fake.gc_enabled == [False, False, False, False, True]
    assert gc.isenabled()


@pytest.mark.parametrize(
    ("own_reason", "message"), [(None, "non-finite theta"), ("the engine says so", None)]
)
def test_divergence_ends_the_run_after_its_chunk(gc_on, own_reason, message):
    """check_divergence reads each chunk; the engine's own reason comes first."""
    engine = FakeEngine(bad_from=1, own_reason=own_reason)
    run = engine.simulate(SCENE, RunSettings(timestep=DT))
    assert run.info.status is RunStatus.DIVERGED
    assert run.info.message == (message or own_reason)
    assert run.info.n_steps == 2000
    [fake] = engine.runs
    assert [call[0] for call in fake.calls] == ["advance", "advance", "finish", "trajectory"]
    assert fake.calls[-2:] == [("finish", True), ("trajectory", 2000, True)]


def test_the_divergence_check_reads_the_contact_shape(monkeypatch):
    seen = []
    monkeypatch.setattr(base, "check_divergence", lambda *args: seen.append(args[3]))
    engine = FakeEngine()
    engine.simulate(SCENE, RunSettings(timestep=DT))
    assert seen == [engine.shape] * 3


def test_the_stop_monitor_is_fed_each_chunk_and_ends_the_run(gc_on, monkeypatch):
    fed = []

    def feed(monitor, states, last_step):
        fed.append((len(states["theta"]), last_step, monitor.shape))
        return StopReason.SETTLED if len(fed) == 2 else None

    monkeypatch.setattr(base.StopMonitor, "feed", feed)
    engine = FakeEngine()
    run = engine.simulate(SCENE, RunSettings(timestep=DT, stop=StopRule(settle_after=0.0)))
    # The chunk's states and the step index the adapter gave (7), with the run's shape.
    assert fed == [(1000, 7, engine.shape), (1000, 7, engine.shape)]
    assert run.info.status is RunStatus.OK
    assert run.info.stop_reason == "settled" and run.info.n_steps == 2000
    assert engine.runs[0].calls[-1] == ("trajectory", 2000, True)
    fed.clear()
    FakeEngine().simulate(SCENE, RunSettings(timestep=DT))  # no rule, no monitor
    FakeEngine(bad_from=0).simulate(SCENE, RunSettings(timestep=DT, stop=StopRule()))
    assert fed == []  # nor for a diverged chunk


def test_the_collector_is_restored_whatever_happens():
    was = gc.isenabled()
    try:
        gc.disable()
        FakeEngine().simulate(SCENE, RunSettings(timestep=DT))
        assert not gc.isenabled()
        gc.enable()
        engine = FakeEngine(fail=True)
        run = engine.simulate(SCENE, RunSettings(timestep=DT))
        assert run.info.status is RunStatus.ERROR
        assert run.info.message == "RuntimeError: fake engine failed"
        assert gc.isenabled() and engine.runs[0].closed
    finally:
        (gc.enable if was else gc.disable)()


def test_bare_loop_time_steps_a_bare_model_with_the_collector_off(gc_on):
    engine = FakeEngine()
    seconds = engine.bare_loop_time(SCENE, RunSettings(timestep=DT))
    assert seconds >= 0.0
    [fake] = engine.runs
    assert not fake.record and fake.closed
    assert fake.calls == [("bare", 2500)]
    assert fake.gc_enabled == [False]
    assert gc.isenabled()
    with pytest.raises(ValueError, match="timestep"):
        engine.bare_loop_time(SCENE, RunSettings(timestep=1.0))


@pytest.mark.parametrize("name", STEPPING)
def test_real_engines_use_the_base_loop_and_yardstick(name):
    cls = engine_class(name)
    assert cls.bare_loop_time is Engine.bare_loop_time
    assert cls._simulate is Engine._simulate
    assert cls._step_bare is not Engine._step_bare


def test_an_engine_that_does_not_step_has_no_bare_loop():
    with pytest.raises(NotImplementedError, match="reference does not step"):
        get_engine("reference").bare_loop_time(SCENE, RunSettings(timestep=DT))
