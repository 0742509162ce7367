"""The normalised trajectory every engine, and the reference, returns."""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike, NDArray

from hoopbench.models import kinematics
from hoopbench.models.formats import FileFormat
from hoopbench.models.scene import Scene
from hoopbench.models.whole_files import write_whole

__all__ = ["COLUMNS", "FORMAT_KEY", "FORMAT_VERSION", "TRAJECTORY_FILE", "Trajectory"]

FORMAT_VERSION = 1
"""Version of the trajectory file layout (CSV comment line / Parquet metadata)."""
FORMAT_KEY = "hoopbench_trajectory_format"
"""The frame attribute holding the version in a Parquet file (pandas stores attrs there)."""
TRAJECTORY_FILE = FileFormat("trajectory file", FORMAT_VERSION, oldest=1)
"""Reading checks a file's version against this (a file without one counts as version 1)."""
PARQUET_COMPRESSION = "zstd"
"""A Parquet trajectory's codec, each float column split into byte streams first
(:meth:`Trajectory.write`)."""
PARQUET_COMPRESSION_LEVEL = 1
"""zstd's fastest level: level 3 gave 1 % smaller files for 40 % more CPU."""
_CSV_VERSION = re.compile(r"#\s*hoopbench trajectory format\s+([^;\s]*)")
"""The CSV's first line, as :meth:`Trajectory.write` writes it."""


