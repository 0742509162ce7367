"""The exact solver's own checks: published numbers, conservation, cones, convergence.

The numbers come from docs/derivations.md (the seed document's scenes, re-derived there). The other
named scenes were found by the DAE cross-check (tests/test_dae_crosscheck.py) where the solver
was once wrong (missed slip inside a rolling step, missed re-stick inside the first slip step);
they stay as regression tests.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np
import pytest
from physics_scenes import (
    CHATTER,
    FALSE_LIFT,
    FALSE_LIFT_CRASH,
    HOP,
    MISSED_SLIP,
    PAINLEVE,
    RESTICK_IN_FIRST_STEP,
    SEED,
    SPURIOUS_PAINLEVE,
    WRONG_WAY_SLIP,
)

from hoopbench.models.events import Outcome, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference import dynamics
from hoopbench.reference.exact import ExactSolution, first_flight_impact, solve_exact


def top_energy_scene(mus: float) -> Scene:
    """Weight at the bottom (theta0 = pi) with the seed scene's energy."""
    return Scene.from_energy(
        SEED.energy_per_mass, lam=0.95, eps=0.01, mus=mus, muk=0.7, theta0=math.pi, name="bottom"
    )


@functools.cache
def solved(scene: Scene, rtol: float = 1e-10, atol: float = 1e-12) -> ExactSolution:
    return solve_exact(scene, rtol=rtol, atol=atol)


def phase_grid(phase, n: int = 400) -> np.ndarray:
    """Times strictly inside a phase."""
    return np.linspace(phase.t_start, phase.t_end, n + 2)[1:-1]


SOUND = [pytest.param(s, id=s.name) for s in (SEED, HOP, top_energy_scene(1.0))]


# --------------------------------------------------------------------------- published numbers
def test_seed_slip_onset():
    sol = solved(SEED)
    ev = sol.events
    assert ev.outcome is Outcome.SLIPS
    assert ev.t_lift is None and ev.t_impact is None and ev.hop_height is None
    assert math.degrees(ev.theta_slip) == pytest.approx(88.5037, abs=1e-4)
    assert ev.thetadot_slip == pytest.approx(3.26607, abs=1e-5)
    assert ev.t_slip == pytest.approx(0.98708, abs=1e-5)
    com_x, com_y, theta, com_xdot, com_ydot, thetadot = sol.state(ev.t_slip)[:, 0]
    assert com_x == pytest.approx(2.49436, abs=1e-5)
    assert com_y == pytest.approx(1.02481, abs=1e-5)
    assert com_xdot == pytest.approx(3.34710, abs=1e-5)
    assert com_ydot == pytest.approx(-3.10171, abs=1e-5)
    assert theta == pytest.approx(ev.theta_slip, abs=1e-12)
    assert thetadot == pytest.approx(ev.thetadot_slip, abs=1e-12)
    # It slides, then sticks again: the seed's hop is an artefact of its scheme.
    assert ev.t_restick is not None and ev.t_restick > ev.t_slip
    assert [p.kind for p in ev.phases][:3] == [PhaseKind.ROLL, PhaseKind.SLIP, PhaseKind.ROLL]


def test_weight_at_the_bottom_with_the_seed_energy():
    scene = top_energy_scene(1.0)
    assert scene.thetadot0 == pytest.approx(19.36699, abs=1e-5)
    ev = solved(scene).events
    assert ev.outcome is Outcome.SLIPS
    assert math.degrees(ev.theta_slip) == pytest.approx(210.73, abs=0.005)
    assert ev.thetadot_slip == pytest.approx(10.109, abs=5e-4)
    ev08 = solved(top_energy_scene(0.8)).events
    assert math.degrees(ev08.theta_slip) == pytest.approx(208.35, abs=0.005)
    # Less static friction, earlier slip.
    assert ev08.t_slip < ev.t_slip


def test_painleve_example():
    ev = solved(PAINLEVE).events
    assert ev.outcome is Outcome.PAINLEVE
    assert [p.kind for p in ev.phases] == [PhaseKind.SLIP]
    assert ev.phases[0].sigma == 1
    assert ev.extra["theta_painleve_deg"] == pytest.approx(311.36, abs=0.005)
    assert ev.extra["t_painleve"] == pytest.approx(0.184, abs=5e-4)
    # D reaches 0 there, from above (the solver stops where its steps collapse).
    theta_end = solved(PAINLEVE).state(ev.extra["t_painleve"])[2, 0]
    assert 0.0 <= float(dynamics.slip_denominator(PAINLEVE, theta_end, 1)) < 1e-3
    # It can only happen because muk exceeds sqrt(1 - lam^2)/lam.
    assert PAINLEVE.muk > math.sqrt(1 - PAINLEVE.lam**2) / PAINLEVE.lam


