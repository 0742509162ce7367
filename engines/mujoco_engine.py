"""MuJoCo adapter: the hoop as one body with slide x, slide z and a hinge about y.

The model comes from :func:`hoopbench.models.mjcf.scene_to_mjcf` (see there for frames and contact).
Stepping runs in C through ``mujoco.rollout`` in chunks of ``CHUNK_STEPS`` steps; each chunk
records the full physics state after every step and the model's ``contact_force`` sensor (a
contact sensor with ``reduce="netforce"``: the summed contact force on the hoop, world frame).
MuJoCo evaluates sensors inside ``mj_step`` before integrating, so the sensor row of step i is
the force acting at the state *before* step i: the adapter rolls out one extra step so that
every recorded state, t = 0 and t_end included, has its own force. The sensor equals
``mj_contactForce`` summed over all contacts and rotated into the world frame, and the
chunked rollout equals a plain ``mj_step`` loop bit for bit (both checked in
tests/test_mujoco.py). A batch of runs (``Engine.simulate_batch``) steps through
``mujoco.batch.Batch`` instead, one model per world, with the same rows bit for bit
(tests/test_batch.py).

Soft contact start. MuJoCo's contacts are springs with an equilibrium penetration (8e-8 m
in the seed scene with the defaults, 1.3e-6 m at solref 0.002). A hoop started exactly
touching gets no force in its first step, sinks in and rings for a few timeconsts (seed
scene: normal force 0, then up to 16 % above the rolling value). The adapter instead
starts the hoop at the penetration where the contact holds the centre with zero vertical
acceleration (found with ``mj_forward``): the first recorded normal force is the exact
rolling one and the recorded clearance at t = 0 is that small negative number. A scene that
leaves the floor at once (lam*chi > 1) starts touching.

Defaults (the ``options`` below), measured on mujoco 4.0.0 at timestep 1e-4. Slip onset of
seed-mu (mu = 0.8, exact 0.98708 s, 88.504 deg) against cone and solref timeconst, other
options at their defaults (RK4, impratio 100, solreffriction 0.015); "threshold" is the
1 mm/s crossing, "refined" the detectors' extrapolated onset:

    cone       solref   threshold           refined             false hop (max clearance)
    elliptic   0.0002   +1.9 ms  +0.35 deg  +1.3 ms  +0.24 deg  no (0.002 mm)
    elliptic   0.0005   +4.5 ms  +0.84 deg  +2.4 ms  +0.45 deg  no (0.002 mm)   <- default
    elliptic   0.002    +6.4 ms  +1.20 deg  +4.2 ms  +0.79 deg  no (0.007 mm)
    elliptic   0.02     +8.2 ms  +1.57 deg  -3.4 ms  -0.63 deg  no (0.068 mm)
    pyramidal  0.0002   +4.7 ms  +0.89 deg  +4.7 ms  +0.89 deg  yes (2.3 mm)
    pyramidal  0.0005   +4.8 ms  +0.91 deg  -5.0 ms  -0.93 deg  yes (0.42 mm)
    pyramidal  0.002    +5.0 ms  +0.95 deg  -6.1 ms  -1.13 deg  yes (0.32 mm)
    pyramidal  0.02     +6.3 ms  +1.20 deg  -14.8 ms -2.72 deg  no (0.014 mm)

With impratio 1, pyramidal and solref 0.02 slip at 26.4 deg (557.6 ms early, the figure in
docs/engines.md) under any integrator; elliptic cones slip within 8 ms with impratio 1 too.
What the defaults fix is not the onset but the slipping phase: a sliding MuJoCo contact
pushes the bodies apart (the convex model initiates slip through normal motion), and with
one solref for all rows the hoop chattered off the floor while slipping, 0.1 mm per m/s of
slip at solref 0.002 (a sliding sphere measured alone), so every hop scene showed a false
lift-off hundreds of ms early and the seed "hopped" at 1.43 s. A softer reference for the
friction rows (solreffriction 0.015) cuts the chatter tenfold; impratio 100 keeps rolling
creep below 0.01 mm/s; the one-step integrators (Euler, implicitfast, discrete) still lost
hop-top and hop-low to the chatter, RK4 did not (hop-top height -1 %, impact -0.8 ms).
The sensor is read at the first RK4 stage: the force at the recorded state.

Releases. The adapter runs MuJoCo 2.3.7 to 4.0 (docs/engines.md, Releases): a release
before 3.3.5 has no contact sensor, and there a run steps with ``mj_step`` from Python, reading
the force by ``mj_forward`` and ``mj_contactForce`` before each step (``_step_reading_forces``:
on 4.0.0 the same numbers as the rollout, bit for bit); batches need ``mujoco.batch`` (4.0).
"""

