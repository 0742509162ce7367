"""MuJoCo Warp adapter (``mujoco-warp``, on NVIDIA Warp): the hoop of the MuJoCo adapter, many
worlds in one ``Data`` (``nworld``), stepped by Warp kernels on the CPU or a GPU.

The model is the MuJoCo adapter's (``models/mjcf.py``: the same pair, solref, solimp, cone,
integrator), and every world starts where the MuJoCo adapter starts it (the equilibrium
penetration found with MuJoCo C's ``mj_forward``): the C model and data are built first, then
put on the device, so a difference between the two engines is the stepping's.

Worlds. Each world is its own scene. MuJoCo Warp's ``Model`` keeps one copy of each array,
except those whose spec has a leading ``*`` (mass, inertia, centre of mass, geom size, pair
friction, gravity, ...), which may hold one row per world: the worlds' models are put on the
device one by one and every such array that differs between them is stacked, one row per
world. An array that differs and has no world axis makes the batch an error, except
``dof_length``, which only the sleeping feature reads (off in this model): the first
world's is kept.

Contact force. Each step is ``forward`` (constraint forces at the state before the step),
then ``contact_force`` (world frame) of every active contact, summed per world, then the
integrator (``mujoco_warp.step`` would leave RK4's last stage's forces): the MuJoCo adapter's
timing (its sensor is evaluated before integrating). Each step is a graph captured once per
kept objects and replayed (``_Batch._step``, ``CAPTURE_STEPS``), as MuJoCo Warp's own
benchmark steps: a CUDA graph on a GPU, Warp's CPU graph on a CPU, whose replay calls the
step's kernels without Python's cost per launch (a lone world's step 8.7 ms launched, 0.05 ms
replayed: docs/engines.md, MuJoCo Warp). States and forces are read back to the host after
every step: free on the CPU (shared memory); on a GPU a copy per step (the contacts' sums
per world would need a kernel of their own: left out).

Built once. What a call builds that no world's state changes (the stacked model, the Data,
the contact buffers, the captured step) is kept per process per device, options, timestep
and worlds (``_KEPT``); a later call writes its worlds' start into the kept Data.

Precision: single (Warp's ``float``), MuJoCo Warp's only one. Warp's compiled kernels go to
its kernel cache (``HOOPBENCH_CACHE`` or the user's cache folder, ``hoopbench/warp``): the
first step of a new build compiles for about 20 s on 2 CPU cores.
"""

from __future__ import annotations

import dataclasses
from collections import OrderedDict
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import (
    DEVICE,
    WARP_CACHE,
    WARP_ENABLE_BACKWARD,
    WorldsEngine,
    import_warp,
    warp_device,
)
from hoopbench.engines.mujoco_engine import MjcfEngine, MujocoEngine
from hoopbench.engines.options import Variant, choice
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.engines.warp_compile import load_modules
from hoopbench.models.mjcf import com_rows
from hoopbench.models.scene import Scene

__all__ = ["MjwarpEngine"]

_MJWARP_INTEGRATORS = ("Euler", "RK4", "implicit", "implicitfast")
"""MuJoCo Warp's integrators without ``discrete`` (its step differs: no force before it)."""

_STATE = ("qpos", "qvel", "qacc_warmstart", "time")
"""What a step changes that the next step reads (MuJoCo's integration state, no actuators)."""

_UNUSED_WITHOUT_WORLD_AXIS = frozenset({"dof_length"})
"""Model arrays without a world axis that may differ between worlds: read only by features
this model turns off (``dof_length``: sleeping)."""


