"""Writes the Markdown report and its figures from the runs table.

One function per report section: each takes the runs table (with every optional column present,
see :func:`with_optional_columns`) and returns the section's Markdown, ending in a blank line;
the two sections with figures also take the output folder and return the figures' paths.
:func:`write_markdown` joins them. Nothing here changes the caller's frame.
"""

from __future__ import annotations

import math
import multiprocessing
import platform
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from hoopbench.engines.judging.columns import FORCE_COLUMNS
from hoopbench.engines.judging.tolerances import tolerances
from hoopbench.engines.judging.verdict import Verdict
from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.engines.settings import DEFAULT_TIMESTEP
from hoopbench.models.catalogue import get_scene, scene_names
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.compare.selection import (
    default_rows,
    engine_rows,
    profile_of,
    reference_rows,
    run_cost_clock,
)
from hoopbench.reports.compare.suite import ROW_COLUMNS, left_out_text
from hoopbench.reports.compare.suite_file import DEFAULT_VARIANT, STABILITY_SUITE, LeftOut
from hoopbench.reports.report import seed_reproduction
from hoopbench.reports.report.answer import answer
from hoopbench.reports.report.answer_files import write_answer_files
from hoopbench.reports.report.answer_words import answer_section
from hoopbench.reports.report.best_settings import BestSettings
from hoopbench.reports.report.drawing_processes import (
    FIGURE_WORKERS,
    drawing_workers,
    interruptible,
)
from hoopbench.reports.report.drawn import drawn_rows, drawn_trajectories, timestep_note
from hoopbench.reports.report.escaping import escape_cell, escape_text, file_stem
from hoopbench.reports.report.figures import events_figure, hoop_figure, paths_figure
from hoopbench.reports.report.files_section import files_section
from hoopbench.reports.report.findings import (
    KEY_FINDINGS,
    MORE_FINDINGS,
    all_findings_markdown,
    event_error,
    findings,
    findings_markdown,
    off_tuned,
    option_text,
)
from hoopbench.reports.report.force_figures import ForcePanel, force_figure
from hoopbench.reports.report.plotting import plain_text
from hoopbench.reports.report.precision import COST, cheapest_runs, precision_figure
from hoopbench.reports.report.readings import READING_RESOLUTION_MS, reading_differences
from hoopbench.reports.report.releases import (
    is_release_row,
    releases_figure,
    releases_section,
)
from hoopbench.reports.report.stability import (
    ENERGY_GAIN_LIMIT,
    PENETRATION_LIMIT,
    stability_figure,
    stability_matrix,
)
from hoopbench.reports.sweep import results

__all__ = ["Say", "SuiteMachine", "machine_text", "markdown_table", "write_markdown"]

_REPORT_COLUMNS = (*ROW_COLUMNS, "suite")
"""Every column the sections read: a stored run's (runs_frame has them all, an old table
migrated) and its suite's name (report_frame)."""


# --------------------------------------------------------------------------- tables


def _cell(value) -> str:
    """A table cell: numbers formatted, text escaped (it may come from a results folder)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "**no**"
    if isinstance(value, float):
        return f"{value:.4g}"
    return escape_cell(value)


def markdown_table(frame: pd.DataFrame, columns: Sequence[str], headers: Sequence[str]) -> str:
    """A GitHub-flavoured Markdown table of the given columns; headers and text cells escaped
    (a scene name from a results folder can be a header)."""
    lines = ["| " + " | ".join(map(escape_cell, headers)) + " |", "|" + "---|" * len(headers)]
    for _, row in frame.iterrows():
        lines.append("| " + " | ".join(_cell(row.get(c)) for c in columns) + " |")
    return "\n".join(lines)


def _table(frame: pd.DataFrame, headers: Mapping[str, str]) -> str:
    """markdown_table with the columns given as {column: header}."""
    return markdown_table(frame, list(headers), list(headers.values()))


def _section(*lines: str) -> str:
    """Markdown lines joined, ending in a blank line (so that sections join with one)."""
    return "\n".join([*lines, ""])


# --------------------------------------------------------------------------- selections
def with_optional_columns(frame: pd.DataFrame) -> pd.DataFrame:
    """A new frame: ``frame`` plus every report column it lacks (a hand-made frame), empty."""
    return results.with_columns(frame, _REPORT_COLUMNS)


def _default(runs: pd.DataFrame) -> pd.DataFrame:
    return default_rows(runs)


def _hops(runs: pd.DataFrame) -> pd.DataFrame:
    default = _default(runs)
    return default[default["scene"].str.startswith("hop")]


def _versions(frame: pd.DataFrame) -> str:
    parts = []
    for engine, group in frame.groupby("engine", sort=False):
        versions = sorted({v for v in group["engine_version"].dropna()})
        parts.append(f"{engine} {', '.join(map(str, versions)) or '(unavailable)'}")
    return escape_text("; ".join(parts))


# --------------------------------------------------------------------------- sections
def _header() -> str:
    """The title and what the report answers, in two sentences."""
    return _section(
        "# hoopbench report",
        "",
        "Which physics engine, with which settings, gets the hopping hoop's contact events "
        "(slip, lift-off, hop height, impact) right, and at what cost: each engine's runs "
        "against the exact solution of the same scene. Errors are engine minus exact.",
    )


@dataclass(frozen=True)
class SuiteMachine:
    """The machine a results folder's sweep ran on, and its load (its meta.json)."""

    suite: str
    cpu_model: str | None
    cpu_count: int | None
    """Logical cores (``os.cpu_count``)."""
    load_start: tuple[float, ...] | None
    """The load average over 1, 5 and 15 minutes at the sweep's start (None: not recorded,
    a folder stored before issue 34)."""
    load_end: tuple[float, ...] | None
    """The same at its end."""
    left_out: tuple[LeftOut, ...] = ()
    """The runs its suite, sized to the machine, left out for want of a GPU."""


def _load_text(load: tuple[float, ...] | None) -> str:
    return "not recorded" if not load else "/".join(f"{x:g}" for x in load)


