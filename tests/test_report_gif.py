"""The README's GIF draws what does not move once (hoop_gif.gif_frames): each frame must be
the same pixels as the whole figure drawn for it, as matplotlib's animation writer drew it.

Cost: about 1 s (three small runs, a dozen frames at the GIF's dpi).
"""

from __future__ import annotations

from io import BytesIO

import numpy as np
import pytest

from hoopbench.models.catalogue import get_scene
from hoopbench.reports.report import hoop_gif
from hoopbench.reports.report.glyph_cache import cache_glyphs
from hoopbench.reports.report.page_animation import EXACT_LABEL, HoopMotion
from hoopbench.reports.report.plotting import plain_text, pyplot

FRAMES = (0, 5, 11, 23, 24, 30, 41, 52, 59)
"""Frames drawn, in order (the marks a frame adds stay for the frames after it)."""


def _motion(name: str, a: float, t_end: float, events: tuple) -> HoopMotion:
    """A hoop rolling along the floor with a small hop, its weight turning with it."""
    t = np.linspace(0.0, t_end, 301)
    x = 2.0 * a * t
    y = a + 0.3 * a * np.clip(np.sin(np.pi * (t - 0.8)), 0.0, None) * (t > 0.8) * (t < 1.8)
    theta = 2.0 * t
    wx, wy = x + a * np.sin(theta), y + a * np.cos(theta)
    X, Y = 0.7 * x + 0.3 * wx, 0.7 * y + 0.3 * wy
    return HoopMotion(name, t, x, y, wx, wy, X, Y, y - a, events)


def _motions() -> tuple[object, list[HoopMotion]]:
    scene = get_scene("hop-top")
    a = scene.a
    hop = (("lift-off", 0.8, "triangle-up"), ("impact", 1.8, "square"))
    return scene, [
        _motion(EXACT_LABEL, a, 2.4, hop),
        _motion("mujoco", a, 2.4, (("slip", 0.3, "x"), *hop)),
        _motion("pymunk", a, 1.5, (("slip", 0.4, "x"),)),  # ends early: drawn faded
    ]


def _whole(fig, dpi: int) -> bytes:
    """The figure drawn whole, as matplotlib's PillowWriter grabbed a frame."""
    buffer = BytesIO()
    fig.savefig(buffer, format="rgba", dpi=dpi)
    return buffer.getvalue()


def test_each_gif_frame_is_the_whole_figure_drawn_for_it():
    scene, motions = _motions()
    with plain_text():
        fig, frame = hoop_gif.gif_figure(scene, motions)
        drawn = hoop_gif.gif_frames(fig, lambda k: frame(FRAMES[k]), len(FRAMES))
        pyplot().close(fig)
        fig, frame = hoop_gif.gif_figure(scene, motions)
        for k, image in zip(FRAMES, drawn, strict=True):
            frame(k)
            whole = np.frombuffer(_whole(fig, hoop_gif._DPI), dtype=np.uint8)
            mine = np.asarray(image.convert("RGBA")).ravel()
            assert mine.shape == whole.shape, k
            differ = int(np.count_nonzero(mine != whole))
            assert differ == 0, f"frame {k}: {differ} bytes differ"
        pyplot().close(fig)


def test_the_gif_has_its_frames_at_its_pace(tmp_path):
    """The file as the animation writer wrote it: every frame, 83 ms apart (GIF keeps
    hundredths: read back as 80), looping, at the GIF's dpi."""
    from PIL import Image

    scene, motions = _motions()
    with plain_text():
        path = hoop_gif.hoop_gif(scene, motions, tmp_path / "hop.gif")
    with Image.open(path) as image:
        assert image.n_frames == hoop_gif.GIF_FRAMES
        assert image.info["duration"] == 80 and image.info["loop"] == 0
        fig, _ = hoop_gif.gif_figure(scene, motions)
        width, height = fig.get_size_inches() * hoop_gif._DPI
        pyplot().close(fig)
        assert image.size == (int(width), int(height))  # as matplotlib sizes a canvas


def _renderer_with_kept_glyphs(skipped: str):
    """A new figure's Agg renderer after cache_glyphs; the test skipped (saying ``skipped``)
    with a matplotlib other than the one cache_glyphs repeats."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    if not matplotlib.__version__.startswith("3.11."):
        pytest.skip(f"matplotlib {matplotlib.__version__}: {skipped}")
    fig = pyplot().figure()
    renderer = FigureCanvasAgg(fig).get_renderer()
    cache_glyphs(renderer)
    pyplot().close(fig)
    return renderer


def test_the_gif_renders_each_glyph_once_with_the_matplotlib_installed():
    """cache_glyphs repeats matplotlib 3.11's glyph drawing (the frame test above
    checks its pixels); with 3.11 installed the GIF's renderer must use it, not quietly draw
    as before (a third more of the GIF's CPU time)."""
    renderer = _renderer_with_kept_glyphs("its own glyph drawing")
    assert "_draw_text_glyphs_and_boxes" in vars(renderer)  # the instance's own, kept glyphs


def test_the_gif_lays_out_each_line_of_text_once_with_the_matplotlib_installed():
    """glyph_cache._keep_layouts repeats matplotlib 3.11's draw_text from a kept layout (the
    frame test above checks its pixels, with labels that change from frame to frame); with
    3.11 installed the GIF's renderer must use it (about 1 CPU-s of the GIF's 6)."""
    renderer = _renderer_with_kept_glyphs("its own text drawing")
    assert "draw_text" in vars(renderer)  # the instance's own, kept layouts
