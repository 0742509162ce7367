"""The report's answer: per engine, the cheapest setting tried that meets each accuracy tier
on every catalogue scene, what it costs, and what the engine gets wrong whatever its setting.

Computing apart from presenting: :func:`answer` reads the runs table and returns a frozen
:class:`Answer`; :func:`answer_markdown` renders it as the report's first section.

A **setting** is what a user chooses: engine, profile, variant and timestep. A setting meets a
tier when it ran every scene the answer covers (the catalogue scenes of the comparison suites
that have an exact answer to judge against) and every one of those runs has a verdict of the
tier (:data:`ACCURACY_TIERS`). Its cost is the median over those runs of the stepping time
per step, and the same as seconds per simulated second (us per step / dt): the number that
says whether an engine keeps up with real time. The stepping time is the process's CPU time
(``cpu_us_per_step``), which moves far less with the machine's load than the wall time; a
table stored without it (before issue 34) is ranked by its wall time (``us_per_step``), and
the answer says which (:attr:`Answer.clock`). The cheapest is the one with the fewest seconds
per simulated second; costs within the measured noise of the cheapest (score.COST_NOISE_FACTOR)
count as equal, and of those :func:`tie_order` chooses, not the clock. Beside its cost, the
setting's **worst transition**:
of every transition the verdicts of its runs that meet the tier timed (the first slip onset,
the lift-off, the impact, each re-stick, later slip onset and reversal), the one farthest from
the exact one against its loose tolerance (the rows' ``max_transition``): how near the tier's
edge the setting is.

A run ended by the sweep's time limit (status ``timeout``) is the machine's failure, not the
engine's: it is left out of the tiers (its setting lacks that scene, as if it had not run it)
and out of what the engine always gets wrong, and the answer names it (:attr:`Answer.timed_out`).

A scene's failure is the engine's, not the timestep's, only if some timestep lets an engine
meet the tier there: :func:`timestep_limits` says, per scene, the coarsest timestep at which
any engine meets the loose tier, so that a scene every engine fails at the suite's timesteps
reads as the timestep's limit where a finer run shows it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from itertools import compress

import numpy as np
import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.score import (
    COST_NOISE_FACTOR,
    CostClock,
    cheapest_of_most,
    costs_equal,
)
from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import TIER_NAMES, TIER_VERDICTS, number_or_none
from hoopbench.engines.options import Profile
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import DEFAULT_TIMESTEP
from hoopbench.models.catalogue import scene_names
from hoopbench.reports.compare.selection import (
    engine_names_of,
    engine_rows,
    profile_of,
    step_cost_column,
)
from hoopbench.reports.compare.suite_file import DEFAULT_VARIANT
from hoopbench.reports.report.best_settings import BestSettings
from hoopbench.reports.report.escaping import escape_cell, escape_text
from hoopbench.reports.report.verdict_words import plain_verdicts, verdict_token

__all__ = [
    "ACCURACY_TIERS",
    "RANK_RULE",
    "AccuracyTier",
    "Answer",
    "AtBest",
    "Choice",
    "EngineAnswer",
    "Regime",
    "SearchChoice",
    "Setting",
    "TimestepLimit",
    "WorstTransition",
    "answer",
    "answer_markdown",
    "at_best",
    "best_search",
    "rank_key",
    "ranked",
    "tie_order",
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
class WorstTransition:
    """The transition of a setting's runs farthest from the exact one, against its loose
    tolerance (the rows' max_transition columns)."""

    scene: str
    name: str
    """'re-stick 2', 'slip onset', 'impact', ..."""
    error_ms: float
    """Run minus exact, ms."""
    ratio: float
    """|error| over the loose tolerance."""


@dataclass(frozen=True)
class Choice:
    """A setting with its cost."""

    setting: Setting
    scenes_met: int
    """How many of the answer's scenes its runs meet the tier on."""
    us_per_step: float
    """Median stepping time per step over the setting's runs (by ``clock``), microseconds."""
    cost_per_sim_s: float
    """Seconds of stepping time (by ``clock``) per simulated second: us_per_step / dt (below
    1: faster than real time)."""
    worst: WorstTransition | None = None
    """The worst transition of its runs that meet the tier on the answer's scenes (None where
    none was timed, or the rows were stored without it)."""
    changed_options: int = 0
    """How many options its runs change from their profile's values (Col.OPTIONS)."""
    clock: str = "CPU"
    """Whose time the cost is: ``CPU`` (the process's) or ``wall`` (a table stored without
    the CPU time)."""
    missed: tuple[tuple[str, tuple[str, ...]], ...] = ()
    """(scene, its runs' verdicts; empty: not run) for each of the scenes it was chosen on
    that its runs do not meet the tier on."""


@dataclass(frozen=True)
class SearchChoice:
    """The setting a shipped search of ``hoopbench tune`` names for a tier (its settings
    file's ``[tiers]``), with what the search measured of it."""

    engine: str
    setting: str
    """The search's name for it (e.g. ``trial-34``): ``settings.toml#TIER`` runs it."""
    timestep: float
    """s (a continuous integrator's is its output step)."""
    scenes_met: int
    """How many of the search's scenes, training and held-out, its runs are within the tier."""
    scenes: int
    heldout: int
    """How many of ``scenes`` are held out (scenes the search never trained on)."""
    heldout_tier: str
    """The tier its runs reach on every held-out scene: agrees, close or none."""
    cost_per_sim_s: float
    """Seconds of stepping time by ``clock`` per simulated second on the training scenes, as
    measured by the search (on the machine and load of the search)."""
    clock: CostClock = CostClock.WALL
    """The clock of the search's costs (its tune.json's cost_clock; wall where it has none)."""
    tuned_cost_per_sim_s: float | None = None
    """The same of the engine's tuned profile, the search's baseline (None where its front
    has none): a cost ratio within one clock and one search, the only comparison of a
    search's cost the answer makes."""


@dataclass(frozen=True)
class AtBest:
    """One engine's best for a tier: the suite's setting or the search's, whichever is within
    the tier on the larger share of its own scenes (the suite's where they tie: their costs
    are never compared, measured by other runs, machines or clocks)."""

    engine: str
    tier: str
    suite: Choice | None
    suite_scenes: int
    """The answer's scene count, which ``suite.scenes_met`` is out of."""
    search: SearchChoice | None

    @property
    def from_search(self) -> bool:
        """Whether the search's setting is the better one (class doc)."""
        if self.search is None:
            return False
        if self.suite is None:
            return True
        return self.search.scenes_met / self.search.scenes > (
            self.suite.scenes_met / self.suite_scenes
        )


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
    searched: tuple[SearchChoice | None, ...] = ()
    """Per tier of ACCURACY_TIERS: the setting the engine's shipped search names for it (None
    where it names none); empty without a search."""


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
class Regime:
    """The answer's scenes of one exact outcome (those that hop, those that slip, ...), and
    per tier the cheapest setting of any engine meeting it on the most of them."""

    outcome: str
    """The exact solution's outcome: hops, slips, rolls, painleve."""
    scenes: tuple[str, ...]
    best: tuple[Choice | None, ...]
    """Per tier of ACCURACY_TIERS (same order); None where no run meets it."""


@dataclass(frozen=True)
class Answer:
    """The report's answer: the scenes it holds settings to, a line per engine, and the
    scenes the timestep limits."""

    scenes: tuple[str, ...]
    """The scenes a setting must meet: the judged catalogue scenes of the runs but those the
    timestep limits (``limits``)."""
    engines: tuple[EngineAnswer, ...]
    limits: tuple[TimestepLimit, ...]
    clock: str = "CPU"
    """Whose time the costs are: ``CPU`` (the process's, Col.CPU_US_PER_STEP) where the runs
    carry it, else ``wall`` (Col.US_PER_STEP: a table stored before issue 34)."""
    timed_out: tuple[tuple[str, str], ...] = ()
    """(setting name, scene) of each run the sweep's time limit ended: left out (module
    doc)."""
    overall: tuple[Choice | None, ...] = ()
    """Per tier of ACCURACY_TIERS: of every engine's setting in the suites, the cheapest of
    those meeting it on the most scenes (the same rule as an engine's); empty without
    engines."""
    regimes: tuple[Regime, ...] = ()
    """The answer's scenes by their exact outcome, where the rows carry it and there are
    two outcomes or more."""
    met_by: tuple[tuple[str, tuple[str, ...]], ...] = ()
    """(scene, the engines some setting of which meets the loose tier on it) per scene of
    ``scenes``."""


# --------------------------------------------------------------------------- computing
def _judged(runs: pd.DataFrame) -> pd.DataFrame:
    """Engine runs that can say something about a setting: available, on a catalogue scene,
    with a verdict (a failed or diverged run has one: it counts against its setting)."""
    rows = engine_rows(runs)
    rows = rows[~rows[Col.STATUS].isin([RunStatus.UNAVAILABLE, RunStatus.TIMEOUT])]
    rows = rows[rows[Col.SCENE].isin(scene_names()) & rows[Col.VERDICT].notna()]
    return rows.assign(profile=profile_of(rows))


def _timed_out(runs: pd.DataFrame) -> tuple[tuple[str, str], ...]:
    """(setting name, scene) of the engine runs on catalogue scenes that the sweep's time
    limit ended (whatever verdict a table stored before issue 34 gave them)."""
    rows = engine_rows(runs)
    rows = rows[(rows[Col.STATUS] == RunStatus.TIMEOUT) & rows[Col.SCENE].isin(scene_names())]
    rows = rows.assign(profile=profile_of(rows))
    return tuple(
        (f"{_setting_name(r.engine, r.profile, r.variant)} dt {float(r.timestep):g}", r.scene)
        for r in rows.itertuples()
    )


def _clock(rows: pd.DataFrame) -> str:
    """Whose time the answer's costs are (Answer.clock): the CPU time where the rows carry
    it, else the wall time (selection.step_cost_column)."""
    return "CPU" if step_cost_column(rows) == Col.CPU_US_PER_STEP else "wall"


_KEYS = [Col.ENGINE, Col.PROFILE, Col.VARIANT, Col.TIMESTEP]


@dataclass(frozen=True)
class _SettingRuns:
    """One setting's runs among some judged rows, and what weighing it against a tier reads
    of them whatever the tier and the scenes: made once per setting, not once per tier and
    group of scenes (a report weighs some 100 settings on 2 tiers for every engine and every
    regime)."""

    setting: Setting
    at: np.ndarray
    """The runs' positions in the judged rows (:class:`_Judged`)."""
    met: tuple[frozenset[str], ...]
    """Per tier of ACCURACY_TIERS: the scenes a run of it meets the tier on."""
    us_per_step: float
    """The median stepping time of the runs (by the answer's clock), microseconds."""
    changed_options: int
    """The most options any of the runs changes from its profile's values."""


@dataclass(frozen=True)
class _Judged:
    """The judged rows (:func:`_judged`) with the columns the answer reads of them as lists
    and arrays, read once for every setting, tier and group of scenes."""

    rows: pd.DataFrame
    scene: list[str]
    verdict: list[str]
    """The verdicts as text, a diverged run's with its cause (verdict_words.verdict_token)."""
    meets: tuple[np.ndarray, ...]
    """Per tier of ACCURACY_TIERS: whether each row's verdict is of it."""
    cost: np.ndarray
    """Each row's stepping time per step by the answer's clock (NaN: not measured), us."""
    options: list[int]
    """Per row, how many options it changes (:func:`_changed_options`)."""
    ratio: np.ndarray | None
    """Each row's max_transition_ratio (None: the rows were stored without it)."""
    clock: str
    settings: dict[tuple, np.ndarray]
    """Each setting's key (_KEYS) -> the positions of its rows, in groupby's order."""


def _judged_rows(rows: pd.DataFrame) -> _Judged:
    clock = _clock(rows)
    column = Col.CPU_US_PER_STEP if clock == "CPU" else Col.US_PER_STEP
    cost = rows[column] if column in rows.columns else pd.Series(math.nan, index=rows.index)
    ratio = (
        pd.to_numeric(rows[Col.MAX_TRANSITION_RATIO], errors="coerce").to_numpy(dtype=float)
        if Col.MAX_TRANSITION_RATIO in rows.columns
        else None
    )
    return _Judged(
        rows,
        rows[Col.SCENE].tolist(),
        _verdict_tokens(rows),
        tuple(rows[Col.VERDICT].isin(tier.verdicts).to_numpy() for tier in ACCURACY_TIERS),
        pd.to_numeric(cost, errors="coerce").to_numpy(dtype=float),
        _changed_options(rows),
        ratio,
        clock,
        dict(rows.groupby(_KEYS).indices) if len(rows) else {},
    )


def _verdict_tokens(rows: pd.DataFrame) -> list[str]:
    """Each row's verdict, a diverged one with the cause its message tells."""
    messages = rows[Col.MESSAGE] if Col.MESSAGE in rows.columns else [None] * len(rows)
    verdicts = rows[Col.VERDICT].astype(str)
    return [verdict_token(v, m) for v, m in zip(verdicts, messages, strict=True)]


def _changed_options(rows: pd.DataFrame) -> list[int]:
    """Per row, how many options it changes from its profile's values (Col.OPTIONS, JSON);
    a row without it counts its variant (0 for the default variant, else 1). A setting's
    count is the most of its rows'."""
    counts = [0 if str(v) == DEFAULT_VARIANT else 1 for v in rows[Col.VARIANT]]
    if Col.OPTIONS in rows.columns:
        for k, text in enumerate(rows[Col.OPTIONS]):
            try:
                counts[k] = max(counts[k], len(json.loads(text)))
            except (TypeError, ValueError):
                continue
    return counts


def _setting_runs(judged: _Judged, key: tuple, at: np.ndarray) -> _SettingRuns:
    scenes = [judged.scene[k] for k in at]
    return _SettingRuns(
        Setting(str(key[0]), str(key[1]), str(key[2]), float(key[3])),
        at,
        tuple(frozenset(compress(scenes, meets[at].tolist())) for meets in judged.meets),
        # The median as pandas takes it (NaN left out), of the same floats.
        float(pd.Series(judged.cost[at]).median()),
        max((judged.options[k] for k in at), default=0),
    )


def _settings_of(judged: _Judged, keep: np.ndarray | None = None) -> list[_SettingRuns]:
    """The settings of the judged rows (of those ``keep`` marks, if given), in groupby's
    order of their keys: a setting without a kept row left out."""
    found = []
    for key, at in judged.settings.items():
        mine = at if keep is None else at[keep[at]]
        if len(mine):
            found.append(_setting_runs(judged, key, mine))
    return found


def _worst_transition(
    judged: _Judged, at: np.ndarray, scenes: Sequence[str], tier: int
) -> WorstTransition | None:
    """The worst transition (the largest max_transition_ratio) of a setting's runs (at) on
    ``scenes`` that meet ``ACCURACY_TIERS[tier]``: how near the tier's edge they are."""
    if judged.ratio is None:
        return None
    wanted = set(scenes)
    meets = judged.meets[tier]
    mine = np.array([k for k in at if judged.scene[k] in wanted and meets[k]], dtype=int)
    ratio = judged.ratio[mine]
    if np.isnan(ratio).all():
        return None
    at_worst = int(mine[int(np.where(np.isnan(ratio), -math.inf, ratio).argmax())])
    rows = judged.rows

    def value(column: str) -> object:
        return rows[column].iloc[at_worst] if column in rows.columns else None

    error = number_or_none(value(Col.MAX_TRANSITION_ERR_MS))
    return WorstTransition(
        str(value(Col.SCENE)),
        str(value(Col.MAX_TRANSITION)),
        math.nan if error is None else error,
        float(np.nanmax(ratio)),
    )


def _missed(
    judged: _Judged, runs: _SettingRuns, scenes: Sequence[str], tier: int
) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """(scene, its runs' verdicts; empty: not run) of each of ``scenes`` that the setting's
    runs do not meet the tier on."""
    verdicts: dict[str, set[str]] = {}
    for k in runs.at:
        verdicts.setdefault(judged.scene[k], set()).add(judged.verdict[k])
    met = runs.met[tier]
    return tuple(
        (scene, tuple(sorted(verdicts.get(scene, ())))) for scene in scenes if scene not in met
    )


def _choice(runs: _SettingRuns, scenes: Sequence[str], tier: int, clock: str) -> Choice:
    """The setting's choice for the tier on ``scenes``, without what only the chosen one
    shows (its worst transition and the scenes it misses: :func:`_cheapest`)."""
    us = runs.us_per_step
    return Choice(
        runs.setting,
        len(runs.met[tier] & set(scenes)),
        us,
        us * 1e-6 / runs.setting.timestep,
        changed_options=runs.changed_options,
        clock=clock,
    )


def tie_order(choice: Choice) -> tuple[float, bool, int, str, str]:
    """The order of settings whose costs are equal within the noise (score.COST_NOISE_FACTOR),
    first chosen first: the larger timestep (the same accuracy from fewer steps), then the
    stock profile before the tuned one (the engine as its users get it), then fewer options
    changed from the profile's values, then the variant's and the profile's names. Nothing
    measured enters it, so two runs of the same suites order alike."""
    setting = choice.setting
    return (
        -setting.timestep,
        setting.profile != str(Profile.STOCK),
        choice.changed_options,
        setting.variant,
        setting.profile,
    )


def _cheapest(
    judged: _Judged, settings: Sequence[_SettingRuns], scenes: Sequence[str], tier: int
) -> Choice | None:
    """Of the settings whose runs meet the tier on the most scenes, the cheapest (a setting
    whose cost was not measured comes last), costs within the noise ordered by tie_order:
    the judging layer's rule (cheapest_of_most). Its worst transition and the scenes it
    misses are read for it alone: neither enters the choice."""
    pairs = [(_choice(runs, scenes, tier, judged.clock), runs) for runs in settings]
    best = cheapest_of_most(
        ((pair, pair[0].scenes_met, pair[0].cost_per_sim_s) for pair in pairs),
        lambda pair: tie_order(pair[0]),
    )
    if best is None:
        return None
    choice, runs = best
    return replace(
        choice,
        worst=_worst_transition(judged, runs.at, scenes, tier),
        missed=_missed(judged, runs, scenes, tier),
    )


def _always_wrong(
    judged: _Judged, at: np.ndarray, scenes: Sequence[str]
) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """(scene, its runs' verdicts) where no run of ``at`` meets the loose tier."""
    loose = ACCURACY_TIERS[-1].verdicts
    by_scene: dict[str, list[str]] = {}
    for k in at:
        by_scene.setdefault(judged.scene[k], []).append(judged.verdict[k])
    wrong = []
    for scene in scenes:
        verdicts = by_scene.get(scene, [])
        if verdicts and not any(v in loose for v in verdicts):
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


def _search_choice(best: BestSettings, tier: AccuracyTier) -> SearchChoice | None:
    """What ``best``'s settings file names for ``tier`` (its [tiers]), with its front row."""
    choice = best.cheapest.get(TIER_NAMES[Tier(tier.name)])
    if choice is None or choice.scenes == 0:
        return None
    row = best.front[best.front["setting"] == choice.setting].iloc[0]
    heldout = row.get("heldout_tier")
    return SearchChoice(
        engine=best.engine,
        setting=choice.setting,
        timestep=float(row["timestep"]),
        scenes_met=choice.scenes_within,
        scenes=choice.scenes,
        heldout=choice.scenes - len(best.training_scenes),
        heldout_tier=str(heldout) if isinstance(heldout, str) else "-",
        cost_per_sim_s=float(row["train_cost_us_per_s"]) * 1e-6,
        clock=best.cost_clock,
        tuned_cost_per_sim_s=_tuned_cost(best.front),
    )


def _tuned_cost(front: pd.DataFrame) -> float | None:
    """The search's cost of its ``tuned`` baseline (by the search's clock), s per simulated
    s (None: none)."""
    tuned = pd.to_numeric(front[front["setting"] == "tuned"]["train_cost_us_per_s"])
    cost = float(tuned.iloc[0]) * 1e-6 if len(tuned) else math.nan
    return cost if math.isfinite(cost) and cost > 0 else None


def _searched(searches: Sequence[BestSettings], engine: str) -> tuple[SearchChoice | None, ...]:
    mine = [best for best in searches if best.engine == engine]
    if not mine:
        return ()
    return tuple(_search_choice(mine[-1], tier) for tier in ACCURACY_TIERS)


def answer(runs: pd.DataFrame, searches: Sequence[BestSettings] = ()) -> Answer:
    """The answer (module doc) from the comparison suites' rows (the stability suite's left
    out by the caller) and the shipped searches' settings files (``searches``: each engine's
    last one counts). The scenes the timestep limits are left out of the settings' scenes:
    every engine fails them at the default timestep and coarser, which says nothing about
    which engine to choose; the answer says so beside the table."""
    rows = _judged(runs)
    judged = _judged_rows(rows)
    limits = timestep_limits(runs)
    limited = {limit.scene for limit in limits}
    scenes = tuple(s for s in dict.fromkeys(rows[Col.SCENE]) if s not in limited)
    tiers = range(len(ACCURACY_TIERS))
    settings = _settings_of(judged)
    engine_of = rows[Col.ENGINE].to_numpy()
    engines = []
    names = dict.fromkeys([*engine_names_of(rows), *(best.engine for best in searches)])
    for engine in names:
        mine = [s for s in settings if s.setting.engine == engine]
        engines.append(
            EngineAnswer(
                engine,
                tuple(_cheapest(judged, mine, scenes, tier) for tier in tiers),
                _always_wrong(judged, np.flatnonzero(engine_of == engine), scenes),
                len(mine),
                _searched(searches, engine),
            )
        )
    overall = tuple(
        cheapest_of_most(
            ((c, c.scenes_met, c.cost_per_sim_s) for c in choices if c is not None), tie_order
        )
        for choices in zip(*(line.cheapest for line in engines), strict=True)
    )
    return Answer(
        scenes,
        tuple(engines),
        limits,
        judged.clock,
        _timed_out(runs),
        overall,
        _regimes(judged, scenes),
        _met_by(judged, scenes),
    )


def _met_by(judged: _Judged, scenes: Sequence[str]) -> tuple[tuple[str, tuple[str, ...]], ...]:
    """Per scene, the engines with a run on it that meets the loose tier, in the rows' order."""
    engines = judged.rows[Col.ENGINE].astype(str).tolist()
    by_scene: dict[str, dict[str, None]] = {}
    for k in np.flatnonzero(judged.meets[-1]):
        by_scene.setdefault(judged.scene[k], {})[engines[k]] = None
    return tuple((scene, tuple(by_scene.get(scene, {}))) for scene in scenes)


RANK_RULE = (
    "engines ranked by how many scenes their loose-tier setting meets (most first), then "
    "their tight-tier setting, then the loose setting's cost (cheapest first; costs within a "
    f"factor {COST_NOISE_FACTOR:g} of the cheapest of theirs count as equal, by name); an "
    "engine of the searches alone last"
)
"""How the answer's table orders its engines (:func:`rank_key`, :func:`ranked`), in words."""


def _scenes_met(line: EngineAnswer) -> tuple[int, ...]:
    """Minus the scenes met per tier, the loosest tier first (most first in a sort)."""
    return tuple(-(c.scenes_met if c is not None else 0) for c in reversed(line.cheapest))


def _loosest_cost(line: EngineAnswer) -> float:
    loosest = line.cheapest[-1] if line.cheapest else None
    cost = loosest.cost_per_sim_s if loosest is not None else math.inf
    return cost if math.isfinite(cost) else math.inf


def rank_key(line: EngineAnswer) -> tuple[bool, tuple[int, ...], float, str]:
    """The answer table's order before its costs' noise (RANK_RULE): the engines with runs
    first; then the scenes met per tier, the loosest tier first; then the loosest tier's
    cost; then the name. :func:`ranked` then orders by name the costs within the noise."""
    return (line.settings_tried == 0, _scenes_met(line), _loosest_cost(line), line.engine)


def _by_name_within_the_noise(lines: Sequence[EngineAnswer]) -> list[EngineAnswer]:
    """Lines in rank_key's order, where each run of lines alike in rank_key's first two
    parts (runs or not, scenes met) whose costs are within the noise of the cheapest of them
    (score.COST_NOISE_FACTOR) is ordered by name: two reports on one machine rank alike where
    only the clock differs (Drake's loose cost was 1.27-1.64 times DART's in seven reports:
    within the noise, so their order would be the clock's)."""
    ordered: list[EngineAnswer] = []
    group: list[EngineAnswer] = []
    for line in lines:
        if group and (
            rank_key(line)[:2] != rank_key(group[0])[:2]
            or not costs_equal(_loosest_cost(group[0]), _loosest_cost(line))
        ):
            ordered += sorted(group, key=lambda member: member.engine)
            group = []
        group.append(line)
    return ordered + sorted(group, key=lambda member: member.engine)


def _regimes(judged: _Judged, scenes: Sequence[str]) -> tuple[Regime, ...]:
    """The answer's scenes grouped by their exact outcome, each with its cheapest settings
    (none where the rows carry no exact outcome, or every scene has the same one)."""
    rows = judged.rows
    if Col.EXACT_OUTCOME not in rows.columns:
        return ()
    keep = rows[Col.SCENE].isin(scenes).to_numpy()
    outcome = rows[keep].groupby(Col.SCENE, sort=False)[Col.EXACT_OUTCOME].first().dropna()
    groups: dict[str, list[str]] = {}
    for scene in scenes:
        if scene in outcome.index:
            groups.setdefault(str(outcome[scene]), []).append(scene)
    if len(groups) < 2:
        return ()
    # Each setting's runs on the answer's scenes (its cost and options counted of those).
    settings = _settings_of(judged, keep)
    tiers = range(len(ACCURACY_TIERS))
    return tuple(
        Regime(kind, tuple(names), tuple(_cheapest(judged, settings, names, t) for t in tiers))
        for kind, names in groups.items()
    )


def best_search(result: Answer, tier: int) -> SearchChoice | None:
    """Of every engine's shipped search, the setting it names for ``ACCURACY_TIERS[tier]``
    that is within the tier on the largest share of its search's scenes; of those, one whose
    search is costed by CPU time before one costed by wall time, and the cheapest of one
    clock (costs of two clocks are never compared): the searches' answer."""
    found = [
        line.searched[tier]
        for line in result.engines
        if line.searched and line.searched[tier] is not None
    ]
    return min(
        (s for s in found if s is not None),
        key=lambda s: (
            -s.scenes_met / s.scenes,
            s.clock is not CostClock.CPU,
            s.cost_per_sim_s,
            s.engine,
        ),
        default=None,
    )


def ranked(result: Answer) -> tuple[EngineAnswer, ...]:
    """The engines of the answer's table, in its order (RANK_RULE): those with runs in the
    suites (an engine of the searches alone is at its best only)."""
    lines = sorted((line for line in result.engines if line.settings_tried), key=rank_key)
    return tuple(_by_name_within_the_noise(lines))


def at_best(result: Answer) -> tuple[AtBest, ...]:
    """Per engine and tier, its best of the suite's setting and the search's (AtBest), for
    every engine with either."""
    best = []
    for line in _by_name_within_the_noise(sorted(result.engines, key=rank_key)):
        searched = line.searched or (None,) * len(ACCURACY_TIERS)
        for tier, suite, search in zip(ACCURACY_TIERS, line.cheapest, searched, strict=True):
            if suite is not None or search is not None:
                best.append(AtBest(line.engine, tier.name, suite, len(result.scenes), search))
    return tuple(best)


# --------------------------------------------------------------------------- presenting
def _worst_cell(worst: WorstTransition | None) -> str:
    """'re-stick 2 on seed-mu, -6.07 ms (0.61 of loose)'."""
    if worst is None:
        return "-"
    return escape_cell(
        f"{worst.name} on {worst.scene}, {worst.error_ms:+.3g} ms ({worst.ratio:.2g} of loose)"
    )


def _choice_cells(choice: Choice | None, scenes: int) -> list[str]:
    if choice is None:
        return ["none", "-", "-", "-"]
    label = escape_cell(choice.setting.label)
    if choice.scenes_met < scenes:
        label += f" (only {choice.scenes_met}/{scenes} scenes)"
    return [
        label,
        f"{choice.cost_per_sim_s:.3g}",
        f"{choice.us_per_step:.3g}",
        _worst_cell(choice.worst),
    ]


def _wrong_cell(line: EngineAnswer) -> str:
    """The scenes no setting gets within loose, each with what its runs did, in words."""
    if not line.always_wrong:
        return "nothing"
    return escape_cell(
        "; ".join(f"{scene} ({plain_verdicts(verdicts)})" for scene, verdicts in line.always_wrong)
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


def _cost_words(clock: str) -> str:
    """What the answer's cost is, and how equal costs are ordered."""
    what = (
        "The stepping time is the process's CPU time, which the machine's load moves far less "
        "than the wall time."
        if clock == "CPU"
        else "The stepping time is the wall time: these runs were stored without their CPU "
        "time, and their costs move with the machine's load."
    )
    return (
        f"{what} Costs within a factor {COST_NOISE_FACTOR:g} of the cheapest count as equal "
        "(the spread measured between two runs of the same suites on one machine); of those, "
        "the larger timestep is named, then the stock profile before the tuned one, then the "
        "fewer options changed."
    )


def _timed_out_sentence(timed_out: Sequence[tuple[str, str]]) -> str:
    """The runs the sweep's time limit ended, named as the machine's failure."""
    runs = "; ".join(f"{name} on {scene}" for name, scene in timed_out)
    return escape_text(
        f"Left out of the tiers: {len(timed_out)} run(s) ended by the sweep's time limit, the "
        f"machine's failure (its load or speed), not the engine's: {runs}. Their settings "
        "count those scenes as not run; run them again on an idle machine."
    )


def _scene_count(n: int) -> str:
    """'all 7 catalogue scenes', 'the 1 catalogue scene'."""
    return "the 1 catalogue scene" if n == 1 else f"all {n} catalogue scenes"


def _best_cells(best: AtBest) -> list[str]:
    """Setting, scenes within the tier, cost and where the setting comes from."""
    search, suite = best.search, best.suite
    if best.from_search and search is not None:
        tier_file = TIER_NAMES[Tier(best.tier)]
        other = (
            ""
            if suite is None
            else f"; the suite's best: {suite.scenes_met}/{best.suite_scenes} catalogue scenes"
        )
        return [
            escape_cell(f"{search.setting} (dt {search.timestep:.3g})"),
            f"{search.scenes_met}/{search.scenes} scenes, {search.heldout} of them held out "
            f"(held-out tier: {escape_cell(search.heldout_tier)})",
            f"{search.cost_per_sim_s:.3g} ({search.clock.label}, the search's)",
            escape_cell(f"search: {search.engine}'s settings.toml#{tier_file}{other}"),
        ]
    assert suite is not None
    return [
        escape_cell(suite.setting.label),
        f"{suite.scenes_met}/{best.suite_scenes} catalogue scenes",
        f"{suite.cost_per_sim_s:.3g} ({suite.clock})",
        "the suites",
    ]


def _at_best_markdown(result: Answer) -> list[str]:
    """The table of each engine at its best (suite or shipped search), with its note."""
    rows = at_best(result)
    if not any(line.searched for line in result.engines):
        return []
    lines = [
        "",
        "Each engine at its best: per tier, the suites' cheapest setting above or the one the "
        "engine's shipped search of `hoopbench tune` names for the tier (reports/tune/searches/"
        "ENGINE/settings.toml, `--settings 'FILE#agrees'` or `#close`), whichever is within "
        "the tier on the larger share of its scenes (the suites' where they tie: a search's "
        "cost is never compared with the suites'). A search's scenes are its training scenes "
        "(the catalogue's) and held-out scenes it never trained on; its cost was measured by "
        "the search, on the machine and load it ran on (shipped with the repository, not "
        "measured by this report), by the clock its tune.json records: the CPU time of its "
        "runs' stepping per simulated second, or, for a search made before the clock was "
        "recorded, the wall time, which grows with that machine's load (each cell says "
        "whose).",
        "",
        "| engine | tier | best setting | within the tier on | s per simulated s | found by |",
        "|---|---|---|---|---|---|",
    ]
    for best in rows:
        cells = [escape_cell(best.engine), best.tier, *_best_cells(best)]
        lines.append("| " + " | ".join(cells) + " |")
    return lines


def answer_markdown(result: Answer, *, heading: bool = True) -> str:
    """The answer as the report's first section (Markdown, ending in a blank line), its
    heading left out without ``heading`` (the README has its own); empty text when no engine
    run was judged."""
    if not result.engines:
        return ""
    clock = "CPU " if result.clock == "CPU" else ""
    headers = ["rank", "engine"]
    for tier in ACCURACY_TIERS:
        headers += [
            f"{tier.name}: cheapest setting",
            f"{clock}s per simulated s",
            f"{clock}us/step",
            "worst transition",
        ]
    headers.append("wrong at every setting tried")
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for rank, line in enumerate(ranked(result), start=1):
        cells = [str(rank), escape_cell(line.engine)]
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
        "cost (seconds of stepping time per simulated second, the report's one cost unit: "
        "below 1 is faster than real time, and settings of different timesteps compare "
        "directly; beside it the stepping time per step); the worst transition of its runs "
        "that meet the tier (of every event time the verdict compares, the farthest from the "
        "exact one against its loose tolerance); the scenes "
        "it gets wrong at every setting tried, with what those runs did (answer.csv and "
        f"answer.json beside this report give the verdicts' names). Tiers: {tiers}. "
        f"The rows: {RANK_RULE}. " + _cost_words(result.clock),
        "",
        *lines,
        *_at_best_markdown(result),
    ]
    if result.timed_out:
        parts += ["", _timed_out_sentence(result.timed_out)]
    if result.limits:
        parts += [
            "",
            "Left out of the table, because no engine meets them at the suite's timesteps:",
            "",
            *(f"- {escape_text(_limit_sentence(limit))}" for limit in result.limits),
        ]
    return "\n".join([*parts, ""])