def machine_text(machines: Sequence[SuiteMachine]) -> str:
    """'Machine: AMD EPYC, 2 cores. Load average (1/5/15 min) at the start and end of each
    suite: default 10.2/8/6 to 12.1/11/8; ...' (empty without machines)."""
    if not machines:
        return ""
    cpus = dict.fromkeys(
        f"{m.cpu_model or 'CPU model not recorded'}, "
        f"{m.cpu_count if m.cpu_count is not None else '?'} cores"
        for m in machines
    )
    loads = "; ".join(
        f"{m.suite} not recorded"
        if m.load_start is None and m.load_end is None
        else f"{m.suite} {_load_text(m.load_start)} to {_load_text(m.load_end)}"
        for m in machines
    )
    moved = "".join(
        f" In the {m.suite} suite, {left_out_text(m.left_out)}" for m in machines if m.left_out
    )
    return escape_text(
        f"Machine: {', and '.join(cpus)}. Load average (runnable processes over 1/5/15 min, "
        f"all users') at the start and end of each suite: {loads}. The runs' wall times grow "
        f"with the load, their CPU times (cpu_us_per_step) far less.{moved}"
    )


def _platform_section(
    runs: pd.DataFrame, generated: str, machines: Sequence[SuiteMachine] = ()
) -> str:
    """Where and when the report was made, with what, on which machine under what load, and
    how its runs ended."""
    tol = tolerances()
    machine = machine_text(machines)
    return _section(
        "## Platform and runs",
        "",
        f"Generated {generated} on {platform.platform()} ({platform.python_version()}). "
        f"Engines: {_versions(runs)}.",
        *(["", machine] if machine else []),
        "",
        "Every engine event is read off its trajectory and contact force by one reading, "
        "the canonical one (`engines/judging/contact.py`, docs/report.md); every section "
        'but "Where the two readings differ" shows it. The exact events come from the '
        "event-driven reference solver for the same scene with mus = muk = the run's mu. "
        "Errors are engine minus exact. Times in s (errors in ms), angles in degrees, "
        "lengths in m. The verdict's tolerances (`engines/judging/tolerances.toml`, shared "
        "with the Findings and the regression tests), 1 m hoop, plus one timestep and the "
        "row's detection floor: "
        + _tolerance_text(tol["tight"], "tight (agrees)")
        + "; "
        + _tolerance_text(tol["loose"], "loose (close)")
        + ".",
        "",
        f"Runs: {len(runs)}; status counts: "
        + escape_text(", ".join(f"{k} {v}" for k, v in runs["status"].value_counts().items()))
        + ".",
    )


def _tolerance_text(table: dict, name: str) -> str:
    return (
        f"{name}: slip onset {table['t_slip_s'] * 1e3:g} ms, lift-off "
        f"{table['t_lift_s'] * 1e3:g} ms, impact {table['t_impact_s'] * 1e3:g} ms, hop "
        f"height {table['hop_height_rel'] * 100:g} %"
    )


def _settings_section(runs: pd.DataFrame) -> str:
    """How each engine's own knobs move slip onset and hop height, stock against tuned: a
    table per engine (:func:`_knob_table`). Empty when no run changed a setting."""
    at_dt = runs[runs["timestep"] == DEFAULT_TIMESTEP]
    variants = at_dt[at_dt["variant"] != DEFAULT_VARIANT]
    if not len(variants):
        return ""
    parts = [
        f"## Contact settings (dt = {DEFAULT_TIMESTEP:g} s)",
        "",
        "How each engine's own knobs move the slip onset and the hop height. Per engine: its "
        "tuned settings (hoopbench's), its stock ones (the engine's own defaults), then each "
        "knob whose stock value differs from the tuned one, set alone to its stock value on "
        "the tuned settings, and the other settings the engine offers. Errors are engine "
        "minus exact (hop height relative); a verdict other than agrees follows its number, "
        "and stands alone where the run has no such event.",
    ]
    of_engine = dict(iter(at_dt.groupby("engine", sort=False)))  # split once, not per engine
    for engine, rows in variants.groupby("engine", sort=False):
        base = default_rows(of_engine[engine])
        parts += [
            "",
            f"### {escape_text(engine)}",
            "",
            _knob_table(engine, pd.concat([base, rows])),
        ]
    return _section(*parts)


def _knob_table(engine: str, rows: pd.DataFrame) -> str:
    """One engine's settings table: a line per setting (tuned, stock, each knob), a column
    per scene of its variant runs (slip onset where the exact run only slips, hop height
    where it hops), and the cost per step."""
    scenes = list(dict.fromkeys(rows[rows["variant"] != DEFAULT_VARIANT]["scene"]))
    lines = []
    # The rows as mappings once, each setting's by position: a frame and a Series per row
    # of every setting took most of the report's settings section.
    records = rows.to_dict("records")
    settings: dict[tuple[str, str, str], list[int]] = {}
    for k, label in enumerate(_setting_labels(engine, records)):
        settings.setdefault(label, []).append(k)
    cost = rows["us_per_step"]
    for label, at in settings.items():
        by_scene = {records[k]["scene"]: records[k] for k in at}
        line = {"knob": label[0], "tuned": label[1], "run": label[2]}
        line |= {scene: _event_cell(by_scene.get(scene)) for scene in scenes}
        line["cost"] = cost.iloc[at].median()
        lines.append(line)
    lift: dict[str, object] = {}
    for record in records:
        lift.setdefault(record["scene"], record["exact_t_lift"])
    headers = {"knob": "knob", "tuned": "tuned value", "run": "this run"}
    for scene in scenes:
        hops = pd.notna(lift[scene])
        headers[scene] = f"{scene} hop height" if hops else f"{scene} slip onset"
    headers["cost"] = "us/step"
    order = {"(all tuned)": 0, "(all stock)": 1}
    lines.sort(key=lambda line: (order.get(line["knob"], 2), "(stock)" not in line["run"]))
    return _table(pd.DataFrame(lines), headers)


