"""A hop map's exact solutions (reports/hop_map/stages.py): stage 1 classifies each point and
stores the exact solution its engine runs are judged against; stage 2's workers read it
instead of solving it again. What they read must be what they would have solved, bit for bit.
The classification and the whole window come from one integration
(reference/exact.py solve_exact_settled): both must be what their own solves give.

About 4 s in all: a few solves of one roll, one hop and the catalogue's slip reversal.
"""

from __future__ import annotations

import pickle
from dataclasses import replace

import numpy as np
import pytest

from hoopbench.engines.judging import comparison
from hoopbench.engines.judging.comparison import exact_solution
from hoopbench.models.catalogue import SCENES
from hoopbench.models.events import Outcome, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference import exact
from hoopbench.reference.exact import ExactSolution, solve_exact, solve_exact_settled
from hoopbench.reference.regimes import classify_solved, classify_whole
from hoopbench.reports.hop_map.spec import MapPoint, MapSpec
from hoopbench.reports.hop_map.stages import (
    EXACT_SUFFIX,
    _engine_task,
    _judging_solution,
    _point_solution,
    _reference_row,
    reference_tasks,
)

SPEC = MapSpec(nx=2, ny=2, engines=("pymunk",), x_range=(0.5, 0.55), y_range=(0.27, 2.0))
"""lam 0.5, 0.55 x chi 0.27, 2 over 3 s: at chi 0.27 the hoop rolls and settles (a full turn
after its start, 2.3 s: the classification stops there), at lam 0.5, chi 2 it hops."""

COLUMNS = ("X", "Y", "theta", "Xdot", "Ydot", "thetadot", "normal_force", "friction_force")


def _point(spec: MapSpec, ix: int, iy: int) -> MapPoint:
    return next(p for p in spec.points() if (p.ix, p.iy) == (ix, iy))


def _same(a: ExactSolution, b: ExactSolution) -> bool:
    """The same events, window and phases, and the same numbers at 3,001 times across it."""
    if a.events != b.events or a.t_final != b.t_final or a.t_settled != b.t_settled:
        return False
    spans = [[(s.kind, s.sigma, s.t_start, s.t_end) for s in x.segments] for x in (a, b)]
    if spans[0] != spans[1]:
        return False
    t = np.linspace(0.0, a.t_final, 3001)
    x, y = a.sample(t), b.sample(t)
    return all(np.array_equal(getattr(x, c), getattr(y, c), equal_nan=True) for c in COLUMNS)


@pytest.fixture(autouse=True)
def _no_kept_solutions():
    exact_solution.cache_clear()
    yield
    exact_solution.cache_clear()


@pytest.mark.parametrize("name", ["slip-reversal", "hop-top", "massless"])
def test_an_exact_solution_pickles_to_the_same_numbers(name):
    """Every kind of phase (roll, slip, flight; the frozen start of a body without inertia)
    survives pickling bit for bit."""
    solution = solve_exact(SCENES[name])
    assert _same(pickle.loads(pickle.dumps(solution)), solution)


@pytest.mark.parametrize("name", ["slip-reversal", "hop-top"])
def test_a_phase_evaluates_its_states_and_forces_together_as_apart(name):
    """Sampling evaluates a roll or slip phase's dense output once for its states and its
    forces (ExactSolution.sample: the map's floor samples 30,000 times a point): the same
    numbers as the two evaluated apart."""
    solution = solve_exact(SCENES[name])
    kinds = set()
    for seg in solution.segments:
        t = np.linspace(seg.t_start, seg.t_end, 501)
        states, f, n = seg.evaluate(t)
        assert np.array_equal(states, seg.states(t))
        assert all(np.array_equal(x, y) for x, y in zip((f, n), seg.forces(t), strict=True))
        if seg.together is not None:
            kinds.add(seg.kind)
    assert kinds == {PhaseKind.ROLL, PhaseKind.SLIP}


@pytest.mark.parametrize(("ix", "iy", "settles"), [(0, 0, True), (0, 1, False)])
def test_the_point_is_judged_against_its_whole_window_solve(ix, iy, settles):
    """The classification (stopped where it settles) and the whole window the engine runs
    are judged against come from one integration, each as its own solve gives it."""
    scene = _point(SPEC, ix, iy).scene()
    point, classified, whole = classify_whole(scene)
    assert (classified.t_settled is not None) == settles
    assert (whole is classified) == (not settles)
    assert point == replace(classify_solved(scene)[0], solve_time_s=point.solve_time_s)
    assert _same(classified, solve_exact(scene, stop_when_settled=True))
    judging = _judging_solution(scene, whole)
    assert judging is whole
    assert _same(judging, solve_exact(scene.with_(mus=scene.mus, muk=scene.mus)))
    assert exact_solution.holds(scene, scene.mus)


