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
takes about 20 s on 2 CPU cores, a cached one about 1 s.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cache
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import CHUNK_STEPS, DEVICE, WorldsEngine, cache_folder
from hoopbench.engines.mujoco_engine import MjcfEngine, MujocoEngine
from hoopbench.engines.options import Option, Variant, choice, one_of
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.models.mjcf import com_rows
from hoopbench.models.scene import Scene

__all__ = ["PRECISIONS", "MjxEngine"]

PRECISIONS: tuple[str, ...] = ("float32", "float64")

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
            integrator=options["integrator"],
            integrate=integrate[options["integrator"]],
            device_text="JAX's default device" if device == "auto" else f"the {device}",
            device_arg="" if device == "auto" else repr(device),
        )

    def _import(self) -> ModuleType:
        module = super()._import()
        import jax

        jax.config.update("jax_compilation_cache_dir", str(cache_folder("jax")))
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
        import jax.numpy as jnp
        from mujoco import mjx

        device = _device(jax, options["device"])
        # One model name for every run: the names are static metadata, which JAX's jit keys
        # its traces on, so a scene's own name cost a trace and a compile per scene (measured:
        # 80-135 s for each 20-step placement run on 2 loaded cores).
        built = [self._build(mujoco, s.with_(name=""), settings, options) for s in scenes]
        models = [mjx.put_model(m, device=device, impl="jax") for m, _ in built]
        datas = [mjx.put_data(m, d, device=device, impl="jax") for m, d in built]
        # Heightfield bounds are static metadata that follow the radius; this model has no
        # heightfield, so the first world's stand for all (scenes of different sizes stack).
        hfield = models[0]._impl.geom_rbound_hfield
        models = [m.replace(_impl=m._impl.replace(geom_rbound_hfield=hfield)) for m in models]
        try:
            model = jax.tree.map(lambda *leaves: jnp.stack(leaves), *models)
        except ValueError as exc:
            raise ValueError(f"the scenes' MJX models differ in more than arrays: {exc}") from None
        data = jax.tree.map(lambda *leaves: jnp.stack(leaves), *datas)
        # put_data's contact indices are int32 where a step makes int64 (x64): the loop's
        # carry must keep its types, so the data takes a step's types first.
        stepped = jax.eval_shape(jax.vmap(_forward().forward), model, data)
        data = jax.tree.map(lambda leaf, like: leaf.astype(like.dtype), data, stepped)
        start = np.array(
            [
                com_rows(scene, d.qpos, d.qvel)[0]
                for scene, (_, d) in zip(scenes, built, strict=True)
            ]
        )
        chunk = _chunk_function(jax, options["integrator"])
        # Compiled here, outside the timed loop: zero steps (a cached compile takes ~1 s).
        jax.block_until_ready(chunk(model, data, 0, np.ones(len(scenes), dtype=bool)))
        return _Batch(scenes=list(scenes), model=model, data=data, chunk=chunk, state=start)

    def _batch_advance(
        self, batch: _Batch, active: np.ndarray, steps: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """The active worlds step (vmap; the others keep their state: a world still running
        must not move while the finishing ones take their last step); chunks longer than the
        compiled buffer are split."""
        states, forces = [batch.state[:, None]], []
        done = 0
        while done < steps:
            n = min(CHUNK_STEPS, steps - done)
            batch.data, qpos, qvel, force = batch.chunk(batch.model, batch.data, n, active)
            qpos, qvel, force = (np.asarray(x[:, :n], dtype=float) for x in (qpos, qvel, force))
            rows = np.stack(
                [com_rows(s, q, v) for s, q, v in zip(batch.scenes, qpos, qvel, strict=True)]
            )
            states.append(rows)
            # world frame: z is the normal (up), x the friction.
            forces.append(force[:, :, [2, 0]])
            done += n
        batch.state = states[-1][:, -1]
        return np.concatenate(states, axis=1), np.concatenate(forces, axis=1)


_SCRIPT = '''
import jax
import mujoco
from mujoco import mjx
from mujoco.mjx._src.support import contact_force  # MJX's mj_contactForce (not re-exported)

jax.config.update("jax_enable_x64", {x64})  # precision {precision}: False is JAX's float32

{model}

CHUNK = {chunk}
"""Steps per call of the compiled loop (its row buffers' length)."""


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
    # A batch of one world, as hoopbench steps it: jit of the unbatched loop compiles to other
    # float32 roundings (measured: the first difference at step 719 of hop-top).
    run = jax.jit(jax.vmap(steps, in_axes=(0, 0, None)))
    mx, dx = (jax.tree.map(lambda leaf: leaf[None], tree) for tree in (mx, dx))
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
def _chunk_function(jax: ModuleType, integrator: str) -> Any:
    """The compiled chunk, one per process and integrator (JAX keeps a trace per shape and
    precision; tracing RK4 takes about 5 s): (model, data, steps, active) -> (data, qpos,
    qvel, force). The inactive worlds' data is left as it was; each world's rows after each
    step fill buffers of CHUNK_STEPS rows (``steps`` is traced, so one compile serves every
    chunk length), with the world-frame contact force of each step."""
    import jax.numpy as jnp
    from mujoco.mjx._src import forward, support

    integrate = {
        "Euler": forward.euler,
        "RK4": forward.rungekutta4,
        "implicitfast": forward.implicit,
    }[integrator]

    def world(model: Any, data: Any, steps: Any, active: Any) -> tuple[Any, Any, Any, Any]:
        rows = (
            jnp.zeros((CHUNK_STEPS, model.nq), data.qpos.dtype),
            jnp.zeros((CHUNK_STEPS, model.nv), data.qvel.dtype),
            jnp.zeros((CHUNK_STEPS, 3), data.qpos.dtype),
        )

        def step(i: Any, carry: tuple[Any, ...]) -> tuple[Any, ...]:
            data, qpos, qvel, force = carry
            before = data
            data = forward.forward(model, data)
            f = support.contact_force(model, data, 0, to_world_frame=True)[:3]
            data = integrate(model, data)
            data = jax.tree.map(lambda new, old: jnp.where(active, new, old), data, before)
            return data, qpos.at[i].set(data.qpos), qvel.at[i].set(data.qvel), force.at[i].set(f)

        return jax.lax.fori_loop(0, steps, step, (data, *rows))

    return jax.jit(jax.vmap(world, in_axes=(0, 0, None, 0)))


@dataclass
class _Batch:
    """The worlds on the device: stacked model and data, the compiled chunk, and every
    world's last centre-of-mass state (W, 6)."""

    scenes: list[Scene]
    model: Any
    data: Any
    chunk: Any
    state: np.ndarray
