"""The answer in plain words: per accuracy tier, which engine and setting to use, what it
costs, and what no engine gets right; sentences generated from the same :class:`Answer` as
the answer's table (reports/report/answer.py), never an engine's name written by hand.

A tier's sentence names the setting within the tier on the largest share of its scenes: the
suites' cheapest such setting (:attr:`Answer.overall`: the answer's rule, applied across
engines) or a shipped search's (:func:`best_search`), whichever covers the larger share (the
suites' where they tie: measured by this report). It then gives the other, the best of the
suites' settings on each group of scenes of one exact outcome (:attr:`Answer.regimes`:
those that hop, those that slip), and closes with what no setting of any engine gets within
the loose tier, and the scenes that one or two engines alone get there
(:attr:`Answer.met_by`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import TIER_NAMES
from hoopbench.reports.compare.suite_file import LeftOut
from hoopbench.reports.report.answer import (
    ACCURACY_TIERS,
    Answer,
    Choice,
    Regime,
    SearchChoice,
    answer_markdown,
    best_search,
)
from hoopbench.reports.report.escaping import escape_text
from hoopbench.reports.report.verdict_words import plain_verdicts

__all__ = [
    "FEW_ENGINES",
    "AnswerLine",
    "answer_lines",
    "answer_section",
    "answer_sentences",
    "left_out_sentence",
]

FEW_ENGINES = 2
"""A scene within the loose tier for at most this many engines is named as one that few get
right."""

_OUTCOME_WORDS = {
    "hops": ("that hops", "that hop"),
    "slips": ("that slips", "that slip"),
    "rolls": ("that rolls", "that roll"),
    "painleve": ("that reaches a Painlevé point", "that reach a Painlevé point"),
}
"""An exact outcome as the sentences say a group of scenes with it (one scene, several)."""


def _cost(choice: Choice) -> str:
    return f"{choice.cost_per_sim_s:.3g} {choice.clock} s per simulated s"


def _suite_setting(choice: Choice) -> str:
    """'pybullet (tuned, default, dt 0.0001 s)'."""
    return f"{choice.setting.engine} ({choice.setting.label} s)"


def _missed(choice: Choice) -> str:
    """'; wrong on hop-low (hops too high), high-spin (lifts off early)'."""
    if not choice.missed:
        return ""
    said = [
        f"{scene} ({plain_verdicts(verdicts) if verdicts else 'not run'})"
        for scene, verdicts in choice.missed
    ]
    return f", short on {', '.join(said)}"


def _capital(text: str) -> str:
    return text[:1].upper() + text[1:]


@dataclass(frozen=True)
class AnswerLine:
    """One line of the answer in words: a lead sentence (which setting, at what cost) and
    the sentences that back it."""

    lead: str
    details: tuple[str, ...] = ()

    @property
    def text(self) -> str:
        return " ".join([self.lead, *self.details])


def _suite_lead(choice: Choice, scenes: int) -> str:
    """The suites' best setting of a tier, as the one to use or the nearest there is."""
    if choice.scenes_met == scenes:
        return (
            f"use {_suite_setting(choice)}, the cheapest of the suites' settings meeting it on "
            f"all {scenes} scenes, at {_cost(choice)}."
        )
    return (
        f"no engine meets it on all {scenes} scenes at the suites' settings; the most, "
        f"{choice.scenes_met}/{scenes}, {_suite_setting(choice)} at {_cost(choice)}"
        + _missed(choice)
        + "."
    )


def _search_lead(search: SearchChoice) -> str:
    """The searches' best setting of a tier: what it is, on how many scenes, its cost."""
    share = (
        f"all {search.scenes}"
        if search.scenes_met == search.scenes
        else f"{search.scenes_met}/{search.scenes}"
    )
    return (
        f"{search.engine}'s searched setting {search.setting} (dt {search.timestep:.3g} s), "
        f"within it on {share} of its search's scenes, {search.heldout} of them held out, at "
        f"{search.cost_per_sim_s:.3g} {search.clock.label} s per simulated s as the search "
        "measured it" + _tuned_ratio(search) + "."
    )


def _run_it(search: SearchChoice, tier: int) -> str:
    name = TIER_NAMES[Tier(ACCURACY_TIERS[tier].name)]
    return f"Run it with --settings 'reports/tune/searches/{search.engine}/settings.toml#{name}'."


def _tuned_ratio(search: SearchChoice) -> str:
    """' (0.62 times tuned's cost in the same search)': a ratio within the search's clock."""
    if search.tuned_cost_per_sim_s is None:
        return ""
    ratio = search.cost_per_sim_s / search.tuned_cost_per_sim_s
    return f" ({ratio:.2g} times the tuned profile's cost in the same search)"


def _regime_clause(regime: Regime, tier: int) -> str:
    choice = regime.best[tier]
    n = len(regime.scenes)
    words = _OUTCOME_WORDS.get(regime.outcome, (f"of outcome {regime.outcome}",) * 2)
    what = f"on the 1 scene {words[0]}" if n == 1 else f"on the {n} scenes {words[1]}"
    if choice is None:
        return f"{what}, none"
    met = ("it" if n == 1 else f"all {n}") if choice.scenes_met == n else f"{choice.scenes_met}/{n}"
    return f"{what}, {_suite_setting(choice)} on {met} at {_cost(choice)}"


