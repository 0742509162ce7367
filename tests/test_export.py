"""``hoopbench export``: every engine's standalone script reproduces its run without hoopbench.

The script is run in a fresh interpreter in which importing hoopbench fails, and the CSV it
writes is compared with ``hoopbench simulate --csv`` of the same run: identical (bit for bit)
for a deterministic engine, within a stated tolerance otherwise. Both profiles, hop-top (a
hop) and seed-mu (a slip). A run that hoopbench stopped as diverged is compared over the rows it
has: the script has no divergence check and steps the whole window.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hoopbench.engines.registry import engine_classes
from hoopbench.models.trajectory import COLUMNS, Trajectory
from hoopbench.reports.cli import main

ENGINES = tuple(name for name in engine_classes() if name != "reference")
"""Every engine that steps: each must export (the reference is the exact solution)."""

WINDOW = {"mjx": 0.3, "mjwarp": 0.05, "newton": 0.3}
"""Window, s, for the engines whose CPU steps cost milliseconds (compile included): their
scripts are checked on the scene's first part; every other engine on the whole 3 s."""

TOLERANCE: dict[str, float] = {}
"""Largest difference allowed between the script's and simulate's columns, relative to each
column's scale, for an engine whose runs are not deterministic; absent: identical."""

_RUN_WITHOUT_HOOPBENCH = (
    "import runpy, sys; sys.modules['hoopbench'] = None; sys.argv = sys.argv[1:]; "
    "runpy.run_path(sys.argv[0], run_name='__main__')"
)
"""Run a script with every import of hoopbench failing (None in sys.modules)."""


def _export_and_simulate(tmp_path: Path, engine: str, scene: str, profile: str) -> tuple:
    common = ["--engine", engine, "--scene", scene, "--dt", "1e-4", "--profile", profile]
    if engine in WINDOW:
        common += ["--t-end", str(WINDOW[engine])]
    script, exported, simulated = (
        tmp_path / "run.py",
        tmp_path / "script.csv",
        tmp_path / "simulate.csv",
    )
    assert main(["export", *common, "--out", str(script)]) == 0
    proc = subprocess.run(
        [sys.executable, "-c", _RUN_WITHOUT_HOOPBENCH, str(script), str(exported)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert main(["simulate", *common, "--csv", str(simulated)]) in (0, 1)
    return script, Trajectory.read(exported), Trajectory.read(simulated)


@pytest.mark.slow
@pytest.mark.parametrize("profile", ["tuned", "stock"])
@pytest.mark.parametrize("scene", ["hop-top", "seed-mu"])
@pytest.mark.parametrize("engine", ENGINES)
def test_script_reproduces_the_run(tmp_path, capsys, engine, scene, profile):
    _, exported, simulated = _export_and_simulate(tmp_path, engine, scene, profile)
    capsys.readouterr()
    # A run the divergence check stopped is shorter: the script steps on (module doc).
    n = len(simulated)
    assert len(exported) >= n
    tolerance = TOLERANCE.get(engine, 0.0)
    for name in COLUMNS:
        ours, theirs = getattr(exported, name)[:n], getattr(simulated, name)
        if tolerance == 0.0:
            assert np.array_equal(ours, theirs), (
                f"{name}: first difference at row {np.flatnonzero(ours != theirs)[0]}"
            )
        elif name != "contact":
            scale = max(float(np.max(np.abs(theirs))), 1e-12)
            assert np.max(np.abs(ours - theirs)) <= tolerance * scale, name


@pytest.mark.parametrize("engine", ENGINES)
def test_script_imports_only_the_engine(engine):
    """The script's imports: the standard library's sys, numpy and the engine's packages."""
    import hoopbench as hb

    text = hb.export(engine, "seed-mu", timestep=1e-3)
    compile(text, "run.py", "exec")
    imported = set()
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            imported.add((node.module or "").split(".")[0])
    engine_packages = {module.split(".")[0] for module in engine_classes()[engine].modules}
    assert "hoopbench" not in imported
    assert imported <= {"sys", "math", "os", "tempfile", "numpy", *engine_packages}, imported


WARP_PACKAGES = {"mjwarp": "mujoco_warp", "newton": "newton"}
"""The package on NVIDIA Warp whose import makes an engine's Warp modules."""


@pytest.mark.parametrize("engine", sorted(WARP_PACKAGES))
def test_warp_script_compiles_no_backward_pass(engine):
    """As the adapter (tests/test_newton.py), the script turns Warp's backward pass off
    (base.WARP_ENABLE_BACKWARD) before it imports the engine, whose modules take the setting
    when they are made: the script compiles the adapter's kernels, no adjoints (about half a
    cold Newton compile). The script's text alone: about 1 s for the first engine (importing
    the adapters), 0.01 s for the second."""
    import hoopbench as hb

    body = ast.parse(hb.export(engine, "seed-mu", timestep=1e-3)).body
    setting = [
        i
        for i, node in enumerate(body)
        if isinstance(node, ast.Assign)
        and [ast.unparse(target) for target in node.targets] == ["wp.config.enable_backward"]
        and isinstance(node.value, ast.Constant)
        and node.value.value is False
    ]
    engine_import = next(
        i
        for i, node in enumerate(body)
        if isinstance(node, ast.Import)
        and any(alias.name.split(".")[0] == WARP_PACKAGES[engine] for alias in node.names)
    )
    assert setting, "the script leaves Warp's backward pass on"
    assert setting[0] < engine_import, "the script sets enable_backward after the engine's import"


def test_script_states_the_run(tmp_path, capsys):
    """The header names the engine, its release, the scene and every setting of the run."""
    out = tmp_path / "run.py"
    argv = ["export", "--engine", "pymunk", "--scene", "hop-top", "--dt", "2e-4"]
    assert main([*argv, "--set", "iterations=20", "--out", str(out)]) == 0
    assert capsys.readouterr().out.strip() == str(out)
    text = out.read_text()
    assert "scene 'hop-top', dt 0.0002 s" in text
    assert "iterations = 20" in text and "space.iterations = 20" in text
    assert "N_STEPS = 15000" in text and "DT = 0.0002" in text


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (["--mu", "0.5"], "drop --mu, --restitution and --geometry"),
        (["--geometry", "ring"], "geometry 'ring' is not available for pymunk"),
        (["--restitution", "0.5"], "drop --mu, --restitution and --geometry"),
        (["--set", "bogus=1"], "unknown pymunk setting(s) bogus"),
        (["--dt", "0"], "timestep must be a number > 0 s, got 0.0"),
    ],
)
def test_bad_export_is_one_line(tmp_path, capsys, extra, message):
    out = tmp_path / "run.py"
    argv = ["export", "--engine", "pymunk", "--scene", "seed-mu", "--out", str(out), *extra]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and "\n" not in err
    assert not out.exists()


