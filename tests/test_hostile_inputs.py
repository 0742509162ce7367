"""The third round of hostile inputs (issue 26): nothing hangs, nothing escapes, nothing is
overwritten. One section per class of the issue; each test failed against the code before it.

- escapes: a results folder's files are read only if they are regular files inside it
  (reports/sweep/folder_files.py); control characters from files and names are shown as their
  codes on the terminal and in the report (reports/sweep/control_chars.py);
- overwrites: a report never replaces the user's files, nor mixes with another report;
- hangs: FIFOs, devices and indices from a folder are refused before anything is read or
  allocated; integer options are capped;
- silent: a resume of a missing or edited map, an output inside a results folder, an API
  value the command line refuses;
- tracebacks: overflowing derived quantities, out-of-grid rows, /dev/zero;
- unclear: messages that name the option, the file, and what was kept.
"""

from __future__ import annotations

import fcntl
import json
import os
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import hoopbench as hb
from hoopbench.reports.cli import main

CONTROLS = "\x1b]0;pwned\x07\x1b[2J\x1b[31mFAKE\x1b[0m\x00\u202e\x9b"
"""An escape sequence that retitles and clears a terminal and paints a red line, a BEL, a
NUL, a right-to-left override and a lone C1 CSI."""
RAW = ("\x1b", "\x07", "\x00", "\u202e", "\x9b")
TINY = 'name = "tiny"\nengines = ["reference"]\ntimesteps = [1e-3]\nscenes = ["seed"]\n'


def one_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("hoopbench: ") and "Traceback" not in captured.err
    return lines[0]


def no_raw_controls(text: str) -> bool:
    return not any(char in text for char in RAW)


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> Path:
    """A compare folder: the reference on seed at 1 ms, its trajectory kept."""
    root = tmp_path_factory.mktemp("results")
    (root / "tiny.toml").write_text(TINY)
    out = root / "res"
    argv = ["compare", "--suite", str(root / "tiny.toml"), "--out", str(out), "--quiet"]
    assert main([*argv, "--trajectories", "default"]) == 0
    return out


@pytest.fixture(scope="module")
def tiny_map(tmp_path_factory) -> Path:
    """A 2 x 2 map of the exact regimes alone (no engine: seconds)."""
    out = tmp_path_factory.mktemp("map") / "m"
    argv = ["map", "--grid", "2x2", "--engines", "--t-end", "0.5", "--out", str(out), "--quiet"]
    assert main(argv) == 0
    return out


def copy_of(folder: Path, tmp_path: Path) -> Path:
    return Path(shutil.copytree(folder, tmp_path / folder.name, symlinks=True))


def report(folder: Path, out: Path) -> int:
    return main(["report", "--results", str(folder), "--out", str(out)])


# =========================================================================== escapes
def test_a_display_file_linked_out_of_the_map_folder_is_not_read(tiny_map, tmp_path, capsys):
    """Its numbers were embedded in report.html as the map's own."""
    folder = copy_of(tiny_map, tmp_path)
    stored = sorted((folder / "display").glob("*.parquet"))[0]
    outside = tmp_path / "elsewhere.parquet"
    shutil.copy(stored, outside)
    stored.unlink()
    stored.symlink_to(outside)
    assert report(folder, tmp_path / "r") == 2
    assert f"{stored} leads out of the results folder" in one_line(capsys)
    assert not (tmp_path / "r" / "report.html").exists()


def test_a_lock_files_content_reaches_the_terminal_as_text(results, tmp_path, capsys):
    folder = copy_of(results, tmp_path)
    fd = os.open(folder / ".sweep.lock", os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)  # another open file: it conflicts
        os.pwrite(fd, CONTROLS.encode(), 0)
        argv = ["compare", "--suite", str(folder / "suite.toml"), "--out", str(folder)]
        assert main([*argv, "--resume"]) == 2
    finally:
        os.close(fd)
    line = one_line(capsys)
    assert "is in use by another sweep" in line and "\\x1b]0;pwned\\x07" in line
    assert no_raw_controls(line)