def test_hop_scene_hops():
    ev = solved(HOP).events
    assert ev.outcome is Outcome.HOPS
    assert HOP.lam * HOP.chi < 1  # it does not lift at t = 0
    assert ev.t_slip < ev.t_lift < ev.t_impact
    assert ev.hop_height > 0
    assert ev.phases[-1].kind is PhaseKind.FLIGHT
    assert ev.phases[-2].kind is PhaseKind.SLIP  # lift-off comes from a slip (Pritchett)


@pytest.mark.parametrize(("lam", "chi"), [(0.9, 1.5), (0.95, 1.2), (0.7, 1.45), (1.0, 1.01)])
def test_lifts_at_start_from_the_top(lam, chi):
    scene = Scene.from_chi(chi, lam=lam, eps=0.0, mus=0.8, muk=0.7)
    f0, n0 = dynamics.rolling_forces(scene, 0.0, scene.thetadot0)
    assert float(n0) == pytest.approx(scene.g * (1 - lam * chi), abs=1e-12)
    assert float(f0) == pytest.approx(0.0, abs=1e-12)
    ev = solved(scene).events
    assert ev.outcome is Outcome.LIFTS_AT_START
    assert ev.t_lift == 0.0
    assert ev.t_impact > 0.0 and ev.hop_height >= 0.0
    assert [p.kind for p in ev.phases] == [PhaseKind.FLIGHT]


@pytest.mark.parametrize(
    "scene",
    [
        pytest.param(Scene.from_chi(1.5, lam=0.9, eps=0.0, mus=0.8, muk=0.7), id="top"),
        pytest.param(FALSE_LIFT, id=FALSE_LIFT.name),
        pytest.param(FALSE_LIFT_CRASH, id=FALSE_LIFT_CRASH.name),
    ],
)
def test_lift_off_at_start_only_when_the_hoop_can_leave_the_floor(scene):
    """Leaving the floor needs the contact-free vertical acceleration of the centre >= 0."""
    ev = solved(scene).events
    free = float(dynamics.free_centre_acceleration(scene, scene.theta0, scene.thetadot0))
    assert (ev.outcome is Outcome.LIFTS_AT_START) == (free >= 0.0)


def test_degenerate_scene_reports_instead_of_raising():
    scene = Scene.from_chi(0.1, lam=1.0, eps=0.0, mus=0.8, muk=0.7)
    ev = solved(scene).events
    assert ev.outcome is Outcome.DEGENERATE
    assert math.degrees(ev.theta_slip) == pytest.approx(77.3196, abs=1e-4)
    # Closed form for lam = 1, eps = 0 (docs/derivations.md): min(acos(chi), 2 atan(mus)).
    assert ev.theta_slip == pytest.approx(min(math.acos(0.1), 2 * math.atan(0.8)), abs=1e-8)
    assert ev.message
    assert solved(scene).sample([0.0, ev.t_slip]).theta[-1] == pytest.approx(ev.theta_slip)


# --------------------------------------------------------------------------- energy
@pytest.mark.parametrize("scene", [*SOUND, pytest.param(PAINLEVE, id="painleve")])
def test_rolling_conserves_energy(scene):
    sol = solved(scene)
    rolls = [p for p in sol.events.phases if p.kind is PhaseKind.ROLL]
    if scene is not PAINLEVE:
        assert rolls
    for phase in rolls:
        energy = sol.sample(phase_grid(phase)).energy
        drift = np.abs(energy - energy[0]).max() / abs(energy[0])
        assert drift < 1e-9, f"rolling energy drifts by {drift:.2e} on {phase}"


@pytest.mark.parametrize(
    "scene",
    [
        *SOUND,
        pytest.param(PAINLEVE, id="painleve"),
        pytest.param(WRONG_WAY_SLIP, id=WRONG_WAY_SLIP.name),
    ],
)
def test_friction_never_adds_energy(scene):
    sol = solved(scene)
    slips = [p for p in sol.events.phases if p.kind is PhaseKind.SLIP]
    assert slips
    scale_power = scene.g * math.sqrt(scene.g * scene.a)
    for phase in slips:
        traj = sol.sample(phase_grid(phase, 1000))
        rise = np.diff(traj.energy).max() / abs(traj.energy[0])
        assert rise <= 1e-9, f"energy rises by {rise:.2e} (relative) within {phase}"
        power = traj.friction_force * traj.slip_velocity
        assert power.max() <= 1e-12 * scale_power, f"friction power {power.max():.3e} > 0"
        assert np.all(np.sign(traj.slip_velocity[1:]) == phase.sigma)


