"""The report's "Across engine releases" section: each engine on each release it ran, and what
changed from one release to the next.

The rows are a suite's runs of an engine on releases other than the installed one
(``[engine_versions]``, ``compare --engine-version``: variant ``release=VERSION``,
compare/releases.py). Releases are compared in version order, run by run (the same scene,
timestep and profile): a change is a verdict that changed, an event whose error moved by more
than its loose tolerance (as the verdict sets it for the newer run: the tolerance table's,
carried to the hoop and timestep, plus the run's detection floor), or a cost per step that
moved by more than the noise of a measured cost (score.COST_NOISE_FACTOR). Each change is
named with the release that made it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path
from typing import Any

import pandas as pd
from packaging.version import InvalidVersion, Version

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.score import COST_NOISE_FACTOR
from hoopbench.engines.judging.tolerances import Tier
from hoopbench.engines.judging.verdict import Event, event_error_ratio, number_or_none
from hoopbench.reports.compare.releases import RELEASE_PREFIX
from hoopbench.reports.report.escaping import escape_cell, escape_text, file_stem
from hoopbench.reports.report.findings import event_error
from hoopbench.reports.report.plotting import pyplot, save

__all__ = [
    "ReleaseChange",
    "is_release_row",
    "release_changes",
    "release_rows",
    "releases_figure",
    "releases_section",
]

_ERROR_COLUMNS = {
    Event.SLIP_ONSET: (Col.ERR_T_SLIP_MS, "ms"),
    Event.LIFT_OFF: (Col.ERR_T_LIFT_MS, "ms"),
    Event.IMPACT: (Col.ERR_T_IMPACT_MS, "ms"),
    Event.HOP_HEIGHT: (Col.ERR_HOP_HEIGHT_REL, ""),
}
"""Each judged event's error column and its unit (hop height: relative, shown in %)."""

_RUN_KEY = [Col.SCENE.value, Col.TIMESTEP.value, Col.PROFILE.value]
"""What makes two releases' rows the same run."""


@dataclass(frozen=True)
class ReleaseChange:
    """One thing that changed between two consecutive releases on one run."""

    engine: str
    before: str
    """The older release."""
    after: str
    """The release that made the change."""
    scene: str
    timestep: float
    """s."""
    profile: str
    what: str
    """'verdict', an Event's name, or 'cost'."""
    text: str
    """The change, old → new, for the report."""


def _release(variant: object) -> str | None:
    if isinstance(variant, str) and variant.startswith(RELEASE_PREFIX):
        return variant[len(RELEASE_PREFIX) :]
    return None


def _version_key(text: str) -> tuple[int, Version | str]:
    try:
        return (0, Version(text))
    except InvalidVersion:
        return (1, text)


def is_release_row(runs: pd.DataFrame) -> pd.Series:
    """Whether each row is a run on a named release (variant ``release=VERSION``)."""
    if Col.VARIANT.value not in runs:
        return pd.Series(False, index=runs.index)
    return runs[Col.VARIANT.value].map(_release).notna()


def release_rows(runs: pd.DataFrame) -> pd.DataFrame:
    """The rows of runs on a named release, with its version in a column ``release``."""
    if runs.empty or Col.VARIANT.value not in runs:
        return runs.iloc[0:0].assign(release=pd.Series(dtype=object))
    releases = runs[Col.VARIANT.value].map(_release)
    return runs[releases.notna()].assign(release=releases[releases.notna()])


def _ordered(rows: pd.DataFrame) -> list[str]:
    return sorted(rows["release"].unique(), key=_version_key)


def _verdict(row: Mapping[str, Any]) -> str:
    verdict = row.get(Col.VERDICT.value)
    return verdict if isinstance(verdict, str) else str(row.get(Col.STATUS.value))


def _event_move(old: Mapping[str, Any], new: Mapping[str, Any], event: Event) -> str | None:
    """The text of an event whose error moved by more than its loose tolerance, else None."""
    column, unit = _ERROR_COLUMNS[event]
    before, after = number_or_none(old.get(column)), number_or_none(new.get(column))
    if before is None or after is None:
        return None
    ratio = event_error_ratio(new, event, Tier.LOOSE)
    if ratio is None or after == 0.0 or ratio == 0.0:
        ratio = event_error_ratio(old, event, Tier.LOOSE)
        size = abs(before)
    else:
        size = abs(after)
    if ratio is None or ratio == 0.0:
        return None
    tolerance = size / ratio
    moved = abs(after - before) / tolerance
    if moved <= 1.0:
        return None
    scale, shown = (100.0, "%") if event is Event.HOP_HEIGHT else (1.0, f" {unit}")
    return (
        f"{event} error {scale * before:+.3g}{shown} → {scale * after:+.3g}{shown} "
        f"({moved:.1f} loose tolerances)"
    )


