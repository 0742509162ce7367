"""The row selections every report section shares (reports/compare/selection.py)."""

from __future__ import annotations

import pandas as pd

from hoopbench.reports.compare.selection import (
    default_rows,
    engine_names_of,
    engine_rows,
    ok_rows,
    profile_of,
    reference_rows,
)

FRAME = pd.DataFrame(
    {
        "engine": ["reference", "mujoco", "pymunk", "mujoco"],
        "variant": ["default", "default", "iterations=10", "default"],
        "status": ["ok", "diverged", "ok", "ok"],
        "profile": ["tuned", "stock", None, "tuned"],
    }
)


def test_engines_and_reference_split_the_table():
    assert list(engine_rows(FRAME).index) == [1, 2, 3]
    assert list(reference_rows(FRAME).index) == [0]
    assert engine_names_of(FRAME) == ["mujoco", "pymunk"]


def test_default_and_ok_rows():
    assert list(default_rows(FRAME).index) == [0, 1, 3]
    assert list(ok_rows(FRAME).index) == [0, 2, 3]


def test_a_missing_profile_is_tuned():
    assert list(profile_of(FRAME)) == ["tuned", "stock", "tuned", "tuned"]
    assert list(profile_of(FRAME.drop(columns="profile"))) == ["tuned"] * 4
