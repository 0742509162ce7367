"""The exact solution sampled at a run's times, kept for the next runs judged at the same times.

A suite judges every engine, profile and variant of a scene at a timestep against the same
exact solution, and every engine samples its steps at the same times (``Trajectory.
from_steps``: step k at k * dt). Sampling the solution's dense output at those times was
the largest part of judging a run: about 15 ms for the RMS position error and 13 ms for the
force columns of a 1e-4 s run, each sampled anew for every run (2 idle cores, 2026-11-29).
Here a worker samples each (solution, times) once: a run whose times equal a kept entry's,
element for element, gets that entry, the very numbers ``ExactSolution.sample`` gives for
them.

A hop map's runs stop early, each at its own step, so their times are rarely equal; but they
are a prefix of the grid the detection floor samples at the same timestep (comparison.py
``_sampled``: every dt to the window's end), which is kept here too. Times that are all
among a kept entry's (the same floats) get that entry's rows at them. These are the numbers
``ExactSolution.sample`` gives for those times alone: every column of a sample is computed
time by time (the dense output's polynomial, the phases' closed forms, NumPy's element-wise
functions), so a time's row does not depend on the other times sampled with it (bit for
bit, sample against sample: tests/test_exact_samples.py on three catalogue scenes, and 900
prefixes and parts of the floor's samples of a 10x10 map's points when this was written).
Nothing is interpolated: a time not in a kept entry is sampled anew.
"""

from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from hoopbench.models.trajectory import Trajectory
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
    ascending: bool
    """t strictly increasing: other times can be looked up in it."""


_kept: OrderedDict[tuple[int, int, float, float], _Kept] = OrderedDict()


def exact_sample(exact: ExactSolution, t: NDArray) -> Trajectory:
    """``exact.sample(t)``, from a kept entry of ``exact`` at the same times or at times
    that include them, if there is one. The returned trajectory is shared: its arrays are
    read-only."""
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or not t.size:
        return exact.sample(t)
    key = (id(exact), t.size, float(t[0]), float(t[-1]))
    kept = _kept.get(key)
    if kept is not None and kept.exact is exact and np.array_equal(kept.t, t):
        _kept.move_to_end(key)
        return kept.sampled
    within = _within_kept(exact, t)
    if within is not None:
        return within
    sampled = exact.sample(t)
    sampled.make_read_only()  # shared from now on: a caller writing into it would raise
    ascending = bool(np.all(np.diff(t) > 0))
    _kept[key] = _Kept(exact, t.copy(), sampled, ascending)
    _kept.move_to_end(key)
    while len(_kept) > 1 and sum(entry.t.size for entry in _kept.values()) > KEPT_SAMPLES:
        _kept.popitem(last=False)
    return sampled


def _within_kept(exact: ExactSolution, t: NDArray) -> Trajectory | None:
    """The rows at ``t`` of the newest kept entry of ``exact`` whose times include all of
    ``t`` (the same floats), or None. A run's times are a prefix of the floor's grid: a slice,
    no copy."""
    for key in reversed(_kept):
        kept = _kept[key]
        if kept.exact is not exact or not kept.ascending or kept.t.size < t.size:
            continue
        index = np.searchsorted(kept.t, t)
        if index.max() >= kept.t.size:
            continue
        if not np.array_equal(kept.t[index], t):
            continue
        _kept.move_to_end(key)
        first, last = int(index[0]), int(index[-1])
        if last - first + 1 == t.size and bool(np.all(np.diff(index) == 1)):
            rows: slice | NDArray = slice(first, last + 1)  # views of read-only arrays
        else:
            rows = index
        return kept.sampled.rows(rows).make_read_only()
    return None


def clear() -> None:
    """Forget every kept sample (tests)."""
    _kept.clear()
