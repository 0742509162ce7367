"""The one home of the plotting backend: pyplot, imported when a figure is first drawn.

Importing matplotlib.pyplot costs about 0.2 s, and the command line and the Python API import
the report modules (reports/api.py imports report/build.py), so no module here imports
matplotlib at its top: each drawing function calls :func:`pyplot`.

The backend is chosen once, on the first call: the one MPLBACKEND names if it is set (a
Jupyter kernel sets its inline one, and switching away from it would end a notebook's figures),
else Agg (files only, no display assumed: the command line, the tests, the sweeps' workers).
"""

from __future__ import annotations

import os
from functools import cache
from types import ModuleType

__all__ = ["pyplot"]


@cache
def pyplot() -> ModuleType:
    """matplotlib.pyplot, its backend chosen on the first call (see the module's docstring)."""
    import matplotlib

    matplotlib.use(os.environ.get("MPLBACKEND") or "Agg")
    import matplotlib.pyplot as plt

    return plt
