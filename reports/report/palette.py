"""One categorical palette keyed by engine name, for every figure, PNG and page alike.

A figure never colours a line by its position among the traces: an engine's colour is looked
up here by its name (:func:`engine_colours`), so MuJoCo is the same blue in the error-against-
time plot, the clearance plot, the contact forces and the animation. The profile is the line
style and marker (:data:`PROFILE_STYLES`); the exact reference is always black and dashed
(:data:`REFERENCE_COLOUR`, :data:`REFERENCE_DASH`), and nothing else is; a Pareto front is a
wide translucent grey band under the runs (:data:`FRONT_COLOUR`).

The ten engines hoopbench ships have fixed colours (mostly matplotlib's and plotly's own
categorical ten, so a reader who knows them reads them). An engine from a plugin, or a name in
an older results folder, takes one of the spare colours, chosen from its name, and never one
another engine of the same figure has.
"""

from __future__ import annotations

import zlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

from hoopbench.engines.options import Profile
from hoopbench.engines.run import REFERENCE_ENGINE

__all__ = [
    "ENDED_COLOUR",
    "ENGINE_COLOURS",
    "FRONT_ALPHA",
    "FRONT_COLOUR",
    "FRONT_WIDTH",
    "HOOP_COLOUR",
    "PROFILE_STYLES",
    "REFERENCE_COLOUR",
    "REFERENCE_DASH",
    "SPARE_COLOURS",
    "WEIGHT_COLOUR",
    "LineStyle",
    "engine_colours",
    "profile_style",
]

REFERENCE_COLOUR = "#000000"
"""The exact reference, in every figure."""

REFERENCE_DASH = (0, (5, 2))
"""The exact reference's line: dashed (matplotlib's dash pattern; the page's is 'dash')."""

FRONT_COLOUR = "#7f7f7f"
FRONT_ALPHA = 0.4
FRONT_WIDTH = 6.0
"""A Pareto front: a solid grey band this wide (points in matplotlib, pixels in plotly), this
opaque, drawn under the runs' lines: unlike the exact reference's black dashes and unlike any
engine's thin coloured line, and the runs it joins still show through it."""

HOOP_COLOUR = "#555555"
"""A hoop and its spoke in the animations: a neutral grey, so that the only colour of a panel
is its engine's (its path and event marks)."""
WEIGHT_COLOUR = "#000000"
ENDED_COLOUR = "#c8c8c8"
"""A hoop whose run has ended (the exact one at its impact): drawn where it stopped, faded."""

ENGINE_COLOURS: Mapping[str, str] = MappingProxyType(
    {
        "mujoco": "#1f77b4",
        "pybullet": "#ff7f0e",
        "pymunk": "#2ca02c",
        "drake": "#d62728",
        "box2d": "#9467bd",
        "rapier": "#8c564b",
        "dart": "#e377c2",
        "mjx": "#17becf",
        "mjwarp": "#bcbd22",
        "newton": "#393b79",
    }
)
"""The shipped engines' colours: the categorical ten's first seven for the seven engines of
one world at a time, its cyan and olive for MJX and MuJoCo Warp, and a dark indigo for Newton
(the ten's grey would read as the animations' neutral hoop)."""

SPARE_COLOURS = ("#7f7f7f", "#637939", "#8c6d31", "#843c39", "#7b4173", "#e7ba52", "#5254a3")
"""For engines without a fixed colour (a plugin's)."""


@dataclass(frozen=True)
class LineStyle:
    """How a profile's lines are drawn: matplotlib's line style and marker, and plotly's."""

    matplotlib_dash: str
    marker: str
    plotly_dash: str
    plotly_symbol: str


PROFILE_STYLES: Mapping[str, LineStyle] = MappingProxyType(
    {
        str(Profile.TUNED): LineStyle("-", "o", "solid", "circle"),
        str(Profile.STOCK): LineStyle(":", "s", "dot", "square"),
    }
)
"""One style per profile: tuned solid with circles, stock dotted with squares."""

_OTHER_PROFILE = LineStyle("-.", "^", "dashdot", "triangle-up")


def profile_style(profile: str) -> LineStyle:
    """The line style of a profile (an unknown one: dash-dot with triangles)."""
    return PROFILE_STYLES.get(str(profile), _OTHER_PROFILE)


def engine_colours(engines: Iterable[str]) -> dict[str, str]:
    """Each engine's colour for one figure: the fixed one, the reference's, or a spare one
    picked from the name and distinct from every other colour of the figure."""
    names = list(dict.fromkeys(str(e) for e in engines))
    colours = {
        name: REFERENCE_COLOUR if name == REFERENCE_ENGINE else ENGINE_COLOURS[name]
        for name in names
        if name == REFERENCE_ENGINE or name in ENGINE_COLOURS
    }
    for name in sorted(n for n in names if n not in colours):
        used = set(colours.values())
        start = zlib.crc32(name.encode("utf-8")) % len(SPARE_COLOURS)
        free = [
            SPARE_COLOURS[(start + k) % len(SPARE_COLOURS)]
            for k in range(len(SPARE_COLOURS))
            if SPARE_COLOURS[(start + k) % len(SPARE_COLOURS)] not in used
        ]
        # More unknown engines than spare colours: a grey of its own for each.
        grey = (len(colours) * 37) % 200 + 30
        colours[name] = free[0] if free else f"#{grey:02x}{grey:02x}{grey:02x}"
    return {name: colours[name] for name in names}
