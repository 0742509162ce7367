"""The fourth round of hostile inputs (issue 36), its ESCAPE and TRACEBACK cases: strings
from settings files, suites, plugins and options reach the terminal as text, never obeyed
(reports/sweep/control_chars.say, terminal_text); a hostile settings file, search folder,
batch-cost table, plugin module or bench option ends in one line and exit 2, never a
traceback. Each test failed against the code before it.
"""

from __future__ import annotations

import json
import subprocess
import sys
import warnings
from pathlib import Path
from types import SimpleNamespace

import pandas as pd
import pytest
from test_hostile_inputs import one_line

import hoopbench.reports.api as api
import hoopbench.reports.cli as cli
from hoopbench.engines.judging.score import CostClock
from hoopbench.reports.cli import main

CONTROLS = "\x1b]0;pwned\x07\x1b[2J\x1b[31mFAKE\x1b[0m\u202e\x9b"
"""An escape sequence that retitles and clears a terminal and paints a red line, a BEL, a
right-to-left override and a lone C1 CSI."""
RAW = ("\x1b", "\x07", "\u202e", "\x9b")
TINY = 'name = "tiny"\nengines = ["reference"]\ntimesteps = [1e-3]\nscenes = ["seed"]\n'


def no_raw_controls(text: str) -> bool:
    return not any(char in text for char in RAW)


def hostile_settings_file(folder: Path) -> Path:
    """A reference-engine settings file whose name and setting's name hold CONTROLS, its
    [tiers] naming that setting within the loose tier on 1 of 2 scenes (the note's case)."""
    name = json.dumps("s" + CONTROLS)
    path = folder / f"set{CONTROLS}.toml"
    path.write_text(
        f'engine = "reference"\n[tiers]\nclose = {name}\nclose_scenes = "1/2"\n'
        f'[[settings]]\nname = {name}\ntimestep = 0.001\nprofile = "tuned"\n[settings.options]\n'
    )
    return path


# =========================================================================== escapes
def test_simulate_settings_file_and_setting_names_reach_the_terminal_as_text(tmp_path, capsys):
    path = hostile_settings_file(tmp_path)
    argv = ["simulate", "--engine", "reference", "--scene", "seed", "--t-end", "0.1"]
    assert main([*argv, "--settings", f"{path}#close"]) == 0
    err = capsys.readouterr().err
    assert "note: settings file set\\x1b]0;pwned" in err and "is s\\x1b]0;pwned" in err
    assert no_raw_controls(err)


def test_compare_settings_file_note_and_suite_name_reach_the_terminal_as_text(
    tmp_path, capsys, monkeypatch
):
    """The note on FILE#close, and the suite's name in the notice of a large suite (10,000
    runs and more; lowered to 1 here: checking 10,000 runs takes seconds)."""
    monkeypatch.setattr(cli, "LARGE_SUITE_RUNS", 1)
    path = hostile_settings_file(tmp_path)
    suite = tmp_path / "s.toml"
    suite.write_text(TINY.replace('"tiny"', json.dumps("tiny" + CONTROLS)))
    argv = ["compare", "--suite", str(suite), "--out", str(tmp_path / "o")]
    assert main([*argv, "--settings", f"{path}#close"]) == 0
    err = capsys.readouterr().err
    assert "suite tiny\\x1b]0;pwned" in err and "note: settings file set\\x1b" in err
    assert no_raw_controls(err)


