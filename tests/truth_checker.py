"""An independent check of a judged run's labels against the run's own trajectory and
contact force (issue 24, item 6; issue 33, item 7). A helper module for
tests/test_truth_random_scenes.py.

It reads the canonical events from their definitions (docs/report.md; the rigid model's
laws) and never calls the judging code (hoopbench.engines.judging, hoopbench.reports.report):
were it to share that code, it would share its mistakes. It does not re-derive the labels
either; it lists the labels that the trajectory *clearly* contradicts. Every check has a
margin on the side of the label, stated where it is made, so that a borderline
disagreement (an onset 1 ms off, friction at 0.998 of the cone) is never a contradiction:
only a label a reader checking it against the trajectory would call false is.

The definitions (issue 33's), for the 1 m hoop under g = 9.8 m/s^2 (lengths scale with a,
times with sqrt(a / g), speeds with sqrt(g a), as the project's thresholds do):

- **in contact** while n > 1e-6 g (forces per unit mass, as trajectories store them); a
  sample **with a contact force** has n or |f| above that level: a friction without a
  normal force still acts on the hoop (DART stock slides 0.16 s so on a drawn scene). The
  windows read the samples with a contact force; the flights are the normal force's;
- **flight**: a stretch without contact; a **hop** is a flight lasting >= 5 ms whose peak
  clearance is above 1 mm; lift-off is its start, impact its end, hop height its peak;
- **slip**: over a window of WINDOW (5 ms), the rim slides against the friction (mean slip
  velocity above the slip threshold, 1 mm/s, somewhere in the stretch, and opposite to the
  mean friction) *and* the friction follows the slip law, not the rolling demand: |mean f|
  at or beyond the cone (|mean f| >= (1 - eps) mu mean n), or rolling cannot go on at the
  run's own state (the rigid model's rolling forces F_roll, N_roll at theta, thetadot:
  |F_roll| >= mu N_roll, or N_roll <= 0), or |mean f| departs from |mean F_roll| by more
  than DEMAND_TOLERANCE (3 %) of mu n on either side (short of it: a friction that saturates
  below mu, as DART stock's at 0.65-0.83 mu n, which starts a slip only where the slide
  then grows by the slip threshold: a friction lagging a demand that ramps up leaves the
  rim creeping at its speed; above it while sliding: a decelerating slide, which keeps a
  slip going but starts none), or the rim slides faster than
  FAST_SLIDE = 0.1 sqrt(g a) (0.31 m/s: fast sliding is never creep). The **slip onset**
  is where the slip starts sliding under that law, samples beyond the cone included;
- **creep**: slow sliding (above the slip threshold, below FAST_SLIDE) against a friction that
  follows the rolling demand inside the cone: never a slip, counted only in contact and
  before the exact solution's lift-off. **Stick outside the cone** (|mean f| above the cone
  without sliding: the flag ``cone-violation``) is never a slip either;
- **chattering** (friction at the cone on some steps, inside it on average) is a property,
  never a phase: the phases are the motion's, R, S+, S- and F;
- **every transition is timed**: an agrees or close row has each of its phases' transitions
  (slip onsets, re-sticks, reversals, lift-off, impact) within the loose tolerance of the
  exact one it matches (re-sticks and reversals with the slip onset's).

Before issue 33 a slip's friction also followed the slip law where it lay "nearer the cone
than the demand" (no more: MuJoCo stock's creep at 0.97-0.98 mu n against a demand of
0.94-0.96 is creep), fast sliding inside the cone was creep, chattering was a phase (C), and
only the first slip onset was timed.
"""

from __future__ import annotations

import itertools
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from importlib.resources.abc import Traversable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from hoopbench.models.events import Outcome, Phase, PhaseKind
from hoopbench.reference.dynamics import rolling_forces
from hoopbench.reference.exact import ExactSolution

__all__ = [
    "CANONICAL_NAMES",
    "DOCS_LOOSE",
    "Contradiction",
    "Exact",
    "Hoop",
    "Kind",
    "Labels",
    "LooseTolerances",
    "contradictions",
]

# ----------------------------------------------------------------------------- definitions
# Stated for the 1 m hoop under g = 9.8 m/s^2 (docs/report.md's canonical events).
CONTACT_LEVEL = 1e-6
"""In contact while n > CONTACT_LEVEL g."""
HOP_DURATION = 5e-3
"""s: a flight this long (and above HOP_CLEARANCE) is a hop."""
HOP_CLEARANCE = 1e-3
"""m: a hop's peak clearance exceeds this."""
SLIP_THRESHOLD = 1e-3
"""m/s: the rim slides when its averaged slip velocity exceeds this."""
FAST_SLIDE = 0.1 * math.sqrt(9.8)
"""m/s: a tenth of sqrt(g a) (0.31 m/s): sliding faster than this is never creep."""
DEMAND_TOLERANCE = 3e-2
"""Fraction of the cone mu n: friction follows the rolling demand while |mean f| stays within
this of |mean F_roll| (issue 33's "a few %", 3 % as the canonical reading states it)."""
STILL = 5e-6
"""m/s: a rim whose averaged slip velocity stays below this does not slide at all (round-off:
the exact roll holds 1e-12, DART's sticks 2e-7), so it is in no slip, whatever its friction."""
PHASE_END = 0.05
"""s: two phase sequences that differ by one last phase starting this close to the record's
end agree (the verdict's phase rule, 1 m hoop): no transition is timed within it."""
WINDOW = 5e-3
"""s: the averaging window of the slip reading ("a few ms"; the issue's own check averaged
over 5 ms)."""

# ----------------------------------------------------------------------------- margins
# A label is contradicted only when the trajectory clearly shows otherwise.
CLEAR = 2.0
"""A clear hop lasts CLEAR x HOP_DURATION and rises CLEAR x HOP_CLEARANCE; a flight shorter
than HOP_DURATION / CLEAR or lower than HOP_CLEARANCE / CLEAR is clearly no hop. Clear
sliding is CLEAR x SLIP_THRESHOLD; below SLIP_THRESHOLD / CLEAR the rim clearly does not
slide. A factor 2 either way is far beyond what sampling or a detector's interpolation moves."""
CONE_CLEAR = 1e-3
"""Averaged friction within this fraction of the cone is clearly at it (the rigid reading's
own tolerance: a real slip holds |f| = mu n exactly)."""
CONE_INSIDE = 2.5e-2
"""Averaged friction more than this fraction inside the cone is clearly inside it. Between
the two cases the issue and the docs settle: Drake's regularised friction slides at
0.98-0.995 mu n (1.1-1.7 % inside on a drawn scene), a slip by every reading; the creep
the issue calls no slip holds 0.950-0.956 mu n (4.4-5 % inside). Friction rises slowly
toward the cone before a slip (0.3 % of the cone per 2 ms on a drawn scene), so the margin
is also time: at 1 % Drake's slip read as creep, at 4 % MuJoCo stock's creep read 30 ms
before the cone passed as near it."""
CONE_OUTSIDE = 0.1
"""Averaged friction more than this fraction above the cone is clearly outside it (DART
sticks at 1.23-2.0 mu n in the issue)."""
LOADED = 0.05
"""A window carries a contact force worth reading when its mean n or its mean |f| exceeds
LOADED g: below both, |f| / (mu n) is the ratio of two numbers near round-off (chatter, a
flight's edge). Friction alone counts: DART holds 0.09 g of friction on 0.02 g of normal
force (5 times the cone) on a drawn scene."""
SLIDE_HORIZON = 2
"""Windows after a read slip onset within which the rim must slide. A slip starts from rest
and its slip velocity grows from 0 (as t^2): at a slow onset the window that starts there is
still below the threshold (the exact solution of a drawn scene: 0.41 mm/s 3 ms after its
onset, 1.2 mm/s after 6 ms). A rim that has not slid at half the threshold within two
windows (10 ms) of the windows near a read onset is still."""
DEMAND_MARGIN = 2.5e-2
"""Fraction of the cone: the rolling demand is clearly inside or beyond the cone only beyond
this margin, as CONE_INSIDE is for the friction itself."""
FOLLOW_MARGIN = 1e-2
"""Fraction of the cone: friction clearly follows the rolling demand within DEMAND_TOLERANCE -
FOLLOW_MARGIN of it (2 %), clearly departs from it beyond DEMAND_TOLERANCE + FOLLOW_MARGIN
(4 %). The two window means (ours over 5 ms ahead, a reading's over a few ms around) differ
by far less: the demand moves by a few % of the cone over tens of ms."""
NOISE_SIGMAS = 2.0
"""A window's mean friction is clearly away from the demand only beyond this many standard
errors of its scatter (see Windows.noise)."""
FAST_CLEAR = 1.5
"""Clearly fast is FAST_CLEAR x FAST_SLIDE (0.47 m/s), clearly slow below FAST_SLIDE /
FAST_CLEAR (0.21 m/s): a slide's speed changes little over a window beside that factor."""
CHATTER_SHARE = 0.2
"""A window with this share of its contact steps at the cone, and its average inside it, is
a chattering contact (only names the kind of a contradiction; decides none)."""
HEIGHT_SLACK = 1e-2
"""Relative: a hop height within 1 % of the exact one is neither too low nor too high,
whatever the table (the sampled peak misses the exact one by g dt^2 / 8, far less)."""
SAMPLE_SLACK = 2
"""Samples an event time may sit off a sample's time (interpolation inside the step, and
the step convention: row i holds the force of the step taken from it)."""


