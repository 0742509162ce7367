"""The verdict on one run: did the engine do what the exact solution does, and if not, what
went wrong?

Pure functions on plain values: :func:`classify` reads one row of the runs table (a mapping
with the row's column names; a stored row, with NaN for a missing number, works as well as a
fresh one) and returns a :class:`Judgement`; :func:`verdict_columns` gives the row's
``verdict``, ``outcome_agrees``, ``verdict_flags`` and ``verdict_reason`` from it.

**Which reading.** A row carries two readings of the engine's events: from its clearance and
slip velocity (engines/judging/detectors.py) and from its contact force
(engines/judging/contact.py). The verdict reads the contact where the row has it, and the
clearance only for rows stored before it (:func:`engine_reading`). Why: the events are
defined by the contact force (a lift-off is where the normal force ends, a slip where
friction reaches the cone), and the kinematic reading confuses with them what an engine's
contact does around them: a hoop resting 0.4 mm deep crosses zero clearance 40 ms after its
force ended, a single step without contact force carries a slip-velocity spike, and a soft
contact creeps long before its friction saturates (docs/report.md gives the measured cases).

**Outcome classes.** The exact outcome and the engine's are compared as classes: roll, slip,
hop (``hops`` and ``lifts-at-start``) and, for the exact side only, Painlevé. An engine hops
if it has a flight above the hop threshold (``DetectorSettings.hop_clearance``, 1 mm on the
1 m hoop) lasting 5 ms inside the exact window; the hop is the highest such flight, not the
first. It slips if its friction saturated (or, read by the clearance, its slip velocity
crossed the slip threshold).

**The checks**, in this order; the primary verdict is the first that fails, and every failed
check is a flag:

- the class: ``false-hop``, ``missed-hop`` (no flight above the threshold inside the exact
  window), ``missed-slip``, ``false-slip``;
- where both hop: the height within a factor HOP_HEIGHT_FACTOR (2) of the exact one
  (``hop-too-low``, ``hop-too-high``; a run that ends in the air can only be too high) and
  the lift-off within LIFT_TIME_TOLERANCE (50 ms) of the exact one (``early-lift-off``,
  ``late-lift-off``);
- where both slip: the first slip onset within SLIP_TIME_TOLERANCE (10 ms) of the exact one
  (``early-slip``, ``late-slip``);
- the phase sequence (``wrong-phases``; the reason names the first phase that differs).

``outcome_agrees`` is true when no class, height or lift-off check failed; ``agrees``
requires every check. The sizes are stated for the catalogue's 1 m hoop and carried to the
row's hoop as the detectors' are (``hoop_scale``): lengths with a, times with sqrt(a / g). A
row without ``a`` (or ``g``) is judged for a = 1 m (g = 9.8 m/s^2).

- **Painlevé.** The exact solution reaches a point where no consistent contact force exists
  (D = 0 while slipping) at ``exact_t_painleve``, and the rigid model says nothing after it;
  a compliant contact resolves it somehow (an impulsive normal force, a lift-off, a stick).
  So the engine agrees unless it contradicts the part the model does predict: a lift-off
  more than 50 ms before the Painlevé point is a false hop, and a run that never slips where
  the exact one slipped first is a missed slip. Its phases are compared up to that point:
  the engine's sequence must begin with the exact one.
- **lifts-at-start** (the normal force is negative at t = 0) is a hop whose lift-off is at
  t = 0.
- ``degenerate`` and ``error`` exact outcomes, exact hops below the hop threshold and exact
  slips below the slip threshold are no answer to judge against: the verdict and
  ``outcome_agrees`` are empty (None).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.detectors import DetectorSettings, hoop_scale
from hoopbench.engines.run import RunStatus
from hoopbench.models.events import Events, Outcome

__all__ = [
    "HOP_CLEARANCE",
    "HOP_HEIGHT_FACTOR",
    "LIFT_TIME_TOLERANCE",
    "OUTCOME_FAILURES",
    "SLIP_TIME_TOLERANCE",
    "EngineReading",
    "HoopThresholds",
    "Judgement",
    "Verdict",
    "classify",
    "counts_as_hop",
    "engine_reading",
    "hoop_thresholds",
    "hop_matches",
    "number_or_none",
    "painleve_time",
    "phases_agree",
    "row_phases_agree",
    "verdict_columns",
]

HOP_CLEARANCE = DetectorSettings().hop_clearance
"""The hop threshold of the 1 m hoop, m: read from its one home,
``DetectorSettings.hop_clearance``; :func:`hoop_thresholds` carries it to a row's hoop."""

