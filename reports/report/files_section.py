"""The report's Files section: what its folder holds, read from the folder itself.

The section lists the files present when report.md is written (its figures, the animation,
the results folders inside it and what each holds) and the two the report writes around it
(report.md itself and report.html, written from it), each as a relative link, with sizes: a
report folder is mostly its default suite's trajectories (461 MB of which 438 MB were
``default/trajectories/`` in one ``make report``), and the section says so and how to keep
the folder small. Results folders outside the report's folder (the shipped searches, a bench)
are listed as links alone.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from urllib.parse import quote

from hoopbench.reports.report.escaping import escape_text
from hoopbench.reports.report.hoop_gif import GIF_SCENE

__all__ = ["FILE_ROLES", "PAGE_NAME", "files_section", "folder_bytes"]

PAGE_NAME = "report.html"
"""The page the report writes from report.md, once report.md is written (page.py)."""

FILE_ROLES = {
    "report.md": "this report",
    PAGE_NAME: "the same report as one page to explore; its figures are embedded, so it "
    "opens alone",
    f"{GIF_SCENE}.gif": f"{GIF_SCENE} animated, the exact hoop beside each engine's",
    "runs.csv": "the rows, one per run, one column per variable (docs/report.md, The runs table)",
    "runs": "the same rows as a Parquet dataset, readable while a sweep runs",
    "trajectories": "each stored run's trajectory at every step (Parquet, one file a run)",
    "suite.toml": "the suite as run",
    "meta.json": "versions, machine, load, command line, counts per status",
    "sweep.json": "the kind of sweep and the sha256 of its files (what --resume checks)",
    "map.toml": "the map's settings",
    "map.md": "the map's own report",
    "display": "each map run's curves, thinned, for the page's clicked cells",
    "tune.json": "the search's settings",
    "front.csv": "its Pareto front",
    "trials.csv": "its trials",
    "settings.toml": "the front's settings, for --settings",
}
"""What a file or folder of a report's folder is, by its name (names not here are listed bare)."""

_FIGURE_SUFFIXES = (".png",)
"""Files listed together, as the report's figures, rather than one line each."""


def folder_bytes(folder: Path) -> tuple[int, int]:
    """(bytes, files) under ``folder``, links not followed (a link counts as itself)."""
    total = count = 0
    for root, _, names in os.walk(folder):
        for name in names:
            total += os.lstat(os.path.join(root, name)).st_size
            count += 1
    return total, count


def _data_bytes(out: Path) -> int:
    """The bytes under ``out`` but report.md's and report.html's (a report --force writes over
    them: their old sizes are no part of what this report holds)."""
    total, _ = folder_bytes(out)
    own = [out / name for name in ("report.md", PAGE_NAME)]
    return total - sum(p.lstat().st_size for p in own if p.is_file())


def _size(n_bytes: int) -> str:
    """A size as people read it (MB = 10^6 bytes, as du -h --si and file managers)."""
    if n_bytes >= 10**9:
        return f"{n_bytes / 1e9:.1f} GB"
    if n_bytes >= 10**6:
        return f"{n_bytes / 1e6:.0f} MB" if n_bytes >= 10**7 else f"{n_bytes / 1e6:.1f} MB"
    return f"{n_bytes / 1e3:.0f} kB" if n_bytes >= 10**3 else f"{n_bytes} bytes"


def _link(name: str, target: str) -> str:
    """A Markdown link to a path relative to the report (the name is data: escaped)."""
    return f"[{escape_text(name)}]({quote(target)})"


def _role(name: str) -> str:
    role = FILE_ROLES.get(name)
    return f": {role}" if role else ""


def _entry(path: Path, out: Path) -> str:
    """One file or folder under ``out``: its name linked (relative to ``out``), size, role."""
    target = path.relative_to(out).as_posix()
    if path.is_dir() and not path.is_symlink():
        n_bytes, count = folder_bytes(path)
        link = _link(path.name + "/", target + "/")
        return f"{link} ({count} files, {_size(n_bytes)}){_role(path.name)}"
    return f"{_link(path.name, target)} ({_size(path.lstat().st_size)}){_role(path.name)}"


