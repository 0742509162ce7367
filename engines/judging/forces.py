"""Contact-force truth: a run's contact forces against the exact solution of its scene.

No benchmark reports whether an engine's contact force is the right one; these columns do,
per run (engines/judging/comparison.py adds them to a suite's rows; a map's rows have none):

* ``force_rms_n_g``, ``force_rms_f_g``: RMS of (n - n_exact)/g and (f - f_exact)/g over the
  *window*: the exact contact phases (roll, slip) up to the end of the last exact phase of the
  common prefix of the exact phase code and the engine's (its contact reading's), less GUARD
  on either side of t = 0 and of every exact phase boundary there (an engine's transitions
  land a few ms from the exact ones, and its re-stick impulse is one sample of 5-27 g:
  tests/test_contact_forces.py). Empty when the window holds no sample.
* ``cone_violation``: the largest (|f| - mu n)/g over the samples with a contact force, the
  whole run; 0 when never above (> 0: friction outside the Coulomb cone).
* ``dissipation_violation``: the fraction of the window's slipping samples (an exact slip
  phase, with a contact force) whose friction does not oppose the slip velocity
  (f * slip_velocity > 0); maximum dissipation says it always opposes. Empty without such
  samples.
* ``max_penetration_in_contact_m``: the deepest penetration, -clearance, over the samples
  with a contact force (0 when none penetrates; empty when none has one).

The samples with a contact force are the canonical reading's (engines/judging/contact.py,
``contact_masks``): a normal force above its contact level, or a friction above its friction
level. So a friction without a normal force (DART stock's, up to 6 g) is a cone violation of
its whole size, and round-off normal forces without friction count for none of the three.
* ``energy_change_before_slip``: (E(t) - E(0)) / E(0) at the exact first slip onset, or the
  window's end if the exact solution never slips (E interpolated between samples): rolling
  conserves energy, so any change is the engine's. Empty when that time is past the run.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.contact import ContactSettings, contact_masks
from hoopbench.engines.judging.exact_samples import exact_sample
from hoopbench.models.events import Phase, PhaseKind
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import ExactSolution

__all__ = ["GUARD", "force_columns", "force_window_end"]

GUARD = 5e-3
"""s left out on either side of t = 0 and of every exact phase boundary in the window."""


def force_window_end(exact_phases: tuple[Phase, ...], engine_phases: str | None) -> float | None:
    """The end of the last exact phase the engine's phase code (``"R S+ R"``) agrees with,
    from the first phase on; None when the first phases differ (or the engine has none)."""
    engine = (engine_phases or "").split()
    common = 0
    for phase, code in zip(exact_phases, engine, strict=False):
        if phase.code != code:
            break
        common += 1
    return exact_phases[common - 1].t_end if common else None


def _window_rows(
    t: NDArray, phases: tuple[Phase, ...], end: float | None
) -> tuple[NDArray[np.intp], NDArray[np.int_]]:
    """The window's row indices, and per row of ``t`` the exact slip direction (0 elsewhere)."""
    sigma = np.zeros(len(t), dtype=int)
    keep = np.zeros(len(t), dtype=bool)
    if end is None:
        return np.flatnonzero(keep), sigma
    for phase in phases:
        inside = (t >= phase.t_start) & (t < phase.t_end) & (t <= end)
        if phase.kind is not PhaseKind.FLIGHT:
            keep |= inside
        if phase.kind is PhaseKind.SLIP:
            sigma[inside] = phase.sigma or 0
    for boundary in [0.0, *(p.t_end for p in phases if p.t_end <= end)]:
        keep &= np.abs(t - boundary) > GUARD
    return np.flatnonzero(keep), sigma


def _rms(values: NDArray) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def _energy_change(traj: Trajectory, until: float | None) -> float | None:
    if until is None or until > traj.t[-1]:
        return None
    e0 = traj.energy[0]
    return float((np.interp(until, traj.t, traj.energy) - e0) / e0)


def _contact_columns(traj: Trajectory, forced: NDArray, mu: float, g: float) -> dict[str, Any]:
    """The columns read over the whole run's samples with a contact force (``forced``)."""
    if not forced.any():
        return {Col.CONE_VIOLATION: None, Col.MAX_PENETRATION_IN_CONTACT_M: None}
    n, f = traj.normal_force[forced], traj.friction_force[forced]
    return {
        Col.CONE_VIOLATION: max(0.0, float(np.max((np.abs(f) - mu * n) / g))),
        Col.MAX_PENETRATION_IN_CONTACT_M: max(0.0, float(np.max(-traj.clearance[forced]))),
    }


def force_columns(
    traj: Trajectory, exact: ExactSolution, mu: float, engine_phases: str | None
) -> dict[str, Any]:
    """The contact-force columns of a run (module doc) against ``exact``, the exact solution
    of its scene and ``mu``; ``engine_phases`` is the run's contact-reading phase code."""
    g = exact.scene.g
    _, forced = contact_masks(traj, ContactSettings().for_scene(exact.scene))
    phases = exact.events.phases
    end = force_window_end(phases, engine_phases)
    if end is not None:
        end = min(end, exact.t_final)
    rows, sigma = _window_rows(traj.t, phases, end)
    columns: dict[str, Any] = {Col.FORCE_RMS_N_G: None, Col.FORCE_RMS_F_G: None}
    if len(rows):
        ref = exact_sample(exact, traj.t[rows])
        columns[Col.FORCE_RMS_N_G] = _rms((traj.normal_force[rows] - ref.normal_force) / g)
        columns[Col.FORCE_RMS_F_G] = _rms((traj.friction_force[rows] - ref.friction_force) / g)
    slipping = rows[(sigma[rows] != 0) & forced[rows]]
    columns[Col.DISSIPATION_VIOLATION] = (
        float(np.mean(traj.friction_force[slipping] * traj.slip_velocity[slipping] > 0))
        if len(slipping)
        else None
    )
    columns.update(_contact_columns(traj, forced, mu, g))
    t_slip = exact.events.t_slip
    columns[Col.ENERGY_CHANGE_BEFORE_SLIP] = _energy_change(
        traj, t_slip if t_slip is not None else end
    )
    return columns
