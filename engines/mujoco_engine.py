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
tests/test_mujoco.py).

Soft contact start. MuJoCo's contacts are springs with an equilibrium penetration (8e-8 m
in the seed scene with the defaults, 1.3e-6 m at solref 0.002). A hoop started exactly
touching gets no force in its first step, sinks in and rings for a few timeconsts (seed
scene: normal force 0, then up to 16 % above the rolling value). The adapter instead
starts the hoop at the penetration where the contact holds the centre with zero vertical
acceleration (found with ``mj_forward``): the first recorded normal force is the exact
rolling one and the recorded clearance at t = 0 is that small negative number. A scene that
leaves the floor at once (lam*chi > 1) starts touching.

Defaults (engines/settings.py), measured on mujoco 4.0.0 at timestep 1e-4. Slip onset of
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
engines.md) under any integrator; elliptic cones slip within 8 ms with impratio 1 too.
What the defaults fix is not the onset but the slipping phase: a sliding MuJoCo contact
pushes the bodies apart (the convex model initiates slip through normal motion), and with
one solref for all rows the hoop chattered off the floor while slipping, 0.1 mm per m/s of
slip at solref 0.002 (a sliding sphere measured alone), so every hop scene showed a false
lift-off hundreds of ms early and the seed "hopped" at 1.43 s. A softer reference for the
friction rows (solreffriction 0.015) cuts the chatter tenfold; impratio 100 keeps rolling
creep below 0.01 mm/s; the one-step integrators (Euler, implicitfast, discrete) still lost
hop-top and hop-low to the chatter, RK4 did not (hop-top height -1 %, impact -0.8 ms).
The sensor is read at the first RK4 stage: the force at the recorded state.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import (
    Engine,
    Simulation,
    check_divergence,
    import_engine,
    n_steps_for,
)
from hoopbench.engines.settings import RunSettings
from hoopbench.models import kinematics
from hoopbench.models.mjcf import check_mujoco_options, check_restitution, scene_to_mjcf
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

__all__ = ["CHUNK_STEPS", "MujocoEngine"]

CHUNK_STEPS = 1000
"""Steps per rollout call; divergence is checked after each chunk."""

_BAD_STATE_WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC")