@register
class MjwarpEngine(WorldsEngine, MjcfEngine):
    """MuJoCo Warp: the MuJoCo adapter's model, nworld worlds in one Data."""

    name = "mjwarp"
    distribution = "mujoco-warp"
    modules = ("mujoco", "warp", "mujoco_warp")
    geometries = ("sphere",)
    step_cost_bound = 0.2
    """6 times a lone world's step on the CPU launched from Python (34 ms, RK4, 2026-11-28;
    replayed as Warp's CPU graph a step costs under 1 ms, 8 worlds tuned: docs/engines.md)."""
    compiled_cache = WARP_CACHE
    gpu_only = (
        "on a CPU its rows give MJX float32's verdicts, and its Warp kernels cost about 33 "
        "CPU-s to compile on a machine's first run"
    )
    # A GPU is the point of it. On a CPU its steps are Warp graphs replayed there, cheap to
    # step (0.05 ms for a lone world stock, 0.15 ms tuned, 2026-11-29) but dear to compile:
    # its 18 runs took 42 CPU-s in make report's first run and 9.5 in the next (2026-11-29, a
    # Xeon at 2.1 GHz, 2 cores: 8 % of that first run's worker CPU), for rows MJX's give
    # already. The full suite runs it everywhere.
    options = (
        *MujocoEngine.options_except("ring_segments", integrator=choice(*_MJWARP_INTEGRATORS)),
        DEVICE,
    )
    variants = (Variant("cone=pyramidal", options={"cone": "pyramidal"}),)

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        device = options["device"]
        chosen = {
            "auto": '"cuda:0" if wp.get_cuda_device_count() else "cpu"',
            "cpu": '"cpu"',
            "gpu": '"cuda:0"',
        }[device]
        return _SCRIPT.format(
            model=self._script_model(scene, settings, options),
            device=chosen,
            device_text="a GPU if Warp sees one, else the CPU" if device == "auto" else device,
            integrator=options["integrator"],
            integrate=_SCRIPT_INTEGRATE[options["integrator"]],
            enable_backward=WARP_ENABLE_BACKWARD,
        )

    def _import(self) -> ModuleType:
        import_warp()
        return super()._import()

    @contextmanager
    def _open_batch(
        self,
        module: ModuleType,
        scenes: Sequence[Scene],
        settings: RunSettings,
        options: dict[str, Any],
    ) -> Iterator[_Batch]:
        import mujoco_warp as mjw
        import warp as wp

        device = warp_device(wp, options["device"])
        with wp.ScopedDevice(device):
            built = [self._build(module, scene, settings, options) for scene in scenes]
            key = (
                device,
                tuple(sorted(options.items())),
                settings.timestep,
                tuple((scene, self.mu_for(scene, settings)) for scene in scenes),
            )
            kept = _KEPT.get(key)
            if kept is None:
                kept = _kept(mjw, wp, built, options)
                _KEPT[key] = kept
                while len(_KEPT) > KEPT_CALLS:
                    _KEPT.popitem(last=False)
            else:
                _KEPT.move_to_end(key)
                kept.calls += 1
            for field in _STATE:  # the worlds' start: MuJoCo C's equilibrium (module doc)
                rows = np.array([np.atleast_1d(getattr(d, field)) for _, d in built])
                getattr(kept.data, field).assign(rows.reshape(getattr(kept.data, field).shape))
            yield _Batch(mjw, wp, list(scenes), kept)

    def _batch_advance(
        self, batch: _Batch, active: np.ndarray, steps: int
    ) -> tuple[np.ndarray, np.ndarray]:
        with batch.wp.ScopedDevice(batch.kept.data.qpos.device):
            qpos, qvel, force = batch.advance(steps, active)
        states = np.stack(
            [com_rows(s, q, v) for s, q, v in zip(batch.scenes, qpos, qvel, strict=True)]
        )
        # world frame: z is the normal (up), x the friction.
        return states, force[:, :, [2, 0]]


_SCRIPT = '''
import mujoco
import warp as wp

wp.config.enable_backward = {enable_backward}  # no gradients: no backward kernels compiled
import mujoco_warp as mjw  # after the line above: its modules take the setting when made

{model}

def simulate():
    """One world on {device_text}. Each step is mjw.forward (constraint forces at the state
    before the step), the world-frame contact force of every contact (summed: the force on
    the hoop), then the integrator ({integrator}): the force at the state the step starts
    from, as MuJoCo C's sensor gives it (mjw.step would leave the last RK4 stage's forces).
    One step more gives the last state its force. MuJoCo Warp runs in single precision."""
    model, data = start(mujoco)
    with wp.ScopedDevice({device}):
        m = mjw.put_model(model)
        d = mjw.put_data(model, data, nworld=1)
        ids = wp.array(np.arange(d.naconmax, dtype=np.int32), dtype=wp.int32)
        contact = wp.zeros(d.naconmax, dtype=wp.spatial_vector)  # force, torque per contact
        qpos, qvel = [d.qpos.numpy()[0].astype(float)], [d.qvel.numpy()[0].astype(float)]
        force = np.zeros((N_STEPS + 1, 3))
        for i in range(N_STEPS + 1):
            mjw.forward(m, d)
            mjw.contact_force(m, d, ids, True, contact)  # True: in the world frame
            n = int(d.nacon.numpy()[0])
            for each in contact.numpy()[:n, :3]:  # float32; summed in float64
                force[i] += each
            mjw.{integrate}(m, d)
            if i < N_STEPS:
                qpos.append(d.qpos.numpy()[0].astype(float))
                qvel.append(d.qvel.numpy()[0].astype(float))
        wp.synchronize()
    qpos, qvel = np.array(qpos), np.array(qvel)
    com = com_state(qpos[:, 0], A + qpos[:, 1], qpos[:, 2], *qvel.T)
    return {{**com, "normal_force": force[:, 2] / M, "friction_force": force[:, 0] / M}}
'''
"""MuJoCo Warp's part of a standalone script (engines/standalone.py), as its users write it."""

