"""Every engine against the exact reference, with the one tolerance table
(engines/judging/tolerances.toml): engines within [loose], the reference within [tight].

These regression tests read the detectors' events (the kinematic reading, hb's kin_events),
as their expected failures were measured; the verdict reads the canonical reading.

One run per (engine, scene) is cached for the whole module: the engines are the slow part.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from conftest import engine_unavailable

from hoopbench.engines.base import DivergenceLimits, EngineUnavailableError, WorldsEngine
from hoopbench.engines.judging.tolerances import Tier, event_tolerances, tolerances
from hoopbench.engines.registry import engine_class, engine_names, get_engine
from hoopbench.engines.run import RunResult, RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene, scene_names
from hoopbench.models.scene import Scene
from hoopbench.reference.exact import solve_exact

TOL = tolerances()
ENGINES = [
    name
    for name in engine_names()
    if name != "reference" and not issubclass(engine_class(name), WorldsEngine)
]
"""The engines judged here at dt 1e-4. The batched simulators (MJX, MuJoCo Warp, Newton) are
not: on the CPU a step of theirs costs 0.1-30 ms (MuJoCo Warp's RK4: 16,000 steps of the seed
would take minutes each); tests/test_mjx.py, test_mjwarp.py and test_newton.py check them at
dt 1e-3, MJX and MuJoCo Warp against MuJoCo C, and the suites judge them at 1e-3."""
HOP_SCENES = [name for name in scene_names() if name.startswith("hop")]
SEED_MU = 0.8
TIMESTEP = 1e-4


def seed_scene() -> Scene:
    """The seed scene with one friction coefficient, as every engine can represent it."""
    return get_scene("seed").with_(mus=SEED_MU, muk=SEED_MU, t_end=1.6)


@cache
def run(engine: str, scene_name: str, timestep: float = TIMESTEP) -> RunResult:
    scene = seed_scene() if scene_name == "seed" else get_scene(scene_name)
    result = get_engine(engine).run(scene, RunSettings(timestep=timestep))
    if result.info.status is RunStatus.UNAVAILABLE:
        engine_unavailable(engine, result.info.message)
    return result


@cache
def exact(scene_name: str):
    scene = seed_scene() if scene_name == "seed" else get_scene(scene_name)
    return solve_exact(scene.with_(muk=scene.mus)).events


def test_hop_scenes_exist():
    assert len(HOP_SCENES) >= 2, "the catalogue must hold at least two hop scenes"


@pytest.mark.parametrize("engine", ENGINES)
def test_seed_runs_clean(engine):
    result = run(engine, "seed")
    assert result.info.status is RunStatus.OK, result.info.message
    traj = result.trajectory
    assert np.isfinite(traj.to_frame().drop(columns="contact").to_numpy()).all()
    assert result.info.n_steps == pytest.approx(seed_scene().t_end / TIMESTEP, abs=1)
    assert result.info.mu == SEED_MU


def _expected_failures(reasons: dict[str, str]) -> list:
    """ENGINES as parameters, those in ``reasons`` marked as strict expected failures."""
    return [
        pytest.param(e, marks=pytest.mark.xfail(strict=True, reason=reasons[e]))
        if e in reasons
        else e
        for e in ENGINES
    ]


_KINEMATIC_LAG = {
    "pybullet": "the free base's rolling creep, about lam a thetadot^2 |sin theta| dt at the "
    "recorded pose (engines/pybullet_engine.py), reaches the 1 mm/s slip threshold early: "
    "refined onset -10.6 ms at dt 1e-4 (measured; by the contact force +0.1 ms, and the chain "
    "+0.1 ms)",
}


@pytest.mark.parametrize("engine", _expected_failures(_KINEMATIC_LAG))
def test_seed_slip_onset(engine):
    """Refined slip onset within [loose] t_slip_s and [slip] theta_deg of the exact onset for
    the same mu."""
    events = run(engine, "seed").events
    ref = exact("seed")
    assert events.t_slip is not None, "no slip detected"
    limit = event_tolerances(Tier.LOOSE).t_slip
    assert abs(events.t_slip - ref.t_slip) <= limit, (events.t_slip, ref.t_slip)
    dtheta = math.degrees(abs(events.theta_slip - ref.theta_slip))
    assert dtheta <= TOL["slip"]["theta_deg"], f"slip angle off by {dtheta:.3f} deg"


@pytest.mark.parametrize("engine", ENGINES)
def test_energy_before_slip(engine):
    result = run(engine, "seed")
    traj = result.trajectory
    before = traj.t < result.events.t_slip
    rise = (traj.energy[before].max() - traj.energy[0]) / traj.energy[0]
    assert rise <= TOL["slip"]["energy_rise"], f"energy rose by {rise:.2%} before slip"


@pytest.mark.parametrize("engine", ENGINES)
def test_rolling_conventions(engine):
    """Rolling from the top: theta increases, no slip, hoop centre on the floor."""
    traj = run(engine, "seed").trajectory
    rolling = traj.t < 0.5
    assert np.all(np.diff(traj.theta[rolling]) > 0)
    assert np.max(np.abs(traj.slip_velocity[rolling])) < 1e-3
    assert np.max(np.abs(traj.clearance[rolling])) < 1e-3
    assert np.median(traj.normal_force[rolling]) > 0


_CONTACT_FLICKER = {
    "rapier": "Rapier's speculative contact has no impulse on 0.14 % of the seed's rolling "
    "steps in its first 0.5 s (measured: the hoop sinks and rises by micrometres as its soft "
    "position correction acts)",
    "pymunk": "pymunk keeps a contact only while the shapes overlap; with the weight in the "
    "upper half each step lifts the centre by ~lam a cos(theta) (thetadot dt)^2 / 2, so "
    "6.4 % of the steps in the seed's first 0.5 s have no contact force (measured)",
}


@pytest.mark.parametrize("engine", _expected_failures(_CONTACT_FLICKER))
def test_contact_force_at_every_rolling_step(engine):
    """Rolling on the floor: the engine reports a contact force at every step."""
    traj = run(engine, "seed").trajectory
    rolling = traj.t < 0.5
    lost = 1.0 - traj.contact[rolling].mean()
    assert lost == 0.0, f"no contact force in {lost:.1%} of the rolling steps"


@pytest.mark.parametrize("engine", ENGINES)
def test_friction_coefficient_is_mu(engine):
    """During a slip |f|/n is the pair's coefficient: the combination rule is undone."""
    result = run(engine, "seed")
    traj, ref = result.trajectory, exact("seed")
    slip_end = ref.phases[1].t_end
    window = (traj.t > ref.t_slip + 0.03) & (traj.t < slip_end - 0.03)
    window &= traj.normal_force > 0.2 * get_scene("seed").g
    assert window.sum() > 100
    ratio = np.median(np.abs(traj.friction_force[window]) / traj.normal_force[window])
    assert ratio == pytest.approx(SEED_MU, rel=TOL["friction"]["ratio_rel"])


