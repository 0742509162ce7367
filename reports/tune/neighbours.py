"""Held-out neighbours of the training scenes: scenes as hard as the training set, drawn from a
seed the search never sees.

A neighbour of a training scene has its parameters moved at random, each by at most
NEIGHBOUR_RANGE of its own scale (eps, g, a, M and the window kept):

- the spin thetadot0 and the friction coefficient (mus and muk alike) by that fraction of
  their own value (chi = a thetadot0^2 / g moves with the spin's square);
- lam by that fraction of its distance to the nearer end of [0, 1] (lam = 0.95 moves by at
  most 0.01: near 1 the hoop's own inertia 1 - lam^2 is what changes, and fast);
- theta0 by that fraction of a quarter turn.

It is kept only if its exact solution (reference/regimes.py ``classify``) has the training
scene's events to judge: the same regime and the same sequence of phases (roll, slip with
its direction, flight), every phase the canonical reading can count in the training scene
(lasting its ``sustain``) countable in the neighbour too, and a hop above the reading's hop
threshold where the training scene's is (engines/judging/contact.py, both carried to the
hoop). Otherwise it is drawn again, at most MAX_NEIGHBOUR_DRAWS times; a training scene
whose neighbourhood gives no such scene in as many draws gets no neighbour (the settings
file lists the held-out scenes drawn).
"""

from __future__ import annotations

import json
import math
import warnings
import zlib
from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from hoopbench.engines.judging.contact import ContactSettings
from hoopbench.models.events import Events
from hoopbench.models.scene import Scene
from hoopbench.reference.regimes import RegimePoint, classify

__all__ = [
    "MAX_NEIGHBOUR_DRAWS",
    "NEIGHBOUR_PREFIX",
    "NEIGHBOUR_RANGE",
    "neighbours",
    "neighbours_of",
    "same_events",
]

NEIGHBOUR_RANGE = 0.2
"""Largest move of each drawn parameter, as a fraction of its scale (module docstring):
far enough that a setting fitted to the training scene's event times does not fit its
neighbour's by construction (hop-top's slip onset moves by tens of ms), near enough that
most draws keep its events."""
MAX_NEIGHBOUR_DRAWS = 50
"""Draws per neighbour before a training scene is left without it."""
NEIGHBOUR_PREFIX = "near-"
"""A neighbour's name: near-<training scene>-<k>."""


def _moved(scene: Scene, rng: np.random.Generator, name: str) -> Scene | None:
    """One draw around ``scene``; None where the draw leaves the parameters' domain."""
    u = rng.uniform(-1.0, 1.0, size=4)
    spin = 1.0 + NEIGHBOUR_RANGE * u[0]
    friction = 1.0 + NEIGHBOUR_RANGE * u[1]
    lam = scene.lam + NEIGHBOUR_RANGE * u[2] * min(scene.lam, 1.0 - scene.lam)
    theta0 = scene.theta0 + NEIGHBOUR_RANGE * u[3] * 0.5 * math.pi
    try:
        return replace(
            scene,
            thetadot0=scene.thetadot0 * spin,
            xdot0=None if scene.xdot0 is None else scene.xdot0 * spin,
            mus=scene.mus * friction,
            muk=scene.muk * friction,
            lam=lam,
            theta0=theta0,
            name=name,
        )
    except ValueError:  # theta0 past a turn, too many turns in the window
        return None


def _solved(scene: Scene) -> RegimePoint:
    with warnings.catch_warnings():  # a Painlevé point evaluates n = num / 0
        warnings.simplefilter("ignore", RuntimeWarning)
        return classify(scene)


def _countable(events: Events, scene: Scene) -> tuple[bool, ...]:
    """Whether the reading can count each phase (it lasts ``sustain``), and for the last
    entry whether the hop rises above the hop threshold."""
    cfg = ContactSettings().for_hoop(scene.a, scene.g)
    lasting = tuple(p.t_end - p.t_start >= cfg.sustain for p in events.phases)
    return (*lasting, (events.hop_height or 0.0) > cfg.hop_clearance)


def same_events(train: RegimePoint, train_scene: Scene, near: RegimePoint, scene: Scene) -> bool:
    """Whether ``near`` has the events ``train`` has for the reading to judge."""
    if near.regime is not train.regime or near.events.phase_code != train.events.phase_code:
        return False
    wanted = _countable(train.events, train_scene)
    found = _countable(near.events, scene)
    return all(f or not w for w, f in zip(wanted, found, strict=True))


def _rng(seed: int, scene: Scene) -> np.random.Generator:
    """A stream of its own for each training scene: its neighbours do not change when other
    training scenes are added or reordered."""
    key = zlib.crc32(json.dumps(scene.to_dict(), sort_keys=True).encode())
    return np.random.default_rng([seed, key])


def neighbours(scene: Scene, seed: int, count: int) -> tuple[Scene, ...]:
    """Up to ``count`` neighbours of ``scene`` with its events (module docstring), drawn from
    ``seed``; fewer where MAX_NEIGHBOUR_DRAWS draws find none."""
    train = _solved(scene)
    rng = _rng(seed, scene)
    found: list[Scene] = []
    for k in range(1, count + 1):
        name = f"{NEIGHBOUR_PREFIX}{scene.name or 'scene'}-{k}"
        for _ in range(MAX_NEIGHBOUR_DRAWS):
            near = _moved(scene, rng, name)
            if near is not None and same_events(train, scene, _solved(near), near):
                found.append(near)
                break
        else:
            return tuple(found)
    return tuple(found)


def neighbours_of(scenes: Sequence[Scene], seed: int, count: int) -> tuple[Scene, ...]:
    """The neighbours of every scene, in order."""
    return tuple(n for scene in scenes for n in neighbours(scene, seed, count))
