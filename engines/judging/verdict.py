"""The verdict on one run: did the engine do what the exact solution does, and if not, what
went wrong?

Pure functions on plain values: :func:`classify` reads one row of the runs table (a mapping
with the row's column names; a stored row, with NaN for a missing number, works as well as a
fresh one) and returns a :class:`Judgement`; :func:`verdict_columns` gives the row's
``verdict``, ``outcome_agrees``, ``verdict_flags`` and ``verdict_reason`` from it.

**One reading.** The verdict reads the row's unprefixed event columns: the canonical reading
(engines/judging/contact.py). The kinematic ``kin_*`` columns are never judged.

**One tolerance table** (engines/judging/tolerances.toml, :mod:`tolerances`): an event
agrees within its TIGHT tolerance, is close within its LOOSE one, and fails beyond it. Each
tolerance is the table's, carried to the row's hoop (times with sqrt(a / g)) and timestep
(plus ``steps`` timesteps), plus the row's **detection floor**: the canonical reading of the
exact solution sampled at the run's timestep against the exact event (``floor_err_*``). So
the reference's own row always agrees, and no engine is judged finer than the reading can
see at its timestep.

**Absorbed at the timestep.** The exact phases compared are the exact solution's as read at
the run's timestep (``floor_phases``): a phase too short for the reading (a 2 ms roll) is
absorbed on both sides, and a slip the reading cannot see at that step is no slip to miss.

**The checks**, every one of them run; the primary verdict is the first that fails, and
every failed check is a flag (``verdict_flags``):

- the outcome class: ``false-hop``, ``missed-hop`` (no hop above the hop threshold inside the
  exact window), ``missed-slip``, ``false-slip``;
- where both hop: the hop height (``hop-too-low``, ``hop-too-high``; a run that ends in the
  air can only be too high), the lift-off (``early-lift-off``, ``late-lift-off``) and the
  impact (``early-impact``, ``late-impact``);
- the first slip onset (``early-slip``, ``late-slip``): where both slip, its time; a run that
  has not slipped by its end where the exact run slipped (and hops, so that the outcome
  check does not say it) slips late, as a run still in the air at its end lands late;
- the phase sequence (``wrong-phases``; the reason names the first phase that differs);
- every later transition (``early-transition``, ``late-transition``; the reason names it):
  each re-stick, later slip onset and slip reversal of the run paired with the exact one
  (engines/judging/transitions.py: where the run's phase codes equal the floor's, or their
  common prefix where they differ; a last phase only one of them has at the window's end is
  not timed), with the t_slip tolerances plus that transition's own detection floor;
- a stick outside the Coulomb cone lasting the table's ``[cone] stick_s``
  (``cone-violation``).

No failure: ``agrees`` when every event is within its tight tolerance, else ``close`` (the
reason names the events outside tight). ``outcome_agrees`` is true when none of the outcome
failures (class, hop height, lift-off, impact) is flagged. A row without ``a`` (or ``g``)
is judged for a = 1 m (g = 9.8 m/s^2).

**The worst transition.** Every event time the checks compare (the first slip onset, the
lift-off, the impact, every later transition) is timed; the one whose error is largest
against its loose tolerance is the row's ``max_transition``, with its signed error
``max_transition_err_ms`` and that ratio ``max_transition_ratio`` (above 1: it fails), so a
reader can sort the rows by it (:func:`verdict_columns`).

- **Painlevé.** The exact solution reaches a point where no consistent contact force exists
  (D = 0 while slipping) at ``exact_t_painleve``, and the rigid model says nothing after it.
  So the engine agrees unless it contradicts the part the model does predict: a lift-off
  more than PHASE_END_TOLERANCE before the Painlevé point is a false hop, and a run that
  never slips where the exact one slipped first is a missed slip. Its phases are compared up
  to that point: the engine's sequence must begin with the exact one, and its later
  transitions in it are timed (its first slip onset is not, as before).
- **lifts-at-start** (the normal force is negative at t = 0) is a hop whose lift-off is at
  t = 0.
- ``degenerate`` and ``error`` exact outcomes, exact hops below the hop threshold and exact
  slips below the slip threshold are no answer to judge against: the verdict and
  ``outcome_agrees`` are empty (None).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.detectors import DetectorSettings, hoop_scale
from hoopbench.engines.judging.tolerances import (
    EventTolerances,
    Tier,
    event_tolerances,
    tolerances,
)
from hoopbench.engines.judging.transitions import row_transitions
from hoopbench.engines.run import RunStatus
from hoopbench.models.events import Events, Outcome

__all__ = [
    "HOP_CLEARANCE",
    "LOOSE_TIER",
    "OUTCOME_FAILURES",
    "PHASE_END_TOLERANCE",
    "TIER_NAMES",
    "TIER_VERDICTS",
    "TIGHT_TIER",
    "Event",
    "HoopThresholds",
    "Judgement",
    "TimedEvent",
    "Verdict",
    "classify",
    "event_error_ratio",
    "event_tolerance",
    "event_within",
    "hoop_thresholds",
    "number_or_none",
    "painleve_time",
    "phases_agree",
    "row_phases_agree",
    "verdict_columns",
]

HOP_CLEARANCE = DetectorSettings().hop_clearance
"""The hop threshold of the 1 m hoop, m: read from its one home,
``DetectorSettings.hop_clearance``; :func:`hoop_thresholds` carries it to a row's hoop."""