_SCRIPT_INTEGRATE = {
    "Euler": "euler",
    "RK4": "rungekutta4",
    "implicit": "implicit",
    "implicitfast": "implicit",
}
"""MuJoCo Warp's integrator function of each integrator option (one serves both implicit)."""


def _stacked_model(mjw: ModuleType, wp: ModuleType, models: Sequence[Any]) -> Any:
    """One MuJoCo Warp model of all worlds: every world-axis array that differs between the
    worlds' models holds one row per world (module doc)."""
    puts = [mjw.put_model(m) for m in models]
    first = puts[0]
    if len(puts) == 1:
        return first
    for path, arrays in _differing_arrays(puts):
        holder = first
        for part in path[:-1]:
            holder = getattr(holder, part)
        name = path[-1]
        if arrays[0].shape[:1] != (1,) or not _has_world_axis(holder, name):
            if name in _UNUSED_WITHOUT_WORLD_AXIS:
                continue
            raise ValueError(
                f"MuJoCo Warp cannot batch these scenes: {'.'.join(path)} differs between "
                "worlds and has no world axis"
            )
        stacked = np.concatenate([a.numpy() for a in arrays])
        setattr(holder, name, wp.array(stacked, dtype=arrays[0].dtype))
    return first


def _has_world_axis(holder: Any, name: str) -> bool:
    """Whether a Model (or Option) field's array spec starts with ``*``, the world axis."""
    spec = {f.name: f.type for f in dataclasses.fields(holder)}.get(name)
    return tuple(getattr(spec, "shape", ()))[:1] == ("*",)


def _differing_arrays(models: Sequence[Any], path: tuple[str, ...] = ()) -> Iterator[Any]:
    """(field path, the worlds' arrays) for each Warp array that is not the same in every
    model, walking the model's nested dataclasses (``opt``)."""
    for f in dataclasses.fields(models[0]):
        values = [getattr(m, f.name) for m in models]
        if dataclasses.is_dataclass(values[0]) and not isinstance(values[0], type):
            yield from _differing_arrays(values, (*path, f.name))
        elif hasattr(values[0], "numpy") and hasattr(values[0], "dtype"):
            first = values[0].numpy()
            if any(not np.array_equal(first, v.numpy()) for v in values[1:]):
                yield (*path, f.name), values


KEPT_CALLS = 4
"""Calls whose built objects one process keeps (the least recently used one goes)."""

_KEPT: OrderedDict[tuple[Any, ...], _Kept] = OrderedDict()
"""Per process, per device, options, timestep and worlds (their scenes and mu): what a call
builds that no world's state changes (:func:`_kept`)."""


@dataclass
class _Kept:
    """What a call builds that does not depend on the worlds' states, kept per process: the
    stacked model, the Data of its worlds (each call writes its worlds' integration state,
    ``_STATE``, into it), the buffers of one step's contact forces, the integrator and the
    captured step."""

    model: Any
    data: Any
    ids: Any
    contact: Any
    contacts: tuple[Any, Any]
    """The count of active contacts and each one's world, copied before the integrator
    (RK4's stages detect contacts again: read after the step, they were the last stage's)."""
    integrate: Any
    graph: Any = None
    """The captured graph of one step (forward, contact_force, the integrator): a CUDA
    graph, or Warp's CPU graph."""
    calls: int = 1
    """Calls served, this one included."""


def _kept(mjw: ModuleType, wp: ModuleType, built: Sequence[Any], options: dict) -> _Kept:
    """The stacked model and Data of new worlds, and one step of a scratch copy of the first
    world: the kernels load (or compile, on first use) here, outside the timed loop."""
    mjm, mjd = built[0]
    model = _stacked_model(mjw, wp, [m for m, _ in built])
    data = mjw.put_data(mjm, mjd, nworld=len(built))
    n = data.naconmax
    ids = wp.array(np.arange(n, dtype=np.int32), dtype=wp.int32)
    contact = wp.zeros(n, dtype=wp.spatial_vector)
    integrate = getattr(mjw, _SCRIPT_INTEGRATE[options["integrator"]])
    contacts = (wp.empty_like(data.nacon), wp.empty_like(data.contact.worldid))
    scratch = mjw.put_data(mjm, mjd, nworld=len(built))
    load_modules(wp, wp.get_device(), WARP_MODULES)
    mjw.forward(model, scratch)
    mjw.contact_force(model, scratch, ids, True, contact)
    integrate(model, scratch)
    wp.synchronize()
    return _Kept(model, data, ids, contact, contacts, integrate)