@dataclass(frozen=True)
class Hoop:
    """Carries the 1 m hoop's definitions to a hoop of radius ``a`` under ``g``."""

    a: float = 1.0
    """m."""
    g: float = 9.8
    """m/s^2."""
    scene: Any = None
    """The run's scene (a hoopbench Scene), for the rolling demand at the run's own state;
    None: the slip law is read from the cone alone."""

    @property
    def length(self) -> float:
        """Lengths scale with a (the definitions' hoop is 1 m)."""
        return self.a

    @property
    def duration(self) -> float:
        """Times scale with sqrt(a / g)."""
        return math.sqrt(self.a / self.g * 9.8)

    @property
    def speed(self) -> float:
        """Speeds scale with sqrt(g a)."""
        return math.sqrt(self.g * self.a / 9.8)


@dataclass(frozen=True)
class LooseTolerances:
    """The loose tier ("close") of the tolerance table: a row that is `agrees` or `close`
    has every event within these. Times on the 1 m hoop (scaled with sqrt(a / g))."""

    slip_s: float
    """s, first slip onset."""
    lift_s: float
    """s, lift-off."""
    impact_s: float
    """s, impact."""
    height_low: float
    """The smallest hop height, as a fraction of the exact one."""
    height_high: float
    """The largest hop height, as a multiple of the exact one."""
    steps: float = 0.0
    """Each time tolerance grows by this many of the run's timesteps."""
    source: str = ""
    """Where the numbers come from."""

    @classmethod
    def from_table(cls, path: Path | Traversable) -> LooseTolerances:
        """The [loose] table of the tolerance file (read as data: the judging code that
        reads it is what this checks)."""
        loose = tomllib.loads(path.read_text())["loose"]
        rel = float(loose["hop_height_rel"])
        return cls(
            slip_s=float(loose["t_slip_s"]),
            lift_s=float(loose["t_lift_s"]),
            impact_s=float(loose["t_impact_s"]),
            height_low=1.0 - rel,
            height_high=1.0 + rel,
            steps=float(loose.get("steps", 0)),
            source=str(path.name),
        )


DOCS_LOOSE = LooseTolerances(
    slip_s=10e-3,
    lift_s=50e-3,
    impact_s=50e-3,
    height_low=0.5,
    height_high=2.0,
    source="docs/report.md before issue 24",
)
"""The verdict's tolerances as docs/report.md stated them before issue 24's table (10 ms slip
onset, 50 ms lift-off, a factor 2 on the hop height; impact, not judged then, given the
lift-off's): what the issue calls the verdict's loose meaning of agrees."""

FLOOR_SLACK = 1e-3
"""s, plus one timestep: the detection floor a judged row's tolerance also grows by (the
canonical reading of the exact solution sampled at the run's timestep; the table measures
it below 0.5 ms plus one step at dt <= 1e-3)."""


class Kind(StrEnum):
    """Which label a trajectory contradicts, and how."""

    REFERENCE = "reference-not-agrees"
    DIVERGED = "diverged-but-bounded"
    HOP_LABEL = "hop-label"
    """t_lift / hop_height / t_impact where the trajectory has no such flight."""
    HOP_VERDICT = "hop-verdict"
    """A hop verdict (missed-hop, false-hop, too low/high, early/late) the flights deny."""
    CREEP_AS_SLIP = "creep-read-as-slip"
    """A slip read where the rim creeps: it slides, slowly, with its friction at the rolling
    demand inside the cone."""
    CHATTER_AS_SLIP = "chatter-read-as-slip"
    """A slip read where friction touches the cone on some steps, inside it on average."""
    STICK_AS_SLIP = "stick-at-or-outside-cone-read-as-slip"
    """A slip read where the averaged friction is at or outside the cone and the rim does
    not slide."""
    NO_SLIP_AS_SLIP = "slip-read-without-slip"
    """A slip read where friction is inside the cone and the rim does not slide."""
    SLIP_LABEL = "slip-label"
    """No slip (or a late first slip, or fewer slip phases) read where the run clearly
    slips with its friction at the cone."""
    SLIDE_AS_ROLL = "slide-read-as-roll"
    """No slip (or a late first slip, or fewer slip phases) read where the run clearly slips
    inside the cone: it slides fast, or its friction is away from the rolling demand (a
    friction law that saturates below mu)."""
    SLIP_PHASES = "slip-phases-beyond-the-run"
    """More slip phases (of a direction) read than the run can hold: a roll read inside one
    clear slide, or a slip where the rim does not slip."""
    CREEP_LABEL = "creep-label"
    """Creep read faster than FAST_SLIDE (fast sliding is never creep), or farther than the
    rim slides in contact before the exact lift-off."""
    CHATTER_PHASE = "chattering-read-as-a-phase"
    """A phase code other than R, S+, S-, F: chattering is a property, never a phase."""
    TRANSITION = "transition-beyond-loose"
    """agrees or close, but the run is clearly in another phase than the exact solution far
    from every exact transition: some transition (a slip onset, re-stick, reversal,
    lift-off or impact) is clearly beyond its loose tolerance."""
    SLIP_VERDICT = "slip-verdict"
    """false-slip, missed-slip, early-slip or late-slip the averaged friction denies."""
    TOLERANCE = "agrees-beyond-tolerance"
    """agrees or close with an event clearly beyond the loose tolerance."""
    MISSING_FLAG = "flags-miss-a-failed-check"
    """A failing row whose flags name no failure of an event clearly beyond the loose
    tolerance."""
    CONE_FLAG = "cone-violation-flag"
    """A sustained stick outside the cone without the flag, or the flag without one."""


@dataclass(frozen=True)
class Contradiction:
    kind: Kind
    text: str


# ----------------------------------------------------------------------------- inputs
CANONICAL_NAMES: Mapping[str, str] = {
    "engine": "engine",
    "status": "status",
    "verdict": "verdict",
    "verdict_flags": "verdict_flags",
    "t_slip": "t_slip",
    "t_lift": "t_lift",
    "t_impact": "t_impact",
    "hop_height": "hop_height",
    "phases": "phases",
    "creep_distance": "creep_distance_m",
    "creep_max_speed": "creep_max_speed",
}
"""Which column of a runs table holds each label (the canonical, unprefixed names)."""

AGREEING = frozenset({"agrees", "close"})
UNJUDGED = frozenset({"diverged", "failed"})


def _number(value: Any) -> float | None:
    if value is None or isinstance(value, str):
        return None
    number = float(value)
    return number if math.isfinite(number) else None


def _text(value: Any) -> str | None:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return None
    return str(value)


@dataclass(frozen=True)
class Labels:
    """What a row says about its run."""

    engine: str
    status: str
    verdict: str | None
    flags: frozenset[str]
    t_slip: float | None
    t_lift: float | None
    t_impact: float | None
    hop_height: float | None
    phases: tuple[str, ...] | None = None
    """The phase codes, in order (None: not read)."""
    creep_distance: float | None = None
    """m: how far the row says the rim creeps."""
    creep_max_speed: float | None = None
    """m/s: the fastest creep the row reads."""

    @classmethod
    def from_row(cls, row: Mapping[str, Any], names: Mapping[str, str] = CANONICAL_NAMES) -> Labels:
        def get(key: str) -> Any:
            return row.get(names[key]) if key in names else None

        flags = _text(get("verdict_flags")) or ""
        phases = _text(get("phases"))
        return cls(
            engine=str(get("engine")),
            status=str(get("status")),
            verdict=_text(get("verdict")),
            flags=frozenset(flags.split()),
            t_slip=_number(get("t_slip")),
            t_lift=_number(get("t_lift")),
            t_impact=_number(get("t_impact")),
            hop_height=_number(get("hop_height")),
            phases=None if phases is None else tuple(phases.split()),
            creep_distance=_number(get("creep_distance")),
            creep_max_speed=_number(get("creep_max_speed")),
        )

    def says(self, label: str) -> bool:
        """Whether the verdict or a flag is ``label``."""
        return self.verdict == label or label in self.flags