PHASE_END_TOLERANCE = 0.05
"""s (1 m hoop, scales with sqrt(a / g)): two phase sequences that differ by one last phase
agree when that phase starts this close to the run's last sample (a re-stick 4 ms before the
window's end in one and just after it in the other); and an engine's lift-off this long
before a Painlevé point is a false hop."""


class Verdict(StrEnum):
    """A run's verdict: ``agrees``, ``close``, or what went wrong (see the module
    docstring); the primary failure is the first in this order."""

    AGREES = "agrees"
    """Every event within the tight tolerances, the outcome and the phases the reference's."""
    CLOSE = "close"
    """No check fails, but some event is outside its tight tolerance (inside the loose)."""
    FALSE_HOP = "false-hop"
    """A hop above the threshold where the reference has none (or, on a Painlevé scene, one
    that leaves more than ``PHASE_END_TOLERANCE`` before the Painlevé point)."""
    MISSED_HOP = "missed-hop"
    """The reference hops and the engine has no hop above the threshold inside the exact
    window."""
    MISSED_SLIP = "missed-slip"
    """The reference slips (as read at the run's timestep, and does not hop) and the engine
    never slips."""
    FALSE_SLIP = "false-slip"
    """The reference rolls throughout and the engine slips (without a hop)."""
    HOP_TOO_LOW = "hop-too-low"
    """Both hop; the engine's hop is lower than the loose tolerance allows."""
    HOP_TOO_HIGH = "hop-too-high"
    """Both hop; the engine's hop is higher than the loose tolerance allows."""
    EARLY_LIFT_OFF = "early-lift-off"
    """Both hop; the engine lifts off earlier than the loose tolerance allows."""
    LATE_LIFT_OFF = "late-lift-off"
    """Both hop; the engine lifts off later than the loose tolerance allows."""
    EARLY_IMPACT = "early-impact"
    """Both hop; the engine lands earlier than the loose tolerance allows."""
    LATE_IMPACT = "late-impact"
    """Both hop; the engine lands later than the loose tolerance allows (or is still in the
    air that long after the exact impact when its run ends)."""
    EARLY_SLIP = "early-slip"
    """Both slip (the reference as read at the run's timestep, and short of a Painlevé point);
    the engine's first slip onset is earlier than the loose tolerance allows."""
    LATE_SLIP = "late-slip"
    """Both slip; the engine's first slip onset is later than the loose tolerance allows (or,
    where the reference slips and then hops, the engine has not slipped that long after the
    exact onset when its run ends)."""
    WRONG_PHASES = "wrong-phases"
    """The phase sequence differs from the exact one read at the run's timestep
    (``floor_phases``); the reason names the first phase that differs."""
    EARLY_TRANSITION = "early-transition"
    """A later transition (a re-stick, a later slip onset, a slip reversal) earlier than the
    loose tolerance allows."""
    LATE_TRANSITION = "late-transition"
    """A later transition later than the loose tolerance allows."""
    CREEPS = "creeps"
    """The rim slides, with its friction inside the cone at what rolling needs (creep),
    farther than the loose tolerance, where the exact solution rolls without sliding."""
    CONE_VIOLATION = "cone-violation"
    """The contact sticks with friction outside the Coulomb cone (|mean f| above mu mean n)
    for at least the table's ``[cone] stick_s``."""
    DIVERGED = "diverged"
    """Status ``diverged``: the run stopped early (NaN, runaway energy or deep penetration).
    No other check runs."""
    FAILED = "failed"
    """The run gave no result: status ``error``, ``crashed`` or ``unavailable`` (or ``ok``
    without events). No other check runs. A run the sweep's time limit ended (status
    ``timeout``) has no verdict in a suite's table: the machine's failure, not the engine's."""


