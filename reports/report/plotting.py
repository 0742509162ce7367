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

import os
from collections.abc import Iterator
from contextlib import contextmanager
from functools import cache
from types import ModuleType

__all__ = ["plain_text", "pyplot"]


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
