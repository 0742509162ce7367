"""The contact-force columns against the exact solution (engines/judging/forces.py) and their
report section: ~0 on the reference's own run, the known numbers on a made-up trajectory."""

from __future__ import annotations

import functools
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.judging.columns import FORCE_COLUMNS, Col
from hoopbench.engines.judging.comparison import (
    exact_solution,
    judged_columns,
    scene_exact_columns,
)
from hoopbench.engines.judging.forces import GUARD, force_columns, force_window_end
from hoopbench.engines.registry import get_engine
from hoopbench.engines.settings import RunSettings
from hoopbench.models.catalogue import get_scene
from hoopbench.models.events import PhaseKind
from hoopbench.models.trajectory import Trajectory
from hoopbench.reference.exact import ExactSolution
from hoopbench.reports.compare.suite import compare
from hoopbench.reports.report.build import build_report

SCENE = "seed-mu"
"""Rolls, slips, re-sticks, slips back, rolls: R S+ R S- R."""


@functools.cache
def exact() -> ExactSolution:
    scene = get_scene(SCENE)
    return exact_solution(scene, scene.mus)


@functools.cache
def sampled() -> Trajectory:
    """The exact solution sampled every 1e-4 s: a run that is exact."""
    return exact().sample_uniform(1e-4)


def columns(traj: Trajectory, phases: str | None = None) -> dict:
    solution = exact()
    code = solution.events.phase_code if phases is None else phases
    return force_columns(traj, solution, solution.scene.mus, code)


def with_forces(traj: Trajectory, **arrays) -> Trajectory:
    return replace(traj, **arrays)


# --------------------------------------------------------------------------- the reference
@pytest.mark.parametrize("scene_name", ["seed-mu", "hop-top"])
def test_the_reference_run_is_its_own_truth(scene_name):
    """The reference engine's run, judged as a suite judges it: every column ~0."""
    scene = get_scene(scene_name)
    result = get_engine("reference").run(scene, RunSettings(timestep=1e-4))
    row = {Col.MU: scene.mus, Col.A: scene.a, Col.G: scene.g, Col.STATUS: "ok"}
    row |= scene_exact_columns(scene, scene.mus)
    judged = judged_columns(row, result, scene, exact_solution(scene, scene.mus))
    assert judged[Col.PHASES] == row[Col.EXACT_PHASES]
    for column in FORCE_COLUMNS:
        assert judged[column] == pytest.approx(0.0, abs=1e-9), column


def test_a_map_row_has_no_force_columns():
    """Without the exact solution (the hop map), the columns are not computed."""
    scene = get_scene(SCENE)
    result = get_engine("reference").run(scene, RunSettings(timestep=1e-3))
    row = {Col.MU: scene.mus, Col.A: scene.a, Col.G: scene.g, Col.STATUS: "ok"}
    judged = judged_columns(row | scene_exact_columns(scene, scene.mus), result, scene)
    assert not set(FORCE_COLUMNS) & set(judged)


# --------------------------------------------------------------------------- known errors
def test_a_force_offset_is_its_rms():
    """n off by 0.1 g and f by -0.05 g on every sample: RMS 0.1 and 0.05."""
    traj = sampled()
    g = exact().scene.g
    made = with_forces(
        traj,
        normal_force=traj.normal_force + 0.1 * g,
        friction_force=traj.friction_force - 0.05 * g,
    )
    got = columns(made)
    assert got[Col.FORCE_RMS_N_G] == pytest.approx(0.1, rel=1e-9)
    assert got[Col.FORCE_RMS_F_G] == pytest.approx(0.05, rel=1e-9)


def test_the_window_ends_where_the_phases_depart():
    """An error of 1 g after the exact third phase counts when the engine's phases agree all
    along, and not when they depart there (engine R S+ R R against the exact R S+ R S- R)."""
    traj = sampled()
    g = exact().scene.g
    phases = exact().events.phases
    assert exact().events.phase_code == "R S+ R S- R"
    end = force_window_end(phases, "R S+ R R")
    assert end == phases[2].t_end
    late = traj.t > end
    made = with_forces(traj, normal_force=traj.normal_force + np.where(late, g, 0.0))
    assert columns(made, "R S+ R R")[Col.FORCE_RMS_N_G] == pytest.approx(0.0, abs=1e-12)
    assert columns(made)[Col.FORCE_RMS_N_G] > 0.3
    assert force_window_end(phases, "S+ R") is None
    assert columns(made, "S+ R")[Col.FORCE_RMS_N_G] is None


def test_a_boundary_spike_is_left_out():
    """A 20 g re-stick impulse one sample after the exact re-stick is left out (GUARD)."""
    traj = sampled()
    g = exact().scene.g
    restick = exact().events.phases[1].t_end
    i = int(np.searchsorted(traj.t, restick + 0.5 * GUARD))
    n = traj.normal_force.copy()
    n[i] += 20 * g
    assert columns(with_forces(traj, normal_force=n))[Col.FORCE_RMS_N_G] == pytest.approx(
        0.0, abs=1e-12
    )


