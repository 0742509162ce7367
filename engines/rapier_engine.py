"""Rapier adapter: the hoop as a 3D rigid body moving in the x-y plane, a ball on a half space.

Rapier (the Rust engine, through its Python binding ``rapier3d``, 3D, single precision) reads no
model file from Python: the world is built by calls, here. Frames: Rapier's (x, y) is
hoopbench's (x, y), gravity is (0, -g, 0), and the body turns about +z, counter-clockwise, so
its angle is -theta and its angular velocity -thetadot. The body's origin is the hoop centre;
``RigidBody.linvel`` is the centre of mass's velocity, as hoopbench's Xdot, Ydot.

The body. Mass M, centre of mass (0, lam a, 0) in the body frame (at the weight's side) and
principal inertia I_com about it, all from the scene (``RigidBodyBuilder
.additional_mass_properties``); the ball collider has density 0, so nothing comes from the
geometry (``test_rapier.py`` reads them back). Rotations about x and y are locked.
Translation along z is left free, not locked: in rapier3d 0.36.1 a body with a translation
lock together with a rotation lock about an axis in the plane of motion gets no friction at
all (a sliding ball keeps its speed; measured for every such pair and plane, and pinned by
``test_rapier.py::test_locking_z_with_x_rotation_stops_friction``). Nothing pushes along z:
the contact normal and the friction lie in the plane, and the body's z stays within
2.4e-7 m, f32 round-off
(measured; tested).

Contact. A ball of radius ``a`` on a half space gives one contact point, straight below the
centre, with Rapier's analytic ball-plane distance: the hoop's circle in the plane. (A
cylinder lying on its side touches along a segment and would give two points.) Friction: each
collider carries mu, so every combine rule but Multiply gives the pair mu; the rules are set
to Max on both, explicitly (Rapier's default is Average, and a pair uses the higher-ranked of
its two colliders' rules). Restitution 0 on both, the same way.

Forces. The contact force is each step's momentum balance, as for Box2D and pymunk: the only
forces on the hoop are gravity and the contact's, and Rapier adds gravity to a free body's
velocity once per substep as ``v += (g M) (1/M) h`` in float32 (``h = dt / substeps``; the
velocity solver's ``solver_vel_incr``), so the free velocity is replayed with the same float32
operations (``free_flight_residual``) and the contact impulse per unit mass is ``v1 - v_free``:
exactly zero where no contact acted, and read as zero within one float32 spacing of it (a
contact point with no impulse still rounds vy by that much). Measured against the solver's own
record (the contact points' normal impulse summed over the substeps, ``ContactData.impulse``,
and with the Coulomb model the friction impulse ``tangent_impulse``) on every catalogue scene,
both profiles: equal to the f32 rounding of the velocities, at most 2.1e-3 g apart at dt 1e-4
and 2.1e-4 g at 1e-3 (``test_rapier.py``; docs/engines.md says what that moves). The balance
costs nothing per step (walking the contact points through the binding was a third of a run's
stepping) and gives the friction under either friction model (Rapier's default Simplified
exposes no friction impulse). Row i holds the state at t_i and the impulse of the step from it,
divided by dt (as PyBullet and Drake); one extra step gives the last row its force.

Start. Rapier's contact is rigid at the velocity level (the relax pass of each substep) and
soft only in its position correction (the biased pass, ``static_contact_softness``), which
is also where positions move: there is no spring with a one-step equilibrium depth to start
at (tried: a root of one step's centre acceleration changed nothing). The hoop starts exactly
touching, ``contact_skin`` 0; contacts are made within the prediction distance, so the first
step has its contact force (the rolling one, exactly). It then sinks at up to 3 g dt over
the first 2 ms and rolls 0.1-0.4 mm deep: strict expected failures in ``test_placement.py``.

Precision. Positions, velocities and impulses are 32-bit floats: 1.2e-7 relative, so at
x = 5 m a position is known to 5e-7 m, a velocity of 2 m/s to 2.4e-7 m/s, and one step's
displacement at dt 1e-4 (1e-4 m) is rounded by up to 2e-3 of itself. The recorded states are
widened to float64 as read.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import Chunk, Engine, call_repeatedly
from hoopbench.engines.options import (
    Option,
    Variant,
    choice,
    flag,
    int_range,
    integer,
    log_range,
    one_of,
    real_tuple,
)
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.models import kinematics
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

__all__ = ["FRICTION_MODELS", "RapierEngine", "free_flight_residual"]

FRICTION_MODELS: tuple[str, ...] = ("coulomb", "simplified")
"""Rapier's FrictionModel values (IntegrationParameters.friction_model)."""

