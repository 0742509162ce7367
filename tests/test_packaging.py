"""pyproject.toml's packages and package data agree with the folders: setuptools' warning
"Package 'X' is absent from the `packages` configuration" (printed on every install, issue 35)
comes from a data file whose folder is not a listed package. Read from the configuration
alone, in milliseconds: no install runs."""

from __future__ import annotations

import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SETUPTOOLS = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def _folder(package: str) -> Path:
    """A package's folder by `package-dir` (the longest mapped prefix of its name)."""
    mapped = SETUPTOOLS["package-dir"]
    parts = package.split(".")
    for k in range(len(parts), 0, -1):
        prefix = ".".join(parts[:k])
        if prefix in mapped:
            return ROOT / mapped[prefix] / Path(*parts[k:])
    return ROOT / Path(*parts)


def test_every_listed_package_has_its_folder():
    missing = [p for p in SETUPTOOLS["packages"] if not _folder(p).is_dir()]
    assert not missing


def test_every_data_file_lies_in_a_listed_package():
    """Each package-data pattern matches files, and each file's own folder is a package of
    `packages`: a pattern reaching into a subfolder ("suites/*.toml") is what setuptools
    warns about, since Python could import that subfolder as a package of its own."""
    folders = {_folder(p).resolve(): p for p in SETUPTOOLS["packages"]}
    for package, patterns in SETUPTOOLS["package-data"].items():
        for pattern in patterns:
            files = sorted(_folder(package).glob(pattern))
            assert files, (package, pattern)
            outside = [f for f in files if f.parent.resolve() not in folders]
            assert not outside, f"{package}: {pattern} holds files of no listed package"
