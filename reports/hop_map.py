"""The hop map (issue 11): the exact regime and every engine's verdict over a grid of scenes.

A :class:`MapSpec` names two of the scene's parameters (:class:`Axis`) as the map's axes, their
ranges and grid, the fixed values of the other three, the window, the engines, their timestep
and profile. It is stored as ``DIR/map.toml`` so that a resumed map and the report can rebuild
it (and a resume with a different spec is refused).

:func:`run_map` runs the map in two stages through the same runner as ``compare``
(:func:`hoopbench.reports.runner.run_tasks`: isolated workers, time limits, resume), both into
the one runs dataset ``DIR/runs/``:

1. one task per point, engine ``reference``: the exact solver classifies the scene
   (:func:`hoopbench.reference.regimes.classify`);
2. one task per (point, engine), carrying the reference's exact columns and ``t_settled``; the
   engine run stops at its first impact, or once it has rolled a full turn after the
   reference's last event, when nothing new can happen. Its row has the event, error and
   verdict columns that ``compare`` gives (the same functions build them).

:func:`map_frame` reads the latest row of every run (columns :data:`MAP_COLUMNS`) and
:func:`agreement_table` counts, per engine and regime, how often the engine agrees.
"""

from __future__ import annotations

import json
import math
import sys
import tomllib
from collections import Counter
from collections.abc import Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, fields
from datetime import UTC, datetime
from enum import StrEnum
from pathlib import Path
from types import MappingProxyType
from typing import Any, TextIO

import numpy as np
import pandas as pd

from hoopbench.engines.base import MAX_STEPS, RunStatus, n_steps_for
from hoopbench.engines.options import Profile
from hoopbench.engines.registry import engine_class, engine_names, get_engine
from hoopbench.engines.settings import DEFAULT_TIMESTEP, RunSettings
from hoopbench.engines.stopping import StopRule
from hoopbench.models.checks import check_integer, check_real
from hoopbench.models.events import Outcome
from hoopbench.models.scene import DegenerateSceneError, Scene
from hoopbench.reference.regimes import Regime, classify
from hoopbench.reports import results
from hoopbench.reports.runner import (
    RunnerError,
    RunSummary,
    is_final_status,
    prepare_dir,
    refuse_in_a_starting_worker,
    run_tasks,
)
from hoopbench.reports.suite import event_columns, exact_columns, run_timeout
from hoopbench.reports.verdict import counts_as_hop, number_or_none, verdict_columns

__all__ = [
    "AXES",
    "DEFAULT_ENGINES",
    "MAP_COLUMNS",
    "MAP_FILE",
    "REFERENCE",
    "Axis",
    "AxisInfo",
    "MapPoint",
    "MapSpec",
    "MapSpecMismatchError",
    "MapTask",
    "agreement_markdown",
    "agreement_table",
    "load_spec",
    "map_frame",
    "reference_tasks",
    "run_map",
    "run_map_task",
]

MAP_FILE = "map.toml"
"""The spec of a map folder, beside runs/."""
FORMAT_VERSION = 1
"""Version of map.toml and of the map's row layout."""
REFERENCE = "reference"
"""The engine name of stage 1's rows (the exact classification)."""
MAX_GRID = 999
"""Largest number of points along an axis: a point's run_id has three digits per axis, and a
999 x 999 map is already a million engine runs."""
REFERENCE_TIMEOUT = 60.0
"""s a classification may take before it becomes a timeout row (40 ms mean, 113 ms at most
on a 10 x 10 map; the solver's own work budget ends a stuck solve long before)."""


# --------------------------------------------------------------------------- axes
class Axis(StrEnum):
    """A scene parameter a map can sweep (theta0 in degrees, as on the command line)."""

    LAM = "lam"
    CHI = "chi"
    MU = "mu"
    EPS = "eps"
    THETA0_DEG = "theta0_deg"


@dataclass(frozen=True)
class AxisInfo:
    """What a map needs to know about a parameter: where it may go, where it goes by default."""

    low: float
    """Smallest allowed value (inclusive)."""
    high: float | None
    """Largest allowed value (inclusive); None: unbounded."""
    default_range: tuple[float, float]
    """The axis's range when none is given."""
    fixed: float
    """The parameter's value when it is not an axis."""
    unit: str
    reason: str
    """Why these defaults."""


