"""DART adapter: the hoop as a skeleton on one PlanarJoint, a boxed-LCP contact on a static floor.

Model. The hoop is the URDF of :func:`hoopbench.models.urdf.scene_to_planar_urdf` (a URDF
``planar`` joint, axis +y), read by ``dartpy.utils.DartLoader``: it becomes a ``PlanarJoint``
in the x-z plane whose positions are (hoop-centre height z, hoop-centre x, theta), with the
link turning about +y, so the angle is theta itself. The link's inertia is the URDF's
``<inertial>`` (mass M, centre of mass lam*a toward the weight, I = M a^2 k), read back in the
tests. The floor is a skeleton of its own, built here (a URDF holds one tree): one body welded
to the world with a box whose top face is z = 0, made immobile (``Skeleton.setMobile(False)``).

Contact shape: a sphere of radius a. Seen in the plane its section is the hoop's circle, and
sphere-box is a primitive pair for all four of DART's collision detectors (FCL, DART, Bullet,
ODE): each reports one contact straight below the centre, and on seed-mu with PGS all four
give the same slip onset to 1e-6 deg. A cylinder (a disc with its axis along y) would need
FCL's or ODE's cylinder-box pair and adds nothing a sphere lacks in the plane.

Contact values. DART combines the two shapes' friction coefficients as their minimum
(``DefaultContactSurfaceHandler::createParams`` in 6.20) and their restitution coefficients as
the product: both shapes get mu, the hoop gets e and the floor 1. A pair friction below 1e-3
(DART_FRICTION_COEFF_THRESHOLD) switches friction off altogether, so 0 < mu <= 1e-3 is
refused. With the Dantzig and PGS solvers friction is a pyramid of two boxed rows (primary
and secondary directions, both at mu from ``DynamicsAspect.setFrictionCoeff``; for the
floor's +z normal along x and y); the NSGS and FBF friction solvers (hoopbench's NSGS) put
it on the Coulomb cone. Either way the friction along x is bounded by exactly mu n
(measured: |f|/n = 0.8000 while slipping on seed-mu). The boxed rows are why PGS let the
hoop sink on hop-top's slip back (26 mm, zero contact force): NSGS with its boxed law sinks
the same, with the cone it does not (docs/engines.md, DART).

What DART does not expose to Python: ``ContactConstraint``'s error reduction parameter (0.01),
its maximum error reduction velocity (1e-3 m/s), its constraint force mixing (1e-5) and its
error allowance (0 m) are static C++ values with no binding in dartpy 6.20, so they are no
options here.

Forces. ``World.step`` detects collisions at the state it starts from, solves the LCP for the
impulses that step and only then moves the positions (semi-implicit Euler). The hoop's
``Skeleton.getConstraintForces()`` then holds the step's constraint impulse over dt as
generalized forces of the planar joint (z, x, theta parts), one call a step: the contact is the
hoop's only constraint. DART keeps that impulse in the body's frame and maps it through the
joint's Jacobian at the pose after the step, so its z, x parts are the world force turned by
the step's rotation: turned back (``_world_force``) they are the contact force (the theta part,
the contact's torque about the centre, needs no turn). Measured at dt 1e-4 on every catalogue
scene, both profiles: equal to the generalized momentum balance M(q) (qdot1 - qdot0) / dt +
C(q, qdot) + g of each step within 5e-11 N. Until issue 34 the adapter summed each contact's
``force`` from ``World.getLastCollisionResult()`` (a walk through the binding, over half a
run's stepping), taking the hoop's as the one that points up; that sign rule fails where the
normal force is 0 or below (-0.0, or a pull of the constraint force mixing) while friction
acts, which the stock Dantzig solver gives (docs/engines.md, DART). Row i of the trajectory
holds the state at t_i and the force of the step from state i, as PyBullet's and Drake's; one
extra step gives the last row its force.

Placement. DART's contact is rigid (velocity level, no allowed penetration: error allowance
0), and a sphere touching the box is a contact at depth 0, but on a tilted start the computed
distance is +1e-16 m and the first step has no contact. The hoop starts START_DEPTH a deep
(1e-9 a), rolling, and gets the rolling force from its first step.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import Chunk, Engine, call_repeatedly, states_and_step_forces
from hoopbench.engines.options import (
    Option,
    Variant,
    choice,
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
from hoopbench.models.checks import check_real
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.models.urdf import FLOOR_HALF_SIZE, PLANAR_JOINT_NAME, scene_to_planar_urdf

__all__ = ["COLLISION_DETECTORS", "LCP_SOLVERS", "MIN_PAIR_FRICTION", "START_DEPTH", "DartEngine"]

LCP_SOLVERS: tuple[str, ...] = ("dantzig", "pgs", "nsgs", "fbf")
"""DART's boxed-LCP solvers (``BoxedLcpConstraintSolver.setBoxedLcpSolver``): Dantzig's
pivoting and projected Gauss-Seidel (the two a World makes), and the friction-cone solvers
``NsgsFrictionSolver`` (non-smooth Gauss-Seidel) and ``FbfFrictionSolver`` (forward-backward
splitting), constructed here."""

_FRICTION_SOLVER_CLASSES = {"nsgs": "NsgsFrictionSolver", "fbf": "FbfFrictionSolver"}

COLLISION_DETECTORS: tuple[str, ...] = ("fcl", "dart", "bullet", "ode")
"""DART's collision detectors (``World.setCollisionDetector``); FCL is DART's default."""

MIN_PAIR_FRICTION = 1e-3
"""DART_FRICTION_COEFF_THRESHOLD: a pair friction at or below this is no friction at all."""

START_DEPTH = 1e-9
"""Depth, in units of a, the hoop starts below the floor: on a tilted start the sphere placed
exactly touching is 1e-16 m apart, gets no contact in its first step and falls at -0.83 g dt
(tests/test_placement.py). DART's rigid contact pushes such a depth out at ERP 0.01 per step,
1e-7 m/s at dt 1e-4."""

_FLOOR_THICKNESS = 1.0
"""m; the floor box's top face is the plane z = 0."""

