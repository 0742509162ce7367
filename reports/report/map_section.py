"""The hop map's Markdown: its section of the report, and the files ``hoopbench map`` writes.

A map folder (it holds ``map.toml`` beside ``runs/``) becomes one section: what was mapped
(from the stored spec), findings generated from the numbers, the figures
(:mod:`hoopbench.reports.report.map_figures`) and the agreement tables
(:func:`hoopbench.reports.hop_map.agreement_table`). Every sentence is a template filled from
the rows: none is written by hand.

- :func:`map_section` is the section (``hoopbench report`` adds one per map folder);
- :func:`write_map_outputs` writes the figures and ``DIR/map.md`` (``hoopbench map`` calls it
  after its runs).
"""

from __future__ import annotations

import hashlib
import os
import shutil
from collections.abc import Callable, Sequence
from concurrent.futures import Executor, Future
from functools import partial
from pathlib import Path
from typing import Any

import pandas as pd

from hoopbench.engines.judging.columns import COST_COLUMNS
from hoopbench.engines.judging.tolerances import Tier, event_tolerances
from hoopbench.engines.judging.verdict import Verdict
from hoopbench.reference.regimes import Regime
from hoopbench.reports.compare.selection import engine_rows, reference_rows
from hoopbench.reports.hop_map.spec import AXES, MAP_FILE, Axis, MapSpec, load_spec
from hoopbench.reports.hop_map.table import ALL_REGIMES, agreement_table, map_frame
from hoopbench.reports.report import glyph_cache, map_figures, plotting
from hoopbench.reports.report.escaping import escape_cell, escape_text
from hoopbench.reports.report.map_figures import (
    FIGURE_KEY,
    engines_of,
    hop_error_figure,
    regime_figure,
    verdict_figure,
)
from hoopbench.reports.report.plotting import Draw, draw_now, written_whole
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.folder_files import MAX_DATA_BYTES, FolderFileError, folder_file

__all__ = [
    "MAP_MARKDOWN",
    "UNDRAWN_COLUMNS",
    "agreement_markdown",
    "drawn_key",
    "figure_key",
    "figure_keys",
    "is_map_folder",
    "map_findings",
    "map_prefixes",
    "map_section",
    "map_sections",
    "write_map_figures",
    "write_map_outputs",
]

MAP_MARKDOWN = "map.md"
"""The map's own summary, beside its runs (written by ``hoopbench map``)."""

_FIGURES: dict[str, tuple[Callable[[pd.DataFrame, Path], Path], str, bool]] = {
    "regimes": (regime_figure, "the exact reference's regimes and hop height", False),
    "verdicts": (verdict_figure, "where each engine's verdict differs from the reference", True),
    "hop_error": (hop_error_figure, "hop height over the exact one where both hop", True),
}
"""Figure name -> (drawing function, alt text, needs engine rows)."""


def is_map_folder(path: str | Path) -> bool:
    """Whether a results folder holds a hop map (its map.toml; whatever is under that name,
    which reading it then checks, hop_map/spec.load_spec)."""
    spec = Path(path) / MAP_FILE
    return spec.exists() or spec.is_symlink()


# --------------------------------------------------------------------------- numbers
def _pct(count: int, total: int) -> str:
    return f"{100 * count / total:.0f} %" if total else "-"


def _share(count: int, total: int) -> str:
    """'12/40 (30 %)'."""
    return f"{count}/{total} ({_pct(count, total)})"


def _engine_rows(frame: pd.DataFrame) -> pd.DataFrame:
    return engine_rows(frame)


def _regime_counts(refs: pd.DataFrame) -> pd.Series:
    """Points per regime, in Regime's order, regimes with none left out."""
    counts = refs["regime"].value_counts()
    return pd.Series({str(r): int(counts[str(r)]) for r in Regime if str(r) in counts}, dtype=int)


def _regime_sentence(frame: pd.DataFrame) -> str:
    refs = reference_rows(frame)
    counts = _regime_counts(refs)
    if counts.empty:
        return ""
    counts = counts.sort_values(ascending=False, kind="stable")  # ties in Regime's order
    n = len(refs)
    parts = [f"{int(c)} {regime} ({_pct(int(c), n)})" for regime, c in counts.items()]
    text = f"The exact reference classifies the {n} points: {', '.join(parts)}"
    unclassified = n - int(counts.sum())
    return text + (f"; {unclassified} have no regime (the solve failed)." if unclassified else ".")


