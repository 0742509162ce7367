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
from collections import OrderedDict
from collections.abc import Mapping
from typing import Any

import numpy as np

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.contact import canonical_events, read_run
from hoopbench.engines.judging.exact_samples import exact_sample
from hoopbench.engines.judging.forces import force_columns
from hoopbench.engines.judging.transitions import exact_transition_times, times_text
from hoopbench.engines.judging.verdict import (
    number_or_none,
    painleve_time,
    row_phases_agree,
    verdict_columns,
)
from hoopbench.engines.run import BatchCost, RunInfo, RunResult
from hoopbench.models import kinematics
from hoopbench.models.events import Events, Outcome
from hoopbench.models.scene import Scene
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import ExactSolution, solve_exact
from hoopbench.reference.regimes import max_slip_speed

__all__ = [
    "cost_columns",
    "event_columns",
    "exact_columns",
    "exact_solution",
    "floor_columns",
    "judged_columns",
    "kin_columns",
    "rms_position_error",
    "scene_exact_columns",
]


KEPT_SOLUTIONS = 64
"""Exact solutions a worker keeps (about 105 kB each, 7 MB in all: a 10x10 map's 100
solutions held 10.5 MB), the least recently used dropped first. A suite judges every engine
and profile of its 8-10 (scene, mu) pairs in turn; a map's task order keeps a point's runs
close (a batch of at most DEFAULT_BATCH_SIZE, 64, points, each point's single runs one after
the other), so a solution is rarely wanted again after 64 others. Unbounded, a worker kept
every point of a map it judged (a 40x40 map's 1,600 points: up to 168 MB). A map's
workers are given each point's solution by its classification (reports/hop_map/stages.py,
:meth:`_KeptSolutions.keep`) instead of solving it."""


class _KeptSolutions:
    """:func:`exact_solution`: the last :data:`KEPT_SOLUTIONS` solutions used, by (scene, mu),
    the least recently used dropped first (as functools.lru_cache, which has no way to keep
    a solution solved elsewhere: :meth:`keep`)."""

    def __init__(self, size: int) -> None:
        self.size = size
        self._kept: OrderedDict[tuple[Scene, float], ExactSolution] = OrderedDict()

    def __call__(self, scene: Scene, mu: float) -> ExactSolution:
        """The exact solution of ``scene`` with mus = muk = ``mu``, solved once per worker
        while kept: a suite or a map judges several engines and profiles on one scene in
        turn."""
        key = (scene, mu)
        solution = self._kept.get(key)
        if solution is None:
            solution = solve_exact(scene.with_(mus=mu, muk=mu))
        self._put(key, solution)
        return solution

    def holds(self, scene: Scene, mu: float) -> bool:
        """Whether this worker keeps the solution of (``scene``, ``mu``)."""
        return (scene, mu) in self._kept

    def keep(self, scene: Scene, mu: float, solution: ExactSolution) -> None:
        """Keep ``solution`` as this worker's solution of (``scene``, ``mu``): it must be
        what :meth:`__call__` would solve, bit for bit (a hop map's classification solves it
        once, in another worker: reports/hop_map/stages.py). Its scene must be
        ``scene`` with mus = muk = ``mu``, else ValueError."""
        if solution.scene != scene.with_(mus=mu, muk=mu):
            raise ValueError(f"a solution of {solution.scene} kept as one of {scene}, mu = {mu}")
        self._put((scene, mu), solution)

    def _put(self, key: tuple[Scene, float], solution: ExactSolution) -> None:
        self._kept[key] = solution
        self._kept.move_to_end(key)
        while len(self._kept) > self.size:
            self._kept.popitem(last=False)

    def cache_clear(self) -> None:
        """Forget every kept solution (tests)."""
        self._kept.clear()


exact_solution = _KeptSolutions(KEPT_SOLUTIONS)
"""The exact solution of ``scene`` with mus = muk = ``mu`` (a call), kept per worker
(:class:`_KeptSolutions`)."""