_DETECTOR_CLASSES = {
    "fcl": "FCLCollisionDetector",
    "dart": "DARTCollisionDetector",
    "bullet": "BulletCollisionDetector",
    "ode": "OdeCollisionDetector",
}


@register
class DartEngine(Engine):
    """DART (dartpy): Featherstone skeletons, contacts as a boxed LCP solved each step."""

    name = "dart"
    distribution = "dartpy"
    modules = ("dartpy",)
    model_format = "URDF (one planar joint; read by dartpy.utils.DartLoader)"
    options = (
        Option(
            "boxed_lcp_solver",
            "nsgs",
            choice(*LCP_SOLVERS),
            "NSGS (NsgsFrictionSolver, Coulomb cone), dt 1e-4, against the exact solution: "
            "hop-top hops -18.2 % (FBF -18.1 %) with the slip onset 0.2 ms late, hop-low "
            "-85.4 % (FBF -83.7 %; NSGS -44 % at dt 5e-5), hop-bottom -0.0 %, seed-mu and "
            "slip-reversal slip within 0.1 ms, lowest point -3.5e-9 m before the lift-off "
            "(-7.6e-5 m at the landing). PGS first sinks the hoop 26 mm (hop-top) and 63 mm "
            "(hop-low) on the back slip with the contact at zero force and hops +43.9 % / "
            "+507 %; Dantzig (DART's default) slips "
            "at 0.287 s instead of 0.442 s and hops -49.6 % on hop-top and not at all on "
            "hop-low. FBF matches NSGS at 3-6x its cost; NSGS costs about what PGS does",
            stock="dantzig",
            space=one_of(*LCP_SOLVERS),
        ),
        Option(
            "collision_detector",
            "ode",
            choice(*COLLISION_DETECTORS),
            "sphere-box is a primitive pair for all four, one contact below the centre; FCL, "
            "Bullet and ODE give seed-mu's slip to 1e-5 deg, DART's own detector 0.0001 deg "
            "apart (PGS); with NSGS FCL and ODE give the same events on hop-top, hop-low, "
            "seed-mu, hop-bottom, slip-reversal and painleve; ODE is the cheapest per step "
            "of the three (FCL is DART's default)",
            stock="fcl",
            space=one_of(*COLLISION_DETECTORS),
        ),
        Option(
            "lcp_fallback",
            1,
            flag(),
            "1: a second solver for the steps the first fails on (DART's default: Dantzig, "
            "then PGS; with PGS, NSGS or FBF first, Dantzig after it). PGS alone fails on "
            "single steps (no convergence in its iterations) and DART then zeroes the step's "
            "impulses; NSGS's runs are bit for bit the same with and without it (hop-top, "
            "hop-low, seed-mu, hop-bottom, slip-reversal, painleve at dt 1e-4)",
            space=one_of(0, 1),
        ),
        Option(
            "pgs_max_iteration",
            30,
            integer(low=1),
            "PgsBoxedLcpSolverOption.mMaxIteration, DART's 30 (PGS only)",
            space=int_range(5, 500, log=True),
        ),
        Option(
            "pgs_delta_x_threshold",
            1e-6,
            number(low=0.0),
            "PgsBoxedLcpSolverOption.mDeltaXThreshold, DART's (PGS only)",
            space=log_range(1e-10, 1e-3),
        ),
        Option(
            "pgs_relative_delta_x_tolerance",
            1e-3,
            number(low=0.0),
            "PgsBoxedLcpSolverOption.mRelativeDeltaXTolerance, DART's (PGS only)",
            space=log_range(1e-8, 0.1),
        ),
    )
    variants = (
        Variant("boxed_lcp_solver=dantzig", options={"boxed_lcp_solver": "dantzig"}),
        Variant("boxed_lcp_solver=pgs", options={"boxed_lcp_solver": "pgs"}),
        Variant("collision_detector=fcl", options={"collision_detector": "fcl"}),
    )

    # ----------------------------------------------------------------- hooks
    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        """A mu DART would turn into no friction at all raises ValueError."""
        mu = check_real("mu", self.mu_for(scene, settings), low=0.0)
        if 0.0 < mu <= MIN_PAIR_FRICTION:
            raise ValueError(
                f"mu must be 0 or above {MIN_PAIR_FRICTION:g} for dart, got {mu:g}: DART "
                "switches a pair's friction off at or below that (DART_FRICTION_COEFF_THRESHOLD)"
            )

    def _model_text(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        settings_text = ", ".join(f"{k}={v}" for k, v in sorted(options.items()))
        comment = (
            "Written by hoopbench (models/urdf.py, scene_to_planar_urdf) for dartpy's DartLoader.\n"
            f"  scene {scene.name or '(unnamed)'!r}: "
            + ", ".join(f"{k}={v}" for k, v in scene.to_dict().items() if k != "name")
            + f"\n  mu={self.mu_for(scene, settings)!r}, restitution={settings.restitution!r}, "
            f"timestep={settings.timestep!r} s\n"
            f"  dart options: {settings_text}\n"
            "Set by the adapter, not in this file: the floor (a static box, top face z = 0),\n"
            "friction mu on both shapes (DART takes the minimum), restitution (the product:\n"
            "hoop e, floor 1), gravity (0, 0, -g), the time step, LCP solver and detector."
        )
        return scene_to_planar_urdf(scene, comment=comment)

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        """A dartpy script of the run: the same URDF, floor, settings and calls as _build and
        the stepping hooks, in the same order, so that it gives the run bit for bit."""
        urdf = self._model_text(scene, settings, options)
        if '"""' in urdf:
            raise ValueError("the URDF holds a triple quote and cannot be embedded")
        detector = _DETECTOR_CLASSES[options["collision_detector"]]
        default = detector == _DETECTOR_CLASSES["fcl"]
        return _SCRIPT.format(
            urdf=urdf,
            side=_floor_side(scene),
            thickness=_FLOOR_THICKNESS,
            start_depth=START_DEPTH,
            detector=detector,
            detector_note="DART's default" if default else "DART's default is FCL",
            solver=_solver_script(options),
        )

    # ----------------------------------------------------------------- model
    def _build(
        self, dart: ModuleType, scene: Scene, settings: RunSettings, options: dict[str, Any]
    ) -> tuple[Any, Any]:
        """(world, hoop skeleton) at the scene's initial state."""
        mu = self.mu_for(scene, settings)
        hoop = dart.utils.DartLoader().parseSkeletonString(
            self._model_text(scene, settings, options), dart.common.Uri("")
        )
        joint = hoop.getJoint(0)
        if hoop.getNumJoints() != 1 or joint.getName() != PLANAR_JOINT_NAME:
            raise RuntimeError(f"DartLoader made joint {joint.getName()!r}, not one planar joint")
        shape = _collision_shape(hoop.getBodyNode(0))
        shape.getDynamicsAspect().setFrictionCoeff(mu)
        shape.getDynamicsAspect().setRestitutionCoeff(settings.restitution)

        world = dart.simulation.World()
        world.setGravity([0.0, 0.0, -scene.g])
        world.setTimeStep(settings.timestep)
        world.addSkeleton(_floor(dart, scene, mu))
        world.addSkeleton(hoop)
        detector = getattr(dart.collision, _DETECTOR_CLASSES[options["collision_detector"]])
        world.setCollisionDetector(detector())
        _set_lcp_solver(dart, world.getConstraintSolver(), options)

        x, y, theta, xdot, ydot, thetadot = kinematics.rolling_start(scene)
        y -= START_DEPTH * scene.a
        hoop.setPositions([y, x, theta])
        hoop.setVelocities([ydot, xdot, thetadot])
        return world, hoop

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
        world, hoop = self._build(module, scene, settings, options)
        run = _Run(world, hoop, scene, settings.timestep)
        if record:
            run.blocks.append(np.concatenate([hoop.getPositions(), hoop.getVelocities()])[None])
        try:
            yield run
        finally:
            world.removeAllSkeletons()

    def _advance(self, run: _Run, done: int, steps: int, last: bool) -> Chunk:
        """Step, reading the joint state and the step's constraint forces after each step."""
        hoop = run.hoop
        step, positions, velocities = run.world.step, hoop.getPositions, hoop.getVelocities
        constraint = hoop.getConstraintForces
        # dartpy returns a new array per call: kept as they are, stacked once per chunk.
        q, v, f = [], [], []
        for _ in range(steps):
            step()
            q.append(positions())
            v.append(velocities())
            f.append(constraint())
        block = np.hstack([np.array(q), np.array(v), np.array(f)])
        run.blocks.append(block)
        return Chunk(_com_state(run.scene, block), done + steps)

    def _finish(self, run: _Run, ended_early: bool) -> None:
        """One more step, not recorded as a state, gives the last row its force."""
        run.world.step()
        run.last = np.concatenate([run.hoop.getPositions(), run.hoop.getConstraintForces()])

    def _trajectory(self, run: _Run, done: int, ended_early: bool) -> Trajectory:
        """The recorded rows, with the force of the step from each (module doc, Forces)."""
        states, generalized = states_and_step_forces(
            run.blocks[0], run.blocks[1:], run.last[3:].tolist()
        )
        state = _com_state(run.scene, states)
        turn = np.diff(np.append(states[:, 2], run.last[2]))
        force = _world_force(generalized, turn) / run.scene.M
        return Trajectory.from_steps(
            run.scene, run.timestep, state, normal_force=force[:, 1], friction_force=force[:, 0]
        )

    def _step_bare(self, run: _Run, steps: int) -> None:
        call_repeatedly(run.world.step, steps)


@dataclass
class _Run:
    """One run's world and hoop, and what it recorded."""

    world: Any
    hoop: Any
    scene: Scene
    timestep: float
    blocks: list[np.ndarray] = field(default_factory=list)
    """The initial joint state (6 columns), then a block per chunk whose rows are, per step:
    z, x, theta, zdot, xdot, thetadot (the joint), then the hoop's constraint forces (z, x
    parts, N, and theta part, N m)."""
    last: np.ndarray = field(default_factory=lambda: np.zeros(6))
    """The step after the last state (``_finish``): the joint positions it reached and its
    constraint forces."""


def _collision_shape(body: Any) -> Any:
    """The body's one colliding shape node (the URDF's weight is a visual only)."""
    nodes = [body.getShapeNode(i) for i in range(body.getNumShapeNodes())]
    colliding = [node for node in nodes if node.hasCollisionAspect()]
    if len(colliding) != 1:
        raise RuntimeError(f"DartLoader made {len(colliding)} colliding shapes, not one")
    return colliding[0]


def _floor(dart: ModuleType, scene: Scene, mu: float) -> Any:
    """A static skeleton: a box welded to the world, top face z = 0, friction mu (DART takes
    the pair's minimum) and restitution 1 (DART multiplies)."""
    floor = dart.dynamics.Skeleton("floor")
    _, body = floor.createWeldJointAndBodyNodePair()
    side = _floor_side(scene)
    node = body.createShapeNode(dart.dynamics.BoxShape([side, side, _FLOOR_THICKNESS]))
    node.setRelativeTranslation([0.0, 0.0, -_FLOOR_THICKNESS / 2])
    node.createCollisionAspect()
    node.createDynamicsAspect()
    node.getDynamicsAspect().setFrictionCoeff(mu)
    node.getDynamicsAspect().setRestitutionCoeff(1.0)
    floor.setMobile(False)
    return floor


def _floor_side(scene: Scene) -> float:
    """Side of the floor box, m: wider than the hoop can travel in the window."""
    return 2.0 * max(FLOOR_HALF_SIZE, 10 * scene.a + kinematics.reach(scene))


def _set_lcp_solver(dart: ModuleType, solver: Any, options: dict[str, Any]) -> None:
    """The primary boxed-LCP solver and the fallback for the steps it fails on: DART's default
    is Dantzig, then PGS; hoopbench's NSGS, then Dantzig (PGS or FBF first: Dantzig after
    it). Without a fallback DART zeroes a failed step's impulses. The PGS options reach the
    world's PGS solver, which runs only where it is the primary or Dantzig's fallback."""
    # The world's own Dantzig and PGS solvers are reordered; the friction-cone solvers are made.
    # DART ignores a primary equal to the secondary, so the secondary is cleared first.
    dantzig, pgs = solver.getBoxedLcpSolver(), solver.getSecondaryBoxedLcpSolver()
    types = (dantzig.getType(), None if pgs is None else pgs.getType())
    if types != ("DantzigBoxedLcpSolver", "PgsBoxedLcpSolver"):
        raise RuntimeError(f"dartpy: expected Dantzig and PGS as the world's solvers, got {types}")
    pgs.setOption(
        dart.constraint.PgsBoxedLcpSolverOption(
            options["pgs_max_iteration"],
            options["pgs_delta_x_threshold"],
            options["pgs_relative_delta_x_tolerance"],
        )
    )
    name = options["boxed_lcp_solver"]
    if name in _FRICTION_SOLVER_CLASSES:
        primary, secondary = getattr(dart.constraint, _FRICTION_SOLVER_CLASSES[name])(), dantzig
    else:
        primary, secondary = (pgs, dantzig) if name == "pgs" else (dantzig, pgs)
    solver.setSecondaryBoxedLcpSolver(None)
    solver.setBoxedLcpSolver(primary)
    solver.setSecondaryBoxedLcpSolver(secondary if options["lcp_fallback"] else None)
    if solver.getBoxedLcpSolver().getType() != primary.getType():
        raise RuntimeError("dartpy: the boxed-LCP solver was not set")


def _solver_script(options: dict[str, Any]) -> str:
    """The lines of a script that set the boxed-LCP solvers as _set_lcp_solver does."""
    name = options["boxed_lcp_solver"]
    pgs_option = (
        f"dart.constraint.PgsBoxedLcpSolverOption({int(options['pgs_max_iteration'])!r}, "
        f"{float(options['pgs_delta_x_threshold'])!r}, "
        f"{float(options['pgs_relative_delta_x_tolerance'])!r})"
    )
    lines = [
        "# A World comes with Dantzig first and PGS as the fallback for the steps it fails on.",
        "dantzig, pgs = solver.getBoxedLcpSolver(), solver.getSecondaryBoxedLcpSolver()",
        "# PGS's options: maximum iterations, delta-x threshold, relative delta-x tolerance",
        f"pgs.setOption({pgs_option})",
        "# DART ignores a primary solver equal to the secondary: clear the secondary first.",
        "solver.setSecondaryBoxedLcpSolver(None)",
    ]
    if name in _FRICTION_SOLVER_CLASSES:
        kind = _FRICTION_SOLVER_CLASSES[name]
        lines.append(f"solver.setBoxedLcpSolver(dart.constraint.{kind}())  # Coulomb cone")
    else:
        lines.append(f"solver.setBoxedLcpSolver({name})")
    if options["lcp_fallback"]:
        other = "pgs" if name == "dantzig" else "dantzig"
        lines.append(f"solver.setSecondaryBoxedLcpSolver({other})  # for the failed steps")
    else:
        lines.append("# no fallback: DART zeroes the impulses of a step the solver fails on")
    return "\n    ".join(lines)


def _world_force(generalized: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """(n, 2) contact force on the hoop, N, world x and z, from the rows of its constraint
    forces (z, x, theta parts, ``Skeleton.getConstraintForces()`` after each step) and each
    step's turn, rad: DART maps the step's body-frame impulse through the Jacobian at the pose
    after the step, so the z, x parts are the world force turned by the step; this turns them
    back."""
    c, s = np.cos(turn), np.sin(turn)
    z, x = generalized[:, 0], generalized[:, 1]
    return np.stack([c * x - s * z, s * x + c * z], axis=1)


def _com_state(scene: Scene, data: np.ndarray) -> dict[str, np.ndarray]:
    """Centre-of-mass state from joint rows (z, x, theta, zdot, xdot, thetadot)."""
    z, x, theta, zdot, xdot, thetadot = data[:, :6].T
    return kinematics.com_state(scene, x, z, theta, xdot, zdot, thetadot)


_SCRIPT = '''
import dartpy as dart

HOOP_URDF = """{urdf}"""
"""The hoop: one planar joint (axis +y: DartLoader makes a PlanarJoint in the x-z plane with
positions centre height z, centre x, theta) and the scene's mass, centre of mass and inertia."""

FLOOR_SIDE = {side!r}  # m, the floor box's side
FLOOR_THICKNESS = {thickness!r}  # m; its top face is the plane z = 0
START_DEPTH = {start_depth!r}  # in units of A: placed exactly touching, a tilted start misses
# its first step's contact (the distance comes out +1e-16 m)


def build():
    """World, hoop: the URDF's hoop, a static floor box, gravity -z, the solvers."""
    hoop = dart.utils.DartLoader().parseSkeletonString(HOOP_URDF, dart.common.Uri(""))
    body = hoop.getBodyNode(0)
    nodes = [body.getShapeNode(i) for i in range(body.getNumShapeNodes())]
    (shape,) = [node for node in nodes if node.hasCollisionAspect()]  # the sphere of radius A
    shape.getDynamicsAspect().setFrictionCoeff(MU)  # DART takes the pair's minimum
    shape.getDynamicsAspect().setRestitutionCoeff(RESTITUTION)  # DART multiplies the pair's

    floor = dart.dynamics.Skeleton("floor")
    _, floor_body = floor.createWeldJointAndBodyNodePair()
    node = floor_body.createShapeNode(
        dart.dynamics.BoxShape([FLOOR_SIDE, FLOOR_SIDE, FLOOR_THICKNESS])
    )
    node.setRelativeTranslation([0.0, 0.0, -FLOOR_THICKNESS / 2])
    node.createCollisionAspect()
    node.createDynamicsAspect()
    node.getDynamicsAspect().setFrictionCoeff(MU)
    node.getDynamicsAspect().setRestitutionCoeff(1.0)
    floor.setMobile(False)

    world = dart.simulation.World()
    world.setGravity([0.0, 0.0, -G])
    world.setTimeStep(DT)
    world.addSkeleton(floor)
    world.addSkeleton(hoop)
    world.setCollisionDetector(dart.collision.{detector}())  # {detector_note}
    solver = world.getConstraintSolver()
    {solver}

    x, y, theta, xdot, ydot, thetadot = CENTRE0
    y -= START_DEPTH * A
    hoop.setPositions([y, x, theta])  # the planar joint: z, x, theta
    hoop.setVelocities([ydot, xdot, thetadot])
    return world, hoop


def world_force(generalized, turn):
    """(n, 2) contact force on the hoop, N, world x and z, from the hoop's constraint forces
    (z, x, theta parts of its planar joint, Skeleton.getConstraintForces() after each step):
    DART maps the step's body-frame impulse through the Jacobian at the pose after the step,
    so the z, x parts are the world force turned by the step's rotation ``turn``; turned back
    here."""
    c, s = np.cos(turn), np.sin(turn)
    z, x = generalized[:, 0], generalized[:, 1]
    return np.stack([c * x - s * z, s * x + c * z], axis=1)


def simulate():
    """Step the window (no divergence checks). Row i: the joint state at i*DT and the force
    of the step from it, read from the hoop's constraint forces after that step; one more
    step gives the last row its force."""
    world, hoop = build()
    first = np.concatenate([hoop.getPositions(), hoop.getVelocities()])[None]
    q, v, f = [], [], []
    for _ in range(N_STEPS):
        world.step()
        q.append(hoop.getPositions())
        v.append(hoop.getVelocities())
        f.append(hoop.getConstraintForces())
    block = np.hstack([np.array(q), np.array(v), np.array(f)])
    world.step()
    last = np.concatenate([hoop.getPositions(), hoop.getConstraintForces()])
    states, generalized = step_forces(first, [block], last[3:])
    z, x, theta, zdot, xdot, thetadot = states.T
    turn = np.diff(np.append(theta, last[2]))  # each step's rotation, rad
    force = world_force(generalized, turn) / M
    state = com_state(x, z, theta, xdot, zdot, thetadot)
    return {{**state, "normal_force": force[:, 1], "friction_force": force[:, 0]}}
'''
"""DART's part of a standalone script (engines/standalone.py), as a dartpy user writes it."""
