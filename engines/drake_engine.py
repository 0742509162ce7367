"""Drake adapter: the hoop as a MultibodyPlant with one planar joint, point contact on a half space.

The model is the SDFormat of :func:`hoopbench.models.sdformat.scene_to_sdformat`, loaded with
Drake's ``Parser`` (see there for frames, the planar joint and how each contact value is written
so that Drake's combination rules give the pair exactly the wanted one). The adapter sets what
the model file cannot:

* gravity: Drake's default is 9.81 m/s^2 along -z; the plant gets the scene's g;
* contact model: Drake's default is ``hydroelastic_with_fallback``; hoopbench asks for
  ``point`` (the sphere-half-space pair has no hydroelastic properties either way);
* point-contact stiffness and Hunt-Crossley dissipation come from ``penetration_allowance``
  with Drake's own rule (``MultibodyPlant::EstimatePointContactParameters``): the pair's
  stiffness is M g / penetration_allowance and its dissipation, critically damped,
  sqrt(penetration_allowance / g) / penetration_allowance, written into the model (2 k per
  geometry: stiffnesses combine in series). In Drake 1.51 that rule never acts by itself:
  SceneGraph's default proximity properties give every geometry without values 1e6 N/m and
  50 s/m (the stock profile, ``penetration_allowance = None``, shows what that does).

Stepping. A ``Simulator`` advances the diagram in chunks of ``CHUNK_STEPS`` steps. One
``VectorLogSink``, publishing every timestep in C++, records the plant's state
(q = (x, y - a, -theta), v = their rates, of the hoop centre) and the hoop's generalized
contact forces (the force along world x and z and the torque about the centre, from the planar
joint's frame), joined by a ``Multiplexer``. Against a bare ``AdvanceTo`` of the same plant
this costs 1.06-1.12x (docs/engines.md, Drake, Cost; ``make bench``). A discrete plant's force
port is sampled: the force logged at t_(i+1) is the one the solver applied over the step from
t_i, so row i of the trajectory gets it (the state it was computed from), and one extra step
gives the last row its force. A continuous plant's force is that of the logged state itself.

Soft contact start. Drake's point contact is a spring: a hoop started exactly touching gets no
force in its first step and rings. As for MuJoCo, the hoop starts at the penetration where the
contact holds the centre with zero vertical acceleration over the first step (a root of one
simulator step of the plant, whose discrete update Drake does not expose by itself, or of its
time derivatives for a continuous plant); the first
recorded normal force is then the rolling one and the recorded clearance at t = 0 that small
negative number. A scene that leaves the floor at once starts touching.

Options and variants (measurements in docs/engines.md, "Drake"): each discrete contact
approximation the pinned Drake offers is a variant, and so is the continuous plant
(``time_step = 0``, error-controlled integration).
"""

from __future__ import annotations

import logging
import math
from collections.abc import Iterator
from contextlib import AbstractContextManager, contextmanager, nullcontext
from dataclasses import dataclass, field
from types import ModuleType
from typing import Any

import numpy as np

from hoopbench.engines.base import Chunk, Engine, equilibrium_depth, import_engine
from hoopbench.engines.options import (
    Option,
    Variant,
    choice,
    linear_range,
    log_range,
    number,
    one_of,
    optional,
)
from hoopbench.engines.registry import register
from hoopbench.engines.settings import RunSettings
from hoopbench.models import kinematics
from hoopbench.models.scene import Scene
from hoopbench.models.sdformat import MODEL_NAME, check_restitution, scene_to_sdformat
from hoopbench.models.trajectory import Trajectory

__all__ = ["APPROXIMATIONS", "CONTACT_MODELS", "INTEGRATION_SCHEMES", "DrakeEngine", "DrakeModel"]

APPROXIMATIONS: tuple[str, ...] = ("tamsi", "sap", "similar", "lagged")
"""Drake's discrete contact approximations (MultibodyPlantConfig.discrete_contact_approximation)
in the pinned version. TAMSI is deprecated there, for removal on or after 2026-09-01."""

CONTACT_MODELS: tuple[str, ...] = ("point", "hydroelastic_with_fallback")
"""Contact models that work without hydroelastic properties (the model writes none)."""

INTEGRATION_SCHEMES: tuple[str, ...] = (
    "runge_kutta3",
    "runge_kutta5",
    "bogacki_shampine3",
    "implicit_euler",
    "radau3",
    "velocity_implicit_euler",
)
"""Error-controlled integrators of Drake's Simulator, for a continuous plant (time_step = 0)."""