def test_export_never_overwrites_without_force(tmp_path, capsys):
    out = tmp_path / "run.py"
    out.write_text("mine")
    out.chmod(0o600)
    argv = ["export", "--engine", "pymunk", "--scene", "seed-mu", "--out", str(out)]
    assert main(argv) == 2
    assert "pass --force to overwrite it" in capsys.readouterr().err
    assert out.read_text() == "mine"
    assert main([*argv, "--force"]) == 0
    assert "import pymunk" in out.read_text()
    assert out.stat().st_mode & 0o777 == 0o600


def test_the_reference_has_no_export(capsys):
    assert main(["export", "--engine", "reference", "--scene", "seed-mu", "--out", "x.py"]) == 2
    assert "invalid choice: 'reference'" in capsys.readouterr().err


def test_export_takes_a_setting_of_a_settings_file(tmp_path, capsys):
    """--settings FILE#NAME gives the script the setting's timestep and options."""
    from hoopbench.reports.compare.settings_file import load_choice

    found = Path(__file__).parents[1] / "reports/tune/searches/pymunk/settings.toml"
    chosen = next(s for s in load_choice(str(found))[0].settings)
    out = tmp_path / "run.py"
    argv = ["export", "--engine", "pymunk", "--scene", "seed-mu", "--out", str(out)]
    assert main([*argv, "--settings", f"{found}#{chosen.name}"]) == 0
    text = out.read_text()
    assert f"DT = {chosen.timestep!r}" in text
    assert f"space.iterations = {int(chosen.options['iterations'])!r}" in text
    assert main([*argv, "--force", "--settings", str(found), "--dt", "1e-3"]) == 2
    assert "--settings gives the timestep and the options" in capsys.readouterr().err