def _setting_labels(engine: str, rows: Sequence[Mapping[str, Any]]) -> list[tuple[str, str, str]]:
    """Per row: (knob, its tuned value, its value in this run), from the run's options off
    the engine's tuned ones (:func:`off_tuned`); '(all tuned)' and '(all stock)' for its
    defaults, the variant's name where the engine is no longer registered."""
    labels = []
    for row in rows:
        if row["variant"] == DEFAULT_VARIANT:
            labels.append(
                (f"(all {row['profile'] if isinstance(row['profile'], str) else 'tuned'})", "", "")
            )
            continue
        off = off_tuned(engine, row)
        if off is None:
            labels.append((str(row["variant"]), "-", "-"))
            continue
        knobs = ", ".join(off) or str(row["variant"])
        before = ", ".join(option_text(tuned) for tuned, _, _ in off.values())
        now = ", ".join(
            option_text(value) + (" (stock)" if is_stock else "")
            for _, value, is_stock in off.values()
        )
        labels.append((knobs, before, now))
    return labels


def _event_cell(row: Mapping[str, Any] | None) -> str:
    """A run's hop-height or slip-onset error (findings.event_error), with its verdict."""
    if row is None:
        return "not run"
    error = event_error(row)
    verdict = row["verdict"] if isinstance(row["verdict"], str) else row["status"]
    if error is None:
        return str(verdict)
    # As the caption says: any verdict but agrees follows the number, a close or a creep too
    # (the number alone reads as a pass where another event failed the run).
    return error if verdict == Verdict.AGREES else f"{error} ({verdict})"


def _timestep_section(runs: pd.DataFrame) -> str:
    default = _default(runs)
    hop_scenes = sorted(n for n in default["scene"].unique() if n.startswith("hop"))
    rows = []
    profile = profile_of(default)
    groups = default.assign(profile=profile).groupby(["engine", "profile", "timestep"], sort=False)
    for (engine, profile, dt), group in groups:
        # Each scene's first run of the group, by position: a filtered frame per scene would
        # take every column of the group, for some 100 groups.
        first: dict[str, int] = {}
        for k, scene in enumerate(group["scene"].tolist()):
            first.setdefault(scene, k)
        seed = first.get("seed-mu")
        row = {
            "engine": engine,
            "profile": profile,
            "timestep": dt,
            "wall": group["wall_time_s"].iloc[seed] if seed is not None else None,
            "slip": group["err_t_slip_ms"].iloc[seed] if seed is not None else None,
            "agree": f"{int((group['outcome_agrees'] == True).sum())}/{len(group)}",  # noqa: E712
        }
        lift = group["err_t_lift_ms"]
        for scene in hop_scenes:
            row[scene] = lift.iloc[first[scene]] if scene in first else None
        rows.append(row)
    table = pd.DataFrame(rows).sort_values(
        ["engine", "profile", "timestep"], ascending=[True, False, False]
    )
    return _section(
        "## Error against timestep and run time (default settings)",
        "",
        "Per engine, profile and timestep: the stepping time of the seed run, the slip-onset "
        "error on seed-mu, the lift-off error on each hop scene (ms; `-` where no lift-off "
        "was detected) and how many scenes end with the exact outcome.",
        "",
        _table(
            table,
            {
                "engine": "engine",
                "profile": "profile",
                "timestep": "dt",
                "wall": "seed wall s",
                "slip": "slip error ms",
                **{s: f"{s} lift error ms" for s in hop_scenes},
                "agree": "exact outcome",
            },
        ),
    )


def _run_time_section(runs: pd.DataFrame, out: Path) -> tuple[str, list[Path]]:
    """Error against run time per event, with the Pareto front and the cheapest runs."""
    figure = precision_figure(runs, out / "error_vs_time.png")
    cheapest = cheapest_runs(runs)
    clock = run_cost_clock(engine_rows(runs))
    columns = ["us_per_step", "cpu_us_per_step", "wall_time_s"]
    rows = engine_rows(runs)
    rows = rows.assign(**{c: pd.to_numeric(rows[c], errors="coerce") for c in columns})
    cost = rows.groupby(["engine", "profile", "timestep"], as_index=False)[columns].median()
    solve = reference_rows(runs).groupby("scene", as_index=False)["wall_time_s"]
    return (
        _section(
            "## Error against run time",
            "",
            f"Each event's |error| against the run's {clock.label} time over its stepping "
            "(the process's CPU time where the runs carry it, which the machine's load moves "
            "far less than the wall time; log axes): one curve per "
            "settings family with its timesteps along it, the Pareto front (no cheaper run is "
            "as accurate: the wide grey band), the target of the table below (dotted), and the "
            "exact reference as a star at its own solve time, on the panel's bottom edge: its "
            'error is zero, which a log axis cannot show ("error 0").',
            "",
            f"![event errors against run time]({figure.name})" if figure else "",
            "",
            "Per event and scene, the cheapest single run within the target (dotted in the "
            "figure). That run alone: it may get other events or scenes wrong, and it may be a "
            "variant; the answer at the top holds a setting to every scene.",
            "",
            _table(
                cheapest,
                {
                    "metric": "event",
                    "scene": "scene",
                    "target": "target",
                    "run": "cheapest run",
                    COST: f"{clock.label} s",
                    "error": "|error|",
                },
            )
            if len(cheapest)
            else "None.",
            "",
            "Cost per engine and timestep (median over the scenes): wall time per step, the "
            "process's CPU time per step (which the machine's load moves far less; empty for "
            "runs stored without it) and wall time per run:",
            "",
            _table(
                cost,
                {
                    "engine": "engine",
                    "profile": "profile",
                    "timestep": "dt",
                    "us_per_step": "us/step",
                    "cpu_us_per_step": "CPU us/step",
                    "wall_time_s": "wall s",
                },
            ),
            "",
            "The exact reference's solve time (event-driven, no timestep), median s per scene:",
            "",
            _table(solve.median(), {"scene": "scene", "wall_time_s": "solve s"}),
        ),
        [figure] if figure else [],
    )