_MODULES = (
    "pydrake",
    "pydrake.multibody.parsing",
    "pydrake.multibody.plant",
    "pydrake.systems.analysis",
    "pydrake.systems.framework",
    "pydrake.systems.primitives",
)


_DRAKE_ALLOWANCE = 1e-3
"""MultibodyPlantConfig's penetration_allowance, m: given to the plant when the option is None.
It does not act: SceneGraph's default proximity properties give every geometry a stiffness."""


def _check_time_step(name: str, value: Any) -> float | None:
    """None (a discrete plant stepping at the run's timestep) or 0 (a continuous plant)."""
    if value is None:
        return None
    if isinstance(value, int | float) and not isinstance(value, bool) and value == 0:
        return 0.0
    raise ValueError(
        f"{name} must be None (a discrete plant at the run's timestep) or 0 (a continuous "
        f"plant), got {value!r}"
    )


@contextmanager
def _quiet_drake() -> Iterator[None]:
    """Drake's warnings while a plant is built (TAMSI's deprecation, half spaces not taking
    part in deformable contact) say nothing about a run: kept off stderr, level restored."""
    logger = logging.getLogger("drake")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


def contact_parameters(scene: Scene, penetration_allowance: float) -> tuple[float, float]:
    """(stiffness N/m, Hunt-Crossley dissipation s/m) of the pair, by Drake's own rule
    (MultibodyPlant::EstimatePointContactParameters, with the hoop's mass and the scene's g):
    a static penetration of ``penetration_allowance`` under the weight, critically damped."""
    stiffness = scene.M * scene.g / penetration_allowance
    time_scale = math.sqrt(scene.M / stiffness)
    return stiffness, time_scale / penetration_allowance


@dataclass
class DrakeModel:
    """A built diagram, ready to step from the scene's initial state."""

    simulator: Any
    plant: Any
    plant_context: Any
    log: Any | None
    """VectorLogSink of [q; v; generalized contact forces], or None (a bare model)."""
    discrete: bool
    start_depth: float = 0.0
    """m: how far into the floor the hoop starts (the soft contact's equilibrium)."""


