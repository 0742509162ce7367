"""The batch path's per-chunk checks vectorised across worlds (engines/base.py
``DivergenceScreen``, engines/mujoco_engine.py ``_com_rows``) give what the single run's
checks give, bit for bit: the screen passes a world exactly when ``check_divergence`` returns
None and gives its reason otherwise, at the limits to the last bit; the batch's
centre-of-mass rows are ``kinematics.com_state``'s; a monitor fed the screen's clearance
decides as one that computes it. Synthetic states, no engine stepped: about 0.3 s."""

from __future__ import annotations

import numpy as np
import pytest

from hoopbench.engines.base import STATE_KEYS, DivergenceLimits, DivergenceScreen, check_divergence
from hoopbench.engines.mujoco_engine import _com_rows
from hoopbench.engines.stopping import StopMonitor, StopRule
from hoopbench.models import kinematics
from hoopbench.models.kinematics import Polygon
from hoopbench.models.scene import Scene

SCENES = [
    Scene.from_chi(1.0, lam=0.5, eps=0.0, mus=0.8, muk=0.8),
    Scene.from_chi(1.6, lam=0.6, eps=0.01, mus=0.6, muk=0.5),
    Scene.from_chi(1.9, lam=0.65, eps=0.0, mus=0.5, muk=0.5, a=0.3, M=2.0),
]
RING = Polygon.regular(8, SCENES[2].a - 0.01, 0.1, rounding=0.01)
"""A faceted contact shape, as MuJoCo's ring of capsules gives one."""
ROWS = 101


def _states(rng: np.random.Generator, scene: Scene, rows: int = ROWS) -> np.ndarray:
    """(rows, 6): a hoop near its start, rolling, bouncing a little, columns STATE_KEYS."""
    start = np.array(scene.initial_state())
    noise = rng.normal(0.0, [1e-3, 1e-4, 1e-2, 1e-2, 1e-2, 1e-1], size=(rows, 6))
    return start + np.cumsum(noise, axis=0) * 0.1


def _screen_and_check(scenes, shapes, limits, states):
    """The screen's reasons for every world, and check_divergence's, world by world."""
    ids = np.arange(len(scenes))
    screened, clear = DivergenceScreen(scenes, shapes, limits).reasons(ids, states)
    screened = [None] * len(scenes) if screened is None else screened
    single = [
        check_divergence(
            scene,
            {k: np.ascontiguousarray(rows[:, j]) for j, k in enumerate(STATE_KEYS)},
            limits,
            shape,
        )
        for scene, shape, rows in zip(scenes, shapes, states, strict=True)
    ]
    return screened, single, clear


def _energy_max(scene: Scene, rows: np.ndarray) -> float:
    return float(
        kinematics.energy_per_mass(scene, rows[:, 1], rows[:, 3], rows[:, 4], rows[:, 5]).max()
    )


def test_the_screen_gives_check_divergence_s_reasons_and_clearance():
    """Worlds that pass, turn non-finite in each column, gain energy or sink, among others
    that pass; circles and a polygon."""
    rng = np.random.default_rng(7)
    scenes = SCENES * 4
    shapes = [None, None, RING] * 4
    states = np.stack([_states(rng, scene) for scene in scenes])
    for world, column in zip(range(6), range(6), strict=True):  # each column non-finite
        states[world, 40 + world, column] = [np.nan, np.inf, -np.inf][world % 3]
    states[6, 70:, 3] += 50.0  # energy
    states[7, 80:, 1] -= 0.2  # penetration
    screened, single, clear = _screen_and_check(scenes, shapes, DivergenceLimits(), states)
    assert screened == single
    assert [reason is None for reason in single] == [False] * 8 + [True] * 4
    for i in range(8, 12):  # the clearance handed to the monitor is the kinematics one
        expected = kinematics.clearance(scenes[i], states[i, :, 1], states[i, :, 2], shapes[i])
        assert np.array_equal(clear[i], expected)