HOP_HEIGHT_FACTOR = 2.0
"""An engine's hop agrees in size when its height is within this factor of the exact one
(the issue's rule): wide enough for a soft contact's energy loss on a marginal hop (MuJoCo's
hop-low, -26 %), narrow enough that a hop of another kind (a few mm against a metre) fails."""

LIFT_TIME_TOLERANCE = 0.05
"""s: how far an engine's lift-off may be from the exact one on the 1 m hoop (the issue's
rule), about a twentieth of the hop scenes' flight times (0.5-1 s); it scales with the
flight times, as sqrt(a / g)."""


SLIP_TIME_TOLERANCE = 0.01
"""s: how far an engine's first slip onset may be from the exact one on the 1 m hoop (the
issue's rule); it scales as sqrt(a / g). The exact onsets of the catalogue are read within
0.5 ms by both readings, so 10 ms is the engine's error, never the harness's."""


class Verdict(StrEnum):
    """What went wrong in a run: the primary verdict is the first in this order; every check
    that fails is also a flag (the row's ``verdict_flags``). See the module docstring."""

    AGREES = "agrees"
    """The reference's outcome class, its hop's size and time, its slip onset and its phase
    sequence."""
    FALSE_HOP = "false-hop"
    """A hop above the threshold where the reference has none (or, on a Painlevé scene, one
    that leaves more than 50 ms before the Painlevé point)."""
    MISSED_HOP = "missed-hop"
    """The reference hops and the engine has no flight above the hop threshold inside the
    exact window."""
    HOP_TOO_LOW = "hop-too-low"
    """Both hop; the engine's hop is lower than the exact one by more than the factor 2."""
    HOP_TOO_HIGH = "hop-too-high"
    """Both hop; the engine's hop is higher than the exact one by more than the factor 2."""
    EARLY_LIFT_OFF = "early-lift-off"
    """Both hop; the engine leaves more than 50 ms (scaled) before the exact lift-off."""
    LATE_LIFT_OFF = "late-lift-off"
    """Both hop; the engine leaves more than 50 ms (scaled) after the exact lift-off."""
    MISSED_SLIP = "missed-slip"
    """The reference slips (and does not hop) and the engine only rolls."""
    FALSE_SLIP = "false-slip"
    """The reference rolls throughout and the engine slips (without a hop)."""
    EARLY_SLIP = "early-slip"
    """Both slip; the engine's first slip starts more than 10 ms (scaled) early."""
    LATE_SLIP = "late-slip"
    """Both slip; the engine's first slip starts more than 10 ms (scaled) late."""
    WRONG_PHASES = "wrong-phases"
    """Everything above agrees; the phase sequence does not."""
    DIVERGED = "diverged"
    """The run stopped early: NaN, runaway energy or deep penetration."""
    FAILED = "failed"
    """The run gave no result: error, timeout, crashed or unavailable."""


OUTCOME_FAILURES = frozenset(
    {
        Verdict.FALSE_HOP,
        Verdict.MISSED_HOP,
        Verdict.HOP_TOO_LOW,
        Verdict.HOP_TOO_HIGH,
        Verdict.EARLY_LIFT_OFF,
        Verdict.LATE_LIFT_OFF,
        Verdict.MISSED_SLIP,
        Verdict.FALSE_SLIP,
    }
)
"""The failures of the outcome (its class, its hop's size and time): ``outcome_agrees`` is
true when none of them is flagged."""


