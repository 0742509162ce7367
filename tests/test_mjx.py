"""MJX (MuJoCo XLA) against MuJoCo C on the same model and settings, and MJX's batches.

The cross-check runs hop-top over its first 0.6 s (it slips at 0.442 s) at dt 1e-3, tuned
settings (RK4, elliptic cone), so that rolling, the slip onset and the slipping phase are in
the window. Measured on mujoco 4.0.0 / mujoco-mjx 3.17.0 / jax 0.10.2, CPU:

* float64 (``jax_enable_x64``): positions within 5.7e-12 (m, rad) of MuJoCo C's, velocities
  2.1e-11, the contact force 6.4e-8 g, the refined slip onset 1.5e-13 s: MJX in double is
  MuJoCo C's step; nothing of MJX's own algorithms shows at this size. Tolerances: 1e-9
  (states), 1e-6 g (forces), 1e-9 s (onset).
* float32 (MJX's default): positions within 5.8e-5, while rolling (t < 0.4 s) the normal
  force within 1.3e-3 g; in the slipping phase, whose contact chatters step by step (the
  MuJoCo adapter's RMS_XFAIL in test_contact_forces.py), one float32 rounding decides
  whether a step is in contact: forces differ by up to 0.35 g, thetadot by 2.1e-2 rad/s, and
  the refined slip onset is 0.58 ms later. Tolerances: positions 2e-4, rolling velocities
  and forces 1e-2. The difference is float32's: float64 removes it (above).
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import mujoco
import numpy as np
import pytest
from conftest import engine_unavailable
from worlds_runs import DT, batched_differences, run_ok, worst

from hoopbench.engines.base import POOL_WORKERS_VARIABLE
from hoopbench.engines.mjx_engine import XLA_THREADS_VARIABLES
from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene

SCENE = get_scene("hop-top").with_(t_end=0.6)


def _run(engine: str, scene=SCENE, **options):
    return run_ok(engine, scene, **options)


@pytest.fixture(scope="module")
def mujoco_c():
    return _run("mujoco")


@contextmanager
def _traced() -> Iterator[list[str]]:
    """The names of the functions JAX traces inside the block, in order."""
    import jax

    traced: list[str] = []

    def listen(event: str, duration: float, **kwargs) -> None:
        if event == "/jax/core/compile/jaxpr_trace_duration":
            traced.append(kwargs.get("fun_name", "?"))

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        yield traced
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)


def test_float64_is_mujoco_c(mujoco_c):
    mjx = _run("mjx", precision="float64")
    a, b = mjx.trajectory, mujoco_c.trajectory
    assert len(a) == len(b)
    assert worst(a, b) <= 1e-9
    g = SCENE.g
    assert np.max(np.abs(a.normal_force - b.normal_force)) / g <= 1e-6
    assert np.max(np.abs(a.friction_force - b.friction_force)) / g <= 1e-6
    assert mjx.events.t_slip == pytest.approx(mujoco_c.events.t_slip, abs=1e-9)


def test_float32_differs_by_float32(mujoco_c):
    mjx = _run("mjx")
    a, b = mjx.trajectory, mujoco_c.trajectory
    positions = max(float(np.max(np.abs(getattr(a, c) - getattr(b, c)))) for c in "XY")
    assert max(positions, float(np.max(np.abs(a.theta - b.theta)))) <= 2e-4
    rolling = b.t < 0.4  # before the slip at 0.442 s
    for column in ("Xdot", "Ydot", "thetadot"):
        assert np.max(np.abs(getattr(a, column) - getattr(b, column))[rolling]) <= 1e-2
    force = np.max(np.abs(a.normal_force - b.normal_force)[rolling]) / SCENE.g
    assert force <= 1e-2
    # float32 is there: the states are not MuJoCo C's to double precision
    assert worst(a, b) > 1e-9


def test_batch_rows_are_the_single_runs():
    """Two worlds of different scenes and windows in one vmap: each is its single run, to
    float32's round-off (XLA may vectorise a batch's arithmetic differently; measured: equal
    bit for bit here)."""
    engine = get_engine("mjx")
    settings = RunSettings(timestep=DT)
    scenes = [SCENE.with_(t_end=0.2), get_scene("seed-mu").with_(t_end=0.3)]
    batch = engine.simulate_batch(scenes, settings)
    for scene, run in zip(scenes, batch, strict=True):
        single = engine.simulate(scene, settings)
        assert run.info.status is RunStatus.OK, run.info.message
        assert run.info.n_steps == single.info.n_steps
        assert worst(run.trajectory, single.trajectory) <= 1e-6
        assert run.info.batch is not None and run.info.batch.size == 2


SUITE_SCENES = (
    "seed-mu",
    "hop-top",
    "hop-low",
    "hop-bottom",
    "high-spin",
    "low-friction",
    "slip-reversal",
    "painleve",
)
"""The default suite's scenes, which it runs on MJX (reports/compare/suites/default.toml)."""