def _exact_summary(row: pd.Series) -> str:
    """The exact events of a scene in one line."""
    parts = [f"exact outcome **{escape_text(row['exact_outcome'])}**"]
    if pd.notna(row.get("exact_t_slip")):
        parts.append(f"slip at {row['exact_t_slip']:.4f} s ({row['exact_theta_slip_deg']:.2f} deg)")
    if pd.notna(row.get("exact_t_lift")):
        parts.append(
            f"lift-off at {row['exact_t_lift']:.4f} s, hop {row['exact_hop_height']:.4g} m"
        )
    if pd.notna(row.get("exact_t_impact")):
        parts.append(f"impact at {row['exact_t_impact']:.4f} s")
    if isinstance(row.get("exact_phases"), str) and row["exact_phases"]:
        parts.append(f"phases {escape_text(row['exact_phases'])}")
    return "; ".join(parts)


def _cost(row: pd.Series) -> str:
    """The reference's solve time; an engine's cost per step."""
    if row["engine"] == REFERENCE_ENGINE:
        return "-" if pd.isna(row["wall_time_s"]) else f"{row['wall_time_s']:.3g} s solve"
    return "-" if pd.isna(row["us_per_step"]) else f"{row['us_per_step']:.3g} us/step"


def _scene_table(rows: pd.DataFrame) -> str:
    """One scene's runs, with the columns of the events its exact solution has."""
    first = rows.iloc[0]
    columns = {"engine": "engine", "profile": "profile", "status": "status"}
    columns |= {"verdict": "verdict"} if rows["verdict"].notna().any() else {}
    columns |= {"outcome": "outcome", "cost": "cost"}
    if pd.notna(first["exact_t_slip"]):
        columns |= {"t_slip": "t_slip s", "err_t_slip_ms": "error ms"}
        columns |= {"err_theta_slip_deg": "angle error deg"}
    if pd.notna(first["exact_t_lift"]):
        columns |= {"t_lift": "t_lift s", "err_t_lift_ms": "error ms ", "hop_height": "hop m"}
        columns |= {"err_hop_height_rel": "hop rel. error"}
    if pd.notna(first["exact_t_impact"]):
        columns |= {"err_t_impact_ms": "impact error ms"}
    columns |= {"phases": "phases"}
    return _table(rows.assign(cost=[_cost(r) for _, r in rows.iterrows()]), columns)


def _scenes_section(runs: pd.DataFrame) -> str:
    """Per scene, every engine and profile at the default timestep, default settings."""
    default = _default(runs)
    default = default[default["timestep"] == DEFAULT_TIMESTEP]
    parts = [
        "## Events per scene",
        "",
        f"Default settings, dt = {DEFAULT_TIMESTEP:g} s; errors are engine minus exact. A "
        "scene's table has the columns of the events its exact solution has: no hop columns "
        "where it does not hop, no impact error where there is no impact.",
    ]
    for scene, rows in default.groupby("scene", sort=False):
        parts += ["", f"### {escape_text(scene)}", "", _exact_summary(rows.iloc[0]) + ".", ""]
        parts.append(_scene_table(rows))
    return _section(*parts)


FORCE_SCENES = ("seed-mu", "hop-top")
"""The scenes of the contact-force figure: a slip that re-sticks, and a hop."""

_FORCE_HEADERS = {
    "force_rms_n_g": "RMS n/g",
    "force_rms_f_g": "RMS f/g",
    "cone_violation": "cone violation /g",
    "dissipation_violation": "friction not opposing",
    "max_penetration_in_contact_m": "penetration in contact m",
    "energy_change_before_slip": "energy change before slip",
}


def _force_table(runs: pd.DataFrame) -> pd.DataFrame:
    """Per engine and profile, the median of each force column over the default-variant runs
    at the default timestep (scenes whose value is empty left out), and the runs counted."""
    default = _default(runs)
    default = default[default["timestep"] == DEFAULT_TIMESTEP]
    default = default.assign(profile=profile_of(default))
    rows = []
    for (engine, profile), group in default.groupby(["engine", "profile"], sort=False):
        columns = group[list(FORCE_COLUMNS)].apply(pd.to_numeric, errors="coerce")
        rows.append({"engine": engine, "profile": profile, "runs": len(group), **columns.median()})
    return pd.DataFrame(rows)


def force_panels(runs: pd.DataFrame) -> list[ForcePanel]:
    """The figure's scenes that have stored trajectories (and are in the catalogue)."""
    panels = []
    for name in FORCE_SCENES:
        trajectories = stored_trajectories(runs, name)
        trajectories.pop(REFERENCE_ENGINE, None)  # the exact curve is drawn anyway
        rows = runs[runs["scene"] == name]
        if not trajectories or name not in scene_names() or rows.empty:
            continue
        scene = get_scene(name)
        mu = pd.to_numeric(rows["mu"], errors="coerce").dropna()
        drawn = drawn_rows(runs, name)
        other = drawn[drawn["timestep"] != DEFAULT_TIMESTEP]
        timesteps = dict(zip(other["engine"], other["timestep"].astype(float), strict=True))
        mu_drawn = float(mu.iloc[0]) if len(mu) else scene.mus
        panels.append(ForcePanel(name, scene, mu_drawn, trajectories, timesteps))
    return panels


def _readings_section(runs: pd.DataFrame) -> str:
    """Where the kinematic and the canonical reading of a default-settings run differ: the
    one section that shows the ``kin_*`` columns."""
    table = reading_differences(runs)
    title = "## Where the two readings differ"
    if table.empty:
        return _section(title, "", "Every default-settings run reads the same by both.")
    return _section(
        title,
        "",
        f"Default settings, dt = {DEFAULT_TIMESTEP:g} s: each event whose error (engine minus "
        f"exact) differs by more than {READING_RESOLUTION_MS:g} ms between the reading by the "
        "clearance and slip velocity (the `kin_*` columns) and the canonical reading by the "
        "contact force, or that one reading has and the other not, and each run whose phase "
        "codes differ. Every other section, and the verdict, read the canonical reading "
        '(docs/report.md, "The canonical reading").',
        "",
        _table(
            table,
            {
                "scene": "scene",
                "engine": "engine",
                "profile": "profile",
                "event": "event",
                "kinematic": "by the clearance (kin_)",
                "contact": "canonical (contact force)",
            },
        ),
    )


