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
from hoopbench.models import kinematics
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.report.page_html import PALETTE, rounded, text

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

    def at(self, t: float) -> int:
        """The sample shown at time t (the last one after the run's end)."""
        return min(int(np.searchsorted(self.t, t, side="right")), len(self.t)) - 1


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
            )
        )
    return motions


def _axes(k: int) -> dict[str, str]:
    return {"xaxis": "x" if k == 0 else f"x{k + 1}", "yaxis": "y" if k == 0 else f"y{k + 1}"}


def _dynamic(motion: HoopMotion, t: float, a: float, frame_times: np.ndarray) -> list:
    """A panel's moving traces at time t: hoop and spoke, weight, path so far, events, label.
    Their axes are the first frame's (a frame repeats only what moves)."""
    i = motion.at(t)
    x, y = motion.x[i], motion.y[i]
    hoop_x = [*(x + a * np.cos(_CIRCLE)), None, x, motion.wx[i]]
    hoop_y = [*(y + a * np.sin(_CIRCLE)), None, y, motion.wy[i]]
    # the path so far through every other frame: half the numbers, still smooth
    past = [motion.at(s) for s in [*frame_times[frame_times < t][::2], t]]
    happened = [e for e in motion.events if e[1] <= t]
    marks = [motion.at(e[1]) for e in happened]
    label = " · ".join(f"{name} {when:.3f} s" for name, when, _ in happened)
    return [
        {"x": rounded(hoop_x, _DIGITS), "y": rounded(hoop_y, _DIGITS)},
        {"x": rounded([motion.wx[i]], _DIGITS), "y": rounded([motion.wy[i]], _DIGITS)},
        {"x": rounded(motion.X[past], _DIGITS), "y": rounded(motion.Y[past], _DIGITS)},
        {
            "x": rounded(motion.X[marks], _DIGITS),
            "y": rounded(motion.Y[marks], _DIGITS),
            "marker": {"symbol": [m for _, _, m in happened], "size": 11, "color": "#d62728"},
        },
        {"text": [f"<b>{text(motion.name)}</b>  t = {t:.3f} s  {label}"]},
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
    for k, motion in enumerate(motions):
        step = max(1, len(motion.t) // _STRIP_SAMPLES)
        traces.append(
            {"type": "scatter", "mode": "lines", "name": text(motion.name),
             "x": rounded(motion.t[::step], _DIGITS), "showlegend": True,
             "y": rounded(motion.clearance[::step] * 1e3, _DIGITS), **strip,
             "line": {"dash": "dash", "color": "black"} if motion is exact
             else {"color": PALETTE[(k - 1) % len(PALETTE)]}}
        )  # fmt: skip
    return traces


def _moving_templates(n_panels: int, n_rows: int) -> list[dict]:
    """Trace styles of the moving traces, in _dynamic's order, then the time cursor."""
    styles: list[dict[str, Any]] = [
        {"mode": "lines", "line": {"color": "#1f4e99", "width": 2}},
        {"mode": "markers", "marker": {"color": "#d62728", "size": 12}},
        {"mode": "lines", "line": {"color": "#2ca02c", "width": 1.5}},
        {"mode": "markers"},
        {"mode": "text", "textposition": "middle right", "x": [0], "y": [0]},
    ]
    traces = [
        {"type": "scatter", "showlegend": False, "hoverinfo": "skip", **style, **_axes(k)}
        for k in range(n_panels)
        for style in styles
    ]
    cursor = {"type": "scatter", "mode": "lines", "line": {"color": "#d62728"}}
    return [*traces, {**cursor, "showlegend": False, "hoverinfo": "skip", **_axes(n_rows - 1)}]


def _cursor(t: float, low: float, high: float) -> dict:
    return {"x": [t, t], "y": [low, high]}


def _label_place(trace: dict, bounds: dict[str, float]) -> dict:
    """A panel's label: above the hoop's highest point, from the panel's left edge."""
    return {**trace, "x": [bounds["x0"]], "y": [bounds["top"] - 0.12 * bounds["y1"]]}


def animation_figure(scene: Scene, motions: list[HoopMotion]) -> dict[str, Any]:
    """The page's animation of one scene (module doc) as a plotly figure dict."""
    a = scene.a
    end = max(float(m.t[-1]) for m in motions)
    times = np.linspace(0.0, end, FRAMES)
    bounds = {
        "x0": min(float(m.x.min()) for m in motions) - 1.15 * a,
        "x1": max(float(m.x.max()) for m in motions) + 1.15 * a,
        "y1": max(float(m.y.max()) for m in motions) + 1.25 * a,
    }
    bounds["top"] = bounds["y1"] * 1.25  # room for the label
    n_rows = len(motions) + 1
    static = _static(motions, bounds, n_rows)
    clear = np.concatenate([m.clearance for m in motions]) * 1e3
    low, high = float(np.nanmin(clear)), float(np.nanmax(clear))
    moving = list(range(len(static), len(static) + 5 * len(motions) + 1))
    frames = []
    for t in times:
        data = []
        for motion in motions:
            dynamic = _dynamic(motion, float(t), a, times)
            dynamic[4] = _label_place(dynamic[4], bounds)
            data += dynamic
        data.append(_cursor(float(t), low, high))
        frames.append({"name": f"{t:.3f}", "data": data, "traces": moving})
    templates = _moving_templates(len(motions), n_rows)
    first = [
        {**template, **datum} for template, datum in zip(templates, frames[0]["data"], strict=True)
    ]
    return {
        "data": [*static, *first],
        "layout": _layout(motions, bounds, n_rows, times),
        "frames": frames,
    }


def _layout(motions: list[HoopMotion], bounds: dict[str, float], n_rows: int, times) -> dict:
    layout: dict[str, Any] = {
        "height": 210 * (n_rows - 1) + 260,
        "grid": {"rows": n_rows, "columns": 1, "pattern": "independent", "ygap": 0.08},
        "margin": {"t": 30, "b": 10},
        "shapes": [],
        "legend": {"x": 1.01, "y": 0, "yanchor": "bottom", "title": {"text": "clearance"}},
    }
    for k in range(len(motions)):
        x, y = _axes(k)["xaxis"], _axes(k)["yaxis"]
        layout[f"xaxis{k + 1 if k else ''}"] = {
            "range": [bounds["x0"], bounds["x1"]],
            "showticklabels": k == len(motions) - 1,
            "constrain": "domain",
        }
        layout[f"yaxis{k + 1 if k else ''}"] = {
            "range": [-0.05 * bounds["y1"], bounds["top"]],
            "scaleanchor": x,
            "showticklabels": False,
        }
        layout["shapes"].append(
            {
                "type": "line",
                "xref": f"{x} domain",
                "yref": y,
                "x0": 0,
                "x1": 1,
                "y0": 0,
                "y1": 0,
                "line": {"color": "#444"},
            }
        )
    layout[f"xaxis{n_rows}"] = {"title": {"text": "t (s)"}}
    layout[f"yaxis{n_rows}"] = {"title": {"text": "clearance (mm)"}}
    layout["updatemenus"] = [_play_buttons()]
    layout["sliders"] = [_slider(times)]
    return layout  # fmt: skip


def _play_buttons() -> dict:
    still = {"mode": "immediate", "frame": {"duration": 0, "redraw": False}}
    play = {
        "frame": {"duration": 40, "redraw": False},
        "fromcurrent": True,
        "transition": {"duration": 0},
    }
    return {
        "type": "buttons", "direction": "left", "x": 0, "y": 0, "xanchor": "left",
        "yanchor": "top", "pad": {"t": 30},
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
    return {"active": 0, "steps": steps, "x": 0.12, "len": 0.88, "y": 0, "yanchor": "top",
            "currentvalue": {"prefix": "t = ", "suffix": " s"}, "pad": {"t": 30}}  # fmt: skip
