"""The shared detectors on synthetic signals and on the reference sampled like an engine."""

from __future__ import annotations

import math

import numpy as np
import pytest
from physics_scenes import SEED

from hoopbench.engines.judging.detectors import DetectorSettings, detect_events, refined_onset
from hoopbench.models.events import Outcome
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import solve_exact


def _synthetic(t, s, clearance=None):
    """A trajectory whose slip velocity and clearance are given (other columns dummy)."""
    zeros = np.zeros_like(t)
    clearance = zeros if clearance is None else clearance
    return Trajectory(
        t=t,
        X=zeros,
        Y=zeros,
        theta=t,
        Xdot=zeros,
        Ydot=zeros,
        thetadot=np.ones_like(t),
        clearance=clearance,
        slip_velocity=s,
        normal_force=np.where(clearance > 0, 0.0, 9.8),
        friction_force=zeros,
        contact=clearance <= 0,
        energy=zeros,
    )


@pytest.mark.parametrize("power", [1.0, 1.5, 2.0, 3.0])
def test_refined_onset_recovers_power_law_start(power):
    t = np.arange(0.0, 1.0, 1e-4)
    t0 = 0.4321
    s = 0.5 * np.clip(t - t0, 0.0, None) ** power
    i = int(np.nonzero(s > 1e-3)[0][0])
    estimate = refined_onset(t, s, i, 1e-3)
    threshold_time = t[i]
    assert abs(estimate - t0) < 0.05 * (threshold_time - t0)


def test_refined_onset_falls_back_on_noise():
    t = np.arange(0.0, 1.0, 1e-3)
    s = np.where(t > 0.5, 1.0, 0.0)  # a jump: no power law to extrapolate
    i = int(np.nonzero(s > 1e-3)[0][0])
    assert refined_onset(t, s, i, 1e-3) == pytest.approx(t[i - 1], abs=1e-3)


def test_single_step_contact_loss_is_not_a_lift_off():
    """A spike of clearance shorter than lift_sustain is ignored (MuJoCo after slip)."""
    t = np.arange(0.0, 0.5, 1e-4)
    clearance = np.where((t > 0.2) & (t < 0.2 + 3e-3), 1e-3, -1e-6)
    events = detect_events(_synthetic(t, np.zeros_like(t), clearance))
    assert events.outcome is Outcome.ROLLS
    assert events.t_lift is None


def test_sustained_clearance_is_a_hop():
    t = np.arange(0.0, 0.5, 1e-4)
    tau = t - 0.2
    clearance = np.where((tau > 0) & (tau < 0.1), 4.0 * tau * (0.1 - tau), -1e-6)
    events = detect_events(_synthetic(t, np.zeros_like(t), clearance))
    assert events.outcome is Outcome.HOPS
    assert events.t_lift == pytest.approx(0.2, abs=2e-4)
    assert events.t_impact == pytest.approx(0.3, abs=2e-4)
    assert events.hop_height == pytest.approx(0.01, rel=1e-3)


def test_bad_thresholds_are_rejected():
    with pytest.raises(ValueError, match="slip_threshold must be > 0"):
        DetectorSettings(slip_threshold=0.0)
    with pytest.raises(ValueError, match="lift_sustain must be >= 0"):
        DetectorSettings(lift_sustain=-1.0)


@pytest.mark.parametrize(
    ("muk", "dt", "max_fraction"),
    [
        # mus = muk (what engines can represent): |s| grows like a power law, the
        # extrapolation removes almost all of the threshold lag.
        (0.8, 1e-4, 0.02),
        (0.8, 1e-3, 0.05),
        # muk < mus (the seed): |s| grows like c1 t + c2 t^2, no single power; measured
        # 18 % of the lag left at dt = 1e-4. Stated here, not hidden.
        (0.7, 1e-4, 0.25),
        (0.7, 1e-3, 0.25),
    ],
)
def test_detector_bias_on_the_reference(muk, dt, max_fraction):
    """Detectors on the exact solution sampled like an engine: distance to the exact events.

    The threshold onset is late by several ms (docs/engines.md: about 5 ms in the seed scene);
    the refined onset must remove most of that lag.
    """
    solution = solve_exact(SEED.with_(muk=muk))
    events = detect_events(solution.sample_uniform(dt))
    exact = solution.events
    lag = events.extra["t_slip_threshold"] - exact.t_slip
    refined_error = abs(events.t_slip - exact.t_slip)
    print(f"muk={muk} dt={dt}: lag {lag * 1e3:.3f} ms, refined error {refined_error * 1e3:.4f} ms")
    assert 2e-3 < lag < 20e-3
    assert refined_error < max_fraction * lag
    assert math.degrees(abs(events.theta_slip - exact.theta_slip)) < 0.2
    assert events.outcome is Outcome.SLIPS
    assert events.t_restick == pytest.approx(exact.t_restick, abs=10 * dt + 6e-3)


