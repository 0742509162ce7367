"""The named scenes hoopbench runs: their parameters and why each one is here.

This module holds parameters only. The numbers quoted in each scene's ``why`` come from the
exact solver and were found with ``python -m hoopbench.reference.find_scenes``, which sweeps the
parameter space and checks that the hop scenes keep their outcome under 1e-3 relative changes of
every parameter; ``tests/test_catalogue.py`` checks every quoted number against the exact solver.
Times in s, angles in deg, lengths in m, "slip (+)" means sigma = sign(xdot - a*thetadot) = +1.

Scenes meant for comparing engines have one friction coefficient (mus = muk), as engines do,
and start rolling (xdot0 = None).

>>> get_scene("seed").mus, get_scene("seed").muk
(0.8, 0.7)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from types import MappingProxyType
from typing import Any

from hoopbench.models.scene import Scene

__all__ = ["SCENES", "check_scene_name", "get_scene", "scene_names"]

_SEED = Scene.from_chi(
    0.1,
    g=9.8,
    a=1.0,
    lam=0.95,
    eps=0.01,
    theta0=0.0,
    mus=0.8,
    muk=0.7,
    t_end=3.0,
    name="seed",
    why=(
        "The source document's scene; exact: it slips at 0.98708 s (88.504 deg), re-sticks at "
        "1.23075 s, slips back and re-sticks at 1.72642 s. It never lifts off, so the "
        "document's small hop is an artefact of its contact tolerance."
    ),
)


def _catalogue() -> tuple[Scene, ...]:
    return (
        _SEED,
        Scene.from_energy(
            _SEED.energy_per_mass,
            lam=0.95,
            eps=0.01,
            mus=1.0,
            muk=0.7,
            theta0=math.pi,
            name="seed-pi",
            why=(
                "The document's postscript: the weight starts at the bottom with the seed's "
                "energy (thetadot0 = 19.36699 rad/s) and mus = 1.0. Exact: slips at 210.731 deg "
                "(0.03712 s, 10.109 rad/s), re-sticks at 0.54334 s, never lifts off."
            ),
        ),
        _SEED.with_(
            mus=0.8,
            muk=0.8,
            name="seed-mu",
            why=(
                "The seed with one friction coefficient, mus = muk = 0.8, so that engines can "
                "run it. Exact: the same slip onset (0.98708 s), re-sticks at 1.22833 s, never "
                "lifts off."
            ),
        ),
        Scene.from_chi(
            0.1,
            lam=1.0,
            eps=0.0,
            mus=0.8,
            muk=0.8,
            name="massless",
            why=(
                "Massless ring and point weight: rolling has a closed form. Exact: slips at "
                "0.91526 s at 77.3196 deg = 2 atan(mus), before n would vanish at acos(chi), and "
                "slipping needs I > 0, so the outcome is degenerate."
            ),
        ),
        Scene.from_chi(
            0.5,
            lam=0.95,
            eps=0.01,
            mus=0.8,
            muk=0.8,
            name="hop-top",
            why=(
                "A real hop from the top: seed-mu spun harder (chi = 0.5); 1e-3 changes of any "
                "parameter keep it. Exact: slip (+) at 0.44203 s, re-stick at 0.77635 s, slip (-) "
                "from 0.81092 s, lift-off at 1.17108 s (315.3 deg), hop 0.3800 m, impact 2.03055 s."
            ),
        ),
        Scene.from_chi(
            0.5,
            lam=0.9,
            eps=0.01,
            mus=0.8,
            muk=0.8,
            name="hop-low",
            why=(
                "A marginal hop from the top with a heavier ring (lam = 0.9): the phases of "
                "hop-top but a height that a 1e-3 change of lam moves by a quarter. Exact: slips "
                "at 0.46591 s, lifts off at 1.30077 s, hop 0.03297 m, impact 1.79990 s."
            ),
        ),
        Scene(
            lam=0.5,
            thetadot0=9.0,
            eps=0.01,
            mus=0.5,
            muk=0.5,
            theta0=math.pi,
            name="hop-bottom",
            why=(
                "A heavy ring rolled fast with the weight at the bottom lifts off during its "
                "first slip, as the weight rises on the left; no Painlevé point is possible "
                "(muk < sqrt(1 - lam^2)/lam). Exact: slip (-) at 0.11353 s (234.34 deg), "
                "lift-off at 0.31084 s (305.5 deg), hop 0.4340 m, impact 1.02034 s."
            ),
        ),
        Scene.from_chi(
            0.05,
            lam=0.9,
            eps=0.01,
            mus=0.2,
            muk=0.2,
            name="slip-reversal",
            why=(
                "Low friction makes the slip reverse without re-sticking. Exact: slip (-) from "
                "0.56263 s turns into slip (+) at 1.24580 s, re-sticks at 1.33527 s, slips (-) "
                "and reverses again at 1.86570 s; never lifts off."
            ),
        ),
        Scene(
            lam=0.9,
            thetadot0=0.0,
            eps=0.0,
            mus=0.6,
            muk=0.6,
            theta0=math.radians(300.0),
            xdot0=10.0,
            name="painleve",
            why=(
                "A sliding start (centre at 10 m/s, no spin, weight at 300 deg) with muk = 0.6 > "
                "sqrt(1 - lam^2)/lam = 0.484. Exact: D reaches 0 at 311.357 deg, t = 0.18418 s, "
                "where the numerator of n vanishes too (Painlevé; nearby scenes may be reported "
                "as a lift-off at that same point)."
            ),
        ),
        Scene.from_chi(
            1.0,
            lam=0.95,
            eps=0.01,
            mus=0.8,
            muk=0.8,
            name="high-spin",
            why=(
                "Stiff start: seed-mu at chi = 1, so the normal force starts at 0.05 g. Exact: "
                "slips at 0.09635 s (17.41 deg), re-sticks at 0.64562 s, lifts off at 0.91960 s, "
                "hop 1.4840 m, impact 1.96628 s."
            ),
        ),
        _SEED.with_(
            mus=0.1,
            muk=0.1,
            name="low-friction",
            why=(
                "The seed with mus = muk = 0.1. Exact: slips at 0.21000 s (12.14 deg), reverses "
                "at 0.90747, 0.98288 and 1.62579 s without re-sticking, re-sticks at 1.89823 s, "
                "slips again at 2.45604 s; never lifts off."
            ),
        ),
    )


def _build() -> dict[str, Scene]:
    scenes: dict[str, Scene] = {}
    for scene in _catalogue():
        if not scene.name or scene.name in scenes or not scene.why:
            raise ValueError(f"catalogue scene {scene.name!r}: names unique, name and why given")
        scenes[scene.name] = scene
    return scenes


SCENES: Mapping[str, Scene] = MappingProxyType(_build())
"""Read-only mapping name -> Scene, in catalogue order."""


def scene_names() -> tuple[str, ...]:
    """The catalogue's scene names, in catalogue order."""
    return tuple(SCENES)


def check_scene_name(name: Any) -> str:
    """``name``, if the catalogue has a scene of that name; else ValueError naming the valid
    names, its message without the checked value's own name, for the caller to put in
    front ("name" here, the CLI's "--scene NAME")."""
    if isinstance(name, str) and name in SCENES:
        return name
    raise ValueError(f"must be a catalogue scene ({', '.join(SCENES)}), got {name!r}")


def get_scene(name: str) -> Scene:
    """The catalogue scene called ``name``.

    Raises ValueError naming the valid scene names when there is no such scene.
    """
    try:
        return SCENES[check_scene_name(name)]
    except ValueError as exc:
        raise ValueError(f"name {exc}") from None
