"""Every transition of a run timed against the exact one (engines/judging/transitions.py):
the exact transitions after the floor's absorption, the pairing, and the columns of real
runs."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import engine_unavailable

import hoopbench as hb
from hoopbench.engines.judging.transitions import (
    exact_transition_times,
    matched_transitions,
    parse_times,
    times_text,
    transition_names,
)
from hoopbench.engines.judging.verdict import Verdict, classify
from hoopbench.models.events import Phase, PhaseKind
from hoopbench.models.trajectory import Trajectory

R, S, F = PhaseKind.ROLL, PhaseKind.SLIP, PhaseKind.FLIGHT


def test_the_times_are_stored_to_the_last_bit():
    times = (0.0, 0.9870806157672033, float("nan"))
    text = times_text(times)
    assert text == "0.0 0.9870806157672033 nan"
    back = parse_times(text)
    assert back is not None and back[:2] == times[:2] and math.isnan(back[2])
    assert parse_times(None) is None and parse_times("0.1 x") is None


def test_each_transition_is_named_and_counted_along_the_phases():
    codes = ["R", "S-", "S+", "R", "S-", "S+", "F"]
    assert transition_names(codes) == [
        "slip onset",
        "reversal 1",
        "re-stick 1",
        "slip onset 2",
        "reversal 2",
        "lift-off",
    ]
    assert transition_names(["R", "C", "R"]) == ["chatter 1", "roll 1"]


def test_a_transition_the_floor_absorbs_is_not_timed():
    """The exact solution re-sticks for 3 ms inside its slip; the reading at the run's
    timestep cannot see a roll that short and reads one slip. Its re-stick is matched to the
    exact re-stick of the same kind nearest in time (the one at 0.9 s), never to the
    absorbed one at 0.6 s, and the run's re-stick there agrees."""
    exact = (
        Phase(R, 0.0, 0.4),
        Phase(S, 0.4, 0.6, 1),
        Phase(R, 0.6, 0.603),
        Phase(S, 0.603, 0.9, 1),
        Phase(R, 0.9, 3.0),
    )
    floor = (Phase(R, 0.0, 0.4005), Phase(S, 0.4005, 0.9008, 1), Phase(R, 0.9008, 3.0))
    times = exact_transition_times(floor, exact)
    assert times == (0.0, 0.4, 0.9)
    row = {
        "status": "ok",
        "exact_outcome": "slips",
        "exact_t_slip": 0.4,
        "exact_phases": "R S+ R S+ R",
        "floor_phases": "R S+ R",
        "outcome": "slips",
        "t_slip": 0.401,
        "max_clearance": 0.0,
        "phases": "R S+ R",
        "phase_times": "0.0 0.401 0.902",
        "floor_phase_times": times_text(phase.t_start for phase in floor),
        "exact_phase_times": times_text(times),
    }
    judgement = classify(row)
    assert judgement.verdict is Verdict.AGREES
    (restick,) = matched_transitions(
        row["phases"],
        row["phase_times"],
        row["floor_phases"],
        row["floor_phase_times"],
        row["exact_phase_times"],
    )[1:]
    assert restick.name == "re-stick 1" and restick.t_exact == 0.9
    assert restick.floor == pytest.approx(0.8e-3)


def test_a_floor_transition_the_exact_solution_does_not_have_is_not_timed():
    """Absorption may change a transition's kind (S+ -> S- -> R read as S+ -> R): no exact
    transition of that kind, no time."""
    exact = (
        Phase(R, 0.0, 0.4),
        Phase(S, 0.4, 0.9, 1),
        Phase(S, 0.9, 0.902, -1),
        Phase(R, 0.902, 3),
    )
    floor = (Phase(R, 0.0, 0.4), Phase(S, 0.4, 0.902, 1), Phase(R, 0.902, 3.0))
    times = exact_transition_times(floor, exact)
    assert times[:2] == (0.0, 0.4) and math.isnan(times[2])
    pairs = matched_transitions(
        "R S+ R", "0.0 0.4 0.95", "R S+ R", "0.0 0.4 0.902", times_text(times)
    )
    assert [pair.name for pair in pairs] == ["slip onset"]