class Tolerance(StrEnum):
    """Which loose tolerance times a transition (the table's; re-sticks and reversals take
    the slip onset's)."""

    SLIP = "slip"
    LIFT = "lift-off"
    IMPACT = "impact"


@dataclass(frozen=True)
class ExactPhase:
    """One phase of the exact solution inside the record."""

    code: str
    """R, S+, S- or F (S+: the rim slides towards +x)."""
    t_start: float
    """s."""
    t_end: float
    """s (the record's end or the impact for the last one)."""
    seen: bool = True
    """A reading can see it: not a slip shorter than two windows or slower than CLEAR slip
    thresholds. The motion inside an unseen slip is left out of the transition check."""


def _code(phase: Phase) -> str:
    if phase.kind is PhaseKind.SLIP:
        return "S+" if (phase.sigma or 0) > 0 else "S-"
    return "F" if phase.kind is PhaseKind.FLIGHT else "R"


def _tolerance_into(code: str, previous: str) -> Tolerance:
    """The loose tolerance of the transition from ``previous`` into ``code``."""
    if code == "F":
        return Tolerance.LIFT
    return Tolerance.IMPACT if previous == "F" else Tolerance.SLIP


@dataclass(frozen=True)
class Exact:
    """The exact solution's events, as far as the checks need them."""

    window_end: float
    """s: the exact window's end (its impact for a hop)."""
    slips: bool
    """Any slip phase in the window (before a lift-off)."""
    t_slip: float | None
    """s: first slip onset, where a reading can resolve it (None otherwise)."""
    t_lift: float | None
    t_impact: float | None
    hop_height: float | None

    hop_unresolved: bool = False
    """The exact solution hops, but not clearly inside the record's window (scene.t_end; the
    exact window runs on to the impact): the hop's checks are left out."""
    peak_after_record: bool = False
    """The exact hop reaches its peak after the record's end: no run sampled up to scene.t_end
    shows its height, so only a hop too high can be told."""
    phases: tuple[ExactPhase, ...] = ()
    """The phases inside the record, for timing every transition (none: no timing)."""
    contact_end: float = math.inf
    """s: where the exact hoop leaves the floor (its lift-off; inf without one): no creep
    after it."""

    def transitions(self) -> list[tuple[float, Tolerance]]:
        """Every transition between the phases, and the impact that ends a last flight."""
        out = [
            (q.t_start, _tolerance_into(q.code, p.code)) for p, q in itertools.pairwise(self.phases)
        ]
        if self.phases and self.phases[-1].code == "F" and self.t_impact is not None:
            out.append((self.t_impact, Tolerance.IMPACT))
        return out

    def codes(self) -> tuple[str, ...]:
        """The phase codes a reading sees: unseen slips left out (absorbed), and a phase the
        same as the one before merged with it."""
        seen = [p.code for p in self.phases if p.seen]
        return tuple(c for k, c in enumerate(seen) if k == 0 or c != seen[k - 1])

    @classmethod
    def from_solution(cls, solution: ExactSolution, hoop: Hoop) -> Exact:
        """Events a reading cannot resolve inside the record (the scene's window, which a
        run samples) are left out, as the exact solution sampled like a run would absorb
        them: a first slip shorter than two windows or slower than CLEAR slip thresholds
        (its onset is not checked), a hop whose flight up to the record's end is not a
        clear hop (none of its checks)."""
        events, record_end = solution.events, solution.scene.t_end
        slips = [p for p in events.phases if p.kind is PhaseKind.SLIP and p.t_start < record_end]
        t_slip = slips[0].t_start if slips and _seen(solution, slips[0], hoop) else None
        # A hoop the floor cannot hold at t = 0 hops from there (lifts-at-start, t_lift 0).
        hops = events.outcome in _HOPS and events.t_lift is not None
        unresolved = hops and not _clear_in_record(solution, hoop)
        keep = hops and not unresolved
        phases = tuple(
            ExactPhase(
                _code(p),
                p.t_start,
                min(p.t_end, solution.t_final, record_end),
                p.kind is not PhaseKind.SLIP or _seen(solution, p, hoop),
            )
            for p in events.phases
            if p.t_start < min(record_end, solution.t_final)
        )
        return cls(
            phases=phases,
            contact_end=math.inf if events.t_lift is None else events.t_lift,
            peak_after_record=keep and _peak_after_record(solution),
            window_end=solution.t_final,
            slips=bool(slips),
            t_slip=t_slip,
            t_lift=events.t_lift if keep else None,
            t_impact=events.t_impact if keep else None,
            hop_height=events.hop_height if keep else None,
            hop_unresolved=unresolved,
        )


_HOPS = (Outcome.HOPS, Outcome.LIFTS_AT_START)
"""The exact outcomes with a hop: lifts-at-start's from t = 0."""


def _seen(solution: ExactSolution, slip: Phase, hoop: Hoop) -> bool:
    """Whether a reading can see an exact slip inside the record: it lasts two windows and
    slides faster than CLEAR slip thresholds."""
    end = min(slip.t_end, solution.t_final, solution.scene.t_end)
    if end - slip.t_start < 2 * WINDOW * hoop.duration:
        return False
    sampled = solution.sample(np.linspace(slip.t_start, end, 201))
    return float(np.max(np.abs(sampled.slip_velocity))) >= CLEAR * SLIP_THRESHOLD * hoop.speed


def _peak_after_record(solution: ExactSolution) -> bool:
    """Whether the exact hop is still rising at the record's end (scene.t_end)."""
    t_lift, height = solution.events.t_lift, solution.events.hop_height
    end = min(solution.t_final, solution.scene.t_end)
    if t_lift is None or height is None or end <= t_lift:
        return False
    peak = float(np.max(solution.sample(np.linspace(t_lift, end, 401)).clearance))
    return peak < (1 - HEIGHT_SLACK) * height


def _clear_in_record(solution: ExactSolution, hoop: Hoop) -> bool:
    """Whether the exact hop's flight, cut at the record's end, is a clear hop."""
    t_lift = solution.events.t_lift
    assert t_lift is not None
    end = min(solution.t_final, solution.scene.t_end)
    if end - t_lift < CLEAR * HOP_DURATION * hoop.duration:
        return False
    peak = float(np.max(solution.sample(np.linspace(t_lift, end, 401)).clearance))
    return peak >= CLEAR * HOP_CLEARANCE * hoop.length


# ----------------------------------------------------------------------------- readings
@dataclass(frozen=True)
class Flight:
    """A stretch of samples without contact: [first, stop)."""

    t_start: float
    """s: its first sample."""
    t_end: float | None
    """s: the first sample back in contact; None if the record ends in the air."""
    duration: float
    """s (to the record's end if it ends in the air)."""
    peak: float
    """m: the largest clearance inside it."""
    landed: bool
    """It ends in contact, or the record ends with it back at the floor (the reference's
    ends at its impact): its peak is its height. Otherwise the peak is a lower bound."""

    def clear_hop(self, hoop: Hoop) -> bool:
        return (
            self.duration >= CLEAR * HOP_DURATION * hoop.duration
            and self.peak >= CLEAR * HOP_CLEARANCE * hoop.length
        )

    def maybe_hop(self, hoop: Hoop) -> bool:
        """Not clearly no hop."""
        return (
            self.duration >= HOP_DURATION * hoop.duration / CLEAR
            and self.peak >= HOP_CLEARANCE * hoop.length / CLEAR
        )


def _runs(mask: NDArray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    return list(zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0], strict=True))