OUTCOME_FAILURES = frozenset(
    {
        Verdict.FALSE_HOP,
        Verdict.MISSED_HOP,
        Verdict.HOP_TOO_LOW,
        Verdict.HOP_TOO_HIGH,
        Verdict.EARLY_LIFT_OFF,
        Verdict.LATE_LIFT_OFF,
        Verdict.EARLY_IMPACT,
        Verdict.LATE_IMPACT,
        Verdict.MISSED_SLIP,
        Verdict.FALSE_SLIP,
    }
)
"""The failures of the outcome (its class, its hop's size and times): ``outcome_agrees`` is
true when none of them is flagged."""

TIGHT_TIER = frozenset({Verdict.AGREES})
"""The verdicts of the tight accuracy tier (summaries count these as right)."""
LOOSE_TIER = frozenset({Verdict.AGREES, Verdict.CLOSE})
"""The verdicts of the loose accuracy tier."""
TIER_VERDICTS: Mapping[Tier, frozenset[Verdict]] = {Tier.TIGHT: TIGHT_TIER, Tier.LOOSE: LOOSE_TIER}
"""The accuracy tiers of every summary (the answer, the findings, the scoreboard), in the
order of the tolerance table's tiers: the verdicts that meet each."""
TIER_NAMES: Mapping[Tier, Verdict] = {Tier.TIGHT: Verdict.AGREES, Tier.LOOSE: Verdict.CLOSE}
"""What a user calls each tier (a settings file's ``FILE#agrees``, ``FILE#close``): the
verdict the tier admits that no finer tier does."""


class _Class(StrEnum):
    ROLL = "roll"
    SLIP = "slip"
    HOP = "hop"
    PAINLEVE = "painleve"
    UNSEEN_SLIP = "slip too short to read"
    UNSEEN_HOP = "hop the window cuts too short to read"
    """The exact solution slips, but not long enough for the reading at the run's step."""


_HOP_OUTCOMES = (str(Outcome.HOPS), str(Outcome.LIFTS_AT_START))
_NO_ANSWER = (str(Outcome.DEGENERATE), str(Outcome.ERROR))


@dataclass(frozen=True)
class TimedEvent:
    """An event time the verdict compared with the exact one. Times in s."""

    name: str
    """'slip onset', 'lift-off', 'impact', 're-stick 1', ..."""
    error: float
    """Run minus exact (negative: early)."""
    tight: float
    """Its tight tolerance, the row's detection floor of it included (> 0)."""
    loose: float
    """Its loose tolerance, the row's detection floor of it included (> 0)."""

    @property
    def ratio(self) -> float:
        """|error| over the loose tolerance: above 1 the check fails."""
        return abs(self.error) / self.loose

    @property
    def later(self) -> bool:
        """A later transition (a re-stick, a later slip onset, a reversal), not one of the
        events with their own checks (the first slip onset, the lift-off, the impact)."""
        return self.name not in _OWN_CHECKS


@dataclass(frozen=True)
class Judgement:
    """A run's verdict, whether its outcome agrees, and a line saying why."""

    verdict: Verdict | None
    outcome_agrees: bool | None
    reason: str
    flags: tuple[Verdict, ...] = ()
    """Every check that failed, the primary verdict first (empty for agrees and close)."""
    timed: tuple[TimedEvent, ...] = ()
    """Every event time the checks compared, in the order they did."""

    @property
    def worst(self) -> TimedEvent | None:
        """The timed event with the largest error against its loose tolerance (the first of
        those tied); None where none was timed."""
        return max(self.timed, key=lambda event: event.ratio, default=None)


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
    """The verdict's sizes, carried to one hoop and timestep (the tolerances before the row's
    own detection floor)."""

    hop_clearance: float
    """m: a lift-off must rise above this to be a hop."""
    slip_threshold: float
    """m/s: the slip threshold; an exact slip slower than this is invisible."""
    phase_end: float
    """s: PHASE_END_TOLERANCE carried to the hoop."""
    cone_stick: float
    """s: a stick outside the cone this long is a cone-violation."""
    tight: EventTolerances
    loose: EventTolerances


