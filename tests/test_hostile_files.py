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

import hoopbench.reports.api as api
import hoopbench.reports.cli as cli
from hoopbench.reports.cli import main

CONTROLS = "\x1b]0;pwned\x07\x1b[2J\x1b[31mFAKE\x1b[0m\u202e\x9b"
"""An escape sequence that retitles and clears a terminal and paints a red line, a BEL, a
right-to-left override and a lone C1 CSI."""
RAW = ("\x1b", "\x07", "\u202e", "\x9b")
TINY = 'name = "tiny"\nengines = ["reference"]\ntimesteps = [1e-3]\nscenes = ["seed"]\n'


def no_raw_controls(text: str) -> bool:
    return not any(char in text for char in RAW)


def one_line(capsys) -> str:
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith("hoopbench: ") and "Traceback" not in captured.err
    return lines[0]


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
    ended = SimpleNamespace(interrupted=interrupted)
    monkeypatch.setattr(api, "run_tune", lambda *a, **k: (ended, None if interrupted else front))
    out = tmp_path / f"t{CONTROLS}"
    code = main(["tune", "--engine", "pymunk", "--out", str(out), "--trials", "2", "--quiet"])
    assert code == (cli.EXIT_INTERRUPTED if interrupted else 0)
    err = capsys.readouterr().err
    assert "t\\x1b]0;pwned" in err and no_raw_controls(err)


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
