"""Every transition of a run's phases timed against the exact one: which of the run's
transitions meets which exact transition, and how far apart they are.

A run's phases (the canonical reading's modes, engines/judging/contact.py) start at
``phase_times``; the exact phases it is compared with are the exact solution read at the
run's timestep (``floor_phases``, starting at ``floor_phase_times``), where a phase too short
for the reading is absorbed. The times to judge against are the exact solver's own
(``exact_phase_times``): each floor transition (from-code -> to-code) is matched to the exact
solver's transition of the same kind nearest in time (:func:`exact_transition_times`), so an
absorbed exact transition is never timed, the time is the true one, and |floor - exact| is
that transition's detection floor.

The run's transition k (the start of its phase k) is paired with the floor's transition k
where both sequences have the same codes up to phase k (:func:`matched_transitions`): every
transition where the codes agree, the common prefix where they differ (the phase rule flags
the rest). So a last phase one sequence has and the other not, at the window's end, is not
timed, and on a Painlevé scene only the transitions before the Painlevé point are.

Pure functions on plain values and on a row's columns (:func:`row_transitions`), so a stored
row is timed again as a fresh one is.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from typing import Any

from hoopbench.engines.judging.columns import Col
from hoopbench.models.events import Phase

__all__ = [
    "Transition",
    "exact_transition_times",
    "matched_transitions",
    "parse_times",
    "row_transitions",
    "times_text",
    "transition_names",
]


@dataclass(frozen=True)
class Transition:
    """One of the run's transitions paired with the exact one. Times in s."""

    name: str
    """What it is, counted along the run's phases: 'slip onset 2', 're-stick 1', 'reversal 1'
    (a slip changing direction), 'lift-off', 'chatter 1', 'roll 1' (a roll after chatter or
    flight); the first slip onset is 'slip onset'."""
    before: str
    """The phase code it leaves, e.g. 'S+'."""
    after: str
    """The phase code it enters, e.g. 'R'."""
    t: float
    """The run's."""
    t_exact: float
    """The exact solver's (true) time of the matched exact transition."""
    floor: float
    """|floor - exact|: how far the exact solution read at the run's timestep sees it from
    its true time (the detection floor of this transition), >= 0."""

    @property
    def error(self) -> float:
        """Run minus exact, s (negative: early)."""
        return self.t - self.t_exact

    @property
    def label(self) -> str:
        """'re-stick 1 (S+ -> R)'."""
        return f"{self.name} ({self.before} -> {self.after})"


def times_text(times: Sequence[float]) -> str:
    """Times as a column stores them: space-separated, each with repr's precision (a missing
    one as 'nan')."""
    return " ".join(repr(float(t)) for t in times)


def parse_times(text: Any) -> tuple[float, ...] | None:
    """The times of a ``*phase_times`` column (nan where missing); None where the column is
    not such a text (a row stored before it, or a run without phases)."""
    if not isinstance(text, str):
        return None
    try:
        return tuple(float(word) for word in text.split())
    except ValueError:
        return None


def _codes(text: Any) -> list[str] | None:
    return text.split() if isinstance(text, str) else None


def _name(before: str, after: str) -> str:
    """The kind of transition from code ``before`` to code ``after``."""
    if after.startswith("S"):
        return "reversal" if before.startswith("S") else "slip onset"
    if after == "R":
        return "re-stick" if before.startswith("S") else "roll"
    if after == "F":
        return "lift-off"
    return "chatter"


def transition_names(codes: Sequence[str]) -> list[str]:
    """The name of each transition of a phase sequence (transition k enters phase k, k >= 1;
    the list holds k - 1): each kind counted from 1 along the sequence; the first slip onset
    is 'slip onset' and the lift-off 'lift-off', as the verdict names them."""
    counts: dict[str, int] = {}
    names = []
    for before, after in pairwise(codes):
        kind = _name(before, after)
        counts[kind] = counts.get(kind, 0) + 1
        if kind == "lift-off" or (kind == "slip onset" and counts[kind] == 1):
            names.append(kind)
        else:
            names.append(f"{kind} {counts[kind]}")
    return names


def exact_transition_times(floor: Sequence[Phase], exact: Sequence[Phase]) -> tuple[float, ...]:
    """For each phase the floor reading found (``floor``), the exact solver's start time of
    the phase it reads (nan where none): the first phase's is the exact first phase's; a later
    one's is the exact transition of the same kind (the same from-code and to-code) nearest in
    time, after the one matched before it. So an exact phase the floor absorbed is skipped,
    and a floor transition of a kind the exact solution does not have there is not timed."""
    if not floor or not exact:
        return (math.nan,) * len(floor)
    times = [exact[0].t_start if floor[0].code == exact[0].code else math.nan]
    last = 0  # the exact phase the previous floor transition was matched to
    for before, after in pairwise(floor):
        candidates = [
            j
            for j in range(last + 1, len(exact))
            if (exact[j - 1].code, exact[j].code) == (before.code, after.code)
        ]
        if not candidates:
            times.append(math.nan)
            continue
        j = min(candidates, key=lambda j: abs(exact[j].t_start - after.t_start))
        times.append(exact[j].t_start)
        last = j
    return tuple(times)


def matched_transitions(
    phases: Any, times: Any, floor_phases: Any, floor_times: Any, exact_times: Any
) -> tuple[Transition, ...]:
    """The run's transitions paired with the exact ones (module docstring): ``phases`` and
    ``floor_phases`` are codes ('R S+ R'), the times their phases' starts as texts
    (:func:`times_text`), ``exact_times`` the exact start of each floor phase
    (:func:`exact_transition_times`). Empty where any is missing or their lengths differ."""
    codes, floor_codes = _codes(phases), _codes(floor_phases)
    mine, floor, exact = parse_times(times), parse_times(floor_times), parse_times(exact_times)
    if codes is None or floor_codes is None or mine is None or floor is None or exact is None:
        return ()
    if len(mine) != len(codes) or len(floor) != len(floor_codes) or len(exact) != len(floor):
        return ()
    common = 0
    while common < min(len(codes), len(floor_codes)) and codes[common] == floor_codes[common]:
        common += 1
    names = transition_names(codes)
    out = []
    for k in range(1, common):
        if math.isnan(exact[k]) or math.isnan(mine[k]):
            continue
        floor_error = 0.0 if math.isnan(floor[k]) else abs(floor[k] - exact[k])
        out.append(Transition(names[k - 1], codes[k - 1], codes[k], mine[k], exact[k], floor_error))
    return tuple(out)


def row_transitions(row: Mapping[str, Any]) -> tuple[Transition, ...]:
    """:func:`matched_transitions` of a row's columns (empty for a row stored without the
    phase times)."""
    return matched_transitions(
        row.get(Col.PHASES),
        row.get(Col.PHASE_TIMES),
        row.get(Col.FLOOR_PHASES),
        row.get(Col.FLOOR_PHASE_TIMES),
        row.get(Col.EXACT_PHASE_TIMES),
    )