def hoop_thresholds(a: Any = None, g: Any = None, timestep: Any = None) -> HoopThresholds:
    """The verdict's sizes for a hoop of radius ``a`` (m) under ``g`` (m/s^2) at
    ``timestep`` (s), the 1 m hoop's (and no timestep) where one is missing."""
    base = DetectorSettings()
    a, g = number_or_none(a) or base.a, number_or_none(g) or base.g
    step = number_or_none(timestep) or 0.0
    length, speed, duration = hoop_scale(a, g, base.a, base.g)
    return HoopThresholds(
        hop_clearance=length * HOP_CLEARANCE,
        slip_threshold=speed * base.slip_threshold,
        phase_end=duration * PHASE_END_TOLERANCE,
        cone_stick=duration * float(tolerances()["cone"]["stick_s"]),
        tight=event_tolerances(Tier.TIGHT, duration, step, length),
        loose=event_tolerances(Tier.LOOSE, duration, step, length),
    )


def _row_thresholds(row: Mapping[str, Any]) -> HoopThresholds:
    return hoop_thresholds(row.get(Col.A), row.get(Col.G), row.get(Col.TIMESTEP))


class Event(StrEnum):
    """The judged events, for :func:`event_within`."""

    SLIP_ONSET = "slip onset"
    LIFT_OFF = "lift-off"
    IMPACT = "impact"
    HOP_HEIGHT = "hop height"


_EVENT_COLUMNS = {
    Event.SLIP_ONSET: (Col.ERR_T_SLIP_MS, Col.FLOOR_ERR_T_SLIP_MS, "t_slip"),
    Event.LIFT_OFF: (Col.ERR_T_LIFT_MS, Col.FLOOR_ERR_T_LIFT_MS, "t_lift"),
    Event.IMPACT: (Col.ERR_T_IMPACT_MS, Col.FLOOR_ERR_T_IMPACT_MS, "t_impact"),
    Event.HOP_HEIGHT: (Col.ERR_HOP_HEIGHT_REL, Col.FLOOR_ERR_HOP_HEIGHT_REL, "hop_height_rel"),
}


def event_within(row: Mapping[str, Any], event: Event, tier: Tier) -> bool | None:
    """Whether the row's error of ``event`` (the canonical reading's) is within ``tier``'s
    tolerance as the verdict sets it (the table's, carried to the row's hoop and timestep,
    plus the row's detection floor); None where the row has no such error."""
    ratio = event_error_ratio(row, event, tier)
    return None if ratio is None else ratio <= 1.0


def event_error_ratio(row: Mapping[str, Any], event: Event, tier: Tier) -> float | None:
    """The row's error of ``event`` over ``tier``'s tolerance as the verdict sets it (so at
    most 1 within it); None where the row has no such error."""
    error = number_or_none(row.get(_EVENT_COLUMNS[event][0]))
    if error is None:
        return None
    return abs(error) / event_tolerance(row, event, tier)


def event_tolerance(row: Mapping[str, Any], event: Event, tier: Tier) -> float:
    """``tier``'s tolerance of ``event`` as the verdict sets it for the row (the table's,
    carried to the row's hoop and timestep, plus the row's detection floor), in the unit of
    the row's error column: ms for a time, relative for the hop height."""
    _, floor_column, field = _EVENT_COLUMNS[event]
    limits = _row_thresholds(row)
    tolerance = getattr(limits.tight if tier is Tier.TIGHT else limits.loose, field)
    floor = abs(number_or_none(row.get(floor_column)) or 0.0)
    if event is not Event.HOP_HEIGHT:
        tolerance *= 1e3  # the time errors are in ms
    return float(tolerance + floor)


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


def _exact_phases(row: Mapping[str, Any]) -> tuple[str | None, Any]:
    """The exact phases the engine's are compared with, and the last one's start: as read at
    the run's timestep where the row has them, else the exact solver's."""
    floor = _text(row.get(Col.FLOOR_PHASES))
    if floor is not None:
        return floor, row.get(Col.FLOOR_T_LAST_PHASE)
    return _text(row.get(Col.EXACT_PHASES)), row.get(Col.EXACT_T_LAST_PHASE)


def _engine_class(row: Mapping[str, Any]) -> _Class | None:
    outcome = _text(row.get(Col.OUTCOME))
    if outcome is None:
        return None
    if number_or_none(row.get(Col.T_LIFT)) is not None:
        return _Class.HOP
    if outcome == str(Outcome.PAINLEVE):
        return _Class.PAINLEVE
    return _Class.SLIP if number_or_none(row.get(Col.T_SLIP)) is not None else _Class.ROLL


def _exact_slip_seen(row: Mapping[str, Any]) -> bool:
    """Whether the reading sees a slip in the exact solution at the run's timestep (true
    where the row has no floor reading)."""
    phases, _ = _exact_phases(row)
    return phases is None or any(code.startswith("S") for code in phases.split())


