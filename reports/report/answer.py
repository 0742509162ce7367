"""The report's answer: per engine, the cheapest setting tried that meets each accuracy tier
on every catalogue scene, what it costs, and what the engine gets wrong whatever its setting.

Computing apart from presenting: :func:`answer` reads the runs table and returns a frozen
:class:`Answer`; :func:`answer_markdown` renders it as the report's first section.

A **setting** is what a user chooses: engine, profile, variant and timestep. A setting meets a
tier when it ran every scene the answer covers (the catalogue scenes of the comparison suites
that have an exact answer to judge against) and every one of those runs has a verdict of the
tier (:data:`ACCURACY_TIERS`). Its cost is the median over those runs of the stepping time
per step, and the same as seconds of wall time per simulated second (``us_per_step`` / dt):
the number that says whether an engine keeps up with real time. The cheapest is the one with
the fewest seconds per simulated second.

A scene's failure is the engine's, not the timestep's, only if some timestep lets an engine
meet the tier there: :func:`timestep_limits` says, per scene, the coarsest timestep at which
any engine meets the loose tier, so that a scene every engine fails at the suite's timesteps
reads as the timestep's limit where a finer run shows it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.score import cheapest_of_most
from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import TIER_VERDICTS
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import DEFAULT_TIMESTEP
from hoopbench.models.catalogue import scene_names
from hoopbench.reports.compare.selection import engine_names_of, engine_rows, profile_of
from hoopbench.reports.compare.suite_file import DEFAULT_VARIANT
from hoopbench.reports.report.escaping import escape_cell, escape_text

__all__ = [
    "ACCURACY_TIERS",
    "AccuracyTier",
    "Answer",
    "Choice",
    "EngineAnswer",
    "Setting",
    "TimestepLimit",
    "answer",
    "answer_markdown",
    "timestep_limits",
]


@dataclass(frozen=True)
class AccuracyTier:
    """An accuracy a user may ask for: the verdicts that meet it."""

    name: str
    verdicts: frozenset[str]
    meaning: str
    """What a run of the tier gets right, for the reader."""


ACCURACY_TIERS: tuple[AccuracyTier, ...] = tuple(
    AccuracyTier(
        str(tier),
        frozenset(str(v) for v in TIER_VERDICTS[tier]),
        f"every event within the {tier} tolerances",
    )
    for tier in Tier
)
"""The accuracy tiers of every summary as the answer words them, tight then loose: tight =
{agrees}, loose = {agrees, close}. The verdicts are the judging layer's
(engines/judging/verdict.TIER_VERDICTS), the tolerances behind them its table
(engines/judging/tolerances.toml)."""


@dataclass(frozen=True)
class Setting:
    """What a user chooses for a run."""

    engine: str
    profile: str
    variant: str
    timestep: float
    """s"""

    @property
    def label(self) -> str:
        return f"{self.profile}, {self.variant}, dt {self.timestep:g}"


@dataclass(frozen=True)
class Choice:
    """A setting with its cost."""

    setting: Setting
    scenes_met: int
    """How many of the answer's scenes its runs meet the tier on."""
    us_per_step: float
    """Median stepping time per step over the setting's runs, microseconds."""
    wall_per_sim_s: float
    """Seconds of wall time per simulated second: us_per_step / dt (below 1: faster than
    real time)."""


@dataclass(frozen=True)
class EngineAnswer:
    """One engine's line of the answer."""

    engine: str
    cheapest: tuple[Choice | None, ...]
    """Per tier of ACCURACY_TIERS (same order): the cheapest of the settings meeting it on
    the most scenes (all of them, where one does); None where no run meets it."""
    always_wrong: tuple[tuple[str, tuple[str, ...]], ...]
    """(scene, the verdicts its runs got) for each scene where no setting tried meets the
    loose tier."""
    settings_tried: int
    """Settings with at least one judged run."""


@dataclass(frozen=True)
class TimestepLimit:
    """A scene no engine meets the loose tier on at the default timestep or coarser."""

    scene: str
    finest: float
    """The finest timestep any engine ran the scene at, s."""
    agreeing_timestep: float | None
    """The coarsest timestep at which some engine meets the loose tier, s; None: none does."""
    agreeing: tuple[str, ...]
    """The settings meeting it there, as 'engine (profile[, variant])'."""


