"""The pieces every part of report.html is made of: escaped text, inert embedded data, and a
plotly figure as a page fragment.

Strings from a results folder (scene names, messages, verdict reasons) come from anyone, so
nothing reaches the page unescaped: text through :func:`text` (HTML entities; plotly shows
them as the characters), data for the page's scripts through :func:`script_json`, which
writes every ``<``, ``>`` and ``&`` as a JSON ``\\u`` escape, so that no ``</script>`` nor
``<!--`` can end or bend the ``<script>`` element that holds it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from plotly.io.json import to_json_plotly

# A value as HTML text, also for plotly's labels, which read entities: the one escape of
# every string from a results folder (reports/report/escaping.py).
from hoopbench.reports.report.escaping import escape_html as text

__all__ = ["FIGURE_CLASS", "figure_fragment", "rounded", "script_json", "text"]

FIGURE_CLASS = "hoop-figure"
"""Class of a figure's <div>; the page's script draws each one as it scrolls into view."""

SIGNIFICANT = 5
"""Significant digits of the numbers a figure draws: finer than any axis shows, and it keeps
the page small (the tables keep the stored numbers)."""


def rounded(values: Any, digits: int = SIGNIFICANT) -> list[float | None]:
    """Numbers to ``digits`` significant digits, as a JSON-ready list (NaN as None: a gap)."""
    spec = f".{digits}g"
    # Python floats (tolist), not NumPy scalars: the page rounds a million numbers or so.
    return [
        float(format(v, spec)) if math.isfinite(v) else None
        for v in np.asarray(values, dtype=float).ravel().tolist()
    ]


def script_json(data: Any) -> str:
    """JSON that is inert inside a <script> element whatever its strings hold (plotly's
    encoder: numpy arrays as lists, NaN as null)."""
    encoded = to_json_plotly(data)
    return encoded.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")


def figure_fragment(
    figure_id: str, figure: dict[str, Any], *, kind: str = "", extra: str = ""
) -> str:
    """A figure's <div> and its data (``figure``: plotly's {data, layout, frames}), drawn by
    the page's script. ``kind`` names a behaviour of the script (the map's click); ``extra``:
    more markup after the figure."""
    return (
        f'<div class="{FIGURE_CLASS}" id="{text(figure_id)}" data-kind="{text(kind)}"></div>'
        f'<script type="application/json" id="{text(figure_id)}-data">'
        f"{script_json(figure)}</script>{extra}"
    )