class MujocoEngine(Engine):
    """MuJoCo through ``mujoco.rollout``; options are ENGINE_OPTIONS['mujoco']."""

    name = "mujoco"

    # ----------------------------------------------------------------- hooks
    def _import(self) -> ModuleType:
        return import_engine("mujoco", "mujoco.rollout")

    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        """Bad option values and restitution != 0 raise ValueError before a run."""
        check_mujoco_options(options)
        check_restitution(settings.restitution)

    # ----------------------------------------------------------------- model
    def mjcf(self, scene: Scene, settings: RunSettings | None = None) -> str:
        """The MJCF document a run of this scene with these settings uses."""
        settings = settings or RunSettings()
        return scene_to_mjcf(
            scene,
            mu=self.mu_for(scene, settings),
            timestep=settings.timestep,
            restitution=settings.restitution,
            geometry=settings.geometry,
            options=settings.resolve(self.name),
        )

    def _build(self, mujoco: ModuleType, scene: Scene, settings: RunSettings) -> tuple[Any, Any]:
        """Model and data at the initial state (equilibrium penetration, see module doc)."""
        model = mujoco.MjModel.from_xml_string(self.mjcf(scene, settings))
        data = mujoco.MjData(model)
        X, Y, theta, Xdot, Ydot, thetadot = scene.initial_state()
        x, y = kinematics.centre_position(scene, X, Y, theta)
        xdot, ydot = kinematics.centre_velocity(scene, Xdot, Ydot, theta, thetadot)
        data.qpos[:] = (float(x), float(y) - scene.a, theta)
        data.qvel[:] = (float(xdot), float(ydot), thetadot)
        data.qpos[1] -= _equilibrium_penetration(mujoco, model, data, scene.a)
        mujoco.mj_forward(model, data)
        return model, data

    # ----------------------------------------------------------------- stepping
    def _simulate(
        self, module: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> Simulation:
        mujoco = module
        from mujoco import rollout

        model, data = self._build(mujoco, scene, settings)
        dt = settings.timestep
        n_steps = n_steps_for(scene, dt)
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS.value
        nstate = mujoco.mj_stateSize(model, spec)
        nsens = model.nsensordata
        qpos_at = mujoco.mj_stateSize(model, mujoco.mjtState.mjSTATE_TIME.value)
        qvel_at = qpos_at + model.nq

        # Row i of ``states`` is the state at t_i; row i of ``sensors`` is the force at t_i.
        # One extra step gives the force at t_end.
        states = np.empty((1, n_steps + 2, nstate))
        sensors = np.empty((1, n_steps + 1, nsens))
        mujoco.mj_getState(model, data, states[0, 0], spec)
        warmstart = np.array(data.qacc_warmstart).reshape(1, model.nv)
        out = {k: np.empty(n_steps + 1) for k in ("X", "Y", "theta", "Xdot", "Ydot", "thetadot")}
        r, a = scene.com_offset, scene.a
        diverged: str | None = None
        done = 0  # states 0..done are recorded

        start = time.perf_counter()
        with _captured_warnings(mujoco) as warnings, rollout.Rollout(nthread=0) as runner:
            while done < n_steps:
                k = min(CHUNK_STEPS, n_steps - done)
                extra = 1 if done + k == n_steps else 0  # the step that gives the last force
                runner.rollout(
                    [model],
                    [data],
                    states[:, done],
                    initial_warmstart=warmstart,
                    nstep=k + extra,
                    state=states[:, done + 1 : done + 1 + k + extra],
                    sensordata=sensors[:, done : done + k + extra],
                    skip_checks=True,
                )
                warmstart[0] = data.qacc_warmstart
                rows = slice(done, done + k + 1)
                q = states[0, rows, qpos_at : qpos_at + 3]
                v = states[0, rows, qvel_at : qvel_at + 3]
                s, c = np.sin(q[:, 2]), np.cos(q[:, 2])
                out["X"][rows] = q[:, 0] + r * s
                out["Y"][rows] = a + q[:, 1] + r * c
                out["theta"][rows] = q[:, 2]
                out["Xdot"][rows] = v[:, 0] + r * c * v[:, 2]
                out["Ydot"][rows] = v[:, 1] - r * s * v[:, 2]
                out["thetadot"][rows] = v[:, 2]
                diverged = _warning_reason(mujoco, data, warnings) or check_divergence(
                    scene, {key: val[rows] for key, val in out.items()}, self.limits
                )
                done += k
                if diverged:
                    break
        wall = time.perf_counter() - start

        # A run stopped early has no force for its last state: drop that state.
        n = done + 1 if not diverged else done
        # Sensor layout: found, then the force (x, y, z) on the hoop in the world frame.
        fx = sensors[0, :n, 1] / scene.M
        fz = sensors[0, :n, 3] / scene.M
        trajectory = Trajectory.from_state(
            scene,
            t=np.arange(n) * dt,
            **{key: val[:n] for key, val in out.items()},
            normal_force=fz,
            friction_force=fx,
        )
        return Simulation(trajectory=trajectory, n_steps=n - 1, wall_time_s=wall, diverged=diverged)

    # ----------------------------------------------------------------- benchmark
    def bare_loop_time(self, scene: Scene, settings: RunSettings | None = None) -> float:
        """Wall time, s, of ``mj_step`` called in C for the same model and number of steps.

        No recording, no sensors read, no divergence checks: the engine's own cost, to set
        against a run's ``wall_time_s``.
        """
        settings = settings or RunSettings()
        check_mujoco_options(settings.resolve(self.name))
        mujoco = self._import()
        model, data = self._build(mujoco, scene, settings)
        n_steps = n_steps_for(scene, settings.timestep)
        start = time.perf_counter()
        mujoco.mj_step(model, data, nstep=n_steps)
        return time.perf_counter() - start


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
    as the hoop sinks, so a doubling bracket and Brent's method find its zero.
    """
    z0 = float(data.qpos[1])

    def zacc(depth: float) -> float:
        data.qpos[1] = z0 - depth
        mujoco.mj_forward(model, data)
        return float(data.qacc[1])

    try:
        if zacc(0.0) >= 0.0:
            return 0.0
        lo, hi = 0.0, 1e-7 * a
        while zacc(hi) < 0.0:
            lo, hi = hi, 2.0 * hi
            if hi > 1e-2 * a:
                return 0.0  # no equilibrium near the surface: start touching
        from scipy.optimize import brentq

        return float(brentq(zacc, lo, hi, xtol=1e-15, rtol=1e-12, maxiter=100))
    finally:
        data.qpos[1] = z0
