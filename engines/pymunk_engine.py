"""pymunk (Chipmunk2D) adapter: the hoop as one dynamic body on a static floor segment.

The model is :mod:`hoopbench.models.pymunk_space`. Each step is recorded with one C call into
pymunk's batch iterator (hoop-centre position, angle, centre-of-mass velocity, angular velocity
appended to a growing buffer), which keeps the adapter's overhead small next to
``Space.step``; the buffer is decoded once per chunk of steps.

Contact forces come from each step's momentum balance rather than from arbiter queries. With
no damping and no applied force Chipmunk updates the velocity as ``v1 = (v0 + gravity*dt) +
J/M``, J the step's total contact impulse, so ``(v1 - (v0 + gravity*dt)) / dt`` evaluated with
the same floating-point operations is J/(M dt): exactly zero when no contact acted, and
``Arbiter.total_impulse / (M dt)`` otherwise (tests/test_pymunk.py compares both through
``Body.each_arbiter``), except on a re-contact after a short separation, where total_impulse
also counts the warm-starting impulse Chipmunk kept but did not apply. The force of step i is
recorded at t_i, the configuration Chipmunk computed it at; row 0 repeats step 1's force.

Known behaviour of the engine (measured, see the report of tests/test_pymunk.py):

* Contacts exist only while the shapes overlap. Symplectic Euler moves the hoop centre by
  about lam*a*cos(theta)*(thetadot*dt)**2/2 per step, upward while the weight is in the upper
  half, so a rolling hoop loses its contact for single steps (about 6 % of the steps of the
  seed scene's first 0.5 s). Each lost step lets the rim slip by about
  lam*a*sin(theta)*thetadot**2*dt.
* The sequential-impulse solver returns zero impulse for a slipping contact when
  mu*lam*|sin theta|*(1 + lam*cos theta) > k + lam**2*sin(theta)**2 (the friction impulse
  changes the normal velocity more than the normal impulse does), and the hoop then sinks
  into the floor.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import Chunk, Engine, call_repeatedly
from hoopbench.engines.options import (
    Option,
    Variant,
    int_range,
    integer,
    log_range,
    number,
    optional,
)
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.models import kinematics
from hoopbench.models.pymunk_space import PymunkSpec, build_space, scene_to_pymunk
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

__all__ = ["PymunkEngine"]

_N_FIELDS = 6
"""Floats per body per step in the batch buffer: x, y, angle, vx, vy, angular velocity."""


def _body_recorder(module: ModuleType, space: Any, buffer: Any) -> Callable[[], None]:
    """A zero-argument callable that appends every body's state to ``buffer``.

    The fast path prepares once the call that ``pymunk.batch.get_space_bodies`` makes on each
    invocation (it allocates its argument block every time, which costs about half a step
    here). If pymunk's internals change, the public function is used instead.
    """
    batch = module.batch
    fields = (
        batch.BodyFields.BODY_ID
        | batch.BodyFields.POSITION
        | batch.BodyFields.ANGLE
        | batch.BodyFields.VELOCITY
        | batch.BodyFields.ANGULAR_VELOCITY
    )
    try:
        from pymunk._chipmunk_cffi import ffi, lib

        data = ffi.new("pmBatchedData *")
        data.fields = fields.value
        data.floatArray = buffer._float_arr
        data.intArray = buffer._int_arr
        iterator = ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched")
        each_body = lib.cpSpaceEachBody
        handle = space._space
    except (ImportError, AttributeError):
        return lambda: batch.get_space_bodies(space, fields, buffer)

    def record() -> None:
        each_body(handle, iterator, data)  # the closure keeps ``data`` alive

    return record


@register
class PymunkEngine(Engine):
    """pymunk 7 with the scene's mass, moment and centre of gravity; SI units."""

    name = "pymunk"
    distribution = "pymunk"
    modules = ("pymunk", "pymunk.batch")
    model_format = "pymunk bodies and shapes (JSON)"
    options = (
        Option(
            "iterations",
            50,
            integer(low=1),
            "pymunk's 10 leaves the slipping contact unconverged; 50 as PyBullet's solver",
            stock=10,
            space=int_range(5, 200, log=True),
        ),
        Option(
            "collision_slop",
            1e-5,
            number(low=0.0, unit="m"),
            "pymunk's default 0.1 (game pixels) is a tenth of the hoop radius here",
            stock=0.1,
            space=log_range(1e-7, 0.1),
        ),
        Option(
            "collision_bias",
            1e-40,
            optional(number(low=0.0, high=1.0, high_open=True)),
            "fraction of overlap left after 1 s (None: pymunk's 0.9**60, made for 60 Hz games, "
            "which let the rolling hop-bottom scene sink 0.2 mm and lift off 12 ms late); "
            "1e-40 removes overlap with an 11 ms time constant",
            stock=None,
            space=log_range(1e-60, 0.5, or_none=True),
        ),
    )
    variants = (Variant("iterations=10", options={"iterations": 10}),)

    def _model_text(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        return self.spec(scene, settings).to_json(indent=2)

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        spec = self.spec(scene, settings)
        bias = options["collision_bias"]
        bias_line = (
            "# collision_bias: pymunk's own (0.9**60)"
            if bias is None
            else f"space.collision_bias = {float(bias)!r}  # overlap left after 1 s"
        )
        return _SCRIPT.format(
            spec=spec,
            iterations=int(options["iterations"]),
            slop=float(options["collision_slop"]),
            bias_line=bias_line,
        )

    # ----------------------------------------------------------------- model
    def spec(self, scene: Scene, settings: RunSettings | None = None) -> PymunkSpec:
        """The pymunk model of the scene for these settings (plain numbers, inspectable)."""
        settings = settings or RunSettings()
        return scene_to_pymunk(
            scene, mu=self.mu_for(scene, settings), restitution=settings.restitution
        )

    def build(self, scene: Scene, settings: RunSettings | None = None) -> tuple[Any, Any, Any]:
        """(space, body, hoop_shape) as a run builds them. ValueError for a bad option."""
        settings = settings or RunSettings()
        return self._build(scene, settings, self.check(scene, settings))

    def _build(
        self, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> tuple[Any, Any, Any]:
        return build_space(
            self.spec(scene, settings),
            iterations=int(options["iterations"]),
            collision_slop=options["collision_slop"],
            collision_bias=options["collision_bias"],
        )

    # ----------------------------------------------------------------- stepping hooks
    def _open(
        self,
        module: ModuleType,
        scene: Scene,
        settings: RunSettings,
        options: dict[str, Any],
        *,
        record: bool,
    ) -> AbstractContextManager[_Run]:
        space, body, _hoop = self._build(scene, settings, options)
        buffer = module.batch.Buffer()
        p, v = body.position, body.velocity
        run = _Run(
            scene=scene,
            timestep=settings.timestep,
            space=space,
            body_id=body.id,
            buffer=buffer,
            record=_body_recorder(module, space, buffer),
            rows=[np.array([[p.x, p.y, body.angle, v.x, v.y, body.angular_velocity]])],
        )
        return nullcontext(run)

    def _advance(self, run: _Run, done: int, steps: int, last: bool) -> Chunk:
        """Step and record each step into the batch buffer; decode the chunk once."""
        step, record, dt = run.space.step, run.record, run.timestep
        for _ in range(steps):
            step(dt)
            record()
        ids = np.frombuffer(run.buffer.int_buf(), dtype=np.uintp)
        floats = np.frombuffer(run.buffer.float_buf(), dtype=float).reshape(-1, _N_FIELDS)
        chunk = floats[ids == run.body_id]  # boolean indexing copies out of the buffer
        run.buffer.clear()
        run.rows.append(chunk)
        return Chunk(_our_state(run.scene, chunk), done + steps)

    def _trajectory(self, run: _Run, done: int, ended_early: bool) -> Trajectory:
        """Every recorded row, with the finite-difference force of the module doc."""
        raw = np.vstack(run.rows)
        dt, gy = run.timestep, float(run.space.gravity.y)
        vx, vy = raw[:, 3], raw[:, 4]
        f = np.empty(len(raw))
        n = np.empty(len(raw))
        # The same operations as Chipmunk's velocity update: no contact gives exactly 0.
        f[1:] = (vx[1:] - (vx[:-1] + 0.0 * dt)) / dt
        n[1:] = (vy[1:] - (vy[:-1] + gy * dt)) / dt
        f[0], n[0] = f[1], n[1]
        state = _our_state(run.scene, raw)
        return Trajectory.from_steps(run.scene, dt, state, normal_force=n, friction_force=f)

    def _step_bare(self, run: _Run, steps: int) -> None:
        call_repeatedly(run.space.step, steps, run.timestep)


_SCRIPT = '''
import pymunk


def build():
    """The space: one dynamic body (the scene's mass and moment, its centre of gravity lam a
    from the hoop centre, toward the weight), a massless circle, a static floor segment whose
    top surface is y = 0. pymunk's angles are counter-clockwise: the body angle is -theta."""
    space = pymunk.Space()
    space.gravity = {spec.gravity!r}
    space.damping = 1.0  # no damping
    space.iterations = {iterations!r}
    space.collision_slop = {slop!r}  # m: pymunk's 0.1 is made for pixels
    {bias_line}
    body = pymunk.Body({spec.mass!r}, {spec.moment!r})
    # Order matters: the angle setter turns the body about its centre of gravity, and the
    # position setter places the body origin (the hoop centre) through that transform.
    body.center_of_gravity = {spec.center_of_gravity!r}
    body.angle = {spec.angle!r}
    body.position = {spec.position!r}  # {spec.start_overlap!r} m into the floor: in contact
    body.velocity = {spec.velocity!r}  # of the centre of gravity
    body.angular_velocity = {spec.angular_velocity!r}
    hoop = pymunk.Circle(body, {spec.hoop_radius!r})  # no mass: the body keeps its own
    hoop.friction = {spec.hoop_friction!r}  # pymunk multiplies the two shapes' values
    hoop.elasticity = {spec.hoop_elasticity!r}
    floor_a, floor_b = {spec.floor_a!r}, {spec.floor_b!r}  # its axis, m
    floor = pymunk.Segment(space.static_body, floor_a, floor_b, {spec.floor_radius!r})
    floor.friction = {spec.floor_friction!r}
    floor.elasticity = {spec.floor_elasticity!r}
    space.add(body, hoop, floor)
    return space, body


def simulate():
    """Step the window; the contact force of each step from its momentum balance (with no
    damping pymunk sets v1 = v0 + g dt + J / M, so this is J / (M dt), exactly 0 without a
    contact), given to the row the step starts from; row 0 repeats step 1's force."""
    space, body = build()
    rows = [(*body.position, body.angle, *body.velocity, body.angular_velocity)]
    for _ in range(N_STEPS):
        space.step(DT)
        rows.append((*body.position, body.angle, *body.velocity, body.angular_velocity))
    raw = np.array(rows)
    vx, vy, gy = raw[:, 3], raw[:, 4], float(space.gravity.y)
    friction, normal = np.empty(len(raw)), np.empty(len(raw))
    friction[1:] = (vx[1:] - (vx[:-1] + 0.0 * DT)) / DT
    normal[1:] = (vy[1:] - (vy[:-1] + gy * DT)) / DT
    friction[0], normal[0] = friction[1], normal[1]
    state = com_state_ccw(*raw.T)
    return {{**state, "normal_force": normal, "friction_force": friction}}
'''
"""pymunk's part of a standalone script (engines/standalone.py), as a pymunk user writes it."""


@dataclass
class _Run:
    """One run's space and what it recorded."""

    scene: Scene
    timestep: float
    space: Any
    body_id: int
    buffer: Any
    """pymunk.batch.Buffer that ``record`` appends every body's state to."""
    record: Callable[[], None]
    rows: list[np.ndarray]
    """Recorded rows (x, y, angle, vx, vy, angular velocity): the initial one, then a block
    per chunk."""


def _our_state(scene: Scene, raw: np.ndarray) -> dict[str, np.ndarray]:
    """pymunk rows (hoop-centre position, ccw angle, COM velocity) -> our COM state.

    pymunk's velocity is already the centre of gravity's; its angle is counter-clockwise, so
    theta = -angle.
    """
    return kinematics.com_state_ccw(scene, *raw[:, :6].T)
