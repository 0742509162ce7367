"""The hop map's spec: its axes, ranges, grid, fixed values, window and engines.

A :class:`MapSpec` names two of the scene's parameters (:class:`Axis`) as the map's axes, their
ranges and grid, the fixed values of the other three, the window, the engines, their timestep
and profile. It is stored as ``DIR/map.toml`` so that a resumed map and the report can rebuild
it (and a resume with a different spec is refused).
"""

from __future__ import annotations

import errno
import json
import math
import numbers
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from enum import StrEnum
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np

from hoopbench.engines.base import MAX_STEPS, check_steps
from hoopbench.engines.options import Profile, check_profile
from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.engines.settings import DEFAULT_TIMESTEP, RunSettings
from hoopbench.models.checks import check_integer, check_real
from hoopbench.models.scene import THETA0_LIMIT_DEG, Scene
from hoopbench.reports.compare.suite_file import MAX_SUITE_RUNS
from hoopbench.reports.sweep.folder_files import read_folder_text
from hoopbench.reports.sweep.runner import (
    RunnerError,
)

__all__ = [
    "AXES",
    "DEFAULT_ENGINES",
    "DEFAULT_GRID",
    "DEFAULT_T_END",
    "ENGINE_TIMESTEPS",
    "FORMAT_VERSION",
    "MAP_FILE",
    "MAX_GRID",
    "REFERENCE",
    "REFERENCE_TIMEOUT",
    "Axis",
    "AxisInfo",
    "MapPoint",
    "MapSpec",
    "MapSpecMismatchError",
    "check_grid",
    "check_stored_points",
    "default_engine_timesteps",
    "load_spec",
]


MAP_FILE = "map.toml"
"""The spec of a map folder, beside runs/."""
FORMAT_VERSION = 1
"""Version of map.toml and of the map's row layout."""
REFERENCE = REFERENCE_ENGINE
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
            (0.5, 0.95),
            0.8,
            "",
            "Range: a start lifts off when lam chi > 1 (physics.md), so below lam = 0.5 no "
            "chi of the default range hops at once and the hoop mostly rolls or slips; it stops "
            "at 0.95, below the massless ring lam = 1 (at eps = 0, I = 0: no engine can build "
            "the body, so every engine run there would be an error; --x-range 0.5 1 maps it "
            "anyway). Fixed: 0.8, heavy enough "
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
            -THETA0_LIMIT_DEG,
            THETA0_LIMIT_DEG,
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