AXES: Mapping[Axis, AxisInfo] = MappingProxyType(
    {
        Axis.LAM: AxisInfo(
            0.0,
            1.0,
            (0.5, 1.0),
            0.8,
            "",
            "Range: a start lifts off when lam chi > 1 (physics.md), so below lam = 0.5 no "
            "chi of the default range hops at once and the hoop mostly rolls or slips; 1 is the "
            "massless ring (at eps = 0, I = 0: the degenerate column). Fixed: 0.8, heavy enough "
            "to hop, and Painleve needs muk > sqrt(1 - lam^2)/lam = 0.75, inside the mu range.",
        ),
        Axis.CHI: AxisInfo(
            0.0,
            None,
            (0.05, 2.0),
            0.5,
            "",
            "Range: from a slow start, where gravity on the weight drives the motion, to twice "
            "the spin at which even a massless ring lifts off at the start (lam chi = 1); a "
            "10 x 10 lam-chi map over it holds rolls, slips, hops and lifts-at-start. Fixed: "
            "0.5, lam chi = 0.4 < 1, so the hoop starts on the floor.",
        ),
        Axis.MU: AxisInfo(
            0.0,
            None,
            (0.05, 1.5),
            0.8,
            "",
            "mus = muk = mu. Range: from nearly frictionless (slips at once) to beyond the "
            "Painleve bound sqrt(1 - lam^2)/lam (0.75 at lam = 0.8). Fixed: 0.8, the seed's mus.",
        ),
        Axis.EPS: AxisInfo(
            0.0,
            None,
            (0.0, 1.0),
            0.0,
            "",
            "The weight's own inertia, I = M a^2 (1 - lam^2 + lam eps). Range: from a point "
            "weight to a weight as wide as the hoop. Fixed: 0, the point weight of the "
            "closed forms.",
        ),
        Axis.THETA0_DEG: AxisInfo(
            -360.0,
            360.0,
            (0.0, 360.0),
            0.0,
            "deg",
            "Range: one turn of the start angle (beyond a turn either way is the same start; "
            "the bound catches radians given as degrees). Fixed: 0, the weight on top, the "
            "seed's start.",
        ),
    }
)
"""Every axis's domain and defaults: the one place they live."""

DEFAULT_ENGINES = ("mujoco", "pybullet", "pymunk")
"""The issue's map: the three engines every install has (Drake is an optional extra)."""
DEFAULT_GRID = (10, 10)
"""Points along x and y: the 10 x 10 map of the issue's measurements, about a minute."""
DEFAULT_T_END = 3.0
"""s: the catalogue's window (Scene.t_end's default)."""


# --------------------------------------------------------------------------- the spec
class MapSpecMismatchError(RunnerError):
    """A resumed map whose spec differs from the one stored in its folder."""


def _axis(name: str, value: Any) -> Axis:
    try:
        return Axis(value)
    except ValueError:
        allowed = ", ".join(a.value for a in Axis)
        raise ValueError(f"{name} must be one of {allowed}, got {value!r}") from None


def _check_value(name: str, axis: Axis, value: Any) -> float:
    info = AXES[axis]
    return check_real(name, value, low=info.low, high=info.high, unit=info.unit)


def _check_range(name: str, axis: Axis, value: Any) -> tuple[float, float]:
    if isinstance(value, str) or not isinstance(value, Sequence) or len(value) != 2:
        raise ValueError(f"{name} must be two numbers (low, high), got {value!r}")
    low, high = (_check_value(f"{name} of {axis}", axis, v) for v in value)
    if not low < high:
        raise ValueError(f"{name} of {axis} must have low < high, got [{low:g}, {high:g}]")
    return (low, high)


