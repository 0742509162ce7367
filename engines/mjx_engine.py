"""MJX adapter: MuJoCo XLA (``mujoco-mjx``, on JAX), the hoop of the MuJoCo adapter stepped as
a batch of worlds: ``jax.vmap`` over the worlds, a ``lax.fori_loop`` over the steps of a
chunk, one compiled function per (worlds, precision, settings).

The model is the MuJoCo adapter's (``models/mjcf.py``, the same ``<pair>``, solref, solimp,
cone and integrator), written without the contact-force sensor, which MJX refuses ("Contact
sensor with body matching semantics not implemented for JAX backend"). Each world starts
where the MuJoCo adapter starts it (at the equilibrium penetration that MuJoCo C's
``mj_forward`` finds): the C model and data are built first and put on the device
(``mjx.put_model``, ``mjx.put_data``), so both engines start from the same numbers and a
difference is the stepping's.

Worlds. Each world is its own scene (mass, radius, centre of mass, inertia, friction,
gravity differ). MJX's ``put_model`` keeps the model's arrays as JAX leaves and its integer
layout (geom types, pair indices, the names) as static metadata: the worlds' models are
stacked leaf by leaf, which needs equal metadata; the only difference between two scenes'
metadata is the model's name (and the addresses of the names written after it), so every
MJX model is built without the scene's name: then the worlds stack, and JAX's jit, which
keys its traces on that metadata, compiles once per (worlds, precision, integrator), not
once per scene.

Contact force. Each step is ``forward`` (which fills ``efc_force`` at the state before the
step), then the integrator; the force read between the two is the contact's at that state,
in the world frame (``mjx._src.support.contact_force``), as the MuJoCo adapter's sensor,
which MuJoCo C evaluates before integrating. ``mjx.step`` itself leaves RK4's last stage's
forces in the data, so the two halves are called here (internal functions of
``mjx._src.forward``: the pin on mujoco-mjx covers them).

Precision. ``float32`` is what MJX's users run (JAX's default); ``float64`` turns on
``jax_enable_x64`` for the run. Compiled functions go to JAX's persistent compilation cache
(``HOOPBENCH_CACHE`` or the user's cache folder, ``hoopbench/jax``): the first RK4 compile
takes about 20 s on 2 CPU cores, a cached one about 1 s. A process keeps its compiled chunks
(:func:`_compiled`) past the clearing of JAX's caches that a change of precision needs
(MjxEngine._open_batch), so coming back to a precision costs no new trace.
"""

from __future__ import annotations

import os
import pkgutil
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from importlib import import_module
from importlib.metadata import entry_points
from importlib.util import find_spec
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import (
    CHUNK_STEPS,
    DEVICE,
    EngineUnavailableError,
    WorldsEngine,
    cache_folder,
    cores_per_process,
    import_engine,
)
from hoopbench.engines.mujoco_engine import MjcfEngine, MujocoEngine
from hoopbench.engines.options import Option, Variant, choice, one_of
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.models.mjcf import com_rows
from hoopbench.models.scene import Scene

__all__ = ["PRECISIONS", "WORLDS_PER_CALL", "MjxEngine"]

PRECISIONS: tuple[str, ...] = ("float32", "float64")

WORLDS_PER_CALL = 8
"""Worlds in every call of the compiled chunk: a batch is cut into calls of this many worlds,
the last padded with copies of its first world that never step. XLA compiles each batch
shape to its own float32 (and float64) roundings: in batches of 1, 2, 3 and 4 worlds hop-top
took four different trajectories (the first difference at step 202, dt 1e-3, float32), while
at one shape a world's trajectory was the same bit for bit whatever its neighbours and its
place. One shape for every call makes a row independent of the batch it ran in, and one
trace and compile per process serve every batch. 8: a call of 8 worlds cost about 1.3 times
a call of one on 2 loaded CPU cores (3.0 against 2.3 ms per step, RK4, float32)."""

_MJX_INTEGRATORS = ("Euler", "RK4", "implicitfast")
"""MJX's integrators (``mjx.IntegratorType``): no implicit, no discrete."""

