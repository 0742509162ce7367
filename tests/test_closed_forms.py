"""Closed forms against the exact solver and the rolling equations."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from hoopbench.models.catalogue import get_scene
from hoopbench.models.events import Outcome, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference import dynamics
from hoopbench.reference.closed_forms import (
    curtate_cycloid,
    massless_forces,
    massless_slip_angle,
    massless_theta,
    rolling_thetadot_from_energy,
)
from hoopbench.reference.exact import solve_exact

TIGHT = {"rtol": 1e-12, "atol": 1e-12}
"""Exact-solver tolerances for these checks."""


def seed_scene(**changes) -> Scene:
    kw = {"lam": 0.95, "eps": 0.01, "mus": 0.8, "muk": 0.7} | changes
    return Scene.from_chi(kw.pop("chi", 0.1), **kw)


def massless_scene(chi: float, mus: float) -> Scene:
    return Scene.from_chi(chi, lam=1.0, eps=0.0, mus=mus, muk=min(mus, 0.5))


def first_roll(solution):
    seg = solution.segments[0]
    assert seg.kind is PhaseKind.ROLL
    return seg


# ---------------------------------------------------------------- massless theta(t)
def test_massless_theta_matches_exact_rolling_phase():
    # mus = 5 is large enough that the hoop rolls until n = 0 at acos(chi).
    chi = 0.1
    scene = massless_scene(chi, mus=5.0)
    solution = solve_exact(scene, **TIGHT)
    seg = first_roll(solution)
    assert seg.t_end == pytest.approx(0.95615, abs=1e-5)
    t = np.linspace(0.0, seg.t_end, 401)
    theta_exact = solution.state(t)[2]
    theta_closed = massless_theta(t, chi, scene.g, scene.a)
    assert np.max(np.abs(theta_closed - theta_exact)) < 1e-8
    assert theta_closed[-1] == pytest.approx(math.acos(chi), abs=1e-8)


def test_massless_theta_rejects_times_past_the_bottom():
    # sqrt(0.1) sinh(sqrt(9.8) t / 2) > 1 for t > 1.19 s.
    with pytest.raises(ValueError, match="outside the closed form's range"):
        massless_theta(1.3, 0.1, 9.8, 1.0)
    with pytest.raises(ValueError, match=r"chi must be in \[0, 1\]"):
        massless_theta(0.1, 1.5, 9.8, 1.0)
    with pytest.raises(ValueError, match="g must be a positive number"):
        massless_theta(0.1, 0.1, 0.0, 1.0)


# ---------------------------------------------------------------- massless slip angle
def test_massless_slip_angle_seed_value():
    assert math.degrees(massless_slip_angle(0.1, 0.8)) == pytest.approx(77.3196, abs=5e-5)


@pytest.mark.parametrize(
    ("chi", "mus"),
    [
        (0.1, 0.8),  # friction fails first: 2 atan(0.8) = 77.3196 deg
        (0.3, 0.5),
        (0.05, 0.3),
        (0.5, 0.2),
        (0.1, 5.0),  # n and f vanish together first: acos(0.1) = 84.2608 deg
        (0.8, 1.0),
    ],
)
def test_massless_slip_angle_matches_exact(chi, mus):
    events = solve_exact(massless_scene(chi, mus), **TIGHT).events
    assert events.outcome is Outcome.DEGENERATE
    assert events.theta_slip == pytest.approx(massless_slip_angle(chi, mus), abs=1e-9)


def test_massless_slip_angle_rejects_bad_input():
    with pytest.raises(ValueError, match=re.escape("mus must be a finite number >= 0, got -0.1")):
        massless_slip_angle(0.1, -0.1)
    with pytest.raises(
        ValueError, match=re.escape("chi must be in [0, 1] for a rolling start, got 1.2")
    ):
        massless_slip_angle(1.2, 0.5)


# ---------------------------------------------------------------- massless forces
@pytest.mark.parametrize("chi", [0.0, 0.1, 0.4, 0.9])
def test_massless_forces_equal_rolling_forces(chi):
    scene = massless_scene(chi, mus=1.0)
    theta = np.linspace(0.0, math.acos(chi), 50)
    thetadot = rolling_thetadot_from_energy(scene, theta)
    f, n = dynamics.rolling_forces(scene, theta, thetadot)
    f_closed, n_closed = massless_forces(theta, chi, scene.g)
    np.testing.assert_allclose(n_closed, n, rtol=0, atol=1e-12 * scene.g)
    np.testing.assert_allclose(f_closed, f, rtol=0, atol=1e-12 * scene.g)


# ---------------------------------------------------------------- energy curve
def test_rolling_thetadot_from_energy_matches_exact_rolling():
    scene = seed_scene()
    solution = solve_exact(scene, **TIGHT)
    seg = first_roll(solution)
    t = np.linspace(0.0, seg.t_end, 301)
    _, _, theta, _, _, thetadot = solution.state(t)
    np.testing.assert_allclose(
        rolling_thetadot_from_energy(scene, theta), thetadot, rtol=1e-10, atol=0
    )


def test_rolling_thetadot_from_energy_massless_closed_form():
    # u = sin(theta/2): thetadot^2 = (g/a) (chi + u^2) / (1 - u^2) on the massless curve.
    chi = 0.1
    scene = massless_scene(chi, mus=1.0)
    theta = np.linspace(0.0, 3.0, 40)
    u2 = np.sin(theta / 2.0) ** 2
    expected = np.sqrt(scene.g / scene.a * (chi + u2) / (1.0 - u2))
    np.testing.assert_allclose(rolling_thetadot_from_energy(scene, theta), expected, rtol=1e-12)


def test_rolling_thetadot_from_energy_rejects_sliding_start_and_unreachable_angle():
    with pytest.raises(ValueError, match="scene must start rolling"):
        rolling_thetadot_from_energy(seed_scene(xdot0=5.0), 0.5)
    # From rest near the bottom the weight cannot climb to the top.
    low = Scene(lam=0.5, thetadot0=0.0, theta0=3.0, mus=1.0, muk=0.5)
    with pytest.raises(ValueError, match="theta is out of reach"):
        rolling_thetadot_from_energy(low, 0.0)


# ---------------------------------------------------------------- curtate cycloid
def test_exact_rolling_path_is_the_curtate_cycloid():
    scene = seed_scene()
    solution = solve_exact(scene, **TIGHT)
    seg = first_roll(solution)
    t = np.linspace(0.0, seg.t_end, 301)
    X, Y, theta, *_ = solution.state(t)
    Xc, Yc = curtate_cycloid(theta, scene.lam, scene.a)
    np.testing.assert_allclose(Xc, X, rtol=0, atol=1e-12)
    np.testing.assert_allclose(Yc, Y, rtol=0, atol=1e-12)
    # Seed's slip-onset centre of mass (docs/derivations.md): (2.49436, 1.02481).
    assert (X[-1], Y[-1]) == pytest.approx((2.49436, 1.02481), abs=1e-5)


def test_newton_euler_with_rolling_forces_stays_on_the_curtate_cycloid():
    # Independent of the exact solver's rolling representation: integrate the three
    # centre-of-mass equations with the rolling forces as given forces.
    scene = seed_scene(theta0=0.4, chi=0.3)
    lam, a, g, k = scene.lam, scene.a, scene.g, scene.k

    def rhs(_t, y):
        _X, Y, theta, Xdot, Ydot, thetadot = y
        f, n = dynamics.rolling_forces(scene, theta, thetadot)
        thetaddot = (n * lam * a * math.sin(theta) - f * Y) / (k * a**2)
        return (Xdot, Ydot, thetadot, f, n - g, thetaddot)

    sol = solve_ivp(rhs, (0.0, 0.6), scene.initial_state(), method="DOP853", rtol=1e-12, atol=1e-12)
    X, Y, theta = sol.y[:3]
    Xc, Yc = curtate_cycloid(theta, lam, a, theta0=scene.theta0, x0=0.0)
    np.testing.assert_allclose(Xc, X, rtol=0, atol=1e-9)
    np.testing.assert_allclose(Yc, Y, rtol=0, atol=1e-9)
    assert theta[-1] - theta[0] > 1.0  # it really rolled


def test_curtate_cycloid_offsets():
    X, Y = curtate_cycloid(np.array([0.5]), 0.6, 2.0, theta0=0.5, x0=3.0)
    assert X[0] == pytest.approx(3.0 + 1.2 * math.sin(0.5))
    assert Y[0] == pytest.approx(2.0 * (1.0 + 0.6 * math.cos(0.5)))
    with pytest.raises(ValueError, match=r"lam must be in \[0, 1\], got 1.5"):
        curtate_cycloid(0.0, 1.5, 1.0)


@pytest.mark.parametrize("resized", [False, True])
def test_rolling_forces_take_rolling_thetaddot_s_numbers(resized):
    """rolling_forces takes sin, cos and thetadot^2 once for itself and for the angular
    acceleration (a run's reading computes them for every sample): the same floats, bit for
    bit, as with rolling_thetaddot's own, on arrays and on single numbers."""
    scene = get_scene("hop-top")
    if resized:
        scene = scene.with_(a=0.25, g=3.0, eps=0.3)
    rng = np.random.default_rng(5)
    theta, thetadot = rng.uniform(-20.0, 20.0, 3_000), rng.uniform(-15.0, 15.0, 3_000)
    lam, a = scene.lam, scene.a
    for th, w in ((theta, thetadot), (float(theta[0]), float(thetadot[0]))):
        s, c, w2 = np.sin(th), np.cos(th), np.asarray(w) ** 2
        alpha = dynamics.rolling_thetaddot(scene, th, w)
        f, n = dynamics.rolling_forces(scene, th, w)
        assert np.array_equal(f, a * ((1.0 + lam * c) * alpha - lam * s * w2))
        assert np.array_equal(n, scene.g - a * lam * (s * alpha + c * w2))
