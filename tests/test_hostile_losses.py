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

import json
import os
import shutil
import stat
import sys
from pathlib import Path
from typing import Any

import pytest
from test_hostile_inputs import one_line

import hoopbench as hb
from hoopbench.reports.cli import main

TINY = 'name = "tiny"\nengines = ["reference"]\ntimesteps = [1e-3]\nscenes = ["seed"]\n'
SHIPPED = Path(__file__).resolve().parents[1] / "reports" / "tune" / "searches" / "pymunk"


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


def test_findings_update_on_a_fifo_says_so(
    results: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """It said the FIFO "does not exist"."""
    fifo = tmp_path / "README.md"
    os.mkfifo(fifo)
    assert main(["findings", "--results", str(results), "--update", str(fifo)]) == 2
    assert f"--update '{fifo}' is not a regular file" in one_line(capsys)


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


# --------------------------------------------------------------------------- searches
def tune_argv(out: Path, *more: str) -> list[str]:
    """A resume of `search` (below) as it was made; ``more`` changes it."""
    argv = ["tune", "--engine", "pymunk", "--out", str(out), "--scenes", "hop-bottom"]
    return [*argv, "--heldout-per-regime", "0", "--trials", "1", "--resume", "--quiet", *more]


def contents(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (links not followed), by path."""
    return {
        str(p.relative_to(folder)): p.read_bytes()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not p.is_symlink()
    }


@pytest.fixture(scope="module")
def search(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A finished search of one trial (pymunk on hop-bottom, one held-out neighbour): ~20 s."""
    pytest.importorskip("optuna")
    out = tmp_path_factory.mktemp("search") / "pymunk"
    argv = tune_argv(out)
    argv.remove("--resume")
    assert main(argv) == 0
    return out


def test_a_compact_search_copy_is_not_resumed_from_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--resume on a shipped search (tune.json, front.csv, trials.csv, settings.toml) ran a new
    search and replaced its three result files; with another --seed too."""
    folder = copy_of(SHIPPED, tmp_path)
    before = contents(folder)
    for more in ([], ["--seed", "3"], ["--engine", "box2d"]):
        assert main([*tune_argv(folder), *more]) == 2
        assert f"{folder} holds no journal.log" in one_line(capsys)
    assert contents(folder) == before
    assert sorted(p.name for p in folder.iterdir()) == sorted(before)  # not even a lock


@pytest.mark.slow
@pytest.mark.parametrize("sweep_json", ["deleted", "corrupt", "fifo"])
@pytest.mark.parametrize(
    ("more", "said"),
    [(["--seed", "3"], "seed 0 (asked: 3)"), (["--engine", "box2d"], "engine 'pymunk' (asked")],
)
def test_a_resume_with_other_options_is_refused_whatever_sweep_json_says(
    sweep_json: str,
    more: list[str],
    said: str,
    search: Path,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """With sweep.json deleted, corrupt or a FIFO, another --seed went on (tune.json kept seed
    0) and another --engine wrote box2d rows into the pymunk search's trials/."""
    folder = copy_of(search, tmp_path)
    (folder / "sweep.json").unlink()
    if sweep_json == "corrupt":
        (folder / "sweep.json").write_text("{not json")
    elif sweep_json == "fifo":
        os.mkfifo(folder / "sweep.json")
    before = contents(folder)
    argv = tune_argv(folder, *more)
    if "--engine" in more:
        argv[argv.index("pymunk")] = "box2d"
    assert main(argv) == 2
    line = one_line(capsys)
    assert f"{folder} holds another search" in line and said in line, line
    assert contents(folder) == before


@pytest.mark.slow
@pytest.mark.parametrize("name", ["trials", "heldout"])
def test_a_runs_folder_linked_elsewhere_is_not_written(
    name: str, search: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """tune --resume wrote into the folder trials/ linked to, replacing its runs.csv."""
    folder = copy_of(search, tmp_path)
    elsewhere = tmp_path / "elsewhere"
    shutil.move(folder / name, elsewhere)
    (folder / name).symlink_to(elsewhere)
    before = contents(elsewhere)
    assert main(tune_argv(folder, "--trials", "2")) == 2
    assert f"{folder / name} is not a folder of the search" in one_line(capsys)
    assert contents(elsewhere) == before


@pytest.mark.slow
def test_a_settings_file_the_user_edited_is_not_replaced_without_a_word(
    search: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """docs/tune.md says "edit freely"; a resume replaced the edited file without a word."""
    folder = copy_of(search, tmp_path)
    edited = (folder / "settings.toml").read_text() + "# my note\n"
    (folder / "settings.toml").write_text(edited)
    before = contents(folder)
    assert main(tune_argv(folder)) == 2
    assert f"{folder / 'settings.toml'} was edited after the search wrote it" in one_line(capsys)
    assert contents(folder) == before


@pytest.mark.slow
def test_a_journal_line_with_a_tampered_timestep_is_refused(
    search: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A told trial's timestep edited to 5 s in journal.log ended in settings.toml, exit 0."""
    folder = copy_of(search, tmp_path)
    journal = folder / "journal.log"
    lines = journal.read_text().splitlines()
    for k, line in enumerate(lines):
        op = json.loads(line)
        if op.get("param_name") == "timestep":
            op["param_value_internal"] = 5.0
            lines[k] = json.dumps(op)
    journal.write_text("\n".join(lines) + "\n")
    before = (folder / "settings.toml").read_text()
    assert main(tune_argv(folder)) == 2
    line = one_line(capsys)
    assert "journal.log: trial 0's timestep = 5 is not in [" in line, line
    assert (folder / "settings.toml").read_text() == before


# =========================================================================== hangs
@pytest.mark.parametrize(
    ("option", "value"), [("--heldout-per-regime", "1000"), ("--heldout-neighbours", "11")]
)
def test_a_held_out_draw_that_cannot_end_is_refused_up_front(
    option: str, value: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--heldout-per-regime 1000 drew for 72-168 s after the search, then a traceback."""
    out = tmp_path / "x"
    argv = ["tune", "--engine", "pymunk", "--out", str(out), "--trials", "1", option, value]
    assert main(argv) == 2
    assert f"{option} must be at most 10" in one_line(capsys)
    assert not out.exists()


# =========================================================================== silent
@pytest.mark.slow
def test_a_timeout_spent_on_the_baselines_says_no_trial_ran(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A --timeout shorter than the baselines started no trial and wrote a front, exit 0."""
    pytest.importorskip("optuna")
    out = tmp_path / "s"
    argv = tune_argv(out, "--timeout", "0.001")
    argv.remove("--resume")
    argv.remove("--trials")
    argv.remove("1")
    assert main(argv) == 2
    line = one_line(capsys)
    assert "the timeout (0.001 s) ended before the first trial" in line, line
    assert not (out / "front.csv").exists() and not (out / "settings.toml").exists()


def test_an_engine_given_twice_to_engine_dt_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The last value was kept without a word."""
    out = tmp_path / "m"
    argv = ["map", "--grid", "2x2", "--engines", "pymunk", "--out", str(out), "--quiet"]
    assert main([*argv, "--engine-dt", "pymunk=1e-3", "pymunk=2e-3"]) == 2
    assert "--engine-dt gives pymunk twice (0.001 and 0.002)" in one_line(capsys)
    assert not out.exists()


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda out: hb.compare("quick", out, engines=[]), "engines must name at least one"),
        (lambda out: hb.tune("pymunk", out, scenes=[], trials=1), "scenes must name at least"),
        (lambda out: hb.tune("pymunk", out, trials=1, resume="no"), "resume must be True or"),
        (lambda out: hb.tune("pymunk", out, trials=1, quiet="no"), "quiet must be True or"),
        (
            lambda out: hb.tune("pymunk", out, scenes=["hop-top", "hop-top"], trials=1),
            "scenes names hop-top more than once",
        ),
    ],
)
def test_the_api_refuses_empty_lists_and_strings_for_flags(
    call: Any, message: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """compare(engines=[]) ran every engine, tune(scenes=[]) the 7 default scenes, and
    tune(resume='no') resumed."""

    def ran(*args: Any, **kwargs: Any) -> None:
        raise AssertionError("the runs started")

    monkeypatch.setattr("hoopbench.reports.api.search", ran)
    monkeypatch.setattr("hoopbench.reports.api.suite_runs.compare", ran)
    with pytest.raises(ValueError, match=message):
        call(tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_the_api_takes_numpy_seeds_and_names_a_missing_folder(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """hb.tune(seed=np.int64(3)) was refused as "not a whole number"; out=None gave a pathlib
    TypeError."""
    import numpy as np

    from hoopbench.reports import api

    job = api.tune_job("pymunk", trials=1, seed=np.int64(3), heldout_seed=np.int64(4))
    assert (job.spec.seed, job.spec.heldout_seed) == (3, 4)
    assert type(job.spec.seed) is int and type(job.spec.heldout_seed) is int
    with pytest.raises(ValueError, match="out must name a folder, got None"):
        api.run_tune(job, None)  # type: ignore[arg-type]


def test_two_searches_of_one_engine_get_one_figure_each_and_no_reads_as_no(
    tmp_path: Path,
) -> None:
    """Both searches showed the second one's figure; front.csv's "overfitted = no" was shown
    as "yes" (the string "no" is truthy)."""
    import pandas as pd

    first, second = (copy_of(SHIPPED, tmp_path / k) for k in ("a", "b"))
    front = pd.read_csv(first / "front.csv")
    front["overfitted"] = "no"
    front.to_csv(first / "front.csv", index=False)
    front = pd.read_csv(second / "front.csv")
    front["train_error"] *= 3  # another search: another figure
    front.to_csv(second / "front.csv", index=False)
    report = hb.report([first, second], tmp_path / "r")
    pngs = [
        tmp_path / "r" / name for name in ("best-settings-pymunk.png", "best-settings-pymunk-2.png")
    ]
    assert pngs[0].read_bytes() != pngs[1].read_bytes()
    text = report.read_text()
    for png in pngs:
        assert f"]({png.name})" in text
    one = text[text.index("### pymunk\n") : text.index("### pymunk (search 2)")]
    assert "| no |" in one and "| yes |" not in one


def test_a_front_csv_overfitted_that_is_no_flag_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import pandas as pd

    folder = copy_of(SHIPPED, tmp_path)
    front = pd.read_csv(folder / "front.csv")
    front["overfitted"] = front["overfitted"].astype(str)
    front.loc[0, "overfitted"] = "maybe"
    front.to_csv(folder / "front.csv", index=False)
    assert main(["report", "--results", str(folder), "--out", str(tmp_path / "r")]) == 2
    line = one_line(capsys)
    assert f"{folder / 'front.csv'}: overfitted must be true or false, got 'maybe'" in line


EXITS = {
    "sys.exit": ("import sys\nsys.exit(0)\n", "called sys.exit(0) while it was imported"),
    "KeyboardInterrupt": (
        "raise KeyboardInterrupt\n",
        "was interrupted (a Ctrl-C, or the module raised KeyboardInterrupt) while it was imported",
    ),
}
"""A module's way out of its own import, and what hoopbench says of it."""


@pytest.mark.parametrize("exit_kind", list(EXITS))
@pytest.mark.parametrize("how", ["plugin", "module"])
def test_a_plugin_that_calls_sys_exit_is_named(
    how: str,
    exit_kind: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """hoopbench exited 0 and printed nothing (sys.exit(0)), or ended as if the user had
    pressed Ctrl-C (a KeyboardInterrupt raised by the module)."""
    source, said = EXITS[exit_kind]
    from hoopbench.engines import registry

    registry.engine_names()  # the built-in engines registered (their modules import once)
    monkeypatch.setattr(registry, "_discovered", False)
    monkeypatch.setattr(registry, "_discovery_error", None)
    monkeypatch.setattr(registry, "_ENGINES", dict(registry._ENGINES))
    monkeypatch.delenv(registry.DISABLE_PLUGINS_VARIABLE, raising=False)
    monkeypatch.delitem(sys.modules, "exiting_hoop_engine", raising=False)
    (tmp_path / "exiting_hoop_engine.py").write_text(source)
    if how == "plugin":
        info = tmp_path / "exiting_hoop_engine-0.1.dist-info"
        info.mkdir()
        (info / "METADATA").write_text("Metadata-Version: 2.1\nName: exiting\nVersion: 0.1\n")
        (info / "entry_points.txt").write_text("[hoopbench.engines]\nx = exiting_hoop_engine\n")
    else:
        monkeypatch.setenv(registry.ENGINE_MODULES_VARIABLE, "exiting_hoop_engine")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert main(["scenes"]) == 2
    line = one_line(capsys)
    assert said in line, line


def test_the_tune_resume_line_gives_back_every_option_of_the_search():
    """The "Resume with:" line of an interrupted or broken search, typed as printed, names
    the same search: it dropped --scenes and the held-out options and said ``--trials N``,
    which is refused (and a resume with other options is refused too)."""
    import shlex

    from hoopbench.reports.cli import _parser, _tune_resume_command

    given = ["tune", "--engine", "pymunk", "--out", "/tmp/my search", "--scenes", "seed-mu"]
    given += ["hop-top", "--trials", "3", "--seed", "7", "--heldout-seed", "11"]
    given += ["--heldout-per-regime", "2", "--heldout-neighbours", "0", "--run-timeout", "30"]
    first = _parser().parse_args(given)
    line = _tune_resume_command(first)
    words = shlex.split(line)
    assert words[0] == "hoopbench" and "N" not in words
    again = _parser().parse_args(words[1:])
    assert again.resume and not first.resume
    for name in ("engine", "out", "scenes", "trials", "timeout", "seed", "heldout_seed"):
        assert getattr(again, name) == getattr(first, name), name
    for name in ("heldout_per_regime", "heldout_neighbours", "run_timeout"):
        assert getattr(again, name) == getattr(first, name), name


UNGUARDED = """
import hoopbench as hb
table = hb.compare("s.toml", "out", quiet=True)
print(sorted(set(table["message"])))
"""
"""A script that starts a sweep with no ``if __name__ == '__main__':``: each worker imports
it, so starts the sweep again."""


def test_a_script_without_the_main_guard_is_told_so_in_its_rows(tmp_path):
    """Its workers died at start-up on the parent's folder lock: a traceback of "out is in
    use by another sweep" from each worker on stderr and crashed rows naming no cause. Each
    row now names the main guard, and no worker prints a traceback. About 5 s."""
    import subprocess

    (tmp_path / "s.toml").write_text(
        'name = "s"\nengines = ["reference"]\ntimesteps = [1e-3]\nscenes = ["seed-mu"]\n'
    )
    (tmp_path / "s.py").write_text(UNGUARDED)
    done = subprocess.run(
        [sys.executable, "s.py"], cwd=tmp_path, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr and "in use" not in done.stderr, done.stderr
    assert "if __name__ == '__main__':" in done.stdout, done.stdout


def test_the_compare_resume_line_keeps_the_runs_it_chose():
    """``compare --engines E`` stopped, then its "resume with:" line typed as printed: the
    line dropped --engines (and the trajectories and the time limit), so the resume ran
    every engine of the suite into the folder, exit 0 and not a word."""
    import shlex

    from hoopbench.reports.cli import _compare_resume_command, _parser

    given = ["compare", "--suite", "my suite.toml", "--out", "o", "--engines", "reference"]
    given += ["pymunk", "--trajectories", "default", "--run-timeout", "30"]
    first = _parser().parse_args(given)
    again = _parser().parse_args(shlex.split(_compare_resume_command(first))[1:])
    assert again.resume and not first.resume
    for name in ("suite", "out", "engines", "trajectories", "run_timeout", "settings"):
        assert getattr(again, name) == getattr(first, name), name


ESCAPING_ENGINE = """
from dataclasses import replace

from hoopbench.engines.reference_engine import ReferenceEngine
from hoopbench.engines.registry import register


class EscapingEngine(ReferenceEngine):
    name = "escaping"
    options = tuple(
        replace(option, reason="\\x1b[2J\\x1b]0;owned\\x07 cleared")
        for option in ReferenceEngine.options
    )


register(EscapingEngine)
"""
"""A plugin engine whose declared reasons hold a clear-screen and a retitling sequence."""


def test_a_plugin_engines_reasons_reach_the_terminal_as_text(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """`hoopbench settings` printed a plugin's reason strings raw: its escape bytes cleared
    the terminal and retitled it."""
    from hoopbench.engines import registry

    registry.engine_names()
    monkeypatch.setattr(registry, "_discovered", False)
    monkeypatch.setattr(registry, "_discovery_error", None)
    monkeypatch.setattr(registry, "_ENGINES", dict(registry._ENGINES))
    monkeypatch.delitem(sys.modules, "escaping_hoop_engine", raising=False)
    (tmp_path / "escaping_hoop_engine.py").write_text(ESCAPING_ENGINE)
    monkeypatch.setenv(registry.ENGINE_MODULES_VARIABLE, "escaping_hoop_engine")
    monkeypatch.syspath_prepend(str(tmp_path))
    assert main(["settings", "--engine", "escaping"]) == 0
    out = capsys.readouterr().out
    assert "cleared" in out and "\x1b" not in out and "\x07" not in out
