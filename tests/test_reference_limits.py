"""The reference solvers' limits: inputs they refuse, and work they will not start or finish.

Extreme but legal scenes (a 1 nm hoop, g = 1e10 m/s^2, a window of 1e5 time scales) must give a
correct answer or a clear error, never a hang; steps so small that float64 round-off drives
the seed scheme, and step or sample counts that would exhaust memory, are refused up front.
"""

from __future__ import annotations

import ast
import inspect
import math
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest
from physics_scenes import HOP, SEED

import hoopbench.reference as reference
from hoopbench.models.events import Outcome
from hoopbench.models.scene import Scene
from hoopbench.reference import exact
from hoopbench.reference.exact import (
    DEFAULT_ATOL,
    DEFAULT_MAX_PHASES,
    DEFAULT_MAX_SAMPLES,
    DEFAULT_MAX_STEPS,
    DEFAULT_RTOL,
    EventReason,
    Mode,
    WorkBudgetError,
    flight_phase,
    solve_exact,
)
from hoopbench.reference.seed_euler import min_step, solve_seed_euler

SEED_PARAMETERS = {"lam": 0.95, "eps": 0.01, "mus": 0.8, "muk": 0.7}


def time_unit(a: float, g: float) -> float:
    """sqrt(a/g) relative to the seed scene's (a = 1 m, g = 9.8 m/s^2)."""
    return math.sqrt((a / g) / (1.0 / 9.8))


@contextmanager
def deadline(seconds: int) -> Iterator[None]:
    """Fail instead of hanging if the solver ignores its budget (a guard, not a timing test)."""

    def expire(signum, frame):
        raise TimeoutError(f"still running after {seconds} s: the work budget did not stop it")

    previous = signal.signal(signal.SIGALRM, expire)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, previous)


# --------------------------------------------------------------------------- mode machine
def test_mode_machine_names_modes_and_reasons_by_enum_only():
    """exact.py spells "roll", "lift", ... only in its Mode and EventReason definitions."""
    tree = ast.parse(Path(exact.__file__).read_text())
    words = {m.value for m in Mode} | {r.value for r in EventReason}
    in_enums = {
        id(node)
        for cls in ast.walk(tree)
        if isinstance(cls, ast.ClassDef) and cls.name in ("Mode", "EventReason")
        for node in ast.walk(cls)
    }
    stray = [
        (node.lineno, node.value)
        for node in ast.walk(tree)
        if isinstance(node, ast.Constant) and node.value in words and id(node) not in in_enums
    ]
    assert not stray, f"mode or event strings outside the enums: {stray}"


# --------------------------------------------------------------------------- tolerances
def test_tolerance_defaults_have_one_source():
    assert (DEFAULT_RTOL, DEFAULT_ATOL) == (1e-10, 1e-12)
    assert (reference.DEFAULT_RTOL, reference.DEFAULT_ATOL) == (DEFAULT_RTOL, DEFAULT_ATOL)
    defaults = inspect.signature(solve_exact).parameters
    assert defaults["rtol"].default == DEFAULT_RTOL
    assert defaults["atol"].default == DEFAULT_ATOL
    assert defaults["max_steps"].default == DEFAULT_MAX_STEPS
    assert defaults["max_phases"].default == DEFAULT_MAX_PHASES
    solution = solve_exact(SEED)
    assert (solution.rtol, solution.atol) == (DEFAULT_RTOL, DEFAULT_ATOL)


# --------------------------------------------------------------------------- scale
@pytest.mark.parametrize(
    ("a", "g"),
    [(1e-9, 9.8), (1.0, 1e10), (1e9, 9.8), (1e-9, 1e10), (1e3, 1e-3)],
    ids=["1nm", "g1e10", "1Gm", "1nm-g1e10", "1km-g1e-3"],
)
def test_a_rescaled_seed_scene_is_solved_alike(a, g):
    """The equations only know lengths in units of a and times in units of sqrt(a/g): the
    seed scene in other units must give the same phases at the same scaled times.

    Fails when the step cap stays 10 ms (a 1 Gm hoop then needs ~1e7 steps: the budget ends
    it), when atol stays in metres (a 1 nm hoop's slip is resolved to 1e-3 of a) or when
    events are located to an absolute 1e-15 s (a 1e-10 s time scale)."""
    unit = time_unit(a, g)
    scene = Scene.from_chi(0.1, **SEED_PARAMETERS, a=a, g=g, t_end=SEED.t_end * unit)
    # The seed needs ~320 steps; the budget keeps a regression from running for hours.
    solution = solve_exact(scene, max_steps=20_000)
    seed = solve_exact(SEED).events
    events = solution.events
    assert events.outcome is seed.outcome, events.message
    assert events.phase_code == seed.phase_code
    for mine, theirs in zip(events.phases, seed.phases, strict=True):
        assert mine.t_end / unit == pytest.approx(theirs.t_end, rel=0, abs=1e-12)
    assert events.theta_slip == pytest.approx(seed.theta_slip, rel=1e-12)
    assert events.thetadot_slip * unit == pytest.approx(seed.thetadot_slip, rel=1e-12)