def _cost_move(old: Mapping[str, Any], new: Mapping[str, Any]) -> str | None:
    """A CPU cost per step that moved by more than the noise: CPU time, not wall time, since
    the wall time of a run grows with the machine's load, which changes within a sweep (on
    the releases suite, 2 cores at load 8-10, wall-time moves of x0.15 to x27 came and went
    between releases whose events were the same to 3 digits)."""
    column = Col.CPU_US_PER_STEP.value
    before, after = number_or_none(old.get(column)), number_or_none(new.get(column))
    if not before or not after or before <= 0 or after <= 0:
        return None
    factor = after / before
    if max(factor, 1 / factor) <= COST_NOISE_FACTOR:
        return None
    return f"CPU cost {before:.3g} → {after:.3g} us/step (x{factor:.2g})"


def _changes_of(engine: str, before: str, after: str, old: Any, new: Any) -> list[ReleaseChange]:
    """What changed on one run from release ``before`` to ``after``."""
    scene, dt, profile = (
        old[Col.SCENE.value],
        float(old[Col.TIMESTEP.value]),
        str(old[Col.PROFILE.value]),
    )

    def change(what: str, text: str) -> ReleaseChange:
        return ReleaseChange(engine, before, after, scene, dt, profile, what, text)

    found: list[ReleaseChange] = []
    if _verdict(old) != _verdict(new):
        found.append(change("verdict", f"verdict {_verdict(old)} → {_verdict(new)}"))
    for event in Event:
        moved = _event_move(old, new, event)
        if moved is not None:
            found.append(change(str(event), moved))
    cost = _cost_move(old, new)
    if cost is not None:
        found.append(change("cost", cost))
    return found


def release_changes(runs: pd.DataFrame) -> list[ReleaseChange]:
    """Every change between consecutive releases of each engine, run by run, in order."""
    rows = release_rows(runs)
    changes: list[ReleaseChange] = []
    for engine, group in rows.groupby(Col.ENGINE.value, sort=True):
        order = _ordered(group)
        for before, after in pairwise(order):
            old = group[group["release"] == before].set_index(_RUN_KEY)
            new = group[group["release"] == after].set_index(_RUN_KEY)
            for key in old.index.intersection(new.index):
                changes += _changes_of(
                    str(engine),
                    before,
                    after,
                    {**old.loc[key].to_dict(), **dict(zip(_RUN_KEY, key, strict=True))},
                    {**new.loc[key].to_dict(), **dict(zip(_RUN_KEY, key, strict=True))},
                )
    return changes


def _cell(row: Mapping[str, Any] | None, changed: bool) -> str:
    if row is None:
        return "not run"
    error = event_error(row)
    text = _verdict(row) if error is None else f"{_verdict(row)}, {error}"
    text = escape_cell(text)
    return f"**{text}**" if changed else text


def _engine_table(engine: str, group: pd.DataFrame, changes: Sequence[ReleaseChange]) -> str:
    order = _ordered(group)
    changed = {
        (c.after, c.scene, c.timestep, c.profile)
        for c in changes
        if c.engine == engine and c.what != "cost"
    }
    headers = ["scene", "dt (s)", "profile", *order]
    lines = ["| " + " | ".join(map(escape_cell, headers)) + " |", "|" + "---|" * len(headers)]
    runs = group.drop_duplicates(_RUN_KEY)[_RUN_KEY].sort_values(_RUN_KEY)
    for _, run in runs.iterrows():
        scene, dt, profile = run[_RUN_KEY[0]], float(run[_RUN_KEY[1]]), str(run[_RUN_KEY[2]])
        cells = []
        for release in order:
            match = group[
                (group["release"] == release)
                & (group[_RUN_KEY[0]] == scene)
                & (group[_RUN_KEY[1]] == dt)
                & (group[_RUN_KEY[2]] == profile)
            ]
            row = None if match.empty else match.iloc[0].to_dict()
            cells.append(_cell(row, (release, scene, dt, profile) in changed))
        lines.append("| " + " | ".join([escape_cell(scene), f"{dt:g}", profile, *cells]) + " |")
    imported = ", ".join(
        f"{r} imported {escape_text(str(v))}"
        for r, v in group.drop_duplicates("release")[["release", Col.ENGINE_VERSION.value]]
        .sort_values("release", key=lambda s: s.map(_version_key))
        .itertuples(index=False)
        if str(v) != r
    )
    note = (
        f"\n\nRows whose imported version is not the release asked: {imported}." if imported else ""
    )
    return "\n".join(lines) + note


