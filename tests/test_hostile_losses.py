"""The fourth round of hostile inputs (issue 36): nothing lost, nothing hangs, nothing silently
wrong. One section per class of the issue; each test failed against the code before it.

- losses: nothing is written through a link (the lock file, a search's subfolders); a search
  is resumed only from the full record it needs (journal.log, tune.json, sweep.json) and with
  its own options; a settings file the user edited is not replaced; a file replaced whole
  keeps its mode;
- hangs: the held-out draw is capped before anything is written;
- silent: a search whose budget ran no trial says so; a tampered journal is refused; front.csv
  is read as written; duplicated options and empty API lists are refused; a plugin that exits
  is named.
"""

from __future__ import annotations

import os
import shutil
import stat
from pathlib import Path

import pytest

from hoopbench.reports.cli import main

TINY = 'name = "tiny"\nengines = ["reference"]\ntimesteps = [1e-3]\nscenes = ["seed"]\n'
SHIPPED = Path(__file__).resolve().parents[1] / "reports" / "tune" / "searches" / "pymunk"


def one_line(capsys: pytest.CaptureFixture[str]) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("hoopbench: ") and "Traceback" not in captured.err
    return lines[0]


@pytest.fixture(scope="module")
def results(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A compare folder: the reference on seed at 1 ms."""
    root = tmp_path_factory.mktemp("results")
    (root / "tiny.toml").write_text(TINY)
    out = root / "res"
    assert main(["compare", "--suite", str(root / "tiny.toml"), "--out", str(out), "--quiet"]) == 0
    return out


def copy_of(folder: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(folder, tmp_path / folder.name, symlinks=True))


# =========================================================================== losses
@pytest.mark.parametrize("command", ["report", "compare"])
def test_a_lock_file_linked_out_of_the_folder_is_not_emptied(
    command: str, results: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`report --results DIR` (which writes into DIR) emptied the file the lock linked to."""
    folder = copy_of(results, tmp_path)
    mine = tmp_path / "mine.txt"
    mine.write_text("my thesis\n")
    (folder / ".sweep.lock").unlink()
    (folder / ".sweep.lock").symlink_to(mine)
    if command == "report":
        argv = ["report", "--results", str(folder)]
    else:
        argv = ["compare", "--suite", str(folder / "suite.toml"), "--out", str(folder), "--resume"]
    assert main(argv) == 2
    line = one_line(capsys)
    assert f"{folder / '.sweep.lock'} is a link" in line
    assert mine.read_text() == "my thesis\n"


def test_a_lock_file_that_is_a_fifo_is_named(
    results: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It said "Illegal seek"."""
    folder = copy_of(results, tmp_path)
    (folder / ".sweep.lock").unlink()
    os.mkfifo(folder / ".sweep.lock")
    assert main(["report", "--results", str(folder)]) == 2
    assert f"{folder / '.sweep.lock'} is not a regular file" in one_line(capsys)


def test_findings_update_keeps_the_files_mode(results: Path, tmp_path: Path) -> None:
    """A mode-600 README became 644."""
    from hoopbench.reports.report.findings import README_BEGIN, README_END

    readme = tmp_path / "README.md"
    readme.write_text(f"x\n{README_BEGIN}\nold\n{README_END}\n")
    readme.chmod(0o600)
    assert main(["findings", "--results", str(results), "--update", str(readme)]) == 0
    assert "old" not in readme.read_text()
    assert stat.S_IMODE(readme.stat().st_mode) == 0o600


@pytest.mark.parametrize("command", ["simulate", "reference"])
def test_a_trajectory_written_with_force_keeps_the_files_mode(command: str, tmp_path: Path) -> None:
    """simulate --csv --force made a mode-600 file 644."""
    csv = tmp_path / "t.csv"
    csv.write_text("mine\n")
    csv.chmod(0o600)
    engine = ["--engine", "pymunk", "--dt", "1e-3"] if command == "simulate" else []
    argv = [command, *engine, "--scene", "seed-mu", "--t-end", "0.05", "--csv", str(csv)]
    assert main([*argv, "--force"]) == 0
    assert csv.read_text() != "mine\n"
    assert stat.S_IMODE(csv.stat().st_mode) == 0o600