# --------------------------------------------------------------------------- work budget
def tiny_hoop(t_end: float) -> Scene:
    """The seed scene on a 1 nm hoop: its window spans t_end / 1e-5 s time scales."""
    return Scene.from_chi(0.1, **SEED_PARAMETERS, a=1e-9, t_end=t_end)


def test_step_budget_ends_a_long_window_with_an_error():
    """A window of ~1000 time scales takes ~3e4 steps; 2000 stop it early, with a reason.

    The scene is short enough that even a solver ignoring its budget finishes in seconds."""
    scene = tiny_hoop(1e-2)
    solution = solve_exact(scene, max_steps=2000)
    events = solution.events
    assert events.outcome is Outcome.ERROR
    assert "max_steps = 2000" in events.message
    assert "time scales sqrt(a/g)" in events.message
    assert solution.t_final < scene.t_end
    # What was found before the budget ran out is kept, and the trajectory still samples.
    assert events.t_slip is not None
    assert events.phases and events.phases[-1].t_end == pytest.approx(solution.t_final)
    assert solution.sample([0.0, solution.t_final]).t.size == 2


def test_step_budget_stops_inside_a_long_phase():
    """A hoop without a weight rolls for ever: one phase of 6000 capped 10 ms steps, stopped
    after 500 of them, not at the phase's end (a regression finishes in seconds)."""
    scene = Scene(lam=0.0, thetadot0=1.0, mus=0.8, muk=0.7, t_end=60.0)
    solution = solve_exact(scene, max_steps=500)
    events = solution.events
    assert events.outcome is Outcome.ERROR
    assert "max_steps = 500" in events.message
    assert events.phase_code == "R"
    assert solution.t_final == pytest.approx(500 * 1e-2, rel=1e-3)


@pytest.mark.parametrize(
    "scene",
    [
        pytest.param(tiny_hoop(3.0), id="a=1e-9"),
        pytest.param(Scene.from_chi(0.1, **SEED_PARAMETERS, g=1e10), id="g=1e10"),
    ],
)
def test_the_issue_scenes_end_with_an_error_not_a_hang(scene):
    """The issue's scenes: 3 s is ~3e5 time scales sqrt(a/g) = 1e-5 s (~1e7 steps)."""
    with deadline(120):
        events = solve_exact(scene, max_steps=3000).events
    assert events.outcome is Outcome.ERROR
    assert "max_steps = 3000" in events.message


def test_phase_budget_ends_with_an_error():
    events = solve_exact(SEED, max_phases=2).events
    assert events.outcome is Outcome.ERROR
    assert "max_phases = 2" in events.message
    assert events.phase_code == "R S+"


@pytest.mark.parametrize("name", ["max_steps", "max_phases"])
@pytest.mark.parametrize("value", [0, -1, 2.5])
def test_budgets_must_be_positive_integers(name, value):
    with pytest.raises(ValueError, match=name):
        solve_exact(SEED, **{name: value})


def test_a_fast_spinning_flight_is_scanned_only_to_its_impact():
    """chi = 1e12 lifts off at once and lands within one spin (~2e-6 s); the fall grid to
    the latest possible impact would hold ~1e8 samples (GBs if allocated at once)."""
    scene = Scene.from_chi(1e12, **SEED_PARAMETERS)
    spin = 2 * math.pi / scene.thetadot0
    _, t_impact, height = flight_phase(scene, 0.0, scene.initial_state(), max_samples=100_000)
    assert 0.0 < t_impact < spin
    assert 0.0 < height <= 2 * scene.com_offset
    events = solve_exact(scene).events
    assert events.outcome is Outcome.LIFTS_AT_START
    assert events.t_impact == pytest.approx(t_impact, rel=1e-12)


