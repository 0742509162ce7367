"""The comparison suite: scenes x engines x contact settings, against the exact reference.

One row per run (tidy): the run's settings, its status and cost, its detected events, the
exact events for the same scene and mu, and the errors. Written as CSV and Parquet, with a
Markdown report and PNG figures.
"""

from __future__ import annotations

import functools
import json
import math
import sys
import time
from collections.abc import Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import pandas as pd

from hoopbench.engines.base import RunResult
from hoopbench.engines.registry import engine_classes, get_engine
from hoopbench.engines.settings import DEFAULT_TIMESTEP, RunSettings
from hoopbench.models.catalogue import get_scene, scene_names
from hoopbench.models.events import Events
from hoopbench.reference.exact import solve_exact

__all__ = ["Case", "default_cases", "run_case", "run_report", "run_suite"]

FORMAT_VERSION = 1
"""Version of the runs table layout."""


@dataclass(frozen=True)
class Case:
    """One run of the suite: a scene in an engine with contact settings."""

    scene: str
    engine: str
    variant: str
    """Short label of the contact settings, e.g. 'default' or 'cone=pyramidal'."""
    timestep: float
    geometry: str = "sphere"
    options: dict[str, Any] = field(default_factory=dict)

    def settings(self) -> RunSettings:
        return RunSettings(timestep=self.timestep, geometry=self.geometry, options=self.options)


_TIMESTEPS = (1e-3, 5e-4, 2e-4, 1e-4, 5e-5)
"""Default-setting timesteps of the full sweep: the error-against-cost curve."""


def suite_scenes(quick: bool = False) -> list[str]:
    """Scenes of the suite: the cross-engine seed, the hop scenes and the stability cases."""
    names = scene_names()
    hops = [n for n in names if n.startswith("hop")]
    if quick:
        return ["seed-mu", *hops[:1]]
    # Stability cases: a hop from near-zero normal force, low friction with direct slip
    # reversals, and a sliding start that reaches the Painlevé point.
    others = [n for n in ("high-spin", "low-friction", "slip-reversal", "painleve") if n in names]
    return ["seed-mu", *hops, *others]


def default_cases(quick: bool = False, engines: Sequence[str] | None = None) -> list[Case]:
    """The default sweep (quick: seed-mu and one hop scene, default settings, dt 1e-4)."""
    classes = engine_classes()
    engines = list(engines or classes)
    cases = []
    for scene in suite_scenes(quick):
        for engine in engines:
            for dt in (DEFAULT_TIMESTEP,) if quick else _TIMESTEPS:
                cases.append(Case(scene, engine, "default", dt))
            if not quick:
                for v in classes[engine].variants:
                    options = dict(v.options)
                    cases.append(Case(scene, engine, v.name, DEFAULT_TIMESTEP, v.geometry, options))
    return cases


# --------------------------------------------------------------------------- one run
@functools.cache  # one exact solve per (scene, mu) per process, not one per run
def _exact_events(scene_name: str, mu: float) -> Events:
    scene = get_scene(scene_name)
    return solve_exact(scene.with_(mus=mu, muk=mu)).events


def _error(value: float | None, reference: float | None) -> float | None:
    if value is None or reference is None:
        return None
    return value - reference


def _row(case: Case, result: RunResult, exact: Events) -> dict[str, Any]:
    info, events, traj = result.info, result.events, result.trajectory
    row: dict[str, Any] = {
        "scene": case.scene,
        "engine": case.engine,
        "variant": case.variant,
        "timestep": case.timestep,
        "geometry": case.geometry,
        "options": json.dumps(
            {k: list(v) if isinstance(v, tuple) else v for k, v in case.options.items()}
        ),
        "status": str(info.status),
        "message": info.message,
        "engine_version": info.engine_version,
        "mu": info.mu,
        "wall_time_s": info.wall_time_s,
        "n_steps": info.n_steps,
        "us_per_step": None
        if not info.n_steps or info.wall_time_s is None
        else 1e6 * info.wall_time_s / info.n_steps,
        "exact_outcome": str(exact.outcome),
        "exact_t_slip": exact.t_slip,
        "exact_theta_slip_deg": None
        if exact.theta_slip is None
        else math.degrees(exact.theta_slip),
        "exact_t_lift": exact.t_lift,
        "exact_hop_height": exact.hop_height,
        "exact_t_impact": exact.t_impact,
        "exact_phases": exact.phase_code,
    }
    if events is None or traj is None:
        return row
    theta_deg = None if events.theta_slip is None else math.degrees(events.theta_slip)
    before = traj.t < (events.t_slip if events.t_slip is not None else traj.t[-1])
    e0 = traj.energy[0]
    row.update(
        {
            "outcome": str(events.outcome),
            "t_slip": events.t_slip,
            "t_slip_threshold": events.extra.get("t_slip_threshold"),
            "theta_slip_deg": theta_deg,
            "t_restick": events.t_restick,
            "t_lift": events.t_lift,
            "hop_height": events.hop_height,
            "t_impact": events.t_impact,
            "err_t_slip_ms": _ms(_error(events.t_slip, exact.t_slip)),
            "err_theta_slip_deg": _error(theta_deg, row["exact_theta_slip_deg"]),
            "err_t_lift_ms": _ms(_error(events.t_lift, exact.t_lift)),
            "err_t_impact_ms": _ms(_error(events.t_impact, exact.t_impact)),
            "err_hop_height_rel": None
            if events.hop_height is None or not exact.hop_height
            else events.hop_height / exact.hop_height - 1.0,
            "energy_rise_before_slip": float((traj.energy[before].max() - e0) / e0)
            if before.any()
            else None,
            "energy_change_end": float((traj.energy[-1] - e0) / e0),
            "max_penetration_m": float(max(0.0, -traj.clearance.min())),
            "outcome_agrees": str(events.outcome) == str(exact.outcome),
            "phases": events.phase_code,
            "phases_agree": events.phase_code == exact.phase_code,
        }
    )
    return row