@dataclass(frozen=True)
class Answer:
    """The report's answer: the scenes it holds settings to, a line per engine, and the
    scenes the timestep limits."""

    scenes: tuple[str, ...]
    """The scenes a setting must meet: the judged catalogue scenes of the runs but those the
    timestep limits (``limits``)."""
    engines: tuple[EngineAnswer, ...]
    limits: tuple[TimestepLimit, ...]


# --------------------------------------------------------------------------- computing
def _judged(runs: pd.DataFrame) -> pd.DataFrame:
    """Engine runs that can say something about a setting: available, on a catalogue scene,
    with a verdict (a failed or diverged run has one: it counts against its setting)."""
    rows = engine_rows(runs)
    rows = rows[rows[Col.STATUS] != RunStatus.UNAVAILABLE]
    rows = rows[rows[Col.SCENE].isin(scene_names()) & rows[Col.VERDICT].notna()]
    return rows.assign(profile=profile_of(rows))


_KEYS = [Col.ENGINE, Col.PROFILE, Col.VARIANT, Col.TIMESTEP]


def _choice(key: tuple, group: pd.DataFrame, scenes: Sequence[str], tier: AccuracyTier) -> Choice:
    setting = Setting(str(key[0]), str(key[1]), str(key[2]), float(key[3]))
    met = group[group[Col.VERDICT].isin(tier.verdicts)][Col.SCENE]
    us = float(pd.to_numeric(group[Col.US_PER_STEP], errors="coerce").median())
    return Choice(setting, len(set(met) & set(scenes)), us, us * 1e-6 / setting.timestep)


def _cheapest(rows: pd.DataFrame, scenes: Sequence[str], tier: AccuracyTier) -> Choice | None:
    """Of the settings whose runs meet the tier on the most scenes, the cheapest (a setting
    whose cost was not measured comes last): the judging layer's rule (cheapest_of_most)."""
    choices = [_choice(key, group, scenes, tier) for key, group in rows.groupby(_KEYS)]
    return cheapest_of_most((c, c.scenes_met, c.wall_per_sim_s) for c in choices)


def _always_wrong(
    rows: pd.DataFrame, scenes: Sequence[str]
) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """(scene, its runs' verdicts) where no run of ``rows`` meets the loose tier."""
    loose = ACCURACY_TIERS[-1].verdicts
    wrong = []
    for scene in scenes:
        verdicts = rows[rows[Col.SCENE] == scene][Col.VERDICT].astype(str)
        if len(verdicts) and not verdicts.isin(loose).any():
            wrong.append((scene, tuple(sorted(set(verdicts)))))
    return tuple(wrong)


def _setting_name(engine: str, profile: str, variant: str) -> str:
    """'pybullet (tuned)', 'mujoco (stock, pyramidal)'."""
    return f"{engine} ({profile}{'' if variant == DEFAULT_VARIANT else f', {variant}'})"


def timestep_limits(runs: pd.DataFrame) -> tuple[TimestepLimit, ...]:
    """Per judged catalogue scene where no engine run at the default timestep or coarser
    meets the loose tier: the coarsest finer timestep at which one does (module doc)."""
    rows = _judged(runs)
    loose = ACCURACY_TIERS[-1].verdicts
    limits = []
    for scene, mine in rows.groupby(Col.SCENE, sort=False):
        good = mine[mine[Col.VERDICT].isin(loose)]
        if (good[Col.TIMESTEP] >= DEFAULT_TIMESTEP).any():
            continue
        finest = float(mine[Col.TIMESTEP].min())
        if good.empty:
            limits.append(TimestepLimit(str(scene), finest, None, ()))
            continue
        dt = float(good[Col.TIMESTEP].max())
        at = good[good[Col.TIMESTEP] == dt]
        names = dict.fromkeys(
            _setting_name(r.engine, r.profile, r.variant) for r in at.itertuples()
        )
        limits.append(TimestepLimit(str(scene), finest, dt, tuple(names)))
    return tuple(limits)