def _exact_hop_seen(row: Mapping[str, Any]) -> bool:
    """Whether the reading sees the exact hop in the exact solution sampled at the run's
    timestep up to the window's end (true where the row has no floor reading): a hop that
    lifts off just before the window ends may not yet reach the hop threshold there."""
    phases, _ = _exact_phases(row)
    return not phases or "F" in phases.split()


def _exact_class(row: Mapping[str, Any], outcome: str) -> _Class:
    if outcome in _HOP_OUTCOMES:
        # A hop the reading cannot see at the run's timestep is no hop to miss.
        return _Class.HOP if _exact_hop_seen(row) else _Class.UNSEEN_HOP
    if outcome == str(Outcome.PAINLEVE):
        return _Class.PAINLEVE
    if outcome != str(Outcome.SLIPS):
        return _Class.ROLL
    # A slip the reading cannot see at the run's timestep is no slip to miss.
    return _Class.SLIP if _exact_slip_seen(row) else _Class.UNSEEN_SLIP


def phases_agree(
    phases: Any,
    exact_phases: Any,
    *,
    prefix: bool = False,
    t_last: Any = None,
    exact_t_last: Any = None,
    t_final: Any = None,
    tolerance: float = PHASE_END_TOLERANCE,
) -> bool | None:
    """Whether the phase codes agree (None if either is missing); with ``prefix``, the
    engine's sequence need only begin with the exact one.

    At the window's end the two may differ by one last phase: the exact solution re-sticks
    at 2.996 s of a 3 s window and the engine 10 ms later, past its last sample. So a
    sequence that is the other's plus one last phase agrees when that phase starts within
    ``tolerance`` (s) of ``t_final``, the run's last sample (s); ``t_last`` and
    ``exact_t_last`` are the start times of the engine's and the exact last phases.
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
    """:func:`phases_agree` on a row's columns: the engine's phases against the exact ones
    read at the run's timestep (``floor_phases``; the exact solver's where the row lacks
    them), a prefix where the exact solution reaches a Painlevé point."""
    outcome = _text(row.get(Col.EXACT_OUTCOME))
    exact, exact_t_last = _exact_phases(row)
    return phases_agree(
        row.get(Col.PHASES),
        exact,
        prefix=outcome == str(Outcome.PAINLEVE),
        t_last=row.get(Col.T_LAST_PHASE),
        exact_t_last=exact_t_last,
        t_final=row.get(Col.T_FINAL),
        tolerance=_row_thresholds(row).phase_end,
    )


def _mm(value: Any) -> str:
    number = number_or_none(value)
    return "-" if number is None else f"{1e3 * number:.3g} mm"


def _ms_text(seconds: float) -> str:
    return f"{abs(1e3 * seconds):.3g} ms {'early' if seconds < 0 else 'late'}"


Failure = tuple[Verdict, str]
"""A failed check and the line that says by how much."""


@dataclass
class _Checks:
    """The checks' findings on one row: failures in order, and events outside tight."""

    failures: list[Failure]
    close: list[str]
    timed: list[TimedEvent]


def _outcome(row: Mapping[str, Any], engine: _Class, exact: _Class) -> Failure | None:
    """The outcome class: a failure, or None if it agrees."""
    if exact is _Class.UNSEEN_HOP or (exact is _Class.UNSEEN_SLIP and engine is not _Class.HOP):
        return None  # either outcome is what the reading sees of it
    if exact is _Class.HOP:
        if engine is _Class.HOP:
            return None
        largest = _mm(row.get(Col.MAX_CLEARANCE))
        threshold = _mm(_row_thresholds(row).hop_clearance)
        return Verdict.MISSED_HOP, f"no hop above {threshold} (largest clearance {largest})"
    if exact is _Class.PAINLEVE:
        return _painleve_outcome(row, engine)
    if engine is _Class.HOP:
        height = _mm(row.get(Col.HOP_HEIGHT))
        return Verdict.FALSE_HOP, f"a {height} hop the reference does not have"
    if engine is _Class.PAINLEVE:
        engine = _Class.SLIP  # only the reference reports it, and it was slipping
    if exact is _Class.SLIP and engine is _Class.ROLL:
        return Verdict.MISSED_SLIP, "never slips where the reference slips"
    if exact is _Class.ROLL and engine is _Class.SLIP:
        return Verdict.FALSE_SLIP, "slips where the reference rolls"
    return None