from __future__ import annotations

import importlib
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from types import ModuleType
from typing import Any, ClassVar

import numpy as np

from hoopbench.engines.base import (
    RUN_ALONE,
    STATE_KEYS,
    Chunk,
    Engine,
    equilibrium_depth,
    n_steps_for,
)
from hoopbench.engines.options import (
    Check,
    Option,
    Scale,
    Space,
    Variant,
    choice,
    int_range,
    integer,
    linear_range,
    log_range,
    number,
    one_of,
    real_tuple,
)
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.models import kinematics
from hoopbench.models.kinematics import Polygon
from hoopbench.models.mjcf import (
    CONES,
    INTEGRATORS,
    MJCF_GEOMETRIES,
    check_restitution,
    contact_shape,
    scene_to_mjcf,
)
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

__all__ = ["MjcfEngine", "MujocoEngine", "mjcf_text", "model_at_start", "start_sink"]

_BAD_STATE_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")

BATCH_THREADS = 1
"""Threads of a ``mujoco.batch.Batch``: one, since the runner's worker processes already
share the machine's cores among them (``--workers``)."""


def _check_solref(name: str, value: Any) -> tuple[float, float]:
    """(timeconst s, dampratio), both > 0, or MuJoCo's direct (-stiffness, -damping)."""
    pair = real_tuple((2,), "a pair (timeconst, dampratio)")(name, value)
    if not (all(v > 0 for v in pair) or all(v < 0 for v in pair)):
        raise ValueError(
            f"{name} must be (timeconst, dampratio), both > 0, or (-stiffness, -damping), "
            f"both < 0; got {value!r}"
        )
    return pair


def _check_solreffriction(name: str, value: Any) -> tuple[float, float]:
    """As solref, or (0, 0) for "same as solref"."""
    pair = real_tuple((2,), "a pair (timeconst, dampratio), or (0, 0)")(name, value)
    if pair == (0.0, 0.0):
        return pair
    if not (all(v > 0 for v in pair) or all(v < 0 for v in pair)):
        raise ValueError(
            f"{name} must be (0, 0) (same as solref), (timeconst, dampratio) both > 0, or "
            f"(-stiffness, -damping) both < 0; got {value!r}"
        )
    return pair


def _check_solimp(name: str, value: Any) -> tuple[float, ...]:
    """(dmin, dmax, width m[, midpoint, power]); MuJoCo's midpoint 0.5 and power 2 if absent."""
    solimp = real_tuple((3, 5), "(dmin, dmax, width[, midpoint, power])")(name, value)
    if len(solimp) == 3:
        solimp = (*solimp, 0.5, 2.0)
    dmin, dmax, width, midpoint, power = solimp
    if not (0 < dmin <= dmax < 1 and width > 0 and 0 < midpoint < 1 and power >= 1):
        raise ValueError(
            f"{name} must satisfy 0 < dmin <= dmax < 1, width > 0, 0 < midpoint < 1, "
            f"power >= 1; got {value!r}"
        )
    return solimp


MAX_RING_SEGMENTS = 1024
"""Most capsules in the ring: at 1024 the polygon's sagitta, a (1 - cos(pi/n)) = 4.7e-6 a, is
below any penetration MuJoCo's soft contact allows; more only grows the model (one capsule
each: 1e8 of them took minutes and gigabytes before the run began)."""