def _ranking_sentence(table: pd.DataFrame) -> str:
    """Most and least agreement, by outcome (then the full verdict)."""
    overall = table[(table["regime"] == ALL_REGIMES) & (table["judged"] > 0)]
    if overall.empty:
        return ""
    ranked = overall.sort_values(
        ["outcome_agrees_pct", "agrees_pct"], ascending=False, kind="stable"
    )

    def numbers(row: pd.Series) -> str:
        return (
            f"the outcome on {_share(row['outcome_agrees'], row['judged'])} of its judged "
            f"points, the phases too on {_share(row['agrees'], row['judged'])}"
        )

    best, worst = ranked.iloc[0], ranked.iloc[-1]
    if len(ranked) == 1:
        return f"{best['engine']} agrees with the reference on {numbers(best)}."
    key = ["outcome_agrees_pct", "agrees_pct"]
    top = ranked[(ranked[key] == best[key]).all(axis=1)]["engine"].astype(str).tolist()
    bottom = ranked[(ranked[key] == worst[key]).all(axis=1)]["engine"].astype(str).tolist()
    if len(top) == len(ranked):  # all alike: a tie, no order
        return f"{_names(top)} agree with the reference alike: each {numbers(best)}."
    verb = "agrees" if len(top) == 1 else "agree"
    return (
        f"{_names(top)} {verb} most with the reference: {numbers(best)}; "
        f"{_names(bottom)} least: {numbers(worst)}."
    )


def _names(engines: list[str]) -> str:
    """'a', 'a and b', 'a, b and c'."""
    return engines[0] if len(engines) == 1 else f"{', '.join(engines[:-1])} and {engines[-1]}"


def _worst_regime_sentence(frame: pd.DataFrame, table: pd.DataFrame, engine: str) -> str:
    """The regime where an engine's verdict is most often not 'agrees', and its usual verdict."""
    rows = table[(table["engine"] == engine) & (table["regime"] != ALL_REGIMES)]
    rows = rows[rows["judged"] > 0].assign(wrong=lambda t: t["judged"] - t["agrees"])
    rows = rows[rows["wrong"] > 0]
    if rows.empty:
        return ""
    # Highest share first; more points break a tie (a bigger sample says more).
    worst = rows.assign(share=rows["wrong"] / rows["judged"]).sort_values(
        ["share", "judged"], ascending=False, kind="stable"
    )
    worst = worst.iloc[0]
    mine = _engine_rows(frame)
    mine = mine[(mine["engine"] == engine) & (mine["regime"] == worst["regime"])]
    counts = mine["verdict"].value_counts()
    wrong = pd.Series({str(v): counts.get(str(v), 0) for v in Verdict if v != Verdict.AGREES})
    wrong = wrong[wrong > 0].sort_values(ascending=False, kind="stable")  # ties: Verdict's order
    usual = ", ".join(f"{v} {int(c)}" for v, c in wrong.items())
    return (
        f"{engine} disagrees most in regime {worst['regime']}: "
        f"{_share(int(worst['wrong']), int(worst['judged']))} have a verdict other than agrees "
        f"({usual})."
    )


def _hardest_regime_sentence(table: pd.DataFrame) -> str:
    """The regime with the lowest agreement over all engines together."""
    rows = table[table["regime"] != ALL_REGIMES]
    sums = rows.groupby("regime", sort=False)[["judged", "agrees", "outcome_agrees"]].sum()
    sums = sums[sums["judged"] > 0]
    if len(sums) < 2:
        return ""
    share = sums["agrees"] / sums["judged"]
    hard, easy = share.idxmin(), share.idxmax()
    if share[hard] == share[easy]:
        return ""
    h, e = sums.loc[hard], sums.loc[easy]
    return (
        f"Over all engines, runs agree least often in regime {hard} "
        f"({_share(int(h['agrees']), int(h['judged']))} of its judged runs, the outcome alone "
        f"{_pct(int(h['outcome_agrees']), int(h['judged']))}) and most often in regime {easy} "
        f"({_share(int(e['agrees']), int(e['judged']))})."
    )


def _hop_sentence(frame: pd.DataFrame, engine: str) -> str:
    """Hop heights where both hop: how many within the loose tolerance (the table's, the
    verdict's), the median ratio."""
    mine = _engine_rows(frame)
    mine = mine[mine["engine"] == engine]
    error = pd.to_numeric(mine["hop_height_error"], errors="coerce")
    exact = pd.to_numeric(mine["exact_hop_height"], errors="coerce")
    both = error.notna() & (exact > 0)
    if not both.any():
        return ""
    ratio = 1.0 + error[both] / exact[both]
    loose = event_tolerances(Tier.LOOSE).hop_height_rel
    within = int(((ratio - 1.0).abs() <= loose).sum())
    return (
        f"Where both hop, {engine}'s hop height is within {100 * loose:g} % (loose) of "
        f"the exact one at {_share(within, int(both.sum()))} points (median ratio "
        f"{ratio.median():.3g}, range {ratio.min():.3g} to {ratio.max():.3g})."
    )


