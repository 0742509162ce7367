"""The exact solution sampled once per (solution, times) in a worker (judging/exact_samples.py):
the very numbers of ``ExactSolution.sample``, shared between runs of equal times or taken from
a kept sample whose times include a run's; and the worker's kept exact solutions. ~2 s CPU."""

from __future__ import annotations

from dataclasses import fields

import numpy as np
import pytest
from scipy.integrate import OdeSolution

from hoopbench.engines.judging import exact_samples
from hoopbench.engines.judging.comparison import KEPT_SOLUTIONS, exact_solution
from hoopbench.engines.judging.exact_samples import exact_sample
from hoopbench.models.catalogue import get_scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference import exact
from hoopbench.reference.exact import ExactSolution, solve_exact


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


def _grid(exact, dt: float = 1e-4) -> np.ndarray:
    """The floor's times at dt (comparison._sampled): every dt to the window's end, and the
    solution's last instant."""
    n = int(np.floor(min(exact.scene.t_end, exact.t_final) / dt * (1.0 + 1e-12)))
    return np.unique(np.minimum(np.append(np.arange(n + 1) * dt, exact.t_final), exact.t_final))


@pytest.mark.parametrize("name", ["hop-top", "seed-mu", "hop-low"])
def test_times_within_a_kept_sample_are_its_rows_the_solutions_numbers(name, monkeypatch):
    """A run stopped early samples a prefix of the floor's times, a force window a part of
    them: both come from the kept sample, each the very numbers ``sample`` gives for those
    times alone (bit for bit: a sample is computed time by time), without sampling again."""
    scene = get_scene(name)
    exact = exact_solution(scene, scene.mus)
    grid = _grid(exact)
    kept = exact_sample(exact, grid)
    prefix = np.arange(len(grid) // 3) * 1e-4  # a run's times, built as from_steps does
    window = prefix[len(prefix) // 5 :: 7]
    alone = {id(t): exact.sample(t) for t in (prefix, window)}
    calls = []
    monkeypatch.setattr(type(exact), "sample", lambda self, t: calls.append(t))
    for t in (prefix, window):
        picked = exact_sample(exact, t)
        assert picked is not kept and _same(picked, alone[id(t)])
        with pytest.raises(ValueError, match="read-only"):
            picked.theta[0] = 0.0
    assert calls == []


def test_times_not_all_within_a_kept_sample_are_sampled_anew():
    """One time between the kept ones, or past their end, and the times are sampled anew:
    nothing is interpolated."""
    scene = get_scene("hop-top")
    exact = exact_solution(scene, scene.mus)
    grid = np.arange(2000) * 1e-4
    exact_sample(exact, grid)
    between = grid[:100].copy()
    between[50] += 0.25e-4
    past = np.arange(2001) * 1e-4
    for t in (between, past):
        picked = exact_sample(exact, t)
        assert _same(picked, exact.sample(t))
        assert exact_sample(exact, t) is picked  # sampled anew, and kept as its own


def test_a_worker_keeps_the_last_kept_solutions_exact_solutions_and_no_more():
    """exact_solution solves a (scene, mu) once while it is among the last KEPT_SOLUTIONS
    used, and forgets older ones (a map's worker kept every point it judged: unbounded)."""
    scene = get_scene("hop-top").with_(t_end=0.002)  # a few integrator steps each
    mus = [0.5 + 1e-3 * k for k in range(KEPT_SOLUTIONS + 1)]
    exact_solution.cache_clear()
    first = exact_solution(scene, mus[0])
    for mu in mus[1:KEPT_SOLUTIONS]:  # KEPT_SOLUTIONS in all
        exact_solution(scene, mu)
    assert exact_solution(scene, mus[0]) is first
    for mu in mus[1:]:  # KEPT_SOLUTIONS others used since: the first is the oldest, gone
        exact_solution(scene, mu)
    assert exact_solution(scene, mus[0]) is not first


def _dense_outputs(solution: ExactSolution) -> list[OdeSolution]:
    """The phases' dense outputs (in the scene's time unit), where they have one."""
    found = []
    for segment in solution.segments:
        dense = getattr(getattr(segment.states, "__self__", None), "dense", None)
        if dense is not None:
            found.append(dense.solution)
    return found


@pytest.mark.parametrize("name", ["seed-mu", "hop-top", "slip-reversal", "painleve", "massless"])
def test_the_dense_output_gives_odesolution_s_numbers(name, monkeypatch):
    """ExactSolution.sample evaluates DOP853's dense output for all times at once
    (reference/exact.py _Dop853Steps): the same numbers, bit for bit, as OdeSolution's own call
    on a run's grid, on times out of order and repeated, and at the integrator's step
    starts."""
    solution = solve_exact(get_scene(name))
    end = solution.t_final
    rng = np.random.default_rng(7)
    grid = np.unique(np.minimum(np.append(np.arange(int(end / 1e-4) + 1) * 1e-4, end), end))
    shuffled = rng.permutation(np.concatenate((grid[::7], grid[::11])))
    cases = [grid, shuffled, np.array([0.0, end])]
    at_once = [solution.sample(t) for t in cases]
    dense = _dense_outputs(solution)
    assert dense or name == "massless"
    for output in dense:  # each step's start and end, where two steps' polynomials meet
        ts = np.asarray(output.ts)
        for t in (ts, ts[::-1], np.repeat(ts, 2)):
            steps = exact._Dop853Steps.of(output)
            assert steps is not None
            assert np.array_equal(steps.at(t), output(t))
    monkeypatch.setattr(exact._Dop853Steps, "at", lambda steps, t: steps.solution(t))
    for t, sample in zip(cases, at_once, strict=True):
        assert _same(sample, solution.sample(t))
