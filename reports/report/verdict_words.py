"""The verdicts in plain words, for a reader who has not met the verdict table: what the
answer's sentences and its "wrong at every setting tried" column say in place of the
verdict's name (the names stay in answer.csv and answer.json, and docs/report.md's verdict
table says each one in full)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from hoopbench.engines.judging.verdict import Verdict
from hoopbench.engines.run import Divergence

__all__ = ["PLAIN_DIVERGENCES", "PLAIN_VERDICTS", "plain_verdicts", "verdict_name", "verdict_token"]

PLAIN_VERDICTS: Mapping[str, str] = {
    Verdict.AGREES: "right within the tight tolerances",
    Verdict.CLOSE: "within the loose tolerances only",
    Verdict.FALSE_HOP: "hops where the exact hoop does not",
    Verdict.MISSED_HOP: "misses the hop",
    Verdict.MISSED_SLIP: "never slips",
    Verdict.FALSE_SLIP: "slips where the exact hoop rolls",
    Verdict.HOP_TOO_LOW: "hops too low",
    Verdict.HOP_TOO_HIGH: "hops too high",
    Verdict.EARLY_LIFT_OFF: "lifts off early",
    Verdict.LATE_LIFT_OFF: "lifts off late",
    Verdict.EARLY_IMPACT: "lands early",
    Verdict.LATE_IMPACT: "lands late",
    Verdict.EARLY_SLIP: "slips early",
    Verdict.LATE_SLIP: "slips late",
    Verdict.WRONG_PHASES: "the wrong phase sequence",
    Verdict.EARLY_TRANSITION: "re-sticks or reverses early",
    Verdict.LATE_TRANSITION: "re-sticks or reverses late",
    Verdict.CREEPS: "creeps where the exact hoop rolls",
    Verdict.CONE_VIOLATION: "sticks beyond the friction cone",
    Verdict.DIVERGED: "blows up",
    Verdict.FAILED: "gives no result",
}
"""Each verdict (engines/judging/verdict.Verdict) in a few plain words; a diverged run whose
cause the harness knows says that cause instead (:data:`PLAIN_DIVERGENCES`)."""

PLAIN_DIVERGENCES: Mapping[Divergence, str] = {
    Divergence.NON_FINITE: "blows up",
    Divergence.ENERGY_RISE: "gains energy",
    Divergence.PENETRATION: "sinks deep into the floor",
    Divergence.OUT_OF_PLANE: "leaves the plane",
}
"""A diverged run's cause in plain words: MuJoCo's stock soft contact that lets a landing
hoop sink 5.2 cm is stopped, but it does not blow up."""

_CAUSE = ":"
"""Joins a verdict's name and its cause in a token (:func:`verdict_token`)."""


def verdict_token(verdict: str, message: object) -> str:
    """The verdict's name, with the cause of a diverged run where its message tells one:
    'diverged:PENETRATION' (:func:`plain_verdicts` says it; :func:`verdict_name` gives the
    name back)."""
    cause = Divergence.of(message) if verdict == Verdict.DIVERGED else None
    return verdict if cause is None else f"{verdict}{_CAUSE}{cause.name}"


def verdict_name(token: str) -> str:
    """The verdict's name of a :func:`verdict_token`."""
    return token.partition(_CAUSE)[0]


def plain_verdicts(verdicts: Iterable[str]) -> str:
    """'hops too low, misses the hop': the words of each verdict or :func:`verdict_token` (a
    name the table does not know, from a table of another version, as it is)."""
    return ", ".join(dict.fromkeys(_plain(v) for v in verdicts))


def _plain(token: str) -> str:
    name, _, cause = token.partition(_CAUSE)
    if cause in Divergence.__members__:
        return PLAIN_DIVERGENCES[Divergence[cause]]
    return PLAIN_VERDICTS.get(name, name)
