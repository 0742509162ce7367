"""The "Best settings" section: per engine searched with ``hoopbench tune``, its front (error
against cost, on the training scenes and on the held-out ones) with ``stock`` and ``tuned``
placed on it, the accuracy tier each setting reaches and the cheapest of each tier, as a
table and a figure.

:func:`best_settings` computes (from a tune folder's tune.json, front.csv and trials.csv
alone, no simulation and no runs: a compact copy of a search, as ``make searches`` ships,
reads the same); :func:`best_settings_section` presents.
"""

from __future__ import annotations

import io
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.score import CostClock
from hoopbench.reports.compare.settings_file import TIER_CHOICES, TierChoice
from hoopbench.reports.report.escaping import escape_cell, escape_text, file_stem
from hoopbench.reports.report.log_ticks import readable_log_axes
from hoopbench.reports.report.palette import engine_colours, profile_style
from hoopbench.reports.report.plotting import Draw, draw_now, pyplot, save
from hoopbench.reports.sweep.folder_files import (
    MAX_DATA_BYTES,
    FolderFileError,
    folder_file,
    read_folder_bytes,
    read_folder_text,
)
from hoopbench.reports.tune.heldout import FRONT_NAME, TRIALS_NAME
from hoopbench.reports.tune.search import COST_CLOCK_KEY, SPEC_NAME, recorded_clock
from hoopbench.reports.tune.tiers import (
    SCENES_COLUMN,
    TIER_COLUMNS,
    cheapest_by_tier,
    count_column,
)

__all__ = [
    "COST_FACTOR",
    "SCORE_AXIS",
    "BestSettings",
    "best_settings",
    "best_settings_section",
    "cost_axis",
    "figure_name",
    "figure_names",
    "is_tune_folder",
]

COST_FACTOR = 10.0
"""The second budget the section reads the front at: ten times tuned's cost."""

SCORE_AXIS = "error (loose tolerances; 10 = failed)"
"""The error axis of the figure, PNG and page alike."""


def figure_name(engine: str, nth: int = 1) -> str:
    """The file name of an engine's figure (the page draws its own in its place); ``nth``:
    the engine's nth search in one report (the first keeps the plain name)."""
    suffix = "" if nth == 1 else f"-{nth}"
    return f"best-settings-{file_stem(engine)}{suffix}.png"


def figure_names(found: Sequence[BestSettings]) -> list[str]:
    """Each search's figure, one file a search: two searches of one engine in one report
    drew both into one file (both showed the second one's figure)."""
    seen: dict[str, int] = {}
    names = []
    for best in found:
        seen[best.engine] = seen.get(best.engine, 0) + 1
        names.append(figure_name(best.engine, seen[best.engine]))
    return names


def is_tune_folder(folder: str | Path) -> bool:
    """Whether a folder holds a search of ``hoopbench tune``."""
    return (Path(folder) / SPEC_NAME).is_file()


@dataclass(frozen=True)
class BestSettings:
    """One engine's search, read back."""

    engine: str
    front: pd.DataFrame
    """front.csv: the Pareto set and the baselines, training and held-out error and cost."""
    trials: pd.DataFrame
    """trials.csv: every trial's training error and cost."""
    training_scenes: tuple[str, ...]
    tuned_heldout: float | None
    """tuned's held-out error."""
    at_tuned_cost: float | None
    """The best held-out error of the Pareto set at no more than tuned's held-out cost."""
    at_ten_times: float | None
    """The same at COST_FACTOR times tuned's held-out cost."""
    cheapest: dict[str, TierChoice | None]
    """Tier name -> the cheapest of the Pareto settings within it on the most scenes,
    training and held-out (settings.toml's [tiers]); every tier None for a front.csv from
    before the scene counts."""
    created: str | None = None
    """When the search started (tune.json's ``created``, ISO 8601); None where it is not
    recorded."""
    cost_clock: CostClock = CostClock.WALL
    """The clock of the search's costs (tune.json's ``cost_clock``; a search made before the
    key, as every search shipped so far, has none: wall time)."""

    @property
    def has_tiers(self) -> bool:
        """Whether front.csv labels each setting's tiers (a search from before does not)."""
        return set(TIER_COLUMNS) <= set(self.front.columns)

    @property
    def has_counts(self) -> bool:
        """Whether front.csv counts each setting's scenes within each tier (a search from
        before does not)."""
        return SCENES_COLUMN in self.front.columns


