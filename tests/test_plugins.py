"""Engine plugins: a distribution's entry point in the group ``hoopbench.engines`` adds an
engine (engines/registry.py). Each test installs a real tiny distribution into a temporary
folder (a module and its ``*.dist-info`` with ``entry_points.txt``, all importlib.metadata
needs) and puts the folder on the path: of a subprocess, or of this one for the broken ones."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pandas as pd
import pytest

from hoopbench.engines import registry
from hoopbench.reports.cli import main

PLUGIN = "tiny-plugin"

ENGINE_MODULE = f'''\
"""A plugin engine: the reference under another name, registered by its entry point."""
from hoopbench.engines.reference_engine import ReferenceEngine


class TinyEngine(ReferenceEngine):
    name = "{PLUGIN}"


def not_an_engine():
    return None
'''


def install(site: Path, entry: str, module: str = ENGINE_MODULE, name: str = PLUGIN) -> Path:
    """A distribution 'tiny-hoop-engine' in ``site`` whose entry point is ``name = entry``."""
    site.mkdir(parents=True, exist_ok=True)
    (site / "tiny_hoop_engine.py").write_text(module)
    info = site / "tiny_hoop_engine-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: tiny-hoop-engine\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(f"[hoopbench.engines]\n{name} = {entry}\n")
    return site


def run(site: Path, *argv: str, cwd: Path) -> subprocess.CompletedProcess:
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join(filter(None, [str(site), os.environ.get("PYTHONPATH")])),
    }
    env.pop(registry.DISABLE_PLUGINS_VARIABLE, None)
    return subprocess.run(
        [sys.executable, *argv], capture_output=True, text=True, env=env, cwd=cwd, timeout=300
    )


def test_a_plugin_engine_is_listed_and_runs(tmp_path):
    site = install(tmp_path / "site", "tiny_hoop_engine:TinyEngine")
    code = textwrap.dedent(
        f"""
        import sys
        import hoopbench as hb
        from hoopbench.engines import registry
        assert "tiny_hoop_engine" not in sys.modules  # nothing loads before the registry's use
        print(hb.engine_names())
        run = hb.run("{PLUGIN}", "hop-top", timestep=1e-3)
        print(run.status, run.verdict)
        """
    )
    done = run(site, "-c", code, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    names, status = done.stdout.splitlines()
    assert PLUGIN in names and "mujoco" in names
    assert status == "ok agrees"
    settings = run(site, "-m", "hoopbench.reports.cli", "settings", "--json", cwd=tmp_path)
    assert settings.returncode == 0, settings.stderr
    assert PLUGIN in json.loads(settings.stdout)["engines"]


@pytest.mark.slow
def test_a_plugin_engine_runs_in_the_suite_workers(tmp_path):
    site = install(tmp_path / "site", "tiny_hoop_engine:TinyEngine")
    suite = tmp_path / "tiny.toml"
    suite.write_text(
        f'name = "tiny"\nengines = ["{PLUGIN}"]\ntimesteps = [1e-3]\nscenes = ["hop-top"]\n'
    )
    argv = ["compare", "--suite", str(suite), "--out", "out", "--jobs", "1", "--quiet"]
    done = run(site, "-m", "hoopbench.reports.cli", *argv, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    rows = pd.read_parquet(tmp_path / "out" / "runs")
    assert list(rows["engine"]) == [PLUGIN] and list(rows["status"]) == ["ok"]


@pytest.fixture
def fresh_registry(monkeypatch):
    """Discovery to do again in this process; the registry as it was afterwards."""
    registry.engine_names()  # the built-in engines registered (their modules import once)
    monkeypatch.setattr(registry, "_discovered", False)
    monkeypatch.setattr(registry, "_discovery_error", None)
    monkeypatch.setattr(registry, "_ENGINES", dict(registry._ENGINES))
    monkeypatch.delenv(registry.DISABLE_PLUGINS_VARIABLE, raising=False)
    monkeypatch.delitem(sys.modules, "tiny_hoop_engine", raising=False)
    return monkeypatch


@pytest.mark.parametrize(
    ("entry", "module", "problem"),
    [
        ("no_such_module:TinyEngine", ENGINE_MODULE, "cannot be loaded: ModuleNotFoundError: No "),
        ("tiny_hoop_engine:TinyEngine", "raise RuntimeError('boom\\nmore')", "RuntimeError: boom "),
        ("tiny_hoop_engine:Missing", ENGINE_MODULE, "cannot be loaded: AttributeError: "),
        ("tiny_hoop_engine:not_an_engine", ENGINE_MODULE, "is neither an Engine class nor a "),
    ],
)
def test_a_broken_plugin_is_one_line_naming_it(
    fresh_registry, tmp_path, capsys, entry, module, problem
):
    fresh_registry.syspath_prepend(str(install(tmp_path, entry, module)))
    where = f"engine plugin '{PLUGIN}' ({entry}) of tiny-hoop-engine"
    with pytest.raises(ValueError, match="^" + _literal(where)) as first:
        registry.engine_names()
    assert problem in str(first.value) and "\n" not in str(first.value)
    with pytest.raises(ValueError, match=_literal(where)):
        registry.engine_names()  # again: the broken plugin is not dropped after its first error
    assert main(["scenes"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"hoopbench: error: {where}") and len(err.splitlines()) == 1


def test_plugins_can_be_switched_off(fresh_registry, tmp_path):
    fresh_registry.syspath_prepend(str(install(tmp_path, "no_such_module:TinyEngine")))
    fresh_registry.setenv(registry.DISABLE_PLUGINS_VARIABLE, "1")
    assert "mujoco" in registry.engine_names() and PLUGIN not in registry.engine_names()


def test_a_plugin_named_unlike_its_engine_is_refused(fresh_registry, tmp_path):
    site = install(tmp_path, "tiny_hoop_engine:TinyEngine", name="other-name")
    fresh_registry.syspath_prepend(str(site))
    with pytest.raises(ValueError, match="its class is named 'tiny-plugin', not 'other-name'"):
        registry.engine_names()


def _literal(text: str) -> str:
    return re.escape(text)
