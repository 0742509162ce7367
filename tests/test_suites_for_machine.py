"""Suites sized to the machine (issue 34): the runs an engine declares to pay off only on a GPU
run in a suite sized to the machine only where there is a GPU; the report says which were left
out, and why. MuJoCo Warp and Newton's MuJoCo solver (MuJoCo Warp inside Newton) declare one:
on a CPU their kernels' compile is dear and their rows are MJX float32's. The tests give MuJoCo
Warp a reason of their own for the time of a test."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from hoopbench.engines import mjx_engine
from hoopbench.engines.mjwarp_engine import MjwarpEngine
from hoopbench.engines.mjx_engine import MjxEngine
from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.reports.compare import suite as suite_module
from hoopbench.reports.compare.suite import LEFT_OUT_KEY, compare, left_out_text, runs_frame
from hoopbench.reports.compare.suite_file import (
    LeftOut,
    SuiteError,
    builtin_suite,
    load_suite,
    parse_suite,
)
from hoopbench.reports.report.build import _suite_machine
from hoopbench.reports.report.markdown import machine_text

SIZED = {
    "name": "sized",
    "engines": ["reference", "mjwarp", "newton"],
    "timesteps": [1e-3],
    "scenes": ["seed-mu", "hop-top"],
    "sized_to_machine": True,
    "variant": [
        {"engine": "newton", "name": "solver=mujoco", "options": {"solver": "mujoco"}},
        {"engine": "newton", "name": "solver=featherstone", "options": {"solver": "featherstone"}},
    ],
}


REASON = "Warp kernels launched from Python at every step (a test's reason)"


@pytest.fixture
def gpu_only_mjwarp(monkeypatch):
    """MuJoCo Warp declaring that its runs pay off only on a GPU, for this test."""
    monkeypatch.setattr(MjwarpEngine, "gpu_only", REASON)


def _no_question(engine: str) -> bool:
    raise AssertionError("a suite that runs everything everywhere asks for no GPU")


def test_mujoco_warp_and_newtons_mujoco_solver_alone_pay_off_only_on_a_gpu():
    """On a CPU MuJoCo Warp's kernels cost about 33 CPU-s to compile on a first run for MJX
    float32's verdicts; Newton's MuJoCo solver is MuJoCo Warp. No other engine or solver."""
    declared = {
        name
        for name in engine_names()
        if engine_class(name).gpu_only_reason(engine_class(name).defaults()) is not None
    }
    assert declared == {"mjwarp"}
    assert "MJX float32" in engine_class("mjwarp").gpu_only_reason({})
    newton = engine_class("newton")
    solvers = ("xpbd", "featherstone", "semi_implicit", "mujoco")
    reasons = {s: newton.gpu_only_reason({**newton.defaults(), "solver": s}) for s in solvers}
    assert [s for s, why in reasons.items() if why] == ["mujoco"]
    assert "MuJoCo Warp" in reasons["mujoco"]


def test_without_a_gpu_a_sized_suite_leaves_the_gpu_only_runs_out(gpu_only_mjwarp):
    suite = parse_suite(SIZED)
    tasks = suite.tasks()
    kept, left_out = suite.for_machine(tasks, lambda engine: False)
    assert {(t.engine, t.variant) for t in kept} == {
        ("reference", "default"),
        ("newton", "default"),
        ("newton", "solver=featherstone"),
    }
    newton_mujoco = engine_class("newton").gpu_only_reason({"solver": "mujoco"})
    assert [(item.label, item.runs, item.reason) for item in left_out] == [
        ("mjwarp", 2, REASON),  # 2 scenes, tuned (the suite's profile)
        ("newton solver=mujoco", 2, newton_mujoco),
    ]
    assert kept == [t for t in tasks if t in kept]  # the same runs, in the same order


def test_with_a_gpu_or_unsized_every_run_runs(gpu_only_mjwarp):
    suite = parse_suite(SIZED)
    tasks = suite.tasks()
    assert suite.for_machine(tasks, lambda engine: True) == (tasks, ())
    unsized = parse_suite({**SIZED, "sized_to_machine": False})
    assert unsized.for_machine(unsized.tasks(), _no_question) == (unsized.tasks(), ())
    assert suite.with_engines(["reference", "mjwarp"]).sized_to_machine
    with pytest.raises(SuiteError, match="sized_to_machine must be true or false"):
        parse_suite({**SIZED, "sized_to_machine": "yes"})


def test_without_a_gpu_the_shipped_suites_leave_mujoco_warp_to_the_full_suite():
    """The default and stability suites are sized to the machine: without a GPU they leave
    out MuJoCo Warp's runs and Newton's MuJoCo solver's, with a GPU nothing. The full suite
    runs every run everywhere."""
    left = {}
    for name in ("default", "stability"):
        suite = load_suite(builtin_suite(name))
        assert suite.sized_to_machine
        tasks = suite.tasks()
        assert suite.for_machine(tasks, lambda engine: True) == (tasks, ())
        kept, left_out = suite.for_machine(tasks, lambda engine: False)
        left[name] = [(item.label, item.runs) for item in left_out]
        assert "mjwarp" not in {task.engine for task in kept}
        assert len(kept) + sum(item.runs for item in left_out) == len(tasks)
    assert left == {
        "default": [("mjwarp", 16), ("newton solver=mujoco", 2)],
        "stability": [("mjwarp", 2)],
    }
    default = load_suite(builtin_suite("default")).tasks()
    assert {t.scene for t in default if t.engine == "mjwarp"} == {
        t.scene for t in default if t.engine == "mjx"
    }
    full = load_suite(builtin_suite("full"))
    assert full.for_machine(full.tasks(), _no_question) == (full.tasks(), ())


def test_compare_without_a_gpu_records_and_the_report_says_what_it_left_out(
    tmp_path, monkeypatch, gpu_only_mjwarp
):
    """The detection monkeypatched: the left-out runs are not run, meta.json lists them, and
    the report's Platform and runs section says so in a sentence (about 5 s: one reference
    run)."""
    suite_file = tmp_path / "sized.toml"
    suite_file.write_text(
        'name = "sized"\nengines = ["reference", "mjwarp"]\ntimesteps = [1e-3]\n'
        'scenes = ["seed-mu"]\nsized_to_machine = true\n'
    )
    monkeypatch.setattr(MjwarpEngine, "sees_gpu", classmethod(lambda cls: False))
    out = tmp_path / "out"
    compare(suite_file, out, jobs=1, quiet=True)
    assert set(runs_frame(out)["engine"]) == {"reference"}
    meta = json.loads((out / "meta.json").read_text())
    (stored,) = meta[LEFT_OUT_KEY]
    assert LeftOut.from_dict(stored) == LeftOut("mjwarp", "default", 1, REASON)
    text = machine_text([_suite_machine(out)])
    assert (
        "In the sized suite, no GPU here (NVIDIA Warp sees none), so 1 run that pays off only "
        "on a GPU was left out, to the full suite: mjwarp (1 run): Warp kernels" in text
    )


def test_a_report_of_a_suite_that_left_nothing_out_says_nothing_of_it(tmp_path):
    bad = [{"engine": "mjwarp", "variant": "default", "runs": "2", "reason": "slow"}]
    (tmp_path / "meta.json").write_text(json.dumps({"suite": "quick", LEFT_OUT_KEY: bad}))
    machine = _suite_machine(tmp_path)
    assert machine.left_out == ()
    assert "GPU" not in machine_text([machine])


def test_newtons_runs_of_one_settings_go_in_one_batch_of_up_to_eight():
    """On a CPU a Newton step costs its kernel launches whatever the worlds (3.53 s of CPU
    for 1 world, 3.82 s for 8): the finer suite's 8 Newton runs at 1e-4 s are one batch, not
    four of 2 (110 of the suite's 190 s of stepping in four batches of 2, 2026-11-28)."""
    from hoopbench.engines.settings import DEFAULT_BATCH_SIZE
    from hoopbench.reports.compare.suite import batch_key, batch_least
    from hoopbench.reports.sweep.runner import Batching, TaskBatch

    tasks = load_suite(builtin_suite("finer")).tasks()
    units = Batching(suite_module.run_task_batch, batch_key, DEFAULT_BATCH_SIZE, batch_least)
    sizes = [
        len(unit.tasks)
        for unit in units.units(tasks, parallel=4)
        if isinstance(unit, TaskBatch) and unit.tasks[0].engine == "newton"
    ]
    assert sizes == [8]


def test_the_finer_suite_runs_mjx_only_where_jax_sees_a_gpu():
    """MJX's 8 runs at 1e-4 s, make report's dearest call on a CPU (about 100 CPU-s), are the
    finer suite's [engine_gpu_only]: left out without a GPU, said with the suite's reason, and
    run by the full suite everywhere; every other run of the suite is kept."""
    finer = load_suite(builtin_suite("finer"))
    tasks = finer.tasks()
    asked = []
    kept, left_out = finer.for_machine(tasks, lambda engine: asked.append(engine) or False)
    assert asked == ["mjx"]  # only the engine with such runs is asked
    assert kept == [t for t in tasks if t.engine != "mjx"]
    ((item),) = left_out
    assert (item.engine, item.variant, item.runs) == ("mjx", "default", 8)
    assert item.reason == finer.engine_gpu_only["mjx"] and "CPU-s" in item.reason
    assert "no GPU here (JAX sees none), so 8 runs" in left_out_text(left_out)
    assert finer.for_machine(tasks, lambda engine: True) == (tasks, ())
    full = load_suite(builtin_suite("full")).tasks()
    in_full = {(t.scene, t.profile, t.timestep) for t in full if t.engine == "mjx"}
    assert {(t.scene, t.profile, t.timestep) for t in tasks if t.engine == "mjx"} <= in_full


def test_a_sized_suite_asks_the_engine_itself_by_default(monkeypatch):
    finer = load_suite(builtin_suite("finer"))
    monkeypatch.setattr(MjxEngine, "sees_gpu", classmethod(lambda cls: True))
    assert finer.for_machine(finer.tasks()) == (finer.tasks(), ())
    monkeypatch.setattr(MjxEngine, "sees_gpu", classmethod(lambda cls: False))
    assert {t.engine for t in finer.for_machine(finer.tasks())[0]} == set(finer.engines) - {"mjx"}


def test_mjx_sees_a_gpu_only_through_a_jax_gpu_plugin(monkeypatch):
    """Without a plugin JAX is not even imported; with one, JAX's default device decides."""

    def no_import(name):
        raise AssertionError(f"{name} imported")

    assert isinstance(mjx_engine._jax_gpu_plugins(), list)  # the real one runs here

    monkeypatch.setattr(mjx_engine, "_jax_gpu_plugins", lambda: [])
    monkeypatch.setattr(mjx_engine, "import_engine", no_import)
    assert MjxEngine.sees_gpu() is False
    monkeypatch.setattr(mjx_engine, "_jax_gpu_plugins", lambda: ["xla_cuda12"])
    for platform, sees in (("gpu", True), ("cpu", False)):
        device = SimpleNamespace(platform=platform)
        fake = SimpleNamespace(devices=lambda device=device: [device])
        monkeypatch.setattr(mjx_engine, "import_engine", lambda name, fake=fake: fake)
        assert MjxEngine.sees_gpu() is sees


@pytest.mark.parametrize(
    ("table", "sized", "message"),
    [
        ({"mjwarp": "slow"}, False, "engine_gpu_only needs sized_to_machine = true"),
        ({"mujoco": "slow"}, True, "engine_gpu_only.mujoco: 'mujoco' is not one of"),
        ({"mjwarp": " "}, True, "engine_gpu_only.mjwarp must be a non-empty reason"),
        (["mjwarp"], True, "engine_gpu_only must be a table"),
    ],
)
def test_a_bad_engine_gpu_only_table_is_named(table, sized, message):
    with pytest.raises(SuiteError, match=message):
        parse_suite({**SIZED, "sized_to_machine": sized, "engine_gpu_only": table})
