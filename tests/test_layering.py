"""The architecture in the imports: models -> reference/engines -> reports, never upward."""

from __future__ import annotations

import ast
import subprocess
import sys
from importlib.metadata import version
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


def imported_modules(path: Path) -> set[str]:
    """Every absolute module name the file imports."""
    tree = ast.parse(path.read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def imported_packages(path: Path) -> set[str]:
    """The hoopbench sub-packages (models, reference, ...) the file imports."""
    parts = (name.split(".") for name in imported_modules(path))
    return {p[1] for p in parts if len(p) > 1 and p[0] == "hoopbench"} & FIRST_PARTY


@pytest.mark.parametrize("package", sorted(ALLOWED))
def test_no_import_runs_upward(package):
    files = sorted((ROOT / package).rglob("*.py"))
    assert files
    for path in files:
        wrong = imported_packages(path) - ALLOWED[package]
        assert not wrong, f"{path.relative_to(ROOT)} imports {sorted(wrong)}"


@pytest.mark.parametrize("folder", [*sorted(ALLOWED), "tests"])
def test_imports_use_the_installed_names(folder):
    """`import models` would find another project's package: only hoopbench.* names."""
    for path in sorted((ROOT / folder).rglob("*.py")):
        bare = {m for m in imported_modules(path) if m.split(".")[0] in FIRST_PARTY}
        assert not bare, f"{path.relative_to(ROOT)} imports {sorted(bare)} without hoopbench."
        # A relative import (`from .. import engines`) would slip past the layering check.
        tree = ast.parse(path.read_text())
        relative = [n.lineno for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) and n.level]
        assert not relative, f"{path.relative_to(ROOT)}: relative import on lines {relative}"


def test_reference_solver_and_dae_are_independent():
    """The DAE cross-check must not reuse the solver it checks."""
    tree = ast.parse((ROOT / "reference" / "dae.py").read_text())
    modules = {n.module for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not modules & {"hoopbench.reference.exact", "hoopbench.reference.dynamics"}


def test_installed_names(tmp_path):
    """Installed, the project is `hoopbench.*` only: `import models` finds nothing of ours."""
    code = (
        "import importlib.util, hoopbench, hoopbench.models, hoopbench.engines;"
        "import hoopbench.reference, hoopbench.reports;"
        "print(hoopbench.__version__);"
        "print([n for n in ('models', 'engines', 'reference', 'reports')"
        " if importlib.util.find_spec(n) is not None])"
    )
    # Another folder as working directory: the repository root is then not on sys.path.
    out = subprocess.run(
        [sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, check=True
    ).stdout.split("\n")
    assert out[0] == version("hoopbench")
    assert out[1] == "[]"
