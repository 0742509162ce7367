"""The judge's event checks: contact noise is not a hop, and a hop must fit its flight time.

Trajectories are synthetic, built with Trajectory.from_state from a prescribed hoop-centre
clearance, so that each test knows exactly what the hoop did.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from physics_scenes import HOP

from hoopbench.engines.judging.detectors import DetectorSettings, detect_events
from hoopbench.engines.judging.event_checks import (
    EventFlag,
    check_flight,
    checked_events,
    flight_height_bounds,
)
from hoopbench.engines.judging.judge import judge
from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import Run, RunInfo, RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models import kinematics
from hoopbench.models.catalogue import get_scene
from hoopbench.models.events import Events, Outcome
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory

SCENE = get_scene("hop-bottom")  # lam = 0.5, a = 1 m, g = 9.8
DT = 1e-4
SPIN = 1.0
"""rad/s: slow enough that the centre's flight is nearly the centre of mass's parabola."""
HOP_CLEARANCE = DetectorSettings().hop_clearance


def _trajectory(clearance: np.ndarray, scene: Scene = SCENE, spin: float = SPIN) -> Trajectory:
    """A hoop rolling at a constant spin whose centre has the given clearance (m)."""
    t = np.arange(len(clearance)) * DT
    theta = scene.theta0 + spin * t
    x = scene.a * spin * t
    y = scene.a + clearance
    state = kinematics.com_state(
        scene,
        x,
        y,
        theta,
        np.full_like(t, scene.a * spin),
        np.gradient(y, t),
        np.full_like(t, spin),
    )
    on_floor = clearance <= 0
    return Trajectory.from_state(
        scene,
        t=t,
        **state,
        normal_force=np.where(on_floor, scene.g, 0.0),
        friction_force=np.zeros_like(t),
    )


def _ballistic(
    n: int, t_lift: float, duration: float, scene: Scene = SCENE, spin: float = SPIN
) -> np.ndarray:
    """Clearance of a true flight: the centre of mass on a parabola, the spin constant, the
    centre leaving and meeting the floor ``duration`` apart."""
    t = np.arange(n) * DT
    theta = scene.theta0 + spin * t
    r, g = scene.com_offset, scene.g
    th0, th1 = scene.theta0 + spin * t_lift, scene.theta0 + spin * (t_lift + duration)
    tau = t - t_lift
    s = tau / duration
    c = (
        r * ((1 - s) * math.cos(th0) + s * math.cos(th1) - np.cos(theta))
        + g * tau * (duration - tau) / 2
    )
    inside = (tau > 0) & (tau < duration)
    assert np.all(c[inside] > 0), "not a flight: the centre dips below the floor"
    return np.where(inside, c, 0.0)


def _jump(n: int, t_lift: float, height: float) -> np.ndarray:
    """Clearance of a hoop put ``height`` up at once (a position correction), then falling."""
    tau = np.arange(n) * DT - t_lift
    c = height - 0.5 * SCENE.g * tau**2
    return np.where((tau >= 0) & (c > 0), c, 0.0)


def test_a_true_flight_keeps_its_numbers():
    events = checked_events(_trajectory(_ballistic(8000, 0.3, 0.2)), scene=SCENE)
    assert events.outcome is Outcome.HOPS
    assert events.flags == ()
    assert events.hop_height == pytest.approx(SCENE.g * 0.2**2 / 8, rel=0.05)
    assert events.t_lift == pytest.approx(0.3, abs=1e-3)
    assert events.t_impact == pytest.approx(0.5, abs=1e-3)


def test_a_flight_without_spin_sits_on_both_bounds():
    """Without spin both bounds are g T^2 / 8: only the slack keeps a sampled flight, with
    its lift-off and impact read to within a sample, from being flagged."""
    c = _ballistic(8000, 0.3, 0.2, spin=0.0)
    events = checked_events(_trajectory(c, spin=0.0), scene=SCENE)
    assert events.flags == ()
    assert events.hop_height == pytest.approx(SCENE.g * 0.2**2 / 8, rel=1e-3)


def test_the_hop_threshold_cannot_be_below_the_lift_off_threshold():
    with pytest.raises(ValueError, match=r"hop_clearance .* must not be below lift_clearance"):
        DetectorSettings(hop_clearance=1e-5)
    with pytest.raises(ValueError, match="hop_clearance must be > 0"):
        DetectorSettings(hop_clearance=math.nan)


@pytest.mark.parametrize("name", ["hop-top", "hop-low", "hop-bottom", "high-spin"])
def test_exact_hops_are_consistent(name):
    """The exact solution's flights, spin included, all pass the flight-time bound (the
    reference engine's samples end at the impact, so the flight is complete)."""
    scene = get_scene(name)
    run = get_engine("reference").simulate(scene, RunSettings(timestep=1e-3))
    events = checked_events(run.trajectory, scene=scene)
    exact = run.exact_events
    assert events.outcome is Outcome.HOPS
    assert events.flags == ()
    assert events.t_impact == pytest.approx(exact.t_impact, abs=1e-6)
    assert events.hop_height == pytest.approx(exact.hop_height, rel=1e-3)


def test_a_jump_is_too_high_for_its_flight_and_is_withheld():
    """Put 20 mm up without a velocity, it falls in 64 ms: g T^2 / 2, four times what any
    flight of that duration reaches."""
    events = checked_events(_trajectory(_jump(6000, 0.3, 0.02)), scene=SCENE)
    assert events.outcome is Outcome.HOPS
    assert events.flags == (str(EventFlag.HOP_TOO_HIGH),)
    assert events.t_lift is None and events.hop_height is None and events.t_impact is None
    assert "hop-too-high" in events.message and "withheld" in events.message