# --------------------------------------------------------------------------- contact forces
@pytest.mark.parametrize(
    "scene",
    [
        *SOUND,
        pytest.param(PAINLEVE, id="painleve"),
        pytest.param(MISSED_SLIP, id=MISSED_SLIP.name),
        pytest.param(WRONG_WAY_SLIP, id=WRONG_WAY_SLIP.name),
    ],
)
def test_contact_forces_respect_the_friction_cone(scene):
    sol = solved(scene)
    g = scene.g
    for phase in sol.events.phases:
        if phase.kind is PhaseKind.FLIGHT:
            continue
        traj = sol.sample(phase_grid(phase, 1000))
        f, n = traj.friction_force, traj.normal_force
        assert n.min() >= -1e-9 * g, f"pulling floor in {phase}"
        assert np.abs(traj.clearance).max() < 1e-9 * scene.a, f"off the floor in {phase}"
        assert traj.contact.all()
        if phase.kind is PhaseKind.ROLL:
            assert np.abs(traj.slip_velocity).max() < 1e-9 * math.sqrt(g * scene.a)
            excess = (np.abs(f) - scene.mus * n).max()
            assert excess <= 1e-9 * g, f"rolling outside the static cone by {excess:.3e}"
        else:
            assert np.abs(np.abs(f) - scene.muk * n).max() <= 1e-9 * g
            # Friction opposes the slip: on the cone edge, on the right side of it.
            assert np.all(f * traj.slip_velocity <= 1e-12 * g * math.sqrt(g * scene.a))


@pytest.mark.parametrize("lam", [0.3, 0.6, 0.9])
@pytest.mark.parametrize("chi", [0.5, 1.2, 2.0, 4.0])
def test_the_first_flights_landing_is_the_solutions_first_impact(lam, chi):
    """first_flight_impact, the hop map's cost shortcut, integrates nothing: where the
    solution starts with a flight it gives that flight's landing, the solution's first
    impact, and None wherever the solution starts otherwise."""
    scene = Scene.from_chi(chi, lam=lam, mus=0.8, muk=0.8, eps=0.01, theta0=0.0, t_end=2.0)
    solution = solve_exact(scene)
    t_impact = first_flight_impact(scene)
    if solution.segments[0].kind is PhaseKind.FLIGHT and solution.segments[0].t_start == 0:
        assert t_impact == pytest.approx(solution.events.t_impact, abs=1e-12)
    else:
        assert t_impact is None


def test_flight_has_no_contact_force():
    sol = solved(HOP)
    flight = sol.events.phases[-1]
    traj = sol.sample(phase_grid(flight))
    assert not traj.contact.any()
    assert np.all(traj.normal_force == 0.0) and np.all(traj.friction_force == 0.0)
    assert traj.clearance.max() == pytest.approx(sol.events.hop_height, rel=1e-6)
    assert traj.clearance.min() > 0.0


@pytest.mark.parametrize(
    "scene",
    [
        *SOUND,
        pytest.param(PAINLEVE, id="painleve"),
        pytest.param(WRONG_WAY_SLIP, id=WRONG_WAY_SLIP.name),
        pytest.param(RESTICK_IN_FIRST_STEP, id=RESTICK_IN_FIRST_STEP.name),
        pytest.param(CHATTER, id=CHATTER.name),
    ],
)
def test_phases_tile_the_window(scene):
    """Phases follow each other without gaps, and each changes the mode."""
    sol = solved(scene)
    phases = sol.events.phases
    assert phases[0].t_start == 0.0
    assert phases[-1].t_end == pytest.approx(sol.t_final, abs=1e-15)
    for p, q in itertools.pairwise(phases):
        assert q.t_start == p.t_end, f"gap between {p} and {q}"
        assert (p.kind, p.sigma) != (q.kind, q.sigma), f"{p} and {q} are one mode"
        assert p.t_end > p.t_start