def test_micro_chatter_before_a_flight_does_not_move_the_lift_off():
    """Micrometre contact chatter (MuJoCo while slipping) before a real flight: the lift-off
    is extrapolated from the flight's own rise, not taken at the last micro-contact."""
    t = np.arange(0.0, 0.6, 1e-4)
    tau = t - 0.3
    flight = np.where(tau > 0, 50.0 * tau**3 * (0.25 - tau) / 0.25, 0.0)
    # The hoop hovers 3 um up from 0.28 s: the last sample on the floor is 20 ms early.
    hover = np.where((t > 0.28) & (t <= 0.3), 3e-6, -1e-8)
    clearance = np.where(flight > 0, np.maximum(flight, 3e-6), hover)
    events = detect_events(_synthetic(t, np.zeros_like(t), clearance))
    assert events.t_lift == pytest.approx(0.3, abs=1e-3)


def test_refined_onset_is_bounded_for_step_growth():
    """A slip that jumps to the threshold and then creeps (a soft contact) must not be
    extrapolated as a slow power law reaching far back in time."""
    t = np.arange(0.0, 1.0, 1e-4)
    s = np.interp(
        t,
        [0.0, 0.4999, 0.5, 0.51, 0.5206, 1.0],
        [1e-6, 1e-6, 1.0001e-3, 2.0001e-3, 4.0001e-3, 1e-2],
    )
    i = int(np.nonzero(s > 1e-3)[0][0])
    estimate = refined_onset(t, s, i, 1e-3)
    assert 0.4997 <= estimate <= t[i]


@pytest.mark.parametrize(
    "name",
    [
        "seed",
        "seed-mu",
        "seed-pi",
        "hop-top",
        "hop-low",
        "hop-bottom",
        "high-spin",
        "low-friction",
        "slip-reversal",
    ],
)
def test_phases_read_off_the_reference_match_the_exact_ones(name):
    """On the exact solution sampled at 1e-4 s the detectors find the exact phase sequence,
    each boundary within 3 ms (re-sticks are dated at the start of the quiet stretch)."""
    from hoopbench.models.catalogue import get_scene

    solution = solve_exact(get_scene(name))
    detected = detect_events(solution.sample_uniform(1e-4))
    exact = solution.events
    assert detected.phase_code == exact.phase_code
    for got, want in zip(detected.phases, exact.phases, strict=True):
        assert got.t_start == pytest.approx(want.t_start, abs=3e-3), (got, want)


def test_a_direct_slip_reversal_is_one_phase_change():
    """s goes from +1 to -1 m/s through zero without dwelling: S+ then S- at the crossing."""
    t = np.arange(0.0, 1.0, 1e-4)
    s = np.interp(t, [0.0, 0.2, 0.4, 0.6, 0.8, 1.0], [0.0, 0.0, 1.0, 0.0, -1.0, -1.0])
    events = detect_events(_synthetic(t, s))
    assert events.phase_code == "R S+ S-"
    assert events.phases[2].t_start == pytest.approx(0.6, abs=2e-4)
    assert events.t_restick is None


def test_a_dwell_at_zero_is_a_re_stick():
    t = np.arange(0.0, 1.0, 1e-4)
    s = np.interp(t, [0.0, 0.2, 0.4, 0.5, 0.55, 0.7, 1.0], [0, 0, 1.0, 0, 0, -1.0, -1.0])
    events = detect_events(_synthetic(t, s))
    assert events.phase_code == "R S+ R S-"
    assert events.t_restick == pytest.approx(0.5, abs=2e-3)


@pytest.mark.parametrize(("roll_time", "code"), [(2e-4, "S+ R"), (3e-3, "S+ R"), (8e-3, "R S+ R")])
def test_a_first_roll_shorter_than_the_re_stick_time_is_not_a_phase(roll_time, code):
    """A hoop that slips at once crosses the slip threshold after a fraction of a ms: that
    time is no roll phase (a roll needs restick_sustain = 5 ms of quiet, as a re-stick does);
    a longer first roll is kept."""
    t = np.arange(0.0, 1.0, 1e-4)
    s = np.interp(t, [0.0, roll_time, roll_time + 0.1, 0.5, 1.0], [0.0, 0.0, 1.0, 0.0, 0.0])
    events = detect_events(_synthetic(t, s))
    assert events.phase_code == code
    assert events.phases[0].t_start == 0.0
    assert events.t_slip == pytest.approx(roll_time, abs=2e-4)