@register
class DrakeEngine(Engine):
    """Drake's MultibodyPlant with point contact, stepped by its Simulator."""

    name = "drake"
    distribution = "drake"
    modules = _MODULES
    model_format = "SDFormat (XML, with Drake's drake: extensions)"
    options = (
        Option(
            "discrete_contact_approximation",
            "tamsi",
            choice(*APPROXIMATIONS),
            "TAMSI (deprecated in Drake, hence the pin): seed-mu slip +0.04 ms and the exact "
            "phase sequences of seed-mu, slip-reversal and every hop scene. lagged (Drake's "
            "default) costs ~4x per step and its Coulomb slip starts later (seed-mu, dt 1e-4: "
            "+3.1 ms by the contact force against +0.2; -0.3 ms by slip velocity); SAP and "
            "similar kick a sliding stiff contact off the floor: false lift-offs in every "
            "scene that slips",
            stock="lagged",
            space=one_of(*APPROXIMATIONS),
        ),
        Option(
            "time_step",
            None,
            _check_time_step,
            "None: a discrete plant stepping at the run's timestep; 0: a continuous plant, "
            "integrated with error control and sampled at the run's timestep",
            space=one_of(None, 0.0),
        ),
        Option(
            "contact_model",
            "point",
            choice(*CONTACT_MODELS),
            "the issue's choice, explicit: Drake's default hydroelastic_with_fallback falls back "
            "to point contact here, as the model gives no hydroelastic properties",
            stock="hydroelastic_with_fallback",
            space=one_of(*CONTACT_MODELS),
        ),
        Option(
            "penetration_allowance",
            1e-6,
            optional(number(low=0.0, low_open=True, unit="m")),
            "static penetration under the weight: pair stiffness M g / allowance (2x per "
            "geometry), critically damped, Drake's rule. None writes nothing: SceneGraph's "
            "1e6 N/m per geometry acts. 1e-6 m: at 1e-5 the 0.2 mm deep contact of hop-top "
            "(420 g) read as a 2 mm/s slip (s uses radius a) and hid a re-stick; TAMSI stopped "
            "converging on hop-low at 1e-7",
            stock=None,
            space=log_range(1e-8, 1e-2, or_none=True),
        ),
        Option(
            "stiction_tolerance",
            1e-5,
            number(low=0.0, low_open=True, unit="m/s"),
            "regularized friction (TAMSI, similar, lagged, continuous): slip creeps at up to "
            "this speed while rolling; Drake's 1e-4 put seed-mu's slip onset 0.7 ms early, "
            "1e-5 puts it +0.04 ms",
            stock=1e-4,
            space=log_range(1e-7, 1e-2),
        ),
        Option(
            "relaxation_time",
            0.0,
            optional(number(low=0.0, unit="s")),
            "SAP only, the pair's (half written per geometry: Drake adds them). None: Drake's "
            "0.1 s per geometry, with which a sliding hoop climbed 38 mm in 20 ms at any "
            "timestep; 0 leaves SAP's O(dt) gliding (4 mm at dt 1e-4, 0.03 mm at 2.5e-5)",
            stock=None,
            space=linear_range(0.0, 0.1, or_none=True),
        ),
        Option(
            "sap_near_rigid_threshold",
            1.0,
            number(low=0.0),
            "Drake's default; 0 (no near-rigid regularization) left SAP's false lift-offs as "
            "they were",
            space=linear_range(0.0, 2.0),
        ),
        Option(
            "integration_scheme",
            "implicit_euler",
            choice(*INTEGRATION_SCHEMES),
            "continuous plant only. Drake's explicit runge_kutta3 needed 16 ms per 1e-4 s "
            "sample on the stiff contact and friction; implicit_euler ~0.3-0.7 ms, and hop-top "
            "within 0.5 ms and 0.5 %",
            stock="runge_kutta3",
            space=one_of(*INTEGRATION_SCHEMES),
        ),
        Option(
            "accuracy",
            1e-4,
            number(low=0.0, low_open=True, high=1.0),
            "continuous plant only: Drake's default (error control's target accuracy)",
            space=log_range(1e-8, 0.1),
        ),
    )
    variants = (
        Variant(
            "discrete_contact_approximation=sap", options={"discrete_contact_approximation": "sap"}
        ),
        Variant(
            "discrete_contact_approximation=similar",
            options={"discrete_contact_approximation": "similar"},
        ),
        Variant(
            "discrete_contact_approximation=lagged",
            options={"discrete_contact_approximation": "lagged"},
        ),
        Variant(
            "sap,relaxation_time=0.2",
            options={"discrete_contact_approximation": "sap", "relaxation_time": 0.2},
        ),
        Variant("time_step=0", options={"time_step": 0}),
    )

    # ----------------------------------------------------------------- hooks
    def _import(self) -> ModuleType:
        return import_engine(*self.modules)

    def _check(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> None:
        """Restitution != 0 raises ValueError before a run (Drake's point contact has none)."""
        check_restitution(settings.restitution)

    def _model_text(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        allowance = options["penetration_allowance"]
        stiffness, dissipation = (
            (None, None) if allowance is None else contact_parameters(scene, allowance)
        )
        settings_text = ", ".join(f"{k}={v}" for k, v in sorted(options.items()))
        comment = (
            "Written by hoopbench (models/sdformat.py) for Drake's Parser.\n"
            f"  scene {scene.name or '(unnamed)'!r}: "
            + ", ".join(f"{k}={v}" for k, v in scene.to_dict().items() if k != "name")
            + f"\n  mu={self.mu_for(scene, settings)!r}, timestep={settings.timestep!r} s\n"
            f"  drake options: {settings_text}\n"
            "Set on the plant, not in this file: gravity (0, 0, -g), the contact model, the\n"
            "time step and contact approximation; the state (x, y - a, -theta) and its rates."
        )
        return scene_to_sdformat(
            scene,
            mu=self.mu_for(scene, settings),
            stiffness=stiffness,
            dissipation=dissipation,
            relaxation_time=options["relaxation_time"],
            restitution=settings.restitution,
            comment=comment,
        )

    def _script(self, scene: Scene, settings: RunSettings, options: dict[str, Any]) -> str:
        model_text = self._model_text(scene, settings, options)
        if '"""' in model_text or "\\" in model_text:
            raise ValueError("drake export: the model text cannot be embedded as a literal")
        discrete = options["time_step"] is None
        # The start depth is a root of the built diagram's own step (found with scipy, which
        # the script does not import): written as its value.
        depth = self._build(self._import(), scene, settings, options, record=True).start_depth
        continuous = (
            ""
            if discrete
            else _CONTINUOUS_CONFIG.format(
                scheme=options["integration_scheme"], accuracy=float(options["accuracy"])
            )
        )
        return _SCRIPT.format(
            model=model_text,
            discrete=discrete,
            depth=depth,
            time_step=settings.timestep if discrete else 0.0,
            contact_model=options["contact_model"],
            approximation=options["discrete_contact_approximation"],
            allowance=options["penetration_allowance"] or _DRAKE_ALLOWANCE,
            stiction=options["stiction_tolerance"],
            near_rigid=options["sap_near_rigid_threshold"],
            model_name=MODEL_NAME,
            continuous_config=continuous,
        )

    # ----------------------------------------------------------------- model
    def build(
        self, scene: Scene, settings: RunSettings | None = None, *, record: bool = True
    ) -> DrakeModel:
        """The diagram a run steps, at the scene's initial state. ValueError for bad options."""
        settings = settings or RunSettings()
        options = self.check(scene, settings)
        return self._build(self._import(), scene, settings, options, record=record)

    def _build(
        self,
        module: ModuleType,
        scene: Scene,
        settings: RunSettings,
        options: dict[str, Any],
        *,
        record: bool,
    ) -> DrakeModel:
        from pydrake.multibody.parsing import Parser
        from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
        from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
        from pydrake.systems.framework import DiagramBuilder
        from pydrake.systems.primitives import LogVectorOutput, Multiplexer

        dt = settings.timestep
        discrete = options["time_step"] is None
        config = MultibodyPlantConfig(
            time_step=dt if discrete else 0.0,
            contact_model=options["contact_model"],
            discrete_contact_approximation=options["discrete_contact_approximation"],
            penetration_allowance=options["penetration_allowance"] or _DRAKE_ALLOWANCE,
            stiction_tolerance=options["stiction_tolerance"],
            sap_near_rigid_threshold=options["sap_near_rigid_threshold"],
        )
        builder = DiagramBuilder()
        with _quiet_drake():
            plant, _scene_graph = AddMultibodyPlant(config, builder)
            Parser(plant).AddModelsFromString(self._model_text(scene, settings, options), "sdf")
            plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -scene.g])
            plant.Finalize()
        log = None
        if record:
            # One logger (one publish event per step) for [state; generalized contact forces].
            instance = plant.GetModelInstanceByName(MODEL_NAME)
            forces = plant.get_generalized_contact_forces_output_port(instance)
            state = plant.get_state_output_port()
            mux = builder.AddSystem(Multiplexer([state.size(), forces.size()]))
            builder.Connect(state, mux.get_input_port(0))
            builder.Connect(forces, mux.get_input_port(1))
            log = LogVectorOutput(mux.get_output_port(0), builder, dt)
        with _quiet_drake():
            diagram = builder.Build()
            simulator = Simulator(diagram)
        if not discrete:
            ApplySimulatorConfig(
                SimulatorConfig(
                    integration_scheme=options["integration_scheme"],
                    accuracy=options["accuracy"],
                    max_step_size=dt,
                    use_error_control=True,
                ),
                simulator,
            )
        context = simulator.get_mutable_context()
        plant_context = plant.GetMyMutableContextFromRoot(context)
        model = DrakeModel(simulator, plant, plant_context, log, discrete)
        self._set_initial_state(model, scene)
        return model

    def _set_initial_state(self, model: DrakeModel, scene: Scene) -> None:
        X, Y, theta, Xdot, Ydot, thetadot = scene.initial_state()
        x, y = kinematics.centre_position(scene, X, Y, theta)
        xdot, ydot = kinematics.centre_velocity(scene, Xdot, Ydot, theta, thetadot)
        plant, context = model.plant, model.plant_context
        q = np.array([float(x), float(y) - scene.a, -theta])
        plant.SetPositions(context, q)
        plant.SetVelocities(context, np.array([float(xdot), float(ydot), -thetadot]))
        model.start_depth = _equilibrium_penetration(model, scene.a)
        q[1] -= model.start_depth
        plant.SetPositions(context, q)
        if model.log is not None:
            model.log.FindMutableLog(model.simulator.get_mutable_context()).Clear()

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
        """The diagram, initialized; a bare one has no logger."""
        model = self._build(module, scene, settings, options, record=record)
        simulator = model.simulator
        # A model built with record=True has a logger, a bare one none.
        log = None if model.log is None else model.log.FindLog(simulator.get_context())
        simulator.Initialize()  # the logger's sample at t = 0
        return nullcontext(_Run(model, scene, settings.timestep, log))

    def _advance(self, run: _Run, done: int, steps: int, last: bool) -> Chunk:
        """Advance to the chunk's last sample and take the logger's samples out."""
        # A discrete plant's last force comes from one step more. The logger publishes on
        # the grid k*dt; stopping half a step past the chunk's last sample keeps a rounded
        # stop time from leaving that sample out.
        if run.log is None:
            raise RuntimeError("a bare Drake model has no logger: only _step_bare steps it")
        extra = 1 if run.model.discrete and last else 0
        run.model.simulator.AdvanceTo((done + steps + extra + 0.5) * run.timestep)
        run.chunks.append(np.array(run.log.data()))  # a copy: data() is a view of the log
        run.log.Clear()
        # The logger's samples end at step done + steps + extra (published on k*dt).
        return Chunk(_our_state(run.scene, run.chunks[-1]), done + steps + extra)

    def _trajectory(self, run: _Run, done: int, ended_early: bool) -> Trajectory:
        rows = np.hstack(run.chunks)
        state, force = rows[:6], rows[6:]
        if run.model.discrete:
            force = force[:, 1:]  # row i: the force of the step from state i
        n = min(done + 1, state.shape[1], force.shape[1])
        if not ended_early and n != done + 1:
            raise RuntimeError(f"Drake's logger recorded {n} samples, expected {done + 1}")
        state, force = state[:, :n], force[:, :n]
        # The planar joint's generalized forces: along world x, along world z, about -y.
        return Trajectory.from_steps(
            run.scene,
            run.timestep,
            _our_state(run.scene, state),
            normal_force=force[1] / run.scene.M,
            friction_force=force[0] / run.scene.M,
        )

    def _step_bare(self, run: _Run, steps: int) -> None:
        """``Simulator.AdvanceTo`` over the steps, no logger: Drake's own cost."""
        run.model.simulator.AdvanceTo((steps + 0.5) * run.timestep)


