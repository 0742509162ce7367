"""Ending runs early (engines/stopping.py): the monitor on synthetic chunks, the rule's
checks, and every engine on a hop and a rolling scene against its full-window run."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest

from hoopbench.engines.base import n_steps_for
from hoopbench.engines.judging.contact import canonical_events, read_run
from hoopbench.engines.judging.detectors import DetectorSettings
from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunResult
from hoopbench.engines.settings import RunSettings
from hoopbench.engines.stopping import StopMonitor, StopReason, StopRule
from hoopbench.models.catalogue import get_scene
from hoopbench.models.scene import Scene

DT = 1e-4
ENGINES = ["mujoco", "pybullet", "pymunk", "drake"]  # drake: installed with the test extra
ROLLING = Scene.from_chi(1.0, lam=0.5, eps=0.0, mus=0.8, muk=0.8)
"""Rolls without slipping; exact: a full turn at 1.43582 s (tests/test_regimes.py)."""
ROLLING_SETTLED = 1.4358237287688038
"""classify(ROLLING).t_settled, s (the map passes it as settle_after)."""
SYNTHETIC = Scene.from_chi(1.0, lam=0.5, eps=0.0, mus=0.8, muk=0.8, t_end=3.0)
LIMITS = DetectorSettings()


# --------------------------------------------------------------------------- synthetic
def _states(theta, thetadot, clearance, slip, scene: Scene = SYNTHETIC):
    """COM states with this clearance (m) and slip velocity (m/s) for the circle."""
    r, a = scene.com_offset, scene.a
    theta, thetadot = np.asarray(theta, float), np.asarray(thetadot, float)
    return {
        "X": np.zeros_like(theta),
        "Y": a + r * np.cos(theta) + np.asarray(clearance),
        "theta": theta,
        "Xdot": np.asarray(slip) + (a + r * np.cos(theta)) * thetadot,
        "Ydot": np.zeros_like(theta),
        "thetadot": thetadot,
    }


def _record(n: int, clearance=None, slip=None, spin: float = 1.0):
    """n + 1 samples (steps 0..n) spinning at ``spin`` rad/s."""
    t = np.arange(n + 1) * DT
    clearance = np.zeros(n + 1) if clearance is None else clearance
    slip = np.zeros(n + 1) if slip is None else slip
    return _states(spin * t, np.full(n + 1, spin), clearance, slip)


def _feed(monitor: StopMonitor, states, chunk: int, overlap: bool = False) -> list:
    """Feed the record in chunks as an engine does (overlap: repeat each chunk's first row,
    as MuJoCo's loop does); the reason returned after each chunk."""
    n = len(states["theta"]) - 1
    reasons = []
    for done in range(0, n, chunk):
        last = min(done + chunk, n)
        first = done if overlap else done + 1
        rows = slice(first, last + 1)
        reasons.append(monitor.feed({k: v[rows] for k, v in states.items()}, last))
        if reasons[-1]:
            break
    return reasons


def _flight(n: int, lift: int, duration: float, height: float) -> np.ndarray:
    """A clearance that rises from sample ``lift`` to ``height`` and lands ``duration`` s
    later (a parabola), 0 elsewhere."""
    t = np.arange(n + 1) * DT
    tau = t - lift * DT
    c = 4 * height * tau * (duration - tau) / duration**2
    return np.where((tau > 0) & (tau < duration), c, 0.0)


def _monitor(rule: StopRule) -> StopMonitor:
    return StopMonitor(SYNTHETIC, rule, DT, detectors=LIMITS)


def test_impact_split_across_chunks():
    """A hop from step 1500 to 3500 (0.2 s, 5 cm), fed in chunks of 1000: nothing while it
    is in the air, IMPACT in the chunk where it lands."""
    states = _record(6000, clearance=_flight(6000, 1500, 0.2, 0.05))
    assert _feed(_monitor(StopRule()), states, 1000) == [None, None, None, StopReason.IMPACT]


def test_impact_with_repeated_rows():
    states = _record(6000, clearance=_flight(6000, 1500, 0.2, 0.05))
    reasons = _feed(_monitor(StopRule()), states, 1000, overlap=True)
    assert reasons == [None, None, None, StopReason.IMPACT]


def test_rows_already_fed_are_ignored():
    """A chunk of rows the monitor has seen (on the floor, before the lift-off) does not
    end the flight that is under way."""
    states = _record(6000, clearance=_flight(6000, 1500, 0.2, 0.05))
    monitor = _monitor(StopRule())
    assert _feed(monitor, {k: v[:2501] for k, v in states.items()}, 1000) == [None] * 3
    assert monitor.feed({k: v[1:1001] for k, v in states.items()}, 1000) is None
    rest = monitor.feed({k: v[2501:] for k, v in states.items()}, 6000)
    assert rest is StopReason.IMPACT


def test_impact_in_one_chunk_and_small_chunks():
    states = _record(6000, clearance=_flight(6000, 1500, 0.2, 0.05))
    assert _feed(_monitor(StopRule()), states, 6000) == [StopReason.IMPACT]
    reasons = _feed(_monitor(StopRule()), states, 7)
    assert reasons[-1] is StopReason.IMPACT
    assert len(reasons) == math.ceil(3500 / 7)  # the chunk holding step 3500, the landing


def test_no_impact_without_a_hop():
    """Contact noise (a 20 ms, 0.5 mm lift: below hop_clearance), a blip above it but too
    short (2 ms, under lift_sustain), and a flight still in the air: no stop."""
    noise = _flight(6000, 500, 0.02, 0.5 * LIMITS.hop_clearance)
    blip = _flight(6000, 2000, 0.002, 5 * LIMITS.hop_clearance)
    airborne = _flight(6000, 5000, 0.5, 0.05)
    states = _record(6000, clearance=noise + blip + airborne)
    assert _feed(_monitor(StopRule()), states, 1000) == [None] * 6


class _LoopMonitor(StopMonitor):
    """The monitor with its impact check as it was written first, an excursion at a time:
    the definition the vectorised check must follow."""

    def _impact(self, t, clear):
        t = np.concatenate((self._open_t, t))
        clear = np.concatenate((self._open_clear, clear))
        mask = np.concatenate(([0], (clear > self.limits.floor_level).astype(np.int8), [0]))
        edges = np.flatnonzero(np.diff(mask))
        for start, stop in zip(edges[::2], edges[1::2], strict=True):
            if stop == len(clear):
                self._open_t, self._open_clear = t[start:], clear[start:]
                return False
            if self._is_hop(t[start:stop], clear[start:stop]):
                return True
        self._open_t, self._open_clear = np.empty(0), np.empty(0)
        return False


def _flickering(rng: np.random.Generator, n: int) -> np.ndarray:
    """A clearance that flickers off the floor for a step or a few (contact noise, some of
    it above hop_clearance), with a hop now and then; some samples exactly on the floor."""
    clear = np.where(rng.random(n + 1) < 0.3, rng.random(n + 1) * 3 * LIMITS.hop_clearance, 0.0)
    clear[rng.random(n + 1) < 0.05] = -1e-6  # below the floor
    for _ in range(rng.integers(0, 3)):
        lift = int(rng.integers(0, n))
        clear = np.maximum(clear, _flight(n, lift, float(rng.uniform(0.001, 0.05)), 0.01))
    return clear


def test_impact_is_the_excursion_by_excursion_check():
    """On 100 flickering records fed in chunks of random sizes (about 0.6 s): the same
    reason after every chunk and the same open excursion carried to the next, as checking
    one excursion at a time gives."""
    rng = np.random.default_rng(34)
    stops = 0
    for _ in range(100):
        states = _record(1000, clearance=_flickering(rng, 1000))
        fast, slow = _monitor(StopRule()), _LoopMonitor(SYNTHETIC, StopRule(), DT, detectors=LIMITS)
        done = 0
        while done < 1000:
            last = min(done + int(rng.integers(1, 300)), 1000)
            rows = {k: v[done + 1 : last + 1] for k, v in states.items()}
            reason = fast.feed(rows, last)
            assert reason == slow.feed(rows, last)
            assert np.array_equal(fast._open_t, slow._open_t)
            assert np.array_equal(fast._open_clear, slow._open_clear)
            done = last
            if reason:
                stops += 1
                break
    assert 20 < stops < 80, stops  # hops found, and records without one


def test_thresholds_scale_with_the_hoop():
    """On a 1 cm hoop the judge's hop threshold is 10 um (DetectorSettings.for_scene): a
    0.5 mm hop, contact noise on the 1 m hoop, is a hop there."""
    small = SYNTHETIC.with_(a=0.01)
    clearance = _flight(3000, 500, 0.02, 5e-4)
    t = np.arange(3001) * DT
    states = _states(t, np.ones(3001), clearance, np.zeros(3001), scene=small)
    assert _feed(StopMonitor(small, StopRule(), DT), states, 1000) == [StopReason.IMPACT]
    assert _feed(_monitor(StopRule()), _record(3000, clearance=clearance), 1000) == [None] * 3


def test_impact_only_when_asked():
    states = _record(6000, clearance=_flight(6000, 1500, 0.2, 0.05))
    assert _feed(_monitor(StopRule(at_first_impact=False)), states, 1000) == [None] * 6


def test_settled_after_a_full_turn_and_settle_after():
    """Rolling at 2 rad/s: a full turn takes pi s, 31416 steps."""
    spin = 2.0
    turn = math.ceil(2 * math.pi / spin / DT)
    states = _record(40000, spin=spin)
    reasons = _feed(_monitor(StopRule(settle_after=0.0)), states, 1000)
    assert reasons[-1] is StopReason.SETTLED
    assert len(reasons) == math.ceil(turn / 1000)
    # settle_after later than the turn: not before it
    reasons = _feed(_monitor(StopRule(settle_after=3.65)), states, 1000)
    assert reasons[-1] is StopReason.SETTLED and len(reasons) == 37
    assert _feed(_monitor(StopRule()), states, 1000) == [None] * 40  # no settle_after


@pytest.mark.parametrize("what", ["slip", "lift"])
def test_settled_counts_from_the_last_slip_or_lift(what):
    """A slip (|s| above slip_threshold) or a lift (clearance above lift_clearance) for a
    few steps from step 20000 restarts the turn."""
    spin = 2.0
    turn = math.ceil(2 * math.pi / spin / DT)
    n = 60000
    slip, clearance = np.zeros(n + 1), np.zeros(n + 1)
    if what == "slip":
        slip[20000:20005] = 2 * LIMITS.slip_threshold
    else:
        clearance[20000:20005] = 2 * LIMITS.lift_clearance
    states = _record(n, clearance=clearance, slip=slip, spin=spin)
    reasons = _feed(_monitor(StopRule(settle_after=0.0)), states, 1000)
    assert reasons[-1] is StopReason.SETTLED
    assert len(reasons) == math.ceil((20005 + turn) / 1000)


def test_stop_time_on_a_known_motion():
    """Where the rule ends a run that follows the exact motion (a map run's cost): the
    earlier of its first impact (when asked) and settle_after; None: its whole window."""
    assert StopRule().stop_time(0.4) == 0.4
    assert StopRule().stop_time(None) is None
    assert StopRule(at_first_impact=False).stop_time(0.4) is None
    assert StopRule(settle_after=1.5).stop_time(0.4) == 0.4
    assert StopRule(settle_after=1.5).stop_time(2.0) == 1.5
    assert StopRule(at_first_impact=False, settle_after=1.5).stop_time(0.4) == 1.5


def test_rule_checks():
    for bad in (-1.0, math.nan, math.inf, "1", True):
        with pytest.raises(ValueError, match="settle_after"):
            StopRule(settle_after=bad)
    with pytest.raises(ValueError, match="at_first_impact"):
        StopRule(at_first_impact=1)
    with pytest.raises(ValueError, match="stop must be a StopRule"):
        RunSettings(stop={"at_first_impact": True})
    assert StopRule(settle_after=1).settle_after == 1.0
    assert "stop" not in RunSettings().to_dict()  # rows and run ids as before
    assert RunSettings(stop=StopRule(settle_after=2.0)).to_dict()["stop"] == {
        "at_first_impact": True,
        "settle_after": 2.0,
    }


# --------------------------------------------------------------------------- engines
SETTLE_BASE: dict[str, str] = {"pybullet": "chain"}
"""The base under which an engine's rolling reads as rolling to the monitor. PyBullet's free
body (its default) creeps at up to 1.7 mm/s on ROLLING at dt 1e-4, above the 1 mm/s roll
threshold (the position update after the velocity solve, engines/pybullet_engine.py), so the
monitor never reads it settled and its runs step the whole window: a cost, not a wrong
verdict (the canonical reading says rolls; the kinematic one, slips). Its chain does not creep."""


@cache
def _run(engine: str, scene_name: str, stop: StopRule | None, base: str | None = None) -> RunResult:
    scene = ROLLING if scene_name == "rolling" else get_scene(scene_name)
    options = {} if base is None else {"base": base}
    return get_engine(engine).run(scene, RunSettings(timestep=DT, stop=stop, options=options))


def _judged(result: RunResult) -> tuple:
    e = result.events
    return (e.outcome, e.t_slip, e.t_lift, e.hop_height, e.t_impact, e.phases, e.flags)


@pytest.mark.parametrize("engine", ENGINES)
def test_stops_after_the_first_impact(engine):
    full, stopped = _run(engine, "hop-top", None), _run(engine, "hop-top", StopRule())
    assert full.ok and stopped.ok
    assert full.events.t_impact is not None  # the scene hops in every engine
    assert _judged(stopped) == _judged(full)
    assert stopped.info.stop_reason == StopReason.IMPACT
    assert full.info.stop_reason is None
    assert stopped.info.n_steps < full.info.n_steps
    assert stopped.info.n_steps * DT < full.events.t_impact + 0.2  # within a chunk or two
    # Stepping is deterministic: the stopped run is the full run's beginning, forces included.
    n = len(stopped.trajectory.t)
    assert n == stopped.info.n_steps + 1
    for name in ("t", "X", "Y", "theta", "thetadot", "normal_force", "friction_force"):
        np.testing.assert_array_equal(
            getattr(stopped.trajectory, name), getattr(full.trajectory, name)[:n], err_msg=name
        )


@pytest.mark.parametrize("engine", ENGINES)
def test_stops_once_settled(engine):
    base = SETTLE_BASE.get(engine)
    full = _run(engine, "rolling", None, base)
    stopped = _run(engine, "rolling", StopRule(settle_after=ROLLING_SETTLED), base)
    assert full.ok and stopped.ok
    assert stopped.info.stop_reason == StopReason.SETTLED
    assert stopped.events.outcome == full.events.outcome
    # the same phases, the last ending earlier
    assert [(p.kind, p.t_start) for p in stopped.events.phases] == [
        (p.kind, p.t_start) for p in full.events.phases
    ]
    assert ROLLING_SETTLED <= stopped.info.n_steps * DT < ROLLING_SETTLED + 0.25


@pytest.mark.parametrize("engine", ENGINES)
def test_no_rule_runs_the_window(engine):
    """stop=None runs every step; a rule that never fires leaves the trajectory as it is."""
    full = _run(engine, "hop-top", None)
    idle = _run(engine, "hop-top", StopRule(at_first_impact=False))
    assert full.info.n_steps == n_steps_for(get_scene("hop-top"), DT)
    assert idle.info.stop_reason is None and idle.info.n_steps == full.info.n_steps
    np.testing.assert_array_equal(idle.trajectory.theta, full.trajectory.theta)
    np.testing.assert_array_equal(idle.trajectory.clearance, full.trajectory.clearance)
    assert "stop_reason" not in full.info.to_dict()


def test_free_pybullet_creeps_too_fast_to_settle():
    """SETTLE_BASE's reason, measured: the free body never reads settled, yet it rolls."""
    stopped = _run("pybullet", "rolling", StopRule(settle_after=ROLLING_SETTLED))
    assert stopped.ok and stopped.info.stop_reason is None
    reading = read_run(stopped.trajectory, ROLLING, ROLLING.mus)
    assert canonical_events(stopped.trajectory, reading).outcome == "rolls"
    assert stopped.events.outcome == "slips"  # the kinematic reading, as the monitor's
    assert 1e-3 < np.max(np.abs(stopped.trajectory.slip_velocity)) < 3e-3
