"""Where the two readings differ (reports/report/readings.py)."""

from __future__ import annotations

import pandas as pd

from hoopbench.reports.report.readings import reading_differences

BASE = {
    "engine": "mujoco",
    "profile": "stock",
    "variant": "default",
    "timestep": 1e-4,
    "status": "ok",
    "kin_phases": "R S+ R S- R",
    "phases": "R S+ R S- R",
    "kin_err_t_slip_ms": 0.1,
    "err_t_slip_ms": 0.05,
    "kin_err_t_lift_ms": None,
    "err_t_lift_ms": None,
    "kin_err_t_impact_ms": None,
    "err_t_impact_ms": None,
}
"""A row with both readings: the kinematic one in kin_*, the canonical one unprefixed."""


def _frame(*rows: dict) -> pd.DataFrame:
    return pd.DataFrame([{**BASE, "scene": f"s{k}", **row} for k, row in enumerate(rows)])


def test_only_the_differences_beyond_the_resolution_are_listed():
    frame = _frame(
        {},  # the same within 1 ms: not listed
        {"kin_err_t_slip_ms": -914.0, "err_t_slip_ms": 1.32, "kin_phases": "R S- R S+ S- S+"},
        {"kin_err_t_lift_ms": 53.4, "err_t_lift_ms": None},  # one reading has it
        {"engine": "reference", "kin_err_t_slip_ms": -914.0},  # the reference is no engine
        {"variant": "iterations=10", "kin_err_t_slip_ms": -914.0},  # not the default settings
        {"timestep": 1e-3, "kin_err_t_slip_ms": -914.0},  # not the default timestep
    )
    table = reading_differences(frame)
    assert list(zip(table["scene"], table["event"], strict=True)) == [
        ("s1", "slip onset"),
        ("s1", "phases"),
        ("s2", "lift-off"),
    ]
    assert list(table.iloc[0][["kinematic", "contact"]]) == ["-914 ms", "+1.32 ms"]
    assert list(table.iloc[2][["kinematic", "contact"]]) == ["+53.4 ms", "none"]


def test_rows_without_both_readings_are_left_out():
    frame = _frame({"phases": None, "kin_err_t_slip_ms": -914.0})
    assert reading_differences(frame).empty
