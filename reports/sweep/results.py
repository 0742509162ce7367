"""The results directory of a suite run, safe to read while the suite is still writing it.

A sweep left running overnight must not lose what it has done when it is interrupted, killed
or runs out of disk, and its results must be readable at any moment (``pandas.read_parquet``
on ``DIR/runs`` mid-sweep). Hence:

* ``DIR/runs/`` is a Parquet *dataset*: one small part file per flush, appended, never
  rewritten. Every file is written under a temporary name that readers ignore (pyarrow skips
  names starting with ``.`` or ``_``) and then renamed, so a reader sees whole files only.
* A resumed sweep appends new rows for the run_ids it runs again; every row carries a
  sequence number ``seq``, increasing across sessions, so "the latest row of a run" is
  well defined (:func:`read_runs`).
* pyarrow takes a dataset's schema from its first file (in path order), so ``0-schema.parquet``,
  an empty table with the union of every part's columns, sorts first and is rewritten
  *before* a part with a new column or a wider type is written. Old parts are then read
  through it: missing columns come back as nulls, int64 widens to float64 and, when the types
  of a column disagree in ways Arrow cannot promote, the column becomes text.
* ``runs.csv`` (plain CSV, header on line 1) and ``meta.json`` are written once the sweep has
  finished, from the latest row of every run.
* ``meta.json`` records the version of the rows' layout (:data:`FORMAT_KEY`), which
  :func:`read_table` checks against the table kind's ``FileFormat`` (models/formats.py): a
  newer version is refused, an older one migrated. A folder without it (a sweep still
  running, or interrupted) counts as the oldest version: migrations leave current rows alone.
"""

from __future__ import annotations

import dataclasses
import enum
import json
import os
import platform
import subprocess
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError
from importlib.metadata import version as package_version
from pathlib import Path, PurePath
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.dataset as ds
import pyarrow.parquet as pq

from hoopbench.models.formats import FileFormat
from hoopbench.models.whole_files import write_whole
from hoopbench.reports.sweep.folder_files import FolderFileError, folder_files, read_folder_text

__all__ = [
    "BOOKKEEPING_COLUMNS",
    "CSV_NAME",
    "FORMAT_KEY",
    "META_NAME",
    "RUNS_NAME",
    "SCHEMA_FILE",
    "TIMING_COLUMNS",
    "RunsWriter",
    "atomic_write",
    "environment_meta",
    "leftover_temp_files",
    "load_average",
    "read_runs",
    "read_table",
    "recorded_format_version",
    "resumed_format_version",
    "stored_statuses",
    "with_columns",
    "write_csv",
    "write_meta",
]

RUNS_NAME = "runs"
"""The Parquet dataset folder inside the results directory."""
CSV_NAME = "runs.csv"
META_NAME = "meta.json"
FORMAT_KEY = "runs_format_version"
"""meta.json's key for the version of the rows' layout (the table kind's FileFormat.version)."""
SCHEMA_FILE = "0-schema.parquet"
"""Empty table holding the dataset's schema; its name sorts before every part ('part-...')."""
TEMP_SUFFIX = ".tmp"

TIMING_COLUMNS = ("seq", "finished_at", "elapsed_s", "attempts")
"""Columns the runner adds that differ between two runs of the same suite."""
BOOKKEEPING_COLUMNS = ("run_id", "status", "message", *TIMING_COLUMNS)
"""Columns the runner always sets: the first three lead every row, the timing ones end it."""

_BASE_SCHEMA = pa.schema(
    [
        ("run_id", pa.string()),
        ("status", pa.string()),
        ("message", pa.string()),
        ("seq", pa.int64()),
        ("finished_at", pa.timestamp("us", tz="UTC")),
        ("elapsed_s", pa.float64()),
        ("attempts", pa.int64()),
    ]
)


# --------------------------------------------------------------------------- atomic files
def temp_path(path: Path) -> Path:
    """The temporary name ``path`` is written under: hidden (readers skip it), per process."""
    return path.with_name(f".{path.name}.{os.getpid()}{TEMP_SUFFIX}")


def atomic_write(path: str | os.PathLike[str], write: Callable[[Path], object]) -> Path:
    """Call ``write(tmp)`` to fill a temporary file (its return value is ignored), flush it to
    disk, rename it to ``path``.

    A reader sees the old file or the new one, never half of one. If ``write`` fails, the
    temporary file is removed when possible (a crash leaves it: :func:`leftover_temp_files`).
    """
    return write_whole(path, write, tmp=temp_path(Path(path)), sync=True)


