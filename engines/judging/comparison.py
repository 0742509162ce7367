"""A judged run against the exact solution of its scene: the exact columns, the event and
error columns, and the verdict, as one row's columns.

The one place where a run meets the reference: the suites and the hop map call
:func:`judged_columns` once per run and only add their own descriptive columns. The exact
solution is the reference solver's (``hoopbench.reference.exact``), solved once per scene and
mu in each worker process.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.contact import ContactSettings, read_contact
from hoopbench.engines.judging.forces import force_columns
from hoopbench.engines.judging.verdict import (
    number_or_none,
    painleve_time,
    row_phases_agree,
    verdict_columns,
)
from hoopbench.engines.run import BatchCost, RunInfo, RunResult
from hoopbench.models import kinematics
from hoopbench.models.events import Events
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import ExactSolution, solve_exact
from hoopbench.reference.regimes import max_slip_speed

__all__ = [
    "contact_columns",
    "cost_columns",
    "event_columns",
    "exact_columns",
    "exact_solution",
    "judged_columns",
    "rms_position_error",
    "scene_exact_columns",
]


@functools.cache  # one exact solve per (scene, mu) per worker process, not one per run
@functools.lru_cache(maxsize=16)
def exact_solution(scene: Scene, mu: float) -> ExactSolution:
    """The exact solution of ``scene`` with mus = muk = ``mu``. Kept for the last few scenes:
    a suite or a map judges several engines and profiles on one scene in turn."""
    return solve_exact(scene.with_(mus=mu, muk=mu))


@functools.cache
def _exact_max_slip_speed(scene: Scene, mu: float) -> float | None:
    return max_slip_speed(exact_solution(scene, mu))


def cost_columns(info: RunInfo) -> dict[str, Any]:
    """The cost of the batch a run was stepped in (Col.BATCH_SIZE and after; empty for a run
    that produced nothing): a run stepped alone is a batch of one, its own wall time and
    steps. A batched run's wall_time_s is its share of the batch's, by steps."""
    if info.wall_time_s is None or info.n_steps is None:
        return {}
    batch = info.batch or BatchCost(1, info.wall_time_s, info.n_steps)
    per_step = batch.s_per_world_step
    return {
        Col.BATCH_SIZE: batch.size,
        Col.US_PER_WORLD_STEP: None if per_step is None else 1e6 * per_step,
        Col.WORLD_STEPS_PER_S: batch.world_steps_per_s,
    }


def scene_exact_columns(scene: Scene, mu: float) -> dict[str, Any]:
    """:func:`exact_columns` of ``scene`` with mus = muk = ``mu``."""
    return exact_columns(exact_solution(scene, mu).events, _exact_max_slip_speed(scene, mu))


def exact_columns(exact: Events, max_slip_speed: float | None = None) -> dict[str, Any]:
    """The ``exact_*`` columns of a row: the exact events of its scene (and mu), and the
    exact slips' largest speed, m/s (reference/regimes.py ``max_slip_speed``)."""
    return {
        Col.EXACT_OUTCOME: str(exact.outcome),
        Col.EXACT_T_SLIP: exact.t_slip,
        Col.EXACT_THETA_SLIP_DEG: None
        if exact.theta_slip is None
        else math.degrees(exact.theta_slip),
        Col.EXACT_T_LIFT: exact.t_lift,
        Col.EXACT_HOP_HEIGHT: exact.hop_height,
        Col.EXACT_T_IMPACT: exact.t_impact,
        Col.EXACT_T_PAINLEVE: painleve_time(exact),
        Col.EXACT_PHASES: exact.phase_code,
        Col.EXACT_T_LAST_PHASE: exact.phases[-1].t_start if exact.phases else None,
        Col.EXACT_MAX_SLIP_SPEED: max_slip_speed,
    }


def rms_position_error(trajectory: Trajectory, exact: ExactSolution) -> float | None:
    """RMS distance, m, between the run's and the exact hoop-centre positions over the common
    window (from 0 to whichever ends first: the run, or the exact solution at its impact).

    The hoop centre, not the centre of mass: it is where the contact events happen, and its
    path is the one the report draws.
    """
    t = trajectory.t[trajectory.t <= exact.t_final]
    if len(t) < 2:
        return None
    n = len(t)
    ref = exact.sample(t)
    x, y = kinematics.centre_position(
        exact.scene, trajectory.X[:n], trajectory.Y[:n], trajectory.theta[:n]
    )
    x0, y0 = kinematics.centre_position(exact.scene, ref.X, ref.Y, ref.theta)
    return float(np.sqrt(np.mean((x - x0) ** 2 + (y - y0) ** 2)))


def _error(value: float | None, reference: float | None) -> float | None:
    if value is None or reference is None:
        return None
    return value - reference


def _ms(seconds: float | None) -> float | None:
    return None if seconds is None else 1e3 * seconds


def _energy_columns(events: Events, traj: Trajectory) -> dict[str, Any]:
    before = traj.t < (events.t_slip if events.t_slip is not None else traj.t[-1])
    e0 = traj.energy[0]
    return {
        Col.ENERGY_RISE_BEFORE_SLIP: float((traj.energy[before].max() - e0) / e0)
        if before.any()
        else None,
        Col.ENERGY_CHANGE_END: float((traj.energy[-1] - e0) / e0),
    }