DEFAULT_ENGINES = ("mujoco", "pybullet", "pymunk", "mjx", "newton")
"""The three engines every install has, and the batched MJX and Newton (the ``mjx`` and
``warp`` extras, in ``engines``; without them their rows are ``unavailable``) at their own
step (ENGINE_TIMESTEPS). MuJoCo Warp only with ``--engines``: on a CPU its world-step costs
5.4 ms in the default map's batches of 25 (measured on a loaded machine: an upper bound),
so it alone would add up to 19 CPU-minutes to a map of two, and it gave MJX float32's
verdict at every point and scene compared (docs/map.md, Cost). Drake, Box2D, Rapier and DART
only with ``--engines``, as before."""
ENGINE_TIMESTEPS: Mapping[str, float] = MappingProxyType(
    {"mjx": 1e-3, "mjwarp": 1e-3, "newton": 1e-3}
)
"""s: the batched engines' own step in a map unless one is given (``engine_timesteps``), the
suites' step for them: on a CPU their world-step costs 4 to 300 times MuJoCo C's in the
default map's batches (docs/map.md, Cost): at the map's 1e-4 s MJX and Newton would step
about 15 CPU-minutes of a default map that takes about 2 minutes at 1e-3 s."""
DEFAULT_GRID = (10, 10)
"""Points along x and y: the 10 x 10 map of the issue's measurements, about a minute with the
three C engines and two with MJX and Newton (docs/map.md, Cost)."""
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
    """The step of the engines without their own (``engine_timesteps``), s."""
    profile: Profile = Profile.TUNED
    """The engines' option values: hoopbench's tuned ones or the engines' stock ones."""
    engine_timesteps: Mapping[str, float] | tuple[tuple[str, float], ...] | None = None
    """Engines with their own step, s, name -> step, each one of the map's engines; None:
    ENGINE_TIMESTEPS's for the map's engines (default_engine_timesteps). Stored as sorted
    (name, step) pairs."""

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
        set_(self, "timestep", self._checked_step("timestep", self.timestep))
        set_(self, "profile", check_profile("profile", self.profile))
        set_(self, "engines", self._checked_engine_names())
        set_(self, "engine_timesteps", self._checked_engine_timesteps())
        self._check_engine_settings()
        if self.run_count > MAX_SUITE_RUNS:  # a suite's cap, for the same reasons
            raise ValueError(
                f"the map makes {self.run_count:,} runs ({self.nx} x {self.ny} points, the "
                f"reference and {len(self.engines)} engine(s) at each), more than "
                f"{MAX_SUITE_RUNS:,}: use a coarser grid or fewer engines"
            )

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

    def _checked_step(self, name: str, value: Any) -> float:
        dt = check_real(name, value, low=0.0, low_open=True, unit="s")
        try:
            check_steps(self.t_end, dt, MAX_STEPS)  # the runs' own window check, before any run
        except ValueError as exc:
            if name == "timestep":
                raise
            raise ValueError(f"{name}: {exc}") from None
        return dt

    def _checked_engine_names(self) -> tuple[str, ...]:
        if isinstance(self.engines, str):
            raise ValueError(f"engines must be a list of engine names, got {self.engines!r}")
        engines = tuple(self.engines)
        known = [name for name in engine_names() if name != REFERENCE]
        for name in engines:
            if name not in known:
                raise ValueError(f"unknown engine {name!r} for a map; known: {', '.join(known)}")
        repeated = sorted({name for name in engines if engines.count(name) > 1})
        if repeated:
            raise ValueError(f"engine {repeated[0]!r} is given twice")
        return engines

    def _checked_engine_timesteps(self) -> tuple[tuple[str, float], ...]:
        given: Any = self.engine_timesteps
        if given is None:
            given = default_engine_timesteps(self.engines)
        elif isinstance(given, tuple) and all(
            isinstance(p, tuple) and len(p) == 2 for p in given
        ):  # the stored pairs
            given = dict(given)
        if not isinstance(given, Mapping):
            raise ValueError(f"engine_timesteps must map engine names to steps, got {given!r}")
        for name in given:
            if name not in self.engines:
                raise ValueError(
                    f"engine_timesteps gives {name!r} a step, but {name!r} is not one of the "
                    f"map's engines ({', '.join(self.engines) or 'none'})"
                )
        return tuple(
            (name, self._checked_step(f"engine_timesteps[{name}]", given[name]))
            for name in sorted(given)
        )

    def _check_engine_settings(self) -> None:
        """Options and profile as a run checks them: a bad one fails before anything runs."""
        for name in self.engines:
            settings = RunSettings(timestep=self.timestep_of(name), profile=self.profile)
            engine_class(name).resolve(settings)

    # ----------------------------------------------------------------- derived
    def timestep_of(self, engine: str) -> float:
        """The step ``engine`` runs at on this map, s: its own or the map's."""
        return dict(self.engine_timesteps or ()).get(engine, self.timestep)

    @property
    def fixed_values(self) -> dict[str, float]:
        """The fixed parameters, name -> value."""
        return dict(self.fixed)

    def _range(self, axis: Axis) -> tuple[float, float]:
        """The range (low, high) along x or y. The fields allow None as input only:
        __post_init__ stores the axis's default (AXES) for it, as this does."""
        if axis not in (self.x, self.y):
            raise ValueError(f"{axis} is not an axis of this map ({self.x}, {self.y})")
        given = self.x_range if axis == self.x else self.y_range
        return AXES[axis].default_range if given is None else given

    def axis_values(self, axis: Axis) -> np.ndarray:
        """The grid values along x or y: shape (nx,) or (ny,), both range ends included."""
        low, high = self._range(axis)
        return np.linspace(low, high, self.nx if axis == self.x else self.ny)

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
            "x_range": list(self._range(self.x)),
            "y_range": list(self._range(self.y)),
            "nx": self.nx,
            "ny": self.ny,
            "t_end": self.t_end,
            "engines": list(self.engines),
            "timestep": self.timestep,
            "profile": str(self.profile),
            "fixed": self.fixed_values,
            "engine_timesteps": dict(self.engine_timesteps or ()),
        }

    def to_toml(self) -> str:
        """The spec as TOML (floats written by repr, so they read back exactly)."""
        data = self.to_dict()
        tables = {key: data.pop(key) for key in ("fixed", "engine_timesteps")}
        lines = ["# A hoopbench hop map (hoopbench map); read by --resume and the report."]
        lines += [f"{key} = {_toml_value(value)}" for key, value in data.items()]
        for name, table in tables.items():
            lines += ["", f"[{name}]"]
            lines += [f"{key} = {_toml_value(value)}" for key, value in table.items()]
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
            if key in data and not isinstance(data[key], list):
                raise ValueError(f"{key} must be a list, got {data[key]!r}")
            if key in data:
                data[key] = tuple(data[key])
        for key in ("fixed", "engine_timesteps"):
            if key in data and not isinstance(data[key], Mapping):
                raise ValueError(f"{key} must be a table, got {data[key]!r}")
        # A map stored before engines had their own steps ran every engine at `timestep`.
        data.setdefault("engine_timesteps", {})
        return cls(**data)

    @classmethod
    def from_toml(cls, text: str) -> MapSpec:
        try:
            data = tomllib.loads(text)
        except ValueError as exc:  # not TOML, or an integer past int()'s 4300 digits
            raise ValueError(f"{MAP_FILE} is not valid TOML: {exc}") from None
        except RecursionError:  # tomllib parses nested arrays recursively
            raise ValueError(f"{MAP_FILE}: its arrays or tables nest too deep") from None
        return cls.from_dict(data)

    def differences(self, other: MapSpec) -> list[str]:
        """'name value (other: value)' for every field that differs."""
        mine, theirs = self.to_dict(), other.to_dict()
        return [f"{k} {mine[k]!r} (stored: {theirs[k]!r})" for k in mine if mine[k] != theirs[k]]


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


