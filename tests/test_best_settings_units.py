"""The Best settings figures in the report's one cost unit (issue 35): seconds of stepping
per simulated second, as the section's table and the answer say it; front.csv stores us."""

import json
from pathlib import Path

import numpy as np
import pytest

from hoopbench.engines.judging.score import CostClock
from hoopbench.reports.report.best_settings import best_settings, best_settings_section, cost_axis
from hoopbench.reports.report.page_best_settings import best_settings_page_figure
from hoopbench.reports.sweep.folder_files import FolderFileError

SEARCH = Path(__file__).resolve().parents[1] / "reports" / "tune" / "searches" / "pymunk"


def test_the_page_figure_draws_costs_in_seconds_per_simulated_second():
    (best,) = best_settings([SEARCH])
    figure = best_settings_page_figure(best)
    pareto = best.front[best.front["kind"] == "pareto"].sort_values("train_cost_us_per_s")
    drawn = next(t for t in figure["data"] if t["name"] == "Pareto set")
    np.testing.assert_allclose(drawn["x"], pareto["train_cost_us_per_s"] * 1e-6, rtol=1e-3)
    axis = cost_axis(best.cost_clock)
    assert figure["layout"]["xaxis"]["title"]["text"] == axis
    assert "us" not in axis.split() and "per simulated s" in axis
    assert all("us/sim" not in str(t.get("hovertemplate")) for t in figure["data"])


def _copy_with_clock(tmp_path: Path, clock: object) -> Path:
    """The shipped pymunk search (made before the clock key) with tune.json's cost_clock set
    to ``clock`` (None: as shipped, no key)."""
    folder = tmp_path / "pymunk"
    folder.mkdir()
    for name in ("front.csv", "trials.csv", "settings.toml"):
        (folder / name).write_bytes((SEARCH / name).read_bytes())
    spec = json.loads((SEARCH / "tune.json").read_text())
    assert "cost_clock" not in spec  # every shipped search so far: wall time
    if clock is not None:
        spec["cost_clock"] = clock
    (folder / "tune.json").write_text(json.dumps(spec))
    return folder


def test_a_search_without_a_clock_is_said_to_be_wall_time(tmp_path: Path) -> None:
    (best,) = best_settings([_copy_with_clock(tmp_path, None)])
    assert best.cost_clock is CostClock.WALL
    section = best_settings_section([best], tmp_path)
    assert "training cost (wall s per simulated s)" in section
    assert "Its costs are wall time (its tune.json names no cost_clock" in section
    assert "0 of the 1 searches here are costed by CPU time, 1 by wall time" in section
    assert "CPU s per simulated s" not in section


def test_a_search_costed_by_cpu_time_says_so_in_its_table_figure_and_hovers(
    tmp_path: Path,
) -> None:
    (best,) = best_settings([_copy_with_clock(tmp_path, "cpu")])
    assert best.cost_clock is CostClock.CPU
    section = best_settings_section([best], tmp_path)
    assert "training cost (CPU s per simulated s)" in section
    assert "Its costs are the process's CPU time" in section
    assert "1 of the 1 searches here are costed by CPU time;" in section
    assert "wall s per simulated s" not in section  # the tiers' line and the table
    figure = best_settings_page_figure(best)
    assert figure["layout"]["xaxis"]["title"]["text"] == "cost, CPU s of stepping per simulated s"
    hovers = [str(t.get("hovertemplate")) for t in figure["data"]]
    assert all("CPU s/sim s" in h and "wall" not in h for h in hovers)


def test_a_clock_that_is_none_of_them_is_refused_naming_the_key(tmp_path: Path) -> None:
    with pytest.raises(FolderFileError, match=r"tune.json: cost_clock must be 'cpu' or 'wall'"):
        best_settings([_copy_with_clock(tmp_path, "sundial")])