def _painleve_outcome(row: Mapping[str, Any], engine: _Class) -> Failure | None:
    """Where the reference reaches a Painlevé point: nothing may contradict the motion the
    rigid model predicts up to it (module docstring)."""
    t_p = number_or_none(row.get(Col.EXACT_T_PAINLEVE)) or 0.0
    if engine is _Class.HOP:
        t_lift = number_or_none(row.get(Col.T_LIFT))
        if t_lift is None or t_lift < t_p - _row_thresholds(row).phase_end:
            when = "withheld" if t_lift is None else f"{t_lift:.6g} s"
            return Verdict.FALSE_HOP, f"lift-off ({when}) before the Painlevé point {t_p:.6g} s"
        return None
    if engine is _Class.ROLL and number_or_none(row.get(Col.EXACT_T_SLIP)) is not None:
        return Verdict.MISSED_SLIP, "no slip before the Painlevé point"
    return None


def _floor_s(row: Mapping[str, Any], column: Col) -> float:
    """The row's detection floor of an event, s (0 where the row has none)."""
    return abs(number_or_none(row.get(column)) or 0.0) * 1e-3


def _timing(
    checks: _Checks,
    name: str,
    kinds: tuple[Verdict, Verdict],
    t: float | None,
    t0: float | None,
    tight: float,
    loose: float,
    label: str | None = None,
) -> None:
    """One event time against the exact one: within ``tight`` (s) agrees, within ``loose``
    close, beyond it the early or late failure of ``kinds``; the reason says ``label`` (the
    name where None). Recorded as timed under ``name``."""
    if t is None or t0 is None:
        return
    error = t - t0
    checks.timed.append(TimedEvent(name, error, tight, loose))
    text = f"{label or name} {_ms_text(error)} ({t:.6g} s against {t0:.6g} s"
    if abs(error) > loose:
        checks.failures.append(
            (kinds[0] if error < 0 else kinds[1], f"{text}, loose {1e3 * loose:.3g} ms)")
        )
    elif abs(error) > tight:
        checks.close.append(f"{text}, tight {1e3 * tight:.3g} ms)")


def _hop_checks(row: Mapping[str, Any], checks: _Checks) -> None:
    """Both hop: the height, the lift-off and the impact against the exact ones."""
    limits = _row_thresholds(row)
    h, h0 = number_or_none(row.get(Col.HOP_HEIGHT)), number_or_none(row.get(Col.EXACT_HOP_HEIGHT))
    t_impact = number_or_none(row.get(Col.T_IMPACT))
    if h is not None and h0:
        error = h / h0 - 1.0
        floor = abs(number_or_none(row.get(Col.FLOOR_ERR_HOP_HEIGHT_REL)) or 0.0)
        cut = t_impact is None and error < 0.0  # ends in the air: only too high can be told
        text = f"hop {_mm(h)} against {_mm(h0)}: {100 * error:+.3g} %"
        if not cut and abs(error) > limits.loose.hop_height_rel + floor:
            kind = Verdict.HOP_TOO_LOW if error < 0 else Verdict.HOP_TOO_HIGH
            checks.failures.append((kind, text))
        elif not cut and abs(error) > limits.tight.hop_height_rel + floor:
            checks.close.append(text)
    lift_floor = _floor_s(row, Col.FLOOR_ERR_T_LIFT_MS)
    _timing(
        checks,
        "lift-off",
        (Verdict.EARLY_LIFT_OFF, Verdict.LATE_LIFT_OFF),
        number_or_none(row.get(Col.T_LIFT)),
        number_or_none(row.get(Col.EXACT_T_LIFT)),
        limits.tight.t_lift + lift_floor,
        limits.loose.t_lift + lift_floor,
    )
    _impact_checks(row, checks, limits, t_impact)


def _impact_checks(
    row: Mapping[str, Any], checks: _Checks, limits: HoopThresholds, t_impact: float | None
) -> None:
    t0 = number_or_none(row.get(Col.EXACT_T_IMPACT))
    floor = _floor_s(row, Col.FLOOR_ERR_T_IMPACT_MS)
    if t_impact is None:
        end = number_or_none(row.get(Col.T_FINAL))
        if t0 is not None and end is not None and end - t0 > limits.loose.t_impact + floor:
            text = f"still in the air at the run's end, {_ms_text(end - t0)} after the exact impact"
            checks.failures.append((Verdict.LATE_IMPACT, text))
        return
    _timing(
        checks,
        "impact",
        (Verdict.EARLY_IMPACT, Verdict.LATE_IMPACT),
        t_impact,
        t0,
        limits.tight.t_impact + floor,
        limits.loose.t_impact + floor,
    )