@dataclass(frozen=True)
class Run:
    """A run's samples and what the definitions read from them."""

    t: NDArray
    dt: float
    f: NDArray
    n: NDArray
    s: NDArray
    touching: NDArray
    """n above the contact level: the flights are the stretches without it."""
    forced: NDArray
    """n or |f| above the contact level: the samples with a contact force."""
    down: NDArray
    """The clearance at most the hop threshold: no hop could be under way."""
    flights: tuple[Flight, ...]
    hoop: Hoop
    mu: float
    demand: tuple[NDArray, NDArray] | None = None
    """(F_roll, N_roll) per sample, m/s^2: what rolling would need at the run's own state."""

    @classmethod
    def from_frame(cls, frame: pd.DataFrame, mu: float, hoop: Hoop) -> Run:
        t = frame["t"].to_numpy(float)
        n = frame["normal_force"].to_numpy(float)
        level = CONTACT_LEVEL * hoop.g
        touching = n > level
        f = frame["friction_force"].to_numpy(float)
        clearance = frame["clearance"].to_numpy(float)
        flights = []
        for start, stop in _runs(~touching):
            end = None if stop == len(t) else float(t[stop])
            last = float(t[-1]) if end is None else end
            peak = float(np.max(clearance[start:stop]))
            landed = end is not None or clearance[-1] <= HOP_CLEARANCE * hoop.length / CLEAR
            flights.append(Flight(float(t[start]), end, last - float(t[start]), peak, landed))
        return cls(
            t=t,
            dt=float(np.median(np.diff(t))) if len(t) > 1 else 0.0,
            f=f,
            n=n,
            s=frame["slip_velocity"].to_numpy(float),
            touching=touching,
            forced=touching | (np.abs(f) > level),
            down=clearance <= HOP_CLEARANCE * hoop.length,
            flights=tuple(flights),
            hoop=hoop,
            mu=mu,
            demand=None
            if hoop.scene is None
            else rolling_forces(
                hoop.scene, frame["theta"].to_numpy(float), frame["thetadot"].to_numpy(float)
            ),
        )

    @property
    def slack(self) -> float:
        return SAMPLE_SLACK * self.dt


@dataclass(frozen=True)
class Windows:
    """Forward windows of WINDOW: window k covers samples [k, k + m)."""

    start: NDArray
    """s, each window's first sample time."""
    ratio: NDArray
    """|mean f| / (mu mean n); NaN where the window is not LOADED."""
    mean_s: NDArray
    """m/s, mean slip velocity."""
    opposes: NDArray
    """mean slip velocity and mean friction of opposite signs."""
    friction_sign: NDArray
    """sign(mean f): a slip's direction is the opposite one."""
    all_forced: NDArray
    """Every sample of the window has a contact force (Run.forced)."""
    steps_at_cone: NDArray
    """Share of the window's contact samples with |f| >= (1 - CONE_CLEAR) mu n."""
    in_region: NDArray
    """The window ends before the region's end (see :func:`_region_end`)."""
    length: int
    """m, samples per window."""
    unread: NDArray
    """Not LOADED while the hoop is down throughout: its friction law cannot be read (the
    contact force near round-off, or none while the rim slides: pymunk's solver returns no
    impulse at all for some slipping contacts, adapter's docstring), so nothing there says
    that the rim, if it slides, does not slip."""
    demand: NDArray | None = None
    """|mean F_roll| / (mu mean N_roll) (inf where rolling needs a pull); None without it."""
    follow: NDArray | None = None
    """|mean f - mean F_roll| / (mu mean n): how far the friction is from what rolling needs,
    as a share of the run's cone (F_roll counted on the samples in contact, as f is)."""
    depart: NDArray | None = None
    """| |mean f| - |mean F_roll| | / (mu mean n): the same without the signs (no larger)."""
    shortfall: NDArray | None = None
    """(|mean F_roll| - |mean f|) / (mu mean n): the friction short of what rolling needs
    (> 0) or above it (< 0)."""
    lag: NDArray | None = None
    """The mean change of F_roll over one step, either side, / (mu mean n): how far the
    demand a friction follows may be from ours by the step convention alone (row i holds
    the force of the step taken from it, SAMPLE_SLACK; Rapier's and Box2D's rolling friction
    lag the demand by a step, 3 % of the cone on a fast-changing demand at dt 1e-3)."""
    noise: NDArray | None = None
    """NOISE_SIGMAS standard errors of the window's mean of f - F_roll, / (mu mean n): how
    far a noisy friction's mean may be from the demand it follows by its scatter alone (Box2D
    at dt 1e-3 scatters 0.1 mu n from step to step at a low normal force)."""

    @classmethod
    def of(cls, run: Run, region_end: float) -> Windows:
        m = max(2, round(WINDOW * run.hoop.duration / run.dt)) if run.dt > 0 else 2
        m = min(m, len(run.t))

        def mean(x: NDArray) -> NDArray:
            c = np.concatenate(([0.0], np.cumsum(x, dtype=float)))
            return (c[m:] - c[:-m]) / m

        mean_f, mean_n, mean_s = mean(run.f), mean(run.n), mean(run.s)
        loaded = (mean_n > LOADED * run.hoop.g) | (np.abs(mean_f) > LOADED * run.hoop.g)
        with np.errstate(divide="ignore", invalid="ignore"):
            cone = np.where(loaded, run.mu * mean_n, np.nan)
            ratio = np.abs(mean_f) / cone
            at_cone = run.forced & (np.abs(run.f) >= (1 - CONE_CLEAR) * run.mu * run.n)
            share = mean(at_cone.astype(float)) / mean(run.forced.astype(float))
        ends = run.t[m - 1 :]
        demand = follow = depart = shortfall = lag = noise = None
        if run.demand is not None:
            need = mean(np.where(run.forced, run.demand[0], 0.0))
            change = np.abs(np.diff(run.demand[0]))
            step = np.maximum(np.append(change, 0.0), np.insert(change, 0, 0.0))
            rolling_cone = run.mu * mean(run.demand[1])
            with np.errstate(divide="ignore", invalid="ignore"):
                demand = np.where(
                    rolling_cone > 0, np.abs(mean(run.demand[0])) / rolling_cone, np.inf
                )
                follow = np.abs(mean_f - need) / cone
                shortfall = (np.abs(need) - np.abs(mean_f)) / cone
                depart = np.abs(shortfall)
                lag = mean(np.where(np.isfinite(step), step, np.inf)) / cone
                gap = run.f - np.where(run.forced, run.demand[0], 0.0)
                spread = np.sqrt(np.maximum(mean(gap**2) - mean(gap) ** 2, 0.0))
                noise = NOISE_SIGMAS * spread / math.sqrt(m) / cone
        return cls(
            start=run.t[: len(ratio)],
            ratio=ratio,
            mean_s=mean_s,
            opposes=mean_s * mean_f < 0,
            friction_sign=np.sign(mean_f),
            all_forced=mean(run.forced.astype(float)) >= 1.0,
            steps_at_cone=np.nan_to_num(share),
            in_region=ends <= region_end,
            length=m,
            unread=~loaded & (mean((~run.down).astype(float)) == 0),
            demand=demand,
            follow=follow,
            depart=depart,
            shortfall=shortfall,
            lag=lag,
            noise=noise,
        )

    def slip_law(self, hoop: Hoop, *, clearly: bool) -> NDArray:
        """Windows whose friction follows the slip law, not the rolling constraint (clearly,
        or not clearly not): at or beyond the cone, or rolling cannot go on at the run's
        state (the demand at or beyond its cone), or the friction away from the rolling
        demand by more than DEMAND_TOLERANCE of the cone (either side), or the rim sliding
        faster than FAST_SLIDE (fast sliding is never creep); not clearly not where the
        window is :attr:`unread`."""
        if clearly:
            return self._clear_law(hoop, self.depart)
        fast = FAST_SLIDE * hoop.speed * (1 / FAST_CLEAR)
        with np.errstate(invalid="ignore"):
            law = (self.ratio >= 1 - CONE_INSIDE) | (np.abs(self.mean_s) >= fast) | self.unread
            if self.demand is not None:
                law |= self.demand >= 1 - DEMAND_MARGIN
            if self.follow is not None:
                # Not clearly near the demand even with a step's lag and the scatter.
                law |= self.follow >= DEMAND_TOLERANCE - FOLLOW_MARGIN
        return law

    def follows_demand(self, hoop: Hoop) -> NDArray:
        """Clearly not under the slip law: friction clearly inside the cone and near the
        rolling demand, which is clearly inside its cone, and the rim clearly slow. Without
        the demand, no window is (the rolling demand is half the definition)."""
        if self.demand is None or self.follow is None:
            return np.zeros(len(self.ratio), dtype=bool)
        with np.errstate(invalid="ignore"):
            return (
                (self.ratio <= 1 - CONE_INSIDE)
                & (self.demand <= 1 - DEMAND_MARGIN)
                & (self.follow <= DEMAND_TOLERANCE - FOLLOW_MARGIN)
                & (np.abs(self.mean_s) <= FAST_SLIDE * hoop.speed / FAST_CLEAR)
            )

    def sliding(self, hoop: Hoop) -> NDArray:
        """The rim is not clearly still: it slides at half the slip threshold against the
        friction, averaged over the window (against whatever friction an :attr:`unread`
        window has)."""
        fast = np.abs(self.mean_s) >= SLIP_THRESHOLD * hoop.speed / CLEAR
        return fast & (self.opposes | self.unread)

    def slides_soon(self, hoop: Hoop) -> NDArray:
        """:meth:`sliding` in one of the SLIDE_HORIZON windows that start from here."""
        c = np.concatenate(([0], np.cumsum(self.sliding(hoop))))
        k = np.arange(len(self.mean_s))
        stop = np.minimum(k + SLIDE_HORIZON * self.length + 1, len(k))
        return (c[stop] - c[k]) > 0

    def maybe_slip(self, hoop: Hoop, *, soon: bool = False) -> NDArray:
        """Not clearly no slip: the friction not clearly off the slip law, and the rim not
        clearly still (:meth:`sliding`, or with ``soon`` :meth:`slides_soon`)."""
        slides = self.slides_soon(hoop) if soon else self.sliding(hoop)
        with np.errstate(invalid="ignore"):
            return self.in_region & self.slip_law(hoop, clearly=False) & slides

    def clear_slip(self, hoop: Hoop) -> NDArray:
        """Clearly a slip, sustained: WINDOW of consecutive windows each in contact
        throughout, clearly under the slip law and sliding clearly against the friction. At
        the cone is the definition's |mean f| >= (1 - eps) mu mean n, one-sided: a rim
        sliding against a friction above the cone slips (DART stock slides at 1 m/s with
        friction at 1.1 mu n, Drake stock at 2 mm/s with 1.01-1.04 mu n); the excess is a
        Coulomb violation besides, which the cone-violation flag is for only where the rim
        does not slide."""
        sliding = (np.abs(self.mean_s) >= CLEAR * SLIP_THRESHOLD * hoop.speed) & self.opposes
        with np.errstate(invalid="ignore"):
            law = self.slip_law(hoop, clearly=True)
            each = self.in_region & self.all_forced & law & sliding
        clear = _sustained(each, self.length)
        # A friction above the rolling demand brakes a slide already going but starts none:
        # a clear stretch none of whose windows could start a slip is no slip (a saturating
        # friction short of the demand by less than the tolerance, then above it as the
        # demand falls: DART stock's rim creeps 6 mm/s at most, 0.3 mm).
        starts = each & self.could_start(hoop)
        # A friction short of the demand inside the cone starts a slip only where the slide
        # grows: one that lags a demand ramping up leaves the rim creeping at its speed
        # (Box2D stock: 4-6 % of the cone for 6 ms, the rim on at 3.8-4.5 mm/s).
        firm = each & self._clear_law(hoop, None)  # at the cone, rolling impossible, or fast
        speed = np.abs(self.mean_s)
        for first, stop in _runs(clear):
            span = slice(first, stop + self.length - 1)
            if not starts[span].any():
                clear[first:stop] = False
            elif not firm[span].any():
                k = first + int(np.argmax(starts[span]))
                grown = speed[k : span.stop].max() - speed[k]
                if grown < CLEAR * SLIP_THRESHOLD * hoop.speed:
                    clear[first:stop] = False
        return clear

    def could_start(self, hoop: Hoop) -> NDArray:
        """Windows whose friction clearly cannot give what rolling needs, or whose rim
        slides clearly fast: at the cone, the demand beyond its cone, the friction clearly
        short of the demand (not above it: that only brakes a slide), or fast."""
        return self._clear_law(hoop, self.shortfall)

    def _clear_law(self, hoop: Hoop, away: NDArray | None) -> NDArray:
        """Clearly under the slip law: at the cone, the demand beyond its cone, the rim
        clearly fast, or ``away`` (the friction's distance from the rolling demand as a share
        of the cone: :attr:`depart` either side, :attr:`shortfall` short of it only) beyond
        DEMAND_TOLERANCE even with a step's lag and the friction's scatter."""
        fast = FAST_SLIDE * hoop.speed * FAST_CLEAR
        with np.errstate(invalid="ignore"):
            law = (self.ratio >= 1 - CONE_CLEAR) | (np.abs(self.mean_s) >= fast)
            if self.demand is not None:
                law |= self.demand >= 1 + DEMAND_MARGIN
            if away is not None and self.lag is not None and self.noise is not None:
                slack = FOLLOW_MARGIN + self.lag + self.noise
                law |= away >= DEMAND_TOLERANCE + slack
        return law

    def clear_roll(self, hoop: Hoop) -> NDArray:
        """Clearly in no slip, sustained as :meth:`clear_slip`: in contact throughout, and the
        rim still (below STILL) or its friction clearly following the rolling demand
        (:meth:`follows_demand`: a creep at most)."""
        still = np.abs(self.mean_s) < STILL * hoop.speed
        each = self.in_region & self.all_forced & (still | self.follows_demand(hoop))
        return _sustained(each, self.length)

    def stick_outside(self, hoop: Hoop) -> NDArray:
        """Clearly stuck outside the cone, sustained as :meth:`clear_slip`."""
        still = np.abs(self.mean_s) < SLIP_THRESHOLD * hoop.speed / CLEAR
        with np.errstate(invalid="ignore"):
            each = self.in_region & self.all_forced & (self.ratio > 1 + CONE_OUTSIDE) & still
        return _sustained(each, self.length)

    def describe(self, k: int) -> str:
        demand = ""
        if self.demand is not None and self.follow is not None:
            demand = (
                f", rolling demand {self.demand[k]:.3f} of its cone, friction "
                f"{self.follow[k]:.3f} mu n from it"
            )
        return (
            f"|mean f| = {self.ratio[k]:.3f} mu n, mean slip velocity {1e3 * self.mean_s[k]:.3g} "
            f"mm/s{'' if self.opposes[k] else ' (not against the friction)'}, "
            f"{100 * self.steps_at_cone[k]:.0f} % of the steps at the cone{demand}"
        )


