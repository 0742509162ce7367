"""The batched engines' cost per world-step by batch size: the file ``make bench`` writes and the
report's section of it.

``python -m hoopbench.reports.bench.batched_engines --out DIR`` measures each batched engine
(and MuJoCo C through ``mujoco.batch``) at batch sizes 1, 64 and 1,024 and writes one row per
engine setting and size to ``DIR/batch_cost.csv`` (:data:`BATCH_COST_FILE`; the columns of
:data:`BATCH_COST_COLUMNS`, named as a runs table's). ``hoopbench report --results DIR`` reads
such a folder (:func:`is_batch_cost_folder`) and adds the section :func:`batch_cost_section`.
Computing apart from presenting: :func:`batch_cost_table` is the table, the section renders it.
A suite's own rows cannot give this: its batches hold a suite's few scenes of one setting.
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.reports.report.escaping import escape_cell
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.folder_files import read_folder_text

__all__ = [
    "BATCH_COST_COLUMNS",
    "BATCH_COST_FILE",
    "batch_cost_section",
    "batch_cost_table",
    "is_batch_cost_folder",
    "read_batch_cost",
    "write_batch_cost",
]

BATCH_COST_FILE = "batch_cost.csv"
"""The bench's file in its folder."""
SETTING = "setting"
"""An engine and its options as the table labels it: 'mjx precision=float64'."""
STEPS_PER_WORLD = "steps_per_world"
DEVICE = "device"
MEASURED_AT = "measured_at"
BATCH_COST_COLUMNS = (
    Col.ENGINE,
    SETTING,
    Col.ENGINE_VERSION,
    Col.TIMESTEP,
    STEPS_PER_WORLD,
    DEVICE,
    Col.BATCH_SIZE,
    Col.US_PER_WORLD_STEP,
    Col.WORLD_STEPS_PER_S,
    MEASURED_AT,
)
"""The file's columns: timestep in s, cost in us per world-step and world-steps per s."""
_NUMERIC = (Col.TIMESTEP, STEPS_PER_WORLD, Col.BATCH_SIZE, Col.US_PER_WORLD_STEP)
_COUNTS = (STEPS_PER_WORLD, Col.BATCH_SIZE)
"""Of _NUMERIC, the whole numbers (batch_cost_table takes the sizes as ints)."""


def write_batch_cost(frame: pd.DataFrame, out: str | Path) -> Path:
    """``frame`` (the columns of BATCH_COST_COLUMNS) as ``out/batch_cost.csv``, written whole."""
    path = Path(out) / BATCH_COST_FILE
    path.parent.mkdir(parents=True, exist_ok=True)
    table = frame[list(BATCH_COST_COLUMNS)]
    return results.atomic_write(path, lambda tmp: table.to_csv(tmp, index=False))


def is_batch_cost_folder(folder: str | Path) -> bool:
    """Whether ``folder`` holds the bench's file and no runs of a sweep."""
    folder = Path(folder)
    return (folder / BATCH_COST_FILE).is_file() and not (folder / results.RUNS_NAME).exists()


def read_batch_cost(folder: str | Path) -> pd.DataFrame:
    """The bench's rows of ``folder``; ValueError naming the file for one no bench wrote."""
    where = Path(folder) / BATCH_COST_FILE
    text = read_folder_text(folder, BATCH_COST_FILE)
    if text is None:
        raise ValueError(f"{where} is missing")
    try:
        frame = pd.read_csv(io.StringIO(text))
    except (ValueError, pd.errors.ParserError) as exc:
        raise ValueError(f"{where} is not a CSV table: {exc}") from None
    missing = [c for c in BATCH_COST_COLUMNS if c not in frame.columns]
    if missing or frame.empty:
        what = f"has no column(s) {', '.join(missing)}" if missing else "holds no rows"
        raise ValueError(f"{where} {what}: not a batch-cost file of the bench")
    for column in _NUMERIC:
        values = pd.to_numeric(frame[column], errors="coerce")
        bad = ~((values > 0) & (values < math.inf))  # NaN included: text, an empty cell
        whole = column in _COUNTS
        if whole:
            bad |= values % 1 != 0
        if column == Col.US_PER_WORLD_STEP:  # a failed measurement leaves its cost empty
            bad &= frame[column].notna()
        if bad.any():
            shown = frame[column][bad].iloc[0]
            shown = shown.item() if hasattr(shown, "item") else shown  # inf, not np.float64(inf)
            kind = "a whole number > 0" if whole else "a number > 0"
            raise ValueError(f"{where}: {column} must be {kind}, got {shown!r}")
        frame[column] = values.astype(int) if whole else values
    return frame