def _best_within(front: pd.DataFrame, cost: float | None) -> float | None:
    if cost is None or not math.isfinite(cost):
        return None
    pareto = front[(front["kind"] == "pareto") & (front["heldout_cost_us_per_s"] <= cost)]
    return None if pareto.empty else float(pareto["heldout_error"].min())


_FRONT_COLUMNS = (
    "setting",
    "kind",
    "timestep",
    "train_error",
    "heldout_error",
    "train_cost_us_per_s",
    "heldout_cost_us_per_s",
    "overfitted",
)
"""front.csv's columns the section reads (the tiers' and counts' are newer: optional)."""
_TRIALS_COLUMNS = ("trial", "state", "train_error", "train_cost_us_per_s")
_NUMBER_COLUMNS: tuple[str, ...] = ("timestep", "train_error", "heldout_error")
_NUMBER_COLUMNS += ("train_cost_us_per_s", "heldout_cost_us_per_s")
"""Numbers (NaN for a run that failed; inf read as NaN: never a cost or an error)."""


def _table_file(folder: Path, name: str, columns: Sequence[str]) -> pd.DataFrame:
    """A CSV file of the folder, read through folder_files (a link out of the folder, a FIFO
    or a huge file is refused); FolderFileError naming the file if it is not a table with
    ``columns``."""
    data = read_folder_bytes(folder, name, MAX_DATA_BYTES)
    if data is None:
        raise FolderFileError(f"{folder / name} is missing")
    try:
        table = pd.read_csv(io.BytesIO(data))
    except (ValueError, pd.errors.ParserError) as exc:  # EmptyDataError is a ValueError
        raise FolderFileError(f"{folder / name} is not a CSV table: {_one_line(exc)}") from None
    missing = [column for column in columns if column not in table.columns]
    if missing:
        raise FolderFileError(f"{folder / name} lacks the column(s) {', '.join(missing)}")
    if table.empty and name == FRONT_NAME:
        raise FolderFileError(f"{folder / name} holds no settings")
    for column in (c for c in _NUMBER_COLUMNS if c in table.columns):
        numbers = pd.to_numeric(table[column], errors="coerce")
        table[column] = numbers.where(numbers.abs() != math.inf)
    return table


def _one_line(exc: Exception) -> str:
    return " ".join(str(exc).split())


def _counts_checked(path: Path, front: pd.DataFrame) -> None:
    """The tiers' counts of scenes (where front.csv has them): whole numbers, 0 <= k <= n
    (cheapest_by_tier takes them as ints)."""
    columns = [count_column(tier) for tier in TIER_CHOICES] + [SCENES_COLUMN]
    for column in (c for c in columns if c in front.columns):
        counts = pd.to_numeric(front[column], errors="coerce")
        whole = counts.notna() & counts.abs().lt(math.inf) & (counts >= 0) & (counts % 1 == 0)
        if not whole.all():
            bad = front[column][~whole].iloc[0]
            raise FolderFileError(f"{path}: {column} must be a whole number of scenes, got {bad}")
        front[column] = counts.astype(int)
    if SCENES_COLUMN in front.columns:
        for column in (c for c in columns[:-1] if c in front.columns):
            if (front[column] > front[SCENES_COLUMN]).any():
                raise FolderFileError(f"{path}: {column} counts more scenes than {SCENES_COLUMN}")


@dataclass(frozen=True)
class _Spec:
    """What the section reads of tune.json."""

    engine: str
    scenes: tuple[str, ...]
    created: str | None
    cost_clock: CostClock


def _spec(folder: Path) -> _Spec:
    """tune.json's engine, training scenes' names, start time (None if not a string) and
    costs' clock; FolderFileError naming the file and the field for anything else."""
    path = folder / SPEC_NAME
    text = read_folder_text(folder, SPEC_NAME)
    if text is None:
        raise FolderFileError(f"{path} is missing")
    try:
        spec = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise FolderFileError(f"{path} is not JSON: {_one_line(exc)}") from None
    if not isinstance(spec, dict):
        raise FolderFileError(f"{path} must hold a JSON object, got {type(spec).__name__}")
    engine, scenes = spec.get("engine"), spec.get("scenes")
    if not isinstance(engine, str) or not engine:
        raise FolderFileError(f"{path}: engine must be an engine's name, got {engine!r}")
    if not isinstance(scenes, list) or not all(
        isinstance(s, dict) and isinstance(s.get("name"), str) for s in scenes
    ):
        shown = "nothing" if scenes is None else type(scenes).__name__
        raise FolderFileError(
            f"{path}: scenes must be a list of scenes, each with a name, got {shown}"
        )
    created = spec.get("created")
    try:
        clock = recorded_clock(spec)
    except ValueError as exc:
        raise FolderFileError(f"{path}: {exc}") from None
    names = tuple(s["name"] for s in scenes)
    return _Spec(engine, names, created if isinstance(created, str) else None, clock)


