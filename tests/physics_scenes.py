"""Scenes shared by the solver tests: docs/derivations.md's, and the former bugs' regression scenes.

Deliberately independent of models/catalogue.py: a test must not trust the catalogue it
helps to check.
"""

from __future__ import annotations

import math

from hoopbench.models.scene import Scene

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
"""The Painlevé example of docs/derivations.md: thrown sliding forward at 10 m/s, no spin."""


# --------------------------------------------------------------------------- former bugs
# Random draws where reference/exact.py was wrong, found by the DAE cross-check; kept as
# regression scenes by both test files.
MISSED_SLIP = Scene(
    lam=0.8956968813019046,
    thetadot0=3.813479793328449,
    mus=0.7559614241676756,
    muk=0.7535534273356567,
    eps=0.08978657881276951,
    theta0=2.0962985817599056,
    t_end=1.5,
    name="missed-slip",
)
"""mus n - |f| dips below zero on 0.0253-0.0584 s, inside one rolling step: the solver once
missed the slip and kept rolling with |f| > mus n (fixed by capping the step, max_step)."""

WRONG_WAY_SLIP = Scene(
    lam=0.8665044427898028,
    thetadot0=3.4879290286257825,
    mus=1.3935763754025865,
    muk=1.1597349850721221,
    eps=0.0051673939119395995,
    theta0=5.106656617931736,
    t_end=1.5,
    name="restick-after-start-slip",
)
"""Slips from t = 0 (sigma = -1) and re-sticks at 0.0199516 s. The solver once missed the
re-stick: first friction kept pushing the wrong way, adding energy; later the flipped slip
direction had D < 0 and the run ended as a spurious Painlevé (see RESTICK_IN_FIRST_STEP)."""

CHATTER = Scene(
    lam=0.9547166900279551,
    thetadot0=3.4061750637499775,
    mus=1.371461512139528,
    muk=0.8711423910782137,
    eps=0.0013991021028433527,
    theta0=4.573098292697877,
    t_end=1.5,
    name="start-slip-chatter",
)
"""Slips from t = 0 and re-sticks at 0.0211311 s. The re-stick event once fired at t = 0
itself and the slip direction flipped until RuntimeError('more than 10000 phases'); the
re-stick event is now armed only once the slip has started."""

FALSE_LIFT = Scene(
    lam=0.9692095449387306,
    thetadot0=3.681543372643219,
    mus=0.2665519708572509,
    muk=0.16206139082845347,
    eps=0.051985462029042855,
    theta0=4.909917710676887,
    t_end=1.5,
    name="no-lift-at-start",
)
"""Rolling would need n(0) < 0, but the free vertical acceleration of the centre points down
(-7.2 m/s^2): the hoop cannot leave the floor, it slips (n = 0.67 m/s^2, sigma = -1). The
solver once reported lifts-at-start with a 2.4e-9 s 'flight'."""

FALSE_LIFT_CRASH = Scene(
    lam=0.8873725290169419,
    thetadot0=3.4538743329502664,
    mus=1.0805127054878845,
    muk=0.9460700515511806,
    eps=0.046892779903400975,
    theta0=0.692269806572599,
    t_end=1.5,
    name="no-lift-at-start-2",
)
"""As FALSE_LIFT (free vertical acceleration -1.65 m/s^2 at t = 0); the flight phase once
found the clearance negative at once and brentq raised ValueError."""


RESTICK_IN_FIRST_STEP = Scene(
    lam=0.8985499430218049,
    thetadot0=3.6725868054646216,
    mus=0.9946737005822146,
    muk=0.8835627515278803,
    eps=0.011771330321030138,
    theta0=4.4813782064328835,
    t_end=1.5,
    name="restick-in-first-step",
)
"""Slips from t = 0 (sigma = -1) and re-sticks at 0.0180182310 s (rolling margin
mus n - |f| = 0.06 g there). The first slip step spans the whole slip, so the re-stick event
is never armed at a step end; the solver now recovers the re-stick from the dense output
instead of reporting ns-long slips of alternating direction."""

SPURIOUS_PAINLEVE = Scene(
    lam=0.8666098412510674,
    thetadot0=3.376461819177481,
    mus=1.3245996592059945,
    muk=0.7849116915893923,
    eps=0.0569015660162529,
    theta0=5.4299931247053275,
    t_end=1.5,
    name="spurious-painleve",
)
"""Same defect as RESTICK_IN_FIRST_STEP: the slip from t = 0 re-sticks at 0.0226976 s
(margin 0.07 g) and the hoop later hops; the missed re-stick once flipped sigma to +1, where
D < 0, and the run ended as 'painleve' at 0.0227 s."""

MISSED_SLIP_2 = Scene(
    lam=0.7218179778453573,
    thetadot0=2.422721176333123,
    mus=1.0083910556167286,
    muk=0.7991328941766799,
    eps=0.02500183399320113,
    theta0=5.95021524520852,
    t_end=1.5,
    name="missed-slip-2",
)
"""As MISSED_SLIP: mus n - |f| < 0 from 1.1386 s went unseen inside one rolling step."""

FORMER_BUGS = (
    WRONG_WAY_SLIP,
    FALSE_LIFT,
    CHATTER,
    MISSED_SLIP,
    MISSED_SLIP_2,
    RESTICK_IN_FIRST_STEP,
    SPURIOUS_PAINLEVE,
)
"""The scenes test_dae_crosscheck.py checks the two formulations on."""