def _sustained(each: NDArray, m: int) -> NDArray:
    """Where ``each`` holds for m consecutive windows from here."""
    out = np.zeros(len(each), dtype=bool)
    for start, stop in _runs(each):
        if stop - start >= m:
            out[start : stop - m + 1] = True
    return out


def _first(mask: NDArray, times: NDArray) -> float | None:
    hits = np.nonzero(mask)[0]
    return float(times[hits[0]]) if hits.size else None


# ----------------------------------------------------------------------------- the checks
def contradictions(
    frame: pd.DataFrame,
    labels: Labels,
    exact: Exact,
    *,
    mu: float,
    hoop: Hoop | None = None,
    loose: LooseTolerances = DOCS_LOOSE,
) -> list[Contradiction]:
    """Every label of ``labels`` that the run's trajectory ``frame`` (a Trajectory's frame:
    t, clearance, slip_velocity, normal_force, friction_force, ...) clearly contradicts,
    for the pair's friction coefficient ``mu`` and the exact events ``exact``."""
    hoop = hoop if hoop is not None else Hoop()
    out: list[Contradiction] = []
    if labels.engine == "reference" and labels.verdict != "agrees":
        out.append(Contradiction(Kind.REFERENCE, f"the reference's row is {labels.verdict}"))
    if labels.says("diverged"):
        out += _diverged(frame, hoop)
    if labels.verdict in UNJUDGED or labels.status != "ok" or frame is None or len(frame) < 2:
        return out
    run = Run.from_frame(frame, mu, hoop)
    out += _hop_labels(run, labels, exact)
    hop = _engine_hop(run, labels, exact)
    region_end = exact.window_end if hop is None else min(exact.window_end, hop.t_start)
    windows = Windows.of(run, region_end)
    out += _slip_labels(run, windows, labels)
    out += _slip_phases(run, windows, labels)
    out += _chattering_phase(labels)
    out += _creep_labels(run, labels, exact)
    out += _cone_flag(run, windows, labels)
    if labels.verdict is None:  # no exact answer to judge against: the events only
        return out
    out += _hop_verdict(run, labels, exact, hop)
    out += _slip_verdict(run, windows, labels, exact)
    out += _beyond_loose(run, windows, labels, exact, hop, loose)
    out += _transitions(run, windows, labels, exact, loose)
    return out


def _diverged(frame: pd.DataFrame | None, hoop: Hoop) -> list[Contradiction]:
    """`diverged` is contradicted by a record that is finite throughout, gains at most half
    the divergence rule's energy rise (25 % of the initial energy) and penetrates at most
    half its depth (0.025 a): well inside the bounds the run is stopped for."""
    if frame is None or len(frame) < 2:
        return []
    values = frame[["X", "Y", "theta", "Xdot", "Ydot", "thetadot", "energy", "clearance"]]
    if not np.isfinite(values.to_numpy(float)).all():
        return []
    energy = frame["energy"].to_numpy(float)
    bounded = energy.max() <= 1.25 * energy[0] and frame["clearance"].min() >= -0.025 * hoop.a
    if not bounded:
        return []
    return [
        Contradiction(
            Kind.DIVERGED,
            f"diverged, but the record to {frame['t'].iloc[-1]:.4g} s is finite, its energy "
            f"at most {energy.max() / energy[0]:.3g} x the initial and its penetration "
            f"{-1e3 * min(0.0, frame['clearance'].min()):.3g} mm",
        )
    ]