@pytest.mark.slow
def test_a_row_is_the_same_alone_and_in_any_batch():
    """Each default-suite scene over its whole window (3 s, dt 1e-3, tuned, float32) alone,
    in one batch of the eight, and in a batch of ten in another order (two calls of
    WORLDS_PER_CALL worlds, hop-top and seed-mu twice, in both calls): the same run bit for
    bit. Before every call had one shape (WORLDS_PER_CALL), XLA's code for each batch size
    rounded differently: none of the default suite's 16 MJX rows was the same alone and in
    the suite's batches, and hop-top's trajectory alone left its pair's at step 202 (its
    lift-off 1.1209 s alone, 1.1711 s in pairs). Cost: 93 CPU-s, 220 s wall at a load of
    8 to 11 on 2 cores (eight 3 s windows alone, then 18 worlds in three calls)."""
    scenes = [get_scene(name) for name in SUITE_SCENES]
    order = [7, 1, 6, 0, 5, 2, 4, 3, 1, 0]  # hop-top and seed-mu in both calls
    orders = [list(range(len(scenes))), order]
    differences = batched_differences("mjx", scenes, RunSettings(timestep=DT), orders)
    assert not differences, differences


def test_model_file_has_no_contact_sensor():
    """`hoopbench model --engine mjx` writes the MJCF MJX loads: MuJoCo's, without the
    contact sensor MJX refuses."""
    text = get_engine("mjx").model_text(SCENE)
    assert "<sensor" not in text
    assert "<sensor" in get_engine("mujoco").model_text(SCENE)
    model = mujoco.MjModel.from_xml_string(text)
    try:
        from mujoco import mjx
    except ImportError as exc:
        engine_unavailable("mjx", str(exc))
    mjx.put_model(model, impl="jax")  # raises for the sensor (NotImplementedError)


def test_unknown_integrator_is_named():
    with pytest.raises(ValueError, match="integrator must be one of Euler, RK4, implicitfast"):
        get_engine("mjx").check(SCENE, RunSettings(options={"integrator": "implicit"}))


@pytest.mark.gpu
def test_runs_on_a_gpu():
    try:
        import jax

        jax.devices("gpu")
    except (ImportError, RuntimeError) as exc:
        pytest.skip(f"no GPU for JAX: {exc}")
    result = _run("mjx", scene=SCENE.with_(t_end=0.05), device="gpu")
    assert result.info.status is RunStatus.OK


def _mjx() -> None:
    """Skip (or, where the engine must run, fail) when MJX cannot be imported."""
    try:
        from mujoco import mjx  # noqa: F401
    except ImportError as exc:
        engine_unavailable("mjx", str(exc))


def test_settings_that_change_only_arrays_share_one_compile():
    """The stacked mjx.Model is the compiled chunk's argument: a run that changes only the
    model's arrays (timestep, solref, solimp, impratio, the scene's mass, radius and
    friction: the stability suite's 1 cm hoop) reuses the compiled chunk of the settings
    before it; only MJX's static fields (integrator, cone, solver, iterations, the shapes,
    the precision) trace anew. Euler, the cheapest compile. Cost: about 10 CPU-s (a trace
    and a compile, two 20-step runs)."""
    _mjx()

    engine = get_engine("mjx")
    first = RunSettings(timestep=7e-4, options={"integrator": "Euler"})
    other = RunSettings(
        timestep=9e-4,
        options={
            "integrator": "Euler",
            "solref": (0.0123, 0.9),
            "solimp": (0.91, 0.97, 0.002, 0.5, 2.0),
            "impratio": 7.0,
        },
    )
    runs = engine.simulate_batch([SCENE.with_(t_end=20 * first.timestep)], first)
    assert runs[0].info.status is RunStatus.OK, runs[0].info.message
    with _traced() as traced:
        # Another radius too (the stability suite's 1 cm hoop): MJX's heightfield bounds,
        # static, follow it; a call led by such a world traced anew (about 3.5 s).
        scene = get_scene("high-spin").with_(a=0.01, t_end=20 * other.timestep)
        runs = engine.simulate_batch([scene], other)
    assert runs[0].info.status is RunStatus.OK, runs[0].info.message
    assert "world" not in traced, traced


