"""The answer's table as files beside report.md, for a script or a paper: ``answer.csv`` (one
row per engine, in the table's rank order) and ``answer.json`` (the same rows, with the
scenes, the cost's clock, the ranking rule and the answer's sentences).

The rows are the answer table's (reports/report/answer.py), one flat record per engine;
:data:`ANSWER_COLUMNS` names and documents every column (docs/report.md lists them).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pandas as pd

from hoopbench.reports.report.answer import (
    ACCURACY_TIERS,
    RANK_RULE,
    Answer,
    Choice,
    EngineAnswer,
    ranked,
)
from hoopbench.reports.report.answer_words import answer_sentences
from hoopbench.reports.report.verdict_words import verdict_name
from hoopbench.reports.sweep import results

__all__ = [
    "ANSWER_COLUMNS",
    "ANSWER_CSV",
    "ANSWER_JSON",
    "answer_frame",
    "answer_json",
    "answer_records",
    "write_answer_files",
]

ANSWER_CSV = "answer.csv"
ANSWER_JSON = "answer.json"

_TIER_COLUMNS: tuple[tuple[str, str], ...] = (
    ("setting", "the cheapest setting meeting the tier: 'profile, variant, dt TIMESTEP'"),
    ("profile", "its profile: stock or tuned"),
    ("variant", "its variant (default: the profile's own values)"),
    ("timestep_s", "its timestep, s"),
    ("scenes_met", "how many of the answer's scenes its runs meet the tier on"),
    ("cost_s_per_sim_s", "seconds of stepping time (by ``clock``) per simulated second"),
    ("us_per_step", "its median stepping time per step (by ``clock``), us"),
    ("worst_transition", "its worst timed transition: 'slip onset', 're-stick 2', ..."),
    ("worst_scene", "the scene of that transition"),
    ("worst_error_ms", "that transition's error, run minus exact, ms"),
    ("worst_ratio", "that error over its loose tolerance"),
    ("missed", "the scenes it does not meet the tier on, 'scene: verdict verdict; ...'"),
)
"""Each tier's columns, prefixed by the tier's name (``tight_setting``); empty where no run
meets the tier."""

ANSWER_COLUMNS: tuple[tuple[str, str], ...] = (
    ("rank", "the engine's place in the table (answer.RANK_RULE), 1 first"),
    ("engine", "the engine"),
    ("settings_tried", "its settings with at least one judged run"),
    ("scenes", "how many scenes the answer holds a setting to"),
    ("clock", "whose time the costs are: CPU (the process's) or wall"),
    *(
        (f"{tier.name}_{name}", f"{tier.name} tier: {meaning}")
        for tier in ACCURACY_TIERS
        for name, meaning in _TIER_COLUMNS
    ),
    (
        "wrong_everywhere",
        "the scenes no setting tried meets the loose tier on, with those "
        "runs' verdicts: 'scene: verdict verdict; ...'",
    ),
)
"""(column, meaning) of answer.csv, in its order; answer.json's rows have the same keys."""


def _number(value: float) -> float | None:
    return value if math.isfinite(value) else None


def _scene_verdicts(pairs: tuple[tuple[str, tuple[str, ...]], ...]) -> str:
    """'hop-top: hop-too-low missed-hop; high-spin: diverged' ('not-run' for none): the
    verdicts' names, without a diverged run's cause (the answer's words say it)."""
    return "; ".join(f"{scene}: {_names(verdicts) or 'not-run'}" for scene, verdicts in pairs)


def _names(tokens: tuple[str, ...]) -> str:
    return " ".join(dict.fromkeys(verdict_name(token) for token in tokens))


def _tier_cells(tier: str, choice: Choice | None) -> dict[str, Any]:
    if choice is None:
        return {f"{tier}_{name}": None for name, _ in _TIER_COLUMNS}
    worst = choice.worst
    cells: dict[str, Any] = {
        "setting": choice.setting.label,
        "profile": choice.setting.profile,
        "variant": choice.setting.variant,
        "timestep_s": choice.setting.timestep,
        "scenes_met": choice.scenes_met,
        "cost_s_per_sim_s": _number(choice.cost_per_sim_s),
        "us_per_step": _number(choice.us_per_step),
        "worst_transition": None if worst is None else worst.name,
        "worst_scene": None if worst is None else worst.scene,
        "worst_error_ms": None if worst is None else _number(worst.error_ms),
        "worst_ratio": None if worst is None else _number(worst.ratio),
        "missed": _scene_verdicts(choice.missed),
    }
    return {f"{tier}_{name}": value for name, value in cells.items()}


def _row(rank: int, line: EngineAnswer, result: Answer) -> dict[str, Any]:
    row: dict[str, Any] = {
        "rank": rank,
        "engine": line.engine,
        "settings_tried": line.settings_tried,
        "scenes": len(result.scenes),
        "clock": result.clock,
    }
    for tier, choice in zip(ACCURACY_TIERS, line.cheapest, strict=True):
        row |= _tier_cells(tier.name, choice)
    row["wrong_everywhere"] = _scene_verdicts(line.always_wrong)
    return row


def answer_records(result: Answer) -> list[dict[str, Any]]:
    """The table's rows, rank order, keyed by ANSWER_COLUMNS."""
    return [_row(rank, line, result) for rank, line in enumerate(ranked(result), start=1)]


def answer_frame(result: Answer) -> pd.DataFrame:
    """The table's rows as answer.csv holds them (ANSWER_COLUMNS, rank order)."""
    frame = pd.DataFrame(answer_records(result), columns=[name for name, _ in ANSWER_COLUMNS])
    counts = [f"{tier.name}_scenes_met" for tier in ACCURACY_TIERS]
    return frame.astype(dict.fromkeys(counts, "Int64"))  # a count, empty where none meets


def answer_json(result: Answer) -> dict[str, Any]:
    """answer.json: the scenes, the clock, the ranking rule, the sentences and the rows."""
    return {
        "scenes": list(result.scenes),
        "clock": result.clock,
        "cost_unit": "s of stepping time per simulated s",
        "rank_rule": RANK_RULE,
        "sentences": answer_sentences(result),
        "columns": dict(ANSWER_COLUMNS),
        "rows": answer_records(result),
    }


def write_answer_files(result: Answer, out: str | Path) -> list[Path]:
    """answer.csv and answer.json in ``out``, each written whole; nothing (an empty list)
    when no engine run was judged."""
    if not ranked(result):
        return []
    out = Path(out)
    frame = answer_frame(result)
    text = json.dumps(answer_json(result), indent=2, allow_nan=False) + "\n"
    return [
        results.atomic_write(out / ANSWER_CSV, lambda tmp: frame.to_csv(tmp, index=False)),
        results.atomic_write(out / ANSWER_JSON, lambda tmp: tmp.write_text(text)),
    ]
