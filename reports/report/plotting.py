"""The one home of the plotting backend: pyplot, imported when a figure is first drawn.

Importing matplotlib.pyplot costs about 0.2 s, and the command line and the Python API import
the report modules (reports/api.py imports report/build.py), so no module here imports
matplotlib at its top: each drawing function calls :func:`pyplot`.

The backend is chosen once, on the first call: the one MPLBACKEND names if it is set (a
Jupyter kernel sets its inline one, and switching away from it would end a notebook's figures),
else Agg (files only, no display assumed: the command line, the tests, the sweeps' workers).

:func:`plain_text` draws text as written, never as math: scene and engine names come from
results folders anyone may write, and a name such as ``x$\\frac$`` would otherwise stop a
figure with a mathtext error. A label that means math passes ``parse_math=True`` itself.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

__all__ = ["plain_text", "pyplot", "save_figure", "written_whole"]


@cache
def pyplot() -> ModuleType:
    """matplotlib.pyplot, its backend chosen on the first call (see the module's docstring)."""
    import matplotlib

    matplotlib.use(os.environ.get("MPLBACKEND") or "Agg")
    import matplotlib.pyplot as plt

    return plt


@contextmanager
def plain_text() -> Iterator[None]:
    """Within: figures' text is drawn as written, not parsed as math (the module docstring);
    matplotlib's settings are restored after, so a notebook's own figures are untouched."""
    import matplotlib

    pyplot()
    with matplotlib.rc_context({"text.parse_math": False}):
        yield


def written_whole(path: str | os.PathLike[str], write: Callable[[Path], object]) -> Path:
    """``write(tmp)`` into a hidden temporary file of the same suffix (matplotlib and Pillow
    take the format from it), then renamed to ``path``: a report killed mid-figure leaves
    the old file or none, never half a PNG under its final name."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise
    return path


def save_figure(fig: Any, path: str | os.PathLike[str], **savefig: Any) -> Path:
    """``fig.savefig(path, **savefig)``, written whole (:func:`written_whole`)."""
    return written_whole(path, lambda tmp: fig.savefig(tmp, **savefig))
