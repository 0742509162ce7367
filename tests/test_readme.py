"""The README as a newcomer reads it: short, every link leads somewhere, and every command in
it works as written (run here in a scratch folder; `make` targets dry-run, the install's
extra checked against pyproject.toml)."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
MAX_LINES = 250


def _blocks(language: str) -> list[str]:
    return re.findall(rf"```{language}\n(.*?)```", README.read_text(encoding="utf-8"), re.S)


def _commands() -> list[str]:
    """Each command line of the README's shell blocks, its comment cut off."""
    lines = [line.split("  #")[0].strip() for block in _blocks("sh") for line in block.splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


def test_the_readme_is_short():
    assert len(README.read_text(encoding="utf-8").splitlines()) <= MAX_LINES


def test_every_relative_link_of_the_readme_leads_to_a_file():
    links = re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", README.read_text(encoding="utf-8"))
    local = [link for link in links if "://" not in link]
    assert local
    missing = [link for link in local if not (ROOT / link).exists()]
    assert not missing


def test_the_readme_has_the_files_a_project_has():
    for name in ("LICENSE", "CHANGELOG.md", "CITATION.cff", "CONTRIBUTING.md"):
        assert (ROOT / name).is_file(), name
        assert name in README.read_text(encoding="utf-8")


def test_make_targets_and_the_install_extra_exist():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"
    ]
    seen = set()
    for command in _commands():
        words = shlex.split(command)
        if words[0] == "make":
            dry = subprocess.run(["make", "-n", *words[1:]], cwd=ROOT, capture_output=True)
            assert dry.returncode == 0, (command, dry.stderr)
            seen.add("make")
        elif words[:3] == ["pip", "install", "-e"]:
            extra = re.fullmatch(r"\.\[(\w+)\]", words[3])
            assert extra and extra[1] in extras, command
            seen.add("pip")
    assert seen == {"make", "pip"}


@pytest.mark.slow  # the quick suite and its report, about 20 s
def test_every_hoopbench_command_of_the_readme_works_as_written(tmp_path):
    """Run in order in one scratch folder, as a reader would (the report reads the suite's
    results): each exits 0."""
    commands = [c for c in _commands() if c.startswith("hoopbench ")]
    assert len(commands) >= 4
    script = Path(sys.executable).parent / "hoopbench"
    for command in commands:
        words = shlex.split(command)
        done = subprocess.run(
            [str(script), *words[1:]], cwd=tmp_path, capture_output=True, text=True, timeout=600
        )
        assert done.returncode == 0, (command, done.stderr[-2000:])


def test_the_python_quickstart_runs(tmp_path, capsys):
    (code,) = _blocks("python")
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    finally:
        os.chdir(cwd)
    out = capsys.readouterr().out.splitlines()
    assert out[0].startswith("hops 1.171")


def test_python_m_hoopbench_is_the_command_line():
    done = subprocess.run(
        [sys.executable, "-m", "hoopbench", "--help"], capture_output=True, text=True, check=True
    )
    assert done.stdout.startswith("usage: hoopbench")