_ROW = 7
"""Recorded per step: x, y, quaternion z, w, vx, vy, omega_z (body)."""

_VX, _VY = 4, 5
"""The recorded velocity's columns."""


def _check_softness(name: str, value: Any) -> tuple[float, float]:
    """(natural frequency Hz, damping ratio), both > 0: Rapier's SpringCoefficients."""
    pair = real_tuple((2,), "a pair (natural_frequency Hz, damping_ratio)")(name, value)
    if not all(v > 0 for v in pair):
        raise ValueError(
            f"{name} must be (natural_frequency Hz, damping_ratio), both > 0; got {value!r}"
        )
    return pair


@register
class RapierEngine(Engine):
    """Rapier (rapier3d, f32): a planar-locked 3D body, substepped soft-contact solver."""

    name = "rapier"
    distribution = "rapier3d"
    modules = ("rapier3d",)
    model_note = "the world is built by calls (RigidBodyBuilder, ColliderBuilder), not read"
    options = (
        Option(
            "num_solver_iterations",
            4,
            integer(low=1),
            "Rapier's 4: the solver's substeps per step, each with its own position update",
            space=int_range(1, 64, log=True),
        ),
        Option(
            "num_internal_pgs_iterations",
            1,
            integer(low=1),
            "Rapier's 1: Gauss-Seidel sweeps per substep (one contact: one sweep is exact)",
            space=int_range(1, 16, log=True),
        ),
        Option(
            "num_internal_stabilization_iterations",
            1,
            integer(low=0),
            "Rapier's 1: relax (unbiased) sweeps per substep, which remove the position "
            "correction's velocity",
            space=int_range(0, 8),
        ),
        Option(
            "static_contact_softness",
            (200.0, 1.0),
            _check_softness,
            "(natural_frequency Hz, damping_ratio) of contacts with a fixed body: the position "
            "correction (the relax pass keeps the contact rigid). Rapier's (60, 10) let the "
            "hoop sink 1 mm and seed-mu's slip velocity creep (slip -43 ms by it, dt 1e-4); "
            "(200, 1): -1.5 ms, 0.4 mm; stiffer (1000, 1) made the slip flicker (-282 ms)",
            stock=(60.0, 10.0),
            space=(log_range(10.0, 5000.0), log_range(0.1, 50.0)),
        ),
        Option(
            "friction_model",
            "coulomb",
            choice(*FRICTION_MODELS),
            "one contact point: both models solve one friction constraint at it; coulomb also "
            "exposes the friction impulse (test_rapier.py checks the momentum balance with it)",
            stock="simplified",
            space=one_of(*FRICTION_MODELS),
        ),
        Option(
            "contact_recycling",
            0,
            flag(),
            "Rapier's 1 keeps a pair's contact points while the pose moved less than 0.05 m: a "
            "rolling hoop's contact point then stays behind on the rim",
            stock=1,
            space=one_of(0, 1),
        ),
        Option(
            "friction_in_bias_pass",
            0,
            flag(),
            "Rapier's 0: friction acts in the relax pass only",
            space=one_of(0, 1),
        ),
    )
    variants = (
        Variant("num_solver_iterations=8", options={"num_solver_iterations": 8}),
        Variant("static_contact_softness=60,10", options={"static_contact_softness": (60.0, 10.0)}),
    )

    # ----------------------------------------------------------------- model
    def _world(
        self, rp: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> tuple[Any, Any, Any, Any]:
        """(world, body handle, hoop collider handle, floor collider handle) at the scene's
        initial state, every parameter set."""
        world = rp.PhysicsWorld(gravity=(0.0, -scene.g, 0.0))
        _set_parameters(rp, world.integration_parameters, settings.timestep, options)
        mu, rule = self.mu_for(scene, settings), rp.CoefficientCombineRule.MAX
        x, y, theta, _, _, thetadot = kinematics.rolling_start(scene)
        _, _, _, Xdot, Ydot, _ = scene.initial_state()
        # The scene's mass properties, never the collider's (density 0).
        inertia = scene.inertia_com
        mass = rp.MassProperties(
            local_com=(0.0, scene.com_offset, 0.0),
            mass=scene.M,
            principal_inertia=(inertia, inertia, inertia),
        )
        locks = rp.LockedAxes.ROTATION_LOCKED_X | rp.LockedAxes.ROTATION_LOCKED_Y
        builder = (
            rp.RigidBody.dynamic()
            .translation((x, y, 0.0))
            .rotation((0.0, 0.0, -theta))
            .linvel((Xdot, Ydot, 0.0))
            .angvel((0.0, 0.0, -thetadot))
            .locked_axes(locks)
            .additional_mass_properties(mass)
            .can_sleep(False)
        )
        ball = _material(rp.Collider.ball(scene.a).density(0.0), mu, settings.restitution, rule)
        body = world.add_body(builder, [ball])
        floor = world.add_collider(
            _material(rp.Collider.halfspace((0.0, 1.0, 0.0)), mu, settings.restitution, rule)
        )
        hoop = world.rigid_bodies[body].colliders[0]
        return world, body, hoop, floor

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        frequency, damping = options["static_contact_softness"]
        return _SCRIPT.format(
            substeps=int(options["num_solver_iterations"]),
            pgs=int(options["num_internal_pgs_iterations"]),
            relax=int(options["num_internal_stabilization_iterations"]),
            frequency=float(frequency),
            damping=float(damping),
            friction_model=str(options["friction_model"]).upper(),
            recycling=bool(options["contact_recycling"]),
            bias_friction=bool(options["friction_in_bias_pass"]),
        )

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
        world, body, _, _ = self._world(module, scene, settings, options)
        run = _Run(
            scene,
            settings.timestep,
            int(options["num_solver_iterations"]),
            world,
            world.rigid_bodies[body],
        )
        run.theta_end = scene.theta0
        if record:
            x, y, theta, _, _, thetadot = kinematics.rolling_start(scene)
            _, _, _, Xdot, Ydot, _ = scene.initial_state()
            run.first = np.array(
                [x, y, math.sin(-theta / 2), math.cos(-theta / 2), Xdot, Ydot, -thetadot]
            )
        yield run

    def _advance(self, run: _Run, done: int, steps: int, last: bool) -> Chunk:
        """Step, reading the body after each step (the force comes from its velocities)."""
        step, body = run.world.step, run.body
        buf = array("d")
        record = buf.extend
        for _ in range(steps):
            step()
            p, q, v, w = body.translation, body.rotation, body.linvel, body.angvel
            record((p.x, p.y, q.k, q.w, v.x, v.y, w.z))
        block = np.frombuffer(buf).reshape(-1, _ROW)
        run.blocks.append(block)
        state = _com_state(run.scene, block, run.theta_end)
        run.theta_end = float(state["theta"][-1])
        return Chunk(state, done + steps)

    def _diverged(self, run: _Run) -> str | None:
        # Rapier neutralizes a body whose state became non-finite: reset, zeroed, disabled.
        return None if run.body.is_enabled else "rapier quarantined the body (non-finite state)"

    def _finish(self, run: _Run, ended_early: bool) -> None:
        """One more step, not recorded as a state: its velocity gives the last row its force."""
        run.world.step()
        v = run.body.linvel
        run.last = (v.x, v.y)

    def _trajectory(self, run: _Run, done: int, ended_early: bool) -> Trajectory:
        """The recorded rows, with the momentum-balance force of the module doc: row i gets
        the impulse of the step from state i."""
        states = np.concatenate([np.atleast_2d(run.first), *run.blocks])
        state = _com_state(run.scene, states, run.scene.theta0)
        velocity = np.vstack([states[:, [_VX, _VY]], run.last])
        dv_x, dv_y = free_flight_residual(
            velocity, run.timestep, run.substeps, run.scene.g, run.scene.M
        )
        return Trajectory.from_steps(
            run.scene,
            run.timestep,
            state,
            normal_force=dv_y / run.timestep,
            friction_force=dv_x / run.timestep,
        )

    def _step_bare(self, run: _Run, steps: int) -> None:
        call_repeatedly(run.world.step, steps)


_SCRIPT = '''
import math

import rapier3d as rp

SUBSTEPS = {substeps!r}  # the solver's substeps per step


def integration_parameters(world, dt):
    """The world's IntegrationParameters, set in place."""
    params = world.integration_parameters
    params.dt = dt
    params.num_solver_iterations = SUBSTEPS
    params.num_internal_pgs_iterations = {pgs!r}  # Gauss-Seidel sweeps per substep
    params.num_internal_stabilization_iterations = {relax!r}  # relax sweeps per substep
    # (natural frequency Hz, damping ratio) of the position correction against a fixed body
    params.static_contact_softness = rp.SpringCoefficients({frequency!r}, {damping!r})
    params.friction_model = rp.FrictionModel.{friction_model}
    params.contact_recycling = {recycling!r}  # keep contact points while the pose barely moves
    params.friction_in_bias_pass = {bias_friction!r}


def material(builder, mu, restitution):
    """Friction and restitution, combined by Max: both colliders carry the pair's value."""
    return (
        builder.friction(mu)
        .restitution(restitution)
        .friction_combine_rule(rp.CoefficientCombineRule.MAX)
        .restitution_combine_rule(rp.CoefficientCombineRule.MAX)
    )


def build():
    """The world: the hoop as a dynamic body whose origin is the hoop centre, turning about +z
    (counter-clockwise: its angle is -theta), rotations about x and y locked, the scene's mass,
    centre of mass and inertia given explicitly (the ball collider has density 0); a ball of
    radius A on the half space y > 0. The hoop starts exactly touching."""
    world = rp.PhysicsWorld(gravity=(0.0, -G, 0.0))
    integration_parameters(world, DT)
    x, y, theta, _, _, thetadot = CENTRE0
    _, _, _, Xdot, Ydot, _ = COM0
    mass = rp.MassProperties(
        local_com=(0.0, COM_OFFSET, 0.0), mass=M, principal_inertia=(I_COM, I_COM, I_COM)
    )
    builder = (
        rp.RigidBody.dynamic()
        .translation((x, y, 0.0))
        .rotation((0.0, 0.0, -theta))
        .linvel((Xdot, Ydot, 0.0))  # the centre of mass's velocity
        .angvel((0.0, 0.0, -thetadot))
        # z translation stays free: locking it beside a rotation lock removes all friction
        # in rapier3d 0.36.1; nothing pushes along z
        .locked_axes(rp.LockedAxes.ROTATION_LOCKED_X | rp.LockedAxes.ROTATION_LOCKED_Y)
        .additional_mass_properties(mass)
        .can_sleep(False)
    )
    ball = material(rp.Collider.ball(A).density(0.0), MU, RESTITUTION)
    body = world.add_body(builder, [ball])
    floor = world.add_collider(material(rp.Collider.halfspace((0.0, 1.0, 0.0)), MU, RESTITUTION))
    return world, body, world.rigid_bodies[body].colliders[0], floor


def free_flight_residual(velocity):
    """Per step, the velocity change that is not free flight: the recorded velocity minus
    the one Rapier reaches without a contact, replayed with its float32 operations (per
    substep h = DT / SUBSTEPS, v = v + (g M) (1/M) h, the velocity solver's gravity
    increment). Exactly 0 where no contact acted, and 0 where vy is within one float32
    spacing of the free flight (a contact point with no impulse still rounds vy by it)."""
    f32 = np.float32
    v = velocity.astype(f32)
    h = f32(f32(DT) / f32(SUBSTEPS))
    dv = f32(f32(f32(-G) * f32(M)) * f32(f32(1.0) / f32(M))) * h
    free_y = v[:-1, 1].copy()
    for _ in range(SUBSTEPS):
        free_y = (free_y + dv).astype(f32)
    res_x = v[1:, 0].astype(float) - v[:-1, 0].astype(float)  # gravity has no x part
    res_y = v[1:, 1].astype(float) - free_y.astype(float)
    spacing = np.maximum(np.spacing(np.abs(v[1:, 1])), np.spacing(np.abs(free_y)))
    acted = np.abs(res_y) > spacing
    return np.where(acted, res_x, 0.0), np.where(acted, res_y, 0.0)


def simulate():
    """Step the window, reading the body (f32, widened) after each step, and one step more;
    the contact force of each step from its momentum balance (the only other force on the
    hoop is gravity), given to the row the step starts from."""
    world, handle, _, _ = build()
    body = world.rigid_bodies[handle]
    x, y, theta, _, _, thetadot = CENTRE0
    _, _, _, Xdot, Ydot, _ = COM0
    # x, y, quaternion (k, w), vx, vy, omega_z
    states = [[x, y, math.sin(-theta / 2), math.cos(-theta / 2), Xdot, Ydot, -thetadot]]
    for _ in range(N_STEPS):
        world.step()
        p, q, v, w = body.translation, body.rotation, body.linvel, body.angvel
        states.append([p.x, p.y, q.k, q.w, v.x, v.y, w.z])
    world.step()
    states = np.array(states)
    velocity = np.vstack([states[:, 4:6], [[body.linvel.x, body.linvel.y]]])
    friction, normal = free_flight_residual(velocity)
    angle = 2.0 * np.arctan2(states[:, 2], states[:, 3])  # counter-clockwise, about +z
    theta = np.unwrap(np.concatenate([[THETA0], -angle]))[1:]
    return {{
        "X": states[:, 0] + COM_OFFSET * np.sin(theta),
        "Y": states[:, 1] + COM_OFFSET * np.cos(theta),
        "theta": theta,
        "Xdot": states[:, 4],
        "Ydot": states[:, 5],
        "thetadot": -states[:, 6],
        "normal_force": normal / DT,
        "friction_force": friction / DT,
    }}
'''
"""Rapier's part of a standalone script (engines/standalone.py), as a rapier3d user writes it."""


@dataclass
class _Run:
    """One run's world and handles, and what it recorded."""

    scene: Scene
    timestep: float
    substeps: int
    """The solver's substeps per step (num_solver_iterations)."""
    world: Any
    body: Any
    """The hoop's RigidBody: a live view into the world."""
    first: np.ndarray = field(default_factory=lambda: np.empty(_ROW))
    """The initial state in the recorded columns (the scene's, in float64)."""
    blocks: list[np.ndarray] = field(default_factory=list)
    last: tuple[float, float] = (0.0, 0.0)
    """vx, vy (m/s) after the step from the last state: that step's force."""
    theta_end: float = 0.0
    """theta at the last recorded row, rad: the next chunk's angle unwraps from it."""


def _com_state(scene: Scene, rows: np.ndarray, theta_before: float) -> dict[str, np.ndarray]:
    """Centre-of-mass state from recorded rows, the angle unwrapped from ``theta_before``
    (the previous row's, rad): a quaternion gives the angle modulo 2 pi."""
    angle = 2.0 * np.arctan2(rows[:, 2], rows[:, 3])  # counter-clockwise, about +z
    theta = np.unwrap(np.concatenate([[theta_before], -angle]))[1:]
    X, Y = kinematics.com_position(scene, rows[:, 0], rows[:, 1], theta)
    return {
        "X": X,
        "Y": Y,
        "theta": theta,
        "Xdot": rows[:, 4],
        "Ydot": rows[:, 5],
        "thetadot": -rows[:, 6],
    }


def _material(builder: Any, mu: float, restitution: float, rule: Any) -> Any:
    return (
        builder.friction(mu)
        .restitution(restitution)
        .friction_combine_rule(rule)
        .restitution_combine_rule(rule)
    )


def _set_parameters(rp: ModuleType, params: Any, dt: float, options: dict[str, Any]) -> None:
    """Set the world's IntegrationParameters (modified in place) from the run's options."""
    params.dt = dt
    params.num_solver_iterations = int(options["num_solver_iterations"])
    params.num_internal_pgs_iterations = int(options["num_internal_pgs_iterations"])
    params.num_internal_stabilization_iterations = int(
        options["num_internal_stabilization_iterations"]
    )
    frequency, damping = options["static_contact_softness"]
    params.static_contact_softness = rp.SpringCoefficients(frequency, damping)
    params.friction_model = getattr(rp.FrictionModel, options["friction_model"].upper())
    params.contact_recycling = bool(options["contact_recycling"])
    params.friction_in_bias_pass = bool(options["friction_in_bias_pass"])


def free_flight_residual(
    velocity: np.ndarray, timestep: float, substeps: int, g: float, mass: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per step, the centre-of-mass velocity change (m/s, x and y) that is not free flight:
    ``velocity`` (rows of the recorded vx, vy) after each step minus the velocity Rapier
    would reach from the row before without a contact, replayed with its float32 operations
    (per substep ``v = v + (g M) (1/M) h``, ``h = dt / substeps``: the velocity solver's
    gravity increment). Exactly 0 where no contact acted, and 0 (both parts) where vy is
    within one float32 spacing of the free flight: a step whose contact point got no impulse
    still rounds vy by that spacing, either way, and less than it is no impulse the f32
    velocity resolves."""
    f32 = np.float32
    v = velocity.astype(f32)
    h = f32(f32(timestep) / f32(substeps))
    inverse_mass = f32(f32(1.0) / f32(mass))
    dv = f32(f32(f32(-g) * f32(mass)) * inverse_mass) * h
    free_y = v[:-1, 1].copy()
    for _ in range(substeps):
        free_y = (free_y + dv).astype(f32)
    # gravity has no x part: v + 0 is v exactly
    res_x = v[1:, 0].astype(float) - v[:-1, 0].astype(float)
    res_y = v[1:, 1].astype(float) - free_y.astype(float)
    spacing = np.maximum(np.spacing(np.abs(v[1:, 1])), np.spacing(np.abs(free_y)))
    acted = np.abs(res_y) > spacing
    return np.where(acted, res_x, 0.0), np.where(acted, res_y, 0.0)