def default_engine_timesteps(engines: Sequence[str]) -> dict[str, float]:
    """ENGINE_TIMESTEPS's steps of the engines among ``engines``, name -> s."""
    return {name: ENGINE_TIMESTEPS[name] for name in engines if name in ENGINE_TIMESTEPS}


def check_grid(value: str | Sequence[int]) -> tuple[int, int]:
    """Points along x and y: ``'40x40'`` or ``(40, 40)`` -> (40, 40), whole numbers >= 1."""
    if isinstance(value, str):
        nx, sep, ny = value.lower().partition("x")
        # ASCII digits only: int() also reads '２' (full width) and ' 3', not what one types
        digits = all(part.isascii() and part.isdigit() for part in (nx, ny))
        grid = (int(nx), int(ny)) if sep and digits else None
    else:
        pair = tuple(value) if isinstance(value, Sequence) else ()
        whole = [n for n in pair if isinstance(n, numbers.Integral) and not isinstance(n, bool)]
        grid = (int(whole[0]), int(whole[1])) if len(pair) == len(whole) == 2 else None
    if grid is None or min(grid) < 1:
        raise ValueError(f"must be NXxNY, whole numbers >= 1, got {value!r}")
    return grid


def check_stored_points(spec: MapSpec, rows: Any, where: str) -> None:
    """ValueError naming ``where`` unless every stored row (a DataFrame with columns ix, iy,
    x, y) lies on ``spec``'s grid: indices inside it, checked before anything is allocated
    for them, and the axis values the spec gives at those indices (a map.toml edited after
    the run, nx 2 -> 3, moves every point: its rows would be drawn where they were not run)."""
    for index, count, axis, value in (("ix", spec.nx, spec.x, "x"), ("iy", spec.ny, spec.y, "y")):
        indices = np.asarray(rows[index], dtype=float)
        bad = ~np.isfinite(indices) | (indices != np.round(indices))
        bad |= (indices < 0) | (indices >= count)
        if bad.any():
            shown = indices[int(np.argmax(bad))]
            raise ValueError(
                f"{where}: a row has {index} = {shown:g}, not a point of the map's grid "
                f"(0 to {count - 1}: {MAP_FILE} says n{value} = {count})"
            )
        expected = spec.axis_values(axis)[indices.astype(np.int64)]
        stored = np.asarray(rows[value], dtype=float)
        moved = ~np.isclose(stored, expected, rtol=1e-9, atol=1e-12)
        if moved.any():
            k = int(np.argmax(moved))
            raise ValueError(
                f"{where}: the rows were run on another grid than {MAP_FILE} describes "
                f"({index} = {int(indices[k])}: {axis} = {stored[k]:.6g} stored, "
                f"{expected[k]:.6g} by {MAP_FILE}); was {MAP_FILE} edited after the run?"
            )


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
    """The spec stored in a map folder (FileNotFoundError without one; FolderFileError, a
    ValueError, for a map.toml that is no file to read)."""
    path = Path(out) / MAP_FILE
    text = read_folder_text(out, MAP_FILE)
    if text is None:
        raise FileNotFoundError(errno.ENOENT, f"{path} is missing", str(path))
    try:
        return MapSpec.from_toml(text)
    except (TypeError, RecursionError) as exc:  # a value of the wrong shape: still bad data
        raise ValueError(f"{MAP_FILE} is not a map's spec: {exc}") from None