def _force_section(runs: pd.DataFrame, out: Path) -> tuple[str, list[Path]]:
    """Contact forces against the exact solution: the force columns' medians per engine and
    profile, and the figure of n/g and |f|/(mu n) on seed-mu and hop-top. Empty when no run
    has a force column (an older table, or only map rows)."""
    table = _force_table(runs)
    if table.empty or table[list(FORCE_COLUMNS)].isna().all().all():
        return "", []
    panels = force_panels(runs)
    figure = force_figure(panels, out / "contact_forces.png") if panels else None
    lines = [
        "## Contact forces against the exact solution",
        "",
        f"Default settings, dt = {DEFAULT_TIMESTEP:g} s: per engine and profile, the median over "
        "its scenes of each run's contact force against the exact one (docs/report.md, "
        '"The contact force against the exact solution"). RMS over the exact contact phases up to '
        "where the engine's phases first depart from the exact ones, 5 ms left out around "
        "each phase boundary; the cone violation is the largest (|f| - mu n)/g (0: inside the "
        "Coulomb cone); the next column the share of slipping samples whose friction does not "
        "oppose the slip; the energy change is relative, from t = 0 to the exact slip onset "
        "(rolling conserves energy). The reference's row is the floor (0).",
        "",
        _table(table, {"engine": "engine", "profile": "profile", "runs": "runs", **_FORCE_HEADERS}),
    ]
    if figure is not None:
        lines += [
            "",
            f"![contact forces]({figure.name})",
            "",
            "Tuned, default settings, "
            + timestep_note(pd.concat([drawn_rows(runs, p.name) for p in panels]))
            + ": n/g (top) and |f|/(mu n) (bottom) of every engine with a stored trajectory "
            "over the exact curves (dashed). Look for where a curve leaves the dashed one: spikes "
            "and gaps (n = 0 while the exact hoop rolls or slips) are a contact that chatters, "
            "|f|/(mu n) above 1 is friction outside the cone, and below 1 while the exact "
            "one is on 1 a slip the engine sticks through.",
        ]
    return _section(*lines), [figure] if figure else []


def _stability_section(runs: pd.DataFrame) -> str:
    bad = runs[
        (runs["status"] != "ok")
        | (runs["outcome_agrees"] == False)  # noqa: E712 - NaN rows must not match
        | (runs["max_penetration_m"] > 1e-3 * runs["a"].fillna(1.0))
    ]
    table = _table(
        bad,
        {
            "scene": "scene",
            "engine": "engine",
            "variant": "settings",
            "timestep": "dt",
            "status": "status",
            "message": "message",
            "outcome": "outcome",
            "exact_outcome": "exact outcome",
            "max_penetration_m": "max penetration m",
            "energy_rise_before_slip": "energy rise",
        },
    )
    return _section(
        "## Stability",
        "",
        "Runs that did not finish cleanly, or whose detected outcome differs from the exact "
        "one, or that penetrated the floor by more than 0.1 % of the hoop radius (1 mm on the "
        "catalogue's 1 m hoop):",
        "",
        table if len(bad) else "None.",
    )


def _findings_section(runs: pd.DataFrame, every: Sequence[str]) -> str:
    """The scoreboard and the key findings (``every``: ``findings(runs)``), plain sentences
    generated from the numbers below (reports/report/findings.py); the rest in
    :func:`_all_findings_section`."""
    text = findings_markdown(runs, every=every)
    return _section("## Scoreboard and findings", "", text) if text else ""


def _all_findings_section(runs: pd.DataFrame, every: Sequence[str]) -> str:
    """Every finding (``every``: ``findings(runs)``; the page folds this section)."""
    text = all_findings_markdown(runs, every)
    return _section(f"## {MORE_FINDINGS}", "", text) if len(every) > KEY_FINDINGS else ""


def _answer_section(
    runs: pd.DataFrame,
    searches: Sequence[BestSettings],
    out: Path,
    machines: Sequence[SuiteMachine] = (),
) -> str:
    """The answer (reports/report/answer.py) of the comparison suites' rows and the shipped
    searches, in words and as a table, with the comparison suites' runs left out for want
    of a GPU (``machines``); the same rows as answer.csv and answer.json in ``out``
    (reports/report/answer_files.py)."""
    result = answer(runs, searches)
    write_answer_files(result, out)
    return answer_section(result, left_out=answer_left_out(machines))


def answer_left_out(machines: Sequence[SuiteMachine]) -> list[tuple[str, LeftOut]]:
    """The runs the answer's suites (all but the stability suite, which it does not read)
    left out for want of a GPU, with their suite's name."""
    return [(m.suite, item) for m in machines if m.suite != STABILITY_SUITE for item in m.left_out]


def _seed_section(out: Path) -> tuple[str, list[Path]]:
    """The seed's printed numbers beside the exact reference and the seed scheme."""
    figure = seed_reproduction.delta_figure(out / "seed_delta.png")
    onset = seed_reproduction.onset_table()
    steps = seed_reproduction.timestep_table()
    deltas = seed_reproduction.delta_table()

    def table(frame: pd.DataFrame) -> str:
        return markdown_table(frame, list(frame.columns), list(frame.columns))

    text = _section(
        "## Seed reproduction",
        "",
        "The seed scene (lam 0.95, eps 0.01, chi 0.1, mus 0.8, muk 0.7): its printed slip "
        "onset beside the exact solver, which finds a slip and a return to rolling but no "
        "lift-off:",
        "",
        table(onset),
        "",
        "The seed's improved-Euler scheme as this port runs it, against the seed's printed "
        "tables (delta = 1e-4 m; then dt = 2 ms):",
        "",
        table(steps),
        "",
        table(deltas),
        "",
        "Its hop height follows the contact tolerance delta, not the physics:",
        "",
        f"![hop height against delta]({figure.name})",
    )
    return text, [figure]