@contextmanager
def _jax_work() -> Iterator[list[tuple[str, str]]]:
    """What JAX traces, lowers and compiles (a persistent-cache hit included) inside the
    block: (event, function) in order."""
    import jax

    work: list[tuple[str, str]] = []

    def listen(event: str, duration: float, **kwargs) -> None:
        if event.startswith("/jax/core/compile/"):
            work.append((event.rsplit("/", 1)[-1], kwargs.get("fun_name", "?")))

    jax.monitoring.register_event_duration_secs_listener(listen)
    try:
        yield work
    finally:
        jax.monitoring.unregister_event_duration_listener(listen)


def test_a_later_batch_of_the_settings_traces_and_compiles_nothing():
    """Once a process has run a settings group, a batch of other scenes, another count of
    worlds and other windows (other chunk lengths, worlds that finish before the others) with
    those settings traces, lowers and compiles nothing, not even a helper: each call has the
    compiled chunk's shape (WORLDS_PER_CALL), the steps are traced, and the stacking, the
    slices of the rows and the select of the finished worlds are the host's. Measured in a
    cold ``make report`` (MJX alone, JAX's compile log): each of MJX's four programs compiled
    once, in one worker; helpers compiled once per process (a float32 scalar cast, and the
    float64 cast of MjxEngine._batch, 0.1-0.4 s). Euler at the settings of the tests above:
    with them, about 0.2 CPU-s; alone, a trace and a cached compile (about 10 CPU-s)."""
    _mjx()

    engine = get_engine("mjx")
    settings = RunSettings(timestep=7e-4, options={"integrator": "Euler"})
    runs = engine.simulate_batch([SCENE.with_(t_end=20 * settings.timestep)], settings)
    assert runs[0].info.status is RunStatus.OK, runs[0].info.message
    windows = {"seed-mu": 15, "painleve": 9, "hop-low": 12}
    scenes = [get_scene(name).with_(t_end=n * settings.timestep) for name, n in windows.items()]
    with _jax_work() as work:
        runs = engine.simulate_batch(scenes, settings)
    for run, steps in zip(runs, windows.values(), strict=True):
        assert run.info.status is RunStatus.OK, run.info.message
        assert run.info.n_steps == steps
    assert work == []


def test_kept_takes_each_world_from_its_own_side():
    """The select that puts back the worlds that did not step: world by world, every leaf
    (of any rank), bit for bit, on the device it was given. Cost: milliseconds."""
    _mjx()
    import jax

    from hoopbench.engines.mjx_engine import _kept

    stepped = {"qpos": np.arange(12.0).reshape(4, 3), "time": np.array([1.0, 2.0, 3.0, 4.0])}
    before = jax.tree.map(lambda leaf: -leaf - 0.5, stepped)
    active = np.array([True, False, True, False])
    device = jax.devices("cpu")[0]
    kept = _kept(jax, active, stepped, before, device)
    for name, leaf in kept.items():
        assert leaf.devices() == {device}
        for world in range(4):
            side = stepped if active[world] else before
            assert np.array_equal(np.asarray(leaf)[world], side[name][world])


def test_float32_data_has_a_steps_types():
    """Without x64 mjx.put_data's types are those a step makes, so the adapter casts the data
    (a trace of ``forward``) in float64 only, where the contact indices are int32 against a
    step's int64 (MjxEngine._batch). Cost: one abstract trace of forward, about 1 CPU-s."""
    _mjx()
    import jax
    from mujoco import mjx

    model = mujoco.MjModel.from_xml_string(get_engine("mjx").model_text(SCENE))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    with jax.enable_x64(False):
        mx, dx = mjx.put_model(model, impl="jax"), mjx.put_data(model, data, impl="jax")
        like = jax.eval_shape(mjx.forward, mx, dx)
    put = [leaf.dtype for leaf in jax.tree.leaves(dx)]
    assert put == [leaf.dtype for leaf in jax.tree.leaves(like)]


