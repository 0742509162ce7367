"""Validation and derived quantities of models.scene.Scene."""

from __future__ import annotations

import math

import pytest

from hoopbench.models import kinematics
from hoopbench.models.scene import DegenerateSceneError, Scene

SEED = {"lam": 0.95, "eps": 0.01, "mus": 0.8, "muk": 0.7}
"""The seed scene's parameters (chi = 0.1 from the top)."""


def make(**changes) -> Scene:
    kw = {"thetadot0": 1.0} | SEED | changes
    return Scene(**kw)


# --------------------------------------------------------------------------- validation
@pytest.mark.parametrize(
    ("changes", "match"),
    [
        ({"a": 0.0}, r"^a \(hoop radius\) must be > 0 m, got 0\.0$"),
        ({"a": -1.0}, r"^a \(hoop radius\) must be > 0 m, got -1\.0$"),
        ({"g": 0.0}, r"^g must be > 0 m/s\^2, got 0\.0$"),
        ({"M": -2.0}, r"^M \(total mass\) must be > 0 kg, got -2\.0$"),
        ({"lam": -0.1}, r"^lam must be in \[0, 1\], got -0\.1$"),
        ({"lam": 1.01}, r"^lam must be in \[0, 1\], got 1\.01$"),
        ({"eps": -1e-3}, r"^eps must be >= 0, got -0\.001$"),
        ({"mus": -0.5, "muk": 0.0}, r"^mus must be >= 0, got -0\.5$"),
        ({"muk": -0.1}, r"^muk must be >= 0, got -0\.1$"),
        ({"mus": 0.5, "muk": 0.6}, r"^muk must be <= mus \(= 0\.5\), got 0\.6$"),
        ({"t_end": 0.0}, r"^t_end must be > 0 s, got 0\.0$"),
        ({"t_end": -1.0}, r"^t_end must be > 0 s, got -1\.0$"),
    ],
)
def test_out_of_range_field_is_named(changes, match):
    with pytest.raises(ValueError, match=match):
        make(**changes)


FLOAT_FIELDS = ("lam", "thetadot0", "mus", "muk", "eps", "theta0", "g", "a", "M", "t_end", "xdot0")


@pytest.mark.parametrize("name", FLOAT_FIELDS)
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_field_is_named(name, bad):
    with pytest.raises(ValueError, match=rf"^{name} must be finite, got -?(nan|inf)$"):
        make(**{name: bad})


@pytest.mark.parametrize("name", ["lam", "t_end", "xdot0"])
def test_non_number_field_is_named(name):
    with pytest.raises(ValueError, match=rf"^{name} must be a real number, got 'x'$"):
        make(**{name: "x"})


def test_with_revalidates():
    with pytest.raises(ValueError, match=r"^lam must be in \[0, 1\], got 2\.0$"):
        make().with_(lam=2.0)


def test_from_chi_rejects_negative_and_non_finite_chi():
    with pytest.raises(ValueError, match=r"^chi must be >= 0, got -0\.1$"):
        Scene.from_chi(-0.1, **SEED)
    with pytest.raises(ValueError, match=r"^chi must be finite, got nan$"):
        Scene.from_chi(math.nan, **SEED)


def test_from_chi_names_a_bad_radius_rather_than_failing_on_the_square_root():
    with pytest.raises(ValueError, match=r"^a \(hoop radius\) must be > 0 m"):
        Scene.from_chi(0.1, a=-1.0, **SEED)


def test_from_energy_with_too_little_energy():
    # At the top the potential energy alone is g a (1 + lam).
    potential = 9.8 * (1.0 + SEED["lam"])
    with pytest.raises(ValueError, match=r"^energy_per_mass .* below the potential energy"):
        Scene.from_energy(potential - 1e-6, **SEED)
    with pytest.raises(ValueError, match=r"^energy_per_mass must be finite, got inf$"):
        Scene.from_energy(math.inf, **SEED)


def test_from_energy_refuses_a_sliding_start():
    with pytest.raises(ValueError, match=r"^from_energy builds a rolling start; do not pass xdot0"):
        Scene.from_energy(30.0, xdot0=1.0, **SEED)


# --------------------------------------------------------------------------- derived quantities
@pytest.mark.parametrize("lam", [0.0, 0.3, 0.95, 1.0])
@pytest.mark.parametrize("eps", [0.0, 0.01, 0.1])
def test_inertia(lam, eps):
    scene = Scene.from_chi(0.1, lam=lam, eps=eps, mus=0.8, muk=0.7, a=0.5, M=3.0)
    assert scene.k == pytest.approx(1.0 - lam**2 + lam * eps, abs=1e-15)
    assert scene.inertia_com == pytest.approx(3.0 * 0.25 * scene.k, abs=1e-15)
    assert scene.com_offset == pytest.approx(lam * 0.5, abs=1e-15)