_precision_used: list[str] = []
"""The precisions this process has run, last one last (see MjxEngine._open_batch)."""

PRECISION = Option(
    "precision",
    "float32",
    choice(*PRECISIONS),
    "float32 is what the engine's users run (JAX's default); float64 (jax_enable_x64) is "
    "the option that tells round-off from the engine's own differences",
    space=one_of(*PRECISIONS),
)


@register
class MjxEngine(WorldsEngine, MjcfEngine):
    """MuJoCo XLA (JAX): the MuJoCo adapter's model, worlds stepped with vmap."""

    name = "mjx"
    distribution = "mujoco-mjx"
    modules = ("mujoco", "jax", "mujoco.mjx")
    geometries = ("sphere",)
    contact_sensor = False
    step_cost_bound = 0.02
    worlds_per_call = WORLDS_PER_CALL
    compiled_cache = "jax"
    """5 times a lone world's float32 step on the CPU (3.7 ms, docs/engines.md)."""
    options = (
        *MujocoEngine.options_except(
            "noslip_iterations",  # MJX's JAX solver has no noslip pass
            "ring_segments",  # sphere only
            integrator=choice(*_MJX_INTEGRATORS),
        ),
        PRECISION,
        DEVICE,
    )
    variants = (
        Variant("precision=float64", options={"precision": "float64"}),
        Variant("cone=pyramidal", options={"cone": "pyramidal"}),
    )

    gpu_finder = "JAX"

    @classmethod
    def sees_gpu(cls) -> bool:
        """Whether JAX's default device, which ``device`` auto picks, is a GPU: never without
        a JAX GPU plugin installed (JAX is not imported then: a second of the parent's CPU)."""
        if not _jax_gpu_plugins():
            return False
        try:
            jax = import_engine("jax")
        except EngineUnavailableError:
            return False
        return bool(jax.devices()[0].platform != "cpu")

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        # The run's model has no name (see _batch): the same text, the same model.
        model = self._script_model(scene.with_(name=""), settings, options)
        device = options["device"]
        integrate = {"Euler": "euler", "RK4": "rungekutta4", "implicitfast": "implicit"}
        return _SCRIPT.format(
            model=model,
            x64=options["precision"] == "float64",
            precision=options["precision"],
            chunk=CHUNK_STEPS,
            worlds=WORLDS_PER_CALL,
            integrator=options["integrator"],
            integrate=integrate[options["integrator"]],
            device_text="JAX's default device" if device == "auto" else f"the {device}",
            device_arg="" if device == "auto" else repr(device),
        )

    def _import(self) -> ModuleType:
        _xla_threads_per_share()
        module = super()._import()
        import jax

        jax.config.update("jax_compilation_cache_dir", str(cache_folder(self.compiled_cache)))
        # An error row's message is its exception's last line: JAX's own, not its note
        # about the frames it removed.
        jax.config.update("jax_traceback_filtering", "off")
        return module

    @contextmanager
    def _open_batch(
        self,
        module: ModuleType,
        scenes: Sequence[Scene],
        settings: RunSettings,
        options: dict[str, Any],
    ) -> Iterator[_Batch]:
        import jax

        precision = options["precision"]
        if _precision_used and _precision_used[-1] != precision:
            # JAX 0.10 keeps inner traces (MJX's RK4 tableau) across a change of
            # jax_enable_x64 and then fails to lower ("operand type mismatch"): a process
            # that changes precision starts its traces anew (a trace takes about 5 s).
            jax.clear_caches()
            _chunk_function.cache_clear()
            _typed_function.cache_clear()
        _precision_used.append(precision)
        with jax.enable_x64(precision == "float64"):
            yield self._batch(module, scenes, settings, options)

    def _batch(
        self,
        mujoco: ModuleType,
        scenes: Sequence[Scene],
        settings: RunSettings,
        options: dict[str, Any],
    ) -> _Batch:
        import jax
        from mujoco import mjx

        device = _device(jax, options["device"])
        precision = options["precision"]
        # One model name for every run: the names are static metadata, which JAX's jit keys
        # its traces on, so a scene's own name cost a trace and a compile per scene (measured:
        # 80-135 s for each 20-step placement run on 2 loaded cores).
        built = [self._build(mujoco, s.with_(name=""), settings, options) for s in scenes]
        models = [mjx.put_model(m, device=device, impl="jax") for m, _ in built]
        datas = [mjx.put_data(m, d, device=device, impl="jax") for m, d in built]
        # Heightfield bounds are static metadata that follow the radius; this model has no
        # heightfield (MJX reads them only for a heightfield's collision grid), so zeros stand
        # for every world's: scenes of different sizes stack, and a call whose first world
        # has another radius than an earlier call's finds the earlier trace (the first
        # world's bounds cost a retrace, about 3.5 s, for the stability suite's hoop-1cm).
        hfield = np.zeros_like(models[0]._impl.geom_rbound_hfield)
        models = [m.replace(_impl=m._impl.replace(geom_rbound_hfield=hfield)) for m in models]
        # Every call steps WORLDS_PER_CALL worlds: the last call's free places hold copies
        # of its first world, never active (a world's neighbours do not change its steps).
        calls = []
        for first in range(0, len(scenes), WORLDS_PER_CALL):
            call = list(zip(models, datas, strict=True))[first : first + WORLDS_PER_CALL]
            call += [call[0]] * (WORLDS_PER_CALL - len(call))
            try:
                model = _stacked(jax, [m for m, _ in call], device)
            except ValueError as exc:
                raise ValueError(
                    f"the scenes' MJX models differ in more than arrays: {exc}"
                ) from None
            data = _stacked(jax, [d for _, d in call], device)
            if precision == "float64":
                data = _compiled(jax, "typed", _typed_function(jax), model, data)(model, data)
            calls.append(_Call(model=model, data=data))
        start = np.array(
            [
                com_rows(scene, d.qpos, d.qvel)[0]
                for scene, (_, d) in zip(scenes, built, strict=True)
            ]
        )
        # Compiled here, outside the timed loop (a cached compile takes ~1 s); every call has
        # this shape, so this is the batch's only compile.
        integrator = options["integrator"]
        function = _chunk_function(jax, integrator)
        chunk = _compiled(jax, integrator, function, calls[0].model, calls[0].data, 0)
        return _Batch(scenes=list(scenes), calls=calls, chunk=chunk, state=start, device=device)

    def _batch_advance(
        self, batch: _Batch, active: np.ndarray, steps: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """The active worlds step (vmap; the others keep their state: a world still running
        must not move while the finishing ones take their last step); chunks longer than the
        compiled buffer are split. A call whose worlds are all inactive is not made."""
        states, forces = [batch.state[:, None]], []
        done = 0
        while done < steps:
            n = min(CHUNK_STEPS, steps - done)
            rows, force = self._advance_calls(batch, active, n)
            states.append(rows)
            forces.append(force)
            batch.state = rows[:, -1]
            done += n
        return np.concatenate(states, axis=1), np.concatenate(forces, axis=1)

    def _advance_calls(
        self, batch: _Batch, active: np.ndarray, n: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """``n`` steps of every call that has an active world: the worlds' states (W, n, 6)
        and forces (W, n, 2); a world not stepped repeats its state, with no force."""
        worlds = len(batch.scenes)
        rows = np.repeat(batch.state[:, None], n, axis=1)
        force = np.zeros((worlds, n, 2))
        mask = np.zeros(len(batch.calls) * WORLDS_PER_CALL, dtype=bool)
        mask[:worlds] = active
        import jax

        launched = []
        for k, call in enumerate(batch.calls):  # every call launched before any is read
            first = k * WORLDS_PER_CALL
            here = mask[first : first + WORLDS_PER_CALL]
            if not here.any():
                continue
            stepped, *out = batch.chunk(call.model, call.data, n)
            if not here.all():
                stepped = _kept(jax, here, stepped, call.data, batch.device)
            call.data = stepped
            launched.append((first, out))
        for first, out in launched:
            # Sliced on the host: a slice of the device array compiled once per length n.
            qpos, qvel, f = (np.asarray(x, dtype=float)[:, :n] for x in out)
            for k in map(int, np.flatnonzero(mask[first : first + WORLDS_PER_CALL])):
                i = first + k  # an active world (a padding copy never is)
                rows[i] = com_rows(batch.scenes[i], qpos[k], qvel[k])
                force[i] = f[k][:, [2, 0]]  # world frame: z is the normal (up), x the friction
        return rows, force


_SCRIPT = '''
import jax
import mujoco
from mujoco import mjx
from mujoco.mjx._src.support import contact_force  # MJX's mj_contactForce (not re-exported)

jax.config.update("jax_enable_x64", {x64})  # precision {precision}: False is JAX's float32

{model}

CHUNK = {chunk}
"""Steps per call of the compiled loop (its row buffers' length)."""
WORLDS = {worlds}
"""Worlds per call of the compiled loop."""


def steps(model, data, n):
    """n steps (n <= CHUNK, traced: one compile serves every n) from data: each is
    mjx.forward (constraint forces at the state before the step), the contact force of
    contact 0 (the hoop-floor pair) in the world frame, then the integrator ({integrator}):
    the force at the state the step starts from, as MuJoCo C's sensor gives it (mjx.step
    would leave the last RK4 stage's forces in data)."""
    rows = (
        jax.numpy.zeros((CHUNK, model.nq), data.qpos.dtype),
        jax.numpy.zeros((CHUNK, model.nv), data.qvel.dtype),
        jax.numpy.zeros((CHUNK, 3), data.qpos.dtype),
    )

    def step(i, carry):
        data, qpos, qvel, force = carry
        data = mjx.forward(model, data)
        f = contact_force(model, data, 0, to_world_frame=True)[:3]
        data = mjx.{integrate}(model, data)
        return data, qpos.at[i].set(data.qpos), qvel.at[i].set(data.qvel), force.at[i].set(f)

    return jax.lax.fori_loop(0, n, step, (data, *rows))


def simulate():
    """One world on {device_text}: the window in compiled chunks of CHUNK steps, one step
    more for the last state's force."""
    model, data = start(mujoco)
    device = jax.devices({device_arg})[0]
    mx = mjx.put_model(model, device=device, impl="jax")
    dx = mjx.put_data(model, data, device=device, impl="jax")
    # put_data's contact indices are int32 where a step makes int64 (x64): the loop's carry
    # must keep its types, so the data takes a step's types first.
    like = jax.eval_shape(mjx.forward, mx, dx)
    dx = jax.tree.map(lambda leaf, typed: leaf.astype(typed.dtype), dx, like)
    # A call of WORLDS worlds (this one and copies of it), as hoopbench steps it: XLA
    # compiles each batch shape to its own float32 roundings (measured on hop-top: the
    # unbatched loop first differs at step 719, batches of 1, 2, 3 and 4 worlds at step 202).
    run = jax.jit(jax.vmap(steps, in_axes=(0, 0, None)))
    mx, dx = (jax.tree.map(lambda leaf: jax.numpy.stack([leaf] * WORLDS), t) for t in (mx, dx))
    qpos, qvel, force = [np.array([data.qpos])], [np.array([data.qvel])], []
    done = 0
    while done <= N_STEPS:
        n = min(CHUNK - done % CHUNK, N_STEPS - done) or 1  # 1: the last force's step
        dx, q, v, f = run(mx, dx, n)
        force.append(np.asarray(f[0, :n], dtype=float))
        if done < N_STEPS:
            qpos.append(np.asarray(q[0, :n], dtype=float))
            qvel.append(np.asarray(v[0, :n], dtype=float))
        done += n
    qpos, qvel, force = (np.concatenate(x)[: N_STEPS + 1] for x in (qpos, qvel, force))
    com = com_state(qpos[:, 0], A + qpos[:, 1], qpos[:, 2], *qvel.T)
    return {{**com, "normal_force": force[:, 2] / M, "friction_force": force[:, 0] / M}}
'''
"""MJX's part of a standalone script (engines/standalone.py), as an MJX user writes it."""


XLA_THREADS_VARIABLES = ("PJRT_NPROC", "NPROC")
"""The environment variables XLA's CPU client reads, in this order, for the size of its thread
pool when JAX creates it (``xla/pjrt/cpu/cpu_client.cc``); unset, the pool has a thread per
schedulable core."""


def _xla_threads_per_share() -> None:
    """XLA's CPU pool sized to this process's share of the cores (``PJRT_NPROC``,
    :func:`cores_per_process`: one in each of ``make report``'s two workers on 2 cores, every
    core for a run alone) unless the user chose a size; set before JAX creates its CPU client
    (a process whose client exists keeps its pool). A batch step runs thousands of small
    kernels (XLA thunks: RK4's four solves, each solver iteration a 50-iteration line search of
    90), and with more threads than its share XLA's thunk executor hands ready ones between
    threads the other workers need: the finer suite's call (8 worlds, 30,000 steps at dt 1e-4)
    stepped in 6.6-7.6 % less CPU time with one thread per worker, the same rows bit for bit
    (docs/engines.md, MJX)."""
    if not any(os.environ.get(name) for name in XLA_THREADS_VARIABLES):
        os.environ[XLA_THREADS_VARIABLES[0]] = str(cores_per_process())


def _jax_gpu_plugins() -> list[str]:
    """The JAX GPU plugins installed (``jax-cuda12-plugin`` and the like): JAX finds them as
    ``jax_plugins`` entry points or modules of that namespace package (``jax._src.xla_bridge
    .discover_pjrt_plugins``); without one JAX has only its CPU."""
    found = [entry.name for entry in entry_points(group="jax_plugins")]
    if find_spec("jax_plugins") is not None:
        namespace = import_module("jax_plugins")
        found += [module.name for module in pkgutil.iter_modules(namespace.__path__)]
    return found


def _device(jax: ModuleType, choice: str) -> Any:
    """The device of a run: JAX's default (a GPU if it sees one), the CPU, or a GPU
    (RuntimeError if there is none: the run is an error row saying so)."""
    if choice == "auto":
        return jax.devices()[0]
    try:
        return jax.devices(choice)[0]
    except RuntimeError as exc:
        raise RuntimeError(f"no {choice} device for JAX: {exc}") from None


def _forward() -> ModuleType:
    """MJX's ``forward`` module (internal: ``forward`` and the integrators apart)."""
    from mujoco.mjx._src import forward

    return forward


@cache
def _typed_function(jax: ModuleType) -> Any:
    """(model, data) -> data with a step's dtypes, compiled once per process: put_data's
    contact indices are int32 where a step makes int64 (x64), and the loop's carry must keep
    its types. Traced in a jit that lives as long as the process (tracing ``forward`` anew
    for every batch cost 1.4-2 s of each repeated call). Called in float64 only: without x64
    put_data's types are a step's (tests/test_mjx.py), and the trace cost 0.6 CPU-s."""

    def typed(model: Any, data: Any) -> Any:
        like = jax.eval_shape(_forward().forward, model, data)
        return jax.tree.map(lambda leaf, t: leaf.astype(t.dtype), data, like)

    return jax.jit(jax.vmap(typed))


@cache
def _chunk_function(jax: ModuleType, integrator: str) -> Any:
    """The compiled chunk, one per process and integrator (JAX keeps a trace per shape and
    precision; tracing RK4 takes about 5 s): (model, data, steps) -> (data, qpos, qvel,
    force), every world stepped; each world's rows after each step fill buffers of
    CHUNK_STEPS rows (``steps`` is traced, so one compile serves every chunk length), with
    the world-frame contact force of each step. The loop is the standalone script's
    (``_SCRIPT``): a mask inside it (``where(active, ...)`` per step) compiled a batch of 8
    worlds to other roundings than the script's loop (hop-top's Y from row 55 at dt 1e-4),
    so the inactive worlds are put back after the call (:func:`_kept`)."""
    import jax.numpy as jnp
    from mujoco.mjx._src import forward, support

    integrate = {
        "Euler": forward.euler,
        "RK4": forward.rungekutta4,
        "implicitfast": forward.implicit,
    }[integrator]

    def world(model: Any, data: Any, steps: Any) -> tuple[Any, Any, Any, Any]:
        rows = (
            jnp.zeros((CHUNK_STEPS, model.nq), data.qpos.dtype),
            jnp.zeros((CHUNK_STEPS, model.nv), data.qvel.dtype),
            jnp.zeros((CHUNK_STEPS, 3), data.qpos.dtype),
        )

        def step(i: Any, carry: tuple[Any, ...]) -> tuple[Any, ...]:
            data, qpos, qvel, force = carry
            data = forward.forward(model, data)
            f = support.contact_force(model, data, 0, to_world_frame=True)[:3]
            data = integrate(model, data)
            return data, qpos.at[i].set(data.qpos), qvel.at[i].set(data.qvel), force.at[i].set(f)

        return jax.lax.fori_loop(0, steps, step, (data, *rows))

    return jax.jit(jax.vmap(world, in_axes=(0, 0, None)))


_compiled_functions: dict[tuple[Any, ...], Any] = {}
"""This process's compiled functions by what they were compiled for (:func:`_compiled`), the
last used last."""

KEPT_COMPILED = 16
"""Compiled functions a process keeps, the least recently used dropped first: a suite's worker
meets a handful of settings groups (``make report``: 5 chunks and a cast), while a search
that changes MJX's static settings trial after trial would otherwise keep every executable."""


def _compiled(jax: ModuleType, name: str, function: Any, *arguments: Any) -> Any:
    """``function`` (a jit) traced, lowered and compiled for ``arguments`` (JAX's persistent
    cache gives the compile), once per process for their precision, pytree structure (MJX's
    static metadata by content), types and devices: the same executable as the jit's own
    call. Kept here because a change of precision clears JAX's caches (MjxEngine._open_batch),
    and a process that came back to the precision it had left traced MJX's step anew (about
    5 CPU-s for RK4); a compiled function holds its own executable, which that clearing leaves
    usable (tests/test_mjx.py)."""
    leaves, tree = jax.tree.flatten(arguments)
    types = tuple(jax.typeof(leaf) for leaf in leaves)
    devices = {d for leaf in leaves if isinstance(leaf, jax.Array) for d in leaf.devices()}
    key = (name, bool(jax.config.jax_enable_x64), tree, types, frozenset(devices))
    compiled = _compiled_functions.pop(key, None)
    if compiled is None:
        compiled = function.trace(*arguments).lower().compile()
    _compiled_functions[key] = compiled
    while len(_compiled_functions) > KEPT_COMPILED:
        del _compiled_functions[next(iter(_compiled_functions))]
    return compiled


def _stacked(jax: ModuleType, trees: Sequence[Any], device: Any) -> Any:
    """The worlds' models (or datas) stacked leaf by leaf on the host and put on the device:
    ``jnp.stack`` compiled a stack for each leaf's shape and type, about 1.4 CPU-s of every
    batch's set-up, for the same numbers (a copy). ValueError if their metadata differ."""
    host = jax.tree.map(lambda *leaves: np.stack([np.asarray(x) for x in leaves]), *trees)
    return jax.device_put(host, device)


def _kept(jax: ModuleType, active: np.ndarray, stepped: Any, before: Any, device: Any) -> Any:
    """The data of the active worlds from ``stepped``, of the others from ``before``: a
    select on the host (the compiled select cost 0.5 CPU-s of every batch's set-up), exact,
    for the calls of the window's last chunks only."""

    def keep(new: Any, old: Any) -> np.ndarray:
        new, old = np.asarray(new), np.asarray(old)
        return np.where(active.reshape(-1, *[1] * (new.ndim - 1)), new, old)

    return jax.device_put(jax.tree.map(keep, stepped, before), device)


@dataclass
class _Call:
    """WORLDS_PER_CALL worlds on the device: their stacked model and data."""

    model: Any
    data: Any


@dataclass
class _Batch:
    """The worlds on the device in calls of WORLDS_PER_CALL, the compiled chunk, and every
    world's last centre-of-mass state (W, 6)."""

    scenes: list[Scene]
    calls: list[_Call]
    chunk: Any
    state: np.ndarray
    device: Any
