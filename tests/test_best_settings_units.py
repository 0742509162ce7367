"""The Best settings figures in the report's one cost unit (issue 35): seconds of stepping
per simulated second, as the section's table and the answer say it; front.csv stores us."""

from pathlib import Path

import numpy as np

from hoopbench.reports.report.best_settings import COST_AXIS, best_settings
from hoopbench.reports.report.page_best_settings import best_settings_page_figure

SEARCH = Path(__file__).resolve().parents[1] / "reports" / "tune" / "searches" / "pymunk"


def test_the_page_figure_draws_costs_in_seconds_per_simulated_second():
    (best,) = best_settings([SEARCH])
    figure = best_settings_page_figure(best)
    pareto = best.front[best.front["kind"] == "pareto"].sort_values("train_cost_us_per_s")
    drawn = next(t for t in figure["data"] if t["name"] == "Pareto set")
    np.testing.assert_allclose(drawn["x"], pareto["train_cost_us_per_s"] * 1e-6, rtol=1e-3)
    assert figure["layout"]["xaxis"]["title"]["text"] == COST_AXIS
    assert "us" not in COST_AXIS.split() and "per simulated s" in COST_AXIS
    assert all("us/sim" not in str(t.get("hovertemplate")) for t in figure["data"])
