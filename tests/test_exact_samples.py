"""The exact solution sampled once per (solution, times) in a worker (judging/exact_samples.py):
the very numbers of ``ExactSolution.sample``, shared only between runs of equal times. ~1 s."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest

from hoopbench.engines.judging import exact_samples
from hoopbench.engines.judging.comparison import exact_solution
from hoopbench.engines.judging.exact_samples import exact_sample
from hoopbench.models.catalogue import get_scene
from hoopbench.models.trajectory import Trajectory


@pytest.fixture(autouse=True)
def _fresh():
    exact_samples.clear()
    yield
    exact_samples.clear()


def _same(a: Trajectory, b: Trajectory) -> bool:
    return all(np.array_equal(getattr(a, f.name), getattr(b, f.name)) for f in fields(Trajectory))


def test_equal_times_share_one_sample_with_the_solutions_numbers():
    scene = get_scene("hop-top")
    exact = exact_solution(scene, scene.mus)
    t = np.arange(2000) * 1e-4
    first = exact_sample(exact, t)
    assert _same(first, exact.sample(t))
    again = exact_sample(exact, np.arange(2000) * 1e-4)  # another array, equal times
    assert again is first
    with pytest.raises(ValueError, match="read-only"):
        first.X[0] = 0.0  # shared: nobody may write into it


def test_other_times_or_another_solution_are_sampled_anew():
    """Times of the same length, first and last but one other in the middle are other
    times; the same times of another solution are another sample."""
    scene = get_scene("hop-top")
    exact = exact_solution(scene, scene.mus)
    t = np.arange(2000) * 1e-4
    kept = exact_sample(exact, t)
    moved = t.copy()
    moved[1000] += 0.5e-4
    other = exact_sample(exact, moved)
    assert other is not kept and _same(other, exact.sample(moved))
    seed = get_scene("seed-mu")
    theirs = exact_sample(exact_solution(seed, seed.mus), t)
    assert not _same(theirs, kept)


def test_the_oldest_samples_go_first(monkeypatch):
    monkeypatch.setattr(exact_samples, "KEPT_SAMPLES", 3000)
    scene = get_scene("hop-top")
    exact = exact_solution(scene, scene.mus)
    one, two = np.arange(2000) * 1e-4, np.arange(2000) * 2e-4
    first = exact_sample(exact, one)
    exact_sample(exact, two)  # 4,000 samples kept would be too many: the first goes
    assert exact_sample(exact, one) is not first