def _flight_at(run: Run, t: float) -> Flight | None:
    """The flight starting at ``t`` (within the sample slack; a hop-sized one first, as a
    chatter step just before a lift-off may fall within the slack too)."""
    near = [fl for fl in run.flights if abs(fl.t_start - t) <= run.slack]
    near.sort(key=lambda fl: (not fl.maybe_hop(run.hoop), abs(fl.t_start - t)))
    return near[0] if near else None


def _in_window(run: Run, flight: Flight, exact: Exact) -> bool:
    return flight.t_start <= exact.window_end + run.slack


def _engine_hop(run: Run, labels: Labels, exact: Exact) -> Flight | None:
    """The run's hop as the labels name it (the flight at the row's t_lift), else its
    highest possible hop inside the exact window."""
    if labels.t_lift is not None:
        flight = _flight_at(run, labels.t_lift)
        if flight is not None and flight.maybe_hop(run.hoop):
            return flight
    hops = [fl for fl in run.flights if fl.maybe_hop(run.hoop) and _in_window(run, fl, exact)]
    return max(hops, key=lambda fl: fl.peak, default=None)


def _clear_hops(run: Run, exact: Exact) -> list[Flight]:
    return [fl for fl in run.flights if fl.clear_hop(run.hoop) and _in_window(run, fl, exact)]


def _hop_labels(run: Run, labels: Labels, exact: Exact) -> list[Contradiction]:
    """t_lift, hop_height and t_impact against the flights."""
    out: list[Contradiction] = []
    if labels.t_lift is None:
        clear = _clear_hops(run, exact)
        if clear:
            fl = clear[0]
            out.append(_hop_label(f"no lift-off read, but a {_flight_text(fl)}"))
        return out
    flight = _flight_at(run, labels.t_lift)
    if flight is None:
        return [_hop_label(f"lift-off read at {labels.t_lift:.4g} s, where no flight starts")]
    if not flight.maybe_hop(run.hoop):
        return [_hop_label(f"lift-off read at {labels.t_lift:.4g} s from a {_flight_text(flight)}")]
    h = labels.hop_height
    # 10 % and 0.2 mm: the peak between samples differs from the sampled one by far less.
    if h is not None and abs(h - flight.peak) > 0.1 * flight.peak + 2e-4 * run.hoop.length:
        out.append(_hop_label(f"hop height {_mm(h)} read from a {_flight_text(flight)}"))
    out += _impact_label(run, labels, flight)
    return out


def _impact_label(run: Run, labels: Labels, flight: Flight) -> list[Contradiction]:
    t = labels.t_impact
    if flight.t_end is None:
        if t is not None and t < run.t[-1] - run.slack:
            return [_hop_label(f"impact read at {t:.4g} s inside a flight that never lands")]
        if t is None and flight.landed:
            return [_hop_label(f"no impact read, but the flight is down at {run.t[-1]:.4g} s")]
        return []
    if t is None:
        return [_hop_label(f"no impact read, but the flight lands at {flight.t_end:.4g} s")]
    if abs(t - flight.t_end) > run.slack:
        return [_hop_label(f"impact read at {t:.4g} s, the flight lands at {flight.t_end:.4g} s")]
    return []


def _hop_label(text: str) -> Contradiction:
    return Contradiction(Kind.HOP_LABEL, text)


def _flight_text(fl: Flight) -> str:
    return f"flight from {fl.t_start:.4g} s lasting {1e3 * fl.duration:.3g} ms, peak {_mm(fl.peak)}"


def _mm(x: float) -> str:
    return f"{1e3 * x:.3g} mm"


def _hop_verdict(run: Run, labels: Labels, exact: Exact, hop: Flight | None) -> list[Contradiction]:
    """Each hop verdict or flag against the flights (``hop``: the run's hop, if any)."""
    out: list[Contradiction] = []
    clear = _clear_hops(run, exact)
    if labels.says("missed-hop") and clear:
        out.append(_hop_verdict_text("missed-hop", f"a {_flight_text(clear[0])}"))
    if labels.says("false-hop") and hop is None:
        out.append(_hop_verdict_text("false-hop", "no flight in the window is a hop"))
    if hop is None or exact.t_lift is None or exact.hop_height is None:
        return out
    # Each direction is denied when the run's hop is not beyond the exact value that way at
    # all (not by the loose tolerance: see _slip_verdict).
    denied = {
        "hop-too-low": hop.peak >= (1 - HEIGHT_SLACK) * exact.hop_height,
        "hop-too-high": hop.landed and hop.peak <= (1 + HEIGHT_SLACK) * exact.hop_height,
        "early-lift-off": hop.t_start >= exact.t_lift + run.slack,
        "late-lift-off": hop.t_start <= exact.t_lift - run.slack,
    }
    if hop.t_end is not None and exact.t_impact is not None:
        denied["early-impact"] = hop.t_end >= exact.t_impact + run.slack
        denied["late-impact"] = hop.t_end <= exact.t_impact - run.slack
    for label, no in denied.items():
        if no and labels.says(label):
            out.append(_hop_verdict_text(label, f"{_flight_text(hop)}; exact {_exact_hop(exact)}"))
    return out


def _hop_verdict_text(label: str, text: str) -> Contradiction:
    return Contradiction(Kind.HOP_VERDICT, f"{label}, but {text}")


def _exact_hop(exact: Exact) -> str:
    impact = "-" if exact.t_impact is None else f"{exact.t_impact:.4g} s"
    return f"lift-off {exact.t_lift:.4g} s, impact {impact}, peak {_mm(exact.hop_height or 0.0)}"


def _slip_labels(run: Run, windows: Windows, labels: Labels) -> list[Contradiction]:
    """The row's first slip onset against the averaged friction and slip velocity. An
    onset is contradicted when no window starting within two windows of it shows a slip:
    one window for where a reading places its window (before, around or after the onset),
    one for its length ("a few ms": up to twice ours)."""
    maybe = windows.maybe_slip(run.hoop, soon=True)
    t_clear = _first(windows.clear_slip(run.hoop), windows.start)
    reach = 2 * WINDOW * run.hoop.duration + run.slack
    if labels.t_slip is None:
        if t_clear is None:
            return []
        k = int(np.searchsorted(windows.start, t_clear))
        return [_unread_slip(run, windows, k, f"no slip read, but from {t_clear:.4g} s")]
    near = np.abs(windows.start - labels.t_slip) <= reach
    if near.any() and not (maybe & near).any():
        k = min(int(np.searchsorted(windows.start, labels.t_slip)), len(windows.start) - 1)
        return [_not_a_slip(run, windows, k, labels.t_slip)]
    if t_clear is not None and labels.t_slip > t_clear + reach:
        k = int(np.searchsorted(windows.start, t_clear))
        text = f"first slip read at {labels.t_slip:.4g} s, but from {t_clear:.4g} s"
        return [_unread_slip(run, windows, k, text)]
    return []


def _unread_slip(run: Run, windows: Windows, k: int, text: str) -> Contradiction:
    """A clear slip from window k that the row does not read: at the cone (or where rolling
    cannot go on) it is a slip-label contradiction; inside the cone (fast, or friction away
    from the rolling demand) a slide read as roll."""
    with np.errstate(invalid="ignore"):
        at_cone = windows.ratio[k] >= 1 - CONE_CLEAR or (
            windows.demand is not None and windows.demand[k] >= 1 + DEMAND_MARGIN
        )
    kind = Kind.SLIP_LABEL if at_cone else Kind.SLIDE_AS_ROLL
    return Contradiction(kind, f"{text} {windows.describe(k)}")


def _not_a_slip(run: Run, windows: Windows, k: int, t_slip: float) -> Contradiction:
    """Which kind of no-slip the windows at a read onset show."""
    text = f"slip read at {t_slip:.4g} s: {windows.describe(k)}"
    if not np.isfinite(windows.ratio[k]):
        return Contradiction(Kind.NO_SLIP_AS_SLIP, f"{text} (almost no normal force)")
    chatter = windows.steps_at_cone[k] >= CHATTER_SHARE
    if not windows.slides_soon(run.hoop)[k]:
        kind = Kind.STICK_AS_SLIP if windows.ratio[k] >= 1.0 else Kind.NO_SLIP_AS_SLIP
    elif chatter:
        kind = Kind.CHATTER_AS_SLIP
    else:
        kind = Kind.CREEP_AS_SLIP if windows.follows_demand(run.hoop)[k] else Kind.NO_SLIP_AS_SLIP
    return Contradiction(kind, text)


