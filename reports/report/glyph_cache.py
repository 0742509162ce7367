"""matplotlib's Agg text drawing, the same pixels for less CPU: each glyph rendered once at
each place within a pixel, each line of text laid out once (:func:`cache_glyphs`). The
report's figures (plotting.save) and the README's GIF (hoop_gif.gif_frames: 60 frames of the
same labels) draw with it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["GLYPHS_AS_IN", "cache_glyphs", "with_kept_glyphs"]

GLYPHS_AS_IN = "3.11."
"""The matplotlib whose RendererAgg._draw_text_glyphs_and_boxes :func:`cache_glyphs` repeats
(rendered a glyph at a time; earlier ones drew a text's glyphs in one bitmap)."""


def cache_glyphs(renderer: Any) -> None:
    """``renderer`` renders each glyph once at each position within a pixel and keeps it: the
    GIF's frames' labels are two thirds of their drawing and repeat the same glyphs at the
    same places (a run's name, "t = ", the digits, its events), and a figure's tick labels
    repeat their digits. The same pixels: FreeType renders a
    glyph moved by whole pixels as the same bitmap moved by as many (its outlines are in
    1/64 px), and a glyph is blended into the canvas as matplotlib does it; each font is left
    as matplotlib leaves it (its size and the last glyph's transform). It also lays out each
    line of text once (:func:`_keep_layouts`: a GIF label's events line is the same in most
    frames), and builds FreeType's transform once per angle (matplotlib builds it with NumPy
    for each glyph: a third of the GIF's frames' CPU time). With any other matplotlib the
    renderer is left as it is (tests/test_report_gif.py compares each frame with a whole
    figure's drawing, tests/test_plotting.py a figure saved with and without it)."""
    import matplotlib

    draw_glyphs = getattr(renderer, "_draw_text_glyphs_and_boxes", None)
    if draw_glyphs is None or not matplotlib.__version__.startswith(GLYPHS_AS_IN):
        return
    from matplotlib.backends.backend_agg import get_hinting_flag
    from matplotlib.ft2font import RenderMode

    kept: dict[tuple[Any, ...], tuple[np.ndarray, int, int]] = {}
    matrices: dict[tuple[float, float, float], tuple[np.ndarray, bytes]] = {}
    """FreeType's 16.16 transform by (angle, slant, extend): one for all of a label's glyphs,
    where matplotlib builds it with NumPy for each glyph."""

    def transform(angle: float, cos: float, sin: float, slant: float, extend: float) -> tuple:
        key = (angle, slant, extend)
        if key not in matrices:
            matrix = (
                (0x10000 * np.array([[cos, -sin], [sin, cos]]) @ [[extend, extend * slant], [0, 1]])
                .round()
                .astype(int)
            )
            matrices[key] = (matrix, matrix.tobytes())
        return matrices[key]

    def draw(gc: Any, x: float, y: float, angle: float, glyphs: Any, boxes: Any) -> None:
        cos, sin = math.cos(math.radians(angle)), math.sin(math.radians(angle))
        load_flags = get_hinting_flag()
        antialiased = gc.get_antialiased()
        fonts: dict[Any, tuple] = {}  # each font's state after its last glyph
        for font, size, glyph_index, slant, extend, dx, dy in glyphs:  # dy is upwards
            matrix, matrix_bytes = transform(angle, cos, sin, slant, extend)
            tx = round(0x40 * (x + dx * cos - dy * sin))  # 1/64 px; FreeType's y is upwards
            ty = round(0x40 * (renderer.height - y + dx * sin + dy * cos))
            key: tuple[Any, ...] = (font, size, glyph_index, matrix_bytes, tx & 63, ty & 63)
            key += (load_flags, antialiased)
            if key not in kept:
                font.set_size(size, renderer.dpi)
                font._set_transform(matrix, [tx & 63, ty & 63])
                mode = RenderMode.NORMAL if antialiased else RenderMode.MONO
                bitmap = font._render_glyph(glyph_index, load_flags, mode)
                buffer = np.array(bitmap.buffer)
                if not antialiased:
                    buffer *= 0xFF
                kept[key] = (buffer, bitmap.left, bitmap.top)
            buffer, left, top = kept[key]
            left, top = left + (tx >> 6), top + (ty >> 6)
            # draw_text_image's y is downwards and the bitmap's bottom side
            renderer._renderer.draw_text_image(
                buffer, left, int(renderer.height) - top + buffer.shape[0], 0, gc
            )
            fonts[font] = (size, matrix, [tx, ty])
        for font, (size, matrix, delta) in fonts.items():
            font.set_size(size, renderer.dpi)
            font._set_transform(matrix, delta)
        draw_glyphs(gc, x, y, angle, (), boxes)  # the boxes (mathtext's rules) as before

    renderer._draw_text_glyphs_and_boxes = draw
    _keep_layouts(renderer, get_hinting_flag)


def _keep_layouts(renderer: Any, hinting: Callable[[], int]) -> None:
    """``renderer`` lays out each line of plain text once per font, size and options, as
    RendererAgg.draw_text of matplotlib 3.11 does (FT2Font._layout: each glyph's font, index
    and place), and keeps it: the layout depends on nothing else, and the glyphs are drawn
    from it as that draw_text draws them (the font prepared as it prepares it)."""
    draw_text = renderer.draw_text
    laid: dict[tuple[Any, ...], tuple[tuple[Any, int, float, float], ...]] = {}

    def draw_kept(
        gc: Any, x: float, y: float, s: str, prop: Any, angle: float, ismath: Any = False,
        mtext: Any = None,
    ) -> None:  # fmt: skip
        if ismath:
            draw_text(gc, x, y, s, prop, angle, ismath, mtext)
            return
        font = renderer._prepare_font(prop)
        features = mtext.get_fontfeatures() if mtext is not None else None
        language = mtext.get_language() if mtext is not None else None
        flags = hinting()
        size = prop.get_size_in_points()
        key = (font, s, size, renderer.dpi, flags, _hashable(features), _hashable(language))
        if key not in laid:
            items = font._layout(s, flags=flags, features=features, language=language)
            laid[key] = tuple((item.ft_object, item.glyph_index, item.x, item.y) for item in items)
        renderer._draw_text_glyphs_and_boxes(
            gc, x, y, angle,
            ((face, size, index, 0, 1, gx, gy) for face, index, gx, gy in laid[key]),
            [],
        )  # fmt: skip

    renderer.draw_text = draw_kept


def _hashable(value: Any) -> Any:
    """A text option (a font feature list, a language) as part of a dict key."""
    if isinstance(value, list | tuple):
        return tuple(_hashable(v) for v in value)
    return value


def with_kept_glyphs(canvas: Any) -> None:
    """Every renderer ``canvas`` (an Agg canvas: the figure's own, which savefig draws a PNG
    with) hands out draws with :func:`cache_glyphs` (a figure's layout engine and savefig ask
    the canvas for one at the file's dpi); any other canvas is left as it is."""
    get_renderer = getattr(canvas, "get_renderer", None)
    if get_renderer is None or "get_renderer" in vars(canvas):
        return

    def kept() -> Any:
        renderer = get_renderer()
        if "_draw_text_glyphs_and_boxes" not in vars(renderer):
            cache_glyphs(renderer)
        return renderer

    canvas.get_renderer = kept
