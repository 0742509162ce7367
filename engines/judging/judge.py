"""The judge step: a simulated run, or a stored trajectory, turned into events.

Kept apart from stepping so that stored trajectories can be judged again (with other
detector settings, or after a detector fix) without simulating.
"""

from __future__ import annotations

import traceback
from dataclasses import replace

import numpy as np

from hoopbench.engines.judging.detectors import DetectorSettings
from hoopbench.engines.judging.event_checks import checked_events
from hoopbench.engines.run import Divergence, Run, RunResult, RunStatus
from hoopbench.models.events import Outcome
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import COLUMNS, Trajectory

__all__ = ["judge", "non_finite_columns"]


def non_finite_columns(trajectory: Trajectory) -> list[str]:
    """Columns holding NaN or inf: a run with any is no result, whatever its status says."""
    return [
        name
        for name in COLUMNS
        if name != "contact" and not np.all(np.isfinite(getattr(trajectory, name)))
    ]


def judge(
    run: Run, detectors: DetectorSettings | None = None, scene: Scene | None = None
) -> RunResult:
    """The run's events from the shared detectors; a run without a usable trajectory keeps
    its status and gets no events. A non-finite value anywhere makes an ``ok`` run
    ``diverged`` (an adapter must never pass NaN on as a result).

    The events pass the checks of :mod:`hoopbench.engines.judging.event_checks`: a lift-off below
    the hop threshold is contact noise, not a hop, and an impossible hop (an impact before
    its lift-off; with ``scene``, a height its flight time cannot give) is flagged and its
    numbers withheld."""
    trajectory, info = run.trajectory, run.info
    if trajectory is None or info.status is RunStatus.ERROR:
        return RunResult(trajectory, None, info, run.exact_events)
    bad = non_finite_columns(trajectory)
    if bad and info.status is RunStatus.OK:
        info = replace(
            info, status=RunStatus.DIVERGED, message=f"{Divergence.NON_FINITE} {', '.join(bad)}"
        )
    if bad:
        return RunResult(trajectory, None, info, run.exact_events)
    try:
        events = checked_events(trajectory, detectors, scene)
        if run.exact_events is not None and run.exact_events.outcome is Outcome.PAINLEVE:
            # The reference knows it reached a point with no consistent contact force; the
            # detectors, reading motion alone, cannot tell it from a slip.
            events = replace(events, outcome=Outcome.PAINLEVE)
    except Exception as exc:  # a trajectory the detectors cannot read is an error row
        last = traceback.format_exception_only(type(exc), exc)[-1].strip()
        info = replace(info, status=RunStatus.ERROR, message=f"detectors: {last}")
        return RunResult(trajectory, None, info, run.exact_events)
    return RunResult(trajectory, events, info, run.exact_events)