_FLAGS = {"true": True, "yes": True, "1": True, "false": False, "no": False, "0": False}
"""front.csv's overfitted as written (True/False) or as a person writes it."""


def _flags(column: pd.Series, path: Path) -> pd.Series:
    """A yes/no column read as text, each value one of _FLAGS (the string "no" is truthy:
    a front.csv saying overfitted = no was shown as yes); FolderFileError naming the file
    and the value otherwise."""
    values = []
    for value in column:
        key = str(value).strip().lower()
        if key not in _FLAGS:
            raise FolderFileError(f"{path}: overfitted must be true or false, got {value!r}")
        values.append(_FLAGS[key])
    return pd.Series(values, index=column.index, dtype=bool)


def _read(folder: Path) -> BestSettings:
    spec = _spec(folder)
    front = _table_file(folder, FRONT_NAME, _FRONT_COLUMNS)
    _counts_checked(folder / FRONT_NAME, front)
    trials = _table_file(folder, TRIALS_NAME, _TRIALS_COLUMNS)
    if "overfitted" in front.columns:
        front["overfitted"] = _flags(front["overfitted"], folder / FRONT_NAME)
    tuned = front[front["setting"] == "tuned"]
    cost = float(tuned["heldout_cost_us_per_s"].iloc[0]) if len(tuned) else None
    return BestSettings(
        engine=spec.engine,
        front=front,
        trials=trials,
        training_scenes=spec.scenes,
        tuned_heldout=float(tuned["heldout_error"].iloc[0]) if len(tuned) else None,
        at_tuned_cost=_best_within(front, cost),
        at_ten_times=_best_within(front, None if cost is None else COST_FACTOR * cost),
        cheapest=cheapest_by_tier(front),
        created=spec.created,
        cost_clock=spec.cost_clock,
    )


def best_settings(folders: Sequence[str | Path]) -> list[BestSettings]:
    """Every tune folder's search, read back. ValueError naming a folder whose search has not
    finished (no front.csv: resume it)."""
    found = []
    for folder in map(Path, folders):
        if folder_file(folder, FRONT_NAME, MAX_DATA_BYTES) is None:
            raise ValueError(f"{folder}: the search has no {FRONT_NAME} yet: resume it first")
        found.append(_read(folder))
    return found


# --------------------------------------------------------------------------- presenting
def _number(value: Any, spec: str = ".3g") -> str:
    try:
        number = float(value)
    except (TypeError, ValueError):
        return "-"
    return "-" if not math.isfinite(number) else format(number, spec)


def _tier(row: dict[str, Any], column: str) -> str:
    value = row.get(column)
    return escape_cell(value) if isinstance(value, str) else "-"


def _counts(row: dict[str, Any]) -> str:
    """The row's cells of scenes within each tier, "k/n" ("-" from before the counts)."""
    scenes = _number(row.get(SCENES_COLUMN), ".0f")
    cells = [_number(row.get(count_column(tier)), ".0f") for tier in TIER_CHOICES]
    return " | ".join("-" if "-" in (c, scenes) else f"{c}/{scenes}" for c in cells)


def _table(best: BestSettings) -> list[str]:
    within = "".join(f" scenes within {tier} |" for tier in TIER_CHOICES)
    lines = [
        "| setting | kind | timestep (s) | training error | held-out error | training cost "
        f"({best.cost_clock.label} s per simulated s) | overfitted | training tier | "
        f"held-out tier |{within}",
        "|" + "---|" * (9 + len(TIER_CHOICES)),
    ]
    train, heldout = TIER_COLUMNS
    for row in best.front.to_dict("records"):
        lines.append(
            f"| {escape_cell(row['setting'])} | {escape_cell(row['kind'])} | "
            f"{_number(row['timestep'])} | "
            f"{_number(row['train_error'])} | {_number(row['heldout_error'])} | "
            f"{_per_sim_s(row['train_cost_us_per_s'])} | "
            f"{'yes' if row['overfitted'] else 'no'} | "
            f"{_tier(row, train)} | {_tier(row, heldout)} | {_counts(row)} |"
        )
    return lines


