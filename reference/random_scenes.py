"""Scenes drawn at random, seeded, sorted by their exact regime: scenes nobody tuned on (the
truth test's scenes, and the held-out scenes of `hoopbench tune`).

:func:`draw` draws (lam, chi, mu, theta0, eps) from wide ranges, solves each scene exactly
(reference/regimes.py ``classify``) and keeps the first scenes of each wanted regime until
every quota is met. The ranges reach every regime: rolls (high mu, low spin), slips and slip
reversals (low mu), hops from the top and from the bottom (spin chi up to 8). A drawn scene
is skipped, and the reason recorded, when its exact solution gives nothing to check an
engine's events against or an event no engine can time:

- regimes without an answer (painleve, degenerate, error) or outside the wanted set
  (lifts-at-start: the normal force is negative at t = 0, so there is no lift-off to time);
- a first phase that is a slip from t = 0: its onset is the start itself, where every
  engine's contact force is still building up over its first steps.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from hoopbench.models.events import PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference.regimes import Regime, classify

__all__ = ["RANDOM_PREFIX", "RANGES", "Draw", "draw"]

RANDOM_PREFIX = "random-"
"""A drawn scene's name: random-<its draw's index>."""

RANGES: Mapping[str, tuple[float, float]] = {
    "lam": (0.5, 0.97),
    "log_chi": (math.log(0.02), math.log(8.0)),
    "mu": (0.15, 1.0),
    "theta0": (0.0, 2.0 * math.pi),
    "eps": (0.0, 0.05),
}
"""Uniform ranges of the drawn parameters (chi log-uniform: spins from a creeping roll to a
hop from the bottom)."""


@dataclass(frozen=True)
class Draw:
    """The kept scenes (in the order drawn) and every skipped one with its reason."""

    scenes: tuple[Scene, ...]
    regimes: tuple[Regime, ...]
    skipped: tuple[tuple[Scene, str], ...] = field(repr=False)
    draws: int


def _scene(rng: np.random.Generator, index: int, t_end: float) -> Scene:
    values = {name: rng.uniform(low, high) for name, (low, high) in RANGES.items()}
    mu = float(values["mu"])
    return Scene.from_chi(
        math.exp(values["log_chi"]),
        lam=float(values["lam"]),
        eps=float(values["eps"]),
        mus=mu,
        muk=mu,
        theta0=float(values["theta0"]),
        t_end=t_end,
        name=f"{RANDOM_PREFIX}{index}",
    )


def _skip_reason(regime: Regime, phases: tuple, wanted: Mapping[Regime, int]) -> str | None:
    if regime not in wanted:
        return f"regime {regime}"
    if phases and phases[0].kind is PhaseKind.SLIP:
        return "slips from t = 0"
    return None


def draw(
    seed: int, quota: Mapping[Regime, int], *, t_end: float = 1.5, max_draws: int = 2000
) -> Draw:
    """Draw scenes until each regime of ``quota`` has its number of scenes (each with a
    window of ``t_end`` s). Raises RuntimeError if ``max_draws`` draws do not fill it."""
    rng = np.random.default_rng(seed)
    need = dict(quota)
    kept: list[tuple[Scene, Regime]] = []
    skipped: list[tuple[Scene, str]] = []
    for index in range(max_draws):
        scene = _scene(rng, index, t_end)
        with warnings.catch_warnings():  # a Painlevé point evaluates n = num / 0
            warnings.simplefilter("ignore", RuntimeWarning)
            point = classify(scene)
        reason = _skip_reason(point.regime, point.events.phases, quota)
        if reason is None and need[point.regime] == 0:
            reason = f"quota of {point.regime} met"
        if reason is not None:
            skipped.append((scene, reason))
            continue
        kept.append((scene, point.regime))
        need[point.regime] -= 1
        if not any(need.values()):
            return Draw(
                tuple(s for s, _ in kept), tuple(r for _, r in kept), tuple(skipped), index + 1
            )
    raise RuntimeError(f"{max_draws} draws did not fill the quota {dict(quota)}; left {need}")