class _Class(StrEnum):
    ROLL = "roll"
    SLIP = "slip"
    HOP = "hop"
    PAINLEVE = "painleve"


_HOP_OUTCOMES = (str(Outcome.HOPS), str(Outcome.LIFTS_AT_START))
_NO_ANSWER = (str(Outcome.DEGENERATE), str(Outcome.ERROR))


@dataclass(frozen=True)
class Judgement:
    """A run's verdict, whether its outcome agrees, and a line saying why."""

    verdict: Verdict | None
    outcome_agrees: bool | None
    reason: str
    flags: tuple[Verdict, ...] = ()
    """Every check that failed, the primary verdict first (empty for agrees)."""


@dataclass(frozen=True)
class EngineReading:
    """The engine's events as the verdict reads them: from the contact force where the row
    has the contact reading (engines/judging/contact.py), else from the clearance and slip
    velocity (rows stored before it)."""

    source: str
    """'contact' or 'clearance'."""
    t_slip: float | None
    t_lift: float | None
    hop_height: float | None
    phases: str | None
    t_last_phase: float | None
    t_impact: float | None = None
    """None: the run ended in the air (its window ends before the landing)."""


def engine_reading(row: Mapping[str, Any]) -> EngineReading:
    """The reading the verdict uses for ``row`` (see :class:`EngineReading`)."""
    if _text(row.get(Col.CONTACT_PHASES)) is not None:
        return EngineReading(
            "contact",
            number_or_none(row.get(Col.CONTACT_T_SLIP)),
            number_or_none(row.get(Col.CONTACT_T_LIFT)),
            number_or_none(row.get(Col.CONTACT_HOP_HEIGHT)),
            _text(row.get(Col.CONTACT_PHASES)),
            number_or_none(row.get(Col.CONTACT_T_LAST_PHASE)),
            number_or_none(row.get(Col.CONTACT_T_IMPACT)),
        )
    return EngineReading(
        "clearance",
        number_or_none(row.get(Col.T_SLIP)),
        number_or_none(row.get(Col.T_LIFT)),
        number_or_none(row.get(Col.HOP_HEIGHT)),
        _text(row.get(Col.PHASES)),
        number_or_none(row.get(Col.T_LAST_PHASE)),
        number_or_none(row.get(Col.T_IMPACT)),
    )


def number_or_none(value: Any) -> float | None:
    """A float, or None for a missing value (None, NaN, pandas' NA)."""
    if value is None or isinstance(value, str):
        return None
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return None if math.isnan(number) else number


def _text(value: Any) -> str | None:
    return value if isinstance(value, str) else None


@dataclass(frozen=True)
class HoopThresholds:
    """The verdict's sizes, carried to one hoop."""

    hop_clearance: float
    """m: a lift-off must rise above this to be a hop."""
    lift_time_tolerance: float
    """s: how far a hop's lift-off may be from the exact one."""
    slip_threshold: float
    """m/s: the detectors' slip threshold; an exact slip slower than this is invisible."""
    slip_time_tolerance: float
    """s: how far a first slip onset may be from the exact one."""


def hoop_thresholds(a: Any = None, g: Any = None) -> HoopThresholds:
    """HOP_CLEARANCE, LIFT_TIME_TOLERANCE and the detectors' slip threshold for a hoop of
    radius ``a`` (m) under ``g`` (m/s^2), the 1 m hoop's where either is missing."""
    base = DetectorSettings()
    a, g = number_or_none(a) or base.a, number_or_none(g) or base.g
    length, speed, duration = hoop_scale(a, g, base.a, base.g)
    return HoopThresholds(
        length * HOP_CLEARANCE,
        duration * LIFT_TIME_TOLERANCE,
        speed * base.slip_threshold,
        duration * SLIP_TIME_TOLERANCE,
    )


def _row_thresholds(row: Mapping[str, Any]) -> HoopThresholds:
    return hoop_thresholds(row.get(Col.A), row.get(Col.G))


