"""The one home of the plotting backend: pyplot, imported when a figure is first drawn.

Importing matplotlib.pyplot costs about 0.2 s, and the command line and the Python API import
the report modules (reports/api.py imports report/build.py), so no module here imports
matplotlib at its top: each drawing function calls :func:`pyplot`.

The backend is chosen once, on the first call: the one MPLBACKEND names if it is set (a
Jupyter kernel sets its inline one, and switching away from it would end a notebook's figures),
else Agg (files only, no display assumed: the command line, the tests, the sweeps' workers).

:func:`plain_text` draws text as written, never as math: scene and engine names come from
results folders anyone may write, and a name such as ``x$\\frac$`` would otherwise stop a
figure with a mathtext error. A label that means math passes ``parse_math=True`` itself. So
that the tick labels of log axes, which matplotlib writes as math, still read as numbers, every
figure is written by :func:`save`, which turns them into plain text (``10⁻⁶``).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

from hoopbench.models.whole_files import write_whole
from hoopbench.reports.report.glyph_cache import with_kept_glyphs
from hoopbench.reports.report.log_ticks import readable_log_axes
from hoopbench.reports.sweep.control_chars import visible_controls

__all__ = [
    "Draw",
    "draw_now",
    "laid_out",
    "plain_text",
    "plain_tick_label",
    "pyplot",
    "save",
    "written_whole",
]

Draw = Callable[..., object]
"""Where a report section's figure is drawn: called with the drawing function and its
arguments (the report's FigurePool.submit draws it beside its other work; :func:`draw_now`
here, now)."""


def draw_now(function: Callable[..., Path], *args: object) -> Path:
    """Draw a figure here and now: ``function(*args)``."""
    return function(*args)


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


_SUPERSCRIPT = str.maketrans("0123456789-−.", "⁰¹²³⁴⁵⁶⁷⁸⁹⁻⁻·")
_MATH_LABEL = re.compile(r"\$\\mathdefault\{(?P<body>.*)\}\$")
_POWER = re.compile(r"\^\{(?P<exponent>[^}]*)\}")


def plain_tick_label(label: str) -> str:
    """A tick label matplotlib writes as math (``$\\mathdefault{2\\times10^{-6}}$``) as plain
    text (``2×10⁻⁶``), which :func:`plain_text` draws as written; any other label unchanged."""
    match = _MATH_LABEL.fullmatch(label)
    if match is None:
        return label
    body = match["body"].replace("\\times", "×").replace("\\cdot", "·")
    return _POWER.sub(lambda m: m["exponent"].translate(_SUPERSCRIPT), body)


def _plain_formatter(formatter: Any) -> Any:
    """``formatter``, its tick labels passed through :func:`plain_tick_label` and their
    control characters as their codes (visible_controls: a category's name from a file);
    matplotlib draws tick labels from ``format_ticks``; wrapped once, on the instance."""
    if getattr(formatter, "_hoopbench_plain", False):
        return formatter
    ticks = formatter.format_ticks

    def format_ticks(values: Any) -> list[str]:
        return [visible_controls(plain_tick_label(label)) for label in ticks(values)]

    setattr(formatter, "format_ticks", format_ticks)  # noqa: B010 - an instance's method
    setattr(formatter, "_hoopbench_plain", True)  # noqa: B010
    return formatter


def written_whole(path: str | os.PathLike[str], write: Callable[[Path], object]) -> Path:
    """``write(tmp)`` into a hidden temporary file of the same suffix (matplotlib and Pillow
    take the format from it), then renamed to ``path``: a report killed mid-figure leaves
    the old file or none, never half a PNG under its final name."""
    path = Path(path)
    return write_whole(
        path, write, tmp=path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    )


def save(
    fig: Any, out: str | os.PathLike[str], *, dpi: int, metadata: dict[str, str] | None = None
) -> Path:
    """Write ``fig`` to ``out`` whole (:func:`written_whole`) and close it. Every tick label
    drawn as math (a log or symlog axis's, a log colour bar's) is written as plain text first:
    under :func:`plain_text` matplotlib would show ``$\\mathdefault{10^{2}}$`` as written.
    Every text's control characters (a scene's or a setting's name from a file) are drawn as
    their codes (visible_controls): matplotlib has no glyph for them and its "Glyph missing"
    warning would carry them to the terminal raw. ``metadata``: text entries of the PNG
    (map_section's figure key), none by default. Its text is drawn with each glyph rendered
    once (glyph_cache.with_kept_glyphs: the same pixels). Every log axis shows at least two
    labelled ticks (log_ticks.readable_log_axes)."""
    readable_log_axes(fig)
    for text in _texts(fig):
        text.set_text(visible_controls(text.get_text()))
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            axis.set_major_formatter(_plain_formatter(axis.get_major_formatter()))
            axis.set_minor_formatter(_plain_formatter(axis.get_minor_formatter()))
    try:
        with_kept_glyphs(fig.canvas)
        laid_out(fig, dpi)
        extra: dict[str, Any] = {} if metadata is None else {"metadata": metadata}
        return written_whole(out, lambda tmp: fig.savefig(tmp, dpi=dpi, **extra))
    finally:
        pyplot().close(fig)


def _texts(artist: Any) -> Iterator[Any]:
    """Every text of ``artist`` and its children but the tick labels, which each axis writes
    from its formatter when drawn (:func:`_plain_formatter`): ``findobj`` made every axis's
    ticks and their labels to visit them, and the drawing wrote over them."""
    from matplotlib.axis import Axis
    from matplotlib.text import Text

    if isinstance(artist, Text):
        yield artist
    for child in (
        [artist.label, artist.offsetText] if isinstance(artist, Axis) else artist.get_children()
    ):
        yield from _texts(child)


def laid_out(fig: Any, dpi: float) -> None:
    """``fig`` laid out by its layout engine at ``dpi`` (the file's), the engine then
    dropped: savefig draws a figure with an engine twice, once to lay it out (nothing
    rendered, yet every text laid out and every tick and line transformed) and once to render
    it; laid out here, it draws once. A figure laid out already (``tight_layout()`` leaves a
    placeholder engine, for which savefig draws twice too) draws once. The same pixels:
    savefig's first draw runs the engine at the file's dpi, as here, and its second draw
    runs without the engine (tests/test_plotting.py)."""
    import matplotlib
    from matplotlib.layout_engine import PlaceHolderLayoutEngine

    engine = fig.get_layout_engine()
    get_renderer = getattr(fig.canvas, "get_renderer", None)  # Agg's canvases (the PNG's)
    if engine is None or get_renderer is None:
        return
    if fig.axes and not isinstance(engine, PlaceHolderLayoutEngine):
        shown_dpi = fig.dpi
        fig.dpi = dpi
        try:  # the engine measures text with the canvas's renderer, of the figure's dpi
            engine.execute(fig)
        except ValueError:  # as Figure.draw, which savefig's first draw ran it in, lets it
            pass
        finally:
            fig.dpi = shown_dpi
    # None, not "none": savefig draws a figure twice for a placeholder engine too; and None
    # whatever the rcParams, which would make None a new engine
    with matplotlib.rc_context(
        {"figure.autolayout": False, "figure.constrained_layout.use": False}
    ):
        fig.set_layout_engine(None)