def _tier_line(result: Answer, tier: int) -> AnswerLine:
    """One tier: the setting to use and its cost; then the other source's best, and the
    suites' best per exact outcome."""
    name = ACCURACY_TIERS[tier]
    suite = result.overall[tier] if result.overall else None
    search = best_search(result, tier)
    n = len(result.scenes)
    suite_share = 0.0 if suite is None else suite.scenes_met / n
    head = f"{_capital(name.name)} ({name.meaning}): "
    details: list[str] = []
    if search is not None and search.scenes_met / search.scenes > suite_share:
        lead = f"{head}use {_search_lead(search)}"
        details.append(_run_it(search, tier))
        details.append(
            "No run of the suites meets it." if suite is None else _capital(_suite_lead(suite, n))
        )
    elif suite is not None:
        lead = f"{head}{_suite_lead(suite, n)}"
        if search is not None:
            details.append(f"The shipped searches' best: {_search_lead(search)}")
    else:
        lead = f"{head}no run meets it."
    if result.regimes:
        clauses = "; ".join(_regime_clause(regime, tier) for regime in result.regimes)
        details.append(f"By exact outcome, at the suites' settings: {clauses}.")
    return AnswerLine(lead, tuple(details))


def _nobody_line(result: Answer) -> AnswerLine:
    """What no engine gets within the loose tier (at any setting tried, or at the suites'
    timesteps), and what few do."""
    never = [limit.scene for limit in result.limits if limit.agreeing_timestep is None]
    finer = [limit for limit in result.limits if limit.agreeing_timestep is not None]
    loose = result.overall[-1] if result.overall else None
    said = []
    if never:
        said.append(
            f"no setting of any engine meets the loose tier on {', '.join(never)}, at any "
            "timestep tried"
        )
    if finer:
        said.append(
            "no engine meets the loose tier on "
            + ", ".join(f"{limit.scene} but at dt {limit.agreeing_timestep:g} s" for limit in finer)
            + ", finer than the suites' own timesteps (below)"
        )
    if loose is None or loose.scenes_met < len(result.scenes):
        said.append(
            f"no one setting of the suites meets the loose tier on all {len(result.scenes)} "
            "scenes of the table, though each is met by some engine"
        )
    lead = "What no engine gets right: " + ("; ".join(said) if said else "nothing") + "."
    few = [(s, engines) for s, engines in result.met_by if 0 < len(engines) <= FEW_ENGINES]
    if not few:
        return AnswerLine(lead)
    met = "; ".join(f"{scene} by {' and '.join(engines)} alone" for scene, engines in few)
    return AnswerLine(lead, (f"Met within loose by few engines: {met}.",))


def answer_lines(result: Answer) -> list[AnswerLine]:
    """The answer in plain words (module doc): a line per tier and one on what no engine
    gets right, as plain text (the report escapes it); empty when no engine run was
    judged."""
    if not result.engines or not result.scenes:
        return []
    return [
        *(_tier_line(result, tier) for tier in range(len(ACCURACY_TIERS))),
        _nobody_line(result),
    ]


def answer_sentences(result: Answer) -> list[str]:
    """Each of :func:`answer_lines` as one text: its lead, then its details."""
    return [line.text for line in answer_lines(result)]


def _bullets(lines: Sequence[AnswerLine]) -> list[str]:
    """A bullet per line, its lead in bold, its details a nested bullet each."""
    out = []
    for line in lines:
        out.append(f"- **{escape_text(line.lead)}**")
        out += [f"  - {escape_text(detail)}" for detail in line.details]
    return out


def answer_section(
    result: Answer,
    *,
    heading: bool = True,
    left_out: Sequence[tuple[str, LeftOut]] = (),
) -> str:
    """The answer's section (Markdown, ending in a blank line): the lines in words, then
    the table and its notes (answer_markdown), then what its suites left out here for want
    of a GPU (``left_out``: suite name and LeftOut, :func:`left_out_sentence`); its heading
    left out without ``heading`` (the README has its own); empty text when no engine run was
    judged."""
    table = answer_markdown(result, heading=False)
    if not table:
        return ""
    title = ["## The answer: which engine, which settings, at what cost", ""] if heading else []
    words = _bullets(answer_lines(result))
    missing = [left_out_sentence(left_out), ""] if left_out else []
    return "\n".join([*title, *words, *([""] if words else []), table, *missing])


def left_out_sentence(left_out: Sequence[tuple[str, LeftOut]]) -> str:
    """One sentence under the answer's table: the runs its suites did not run on this machine
    for want of a GPU (suite name and LeftOut each), so that an engine's row is read as
    without them."""
    parts = "; ".join(
        f"{item.label}, {item.runs} run{'s' if item.runs != 1 else ''} of the {suite} suite "
        f"({item.reason})"
        for suite, item in left_out
    )
    return escape_text(
        f"Left out on this machine for want of a GPU, so not in the rows above: {parts}."
    )