_SCRIPT = '''
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import AddMultibodyPlant, MultibodyPlantConfig
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import LogVectorOutput, Multiplexer

MODEL = """{model}"""
"""The SDFormat model: the hoop link on a planar joint (x, z - A, turn about -y) over a
half-space floor; mass, centre of mass and inertia from the scene; point-contact values per
geometry such that Drake's combination rules give the pair the wanted ones."""

DISCRETE = {discrete!r}  # True: a discrete plant stepping at DT; False: a continuous plant
START_DEPTH = {depth!r}
"""m: the hoop starts this far into the floor, where one step of the plant holds its centre
with zero vertical acceleration (found by root finding on this same diagram when exported;
0: the hoop starts touching)."""
CHUNK = 1000
"""Steps per Simulator.AdvanceTo: the run advanced in chunks (a continuous plant's integrator
stops at each chunk end, so the chunks are kept to reproduce it exactly)."""


def build():
    """The diagram: plant and scene graph, the model parsed, gravity set; one logger of the
    state [q; v] and the hoop's generalized contact forces, sampled every DT."""
    config = MultibodyPlantConfig(
        time_step={time_step!r},  # s; 0: continuous
        contact_model={contact_model!r},
        discrete_contact_approximation={approximation!r},
        penetration_allowance={allowance!r},  # m
        stiction_tolerance={stiction!r},  # m/s, regularized friction
        sap_near_rigid_threshold={near_rigid!r},
    )
    builder = DiagramBuilder()
    plant, scene_graph = AddMultibodyPlant(config, builder)
    Parser(plant).AddModelsFromString(MODEL, "sdf")
    plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, -G])  # Drake's z is up
    plant.Finalize()
    instance = plant.GetModelInstanceByName({model_name!r})
    forces = plant.get_generalized_contact_forces_output_port(instance)
    state = plant.get_state_output_port()
    mux = builder.AddSystem(Multiplexer([state.size(), forces.size()]))
    builder.Connect(state, mux.get_input_port(0))
    builder.Connect(forces, mux.get_input_port(1))
    logger = LogVectorOutput(mux.get_output_port(0), builder, DT)
    diagram = builder.Build()
    simulator = Simulator(diagram)
{continuous_config}
    return simulator, plant, logger


def simulate():
    """Step the window and read the logger: row i the state at i DT and, for a discrete plant,
    the contact force of the step from it (logged at the next sample: one more step gives the
    last row its force), for a continuous plant the force at that state."""
    simulator, plant, logger = build()
    context = plant.GetMyMutableContextFromRoot(simulator.get_mutable_context())
    x, y, theta, xdot, ydot, thetadot = CENTRE0
    q = np.array([x, y - A, -theta])  # the planar joint: x, height above A, turn = -theta
    plant.SetPositions(context, q)
    plant.SetVelocities(context, np.array([xdot, ydot, -thetadot]))
    q[1] -= START_DEPTH
    plant.SetPositions(context, q)
    simulator.Initialize()  # the logger's sample at t = 0
    for done in range(0, N_STEPS, CHUNK):
        steps = min(CHUNK, N_STEPS - done)
        extra = 1 if DISCRETE and done + steps == N_STEPS else 0
        # half a step past the chunk's last sample: a rounded stop time keeps that sample
        simulator.AdvanceTo((done + steps + extra + 0.5) * DT)
    rows = np.array(logger.FindLog(simulator.get_context()).data())
    state, force = rows[:6], rows[6:]
    if DISCRETE:
        force = force[:, 1:]
    state, force = state[:, : N_STEPS + 1], force[:, : N_STEPS + 1]
    # generalized contact forces of the planar joint: along world x, along world z, turn
    com = com_state(state[0], A + state[1], -state[2], state[3], state[4], -state[5])
    return {{**com, "normal_force": force[1] / M, "friction_force": force[0] / M}}
'''
"""Drake's part of a standalone script (engines/standalone.py), as a pydrake user writes it."""