@dataclass(frozen=True)
class MapSpec:
    """What a map runs. Validated on construction: a bad value raises ValueError naming it."""

    x: Axis = Axis.LAM
    y: Axis = Axis.CHI
    x_range: tuple[float, float] | None = None
    """Range of x (both ends are grid points); None: the axis's default (AXES)."""
    y_range: tuple[float, float] | None = None
    nx: int = DEFAULT_GRID[0]
    """Points along x, 1 to MAX_GRID (one point sits at the range's low end)."""
    ny: int = DEFAULT_GRID[1]
    fixed: Mapping[str, float] | tuple[tuple[str, float], ...] = ()
    """Values of the parameters that are not axes (missing ones: AXES defaults); stored as
    sorted (name, value) pairs, all three of them."""
    t_end: float = DEFAULT_T_END
    """End of each scene's window, s (it also ends at the first impact)."""
    engines: tuple[str, ...] = DEFAULT_ENGINES
    """Engines to run at every point (none: the reference's regime map alone)."""
    timestep: float = DEFAULT_TIMESTEP
    """The engines' step, s."""
    profile: Profile = Profile.TUNED
    """The engines' option values: hoopbench's tuned ones or the engines' stock ones."""

    def __post_init__(self) -> None:
        x, y = _axis("x", self.x), _axis("y", self.y)
        if x == y:
            raise ValueError(f"x and y are both {x}: a map needs two different parameters")
        set_ = object.__setattr__
        set_(self, "x", x)
        set_(self, "y", y)
        for name, axis in (("x_range", x), ("y_range", y)):
            value = getattr(self, name)
            value = AXES[axis].default_range if value is None else value
            set_(self, name, _check_range(name, axis, value))
        set_(self, "nx", check_integer("nx", self.nx, low=1, high=MAX_GRID))
        set_(self, "ny", check_integer("ny", self.ny, low=1, high=MAX_GRID))
        set_(self, "fixed", self._checked_fixed())
        set_(self, "t_end", check_real("t_end", self.t_end, low=0.0, low_open=True, unit="s"))
        self._check_timestep()
        try:
            set_(self, "profile", Profile(self.profile))
        except ValueError:
            allowed = ", ".join(p.value for p in Profile)
            raise ValueError(f"profile must be one of {allowed}, got {self.profile!r}") from None
        set_(self, "engines", self._checked_engines())

    def _checked_fixed(self) -> tuple[tuple[str, float], ...]:
        given = dict(self.fixed)
        for name in given:
            axis = _axis("fixed parameter", name)
            if axis in (self.x, self.y):
                which = "x" if axis == self.x else "y"
                raise ValueError(
                    f"{axis} = {given[name]} is fixed, but {axis} is the {which} axis: "
                    f"give its range ({which}_range) instead"
                )
        return tuple(
            (str(axis), _check_value(str(axis), axis, given.get(str(axis), AXES[axis].fixed)))
            for axis in Axis
            if axis not in (self.x, self.y)
        )

    def _check_timestep(self) -> None:
        dt = check_real("timestep", self.timestep, low=0.0, low_open=True, unit="s")
        object.__setattr__(self, "timestep", dt)
        if dt > self.t_end:
            raise ValueError(
                f"timestep {dt:g} s is longer than the window t_end = {self.t_end:g} s"
            )
        steps = self.t_end / dt
        if steps > MAX_STEPS:
            raise ValueError(
                f"timestep {dt:g} s needs {steps:.3g} steps per run over t_end = {self.t_end:g} s,"
                f" over max_steps = {MAX_STEPS:.3g}"
            )

    def _checked_engines(self) -> tuple[str, ...]:
        if isinstance(self.engines, str):
            raise ValueError(f"engines must be a list of engine names, got {self.engines!r}")
        engines = tuple(self.engines)
        known = [name for name in engine_names() if name != REFERENCE]
        for name in engines:
            if name not in known:
                raise ValueError(f"unknown engine {name!r} for a map; known: {', '.join(known)}")
            # Options and profile as a run checks them: a bad one fails before anything runs.
            engine_class(name).resolve(RunSettings(timestep=self.timestep, profile=self.profile))
        repeated = sorted({name for name in engines if engines.count(name) > 1})
        if repeated:
            raise ValueError(f"engine {repeated[0]!r} is given twice")
        return engines

    # ----------------------------------------------------------------- derived
    @property
    def fixed_values(self) -> dict[str, float]:
        """The fixed parameters, name -> value."""
        return dict(self.fixed)  # type: ignore[arg-type]

    def axis_values(self, axis: Axis) -> np.ndarray:
        """The grid values along x or y: shape (nx,) or (ny,), both range ends included."""
        if axis == self.x:
            return np.linspace(*self.x_range, self.nx)  # type: ignore[misc]
        if axis == self.y:
            return np.linspace(*self.y_range, self.ny)  # type: ignore[misc]
        raise ValueError(f"{axis} is not an axis of this map ({self.x}, {self.y})")

    def points(self) -> tuple[MapPoint, ...]:
        """Every point of the grid, x outer and y inner (the order of their run_ids)."""
        xs, ys = self.axis_values(self.x), self.axis_values(self.y)
        base = self.fixed_values
        return tuple(
            MapPoint(
                ix=ix,
                iy=iy,
                x_axis=self.x,
                y_axis=self.y,
                x=float(x),
                y=float(y),
                t_end=self.t_end,
                **{**base, str(self.x): float(x), str(self.y): float(y)},
            )
            for ix, x in enumerate(xs)
            for iy, y in enumerate(ys)
        )

    @property
    def run_count(self) -> int:
        """Runs of the whole map: the reference and every engine at every point."""
        return self.nx * self.ny * (1 + len(self.engines))

    # ----------------------------------------------------------------- TOML
    def to_dict(self) -> dict[str, Any]:
        """Plain values (the TOML's keys)."""
        return {
            "format_version": FORMAT_VERSION,
            "x": str(self.x),
            "y": str(self.y),
            "x_range": list(self.x_range),  # type: ignore[arg-type]
            "y_range": list(self.y_range),  # type: ignore[arg-type]
            "nx": self.nx,
            "ny": self.ny,
            "t_end": self.t_end,
            "engines": list(self.engines),
            "timestep": self.timestep,
            "profile": str(self.profile),
            "fixed": self.fixed_values,
        }

    def to_toml(self) -> str:
        """The spec as TOML (floats written by repr, so they read back exactly)."""
        data = self.to_dict()
        fixed = data.pop("fixed")
        lines = ["# A hoopbench hop map (hoopbench map); read by --resume and the report."]
        lines += [f"{key} = {_toml_value(value)}" for key, value in data.items()]
        lines += ["", "[fixed]"]
        lines += [f"{key} = {_toml_value(value)}" for key, value in fixed.items()]
        return "\n".join(lines) + "\n"

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> MapSpec:
        data = dict(data)
        version = data.pop("format_version", FORMAT_VERSION)
        if version != FORMAT_VERSION:
            raise ValueError(f"map format_version {version!r} is not {FORMAT_VERSION}")
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ValueError(f"unknown map key(s) {', '.join(unknown)}; known: {', '.join(known)}")
        for key in ("x_range", "y_range", "engines"):
            if isinstance(data.get(key), list):
                data[key] = tuple(data[key])
        return cls(**data)

    @classmethod
    def from_toml(cls, text: str) -> MapSpec:
        try:
            return cls.from_dict(tomllib.loads(text))
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{MAP_FILE} is not valid TOML: {exc}") from None

    def differences(self, other: MapSpec) -> list[str]:
        """'name value (other: value)' for every field that differs."""
        mine, theirs = self.to_dict(), other.to_dict()
        return [f"{k} {mine[k]!r} (stored: {theirs[k]!r})" for k in mine if mine[k] != theirs[k]]


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | float):
        return repr(value) if isinstance(value, int) else repr(float(value))
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"cannot write {type(value).__name__} to TOML")


