"""The report from stored results: the runs of every results folder, and the report files.

No simulation happens here: each results folder's rows (and a map folder's section) become one
``report.md`` with its figures (:mod:`hoopbench.reports.report.markdown`).
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable, Sequence
from concurrent.futures import Future
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.reports.compare.suite import LEFT_OUT_KEY, runs_frame
from hoopbench.reports.compare.suite_file import CatalogueNameError, LeftOut, load_suite
from hoopbench.reports.hop_map.spec import MAP_FILE
from hoopbench.reports.report.answer_files import ANSWER_CSV, ANSWER_JSON
from hoopbench.reports.report.batch_cost import batch_cost_section, is_batch_cost_folder
from hoopbench.reports.report.best_settings import (
    best_settings,
    best_settings_section,
    is_tune_folder,
)
from hoopbench.reports.report.drawing_processes import started_drawing
from hoopbench.reports.report.map_section import is_map_folder, map_prefixes, map_sections
from hoopbench.reports.report.markdown import (
    FigurePool,
    Say,
    SuiteMachine,
    answer_left_out,
    write_markdown,
)
from hoopbench.reports.report.page import (
    GIF_SCENE,
    gif_runs,
    page_fragments,
    page_jobs,
    write_gif,
    write_page,
)
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.folder_files import (
    MAX_DATA_BYTES,
    FolderFileError,
    folder_file,
    read_folder_text,
)
from hoopbench.reports.sweep.runner import sweep_lock

__all__ = [
    "ReportFilesExistError",
    "answer_left_out_of",
    "build_report",
    "files_to_replace",
    "report_frame",
]


class ReportFilesExistError(ValueError):
    """The report's folder holds files the report would write: nothing is replaced."""


REPORT_FILES = ("report.md", "report.html", ANSWER_CSV, ANSWER_JSON)
FIGURE_SUFFIXES = (".png", ".gif")
"""What a report writes: these files and its figures (their names depend on the results)."""


def files_to_replace(out: Path, dirs: Sequence[Path]) -> list[Path]:
    """The files of ``out`` a report would write over: report.md, report.html, answer.csv,
    answer.json and (unless ``out`` is one of the results folders, whose own figures a map
    redraws) any figure."""
    if not out.is_dir():
        return []
    own = any(out.resolve() == d.resolve() for d in dirs)
    return sorted(
        (
            p
            for p in out.iterdir()
            if p.name in REPORT_FILES or (not own and p.suffix in FIGURE_SUFFIXES)
        ),
        key=lambda p: (
            REPORT_FILES.index(p.name) if p.name in REPORT_FILES else len(REPORT_FILES),
            p.name,
        ),
    )


def _check_out(out: Path, dirs: Sequence[Path], force: bool) -> None:
    """ReportFilesExistError if ``out`` holds files the report would write (the user's files
    are never replaced without ``force``)."""
    held = [] if force else files_to_replace(out, dirs)
    if held:
        raise ReportFilesExistError(
            f"{str(held[0])!r} exists; pass --force (force=True) to replace it"
            + (f" (and {len(held) - 1} more file(s) the report writes)" if len(held) > 1 else "")
        )