def _phase_times(row) -> list[float]:
    times = parse_times(row["phase_times"])
    assert times is not None
    return list(times)


def test_the_reference_run_times_every_transition_to_within_a_step():
    """hb.run's row of the exact solution sampled at 1 ms: every transition of seed-mu timed,
    each within a step of the exact one, and the worst named."""
    run = hb.run("reference", "seed-mu", timestep=1e-3)
    row = run.row
    assert row["verdict"] == "agrees"
    assert row["phases"] == row["floor_phases"] == "R S+ R S- R"
    errors = np.subtract(_phase_times(row), parse_times(row["exact_phase_times"]))
    assert np.all(np.abs(errors) <= 1e-3)
    assert row["max_transition"] in {"slip onset", "re-stick 1", "slip onset 2", "re-stick 2"}
    assert abs(row["max_transition_err_ms"]) <= 1.0 and row["max_transition_ratio"] < 0.1


def _stops_sliding(trajectory: Trajectory, after: float, speed: float = 1e-3) -> float:
    """The first time after ``after`` (s) from which the contact point's slip speed stays
    below ``speed`` (m/s) for 5 ms: a re-stick read from the trajectory's kinematics alone."""
    t, slip = trajectory.t, np.abs(trajectory.slip_velocity)
    for i in np.flatnonzero((t > after) & (slip < speed)):
        if np.all(slip[(t >= t[i]) & (t <= t[i] + 5e-3)] < speed):
            return float(t[i])
    raise AssertionError(f"still sliding after {after} s")


def test_a_restick_34_ms_early_no_longer_agrees():
    """pymunk (tuned) on seed-mu at dt 1e-3 slides back twice as fast as the exact hoop and
    stops 34 ms before it: its phase codes are the exact ones, and the row agreed. The
    re-stick the row times is where the trajectory's contact point stops (within a step),
    while the exact hoop still slides at over 0.3 m/s."""
    run = hb.run("pymunk", "seed-mu", timestep=1e-3)
    row = run.row
    assert row["phases"] == row["floor_phases"] == "R S+ R S- R"
    assert row["verdict"] == "early-transition"
    assert row["verdict_reason"].startswith("re-stick 2 (S- -> R)")
    assert row["max_transition"] == "re-stick 2" and row["max_transition_ratio"] > 2
    restick, exact = _phase_times(row)[4], parse_times(row["exact_phase_times"])[4]
    assert restick == pytest.approx(exact + 1e-3 * row["max_transition_err_ms"], abs=1e-9)
    assert run.result.trajectory is not None
    stopped = _stops_sliding(run.result.trajectory, _phase_times(row)[3] + 0.05)
    assert stopped == pytest.approx(restick, abs=2e-3)
    exact_slip = hb.exact("seed-mu").sample(np.array([restick])).slip_velocity[0]
    assert abs(exact_slip) > 0.3  # m/s: the exact hoop is far from re-sticking


def test_the_columns_of_a_mujoco_stock_run_hold_together():
    """MuJoCo stock on seed-mu at dt 1e-3: every transition timed, the worst of them in the
    columns as the verdict judged it (its ratio beyond 1 exactly where a check failed)."""
    run = hb.run("mujoco", "seed-mu", timestep=1e-3, profile="stock")
    if run.row["status"] == "unavailable":
        engine_unavailable("mujoco", run.row["message"])
    row = run.row
    judgement = classify(row)
    assert [event.name for event in judgement.timed] == [
        "slip onset",
        "re-stick 1",
        "slip onset 2",
        "re-stick 2",
    ]
    worst = judgement.worst
    assert worst is not None and row["max_transition"] == worst.name
    assert row["max_transition_err_ms"] == pytest.approx(1e3 * worst.error)
    assert row["max_transition_ratio"] == pytest.approx(abs(worst.error) / worst.loose)
    failed = {"early-transition", "late-transition", "early-slip", "late-slip"}
    assert bool(failed & set(row["verdict_flags"].split())) is (worst.ratio > 1)