def answer(runs: pd.DataFrame) -> Answer:
    """The answer (module doc) from the comparison suites' rows (the stability suite's left
    out by the caller). The scenes the timestep limits are left out of the settings' scenes:
    every engine fails them at the default timestep and coarser, which says nothing about
    which engine to choose; the answer says so beside the table."""
    rows = _judged(runs)
    limits = timestep_limits(runs)
    limited = {limit.scene for limit in limits}
    scenes = tuple(s for s in dict.fromkeys(rows[Col.SCENE]) if s not in limited)
    engines = []
    for engine in engine_names_of(rows):
        mine = rows[rows[Col.ENGINE] == engine]
        engines.append(
            EngineAnswer(
                engine,
                tuple(_cheapest(mine, scenes, tier) for tier in ACCURACY_TIERS),
                _always_wrong(mine, scenes),
                mine.groupby(_KEYS).ngroups,
            )
        )
    return Answer(scenes, tuple(engines), limits)


# --------------------------------------------------------------------------- presenting
def _choice_cells(choice: Choice | None, scenes: int) -> list[str]:
    if choice is None:
        return ["none", "-", "-"]
    label = escape_cell(choice.setting.label)
    if choice.scenes_met < scenes:
        label += f" (only {choice.scenes_met}/{scenes} scenes)"
    return [label, f"{choice.us_per_step:.3g}", f"{choice.wall_per_sim_s:.3g}"]


def _wrong_cell(line: EngineAnswer) -> str:
    if not line.always_wrong:
        return "nothing"
    return escape_cell(
        "; ".join(f"{scene} ({', '.join(verdicts)})" for scene, verdicts in line.always_wrong)
    )


def _limit_sentence(limit: TimestepLimit) -> str:
    if limit.agreeing_timestep is None:
        return (
            f"{limit.scene}: no engine meets the loose tier at any timestep tried (the finest "
            f"{limit.finest:g} s)."
        )
    return (
        f"{limit.scene}: no engine meets the loose tier at dt {DEFAULT_TIMESTEP:g} s or "
        f"coarser; at {limit.agreeing_timestep:g} s {', '.join(limit.agreeing)} do. The "
        "timestep limits this scene, not the engines."
    )


def _scene_count(n: int) -> str:
    """'all 7 catalogue scenes', 'the 1 catalogue scene'."""
    return "the 1 catalogue scene" if n == 1 else f"all {n} catalogue scenes"


def answer_markdown(result: Answer, *, heading: bool = True) -> str:
    """The answer as the report's first section (Markdown, ending in a blank line), its
    heading left out without ``heading`` (the README has its own); empty text when no engine
    run was judged."""
    if not result.engines:
        return ""
    headers = ["engine"]
    for tier in ACCURACY_TIERS:
        headers += [f"{tier.name}: cheapest setting", "us/step", "s per simulated s"]
    headers.append("wrong at every setting tried")
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for line in result.engines:
        cells = [escape_cell(line.engine)]
        for choice in line.cheapest:
            cells += _choice_cells(choice, len(result.scenes))
        lines.append("| " + " | ".join([*cells, _wrong_cell(line)]) + " |")
    tiers = "; ".join(
        f"**{t.name}**: {t.meaning} (verdict {' or '.join(sorted(t.verdicts))})"
        for t in ACCURACY_TIERS
    )
    title = ["## The answer: which engine, which settings, at what cost", ""] if heading else []
    parts = [
        *title,
        "Per engine: the cheapest setting tried (profile, settings, timestep) whose runs meet "
        f"each accuracy tier on {_scene_count(len(result.scenes))} "
        f"({escape_text(', '.join(result.scenes))}), or on as many as any setting does; its "
        "cost (stepping time per step, and wall seconds per simulated second: below 1 is "
        "faster than real time); the scenes it gets wrong at every setting tried, with those "
        f"runs' verdicts. Tiers: {tiers}.",
        "",
        *lines,
    ]
    if result.limits:
        parts += [
            "",
            "Left out of the table, because no engine meets them at the suite's timesteps:",
            "",
            *(f"- {escape_text(_limit_sentence(limit))}" for limit in result.limits),
        ]
    return "\n".join([*parts, ""])