@functools.cache
def _exact_max_slip_speed(scene: Scene, mu: float) -> float | None:
    return max_slip_speed(exact_solution(scene, mu))


def cost_columns(info: RunInfo) -> dict[str, Any]:
    """What a run cost beside its wall time: the process's CPU time over its stepping
    (Col.CPU_TIME_S, Col.CPU_US_PER_STEP) and the cost of the batch it was stepped in
    (Col.BATCH_SIZE and after; empty for a run that produced nothing): a run stepped alone
    is a batch of one, its own times and steps. A batched run's wall_time_s and cpu_time_s
    are its shares of the batch's, by steps."""
    if info.wall_time_s is None or info.n_steps is None:
        return {}
    batch = info.batch or BatchCost(1, info.wall_time_s, info.n_steps, info.cpu_time_s)
    per_step = batch.s_per_world_step
    cpu_per_step = batch.cpu_s_per_world_step
    cpu = info.cpu_time_s
    return {
        Col.CPU_TIME_S: cpu,
        Col.CPU_US_PER_STEP: None if cpu is None or not info.n_steps else 1e6 * cpu / info.n_steps,
        Col.BATCH_SIZE: batch.size,
        Col.US_PER_WORLD_STEP: None if per_step is None else 1e6 * per_step,
        Col.WORLD_STEPS_PER_S: batch.world_steps_per_s,
        Col.CPU_US_PER_WORLD_STEP: None if cpu_per_step is None else 1e6 * cpu_per_step,
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
    ref = exact_sample(exact, t)
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


def _energy_columns(t_slip: float | None, traj: Trajectory) -> dict[str, Any]:
    before = traj.t < (t_slip if t_slip is not None else traj.t[-1])
    e0 = traj.energy[0]
    return {
        Col.ENERGY_RISE_BEFORE_SLIP: float((traj.energy[before].max() - e0) / e0)
        if before.any()
        else None,
        Col.ENERGY_CHANGE_END: float((traj.energy[-1] - e0) / e0),
    }


def _errors(events: Events, exact: Mapping[str, Any]) -> dict[str, float | None]:
    """Engine minus exact: times in ms, the angle in degrees, the height relative."""
    exact_hop = number_or_none(exact.get(Col.EXACT_HOP_HEIGHT))
    theta = None if events.theta_slip is None else math.degrees(events.theta_slip)
    return {
        "t_slip": _ms(_error(events.t_slip, number_or_none(exact.get(Col.EXACT_T_SLIP)))),
        "theta": _error(theta, number_or_none(exact.get(Col.EXACT_THETA_SLIP_DEG))),
        "t_lift": _ms(_error(events.t_lift, number_or_none(exact.get(Col.EXACT_T_LIFT)))),
        "t_impact": _ms(_error(events.t_impact, number_or_none(exact.get(Col.EXACT_T_IMPACT)))),
        "hop": None
        if events.hop_height is None or not exact_hop
        else events.hop_height / exact_hop - 1.0,
    }


def event_columns(
    traj: Trajectory,
    scene: Scene,
    mu: float,
    exact: Mapping[str, Any],
    *,
    painleve: bool = False,
) -> dict[str, Any]:
    """The run's events by the canonical reading (engines/judging/contact.py) with the
    pair's ``mu``, and their errors against ``exact`` (the row's exact columns); with
    ``painleve``, the outcome is the reference's ``painleve``."""
    window_end = number_or_none(exact.get(Col.EXACT_T_IMPACT))
    exact_lift = number_or_none(exact.get(Col.EXACT_T_LIFT))
    reading = read_run(traj, scene, mu, window_end=window_end, exact_lift=exact_lift)
    events = canonical_events(traj, reading, painleve=painleve)
    errors = _errors(events, exact)
    return {
        Col.OUTCOME: str(events.outcome),
        Col.T_SLIP: events.t_slip,
        Col.THETA_SLIP_DEG: None if events.theta_slip is None else math.degrees(events.theta_slip),
        Col.T_RESTICK: events.t_restick,
        Col.T_LIFT: events.t_lift,
        Col.HOP_HEIGHT: events.hop_height,
        Col.T_IMPACT: events.t_impact,
        Col.ERR_T_SLIP_MS: errors["t_slip"],
        Col.ERR_THETA_SLIP_DEG: errors["theta"],
        Col.ERR_T_LIFT_MS: errors["t_lift"],
        Col.ERR_T_IMPACT_MS: errors["t_impact"],
        Col.ERR_HOP_HEIGHT_REL: errors["hop"],
        Col.PHASES: reading.phases,
        Col.PHASE_TIMES: times_text([mode.t_start for mode in reading.modes]),
        Col.T_LAST_PHASE: reading.t_last_phase,
        Col.N_FLIGHTS: len(reading.flights),
        Col.CHATTER_COUNT: reading.chatter_count,
        Col.CHATTER_MAX_CLEARANCE: reading.chatter_max_clearance,
        Col.CREEP_TIME_S: reading.creep_time,
        Col.CREEP_MAX_SPEED: reading.creep_max_speed,
        Col.CREEP_DISTANCE_M: reading.creep_distance,
        Col.CONE_STICK_TIME_S: reading.cone_stick_time,
        Col.CHATTERING_TIME_S: reading.chattering_time,
        Col.CHATTER_CONE_SHARE: reading.chatter_cone_share,
        Col.CHATTERS: reading.chatters,
        Col.MU_EFFECTIVE: None
        if reading.slip_friction_ratio is None
        else reading.slip_friction_ratio * mu,
        Col.MU_EFFECTIVE_RATIO: reading.slip_friction_ratio,
        **_energy_columns(events.t_slip, traj),
        Col.MAX_PENETRATION_M: float(max(0.0, -traj.clearance.min())),
        Col.MAX_CLEARANCE: float(traj.clearance.max()),
        Col.T_FINAL: float(traj.t[-1]),
    }


def kin_columns(events: Events, exact: Mapping[str, Any]) -> dict[str, Any]:
    """The kinematic reading's columns (the shared detectors' events, checked against the
    scene: engines/judging/event_checks.py) and their errors against ``exact``: shown only
    where the two readings are compared."""
    errors = _errors(events, exact)
    return {
        Col.KIN_OUTCOME: str(events.outcome),
        Col.KIN_T_SLIP: events.t_slip,
        Col.KIN_T_SLIP_THRESHOLD: events.extra.get("t_slip_threshold"),
        Col.KIN_THETA_SLIP_DEG: None
        if events.theta_slip is None
        else math.degrees(events.theta_slip),
        Col.KIN_T_RESTICK: events.t_restick,
        Col.KIN_T_LIFT: events.t_lift,
        Col.KIN_HOP_HEIGHT: events.hop_height,
        Col.KIN_T_IMPACT: events.t_impact,
        Col.KIN_ERR_T_SLIP_MS: errors["t_slip"],
        Col.KIN_ERR_THETA_SLIP_DEG: errors["theta"],
        Col.KIN_ERR_T_LIFT_MS: errors["t_lift"],
        Col.KIN_ERR_T_IMPACT_MS: errors["t_impact"],
        Col.KIN_ERR_HOP_HEIGHT_REL: errors["hop"],
        Col.KIN_PHASES: events.phase_code,
        Col.KIN_T_LAST_PHASE: events.phases[-1].t_start if events.phases else None,
        Col.CONSISTENT: not events.flags,
        Col.EVENT_FLAGS: " ".join(events.flags),
    }


def _sampled(solution: ExactSolution, timestep: float) -> Trajectory | None:
    """The exact solution on a run's time grid, as the reference engine samples it: every
    ``timestep`` up to the scene's window end (or the solution's end, if earlier), plus the
    solution's last instant (the impact, for a hop). None where that is too many samples."""
    end = min(solution.scene.t_end, solution.t_final)
    n = math.floor(end / timestep * (1.0 + 1e-12))
    if n > 10_000_000:
        return None
    t = np.unique(
        np.minimum(np.append(np.arange(n + 1) * timestep, solution.t_final), solution.t_final)
    )
    # Kept (exact_samples.py): a run at this timestep samples a prefix of these times.
    sampled = exact_sample(solution, t)
    finite = np.isfinite(sampled.normal_force) & np.isfinite(sampled.friction_force)
    if not finite.all():  # a Painlevé point's last instant has no finite force
        sampled = exact_sample(solution, t[finite])
    return sampled if len(sampled.t) >= 2 else None


@functools.lru_cache(maxsize=64)
def _floor(scene: Scene, mu: float, timestep: float) -> dict[str, Any]:
    solution = exact_solution(scene, mu)
    exact = exact_columns(solution.events)
    sampled = _sampled(solution, timestep)
    if sampled is None:
        return {}
    window_end = number_or_none(exact.get(Col.EXACT_T_IMPACT))
    exact_lift = number_or_none(exact.get(Col.EXACT_T_LIFT))
    reading = read_run(sampled, solution.scene, mu, window_end=window_end, exact_lift=exact_lift)
    errors = _errors(canonical_events(sampled, reading), exact)
    exact_times = exact_transition_times(reading.modes, solution.events.phases)
    return {
        Col.FLOOR_PHASES: reading.phases,
        Col.FLOOR_PHASE_TIMES: times_text([mode.t_start for mode in reading.modes]),
        Col.EXACT_PHASE_TIMES: times_text(exact_times),
        Col.FLOOR_T_LAST_PHASE: reading.t_last_phase,
        Col.FLOOR_ERR_T_SLIP_MS: errors["t_slip"],
        Col.FLOOR_ERR_T_LIFT_MS: errors["t_lift"],
        Col.FLOOR_ERR_T_IMPACT_MS: errors["t_impact"],
        Col.FLOOR_ERR_HOP_HEIGHT_REL: errors["hop"],
    }


def floor_columns(scene: Scene, mu: float, timestep: float | None) -> dict[str, Any]:
    """The detection floor of a run (docs/report.md): the exact solution of ``scene`` with
    ``mu``, sampled at the run's ``timestep`` and read by the canonical reading, its phases
    and their start times, the exact solver's start times of those phases (the floor's
    transitions matched to the exact ones: engines/judging/transitions.py), and its errors
    against the exact events. Empty without a timestep."""
    if timestep is None or not timestep > 0:
        return {}
    return dict(_floor(scene, mu, float(timestep)))


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
    message, the exact columns, its timestep and the hoop's a and g): its events by the
    canonical reading and their errors, the kinematic reading, the detection floor at its
    timestep, the RMS position error and the contact force against the exact one
    (engines/judging/forces.py) when ``exact`` is given, and the verdict. A run without
    events (it failed or diverged) gets the verdict alone."""
    added: dict[str, Any] = {}
    mu = _row_mu(row, scene)
    if result.events is not None and result.trajectory is not None:
        painleve = result.events.outcome is Outcome.PAINLEVE  # the reference's own verdict
        added.update(event_columns(result.trajectory, scene, mu, row, painleve=painleve))
        added.update(kin_columns(result.events, row))
        if row.get(Col.EXACT_OUTCOME) is not None:
            added.update(floor_columns(scene, mu, number_or_none(row.get(Col.TIMESTEP))))
    # The phase rule and the verdict read the canonical events, with their sizes carried to
    # the scene's hoop (a map row has no a or g).
    judged = {**row, **added, Col.A: scene.a, Col.G: scene.g}
    if added:
        added[Col.PHASES_AGREE] = row_phases_agree(judged)
    verdict = verdict_columns(judged)
    if exact is not None and result.events is not None and result.trajectory is not None:
        added[Col.RMS_POSITION_M] = rms_position_error(result.trajectory, exact)
        added.update(force_columns(result.trajectory, exact, mu, added.get(Col.PHASES)))
    return {**added, **verdict}