@dataclass(frozen=True, eq=False)
class Trajectory:
    """Samples of one run, one row per time, SI units, theta clockwise from the top.

    Every array has shape (n,). Build it with :meth:`from_state` so that the derived
    columns (clearance, slip velocity, energy) come from :mod:`hoopbench.models.kinematics`.
    """

    t: NDArray
    """Time, s."""
    X: NDArray
    """Centre-of-mass horizontal position, m."""
    Y: NDArray
    """Centre-of-mass height above the floor, m."""
    theta: NDArray
    """Angle of the weight from the upward vertical, rad, clockwise positive (unwrapped)."""
    Xdot: NDArray
    """Centre-of-mass horizontal velocity, m/s."""
    Ydot: NDArray
    """Centre-of-mass vertical velocity, m/s."""
    thetadot: NDArray
    """Angular velocity, rad/s, clockwise positive."""
    clearance: NDArray
    """Height of the body's lowest point above the floor, m (penetration is negative): y - a
    for the hoop's circle, y - h(theta) for a polygon (kinematics.clearance)."""
    slip_velocity: NDArray
    """Horizontal velocity of the body's lowest point, m/s: xdot - a*thetadot for the hoop's
    circle, xdot - h(theta)*thetadot for a polygon (kinematics.slip_velocity)."""
    normal_force: NDArray
    """Normal contact force per unit mass, m/s^2 (0 in flight)."""
    friction_force: NDArray
    """Horizontal contact force per unit mass, m/s^2, +x positive."""
    contact: NDArray
    """True where the engine (or the reference) reports a contact force, bool."""
    energy: NDArray
    """Mechanical energy per unit mass, J/kg."""

    @classmethod
    def from_state(
        cls,
        scene: Scene,
        *,
        t: ArrayLike,
        X: ArrayLike,
        Y: ArrayLike,
        theta: ArrayLike,
        Xdot: ArrayLike,
        Ydot: ArrayLike,
        thetadot: ArrayLike,
        normal_force: ArrayLike,
        friction_force: ArrayLike,
        contact: ArrayLike | None = None,
        shape: kinematics.Polygon | None = None,
    ) -> Trajectory:
        """Build from centre-of-mass states and contact forces; derive the rest.

        ``shape`` is the contact shape when it is not the hoop's circle of radius a (None):
        clearance and slip velocity are then read at the polygon's lowest point (see
        :mod:`hoopbench.models.kinematics`). An adapter whose collision geometry is faceted
        passes it.
        """
        arr = {
            name: np.asarray(value, dtype=float)
            for name, value in dict(
                t=t,
                X=X,
                Y=Y,
                theta=theta,
                Xdot=Xdot,
                Ydot=Ydot,
                thetadot=thetadot,
                normal_force=normal_force,
                friction_force=friction_force,
            ).items()
        }
        n = arr["t"].shape
        for name, value in arr.items():
            if value.shape != n:
                raise ValueError(f"{name} has shape {value.shape}, expected {n}")
        if contact is None:
            contact = arr["normal_force"] > 0
        return cls(
            **arr,
            clearance=kinematics.clearance(scene, arr["Y"], arr["theta"], shape),
            slip_velocity=kinematics.slip_velocity(
                scene, arr["Xdot"], arr["theta"], arr["thetadot"], shape
            ),
            contact=np.asarray(contact, dtype=bool),
            energy=kinematics.energy_per_mass(
                scene, arr["Y"], arr["Xdot"], arr["Ydot"], arr["thetadot"]
            ),
        )

    @classmethod
    def from_steps(
        cls,
        scene: Scene,
        timestep: float,
        state: Mapping[str, ArrayLike],
        *,
        normal_force: NDArray,
        friction_force: NDArray,
        shape: kinematics.Polygon | None = None,
    ) -> Trajectory:
        """An engine's samples, one per step of ``timestep`` s from t = 0: centre-of-mass
        states (``state``: the keys of ``kinematics.com_state``) and the contact force per
        unit mass, m/s^2, in contact where the normal force is positive (from_state)."""
        return cls.from_state(
            scene,
            t=np.arange(len(normal_force)) * timestep,
            **state,
            normal_force=normal_force,
            friction_force=friction_force,
            shape=shape,
        )

    def __len__(self) -> int:
        return len(self.t)

    def rows(self, index: slice | NDArray) -> Trajectory:
        """The samples at ``index`` (a slice gives views, an index array copies), every
        column picked alike."""
        return Trajectory(**{name: getattr(self, name)[index] for name in COLUMNS})

    def make_read_only(self) -> Trajectory:
        """Mark every column's array read-only (a trajectory shared by several readers, whom
        a write would then fail loudly); itself."""
        for name in COLUMNS:
            getattr(self, name).flags.writeable = False
        return self

    def to_frame(self) -> pd.DataFrame:
        """One row per sample, one column per variable (names as in COLUMNS)."""
        return pd.DataFrame({name: getattr(self, name) for name in COLUMNS})

    @classmethod
    def from_frame(cls, frame: pd.DataFrame) -> Trajectory:
        missing = [c for c in COLUMNS if c not in frame.columns]
        if missing:
            raise ValueError(f"trajectory table lacks columns {missing}")
        values = {c: frame[c].to_numpy() for c in COLUMNS}
        values["contact"] = values["contact"].astype(bool)
        values = {c: v if c == "contact" else v.astype(float) for c, v in values.items()}
        return cls(**values)

    def write(self, path: str | Path, *, suffix: str | None = None) -> Path:
        """Write as CSV (with a format-version comment) or Parquet, chosen by the suffix
        (``suffix`` overrides the path's, e.g. for a temporary name). Written whole: into a
        hidden temporary file renamed at the end, so that a full disk or a kill leaves the
        old file or none, never a truncated one under the name."""
        path = Path(path)
        suffix = path.suffix if suffix is None else suffix
        if suffix not in (".parquet", ".csv"):
            raise ValueError(f"trajectory file must end in .csv or .parquet, got {path.name!r}")
        return write_whole(path, lambda tmp: self._write(tmp, suffix))

    def _write(self, path: Path, suffix: str) -> None:
        frame = self.to_frame()
        if suffix == ".parquet":
            frame.attrs[FORMAT_KEY] = FORMAT_VERSION
            # No dictionary encoding: a run's floats hardly repeat, and Arrow's attempt at a
            # dictionary before falling back was 60 % of the write (a 30,000-sample run: 23
            # ms with it, 9 ms without, and 2.4 MB against 2.9; the same values read back).
            # Snappy left a run's doubles as large as they are (2.8 MB for 30,001 samples);
            # split into byte streams, a smooth signal's sign and exponent bytes repeat and
            # zstd finds them: make report's 407 trajectories 378 -> 241 MB, their writes
            # 1.6 CPU-s either way, the same values read back (Parquet's own encoding, which
            # pyarrow, DuckDB and polars read).
            frame.to_parquet(
                path,
                index=False,
                use_dictionary=False,
                compression=PARQUET_COMPRESSION,
                compression_level=PARQUET_COMPRESSION_LEVEL,
                use_byte_stream_split=[c for c in frame.columns if c != "contact"],
            )
        elif suffix == ".csv":
            with path.open("w", newline="") as fh:
                fh.write(f"# hoopbench trajectory format {FORMAT_VERSION}; SI units\n")
                frame.to_csv(fh, index=False, float_format="%.17g")

    @classmethod
    def read(cls, path: str | Path) -> Trajectory:
        """Read a file :meth:`write` wrote; an older format is migrated, a newer one refused
        (FormatVersionError, a ValueError naming both versions)."""
        path = Path(path)
        if path.suffix == ".parquet":
            frame = pd.read_parquet(path)
            recorded = frame.attrs.get(FORMAT_KEY)
        else:
            frame, recorded = pd.read_csv(path, comment="#"), _csv_version(path)
        return cls.from_frame(TRAJECTORY_FILE.upgrade(frame, recorded, str(path)))


def _csv_version(path: Path) -> int | str | None:
    """The version a CSV's first line records (the text itself when it is not a number)."""
    with path.open(newline="") as fh:
        match = _CSV_VERSION.match(fh.readline())
    if match is None:
        return None
    text = match.group(1)
    return int(text) if text.isascii() and text.isdigit() else text


COLUMNS: tuple[str, ...] = tuple(f.name for f in fields(Trajectory))