def build_report(
    results_dirs: str | os.PathLike[str] | Sequence[str | os.PathLike[str]],
    out: str | Path | None = None,
    *,
    force: bool = False,
    say: Say | None = None,
) -> Path:
    """report.md and its figures, and report.html, from stored results alone (no simulation).

    Several results folders (e.g. the default suite and the stability suite) make one report;
    each row keeps the name of its suite in the column ``suite``. A hop map folder (it holds
    map.toml) adds its own section (reports/report/map_section.py), and so does a folder of the
    batched engines' bench (batch_cost.csv: reports/report/batch_cost.py). ``out`` defaults to
    the first folder. ``say`` hears what it is doing, a line a step (markdown.Say).
    """
    given = [results_dirs] if isinstance(results_dirs, str | os.PathLike) else results_dirs
    dirs = [Path(d) for d in given]
    out = Path(out) if out is not None else dirs[0]
    maps = [d for d in dirs if is_map_folder(d)]  # hop maps: a section each, not runs rows
    tunes = [d for d in dirs if is_tune_folder(d)]  # searches: the Best settings section
    benches = [d for d in dirs if is_batch_cost_folder(d)]  # make bench's batch costs
    found = best_settings(tunes)
    plain = [d for d in dirs if d not in maps and d not in tunes and d not in benches]
    runs = [report_frame(d) for d in plain]
    _refuse_shared_runs(plain, runs)
    frame = pd.concat(runs, ignore_index=True) if runs else pd.DataFrame()
    _check_out(out, dirs, force)
    # Said once the inputs are read and checked: a refused input is the one line of stderr.
    if say is not None:
        say(f"read {len(plain)} results folder(s), {len(tunes)} search(es), "
            f"{len(maps)} map(s), {len(benches)} bench folder(s)")  # fmt: skip
    generated = datetime.now(UTC).isoformat(timespec="seconds")
    # Two reports into one folder would mix their figures: the sweeps' lock serves.
    # The figures are drawn in a FigurePool beside the tables, each as written
    # (FigurePool.submit), none in this process: the sections' own (the maps', the
    # searches') as soon as each section is made, so that the process the GIF leaves free
    # draws them while this one makes the next sections; then report.md's, the dearest
    # first. The pool's fork server imports the drawing modules once (FigurePool's
    # preload); drawing processes started ahead (report-runs --report) are taken once the
    # lock is held.
    started = started_drawing.get()
    take = started.take if started is not None else lambda: None
    with sweep_lock(out), FigurePool(processes=take(), preload=[__name__]) as pool:
        _check_out(out, dirs, force)  # again, under the lock: one may have just finished
        awaited: list[Future] = []

        def draw(function: Callable[..., Any], *args: Any) -> None:
            awaited.append(pool.submit(function, *args))

        # The animation, the dearest drawing, started now: a drawing process works on it
        # while the sections below are made. report.md waits for it (its Files section
        # lists what the folder holds).
        if gif_runs(frame):
            if say is not None:
                say(f"the animation {GIF_SCENE}.gif")
            awaited.append(pool.submit(write_gif, frame, out))
        if maps and say is not None:
            say(f"the hop map section(s) of {len(maps)} map(s)")
        extra = map_sections(maps, out, draw)
        if found:
            if say is not None:
                say(f"the Best settings section of {len(found)} search(es)")
            extra.append(best_settings_section(found, out, draw))
        if benches:
            extra.append(batch_cost_section(benches))
        machines = [_suite_machine(d) for d in plain]
        prefixes = map_prefixes(len(maps))
        # The page's figures are drawn after report.md's, while report.md is written.
        fragments = page_fragments(frame, maps, prefixes, found)
        report = write_markdown(
            frame,
            out,
            generated=generated,
            extra=extra,
            searches=found,
            machines=machines,
            results_dirs=dirs,
            say=say,
            pool=pool,
            awaited=awaited,
            then=list(page_jobs(fragments).values()),
        )
        write_page(
            frame, out, maps=maps, map_prefixes=prefixes, searches=found, say=say, pool=pool,
            fragments=fragments,
        )  # fmt: skip
    return report


def report_frame(results_dir: str | Path) -> pd.DataFrame:
    """The runs of a results folder as the report reads them: trajectory paths resolved
    (they are stored relative to the folder, so that the folder can move)."""
    results_dir = Path(results_dir)
    frame = runs_frame(results_dir)
    _check_rows(frame, results_dir)
    paths = [_trajectory_path(results_dir, p) for p in frame["trajectory_file"]]
    frame = frame.assign(trajectory_file=paths, suite=_suite_name(results_dir))
    # Rows are stored as runs finish; tables read best in the suite's own order.
    order = _suite_order(results_dir / "suite.toml")
    rank = [order.get(run_id, len(order)) for run_id in frame["run_id"]]
    return frame.iloc[sorted(range(len(frame)), key=rank.__getitem__)].reset_index(drop=True)


_REQUIRED = (Col.RUN_ID, Col.STATUS, Col.SCENE, Col.ENGINE, Col.VARIANT, Col.TIMESTEP)
"""Columns every row of a compare folder has, a failed run's too (compare/suite.py)."""


def _check_rows(frame: pd.DataFrame, results_dir: Path) -> None:
    """ValueError naming the runs folder and what is wrong, for a table no sweep writes: an
    empty one, rows without their run's identity, a timestep that is no number, or a hop
    map's rows without the map.toml that makes them one."""
    where = results_dir / results.RUNS_NAME
    if frame.empty:
        raise ValueError(f"{where} holds no runs: nothing to report")
    if "ix" in frame.columns and frame[Col.SCENE].isna().all():
        raise ValueError(f"{where} holds a hop map's rows but {results_dir / MAP_FILE} is missing")
    for column in _REQUIRED:
        missing = int(frame[column].isna().sum())
        if missing:
            raise ValueError(f"{where}: {missing} of {len(frame)} row(s) have no {column}")
    timestep = pd.to_numeric(frame[Col.TIMESTEP], errors="coerce")
    wrong = ~np.isfinite(timestep.to_numpy(dtype=float)) | (timestep <= 0).to_numpy()
    if wrong.any():  # "at inf" in a table is no timestep a run had
        bad = frame[Col.TIMESTEP][wrong].iloc[0]
        bad = bad.item() if hasattr(bad, "item") else bad  # 'inf', not 'np.float64(inf)'
        raise ValueError(f"{where}: timestep must be a finite number > 0 s, got {bad!r}")