def _stability_matrix_section(runs: pd.DataFrame, out: Path) -> tuple[str, list[Path]]:
    """The stability suite's matrix: each engine x scene x timestep cell classified."""
    if runs.empty:
        return "", []
    table = stability_matrix(runs)
    figure = stability_figure(runs, out / "stability.png")
    header = "| scene | engine | " + " | ".join(_cell(f"dt {dt:g}") for dt in table.columns) + " |"
    rule = "|---|---|" + "---|" * len(table.columns)
    rows = [
        f"| {escape_cell(scene)} | {escape_cell(engine)} | "
        + " | ".join(_cell(v) for v in cells)
        + " |"
        for (scene, engine), cells in zip(table.index, table.to_numpy(), strict=True)
    ]
    text = _section(
        "## Stability matrix (stiff and extreme scenes)",
        "",
        f"Each cell is the worst of: diverged (NaN, or stopped by the divergence check), "
        f"energy gain (over {100 * ENERGY_GAIN_LIMIT:g} % before the first slip), deep "
        f"penetration (over {100 * PENETRATION_LIMIT:g} % of the radius), wrong outcome "
        "(against the exact reference), timeout, crashed; ok otherwise. Default settings. "
        "The figure: a panel per scene, its timesteps (s) along the top, coarse to fine, the "
        "engines down the side; a blank cell: that engine did not run at that timestep.",
        "",
        f"![stability matrix]({figure.name})" if figure else "",
        "",
        "\n".join([header, rule, *rows]),
    )
    return text, [figure] if figure else []


def stored_trajectories(runs: pd.DataFrame, scene_name: str) -> dict[str, Trajectory]:
    """The recorded tuned default-settings trajectories of one scene, one per engine that
    ran it: at the default timestep, else at its finest stored one (drawn.drawn_rows)."""
    return drawn_trajectories(runs, scene_name)


def _event_window(row: pd.Series) -> tuple[float, float] | None:
    """Around the exact lift-off and impact of a hop, else around the slip onset."""
    lift, impact, slip = row["exact_t_lift"], row["exact_t_impact"], row["exact_t_slip"]
    if pd.notna(lift) and pd.notna(impact):
        span = impact - lift
        return (lift - span, impact + span)
    if pd.notna(slip):
        return (slip - 0.1, slip + 0.3)
    return None


def _trajectory_figures(runs: pd.DataFrame, scene_name: str, out: Path) -> list[Path]:
    """The paths figure and the events figure of one scene, if its trajectories were kept."""
    trajectories = stored_trajectories(runs, scene_name)
    if not trajectories:
        return []
    row = runs[runs["scene"] == scene_name].iloc[0]
    # The name comes from the results folder: a file name from it must stay in ``out``.
    stem = file_stem(scene_name)
    note = timestep_note(drawn_rows(runs, scene_name))
    events = events_figure(
        trajectories,
        out / f"events_{stem}.png",
        title=f"{scene_name}: clearance and slip velocity around its events\n{note}",
        t_window=_event_window(row),
    )
    scene = get_scene(scene_name) if scene_name in scene_names() else None
    if scene is None:
        return [events]
    paths = paths_figure(scene, trajectories, out / f"paths_{stem}.png", note=note)
    return [paths, events]


def _exact_path_figure(scene_name: str, out: Path) -> list[Path]:
    """The exact path of a catalogue scene (hoop_<scene>.png)."""
    return [hoop_figure(get_scene(scene_name), out / f"hoop_{file_stem(scene_name)}.png")]


def _figure_jobs(runs: pd.DataFrame, out: Path) -> list[tuple[Callable, tuple]]:
    """The figure calls of the Trajectories section, each returning its list of paths: per
    scene with kept trajectories, every engine's path over the reference's and its clearance
    and slip velocity around the events; the exact paths of the hop scenes and the seed."""
    jobs: list[tuple[Callable, tuple]] = [
        (_trajectory_figures, (runs, name, out)) for name in dict.fromkeys(runs["scene"])
    ]
    exact = [name for name in [*_hops(runs)["scene"].unique(), "seed"] if name in scene_names()]
    return jobs + [(_exact_path_figure, (name, out)) for name in exact]


def _figures_section(figures: Sequence[Path]) -> str:
    """Trajectories: the figures of :func:`_figure_jobs`, in order."""
    lines = [
        "## Trajectories",
        "",
        f"Default settings, tuned, every engine that ran the scene with its trajectory stored "
        f"(`--trajectories default`): at dt = {DEFAULT_TIMESTEP:g} s, or where an engine has "
        "no run stored there at its finest stored timestep, which each figure's title "
        "names.",
        "",
    ]
    for figure in figures:
        alt = escape_text(figure.stem)
        if alt.startswith("hoop_"):
            alt = f"{alt.removeprefix('hoop_')}: the exact path"
        lines += [f"![{alt}]({figure.name})", ""]
    return _section(*lines)


_Job = tuple[Callable[..., Any], tuple[Any, ...]]
"""A figure-drawing call: the function and its arguments."""


Say = Callable[[str], None]
"""Where the report says what it is doing: a line a step (the command line: stderr)."""

_JOB_NAMES = {
    "_run_time_section": "event errors against run time",
    "_seed_section": "seed reproduction",
    "_stability_matrix_section": "stability matrix",
    "_force_section": "contact forces",
    "_trajectory_figures": "paths and events of {}",
    "_exact_path_figure": "exact path of {}",
}
"""What each figure-drawing call draws, for the progress lines (its scene, if it takes one)."""


def _job_name(job: _Job) -> str:
    function, args = job
    name = _JOB_NAMES.get(function.__name__, function.__name__.strip("_").replace("_", " "))
    scene = next((arg for arg in args if isinstance(arg, str)), "")
    return name.format(scene)


DRAWING_MODULES = (
    "matplotlib.pyplot",
    "matplotlib.backends.backend_agg",
    "pyarrow.parquet",
    "PIL.Image",
    "PIL.PngImagePlugin",
    "PIL.GifImagePlugin",
)
"""What every drawing process imports (besides the report's own modules): its fork server
imports them once for all of them (:class:`FigurePool`)."""