_CONTINUOUS_CONFIG = """    ApplySimulatorConfig(
        SimulatorConfig(
            integration_scheme={scheme!r},
            accuracy={accuracy!r},
            max_step_size=DT,
            use_error_control=True,
        ),
        simulator,
    )"""


@dataclass
class _Run:
    """One run's diagram and the logger's samples taken out of it."""

    model: DrakeModel
    scene: Scene
    timestep: float
    log: Any | None
    """The VectorLog in the simulator's context (None: a bare model)."""
    chunks: list[np.ndarray] = field(default_factory=list)
    """The logger's samples per chunk: rows [q; v; generalized contact forces]."""


def _our_state(scene: Scene, raw: np.ndarray) -> dict[str, np.ndarray]:
    """Plant state rows (x, y - a, phi, xdot, ydot, phidot; phi = -theta) -> our COM state."""
    return kinematics.com_state(scene, raw[0], scene.a + raw[1], -raw[2], raw[3], raw[4], -raw[5])


def _vertical_acceleration(model: DrakeModel, q: np.ndarray, v: np.ndarray) -> float:
    """The hoop centre's vertical acceleration from state (q, v) at t = 0: over one step of the
    simulator for a discrete plant (its update is not exposed by itself), else the time
    derivative. Leaves the plant in its default state at (q, v), t = 0."""
    plant, context = model.plant, model.plant_context
    root = model.simulator.get_mutable_context()
    root.SetTime(0.0)
    plant.SetDefaultState(context, context.get_mutable_state())
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    if not model.discrete:
        derivatives = plant.EvalTimeDerivatives(context).get_vector().CopyToVector()
        return float(derivatives[plant.num_positions() + 1])
    dt = plant.time_step()
    model.simulator.Initialize()
    model.simulator.AdvanceTo(dt)
    v1 = plant.GetVelocities(context)[1]
    root.SetTime(0.0)
    plant.SetDefaultState(context, context.get_mutable_state())
    plant.SetPositions(context, q)
    plant.SetVelocities(context, v)
    return float((v1 - v[1]) / dt)


def _equilibrium_penetration(model: DrakeModel, a: float) -> float:
    """Penetration, m, at which the contact holds the hoop centre with zero vertical
    acceleration; 0 if the hoop, exactly touching, would leave the floor. The acceleration
    rises monotonically as the hoop sinks: a doubling bracket and Brent's method find it.
    Leaves the plant at t = 0 in its default state with the positions and velocities it had."""
    plant, context = model.plant, model.plant_context
    q = plant.GetPositions(context).copy()
    v = plant.GetVelocities(context).copy()
    y0 = q[1]

    def accel(depth: float) -> float:
        q[1] = y0 - depth
        return _vertical_acceleration(model, q, v)

    try:
        return equilibrium_depth(accel, a, first=1e-9, xtol=1e-16, maxiter=200)
    finally:
        q[1] = y0
        model.simulator.get_mutable_context().SetTime(0.0)
        plant.SetDefaultState(context, context.get_mutable_state())
        plant.SetPositions(context, q)
        plant.SetVelocities(context, v)