def batch_cost_table(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per engine setting (in the file's order), one column per batch size: us per
    world-step (NaN: not measured or failed); plus ``alone / largest``, how many times
    cheaper a world-step is in the largest batch than alone."""
    sizes = sorted(int(s) for s in frame[Col.BATCH_SIZE].unique())
    table = frame.pivot_table(
        index=SETTING, columns=Col.BATCH_SIZE, values=Col.US_PER_WORLD_STEP, aggfunc="median"
    )
    table = table.reindex(index=list(dict.fromkeys(frame[SETTING])), columns=sizes)
    table.columns = [int(c) for c in table.columns]
    if len(sizes) > 1:
        table["gain"] = table[sizes[0]] / table[sizes[-1]]
    return table


def _number(value: float) -> str:
    if not math.isfinite(value):
        return "-"
    return f"{value:,.3g}" if value < 1000 else f"{value:,.0f}"


def _conditions(frame: pd.DataFrame) -> str:
    """'dt 0.001 s, 100 steps per world, device auto / cpu, measured from 2026-11-26T...'
    (each value as the file gives it; several joined by ' / ')."""
    parts = []
    for column, say in (
        (Col.TIMESTEP, "dt {} s"),
        (STEPS_PER_WORLD, "{} steps per world"),
        (DEVICE, "device {}"),
        (MEASURED_AT, "measured from {}"),
    ):
        values = [f"{v:g}" if isinstance(v, float) else str(v) for v in frame[column].unique()]
        parts.append(say.format(" / ".join(values)))
    return ", ".join(parts)


def batch_cost_section(folders: Sequence[Path]) -> str:
    """The report's section of the bench folders (Markdown, ending in a blank line): each
    world-step's cost in the report's one cost unit, seconds of stepping per simulated
    second of one world (us per world-step x 1e-6 / its timestep)."""
    lines = ["## Cost per world-step by batch size", ""]
    for folder in folders:
        frame = read_batch_cost(folder)
        table = batch_cost_table(frame)
        timestep = frame.groupby(SETTING, sort=False)[Col.TIMESTEP].first()
        sizes = [c for c in table.columns if c != "gain"]
        head = ["engine, settings", *(f"{s:,} world{'s' if s > 1 else ''}" for s in sizes)]
        if "gain" in table.columns:
            head.append(f"{sizes[0]:,} / {sizes[-1]:,}")
        lines += [
            f"From `{escape_cell(str(folder.name))}/{BATCH_COST_FILE}` "
            "(`python -m hoopbench.reports.bench.batched_engines --out DIR`, `make bench`), "
            "read, not measured, by this report: `make report` shows the file shipped with "
            "the repository (reports/bench/measured) until `make bench` writes one here. "
            "Seconds of stepping per simulated second of one world (the report's one cost "
            "unit: µs per world-step x 1e-6 / dt), tuned, "
            f"{escape_cell(_conditions(frame))} (device auto: a "
            "GPU if the engine sees one, else the CPU; MuJoCo C runs on the CPU). The "
            "stepping loop of `Engine.simulate_batch` over the batch's world-steps (compile "
            "and model building excluded), wall time; the last column is how many times "
            "cheaper a world-step is "
            "in the largest batch than alone. A machine shared with other work makes these "
            "upper bounds.",
            "",
            "| " + " | ".join(head) + " |",
            "|---|" + "---:|" * (len(head) - 1),
        ]
        for setting, row in table.iterrows():
            per_sim_s = 1e-6 / float(timestep[setting])
            cells = [_number(float(row[s]) * per_sim_s) for s in sizes]
            if "gain" in table.columns:
                gain = float(row["gain"])
                cells.append(f"{gain:.3g}x" if math.isfinite(gain) else "-")
            lines.append(f"| {escape_cell(str(setting))} | " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines) + "\n"