class FigurePool:
    """Drawing calls run beside the caller's own work (the report's tables): drawing is most
    of a report's time and one process draws on one core. The calls run in ``workers``
    processes from a fork server (not forked from here: the report has read Parquet with
    Arrow's threads, which a fork would copy mid-flight), started at the first call; with
    fewer than 2 (one core, or too few calls to gain from it) each call is drawn here when
    it is submitted. Measured on a 3-engine default report: 20.0 s drawn here, 12.8 s so.
    Each worker holds its own matplotlib and pandas (under 500 MB on make report's results,
    the GIF's frames included; the report's own process then peaks at about 400 MB, not
    590).

    The fork server imports this module, DRAWING_MODULES and ``preload`` (the caller's
    modules: those its drawing calls' modules import) once, started when the pool is
    entered so that it imports them while the caller works: each worker then starts with
    them, where it imported them itself (about 2 CPU-s a worker; Python 3.11's fork server
    does not import the caller's ``__main__`` either, so each worker also ran the command
    line's script anew). Effective only if this process's fork server is not running yet
    (a sweep's WorkerPool starts it with its own modules); ``processes`` started already
    (drawing_processes.StartedDrawing, make report's) start nothing more."""

    def __init__(
        self,
        workers: int = FIGURE_WORKERS,
        processes: ProcessPoolExecutor | None = None,
        *,
        preload: Sequence[str] = (),
    ) -> None:
        self.workers = drawing_workers(workers)
        self._preload = [__name__, *DRAWING_MODULES, *preload]
        self._pool: ProcessPoolExecutor | None = processes if self.workers >= 2 else None
        """``processes``: started already (drawing_processes.StartedDrawing), shut down with
        this pool."""
        if processes is not None and self._pool is None:
            processes.shutdown(wait=True, cancel_futures=True)
        self._started: dict[tuple[Any, ...], tuple[tuple[Any, ...], Future]] = {}

    def __enter__(self) -> FigurePool:
        if self.workers >= 2 and self._pool is None:
            self._start_server()
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True, cancel_futures=True)

    def _start_server(self) -> None:
        """The fork server started (it returns at once; the server imports on its own)."""
        from multiprocessing import forkserver

        multiprocessing.get_context("forkserver").set_forkserver_preload(self._preload)
        forkserver.ensure_running()

    def submit(self, function: Callable[..., Any], *args: Any) -> Future:
        """The call's future: its result once drawn (its text drawn as written). A call
        submitted before (the same function with the same argument objects, which drawing
        never changes) is not drawn again: its future is returned. The page's figures are
        started right after report.md's (build.py) and write_page asks for them again."""
        key = (function, *map(id, args))
        if key not in self._started:  # the arguments are kept with it: their ids stay theirs
            self._started[key] = (args, self._submit(function, *args))
        return self._started[key][1]

    def _submit(self, function: Callable[..., Any], *args: Any) -> Future:
        if self.workers < 2:
            future: Future = Future()
            try:
                future.set_result(_draw_plain(function, *args))
            except Exception as exc:  # raised where its result is asked for, as a worker's
                future.set_exception(exc)
            return future
        if self._pool is None:
            self._start_server()
            context = multiprocessing.get_context("forkserver")
            self._pool = ProcessPoolExecutor(max_workers=self.workers, mp_context=context)
        return self._pool.submit(_draw_plain, function, *args)


DRAWING_CPU_S = {
    "write_gif": 7.5,
    "_run_time_section": 2.4,
    "map_fragment": 2.1,
    "_force_section": 1.9,
    "_trajectory_figures": 1.4,
    "_seed_section": 1.2,
    "_stability_matrix_section": 0.8,
    "_figure_html:precision_page_figure": 0.7,
    "regime_figure": 0.55,
    "_exact_path_figure": 0.45,
    "_figure_html:_force_figure": 0.45,
    "hop_error_figure": 0.35,
    "verdict_figure": 0.3,
    "_figure": 0.3,
    "_animation_html": 0.27,
    "_figure_html:stability_page_figure": 0.08,
    "_figure_html:best_settings_page_figure": 0.02,
}
"""A drawing call's CPU time, s, by its function's name (a page figure's by the function
that makes it, its first argument that is a function): measured in each drawing process of
a report of `make report`'s results (3 suites, the map, 9 searches; 2026-11-29, 2 cores
under load). Only their order matters (:func:`dearest_first`)."""
_UNMEASURED_CPU_S = 1.0


def _expected_cpu_s(job: _Job) -> float:
    function, args = job
    make = next((arg for arg in args if callable(arg)), None)
    named = f"{function.__name__}:{getattr(make, '__name__', '')}"
    return DRAWING_CPU_S.get(named, DRAWING_CPU_S.get(function.__name__, _UNMEASURED_CPU_S))


def dearest_first(jobs: Sequence[_Job]) -> list[int]:
    """The positions of ``jobs``, the dearest (DRAWING_CPU_S) first, ties in their order:
    the longest call started first, two processes end their share at about the same time
    (a dear call started last would leave the other process idle while it runs)."""
    cost = [_expected_cpu_s(job) for job in jobs]
    return sorted(range(len(jobs)), key=lambda k: -cost[k])


def _submitted(jobs: Sequence[_Job], pool: FigurePool, say: Say | None) -> list[Future]:
    """The futures of ``jobs``, in their order, submitted dearest first (:func:`dearest_first`)."""
    if say is not None:
        say(f"drawing {len(jobs)} figure groups in {pool.workers} process(es)")
    futures: dict[int, Future] = {}
    for k in dearest_first(jobs):
        function, args = jobs[k]
        futures[k] = pool.submit(function, *args)
    return [futures[k] for k in range(len(jobs))]


def _gathered(jobs: Sequence[_Job], futures: Sequence[Future], say: Say | None) -> list[Any]:
    """The results of the submitted calls, in order; ``say`` hears of each call as it ends
    ("figures 3/14: contact forces")."""
    names = {future: _job_name(job) for job, future in zip(jobs, futures, strict=True)}
    for k, future in enumerate(as_completed(futures), start=1):
        if say is not None:
            say(f"figures {k}/{len(jobs)}: {names[future]}")
    return [future.result() for future in futures]