@pytest.mark.parametrize("shape", [None, RING], ids=["circle", "polygon"])
def test_the_screen_agrees_at_the_limits_to_the_last_bit(shape):
    """A limit equal to the chunk's extreme passes (check_divergence's > and <), one bit
    tighter fails, for the energy and the penetration."""
    scene = SCENES[2]
    rng = np.random.default_rng(3)
    states = _states(rng, scene)[None]
    e0, most = scene.energy_per_mass, _energy_max(scene, states[0])
    rise, tighter = _at_and_inside(lambda r: e0 * (1.0 + r) - most, most / e0 - 1.0)
    least = float(kinematics.clearance(scene, states[0, :, 1], states[0, :, 2], shape).min())
    deep, shallower = _at_and_inside(lambda p: least - (-p * scene.a), -least / scene.a)
    for limits in (
        DivergenceLimits(energy_rise=rise, penetration=1.0),
        DivergenceLimits(energy_rise=tighter, penetration=1.0),
        DivergenceLimits(energy_rise=10.0, penetration=deep),
        DivergenceLimits(energy_rise=10.0, penetration=shallower),
    ):
        screened, single, _ = _screen_and_check([scene], [shape], limits, states)
        assert screened == single, limits
    outcomes = [
        _screen_and_check([scene], [shape], DivergenceLimits(energy_rise=float(r)), states)[1]
        for r in (rise, tighter)
    ]
    assert outcomes[0] == [None] and outcomes[1][0].startswith("energy rose")
    outcomes = [
        _screen_and_check([scene], [shape], DivergenceLimits(penetration=p), states)[1]
        for p in (deep, shallower)
    ]
    assert outcomes[0] == [None] and outcomes[1][0].startswith("penetration")


def _at_and_inside(gap, guess: float) -> tuple[float, float]:
    """(the smallest x with gap(x) >= 0, the next float below it, whose gap is < 0): the
    tightest limit a chunk passes and the one that fails it. ``gap`` rises with x."""
    x = guess
    while gap(x) < 0.0:
        x = float(np.nextafter(x, np.inf))
    while gap(inside := float(np.nextafter(x, -np.inf))) >= 0.0:
        x = inside
    return x, inside


def test_states_of_another_precision_are_checked_world_by_world():
    rng = np.random.default_rng(5)
    states = np.stack([_states(rng, s) for s in SCENES]).astype(np.float32)
    states[1, 50:, 3] += 50.0
    screened, single, clear = _screen_and_check(SCENES, [None] * 3, DivergenceLimits(), states)
    assert screened == single and clear is None
    assert [reason is None for reason in single] == [True, False, True]


def test_the_batch_s_centre_of_mass_rows_are_com_state_s():
    """MuJoCo's batch converts every world's joint rows at once, as com_state does one
    world's (the slide z joint above the resting height a)."""
    rng = np.random.default_rng(11)
    q = rng.normal(0.0, [0.3, 0.01, 3.0], size=(3, ROWS, 3))
    v = rng.normal(0.0, [2.0, 0.5, 20.0], size=(3, ROWS, 3))
    offset = np.array([[s.com_offset] for s in SCENES])
    a = np.array([[s.a] for s in SCENES])
    com = np.empty((3, ROWS, 6))
    _com_rows(offset, a, q, v, com)
    for i, scene in enumerate(SCENES):
        x, z, theta = q[i].T
        single = kinematics.com_state(scene, x, scene.a + z, theta, *v[i].T)
        for k, key in enumerate(STATE_KEYS):
            assert np.array_equal(com[i, :, k], single[key]), key


def test_a_monitor_fed_the_clearance_decides_as_one_that_computes_it():
    """Chunks that repeat their first row (rows already seen are skipped from the given
    clearance too): the same reasons after every chunk, for an impact and for settling."""
    scene = SCENES[0]
    rng = np.random.default_rng(2)
    n, chunk, spin = 12000, 700, 8.0
    t = np.arange(n + 1) * 1e-4
    theta = spin * t
    lift = np.where((t > 0.2) & (t < 0.3), 0.02 * np.sin(np.pi * (t - 0.2) / 0.1), 0.0)
    r = scene.com_offset
    states = {
        "X": np.zeros(n + 1),
        "Y": scene.a + r * np.cos(theta) + lift + rng.normal(0, 1e-9, n + 1),
        "theta": theta,
        "Xdot": (scene.a + r * np.cos(theta)) * spin,
        "Ydot": np.zeros(n + 1),
        "thetadot": np.full(n + 1, spin),
    }
    for rule in (StopRule(), StopRule(at_first_impact=False, settle_after=0.4)):
        plain, given = StopMonitor(scene, rule, 1e-4), StopMonitor(scene, rule, 1e-4)
        decided = []
        for done in range(0, n, chunk):
            rows = slice(done, min(done + chunk, n) + 1)  # the first row repeats
            part = {k: v[rows] for k, v in states.items()}
            clear = kinematics.clearance(scene, part["Y"], part["theta"])
            last = rows.stop - 1
            decided.append((plain.feed(part, last), given.feed(part, last, clear)))
            # The open flight's samples too: a shifted clearance would move them.
            assert np.array_equal(plain._open_clear, given._open_clear), done
        assert all(a == b for a, b in decided), decided
        assert decided[-1][0] is not None, rule