def _hop_cases():
    for engine in ["reference", *ENGINES]:
        xfails = TOL["hop"].get(engine, {}).get("xfail", {})
        for scene in HOP_SCENES:
            marks = []
            if scene in xfails:
                marks.append(pytest.mark.xfail(strict=True, reason=xfails[scene]))
            yield pytest.param(engine, scene, marks=marks, id=f"{engine}-{scene}")


@pytest.mark.parametrize(("engine", "scene_name"), list(_hop_cases()))
def test_hop(engine, scene_name):
    """Lift-off, hop height and impact against the exact solver: [loose] (the reference:
    [tight]), with the known failures of [hop.<engine>.xfail]."""
    result = run(engine, scene_name)
    assert result.info.status is RunStatus.OK, result.info.message
    ref = exact(scene_name)
    assert ref.t_lift is not None
    tol = event_tolerances(Tier.TIGHT if engine == "reference" else Tier.LOOSE)
    events = result.events
    assert events.t_lift is not None, "no lift-off detected"
    assert events.t_impact is not None, "no impact detected"
    assert abs(events.t_lift - ref.t_lift) <= tol.t_lift, (events.t_lift, ref.t_lift)
    assert abs(events.t_impact - ref.t_impact) <= tol.t_impact, (events.t_impact, ref.t_impact)
    assert events.hop_height == pytest.approx(ref.hop_height, rel=tol.hop_height_rel)


