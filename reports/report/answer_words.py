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

from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import TIER_NAMES
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

__all__ = ["FEW_ENGINES", "answer_section", "answer_sentences"]

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


def _suite_clause(choice: Choice | None, scenes: int) -> str:
    """What the suites' best setting of a tier does on the answer's scenes."""
    if choice is None:
        return "no run of the suites meets it"
    if choice.scenes_met == scenes:
        return (
            f"of the suites' settings, {_suite_setting(choice)} is the cheapest meeting it on "
            f"all {scenes} scenes, at {_cost(choice)}"
        )
    return (
        f"at the suites' settings no engine meets it on all {scenes} scenes: the most, "
        f"{choice.scenes_met}/{scenes}, {_suite_setting(choice)} at {_cost(choice)}"
        + _missed(choice)
    )


def _search_clause(search: SearchChoice, tier: int) -> str:
    """What the searches' best setting of a tier does on its search's scenes."""
    name = TIER_NAMES[Tier(ACCURACY_TIERS[tier].name)]
    share = (
        f"all {search.scenes}"
        if search.scenes_met == search.scenes
        else f"{search.scenes_met}/{search.scenes}"
    )
    return (
        f"{search.engine}'s searched setting {search.setting} (dt {search.timestep:.3g} s; "
        f"--settings 'reports/tune/searches/{search.engine}/settings.toml#{name}'), within "
        f"it on {share} of its search's scenes, {search.heldout} of them held out, at "
        f"{search.wall_per_sim_s:.3g} wall s per simulated s as the search measured it"
        + _tuned_ratio(search)
    )


def _tuned_ratio(search: SearchChoice) -> str:
    """' (0.62 times tuned's cost in the same search)': a ratio within the search's clock."""
    if search.tuned_wall_per_sim_s is None:
        return ""
    ratio = search.wall_per_sim_s / search.tuned_wall_per_sim_s
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


def _tier_sentence(result: Answer, tier: int) -> str:
    """One tier: the setting to use, its cost, and the other source's best."""
    name = ACCURACY_TIERS[tier]
    suite = result.overall[tier] if result.overall else None
    search = best_search(result, tier)
    n = len(result.scenes)
    suite_share = 0.0 if suite is None else suite.scenes_met / n
    head = f"{name.name.capitalize()} ({name.meaning}): "
    if search is not None and search.scenes_met / search.scenes > suite_share:
        text = f"{head}use {_search_clause(search, tier)}; {_suite_clause(suite, n)}."
    elif suite is not None:
        use = "" if suite.scenes_met < n else f"use {_suite_setting(suite)}: "
        text = f"{head}{use}{_suite_clause(suite, n)}."
        if search is not None:
            text += f" The shipped searches' best: {_search_clause(search, tier)}."
    else:
        text = f"{head}no run meets it."
    if result.regimes:
        text += " By exact outcome: " + "; ".join(
            _regime_clause(regime, tier) for regime in result.regimes
        )
        text += "."
    return text


def _nobody_sentence(result: Answer) -> str:
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
    text = "What no engine gets right: " + ("; ".join(said) if said else "nothing") + "."
    few = [(s, engines) for s, engines in result.met_by if 0 < len(engines) <= FEW_ENGINES]
    if few:
        text += " Met within loose by few engines: " + "; ".join(
            f"{scene} by {' and '.join(engines)} alone" for scene, engines in few
        )
        text += "."
    return text


def answer_sentences(result: Answer) -> list[str]:
    """The answer in plain words (module doc), one sentence or two per tier and one on what
    no engine gets right, as plain text (the report escapes it); empty when no engine run was
    judged."""
    if not result.engines or not result.scenes:
        return []
    return [
        *(_tier_sentence(result, tier) for tier in range(len(ACCURACY_TIERS))),
        _nobody_sentence(result),
    ]


def _bullets(sentences: Sequence[str]) -> list[str]:
    return [f"- {escape_text(sentence)}" for sentence in sentences]


def answer_section(result: Answer, *, heading: bool = True) -> str:
    """The answer's section (Markdown, ending in a blank line): the sentences, then the
    table and its notes (answer_markdown); its heading left out without ``heading`` (the
    README has its own); empty text when no engine run was judged."""
    table = answer_markdown(result, heading=False)
    if not table:
        return ""
    title = ["## The answer: which engine, which settings, at what cost", ""] if heading else []
    words = _bullets(answer_sentences(result))
    return "\n".join([*title, *words, *([""] if words else []), table])