SECONDS_PER_US = 1e-6
"""front.csv's costs are us per simulated s; the report's one cost unit is s per simulated s."""


def cost_axis(clock: CostClock) -> str:
    """The figures' cost axis, in the report's one cost unit, by the search's clock."""
    return f"cost, {clock.label} s of stepping per simulated s"


def in_seconds(us_per_s: Any) -> Any:
    """Costs in us per simulated s (front.csv's, trials.csv's) as s per simulated s."""
    return pd.to_numeric(us_per_s, errors="coerce") * SECONDS_PER_US


def _per_sim_s(us_per_s: Any) -> str:
    """A search's cost, us per simulated s as front.csv stores it, in the report's one cost
    unit: seconds per simulated second."""
    try:
        return _number(float(us_per_s) * SECONDS_PER_US)
    except (TypeError, ValueError):
        return "-"


def _tier_choice(tier: str, choice: TierChoice | None, costs: pd.Series, clock: CostClock) -> str:
    if choice is None:
        return f"{tier}: none"
    cost = _per_sim_s(costs.get(choice.setting))
    scenes = f"{choice.scenes_within}/{choice.scenes} scenes"
    within = scenes if choice.scenes_within == choice.scenes else f"only {scenes}"
    return (
        f"{tier}: {escape_text(choice.setting)} ({within}; {cost} {clock.label} s per simulated s)"
    )


def _tiers_line(best: BestSettings) -> str:
    """The cheapest setting of each tier, as the settings file names it."""
    if not best.has_counts:
        return (
            "This search's front.csv is from before the tiers' scene counts: resume its whole "
            "folder (`hoopbench tune --resume`, no new trials; a compact copy cannot be "
            "resumed) to name the cheapest of each tier."
        )
    costs = best.front.set_index("setting")["train_cost_us_per_s"]
    said = [
        _tier_choice(tier, choice, costs, best.cost_clock) for tier, choice in best.cheapest.items()
    ]
    return (
        "The cheapest setting whose runs are within each accuracy tier on all scenes, "
        "training and held-out, or on as many as any setting is "
        "(`--settings 'settings.toml#close'`): " + "; ".join(said) + "."
    )


def _summary(best: BestSettings) -> str:
    return (
        f"Held-out error of tuned: {_number(best.tuned_heldout)}; the best of the Pareto set at "
        f"no more than tuned's cost: {_number(best.at_tuned_cost)}; at {COST_FACTOR:g}x its "
        f"cost: {_number(best.at_ten_times)} (- where no setting of the front is that cheap)."
    )


def _plain_log_axis(axis: Any) -> None:
    """Plain numbers (``0.2``, ``1,000``), not powers; which ticks are labelled is
    plotting.save's rule (log_ticks)."""
    from matplotlib.ticker import FuncFormatter

    axis.set_major_formatter(
        FuncFormatter(lambda v, _: f"{v:,.0f}" if v >= 1 and float(v).is_integer() else f"{v:g}")
    )


def _positive(values: Any) -> bool:
    """Whether any of the values is a finite number > 0 (a point a log axis can show)."""
    numbers = pd.to_numeric(pd.Series(np.asarray(values, dtype=object)), errors="coerce")
    return bool(((numbers > 0) & (numbers < math.inf)).any())


def _panel(ax: Any, best: BestSettings, which: str) -> None:
    front = best.front
    colour = engine_colours([best.engine])[best.engine]  # the engine's colour in every figure
    if which == "train":
        done = best.trials[best.trials["state"] == "complete"]
        ax.scatter(
            in_seconds(done["train_cost_us_per_s"]),
            done["train_error"],
            s=12,
            c="0.7",
            label="trials",
        )
    pareto = front[front["kind"] == "pareto"].sort_values(f"{which}_cost_us_per_s")
    # On the held-out scenes the training front is no front: its points, not a line.
    style = "o-" if which == "train" else "o"
    ax.plot(
        in_seconds(pareto[f"{which}_cost_us_per_s"]),
        pareto[f"{which}_error"],
        style,
        c=colour,
        label="Pareto set",
    )
    for name in ("stock", "tuned"):  # the profiles' markers, edged black to stand out
        point = front[front["setting"] == name]
        ax.scatter(
            in_seconds(point[f"{which}_cost_us_per_s"]),
            point[f"{which}_error"],
            marker=profile_style(name).marker,
            s=60,
            c=colour,
            edgecolors="black",
            label=name,
            zorder=3,
        )
    if any(_positive(line.get_xdata()) for line in ax.lines) or any(
        _positive(points.get_offsets()[:, 0]) for points in ax.collections
    ):  # a log axis of nothing drawn fails ("Data cannot be log-scaled")
        ax.set_xscale("log")
        _plain_log_axis(ax.xaxis)
    ax.set_xlabel(cost_axis(best.cost_clock))
    ax.set_ylabel(SCORE_AXIS)
    ax.set_title("training scenes" if which == "train" else "held-out scenes")
    ax.grid(True, which="both", alpha=0.3)