def counts_as_hop(
    hop_height: float | None,
    max_clearance: float | None = None,
    threshold: float = HOP_CLEARANCE,
) -> bool:
    """Whether a detected lift-off is a hop: its height (or, where that was withheld, the
    run's largest clearance) exceeds ``threshold`` (m; the 1 m hoop's HOP_CLEARANCE unless
    given). With neither known, the detectors' word stands."""
    size = number_or_none(hop_height)
    size = number_or_none(max_clearance) if size is None else size
    return size is None or size > threshold


def hop_matches(
    hop_height: float | None,
    t_lift: float | None,
    exact_hop_height: float | None,
    exact_t_lift: float | None,
    tolerance: float = LIFT_TIME_TOLERANCE,
) -> bool:
    """Whether an engine's hop is the exact one: height within HOP_HEIGHT_FACTOR, lift-off
    within ``tolerance`` (s; the 1 m hoop's LIFT_TIME_TOLERANCE unless given). False where
    any of the four numbers is missing."""
    h, t, h0, t0 = (number_or_none(v) for v in (hop_height, t_lift, exact_hop_height, exact_t_lift))
    if h is None or t is None or h0 is None or t0 is None or h0 <= 0:
        return False
    return h0 / HOP_HEIGHT_FACTOR <= h <= h0 * HOP_HEIGHT_FACTOR and abs(t - t0) <= tolerance


def painleve_time(exact: Events) -> float | None:
    """When the exact solution reached its Painlevé point, s (None for other outcomes): the
    solver's ``t_painleve``, else the end of its last phase (a slip that starts at D <= 0),
    else 0 (D <= 0 at the start)."""
    if exact.outcome is not Outcome.PAINLEVE:
        return None
    t = exact.extra.get("t_painleve")
    if isinstance(t, int | float):
        return float(t)
    return exact.phases[-1].t_end if exact.phases else 0.0


def _engine_class(row: Mapping[str, Any]) -> _Class | None:
    outcome = _text(row.get(Col.OUTCOME))
    if outcome is None:
        return None
    reading = engine_reading(row)
    if reading.source == "contact":
        hops = reading.t_lift is not None  # a contact hop is above the hop threshold
    else:
        threshold = _row_thresholds(row).hop_clearance
        hops = outcome in _HOP_OUTCOMES and counts_as_hop(
            row.get(Col.HOP_HEIGHT), row.get(Col.MAX_CLEARANCE), threshold
        )
    if hops:
        return _Class.HOP
    if outcome == str(Outcome.PAINLEVE):
        return _Class.PAINLEVE
    if reading.t_slip is not None or (reading.source != "contact" and outcome == Outcome.SLIPS):
        return _Class.SLIP
    return _Class.ROLL


def _exact_class(outcome: str) -> _Class:
    if outcome in _HOP_OUTCOMES:
        return _Class.HOP
    if outcome == str(Outcome.PAINLEVE):
        return _Class.PAINLEVE
    return _Class.SLIP if outcome == str(Outcome.SLIPS) else _Class.ROLL


def phases_agree(
    phases: Any,
    exact_phases: Any,
    *,
    prefix: bool = False,
    t_last: Any = None,
    exact_t_last: Any = None,
    t_final: Any = None,
    tolerance: float = LIFT_TIME_TOLERANCE,
) -> bool | None:
    """Whether the phase codes agree (None if either is missing); with ``prefix``, the
    engine's sequence need only begin with the exact one.

    At the window's end the two may differ by one last phase: the exact solution re-sticks
    at 2.996 s of a 3 s window and the engine 10 ms later, past its last sample. So a
    sequence that is the other's plus one last phase agrees when that phase starts within
    ``tolerance`` (the lift-off tolerance, s) of ``t_final``, the run's last sample (s);
    ``t_last`` and ``exact_t_last`` are the start times of the engine's and the exact last
    phases.
    """
    code, exact = _text(phases), _text(exact_phases)
    if code is None or exact is None:
        return None
    tokens, expected = code.split(), exact.split()
    if (tokens[: len(expected)] == expected) if prefix else (tokens == expected):
        return True
    end = number_or_none(t_final)
    if end is None:
        return False
    if len(tokens) == len(expected) + 1 and tokens[:-1] == expected:
        start = number_or_none(t_last)
    elif len(expected) == len(tokens) + 1 and expected[:-1] == tokens:
        start = number_or_none(exact_t_last)
    else:
        return False
    return start is not None and end - start <= tolerance