def load_spec(out: str | Path) -> MapSpec:
    """The spec stored in a map folder (FileNotFoundError without one)."""
    path = Path(out) / MAP_FILE
    return MapSpec.from_toml(path.read_text(encoding="utf-8"))


# --------------------------------------------------------------------------- points, tasks
@dataclass(frozen=True)
class MapPoint:
    """One grid point: its indices, axis values and the full parameter set of its scene."""

    ix: int
    iy: int
    x_axis: Axis
    y_axis: Axis
    x: float
    y: float
    lam: float
    chi: float
    mu: float
    """mus = muk = mu."""
    eps: float
    theta0_deg: float
    """deg."""
    t_end: float
    """s."""

    @property
    def name(self) -> str:
        """'r017-023': stable and readable, the prefix of the point's run_ids."""
        return f"r{self.ix:03d}-{self.iy:03d}"

    def scene(self) -> Scene:
        """The point's scene (a rolling start, chi via Scene.from_chi)."""
        return Scene.from_chi(
            self.chi,
            lam=self.lam,
            mus=self.mu,
            muk=self.mu,
            eps=self.eps,
            theta0=math.radians(self.theta0_deg),
            t_end=self.t_end,
            name=self.name,
        )

    def columns(self) -> dict[str, Any]:
        return {
            "ix": self.ix,
            "iy": self.iy,
            "x_axis": str(self.x_axis),
            "y_axis": str(self.y_axis),
            "x": self.x,
            "y": self.y,
            "lam": self.lam,
            "chi": self.chi,
            "mu": self.mu,
            "eps": self.eps,
            "theta0_deg": self.theta0_deg,
            "t_end": self.t_end,
        }


EXACT_CARRIED = (
    "regime",
    "n_slips",
    "exact_outcome",
    "exact_hop_height",
    "exact_t_slip",
    "exact_t_lift",
    "exact_t_impact",
    "exact_phases",
    "exact_theta_slip_deg",
    "exact_t_painleve",
    "exact_t_settled",
    "exact_t_last_phase",
    "exact_max_slip_speed",
)
"""The reference row's columns an engine task carries and its row repeats."""


