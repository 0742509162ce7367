"""Search parameter space with the exact solver for the scenes of the catalogue.

Run ``python -m hoopbench.reference.find_scenes`` (about ten seconds on two cores; ``--quick``
skips the sweeps and only checks the catalogue). The script

1. sweeps three families of scenes with :func:`hoopbench.reference.exact.solve_exact` and prints the
   candidates that pass the filters below, with their phase sequence and margins:

   * hops from the top (theta0 = 0) with a larger spin chi, seed-like hoop;
   * hops from the bottom (theta0 = pi) with a heavier ring (smaller lam);
   * direct slip reversals (a slip phase followed by one of the opposite sign, no roll between);

2. solves every scene of :mod:`hoopbench.models.catalogue`, prints its events, and checks
   robustness:
   each parameter (lam, eps, thetadot0, theta0, the friction coefficients, xdot0) is moved by
   1e-3 relative (1e-3 absolute where it is zero) in both directions, and the outcome and the
   phase sequence must not change;
3. prints the catalogue table.

The catalogue holds the parameters picked by hand from this output; ``tests/test_catalogue.py``
checks that each scene still does what its ``why`` says.

Phase sequences are written as one letter per phase: ``R`` roll, ``S+`` / ``S-`` slip with
sigma = +1 / -1, ``F`` flight. "D min" is the smallest slipping denominator D met (D = 0 is the
Painlevé point; a hop far from it is not an artefact of a near-singular normal force). "margin"
is the smallest | |f| - mus n | / g at the ends of slip phases (f, n: the rolling forces), where
the solver decides between re-sticking (|f| <= mus n) and reversing: a small margin makes that
decision fragile. "D lift" is D at a lift-off from slipping: near 0 means the lift-off is the
Painlevé point itself (there D and the numerator of n vanish together, so the solver may call
it either), not a clean lift-off.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import math
import sys
import warnings
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from typing import Any

import numpy as np

from hoopbench.models import kinematics
from hoopbench.models.catalogue import SCENES
from hoopbench.models.events import Outcome, PhaseKind
from hoopbench.models.scene import Scene
from hoopbench.reference import dynamics
from hoopbench.reference.exact import ExactSolution, solve_exact

__all__ = ["Summary", "is_robust", "main", "perturbations", "phase_code", "summarise"]

REL_STEP = 1e-3
"""Relative size of the robustness perturbations."""

# Filters for the hop candidates: visible to an engine, early in the window, far from Painlevé.
MIN_HOP_HEIGHT = 1e-2  # m
MIN_FLIGHT = 0.05  # s
T_LIFT_RANGE = (0.2, 2.0)  # s
MIN_D = 0.2
MIN_MARGIN = 0.02
WINDOW_EDGE = 0.1  # s: phases starting this close to t_end are not compared for robustness


@dataclass(frozen=True)
class Summary:
    """What the exact solver finds for one scene, reduced to the numbers the search ranks on."""

    scene: Scene
    outcome: str
    """Outcome value, or "error" when the solver raised."""
    phases: tuple[tuple[str, float], ...] = ()
    """(letter, start time in s) of each phase: R, S+ / S-, F."""
    t_slip: float | None = None
    """s."""
    t_restick: float | None = None
    """s."""
    t_lift: float | None = None
    """s."""
    hop_height: float | None = None
    """m."""
    t_impact: float | None = None
    """s."""
    d_min: float = math.inf
    """Smallest slipping denominator D over the slip phases (inf without slip)."""
    margin: float = math.inf
    """Smallest | |f| - mus n | / g at the end of a slip phase, dimensionless (inf if none)."""
    d_lift: float | None = None
    """D at a lift-off from a slip phase (None otherwise)."""
    reversals: int = 0
    """Number of direct slip reversals."""
    energy_gain: float = 0.0
    """Largest rise of the energy per mass above its earlier minimum, J/kg (should be ~0)."""
    message: str = ""

    @property
    def code(self) -> str:
        """Phase sequence, e.g. "RS+RS-F"."""
        return "".join(letter for letter, _ in self.phases)

    def code_before(self, t: float) -> str:
        """Phase sequence of the phases that start before t (s)."""
        return "".join(letter for letter, start in self.phases if start < t)

    @property
    def flight(self) -> float | None:
        """Flight duration, s."""
        if self.t_lift is None or self.t_impact is None:
            return None
        return self.t_impact - self.t_lift


def _letters(solution: ExactSolution) -> tuple[tuple[str, float], ...]:
    out = []
    for phase in solution.events.phases:
        if phase.kind is PhaseKind.SLIP:
            letter = "S+" if (phase.sigma or 0) > 0 else "S-"
        else:
            letter = "F" if phase.kind is PhaseKind.FLIGHT else "R"
        out.append((letter, phase.t_start))
    return tuple(out)


def phase_code(solution: ExactSolution) -> str:
    """The phase sequence as letters: R, S+ / S-, F."""
    return "".join(letter for letter, _ in _letters(solution))


def _slip_margins(solution: ExactSolution) -> tuple[float, int]:
    """(smallest decision margin at slip ends, number of direct reversals)."""
    scene = solution.scene
    phases = solution.events.phases
    margin, reversals = math.inf, 0
    for this, following in itertools.pairwise(phases):
        if this.kind is not PhaseKind.SLIP or following.kind is PhaseKind.FLIGHT:
            continue
        if following.kind is PhaseKind.SLIP:
            reversals += 1
        _, _, theta, _, _, thetadot = solution.state(this.t_end)[:, 0]
        f, n = (float(v) for v in dynamics.rolling_forces(scene, theta, thetadot))
        margin = min(margin, abs(abs(f) - scene.mus * n) / scene.g)
    return margin, reversals


def _d_lift(solution: ExactSolution) -> float | None:
    segs = solution.segments
    if (
        len(segs) < 2
        or segs[-1].kind is not PhaseKind.FLIGHT
        or segs[-2].kind is not PhaseKind.SLIP
    ):
        return None
    slip = segs[-2]
    assert slip.sigma is not None  # a slip segment always has a direction
    theta = slip.states(np.array([slip.t_end]))[2]
    return float(dynamics.slip_denominator(solution.scene, theta, slip.sigma)[0])


def _d_min(solution: ExactSolution) -> float:
    scene = solution.scene
    if scene.is_degenerate:
        return math.inf
    d_min = math.inf
    for seg in solution.segments:
        if seg.kind is PhaseKind.SLIP and seg.t_end > seg.t_start:
            assert seg.sigma is not None  # a slip segment always has a direction
            theta = seg.states(np.linspace(seg.t_start, seg.t_end, 201))[2]
            d_min = min(d_min, float(np.min(dynamics.slip_denominator(scene, theta, seg.sigma))))
    return d_min


def _energy_gain(solution: ExactSolution) -> float:
    t = np.linspace(0.0, solution.t_final, 2001)
    _, Y, _, Xdot, Ydot, thetadot = solution.state(t)
    energy = kinematics.energy_per_mass(solution.scene, Y, Xdot, Ydot, thetadot)
    return float(np.max(energy - np.minimum.accumulate(energy)))


def summarise(scene: Scene) -> Summary:
    """Solve one scene exactly and reduce it to a :class:`Summary` (errors are returned)."""
    # At a Painlevé point n = num/D is evaluated at D = 0 (inf/nan); that is the finding.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return _summarise(scene)


def _summarise(scene: Scene) -> Summary:
    try:
        solution = solve_exact(scene)
    except (RuntimeError, ValueError) as exc:  # solver limitation: report, keep sweeping
        return Summary(scene, "error", message=str(exc)[:80])
    ev = solution.events
    margin, reversals = _slip_margins(solution)
    return Summary(
        scene,
        str(ev.outcome),
        phases=_letters(solution),
        t_slip=ev.t_slip,
        t_restick=ev.t_restick,
        t_lift=ev.t_lift,
        hop_height=ev.hop_height,
        t_impact=ev.t_impact,
        d_min=_d_min(solution),
        margin=margin,
        d_lift=_d_lift(solution),
        reversals=reversals,
        energy_gain=_energy_gain(solution),
        message=ev.message,
    )


def _summarise_all(scenes: Sequence[Scene], workers: int) -> list[Summary]:
    if workers <= 1:
        return [summarise(s) for s in scenes]
    with ProcessPoolExecutor(workers) as pool:
        return list(pool.map(summarise, scenes, chunksize=4))


# --------------------------------------------------------------------------- robustness
def perturbations(scene: Scene, rel: float = REL_STEP) -> list[tuple[str, Scene]]:
    """The scene with each parameter moved by +-rel (relative; absolute where it is zero).

    Friction is moved as a pair when mus = muk (so it stays equal, as in the engines), and
    each coefficient separately otherwise. Moves that leave the valid range are skipped.
    """
    out: list[tuple[str, Scene]] = []

    def add(label: str, **changes: Any) -> None:  # Any: the field names are chosen at run time
        with contextlib.suppress(ValueError):  # outside the valid range: lam > 1, eps < 0, ...
            out.append((label, scene.with_(**changes)))

    def moved(value: float, sign: int) -> float:
        return value * (1.0 + sign * rel) if value != 0.0 else sign * rel

    for sign in (1, -1):
        tag = "+" if sign > 0 else "-"
        for name in ("lam", "eps", "thetadot0", "theta0"):
            add(f"{name}{tag}", **{name: moved(getattr(scene, name), sign)})
        if scene.mus == scene.muk:
            mu = moved(scene.mus, sign)
            add(f"mu{tag}", mus=mu, muk=mu)
        else:
            add(f"mus{tag}", mus=moved(scene.mus, sign))
            add(f"muk{tag}", muk=moved(scene.muk, sign))
        if scene.xdot0 is not None:
            add(f"xdot0{tag}", xdot0=moved(scene.xdot0, sign))
    return out


def _same(nominal: Summary, other: Summary) -> bool:
    # Phases that start in the last WINDOW_EDGE seconds may come or go with a tiny change (and
    # event times drift more after many phases): compare only the nominal's earlier phases.
    cut = nominal.scene.t_end - WINDOW_EDGE
    keep = sum(1 for _, start in nominal.phases if start < cut)
    letters = [letter for letter, _ in other.phases[:keep]]
    return other.outcome == nominal.outcome and letters == [x for x, _ in nominal.phases[:keep]]


def is_robust(nominal: Summary, perturbed: Iterable[Summary]) -> bool:
    """True when every perturbed run has the nominal outcome and phase sequence.

    Only the nominal's phases that start earlier than WINDOW_EDGE before t_end are compared.
    """
    return all(_same(nominal, p) for p in perturbed)


def _robustness_line(nominal: Summary, perturbed: list[tuple[str, Summary]]) -> str:
    changed = []
    for label, p in perturbed:
        if not _same(nominal, p):
            note = f" (D = {p.d_lift:.1g} at lift-off)" if p.d_lift is not None else ""
            changed.append(f"{label}: {p.outcome} {p.code}{note}")
    if changed:
        return "NOT robust -> " + "; ".join(changed)
    spread = ""
    lifts = [p.t_lift for _, p in perturbed if p.t_lift is not None]
    heights = [p.hop_height for _, p in perturbed if p.hop_height is not None]
    if lifts and nominal.t_lift and nominal.hop_height:
        d_lift = max(abs(x - nominal.t_lift) for x in lifts)
        span = f"{min(heights):.4g}..{max(heights):.4g} m"
        spread = f" (t_lift moves <= {d_lift:.2g} s, hop height {span})"
    return f"robust: {len(perturbed)} perturbations keep {nominal.outcome} {nominal.code}{spread}"


# --------------------------------------------------------------------------- sweeps
def _hop_top_family() -> list[Scene]:
    return [
        Scene.from_chi(chi, lam=lam, eps=0.01, mus=mu, muk=mu)
        for lam in (0.8, 0.9, 0.95)
        for chi in (0.3, 0.4, 0.5, 0.6, 0.7)
        for mu in (0.3, 0.5, 0.8)
    ]


def _hop_bottom_family() -> list[Scene]:
    return [
        Scene(lam=lam, thetadot0=w, eps=0.01, mus=mu, muk=mu, theta0=math.pi)
        for lam in (0.5, 0.6, 0.7)
        for w in (8.0, 8.5, 9.0, 9.5, 10.0)
        for mu in (0.3, 0.5)
    ]


def _reversal_family() -> list[Scene]:
    return [
        Scene.from_chi(chi, lam=lam, eps=0.01, mus=mu, muk=mu)
        for lam in (0.9, 0.95)
        for chi in (0.05, 0.1, 0.2)
        for mu in (0.2, 0.3, 0.4)
    ]


def _is_hop_candidate(s: Summary) -> bool:
    return (
        s.outcome == Outcome.HOPS
        and s.t_lift is not None
        and T_LIFT_RANGE[0] <= s.t_lift <= T_LIFT_RANGE[1]
        and (s.hop_height or 0.0) >= MIN_HOP_HEIGHT
        and (s.flight or 0.0) >= MIN_FLIGHT
        and s.d_min >= MIN_D
        and s.margin >= MIN_MARGIN
        and (s.d_lift is None or s.d_lift >= MIN_D)
    )


def _is_reversal_candidate(s: Summary) -> bool:
    return s.outcome == Outcome.SLIPS and s.reversals > 0 and s.margin >= MIN_MARGIN


def _fmt(x: float | None, spec: str = ".5g") -> str:
    return "-" if x is None else format(x, spec)


def _params(scene: Scene) -> str:
    text = (
        f"lam={scene.lam:g} eps={scene.eps:g} th0={math.degrees(scene.theta0):g}deg "
        f"w0={scene.thetadot0:.5g} chi={scene.chi:.4g} mus={scene.mus:g} muk={scene.muk:g}"
    )
    if scene.xdot0 is not None:
        text += f" xdot0={scene.xdot0:g}"
    return text


def _line(s: Summary) -> str:
    text = (
        f"{_params(s.scene):62s} {s.outcome:10s} {s.code:14s} slip={_fmt(s.t_slip)} "
        f"lift={_fmt(s.t_lift)} hop={_fmt(s.hop_height, '.4g')} flight={_fmt(s.flight, '.3g')} "
        f"Dmin={s.d_min:.3g} margin={s.margin:.3g}"
    )
    return text if s.d_lift is None else text + f" Dlift={s.d_lift:.3g}"


def _sweep(
    title: str,
    scenes: list[Scene],
    keep: Callable[[Summary], bool],
    workers: int,
    show: int = 12,
) -> None:
    results = _summarise_all(scenes, workers)
    errors = [r for r in results if r.outcome == "error"]
    found = [r for r in results if keep(r)]
    print(f"\n== {title}: {len(scenes)} scenes, {len(found)} candidates, {len(errors)} errors")
    # Clearest first: a re-stick/reversal decision far from the friction-cone edge (margins
    # above 1 g count as equal), then far from the Painlevé point.
    found.sort(key=lambda r: (-min(r.margin, 1.0), -min(r.d_min, 10.0)))
    for r in found[:show]:
        print("  " + _line(r))
    for r in errors:
        print(f"  solver error: {_params(r.scene)}: {r.message}")


# --------------------------------------------------------------------------- catalogue
def check_catalogue(workers: int) -> list[Summary]:
    """Solve each catalogue scene, print its events and robustness; return the summaries."""
    names = list(SCENES)
    nominal = _summarise_all([SCENES[n] for n in names], workers)
    labelled_all = [perturbations(SCENES[n]) for n in names]
    flat = _summarise_all([p for labelled in labelled_all for _, p in labelled], workers)
    print("\n== catalogue scenes and robustness (1e-3 relative perturbations)")
    start = 0
    for name, s, labelled in zip(names, nominal, labelled_all, strict=True):
        perturbed = flat[start : start + len(labelled)]
        start += len(labelled)
        print(f"- {name}: {_line(s)}")
        if s.message:
            print(f"    {s.message}")
        print(f"    energy gain {s.energy_gain:.2g} J/kg; reversals {s.reversals}")
        pairs = [(label, p) for (label, _), p in zip(labelled, perturbed, strict=True)]
        print("    " + _robustness_line(s, pairs))
    return nominal


def print_table(summaries: Sequence[Summary]) -> None:
    """The catalogue table: name, parameters, outcome and event times."""
    head = (
        f"{'name':14s} {'parameters':62s} {'outcome':10s} {'t_slip':>8s} {'t_lift':>8s} "
        f"{'hop [m]':>9s} {'t_impact':>8s}  phases"
    )
    print("\n" + head)
    print("-" * len(head))
    for s in summaries:
        print(
            f"{s.scene.name:14s} {_params(s.scene):62s} {s.outcome:10s} {_fmt(s.t_slip):>8s} "
            f"{_fmt(s.t_lift):>8s} {_fmt(s.hop_height, '.4g'):>9s} {_fmt(s.t_impact):>8s}  "
            f"{s.code}"
        )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the sweeps")
    parser.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    args = parser.parse_args(argv)
    if not args.quick:
        _sweep("hops from the top", _hop_top_family(), _is_hop_candidate, args.workers)
        _sweep("hops from the bottom", _hop_bottom_family(), _is_hop_candidate, args.workers)
        _sweep("direct slip reversals", _reversal_family(), _is_reversal_candidate, args.workers)
    print_table(check_catalogue(args.workers))
    return 0


if __name__ == "__main__":
    sys.exit(main())