def test_a_return_to_a_precision_finds_its_compiled_chunk():
    """A change of precision clears JAX's caches (MjxEngine._open_batch), but the compiled
    chunks are kept (mjx_engine._compiled): a process that comes back to the precision it
    left runs its compiled chunk again, with no trace (MJX's RK4 took about 5 CPU-s to
    trace), to the same numbers bit for bit. Euler, the cheapest trace. Cost: about 15 CPU-s
    on loaded cores (two traces and cached compiles, three 20-step runs)."""
    _mjx()

    engine = get_engine("mjx")
    scene = SCENE.with_(t_end=20 * 7e-4)
    settings = {
        precision: RunSettings(
            timestep=7e-4, options={"integrator": "Euler", "precision": precision}
        )
        for precision in ("float32", "float64")
    }
    first = engine.simulate(scene, settings["float32"])
    assert engine.simulate(scene, settings["float64"]).info.status is RunStatus.OK
    with _traced() as traced:
        again = engine.simulate(scene, settings["float32"])
    assert again.info.status is RunStatus.OK, again.info.message
    assert "world" not in traced, traced
    for column in ("X", "Y", "theta", "normal_force"):
        assert np.array_equal(getattr(again.trajectory, column), getattr(first.trajectory, column))


def test_compiled_functions_keep_the_last_used(monkeypatch):
    """The kept compiled functions are bounded (mjx_engine.KEPT_COMPILED), the least recently
    used dropped first: one more than the bound drops the oldest unused one, and a function
    used again is kept. A one-line jit, no MJX. Cost: about 0.5 CPU-s (17 tiny compiles)."""
    _mjx()
    import jax

    from hoopbench.engines import mjx_engine

    monkeypatch.setattr(mjx_engine, "_compiled_functions", {})
    kept = mjx_engine.KEPT_COMPILED
    plus_one = jax.jit(lambda x: x + 1)

    def compiled(size: int):
        return mjx_engine._compiled(jax, "plus one", plus_one, np.zeros(size))

    first, second = compiled(1), compiled(2)
    for size in range(3, kept + 1):
        compiled(size)
    assert compiled(1) is first  # used again: now the last used
    compiled(kept + 1)
    assert len(mjx_engine._compiled_functions) == kept
    assert compiled(1) is first
    assert compiled(2) is not second  # the least recently used, dropped
    assert np.array_equal(compiled(2)(np.zeros(2)), np.ones(2))


_XLA_THREADS = """
import os
from hoopbench.engines.registry import get_engine
get_engine("mjx")._import()
import jax
jax.block_until_ready(jax.numpy.ones(3) + 1)
tasks = os.listdir("/proc/self/task")
print(sum("XLAEigen" in open(f"/proc/self/task/{t}/comm").read() for t in tasks))
"""


def _xla_threads(**environment: str) -> int:
    """The threads of XLA's CPU pool in a fresh interpreter that imports MJX as a run does,
    with none of XLA's thread-count variables (nor the pool's size) set but ``environment``."""
    unset = {*XLA_THREADS_VARIABLES, POOL_WORKERS_VARIABLE}
    env = {k: v for k, v in os.environ.items() if k not in unset}
    done = subprocess.run(
        [sys.executable, "-c", _XLA_THREADS],
        env=env | environment,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr
    return int(done.stdout.split()[-1])


@pytest.mark.skipif(
    not Path("/proc/self/task").is_dir() or len(os.sched_getaffinity(0)) < 2,
    reason="needs Linux's /proc and 2 cores (with one, XLA's pool has one thread anyway)",
)
def test_xla_threads_are_the_process_share_of_the_cores_unless_the_user_chose():
    """A worker of a pool of as many workers as cores gets one XLA thread (the hand-offs of a
    thread per core cost CPU time the other workers need, MjxEngine._import); a run alone keeps
    every core; a size the user set is kept. About 8 CPU-s (three interpreters)."""
    _mjx()
    cores = len(os.sched_getaffinity(0))
    assert _xla_threads(**{POOL_WORKERS_VARIABLE: str(cores)}) == 1
    assert _xla_threads() == cores
    assert _xla_threads(PJRT_NPROC="2", **{POOL_WORKERS_VARIABLE: str(cores)}) == 2