@dataclass(frozen=True)
class MapTask:
    """One run of a map: small and picklable, for a worker process or a Dask worker."""

    run_id: str
    point: MapPoint
    engine: str
    """An engine name, or REFERENCE for the exact classification."""
    timestep: float | None = None
    """s (engines only)."""
    profile: Profile | None = None
    """Engines only."""
    exact: tuple[tuple[str, Any], ...] = ()
    """The reference row's EXACT_CARRIED columns (engines only; empty if it failed)."""

    @property
    def label(self) -> str:
        """What the run is, for progress lines."""
        p = self.point
        return f"{p.x_axis}={p.x:.4g} {p.y_axis}={p.y:.4g} {self.engine}"

    @property
    def n_steps(self) -> int:
        """Steps of the whole window (sizes the time limit; an early stop only shortens it)."""
        return 0 if self.timestep is None else n_steps_for(self.point.scene(), self.timestep)


def reference_tasks(spec: MapSpec) -> list[MapTask]:
    """Stage 1: one classification per point."""
    return [MapTask(f"{p.name}-{REFERENCE}", p, REFERENCE) for p in spec.points()]


def _engine_task(spec: MapSpec, point: MapPoint, engine: str, exact: Mapping[str, Any]) -> MapTask:
    carried = tuple((c, exact[c]) for c in EXACT_CARRIED if c in exact)
    return MapTask(f"{point.name}-{engine}", point, engine, spec.timestep, spec.profile, carried)


def _stored_exact(row: Mapping[str, Any]) -> dict[str, Any]:
    """A stored reference row's carried columns, NaN read back as None."""
    out: dict[str, Any] = {}
    for column in EXACT_CARRIED:
        value = row.get(column)
        out[column] = value if isinstance(value, str) else number_or_none(value)
    if out["n_slips"] is not None:
        out["n_slips"] = int(out["n_slips"])
    return out


# --------------------------------------------------------------------------- rows
MAP_COLUMNS = (
    "run_id",
    "ix",
    "iy",
    "x_axis",
    "y_axis",
    "x",
    "y",
    "lam",
    "chi",
    "mu",
    "eps",
    "theta0_deg",
    "t_end",
    "engine",
    "profile",
    "timestep",
    "status",
    "message",
    "engine_version",
    "wall_time_s",
    "n_steps",
    "sim_time_s",
    "stop_reason",
    *EXACT_CARRIED,
    "outcome",
    "hop_height",
    "max_clearance",
    "t_slip",
    "t_lift",
    "t_impact",
    "phases",
    "verdict",
    "outcome_agrees",
    "hop_height_error",
    # compare's other event columns (suite.event_columns), for the same diagnostics
    "t_slip_threshold",
    "theta_slip_deg",
    "t_restick",
    "err_t_slip_ms",
    "err_theta_slip_deg",
    "err_t_lift_ms",
    "err_t_impact_ms",
    "err_hop_height_rel",
    "energy_rise_before_slip",
    "energy_change_end",
    "max_penetration_m",
    "consistent",
    "event_flags",
    "t_last_phase",
    "t_final",
    "phases_agree",
)
"""Every column of a map row, in order. Reference rows leave the engine's columns empty;
wall_time_s is the classification's time there. sim_time_s: simulated time, s (the run may
stop early: stop_reason). hop_height_error: engine minus exact hop height, m, only where both
hop. Times s, lengths m, angles deg."""

_HOPS = (str(Outcome.HOPS), str(Outcome.LIFTS_AT_START))


def _task_columns(task: MapTask) -> dict[str, Any]:
    """The descriptive columns of a task's row (also those of a timeout or crash row)."""
    return {
        "run_id": task.run_id,
        **task.point.columns(),
        "engine": task.engine,
        "profile": None if task.profile is None else str(task.profile),
        "timestep": task.timestep,
    }


def _ordered(row: Mapping[str, Any]) -> dict[str, Any]:
    return {column: row.get(column) for column in MAP_COLUMNS}


def _reference_row(task: MapTask) -> dict[str, Any]:
    point = classify(task.point.scene())
    return _ordered(
        {
            **_task_columns(task),
            "status": str(RunStatus.OK),
            "message": point.events.message,
            "wall_time_s": point.solve_time_s,
            "regime": str(point.regime),
            "n_slips": point.n_slips,
            **exact_columns(point.events, point.max_slip_speed),
            "exact_t_settled": point.t_settled,
        }
    )


def _engine_settings(task: MapTask, t_settled: float | None) -> RunSettings:
    """The run ends shortly after its first impact, where the exact window ends too, or once
    it has rolled a full turn after the reference's last event (t_settled), when nothing new
    can happen; mu is the scene's (mus = muk)."""
    stop = StopRule(at_first_impact=True, settle_after=t_settled)
    return RunSettings(timestep=task.timestep, profile=task.profile, stop=stop)


