"""detect_phases jumps from mark to mark; its phases are those of the sample-by-sample walk
that defines them (engines/judging/detectors.py), on signals made to sit at the thresholds.
About 0.5 CPU-s."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from hoopbench.engines.judging.detectors import (
    DetectorSettings,
    _phases_sample_by_sample,
    detect_phases,
)
from hoopbench.models.events import PhaseKind

CFG = DetectorSettings()
SETTINGS = (
    CFG,
    replace(CFG, slip_threshold=3e-3, restick_threshold=5e-4),
    replace(CFG, slip_threshold=1e-3, restick_threshold=2e-3),  # quiet above the slip level
    replace(CFG, restick_sustain=0.0),  # re-sticks on its first quiet sample
    replace(CFG, restick_sustain=0.05),
)


def _exactly(phases: list[tuple[PhaseKind, float, int | None]]) -> list[tuple[str, str, object]]:
    """The phases with their times as repr: equal only bit for bit."""
    return [(str(kind), repr(start), sigma) for kind, start, sigma in phases]


def _signal(rng: np.random.Generator, case: int, n: int) -> np.ndarray:
    """A slip velocity, m/s, wandering about the 1 mm/s thresholds: drifts, noise, bursts
    between quiet and sliding stretches, and a chattering oscillation."""
    if case == 0:
        return np.cumsum(rng.normal(0.0, 3e-4, n))
    if case == 1:
        return rng.normal(0.0, 1.5e-3, n)
    if case == 2:
        quiet = rng.random(n) < 0.5
        return np.where(quiet, rng.normal(0.0, 4e-4, n), rng.normal(0.0, 5e-3, n))
    wave = np.sin(np.arange(n) * rng.uniform(1e-3, 0.5)) * rng.uniform(5e-4, 5e-3)
    return wave + rng.normal(0.0, 2e-4, n)


@pytest.mark.parametrize("seed", range(4))
def test_the_phases_are_the_walks_bit_for_bit(seed: int) -> None:
    rng = np.random.default_rng(seed)
    phases = 0
    for trial in range(100):
        n = int(rng.integers(2, 1500))
        dt = float(rng.choice([1e-2, 1e-3, 5e-4, 1e-4]))
        t = np.arange(n) * dt
        s = _signal(rng, trial % 4, n)
        if trial % 7 == 0:  # a NaN compares false both ways, in either
            s[rng.integers(0, n, 3)] = np.nan
        if trial % 5 == 0:  # float32 columns are compared as doubles, as the walk's floats
            s, t = s.astype(np.float32), t.astype(np.float32)
        cfg = SETTINGS[trial % len(SETTINGS)]
        if trial % 3 == 0:
            cfg = replace(cfg, restick_sustain=float(rng.choice([0.0, 3 * dt, 10 * dt])))
        end = int(rng.integers(0, n + 1))
        walk = _phases_sample_by_sample(t, s, end, cfg)
        assert _exactly(detect_phases(t, s, end, cfg)) == _exactly(walk), (trial, n, end, cfg)
        phases += len(walk)
    assert phases > 1000  # the signals do cross the thresholds


def test_a_slip_its_reversal_an_interrupted_quiet_stretch_and_the_restick() -> None:
    """Each branch of the walk, on one hand-made signal at dt 1 ms (sustain 5 ms)."""
    t = np.arange(40) * 1e-3
    s = np.zeros(40)
    s[3:8] = 2e-3  # slips forward at sample 3
    s[8:10] = -2e-3  # reverses at 8
    s[10:13] = 0.0  # quiet for 3 samples: too short
    s[13] = -1.5e-3  # still sliding backward (no reversal, not quiet)
    s[14:] = 0.0  # quiet from 14: re-sticks there, decided at sample 20 (19 is 5 ms - 1 ulp on)
    phases = detect_phases(t, s, len(t), CFG)
    assert [(kind, sigma) for kind, _, sigma in phases] == [
        (PhaseKind.ROLL, None),
        (PhaseKind.SLIP, 1),
        (PhaseKind.SLIP, -1),
        (PhaseKind.ROLL, None),
    ]
    assert phases[-1][1] == t[14]
    assert _exactly(phases) == _exactly(_phases_sample_by_sample(t, s, len(t), CFG))


def test_times_that_go_back_are_walked() -> None:
    """The quiet stretch's bisection needs times that never decrease; others take the walk."""
    t = np.arange(200) * 1e-3
    t[150:] -= 1.0  # the quiet stretch from sample 100 holds 5 ms at 105, then goes back
    s = np.where(np.arange(200) < 100, 2e-3, 0.0)
    walk = _phases_sample_by_sample(t, s, 200, CFG)
    assert walk[-1][0] is PhaseKind.ROLL and walk[-1][1] == t[100]
    assert _exactly(detect_phases(t, s, 200, CFG)) == _exactly(walk)