def test_compare_out_reaches_the_terminal_as_text(tmp_path, capsys):
    (tmp_path / "s.toml").write_text(TINY)
    out = tmp_path / f"o{CONTROLS}"
    assert main(["compare", "--suite", str(tmp_path / "s.toml"), "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "1 ok -> " in err and "o\\x1b]0;pwned" in err and no_raw_controls(err)


@pytest.mark.parametrize("interrupted", [True, False])
def test_tune_out_reaches_the_terminal_as_text(tmp_path, capsys, monkeypatch, interrupted):
    """The search itself stands aside (a stand-in returns at once): what is tested is the
    lines tune prints about --out, the settings file's and the resume line."""
    pytest.importorskip("optuna")
    front = pd.DataFrame(
        [dict.fromkeys(["setting", "kind", "timestep", "train_error", "heldout_error"], 1)]
    ).assign(train_cost_us_per_s=1.0, overfitted="no")
    ended = SimpleNamespace(interrupted=interrupted, cost_clock=CostClock.CPU)
    monkeypatch.setattr(api, "run_tune", lambda *a, **k: (ended, None if interrupted else front))
    out = tmp_path / f"t{CONTROLS}"
    code = main(["tune", "--engine", "pymunk", "--out", str(out), "--trials", "2", "--quiet"])
    assert code == (cli.EXIT_INTERRUPTED if interrupted else 0)
    captured = capsys.readouterr()
    err = captured.err
    assert "t\\x1b]0;pwned" in err and no_raw_controls(err)
    if not interrupted:  # the table's caption: the search's clock, not a constant
        assert captured.out.startswith("costs: CPU time of the stepping, us per simulated s")


def test_a_plugin_engine_with_controls_in_its_name_is_refused_in_one_line(tmp_path):
    """Its name was shown raw in every command's --help (the --engine choices)."""
    (tmp_path / "evil_engines.py").write_text(
        "from hoopbench.engines.registry import register\n"
        "from hoopbench.engines.reference_engine import ReferenceEngine\n"
        "@register\nclass Evil(ReferenceEngine):\n"
        f"    name = {json.dumps('evil' + CONTROLS)}\n"
    )
    env = {"PYTHONPATH": str(tmp_path), "HOOPBENCH_ENGINE_MODULES": "evil_engines"}
    done = run_cli(["simulate", "--help"], env)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr.count("\n") == 1 and no_raw_controls(done.stderr)
    assert "engine name 'evil\\x1b]0;pwned" in done.stderr and "printable" in done.stderr


def run_cli(argv: list[str], env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    import os

    full = {**os.environ, **env}
    cmd = [sys.executable, "-m", "hoopbench.reports.cli", *argv]
    return subprocess.run(cmd, env=full, capture_output=True, text=True, timeout=120)


def test_a_figures_text_is_drawn_with_its_controls_as_codes(tmp_path):
    """A scene's name in a title reached the terminal raw through matplotlib's "Glyph 27
    missing" warning during hoopbench report."""
    from hoopbench.reports.report.plotting import pyplot, save

    fig, ax = pyplot().subplots()
    ax.set_title("x" + CONTROLS)
    ax.plot([0, 1], [0, 1], label="y" + CONTROLS)
    ax.legend()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        save(fig, tmp_path / "f.png", dpi=30)
    assert (tmp_path / "f.png").stat().st_size > 0
    assert "x\\x1b]0;pwned" in ax.get_title() and no_raw_controls(ax.get_title())


# =========================================================================== tracebacks
SETTING = '[[settings]]\nname = "a"\ntimestep = 0.001\nprofile = "tuned"\n[settings.options]\n'
DEEP = "[" * 100_000 + "]" * 100_000
"""Arrays nested 100,000 deep: tomllib parses them recursively (RecursionError)."""
HUGE = "1" * 5000
"""An integer past int()'s 4300 digits: tomllib's ValueError named no file."""


@pytest.mark.parametrize(
    ("text", "needle"),
    [
        (f'engine = "reference"\nx = {DEEP}\n', "nest too deep"),
        (f'engine = "reference"\n{SETTING}x = {HUGE}\n', "not TOML: Exceeds the limit"),
        (f'engine = "reference"\n[tiers]\nclose = "a"\nclose_scenes = "²/3"\n{SETTING}', "'k/n'"),
        (
            f'engine = "reference"\n[tiers]\nclose = "a"\nclose_scenes = "{HUGE}/1"\n{SETTING}',
            "'k/n'",
        ),
    ],
    ids=["nested", "huge-integer", "superscript-count", "huge-count"],
)
def test_a_hostile_settings_file_is_one_line(tmp_path, capsys, text, needle):
    path = tmp_path / "s.toml"
    path.write_text(text)
    argv = ["simulate", "--engine", "reference", "--scene", "seed", "--settings", str(path)]
    assert main(argv) == 2
    line = one_line(capsys)
    assert f"settings file {str(path)!r}" in line and needle in line


def test_a_suite_file_with_a_huge_integer_names_the_file(tmp_path, capsys):
    (tmp_path / "s.toml").write_text(TINY + f"x = {HUGE}\n")
    assert main(["compare", "--suite", str(tmp_path / "s.toml"), "--out", str(tmp_path / "o")]) == 2
    assert "s.toml: not valid TOML: Exceeds the limit" in one_line(capsys)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("text", [f"x = {DEEP}\n", f"nx = {HUGE}\n"], ids=["nested", "huge"])
def test_a_hostile_map_toml_is_a_value_error(text):
    from hoopbench.reports.hop_map.spec import MapSpec

    with pytest.raises(ValueError, match=r"map\.toml"):
        MapSpec.from_toml(text)


SEARCH = Path(__file__).resolve().parent.parent / "reports" / "tune" / "searches" / "pymunk"
"""A shipped compact search (tune.json, front.csv, trials.csv, settings.toml)."""


def _spec_without(key: str):
    return lambda spec: {k: v for k, v in spec.items() if k != key}


def _table_without(name: str, column: str):
    return name, lambda table: table.drop(columns=column)


def _count_inf(table: pd.DataFrame) -> pd.DataFrame:
    return table.astype({"close_scenes": float}).assign(close_scenes=float("inf"))


SPEC_CASES = {
    "list": (lambda spec: [1, 2], "tune.json must hold a JSON object, got list"),
    "no-engine": (_spec_without("engine"), "tune.json: engine must be an engine's name"),
    "string-scenes": (lambda spec: {**spec, "scenes": "seed-mu"}, "scenes must be a list"),
    "no-scenes": (_spec_without("scenes"), "scenes must be a list of scenes"),
}
TABLE_CASES = {
    "front-no-kind": (*_table_without("front.csv", "kind"), "front.csv lacks the column(s) kind"),
    "front-no-cost": (
        *_table_without("front.csv", "heldout_cost_us_per_s"),
        "lacks the column(s) heldout_cost_us_per_s",
    ),
    "trials-no-state": (*_table_without("trials.csv", "state"), "trials.csv lacks the column(s)"),
    "close-scenes-inf": (
        "front.csv",
        _count_inf,
        "close_scenes must be a whole number of scenes, got inf",
    ),
    "front-empty": ("front.csv", lambda table: table.iloc[:0], "front.csv holds no settings"),
}


def _hostile_search(tmp_path: Path) -> Path:
    import shutil

    return Path(shutil.copytree(SEARCH, tmp_path / "pymunk"))


@pytest.mark.parametrize("case", SPEC_CASES)
def test_a_hostile_tune_json_is_one_line(tmp_path, capsys, case):
    change, needle = SPEC_CASES[case]
    folder = _hostile_search(tmp_path)
    spec = json.loads((folder / "tune.json").read_text())
    (folder / "tune.json").write_text(json.dumps(change(spec)))
    assert main(["report", "--results", str(folder), "--out", str(tmp_path / "r")]) == 2
    assert needle in one_line(capsys)


@pytest.mark.parametrize("case", TABLE_CASES)
def test_a_hostile_front_or_trials_table_is_one_line(tmp_path, capsys, case):
    name, change, needle = TABLE_CASES[case]
    folder = _hostile_search(tmp_path)
    change(pd.read_csv(folder / name)).to_csv(folder / name, index=False)
    assert main(["report", "--results", str(folder), "--out", str(tmp_path / "r")]) == 2
    line = one_line(capsys)
    assert str(folder / name) in line and needle in line


def test_a_front_with_nothing_to_draw_still_makes_the_report(tmp_path, capsys):
    """No Pareto row and no stock or tuned row (kind and setting edited): matplotlib's "Data
    cannot be log-scaled" ended the report in a line naming nothing."""
    folder = _hostile_search(tmp_path)
    front = pd.read_csv(folder / "front.csv").assign(kind="edited", setting="edited")
    front.to_csv(folder / "front.csv", index=False)
    assert main(["report", "--results", str(folder), "--out", str(tmp_path / "r")]) == 0
    assert (tmp_path / "r" / "report.md").is_file()


def test_an_engine_module_raising_anything_is_one_line(tmp_path):
    (tmp_path / "boom_engines.py").write_text("raise RuntimeError('boom')\n")
    env = {"PYTHONPATH": str(tmp_path), "HOOPBENCH_ENGINE_MODULES": "boom_engines"}
    done = run_cli(["scenes"], env)
    assert done.returncode == 2 and done.stdout == ""
    assert done.stderr == (
        "hoopbench: error: HOOPBENCH_ENGINE_MODULES: cannot import engine module "
        "'boom_engines': RuntimeError: boom\n"
    )


def _compare_tiny(folder: Path, executor: object) -> object:
    (folder / "tiny.toml").write_text(TINY)
    return api.compare(folder / "tiny.toml", folder / "out", executor=executor)


@pytest.mark.parametrize(
    "call",
    [
        lambda folder: _compare_tiny(folder, object()),
        lambda folder: api.hop_map(folder / "out", grid=(2, 2), engines=[], executor="dask"),
        lambda folder: api.tune("pymunk", folder / "out", trials=2, executor=42),
    ],
    ids=["compare", "hop_map", "tune"],
)
def test_an_executor_that_is_not_one_is_refused_before_the_folder_is_made(tmp_path, call):
    """It failed with an AttributeError after sweep.json and .sweep.lock were written."""
    with pytest.raises(ValueError, match="executor must be an executor"):
        call(tmp_path)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    ("argv", "needle"),
    [
        (["--sizes", "0"], "--sizes: worlds per batch must be 1 to 998001, got 0"),
        (["--sizes", "-1"], "--sizes: worlds per batch must be 1 to 998001, got -1"),
        (["--steps", "0"], "--steps: steps per world must be 1 to 10000000, got 0"),
        (["--steps", str(10**12)], f"--steps: steps per world must be 1 to 10000000, got {10**12}"),
        (["--engines", "bogus"], "--engines: 'bogus' is not measured here (mujoco, mjx"),
        (["--out", "FILE"], "is a file, not a folder"),
    ],
    ids=["sizes-0", "sizes-negative", "steps-0", "steps-huge", "engines-bogus", "out-file"],
)
def test_bad_batched_engines_options_are_one_line(tmp_path, capsys, argv, needle):
    from hoopbench.reports.bench.batched_engines import main as bench_main

    (tmp_path / "f").write_text("mine\n")
    argv = [str(tmp_path / "f") if a == "FILE" else a for a in argv]
    assert bench_main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and captured.out == ""
    assert (tmp_path / "f").read_text() == "mine\n"


def test_bench_steps_past_a_runs_limit_name_the_option(capsys):
    argv = ["bench", "--parts", "batched", "--engines", "mujoco", "--steps", str(10**12)]
    assert main(argv) == 2
    assert "--steps: steps per world must be 1 to 10000000" in one_line(capsys)


JOURNAL_LINES = {
    "not-json": "{\n",
    "unknown-op-code": '{"op_code": 99, "worker_id": "x"}\n',
    "missing-key": '{"op_code": 6, "worker_id": "x"}\n',
    "broken-last-line": '{"op_code": 6',
}
"""Lines Optuna cannot replay: JSONDecodeError, AssertionError ("Should not reach."),
KeyError; a last line cut short, which Optuna skipped and then appended after, making the
journal unreadable for good."""


@pytest.mark.parametrize("case", JOURNAL_LINES)
def test_a_journal_line_optuna_cannot_read_is_refused_and_the_journal_kept(tmp_path, case):
    """The search's journal opened as a resume opens it (search._open_study), on a journal
    Optuna itself wrote (the study made, no trial: a told trial must hold the engine's
    parameters, which the strict replay checks) with one hostile line appended: a ValueError naming
    the file, and not a byte of it changed."""
    optuna = pytest.importorskip("optuna")
    from hoopbench.reports.tune.search import JOURNAL_NAME, STUDY_NAME, _open_study

    path = tmp_path / JOURNAL_NAME
    backend = optuna.storages.journal.JournalFileBackend(str(path))
    study = optuna.create_study(
        study_name=STUDY_NAME,
        storage=optuna.storages.JournalStorage(backend),
        directions=["minimize", "minimize"],
    )
    assert study.trials == []
    spec = api.tune_job("pymunk", scenes=["seed"], trials=2).spec
    _open_study(spec, tmp_path, True, CostClock.CPU)  # Optuna's own journal: read without an error
    with path.open("a") as journal:
        journal.write(JOURNAL_LINES[case])
    before = path.read_bytes()
    with pytest.raises(ValueError, match=r"journal\.log: .*not a journal Optuna can replay"):
        _open_study(spec, tmp_path, True, CostClock.CPU)
    assert path.read_bytes() == before


# =========================================================================== unclear
def test_a_settings_file_whose_name_holds_a_hash_can_be_named(tmp_path, capsys):
    """``a#b.toml`` was read as the file ``a`` and the setting ``b.toml``: "does not exist"."""
    path = tmp_path / "a#b.toml"
    path.write_text(f'engine = "reference"\n{SETTING}')
    argv = ["simulate", "--engine", "reference", "--scene", "seed", "--t-end", "0.1"]
    assert main([*argv, "--settings", str(path)]) == 0
    assert main([*argv, "--settings", f"{path}#a"]) == 0
    assert main([*argv, "--settings", f"{path}#zz"]) == 2
    assert "no setting named 'zz'" in capsys.readouterr().err


def test_a_training_scene_given_twice_is_refused_before_the_folder_is_made(tmp_path, capsys):
    """It was refused after tune.json, sweep.json and journal.log were written, as
    "run_id '58bd4b1a7059a809' appears twice"."""
    pytest.importorskip("optuna")
    out = tmp_path / "t"
    argv = ["tune", "--engine", "pymunk", "--out", str(out), "--scenes", "seed", "seed-mu"]
    assert main([*argv, "seed", "--trials", "2", "--quiet"]) == 2
    assert "--scenes names seed more than once" in one_line(capsys)
    assert not out.exists()
    with pytest.raises(ValueError, match="the same scene given twice"):
        api.tune_job("pymunk", scenes=[api.scene(lam=0.9, chi=0.1, mus=0.5)] * 2, trials=2)


def test_two_different_unnamed_training_scenes_are_not_taken_for_one():
    """Scenes made with hb.scene(...) have no name: only equal scenes are the same scene
    (the name check once refused two different ones as "scenes names  more than once")."""
    pytest.importorskip("optuna")
    scenes = [api.scene(lam=0.9, chi=0.1, mus=0.5), api.scene(lam=0.8, chi=0.1, mus=0.5)]
    assert len(api.tune_job("pymunk", scenes=scenes, trials=2).spec.scenes) == 2