WARP_MODULES = (
    "mujoco_warp._src.forward",
    "mujoco_warp._src.smooth",
    "mujoco_warp._src.sensor",
    "mujoco_warp._src.passive",
    "mujoco_warp._src.solver",
    "mujoco_warp._src.support",
    "mujoco_warp._src.constraint",
)
"""MuJoCo Warp's modules (of all its kernels but those made per model, ``module="unique"``)
that a step loads, stock and tuned, the dearest first (compiled on the CPU, 2026-11-29:
5.3-5.7, 5.2-6.0, 3.7-4.3, 3.1-3.3, 0.7, 0.3 and 0.1 CPU-s of the 27 a cold process pays):
loaded before the first step, where two cold processes split them (engines/warp_compile.py).
"""


@dataclass
class _Batch:
    """The worlds' kept objects on a Warp device (model, Data, contact-force buffers)."""

    mjw: ModuleType
    wp: ModuleType
    scenes: list[Scene]
    kept: _Kept

    @property
    def data(self) -> Any:
        """The worlds' MuJoCo Warp Data."""
        return self.kept.data

    def _step(self) -> None:
        """One step of every world: forward, the contact forces, the integrator, a graph
        captured once per kept objects (``wp.ScopedCapture``, replayed by
        ``wp.capture_launch``, as MuJoCo Warp's own benchmark steps), on a CPU too."""
        mjw, wp, kept = self.mjw, self.wp, self.kept
        if not CAPTURE_STEPS:
            _launch_step(mjw, kept)
            return
        if kept.graph is None:
            with wp.ScopedCapture() as capture:
                _launch_step(mjw, kept)
            kept.graph = capture.graph
        wp.capture_launch(kept.graph)

    def advance(self, steps: int, active: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """qpos, qvel (W, steps + 1, 3): before the chunk and after each step; the
        world-frame contact force on the hoop of each step (W, steps, 3), N. Every world
        steps (one launch serves all); the inactive ones get their state back after each
        step, so that a world still running does not move while others finish."""
        wp, d = self.wp, self.kept.data
        nworld = d.nworld
        kept = (
            {name: getattr(d, name).numpy().copy() for name in _STATE} if not active.all() else {}
        )
        qpos = [d.qpos.numpy().astype(float)]
        qvel = [d.qvel.numpy().astype(float)]
        force = np.zeros((steps, nworld, 3))
        for i in range(steps):
            self._step()
            count, worlds = self.kept.contacts
            n = int(count.numpy()[0])
            np.add.at(force[i], worlds.numpy()[:n], self.kept.contact.numpy()[:n, :3])
            for name, before in kept.items():
                now = getattr(d, name).numpy()
                now[~active] = before[~active]
                getattr(d, name).assign(now)
            qpos.append(d.qpos.numpy().astype(float))
            qvel.append(d.qvel.numpy().astype(float))
        wp.synchronize()
        return (
            np.stack(qpos, axis=1),
            np.stack(qvel, axis=1),
            np.transpose(force, (1, 0, 2)),
        )


CAPTURE_STEPS = True
"""Each step is a captured graph replayed (``wp.ScopedCapture``, ``wp.capture_launch``): a
CUDA graph on a GPU, Warp's CPU graph on a CPU (a lone world's step 8.7 ms launched, 0.05 ms
replayed, stock; 29 and 0.15 ms tuned). False launches each kernel from Python: the same
rows bit for bit (tests/test_mjwarp.py)."""


def _launch_step(mjw: ModuleType, kept: _Kept) -> None:
    """forward (constraint forces at the state before the step), the world-frame force of
    every contact and which contacts they are, then the integrator (module doc, Contact
    force)."""
    mjw.forward(kept.model, kept.data)
    mjw.contact_force(kept.model, kept.data, kept.ids, True, kept.contact)
    count, worlds = kept.contacts
    count.assign(kept.data.nacon)  # a device copy (wp.copy): a graph may hold it
    worlds.assign(kept.data.contact.worldid)
    kept.integrate(kept.model, kept.data)