def _engine_row(task: MapTask) -> dict[str, Any]:
    exact = {column: None for column in EXACT_CARRIED} | dict(task.exact)
    row: dict[str, Any] = {**_task_columns(task), **exact}
    scene = task.point.scene()
    if scene.is_degenerate:
        # No engine builds a body without inertia (each would fail the same way), and no
        # engine answer means nothing to judge: a row saying so, with no verdict.
        message = "not run: degenerate scene"
        try:
            scene.require_inertia("an engine's rigid body")
        except DegenerateSceneError as exc:
            message = f"not run: {exc}"
        return _ordered({**row, "status": str(RunStatus.ERROR), "message": message})
    result = get_engine(task.engine).run(scene, _engine_settings(task, exact["exact_t_settled"]))
    info = result.info
    row.update(
        status=str(info.status),
        message=info.message,
        engine_version=info.engine_version,
        wall_time_s=info.wall_time_s,
        n_steps=info.n_steps,
        sim_time_s=None if info.n_steps is None else info.n_steps * task.timestep,
        stop_reason=info.stop_reason,
    )
    if result.events is not None and result.trajectory is not None:
        row.update(event_columns(result.events, result.trajectory, scene, exact))
    row.update(verdict_columns(row))
    row["hop_height_error"] = _hop_height_error(row)
    return _ordered(row)


def _hop_height_error(row: Mapping[str, Any]) -> float | None:
    """Engine minus exact hop height, m, where both hop (the engine above the hop threshold)
    and the run is judged (an exact hop below the threshold is not: reports/verdict.py)."""
    height, exact = number_or_none(row.get("hop_height")), number_or_none(row["exact_hop_height"])
    engine_hops = row.get("outcome") in _HOPS and counts_as_hop(height, row.get("max_clearance"))
    if height is None or exact is None or not engine_hops or row["exact_outcome"] not in _HOPS:
        return None
    if row.get("verdict") is None:
        return None
    return height - exact


def run_map_task(task: MapTask) -> dict[str, Any]:
    """The worker: one map row; an exception anywhere becomes a row with status error."""
    try:
        return _reference_row(task) if task.engine == REFERENCE else _engine_row(task)
    except Exception as exc:  # one broken run must not stop a map
        return map_failure_row(task, RunStatus.ERROR, f"{type(exc).__name__}: {exc}")


def map_failure_row(task: MapTask, status: RunStatus, message: str) -> dict[str, Any]:
    """The row of a run that produced nothing (timeout, crash, an exception)."""
    row = {**_task_columns(task), **dict(task.exact), "status": str(status), "message": message}
    if task.engine != REFERENCE:
        row.update(verdict_columns(row))
    return _ordered(row)


def _timeout(task: MapTask) -> float:
    # An engine run gets compare's limit for its whole window: stopping early only shortens it.
    return REFERENCE_TIMEOUT if task.engine == REFERENCE else run_timeout(task)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- running
def _prepare(out: Path, spec: MapSpec, resume: bool) -> None:
    """Check the folder (and a stored spec on resume); write map.toml if it is not there."""
    path = out / MAP_FILE
    if resume and path.is_file():
        stored = load_spec(out)
        if stored != spec:
            differ = "; ".join(spec.differences(stored))
            raise MapSpecMismatchError(
                f"{path} holds another map ({differ}): resume it with its own settings, "
                "or choose a new folder"
            )
        return
    if resume and out.is_dir() and any(out.iterdir()):
        raise RunnerError(f"{out} holds no {MAP_FILE}: it is not a hop map folder to resume")
    prepare_dir(out, resume=False)  # the runner's checks: not a file, empty
    results.atomic_write(path, lambda tmp: tmp.write_text(spec.to_toml(), encoding="utf-8"))


def _stage_two_tasks(spec: MapSpec, out: Path) -> tuple[list[MapTask], int]:
    """Engine tasks of the points whose reference row is final, each point's reference task
    before them (stored: skipped, but it puts runs.csv in map order); and how many of those
    reference tasks there are."""
    stored = results.read_runs(out)
    refs = {row["run_id"]: row for row in stored.to_dict("records") if row["engine"] == REFERENCE}
    tasks: list[MapTask] = []
    n_refs = 0
    for ref in reference_tasks(spec):
        row = refs.get(ref.run_id)
        if row is None or not is_final_status(row["status"]):
            continue  # timed out or crashed: a resumed map tries it again, then its engines
        tasks.append(ref)
        n_refs += 1
        exact = _stored_exact(row) if row["status"] == RunStatus.OK else {}
        tasks += [_engine_task(spec, ref.point, engine, exact) for engine in spec.engines]
    return tasks, n_refs