def _error_columns(events: Events, theta_deg: float | None, exact: Mapping[str, Any]) -> dict:
    exact_hop = exact[Col.EXACT_HOP_HEIGHT]
    return {
        Col.ERR_T_SLIP_MS: _ms(_error(events.t_slip, exact[Col.EXACT_T_SLIP])),
        Col.ERR_THETA_SLIP_DEG: _error(theta_deg, exact[Col.EXACT_THETA_SLIP_DEG]),
        Col.ERR_T_LIFT_MS: _ms(_error(events.t_lift, exact[Col.EXACT_T_LIFT])),
        Col.ERR_T_IMPACT_MS: _ms(_error(events.t_impact, exact[Col.EXACT_T_IMPACT])),
        Col.ERR_HOP_HEIGHT_REL: None
        if events.hop_height is None or not exact_hop
        else events.hop_height / exact_hop - 1.0,
    }


def event_columns(
    events: Events, traj: Trajectory, scene: Scene, exact: Mapping[str, Any]
) -> dict[str, Any]:
    """A judged run's event columns and their errors against ``exact`` (the row's
    ``exact_*`` columns, :func:`exact_columns`, with None for a missing value). The events
    are the judge's, checked against the scene (engines/judging/event_checks.py)."""
    theta_deg = None if events.theta_slip is None else math.degrees(events.theta_slip)
    columns = {
        Col.OUTCOME: str(events.outcome),
        Col.T_SLIP: events.t_slip,
        Col.T_SLIP_THRESHOLD: events.extra.get("t_slip_threshold"),
        Col.THETA_SLIP_DEG: theta_deg,
        Col.T_RESTICK: events.t_restick,
        Col.T_LIFT: events.t_lift,
        Col.HOP_HEIGHT: events.hop_height,
        Col.T_IMPACT: events.t_impact,
        **_error_columns(events, theta_deg, exact),
        **_energy_columns(events, traj),
        Col.MAX_PENETRATION_M: float(max(0.0, -traj.clearance.min())),
        Col.MAX_CLEARANCE: float(traj.clearance.max()),
        Col.CONSISTENT: not events.flags,
        Col.EVENT_FLAGS: " ".join(events.flags),
        Col.PHASES: events.phase_code,
        Col.T_LAST_PHASE: events.phases[-1].t_start if events.phases else None,
        Col.T_FINAL: float(traj.t[-1]),
    }
    return columns


def contact_columns(
    traj: Trajectory, scene: Scene, mu: float, exact: Mapping[str, Any]
) -> dict[str, Any]:
    """The run read through its contact force (engines/judging/contact.py) with the pair's
    ``mu``, and its event errors against ``exact`` (the row's exact columns)."""
    settings = ContactSettings().for_hoop(scene.a, scene.g)
    window_end = number_or_none(exact[Col.EXACT_T_IMPACT])
    reading = read_contact(traj, mu, settings, window_end=window_end)
    return {
        Col.CONTACT_PHASES: reading.phases,
        Col.CONTACT_T_SLIP: reading.t_slip,
        Col.CONTACT_T_RESTICK: reading.t_restick,
        Col.CONTACT_T_LIFT: reading.t_lift,
        Col.CONTACT_T_IMPACT: reading.t_impact,
        Col.CONTACT_HOP_HEIGHT: reading.hop_height,
        Col.CONTACT_T_LAST_PHASE: reading.t_last_phase,
        Col.ERR_CONTACT_T_SLIP_MS: _ms(_error(reading.t_slip, exact[Col.EXACT_T_SLIP])),
        Col.ERR_CONTACT_T_LIFT_MS: _ms(_error(reading.t_lift, exact[Col.EXACT_T_LIFT])),
        Col.ERR_CONTACT_T_IMPACT_MS: _ms(_error(reading.t_impact, exact[Col.EXACT_T_IMPACT])),
        Col.N_FLIGHTS: len(reading.flights),
        Col.CHATTER_COUNT: reading.chatter_count,
        Col.CHATTER_MAX_CLEARANCE: reading.chatter_max_clearance,
        Col.CREEP_TIME_S: reading.creep_time,
        Col.CREEP_MAX_SPEED: reading.creep_max_speed,
    }


def _row_mu(row: Mapping[str, Any], scene: Scene) -> float:
    """The pair's mu the run used (the row's), else the scene's."""
    mu = number_or_none(row.get(Col.MU))
    return scene.mus if mu is None else mu


def judged_columns(
    row: Mapping[str, Any],
    result: RunResult,
    scene: Scene,
    exact: ExactSolution | None = None,
) -> dict[str, Any]:
    """The columns a judged run adds to its ``row`` (which holds the run's status and
    message, the exact columns and the hoop's a and g): its events and their errors, the RMS
    position error and the contact force against the exact one (engines/judging/forces.py)
    when ``exact`` is given, and the verdict. A run without events (it failed or diverged)
    gets the verdict alone."""
    added: dict[str, Any] = {}
    if result.events is not None and result.trajectory is not None:
        added.update(event_columns(result.events, result.trajectory, scene, row))
        added.update(contact_columns(result.trajectory, scene, _row_mu(row, scene), row))
    # The phase rule and the verdict read the events as the verdict does (the contact
    # reading), with their sizes carried to the scene's hoop (a map row has no a or g).
    judged = {**row, **added, Col.A: scene.a, Col.G: scene.g}
    if added:
        added[Col.PHASES_AGREE] = row_phases_agree(judged)
    verdict = verdict_columns(judged)
    if exact is not None and result.events is not None and result.trajectory is not None:
        added[Col.RMS_POSITION_M] = rms_position_error(result.trajectory, exact)
        phases = added.get(Col.CONTACT_PHASES)
        added.update(force_columns(result.trajectory, exact, _row_mu(row, scene), phases))
    return {**added, **verdict}