def _settling_scenes() -> list[Scene]:
    """A point that settles, the same at a quarter of the size (its time unit 0.5 s, not
    1 s) and a point that hops."""
    rolls = _point(SPEC, 0, 0).scene()
    return [rolls, rolls.with_(a=0.25), _point(SPEC, 0, 1).scene()]


@pytest.mark.parametrize("index", [0, 1, 2])
def test_one_integration_gives_the_settled_and_the_whole_solve(index):
    scene = _settling_scenes()[index]
    settled, whole = solve_exact_settled(scene)
    assert _same(settled, solve_exact(scene, stop_when_settled=True))
    assert _same(whole, solve_exact(scene))
    assert (settled.t_settled is not None) == (index < 2)


@pytest.mark.parametrize("more", [-5, 5])
def test_a_whole_window_out_of_steps_still_gives_the_settled_solve(more):
    """The step budget runs out before the full turn (both solves fail alike) or after it
    (the settled solve does not fail; the whole one does)."""
    scene = _point(SPEC, 0, 0).scene()
    steps = 232 + more  # the settled solve's integrator steps
    settled, whole = solve_exact_settled(scene, max_steps=steps)
    assert _same(settled, solve_exact(scene, stop_when_settled=True, max_steps=steps))
    assert _same(whole, solve_exact(scene, max_steps=steps))
    assert (settled.events.outcome is Outcome.ERROR) == (more < 0)
    assert whole.events.outcome is Outcome.ERROR


def test_a_failed_integration_is_solved_again_for_the_settled_solve(monkeypatch):
    """The integrator fails in the phase that turns (it would not have failed had the phase
    ended at the turn): the settled solve is solved on its own."""
    scene = _point(SPEC, 0, 0).scene()
    settled, _ = solve_exact_settled(scene)
    which = exact._which_event

    def failing_where_it_turns(sol, names):
        if None in names and len(sol.t_events[2]):
            raise exact.IntegrationError("failed after the turn")
        return which(sol, names)

    monkeypatch.setattr(exact, "_which_event", failing_where_it_turns)
    alone, whole = solve_exact_settled(scene)
    assert whole.events.outcome is Outcome.ERROR
    assert _same(alone, settled)


def _refuse_to_solve(*args, **kwargs):
    raise AssertionError("solved again")


def test_stage_two_reads_stage_ones_solution_instead_of_solving(tmp_path, monkeypatch):
    point = _point(SPEC, 0, 0)
    ref = next(t for t in reference_tasks(SPEC, None, str(tmp_path)) if t.point == point)
    _reference_row(ref)
    assert (tmp_path / f"{point.name}{EXACT_SUFFIX}").is_file()
    scene = point.scene()
    whole = solve_exact(scene)
    exact_solution.cache_clear()  # another worker's: nothing kept
    monkeypatch.setattr(comparison, "solve_exact", _refuse_to_solve)
    task = _engine_task(SPEC, point, "pymunk", {}, None, str(tmp_path))
    stored = _point_solution(task, scene)
    assert _same(stored, whole)
    assert exact_solution(scene, scene.mus) is stored  # the floor's columns use it too


def test_a_stored_solution_of_another_scene_is_not_used(tmp_path):
    point, other = _point(SPEC, 0, 0), _point(SPEC, 0, 1)
    path = tmp_path / f"{point.name}{EXACT_SUFFIX}"
    path.write_bytes(pickle.dumps(solve_exact(other.scene())))
    task = _engine_task(SPEC, point, "pymunk", {}, None, str(tmp_path))
    scene: Scene = point.scene()
    assert _same(_point_solution(task, scene), solve_exact(scene))


def test_a_worker_without_the_folder_solves(tmp_path):
    """A worker on another machine (a Dask cluster's) cannot reach the session's folder:
    the reference task stores nothing and the engine task solves."""
    missing = tmp_path / "elsewhere"
    point = _point(SPEC, 0, 1)
    ref = next(t for t in reference_tasks(SPEC, None, str(missing)) if t.point == point)
    _reference_row(ref)
    assert not missing.exists()
    exact_solution.cache_clear()
    task = _engine_task(SPEC, point, "pymunk", {}, None, str(missing))
    scene = point.scene()
    assert _same(_point_solution(task, scene), solve_exact(scene))


def test_a_noted_turn_does_not_end_the_phase():
    """The full turn's event, only noted (None among the reasons), is not why a phase ends,
    even where it fired first: here the step budget ended it."""
    turn, budget = np.array([0.5]), np.array([0.7])
    ended = exact._Solved(
        t=np.array([0.0, 0.7]),
        y=np.zeros((2, 2)),
        t_events=[np.empty(0), np.empty(0), turn, budget],
        status=1,
        message="",
        sol=None,  # type: ignore[arg-type]
    )
    names = [exact.EventReason.SLIP, exact.EventReason.LIFT, None]
    assert exact._which_event(ended, names) is exact.EventReason.BUDGET