def row_phases_agree(row: Mapping[str, Any]) -> bool | None:
    """:func:`phases_agree` on a row's columns, read as the verdict reads them
    (:func:`engine_reading`): a prefix where the exact solution reaches a Painlevé point, the
    lift-off tolerance carried to the row's hoop."""
    outcome = _text(row.get(Col.EXACT_OUTCOME))
    reading = engine_reading(row)
    return phases_agree(
        reading.phases,
        row.get(Col.EXACT_PHASES),
        prefix=outcome is not None and _exact_class(outcome) is _Class.PAINLEVE,
        t_last=reading.t_last_phase,
        exact_t_last=row.get(Col.EXACT_T_LAST_PHASE),
        t_final=row.get(Col.T_FINAL),
        tolerance=_row_thresholds(row).lift_time_tolerance,
    )


def _mm(value: Any) -> str:
    number = number_or_none(value)
    return "-" if number is None else f"{1e3 * number:.3g} mm"


_OutcomePart = tuple[Verdict | None, str]
"""A failing Verdict (None: the outcome agrees) and the reason."""


def _outcome(row: Mapping[str, Any], engine: _Class, exact: _Class) -> _OutcomePart:
    """The outcome part of the verdict: a failing Verdict, or None if the outcome agrees."""
    if exact is _Class.HOP:
        return _hop_outcome(row, engine)
    if exact is _Class.PAINLEVE:
        return _painleve_outcome(row, engine)
    if engine is _Class.HOP:
        reading = engine_reading(row)
        height = _mm(reading.hop_height)
        return (
            Verdict.FALSE_HOP,
            f"a {height} hop the reference does not have (by the {reading.source})",
        )
    if engine is _Class.PAINLEVE:
        engine = _Class.SLIP  # only the reference reports it, and it was slipping
    if exact is _Class.SLIP and engine is _Class.ROLL:
        return Verdict.MISSED_SLIP, "rolls where the reference slips"
    if exact is _Class.ROLL and engine is _Class.SLIP:
        return Verdict.FALSE_SLIP, "slips where the reference rolls"
    return None, f"{exact}s as the reference does"


def _hop_outcome(row: Mapping[str, Any], engine: _Class) -> _OutcomePart:
    """Where the reference hops: the engine must hop inside the exact window."""
    if engine is not _Class.HOP:
        largest = _mm(row.get(Col.MAX_CLEARANCE))
        threshold = _mm(_row_thresholds(row).hop_clearance)
        return Verdict.MISSED_HOP, f"no hop above {threshold} (largest clearance {largest})"
    return None, "the exact hop"


Failure = tuple[Verdict, str]
"""A failed check and the line that says by how much."""


def _hop_failures(row: Mapping[str, Any], reading: EngineReading) -> list[Failure]:
    """Both hop: the engine's hop height within the factor 2, its lift-off within 50 ms
    (scaled) of the exact ones; each failure says which way and by how much."""
    out: list[Failure] = []
    h, h0 = reading.hop_height, number_or_none(row.get(Col.EXACT_HOP_HEIGHT))
    by = f" (by the {reading.source})"
    if h is not None and h0:
        ratio = h / h0
        # A run that ends in the air has not reached its height: only too high can be told.
        cut = reading.t_impact is None and ratio < 1.0
        if not cut and (ratio < 1.0 / HOP_HEIGHT_FACTOR or ratio > HOP_HEIGHT_FACTOR):
            kind = Verdict.HOP_TOO_LOW if ratio < 1.0 else Verdict.HOP_TOO_HIGH
            out.append((kind, f"hop {_mm(h)} against {_mm(h0)}: {ratio:.2f}x{by}"))
    elif h is None:
        out.append((Verdict.MISSED_HOP, "the hop's numbers were withheld as inconsistent"))
    t, t0 = reading.t_lift, number_or_none(row.get(Col.EXACT_T_LIFT))
    tolerance = _row_thresholds(row).lift_time_tolerance
    if t is not None and t0 is not None and abs(t - t0) > tolerance:
        kind = Verdict.EARLY_LIFT_OFF if t < t0 else Verdict.LATE_LIFT_OFF
        out.append((kind, f"lift-off {_ms_text(t - t0)} ({t:.6g} s against {t0:.6g} s){by}"))
    return out


