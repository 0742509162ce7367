"""The architecture in the imports: models -> reference/engines -> reports, never upward."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
FIRST_PARTY = {"models", "reference", "engines", "reports"}
ALLOWED = {
    "models": {"models"},
    "reference": {"models", "reference"},
    # The reference is one more engine: its adapter may call it.
    "engines": {"models", "reference", "engines"},
    "reports": FIRST_PARTY,
}


def imported_packages(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names & FIRST_PARTY


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_no_import_runs_upward(package):
    files = sorted((ROOT / package).rglob("*.py"))
    assert files
    for path in files:
        wrong = imported_packages(path) - ALLOWED[package]
        assert not wrong, f"{path.relative_to(ROOT)} imports {sorted(wrong)}"


def test_reference_solver_and_dae_are_independent():
    """The DAE cross-check must not reuse the solver it checks."""
    tree = ast.parse((ROOT / "reference" / "dae.py").read_text())
    modules = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not modules & {"reference.exact", "reference.dynamics"}
