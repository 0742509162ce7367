"""Newton adapter (``newton``, on NVIDIA Warp): the hoop as a free rigid body on a ground
plane, one Newton world per scene, every world in one model, stepped by one of Newton's
rigid-body solvers (the ``solver`` setting).

Newton reads no model file here: the worlds are built by calls (``ModelBuilder``). Frames:
Newton's z is up, so hoopbench's (x, y) is Newton's (x, z); the body turns about +y, and a
positive rotation about +y carries the body's +z toward +x: the angle is theta (clockwise
from the top), read from the body's quaternion, 2 atan2(q_y, q_w), unwrapped step by step.
The body's origin is the hoop centre; ``body_qd``'s linear part is the centre of mass's
velocity (Newton's convention), its angular part the world-frame angular velocity.

The body. Mass M, centre of mass (0, 0, lam a) in the body frame and the principal inertia
I_com about y from the scene (``add_body(..., lock_inertia=True)``; the sphere has density 0,
so nothing comes from the geometry); the out-of-plane moments are I_com/2, padded as the MJCF
pads them. The body is free (6 degrees of freedom), not held in the plane: every force on it
(gravity, the contact below the centre, the friction along x) lies in the plane, so it stays
there (measured: the centre's y stays 0 with XPBD, SemiImplicit, Featherstone; 2e-8 m with
MuJoCo). A free body is what every Newton rigid solver takes; a planar joint would leave
XPBD and SemiImplicit to hold it by constraints of their own.

Contact. A sphere of radius a on a ground plane: the hoop's circle in the plane. Each world
has its own ground plane with the scene's mu on both shapes (Newton averages the two
shapes' coefficients). Newton's rolling (``mu_rolling`` 1e-4 m) and torsional
(``mu_torsional`` 5e-3) friction are off in tuned (the rigid hoop has neither; stock keeps
them), and so is SemiImplicit's and Featherstone's ``angular_damping`` (0.05 /s). The contact
law is the solver's: XPBD projects positions (rigid: it reads no ``ke``/``kd``); SemiImplicit
and Featherstone apply a penalty force ``ke`` depth + ``kd`` rate with viscous-regularised
friction ``kf`` capped at mu n; MuJoCo (MuJoCo Warp inside Newton) maps the shapes' ke/kd to
its solref, timeconst 2 / kd and dampratio kd / (2 sqrt(ke)) (Newton's ``convert_solref``,
per unit mass). ke and kd come from a contact time constant tc and damping ratio zeta as
MuJoCo's solref states them, for the hoop's mass M (1 kg):

    ke = M / (zeta tc)^2,    kd = 2 M / tc,

so that the contact of a mass M rings at 1 / (zeta tc) rad/s with damping ratio zeta, and
``solver=mujoco`` gets solref (tc, zeta) exactly. tc = 10 ms, zeta = 1 (ke 1e4 N/m, kd
200 N s/m): the penalty solvers integrate the contact force explicitly, stable while
kd dt / m_c < 2 for the contact's effective mass m_c = M / (1 + lam^2 sin^2 theta / k),
which falls to M / 9.4 on hop-top and seed-mu (lam 0.95, k 0.107): kd < 212 N s/m at the
suites' dt 1e-3, i.e. tc > 9.4 ms. Newton's defaults (ke 2.5e3, kd 100) are tc 20 ms,
zeta 1: MuJoCo's default solref for a 1 kg body. Static sink M g / ke: 1 mm (4 mm stock).

Force. Row i is the step's impulse on the hoop over dt, from the step's own momentum
balance: M (v_{i+1} - v_i) / dt - M g, normal along z and friction along x. The contact is
the only force on the body besides gravity, so this is the contact force the solver applied
over the step from state i, whichever solver it is; SemiImplicit and Featherstone expose no
contact force of their own (``supported_observables``). The velocities are float32, so
without contact the balance is not 0 but rounding: a velocity component Newton stores is a
rounded sum of terms no larger than s = |v| + |omega| |c| (the centre of mass's speed and
the spin's lever to it), off by at most u s per rounding (u = 2^-24, float32's unit
roundoff), and gravity's g dt adds u g dt. A step without contact therefore reads at most

    N u ((s_i + s_{i+1}) / dt + g)    (per unit mass, m/s^2; N = ROUNDINGS[solver])

and a normal force within that floor is read as none: both columns 0, the contact column
False (the trajectory's ``normal_force > 0``). N counts the roundings (``ROUNDINGS``): 2
where the solver integrates the body's velocity itself (XPBD, SemiImplicit), 16 where it
maps it from joint coordinates (Featherstone, MuJoCo). The floor follows dt and the speed:
with N 2 at dt 1e-4 and s 2 m/s it is 5e-3 m/s^2 (5e-4 g). A normal force above it is kept
as balanced, a pull beyond it too (negative: no contact). Measured in flight on hop-top and
hop-bottom, |balance| / (u (s_i + s_{i+1}) / dt + u g): XPBD at most 0.07 (dt 1e-3) and
0.12 (dt 1e-4), SemiImplicit 0.15, Featherstone 6.8 (dt 1e-3): below N with room.
``solver=mujoco`` is not rounding: its free joint integrates the body origin, and the
centre of mass's velocity it reports turns by a first-order residual of 4-5e-2 m/s^2 in
flight at dt 1e-3 (of the order omega^3 lam a dt / 2), far above the floor, so its flights
still read contact (Newton's own ``contact_f`` observable would not; left out for time).

Built once. What a call builds that no world's state changes (the model, solver, collision
pipeline, contacts, state pair, recording buffers and the captured steps) is kept per
process per shape and setting (``_BUILT``); a later call writes its worlds' parameters into
the kept model and resets the states and the solver (docs/engines.md, Batched simulators).
Each step is a graph captured once and replayed, as Newton's examples step, on a CPU too
(Warp's CPU graph: the kernels without Python's cost per launch, ``CAPTURE_STEPS``); a kernel
inside it records the step's state into a buffer, read and made into rows once per chunk.

Precision: single (Warp's ``float``). The first step of a new build compiles kernels (tens
of seconds on 2 CPU cores, kept in Warp's kernel cache, ``HOOPBENCH_CACHE`` or the user's
cache folder, ``hoopbench/warp``).
"""

