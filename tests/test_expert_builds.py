"""Each engine's hoop as its own users build it, against hoopbench's run of the same engine.

``tests/expert/expert_<engine>.py`` builds hop-top and seed-mu from the engine's own
documentation and examples, importing that engine and numpy alone (never hoopbench, and never
the adapter's code). Its module constants say what to expect of hoopbench's run with
``HOOPBENCH_SETTINGS``: the same trajectory (``SAME_AS_HOOPBENCH``, within ``RTOL`` of each
state's scale), or, where the adapter chooses differently for the measured reason in
``DIFFERENCE``, the same events within the tight tolerances. Both are judged by the same
detectors, so the comparison is of the builds, not of the readings.
"""

from __future__ import annotations

import ast
import importlib.util
import sys
from functools import cache
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

import hoopbench as hb
from hoopbench.engines.judging.event_checks import checked_events
from hoopbench.engines.judging.verdict import hoop_thresholds
from hoopbench.engines.registry import engine_classes
from hoopbench.models.events import Events
from hoopbench.models.trajectory import Trajectory

EXPERTS = Path(__file__).parent / "expert"
ENGINES = tuple(name for name in engine_classes() if name != "reference")
SCENES = ("hop-top", "seed-mu")
DT = 1e-4
STATE = ("X", "Y", "theta", "Xdot", "Ydot", "thetadot")
RETURNED = ("t", *STATE, "normal_force", "friction_force")

WINDOW = {"mjx": 1.5, "mjwarp": 0.05, "newton": 1.5}
"""Window, s, for the engines whose CPU steps cost milliseconds: the first part of each
scene (every other engine runs the whole 3 s). hop-top lifts off at 1.17 s, seed-mu slips at
0.99 s: 1.5 s holds both for MJX and Newton; MuJoCo Warp's 8 ms CPU step allows only the
start (a rolling comparison)."""


def _expert(engine: str) -> ModuleType:
    path = EXPERTS / f"expert_{engine}.py"
    if not path.exists():
        pytest.fail(f"no expert build for {engine}: {path} is missing")
    spec = importlib.util.spec_from_file_location(f"expert_{engine}", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@cache
def _runs(engine: str, scene_name: str) -> tuple[Trajectory, Trajectory, object]:
    """(expert trajectory, hoopbench trajectory, the hoopbench scene) of one scene."""
    expert = _expert(engine)
    scene = hb.scene(scene_name)
    if engine in WINDOW:
        scene = scene.with_(t_end=WINDOW[engine])
    out = expert.run(scene.to_dict(), DT, scene.t_end)
    missing = [key for key in RETURNED if key not in out]
    assert not missing, f"expert_{engine}.run returned no {missing}"
    ours = Trajectory.from_state(
        scene, **{key: np.asarray(out[key], dtype=float) for key in RETURNED}
    )
    settings = dict(expert.HOOPBENCH_SETTINGS)
    run = hb.run(
        engine,
        scene,
        timestep=DT,
        profile=settings.get("profile", "tuned"),
        options=settings.get("options") or None,
    )
    assert run.result.trajectory is not None, run.row.get("message")
    return ours, run.result.trajectory, scene


@pytest.mark.parametrize("engine", ENGINES)
def test_expert_imports_only_its_engine(engine):
    """Standard library, numpy and the engine's own packages: nothing of hoopbench."""
    path = EXPERTS / f"expert_{engine}.py"
    if not path.exists():
        pytest.fail(f"no expert build for {engine}: {path} is missing")
    tree = ast.parse(path.read_text())
    imported = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            imported |= {alias.name.split(".")[0] for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            assert node.level == 0, f"expert_{engine}: a relative import"
            imported.add((node.module or "").split(".")[0])
    own = {module.split(".")[0] for module in engine_classes()[engine].modules}
    allowed = {*sys.stdlib_module_names, "numpy", *own, *_EXTRA_PACKAGES.get(engine, ())}
    assert imported <= allowed, sorted(imported - allowed)
    doc = ast.get_docstring(tree) or ""
    assert "http" in doc or "docs" in doc.lower(), "cite the documentation it follows"


_EXTRA_PACKAGES = {"mjx": ("jax", "mujoco"), "mjwarp": ("warp", "mujoco"), "newton": ("warp",)}
"""Packages an engine's own users import beside it (MJX runs on JAX and loads its model with
MuJoCo's; MuJoCo Warp and Newton run on NVIDIA Warp)."""


@pytest.mark.slow
@pytest.mark.parametrize("scene_name", SCENES)
@pytest.mark.parametrize("engine", ENGINES)
def test_expert_build_agrees_with_hoopbench(engine, scene_name):
    expert = _expert(engine)
    ours, theirs, scene = _runs(engine, scene_name)
    n = min(len(ours), len(theirs))
    assert n >= 0.99 * len(ours), "hoopbench's run ended early"
    if expert.SAME_AS_HOOPBENCH:
        assert not expert.DIFFERENCE
        for key in STATE:
            a, b = getattr(ours, key)[:n], getattr(theirs, key)[:n]
            scale = max(float(np.max(np.abs(b))), 1.0)
            assert np.max(np.abs(a - b)) <= expert.RTOL * scale, (key, np.max(np.abs(a - b)))
        return
    assert expert.DIFFERENCE.strip(), "a build that differs states its measured reason"
    _assert_events_within_tight(
        checked_events(ours, None, scene), checked_events(theirs, None, scene), scene
    )


def _assert_events_within_tight(ours: Events, theirs: Events, scene) -> None:
    tol = hoop_thresholds(scene.a, scene.g, DT).tight
    assert ours.outcome == theirs.outcome
    for name, limit in (("t_slip", tol.t_slip), ("t_lift", tol.t_lift)):
        a, b = getattr(ours, name), getattr(theirs, name)
        assert (a is None) == (b is None), name
        if a is not None:
            assert abs(a - b) <= limit, (name, a, b)
    if ours.hop_height is not None or theirs.hop_height is not None:
        assert ours.hop_height is not None and theirs.hop_height is not None
        assert ours.hop_height == pytest.approx(theirs.hop_height, rel=tol.hop_height_rel)
