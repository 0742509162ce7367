"""The hoop in motion: every engine's hoop beside the exact one, for the page (plotly frames
with play, pause and a time slider) and for the README (a GIF, :mod:`hoop_gif`).

A panel per run, the exact one first: the floor, the hoop, its spoke to the weight, the
centre-of-mass path so far over the exact path (grey), and the run's events marked where the
centre of mass was when each happened, each once its time has come (slip x, lift-off
triangle, impact square). A strip below draws every run's clearance against time with the
current time. The events are the ones the report judges: the contact reading's where the row
has it, else the clearance's; the exact solution's for the exact panel.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.engines.settings import DEFAULT_TIMESTEP
from hoopbench.models import kinematics
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.report.page_html import rounded, text
from hoopbench.reports.report.palette import (
    ENDED_COLOUR,
    HOOP_COLOUR,
    REFERENCE_COLOUR,
    WEIGHT_COLOUR,
    engine_colours,
)

__all__ = ["EVENTS", "HoopMotion", "animation_figure", "hoop_motions"]

EVENTS = (
    ("slip", (Col.T_SLIP,), Col.EXACT_T_SLIP, "x"),
    ("lift-off", (Col.T_LIFT,), Col.EXACT_T_LIFT, "triangle-up"),
    ("impact", (Col.T_IMPACT,), Col.EXACT_T_IMPACT, "square"),
)
"""(event, an engine row's column (the canonical reading), the exact column, marker)."""

EXACT_LABEL = "exact"
FRAMES = 80
"""Frames of an animation: 38 ms apart over a 3 s window (the page's size grows with them)."""
_CIRCLE = np.linspace(0.0, 2.0 * np.pi, 21)
"""The hoop drawn as a 20-gon (the page's size: a frame repeats it for every run)."""
_STRIP_SAMPLES = 600
"""Samples of each run's clearance in the strip below the panels (5 ms apart over 3 s), and
of the exact path drawn in every panel."""
_DIGITS = 4
"""Significant digits of the drawn positions: 0.1 mm on a 1 m hoop."""


@dataclass(frozen=True)
class HoopMotion:
    """One run as drawn: its samples' hoop centre and weight, and its events."""

    name: str
    t: np.ndarray
    """s."""
    x: np.ndarray
    """Hoop centre, m."""
    y: np.ndarray
    wx: np.ndarray
    """Weight, m."""
    wy: np.ndarray
    X: np.ndarray
    """Centre of mass, m."""
    Y: np.ndarray
    clearance: np.ndarray
    """m."""
    events: tuple[tuple[str, float, str], ...]
    """(event, time in s, marker), in time order."""
    timestep: float | None = None
    """s; the run's, where it is not the default (the label names it), else None."""

    @property
    def label(self) -> str:
        """The run's name as its panel shows it, with its timestep where it is not the
        default (drawn.drawn_rows: an engine with no run stored there is drawn at another)."""
        return self.name if self.timestep is None else f"{self.name} (dt {self.timestep:g} s)"

    def at(self, t: float) -> int:
        """The sample shown at time t (the last one after the run's end)."""
        return int(self.at_times(np.asarray(t)))

    def at_times(self, times: np.ndarray) -> np.ndarray:
        """The samples shown at each of ``times`` (:meth:`at`)."""
        return np.minimum(np.searchsorted(self.t, times, side="right"), len(self.t)) - 1


def _event_times(row: pd.Series | None, exact: bool) -> tuple[tuple[str, float, str], ...]:
    if row is None:
        return ()
    found = []
    for name, columns, exact_column, marker in EVENTS:
        for column in (exact_column,) if exact else columns:
            value = pd.to_numeric(row.get(column), errors="coerce")
            if pd.notna(value):
                found.append((name, float(value), marker))
                break
    return tuple(sorted(found, key=lambda event: event[1]))


def hoop_motions(
    scene: Scene, trajectories: Mapping[str, Trajectory], rows: pd.DataFrame
) -> list[HoopMotion]:
    """The runs to draw, the exact one first: ``trajectories`` by engine (the reference's is
    the exact solution), ``rows`` the runs' rows (their events)."""
    by_engine = {str(row["engine"]): row for _, row in rows.iterrows()}
    names = sorted(trajectories, key=lambda name: name != REFERENCE_ENGINE)
    motions = []
    for name in names:
        traj = trajectories[name]
        exact = name == REFERENCE_ENGINE
        x, y = kinematics.centre_position(scene, traj.X, traj.Y, traj.theta)
        motions.append(
            HoopMotion(
                name=EXACT_LABEL if exact else name,
                t=traj.t,
                x=x,
                y=y,
                wx=x + scene.a * np.sin(traj.theta),
                wy=y + scene.a * np.cos(traj.theta),
                X=traj.X,
                Y=traj.Y,
                clearance=traj.clearance,
                events=_event_times(by_engine.get(name), exact),
                timestep=_other_timestep(by_engine.get(name)),
            )
        )
    return motions


def _other_timestep(row: pd.Series | None) -> float | None:
    """The row's timestep where it is not the default (s), else None."""
    value = None if row is None else pd.to_numeric(row.get(Col.TIMESTEP), errors="coerce")
    if value is None or pd.isna(value) or float(value) == DEFAULT_TIMESTEP:
        return None
    return float(value)


def _colour(motion: HoopMotion) -> str:
    """The run's colour in every figure (palette.py); the exact run's is the reference's."""
    name = REFERENCE_ENGINE if motion.name == EXACT_LABEL else motion.name
    return engine_colours([name])[name]


def _axes(k: int) -> dict[str, str]:
    return {"xaxis": "x" if k == 0 else f"x{k + 1}", "yaxis": "y" if k == 0 else f"y{k + 1}"}


@dataclass(frozen=True)
class _AtFrames:
    """A run's samples shown at each frame, and its centre of mass there rounded, found once:
    each frame's path so far repeats the frames before it (80 frames: 160 numbers of a run
    rounded once, not 3,360 found and rounded frame by frame)."""

    index: np.ndarray
    """The sample shown at each frame (HoopMotion.at_times)."""
    X: list[float | None]
    Y: list[float | None]

    @classmethod
    def of(cls, motion: HoopMotion, frame_times: np.ndarray) -> _AtFrames:
        index = motion.at_times(frame_times)
        return cls(index, rounded(motion.X[index], _DIGITS), rounded(motion.Y[index], _DIGITS))


def _dynamic(
    motion: HoopMotion, k: int, a: float, frame_times: np.ndarray, shown: _AtFrames
) -> list:
    """A panel's moving traces at frame k: hoop and spoke, weight, path so far, events, label.
    Their axes are the first frame's (a frame repeats only what moves)."""
    t = float(frame_times[k])
    i = int(shown.index[k])
    x, y = motion.x[i], motion.y[i]
    hoop_x = [*(x + a * np.cos(_CIRCLE)), None, x, motion.wx[i]]
    hoop_y = [*(y + a * np.sin(_CIRCLE)), None, y, motion.wy[i]]
    # the path so far through every other frame before t, then t: half the numbers, still
    # smooth
    before = int(np.searchsorted(frame_times, t, side="left"))  # the frames before t
    past_x = [*shown.X[:before:2], shown.X[k]]
    past_y = [*shown.Y[:before:2], shown.Y[k]]
    happened = [e for e in motion.events if e[1] <= t]
    marks = [motion.at(e[1]) for e in happened]
    label = " · ".join(f"{name} {when:.3f} s" for name, when, _ in happened)
    end = float(motion.t[-1])
    ended = t > end + 1e-9
    if ended:  # shown where it stopped, faded, and said: not a hoop resting there
        impact = " (its impact)" if motion.name == EXACT_LABEL else ""
        label += f"<br><b>ended</b> at {end:.3f} s{impact}"
    return [
        {
            "x": rounded(hoop_x, _DIGITS),
            "y": rounded(hoop_y, _DIGITS),
            "line": {"color": ENDED_COLOUR if ended else HOOP_COLOUR, "width": 2},
        },
        {"x": rounded([motion.wx[i]], _DIGITS), "y": rounded([motion.wy[i]], _DIGITS)},
        {"x": past_x, "y": past_y},
        {
            "x": rounded(motion.X[marks], _DIGITS),
            "y": rounded(motion.Y[marks], _DIGITS),
            "marker": {"symbol": [m for _, _, m in happened], "size": 11, "color": _colour(motion)},
        },
        {
            "text": [
                f"<b>{text(motion.label)}</b>  t = {t:.3f} s" + (f"<br>{label}" if label else "")
            ]
        },
    ]


def _static(motions: list[HoopMotion], bounds: dict[str, float], n_rows: int) -> list[dict]:
    """The traces that do not move: the exact path in every panel, the clearance curves."""
    exact = motions[0]
    path_step = max(1, len(exact.t) // _STRIP_SAMPLES)
    traces: list[dict] = []
    for k in range(len(motions)):
        traces.append(
            {"type": "scatter", "mode": "lines", "x": rounded(exact.X[::path_step], _DIGITS),
             "y": rounded(exact.Y[::path_step], _DIGITS), "line": {"color": "#bbb", "width": 3},
             "hoverinfo": "skip", "showlegend": False, **_axes(k)}
        )  # fmt: skip
    strip = _axes(n_rows - 1)
    for motion in motions:
        step = max(1, len(motion.t) // _STRIP_SAMPLES)
        traces.append(
            {"type": "scatter", "mode": "lines", "name": text(motion.name),
             "x": rounded(motion.t[::step], _DIGITS), "showlegend": True,
             "y": rounded(motion.clearance[::step] * 1e3, _DIGITS), **strip,
             "line": {"dash": "dash", "color": REFERENCE_COLOUR} if motion is exact
             else {"color": _colour(motion)}}
        )  # fmt: skip
    return [*traces, *marker_key(n_rows - 1)]


KEY_COLOUR = "#555555"
"""The marker key's neutral colour: a panel draws the marks in its run's colour."""


def marker_key(k: int) -> list[dict]:
    """The key of what a panel draws (nothing drawn: legend entries on the strip's axes ``k``):
    each event's marker, the exact path, the path so far, the weight."""
    entry = {"type": "scatter", "x": [None], "y": [None], "hoverinfo": "skip",
             "legend": "legend2", **_axes(k)}  # fmt: skip
    events = [
        {**entry, "mode": "markers", "name": name,
         "marker": {"symbol": marker, "size": 11, "color": KEY_COLOUR}}
        for name, _, _, marker in EVENTS
    ]  # fmt: skip
    return [
        *events,
        {**entry, "mode": "lines", "name": "exact path", "line": {"color": "#bbb", "width": 3}},
        {**entry, "mode": "lines", "name": "path so far", "line": {"color": KEY_COLOUR}},
        {**entry, "mode": "markers", "name": "weight",
         "marker": {"color": WEIGHT_COLOUR, "size": 12}},
    ]  # fmt: skip


def _moving_templates(motions: list[HoopMotion], n_rows: int) -> list[dict]:
    """Trace styles of the moving traces, in _dynamic's order, then the time cursor: the
    path so far in the run's colour (palette.py), the hoop and its weight neutral."""
    styles: list[dict[str, Any]] = [
        {"mode": "lines", "line": {"color": HOOP_COLOUR, "width": 2}},
        {"mode": "markers", "marker": {"color": WEIGHT_COLOUR, "size": 12}},
        {"mode": "lines", "line": {"width": 1.5}},
        {"mode": "markers"},
        {
            "mode": "text",
            "textposition": "bottom right",
            "textfont": {"size": 12},
            "x": [0],
            "y": [0],
        },
    ]
    traces = []
    for k, motion in enumerate(motions):
        for n, style in enumerate(styles):
            if n == 2:  # the path so far
                style = {**style, "line": {**style["line"], "color": _colour(motion)}}
            traces.append(
                {"type": "scatter", "showlegend": False, "hoverinfo": "skip", **style, **_axes(k)}
            )
    cursor = {"type": "scatter", "mode": "lines", "line": {"color": "#888888", "dash": "dot"}}
    return [*traces, {**cursor, "showlegend": False, "hoverinfo": "skip", **_axes(n_rows - 1)}]


def _cursor(t: float, low: float, high: float) -> dict:
    return {"x": [t, t], "y": [low, high]}


def _label_place(trace: dict, bounds: dict[str, float]) -> dict:
    """A panel's label: hanging from the panel's top left corner, above the hoop."""
    return {**trace, "x": [bounds["x0"]], "y": [bounds["top"]]}


def animation_figure(scene: Scene, motions: list[HoopMotion]) -> dict[str, Any]:
    """The page's animation of one scene (module doc) as a plotly figure dict."""
    a = scene.a
    end = max(float(m.t[-1]) for m in motions)
    times = np.linspace(0.0, end, FRAMES)
    bounds = panel_bounds(motions, a, min(GRID_COLUMNS, len(motions)))
    n_rows = len(motions) + 1
    static = _static(motions, bounds, n_rows)
    clear = np.concatenate([m.clearance for m in motions]) * 1e3
    low, high = float(np.nanmin(clear)), float(np.nanmax(clear))
    moving = list(range(len(static), len(static) + 5 * len(motions) + 1))
    shown = [_AtFrames.of(motion, times) for motion in motions]
    frames = []
    for k, t in enumerate(times):
        data = []
        for motion, at_frames in zip(motions, shown, strict=True):
            dynamic = _dynamic(motion, k, a, times, at_frames)
            dynamic[4] = _label_place(dynamic[4], bounds)
            data += dynamic
        data.append(_cursor(float(t), low, high))
        frames.append({"name": f"{t:.3f}", "data": data, "traces": moving})
    templates = _moving_templates(motions, n_rows)
    first = [
        {**template, **datum} for template, datum in zip(templates, frames[0]["data"], strict=True)
    ]
    return {
        "data": [*static, *first],
        "layout": _layout(motions, bounds, n_rows, times),
        "frames": frames,
    }


GRID_COLUMNS = 3
"""Panels per row of the animation's grid (eleven runs: four rows, a panel wide enough that a
label of three events reads at the page's size)."""
_FIGURE_PX = 1090
"""About the width of the plot area the page gives a figure (its 1200 px body less padding
and the margins): a panel's height follows its width and the drawing's aspect (the axes
keep metres square). The key lies below the strip, so that the panels have the width."""
LABEL_PX = 50
"""Room above a panel's drawing for its label (three lines of 12 px text): the label stays
above the hoop, the paths and the floor."""
_MIN_DRAWING_PX = 80
_PANEL_GAP_PX = 12
_STRIP_PX = 200
_STRIP_GAP_PX = 45
_CONTROLS_PX = 90
_KEY_PX = 150
"""Below the strip: its time axis and the key (the runs' clearance lines, the panels'
marks), laid out in rows."""


def panel_bounds(motions: list[HoopMotion], a: float, columns: int) -> dict[str, float]:
    """A panel's ranges, m: x0 to x1 across, y0 (below the floor) to y1 (above every hoop)
    the drawing, y1 to top the label's room (LABEL_PX at the panel's size); ``px`` the
    drawing's height in pixels at _FIGURE_PX."""
    bounds = {
        "x0": min(float(m.x.min()) for m in motions) - 1.15 * a,
        "x1": max(float(m.x.max()) for m in motions) + 1.15 * a,
        "y1": max(float(m.y.max()) for m in motions) + 1.1 * a,
    }
    bounds["y0"] = -0.05 * bounds["y1"]
    height = bounds["y1"] - bounds["y0"]
    width = _FIGURE_PX / columns - _PANEL_GAP_PX
    drawing_px = max(_MIN_DRAWING_PX, width * height / (bounds["x1"] - bounds["x0"]))
    bounds["px"] = drawing_px
    bounds["top"] = bounds["y1"] + height * LABEL_PX / drawing_px
    return bounds


def _layout(motions: list[HoopMotion], bounds: dict[str, float], n_rows: int, times) -> dict:
    """The panels in a grid of GRID_COLUMNS, the clearance strip across the bottom, the play
    buttons and the time slider on top. ``n_rows``: the panels and the strip (axes)."""
    columns = min(GRID_COLUMNS, len(motions))
    grid_rows = -(-len(motions) // columns)
    panel_px = bounds["px"] + LABEL_PX + _PANEL_GAP_PX
    plot_px = grid_rows * panel_px + _STRIP_GAP_PX + _STRIP_PX  # the plot area's height
    strip_top = _STRIP_PX / plot_px
    panels_top = 1.0
    row_height = panel_px / plot_px
    gap = _PANEL_GAP_PX / plot_px
    layout: dict[str, Any] = {
        "height": round(plot_px + _CONTROLS_PX + _KEY_PX),
        "margin": {"t": _CONTROLS_PX, "b": _KEY_PX, "l": 60, "r": 20},
        "shapes": [],
        # two rows of keys below the strip's time axis: its lines, then the panels' marks
        "legend": {"orientation": "h", "x": 0, "y": -55 / plot_px, "yanchor": "top",
                   "title": {"text": "clearance:"}},
        "legend2": {"orientation": "h", "x": 0, "y": -(55 + 50) / plot_px, "yanchor": "top",
                    "title": {"text": "panels (marks in the run's colour):"}},
    }  # fmt: skip
    for k in range(len(motions)):
        x, y = _axes(k)["xaxis"], _axes(k)["yaxis"]
        row, column = divmod(k, columns)
        top = panels_top - row * row_height
        layout[f"xaxis{k + 1 if k else ''}"] = {
            "domain": [column / columns + 0.005, (column + 1) / columns - 0.005],
            "range": [bounds["x0"], bounds["x1"]],
            "showticklabels": False,
            "showgrid": False,  # no line through the label or the hoop
            "zeroline": False,
            "constrain": "domain",
            "anchor": y,
        }
        layout[f"yaxis{k + 1 if k else ''}"] = {
            "domain": [top - row_height + gap, top],
            "range": [bounds["y0"], bounds["top"]],
            "scaleanchor": x,
            "showticklabels": False,
            "showgrid": False,
            "zeroline": False,
            "anchor": x,
        }
        layout["shapes"].append(
            {"type": "line", "xref": f"{x} domain", "yref": y, "x0": 0, "x1": 1, "y0": 0,
             "y1": 0, "line": {"color": "#444"}}
        )  # fmt: skip
    strip_x, strip_y = _axes(n_rows - 1)["xaxis"], _axes(n_rows - 1)["yaxis"]
    layout[f"xaxis{n_rows}"] = {"title": {"text": "t (s)"}, "domain": [0, 1], "anchor": strip_y}
    layout[f"yaxis{n_rows}"] = {
        "title": {"text": "clearance (mm)"},
        "domain": [0, strip_top],
        "anchor": strip_x,
    }
    layout["updatemenus"] = [_play_buttons()]
    layout["sliders"] = [_slider(times)]
    return layout


def _play_buttons() -> dict:
    still = {"mode": "immediate", "frame": {"duration": 0, "redraw": False}}
    play = {
        "frame": {"duration": 40, "redraw": False},
        "fromcurrent": True,
        "transition": {"duration": 0},
    }
    return {
        "type": "buttons", "direction": "left", "x": 0, "y": 1, "xanchor": "left",
        "yanchor": "bottom", "pad": {"b": 50},
        "buttons": [
            {"label": "play", "method": "animate", "args": [None, play]},
            {"label": "pause", "method": "animate", "args": [[None], still]},
        ],
    }  # fmt: skip


def _slider(times: np.ndarray) -> dict:
    still = {
        "mode": "immediate",
        "frame": {"duration": 0, "redraw": False},
        "transition": {"duration": 0},
    }
    steps = [
        {"label": f"{t:.2f}", "method": "animate", "args": [[f"{t:.3f}"], still]} for t in times
    ]
    return {"active": 0, "steps": steps, "x": 0.15, "len": 0.85, "y": 1, "yanchor": "bottom",
            "currentvalue": {"prefix": "t = ", "suffix": " s"}, "pad": {"b": 10}}  # fmt: skip
