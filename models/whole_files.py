"""Files written whole: into a hidden temporary file beside the target, then renamed onto it.

A reader (or a process killed mid-write) sees the old file or the new one, never half of
one; the new one keeps the permissions of the one it replaces (a file the user made private
stays private). One statement of the rule for the trajectory files (models), the results tables and
report.html (reports/sweep) and the report's figures (reports/report): here, below every
other room, so that all of them share it.
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Callable
from pathlib import Path

__all__ = ["write_whole"]


def write_whole(
    path: str | os.PathLike[str],
    write: Callable[[Path], object],
    *,
    tmp: Path | None = None,
    sync: bool = False,
) -> Path:
    """Call ``write(tmp)`` to fill the temporary file ``tmp`` (default: hidden, per process,
    the target's name plus ``.tmp``), flush it to disk if ``sync``, rename it to ``path``.
    If ``write`` fails, the temporary file is removed when possible and the error raised.
    The file keeps the permission bits of the regular file it replaces, if any."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp") if tmp is None else tmp
    try:
        replaced = os.stat(path)
    except OSError:
        replaced = None
    try:
        write(tmp)
        if replaced is not None and stat.S_ISREG(replaced.st_mode):
            os.chmod(tmp, stat.S_IMODE(replaced.st_mode))
        if sync:
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path
