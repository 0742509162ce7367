"""`make report` and `make bench` install hoopbench with the `engines` extra alone, while this
suite runs in a venv with the test extra (Dask, Optuna, pytest, ...): a module-level import of
a package only the test extra brings passes here and fails on a fresh clone. psutil did so
(the CLI's parser imported the bench, which imported psutil, Dask's dependency): `make
report` stopped with a traceback before running anything. So every hoopbench module is
imported, and the CLI's parser built, in a process where the installed packages that
`hoopbench[engines]` does not bring (read from the installed metadata) cannot be imported;
and where those of a plain `pip install hoopbench`, which runs the engines it has and says
"unavailable" for the others, cannot."""

from __future__ import annotations

import re
import subprocess
import sys
from importlib.metadata import PackageNotFoundError, distribution, packages_distributions

import pytest
from packaging.requirements import Requirement

MAKE_REPORT_EXTRAS = frozenset({"engines"})
"""The extras the Makefile's report and bench targets install."""

_IMPORT_ALL = """
import importlib, importlib.abc, pkgutil, sys

BLOCKED = frozenset(sys.argv[1].split(","))


class Absent(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None


sys.meta_path.insert(0, Absent())
import hoopbench

for module in pkgutil.walk_packages(hoopbench.__path__, "hoopbench."):
    importlib.import_module(module.name)
from hoopbench.reports.cli import _parser

_parser()
print("imported")
"""


def _canonical(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _brought_by(extras: frozenset[str]) -> set[str]:
    """The distributions `pip install hoopbench[extras]` brings (canonical names), following
    the installed packages' own requirements, markers evaluated for this interpreter."""
    brought: set[str] = set()
    seen: set[tuple[str, frozenset[str]]] = set()
    todo = [("hoopbench", extras)]
    while todo:
        name, wanted = todo.pop()
        if (_canonical(name), wanted) in seen:
            continue
        seen.add((_canonical(name), wanted))
        try:
            requires = distribution(name).requires or []
        except PackageNotFoundError:
            continue  # not installed here: nothing of it to block either
        brought.add(_canonical(name))
        for text in requires:
            requirement = Requirement(text)
            marker = requirement.marker
            if marker is None or any(marker.evaluate({"extra": e}) for e in wanted or {""}):
                todo.append((requirement.name, frozenset(requirement.extras)))
    return brought


def _not_brought(extras: frozenset[str]) -> set[str]:
    """Top-level modules installed here by distributions that hoopbench[extras] does not
    bring (a module that one of its distributions also provides is not counted)."""
    brought = _brought_by(extras)
    return {
        module
        for module, dists in packages_distributions().items()
        if module.isidentifier() and not any(_canonical(d) in brought for d in dists)
    }


def test_the_test_extra_brings_packages_make_report_does_not():
    """The check below is not empty here: the test venv has Dask, Optuna and pytest, which
    `make report`'s install does not."""
    absent = _not_brought(MAKE_REPORT_EXTRAS)
    assert {"dask", "optuna", "pytest"} <= absent
    assert not {"numpy", "mujoco", "hoopbench"} & absent
    assert {"jax", "newton", "dask"} <= _not_brought(frozenset())


@pytest.mark.parametrize(
    "extras", [MAKE_REPORT_EXTRAS, frozenset()], ids=["make report's", "a plain install's"]
)
def test_every_module_imports_with_that_install_alone(extras):
    blocked = _not_brought(extras)
    done = subprocess.run(
        [sys.executable, "-c", _IMPORT_ALL, ",".join(sorted(blocked))],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0 and done.stdout.strip() == "imported", done.stderr[-2000:]
