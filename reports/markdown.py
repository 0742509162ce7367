"""Writes the Markdown report and its figures from the runs table."""

from __future__ import annotations

import math
import platform
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from hoopbench.models.catalogue import get_scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.figures import clearance_figure, error_vs_time_figure, hoop_figure
from hoopbench.reports.tolerances import tolerances

__all__ = ["markdown_table", "write_markdown"]


def _cell(value) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "**no**"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def markdown_table(frame: pd.DataFrame, columns: Sequence[str], headers: Sequence[str]) -> str:
    """A GitHub-flavoured Markdown table of the given columns."""
    lines = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    for _, row in frame.iterrows():
        lines.append("| " + " | ".join(_cell(row.get(c)) for c in columns) + " |")
    return "\n".join(lines)


def _versions(frame: pd.DataFrame) -> str:
    parts = []
    for engine, group in frame.groupby("engine", sort=False):
        versions = sorted({v for v in group["engine_version"].dropna()})
        parts.append(f"{engine} {', '.join(versions) or '(unavailable)'}")
    return "; ".join(parts)


def _col(frame: pd.DataFrame, name: str) -> pd.Series:
    return frame[name] if name in frame else pd.Series([None] * len(frame), index=frame.index)


def _phase_table(runs: pd.DataFrame) -> str:
    engines = list(dict.fromkeys(runs["engine"]))
    rows = []
    for scene, group in runs.groupby("scene", sort=False):
        row = {"scene": scene, "exact": group["exact_phases"].iloc[0]}
        for engine in engines:
            hit = group[group["engine"] == engine]
            if len(hit) and isinstance(hit["phases"].iloc[0], str):
                code = hit["phases"].iloc[0]
                row[engine] = code if hit["phases_agree"].iloc[0] else f"**{code}**"
        rows.append(row)
    table = pd.DataFrame(rows)
    return markdown_table(table, ["scene", "exact", *engines], ["scene", "exact", *engines]) + (
        "\n\nBold: differs from the exact sequence."
    )


def _accuracy_table(default: pd.DataFrame) -> str:
    hop_scenes = sorted(n for n in default["scene"].unique() if n.startswith("hop"))
    rows = []
    for (engine, dt), group in default.groupby(["engine", "timestep"], sort=False):
        seed = group[group["scene"] == "seed-mu"]
        row = {
            "engine": engine,
            "timestep": dt,
            "wall": seed["wall_time_s"].iloc[0] if len(seed) else None,
            "slip": seed["err_t_slip_ms"].iloc[0] if len(seed) else None,
            "agree": f"{int((group['outcome_agrees'] == True).sum())}/{len(group)}",  # noqa: E712
        }
        for scene in hop_scenes:
            hit = group[group["scene"] == scene]
            row[scene] = hit["err_t_lift_ms"].iloc[0] if len(hit) else None
        rows.append(row)
    table = pd.DataFrame(rows).sort_values(["engine", "timestep"], ascending=[True, False])
    return markdown_table(
        table,
        ["engine", "timestep", "wall", "slip", *hop_scenes, "agree"],
        [
            "engine",
            "dt",
            "seed wall s",
            "slip error ms",
            *[f"{s} lift error ms" for s in hop_scenes],
            "exact outcome",
        ],
    )