def leftover_temp_files(out_dir: str | os.PathLike[str]) -> list[Path]:
    """Temporary files left by an interrupted write in the results directory or its dataset."""
    out = Path(out_dir)
    found: list[Path] = []
    for folder in (out, out / RUNS_NAME):
        if folder.is_dir():
            found.extend(
                p
                for p in folder.iterdir()
                if p.name.startswith(".") and p.name.endswith(TEMP_SUFFIX)
            )
    return sorted(found)


# --------------------------------------------------------------------------- values and types
def _plain(value: Any) -> Any:
    """A value Arrow stores as a scalar: enums by value, numpy scalars as Python ones, nested
    containers as JSON text (their keys vary from row to row; a struct column would not)."""
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, PurePath):
        return str(value)
    if isinstance(value, Mapping | list | tuple | set | frozenset | np.ndarray):
        if isinstance(value, set | frozenset):
            value = sorted(value, key=repr)
        elif isinstance(value, np.ndarray):
            value = value.tolist()
        return json.dumps(value, default=str, allow_nan=True)
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return json.dumps(dataclasses.asdict(value), default=str, allow_nan=True)
    return value


def _array(values: list[Any]) -> pa.Array:
    """One column; values Arrow cannot put in one type (e.g. text and numbers) become text."""
    try:
        return pa.array(values)
    except (pa.ArrowInvalid, pa.ArrowTypeError, OverflowError):
        return pa.array([None if v is None else str(v) for v in values], pa.string())


def _wider(old: pa.DataType, new: pa.DataType) -> pa.DataType:
    """The type both ``old`` and ``new`` values are read as (text when Arrow cannot promote)."""
    if old == new:
        return old
    try:
        merged = pa.unify_schemas(
            [pa.schema([("c", old)]), pa.schema([("c", new)])], promote_options="permissive"
        )
        return merged.field("c").type
    except (pa.ArrowInvalid, pa.ArrowTypeError, pa.ArrowNotImplementedError):
        return pa.string()


def _ordered(names: Iterable[str]) -> list[str]:
    """run_id, status, message first; the worker's columns in order; timing columns last."""
    names = list(dict.fromkeys(names))
    middle = [n for n in names if n not in BOOKKEEPING_COLUMNS]
    return ["run_id", "status", "message", *middle, *TIMING_COLUMNS]


