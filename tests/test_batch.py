"""The batch path of the engine interface (engines/base.py, Engine's docstring, Batches):
a batch's runs are the single runs, world by world, for a fake engine stepped through the
default one-step hooks and for MuJoCo through ``mujoco.batch``, bit for bit."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, fields
from types import ModuleType

import numpy as np
import pytest

from hoopbench.engines.base import CHUNK_STEPS, RUN_ALONE, STATE_KEYS, Chunk, Engine
from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import Run, RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.engines.stopping import StopRule
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

DT = 1e-4
BAD = "bad"
"""The name of a fake scene whose states turn NaN from step BAD_FROM on."""
BAD_FROM = 1500


def _fake_state(scene: Scene, steps: np.ndarray) -> np.ndarray:
    """(len(steps), 6): the fake's state at these steps, drifting so that a misplaced row
    shows; NaN from BAD_FROM on in a scene named BAD."""
    state = np.array(scene.initial_state()) + np.outer(steps, [1e-6, 0, 1e-5, 0, 0, 0])
    if scene.name == BAD:
        state[steps >= BAD_FROM, 2] = np.nan
    return state


def _fake_force(scene: Scene, steps: np.ndarray) -> np.ndarray:
    """(len(steps), 2), N: the force of the step taken from each of these steps."""
    return np.stack([scene.M * scene.g + 1e-3 * steps, 1e-4 * steps], axis=1)


@dataclass
class _Single:
    scene: Scene
    states: list[np.ndarray] = field(default_factory=list)


@dataclass
class _Worlds:
    scenes: list[Scene]
    step: np.ndarray


class FakeBatchEngine(Engine):
    """Steps a drifting state one world at a time (the single hooks) or many at once (the
    one-step batch hooks, with the base class's default ``_batch_advance``)."""

    name = "test-fake-batch"
    distribution = "hoopbench"
    batches = True

    def __init__(self) -> None:
        super().__init__()
        self.active_counts: list[int] = []
        """Worlds stepped by each _batch_step."""

    def _import(self) -> ModuleType:
        return np

    @contextmanager
    def _open(self, module, scene, settings, options, *, record) -> Iterator[_Single]:
        yield _Single(scene)

    def _advance(self, run: _Single, done: int, steps: int, last: bool) -> Chunk:
        rows = _fake_state(run.scene, np.arange(done, done + steps + 1))
        run.states.append(rows[1:] if run.states else rows)
        return Chunk({key: rows[:, k] for k, key in enumerate(STATE_KEYS)}, done + steps)

    def _trajectory(self, run: _Single, done: int, ended_early: bool) -> Trajectory:
        n = done if ended_early else done + 1  # MuJoCo's timing: an early end drops a row
        state = np.concatenate(run.states)[:n]
        force = _fake_force(run.scene, np.arange(n)) / run.scene.M
        return Trajectory.from_state(
            run.scene,
            t=np.arange(n) * DT,
            **{key: state[:, k] for k, key in enumerate(STATE_KEYS)},
            normal_force=force[:, 0],
            friction_force=force[:, 1],
        )

    @contextmanager
    def _open_batch(self, module, scenes, settings, options) -> Iterator[_Worlds]:
        yield _Worlds(list(scenes), np.zeros(len(scenes), dtype=int))

    def _batch_state(self, batch: _Worlds) -> np.ndarray:
        return np.concatenate(
            [_fake_state(s, batch.step[i : i + 1]) for i, s in enumerate(batch.scenes)]
        )

    def _batch_step(self, batch: _Worlds, active: np.ndarray) -> None:
        self.active_counts.append(int(active.sum()))
        batch.step[active] += 1

    def _batch_force(self, batch: _Worlds) -> np.ndarray:
        return np.concatenate(
            [_fake_force(s, batch.step[i : i + 1] - 1) for i, s in enumerate(batch.scenes)]
        )


def assert_same_runs(singles: list[Run], batch: list[Run]) -> None:
    """Every run of the batch is its single run: info and every trajectory array, bit for
    bit (np.array_equal: one ulp fails it)."""
    assert len(singles) == len(batch)
    for single, batched in zip(singles, batch, strict=True):
        a, b = single.info, batched.info
        assert (a.status, a.message, a.n_steps, a.stop_reason, a.mu, a.timestep) == (
            b.status,
            b.message,
            b.n_steps,
            b.stop_reason,
            b.mu,
            b.timestep,
        )
        assert b.batch is not None and b.batch.size == len(batch)
        assert single.trajectory is not None and batched.trajectory is not None
        for f in fields(Trajectory):
            mine, theirs = getattr(single.trajectory, f.name), getattr(batched.trajectory, f.name)
            assert np.array_equal(mine, theirs, equal_nan=True), f"{f.name} differs"


def _scenes() -> list[Scene]:
    """Windows of different lengths, ending inside and at the end of a chunk."""
    base = Scene.from_chi(1.0, lam=0.5, eps=0.0, mus=0.8, muk=0.8)
    return [
        base.with_(t_end=2.5 * CHUNK_STEPS * DT),
        base.with_(t_end=2.0 * CHUNK_STEPS * DT, name=BAD),
        base.with_(t_end=3.0 * CHUNK_STEPS * DT),
        base.with_(t_end=0.3 * CHUNK_STEPS * DT),
    ]


def test_a_fake_batch_is_its_single_runs():
    engine, settings = FakeBatchEngine(), RunSettings(timestep=DT)
    scenes = _scenes()
    singles = [engine.simulate(scene, settings) for scene in scenes]
    batch = engine.simulate_batch(scenes, settings)
    assert [run.info.status for run in batch] == [
        RunStatus.OK,
        RunStatus.DIVERGED,
        RunStatus.OK,
        RunStatus.OK,
    ]
    assert [run.info.n_steps for run in batch] == [2500, 1999, 3000, 300]
    assert_same_runs(singles, batch)
    cost = batch[0].info.batch
    assert cost is not None and cost.world_steps == 2500 + 1999 + 3000 + 300
    wall = sum(run.info.wall_time_s for run in batch)
    assert wall == pytest.approx(cost.wall_time_s)


def test_a_world_that_ends_is_no_longer_stepped():
    """The short world ends at step 300 (one step more for its last force), the bad one
    diverges at its chunk end 2000, the first ends at 2500, the last at 3000."""
    engine = FakeBatchEngine()
    engine.simulate_batch(_scenes(), RunSettings(timestep=DT))
    counts = np.array(engine.active_counts)
    assert counts.tolist()[:301] == [4] * 300 + [1]  # the finishing step: that world alone
    assert np.count_nonzero(counts == 3) == 2000 - 300
    assert np.count_nonzero(counts == 2) == 500  # 2000..2500
    # The finishing steps at 300, 2500 and 3000, each of its world alone; 2500..3000.
    assert np.count_nonzero(counts == 1) == 3 + 500


def test_a_world_the_batch_cannot_step_runs_alone(monkeypatch):
    """A world the engine says RUN_ALONE of (MuJoCo's batch halts a world on a warning) leaves
    the batch and runs again by itself: its run is its single run, without the batch's cost."""

    def alone(self, batch, active):
        return [RUN_ALONE if s.name == BAD else None for s in batch.scenes]

    monkeypatch.setattr(FakeBatchEngine, "_batch_diverged", alone)
    engine, settings, scenes = FakeBatchEngine(), RunSettings(timestep=DT), _scenes()
    runs = engine.simulate_batch(scenes, settings)
    single = engine.simulate(scenes[1], settings)
    assert runs[1].info.batch is None and runs[1].info.message == single.info.message
    assert runs[1].info.n_steps == single.info.n_steps == 1999
    assert all(run.info.batch is not None for k, run in enumerate(runs) if k != 1)
    # Left at its first chunk end: three worlds up to step 1000 (and one finishing step at
    # 300), two after it.
    assert engine.active_counts[CHUNK_STEPS] == 3 and engine.active_counts[CHUNK_STEPS + 1] == 2


def test_an_engine_without_batches_loops_over_single_runs():
    mujoco = get_engine("reference")
    assert not mujoco.batches
    scene = Scene.from_chi(1.0, lam=0.5, eps=0.0, mus=0.8, muk=0.8, t_end=0.1)
    [run] = mujoco.simulate_batch([scene], RunSettings())
    assert run.info.status is RunStatus.OK and run.info.batch is None


def test_a_batch_hook_that_raises_makes_every_run_an_error(monkeypatch):
    def fail(self, batch, active):
        raise RuntimeError("no")

    monkeypatch.setattr(FakeBatchEngine, "_batch_step", fail)
    runs = FakeBatchEngine().simulate_batch(_scenes(), RunSettings(timestep=DT))
    assert {(run.info.status, run.info.message) for run in runs} == {
        (RunStatus.ERROR, "RuntimeError: no")
    }


def test_bad_settings_raise_before_anything_steps():
    scene = _scenes()[0]
    with pytest.raises(ValueError, match="longer than the window"):
        FakeBatchEngine().simulate_batch([scene, scene.with_(t_end=1e-5)], RunSettings(timestep=DT))


# ----------------------------------------------------------------- MuJoCo through mujoco.batch
def _mujoco_scenes() -> list[Scene]:
    """Scenes that roll, slip and hop (hop-top stops at its impact), windows of different
    lengths, one not a whole number of chunks."""
    return [
        Scene.from_chi(1.0, lam=0.5, eps=0.0, mus=0.8, muk=0.8, t_end=0.25),
        Scene.from_chi(1.3, lam=0.55, eps=0.0, mus=0.3, muk=0.3, t_end=0.3234),
        Scene.from_chi(1.6, lam=0.6, eps=0.0, mus=0.6, muk=0.6, t_end=0.39),
        Scene.from_chi(1.9, lam=0.65, eps=0.0, mus=0.5, muk=0.5, t_end=0.46),
    ]


@pytest.mark.parametrize(
    "settings",
    [
        RunSettings(timestep=DT),
        RunSettings(timestep=DT, stop=StopRule()),
        RunSettings(timestep=2 * DT, geometry="ring", profile="stock"),
    ],
    ids=["window", "stop-rule", "ring-stock"],
)
def test_mujoco_batch_rows_are_its_single_rows_bit_for_bit(settings):
    engine = get_engine("mujoco")
    assert engine.batches
    scenes = _mujoco_scenes()
    singles = [engine.simulate(scene, settings) for scene in scenes]
    batch = engine.simulate_batch(scenes, settings)
    assert all(run.info.status is RunStatus.OK for run in batch)
    assert_same_runs(singles, batch)


def test_mujoco_batch_stops_worlds_on_their_own():
    """With a stop rule, the hopping scene ends at its impact, before its window, while the
    others run on."""
    engine = get_engine("mujoco")
    scenes = _mujoco_scenes()
    runs = engine.simulate_batch(scenes, RunSettings(timestep=DT, stop=StopRule()))
    reasons = [run.info.stop_reason for run in runs]
    assert reasons[:3] == [None, None, None] and reasons[3] == "impact"
    assert runs[3].info.n_steps < round(scenes[3].t_end / DT)


def test_each_world_may_have_its_own_stop_rule():
    """A hop map's runs stop after their own settling times: per-world rules, each run as
    its single run with that rule."""
    engine = get_engine("mujoco")
    scenes = _mujoco_scenes()
    stops = [None, StopRule(at_first_impact=False), None, StopRule()]
    runs = engine.simulate_batch(scenes, RunSettings(timestep=DT), stops=stops)
    singles = [
        engine.simulate(scene, RunSettings(timestep=DT, stop=stop))
        for scene, stop in zip(scenes, stops, strict=True)
    ]
    assert_same_runs(singles, runs)
    assert [run.info.stop_reason for run in runs] == [None, None, None, "impact"]
    assert runs[3].info.settings["stop"] == StopRule().to_dict()
    with pytest.raises(ValueError, match="2 stop rules for 4 scenes"):
        engine.simulate_batch(scenes, RunSettings(timestep=DT), stops=stops[:2])


def _one_window_scenes() -> list[Scene]:
    """Scenes that roll, slip and hop, every window 0.15 s: 1,500 steps, two chunks."""
    return [scene.with_(t_end=0.15) for scene in _mujoco_scenes()]


def test_mujoco_takes_the_last_force_in_the_last_chunk_with_the_same_rows(monkeypatch):
    """Every world ends its window in the last chunk: its last force's step comes in that
    chunk's call (1,000 steps, then 500 + 1), not in a call of its own, and every run is
    still its single run bit for bit. ~0.3 s."""
    engine = get_engine("mujoco")
    assert engine.last_force_in_chunk
    scenes, settings = _one_window_scenes(), RunSettings(timestep=DT)
    singles = [engine.simulate(scene, settings) for scene in scenes]
    calls: list[int] = []
    advance = type(engine)._batch_advance

    def counted(self, batch, active, steps):
        calls.append(steps)
        return advance(self, batch, active, steps)

    monkeypatch.setattr(type(engine), "_batch_advance", counted)
    batch = engine.simulate_batch(scenes, settings)
    assert calls == [CHUNK_STEPS, 500 + 1]
    assert_same_runs(singles, batch)


class FakeLastForceEngine(FakeBatchEngine):
    """The fake batch, its last force's step taken in the last chunk's call."""

    name = "test-fake-last-force"
    last_force_in_chunk = True


def test_a_fake_batch_with_the_last_force_in_its_last_chunk_is_its_single_runs():
    """Windows of one length: no finishing step of its own; of several lengths: a world
    that ends before the others still takes its finishing step alone."""
    engine, settings = FakeLastForceEngine(), RunSettings(timestep=DT)
    same = [scene.with_(t_end=0.25) for scene in _scenes() if scene.name != BAD]
    batch = engine.simulate_batch(same, settings)
    assert_same_runs([engine.simulate(scene, settings) for scene in same], batch)
    assert engine.active_counts == [3] * 2501  # 2,500 steps and the last force's, together
    engine.active_counts.clear()
    scenes = _scenes()
    batch = engine.simulate_batch(scenes, settings)
    assert_same_runs([engine.simulate(scene, settings) for scene in scenes], batch)
    assert engine.active_counts[:301] == [4] * 300 + [1]