def test_friction_outside_the_cone_is_its_excess():
    """One sample in contact with |f| = mu n + 0.3 g: cone violation 0.3."""
    traj = sampled()
    solution = exact()
    g, mu = solution.scene.g, solution.scene.mus
    i = int(np.searchsorted(traj.t, 0.5))
    f = traj.friction_force.copy()
    f[i] = -(mu * traj.normal_force[i] + 0.3 * g)
    got = columns(with_forces(traj, friction_force=f))
    assert got[Col.CONE_VIOLATION] == pytest.approx(0.3, rel=1e-9)


def test_friction_with_the_slip_is_counted():
    """Friction reversed on the window's first slip phase: that phase's share of the
    window's slipping samples."""
    traj = sampled()
    phases = exact().events.phases
    slips = [p for p in phases if p.kind is PhaseKind.SLIP]
    inside = [(traj.t > p.t_start + GUARD) & (traj.t < p.t_end - GUARD) for p in slips]
    f = np.where(inside[0], -traj.friction_force, traj.friction_force)
    got = columns(with_forces(traj, friction_force=f))
    expected = inside[0].sum() / sum(s.sum() for s in inside)
    assert 0.2 < expected < 0.8
    assert got[Col.DISSIPATION_VIOLATION] == pytest.approx(expected, abs=2e-3)


def test_penetration_counts_only_with_a_contact_force():
    """1 mm deep with a force, 5 mm deep without (no normal force, no friction), 4 mm deep
    with a round-off normal force (1e-9 g, below the contact level) and no friction: 1 mm."""
    traj = sampled()
    g = exact().scene.g
    clearance, n = traj.clearance.copy(), traj.normal_force.copy()
    f = traj.friction_force.copy()
    clearance[1000], clearance[2000], clearance[2500] = -1e-3, -5e-3, -4e-3
    n[2000], n[2500] = 0.0, 1e-9 * g
    f[2000] = f[2500] = 0.0
    got = columns(with_forces(traj, clearance=clearance, normal_force=n, friction_force=f))
    assert got[Col.MAX_PENETRATION_IN_CONTACT_M] == pytest.approx(1e-3)


def test_a_friction_without_a_normal_force_is_a_cone_violation_of_its_whole_size():
    """A friction of 0.5 g where the normal force is 0 (DART stock's, up to 6 g, the
    canonical reading's contact force): cone violation 0.5, and the penetration there counts."""
    traj = sampled()
    g = exact().scene.g
    clearance, n = traj.clearance.copy(), traj.normal_force.copy()
    f = traj.friction_force.copy()
    n[1500], f[1500], clearance[1500] = 0.0, -0.5 * g, -2e-3
    got = columns(with_forces(traj, clearance=clearance, normal_force=n, friction_force=f))
    assert got[Col.CONE_VIOLATION] == pytest.approx(0.5, rel=1e-9)
    assert got[Col.MAX_PENETRATION_IN_CONTACT_M] == pytest.approx(2e-3)


def test_energy_gained_before_the_slip():
    """Energy 2 % up from half the exact slip onset on: change 0.02."""
    traj = sampled()
    t_slip = exact().events.t_slip
    energy = np.where(traj.t >= 0.5 * t_slip, 1.02 * traj.energy, traj.energy)
    got = columns(with_forces(traj, energy=energy))
    e0, e_slip = traj.energy[0], np.interp(t_slip, traj.t, traj.energy)
    assert got[Col.ENERGY_CHANGE_BEFORE_SLIP] == pytest.approx(1.02 * e_slip / e0 - 1, rel=1e-6)
    assert got[Col.ENERGY_CHANGE_BEFORE_SLIP] == pytest.approx(0.02, abs=1e-6)


# --------------------------------------------------------------------------- the report
TINY = """
name = "tiny"
engines = ["reference", "pymunk"]
timesteps = [1e-4]
scenes = ["seed-mu"]
"""


@pytest.mark.slow  # one pymunk run of seed-mu, about 5 s
def test_the_section_renders_from_a_tiny_results_folder(tmp_path):
    suite = tmp_path / "tiny.toml"
    suite.write_text(TINY)
    out = tmp_path / "out"
    summary = compare(suite, out, jobs=1, quiet=True, trajectories="default")
    assert summary.completed
    text = build_report(out).read_text()
    section = text.split("## Contact forces against the exact solution")[1].split("\n## ")[0]
    lines = [line for line in section.splitlines() if line.startswith("| ")]
    assert lines[0].startswith("| engine | profile | runs | RMS n/g")
    rows = {line.split(" | ")[0].strip("| "): line.split(" | ") for line in lines[1:]}
    assert set(rows) == {"reference", "pymunk"}
    assert rows["reference"][3:5] == ["0", "0"]
    assert float(rows["pymunk"][3]) > 0.01  # its steps without contact (docs/engines.md)
    assert "![contact forces](contact_forces.png)" in section
    assert (out / "contact_forces.png").stat().st_size > 0
    runs = pd.read_parquet(out / "runs")
    assert runs[list(FORCE_COLUMNS)].notna().all().all()
