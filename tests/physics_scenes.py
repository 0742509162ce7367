"""Scenes restated from physics.md for the solver tests.

Deliberately independent of models/catalogue.py: a test must not trust the catalogue it
helps to check.
"""

from __future__ import annotations

import math

from models.scene import Scene

SEED = Scene.from_chi(0.1, lam=0.95, eps=0.01, mus=0.8, muk=0.7, name="seed")
"""The seed document's scene."""

HOP = Scene.from_chi(0.7, lam=0.95, eps=0.0, mus=1.0, muk=1.0, t_end=3.0, name="hop")
"""A scene that hops (found with the solver: lam chi = 0.665 < 1, so it starts rolling):
roll, slip+, roll, slip-, lift-off at 1.00706 s, a 1.07 m hop, impact at 2.01908 s."""

PAINLEVE = Scene(
    lam=0.9,
    eps=0.0,
    mus=0.6,
    muk=0.6,
    theta0=math.radians(300.0),
    thetadot0=0.0,
    xdot0=10.0,
    name="painleve",
)
"""physics.md's Painlevé example: thrown sliding forward at 10 m/s, no spin."""