def test_a_hoop_held_up_is_too_low_for_its_flight_and_is_withheld():
    """5 mm up for half a second: a real flight that long rises 0.3 m."""
    c = np.zeros(10000)
    c[3000:8000] = 5e-3
    events = checked_events(_trajectory(c), scene=SCENE)
    assert events.flags == (str(EventFlag.HOP_TOO_LOW),)
    assert events.hop_height is None and events.t_lift is None


def test_without_a_scene_the_flight_bound_is_not_applied():
    events = checked_events(_trajectory(_jump(6000, 0.3, 0.02)))
    assert events.flags == ()
    assert events.hop_height == pytest.approx(0.02, rel=1e-3)


@pytest.mark.parametrize(("t_lift", "t_impact"), [(0.5, 0.4), (0.5, 0.5), (None, 0.4)])
def test_an_impact_before_its_lift_off_is_withheld(t_lift, t_impact):
    events = Events(
        outcome=Outcome.HOPS, t_slip=0.1, t_lift=t_lift, hop_height=0.01, t_impact=t_impact
    )
    checked = check_flight(events, _trajectory(np.zeros(8000)))
    assert checked.flags == (str(EventFlag.IMPACT_BEFORE_LIFT),)
    assert (checked.t_lift, checked.hop_height, checked.t_impact) == (None, None, None)
    assert checked.t_slip == 0.1  # only the hop's numbers go
    assert check_flight(checked, _trajectory(np.zeros(8000)), SCENE) == checked  # idempotent


def test_contact_noise_is_not_a_hop():
    """A 0.3 mm flight of 16 ms (MuJoCo's slip chatter) is read as contact."""
    c = _ballistic(8000, 0.3, 2 * math.sqrt(2 * 3e-4 / SCENE.g))
    trajectory = _trajectory(c)
    assert detect_events(trajectory).outcome is Outcome.HOPS  # the detectors alone see one
    events = checked_events(trajectory, scene=SCENE)
    assert events.outcome is Outcome.ROLLS
    assert events.t_lift is None and events.hop_height is None
    assert "contact noise, not a hop" in events.message
    assert float(trajectory.clearance.max()) == pytest.approx(3e-4, rel=0.05)  # max_clearance


@pytest.mark.parametrize(
    ("height", "hops"), [(0.8 * HOP_CLEARANCE, False), (1.25 * HOP_CLEARANCE, True)]
)
def test_the_hop_threshold_decides(height, hops):
    c = _ballistic(8000, 0.3, 2 * math.sqrt(2 * height / SCENE.g))
    events = checked_events(_trajectory(c), scene=SCENE)
    assert (events.outcome is Outcome.HOPS) is hops


def test_a_real_hop_after_a_blip_is_found():
    """The blip is read as contact, so the hop after it is the run's lift-off."""
    c = _ballistic(8000, 0.2, 0.015) + _ballistic(8000, 0.5, 0.2)
    trajectory = _trajectory(c)
    assert detect_events(trajectory).t_lift == pytest.approx(0.2, abs=2e-3)
    events = checked_events(trajectory, scene=SCENE)
    assert events.outcome is Outcome.HOPS
    assert events.t_lift == pytest.approx(0.5, abs=1e-3)
    assert events.hop_height == pytest.approx(SCENE.g * 0.2**2 / 8, rel=0.05)
    assert events.flags == ()


def test_the_judge_flags_and_simulate_shows_why():
    info = RunInfo(engine="test", engine_version=None, status=RunStatus.OK)
    result = judge(Run(_trajectory(_jump(6000, 0.3, 0.02)), info), scene=SCENE)
    payload = result.to_dict()
    assert payload["flags"] == ["hop-too-high"]
    assert payload["hop_height"] is None and payload["t_lift"] is None
    assert "hop-too-high" in payload["message"]


@pytest.mark.parametrize("spin", [0.0, 2.0, 5.0, 9.0])
@pytest.mark.parametrize("theta0_deg", [0.0, 90.0, 180.0, 300.0])
@pytest.mark.parametrize("duration", [0.05, 0.3, 1.0])
def test_flight_height_bounds_hold_for_every_ballistic_flight(spin, theta0_deg, duration):
    """Any torque-free flight from floor to floor, whatever its spin, stays within the
    bounds (the derivation in engines/judging/event_checks.py)."""
    r, g = HOP.com_offset, HOP.g
    tau = np.linspace(0.0, duration, 20001)
    theta = math.radians(theta0_deg) + spin * tau
    s = tau / duration
    c = (
        r * ((1 - s) * np.cos(theta[0]) + s * np.cos(theta[-1]) - np.cos(theta))
        + g * tau * (duration - tau) / 2
    )
    low, high = flight_height_bounds(duration, spin, g, r)
    assert low - 1e-12 <= c.max() <= high + 1e-12
    if spin == 0.0:
        assert low == pytest.approx(high) == pytest.approx(c.max(), rel=1e-6)


def test_engine_run_applies_the_flight_bound(monkeypatch):
    """Engine.run passes its scene to the judge, so `hoopbench simulate` checks flights too."""
    import sys

    from hoopbench.engines.registry import get_engine
    from hoopbench.engines.settings import RunSettings
    from hoopbench.models.catalogue import get_scene

    # Engine.run calls the judge by the name base.py imported.
    judge_module = sys.modules["hoopbench.engines.base"]
    seen = []
    real = judge_module.judge

    def spy(run, detectors=None, scene=None):
        seen.append(scene)
        return real(run, detectors, scene)

    monkeypatch.setattr(judge_module, "judge", spy)
    scene = get_scene("hop-bottom")
    get_engine("reference").run(scene, RunSettings(timestep=1e-3))
    assert seen == [scene]