def _stop_sentence(frame: pd.DataFrame) -> str:
    """How the engine runs ended, and their simulated and wall time."""
    runs = _engine_rows(frame)
    ran = runs[runs["status"].notna() & runs["n_steps"].notna()]
    if ran.empty:
        return ""
    reasons = ran["stop_reason"].fillna("window").value_counts()
    named = {"impact": "at their first impact", "settled": "once settled"}
    parts = [
        f"{int(c)} {named.get(str(r), 'at the end of the window')}" for r, c in reasons.items()
    ]
    sim = pd.to_numeric(ran["sim_time_s"], errors="coerce")
    t_end = pd.to_numeric(ran["t_end"], errors="coerce")
    wall = ran.groupby("engine", sort=False)["wall_time_s"].mean()
    cost = ", ".join(f"{e} {w:.3g} s" for e, w in wall.items())
    return (
        f"Of the {len(ran)} engine runs, {', '.join(parts)}; they simulated "
        f"{sim.mean():.3g} s of a {t_end.max():g} s window on average. Mean wall time per run: "
        f"{cost}."
    )


def map_findings(frame: pd.DataFrame, table: pd.DataFrame | None = None) -> list[str]:
    """The map's findings, one sentence each, every one filled from the frame's numbers.
    ``table``: the frame's agreement_table if the caller made it already (made here if not)."""
    sentences = [_regime_sentence(frame)]
    engines = engines_of(frame)
    if engines:
        table = agreement_table(frame) if table is None else table
        sentences += [_ranking_sentence(table), _hardest_regime_sentence(table)]
        sentences += [_worst_regime_sentence(frame, table, e) for e in engines]
        sentences += [_hop_sentence(frame, e) for e in engines]
        sentences.append(_stop_sentence(frame))
    return [s for s in sentences if s]


# --------------------------------------------------------------------------- text
def _axis_text(axis: Axis, value: float) -> str:
    unit = AXES[axis].unit
    return f"{value:g} {unit}" if unit else f"{value:g}"


def _axis_span(spec: MapSpec, axis: Axis, which: str, n: int) -> str:
    """'lam (x): 6 points from 0.5 to 1' (the grid's values: spec.axis_values)."""
    values = spec.axis_values(axis)
    if n == 1:
        return f"{axis} ({which}) = {_axis_text(axis, values[0])}"
    first, last = _axis_text(axis, values[0]), _axis_text(axis, values[-1])
    return f"{axis} ({which}): {n} points from {first} to {last}"


def _spec_text(spec: MapSpec) -> str:
    fixed = ", ".join(f"{k} = {_axis_text(Axis(k), v)}" for k, v in spec.fixed_values.items())
    return (
        f"A {spec.nx} x {spec.ny} grid, {_axis_span(spec, spec.x, 'x', spec.nx)}, "
        f"{_axis_span(spec, spec.y, 'y', spec.ny)}; fixed {fixed} (mus = muk = mu); "
        f"window t_end = {spec.t_end:g} s. Engines: {_engines_text(spec)}, "
        f"profile {spec.profile}."
    )


def _engines_text(spec: MapSpec) -> str:
    """'mujoco, pymunk at dt = 0.0001 s; mjx at dt = 0.001 s (its own step)'."""
    if not spec.engines:
        return "none (the reference's regimes alone)"
    steps = {name: spec.timestep_of(name) for name in spec.engines}
    parts = []
    for dt in sorted(set(steps.values()), key=lambda v: (v != spec.timestep, v)):
        names = [n for n, v in steps.items() if v == dt]
        own = "" if dt == spec.timestep else f" ({'its' if len(names) == 1 else 'their'} own step)"
        parts.append(f"{', '.join(names)} at dt = {dt:g} s{own}")
    return "; ".join(parts)


def _status_text(frame: pd.DataFrame) -> str:
    counts = frame["status"].value_counts()
    return f"Rows: {len(frame)}; status " + ", ".join(f"{k} {int(v)}" for k, v in counts.items())


def _regime_table(frame: pd.DataFrame) -> str:
    refs = reference_rows(frame)
    lines = ["| exact regime | points | share |", "|---|---:|---:|"]
    lines += [
        f"| {escape_cell(r)} | {c} | {_pct(c, len(refs))} |"
        for r, c in _regime_counts(refs).items()
    ]
    return "\n".join(lines)


