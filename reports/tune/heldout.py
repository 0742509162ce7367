"""The held-out check of a search: its Pareto set (and stock and tuned) run again on scenes
drawn at random from a seed the search never saw (random scenes of each regime, and the
training scenes' neighbours: neighbours.py); the front table and the settings file.

A setting is *overfitted* when its held-out error exceeds OVERFIT_FACTOR times its training
error plus OVERFIT_MARGIN (errors in loose tolerances: engines/judging/score.py).
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.score import CostClock, cost_us_per_s, error_score
from hoopbench.engines.registry import engine_class
from hoopbench.models.scene import Scene
from hoopbench.reference.random_scenes import RANDOM_PREFIX, draw
from hoopbench.reference.regimes import Regime
from hoopbench.reports.compare.settings_file import TunedSetting, settings_text
from hoopbench.reports.compare.suite import runs_frame
from hoopbench.reports.sweep import results
from hoopbench.reports.tune.neighbours import NEIGHBOUR_PREFIX, neighbours_of
from hoopbench.reports.tune.search import (
    COST_CLOCK_KEY,
    FRONT_NAME,
    HELDOUT_DIR,
    SETTINGS_HASH_NAME,
    SETTINGS_NAME,
    TRIALS_DIR,
    TRIALS_NAME,
    Budget,
    Runner,
    SearchResult,
    Setting,
    TuneSpec,
    run_settings,
    setting_of,
    setting_tasks,
    settings_hash,
    trials_frame,
)
from hoopbench.reports.tune.tiers import (
    TIER_COLUMNS,
    cheapest_by_tier,
    count_columns,
    tier_columns,
)

__all__ = [
    "FRONT_NAME",
    "HELDOUT_DIR",
    "MAX_HELDOUT_NEIGHBOURS",
    "MAX_HELDOUT_PER_REGIME",
    "OVERFIT_FACTOR",
    "OVERFIT_MARGIN",
    "SETTINGS_NAME",
    "TRIALS_NAME",
    "heldout_scenes",
    "is_overfitted",
    "validate",
]

HELDOUT_PREFIX = "heldout-"
"""Of a held-out scene's name: heldout-random-N, heldout-near-<training scene>-K."""
HELDOUT_REGIMES = (Regime.ROLLS, Regime.SLIPS, Regime.SLIP_REVERSAL, Regime.HOPS)
HELDOUT_T_END = 1.5
"""s: the held-out scenes' window (the truth test's)."""

MAX_HELDOUT_PER_REGIME = 10
"""Held-out random scenes per regime at most: the rarest regime takes some 60 draws of the
exact solution a scene (10 a regime: 629 draws, 112 s on 2 loaded cores, 2026-11-28), and the
draw gives up after 2,000 (reference/random_scenes.py), after the whole search."""
MAX_HELDOUT_NEIGHBOURS = 10
"""Held-out neighbours per training scene at most: each takes up to MAX_NEIGHBOUR_DRAWS
exact solutions."""

OVERFIT_FACTOR = 2.0
OVERFIT_MARGIN = 0.5
"""Half a loose tolerance: a held-out error this much above twice the training one is more
than the spread between scenes of one regime."""


def heldout_scenes(spec: TuneSpec) -> tuple[Scene, ...]:
    """The held-out scenes, from ``heldout_seed``: ``heldout_per_regime`` random scenes of
    each regime, then ``heldout_neighbours`` neighbours of each training scene."""
    drawn: tuple[Scene, ...] = ()
    if spec.heldout_per_regime:
        quota = dict.fromkeys(HELDOUT_REGIMES, spec.heldout_per_regime)
        drawn = draw(spec.heldout_seed, quota, t_end=HELDOUT_T_END).scenes
    near = neighbours_of(spec.scenes, spec.heldout_seed, spec.heldout_neighbours)
    return tuple(replace(s, name=f"{HELDOUT_PREFIX}{s.name}") for s in (*drawn, *near))


def is_overfitted(train_error: float | None, heldout_error: float | None) -> bool:
    """Whether a setting does much worse on the held-out scenes than on the training ones."""
    if train_error is None or heldout_error is None:
        return False
    return heldout_error > OVERFIT_FACTOR * train_error + OVERFIT_MARGIN


def _part_error(rows: list[dict[str, Any]], prefix: str) -> float | None:
    """The error on the held-out scenes named ``prefix...``; None without any."""
    part = [r for r in rows if str(r.get(Col.SCENE, "")).startswith(prefix)]
    return error_score(part) if part else None


