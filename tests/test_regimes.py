"""The exact reference's regimes (reference/regimes.py) and its settling time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from hoopbench.models.catalogue import get_scene
from hoopbench.models.events import Events, Outcome, Phase, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference.exact import solve_exact
from hoopbench.reference.regimes import Regime, classify, max_slip_speed, regime_of

ROLLING = Scene.from_chi(1.0, lam=0.5, eps=0.0, mus=0.8, muk=0.8)
"""Rolls with no slip and completes a full turn at about 1.436 s (exact)."""
LIFTS_AT_START = Scene.from_chi(2.0, lam=0.95, eps=0.0, mus=0.8, muk=0.8)
"""n < 0 at t = 0: spun so hard that the weight on top lifts the hoop at once."""
SLIDING = Scene(lam=0.1, thetadot0=0.0, xdot0=8.0, eps=0.0, mus=0.5, muk=0.5, theta0=math.pi)
"""Thrown sliding with no spin: friction spins it up, it re-sticks at 0.84930 s and rolls a
full turn by 2.57037 s (exact)."""


@pytest.mark.parametrize(
    ("name", "regime", "n_slips"),
    [
        ("seed", Regime.SLIPS, 2),
        ("seed-pi", Regime.SLIPS, 3),
        ("slip-reversal", Regime.SLIP_REVERSAL, 4),
        ("low-friction", Regime.SLIP_REVERSAL, 5),
        ("hop-top", Regime.HOPS, 2),
        ("hop-bottom", Regime.HOPS, 1),
        ("high-spin", Regime.HOPS, 2),
        ("painleve", Regime.PAINLEVE, 1),
        ("massless", Regime.DEGENERATE, 0),
    ],
)
def test_catalogue_regimes(name: str, regime: Regime, n_slips: int) -> None:
    point = classify(get_scene(name))
    assert point.regime is regime
    assert point.n_slips == n_slips
    assert point.events == solve_exact(get_scene(name)).events
    assert point.solve_time_s > 0


def test_hop_height_only_where_it_hops() -> None:
    hop = classify(get_scene("hop-top"))
    assert hop.hop_height == pytest.approx(0.3800, abs=1e-4)  # the catalogue's number
    assert hop.t_settled is None
    assert classify(get_scene("seed")).hop_height is None


def test_rolls_and_lifts_at_start() -> None:
    rolls = classify(ROLLING)
    assert rolls.regime is Regime.ROLLS
    assert rolls.n_slips == 0
    assert rolls.events.phase_code == "R"
    start = classify(LIFTS_AT_START)
    assert start.regime is Regime.LIFTS_AT_START
    assert start.events.phase_code == "F"
    assert start.hop_height is not None and start.hop_height > 0


def _events(outcome: Outcome, *codes: str, **fields: float) -> Events:
    kinds = {"R": PhaseKind.ROLL, "S": PhaseKind.SLIP, "F": PhaseKind.FLIGHT}
    phases = tuple(
        Phase(kinds[c[0]], float(i), float(i + 1), {"+": 1, "-": -1}.get(c[1:]))
        for i, c in enumerate(codes)
    )
    return Events(outcome=outcome, phases=phases, **fields)


@pytest.mark.parametrize(
    ("events", "regime"),
    [
        # a lift-off outranks an earlier reversal
        (_events(Outcome.HOPS, "R", "S-", "S+", "F", t_slip=1.0, t_lift=3.0), Regime.HOPS),
        # a reversal needs two slips in a row with opposite sigma, not a roll between
        (_events(Outcome.SLIPS, "R", "S+", "R", "S-", t_slip=1.0), Regime.SLIPS),
        (_events(Outcome.SLIPS, "R", "S+", "S-", "R", t_slip=1.0), Regime.SLIP_REVERSAL),
        (_events(Outcome.PAINLEVE, "R", "S+", "S-", t_slip=1.0), Regime.PAINLEVE),
        (_events(Outcome.ERROR, "R", "S+", "S-", t_slip=1.0), Regime.ERROR),
        (_events(Outcome.ROLLS, "R"), Regime.ROLLS),
        # a flight that ran out of budget before its impact still lifted off
        (_events(Outcome.ERROR, "R", "F", t_lift=1.0), Regime.HOPS),
    ],
)
def test_regime_rules(events: Events, regime: Regime) -> None:
    assert regime_of(events) is regime


def test_settled_motion_repeats() -> None:
    """After t_settled the motion is the first turn again, shifted by one period."""
    point = classify(ROLLING)
    assert point.t_settled == pytest.approx(1.43582, abs=1e-5)
    full = solve_exact(ROLLING)  # dense to t_end, with no early stop
    period = point.t_settled  # it rolls from t = 0, the last event
    t = np.linspace(0.0, ROLLING.t_end - period, 50)
    first, later = full.state(t), full.state(t + period)
    np.testing.assert_allclose(later[2] - first[2], 2.0 * math.pi, rtol=0, atol=1e-8)
    np.testing.assert_allclose(later[5], first[5], rtol=0, atol=1e-8)  # thetadot
    np.testing.assert_allclose(later[3], first[3], rtol=0, atol=1e-8)  # Xdot


def test_settled_after_the_last_event() -> None:
    """The turn is counted from the last event (the re-stick), not from t = 0."""
    point = classify(SLIDING)
    assert point.regime is Regime.SLIPS
    assert point.events.phase_code == "S+ R"
    t_last = point.events.phases[-1].t_start
    assert t_last == pytest.approx(0.84930, abs=1e-5)
    assert point.t_settled == pytest.approx(2.57037, abs=1e-5)
    full = solve_exact(SLIDING)
    period = point.t_settled - t_last
    t = np.linspace(t_last, SLIDING.t_end - period, 20)
    first, later = full.state(t), full.state(t + period)
    np.testing.assert_allclose(later[2] - first[2], 2.0 * math.pi, rtol=0, atol=1e-8)
    np.testing.assert_allclose(later[5], first[5], rtol=0, atol=1e-8)


def test_not_settled_in_a_short_window() -> None:
    point = classify(ROLLING.with_(t_end=1.4))
    assert point.regime is Regime.ROLLS
    assert point.t_settled is None
    assert classify(SLIDING.with_(t_end=2.5)).t_settled is None
    assert classify(get_scene("seed")).t_settled is None  # no full turn after 1.72642 s


@pytest.mark.parametrize("scene", [ROLLING, SLIDING])
def test_early_stop_keeps_the_events(scene: Scene) -> None:
    stopped, full = classify(scene), classify(scene, stop_when_settled=False)
    assert stopped.events == full.events
    assert stopped.regime is full.regime
    assert stopped.t_settled == pytest.approx(full.t_settled, abs=1e-10)
    assert solve_exact(scene, stop_when_settled=True).t_final < scene.t_end


def test_max_slip_speed_finds_the_largest_slip_speed():
    """Dense sampling of the seed's slips agrees with the 201-sample estimate; a scene that
    never slips has none; a sub-threshold slip scene of the hop map reads as one."""
    solution = solve_exact(get_scene("seed"))
    t = np.linspace(0.0, solution.t_final, 300_001)
    dense = np.abs(solution.sample(t).slip_velocity).max()
    assert max_slip_speed(solution) == pytest.approx(dense, rel=1e-3)
    rolling = Scene.from_chi(0.05, lam=0.5, mus=0.8, muk=0.8, t_end=0.5)
    assert max_slip_speed(solve_exact(rolling)) is None
    faint = classify(Scene.from_chi(1.25, lam=0.5 + 0.5 * 3 / 39, mus=0.8, muk=0.8))
    assert faint.regime is Regime.SLIPS
    assert faint.max_slip_speed < 1e-4