def _slip_checks(row: Mapping[str, Any], checks: _Checks) -> None:
    """The first slip onset against the exact one: where both slip, its time; where only
    the exact run slips and the outcome check has not said so (it hops, and the run does
    not slip before its own hop or at all), a run that has not slipped by its last sample,
    more than the loose tolerance after the exact onset, slips late, as a run still in the
    air slips its impact late."""
    limits, floor = _row_thresholds(row), _floor_s(row, Col.FLOOR_ERR_T_SLIP_MS)
    t_slip = number_or_none(row.get(Col.T_SLIP))
    t0 = number_or_none(row.get(Col.EXACT_T_SLIP))
    if t_slip is None and t0 is not None:
        end = number_or_none(row.get(Col.T_FINAL))
        said = any(kind is Verdict.MISSED_SLIP for kind, _ in checks.failures)
        if not said and end is not None and end - t0 > limits.loose.t_slip + floor:
            text = f"never slips up to its end at {end:.6g} s (exact slip onset {t0:.6g} s)"
            checks.failures.append((Verdict.LATE_SLIP, text))
        return
    _timing(
        checks,
        "slip onset",
        (Verdict.EARLY_SLIP, Verdict.LATE_SLIP),
        t_slip,
        t0,
        limits.tight.t_slip + floor,
        limits.loose.t_slip + floor,
    )


def _phase_checks(row: Mapping[str, Any], checks: _Checks) -> None:
    if row_phases_agree(row) is False:
        exact, _ = _exact_phases(row)
        text = _phase_difference(_text(row.get(Col.PHASES)) or "", exact or "")
        checks.failures.append((Verdict.WRONG_PHASES, text))


_OWN_CHECKS = ("slip onset", "lift-off", "impact")
"""The events with their own checks (and verdicts), as the transitions name them."""


def _transition_checks(row: Mapping[str, Any], checks: _Checks) -> None:
    """Every later transition the run shares with the exact phases (module docstring): the
    first slip onset and the lift-off have their own checks."""
    limits = _row_thresholds(row)
    for transition in row_transitions(row):
        if transition.name in _OWN_CHECKS:
            continue
        _timing(
            checks,
            transition.name,
            (Verdict.EARLY_TRANSITION, Verdict.LATE_TRANSITION),
            transition.t,
            transition.t_exact,
            limits.tight.t_slip + transition.floor,
            limits.loose.t_slip + transition.floor,
            transition.label,
        )


def _cone_checks(row: Mapping[str, Any], checks: _Checks) -> None:
    stick = number_or_none(row.get(Col.CONE_STICK_TIME_S))
    limit = _row_thresholds(row).cone_stick
    if stick is not None and stick >= limit:
        text = f"sticks {1e3 * stick:.3g} ms with friction outside the Coulomb cone"
        checks.failures.append((Verdict.CONE_VIOLATION, text))


def _phase_difference(phases: str, exact: str) -> str:
    """Which phase differs first, e.g. 'phase 3 is S- instead of R (R S+ S- R against R S+ R
    S- R)'."""
    mine, theirs = phases.split(), exact.split()
    k = next((i for i, (a, b) in enumerate(zip(mine, theirs, strict=False)) if a != b), None)
    k = min(len(mine), len(theirs)) if k is None else k
    got = mine[k] if k < len(mine) else "nothing"
    expected = theirs[k] if k < len(theirs) else "nothing"
    return f"phase {k + 1} is {got} instead of {expected} ({phases} against {exact})"


def _exact_slips_below_threshold(row: Mapping[str, Any]) -> str | None:
    """Why exact slips cannot be judged, or None: none of them reaches the slip threshold
    (1 mm/s on the 1 m hoop), so an engine that reproduced them exactly would not slide
    fast enough to slip by the reading."""
    speed = number_or_none(row.get(Col.EXACT_MAX_SLIP_SPEED))
    threshold = _row_thresholds(row).slip_threshold
    if speed is None or speed > threshold:
        return None
    return (
        f"the exact slips reach {1e3 * speed:.3g} mm/s, below the {1e3 * threshold:.3g} mm/s "
        "slip threshold: no engine slip can be judged against them"
    )


def _exact_hop_below_threshold(row: Mapping[str, Any]) -> str | None:
    """Why an exact hop cannot be judged, or None: it is no higher than the hop threshold, so
    no engine lift-off that small counts as a hop, and the exact solution ends at its
    impact: neither "agrees" nor "missed" would be true."""
    height = number_or_none(row.get(Col.EXACT_HOP_HEIGHT))
    threshold = _row_thresholds(row).hop_clearance
    if height is None or height > threshold:
        return None
    return (
        f"the exact hop ({_mm(height)}) is below the {_mm(threshold)} hop threshold: "
        "no engine hop can be judged against it"
    )