def agreement_markdown(table: pd.DataFrame) -> str:
    """Two Markdown tables from :func:`~hoopbench.reports.hop_map.table.agreement_table`: the
    outcome agreement and the full agreement (outcome and phases), regimes down, engines
    across, cells 'agree/judged (%)'; engine and regime names escaped (they are data)."""
    blocks = []
    for column, title in (
        ("outcome_agrees", "Outcome agrees (class, hop size and lift-off time)"),
        ("agrees", "Verdict agrees (the outcome and the phase sequence)"),
    ):
        engines = list(dict.fromkeys(table["engine"]))
        regimes = list(dict.fromkeys(table["regime"]))
        header = " | ".join(map(escape_cell, engines))
        lines = [f"**{title}**", "", f"| regime | {header} |"]
        lines.append("|---|" + "---:|" * len(engines))
        for regime in regimes:
            cells = []
            for engine in engines:
                row = table[(table["engine"] == engine) & (table["regime"] == regime)].iloc[0]
                cells.append(_agreement_cell(row[column], row["judged"], row[f"{column}_pct"]))
            lines.append(f"| {escape_cell(regime)} | " + " | ".join(cells) + " |")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


def _agreement_cell(count: int, judged: int, pct: float) -> str:
    return f"{count}/{judged} ({pct:.0f} %)" if judged else "-"


UNDRAWN_COLUMNS = (*COST_COLUMNS, *results.TIMING_COLUMNS)
"""The map rows' columns no map figure draws and no two runs of one map share (what a run
cost, when it finished): left out of :func:`figure_key`, so that a map run again, or a report
of it, copies its figures rather than drawing them anew with a new key in the same pixels."""


def figure_key(frame: pd.DataFrame, name: str) -> str:
    """What a map figure is drawn from, as a sha256: the figure's name, the frame's every
    value but what the run cost and when it ran (:data:`UNDRAWN_COLUMNS`), the drawing code
    (map_figures.py, plotting.py, glyph_cache.py) and matplotlib's version. Two figures of
    one key are the same picture."""
    return figure_keys(frame, [name])[name]


def figure_keys(frame: pd.DataFrame, names: Sequence[str]) -> dict[str, str]:
    """:func:`figure_key` of each name: the frame's values (as CSV: 0.1 CPU-s for a 10 x 10
    map of three engines) and the code read once for them all, not once a figure."""
    import matplotlib

    drawn_from = []
    for module in (map_figures, plotting, glyph_cache):
        try:
            drawn_from.append(Path(str(module.__file__)).read_bytes())
        except OSError:  # code not readable as a file (a zipped install): a key never reused
            drawn_from.append(os.urandom(16))
    drawn = frame.drop(columns=[c for c in UNDRAWN_COLUMNS if c in frame.columns])
    drawn_from.append(drawn.to_csv(index=False).encode())  # floats as repr: every digit
    keys = {}
    for name in names:
        digest = hashlib.sha256(f"{name}\0{matplotlib.__version__}\0".encode())
        for part in drawn_from:
            digest.update(part)
        keys[name] = digest.hexdigest()
    return keys


def drawn_key(folder: Path, name: str) -> str | None:
    """The figure key a PNG of ``folder`` holds (None: no such file, or no key)."""
    from PIL import Image, UnidentifiedImageError

    try:
        path = folder_file(folder, name, MAX_DATA_BYTES)
        if path is None:
            return None
        with Image.open(path) as image:
            key = image.info.get(FIGURE_KEY)
    except (FolderFileError, OSError, UnidentifiedImageError, SyntaxError, ValueError):
        return None  # a figure this report cannot read is drawn again
    return key if isinstance(key, str) else None


def _copy(source: Path, target: Path) -> None:
    shutil.copyfile(source, target)


def write_map_figures(
    frame: pd.DataFrame,
    out: str | Path,
    *,
    prefix: str = "map",
    draw: Draw | None = None,
    drawn_in: Path | None = None,
) -> list[Path]:
    """The map's figures as ``out/<prefix>_<name>.png`` (the per-engine ones only if the
    frame has engine rows), drawn by ``draw(function, *args)`` (default: here, now); their
    paths. A figure already drawn of the same data (figure_key), in ``out`` or as the map
    folder ``drawn_in``'s own (``hoopbench map`` drew it), is kept or copied, not drawn."""
    out = Path(out)
    has_engines = bool(engines_of(frame))
    drawn = [name for name, (_, _, engines) in _FIGURES.items() if has_engines or not engines]
    keys = figure_keys(frame, drawn)
    paths = []
    for name in drawn:
        figure = _FIGURES[name][0]
        path = out / f"{prefix}_{name}.png"
        paths.append(path)
        key = keys[name]
        if drawn_key(out, path.name) == key:
            continue
        if drawn_in is not None and drawn_key(drawn_in, f"map_{name}.png") == key:
            source = drawn_in / f"map_{name}.png"
            out.mkdir(parents=True, exist_ok=True)
            written_whole(path, partial(_copy, source))
            continue
        (draw or draw_now)(figure, frame, path, key)
    return paths