def _ms(seconds: float | None) -> float | None:
    return None if seconds is None else 1e3 * seconds


def run_case(case: Case, trajectory_dir: str | None = None) -> dict[str, Any]:
    """Run one case and return its row; a failure anywhere becomes a row with status error."""
    try:
        return _run_case(case, trajectory_dir)
    except Exception as exc:  # one broken run must not stop a sweep
        return {
            "scene": case.scene,
            "engine": case.engine,
            "variant": case.variant,
            "timestep": case.timestep,
            "geometry": case.geometry,
            "status": "error",
            "message": f"{type(exc).__name__}: {exc}",
        }


def _run_case(case: Case, trajectory_dir: str | None) -> dict[str, Any]:
    scene = get_scene(case.scene)
    result = get_engine(case.engine).run(scene, case.settings())
    exact = _exact_events(case.scene, result.info.mu)
    row = _row(case, result, exact)
    if trajectory_dir and result.trajectory is not None and case.variant == "default":
        name = f"{case.scene}__{case.engine}__dt{case.timestep:g}.parquet"
        path = Path(trajectory_dir) / name
        result.trajectory.write(path)
        row["trajectory_file"] = str(path)
    return row


def run_suite(
    cases: Iterable[Case],
    *,
    workers: int = 2,
    trajectory_dir: str | None = None,
    progress=sys.stderr,
) -> pd.DataFrame:
    """Run the cases on ``workers`` processes; progress lines go to ``progress``."""
    cases = list(cases)
    rows: list[dict[str, Any]] = []
    start = time.perf_counter()
    if workers <= 1:
        results = ((case, run_case(case, trajectory_dir)) for case in cases)
        for k, (case, row) in enumerate(results, 1):
            rows.append(row)
            _progress(progress, k, len(cases), case, row, start)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futures = {pool.submit(run_case, case, trajectory_dir): case for case in cases}
            for k, future in enumerate(as_completed(futures), 1):
                row = future.result()
                rows.append(row)
                _progress(progress, k, len(cases), futures[future], row, start)
    frame = pd.DataFrame(rows)
    order = {(c.scene, c.engine, c.variant, c.timestep): i for i, c in enumerate(cases)}
    frame["_order"] = [
        order[(r.scene, r.engine, r.variant, r.timestep)] for r in frame.itertuples()
    ]
    return frame.sort_values("_order").drop(columns="_order").reset_index(drop=True)


def _progress(stream, k: int, total: int, case: Case, row: dict, start: float) -> None:
    if stream is None:
        return
    wall = row.get("wall_time_s")
    cost = "" if wall is None else f" {wall:.2f} s"
    elapsed = time.perf_counter() - start
    print(
        f"[{k:>3}/{total}] {case.engine:<9} {case.scene:<14} {case.variant:<22} "
        f"dt={case.timestep:g}: {row['status']}{cost} (elapsed {elapsed:.0f} s)",
        file=stream,
        flush=True,
    )


# --------------------------------------------------------------------------- report
def run_report(
    out: str | Path = "reports/output", *, quick: bool = False, workers: int = 2
) -> Path:
    """Run the default suite and write runs.csv, runs.parquet, report.md and figures."""
    from hoopbench.reports.markdown import write_markdown

    out = Path(out)
    traj_dir = out / "trajectories"
    traj_dir.mkdir(parents=True, exist_ok=True)
    cases = default_cases(quick)
    print(f"hoopbench report: {len(cases)} runs on {workers} worker(s) -> {out}", file=sys.stderr)
    frame = run_suite(cases, workers=workers, trajectory_dir=str(traj_dir))
    frame.attrs["hoopbench_runs_format"] = FORMAT_VERSION
    # Plain CSV (header on line 1, for any CSV reader); what it is goes in runs.json.
    frame.to_csv(out / "runs.csv", index=False)
    frame.to_parquet(out / "runs.parquet", index=False)
    meta = {
        "format": "hoopbench runs",
        "format_version": FORMAT_VERSION,
        "units": {"times": "s", "angles": "deg", "lengths": "m", "*_ms": "ms"},
        "columns": list(frame.columns),
        "runs": len(frame),
    }
    (out / "runs.json").write_text(json.dumps(meta, indent=2) + "\n")
    report = write_markdown(frame, out, generated=datetime.now(UTC).isoformat(timespec="seconds"))
    print(f"wrote {report}", file=sys.stderr)
    return report