def _drawn(jobs: Sequence[_Job], say: Say | None = None) -> list[Any]:
    """The results of independent figure-drawing calls, in order, drawn side by side in a
    FigurePool of their own (here when there is one call)."""
    with FigurePool(min(FIGURE_WORKERS, len(jobs))) as pool:
        return _gathered(jobs, _submitted(jobs, pool, say), say)


def _draw_plain(function: Callable[..., Any], *args: Any) -> Any:
    """One drawing call with its text drawn as written (plotting.plain_text): a worker
    process does not inherit the caller's matplotlib settings), and Ctrl-C interrupts it
    (drawing_processes.interruptible: in a process started ahead too)."""
    with plain_text(), interruptible():
        return function(*args)


# --------------------------------------------------------------------------- the report
def _tables(
    runs: pd.DataFrame,
    everything: pd.DataFrame,
    searches: Sequence[BestSettings],
    out: Path,
    machines: Sequence[SuiteMachine] = (),
) -> dict[str, str]:
    """The sections of report.md without figures, by name (those of the comparison suites'
    runs only where there are some)."""
    every = findings(everything)  # seconds of work: made once, for both sections
    tables = {
        "answer": _answer_section(runs, searches, out, machines),
        "findings": _findings_section(everything, every),
        "all findings": _all_findings_section(everything, every),
    }
    if not runs.empty:
        tables |= {
            "scenes": _scenes_section(runs),
            "readings": _readings_section(runs),
            "settings": _settings_section(runs),
            "timestep": _timestep_section(runs),
            "stability": _stability_section(runs),
        }
    return tables


def write_markdown(
    frame: pd.DataFrame,
    out: Path,
    *,
    generated: str,
    extra: Sequence[str] = (),
    searches: Sequence[BestSettings] = (),
    machines: Sequence[SuiteMachine] = (),
    results_dirs: Sequence[Path] = (),
    say: Say | None = None,
    pool: FigurePool | None = None,
    awaited: Sequence[Future] = (),
    then: Sequence[_Job] = (),
) -> Path:
    """Write out/report.md with tables and PNG figures; return its path. ``frame`` is unchanged.
    ``machines``: the machine and load of each results folder's sweep (Platform and runs).

    ``extra``: finished sections of other results (the hop maps', the Best settings), placed
    before the Files section; with an empty ``frame`` the report holds its title and those alone.
    ``searches``: the shipped searches, whose settings the answer weighs too.
    ``results_dirs``: the folders the report reads, listed in its Files section with what
    ``out`` holds once the figures are drawn. ``say`` hears what it is doing, a line a step
    (:data:`Say`). ``pool``: where the figures are drawn, beside the tables (default: a
    FigurePool of their own); ``awaited``: other drawings of the report (its GIF, the maps'
    and the searches' figures, submitted by their makers) to finish before the Files section
    lists the folder; ``then``: drawings report.md does not wait for (the page's figures),
    started after all of its own, dearest first (asked for again, ``pool`` returns their
    futures).
    """
    if pool is None:
        with FigurePool() as own:
            return write_markdown(
                frame, out, generated=generated, extra=extra, searches=searches,
                machines=machines, results_dirs=results_dirs, say=say, pool=own,
                awaited=awaited, then=then,
            )  # fmt: skip
    out = Path(out)
    if frame.empty:  # hop maps alone: no runs table to make sections of
        when = f"Generated {generated} on {platform.platform()}."
        text = "\n".join([_section("# hoopbench report", "", when), *extra])
        _submitted(then, pool, None)
        for future in awaited:
            future.result()
        return results.atomic_write(out / "report.md", lambda tmp: tmp.write_text(text))
    everything = with_optional_columns(frame)
    # Runs on other engine releases (compare --engine-version) have their own section; every
    # other section is of the installed releases' runs.
    on_releases = is_release_row(everything)
    whole, releases_runs = everything, everything[on_releases]
    everything = everything[~on_releases]
    # The stability suite's stiff and extreme scenes have a section of their own; the event
    # tables and agreement counts are the comparison suites' alone.
    is_stability = everything["suite"] == STABILITY_SUITE
    runs = everything[~is_stability]
    # The figures first, side by side (_drawn), the dearest calls leading for an even split.
    # A report of the stability suite alone has no event tables and no run-time section.
    head = [] if runs.empty else [(_run_time_section, (runs, out))]
    tail = [] if runs.empty else _figure_jobs(runs, out)
    both: list[_Job] = [
        (_seed_section, (out,)),
        (_stability_matrix_section, (everything[is_stability], out)),
        (_force_section, (runs, out)),
    ]
    # The engines' releases (compare --engine-version): their own section, figure included.
    releases = [(releases_figure, (releases_runs, out))] if len(releases_runs) else []
    jobs = [*head, *both, *releases, *tail]
    # report.md's own drawings, the dearest first; the page's after them.
    futures = _submitted(jobs, pool, say)
    _submitted(then, pool, None)
    # The tables while the figures are drawn: the tables need none of them.
    if say is not None:
        say("tables: the answer, the findings and the sections of report.md")
    tables = _tables(runs, everything, searches, out, machines)
    drawn = _gathered(jobs, futures, say)
    for future in awaited:
        future.result()
    (seed, _), (stability, _), (forces, _) = drawn[len(head) : len(head) + 3]
    released = drawn[len(head) + 3] if releases else []
    sections = [_header(), tables["answer"], tables["findings"], seed]
    figures = ""
    if not runs.empty:
        run_time, _ = drawn[0]
        trajectories = drawn[len(head) + 3 + len(releases) :]
        figures = _figures_section([path for paths in trajectories for path in paths])
        sections += [tables["scenes"], tables["readings"], forces, tables["settings"]]
        sections += [tables["timestep"], run_time, tables["stability"]]
    sections += [
        stability,
        figures,
        releases_section(releases_runs, released),
        *extra,
        tables["all findings"],
        _platform_section(whole, generated, machines),
        files_section(out, results_dirs),
    ]
    text = "\n".join(section for section in sections if section)
    # Whole or not at all: a full disk keeps the report.md before (--force) as it was.
    return results.atomic_write(out / "report.md", lambda tmp: tmp.write_text(text))