# --------------------------------------------------------------------------- writing
class RunsWriter:
    """Appends rows to ``DIR/runs`` as small Parquet parts; see the module docstring.

    Keeps only the rows not yet flushed: the parent's memory does not grow with the sweep.
    """

    def __init__(self, runs_dir: str | os.PathLike[str]) -> None:
        self.runs_dir = Path(runs_dir)
        if not self.runs_dir.is_dir():
            self._create()
        self._schema = self._stored_schema()
        self._next_seq = self._stored_max_seq() + 1
        self._session = f"{datetime.now(UTC):%Y%m%dT%H%M%S%fZ}-{os.getpid()}"
        self._parts = 0
        self._buffer: list[dict[str, Any]] = []
        self.rows_written = 0
        self._write_schema()

    def _create(self) -> None:
        """The folder appears with its schema file in it: never an empty dataset to read."""
        tmp = temp_path(self.runs_dir)
        tmp.mkdir(parents=True)
        atomic_write(tmp / SCHEMA_FILE, lambda t: pq.write_table(_BASE_SCHEMA.empty_table(), t))
        os.replace(tmp, self.runs_dir)

    def _parts_paths(self) -> list[Path]:
        return sorted(p for p in self.runs_dir.glob("*.parquet") if p.name != SCHEMA_FILE)

    def _stored_schema(self) -> pa.Schema:
        schema = _BASE_SCHEMA
        anchor = self.runs_dir / SCHEMA_FILE
        stored = [pq.read_schema(anchor)] if anchor.exists() else []
        if not stored:  # no anchor (written by hand?): every part's own schema
            stored = [pq.read_schema(p) for p in self._parts_paths()]
        for other in stored:
            schema = self._merge(schema, other)
        return schema

    def _stored_max_seq(self) -> int:
        if not self._parts_paths():
            return 0
        table = ds.dataset(self.runs_dir, format="parquet").to_table(columns=["seq"])
        top = pc.max(table["seq"]).as_py()
        return int(top) if top is not None else 0

    @staticmethod
    def _merge(schema: pa.Schema, other: pa.Schema) -> pa.Schema:
        types = {f.name: f.type for f in schema}
        for f in other:
            types[f.name] = _wider(types[f.name], f.type) if f.name in types else f.type
        return pa.schema([(name, types[name]) for name in _ordered([*schema.names, *types])])

    def _write_schema(self) -> None:
        anchor = self.runs_dir / SCHEMA_FILE
        if anchor.exists() and pq.read_schema(anchor).remove_metadata() == self._schema:
            return
        atomic_write(anchor, lambda tmp: pq.write_table(self._schema.empty_table(), tmp))

    def add(self, row: Mapping[str, Any]) -> int:
        """Buffer one row (it must hold run_id and status); return its sequence number."""
        seq = self._next_seq
        self._next_seq += 1
        self._buffer.append({**row, "seq": seq})
        return seq

    @property
    def buffered(self) -> int:
        return len(self._buffer)

    def flush(self) -> Path | None:
        """Write the buffered rows as one part file; None if there were none."""
        if not self._buffer:
            return None
        rows = self._buffer
        names = _ordered(name for row in rows for name in row)
        arrays = {n: _array([_plain(row.get(n)) for row in rows]) for n in names}
        table = pa.table(arrays)
        schema = self._merge(self._schema, table.schema)
        if schema != self._schema:
            # The anchor first: a part is never wider than the schema readers take.
            self._schema = schema
            self._write_schema()
        columns = [
            arrays[f.name].cast(f.type) if f.name in arrays else pa.nulls(len(rows), f.type)
            for f in schema
        ]
        part = pa.Table.from_arrays(columns, schema=schema)
        self._parts += 1
        path = self.runs_dir / f"part-{self._session}-{self._parts:06d}.parquet"
        atomic_write(path, lambda tmp: pq.write_table(part, tmp))
        self._buffer = []
        self.rows_written += len(rows)
        return path


# --------------------------------------------------------------------------- reading
def _dataset(out_dir: str | os.PathLike[str]) -> ds.Dataset:
    runs = Path(out_dir) / RUNS_NAME
    if not runs.is_dir():
        raise FileNotFoundError(f"no results dataset at {runs}")
    # each file checked (inside the folder, a regular file): pyarrow would read any
    return ds.dataset(folder_files(out_dir, RUNS_NAME, ".parquet"), format="parquet")


def read_runs(
    out_dir: str | os.PathLike[str],
    *,
    latest: bool = True,
    columns: Sequence[str] | None = None,
) -> pd.DataFrame:
    """The rows stored in ``out_dir/runs``, in the order they were written.

    With ``latest`` (the default) only the last row of each run_id is kept: a resumed sweep
    appends a new row for every run it tries again. ``columns`` reads only those (run_id and
    seq come too). Safe to call while a sweep is writing.
    """
    dataset = _dataset(out_dir)
    wanted = None if columns is None else list(dict.fromkeys(["run_id", *columns, "seq"]))
    if "seq" not in dataset.schema.names:  # no file at all (schema file removed by hand)
        return pd.DataFrame(columns=list(BOOKKEEPING_COLUMNS) if wanted is None else wanted)
    if "run_id" not in dataset.schema.names:  # no sweep writes it so: the folder is not ours
        raise ValueError(f"{Path(out_dir) / RUNS_NAME}: the table has no run_id column")
    try:
        frame = dataset.to_table(columns=wanted).to_pandas()
    except pa.ArrowException as exc:  # a part no sweep wrote: name the folder it is in
        raise ValueError(f"{Path(out_dir) / RUNS_NAME}: {exc}") from None
    frame = frame.sort_values("seq", kind="stable")
    if latest:
        frame = frame.drop_duplicates("run_id", keep="last")
    return frame.reset_index(drop=True)


def with_columns(frame: pd.DataFrame, names: Iterable[str]) -> pd.DataFrame:
    """A new frame: ``frame`` with each of ``names`` it lacks added at the end, all empty."""
    missing = [n for n in dict.fromkeys(names) if n not in frame.columns]
    # In one block: a column at a time fragments the frame (pandas' PerformanceWarning past
    # a hundred, as a map's few stored columns grow to MAP_COLUMNS).
    empty = pd.DataFrame(dict.fromkeys(missing, None), index=frame.index, dtype=object)
    return pd.concat([frame, empty], axis=1) if missing else frame.copy()


