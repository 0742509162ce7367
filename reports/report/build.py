"""The report from stored results: the runs of every results folder, and the report files.

No simulation happens here: each results folder's rows (and a map folder's section) become one
``report.md`` with its figures (:mod:`hoopbench.reports.report.markdown`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Sequence
from datetime import UTC, datetime
from pathlib import Path

import pandas as pd

from hoopbench.reports.compare.suite import runs_frame
from hoopbench.reports.compare.suite_file import load_suite
from hoopbench.reports.report.map_section import is_map_folder, map_prefixes, map_sections
from hoopbench.reports.report.markdown import write_markdown
from hoopbench.reports.report.page import write_page
from hoopbench.reports.sweep import results

__all__ = ["build_report", "report_frame"]


def build_report(
    results_dirs: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    out: str | Path | None = None,
) -> Path:
    """report.md and its figures, and report.html, from stored results alone (no simulation).

    Several results folders (e.g. the default suite and the stability suite) make one report;
    each row keeps the name of its suite in the column ``suite``. A hop map folder (it holds
    map.toml) adds its own section (reports/report/map_section.py). ``out`` defaults to the first
    folder.
    """
    given = [results_dirs] if isinstance(results_dirs, str | os.PathLike) else results_dirs
    dirs = [Path(d) for d in given]
    out = Path(out) if out is not None else dirs[0]
    maps = [d for d in dirs if is_map_folder(d)]  # hop maps: a section each, not runs rows
    runs = [report_frame(d) for d in dirs if d not in maps]
    frame = pd.concat(runs, ignore_index=True) if runs else pd.DataFrame()
    out.mkdir(parents=True, exist_ok=True)
    generated = datetime.now(UTC).isoformat(timespec="seconds")
    report = write_markdown(frame, out, generated=generated, extra=map_sections(maps, out))
    write_page(frame, out, maps=maps, map_prefixes=map_prefixes(len(maps)))  # report.html
    return report


def report_frame(results_dir: str | Path) -> pd.DataFrame:
    """The runs of a results folder as the report reads them: trajectory paths resolved
    (they are stored relative to the folder, so that the folder can move)."""
    results_dir = Path(results_dir)
    frame = runs_frame(results_dir)
    paths = [
        str(results_dir / p) if isinstance(p, str) and p else None for p in frame["trajectory_file"]
    ]
    frame = frame.assign(trajectory_file=paths, suite=_suite_name(results_dir))
    # Rows are stored as runs finish; tables read best in the suite's own order.
    order = _suite_order(results_dir / "suite.toml")
    rank = [order.get(run_id, len(order)) for run_id in frame["run_id"]]
    return frame.iloc[sorted(range(len(frame)), key=rank.__getitem__)].reset_index(drop=True)


def _suite_name(results_dir: Path) -> str:
    """The suite a results folder holds (from meta.json; the folder name if it is missing)."""
    try:
        return str(json.loads((results_dir / results.META_NAME).read_text())["suite"])
    except (OSError, ValueError, KeyError):
        return results_dir.name


def _suite_order(suite_file: Path) -> dict[str, int]:
    """run_id -> position in the suite as run (empty if its copy is missing or unreadable)."""
    try:
        tasks = load_suite(suite_file).tasks()
    except ValueError:
        return {}
    return {task.run_id: k for k, task in enumerate(tasks)}
