"""Loads reports/report/tolerances.toml: the one source of the regression tolerances."""

from __future__ import annotations

import tomllib
from functools import cache
from importlib.resources import files
from typing import Any

__all__ = ["tolerances"]


@cache
def tolerances() -> dict[str, Any]:
    """The parsed tolerances file (read once)."""
    return tomllib.loads(files("hoopbench.reports.report").joinpath("tolerances.toml").read_text())