def recorded_format_version(out_dir: str | os.PathLike[str]) -> object:
    """The format version ``out_dir/meta.json`` records; None without one (no meta.json yet:
    a sweep still running or interrupted). ValueError for a meta.json that is not a JSON
    object."""
    path = Path(out_dir) / META_NAME
    try:
        text = read_folder_text(out_dir, META_NAME)
    except FolderFileError:
        raise
    except (OSError, ValueError) as exc:
        raise ValueError(f"{path} is unreadable: {exc}") from None
    if text is None:
        return None
    try:
        meta = json.loads(text)
    except ValueError as exc:
        raise ValueError(f"{path} is unreadable: {exc}") from None
    if not isinstance(meta, dict):
        raise ValueError(f"{path} is unreadable: not a JSON object but {meta!r:.40}")
    return meta.get(FORMAT_KEY)


def read_table(
    out_dir: str | os.PathLike[str], table: FileFormat, *, latest: bool = True
) -> pd.DataFrame:
    """:func:`read_runs` in the current layout of ``table``: meta.json's version checked
    (FormatVersionError, a ValueError, for a newer one), an older table migrated."""
    recorded = recorded_format_version(out_dir)
    table.version_of(recorded, str(out_dir))  # refused before anything is read
    return table.upgrade(read_runs(out_dir, latest=latest), recorded, str(out_dir))


def resumed_format_version(out_dir: str | os.PathLike[str], table: FileFormat) -> int:
    """The version to record for a sweep resumed into ``out_dir``: the current one for a
    folder without rows; else the stored one, kept when older (the folder then holds rows of
    both: the migrations leave the new ones alone) and the oldest when none is recorded.
    FormatVersionError for a newer one: an older hoopbench must not append to it."""
    if not (Path(out_dir) / RUNS_NAME).is_dir():
        return table.version
    return table.version_of(recorded_format_version(out_dir), str(out_dir))


def stored_statuses(out_dir: str | os.PathLike[str]) -> dict[str, str]:
    """run_id -> status of its latest row ({} when nothing is stored yet)."""
    if not (Path(out_dir) / RUNS_NAME).is_dir():
        return {}
    frame = read_runs(out_dir, columns=["status"])
    return dict(zip(frame["run_id"], frame["status"], strict=True))


def write_csv(frame: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Plain CSV: the header on line 1, no comment lines, empty cells for missing values."""
    return atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False))


def write_meta(meta: Mapping[str, Any], path: str | os.PathLike[str]) -> Path:
    text = json.dumps(meta, indent=2, default=str, allow_nan=True) + "\n"
    return atomic_write(path, lambda tmp: tmp.write_text(text))


# --------------------------------------------------------------------------- metadata
def _git_commit() -> str | None:
    try:
        done = subprocess.run(
            ["git", "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10, check=False
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return (done.stdout.strip() or None) if done.returncode == 0 else None


def _cpu_model() -> str | None:
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as f:
            for line in f:
                key, _, value = line.partition(":")
                if key.strip() in ("model name", "Hardware", "Processor"):
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or None


def _hoopbench_version() -> str | None:
    try:
        return package_version("hoopbench")
    except PackageNotFoundError:
        return None


def load_average() -> list[float] | None:
    """The machine's load average over the last 1, 5 and 15 minutes (``os.getloadavg``:
    runnable processes, all users'), kept in meta.json's ``session`` at the sweep's start and
    end: the wall times of its runs grow with it, their CPU times far less. None where the
    system gives none."""
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (AttributeError, OSError):
        return None


def environment_meta(argv: Sequence[str] | None = None) -> dict[str, Any]:
    """Where and how the sweep ran: versions, commit, machine, command line."""
    return {
        "hoopbench_version": _hoopbench_version(),
        "git_commit": _git_commit(),
        "python": sys.version.split()[0],
        "python_implementation": platform.python_implementation(),
        "platform": platform.platform(),
        "cpu_model": _cpu_model(),
        "cpu_count": os.cpu_count(),
        "argv": list(sys.argv if argv is None else argv),
    }