def _slip_failures(row: Mapping[str, Any], reading: EngineReading) -> list[Failure]:
    """Both slip: the engine's first slip onset within 10 ms (scaled) of the exact one."""
    t, t0 = reading.t_slip, number_or_none(row.get(Col.EXACT_T_SLIP))
    if t is None or t0 is None:
        return []
    if abs(t - t0) <= _row_thresholds(row).slip_time_tolerance:
        return []
    kind = Verdict.EARLY_SLIP if t < t0 else Verdict.LATE_SLIP
    text = f"slip onset {_ms_text(t - t0)} ({t:.6g} s against {t0:.6g} s, by the {reading.source})"
    return [(kind, text)]


def _phase_failures(row: Mapping[str, Any], reading: EngineReading) -> list[Failure]:
    if row_phases_agree(row) is not False:
        return []
    exact = _text(row.get(Col.EXACT_PHASES)) or ""
    return [(Verdict.WRONG_PHASES, _phase_difference(reading.phases or "", exact))]


def _phase_difference(phases: str, exact: str) -> str:
    """Which phase differs first, e.g. 'phase 3 is S- instead of R (R S+ S- R against R S+ R
    S- R)'."""
    mine, theirs = phases.split(), exact.split()
    k = next((i for i, (a, b) in enumerate(zip(mine, theirs, strict=False)) if a != b), None)
    k = min(len(mine), len(theirs)) if k is None else k
    got = mine[k] if k < len(mine) else "nothing"
    expected = theirs[k] if k < len(theirs) else "nothing"
    return f"phase {k + 1} is {got} instead of {expected} ({phases} against {exact})"


def _ms_text(seconds: float) -> str:
    return f"{abs(1e3 * seconds):.3g} ms {'early' if seconds < 0 else 'late'}"


def _painleve_outcome(row: Mapping[str, Any], engine: _Class) -> _OutcomePart:
    """Where the reference reaches a Painlevé point: nothing may contradict the motion the
    rigid model predicts up to it (module docstring)."""
    t_p = number_or_none(row.get(Col.EXACT_T_PAINLEVE)) or 0.0
    if engine is _Class.HOP:
        t_lift = number_or_none(row.get(Col.T_LIFT))
        if t_lift is None or t_lift < t_p - _row_thresholds(row).lift_time_tolerance:
            when = "withheld" if t_lift is None else f"{t_lift:.6g} s"
            return Verdict.FALSE_HOP, f"lift-off ({when}) before the Painlevé point {t_p:.6g} s"
        return None, f"lift-off at {t_lift:.6g} s, not before the Painlevé point {t_p:.6g} s"
    if engine is _Class.ROLL and number_or_none(row.get(Col.EXACT_T_SLIP)) is not None:
        return Verdict.MISSED_SLIP, "no slip before the Painlevé point"
    return None, "nothing contradicts the motion up to the Painlevé point"


