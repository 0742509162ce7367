"""The exact solution sampled at a run's times, kept for the next runs judged at the same times.

A suite judges every engine, profile and variant of a scene at a timestep against the same
exact solution, and every engine samples its steps at the same times (``Trajectory.
from_steps``: step k at k * dt). Sampling the solution's dense output at those times was
the largest part of judging a run: about 15 ms for the RMS position error and 13 ms for the
force columns of a 1e-4 s run, each sampled anew for every run (2 idle cores, 2026-11-29).
Here a worker samples each (solution, times) once: a run whose times equal a kept entry's,
element for element, gets that entry, the very numbers ``ExactSolution.sample`` gives for
them (nothing is interpolated or sliced from other times).
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from hoopbench.models.trajectory import COLUMNS, Trajectory
from hoopbench.reference.exact import ExactSolution

__all__ = ["KEPT_SAMPLES", "clear", "exact_sample"]

KEPT_SAMPLES = 400_000
"""Samples kept in all (about 40 MB: a sample is 13 columns, 100 bytes), the oldest dropped
first: a suite's worker judges one scene's 3 timesteps in turn, 30,000 samples each at
1e-4 s for a 3 s window, twice (the RMS error's times and the force window's)."""


@dataclass(frozen=True)
class _Kept:
    exact: ExactSolution
    """Held, so that its id is not reused while the entry is kept."""
    t: NDArray
    sampled: Trajectory


_kept: OrderedDict[tuple[int, int, float, float], _Kept] = OrderedDict()


def exact_sample(exact: ExactSolution, t: NDArray) -> Trajectory:
    """``exact.sample(t)``, from the kept entry of ``exact`` at the same times if there is
    one. The returned trajectory is shared: its arrays are read-only."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or not t.size:
        return exact.sample(t)
    key = (id(exact), t.size, float(t[0]), float(t[-1]))
    kept = _kept.get(key)
    if kept is not None and kept.exact is exact and np.array_equal(kept.t, t):
        _kept.move_to_end(key)
        return kept.sampled
    sampled = exact.sample(t)
    for name in COLUMNS:  # shared from now on: a caller writing into it would raise
        getattr(sampled, name).setflags(write=False)
    _kept[key] = _Kept(exact, t.copy(), sampled)
    _kept.move_to_end(key)
    while len(_kept) > 1 and sum(entry.t.size for entry in _kept.values()) > KEPT_SAMPLES:
        _kept.popitem(last=False)
    return sampled


def clear() -> None:
    """Forget every kept sample (tests)."""
    _kept.clear()