@pytest.mark.parametrize(
    "scene",
    [
        pytest.param(PAINLEVE, id="painleve"),
    ],
)
def test_painleve_only_where_no_mode_is_consistent(scene):
    """Painlevé means no contact force exists; a hoop at rest on the floor inside the static
    friction cone has one (rolling), so the outcome would be wrong there."""
    sol = solved(scene)
    assert sol.events.outcome is Outcome.PAINLEVE
    traj = sol.sample([sol.t_final])
    f, n = (float(v[0]) for v in dynamics.rolling_forces(scene, traj.theta, traj.thetadot))
    at_rest = abs(traj.slip_velocity[0]) < 1e-6 * math.sqrt(scene.g * scene.a)
    assert not (at_rest and n >= 0 and abs(f) <= scene.mus * n), "rolling was admissible"


# --------------------------------------------------------------------------- convergence
def boundaries(sol: ExactSolution) -> list[tuple[str, float]]:
    return [(f"{p.kind}:{p.sigma}", p.t_end) for p in sol.events.phases]


@pytest.mark.parametrize("scene", [pytest.param(SEED, id="seed"), pytest.param(HOP, id="hop")])
def test_event_times_converge(scene):
    loose = solved(scene, 1e-10, 1e-12)
    tight = solved(scene, 1e-12, 1e-14)
    b_loose, b_tight = boundaries(loose), boundaries(tight)
    assert [k for k, _ in b_loose] == [k for k, _ in b_tight]
    for (kind, t1), (_, t2) in zip(b_loose, b_tight, strict=True):
        assert abs(t1 - t2) < 1e-9, f"{kind} boundary moves by {abs(t1 - t2):.2e} s"
    for name in ("t_slip", "t_restick", "t_lift", "t_impact"):
        a, b = getattr(loose.events, name), getattr(tight.events, name)
        assert (a is None) == (b is None)
        if a is not None:
            assert abs(a - b) < 1e-9, name
    if scene is HOP:
        assert loose.events.hop_height == pytest.approx(tight.events.hop_height, abs=1e-8)


# --------------------------------------------------------------------------- continuity
STATE_COLUMNS = ("X", "Y", "theta", "Xdot", "Ydot", "thetadot", "clearance", "energy")


@pytest.mark.parametrize("scene", [*SOUND, pytest.param(PAINLEVE, id="painleve")])
def test_sampled_states_are_continuous_across_phase_boundaries(scene):
    sol = solved(scene)
    inner = [p.t_end for p in sol.events.phases[:-1]]
    if scene is not PAINLEVE:
        assert inner
    h = 1e-10
    for tb in inner:
        traj = sol.sample([tb - h, tb + h])
        for name in STATE_COLUMNS:
            before, after = getattr(traj, name)
            # Accelerations may jump (up to ~500 rad/s^2 here), so states move by ~1e-7 in 2h.
            assert abs(after - before) < 1e-7 * (1 + abs(before)), f"{name} jumps at t = {tb}"
    # The window's start is the scene's initial state.
    t0 = sol.state(0.0)[:, 0]
    assert t0 == pytest.approx(np.array(scene.initial_state()), abs=1e-14)


@pytest.mark.parametrize(
    "scene", [pytest.param(s, id=s.name) for s in (CHATTER, WRONG_WAY_SLIP, FALSE_LIFT_CRASH)]
)
def test_solver_finishes(scene):
    # No 1.5 s scene comes near 100 phases; the default cap (10 000) takes seconds to reach.
    sol = solve_exact(scene, max_phases=100)
    assert sol.t_final == pytest.approx(scene.t_end) or sol.events.outcome in (
        Outcome.HOPS,
        Outcome.LIFTS_AT_START,
        Outcome.PAINLEVE,
    )


@pytest.mark.parametrize(
    "scene",
    [pytest.param(s, id=s.name) for s in (WRONG_WAY_SLIP, SPURIOUS_PAINLEVE)],
)
def test_missed_restick_no_longer_ends_in_painleve(scene):
    """Regression: these scenes re-stick early; a missed re-stick once flipped sigma into
    D < 0 and ended the run as a spurious 'painleve'."""
    events = solved(scene).events
    assert events.outcome is not Outcome.PAINLEVE
    assert events.t_restick is not None


@pytest.mark.parametrize("dt", [1e-4, 1e-3, 0.00777])
def test_uniform_sampling_covers_a_flight_window(dt):
    """The sampled grid stays inside [0, t_final] whatever dt (regression: t_final ends at
    the impact, not on the grid)."""
    sol = solved(HOP)
    traj = sol.sample_uniform(dt)
    assert traj.t[0] == 0.0
    assert traj.t[-1] <= sol.t_final
    assert sol.t_final - traj.t[-1] < dt
    assert np.allclose(np.diff(traj.t), dt)