def _say(text: str, quiet: bool, stream: TextIO | None) -> None:
    if not quiet:
        print(text, file=stream or sys.stderr, flush=True)


def run_map(
    spec: MapSpec,
    out: str | Path,
    *,
    jobs: int = 2,
    executor: Executor | None = None,
    resume: bool = False,
    quiet: bool = False,
    stream: TextIO | None = None,
) -> RunSummary:
    """Run the map into ``out`` (two stages, one runs dataset; see the module docstring).

    ``executor``: any ``concurrent.futures.Executor`` (e.g. Dask's ``Client.get_executor()``);
    None: the runner's local pool of ``jobs`` processes. Raises OutputDirNotEmptyError for a
    folder that holds files when ``resume`` is false, MapSpecMismatchError when it holds
    another map; both before anything runs. The summary covers both stages.
    """
    refuse_in_a_starting_worker()
    out = Path(out)
    _prepare(out, spec, resume)
    started_at = datetime.now(UTC)
    meta = {"map": spec.to_dict(), "runs_format_version": FORMAT_VERSION}
    common = dict(
        failure_row=map_failure_row,
        timeout=_timeout,
        jobs=jobs,
        executor=executor,
        resume=True,  # the folder holds map.toml; resume=False would refuse it
        meta=meta,
        quiet=quiet,
        stream=stream,
    )
    refs = reference_tasks(spec)
    first = _stage_one(refs, out, common, quiet, stream)
    if first.interrupted is not None:
        return _summary(spec, out, [first], 0)
    tasks, n_refs = _stage_two_tasks(spec, out)
    engines = ", ".join(spec.engines) or "none"
    _say(f"hop map, stage 2 of 2: {len(tasks) - n_refs} engine runs ({engines})", quiet, stream)
    finished = _is_finished(spec, out, tasks)
    if not finished:
        # Stage 1's runs.csv and meta.json (or a stale pair) go: they are written again at the
        # end of stage 2 with every row, as a map's must be, and never stand for it meanwhile.
        for name in (results.CSV_NAME, results.META_NAME):
            (out / name).unlink(missing_ok=True)
    second = run_tasks(tasks, run_map_task, out, **common)  # type: ignore[arg-type]
    summary = _summary(spec, out, [first, second], n_refs)
    if second.interrupted is None and not finished:
        _complete_meta(out, started_at, resume, summary)
    return summary


def _is_finished(spec: MapSpec, out: Path, tasks: Sequence[MapTask]) -> bool:
    """Every run of the map stored with a final status, and its runs.csv and meta.json
    there: a resume has nothing to run, and those files (of the run that finished the map,
    with its wall time) stay as they are."""
    if not all((out / name).is_file() for name in (results.CSV_NAME, results.META_NAME)):
        return False
    stored = results.stored_statuses(out)
    return len(tasks) == spec.run_count and all(
        is_final_status(stored.get(t.run_id)) for t in tasks
    )


def _stage_one(
    refs: list[MapTask],
    out: Path,
    common: Mapping[str, Any],
    quiet: bool,
    stream: TextIO | None,
) -> RunSummary:
    """Stage 1, or nothing when every classification is stored (a resume in stage 2)."""
    stored = results.stored_statuses(out)
    if refs and all(is_final_status(stored.get(t.run_id)) for t in refs):
        return RunSummary(out, {}, 0.0, None, len(refs), 0)
    _say(f"hop map, stage 1 of 2: the exact reference at {len(refs)} points", quiet, stream)
    return run_tasks(refs, run_map_task, out, **common)  # type: ignore[arg-type]


def _summary(spec: MapSpec, out: Path, stages: Sequence[RunSummary], n_refs: int) -> RunSummary:
    counts: Counter[RunStatus] = Counter()
    for stage in stages:
        counts.update(stage.counts)
    stored = results.stored_statuses(out) if (out / results.RUNS_NAME).is_dir() else {}
    return RunSummary(
        out_dir=out,
        counts=dict(counts),
        wall_time_s=sum(s.wall_time_s for s in stages),
        interrupted=next((s.interrupted for s in stages if s.interrupted is not None), None),
        # stage 2 lists the stored reference tasks only to order runs.csv
        skipped=sum(s.skipped for s in stages) - n_refs,
        unfinished=spec.run_count - len(stored),
        notes=tuple(note for s in stages for note in s.notes),
    )