def _trajectory_path(results_dir: Path, stored: object) -> str | None:
    """A row's trajectory file, stored relative to the folder (so that it can move); a path
    that leads out of the folder is data from elsewhere, not a file of this folder's."""
    if not isinstance(stored, str) or not stored:
        return None
    try:
        path = folder_file(results_dir, stored, MAX_DATA_BYTES)
    except FolderFileError:
        return None
    return None if path is None else str(path)


def _refuse_shared_runs(dirs: Sequence[Path], frames: Sequence[pd.DataFrame]) -> None:
    """ValueError if two folders hold the same runs (one folder given twice, or a copy):
    the report would count each of them twice."""
    seen: dict[str, Path] = {}
    for folder, frame in zip(dirs, frames, strict=True):
        shared = set(frame[Col.RUN_ID]) & set(seen)
        if shared:
            other = seen[next(iter(sorted(shared)))]
            raise ValueError(
                f"--results {str(other)!r} and {str(folder)!r} hold {len(shared)} of the same "
                "runs: each would be counted twice; give one of them"
            )
        seen |= dict.fromkeys(frame[Col.RUN_ID], folder)


def _suite_name(results_dir: Path) -> str:
    """The suite a results folder holds (from meta.json; the folder name if it is missing)."""
    text = read_folder_text(results_dir, results.META_NAME)  # FolderFileError: not a file
    try:
        return str(json.loads(text)["suite"]) if text is not None else results_dir.name
    except (ValueError, KeyError, TypeError):
        return results_dir.name


def _meta(results_dir: Path) -> dict:
    """A results folder's meta.json (empty where it is missing or unreadable)."""
    text = read_folder_text(results_dir, results.META_NAME)  # FolderFileError: not a file
    try:
        meta = json.loads(text) if text is not None else {}
    except ValueError:
        return {}
    return meta if isinstance(meta, dict) else {}


def _load(value: object) -> tuple[float, ...] | None:
    """A stored load average (1, 5 and 15 min); None where it is not one."""
    if not isinstance(value, list) or not value:
        return None
    if not all(isinstance(x, int | float) and not isinstance(x, bool) for x in value):
        return None
    return tuple(float(x) for x in value)


def _suite_machine(results_dir: Path) -> SuiteMachine:
    """The machine and load a results folder's sweep ran with (its meta.json: cpu_model,
    cpu_count, and the session's load averages at its start and end)."""
    meta = _meta(results_dir)
    session = meta.get("session")
    session = session if isinstance(session, dict) else {}
    model, count = meta.get("cpu_model"), meta.get("cpu_count")
    return SuiteMachine(
        suite=_suite_name(results_dir),
        cpu_model=model if isinstance(model, str) else None,
        cpu_count=count if isinstance(count, int) and not isinstance(count, bool) else None,
        load_start=_load(session.get("load_average_start")),
        load_end=_load(session.get("load_average_end")),
        left_out=_left_out(meta.get(LEFT_OUT_KEY)),
    )


def answer_left_out_of(results_dirs: Sequence[Path]) -> list[tuple[str, LeftOut]]:
    """What the answer's suites among these results folders left out for want of a GPU
    (their meta.json), with each suite's name: ``hoopbench findings`` says it under the
    README's answer, as the report does."""
    return answer_left_out([_suite_machine(Path(folder)) for folder in results_dirs])


def _left_out(value: Any) -> tuple[LeftOut, ...]:
    """The stored runs a suite left out for want of a GPU (none where the entry is not a
    list of them)."""
    if not isinstance(value, list):
        return ()
    items = [LeftOut.from_dict(item) for item in value]
    return tuple(item for item in items if item is not None)


def _suite_order(suite_file: Path) -> dict[str, int]:
    """run_id -> position in the suite as run (empty if its copy is missing or unreadable)."""
    if folder_file(suite_file.parent, suite_file.name) is None:  # FolderFileError: no file
        return {}
    try:
        tasks = load_suite(suite_file).tasks()
    except CatalogueNameError as exc:  # its rows would be drawn as the catalogue's scene
        raise ValueError(f"{suite_file.parent}: {exc}") from None
    except ValueError:  # e.g. an engine no longer registered: the rows are still readable
        return {}
    return {task.run_id: k for k, task in enumerate(tasks)}