def _section(
    results_dir: Path, out: Path, prefix: str, level: int, draw: Draw | None = None
) -> tuple[str, list[Path]]:
    try:
        spec = load_spec(results_dir)
    except ValueError as exc:  # a folder from elsewhere: say which file is wrong
        raise ValueError(f"{results_dir / MAP_FILE}: {exc}") from None
    frame = map_frame(results_dir)
    h = "#" * level
    # The folder's name and everything read from it are data: escaped, never markup.
    lines = [f"{h} Hop map: {spec.x} x {spec.y} ({escape_text(results_dir.name)})", ""]
    lines += [escape_text(_spec_text(spec)), "", escape_text(_status_text(frame)) + ".", ""]
    if frame.empty:
        return "\n".join([*lines, "No runs stored yet.", ""]), []
    # The figures first: drawn elsewhere (write_map_outputs' processes), they are drawn
    # while the text below is made, not after it.
    figures = write_map_figures(frame, out, prefix=prefix, draw=draw, drawn_in=results_dir)
    table = agreement_table(frame) if engines_of(frame) else None  # made once, read twice
    lines += [f"{h}# Findings", ""]
    lines += [f"- {escape_text(s)}" for s in map_findings(frame, table)]
    lines += ["", f"{h}# Figures", ""]
    for path in figures:
        alt = _FIGURES[path.stem.removeprefix(f"{prefix}_")][1]
        lines += [f"![{alt}]({path.name})", ""]
    lines += [f"{h}# Exact regimes", "", _regime_table(frame), ""]
    if table is not None:
        lines += [f"{h}# Agreement with the exact reference", ""]
        lines += [
            "Per engine and exact regime: judged points (those with an exact answer) whose "
            "outcome agrees, and whose verdict is agrees (the phases too).",
            "",
            agreement_markdown(table),
        ]
    return "\n".join(lines).rstrip() + "\n", figures


def map_section(
    results_dir: str | Path,
    out: str | Path | None = None,
    *,
    prefix: str = "map",
    level: int = 2,
    draw: Draw | None = None,
) -> str:
    """The Markdown of a map folder's section, its figures written to ``out`` (default: the
    folder itself) as ``<prefix>_*.png`` by ``draw`` (write_map_figures). ``level``: the
    heading level of its title."""
    results_dir = Path(results_dir)
    out = results_dir if out is None else Path(out)
    return _section(results_dir, out, prefix, level, draw)[0]


def map_sections(
    results_dirs: Sequence[str | Path], out: str | Path, draw: Draw | None = None
) -> list[str]:
    """The sections of several map folders in one report, figures written to ``out`` with a
    prefix per folder (map, or map1, map2, ... when there are several) by ``draw``."""
    prefixes = map_prefixes(len(results_dirs))
    return [
        map_section(d, out, prefix=p, draw=draw)
        for d, p in zip(results_dirs, prefixes, strict=True)
    ]


def map_prefixes(n: int) -> list[str]:
    """The figure-name prefixes of n map folders in one report: map, or map1, map2, ..."""
    return ["map"] if n == 1 else [f"map{k + 1}" for k in range(n)]


def write_map_outputs(results_dir: str | Path, processes: Executor | None = None) -> list[Path]:
    """After ``hoopbench map``: the figures and ``DIR/map.md`` (the section as a document,
    figures beside it); their paths, map.md last. ``processes``: where the figures are drawn,
    side by side (report-runs --report: the report's drawing processes, started already),
    map.md written once they are; by default here, one after the other."""
    results_dir = Path(results_dir)
    drawing: list[Future[Any]] = []

    def draw(function: Callable[..., Any], *args: Any) -> None:
        assert processes is not None
        drawing.append(processes.submit(function, *args))

    text, figures = _section(
        results_dir, results_dir, "map", 1, None if processes is None else draw
    )
    for future in drawing:
        future.result()

    def write(tmp: Path) -> None:
        tmp.write_text(text, encoding="utf-8")

    path = results.atomic_write(results_dir / MAP_MARKDOWN, write)
    return [*figures, path]
