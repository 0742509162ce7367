"""The judge step: events from a run or a stored trajectory, and honest statuses."""

from __future__ import annotations

from collections.abc import Iterator
from types import ModuleType
from typing import Any

import numpy as np
import pyarrow.parquet as pq
import pytest

from hoopbench.engines.base import Engine, Simulation
from hoopbench.engines.judging.judge import judge
from hoopbench.engines.registry import engine_names, get_engine, register, unregister
from hoopbench.engines.run import Run, RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.models.trajectory import Trajectory


class NanEngine(Engine):
    """Test-only: the reference's trajectory with one NaN, reported by the adapter as fine."""

    name = "test-nan"
    distribution = "hoopbench"

    def _import(self) -> ModuleType:
        import numpy

        return numpy

    def _simulate(self, module, scene, settings, options: dict[str, Any]) -> Simulation:
        run = get_engine("reference").simulate(scene, settings)
        frame = run.trajectory.to_frame()
        frame.loc[len(frame) // 2, "normal_force"] = np.nan
        trajectory = Trajectory.from_frame(frame)
        return Simulation(trajectory=trajectory, n_steps=len(frame) - 1, wall_time_s=0.0)


@pytest.fixture
def nan_engine() -> Iterator[str]:
    register(NanEngine)
    try:
        yield NanEngine.name
    finally:
        unregister(NanEngine.name)


def test_a_nan_from_an_adapter_is_diverged_not_ok(nan_engine):
    assert nan_engine in engine_names()
    scene = get_scene("seed-mu").with_(t_end=0.2)
    result = get_engine(nan_engine).run(scene, RunSettings(timestep=1e-3))
    assert result.info.status is RunStatus.DIVERGED
    assert result.info.message == "non-finite normal_force"
    assert result.events is None


def test_test_engines_leave_the_registry():
    assert "test-nan" not in engine_names()


def test_a_stored_trajectory_is_judged_as_the_run(tmp_path):
    """Stepping and judging are separate: the events come back from a file alone."""
    scene = get_scene("hop-bottom")
    engine = get_engine("pymunk")
    run = engine.simulate(scene, RunSettings(timestep=1e-4))
    assert isinstance(run, Run) and run.info.status is RunStatus.OK
    direct = judge(run)
    path = run.trajectory.write(tmp_path / "hop.parquet")
    again = judge(Run(Trajectory.read(path), run.info))
    assert again.events == direct.events
    assert direct.events.t_lift is not None  # a real hop, so the comparison means something


def test_an_error_run_gets_no_events():
    run = get_engine("reference").simulate(get_scene("massless").with_(t_end=1.5))
    assert run.info.status is RunStatus.ERROR
    assert judge(run).events is None


def test_a_stored_trajectory_reads_back_whole_without_dictionaries(tmp_path):
    """A Parquet trajectory holds its floats plain (no dictionary: a run's floats hardly
    repeat, and Arrow's try at one was most of a write) and reads back bit for bit."""
    scene = get_scene("hop-bottom")
    run = get_engine("pymunk").simulate(scene.with_(t_end=0.3), RunSettings(timestep=1e-4))
    assert run.trajectory is not None
    path = run.trajectory.write(tmp_path / "hop.parquet")
    back = Trajectory.read(path)
    for name in ("t", "X", "Y", "theta", "normal_force", "friction_force", "contact"):
        assert np.array_equal(getattr(back, name), getattr(run.trajectory, name)), name
    meta = pq.ParquetFile(path).metadata
    for i in range(meta.num_columns):
        encodings = meta.row_group(0).column(i).encodings
        assert not any("DICTIONARY" in e for e in encodings), (i, encodings)