def _change_lines(changes: Sequence[ReleaseChange]) -> list[str]:
    if not changes:
        return ["No change between consecutive releases on these runs."]
    return [
        f"- {escape_text(c.engine)} {escape_text(c.after)} (from {escape_text(c.before)}): "
        f"{escape_text(c.scene)} dt {c.timestep:g} s {escape_text(c.profile)}: "
        f"{escape_text(c.text)}"
        for c in changes
    ]


def releases_section(runs: pd.DataFrame, figures: Sequence[Path] = ()) -> str:
    """The section, or "" when no run is on a named release."""
    rows = release_rows(runs)
    if rows.empty:
        return ""
    changes = release_changes(runs)
    parts = [
        "## Across engine releases",
        "",
        "Each engine on each release named by the suite's `[engine_versions]` or "
        "`compare --engine-version` (its own cached install; docs/engines.md, Releases), the "
        "same scenes and settings, releases in version order. A cell is the verdict with the "
        "hop-height or slip-onset error; **bold** where it changed from the release before: a "
        "verdict that changed, or an event whose error moved by more than its loose tolerance. "
        f"The list below adds a CPU cost per step that moved by more than x{COST_NOISE_FACTOR:g} "
        "(the noise of a measured cost).",
        "",
    ]
    for engine, group in rows.groupby(Col.ENGINE.value, sort=True):
        parts += [
            f"### {escape_text(str(engine))}",
            "",
            _engine_table(str(engine), group, changes),
            "",
        ]
    parts += ["### What changed, and the release that made it", "", *_change_lines(changes), ""]
    for path in figures:
        parts += [f"![{escape_text(path.stem)}]({path.name})", ""]
    return "\n".join(parts)


def _figure_event(group: pd.DataFrame) -> tuple[Event, str] | None:
    """The event the figure draws: the slip onset if the runs have it, else the hop height."""
    for event in (Event.SLIP_ONSET, Event.HOP_HEIGHT):
        column = _ERROR_COLUMNS[event][0]
        if column in group and group[column].notna().any():
            return event, column
    return None


def releases_figure(runs: pd.DataFrame, out: Path) -> list[Path]:
    """Per engine, one event's error (slip onset, ms) against release, a line per scene and
    timestep: where a release moved it. Nothing when no run is on a named release."""
    rows = release_rows(runs)
    if rows.empty:
        return []
    plt = pyplot()
    paths: list[Path] = []
    for engine, group in rows.groupby(Col.ENGINE.value, sort=True):
        found = _figure_event(group)
        if found is None:
            continue
        event, column = found
        order = _ordered(group)
        scale, unit = (100.0, "%") if event is Event.HOP_HEIGHT else (1.0, "ms")
        fig, ax = plt.subplots(figsize=(9.5, 4))
        for (scene, dt, profile), runs_of in group.groupby(_RUN_KEY, sort=True):
            values = [
                number_or_none(runs_of[runs_of["release"] == r][column].iloc[0])
                if (runs_of["release"] == r).any()
                else None
                for r in order
            ]
            ys = [math.nan if v is None else scale * v for v in values]
            if all(math.isnan(y) for y in ys):
                continue
            ax.plot(range(len(order)), ys, marker="o", label=f"{scene} dt {dt:g} {profile}")
        ax.set_xticks(range(len(order)), order)
        ax.axhline(0.0, color="0.5", lw=0.8)
        ax.set_xlabel(f"{engine} release")
        ax.set_ylabel(f"{event} error, engine - exact ({unit})")
        ax.set_title(f"{engine}: {event} error against release")
        ax.legend(fontsize=7, loc="center left", bbox_to_anchor=(1.0, 0.5))
        fig.tight_layout()
        paths.append(save(fig, out / f"releases-{file_stem(str(engine))}.png", dpi=110))
    return paths