from __future__ import annotations

import functools
import math
import operator
import warnings
from collections import OrderedDict
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import (
    CHUNK_STEPS,
    DEVICE,
    WARP_CACHE,
    WARP_ENABLE_BACKWARD,
    WorldsEngine,
    import_warp,
    warp_device,
)
from hoopbench.engines.options import (
    Option,
    Variant,
    choice,
    int_range,
    integer,
    log_range,
    number,
    one_of,
    optional,
)
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.engines.warp_compile import load_modules
from hoopbench.models import kinematics
from hoopbench.models.checks import check_real
from hoopbench.models.mjcf import INERTIA_PAD
from hoopbench.models.scene import Scene

__all__ = ["SOLVERS", "NewtonEngine"]

SOLVERS: dict[str, str] = {
    "xpbd": "SolverXPBD",
    "featherstone": "SolverFeatherstone",
    "semi_implicit": "SolverSemiImplicit",
    "mujoco": "SolverMuJoCo",
}
"""The ``solver`` setting -> Newton's solver class. Newton's other solvers cannot hold the
hoop: VBD, Style3D and ImplicitMPM step particles, cloth and continua (VBD's rigid bodies
need a colouring and a rigid-body mode this build refuses without one), Kamino and Steel are
experimental (docs/engines.md, Newton)."""


CONTACT_MASS = 1.0
"""kg: the catalogue hoop's mass, the mass the contact's ke and kd are stated for."""
CONTACT_TIME = 0.01
"""s: the contact's time constant tc (as MuJoCo's solref timeconst; module doc, Contact)."""
DAMPING_RATIO = 1.0
"""The contact's damping ratio zeta (as MuJoCo's solref dampratio): critical."""
CONTACT_KE = CONTACT_MASS / (DAMPING_RATIO * CONTACT_TIME) ** 2
"""N/m: ke = M / (zeta tc)^2."""
CONTACT_KD = 2.0 * CONTACT_MASS / CONTACT_TIME
"""N s/m: kd = 2 M / tc."""
UNIT_ROUNDOFF = 2.0**-24
"""float32's unit roundoff u: a rounded result is within u |x| of the exact x."""
WARP_MODULES = (
    "newton._src.sim.articulation",
    "newton._src.sim.collide",
    "newton._src.geometry.bvh",
    "newton._src.geometry.narrow_phase",
    "newton._src.geometry.broad_phase_nxn",
)
"""Newton's modules (of all its kernels but those made per call, ``module="unique"``) that
every solver's call loads, the dearest first (compiled on the CPU, 2026-11-29: 2.6, 1.5,
1.2, 0.8 and 0.6 CPU-s of the 17.5 a cold XPBD process pays): loaded before the model
is built, where two cold processes split them (engines/warp_compile.py)."""

SOLVER_MODULES: dict[str, tuple[str, ...]] = {
    "xpbd": ("newton._src.solvers.xpbd.kernels", "newton._src.solvers.solver"),
    "featherstone": (
        "newton._src.solvers.featherstone.kernels",
        "newton._src.solvers.semi_implicit.kernels_contact",
    ),
    "semi_implicit": (
        "newton._src.solvers.semi_implicit.kernels_body",
        "newton._src.solvers.semi_implicit.kernels_contact",
        "newton._src.solvers.solver",
    ),
    "mujoco": (
        "mujoco_warp._src.forward",
        "newton._src.solvers.mujoco.kernels",
        "mujoco_warp._src.smooth",
        "mujoco_warp._src.passive",
        "mujoco_warp._src.derivative",
        "mujoco_warp._src.set_const",
        "mujoco_warp._src.solver",
        "mujoco_warp._src.support",
        "mujoco_warp._src.constraint",
    ),
}
"""The Warp modules each solver's call adds, the dearest first (CPU-s on a cold cache,
2026-11-29: XPBD 4.8, 0.4; Featherstone 6.7, 1.3; SemiImplicit 2.9, 1.2, 0.4; MuJoCo 5.5-5.8
each for MuJoCo Warp's forward and Newton's MuJoCo kernels, then 4.1, 2.8, 1.9, 1.0, 0.7,
0.3, 0.1), loaded with :data:`WARP_MODULES`. MuJoCo Warp's modules are the same binaries
the mjwarp adapter loads (one hash each), shared through the cache."""

ROUNDINGS: dict[str, int] = {"xpbd": 2, "semi_implicit": 2, "featherstone": 16, "mujoco": 16}
"""Per solver, the roundings N a velocity Newton stores may carry per step (module doc,
Force): 2 where the solver integrates the body's velocity itself (v + a dt, one rounding per
component, and one of a dt); 16 where it maps it from joint coordinates (a spatial transform
of the 6-vector: quaternion rotations and the lever's cross product)."""