def write_markdown(frame: pd.DataFrame, out: Path, *, generated: str) -> Path:
    """Write out/report.md with tables and PNG figures; return its path."""
    out = Path(out)
    tol = tolerances()
    for name in (
        "err_t_slip_ms",
        "err_theta_slip_deg",
        "err_t_lift_ms",
        "err_t_impact_ms",
        "err_hop_height_rel",
        "outcome",
        "t_slip_threshold",
        "max_penetration_m",
        "energy_rise_before_slip",
        "outcome_agrees",
        "hop_height",
        "phases",
        "phases_agree",
        "exact_phases",
    ):
        frame[name] = _col(frame, name)
    default = frame[frame["variant"] == "default"]
    md = [
        "# hoopbench report",
        "",
        f"Generated {generated} on {platform.platform()} ({platform.python_version()}). "
        f"Engines: {_versions(frame)}.",
        "",
        "Every engine event is read off its trajectory by the same detectors "
        "(`engines/detectors.py`); the exact events come from the event-driven reference "
        "solver for the same scene with mus = muk = the run's mu. Errors are engine minus "
        "exact. Times in s (errors in ms), angles in degrees, lengths in m. "
        f"Tolerances of the regression tests: slip {tol['slip']['t_s'] * 1e3:g} ms and "
        f"{tol['slip']['theta_deg']:g} deg.",
        "",
        f"Runs: {len(frame)}; status counts: "
        + ", ".join(f"{k} {v}" for k, v in frame["status"].value_counts().items())
        + ".",
        "",
    ]

    md += ["## Slip onset (seed scene, mu = 0.8, default settings)", ""]
    seed = default[default["scene"] == "seed-mu"].copy()
    seed["lag_ms"] = (seed["t_slip_threshold"] - seed["exact_t_slip"]) * 1e3
    md.append(
        markdown_table(
            seed,
            [
                "engine",
                "timestep",
                "status",
                "exact_t_slip",
                "t_slip",
                "err_t_slip_ms",
                "lag_ms",
                "exact_theta_slip_deg",
                "theta_slip_deg",
                "err_theta_slip_deg",
                "energy_rise_before_slip",
                "outcome",
                "exact_outcome",
            ],
            [
                "engine",
                "dt",
                "status",
                "exact t_slip",
                "t_slip (refined)",
                "error ms",
                "threshold lag ms",
                "exact theta",
                "theta",
                "error deg",
                "energy rise",
                "outcome",
                "exact outcome",
            ],
        )
    )
    md += [
        "",
        "`threshold lag` is how late the raw |slip velocity| > 1 mm/s detector fires; the "
        "refined onset extrapolates it back. The reference rows measure the detectors' own "
        "bias on the exact solution sampled at the engine step.",
        "",
    ]

    hops = default[default["scene"].str.startswith("hop")]
    if len(hops):
        md += ["## Lift-off, hop height and impact (hop scenes, default settings)", ""]
        md.append(
            markdown_table(
                hops,
                [
                    "scene",
                    "engine",
                    "timestep",
                    "status",
                    "outcome",
                    "exact_t_lift",
                    "t_lift",
                    "err_t_lift_ms",
                    "exact_hop_height",
                    "hop_height",
                    "err_hop_height_rel",
                    "exact_t_impact",
                    "t_impact",
                    "err_t_impact_ms",
                ],
                [
                    "scene",
                    "engine",
                    "dt",
                    "status",
                    "outcome",
                    "exact t_lift",
                    "t_lift",
                    "error ms",
                    "exact hop",
                    "hop",
                    "rel. error",
                    "exact t_impact",
                    "t_impact",
                    "error ms",
                ],
            )
        )
        md.append("")

    md += ["## Phase sequences (default settings, dt = 1e-4)", ""]
    md.append(
        "R roll, S+/S- slip forward/backward, F flight, up to the first impact. The engine "
        "sequences come from the shared detectors; the reference row shows what they read off "
        "the exact solution."
    )
    md.append("")
    md.append(_phase_table(default[default["timestep"] == 1e-4]))
    md.append("")

    variants = frame[frame["variant"] != "default"]
    if len(variants):
        md += ["## Contact settings (dt = 1e-4)", ""]
        md.append(
            markdown_table(
                variants,
                [
                    "scene",
                    "engine",
                    "variant",
                    "status",
                    "outcome",
                    "exact_outcome",
                    "err_t_slip_ms",
                    "err_theta_slip_deg",
                    "err_t_lift_ms",
                    "err_hop_height_rel",
                    "us_per_step",
                ],
                [
                    "scene",
                    "engine",
                    "settings",
                    "status",
                    "outcome",
                    "exact outcome",
                    "slip error ms",
                    "slip error deg",
                    "lift error ms",
                    "hop rel. error",
                    "us/step",
                ],
            )
        )
        md.append("")

    md += ["## Error against timestep and run time (default settings)", ""]
    md.append(
        "Per engine and timestep: the stepping time of the seed run, the slip-onset error on "
        "seed-mu, the lift-off error on each hop scene (ms; `-` where no lift-off was "
        "detected) and how many scenes end with the exact outcome."
    )
    md.append("")
    md.append(_accuracy_table(default))
    md.append("")
    md += ["## Error against run time", ""]
    fig1 = error_vs_time_figure(
        default[default["engine"] != "reference"],
        out / "error_vs_time.png",
        panels=[
            ("seed-mu", "err_t_slip_ms", "slip onset error (ms)"),
            ("hop-top", "err_t_lift_ms", "lift-off error (ms)"),
        ],
        title="default settings; labels are the timesteps (s)",
    )
    md += [f"![event errors against run time]({fig1.name})", ""]
    cost = (
        frame[frame["variant"] == "default"]
        .groupby(["engine", "timestep"], as_index=False)[["us_per_step", "wall_time_s"]]
        .median()
    )
    md.append(
        markdown_table(
            cost,
            ["engine", "timestep", "us_per_step", "wall_time_s"],
            ["engine", "dt", "median us/step", "median wall s"],
        )
    )
    md.append("")

    md += ["## Stability", ""]
    md.append(
        "Runs that did not finish cleanly, or whose detected outcome differs from the exact "
        "one, or that penetrated the floor by more than 1 mm:"
    )
    md.append("")
    bad = frame[
        (frame["status"] != "ok")
        | (frame["outcome_agrees"] == False)  # noqa: E712 - NaN rows must not match
        | (frame["max_penetration_m"] > 1e-3)
    ]
    md.append(
        markdown_table(
            bad,
            [
                "scene",
                "engine",
                "variant",
                "timestep",
                "status",
                "message",
                "outcome",
                "exact_outcome",
                "max_penetration_m",
                "energy_rise_before_slip",
            ],
            [
                "scene",
                "engine",
                "settings",
                "dt",
                "status",
                "message",
                "outcome",
                "exact outcome",
                "max penetration m",
                "energy rise",
            ],
        )
        if len(bad)
        else "None."
    )
    md.append("")

    md += ["## Figures", ""]
    for scene_name in hops["scene"].unique() if len(hops) else []:
        runs = {}
        for _, row in default[
            (default["scene"] == scene_name) & (default["timestep"] == 1e-4)
        ].iterrows():
            path = row.get("trajectory_file")
            if isinstance(path, str):
                runs[row["engine"]] = Trajectory.read(path)
        if runs:
            exact_lift = hops[hops["scene"] == scene_name]["exact_t_lift"].iloc[0]
            exact_impact = hops[hops["scene"] == scene_name]["exact_t_impact"].iloc[0]
            window = None
            if exact_lift is not None and not math.isnan(exact_lift):
                span = exact_impact - exact_lift
                window = (exact_lift - span, exact_impact + span)
            fig = clearance_figure(
                runs,
                out / f"clearance_{scene_name}.png",
                title=f"{scene_name}: hoop-centre clearance, dt = 1e-4",
                t_window=window,
            )
            md += [f"![clearance in {scene_name}]({fig.name})", ""]
        fig = hoop_figure(get_scene(scene_name), out / f"hoop_{scene_name}.png")
        md += [f"![{scene_name} path]({fig.name})", ""]
    fig = hoop_figure(get_scene("seed"), out / "hoop_seed.png")
    md += [f"![seed path]({fig.name})", ""]
    md += [
        "## Files",
        "",
        "- `runs.csv`, `runs.parquet`: one row per run, one column per variable.",
        "- `trajectories/`: the default-setting trajectories (Parquet, normalised columns).",
        "",
    ]
    path = out / "report.md"
    path.write_text("\n".join(md))
    return path
