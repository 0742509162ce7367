"""The page's interactive version of each engine's Best settings figure (best-settings-E.png):
the same two panels, error against cost on the training scenes and on the held-out ones, from
the same front.csv and trials.csv (:class:`best_settings.BestSettings`), where a point's hover
names its setting: timestep, options, both errors and costs, the tier it reaches on each set
of scenes, on how many scenes it is within each tier and whether it is overfitted; a trial's
names its number.
"""

from __future__ import annotations

import json
from typing import Any

import pandas as pd

from hoopbench.engines.judging.score import CostClock
from hoopbench.reports.compare.settings_file import TIER_CHOICES
from hoopbench.reports.report.best_settings import SCORE_AXIS, BestSettings, cost_axis, in_seconds
from hoopbench.reports.report.page_html import rounded, text
from hoopbench.reports.report.palette import engine_colours, profile_style
from hoopbench.reports.tune.tiers import SCENES_COLUMN, TIER_COLUMNS, count_column

__all__ = ["best_settings_page_figure"]

Figure = dict[str, Any]

_PANELS = (("train", "training scenes"), ("heldout", "held-out scenes"))


def _setting_hover(clock: CostClock) -> str:
    """A setting's hover, its costs by the search's clock."""
    unit = f"{clock.label} s/sim s"
    return (
        "<b>%{customdata[0]}</b> (%{customdata[1]})<br>dt %{customdata[2]} s<br>"
        f"%{{customdata[3]}}<br>training: error %{{customdata[4]}}, %{{customdata[5]}} {unit}, "
        f"tier %{{customdata[6]}}<br>held-out: error %{{customdata[7]}}, %{{customdata[8]}} "
        f"{unit}, tier %{{customdata[9]}}<br>scenes within each tier: %{{customdata[11]}}<br>"
        "overfitted: %{customdata[10]}<extra></extra>"
    )


def _trial_hover(clock: CostClock) -> str:
    """A trial's hover, its cost by the search's clock."""
    unit = f"{clock.label} s/sim s"
    return f"trial %{{customdata}}<br>error %{{y:.3g}}, %{{x:.3g}} {unit}<extra></extra>"


def _number(value: Any) -> str:
    number = pd.to_numeric(value, errors="coerce")
    return "-" if pd.isna(number) else f"{float(number):.3g}"


def _options(value: Any) -> str:
    """A setting's options as name = value lines (front.csv stores them as JSON)."""
    try:
        options = json.loads(value) if isinstance(value, str) else {}
    except ValueError:
        return text(value)
    if not isinstance(options, dict) or not options:
        return "(no option changed)"
    return "<br>".join(f"{text(k)} = {text(v)}" for k, v in sorted(options.items()))


def _tier(value: Any) -> str:
    return text(value) if isinstance(value, str) else "-"  # a front.csv from before the tiers


def _counts(row: dict[str, Any]) -> str:
    """'agrees 15/22, close 21/22' ('-' for a front.csv from before the counts)."""
    scenes = _number(row.get(SCENES_COLUMN))
    if scenes == "-":
        return "-"
    return ", ".join(
        f"{tier} {_number(row.get(count_column(tier)))}/{scenes}" for tier in TIER_CHOICES
    )


def _hover_data(rows: pd.DataFrame) -> list[list[str]]:
    train, heldout = TIER_COLUMNS
    return [
        [
            text(row["setting"]),
            text(row["kind"]),
            _number(row["timestep"]),
            _options(row.get("options")),
            _number(row["train_error"]),
            _number(in_seconds(row["train_cost_us_per_s"])),
            _tier(row.get(train)),
            _number(row["heldout_error"]),
            _number(in_seconds(row["heldout_cost_us_per_s"])),
            _tier(row.get(heldout)),
            "yes" if row["overfitted"] is True or str(row["overfitted"]) == "True" else "no",
            _counts(row),
        ]
        for row in rows.to_dict("records")
    ]


def _axes(k: int) -> dict[str, str]:
    return {"xaxis": "x" if k == 0 else f"x{k + 1}", "yaxis": "y" if k == 0 else f"y{k + 1}"}


def _panel_traces(best: BestSettings, which: str, k: int, colour: str) -> list[dict]:
    front, axes = best.front, _axes(k)
    traces: list[dict[str, Any]] = []
    if which == "train":
        done = best.trials[best.trials["state"] == "complete"]
        traces.append(
            {
                "type": "scatter",
                "mode": "markers",
                "x": rounded(in_seconds(done["train_cost_us_per_s"])),
                "y": rounded(done["train_error"]),
                "customdata": [str(n) for n in done["trial"]],
                "hovertemplate": _trial_hover(best.cost_clock),
                "marker": {"color": "#b3b3b3", "size": 6},
                "name": "trials",
                **axes,
            }
        )
    pareto = front[front["kind"] == "pareto"].sort_values(f"{which}_cost_us_per_s")
    traces.append(
        {
            "type": "scatter",
            # On the held-out scenes the training front is no front: its points, not a line.
            "mode": "lines+markers" if which == "train" else "markers",
            "x": rounded(in_seconds(pareto[f"{which}_cost_us_per_s"])),
            "y": rounded(pareto[f"{which}_error"]),
            "customdata": _hover_data(pareto),
            "hovertemplate": _setting_hover(best.cost_clock),
            "line": {"color": colour},
            "marker": {"color": colour, "size": 8},
            "name": "Pareto set",
            "legendgroup": "pareto",
            "showlegend": k == 0,
            **axes,
        }
    )
    for name in ("stock", "tuned"):  # the profiles' markers, edged black to stand out
        point = front[front["setting"] == name]
        traces.append(
            {
                "type": "scatter",
                "mode": "markers",
                "x": rounded(in_seconds(point[f"{which}_cost_us_per_s"])),
                "y": rounded(point[f"{which}_error"]),
                "customdata": _hover_data(point),
                "hovertemplate": _setting_hover(best.cost_clock),
                "marker": {
                    "color": colour,
                    "size": 12,
                    "symbol": profile_style(name).plotly_symbol,
                    "line": {"color": "black", "width": 1.5},
                },
                "name": name,
                "legendgroup": name,
                "showlegend": k == 0,
                **axes,
            }
        )
    return traces


def best_settings_page_figure(best: BestSettings) -> Figure:
    """One engine's front, training and held-out side by side (best-settings-E.png's)."""
    colour = engine_colours([best.engine])[best.engine]
    traces: list[dict] = []
    layout: dict[str, Any] = {
        "height": 420,
        "grid": {"rows": 1, "columns": len(_PANELS), "pattern": "independent"},
        "title": {"text": f"{text(best.engine)}: error against cost"},
        "legend": {"font": {"size": 10}},
        "margin": {"t": 70},
        "annotations": [],
    }
    for k, (which, title) in enumerate(_PANELS):
        traces += _panel_traces(best, which, k, colour)
        suffix = "" if k == 0 else str(k + 1)
        layout[f"xaxis{suffix}"] = {  # plain numbers, as the PNG's axis (10,000, not 10k)
            "type": "log",
            "exponentformat": "none",
            "separatethousands": True,
            "title": {"text": cost_axis(best.cost_clock)},
        }
        layout[f"yaxis{suffix}"] = {
            "title": {"text": SCORE_AXIS},
            **({"matches": "y"} if k else {}),
        }
        layout["annotations"].append(
            {
                "text": title,
                "xref": f"x{suffix} domain",
                "yref": f"y{suffix} domain",
                "x": 0.5,
                "y": 1.0,
                "yanchor": "bottom",
                "showarrow": False,
            }
        )
    return {"data": traces, "layout": layout}
