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
  engine's contact force is still building up over its first steps;
- a scene whose exact solution does not meet its regime's condition, where the draw asks for
  one (``conditions``): e.g. :func:`near_slip`, a roll whose friction comes near the cone.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np

from hoopbench.models.events import PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference.exact import ExactSolution
from hoopbench.reference.regimes import Regime, classify_solved

__all__ = [
    "RANDOM_PREFIX",
    "RANGES",
    "Condition",
    "Draw",
    "draw",
    "near_slip",
    "peak_rolling_share",
]

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


Condition = Callable[[ExactSolution], str | None]
"""What a regime's scenes must also show: why a scene's exact solution does not (None: it
does)."""

PEAK_SAMPLES = 4001
"""Samples of the exact roll phases scanned for the friction's peak share of the cone (the
share changes over tens of ms; the window holds a few seconds at most)."""


def peak_rolling_share(solution: ExactSolution) -> float:
    """The largest |f| / (mus n) of the exact solution's roll phases inside the record
    (t <= scene.t_end) and before any lift-off: how near the cone the friction that rolling
    needs comes (1 at a slip onset; 0 without a roll phase).

    A solve stopped once settled has rolled a full turn of theta since its last event, so
    its roll phases show every state the rest of the window repeats."""
    scene = solution.scene
    end = min(solution.t_final, scene.t_end)
    peak = 0.0
    for phase in solution.events.phases:
        if phase.kind is PhaseKind.FLIGHT or phase.t_start >= end:
            break
        if phase.kind is not PhaseKind.ROLL:
            continue
        t = np.linspace(phase.t_start, min(phase.t_end, end), PEAK_SAMPLES)
        sampled = solution.sample(t)
        n, f = sampled.normal_force, sampled.friction_force
        with np.errstate(divide="ignore", invalid="ignore"):
            share = np.where(n > 0.0, np.abs(f) / (scene.mus * n), math.inf)
        peak = max(peak, float(np.max(share)))
    return peak


def near_slip(share: float = 0.9) -> Condition:
    """A roll whose friction comes within ``share`` of the cone (:func:`peak_rolling_share`
    above it) without reaching it: a near-slip roll, where an engine whose friction law
    saturates below mu slides and a soft friction creeps near the cone."""

    def condition(solution: ExactSolution) -> str | None:
        peak = peak_rolling_share(solution)
        return None if peak > share else f"rolling friction peaks at {peak:.3g} of the cone"

    return condition


def _skip_reason(regime: Regime, phases: tuple, wanted: Mapping[Regime, int]) -> str | None:
    if regime not in wanted:
        return f"regime {regime}"
    if phases and phases[0].kind is PhaseKind.SLIP:
        return "slips from t = 0"
    return None


def draw(
    seed: int,
    quota: Mapping[Regime, int],
    *,
    t_end: float = 1.5,
    max_draws: int = 2000,
    conditions: Mapping[Regime, Condition] | None = None,
) -> Draw:
    """Draw scenes until each regime of ``quota`` has its number of scenes (each with a
    window of ``t_end`` s), those of a regime in ``conditions`` meeting its condition too.
    Raises RuntimeError if ``max_draws`` draws do not fill it."""
    rng = np.random.default_rng(seed)
    need = dict(quota)
    kept: list[tuple[Scene, Regime]] = []
    skipped: list[tuple[Scene, str]] = []
    for index in range(max_draws):
        scene = _scene(rng, index, t_end)
        with warnings.catch_warnings():  # a Painlevé point evaluates n = num / 0
            warnings.simplefilter("ignore", RuntimeWarning)
            point, solution = classify_solved(scene)
        reason = _skip_reason(point.regime, point.events.phases, quota)
        condition = (conditions or {}).get(point.regime)
        if reason is None and need[point.regime] > 0 and condition is not None:
            reason = condition(solution)
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
