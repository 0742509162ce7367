"""The comparison suite and its report, on the quick sweep."""

from __future__ import annotations

import pandas as pd
import pytest

from hoopbench.reports.markdown import write_markdown
from hoopbench.reports.suite import Case, default_cases, run_case, run_report, suite_scenes


@pytest.fixture(scope="module")
def quick_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    return out, run_report(out, quick=True, workers=1)


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_quick_report_writes_its_files(quick_report):
    out, report = quick_report
    assert report == out / "report.md"
    for name in ("runs.csv", "runs.parquet", "error_vs_time.png", "hoop_seed.png"):
        assert (out / name).stat().st_size > 0
    assert any((out / "trajectories").glob("*.parquet"))


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_runs_table_is_tidy_and_complete(quick_report):
    out, _ = quick_report
    runs = pd.read_parquet(out / "runs.parquet")
    cases = default_cases(quick=True)
    assert len(runs) == len(cases)
    assert not runs.duplicated(["scene", "engine", "variant", "timestep"]).any()
    assert set(runs["status"]) <= {"ok", "diverged", "error", "unavailable"}
    csv = pd.read_csv(out / "runs.csv", comment="#")
    assert list(csv.columns) == list(runs.columns)
    ref = runs[(runs["engine"] == "reference") & (runs["scene"] == "seed-mu")].iloc[0]
    # The reference row measures the detectors' own bias: it must be small.
    assert abs(ref["err_t_slip_ms"]) < 0.1


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_report_has_the_tables(quick_report):
    _, report = quick_report
    text = report.read_text()
    for heading in (
        "## Slip onset",
        "## Lift-off, hop height and impact",
        "## Error against run time",
        "## Stability",
    ):
        assert heading in text
    assert "| reference |" in text


@pytest.mark.slow  # the quick suite, about 10 s once per module
def test_write_markdown_leaves_its_input_alone(quick_report, tmp_path):
    """The report derives its columns locally: the caller's frame comes back unchanged, here one
    that lacks the optional columns which the report fills with blanks."""
    out, _ = quick_report
    optional = ["phases", "phases_agree", "exact_phases", "outcome_agrees", "max_penetration_m"]
    frame = pd.read_parquet(out / "runs.parquet").drop(columns=optional)
    before, columns = frame.copy(), list(frame.columns)
    assert write_markdown(frame, tmp_path, generated="now") == tmp_path / "report.md"
    assert list(frame.columns) == columns
    pd.testing.assert_frame_equal(frame, before)
    assert "## Stability" in (tmp_path / "report.md").read_text()


def test_a_broken_run_becomes_an_error_row():
    row = run_case(Case("seed-mu", "mujoco", "bad", 1e-4, options={"cone": "hexagonal"}))
    assert row["status"] == "error"
    assert "cone must be one of" in row["message"]


def test_default_sweep_covers_every_engine_and_the_hop_scenes():
    cases = default_cases()
    assert {c.engine for c in cases} == {"reference", "mujoco", "pybullet", "pymunk"}
    assert {"seed-mu", "hop-top", "hop-bottom"} <= set(suite_scenes())
    assert {c.variant for c in cases if c.engine == "pybullet"} >= {"geometry=hull"}