def _line(
    setting: Setting,
    kind: str,
    rows: list[dict[str, Any]],
    train_rows: list[dict[str, Any]],
    clock: CostClock,
) -> dict[str, Any]:
    """A setting's front.csv line; its costs by the search's ``clock``, the wall time's
    beside them."""
    heldout = error_score(rows)
    return {
        "setting": setting.name,
        "kind": kind,
        "timestep": setting.timestep,
        "options": json.dumps(dict(setting.options), sort_keys=True, default=list),
        "train_error": setting.train_error,
        "train_cost_us_per_s": setting.train_cost,
        "train_wall_us_per_s": setting.train_wall,
        "heldout_error": heldout,
        "heldout_cost_us_per_s": cost_us_per_s(rows, clock),
        "heldout_wall_us_per_s": cost_us_per_s(rows, CostClock.WALL),
        "overfitted": is_overfitted(setting.train_error, heldout),
        **tier_columns(train_rows, rows),
        **count_columns(train_rows, rows),
        "heldout_random_error": _part_error(rows, f"{HELDOUT_PREFIX}{RANDOM_PREFIX}"),
        "heldout_near_error": _part_error(rows, f"{HELDOUT_PREFIX}{NEIGHBOUR_PREFIX}"),
    }


def validate(
    spec: TuneSpec, result: SearchResult, out: Path, runner: Runner, budget: Budget
) -> pd.DataFrame | None:
    """Run the Pareto set and the baselines on the held-out scenes; write front.csv,
    trials.csv and settings.toml. None if a signal stopped the runs (resume goes on)."""
    scenes = heldout_scenes(spec)
    clock = result.cost_clock
    front = [setting_of(spec.engine, t, clock) for t in result.study.best_trials]
    front.sort(key=lambda s: (s.train_error, s.train_cost))
    lines = []
    trained = runs_frame(out / TRIALS_DIR)
    for kind, settings in (("pareto", front), ("baseline", list(result.baselines))):
        for setting in settings:
            tasks = setting_tasks(spec.engine, scenes, setting)
            summary, rows = run_settings(tasks, out / HELDOUT_DIR, runner)
            if summary.interrupted is not None:
                return None
            ids = {t.run_id for t in setting_tasks(spec.engine, spec.scenes, setting)}
            train_rows = trained[trained["run_id"].isin(ids)].to_dict("records")
            lines.append(_line(setting, kind, rows, train_rows, clock))
    table = pd.DataFrame(lines)
    results.write_csv(table, out / FRONT_NAME)
    results.write_csv(trials_frame(result.study, clock), out / TRIALS_NAME)
    _write_settings(spec, result, table, front, scenes, budget, out)
    return table


def _number(value: Any) -> float | str:
    number = float(value) if value is not None else math.nan
    return number if math.isfinite(number) else "none"


def _write_settings(
    spec: TuneSpec,
    result: SearchResult,
    table: pd.DataFrame,
    front: Sequence[Setting],
    scenes: Sequence[Scene],
    budget: Budget,
    out: Path,
) -> None:
    by_name = table.set_index("setting")
    settings = [
        TunedSetting(
            s.name,
            s.timestep,
            s.options,
            s.profile,
            {
                "train_error": _number(s.train_error),
                "heldout_error": _number(by_name.loc[s.name, "heldout_error"]),
                "cost_us_per_s": _number(s.train_cost),
                "wall_us_per_s": _number(s.train_wall),
                "overfitted": bool(by_name.loc[s.name, "overfitted"]),
                **{c: str(by_name.loc[s.name, c]) for c in TIER_COLUMNS},
            },
        )
        for s in front
    ]
    provenance = {
        COST_CLOCK_KEY: str(result.cost_clock),
        "training_scenes": [s.name for s in spec.scenes],
        "heldout_scenes": [s.name for s in scenes],
        "heldout_seed": spec.heldout_seed,
        "heldout_per_regime": spec.heldout_per_regime,
        "heldout_neighbours": spec.heldout_neighbours,
        "seed": spec.seed,
        "trials": len(result.study.trials),
        "budget_trials": budget.trials if budget.trials is not None else "none",
        "budget_timeout_s": budget.timeout_s if budget.timeout_s is not None else "none",
        "sampler": type(result.study.sampler).__name__,
        "date": datetime.now(UTC).isoformat(timespec="seconds"),
    }
    version = engine_class(spec.engine)().version()
    text = settings_text(spec.engine, version, provenance, settings, cheapest_by_tier(table))
    results.atomic_write(out / SETTINGS_NAME, lambda tmp: tmp.write_text(text, encoding="utf-8"))
    digest = settings_hash(text) + "\n"
    results.atomic_write(out / SETTINGS_HASH_NAME, lambda tmp: tmp.write_text(digest))
