"""Versions of the stored tables' layouts: what a file's recorded version means on reading.

Every stored table kind (a results folder's runs table, a hop map's, a trajectory file) has a
:class:`FileFormat`: the version written now, the version a file that records none counts as
(it was written before versions were recorded), and one migration per older version. Reading
checks the recorded version: a newer one is refused (:class:`FormatVersionError`, one line
naming both versions), an older one is brought to the current layout by its migrations, in
order. This is the one place where old tables are patched.

Here, below every other room, so that the trajectory files (models) and the runs tables
(reports) share it.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import pandas as pd

__all__ = ["FileFormat", "FormatVersionError", "Migration"]

Migration = Callable[[pd.DataFrame], pd.DataFrame]
"""Takes a table in one version's layout to the next version's, as a new frame."""


class FormatVersionError(ValueError):
    """A stored table this hoopbench cannot read: a format version newer than it knows, older
    than its oldest migration, or not a version at all."""


@dataclass(frozen=True)
class FileFormat:
    """One stored table kind's versions: see the module docstring."""

    what: str
    """What the files are, for messages: 'runs table', 'trajectory file'."""
    version: int
    """The version written now."""
    oldest: int
    """The version of a file that records none (the oldest this hoopbench reads)."""
    migrations: Mapping[int, Migration] = field(default_factory=dict)
    """k -> the migration from version k to k + 1, for every k from ``oldest`` to
    ``version - 1``. Each must leave rows already in the newer layout as they are: a resumed
    results folder keeps the oldest version it holds, and holds newer rows too."""

    def __post_init__(self) -> None:
        missing = [k for k in range(self.oldest, self.version) if k not in self.migrations]
        if missing:  # a version bump without its migration: caught on import
            raise ValueError(f"{self.what} format {self.version} lacks migrations from {missing}")
        object.__setattr__(self, "migrations", MappingProxyType(dict(self.migrations)))

    def version_of(self, recorded: object, source: str) -> int:
        """The version of a file that records ``recorded`` (None: none recorded, the oldest);
        FormatVersionError, naming ``source``, for one this hoopbench cannot read."""
        if recorded is None:
            return self.oldest
        if isinstance(recorded, bool) or not isinstance(recorded, int):
            raise FormatVersionError(
                f"{source}: {self.what} format version must be a whole number, got {recorded!r}"
            )
        if recorded > self.version:
            raise FormatVersionError(
                f"{source}: {self.what} format version {recorded} is newer than this "
                f"hoopbench's {self.version}: use a newer hoopbench"
            )
        if recorded < self.oldest:
            raise FormatVersionError(
                f"{source}: {self.what} format version {recorded} is older than the oldest "
                f"this hoopbench reads ({self.oldest})"
            )
        return recorded

    def upgrade(self, frame: pd.DataFrame, recorded: object, source: str) -> pd.DataFrame:
        """``frame``, stored as version ``recorded``, in the current layout (see
        :meth:`version_of` for what is refused)."""
        for k in range(self.version_of(recorded, source), self.version):
            frame = self.migrations[k](frame)
        return frame
