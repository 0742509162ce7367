"""The stability matrix: classes from synthetic rows, the matrix, the figure, the report."""

from __future__ import annotations

import pandas as pd
import pytest

from hoopbench.reports.compare.suite import ROW_COLUMNS
from hoopbench.reports.compare.suite_file import builtin_suite, load_suite
from hoopbench.reports.report.markdown import write_markdown
from hoopbench.reports.report.page_figures import stability_page_figure
from hoopbench.reports.report.stability import (
    ENERGY_GAIN_LIMIT,
    PENETRATION_LIMIT,
    Stability,
    classify,
    stability_figure,
    stability_matrix,
)

CLEAN = {
    "status": "ok",
    "message": "",
    "a": 1.0,
    "energy_rise_before_slip": 1e-6,
    "max_penetration_m": 1e-6,
    "verdict": "agrees",
    "outcome": "slips",
    "exact_outcome": "slips",
    "wall_time_s": 0.1,
    "us_per_step": 10.0,
}


@pytest.mark.parametrize(
    ("change", "expected", "figure"),
    [
        ({}, Stability.OK, ""),
        ({"status": "crashed", "message": "worker died"}, Stability.CRASHED, "worker died"),
        ({"status": "timeout"}, Stability.TIMEOUT, ""),
        ({"status": "error", "message": "boom"}, Stability.FAILED, "boom"),
        ({"status": "diverged", "message": "non-finite theta"}, Stability.DIVERGED, "non-finite"),
        ({"energy_rise_before_slip": 2 * ENERGY_GAIN_LIMIT}, Stability.ENERGY_GAIN, "+2 %"),
        ({"max_penetration_m": 0.02}, Stability.DEEP_PENETRATION, "2 % of a"),
        # The same 2 cm is shallow on a 10 m hoop: the limit is relative to the radius.
        ({"max_penetration_m": 0.02, "a": 10.0}, Stability.OK, ""),
        ({"verdict": "false-hop"}, Stability.WRONG_OUTCOME, "false-hop"),
        ({"verdict": "wrong-phases"}, Stability.OK, ""),  # the outcome is right
        # Worst first: a diverged run that also gained energy is diverged.
        ({"status": "diverged", "energy_rise_before_slip": 5.0}, Stability.DIVERGED, ""),
    ],
)
def test_classes_and_their_figures(change, expected, figure):
    kind, text = classify({**CLEAN, **change})
    assert kind is expected
    assert figure in text


def test_rows_without_a_verdict_fall_back_on_outcome_agreement():
    row = {**CLEAN, "verdict": None, "outcome_agrees": False, "outcome": "hops"}
    assert classify(row) == (Stability.WRONG_OUTCOME, "hops (exact slips)")
    assert classify({**row, "outcome_agrees": True})[0] is Stability.OK


def test_the_penetration_limit_is_a_fraction_of_the_radius():
    assert PENETRATION_LIMIT == 0.01


def rows() -> pd.DataFrame:
    out = []
    for scene in ("lam-0.99", "mu-5"):
        for engine in ("reference", "mujoco"):
            for dt in (1e-2, 1e-3):
                bad = engine == "mujoco" and dt == 1e-2
                out.append(
                    {
                        **CLEAN,
                        "scene": scene,
                        "engine": engine,
                        "variant": "default",
                        "profile": "tuned",
                        "timestep": dt,
                        "suite": "stability",
                        "status": "diverged" if bad else "ok",
                    }
                )
    # A variant's run is not a cell, even listed first.
    out.insert(0, {**out[0], "variant": "cone=pyramidal", "status": "crashed"})
    frame = pd.DataFrame(out)
    # Every other column of a real row, empty, as the report reads them.
    return frame.reindex(columns=list(dict.fromkeys([*frame.columns, *ROW_COLUMNS])))


def test_matrix_has_a_cell_per_scene_engine_and_timestep(tmp_path):
    table = stability_matrix(rows())
    assert list(table.columns) == [1e-2, 1e-3]
    assert list(table.index) == [
        ("lam-0.99", "reference"),
        ("lam-0.99", "mujoco"),
        ("mu-5", "reference"),
        ("mu-5", "mujoco"),
    ]
    assert table.loc[("mu-5", "mujoco"), 1e-2].startswith("diverged")
    assert table.loc[("mu-5", "reference"), 1e-2] == "ok"
    assert table.loc[("lam-0.99", "reference"), 1e-2] == "ok"  # its crashed variant is left out
    assert stability_figure(rows(), tmp_path / "s.png").stat().st_size > 0


def test_the_report_has_the_matrix_only_for_the_stability_suite(tmp_path):
    text = write_markdown(rows(), tmp_path, generated="now").read_text()
    assert "## Stability matrix" in text and "stability.png" in text
    other = rows().assign(suite="default")
    (tmp_path / "o").mkdir()
    text = write_markdown(other, tmp_path / "o", generated="now").read_text()
    assert "## Stability matrix" not in text


def test_the_shipped_stability_suite_covers_the_cases_asked_for():
    suite = load_suite(builtin_suite("stability"))
    assert suite.timesteps == (1e-2, 1e-3, 1e-4)  # 1e-5: left out for time (its comment)
    scenes = {s.name: s for s in suite.scenes}
    assert {"painleve", "lam-0.99", "lam-0.999", "mu-0.01", "mu-5", "lifts-at-start"} <= set(scenes)
    assert scenes["lifts-at-start"].lam * scenes["lifts-at-start"].chi > 1
    assert scenes["hoop-1cm"].a == 0.01 and scenes["hoop-1000kg"].M == 1000.0


def test_an_engine_run_at_some_timesteps_only_leaves_blank_cells(tmp_path):
    """The batched engines run the stability suite at 1e-3 only: their other cells are
    empty, drawn blank ("not run"), not a failed report."""
    frame = rows()
    frame = frame[~((frame["engine"] == "mujoco") & (frame["timestep"] == 1e-2))]
    table = stability_matrix(frame)
    assert table[1e-2].isna().any()
    assert stability_figure(frame, tmp_path / "s.png").stat().st_size > 0
    page = stability_page_figure(frame)
    assert page is not None
    z = page["data"][0]["z"]
    assert any(None in row for row in z)
