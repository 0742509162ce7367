"""The verdicts in plain words, for a reader who has not met the verdict table: what the
answer's sentences and its "wrong at every setting tried" column say in place of the
verdict's name (the names stay in answer.csv and answer.json, and docs/report.md's verdict
table says each one in full)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from hoopbench.engines.judging.verdict import Verdict

__all__ = ["PLAIN_VERDICTS", "plain_verdicts"]

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
"""Each verdict (engines/judging/verdict.Verdict) in a few plain words."""


def plain_verdicts(verdicts: Iterable[str]) -> str:
    """'hops too low, misses the hop': the words of each verdict (a name the table does not
    know, from a table of another version, as it is)."""
    return ", ".join(PLAIN_VERDICTS.get(v, v) for v in dict.fromkeys(verdicts))