def _figure(best: BestSettings, path: Path) -> Path:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    _panel(axes[0], best, "train")
    _panel(axes[1], best, "heldout")
    axes[0].legend(loc="best", fontsize=8)
    fig.suptitle(f"{best.engine}: error against cost")
    readable_log_axes(fig)  # as save labels them, before tight_layout makes room for labels
    fig.tight_layout()
    return save(fig, path, dpi=110)  # whole or not at all, plain tick labels


def _clock_words(clock: CostClock) -> str:
    """Which clock a search's costs are, in words."""
    if clock is CostClock.CPU:
        return f"Its costs are the process's CPU time (tune.json's {COST_CLOCK_KEY})"
    return (
        f"Its costs are wall time (its tune.json names no {COST_CLOCK_KEY}: the search was "
        "made before searches were costed by CPU time)"
    )


def _clocks_sentence(found: Sequence[BestSettings]) -> str:
    """How many of the searches are costed by each clock, and what that allows."""
    wall = sum(best.cost_clock is CostClock.WALL for best in found)
    counts = f"{len(found) - wall} of the {len(found)} searches here are costed by CPU time"
    counts += f", {wall} by wall time" if wall else ""
    redo = (
        " (to cost them by CPU time, run the searches again, `make tune` then `make "
        "searches`: hours of the machine; docs/tune.md)"
        if wall
        else ""
    )
    return (
        f"{counts}{redo}; each engine's part says its search's clock and when it started. A "
        "search's costs are compared with its own baselines (stock and tuned, measured in the "
        "same search), never with the suites' costs or another clock's."
    )


def best_settings_section(
    found: Sequence[BestSettings], out: str | Path, draw: Draw | None = None
) -> str:
    """The section's Markdown, its figures written to ``out`` (best-settings-ENGINE.png) by
    ``draw(function, *args)`` (default: here, now; the report's FigurePool.submit draws them
    beside its other work)."""
    out = Path(out)
    lines = [
        "## Best settings",
        "",
        "Each engine's settings searched by `hoopbench tune` (docs/tune.md): error (the mean "
        "over scenes of each run's worst event error in loose tolerances; 10 for a failed run, "
        "a missed or invented event) against cost, on the training scenes and on held-out "
        "scenes drawn at random from a seed the search never saw. A setting is overfitted when "
        "its held-out error is more than twice its training error plus 0.5. Its tier on a set "
        "of scenes is the finest every one of its runs there is within: agrees (every event "
        "within the tight tolerances), close (within the loose ones) or none. The searches' "
        "files were shipped with the repository (reports/tune/searches, `make searches`): "
        "this report reads them and measures nothing of them again. A cost is the time of "
        "a setting's runs' stepping per simulated second (the report's one cost unit, seconds "
        "per simulated second), measured by the search on the machine it ran on, which its "
        "files do not name, by the clock its tune.json records: the process's CPU time, or "
        "the wall time, which grows with that machine's load. " + _clocks_sentence(found),
    ]
    for best, name in zip(found, figure_names(found), strict=True):
        (draw or draw_now)(_figure, best, out / name)
        engine = escape_text(best.engine)
        nth = name.removesuffix(".png").removeprefix(f"best-settings-{file_stem(best.engine)}")
        lines += [
            "",
            f"### {engine}" + (f" (search {nth.lstrip('-')})" if nth else ""),
            "",
            f"Search started {escape_text(best.created or 'at a time not recorded')}. "
            f"{_clock_words(best.cost_clock)}. "
            f"Training scenes: {escape_text(', '.join(best.training_scenes))}; "
            f"{len(best.trials)} trials. {_summary(best)}",
            "",
            _tiers_line(best),
            "",
            *_table(best),
            "",
            f"![{engine}: error against cost]({name})",
        ]
    return "\n".join(lines) + "\n"