def classify(row: Mapping[str, Any]) -> Judgement:
    """The verdict on one run from its row (its status, the exact_* and floor_* columns, and
    the canonical event columns). See the module docstring for the rules."""
    status = _text(row.get(Col.STATUS))
    if status == RunStatus.DIVERGED:
        return Judgement(
            Verdict.DIVERGED, False, row.get(Col.MESSAGE) or "diverged", (Verdict.DIVERGED,)
        )
    if status != RunStatus.OK:
        text = f"status {status}: {row.get(Col.MESSAGE) or ''}"
        return Judgement(Verdict.FAILED, False, text, (Verdict.FAILED,))
    exact_outcome = _text(row.get(Col.EXACT_OUTCOME))
    if exact_outcome is None or exact_outcome in _NO_ANSWER:
        return Judgement(None, None, f"no exact answer to judge against ({exact_outcome})")
    exact = _exact_class(row, exact_outcome)
    below = _exact_hop_below_threshold(row) if exact is _Class.HOP else None
    below = below or (_exact_slips_below_threshold(row) if exact is _Class.SLIP else None)
    if below:
        return Judgement(None, None, below)
    engine = _engine_class(row)
    if engine is None:
        return Judgement(Verdict.FAILED, False, "status ok but no events", (Verdict.FAILED,))
    return _judged(row, engine, exact)


def _creep_checks(row: Mapping[str, Any], checks: _Checks) -> None:
    distance = number_or_none(row.get(Col.CREEP_DISTANCE_M))
    if distance is None:
        return
    limits = _row_thresholds(row)
    speed = _mm(row.get(Col.CREEP_MAX_SPEED))
    text = f"creeps {_mm(distance)} with friction inside the cone (up to {speed}/s)"
    if distance > limits.loose.creep_distance:
        checks.failures.append((Verdict.CREEPS, text))
    elif distance > limits.tight.creep_distance:
        checks.close.append(text)


_EVENT_CHECKS: tuple[Callable[[Mapping[str, Any], _Checks], None], ...] = (
    _phase_checks,
    _transition_checks,
    _creep_checks,
    _cone_checks,
)


def _judged(row: Mapping[str, Any], engine: _Class, exact: _Class) -> Judgement:
    checks = _Checks([], [], [])
    failure = _outcome(row, engine, exact)
    if failure is not None:
        checks.failures.append(failure)
    if exact is _Class.HOP and engine is _Class.HOP:
        _hop_checks(row, checks)
    if _Class.PAINLEVE not in (exact, engine) and _exact_slip_seen(row):
        _slip_checks(row, checks)
    for check in _EVENT_CHECKS:
        check(row, checks)
    flags = tuple(dict.fromkeys(kind for kind, _ in checks.failures))
    agrees = not any(kind in OUTCOME_FAILURES for kind in flags)
    timed = tuple(checks.timed)
    if flags:
        return Judgement(flags[0], agrees, checks.failures[0][1], flags, timed)
    if checks.close:
        return Judgement(Verdict.CLOSE, True, "; ".join(checks.close), timed=timed)
    return Judgement(
        Verdict.AGREES,
        True,
        f"{exact}s as the reference does, every event within tight",
        timed=timed,
    )


def verdict_columns(row: Mapping[str, Any]) -> dict[str, Any]:
    """The row's ``verdict`` (a string, None without an exact answer), ``outcome_agrees``,
    ``verdict_flags`` (every failed check), ``verdict_reason`` (the primary one's line, or
    for ``close`` the events outside tight), and its worst timed transition
    (:attr:`Judgement.worst`: ``max_transition``, its signed error ``max_transition_err_ms``
    and ``max_transition_ratio``; None where nothing was timed, or where the row has no
    ``phase_times``: stored before every transition was timed, its worst is not known)."""
    judgement = classify(row)
    verdict = None if judgement.verdict is None else str(judgement.verdict)
    worst = judgement.worst if isinstance(row.get(Col.PHASE_TIMES), str) else None
    return {
        Col.VERDICT: verdict,
        Col.OUTCOME_AGREES: judgement.outcome_agrees,
        Col.VERDICT_FLAGS: " ".join(str(flag) for flag in judgement.flags),
        Col.VERDICT_REASON: judgement.reason,
        Col.MAX_TRANSITION_ERR_MS: None if worst is None else 1e3 * worst.error,
        Col.MAX_TRANSITION: None if worst is None else worst.name,
        Col.MAX_TRANSITION_RATIO: None if worst is None else worst.ratio,
    }
