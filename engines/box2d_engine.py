"""Box2D v3 adapter (pyb2d3): the hoop as one dynamic body with a circle on a static floor box.

The model is :mod:`hoopbench.models.box2d_world` (mass data from the scene, friction
sqrt(mu * mu) = mu). Box2D v3 solves contacts with its "soft step": each step is split into
``subStepCount`` substeps; in each, gravity is integrated, the contact impulses are warm
started and solved with a soft constraint (stiffness ``contactHertz``, twice that for a
static pair, and ``contactDampingRatio``) that pushes an overlap out, the positions are
integrated, and a rigid "relax" pass removes the normal velocity the soft solve left. A
contact point exists within the speculative distance (4 linear slops, 2 cm) and acts only if
the hoop would close the gap within a substep. Everything is single precision.

Contact force. pyb2d3 0.11 exposes no contact manifold of a running world: it binds neither
``b2Body_GetContactData`` nor ``b2Shape_GetContactData`` (``Body.GetContactData`` is in its
C++ wrapper but not exported, and the library is linked without exported symbols), and its
contact events carry a manifold only when a touch begins. The force is therefore the step's
momentum balance, as for pymunk: without a contact Box2D updates a velocity once per substep
as ``v = h*g + v`` in float32 (``b2IntegrateVelocitiesTask`` with no damping and no force),
so the free velocity is replayed with the same float32 operations and the contact impulse
per unit mass is ``v1 - v_free``: exactly zero when no contact acted. Even a manifold would
not give the step's impulse: its stored impulse is the last substep's. Box2D collides at the
start of a step, so a step's contact is that of the state it starts from: row i gets the
impulse of the step from state i, [t_i, t_i + dt], divided by dt (PyBullet's and Drake's
convention; measured against the force law at the engine's own state, the best shift is
0), and one extra step gives the last row its force.

Placement. Box2D's contact is soft only below zero separation (a speculative point, s > 0,
is a rigid constraint), so an overlap sinks to where the soft push balances the weight. The
hoop starts exactly touching: the depth the soft contact settles to (g / omega^2 at rest,
omega = 2 pi 2 contactHertz: 69 um at Box2D's 30 Hz) is more than the start check allows.
"""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import Chunk, Engine, call_repeatedly
from hoopbench.engines.options import (
    Option,
    Variant,
    flag,
    int_range,
    integer,
    log_range,
    number,
    one_of,
)
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.models import kinematics
from hoopbench.models.box2d_world import (
    Box2DSpec,
    WorldTuning,
    build_world,
    check_restitution,
    scene_to_box2d,
)
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

__all__ = ["Box2DEngine", "free_flight_residual"]

_N_FIELDS = 6
"""Floats recorded per step: x, y, angle, vx, vy, angular velocity."""


