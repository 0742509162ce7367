"""A results folder is input from anyone: every file of it is read through this module.

A folder may come from a colleague, a cluster or a download, so a file where a reader expects
one may be a symbolic link to a file outside the folder (whose numbers would then be shown as
the folder's), a FIFO or a device (a read that never ends, or never stops: ``/dev/zero``), a
folder, or a file far larger than any sweep writes. Every reader of a results folder (runs/,
meta.json, sweep.json, suite.toml, map.toml, display/, trajectories/) asks here first:

- :func:`folder_file` checks that a file of the folder is a regular file inside the folder
  (after following links) and no larger than the cap for its kind, and returns its path;
- :func:`read_folder_bytes` / :func:`read_folder_text` read it, checked the same way on the
  opened file (a file swapped between the check and the read is caught too);
- :func:`read_input_file` reads a file the user named (a suite file): any place, but a
  regular file under the cap.

Each refusal is a :class:`FolderFileError` (a ValueError) naming the file and the reason.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

__all__ = [
    "MAX_DATA_BYTES",
    "MAX_TEXT_BYTES",
    "FolderFileError",
    "folder_file",
    "folder_files",
    "read_folder_bytes",
    "read_folder_text",
    "read_input_file",
]

MAX_TEXT_BYTES = 64 << 20
"""meta.json, sweep.json, suite.toml, map.toml: a suite at the run limit (100,000 runs) is a
few MB of TOML; 64 MiB is past any file a sweep writes and far below what fills a machine."""
MAX_DATA_BYTES = 4 << 30
"""A Parquet file of runs/, display/ or trajectories/: a whole trajectory at the smallest
step a run allows is a few hundred MB."""


class FolderFileError(ValueError):
    """A file of a results folder (or one the user named) that is not one to read."""


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def _check_stat(path: Path, info: os.stat_result, cap: int) -> None:
    if not stat.S_ISREG(info.st_mode):
        raise FolderFileError(f"{path} is {_kind(info.st_mode)}, not a file: not read")
    if info.st_size > cap:
        raise FolderFileError(
            f"{path} holds {info.st_size:,} bytes, more than the {cap:,} a sweep writes: not read"
        )


def _inside(folder: Path, path: Path) -> None:
    """FolderFileError if ``path`` (links followed) leads out of ``folder``."""
    try:
        real, root = path.resolve(strict=False), folder.resolve(strict=False)
    except (OSError, RuntimeError) as exc:  # a loop of links
        raise FolderFileError(f"{path} cannot be followed: {exc}") from None
    if not real.is_relative_to(root):
        raise FolderFileError(
            f"{path} leads out of the results folder {folder} (to {real}): not read"
        )


def folder_file(
    folder: str | os.PathLike[str], relative: str | os.PathLike[str], cap: int = MAX_TEXT_BYTES
) -> Path | None:
    """The path of ``folder/relative`` if it is a regular file inside ``folder`` of at most
    ``cap`` bytes; None if nothing is there; FolderFileError otherwise."""
    folder = Path(folder)
    path = folder / relative
    _inside(folder, path)
    try:
        info = path.stat()
    except FileNotFoundError:
        return None
    except OSError as exc:
        raise FolderFileError(f"{path} cannot be read: {exc.strerror or exc}") from None
    _check_stat(path, info, cap)
    return path


def folder_files(
    folder: str | os.PathLike[str], subfolder: str, suffix: str, cap: int = MAX_DATA_BYTES
) -> list[Path]:
    """Every ``*suffix`` file of ``folder/subfolder`` that a reader would take (names not
    starting with ``.`` or ``_``, as pyarrow skips), each checked as :func:`folder_file`."""
    folder = Path(folder)
    where = folder / subfolder
    _inside(folder, where)
    names = sorted(p.name for p in where.iterdir()) if where.is_dir() else []
    found = []
    for name in names:
        if name.startswith((".", "_")) or not name.endswith(suffix):
            continue
        path = folder_file(folder, Path(subfolder) / name, cap)
        if path is not None:
            found.append(path)
    return found


def _read_opened(path: Path, cap: int) -> bytes:
    """The bytes of ``path``, opened without blocking (a FIFO put there after the check) and
    checked again once open."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise FolderFileError(f"{path} cannot be read: {exc.strerror or exc}") from None
    try:
        _check_stat(path, os.fstat(fd), cap)
        chunks, size = [], 0
        while chunk := os.read(fd, 1 << 20):
            chunks.append(chunk)
            size += len(chunk)
            if size > cap:
                raise FolderFileError(f"{path} grew past {cap:,} bytes while read: not read")
        return b"".join(chunks)
    except OSError as exc:
        raise FolderFileError(f"{path} cannot be read: {exc.strerror or exc}") from None
    finally:
        os.close(fd)


def read_folder_bytes(
    folder: str | os.PathLike[str], relative: str | os.PathLike[str], cap: int = MAX_TEXT_BYTES
) -> bytes | None:
    """The bytes of ``folder/relative`` (:func:`folder_file`'s checks); None if it is not
    there."""
    path = folder_file(folder, relative, cap)
    return None if path is None else _read_opened(path, cap)


def _decoded(path: Path, data: bytes) -> str:
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FolderFileError(f"{path} is not UTF-8 text (byte {exc.start})") from None


def read_folder_text(
    folder: str | os.PathLike[str], relative: str | os.PathLike[str], cap: int = MAX_TEXT_BYTES
) -> str | None:
    """The UTF-8 text of ``folder/relative``; None if it is not there."""
    data = read_folder_bytes(folder, relative, cap)
    return None if data is None else _decoded(Path(folder) / relative, data)


def read_input_file(path: str | os.PathLike[str], cap: int = MAX_TEXT_BYTES) -> bytes:
    """The bytes of a file the user named (anywhere): a regular file of at most ``cap`` bytes.
    FileNotFoundError if it is not there; FolderFileError if it is no file to read."""
    path = Path(path)
    info = path.stat()  # FileNotFoundError, as open() would raise it
    _check_stat(path, info, cap)
    return _read_opened(path, cap)