def test_a_flight_over_its_sample_budget_is_an_error(monkeypatch):
    solution = solve_exact(HOP)
    t_lift = solution.events.t_lift
    lift_off = tuple(solution.state(t_lift)[:, 0])
    with pytest.raises(WorkBudgetError, match="max_samples = 10 "):
        flight_phase(HOP, t_lift, lift_off, max_samples=10)
    monkeypatch.setattr(exact, "FLIGHT_MAX_SAMPLES", 10)
    events = solve_exact(HOP).events
    assert events.outcome is Outcome.ERROR
    assert events.t_lift is not None
    assert "max_samples = 10" in events.message


# --------------------------------------------------------------------------- sampling
def test_uniform_sampling_refuses_too_many_samples():
    solution = solve_exact(SEED)
    assert inspect.signature(solution.sample_uniform).parameters["max_samples"].default == (
        DEFAULT_MAX_SAMPLES
    )
    with pytest.raises(ValueError, match=r"3e\+04 samples, more than max_samples = 1000"):
        solution.sample_uniform(1e-4, max_samples=1000)
    assert len(solution.sample_uniform(1e-3, max_samples=3001)) == 3001


@pytest.mark.parametrize("dt", [3.5, 1e3])
def test_uniform_sampling_refuses_a_step_longer_than_the_window(dt):
    solution = solve_exact(SEED)
    with pytest.raises(ValueError, match=rf"dt = {dt:g} s is longer than the window"):
        solution.sample_uniform(dt)
    assert len(solution.sample_uniform(SEED.t_end)) == 2


# --------------------------------------------------------------------------- seed scheme
def test_min_step_is_the_round_off_bound():
    """sqrt(2 * 1000 * spacing(2a) / g): 3.0e-7 s for the seed, scaling like sqrt(a)."""
    assert min_step(SEED) == pytest.approx(math.sqrt(2e3 * 2.0**-51 / 9.8), rel=1e-12)
    assert min_step(SEED) == pytest.approx(3.01e-7, rel=1e-2)
    tiny = tiny_hoop(3.0)
    assert min_step(tiny) < min_step(SEED) * 1e-4


@pytest.mark.parametrize("dt", [2e-7, 1e-9, 1e-13])
def test_seed_scheme_refuses_a_round_off_dominated_step(dt):
    """At 1e-9 s the seed scheme once reported a 0.9 m hop; at 1e-13 s a 1 m hop in 0.2 ms."""
    with pytest.raises(ValueError, match=rf"dt = {dt:g} s is below 3.01e-07 s.*round-off"):
        solve_seed_euler(SEED, dt=dt)


def test_seed_scheme_accepts_the_smallest_sound_step():
    result = solve_seed_euler(SEED, dt=1.01 * min_step(SEED))
    assert result.events.outcome is Outcome.HOPS
    assert 2000 < result.n_steps < 3000
    # The hop stays a delta-sized artefact, not a launch.
    assert result.events.hop_height < 0.1


@pytest.mark.parametrize("dt", [0.0, -0.002, math.nan, math.inf, 3.5, "fast"])
def test_seed_scheme_refuses_a_bad_step(dt):
    with pytest.raises(ValueError, match="dt"):
        solve_seed_euler(SEED, dt=dt)


@pytest.mark.parametrize("delta", [0.0, -1e-4, math.nan, math.inf, 1e-14, 1.5])
def test_seed_scheme_refuses_a_bad_contact_tolerance(delta):
    with pytest.raises(ValueError, match="delta"):
        solve_seed_euler(SEED, delta=delta)


def test_seed_scheme_refuses_too_many_steps_stating_the_estimate():
    """(3 - 0.98708) s / 1e-5 s = 201292 steps from the slip onset to t_end."""
    with pytest.raises(ValueError, match=r"up to 2.01e\+05 steps .* more than max_steps = 1000"):
        solve_seed_euler(SEED, dt=1e-5, max_steps=1000)
    assert solve_seed_euler(SEED, dt=1e-5, max_steps=201_292).n_steps == 228


def test_seed_scheme_trajectory_refuses_too_many_samples():
    result = solve_seed_euler(SEED, dt=1e-3)
    with pytest.raises(ValueError, match=r"about 1.\d+e\+03 samples, more than max_samples = 100"):
        result.trajectory(max_samples=100)
    assert len(result.trajectory(max_samples=10_000)) > 1000
