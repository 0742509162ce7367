"""One vocabulary of row columns (engines/judging/columns.py): every table names its
columns through it, and the verdict reads a row only through it."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from hoopbench.engines.judging.columns import EXACT_COLUMNS, Col
from hoopbench.engines.judging.comparison import exact_columns
from hoopbench.models.events import Events, Outcome
from hoopbench.reports.compare.suite import ROW_COLUMNS
from hoopbench.reports.hop_map.stages import EXACT_CARRIED, MAP_COLUMNS

ROOT = Path(__file__).resolve().parent.parent
READERS = ["engines/judging/verdict.py", "engines/judging/comparison.py"]


@pytest.mark.parametrize(
    "table", [ROW_COLUMNS, MAP_COLUMNS, EXACT_CARRIED], ids=["runs", "map", "exact-carried"]
)
def test_every_table_column_is_a_named_column(table):
    assert all(isinstance(c, Col) for c in table)
    assert len(set(table)) == len(table)


def test_the_exact_columns_are_what_exact_columns_builds():
    built = exact_columns(Events(Outcome.ROLLS))
    assert tuple(built) == EXACT_COLUMNS
    assert set(EXACT_COLUMNS) <= set(ROW_COLUMNS) and set(EXACT_COLUMNS) <= set(MAP_COLUMNS)


@pytest.mark.parametrize("path", READERS)
def test_rows_are_read_by_named_columns_only(path):
    """`row.get("exact_t_slp")` would read a misspelt column as missing without a word;
    `row.get(Col.EXACT_T_SLP)` fails at once. No string literal indexes a row here."""
    tree = ast.parse((ROOT / path).read_text())
    literal = []
    for node in ast.walk(tree):
        call = isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
        if call and node.func.attr == "get" and _is_row(node.func.value) and _str_arg(node.args):
            literal.append(node.lineno)
        if isinstance(node, ast.Subscript) and _is_row(node.value) and _str_arg([node.slice]):
            literal.append(node.lineno)
    assert not literal, f"{path}: a row read by a string literal on lines {literal}"


def _is_row(node: ast.expr) -> bool:
    return isinstance(node, ast.Name) and node.id in {"row", "exact"}


def _str_arg(args: list[ast.expr]) -> bool:
    return bool(args) and isinstance(args[0], ast.Constant) and isinstance(args[0].value, str)


def test_a_misspelt_column_is_an_error():
    with pytest.raises(AttributeError):
        _ = Col.EXACT_T_SLP  # type: ignore[attr-defined]