@pytest.mark.parametrize("engine", ["reference", *ENGINES])
def test_unknown_setting_is_an_error(engine):
    with pytest.raises(ValueError, match=r"unknown .* setting.*no_such_knob"):
        get_engine(engine).run(seed_scene(), RunSettings(options={"no_such_knob": 1}))


@pytest.mark.parametrize("engine", ["reference", *ENGINES])
def test_unknown_geometry_is_an_error(engine):
    with pytest.raises(ValueError, match="geometry 'teapot' is not available"):
        get_engine(engine).run(seed_scene(), RunSettings(geometry="teapot"))


def test_unknown_engine_is_an_error():
    known = ", ".join(engine_names())
    with pytest.raises(ValueError, match=f"^unknown engine 'bullet3'; known: {known}$"):
        get_engine("bullet3")
    assert known.startswith("reference, ")


@pytest.mark.parametrize("engine", ENGINES)
def test_missing_engine_is_reported(engine, monkeypatch):
    adapter = get_engine(engine)

    def missing():
        raise EngineUnavailableError(f"{engine} is not installed")

    monkeypatch.setattr(adapter, "_import", missing)
    result = adapter.run(seed_scene())
    assert result.info.status is RunStatus.UNAVAILABLE
    assert result.info.message == f"{engine} is not installed"
    assert result.trajectory is None


@pytest.mark.parametrize("engine", ENGINES)
def test_failing_engine_is_reported(engine, monkeypatch):
    adapter = get_engine(engine)

    def boom(*args, **kwargs):
        raise RuntimeError("solver exploded")

    monkeypatch.setattr(adapter, "_simulate", boom)
    result = adapter.run(seed_scene())
    assert result.info.status is RunStatus.ERROR
    assert result.info.message == "RuntimeError: solver exploded"


@pytest.mark.parametrize("engine", ENGINES)
def test_divergence_stops_the_run_and_is_reported(engine):
    """A run that breaks a divergence limit stops early with status diverged and keeps its
    partial trajectory (here the energy limit is set so that any run breaks it)."""
    adapter = get_engine(engine, limits=DivergenceLimits(energy_rise=-0.5))
    result = adapter.run(seed_scene())
    assert result.info.status is RunStatus.DIVERGED
    assert "energy rose" in result.info.message
    assert result.trajectory is not None
    assert 0 < len(result.trajectory) < seed_scene().t_end / TIMESTEP / 2


@pytest.mark.parametrize("engine", ["reference", *ENGINES])
def test_runs_are_reproducible(engine):
    """The same scene and settings give the same trajectory, bit for bit."""
    scene = seed_scene().with_(t_end=0.5)
    first = get_engine(engine).run(scene, RunSettings(timestep=1e-3)).trajectory.to_frame()
    second = get_engine(engine).run(scene, RunSettings(timestep=1e-3)).trajectory.to_frame()
    assert first.equals(second)


def _phase_cases():
    for engine in ENGINES:
        xfails = TOL["phases"].get("xfail", {}).get(engine, {})
        for scene in TOL["phases"]["scenes"]:
            marks = []
            if scene in xfails:
                marks.append(pytest.mark.xfail(strict=True, reason=xfails[scene]))
            yield pytest.param(engine, scene, marks=marks, id=f"{engine}-{scene}")


@pytest.mark.parametrize(("engine", "scene_name"), list(_phase_cases()))
def test_phase_sequence(engine, scene_name):
    """The engine goes through the exact sequence of rolls, slips and flights."""
    ref_scene = seed_scene() if scene_name == "seed" else get_scene(scene_name)
    exact_code = solve_exact(ref_scene.with_(muk=ref_scene.mus)).events.phase_code
    assert run(engine, scene_name).events.phase_code == exact_code
