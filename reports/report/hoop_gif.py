"""The README's top figure: hop-top in motion, every engine's hoop beside the exact one, as a
GIF (drawn by matplotlib, written by Pillow). The same runs and events as the page's
animation (:func:`page_animation.hoop_motions`): a panel per run, the exact one first, the
centre-of-mass path so far over the exact path, and each event written in as it happens,
its label above it, and a key of the marks below the panels.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.models.scene import Scene
from hoopbench.reports.report.glyph_cache import cache_glyphs
from hoopbench.reports.report.page_animation import EVENTS, EXACT_LABEL, HoopMotion
from hoopbench.reports.report.palette import (
    ENDED_COLOUR,
    HOOP_COLOUR,
    WEIGHT_COLOUR,
    engine_colours,
)
from hoopbench.reports.report.plotting import pyplot, written_whole

if TYPE_CHECKING:
    from matplotlib.figure import Figure
    from PIL import Image

__all__ = ["GIF_FRAMES", "GIF_SCENE", "gif_figure", "gif_frames", "hoop_gif", "key_handles"]

GIF_SCENE = "hop-top"
"""The scene of the README's animation: the catalogue's clearest hop (0.38 m at 1.17 s)."""
GIF_FRAMES = 60
"""Frames, 80 ms apart: the whole window in about 5 s (eleven runs of hop-top: 1.7 MB)."""
_FRAME_MS = 80
GIF_COLUMNS = 2
"""Panels per row: eleven runs in six rows, each panel about 350 px wide at the README's
width (hop-top's window is eleven metres of floor: a third of that would be 60 px high)."""
_PANEL_WIDTH_IN = 4.4
_LABEL_IN = 0.36
"""Above each panel: its two lines of label (name and time; its events)."""
_KEY_IN = 0.42
"""Below the panels: the key of the marks and lines."""
_DPI = 80
_EVENT_MARKERS = {"x": "x", "triangle-up": "^", "square": "s"}
"""The page's marker names as matplotlib's."""
KEY_COLOUR = "#555555"
"""The key's neutral colour: a panel draws its marks in its run's colour."""


def _panel(ax, motion: HoopMotion, exact: HoopMotion, scene: Scene, limits: tuple) -> dict:
    """One run's axes and the artists a frame moves."""
    ax.plot(exact.X, exact.Y, color="0.8", lw=2.5)
    ax.axhline(0.0, color="0.3", lw=1.0)
    ax.set_xlim(*limits[0])
    ax.set_ylim(*limits[1])
    ax.set_aspect("equal")
    ax.set_axis_off()
    hoop = ax.add_patch(pyplot().Circle((0, 0), scene.a, fill=False, color=HOOP_COLOUR, lw=1.5))
    name = REFERENCE_ENGINE if motion.name == EXACT_LABEL else motion.name
    colour = engine_colours([name])[name]
    # Above the drawing, not on it: nothing runs through the label.
    label = ax.text(0.0, 1.03, "", fontsize=9, va="bottom", transform=ax.transAxes)
    return {
        "hoop": hoop,
        "spoke": ax.plot([], [], color=HOOP_COLOUR, lw=1)[0],
        "weight": ax.plot([], [], "o", color=WEIGHT_COLOUR, ms=6)[0],
        "path": ax.plot([], [], color=colour, lw=1.4)[0],
        "colour": colour,
        "label": label,
        "marks": [],
        "ax": ax,
    }


def _update(artists: dict, motion: HoopMotion, t: float, times: np.ndarray) -> None:
    i = motion.at(t)
    artists["hoop"].center = (motion.x[i], motion.y[i])
    artists["spoke"].set_data([motion.x[i], motion.wx[i]], [motion.y[i], motion.wy[i]])
    artists["weight"].set_data([motion.wx[i]], [motion.wy[i]])
    past = [motion.at(s) for s in times[times <= t]]
    artists["path"].set_data(motion.X[past], motion.Y[past])
    happened = [e for e in motion.events if e[1] <= t]
    for _, when, marker in happened[len(artists["marks"]) :]:
        j = motion.at(when)
        symbol = _EVENT_MARKERS[marker]
        artists["marks"].append(
            artists["ax"].plot(motion.X[j], motion.Y[j], symbol, color=artists["colour"], ms=7)[0]
        )
    events = "  ".join(f"{name} {when:.2f} s" for name, when, _ in happened)
    end = float(motion.t[-1])
    ended = t > end + 1e-9  # drawn where it stopped, faded, and said
    artists["hoop"].set_edgecolor(ENDED_COLOUR if ended else HOOP_COLOUR)
    artists["spoke"].set_color(ENDED_COLOUR if ended else HOOP_COLOUR)
    title = f"{motion.label}   t = {t:.2f} s"
    if ended:
        title += f"   ended at {end:.2f} s" + (" (impact)" if motion.name == EXACT_LABEL else "")
    artists["label"].set_text(f"{title}\n{events}")


def key_handles() -> list:
    """The key of what a panel draws: each event's mark, the exact path, the path so far,
    the weight (the marks and the path in a neutral grey: a panel's are its run's colour)."""
    from matplotlib.lines import Line2D

    marks = [
        Line2D([], [], ls="", marker=_EVENT_MARKERS[marker], color=KEY_COLOUR, ms=7, label=name)
        for name, _, _, marker in EVENTS
    ]
    return [
        *marks,
        Line2D([], [], color="0.8", lw=2.5, label="exact path"),
        Line2D([], [], color=KEY_COLOUR, lw=1.4, label="path so far (run's colour)"),
        Line2D([], [], ls="", marker="o", color=WEIGHT_COLOUR, ms=6, label="weight"),
    ]


def hoop_gif(scene: Scene, motions: list[HoopMotion], out: str | Path) -> Path:
    """Write the GIF (module doc) of ``motions`` (the exact one first) to ``out``."""
    fig, frame = gif_figure(scene, motions)
    frames = gif_frames(fig, frame, GIF_FRAMES)
    pyplot().close(fig)
    out = Path(out)
    written_whole(out, lambda tmp: _write_gif(frames, tmp))
    return out


def gif_figure(scene: Scene, motions: list[HoopMotion]) -> tuple[Figure, Callable[[int], None]]:
    """The GIF's figure and the call that moves its artists to frame k of GIF_FRAMES."""
    plt = pyplot()
    a = scene.a
    x0 = min(float(m.x.min()) for m in motions) - 1.1 * a
    x1 = max(float(m.x.max()) for m in motions) + 1.1 * a
    y1 = max(float(m.y.max()) for m in motions) + 1.1 * a
    limits = ((x0, x1), (-0.05 * a, y1))
    columns = min(GIF_COLUMNS, len(motions))
    rows = -(-len(motions) // columns)
    panel_in = _PANEL_WIDTH_IN * (y1 + 0.05 * a) / (x1 - x0)
    height = rows * (panel_in + _LABEL_IN) + _KEY_IN
    fig, axes = plt.subplots(
        rows, columns, figsize=(_PANEL_WIDTH_IN * columns, height), squeeze=False
    )
    fig.subplots_adjust(
        left=0.01,
        right=0.99,
        top=1.0 - _LABEL_IN / height,
        bottom=_KEY_IN / height,
        hspace=_LABEL_IN / panel_in,
        wspace=0.04,
    )
    panels = [
        _panel(ax, motion, motions[0], scene, limits)
        for ax, motion in zip(axes.ravel(), motions, strict=False)
    ]
    for ax in axes.ravel()[len(motions) :]:
        ax.set_axis_off()
    fig.legend(
        handles=key_handles(), loc="lower center", ncols=6, fontsize=8, frameon=False,
        title="marks in each run's colour", title_fontsize=8, alignment="left",
    )  # fmt: skip
    times = np.linspace(0.0, max(float(m.t[-1]) for m in motions), GIF_FRAMES)

    def frame(k: int) -> None:
        for artists, motion in zip(panels, motions, strict=True):
            _update(artists, motion, float(times[k]), times)

    return fig, frame


def gif_frames(fig: Figure, frame: Callable[[int], None], n: int) -> list[Image.Image]:
    """The ``n`` frames of ``fig`` at _DPI, ``frame(k)`` moving its artists to frame k.

    The same pixels as matplotlib's animation writer (FuncAnimation.save with PillowWriter,
    which drew every frame twice, once at the figure's own dpi and once at the writer's) for
    a third of its time: what does not move (the figure's background and the key) is drawn
    once, and each frame restores it and draws the panels alone over it. Drawing the key
    first rather than after the panels changes no pixel: it lies below them and no panel's
    drawing (clipped to its axes) nor label reaches it (tests/test_report_gif.py compares
    each frame with a whole figure's drawing)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig.set_dpi(_DPI)
    canvas = FigureCanvasAgg(fig)
    panels = list(fig.axes)
    for ax in panels:
        ax.set_visible(False)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    for ax in panels:
        ax.set_visible(True)
    renderer = canvas.get_renderer()
    cache_glyphs(renderer)
    frames = []
    for k in range(n):
        frame(k)
        canvas.restore_region(background)
        for ax in panels:  # in the figure's own order (all of zorder 0), as Figure.draw
            ax.draw(renderer)
        frames.append(_frame_image(canvas))
    return frames


def _frame_image(canvas: Any) -> Image.Image:
    """The canvas as PillowWriter keeps a frame: RGB when it is opaque (GIF's palette is
    then chosen better), RGBA when not."""
    from PIL import Image

    width, height = canvas.get_width_height()
    image = Image.frombuffer(
        "RGBA", (width, height), bytes(canvas.buffer_rgba()), "raw", "RGBA", 0, 1
    )
    extrema: Any = image.getextrema()  # per band: (least, most)
    return image.convert("RGB") if extrema[3][0] == 255 else image


def _write_gif(frames: list[Image.Image], path: Path) -> None:
    """The frames as an endless GIF, _FRAME_MS apart (as PillowWriter at 1000 // _FRAME_MS
    frames a second writes them)."""
    frames[0].save(
        path,
        save_all=True,
        append_images=frames[1:],
        duration=int(1000 / (1000 // _FRAME_MS)),
        loop=0,
    )