@register
class NewtonEngine(WorldsEngine):
    """Newton: one world per scene in one model; XPBD, Featherstone, SemiImplicit, MuJoCo."""

    name = "newton"
    distribution = "newton"
    modules = ("newton", "warp")
    model_note = "the worlds are built by calls (newton.ModelBuilder), not read"
    worlds_per_call = 8
    compiled_cache = WARP_CACHE
    """The fewest worlds the runner cuts a settings' runs to: on a CPU a Newton step costs
    about the same whatever the worlds (XPBD, 3,000 steps at 1e-3 s, CPU time of a kept
    call's stepping: 0.10 s for 1 world or 2, 0.12 s for 8, replayed as a captured graph,
    2026-11-29; 3.53, 3.67 and 3.82 s when launched from Python, 2026-11-28), so that
    batches of 2 cost nearly 4 times a batch of 8. Unlike MJX, Newton pads nothing: a world's row is
    the same alone and in any batch (tests/test_newton.py)."""
    step_cost_bound = 0.2
    """5 times a lone world's step on the CPU with its dearest solver (MuJoCo: 41 ms,
    docs/engines.md)."""

    @classmethod
    def gpu_only_reason(cls, options: Mapping[str, Any]) -> str | None:
        """Newton's MuJoCo solver is MuJoCo Warp (its ``gpu_only``); the other solvers pay
        off on a CPU too."""
        if options.get("solver") != "mujoco":
            return None
        return (
            "its MuJoCo solver is MuJoCo Warp, whose kernels cost about 12 CPU-s more to "
            "compile on a machine's first run"
        )

    options = (
        Option(
            "solver",
            "xpbd",
            choice(*SOLVERS),
            "Newton's examples' default (XPBD). Its contact is positional, with no stiffness "
            "to choose; the penalty solvers (semi_implicit, featherstone) depend on ke, kd, kf",
            space=one_of(*SOLVERS),
        ),
        Option(
            "ke",
            CONTACT_KE,
            number(low=0.0, low_open=True, unit="N/m"),
            "contact stiffness M / (zeta tc)^2 for the 1 kg hoop, tc "
            f"{CONTACT_TIME * 1e3:g} ms, zeta {DAMPING_RATIO:g} (module doc, Contact): the "
            "stiffest critically damped contact the explicit penalty solvers hold at dt 1e-3 "
            "(the hoop's contact mass falls to 0.11 kg); at dt 1e-4 the stiffer 1e5 / 100 "
            "did better for them (docs/engines.md, Newton). Newton's 2.5e3 with kd 100 is "
            "MuJoCo's solref (0.02, 1) and sinks the hoop 4 mm at rest. Read by "
            "semi_implicit, featherstone, mujoco (as solref); XPBD's contact is positional "
            "and reads no ke",
            stock=2.5e3,
            space=log_range(1e3, 1e7),
        ),
        Option(
            "kd",
            CONTACT_KD,
            number(low=0.0, unit="N s/m"),
            f"contact damping 2 M / tc for the 1 kg hoop (tc {CONTACT_TIME * 1e3:g} ms, "
            "critical with ke). Read by semi_implicit, featherstone, mujoco; not by XPBD",
            stock=100.0,
            space=log_range(1.0, 1e4),
        ),
        Option(
            "kf",
            1000.0,
            number(low=0.0, unit="N s/m"),
            "Newton's: the slope of the penalty solvers' viscous friction below mu n",
            space=log_range(10.0, 1e5),
        ),
        Option(
            "mu_rolling",
            0.0,
            number(low=0.0, unit="m"),
            "off: the rigid hoop has no rolling resistance. Newton's default 1e-4 m is on in "
            "stock (hop-top at dt 1e-4, XPBD: hop -46.5 % with it, -43.2 % without)",
            stock=1e-4,
            space=one_of(0.0, 1e-5, 1e-4, 1e-3),
        ),
        Option(
            "mu_torsional",
            0.0,
            number(low=0.0),
            "off: the rigid hoop has no torsional friction. Newton's default 5e-3 is on in "
            "stock (it resists spin about the contact normal, which the planar hoop never has)",
            stock=5e-3,
            space=one_of(0.0, 5e-4, 5e-3, 5e-2),
        ),
        Option(
            "angular_damping",
            0.0,
            optional(number(low=0.0, unit="1/s")),
            "off: the rigid hoop loses no spin. Stock (None) keeps each solver's own: "
            "0.05 /s for semi_implicit and featherstone (a tenth of the spin in 2 s), 0 for "
            "xpbd. Read by semi_implicit, featherstone, xpbd; SolverMuJoCo takes none",
            stock=None,
            space=one_of(0.0, None, 5e-3, 5e-2, 0.5),
        ),
        Option(
            "iterations",
            2,
            integer(low=1),
            "Newton's XPBD default (read by xpbd only)",
            space=int_range(1, 50, log=True),
        ),
        DEVICE,
    )
    variants = tuple(
        Variant(f"solver={solver}", options={"solver": solver})
        for solver in SOLVERS
        if solver != "xpbd"  # the default
    )

    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        """Restitution != 0 raises ValueError before a run: none of the solvers here takes
        it as the other engines do (the run used to ignore it and report restitution 0's)."""
        value = check_real("restitution", settings.restitution, low=0.0, high=1.0)
        if value != 0.0:
            raise ValueError(
                f"restitution must be 0 for Newton, got {settings.restitution}: its XPBD "
                "solver applies restitution only when built with enable_restitution=True "
                "(after the positional solve), its Featherstone and SemiImplicit contacts are "
                "penalty springs (ke, kd) and its MuJoCo solver has no coefficient; hoopbench "
                "builds Newton's hoop without restitution"
            )

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        solver = options["solver"]
        args = [] if solver != "xpbd" else [f"iterations={int(options['iterations'])}"]
        if solver != "mujoco" and options["angular_damping"] is not None:
            args.append(f"angular_damping={float(options['angular_damping'])!r}")
        device = {"cpu": '"cpu"', "gpu": '"cuda:0"'}.get(
            options["device"], '"cuda:0" if wp.get_cuda_device_count() > 0 else "cpu"'
        )
        return _SCRIPT.format(
            ke=float(options["ke"]),
            kd=float(options["kd"]),
            kf=float(options["kf"]),
            mu_rolling=float(options["mu_rolling"]),
            mu_torsional=float(options["mu_torsional"]),
            pad=INERTIA_PAD,
            solver=SOLVERS[solver],
            solver_args="".join(f", {a}" for a in args),
            device=device,
            chunk=CHUNK_STEPS,
            roundings=ROUNDINGS[solver],
            unit_roundoff=UNIT_ROUNDOFF,
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
        import warp as wp

        newton = module
        with wp.ScopedDevice(warp_device(wp, options["device"])), warnings.catch_warnings():
            # SolverMuJoCo warns that it was built against mujoco 3.17 (here: 4.0).
            warnings.filterwarnings("ignore", message="MuJoCo dependency version mismatch")
            mus = [self.mu_for(scene, settings) for scene in scenes]
            # This adapter's own kernels (a recorded step's hold, record and count) too: left
            # to the first captured step, their compile counted as stepping (a cold cache's
            # first call stepped 0.49 CPU-s against 0.16 warm, and the answer's tie between
            # two profiles went the other way).
            recording = _recording_kernels(wp)[0].module.name
            modules = (*SOLVER_MODULES[options["solver"]], *WARP_MODULES, recording)
            load_modules(wp, wp.get_device(), modules)
            model = _build(newton, wp, scenes, mus, options)
            built = _built(newton, wp, model, options, settings.timestep)
            batch = _Batch(
                newton,
                wp,
                list(scenes),
                built,
                settings.timestep,
                ROUNDINGS[options["solver"]],
                captured=CAPTURE_STEPS,
            )
            batch.start()
            yield batch

    def _batch_advance(
        self, batch: _Batch, active: np.ndarray, steps: int
    ) -> tuple[np.ndarray, np.ndarray]:
        with batch.wp.ScopedDevice(batch.built.model.device):
            return batch.advance(steps, active)


def _build(
    newton: ModuleType, wp: ModuleType, scenes: Sequence[Scene], mus: Sequence[float], opts: dict
) -> Any:
    """One world per scene: its ground plane and its hoop, at the scene's initial pose."""
    builder = newton.ModelBuilder(gravity=(0.0, 0.0, -scenes[0].g))
    for scene, mu in zip(scenes, mus, strict=True):
        cfg = newton.ModelBuilder.ShapeConfig(
            density=0.0,
            mu=mu,
            ke=opts["ke"],
            kd=opts["kd"],
            kf=opts["kf"],
            mu_rolling=opts["mu_rolling"],
            mu_torsional=opts["mu_torsional"],
        )
        builder.begin_world(gravity=(0.0, 0.0, -scene.g))
        builder.add_ground_plane(cfg=cfg)
        x, y, theta, *_ = kinematics.rolling_start(scene)
        side = 0.5 * scene.inertia_com * (1.0 + INERTIA_PAD)
        body = builder.add_body(
            xform=wp.transform((x, 0.0, y), wp.quat_from_axis_angle(wp.vec3(0, 1, 0), theta)),
            com=(0.0, 0.0, scene.com_offset),
            inertia=wp.mat33(side, 0, 0, 0, scene.inertia_com, 0, 0, 0, side),
            mass=scene.M,
            lock_inertia=True,
        )
        builder.add_shape_sphere(body, radius=scene.a, cfg=cfg)
        builder.end_world()
    return builder.finalize()


def _solver(newton: ModuleType, model: Any, opts: dict) -> Any:
    cls = getattr(newton.solvers, SOLVERS[opts["solver"]])
    kwargs: dict[str, Any] = {}
    if opts["solver"] == "xpbd":
        kwargs["iterations"] = opts["iterations"]
    if opts["solver"] != "mujoco" and opts["angular_damping"] is not None:
        kwargs["angular_damping"] = opts["angular_damping"]
    return cls(model, **kwargs)


BUILT_KEPT = 4
"""Shapes and settings whose built objects one process keeps (the least recently used one
goes): a suite's worker meets a few settings at a time, a hop map many scene sets of one
shape and setting."""

_BUILT: OrderedDict[tuple[Any, ...], _Built] = OrderedDict()
"""Per process, per shape (worlds) and setting (options, device): what a call builds that no
world's state changes (:func:`_built`)."""


@dataclass
class _Built:
    """What a call builds that does not depend on the worlds' states, kept per process: the
    model (each call writes its own worlds' parameters into its arrays), the solver, the
    collision pipeline (its kernels are generated per instance) and contacts, the pair of
    states, the buffers a step records into and holds worlds from, and the captured steps."""

    model: Any
    solver: Any
    pipeline: Any
    contacts: Any
    control: Any
    states: tuple[Any, Any]
    history: tuple[Any, Any, Any]
    """Device buffers of a chunk's recorded body_q (CHUNK_STEPS + 1, W), body_qd
    (CHUNK_STEPS + 1, W: a chunk and the last state's force step) and the step counter the
    recording kernel reads."""
    held: tuple[Any, ...]
    """Device buffers of the worlds a step holds (``_recording_kernels``): which (W, int32,
    1 for held) and their state at the chunk's start (body_q, body_qd, joint_q, joint_qd)."""
    graphs: dict[tuple[float, int], Any] = field(default_factory=dict)
    """Captured graphs of one recorded step (CUDA graphs, or Warp's CPU graphs), by time
    step (s: a graph keeps its launches' arguments) and by which of ``states`` holds the
    state the step starts from (0, 1)."""
    calls: int = 1
    """Calls served, this one included."""


def _built(newton: ModuleType, wp: ModuleType, model: Any, opts: dict, dt: float) -> _Built:
    """The kept objects of this shape and setting, holding ``model``'s parameters (the
    worlds' masses, inertia, shapes, friction, initial poses); built on a first call. A
    kept model takes a new call's parameters only when every value that is not a Warp
    array is the same (counts, flags), and its solver is told they changed, as Newton's
    users change a model in place (``notify_model_changed``)."""
    key = (model.body_count, str(model.device), tuple(sorted(opts.items())))
    kept = _BUILT.get(key)
    if kept is not None and _take_parameters(wp, kept.model, model):
        _BUILT.move_to_end(key)
        kept.solver.notify_model_changed(_changed_flags(newton))
        kept.calls += 1
        return kept
    _BUILT[key] = built = _build_once(newton, wp, model, opts, dt)
    while len(_BUILT) > BUILT_KEPT:
        _BUILT.popitem(last=False)
    return built


_CHANGED = (
    "MODEL_PROPERTIES",  # gravity
    "BODY_PROPERTIES",  # the initial pose
    "BODY_INERTIAL_PROPERTIES",  # mass, inertia, centre of mass
    "SHAPE_PROPERTIES",  # radius, mu, ke, kd, kf, rolling and torsional friction
    "JOINT_PROPERTIES",  # the free joint's frame
    "JOINT_DOF_PROPERTIES",
)
"""The ``newton.ModelFlags`` of what differs between two calls' worlds of one shape and
setting (the shapes' kinds and counts are the same: ``_take_parameters``)."""


def _changed_flags(newton: ModuleType) -> int:
    """The bits of :data:`_CHANGED`."""
    return functools.reduce(operator.or_, (int(newton.ModelFlags[n]) for n in _CHANGED), 0)


def _take_parameters(wp: ModuleType, kept: Any, model: Any) -> bool:
    """Copy ``model``'s Warp arrays into ``kept``'s, if the two have the same shape: every
    array the same size and type, every public number, string and flag equal (the private
    ones are caches Newton fills on first use, e.g. the contact capacity). False (nothing
    copied) otherwise."""
    arrays = []
    for name, value in vars(model).items():
        old = getattr(kept, name, None)
        if name.startswith("_"):
            continue
        if isinstance(value, wp.array):
            if not isinstance(old, wp.array) or (old.shape, old.dtype) != (
                value.shape,
                value.dtype,
            ):
                return False
            arrays.append((old, value))
        elif isinstance(value, int | float | str | bool | type(None)) and old != value:
            return False
    for old, value in arrays:
        if value.size:
            old.assign(value)
    return True


def _build_once(newton: ModuleType, wp: ModuleType, model: Any, opts: dict, dt: float) -> _Built:
    """The solver, collision pipeline, states and buffers of a new shape or setting, and one
    step of a pair of scratch states: the kernels load (or compile) here, outside the timed
    loop. The scratch step must not start from the run's state: XPBD writes its state_in
    (stepping from it moved the run one step on before its first row: every row was the
    next step's state, until 2026-11-28)."""
    solver = _solver(newton, model, opts)
    pipeline = newton.CollisionPipeline(model)
    contacts = pipeline.contacts()
    control = model.control()
    worlds = model.body_count
    history = (
        wp.zeros((CHUNK_STEPS + 1, worlds), dtype=wp.transform),
        wp.zeros((CHUNK_STEPS + 1, worlds), dtype=wp.spatial_vector),
        wp.zeros(1, dtype=wp.int32),
    )
    scratch_in, scratch_out = model.state(), model.state()
    pipeline.collide(scratch_in, contacts)
    solver.step(scratch_in, scratch_out, control, contacts, dt)
    wp.synchronize()
    states = (model.state(), model.state())
    start = (wp.zeros_like(getattr(scratch_in, name)) for name in HELD_STATE)
    held = (wp.zeros(worlds, dtype=wp.int32), *start)
    return _Built(model, solver, pipeline, contacts, control, states, history, held)


HELD_STATE = ("body_q", "body_qd", "joint_q", "joint_qd")
"""The state a held world gets back after each step (one body and one free joint a world:
joint_q 7 and joint_qd 6 values)."""

CAPTURE_STEPS = True
"""Each step is a captured graph replayed (``wp.ScopedCapture``, ``wp.capture_launch``), as
Newton's examples step on every device (``example_basic_shapes``): a CUDA graph on a GPU,
Warp's CPU graph on a CPU, whose replay calls the step's kernels without Python's cost per
launch (XPBD, 8 worlds: 1.6 ms a step launched, 47 us replayed; docs/engines.md, Newton).
False launches each kernel from Python (the same rows: tests/test_newton.py)."""


@functools.cache
def _recording_kernels(wp: ModuleType) -> tuple[Any, Any, Any]:
    """The kernels a recorded step adds (a captured graph holds no host read or write):
    ``hold`` gives the held worlds their chunk-start state back, ``record`` writes the
    worlds' body_q and body_qd into row ``step[0]`` of the history, ``count`` adds 1 to
    ``step[0]``. Defined here, not at the top: Warp is imported with the engine, not with
    the adapter (mypy cannot read Warp's array types off a module argument: the ignores)."""

    @wp.kernel
    def hold(
        held: wp.array[wp.int32],  # type: ignore[name-defined]
        body_q: wp.array[wp.transform],  # type: ignore[name-defined]
        body_qd: wp.array[wp.spatial_vector],  # type: ignore[name-defined]
        joint_q: wp.array[wp.float32],  # type: ignore[name-defined]
        joint_qd: wp.array[wp.float32],  # type: ignore[name-defined]
        start_q: wp.array[wp.transform],  # type: ignore[name-defined]
        start_qd: wp.array[wp.spatial_vector],  # type: ignore[name-defined]
        start_joint_q: wp.array[wp.float32],  # type: ignore[name-defined]
        start_joint_qd: wp.array[wp.float32],  # type: ignore[name-defined]
    ) -> None:
        world = wp.tid()
        if held[world] != 0:
            body_q[world] = start_q[world]
            body_qd[world] = start_qd[world]
            n_q = joint_q.shape[0] // held.shape[0]
            for i in range(n_q):
                joint_q[world * n_q + i] = start_joint_q[world * n_q + i]
            n_qd = joint_qd.shape[0] // held.shape[0]
            for i in range(n_qd):
                joint_qd[world * n_qd + i] = start_joint_qd[world * n_qd + i]

    @wp.kernel
    def record(
        body_q: wp.array[wp.transform],  # type: ignore[name-defined]
        body_qd: wp.array[wp.spatial_vector],  # type: ignore[name-defined]
        step: wp.array[wp.int32],  # type: ignore[name-defined]
        q_out: wp.array2d[wp.transform],  # type: ignore[name-defined]
        qd_out: wp.array2d[wp.spatial_vector],  # type: ignore[name-defined]
    ) -> None:
        world = wp.tid()
        q_out[step[0], world] = body_q[world]
        qd_out[step[0], world] = body_qd[world]

    @wp.kernel
    def count(step: wp.array[wp.int32]) -> None:  # type: ignore[name-defined]
        step[0] = step[0] + wp.int32(1)

    return hold, record, count


@dataclass
class _Batch:
    """The worlds' kept objects (model, solver, states, contacts) and the last angles read."""

    newton: ModuleType
    wp: ModuleType
    scenes: list[Scene]
    built: _Built
    timestep: float
    roundings: int
    captured: bool = True
    """Each step a captured graph replayed (:data:`CAPTURE_STEPS`), else launched."""
    mass: np.ndarray = field(init=False)
    gravity: np.ndarray = field(init=False)
    theta: np.ndarray = field(init=False)
    lever: np.ndarray = field(init=False)

    def start(self) -> None:
        """The worlds' initial states in the kept pair (a new model's ``state()``), the
        solver's own state cleared (``reset``: MuJoCo's warm start), then the initial
        velocities and the joint coordinates the articulated solvers step."""
        newton, built = self.newton, self.built
        self.state, self.next = built.states
        initial = built.model.state()
        for state in built.states:
            for name, array in vars(initial).items():
                if isinstance(array, self.wp.array) and array.size:
                    getattr(state, name).assign(array)
        built.solver.reset(self.state)
        qd = [_start_velocity(scene) for scene in self.scenes]
        self.state.body_qd.assign(np.array(qd, dtype=np.float32))
        newton.eval_ik(built.model, self.state, self.state.joint_q, self.state.joint_qd)
        self.mass = np.array([scene.M for scene in self.scenes])
        self.gravity = np.array([scene.g for scene in self.scenes])
        self.theta = np.array([scene.theta0 for scene in self.scenes])
        self.lever = np.array([abs(scene.com_offset) for scene in self.scenes])
        self.wp.synchronize()

    def advance(self, steps: int, active: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every world steps (one launch serves all); the inactive ones are held: they get
        their state back after each step, so that a world still running does not move while
        others finish. The states are recorded raw (float32) at each step and turned into
        rows once per chunk."""
        w = len(self.scenes)
        q = np.empty((steps + 1, w, 7), dtype=np.float32)
        qd = np.empty((steps + 1, w, 6), dtype=np.float32)
        q[0], qd[0] = self.state.body_q.numpy(), self.state.body_qd.numpy()
        self._advance_recorded(steps, active, q[1:], qd[1:])
        rows = self._rows(q, qd)  # (W, steps + 1, 7)
        forces = _step_forces(rows, self.mass, self.gravity, self.timestep, self.roundings)
        states = np.stack(
            [_com_rows(s, world[:, :6]) for s, world in zip(self.scenes, rows, strict=True)]
        )
        return states, forces

    def _step(self) -> None:
        """One step of every world from ``state`` into ``next``."""
        built = self.built
        self.state.clear_forces()
        built.pipeline.collide(self.state, built.contacts)
        built.solver.step(self.state, self.next, built.control, built.contacts, self.timestep)

    def _advance_recorded(
        self, steps: int, active: np.ndarray, q: np.ndarray, qd: np.ndarray
    ) -> None:
        """``steps`` steps recorded on the device and read back once. Each step is a graph
        captured once per shape, setting and time step (``wp.ScopedCapture``, launched by
        ``wp.capture_launch``, as Newton's examples step), one per state buffer the step
        starts from, since the step swaps the pair."""
        wp, built = self.wp, self.built
        history_q, history_qd, counter = built.history
        if steps > history_q.shape[0]:
            raise ValueError(f"{steps} steps: the history holds {history_q.shape[0]}")
        counter.zero_()
        self._hold(active)
        for _ in range(steps):
            if not self.captured:
                self._step_recording()
            else:
                key = (self.timestep, 0 if self.state is built.states[0] else 1)
                if key not in built.graphs:
                    with wp.ScopedCapture() as capture:
                        self._step_recording()
                    built.graphs[key] = capture.graph
                wp.capture_launch(built.graphs[key])
            self.state, self.next = self.next, self.state
        q[:] = history_q[:steps].numpy()
        qd[:] = history_qd[:steps].numpy()

    def _hold(self, active: np.ndarray) -> None:
        """Mark the inactive worlds held, and keep their state (the chunk's start) for the
        step's ``hold`` kernel to give back."""
        held, *start = self.built.held
        held.assign((~active).astype(np.int32))
        if not active.all():
            for name, array in zip(HELD_STATE, start, strict=True):
                self.wp.copy(array, getattr(self.state, name))

    def _step_recording(self) -> None:
        """One step, the held worlds' state given back, then the new state into the
        history's row ``counter``."""
        hold, record, count = _recording_kernels(self.wp)
        history_q, history_qd, counter = self.built.history
        held, *start = self.built.held
        self._step()
        self.wp.launch(
            hold,
            dim=len(self.scenes),
            inputs=[held, *(getattr(self.next, name) for name in HELD_STATE), *start],
        )
        self.wp.launch(
            record,
            dim=len(self.scenes),
            inputs=[self.next.body_q, self.next.body_qd, counter, history_q, history_qd],
        )
        self.wp.launch(count, dim=1, inputs=[counter])

    def _rows(self, q: np.ndarray, qd: np.ndarray) -> np.ndarray:
        """(W, n, 7) from raw body_q (n, W, 7) and body_qd (n, W, 6): every world's hoop
        centre (x, z), theta (unwrapped: the nearest angle to the last one), centre-of-mass
        velocity (x, z) and spin about y; and the speed bound s = |v| + |omega| |c| (m/s) of
        its velocity's rounding (module doc, Force)."""
        qf, qdf = q.astype(float), qd.astype(float)
        turn = 2.0 * np.arctan2(qf[..., 4], qf[..., 6])
        theta = np.empty_like(turn)
        last = self.theta
        for k, now in enumerate(turn):  # each angle from the last: a sequence, not a vector
            last = last + (now - last + math.pi) % (2 * math.pi) - math.pi
            theta[k] = last
        self.theta = last
        lever = self.lever[None, :]
        speed = (
            np.linalg.norm(qdf[..., :3], axis=-1) + np.linalg.norm(qdf[..., 3:], axis=-1) * lever
        )
        rows = np.stack(
            [qf[..., 0], qf[..., 2], theta, qdf[..., 0], qdf[..., 2], qdf[..., 4], speed], axis=-1
        )
        return np.transpose(rows, (1, 0, 2))


def _step_forces(
    rows: np.ndarray, mass: np.ndarray, gravity: np.ndarray, dt: float, roundings: int
) -> np.ndarray:
    """(W, steps, 2): each step's contact force, N, (normal, friction), from the rows of
    ``_Batch.read`` (W, steps + 1, 7): the momentum balance M dv/dt - M g (module doc,
    Force), and 0 (no contact) where the normal part is within the rounding floor
    N u (s_i + s_{i+1}) / dt + N u g of float32 velocities."""
    dv = np.diff(rows[:, :, 3:5], axis=1) / dt
    g = gravity[:, None]
    normal = dv[..., 1] + g  # per unit mass, m/s^2
    speed = rows[:, :, 6]
    floor = roundings * UNIT_ROUNDOFF * ((speed[:, :-1] + speed[:, 1:]) / dt + g)
    touching = np.abs(normal) > floor  # a pull beyond the floor stays visible (negative)
    m = mass[:, None]
    return np.stack(
        [np.where(touching, m * normal, 0.0), np.where(touching, m * dv[..., 0], 0.0)], -1
    )


def _com_rows(scene: Scene, rows: np.ndarray) -> np.ndarray:
    """(n, 6) centre-of-mass rows (STATE_KEYS) from (n, 6) rows of ``_Batch.read``."""
    X, Y = kinematics.com_position(scene, rows[:, 0], rows[:, 1], rows[:, 2])
    return np.stack([X, Y, rows[:, 2], rows[:, 3], rows[:, 4], rows[:, 5]], axis=-1)


def _start_velocity(scene: Scene) -> list[float]:
    """Newton's body velocity at t = 0: the centre of mass's (x, z) and the spin about y."""
    _, _, _, Xdot, Ydot, thetadot = scene.initial_state()
    return [Xdot, 0.0, Ydot, 0.0, thetadot, 0.0]


_SCRIPT = '''
import warp as wp

wp.config.quiet = True
wp.config.enable_backward = {enable_backward}  # no gradients: no backward kernels compiled
import newton  # after the line above: its modules take the setting when made

# Newton's contact settings of both shapes (the sphere and the ground plane).
SHAPE = dict(
    density=0.0,  # no mass from the geometry: the body's mass and inertia are set below
    mu=MU,  # Coulomb friction (Newton averages the two shapes')
    ke={ke!r},  # contact stiffness, N/m (penalty solvers; MuJoCo maps it to solref)
    kd={kd!r},  # contact damping, N s/m
    kf={kf!r},  # penalty solvers' viscous friction slope, N s/m
    mu_rolling={mu_rolling!r},  # rolling friction, m
    mu_torsional={mu_torsional!r},  # torsional friction
)
CHUNK = {chunk}  # steps between re-reads of the angle, as the run records them
ROUNDINGS = {roundings}  # the rounding floor's count of float32 roundings per velocity
UNIT_ROUNDOFF = {unit_roundoff!r}  # float32's unit roundoff, 2**-24


def build():
    """One world: the ground plane and the hoop, a free body with the hoop's mass, centre of
    mass (0, 0, LAM A) and inertia, and a sphere of radius A (Newton's z is up; the hoop
    turns about +y, theta clockwise from the top)."""
    builder = newton.ModelBuilder(gravity=(0.0, 0.0, -G))
    cfg = newton.ModelBuilder.ShapeConfig(**SHAPE)
    builder.begin_world(gravity=(0.0, 0.0, -G))
    builder.add_ground_plane(cfg=cfg)
    x, y, theta = CENTRE0[0], CENTRE0[1], CENTRE0[2]
    side = 0.5 * I_COM * (1.0 + {pad!r})  # out-of-plane moments, padded as the MJCF pads them
    body = builder.add_body(
        xform=wp.transform((x, 0.0, y), wp.quat_from_axis_angle(wp.vec3(0, 1, 0), theta)),
        com=(0.0, 0.0, COM_OFFSET),
        inertia=wp.mat33(side, 0, 0, 0, I_COM, 0, 0, 0, side),
        mass=M,
        lock_inertia=True,
    )
    builder.add_shape_sphere(body, radius=A, cfg=cfg)
    builder.end_world()
    return builder.finalize()


def simulate():
    with wp.ScopedDevice({device}):
        model = build()
        solver = newton.solvers.{solver}(model{solver_args})
        state, nxt, control = model.state(), model.state(), model.control()
        pipeline = newton.CollisionPipeline(model)
        contacts = pipeline.contacts()
        # body_qd: the centre of mass's velocity (x, y, z) and the angular velocity
        qd0 = [[COM0[3], 0.0, COM0[4], 0.0, COM0[5], 0.0]]
        state.body_qd.assign(np.array(qd0, dtype=np.float32))
        newton.eval_ik(model, state, state.joint_q, state.joint_qd)
        last_theta = np.array([THETA0])
        lever = np.array([abs(COM_OFFSET)])

        def read():
            """(1, 7): centre (x, z), theta unwrapped, velocity (x, z), spin, speed bound."""
            nonlocal last_theta
            q = state.body_q.numpy().astype(float)
            qd = state.body_qd.numpy().astype(float)
            turn = 2.0 * np.arctan2(q[:, 4], q[:, 6])
            last_theta = last_theta + (turn - last_theta + np.pi) % (2 * np.pi) - np.pi
            speed = np.linalg.norm(qd[:, :3], axis=1) + np.linalg.norm(qd[:, 3:], axis=1) * lever
            return np.stack([q[:, 0], q[:, 2], last_theta, qd[:, 0], qd[:, 2], qd[:, 4], speed], -1)

        graphs = {{}}  # a step captured once per state buffer it starts from (the pair swaps)

        def step():
            state.clear_forces()
            pipeline.collide(state, contacts)
            solver.step(state, nxt, control, contacts, DT)

        def advance(steps):
            """The rows before and after each of ``steps`` steps, and each step's force, N:
            the momentum balance, 0 within the float32 rounding floor (no contact). Each step
            is a captured graph replayed, as Newton's examples step."""
            nonlocal state, nxt
            raw = [read()]
            for _ in range(steps):
                if id(state) not in graphs:
                    with wp.ScopedCapture() as capture:
                        step()
                    graphs[id(state)] = capture.graph
                wp.capture_launch(graphs[id(state)])
                state, nxt = nxt, state
                raw.append(read())
            rows = np.stack(raw, axis=1)  # (1, steps + 1, 7)
            dv = np.diff(rows[:, :, 3:5], axis=1) / DT
            g = np.array([G])[:, None]
            normal = dv[..., 1] + g
            speed = rows[:, :, 6]
            floor = ROUNDINGS * UNIT_ROUNDOFF * ((speed[:, :-1] + speed[:, 1:]) / DT + g)
            touching = np.abs(normal) > floor
            m = np.array([M])[:, None]
            forces = np.stack(
                [np.where(touching, m * normal, 0.0), np.where(touching, m * dv[..., 0], 0.0)], -1
            )
            return rows[0], forces[0]

        blocks, forces, done = [], [], 0
        while done < N_STEPS:  # no divergence checks: the whole window
            rows, f = advance(min(CHUNK - done % CHUNK, N_STEPS - done))
            if blocks:  # a chunk's first row restates the last one
                blocks[-1] = blocks[-1][:-1]
            blocks.append(rows)
            forces.append(f)
            done += len(f)
        forces.append(advance(1)[1])  # the last state's force: one step more
    rows = np.concatenate(blocks)
    force = np.concatenate(forces) / M
    state_ = com_state(rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3], rows[:, 4], rows[:, 5])
    return {{**state_, "Xdot": rows[:, 3], "Ydot": rows[:, 4], "thetadot": rows[:, 5],
            "normal_force": force[:, 0], "friction_force": force[:, 1]}}
'''
"""The engine part of ``hoopbench export`` (engines/standalone.py): the adapter's run of one
world, the same calls in the same order and the same float expressions."""