def test_a_short_first_roll_before_a_flight_is_not_a_phase():
    t = np.arange(0.0, 0.5, 1e-4)
    lift = 3e-4
    clearance = np.where(t > lift, 1.0 * (t - lift) * (0.3 - t), 0.0)
    events = detect_events(_synthetic(t, np.zeros_like(t), clearance))
    assert events.phase_code == "F"
    assert events.t_lift == pytest.approx(lift, abs=2e-4)


def test_a_lift_off_at_the_first_sample_has_only_a_flight_phase():
    t = np.arange(0.0, 0.5, 1e-4)
    clearance = 1.0 * t * (0.3 - t)
    events = detect_events(_synthetic(t, np.full_like(t, 0.5), clearance))
    assert events.outcome is Outcome.LIFTS_AT_START
    assert events.phase_code == "F"
    assert events.t_slip is None


# --------------------------------------------------------------------------- the hoop's size
def _scaled(scene, a):
    """The same motion on a hoop of radius a: the spin parameter kept, time scaled by
    sqrt(a / scene.a)."""
    k = math.sqrt(a / scene.a)
    return scene.with_(a=a, thetadot0=scene.thetadot0 / k, t_end=scene.t_end * k)


def test_every_threshold_scales_as_what_it_measures():
    base = DetectorSettings()
    small = base.for_hoop(0.01, 9.8)
    lengths = ("lift_clearance", "lift_level", "hop_clearance")
    speeds = ("slip_threshold", "restick_threshold")
    durations = ("restick_sustain", "lift_sustain")
    for name in lengths:
        assert getattr(small, name) == pytest.approx(0.01 * getattr(base, name), rel=1e-12)
    for name in (*speeds, *durations):
        assert getattr(small, name) == pytest.approx(0.1 * getattr(base, name), rel=1e-12)
    # A threshold added later must be classified: here, it would not have changed.
    listed = {"a", "g", *lengths, *speeds, *durations}
    assert listed == set(DetectorSettings.__dataclass_fields__)
    assert (small.a, small.g) == (0.01, 9.8)
    assert base.for_hoop(1.0, 9.8) is base  # the 1 m hoop: exactly the stated thresholds
    assert small.for_hoop(0.01, 9.8) == small  # applying it twice changes nothing
    faster = base.for_hoop(1.0, 4 * 9.8)  # g alone: speeds x2, durations /2, lengths kept
    assert (faster.slip_threshold, faster.lift_sustain) == pytest.approx((2e-3, 2.5e-3))
    assert faster.hop_clearance == base.hop_clearance


def test_a_hoop_too_small_for_the_floor_level_is_refused():
    with pytest.raises(ValueError, match="too small to detect on"):
        DetectorSettings().for_hoop(5e-5, 9.8)


@pytest.mark.parametrize("name", ["seed-mu", "hop-low", "slip-reversal"])
def test_the_1_cm_hoop_reads_as_the_1_m_hoop(name):
    """The exact motion of a catalogue scene on a 1 cm hoop, sampled 10 times finer, gives
    the same events in the hoop's own units (times / 10, heights / 100) as on the 1 m hoop.
    With the 1 m thresholds it did not: seed-mu's 4.4 ms roll between re-stick and reverse
    slip was shorter than the 5 ms re-stick sustain, and hop-low's 0.33 mm hop was below
    the 1 mm hop threshold."""
    from hoopbench.engines.judging.event_checks import checked_events
    from hoopbench.models.catalogue import get_scene

    big = get_scene(name)
    small = _scaled(big, 0.01)
    on_big = checked_events(solve_exact(big).sample_uniform(1e-4), scene=big)
    on_small = checked_events(solve_exact(small).sample_uniform(1e-5), scene=small)
    assert on_small.phase_code == on_big.phase_code == solve_exact(big).events.phase_code
    for got, want in zip(on_small.phases, on_big.phases, strict=True):
        assert 10 * got.t_start == pytest.approx(want.t_start, abs=1e-6)
    if on_big.hop_height is not None:
        assert 100 * on_small.hop_height == pytest.approx(on_big.hop_height, rel=1e-6)