def _complete_meta(out: Path, started_at: datetime, resume: bool, summary: RunSummary) -> None:
    """meta.json of both stages (the runner wrote stage 2's, and always resumes here)."""
    path = out / results.META_NAME
    meta = json.loads(path.read_text())
    meta.update(
        started_at=started_at.isoformat(),
        wall_time_s=round(summary.wall_time_s, 3),
        resumed=resume,
        session={"ran": summary.total, "skipped": summary.skipped},
    )
    results.write_meta(meta, path)


# --------------------------------------------------------------------------- reading
def map_frame(out: str | Path) -> pd.DataFrame:
    """The latest row of every run of a map folder, one per (point, engine), the reference
    included: MAP_COLUMNS first (missing ones empty), then the runner's bookkeeping; in map
    order (x, y, then the reference and the engines as the spec lists them)."""
    out = Path(out)
    frame = results.read_runs(out)
    missing = [c for c in MAP_COLUMNS if c not in frame.columns]
    frame = frame.assign(**dict.fromkeys(missing, None))
    frame = frame[[*MAP_COLUMNS, *(c for c in frame.columns if c not in MAP_COLUMNS)]]
    try:
        engines = (REFERENCE, *load_spec(out).engines)
    except (OSError, ValueError):
        engines = (REFERENCE,)
    rank = {name: k for k, name in enumerate(engines)}
    key = frame["engine"].map(lambda e: rank.get(e, len(rank)))
    order = np.lexsort((frame["engine"].astype(str), key, frame["iy"], frame["ix"]))
    return frame.iloc[order].reset_index(drop=True)


# --------------------------------------------------------------------------- tables
ALL_REGIMES = "all"
"""The regime label of an engine's overall row in the agreement table."""


def agreement_table(frame: pd.DataFrame) -> pd.DataFrame:
    """Agreement with the reference per engine, overall and per exact regime.

    One row per (engine, regime) with ``points`` (engine rows), ``judged`` (those with a
    verdict: the rest have no exact answer, e.g. degenerate), ``outcome_agrees`` (count of
    outcome_agrees, the outcome class with the hop's size and timing) and ``agrees`` (count of
    verdict 'agrees': the outcome and the phase sequence), each with its percentage of
    ``judged`` (NaN where nothing was judged). Regimes in Regime's order, the overall row
    (regime 'all') first.
    """
    runs = frame[frame["engine"] != REFERENCE]
    regimes = [str(r) for r in Regime if (runs["regime"] == str(r)).any()]
    engines = list(dict.fromkeys(runs["engine"]))
    rows = []
    for engine in engines:
        mine = runs[runs["engine"] == engine]
        for regime in (ALL_REGIMES, *regimes):
            part = mine if regime == ALL_REGIMES else mine[mine["regime"] == regime]
            rows.append({"engine": engine, "regime": regime, **_agreement(part)})
    columns = ["engine", "regime", "points", "judged", "outcome_agrees", "outcome_agrees_pct"]
    return pd.DataFrame(rows, columns=[*columns, "agrees", "agrees_pct"])


def _agreement(part: pd.DataFrame) -> dict[str, Any]:
    judged = int(part["verdict"].notna().sum())
    outcome = int(part["outcome_agrees"].eq(True).sum())
    agrees = int(part["verdict"].eq("agrees").sum())
    return {
        "points": len(part),
        "judged": judged,
        "outcome_agrees": outcome,
        "outcome_agrees_pct": 100.0 * outcome / judged if judged else math.nan,
        "agrees": agrees,
        "agrees_pct": 100.0 * agrees / judged if judged else math.nan,
    }


def agreement_markdown(table: pd.DataFrame) -> str:
    """Two Markdown tables from :func:`agreement_table`: the outcome agreement and the full
    agreement (outcome and phases), regimes down, engines across, cells 'agree/judged (%)'."""
    blocks = []
    for column, title in (
        ("outcome_agrees", "Outcome agrees (class, hop size and lift-off time)"),
        ("agrees", "Verdict agrees (the outcome and the phase sequence)"),
    ):
        engines = list(dict.fromkeys(table["engine"]))
        regimes = list(dict.fromkeys(table["regime"]))
        lines = [f"**{title}**", "", "| regime | " + " | ".join(engines) + " |"]
        lines.append("|---|" + "---:|" * len(engines))
        for regime in regimes:
            cells = []
            for engine in engines:
                row = table[(table["engine"] == engine) & (table["regime"] == regime)].iloc[0]
                cells.append(_cell(row[column], row["judged"], row[f"{column}_pct"]))
            lines.append(f"| {regime} | " + " | ".join(cells) + " |")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


def _cell(count: int, judged: int, pct: float) -> str:
    return f"{count}/{judged} ({pct:.0f} %)" if judged else "-"