class MjcfEngine(Engine):
    """An engine that reads the MJCF of models/mjcf.py and starts at MuJoCo C's equilibrium
    penetration: MuJoCo, and MJX and MuJoCo Warp, which put MuJoCo C's model and data on
    their device. ``contact_sensor``: whether the model declares the contact-force sensor."""

    model_format = "MJCF (XML)"
    contact_sensor: ClassVar[bool] = True

    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        """Restitution != 0 raises ValueError before a run (see scene_to_mjcf)."""
        check_restitution(settings.restitution)

    def _model_text(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        mu = self.mu_for(scene, settings)
        return mjcf_text(scene, settings, options, mu, contact_sensor=self.contact_sensor)

    def _build(
        self, mujoco: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> tuple[Any, Any]:
        """Model and data at the initial state (equilibrium penetration, see module doc)."""
        if self.contact_sensor and not has_contact_sensor(mujoco):
            mu = self.mu_for(scene, settings)
            text = mjcf_text(scene, settings, options, mu, contact_sensor=False)
        else:
            text = self._model_text(scene, settings, options)
        return model_at_start(mujoco, text, scene, settings.geometry, options)

    def _script_model(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        """A standalone script's model part: the MJCF the run loads, as a string, the sink
        its start needs (found here with MuJoCo C, module doc) and ``start(mujoco)``, which
        returns MuJoCo C's model and data at the run's initial state."""
        import mujoco

        text = self._model_text(scene, settings, options)
        sink = start_sink(mujoco, text, scene, settings.geometry, options)
        return _SCRIPT_MODEL.format(mjcf=text.replace("\\", "\\\\"), sink=sink)


_SCRIPT_MODEL = '''
MJCF = """
{mjcf}"""
"""The model: one body with slide x, slide z and a hinge about +y at the hoop centre (MuJoCo's
z is up; the hinge angle is theta, clockwise from the top), the scene's mass and inertia in
<inertial>, a sphere of radius A against the plane through one explicit <pair> (friction,
solref, solreffriction, solimp), and every solver setting in <option>."""

SINK = {sink!r}
"""m: the hoop starts this far into the floor, where the contact holds its centre with zero
vertical acceleration (hoopbench found it with mj_forward and Brent's method on data.qacc of
the slide z joint): started exactly touching, MuJoCo's soft contact would give no force in the
first step and the hoop would sink in and ring."""


def start(mujoco):
    """MuJoCo's model, and its data at the initial state: rolling, SINK into the floor."""
    model = mujoco.MjModel.from_xml_string(MJCF)
    data = mujoco.MjData(model)
    x, y, theta, xdot, ydot, thetadot = CENTRE0
    data.qpos[:] = (x, y - A, theta)  # slide x, slide z (0 at the height A), hinge theta
    data.qvel[:] = (xdot, ydot, thetadot)
    data.qpos[1] -= SINK
    mujoco.mj_forward(model, data)
    return model, data
'''
"""The model part of an MJCF engine's standalone script (MuJoCo, MJX, MuJoCo Warp)."""

_SCRIPT = '''
import mujoco

{model}

def simulate():
    """Step the window with mj_step, reading the model's contact sensor (reduce="netforce":
    the summed contact force on the hoop, world frame) after each step: MuJoCo evaluates
    sensors before it integrates (RK4's first stage), so that is the force at the state the
    step started from. One step more gives the last state its force."""
    model, data = start(mujoco)
    qpos, qvel = np.empty((N_STEPS + 1, 3)), np.empty((N_STEPS + 1, 3))
    force = np.empty((N_STEPS + 1, 3))
    qpos[0], qvel[0] = data.qpos, data.qvel
    for i in range(N_STEPS + 1):
        mujoco.mj_step(model, data)
        force[i] = data.sensordata[1:4]  # after "found": the force x, y, z
        if i < N_STEPS:
            qpos[i + 1], qvel[i + 1] = data.qpos, data.qvel
    com = com_state(qpos[:, 0], A + qpos[:, 1], qpos[:, 2], *qvel.T)
    return {{**com, "normal_force": force[:, 2] / M, "friction_force": force[:, 0] / M}}
'''
"""MuJoCo's part of a standalone script (engines/standalone.py), as a MuJoCo user writes it:
a plain mj_step loop (the adapter's chunked rollout gives the same numbers, bit for bit)."""


def _narrowed(option: Option, check: Check) -> Any:
    """``option``'s search space without the choices ``check`` refuses (a tuple option's
    spaces, one per part, are no choice: as they are)."""
    space = option.space
    if not isinstance(space, Space) or space.scale is not Scale.CHOICE:
        return space
    return replace(space, choices=tuple(c for c in space.choices if _accepts(check, option, c)))


def _accepts(check: Check, option: Option, value: Any) -> bool:
    try:
        check(option.name, value)
    except ValueError:
        return False
    return True


@register
class MujocoEngine(MjcfEngine):
    """MuJoCo through ``mujoco.rollout``, and batches through ``mujoco.batch``."""

    name = "mujoco"
    distribution = "mujoco"
    modules = ("mujoco", "mujoco.rollout")  # and mujoco.batch for a batch (_open_batch)
    batches = True
    steps_worlds_apart = True  # _batch_advance rolls out the active worlds only
    last_force_in_chunk = True  # mujoco.batch steps any count in one rollout, nothing compiled
    geometries = MJCF_GEOMETRIES
    options = (
        Option(
            "solref",
            (0.0005, 1.0),
            _check_solref,
            "(timeconst s, dampratio); refsafe clamps timeconst to 2*timestep. Stiffer than "
            "MuJoCo's 0.02: slip onset within 2.4 ms on seed-mu (table in the module doc)",
            stock=(0.02, 1.0),
            space=(log_range(1e-4, 0.05), linear_range(0.2, 2.0)),
        ),
        Option(
            "solreffriction",
            (0.015, 1.0),
            _check_solreffriction,
            "friction rows of elliptic cones only. A sliding MuJoCo contact pushes the bodies "
            "apart; with one solref for all rows the hoop chattered 0.2 mm off the floor while "
            "slipping and the detectors saw false hops; this cuts the chatter tenfold",
            stock=(0.0, 0.0),
            space=(log_range(1e-4, 0.1), linear_range(0.2, 2.0)),
        ),
        Option(
            "solimp",
            (0.95, 0.99, 0.001, 0.5, 2.0),
            _check_solimp,
            "stiffer than MuJoCo's (0.9, 0.95): on tuned, hop-top lift-off -8.8 ms against "
            "-14.1 with MuJoCo's, seed-mu unchanged (+0.02 ms); on stock it moves hop-top's "
            "lift-off from +20.9 to -1.3 ms and halves seed-mu's rolling creep (2.1 -> 1.1 s) "
            "(contact-force reading, dt 1e-4)",
            stock=(0.9, 0.95, 0.001, 0.5, 2.0),
            space=(
                linear_range(0.8, 0.95),
                linear_range(0.95, 0.9999),
                log_range(1e-4, 1e-2),
                None,
                None,
            ),
        ),
        Option(
            "cone",
            "elliptic",
            choice(*CONES),
            "pyramidal cones reported false hops at every solref tried (0.3-2.3 mm) and, "
            "with solref 0.02 and impratio 1, slipped at 26 deg instead of 88.5",
            stock="pyramidal",
            space=one_of(*CONES),
        ),
        Option(
            "impratio",
            100.0,
            number(low=0.0, low_open=True),
            "friction 100x harder than normal: on tuned (elliptic) it keeps rolling creep "
            "below 0.01 mm/s (impratio 1: seed-mu slip -1.1 ms by slip velocity); it acts on "
            "pyramidal cones too: stock with 100 lifts off on hop-top at -9.9 ms instead of "
            "+20.9 (contact-force reading, dt 1e-4)",
            stock=1.0,
            space=log_range(1.0, 1000.0),
        ),
        Option(
            "noslip_iterations",
            0,
            integer(low=0),
            "tuned: no measurable effect (seed-mu, dt 1e-4: slip onset +0.02 ms by the contact "
            "force with 0 or 10); stock: 10 cuts the rolling creep from 2.1 s to 0.4 s (its "
            "slip-velocity onset -914 -> -297 ms) and leaves the Coulomb onset at +1.3-1.5 ms",
            space=int_range(0, 20),
        ),
        Option(
            "integrator",
            "RK4",
            choice(*INTEGRATORS),
            "RK4 costs ~4x per step, but the one-step integrators lost the hop-top and "
            "hop-low hops to contact chatter (hop-top height -1 % with RK4). A search "
            "(docs/tune.md) found implicit settings better at 7.5e-5 to 9e-5 s at a tenth "
            "of the cost; kept, because one (implicit, solref 5.4 ms, impratio 1.6) invents "
            "5 hops of 8 catalogue scenes at 1e-3 s, where tuned runs too",
            stock="Euler",
            space=one_of(*INTEGRATORS),
        ),
        Option(
            "tolerance",
            1e-10,
            number(low=0.0),
            "tighter than MuJoCo's 1e-8 so that convergence never limits a result; measured: "
            "1e-8 and 1e-10 give the same events on seed-mu and hop-top on both profiles",
            stock=1e-8,
            space=log_range(1e-12, 1e-6),
        ),
        Option(
            "iterations",
            100,
            integer(low=1),
            "enough for the tolerance above on this one-contact problem",
            space=int_range(10, 200, log=True),
        ),
        Option(
            "ring_segments",
            32,
            integer(low=3, high=MAX_RING_SEGMENTS),
            "capsules in the ring geometry: a polygon fine enough to roll, coarse enough to see",
            outside_search="used only by geometry ring; a search runs the sphere",
        ),
    )
    variants = (
        Variant("cone=pyramidal", options={"cone": "pyramidal"}),
        Variant("solref=0.02", options={"solref": (0.02, 1.0)}),
        Variant("noslip_iterations=10", options={"noslip_iterations": 10}),
        Variant("geometry=cylinder", geometry="cylinder"),
        Variant("geometry=ring", geometry="ring"),
    )

    @classmethod
    def options_except(cls, *dropped: str, **checks: Check) -> tuple[Option, ...]:
        """MuJoCo's options for a backend that reads the same MJCF (MJX, MuJoCo Warp): all
        but ``dropped``, with the checks in ``checks`` (name -> check) replacing MuJoCo's
        where the backend allows less, and a choice's search space narrowed to what the
        new check accepts; defaults, stock values and reasons stay MuJoCo's."""
        known = {option.name for option in cls.options}
        unknown = sorted((set(dropped) | set(checks)) - known)
        if unknown:
            raise ValueError(f"not MuJoCo options: {', '.join(unknown)}")
        return tuple(
            replace(option, check=check, space=_narrowed(option, check))
            for option in cls.options
            if option.name not in dropped
            for check in [checks.get(option.name, option.check)]
        )

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        return _SCRIPT.format(model=self._script_model(scene, settings, options))

    # ----------------------------------------------------------------- stepping hooks
    @contextmanager
    def _open(
        self,
        module: ModuleType,
        scene: Scene,
        settings: RunSettings,
        options: dict[str, Any],
        *,
        record: bool,
    ) -> Iterator[_Run]:
        mujoco = module
        model, data = self._build(mujoco, scene, settings, options)
        shape = contact_shape(scene, settings.geometry, options)
        run = _Run(mujoco, scene, settings.timestep, model, data, shape)
        if not record:
            yield run
            return
        if not has_contact_sensor(mujoco):  # before 3.3.5: stepped from Python (module doc)
            with _captured_warnings(mujoco) as run.warnings:
                run.allocate(n_steps_for(scene, settings.timestep))
                yield run
            return
        from mujoco import rollout

        with _captured_warnings(mujoco) as run.warnings, rollout.Rollout(nthread=0) as run.runner:
            run.allocate(n_steps_for(scene, settings.timestep))
            yield run

    def _advance(self, run: _Run, done: int, steps: int, last: bool) -> Chunk:
        """Roll out ``steps`` steps in C; the last chunk takes one more for the last force."""
        mujoco, scene = run.mujoco, run.scene
        extra = 1 if last else 0
        if run.runner is None:
            _step_reading_forces(run, done, steps + extra)
        else:
            self._roll_out(run, done, steps + extra)
        rows = slice(done, done + steps + 1)
        qpos_at = mujoco.mj_stateSize(run.model, mujoco.mjtState.mjSTATE_TIME.value)
        qvel_at = qpos_at + run.model.nq
        q = run.states[0, rows, qpos_at : qpos_at + 3]
        v = run.states[0, rows, qvel_at : qvel_at + 3]
        # The slide z joint is the hoop centre's height above its resting height.
        com = kinematics.com_state(scene, q[:, 0], scene.a + q[:, 1], q[:, 2], *v.T)
        for key, values in com.items():
            run.com[key][rows] = values
        return Chunk(com, done + steps)

    @staticmethod
    def _roll_out(run: _Run, done: int, steps: int) -> None:
        """``steps`` steps in C by ``mujoco.rollout``, the contact sensor read at each."""
        run.runner.rollout(
            [run.model],
            [run.data],
            run.states[:, done],
            initial_warmstart=run.warmstart,
            nstep=steps,
            state=run.states[:, done + 1 : done + 1 + steps],
            sensordata=run.sensors[:, done : done + steps],
            skip_checks=True,
        )
        run.warmstart[0] = run.data.qacc_warmstart

    def _diverged(self, run: _Run) -> str | None:
        return _warning_reason(run.mujoco, run.data, run.warnings)

    def _contact_shape(self, run: _Run) -> Polygon | None:
        return run.shape

    def _trajectory(self, run: _Run, done: int, ended_early: bool) -> Trajectory:
        # A run stopped early has no force for its last state: drop that state.
        n = done if ended_early else done + 1
        # Sensor layout: found, then the force (x, y, z) on the hoop in the world frame.
        fx = run.sensors[0, :n, 1] / run.scene.M
        fz = run.sensors[0, :n, 3] / run.scene.M
        return Trajectory.from_steps(
            run.scene,
            run.timestep,
            {key: val[:n] for key, val in run.com.items()},
            normal_force=fz,
            friction_force=fx,
            # The ring is a polygon: clearance and slip are read at its lowest point.
            shape=run.shape,
        )

    def _step_bare(self, run: _Run, steps: int) -> None:
        """``mj_step`` in C: no sensors read, nothing recorded."""
        run.mujoco.mj_step(run.model, run.data, nstep=steps)

    # ----------------------------------------------------------------- batch hooks
    @contextmanager
    def _open_batch(
        self,
        module: ModuleType,
        scenes: Sequence[Scene],
        settings: RunSettings,
        options: dict[str, Any],
    ) -> Iterator[_Batch]:
        """One model per world (its own mu, mass, ...), in one ``mujoco.batch.Batch``; each
        world's state row is its single run's initial state."""
        mujoco = module
        # Imported here, not with the modules of every run: mujoco.batch is MuJoCo 4's, and
        # the single runs go back to 2.3.7 (docs/engines.md, Releases).
        batching = importlib.import_module("mujoco.batch")
        built = [self._build(mujoco, scene, settings, options) for scene in scenes]
        models = [model for model, _ in built]
        batch = batching.Batch(models[0], len(scenes), BATCH_THREADS)
        batch.set_models(models)
        for field_name in ("qpos", "qvel", "qacc_warmstart", "time"):
            rows = batch.bind(field_name)
            for i, (_, data) in enumerate(built):
                rows[i] = getattr(data, field_name)
        shapes = [contact_shape(scene, settings.geometry, options) for scene in scenes]
        start = np.array([[data.qpos[k] for k in range(3)] for _, data in built])
        velocity = np.array([[data.qvel[k] for k in range(3)] for _, data in built])
        time = np.array([data.time for _, data in built])
        yield _Batch(mujoco, list(scenes), batch, shapes, start, velocity, time)

    def _batch_shapes(self, batch: _Batch) -> Sequence[Polygon | None]:
        return batch.shapes

    def _batch_advance(
        self, batch: _Batch, active: np.ndarray, steps: int
    ) -> tuple[np.ndarray, np.ndarray]:
        """A rollout of the active worlds in C: positions, velocities and the contact
        sensor after each step (the sensor row of a step: the force at its start state)."""
        every = bool(active.all())
        ids = batch.ids if every else np.flatnonzero(active)
        out = batch.batch.rollout(steps, record=batch.record, ids=ids)
        # Every stepped world at once: its last state, then the rollout's rows.
        com = np.empty((len(ids), steps + 1, len(STATE_KEYS)))
        com[:, 0] = batch.com if every else batch.com[ids]
        offset, a = (batch.offset, batch.a) if every else (batch.offset[ids], batch.a[ids])
        _com_rows(offset, a, out["qpos"], out["qvel"], com[:, 1:])
        # Sensor layout: found, then the force (x, y, z) on the hoop in the world frame.
        sensor = out["sensordata"][:, :, 3:0:-2]  # columns 3 and 1: a view
        time = out[batch.record[-1]][:, :, 0]
        # A world the batch stopped stepping repeats its time (np.diff's test, unrolled).
        start = batch.time if every else batch.time[ids]
        stuck = (time[:, 0] - start <= 0) | (time[:, 1:] - time[:, :-1] <= 0).any(axis=1)
        if every:
            batch.com[:], batch.time[:] = com[:, -1], time[:, -1]
            states, forces = com, sensor
        else:  # rows of the worlds not stepped are never read
            batch.com[ids], batch.time[ids] = com[:, -1], time[:, -1]
            states = np.full((len(active), steps + 1, len(STATE_KEYS)), np.nan)
            forces = np.full((len(active), steps, 2), np.nan)
            states[ids], forces[ids] = com, sensor
        if stuck.any():
            batch.halted[ids[stuck]] = True
        return states, forces

    def _batch_diverged(self, batch: _Batch, active: np.ndarray) -> list[str | None]:
        # mujoco.batch stops stepping a world whose warning counters rise; a single run steps
        # on (MuJoCo resets its state), so the world runs again alone.
        return [RUN_ALONE if halted else None for halted in batch.halted.tolist()]


def mjcf_text(
    scene: Scene,
    settings: RunSettings,
    options: dict[str, Any],
    mu: float,
    *,
    contact_sensor: bool = True,
) -> str:
    """The MJCF of a run (models/mjcf.py): this adapter's, and MJX's and MuJoCo Warp's,
    which read the same model (MJX without the contact sensor it refuses)."""
    return scene_to_mjcf(
        scene,
        mu=mu,
        timestep=settings.timestep,
        restitution=settings.restitution,
        geometry=settings.geometry,
        options=options,
        contact_sensor=contact_sensor,
    )


def model_at_start(
    mujoco: ModuleType, text: str, scene: Scene, geometry: str, options: dict[str, Any]
) -> tuple[Any, Any]:
    """MuJoCo C's model of an MJCF text and its data at the scene's initial state, at the
    equilibrium penetration (module doc): the start of this adapter's runs, and of MJX's
    and MuJoCo Warp's, which put these on their device."""
    model, data = _model_touching(mujoco, text, scene, geometry, options)
    data.qpos[1] -= _equilibrium_penetration(mujoco, model, data, scene.a)
    mujoco.mj_forward(model, data)
    return model, data


def start_sink(
    mujoco: ModuleType, text: str, scene: Scene, geometry: str, options: dict[str, Any]
) -> float:
    """The equilibrium penetration, m, that :func:`model_at_start` sinks the hoop by (module
    doc): the number a standalone script starts from (it has no root finder)."""
    model, data = _model_touching(mujoco, text, scene, geometry, options)
    return _equilibrium_penetration(mujoco, model, data, scene.a)


def _model_touching(
    mujoco: ModuleType, text: str, scene: Scene, geometry: str, options: dict[str, Any]
) -> tuple[Any, Any]:
    """MuJoCo C's model of an MJCF text and its data rolling, exactly touching the floor."""
    model = mujoco.MjModel.from_xml_string(text)
    data = mujoco.MjData(model)
    # The lowest point of the contact shape (the ring's vertex) on the floor, rolling.
    shape = contact_shape(scene, geometry, options)
    x, y, theta, xdot, ydot, thetadot = kinematics.rolling_start(scene, shape)
    data.qpos[:] = (x, y - scene.a, theta)
    data.qvel[:] = (xdot, ydot, thetadot)
    return model, data


@dataclass
class _Run:
    """One run's model and data at the initial state; when it records, its rollout, the
    warnings MuJoCo gave, and its buffers (``allocate``)."""

    mujoco: ModuleType
    scene: Scene
    timestep: float
    model: Any
    data: Any
    shape: Polygon | None
    """The contact shape (the ring's polygon; None: a circle)."""
    runner: Any = None
    warnings: list[str] = field(default_factory=list)
    states: np.ndarray = field(init=False)
    sensors: np.ndarray = field(init=False)
    warmstart: np.ndarray = field(init=False)
    com: dict[str, np.ndarray] = field(init=False)

    def allocate(self, n_steps: int) -> None:
        """Buffers for a window of ``n_steps`` and the extra step that gives t_end its force.
        Row i of ``states`` is the full physics state at t_i (row 0 is set here), row i of
        ``sensors`` the force at t_i (MuJoCo evaluates sensors before a step integrates), and
        ``com`` holds the centre-of-mass state per row."""
        mujoco, model, data = self.mujoco, self.model, self.data
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
        self.states = np.empty((1, n_steps + 2, mujoco.mj_stateSize(model, spec)))
        # found, then the force x, y, z: the contact sensor's, or _step_reading_forces's
        self.sensors = np.zeros((1, n_steps + 1, max(model.nsensordata, 4)))
        mujoco.mj_getState(model, data, self.states[0, 0], spec)
        self.warmstart = np.array(data.qacc_warmstart).reshape(1, model.nv)
        self.com = {
            k: np.empty(n_steps + 1) for k in ("X", "Y", "theta", "Xdot", "Ydot", "thetadot")
        }


@dataclass
class _Batch:
    """A batch's worlds: their scenes, the ``mujoco.batch.Batch`` stepping them, each
    world's initial joint positions and velocities (slide x, slide z, hinge) and its last
    recorded centre-of-mass state and time."""

    mujoco: ModuleType
    scenes: list[Scene]
    batch: Any
    shapes: list[Polygon | None]
    qpos: np.ndarray
    qvel: np.ndarray
    time: np.ndarray
    """s, each world's simulation time after its last step: a halted world's stands still."""
    halted: np.ndarray = field(init=False)
    offset: np.ndarray = field(init=False)
    """(W, 1), m: each scene's com_offset, broadcast over a world's rows."""
    a: np.ndarray = field(init=False)
    """(W, 1), m: each scene's hoop radius, as ``offset``."""

    ids: np.ndarray = field(init=False)
    """Every world's index, the ``ids`` of a rollout of them all."""
    record: list[Any] = field(init=False)
    """What a rollout records: positions, velocities, the contact sensor, the time."""
    com: np.ndarray = field(init=False)
    """(W, 6): each world's last centre-of-mass state (STATE_KEYS), a chunk's first row."""

    def __post_init__(self) -> None:
        self.halted = np.zeros(len(self.scenes), dtype=bool)
        self.offset = np.array([[scene.com_offset] for scene in self.scenes])
        self.a = np.array([[scene.a] for scene in self.scenes])
        self.ids = np.arange(len(self.scenes))
        self.record = ["qpos", "qvel", "sensordata", self.mujoco.mjtState.mjSTATE_TIME]
        self.com = np.empty((len(self.scenes), len(STATE_KEYS)))
        _com_rows(self.offset, self.a, self.qpos[:, None], self.qvel[:, None], self.com[:, None])


def _com_rows(
    offset: np.ndarray, a: np.ndarray, q: np.ndarray, v: np.ndarray, com: np.ndarray
) -> None:
    """kinematics.com_state of n worlds' joint rows at once (q, v: (n, rows, 3), slide x,
    slide z, hinge) into ``com`` (n, rows, 6), columns STATE_KEYS, by com_state's operations
    in its order, so that each row is the single run's bit for bit. ``offset``, ``a``:
    (n, 1), m. The slide z joint is the hoop centre's height above its resting height."""
    theta, thetadot = q[:, :, 2], v[:, :, 2]
    # r * sin and r * cos once each: com_state's r * c * thetadot is (r * c) * thetadot.
    rs, rc = offset * np.sin(theta), offset * np.cos(theta)
    np.add(q[:, :, 0], rs, out=com[:, :, 0])
    np.add(a + q[:, :, 1], rc, out=com[:, :, 1])
    com[:, :, 2] = theta
    np.add(v[:, :, 0], rc * thetadot, out=com[:, :, 3])
    np.subtract(v[:, :, 1], rs * thetadot, out=com[:, :, 4])
    com[:, :, 5] = thetadot


def has_contact_sensor(mujoco: ModuleType) -> bool:
    """Whether this MuJoCo release has the contact sensor: 3.3.5 on (measured on the
    releases' wheels: 3.3.4's MJCF schema refuses the element, 3.3.5 has mjSENS_CONTACT)."""
    return hasattr(mujoco.mjtSensor, "mjSENS_CONTACT")


def _step_reading_forces(run: _Run, done: int, steps: int) -> None:
    """``steps`` plain ``mj_step`` calls from Python, for a release without the contact
    sensor: before each, ``mj_forward`` at the recorded state gives the contact forces the
    step starts from (what the sensor reads: MuJoCo evaluates sensors in the step's first
    forward, which repeats this one with the same inputs), summed over the contacts and
    turned into the world frame. On 4.0.0 this equals the rollout with the sensor (states bit
    for bit, force to rounding: tests/test_releases.py)."""
    mujoco, model, data = run.mujoco, run.model, run.data
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
    hoop = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY.value, "hoop")
    local = np.zeros(6)
    for i in range(steps):
        mujoco.mj_forward(model, data)
        total = np.zeros(3)
        # The contacts' fields as arrays (data.contact.frame[c]): before 3.1.4 the struct of
        # one contact (data.contact[c].frame) reads zeros in the Python bindings (measured on
        # 2.3.7 and 3.1.3), and the force read through it was none.
        frames, geom2 = data.contact.frame, data.contact.geom2
        for c in range(data.ncon):
            mujoco.mj_contactForce(model, data, c, local)
            # The force geom1 exerts on geom2, in the contact frame (rows: normal, tangents).
            world = np.reshape(frames[c], (3, 3)).T @ local[:3]
            total += world if model.geom_bodyid[geom2[c]] == hoop else -world
        run.sensors[0, done + i, 0] = float(data.ncon > 0)
        run.sensors[0, done + i, 1:4] = total
        mujoco.mj_step(model, data)
        mujoco.mj_getState(model, data, run.states[0, done + 1 + i], spec)


@contextmanager
def _captured_warnings(mujoco: ModuleType) -> Iterator[list[str]]:
    """MuJoCo's warning texts, collected instead of printed and logged to MUJOCO_LOG.TXT.

    The handler is process-wide: the previous one is put back on exit.
    """
    messages: list[str] = []
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(messages.append)
    try:
        yield messages
    finally:
        mujoco.set_mju_user_warning(previous)


def _warning_reason(mujoco: ModuleType, data: Any, messages: list[str]) -> str | None:
    """MuJoCo resets the data instead of producing NaN; its warning counters tell."""
    for name in _BAD_STATE_WARNINGS:
        index = getattr(mujoco.mjtWarning, name).value
        if data.warning[index].number > 0:
            said = f": {messages[0]}" if messages else ""
            return f"MuJoCo {name}, the engine reset its state{said}"
    return None


def _equilibrium_penetration(mujoco: ModuleType, model: Any, data: Any, a: float) -> float:
    """Penetration, m, at which the contact holds the centre with zero vertical acceleration.

    0 if the hoop, exactly touching, would leave the floor (no contact force needed). The
    vertical acceleration of the centre is qacc of the slide z joint; it rises monotonically
    as the hoop sinks, so a doubling bracket and Brent's method find its zero. For the ring,
    whose rigid centre would swing down about its vertex at (a - rc) thetadot^2, the target
    is still zero: aiming at the swing gives no equilibrium (MuJoCo's contact at zero
    distance already holds the centre more than that) and a start no calmer (measured: the
    clearance rate of the first 2 ms stays within 0.35 g dt either way).
    """
    z0 = float(data.qpos[1])

    def zacc(depth: float) -> float:
        data.qpos[1] = z0 - depth
        mujoco.mj_forward(model, data)
        return float(data.qacc[1])

    try:
        return equilibrium_depth(zacc, a, first=1e-7, xtol=1e-15)
    finally:
        data.qpos[1] = z0