def _exact_slips_below_threshold(row: Mapping[str, Any]) -> str | None:
    """Why exact slips cannot be judged, or None: none of them reaches the slip threshold.

    The detectors call a slip when |slip velocity| exceeds the threshold (1 mm/s on the 1 m
    hoop), so an engine that reproduced such slips exactly would still read as rolling: a
    'missed-slip' would be the harness's blind spot, not the engine's. On a lam x chi map at
    mu 0.8 such slips (0.05-0.2 mm/s, 17-20 ms long) made every engine 'miss' them.
    """
    speed = number_or_none(row.get(Col.EXACT_MAX_SLIP_SPEED))
    threshold = _row_thresholds(row).slip_threshold
    if speed is None or speed > threshold:
        return None
    return (
        f"the exact slips reach {1e3 * speed:.3g} mm/s, below the {1e3 * threshold:.3g} mm/s "
        "slip threshold: no engine slip can be judged against them"
    )


def _exact_hop_below_threshold(row: Mapping[str, Any]) -> str | None:
    """Why an exact hop cannot be judged, or None: it is no higher than the hop threshold.

    No engine lift-off that small counts as a hop (it is read as contact noise), and the
    exact solution ends at that hop's impact, where the rigid model stops saying anything;
    so neither "agrees" nor "missed" would be true. Such hops occur where the normal force
    only just turns negative (lam chi close to 1 from above: 0.07 mm on a lam x chi map).
    """
    height = number_or_none(row.get(Col.EXACT_HOP_HEIGHT))
    threshold = _row_thresholds(row).hop_clearance
    if height is None or height > threshold:
        return None
    return (
        f"the exact hop ({_mm(height)}) is below the {_mm(threshold)} hop threshold: "
        "no engine hop can be judged against it"
    )


def classify(row: Mapping[str, Any]) -> Judgement:
    """The verdict on one run from its row (its status, the exact_* columns, and the engine's
    events as :func:`engine_reading` reads them). See the module docstring for the rules."""
    status = _text(row.get(Col.STATUS))
    if status == RunStatus.DIVERGED:
        return Judgement(Verdict.DIVERGED, False, row.get(Col.MESSAGE) or "diverged")
    if status != RunStatus.OK:
        return Judgement(Verdict.FAILED, False, f"status {status}: {row.get(Col.MESSAGE) or ''}")
    exact_outcome = _text(row.get(Col.EXACT_OUTCOME))
    if exact_outcome is None or exact_outcome in _NO_ANSWER:
        return Judgement(None, None, f"no exact answer to judge against ({exact_outcome})")
    exact = _exact_class(exact_outcome)
    below = _exact_hop_below_threshold(row) if exact is _Class.HOP else None
    below = below or (_exact_slips_below_threshold(row) if exact is _Class.SLIP else None)
    if below:
        return Judgement(None, None, below)
    engine = _engine_class(row)
    if engine is None:
        return Judgement(Verdict.FAILED, False, "status ok but no events")
    return _judged(row, engine, exact)


def _judged(row: Mapping[str, Any], engine: _Class, exact: _Class) -> Judgement:
    failure, reason = _outcome(row, engine, exact)
    if failure is not None:
        return Judgement(failure, False, reason, (failure,))
    reading = engine_reading(row)
    failures = _hop_failures(row, reading) if exact is _Class.HOP else []
    if exact is not _Class.PAINLEVE:
        failures += _slip_failures(row, reading)
    failures += _phase_failures(row, reading)
    if not failures:
        return Judgement(Verdict.AGREES, True, reason)
    flags = tuple(kind for kind, _ in failures)
    agrees = not any(kind in OUTCOME_FAILURES for kind in flags)
    return Judgement(flags[0], agrees, failures[0][1], flags)


def verdict_columns(row: Mapping[str, Any]) -> dict[str, Any]:
    """The row's ``verdict`` (a string, None without an exact answer), ``outcome_agrees``,
    ``verdict_flags`` (every failed check) and ``verdict_reason`` (the primary one's line)."""
    judgement = classify(row)
    verdict = None if judgement.verdict is None else str(judgement.verdict)
    return {
        Col.VERDICT: verdict,
        Col.OUTCOME_AGREES: judgement.outcome_agrees,
        Col.VERDICT_FLAGS: " ".join(str(flag) for flag in judgement.flags),
        Col.VERDICT_REASON: judgement.reason,
    }