# ----------------------------------------------------------------------------- the phases
MOTION_CODES = frozenset({"R", "S+", "S-", "F"})
"""The phase codes of the motion: chattering is a property of a phase, never one."""


def _chattering_phase(labels: Labels) -> list[Contradiction]:
    other = sorted({c for c in labels.phases or () if c not in MOTION_CODES})
    if not other:
        return []
    phases = " ".join(labels.phases or ())
    return [Contradiction(Kind.CHATTER_PHASE, f"phases {phases} hold {' '.join(other)}")]


def _direction(windows: Windows) -> NDArray:
    """+1 or -1 per window: the direction a slip there would slide (opposite the friction)."""
    return -windows.friction_sign.astype(int)


def _stretches(mask: NDArray, sign: NDArray) -> list[tuple[int, int, int]]:
    """(first, stop, direction) of each run of ``mask`` with one direction."""
    out = []
    for start, stop in _runs(mask):
        edges = np.nonzero(np.diff(sign[start:stop]))[0] + 1 + start
        bounds = [start, *edges.tolist(), stop]
        out += [(int(i), int(j), int(sign[i])) for i, j in itertools.pairwise(bounds)]
    return out


def _clear_slips(run: Run, windows: Windows) -> list[tuple[int, int, int]]:
    """The run's clear slips: stretches of clear slip windows of one direction, joined
    across any gap that holds no clear roll, clear flight or clear slip the other way (the
    reading may hold one slip across it). Each needs a slip phase of its own."""
    clear = windows.clear_slip(run.hoop)
    split = windows.clear_roll(run.hoop) | _clear_flight(run, windows)
    joined: list[tuple[int, int, int]] = []
    for first, stop, sign in _stretches(clear, _direction(windows)):
        if joined and joined[-1][2] == sign and not split[joined[-1][1] : first].any():
            joined[-1] = (joined[-1][0], stop, sign)
        else:
            joined.append((first, stop, sign))
    return joined


def _most_slips(run: Run, windows: Windows) -> dict[int, int]:
    """How many slip phases of each direction the run can hold at most. A slip phase needs a
    stretch that may be a slip (not clearly still, friction not clearly off the slip law:
    :meth:`Windows.maybe_slip` with ``soon``, over the whole record), and two slips one way
    need a phase between them that is no slip: a window that clearly is none, or a part of
    one such stretch that is not clearly a slip (each such part, however short, counted as
    room for one more slip)."""
    hoop = run.hoop
    law = windows.slip_law(hoop, clearly=False) & windows.slides_soon(hoop)
    clear = windows.clear_slip(hoop)
    most = {1: 0, -1: 0}
    for first, stop, sign in _stretches(law, _direction(windows)):
        if sign:  # no mean friction: no direction to slide against
            most[sign] += 1 + len(_runs(~clear[first:stop]))
    return most


def _slip_phases(run: Run, windows: Windows, labels: Labels) -> list[Contradiction]:
    """The row's slip phases of each direction against the run's: no more than the run can
    hold (:func:`_most_slips`), no fewer than it has clear slips (:func:`_clear_slips`). A
    row that reads no slip at all is :func:`_slip_labels`'s."""
    if labels.phases is None or labels.t_slip is None:
        return []
    slips_read = {1: labels.phases.count("S+"), -1: labels.phases.count("S-")}
    most = _most_slips(run, windows)
    out = []
    phases = " ".join(labels.phases)
    for sign, read in slips_read.items():
        at_most = most[sign]
        if read > at_most:
            text = (
                f"phases {phases} read {read} slips towards {sign:+d}, but the run can hold at "
                f"most {at_most} that way"
            )
            out.append(Contradiction(Kind.SLIP_PHASES, text))
    for sign, read in slips_read.items():
        clear = [first for first, _, d in _clear_slips(run, windows) if d == sign]
        if len(clear) > read:
            k = clear[read] if read < len(clear) else clear[-1]
            starts = ", ".join(f"{windows.start[i]:.4g}" for i in clear)
            text = (
                f"phases {phases} read {read} slips towards {sign:+d}, but the run clearly slips "
                f"that way {len(clear)} times, from {starts} s; from {windows.start[k]:.4g} s"
            )
            out.append(_unread_slip(run, windows, k, text))
    return out


def _clear_flight(run: Run, windows: Windows) -> NDArray:
    """Windows inside a clear hop's flight throughout."""
    inside = np.zeros(len(run.t), dtype=bool)
    for flight in run.flights:
        if flight.clear_hop(run.hoop):
            end = math.inf if flight.t_end is None else flight.t_end
            inside |= (run.t >= flight.t_start) & (run.t < end) & ~run.touching
    c = np.concatenate(([0], np.cumsum(inside)))
    m = windows.length
    return (c[m:] - c[:-m])[: len(windows.start)] == m


def _creep_labels(run: Run, labels: Labels, exact: Exact) -> list[Contradiction]:
    """Creep read faster than FAST_SLIDE (clearly: FAST_CLEAR times it), or farther than the
    rim slides in all its contact before the exact lift-off (and inside the exact window)."""
    out = []
    speed = labels.creep_max_speed
    fast = FAST_CLEAR * FAST_SLIDE * run.hoop.speed
    if speed is not None and speed > fast:
        text = f"creep read up to {speed:.3g} m/s: faster than {fast:.3g} m/s is never creep"
        out.append(Contradiction(Kind.CREEP_LABEL, text))
    distance = labels.creep_distance
    if distance is None or distance <= 0:
        return out
    step = np.diff(run.t, append=run.t[-1])
    end = min(exact.contact_end, exact.window_end) + run.slack
    where = run.touching & (run.t <= end)
    slid = float(np.sum((step * np.abs(run.s))[where]))
    # 5 % and 0.1 mm: the row sums the same samples' steps, maybe with a few more at an edge.
    if distance > 1.05 * slid + 1e-4 * run.hoop.length:
        text = (
            f"creep read over {_mm(distance)}, but the rim slides {_mm(slid)} in all its "
            f"contact up to {end:.4g} s (the exact lift-off or window end)"
        )
        out.append(Contradiction(Kind.CREEP_LABEL, text))
    return out


# ----------------------------------------------------------------------------- transitions
def _run_modes(run: Run, windows: Windows) -> NDArray:
    """Per window, the phase the run is clearly in over it and the windows after it (the
    masks are sustained: WINDOW of windows, 2 x WINDOW of samples): R, S+, S-, F, or ""."""
    modes = np.full(len(windows.start), "", dtype=object)
    modes[windows.clear_roll(run.hoop)] = "R"
    slip = windows.clear_slip(run.hoop)
    direction = _direction(windows)
    modes[slip & (direction > 0)] = "S+"
    modes[slip & (direction < 0)] = "S-"
    modes[_sustained(_clear_flight(run, windows), windows.length)] = "F"
    return modes


def _transitions(
    run: Run, windows: Windows, labels: Labels, exact: Exact, loose: LooseTolerances
) -> list[Contradiction]:
    """An agrees or close row claims the run's phases are the exact ones (as read at its
    timestep) with every transition within its loose tolerance. Then wherever the exact
    solution is inside one phase, farther than the loose tolerance from each of its
    transitions, the run is in that same phase: were it in another, the transition into the
    exact phase would be late (the run's phase an earlier one) or the one out of it early (a
    later one) by more than the tolerance. So a stretch where the run is clearly in another
    phase (:func:`_run_modes`, two windows long, all of it inside that part of the exact
    phase) contradicts the row. The last PHASE_END of the record is left out (the phase
    rule lets a last phase differ there); so is an unseen exact slip (a reading absorbs it).
    """
    if labels.verdict not in AGREEING or not exact.phases:
        return []
    tolerance = {
        Tolerance.SLIP: _time_tolerance(run, loose.slip_s, loose),
        Tolerance.LIFT: _time_tolerance(run, loose.lift_s, loose),
        Tolerance.IMPACT: _time_tolerance(run, loose.impact_s, loose),
    }
    transitions = exact.transitions()
    modes = _run_modes(run, windows)
    span = run.t[np.minimum(np.arange(len(modes)) + 2 * windows.length - 2, len(run.t) - 1)]
    record_end = float(run.t[-1]) - PHASE_END * run.hoop.duration
    out = []
    for k, phase in enumerate(exact.phases):
        if not phase.seen:
            continue
        lo = phase.t_start + (tolerance[transitions[k - 1][1]] if k else 0.0)
        later = [tolerance[kind] for t, kind in transitions[k:] if t > phase.t_start]
        hi = min(phase.t_end - max(later, default=0.0), record_end)
        inside = (windows.start >= lo) & (span <= hi)
        other = inside & (modes != "") & (modes != phase.code)
        if other.any():
            i = int(np.nonzero(other)[0][0])
            out.append(_transition_text(exact, k, windows, i, str(modes[i]), labels, lo, hi))
    return out


