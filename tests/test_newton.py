"""Newton: its rigid-body solvers on the rolling hoop, and its batches (worlds in one model).

What each solver does with the rolling start of seed-mu (exact: rolls without slipping
until 0.987 s), dt 1e-3, tuned settings (ke 1e5), over 0.1 s; measured on newton 1.8.0,
warp-lang 1.19.0, CPU (docs/engines.md, Newton):

* mujoco (MuJoCo Warp inside Newton, soft constraints, friction solved with the normal):
  rolls, creeping at 0.66 mm/s by 0.1 s;
* xpbd (Newton's examples' default; positional contact and friction): creeps at 5.5 mm/s
  by 0.1 s, a slip velocity that keeps growing (31 mm/s by 0.5 s);
* featherstone, semi_implicit (penalty contact, friction regularised as viscous,
  kf (v_slip) capped at mu n): no rolling without slip; by 0.1 s the contact point slides at
  0.13 m/s (featherstone) and 6.6 mm/s (semi_implicit): a rolling contact is a sliding one at
  f / kf, and kf cannot be raised much: the
  hoop's small moment of inertia (k = 0.107 on seed-mu) makes the contact's effective mass
  about 0.03 kg, so an explicit friction of gain kf is stable only for kf dt / 0.03 kg < 2.
"""

from __future__ import annotations

import numpy as np
import pytest
from worlds_runs import DT, STATE_COLUMNS, run_ok, skip_without_a_warp_gpu

from hoopbench.engines.registry import get_engine
from hoopbench.engines.run import RunStatus
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene

SEED = get_scene("seed-mu").with_(t_end=0.1)
SLIP_AT_0_1_S = {"mujoco": 6.6e-4, "xpbd": 5.5e-3, "featherstone": 0.13, "semi_implicit": 6.6e-3}
"""|slip velocity|, m/s, at 0.1 s, measured (module doc)."""


def _run(scene=SEED, **options):
    return run_ok("newton", scene, **options)


@pytest.mark.parametrize("solver", sorted(SLIP_AT_0_1_S))
def test_what_each_solver_does_with_rolling(solver):
    traj = _run(solver=solver).trajectory
    slip = abs(traj.slip_velocity[-1])
    assert slip == pytest.approx(SLIP_AT_0_1_S[solver], rel=0.3), slip
    assert np.all(np.isfinite(traj.normal_force))


def test_forces_are_each_steps_momentum_change():
    """Row i's force is the step from state i's momentum balance: M dXdot/dt = f,
    M dYdot/dt = n - M g (per unit mass: the columns)."""
    traj = _run().trajectory
    g = SEED.g
    np.testing.assert_allclose(np.diff(traj.Xdot) / DT, traj.friction_force[:-1], atol=1e-9)
    np.testing.assert_allclose(np.diff(traj.Ydot) / DT, traj.normal_force[:-1] - g, atol=1e-9)


def test_batch_rows_are_the_single_runs():
    """Two worlds of different scenes and windows in one model: each is its single run;
    the world still running does not move while the other takes its last step."""
    engine = get_engine("newton")
    settings = RunSettings(timestep=DT)
    scenes = [get_scene("hop-top").with_(t_end=0.05), SEED.with_(t_end=0.08)]
    batch = engine.simulate_batch(scenes, settings)
    for scene, run in zip(scenes, batch, strict=True):
        single = engine.simulate(scene, settings)
        assert run.info.status is RunStatus.OK, run.info.message
        assert run.info.n_steps == single.info.n_steps
        worst = max(
            float(np.max(np.abs(getattr(run.trajectory, c) - getattr(single.trajectory, c))))
            for c in STATE_COLUMNS
        )
        assert worst <= 1e-6


def test_unknown_solver_is_named():
    with pytest.raises(ValueError, match="solver must be one of xpbd, featherstone"):
        get_engine("newton").check(SEED, RunSettings(options={"solver": "vbd"}))


@pytest.mark.gpu
def test_runs_on_a_gpu():
    skip_without_a_warp_gpu()
    assert _run(SEED.with_(t_end=0.02), device="gpu").info.status is RunStatus.OK
