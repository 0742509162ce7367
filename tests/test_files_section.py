"""The report's Files section lists what its folder holds, each link leading to it, with sizes:
on a made-up report folder (a suite's results inside it, a search outside), in milliseconds."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import unquote

import pytest

from hoopbench.reports.report.files_section import PAGE_NAME, files_section

LINK = re.compile(r"\[([^\]]*)\]\(([^)]*)\)")


def _file(path: Path, n_bytes: int) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"x" * n_bytes)


@pytest.fixture
def folder(tmp_path):
    """A report folder as `make report` leaves it before report.md: figures, the animation,
    a suite's results with 3 MB of trajectories; a search outside it."""
    out = tmp_path / "output" / "20261128-120000"
    _file(out / "paths_hop-top.png", 2_000)
    _file(out / "stability.png", 3_000)
    _file(out / "hop-top.gif", 50_000)
    suite = out / "default"
    _file(suite / "runs.csv", 10_000)
    _file(suite / "runs" / "part-1.parquet", 5_000)
    _file(suite / "meta.json", 500)
    _file(suite / ".sweep.lock", 10)
    for k in range(3):
        _file(suite / "trajectories" / f"run{k}.parquet", 1_000_000)
    search = tmp_path / "searches" / "pymunk"
    _file(search / "tune.json", 100)
    return out, suite, search


def _links(text: str) -> list[str]:
    return [unquote(target) for _, target in LINK.findall(text)]


def test_every_link_leads_to_a_file_of_the_folder(folder):
    out, suite, search = folder
    text = files_section(out, [suite, search])
    written_after = {"report.md", PAGE_NAME}  # written around the section
    targets = _links(text)
    assert targets
    missing = [t for t in targets if t not in written_after and not (out / t).exists()]
    assert not missing
    assert "runs.parquet" not in text  # the file the section used to name, which no sweep writes


def test_every_file_and_folder_present_is_listed(folder):
    out, suite, search = folder
    targets = {Path(t.rstrip("/")) for t in _links(files_section(out, [suite, search]))}
    present = {p.relative_to(out) for p in [*out.iterdir(), *suite.iterdir()]}
    hidden = {p for p in present if p.name.startswith(".")}  # the sweep's lock
    assert present - hidden <= targets
    assert Path("default/.sweep.lock") not in targets


def test_the_trajectories_share_of_the_folder_is_said(folder):
    out, suite, search = folder
    text = files_section(out, [suite, search])
    assert "[trajectories/](default/trajectories/) (3 files, 3.0 MB)" in text
    assert "The trajectories (default/trajectories/) are 3.0 MB of the folder's 3.1 MB" in text
    assert "delete them once the report is made" in text


def test_no_trajectories_no_note(folder):
    out, suite, _ = folder
    for path in (suite / "trajectories").iterdir():
        path.unlink()
    (suite / "trajectories").rmdir()
    text = files_section(out, [suite])
    assert "The trajectories" not in text
    assert "trajectories/" not in text


def test_a_report_written_into_its_results_folder_says_its_trajectories_share(folder):
    _, suite, _ = folder
    text = files_section(suite, [suite])  # `hoopbench report --results DIR`: out is DIR
    assert "[trajectories/](trajectories/) (3 files, 3.0 MB)" in text
    assert "The trajectories (trajectories/) are 3.0 MB of the folder's 3.0 MB" in text