def _results_lines(folder: Path, out: Path) -> list[str]:
    """A results folder inside ``out``: a line for it, and one under it for each entry."""
    n_bytes, _ = folder_bytes(folder)
    target = folder.relative_to(out).as_posix() + "/"
    lines = [f"- {_link(target, target)} ({_size(n_bytes)}): results read by this report"]
    for path in sorted(folder.iterdir()):
        if not path.name.startswith("."):  # the sweep's lock
            lines.append(f"  - {_entry(path, out)}")
    return lines


def _inside(path: Path, folder: Path) -> bool:
    return path.resolve().is_relative_to(folder.resolve())


def _own_lines(out: Path, results: Sequence[Path]) -> list[str]:
    """The files of ``out`` itself (not of a results folder in it): report.md and report.html
    (written around this section), other files one line each, the figures on one line."""
    inside = {f.resolve() for f in results}
    present = [
        p for p in sorted(out.iterdir()) if not p.name.startswith(".") and p.resolve() not in inside
    ]
    lines = []
    for name in ("report.md", PAGE_NAME):
        lines.append(f"- {_link(name, name)}{_role(name)}")
    figures = [p for p in present if p.suffix in _FIGURE_SUFFIXES and p.is_file()]
    for path in present:
        if path.name in {"report.md", PAGE_NAME} or path in figures:
            continue
        lines.append(f"- {_entry(path, out)}")
    if figures:
        drawn = sum(p.lstat().st_size for p in figures)
        links = ", ".join(_link(p.name, p.name) for p in figures)
        lines.append(
            f"- {len(figures)} figures (PNG, {_size(drawn)}), shown in this report: {links}"
        )
    return lines


def _trajectory_note(out: Path, results: Sequence[Path]) -> list[str]:
    """Where the folder's bytes are, when trajectories are most of them, and how to keep it
    small: the figures drawn from them are in report.md's PNGs and report.html already."""
    stored = [f / "trajectories" for f in results if (f / "trajectories").is_dir()]
    if not stored:
        return []
    total = _data_bytes(out)
    held = sum(folder_bytes(f)[0] for f in stored)
    where = ", ".join(f.relative_to(out).as_posix() + "/" for f in stored)
    return [
        "",
        f"The trajectories ({where}) are {_size(held)} of the folder's {_size(total)}. The "
        "figures drawn from them (paths, events, contact forces, the animation) are in this "
        "report's PNGs and in report.html already: they are needed only to draw the report "
        "again (`hoopbench report`). To keep the folder small, delete them once the report is "
        "made, or run the suite without `--trajectories` (the figures drawn from them are then "
        "left out); `make report` stores the default suite's with `--trajectories default`.",
    ]


def files_section(out: Path, results: Sequence[Path] = ()) -> str:
    """The Files section of the report written into ``out`` from the results folders
    ``results`` (suites, maps, searches, a bench), read from the disk as it is when report.md
    is written: call it after every figure is drawn."""
    out = Path(out)
    results = [Path(r) for r in results]
    inner = [r for r in results if r.is_dir() and _inside(r, out) and r.resolve() != out.resolve()]
    outer = [r for r in results if r not in inner and r.resolve() != out.resolve()]
    lines = [
        "## Files",
        "",
        f"This folder holds {_size(_data_bytes(out))} besides report.md and report.html; each "
        "link below is relative to it.",
        "",
        *_own_lines(out, inner),
    ]
    for folder in inner:
        lines += _results_lines(folder, out)
    if outer:
        links = ", ".join(
            _link(os.path.relpath(r, out) + "/", os.path.relpath(r, out) + "/") for r in outer
        )
        lines += ["", f"Results read from outside this folder: {links}."]
    own = [r for r in results if r.resolve() == out.resolve()]  # a report into its results
    lines += _trajectory_note(out, [*own[:1], *inner])
    return "\n".join(lines) + "\n"