@register
class Box2DEngine(Engine):
    """Box2D v3.1 through pyb2d3, with the scene's mass data; SI units, single precision."""

    name = "box2d"
    distribution = "pyb2d3"
    modules = ("pyb2d3",)
    model_note = (
        "the world is built by calls (models/box2d_world.py: a body with mass data and a "
        "circle), not read"
    )
    options = (
        Option(
            "subStepCount",
            4,
            integer(low=1),
            "b2World_Step's substeps, Box2D's recommended 4. Measured at dt 1e-4: 8 moves "
            "seed-mu's slip by the contact force from +0.2 to +0.02 ms and hop-top's lift-off "
            "from +11 to +2 ms, with the same 0.77x hop, at 1.4x the cost; the variant shows it",
            space=int_range(1, 16, log=True),
        ),
        Option(
            "contactHertz",
            240.0,
            number(low=0.0, low_open=True, unit="Hz"),
            "contact stiffness (a static pair gets twice it; Box2D caps it at an eighth of the "
            "substep rate). Box2D's 30 Hz lets the hoop sink g/omega^2 = 69 um at rest and "
            "1.2 mm on high-spin, and on hop-top slips 9 ms early by the contact force with "
            "wrong phases; 240 Hz: 1.1 um at rest, 0.25 mm on high-spin, hop-top's phases "
            "right. 1000 Hz changes no hop by more than 1 %",
            stock=30.0,
            space=log_range(10.0, 2000.0),
        ),
        Option(
            "contactDampingRatio",
            10.0,
            number(low=0.0),
            "Box2D's 10: the push-out is overdamped and never bounces the hoop",
            space=log_range(0.1, 100.0),
        ),
        Option(
            "maxContactPushSpeed",
            3.0,
            number(low=0.0, low_open=True, unit="m/s"),
            "Box2D's 3 m/s cap on the push-out; the hoop's overlaps are micrometres",
            space=log_range(0.1, 100.0),
        ),
        Option(
            "enableSleep",
            0,
            flag(),
            "Box2D's 1 may freeze a body slower than 5 cm/s for 0.5 s: a measurement must "
            "not stop because the hoop is slow",
            stock=1,
            space=one_of(0, 1),
        ),
    )
    variants = (
        Variant("subStepCount=8", options={"subStepCount": 8}),
        Variant("contactHertz=30", options={"contactHertz": 30.0}),
    )

    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        check_restitution(settings.restitution)

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        return _SCRIPT.format(
            spec=self.spec(scene, settings),
            substeps=int(options["subStepCount"]),
            hertz=float(options["contactHertz"]),
            damping_ratio=float(options["contactDampingRatio"]),
            push_speed=float(options["maxContactPushSpeed"]),
            sleep=bool(options["enableSleep"]),
            floor_centre_y=-self.spec(scene, settings).floor_half_height,
        )

    # ----------------------------------------------------------------- model
    def spec(self, scene: Scene, settings: RunSettings | None = None) -> Box2DSpec:
        """The Box2D model of the scene for these settings (plain numbers, inspectable)."""
        settings = settings or RunSettings()
        return scene_to_box2d(scene, mu=self.mu_for(scene, settings))

    def build(self, scene: Scene, settings: RunSettings | None = None) -> tuple[Any, Any]:
        """(world, hoop body) as a run builds them. ValueError for a bad option."""
        settings = settings or RunSettings()
        return self._build(scene, settings, self.check(scene, settings))

    def _build(
        self, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> tuple[Any, Any]:
        tuning = WorldTuning(
            contact_hertz=options["contactHertz"],
            contact_damping_ratio=options["contactDampingRatio"],
            max_contact_push_speed=options["maxContactPushSpeed"],
            enable_sleep=bool(options["enableSleep"]),
        )
        return build_world(self.spec(scene, settings), tuning)

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
        world, body = self._build(scene, settings, options)
        run = _Run(
            scene=scene,
            timestep=settings.timestep,
            substeps=int(options["subStepCount"]),
            gravity_y=float(world.gravity[1]),
            world=world,
            body=body,
            values=list(_read(body)),
        )
        run.last_angle = run.values[2]
        return nullcontext(run)

    def _advance(self, run: _Run, done: int, steps: int, last: bool) -> Chunk:
        step, body, dt, n = run.world.step, run.body, run.timestep, run.substeps
        extend = run.values.extend
        # The getters, inline: unpacking a Vec2 iterates it until IndexError (12 us a row,
        # against 0.8 us for the six getters); a flat list of floats converts to an array
        # ten times faster than a list of tuples.
        for _ in range(steps):
            step(dt, n)
            p, v = body.position, body.linear_velocity
            extend((p.x, p.y, body.angle, v.x, v.y, body.angular_velocity))
        # the row before the chunk continues its unwrapped angle
        raw = np.array(run.values[-_N_FIELDS * (steps + 1) :]).reshape(-1, _N_FIELDS)
        angle = np.unwrap(raw[:, 2])
        angle += run.last_angle - angle[0]
        run.last_angle = float(angle[-1])
        return Chunk(_our_state(run.scene, raw[1:], angle[1:]), done + steps)

    def _finish(self, run: _Run, ended_early: bool) -> None:
        """One more step: its impulse is the last recorded row's force."""
        run.world.step(run.timestep, run.substeps)
        run.values.extend(_read(run.body))

    def _trajectory(self, run: _Run, done: int, ended_early: bool) -> Trajectory:
        """The recorded rows but _finish's, with the momentum-balance force of the module
        doc: row i gets the impulse of the step from state i."""
        raw = np.array(run.values).reshape(-1, _N_FIELDS)
        dt = run.timestep
        impulse_x, impulse_y = free_flight_residual(raw[:, 3:5], dt, run.substeps, run.gravity_y)
        f, n = impulse_x / dt, impulse_y / dt
        raw = raw[:-1]
        state = _our_state(run.scene, raw, np.unwrap(raw[:, 2]))
        return Trajectory.from_steps(run.scene, dt, state, normal_force=n, friction_force=f)

    def _step_bare(self, run: _Run, steps: int) -> None:
        call_repeatedly(run.world.step, steps, run.timestep, run.substeps)


def free_flight_residual(
    velocity: np.ndarray, timestep: float, substeps: int, gravity_y: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per step, the centre-of-mass velocity change (m/s, x and y) that is not free flight:
    ``velocity`` (rows of the recorded vx, vy) after each step minus the velocity Box2D
    would reach from the row before without a contact, replayed with its float32 operations
    (``h = dt / substeps``; per substep ``v = h*g + 1*v``). Exactly 0 where no contact acted.
    """
    v = velocity.astype(np.float32)
    h = np.float32(np.float32(timestep) / np.float32(substeps))
    dv = np.float32(h * np.float32(gravity_y))
    free_y = v[:-1, 1].copy()
    for _ in range(substeps):
        free_y = (dv + free_y).astype(np.float32)
    # gravity has no x part: h*0 + v is v exactly
    res_x = v[1:, 0].astype(float) - v[:-1, 0].astype(float)
    res_y = v[1:, 1].astype(float) - free_y.astype(float)
    return res_x, res_y


_SCRIPT = '''
import pyb2d3


def build():
    """The world: one dynamic body (its origin the hoop centre; the scene's mass, its centre
    of mass lam a from the hoop centre toward the weight, the rotational inertia about that
    centre), a circle with no density, and a static floor box whose top face is y = 0.
    Box2D's angles are counter-clockwise: the body rotation is -theta."""
    world = pyb2d3.World(
        gravity={spec.gravity!r},
        contact_hertz={hertz!r},  # Hz, soft contact stiffness (a static pair gets twice it)
        contact_damping_ratio={damping_ratio!r},
    )
    # contactHertz, contactDampingRatio, maxContactPushSpeed (m/s)
    world.set_contact_tuning({hertz!r}, {damping_ratio!r}, {push_speed!r})
    world.sleeping_enabled = {sleep!r}
    floor = world.create_static_body(position=(0.0, 0.0))
    floor.create_polygon_shape(
        # Box2D combines friction as sqrt(friction_a * friction_b): both carry MU
        pyb2d3.shape_def(material=pyb2d3.surface_material(friction={spec.floor_friction!r})),
        # half width, half height, m: the top face at y = 0
        pyb2d3.box(
            {spec.floor_half_width!r}, {spec.floor_half_height!r},
            center=(0.0, {floor_centre_y!r}), rotation=0.0,
        ),
    )
    body = world.create_dynamic_body(position={spec.position!r}, rotation={spec.angle!r})
    hoop_material = pyb2d3.surface_material(friction={spec.hoop_friction!r})
    body.create_circle_shape(
        # no density: the mass data below are the whole body's
        pyb2d3.shape_def(density=0.0, material=hoop_material),
        pyb2d3.circle(radius={spec.hoop_radius!r}),
    )
    # After the shape: creating a shape recomputes the body's mass from the shapes.
    mass = pyb2d3.MassData()
    mass.mass = {spec.mass!r}  # kg
    mass.center = {spec.center!r}  # m, in body coordinates
    mass.rotational_inertia = {spec.rotational_inertia!r}  # kg m^2, about the centre of mass
    body.mass_data = mass
    body.linear_velocity = {spec.linear_velocity!r}  # of the centre of mass, m/s
    body.angular_velocity = {spec.angular_velocity!r}  # rad/s, counter-clockwise
    return world, body


def read(body):
    p, v = body.position, body.linear_velocity
    return (p.x, p.y, body.angle, v.x, v.y, body.angular_velocity)


SUBSTEPS = {substeps!r}  # b2World_Step's subStepCount


def free_flight_residual(velocity, gravity_y):
    """Per step, the velocity change that is not free flight: the recorded velocity minus
    the one Box2D reaches without a contact, replayed with its float32 operations (per
    substep h = DT / SUBSTEPS, v = h*g + v). Exactly 0 where no contact acted."""
    v = velocity.astype(np.float32)
    h = np.float32(np.float32(DT) / np.float32(SUBSTEPS))
    dv = np.float32(h * np.float32(gravity_y))
    free_y = v[:-1, 1].copy()
    for _ in range(SUBSTEPS):
        free_y = (dv + free_y).astype(np.float32)
    res_x = v[1:, 0].astype(float) - v[:-1, 0].astype(float)  # gravity has no x part
    res_y = v[1:, 1].astype(float) - free_y.astype(float)
    return res_x, res_y


def simulate():
    """Step the window and one step more; the contact force of each step from its momentum
    balance (pyb2d3 binds no contact data of a running world), given to the row the step
    starts from, where Box2D collided."""
    world, body = build()
    values = list(read(body))
    for _ in range(N_STEPS + 1):
        world.step(DT, SUBSTEPS)
        values.extend(read(body))
    raw = np.array(values).reshape(-1, 6)
    impulse_x, impulse_y = free_flight_residual(raw[:, 3:5], float(world.gravity[1]))
    friction, normal = impulse_x / DT, impulse_y / DT
    raw = raw[:-1]
    # Box2D keeps the rotation in (-pi, pi]: unwrap it into a turn count
    state = com_state_ccw(raw[:, 0], raw[:, 1], np.unwrap(raw[:, 2]), *raw[:, 3:6].T)
    return {{**state, "normal_force": normal, "friction_force": friction}}
'''
"""Box2D's part of a standalone script (engines/standalone.py), as a pyb2d3 user writes it."""


@dataclass
class _Run:
    """One run's world and what it recorded."""

    scene: Scene
    timestep: float
    substeps: int
    gravity_y: float
    """The world's gravity as Box2D stores it (float32), m/s^2."""
    world: Any
    body: Any
    values: list[float]
    """Recorded rows (x, y, angle, vx, vy, angular velocity), flat, the initial one first."""
    last_angle: float = 0.0
    """The last recorded row's angle, unwrapped, rad (counter-clockwise)."""


def _read(body: Any) -> tuple[float, ...]:
    """(x, y, angle, vx, vy, angular velocity) of the body now."""
    p, v = body.position, body.linear_velocity
    return (p.x, p.y, body.angle, v.x, v.y, body.angular_velocity)


def _our_state(scene: Scene, raw: np.ndarray, angle: np.ndarray) -> dict[str, np.ndarray]:
    """Box2D rows (hoop-centre position, ccw angle, COM velocity) -> our COM state, with
    ``angle`` the rows' angle unwrapped: Box2D keeps a rotation, in (-pi, pi], not a turn
    count."""
    return kinematics.com_state_ccw(scene, raw[:, 0], raw[:, 1], angle, *raw[:, 3:6].T)
