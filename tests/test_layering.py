"""The architecture in the imports: models -> reference/engines -> reports, never upward.

Inside engines/ and reports/ the rooms have an order too (RANKS), no module imports itself
back through others (no circle), and no hoopbench import hides inside a function, where it
would hide a circle, except in the command line and the package root (start-up speed).
"""

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


# Rooms inside a package, lowest first: a module may import its own room and lower ones.
RANKS = {
    "engines": {
        "run": 0,
        "options": 0,
        "judging": 1,
        "stopping": 2,
        "settings": 3,
        "standalone": 3,
        "warp_compile": 3,
        "base": 4,
        "registry": 5,
        "adapters": 6,  # every *_engine.py: each registers itself in the registry
        "__init__": 7,
    },
    "reports": {
        "sweep": 0,
        "compare": 1,
        "hop_map": 2,
        "tune": 2,
        "report": 3,
        "report_runs": 3,
        "bench": 4,
        "api": 5,
        "cli": 6,
        "__init__": 7,
    },
}
LAZY_ALLOWED = {"reports/cli.py", "about/__init__.py"}
"""The only files that may import hoopbench inside a function: they keep start-up fast."""


def room(package: str, parts: list[str]) -> str:
    """The room of module hoopbench.<package>.<parts...> (parts after the package)."""
    if not parts:
        return "__init__"
    head = parts[0]
    if package == "engines" and head.endswith("_engine"):
        return "adapters"
    return head


def package_files() -> list[Path]:
    return [p for folder in (*FIRST_PARTY, "about") for p in sorted((ROOT / folder).rglob("*.py"))]


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    parts[0] = "hoopbench" if parts[0] == "about" else f"hoopbench.{parts[0]}"
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


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


@pytest.mark.parametrize("package", sorted(RANKS))
def test_rooms_import_only_lower_rooms(package):
    ranks = RANKS[package]
    for path in sorted((ROOT / package).rglob("*.py")):
        mine = room(package, list(path.relative_to(ROOT / package).with_suffix("").parts))
        for name in imported_modules(path):
            parts = name.split(".")
            if parts[:2] != ["hoopbench", package]:
                continue
            theirs = room(package, parts[2:])
            assert ranks[theirs] <= ranks[mine], (
                f"{path.relative_to(ROOT)} ({mine}) imports {name} ({theirs}), a higher room"
            )


def test_no_hoopbench_import_inside_a_function():
    for path in package_files():
        rel = str(path.relative_to(ROOT))
        if rel in LAZY_ALLOWED:
            continue
        tree = ast.parse(path.read_text())
        top = {id(node) for node in tree.body}
        inner = [
            node.lineno
            for node in ast.walk(tree)
            if isinstance(node, ast.Import | ast.ImportFrom)
            and id(node) not in top
            and any(name.startswith("hoopbench") for name in _names(node))
        ]
        assert not inner, f"{rel}: hoopbench imported inside a function on lines {inner}"


def resolved_imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """The package modules the file imports; ``from pkg import mod`` is an edge to pkg.mod,
    not to pkg (importing a sibling module runs pkg/__init__ only once it is loaded)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out.update(alias.name for alias in node.names if alias.name in modules)
        elif isinstance(node, ast.ImportFrom) and node.module in modules and not node.level:
            subs = {f"{node.module}.{alias.name}" for alias in node.names}
            found = subs & modules.keys()
            out.update(found or {node.module})
    return out


def _names(node: ast.Import | ast.ImportFrom) -> list[str]:
    if isinstance(node, ast.ImportFrom):
        return [node.module or ""]
    return [alias.name for alias in node.names]


def test_no_import_circle():
    """Every import of a package module, wherever it stands, as an edge: the graph has no
    cycle (a module importing its own package's __init__ counts too)."""
    modules = {module_name(p): p for p in package_files()}
    graph = {
        name: {m for m in resolved_imports(path, modules) if m != name}
        for name, path in modules.items()
    }
    state: dict[str, int] = {}

    def visit(name: str, stack: list[str]) -> None:
        state[name] = 1
        for nxt in sorted(graph[name]):
            if state.get(nxt) == 1:
                cycle = stack[stack.index(nxt) :] if nxt in stack else [nxt]
                pytest.fail("import circle: " + " -> ".join([*cycle, name, nxt]))
            if nxt not in state:
                visit(nxt, [*stack, nxt])
        state[name] = 2

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