def _transition_text(
    exact: Exact, k: int, windows: Windows, i: int, mode: str, labels: Labels, lo: float, hi: float
) -> Contradiction:
    phase, t = exact.phases[k], float(windows.start[i])
    before = exact.phases[k - 1].code if k else None
    after = exact.phases[k + 1].code if k + 1 < len(exact.phases) else None
    if mode == before:
        which = f"the transition into {phase.code} at {phase.t_start:.4g} s is over " + (
            f"{1e3 * (t - phase.t_start):.0f} ms late"
        )
    elif mode == after:
        which = f"the transition into {mode} at {phase.t_end:.4g} s is over " + (
            f"{1e3 * (phase.t_end - t):.0f} ms early"
        )
    else:
        which = "the phases differ"
    return Contradiction(
        Kind.TRANSITION,
        f"{labels.verdict}, but from {t:.4g} s the run is clearly {mode} ({windows.describe(i)}) "
        f"inside the exact {phase.code} phase {phase.t_start:.4g}-{phase.t_end:.4g} s "
        f"(timed {lo:.4g}-{hi:.4g} s): {which}",
    )


def _cone_flag(run: Run, windows: Windows, labels: Labels) -> list[Contradiction]:
    if labels.verdict is None or labels.verdict in UNJUDGED:
        return []
    stuck = windows.stick_outside(run.hoop)
    if stuck.any() and not labels.says("cone-violation"):
        k = int(np.nonzero(stuck)[0][0])
        text = f"no cone-violation, but from {windows.start[k]:.4g} s {windows.describe(k)}"
        return [Contradiction(Kind.CONE_FLAG, text)]
    with np.errstate(invalid="ignore"):
        above = windows.in_region & (windows.ratio > 1 + CONE_CLEAR)
    if labels.says("cone-violation") and not above.any():
        return [Contradiction(Kind.CONE_FLAG, "cone-violation, but no window is above the cone")]
    return []


def _slip_verdict(run: Run, windows: Windows, labels: Labels, exact: Exact) -> list[Contradiction]:
    """false-slip, missed-slip, early-slip and late-slip against the windows."""
    w = WINDOW * run.hoop.duration
    maybe = windows.maybe_slip(run.hoop)
    t_loose = _first(maybe, windows.start)
    t_clear = _first(windows.clear_slip(run.hoop), windows.start)
    out: list[Contradiction] = []

    def deny(label: str, text: str) -> None:
        if labels.says(label):
            out.append(Contradiction(Kind.SLIP_VERDICT, f"{label}, but {text}"))

    if t_loose is None:
        deny("false-slip", "the averaged friction never reaches the cone while sliding")
    if t_clear is not None:
        deny("missed-slip", f"from {t_clear:.4g} s the run clearly slips")
    t0 = exact.t_slip
    if t0 is not None:
        # A canonical onset lies no earlier than a window before the first window showing a
        # slip, and no later than a window after the first clear slip. A failure label is
        # denied only when the onset is not that way at all: how far it must be (the loose
        # tolerance) is the table's, and a check that assumed a wider one than the table's
        # would deny true labels.
        if t_loose is None or t_loose - w >= t0 + run.slack:
            when = "never" if t_loose is None else f"only from {t_loose:.4g} s"
            deny("early-slip", f"the averaged friction reaches the cone {when} (exact {t0:.4g} s)")
        if t_clear is not None and t_clear + w <= t0 - run.slack:
            deny("late-slip", f"the run clearly slips from {t_clear:.4g} s (exact {t0:.4g} s)")
    return out


FLAGS_OF: Mapping[str, frozenset[str]] = {
    "hop": frozenset({"missed-hop", "false-hop"}),
    "lift-off": frozenset({"early-lift-off", "late-lift-off"}),
    "impact": frozenset({"early-impact", "late-impact"}),
    "height": frozenset({"hop-too-low", "hop-too-high"}),
    "slip": frozenset({"missed-slip", "false-slip", "early-slip", "late-slip"}),
}
"""The failure labels of each event: a row with an event clearly beyond the loose tolerance
lists one of them (verdict_flags lists every failed check)."""
_HOP_DETAILS = ("lift-off", "impact", "height")


def _beyond_loose(
    run: Run,
    windows: Windows,
    labels: Labels,
    exact: Exact,
    hop: Flight | None,
    loose: LooseTolerances,
) -> list[Contradiction]:
    """Events clearly beyond the loose tolerances: no row with one is `agrees` or `close`,
    and a failing row lists a failure of that event among its flags. (Where the row fails
    the hop's outcome, its lift-off, impact and height are not compared.)"""
    found = _hop_beyond(run, exact, hop, loose) + _slip_beyond(run, windows, exact, loose)
    said = labels.flags | {labels.verdict or ""}
    no_hop_compare = bool(said & FLAGS_OF["hop"])
    out = []
    for event, text in found:
        if labels.verdict in AGREEING:
            out.append(Contradiction(Kind.TOLERANCE, f"{labels.verdict}, but {text}"))
        elif not said & FLAGS_OF[event] and not (no_hop_compare and event in _HOP_DETAILS):
            flags = " ".join(sorted(labels.flags)) or "none"
            out.append(Contradiction(Kind.MISSING_FLAG, f"flags {flags}, but {text}"))
    return out


Finding = tuple[str, str]
"""(the event, a FLAGS_OF key; what is beyond the tolerance)."""


def _time_tolerance(run: Run, seconds: float, loose: LooseTolerances) -> float:
    """s: a loose time tolerance on the run's hoop with its timestep slack and the detection
    floor, widened by the checker's own sample slack."""
    floor = FLOOR_SLACK * run.hoop.duration + run.dt
    return seconds * run.hoop.duration + loose.steps * run.dt + floor + run.slack


def _hop_beyond(
    run: Run, exact: Exact, hop: Flight | None, loose: LooseTolerances
) -> list[Finding]:
    """How the run's hop is clearly beyond the loose tolerances of the exact one."""
    if exact.hop_unresolved:
        return []
    if exact.t_lift is None or exact.hop_height is None:
        clear = _clear_hops(run, exact)
        text = f"a {_flight_text(clear[0])} where the exact run stays down" if clear else ""
        return [("hop", text)] if clear else []
    if hop is None:
        return [("hop", f"no flight in the window is a hop (exact {_exact_hop(exact)})")]
    out = []
    if abs(hop.t_start - exact.t_lift) > _time_tolerance(run, loose.lift_s, loose):
        out.append(("lift-off", f"lift-off at {hop.t_start:.4g} s (exact {exact.t_lift:.4g} s)"))
    impact = exact.t_impact
    tol = _time_tolerance(run, loose.impact_s, loose)
    if hop.t_end is not None and impact is not None and abs(hop.t_end - impact) > tol:
        out.append(("impact", f"impact at {hop.t_end:.4g} s (exact {impact:.4g} s)"))
    ratio = hop.peak / exact.hop_height
    # A record ending in the air has not reached its height: only too high can be told.
    low = hop.landed and not exact.peak_after_record and ratio < loose.height_low - HEIGHT_SLACK
    if low or ratio > loose.height_high + HEIGHT_SLACK:
        out.append(("height", f"hop peak {_mm(hop.peak)} against {_mm(exact.hop_height)}"))
    return out


def _slip_beyond(run: Run, windows: Windows, exact: Exact, loose: LooseTolerances) -> list[Finding]:
    """How the run's first slip onset is clearly beyond the loose tolerance of the exact
    one: its bounds (see _slip_verdict) lie outside it."""
    w = WINDOW * run.hoop.duration
    t_loose = _first(windows.maybe_slip(run.hoop), windows.start)
    t_clear = _first(windows.clear_slip(run.hoop), windows.start)
    t0 = exact.t_slip
    if t0 is None:
        if not exact.slips and t_clear is not None:
            return [
                ("slip", f"it clearly slips from {t_clear:.4g} s where the exact run never slips")
            ]
        return []
    tol = _time_tolerance(run, loose.slip_s, loose)
    if t_loose is None:
        return [("slip", f"the run never slips (exact slip onset {t0:.4g} s)")]
    if t_loose - w > t0 + tol:
        late = f"only from {t_loose:.4g} s (exact {t0:.4g} s)"
        return [("slip", f"its averaged friction reaches the cone {late}")]
    if t_clear is not None and t_clear + w < t0 - tol:
        return [("slip", f"it clearly slips from {t_clear:.4g} s (exact {t0:.4g} s)")]
    return []
