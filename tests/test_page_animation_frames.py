"""The page's animation (reports/report/page_animation.py): each frame's path so far, found
once a run for every frame (page_animation._AtFrames), is the run's centre of mass at every
other frame before the frame's time, then at that time, as its definition reads."""

from __future__ import annotations

import numpy as np

from hoopbench.models.catalogue import get_scene
from hoopbench.reports.report.page_animation import (
    _DIGITS,
    EXACT_LABEL,
    FRAMES,
    HoopMotion,
    animation_figure,
)
from hoopbench.reports.report.page_html import rounded


def _motion(name: str, t_end: float, samples: int) -> HoopMotion:
    t = np.linspace(0.0, t_end, samples)
    x = 0.3 * t + 0.01 * np.sin(7 * t)
    y = np.full_like(t, 0.5) + 0.05 * np.sin(3 * t) ** 2
    return HoopMotion(
        name=name, t=t, x=x, y=y, wx=x + 0.1, wy=y - 0.2, X=x + 0.05, Y=y - 0.1,
        clearance=y - 0.5, events=(("slip", 0.4 * t_end, "x"),),
    )  # fmt: skip


def test_each_frame_s_path_so_far_is_every_other_frame_before_it_then_its_own():
    """Runs of other lengths and sample counts than the frames (one ends before the last
    frame, where its last sample is shown)."""
    motions = [_motion(EXACT_LABEL, 2.0, 2001), _motion("a", 1.3, 777), _motion("b", 2.0, 50)]
    figure = animation_figure(get_scene("hop-top"), motions)
    times = np.linspace(0.0, 2.0, FRAMES)
    assert len(figure["frames"]) == FRAMES
    for frame, t in zip(figure["frames"], times, strict=True):
        for k, motion in enumerate(motions):
            path = frame["data"][5 * k + 2]
            shown = [motion.at(s) for s in [*times[times < t][::2], float(t)]]
            assert path == {
                "x": rounded(motion.X[shown], _DIGITS),
                "y": rounded(motion.Y[shown], _DIGITS),
            }