@pytest.mark.parametrize("lam", [0.0, 0.3, 0.95, 1.0])
@pytest.mark.parametrize("eps", [0.0, 0.01, 0.1])
@pytest.mark.parametrize("chi", [0.0, 0.1, 1.5])
@pytest.mark.parametrize(("a", "g"), [(1.0, 9.8), (0.3, 1.62)])
def test_energy_from_the_top_matches_the_closed_form(lam, eps, chi, a, g):
    scene = Scene.from_chi(chi, lam=lam, eps=eps, mus=0.8, muk=0.7, a=a, g=g)
    expected = (1 + lam) * (1 + chi) + lam * eps * chi / 2  # E/(M a g), docs/derivations.md
    assert scene.chi == pytest.approx(chi, rel=1e-14, abs=1e-15)
    assert scene.energy_per_mass / (a * g) == pytest.approx(expected, rel=1e-14)


@pytest.mark.parametrize("theta0", [0.0, 1.0, math.pi, 4.0, 2 * math.pi - 0.1])
@pytest.mark.parametrize("lam", [0.3, 0.95])
def test_rolling_start_has_zero_slip_velocity(theta0, lam):
    scene = Scene.from_chi(0.7, lam=lam, eps=0.01, mus=0.8, muk=0.7, theta0=theta0)
    X, Y, theta, Xdot, Ydot, thetadot = scene.initial_state()
    assert scene.rolls_at_start
    assert abs(float(kinematics.slip_velocity(scene, Xdot, theta, thetadot))) < 1e-14
    assert abs(float(kinematics.clearance(scene, Y, theta))) < 1e-15
    x, _ = kinematics.centre_position(scene, X, Y, theta)
    assert abs(float(x)) < 1e-15
    xdot, ydot = kinematics.centre_velocity(scene, Xdot, Ydot, theta, thetadot)
    assert float(xdot) == pytest.approx(scene.a * thetadot, rel=1e-14)
    assert abs(float(ydot)) < 1e-14


def test_sliding_start_has_the_requested_slip_velocity():
    scene = Scene(lam=0.9, thetadot0=0.0, mus=0.6, muk=0.6, theta0=math.radians(300), xdot0=10.0)
    _, _, theta, Xdot, _, thetadot = scene.initial_state()
    assert not scene.rolls_at_start
    assert float(kinematics.slip_velocity(scene, Xdot, theta, thetadot)) == pytest.approx(10.0)


@pytest.mark.parametrize("theta0", [0.0, 0.5, math.pi, 5.0])
def test_from_energy_round_trip(theta0):
    seed = Scene.from_chi(0.1, **SEED)
    scene = Scene.from_energy(seed.energy_per_mass, theta0=theta0, **SEED)
    assert scene.energy_per_mass == pytest.approx(seed.energy_per_mass, rel=1e-14)
    # The rolling energy of docs/derivations.md, written out.
    lam, eps, a, g = scene.lam, scene.eps, scene.a, scene.g
    rolling = (
        g * a * (1 + lam * math.cos(theta0))
        + 0.5 * a**2 * (2 + lam * eps + 2 * lam * math.cos(theta0)) * scene.thetadot0**2
    )
    assert rolling == pytest.approx(seed.energy_per_mass, rel=1e-14)


def test_degenerate_scene():
    scene = Scene.from_chi(0.1, lam=1.0, eps=0.0, mus=0.8, muk=0.7)
    assert scene.is_degenerate
    assert scene.inertia_com == 0.0
    with pytest.raises(DegenerateSceneError, match=r"^the slipping phase needs a positive moment"):
        scene.require_inertia("the slipping phase")
    # DegenerateSceneError is a ValueError, so callers that catch bad input catch it too.
    assert issubclass(DegenerateSceneError, ValueError)


def test_non_degenerate_scene_passes_require_inertia():
    scene = Scene.from_chi(0.1, lam=1.0, eps=1e-3, mus=0.8, muk=0.7)
    assert not scene.is_degenerate
    scene.require_inertia("the slipping phase")


def test_scene_is_frozen_and_name_does_not_count_in_equality():
    a = make(name="one", why="first")
    b = make(name="two", why="second")
    assert a == b
    with pytest.raises(AttributeError):
        a.lam = 0.5  # type: ignore[misc]