def test_a_sweep_json_kind_reaches_the_terminal_as_text(results, tmp_path, capsys):
    folder = copy_of(results, tmp_path)
    (folder / "sweep.json").write_text(json.dumps({"kind": CONTROLS}))
    argv = ["compare", "--suite", str(folder / "suite.toml"), "--out", str(folder), "--resume"]
    assert main(argv) == 2
    line = one_line(capsys)
    assert "\\x1b[2J" in line and no_raw_controls(line)


def test_a_scene_name_in_the_progress_lines_is_text(tmp_path, capsys):
    name = json.dumps("x" + CONTROLS)
    (tmp_path / "s.toml").write_text(
        'name = "s"\nengines = ["reference"]\ntimesteps = [1e-3]\n'
        f"[[scene]]\nname = {name}\nlam = 0.9\nchi = 0.1\nmus = 0.8\nt_end = 0.2\n"
    )
    assert main(["compare", "--suite", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o")]) == 0
    err = capsys.readouterr().err
    assert "[1/1] x\\x1b]0;pwned" in err and no_raw_controls(err)


def test_control_characters_in_the_report_are_their_codes():
    from hoopbench.reports.report.escaping import escape_cell, escape_html, escape_text

    for escape in (escape_text, escape_cell, escape_html):
        shown = escape("hop" + CONTROLS)
        assert no_raw_controls(shown), escape.__name__
        assert "x1b" in shown and "u202e" in shown and "x9b" in shown
    assert escape_text("tab\tand plain text") == "tab\tand plain text"


# =========================================================================== overwrites
def test_a_report_never_replaces_the_users_figures_or_page(results, tmp_path, capsys):
    """A folder with report.html and error_vs_time.png but no report.md was written over."""
    out = tmp_path / "mine"
    out.mkdir()
    for name in ("report.html", "error_vs_time.png"):
        (out / name).write_text("mine")
    assert report(results, out) == 2
    line = one_line(capsys)
    assert f"'{out / 'report.html'}' exists; pass --force to replace it (and 1 more" in line
    assert {p.name: p.read_text() for p in out.iterdir()} == {
        "report.html": "mine",
        "error_vs_time.png": "mine",
    }


def test_two_reports_cannot_write_one_folder_at_once(results, tmp_path, capsys):
    """Both exited 0, one report.md overwritten and the figures mixed; the sweeps' lock
    serves: the second is refused while the first holds it."""
    out = tmp_path / "shared"
    out.mkdir()
    fd = os.open(out / ".sweep.lock", os.O_RDWR | os.O_CREAT)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        os.pwrite(fd, b"pid 1 on elsewhere\n", 0)
        assert report(results, out) == 2
    finally:
        os.close(fd)
    assert "is in use by another sweep (pid 1 on elsewhere)" in one_line(capsys)
    assert [p.name for p in out.iterdir()] == [".sweep.lock"]


def test_figures_and_pages_are_written_whole(tmp_path):
    """report.html and the PNGs were written in place: a kill left half a file."""
    from hoopbench.reports.report.plotting import pyplot, save, written_whole

    target = tmp_path / "figure.png"
    target.write_bytes(b"old")
    fig = pyplot().figure()

    def dies(path, **kwargs):
        Path(path).write_bytes(b"half a PNG")
        raise KeyboardInterrupt

    fig.savefig = dies
    with pytest.raises(KeyboardInterrupt):
        save(fig, target, dpi=100)
    assert not pyplot().fignum_exists(fig.number)
    assert target.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["figure.png"]
    written_whole(target, lambda tmp: tmp.write_bytes(b"new"))
    assert target.read_bytes() == b"new"
    source = (Path(hb.__file__).parent / "reports" / "report" / "page.py").read_text()
    assert "atomic_write(path" in source and "path.write_text(page" not in source


def test_findings_update_writes_through_a_link(results, tmp_path, capsys):
    """The link was replaced by a file; the file it led to kept the old findings."""
    from hoopbench.reports.report.findings import README_BEGIN, README_END

    readme = tmp_path / "README.md"
    readme.write_text(f"x\n{README_BEGIN}\nold\n{README_END}\n")
    link = tmp_path / "LINK.md"
    link.symlink_to(readme)
    assert main(["findings", "--results", str(results), "--update", str(link)]) == 0
    assert link.is_symlink() and "old" not in readme.read_text()


# =========================================================================== hangs
def fifo(path: Path) -> Path:
    path.unlink(missing_ok=True)
    os.mkfifo(path)
    return path


@pytest.mark.parametrize("name", ["meta.json", "suite.toml"])
def test_a_fifo_in_a_results_folder_is_refused(name, results, tmp_path, capsys):
    folder = copy_of(results, tmp_path)
    fifo(folder / name)
    assert report(folder, tmp_path / "r") == 2
    assert f"{folder / name} is a FIFO (named pipe), not a file" in one_line(capsys)


def test_a_fifo_as_the_suite_or_the_trajectory_file_is_refused(tmp_path, capsys):
    suite = fifo(tmp_path / "s.toml")
    assert main(["compare", "--suite", str(suite), "--out", str(tmp_path / "o")]) == 2
    assert f"{suite} is a FIFO (named pipe), not a file" in one_line(capsys)
    csv = fifo(tmp_path / "t.csv")
    assert main(["reference", "--scene", "seed", "--csv", str(csv), "--force"]) == 2
    assert f"output file '{csv}' exists and is not a regular file" in one_line(capsys)


@pytest.mark.parametrize(("column", "value"), [("ix", 10**9), ("iy", -1)])
def test_map_rows_off_the_grid_are_refused_before_anything_is_allocated(
    column, value, tiny_map, tmp_path, capsys
):
    """ix = 10^9 grew the report to 24 GB; iy = -1 was an IndexError traceback."""
    folder = copy_of(tiny_map, tmp_path)
    part = sorted((folder / "runs").glob("part-*.parquet"))[-1]
    frame = pd.read_parquet(part)
    frame[column] = frame[column].astype(float)
    frame.loc[frame.index[0], column] = value
    frame.to_parquet(part)
    assert report(folder, tmp_path / "r") == 2
    line = one_line(capsys)
    assert f"a row has {column} = {value:g}, not a point of the map's grid" in line


# =========================================================================== silent
def test_a_resume_of_a_missing_map_is_refused(tmp_path, capsys):
    """It started a new default 10 x 10 map."""
    missing = tmp_path / "missing"
    assert main(["map", "--out", str(missing), "--resume"]) == 2
    assert f"'{missing}' does not exist: there is no hop map to resume" in one_line(capsys)
    assert not missing.exists()


def test_a_map_toml_edited_after_the_run_is_refused(tiny_map, tmp_path, capsys):
    """nx 2 -> 3: old rows were resumed, and reported, at the wrong grid positions."""
    folder = copy_of(tiny_map, tmp_path)
    spec = folder / "map.toml"
    spec.write_text(spec.read_text().replace("nx = 2", "nx = 3"))
    before = sorted(p.name for p in (folder / "runs").iterdir())
    assert main(["map", "--out", str(folder), "--resume", "--quiet"]) == 2
    assert "was map.toml edited after the run?" in one_line(capsys)
    assert sorted(p.name for p in (folder / "runs").iterdir()) == before
    assert report(folder, tmp_path / "r") == 2
    assert "the rows were run on another grid than map.toml describes" in one_line(capsys)


def test_a_report_inside_a_results_folder_is_refused(results, tmp_path, capsys):
    """--out R/runs exited 0 and broke every later read of R."""
    assert report(results, results / "runs") == 2
    assert "is inside the results folder" in one_line(capsys)
    assert not (results / "runs" / "report.md").exists()


def test_rows_at_an_infinite_timestep_are_refused(results, tmp_path, capsys):
    folder = copy_of(results, tmp_path)
    for part in (folder / "runs").glob("part-*.parquet"):
        frame = pd.read_parquet(part)
        frame["timestep"] = np.inf
        frame.to_parquet(part)
    assert report(folder, tmp_path / "r") == 2
    assert "timestep must be a finite number > 0 s, got inf" in one_line(capsys)


API_REFUSALS = [
    # the command line refuses --out '': the API wrote into the current folder
    (lambda r, t: hb.report(r, out=""), "out must name a folder, got ''"),
    (lambda r, t: hb.report(r, t / "x", force="yes"), "force must be True or False"),
    # "no" is truthy: it resumed
    (lambda r, t: hb.compare(r / "suite.toml", r, resume="no"), "resume must be True or False"),
    (lambda r, t: hb.map(t / "m", resume=1), "resume must be True or False, got 1"),
    (lambda r, t: hb.compare("quick", ""), "out must name a folder, got ''"),
    # split into letters: "engine(s) p, y, m, u, n, k not in suite"
    (lambda r, t: hb.compare("quick", t / "o", engines="pymunk"), "engines must be a list"),
    (lambda r, t: hb.compare("quick", t / "o", run_timeout="x"), "run_timeout must be > 0 s"),
    (lambda r, t: hb.run("pymunk", "seed", options=[1]), "options must be a mapping"),
    (lambda r, t: hb.exact("seed", rtol="x"), "rtol must be a positive number, got 'x'"),
    (lambda r, t: hb.exact("seed", rtol=1e-300), "rtol must be >= 2.22e-14"),
    # suites refuse a catalogue name with other parameters; hb.run ran it as hop-top
    (
        lambda r, t: hb.run("reference", hb.scene("hop-top", lam=0.5), timestep=1e-3),
        "the catalogue's scene of that name has other parameters (lam 0.5",
    ),
    (lambda r, t: hb.scene(lam=0.9, mus=0.8, thetadot0=1e200), "thetadot0 = 1e+200 rad/s"),
    # TypeErrors that named no option
    (lambda r, t: hb.report(3), "results must be a folder or a list of them, got 3"),
    (lambda r, t: hb.map(t / "m", x_range=3), "x_range must be a pair (low, high), got 3"),
    (lambda r, t: hb.map(t / "m", fixed=3), "fixed must be a mapping of parameters, got 3"),
]


@pytest.mark.parametrize(("call", "message"), API_REFUSALS)
def test_the_api_refuses_what_the_command_line_refuses(call, message, results, tmp_path):
    cwd = os.getcwd()
    os.chdir(tmp_path)
    try:
        with pytest.raises(ValueError) as caught:
            call(results, tmp_path)
    finally:
        os.chdir(cwd)
    assert message in str(caught.value)
    assert sorted(p.name for p in tmp_path.iterdir()) == []  # nothing written anywhere


def test_numpy_integers_are_whole_numbers():
    from hoopbench.reports.api import check_positive_int

    assert check_positive_int(np.int64(3)) == 3 and type(check_positive_int(np.int64(3))) is int


# =========================================================================== tracebacks
def test_a_file_linked_to_dev_zero_is_refused(results, tmp_path, capsys):
    folder = copy_of(results, tmp_path)
    (folder / "meta.json").unlink()
    (folder / "meta.json").symlink_to("/dev/zero")
    assert report(folder, tmp_path / "r") == 2
    assert "meta.json leads out of the results folder" in one_line(capsys)
    suite = tmp_path / "s.toml"
    suite.symlink_to("/dev/zero")
    assert main(["compare", "--suite", str(suite), "--out", str(tmp_path / "o")]) == 2
    assert f"{suite} is a device, not a file" in one_line(capsys)


BAD_SUITES = [
    ('[[scene]]\nname = "x"\nlam = 0.9\nthetadot0 = 1e200\nmus = 0.8\n', "thetadot0 = 1e+200"),
    ('[[scene]]\nname = "x"\nlam = ' + "9" * 400 + "\nchi = 0.1\nmus = 0.8\n", "(400 digits)"),
    ('scenes = ["seed"]\n', "more steps than a float counts"),
]


@pytest.mark.parametrize(("body", "message"), BAD_SUITES, ids=["spin", "digits", "subnormal"])
def test_a_suite_of_overflowing_values_is_one_line(body, message, tmp_path, capsys):
    timesteps = "[1e-320]" if "seed" in body else "[1e-3]"
    (tmp_path / "s.toml").write_text(
        f'name = "s"\nengines = ["reference"]\ntimesteps = {timesteps}\n{body}'
    )
    assert main(["compare", "--suite", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o")]) == 2
    assert message in one_line(capsys)


# =========================================================================== unclear
def test_a_fifo_map_toml_is_named_as_a_fifo_not_missing(tiny_map, tmp_path, capsys):
    folder = copy_of(tiny_map, tmp_path)
    fifo(folder / "map.toml")
    assert report(folder, tmp_path / "r") == 2
    line = one_line(capsys)
    assert "is a FIFO (named pipe)" in line and "missing" not in line


def test_a_variants_list_of_profiles_is_named(tmp_path, capsys):
    """'too many values to unpack (expected 1)'."""
    (tmp_path / "s.toml").write_text(
        TINY + '[[variant]]\nengine = "reference"\nname = "v"\nprofile = ["stock", "tuned"]\n'
    )
    assert main(["compare", "--suite", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o")]) == 2
    assert "[[variant]] reference 'v': profile must be one of tuned, stock (a variant" in one_line(
        capsys
    )


def test_ctrl_c_in_a_report_says_what_was_kept(results, tmp_path, monkeypatch, capsys):
    """It said 'before anything ran' after nine figures were written."""
    from hoopbench.reports import api

    def interrupted(folders, target, force=False, say=None):
        raise KeyboardInterrupt

    monkeypatch.setattr(api, "build_report", interrupted)
    assert report(results, tmp_path / "r") == 130
    line = capsys.readouterr().err.strip()
    assert "before anything ran" not in line and "the results are unchanged" in line


def test_a_failed_trajectory_write_names_the_file_and_leaves_no_half(tmp_path, monkeypatch, capsys):
    """'No space left on device' named no path and left a truncated t.csv."""
    import errno

    from hoopbench.models.trajectory import Trajectory

    real = Trajectory._write

    def full(self, path, suffix):
        real(self, path, suffix)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(Trajectory, "_write", full)
    csv = tmp_path / "t.csv"
    argv = ["simulate", "--engine", "pymunk", "--scene", "seed", "--t-end", "0.05"]
    assert main([*argv, "--csv", str(csv)]) == 2
    assert f"cannot write '{csv}': No space left on device" in one_line(capsys)
    assert list(tmp_path.iterdir()) == []


def test_first_use_from_several_threads_finds_every_engine():
    """'unknown engine 'reference'; known: ' (an empty list), 3 of 3 tries."""
    code = (
        "import threading\n"
        "from hoopbench.engines.registry import engine_class\n"
        "errors = []\n"
        "def use():\n"
        "    try:\n"
        "        engine_class('reference')\n"
        "    except ValueError as exc:\n"
        "        errors.append(str(exc))\n"
        "threads = [threading.Thread(target=use) for _ in range(8)]\n"
        "[t.start() for t in threads]\n"
        "[t.join() for t in threads]\n"
        "print(errors)\n"
    )
    for _ in range(3):
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert done.stdout.strip() == "[]", done.stdout + done.stderr


@pytest.mark.parametrize(("sig", "shown"), [("SIGINT", "Ctrl-C"), ("SIGTERM", "SIGTERM")])
def test_a_signal_while_the_command_starts_is_one_line(sig, shown):
    """Ctrl-C in the first second of compare printed the import machinery's traceback (the
    command's modules take a second or more to load). The handler is set before them."""
    code = (
        "import os, signal, sys, time\n"
        "sys.argv[0] = '/bin/hoopbench'\n"
        "import hoopbench.reports.cli\n"
        f"os.kill(os.getpid(), signal.{sig})\n"
        "time.sleep(30)\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.returncode == 128 + getattr(signal, sig)
    assert done.stderr == f"hoopbench: interrupted ({shown}) while starting; nothing ran\n"


def test_ctrl_c_between_a_maps_stages_says_what_is_kept(tmp_path, monkeypatch, capsys):
    """It said 'before anything ran' after 16 rows were stored."""
    from hoopbench.reports import api

    out = tmp_path / "m"

    def stage_one_then_ctrl_c(spec, folder, **kwargs):
        (Path(folder) / "runs").mkdir(parents=True)
        raise KeyboardInterrupt

    monkeypatch.setattr(api, "run_hop_map", stage_one_then_ctrl_c)
    assert main(["map", "--grid", "1x1", "--engines", "--out", str(out)]) == 130
    line = capsys.readouterr().err.strip()
    assert line == (
        f"hoopbench: interrupted (Ctrl-C); the runs stored before are kept in {out}/runs; "
        f"resume with: hoopbench map --out {out} --resume"
    )
