"""The verdict on a run, from synthetic rows of the runs table (engines/judging/verdict.py), and the
row builder that writes it."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
import pytest

from hoopbench.engines.judging.comparison import exact_columns, judged_columns
from hoopbench.engines.judging.judge import judge
from hoopbench.engines.judging.tolerances import Tier, event_tolerances
from hoopbench.engines.judging.verdict import (
    OUTCOME_FAILURES,
    Verdict,
    classify,
    painleve_time,
    row_phases_agree,
    verdict_columns,
)
from hoopbench.engines.run import Run, RunInfo, RunStatus
from hoopbench.models import kinematics
from hoopbench.models.events import Events, Outcome, Phase, PhaseKind
from hoopbench.models.trajectory import Trajectory
from hoopbench.reports.compare.suite import ROW_COLUMNS, TIMEOUT_NOTE, failure_row
from hoopbench.reports.compare.suite_file import parse_suite

HOP_ROW: dict[str, Any] = {
    "status": "ok",
    "exact_outcome": "hops",
    "exact_t_slip": 0.4,
    "exact_t_lift": 1.0,
    "exact_hop_height": 1.0,
    "exact_t_painleve": None,
    "exact_phases": "R S+ F",
    "outcome": "hops",
    "t_slip": 0.4,
    "t_lift": 1.0,
    "hop_height": 1.0,
    "t_impact": 1.9,
    "max_clearance": 1.0,
    "phases": "R S+ F",
}
"""A run that hops exactly as the reference does: a 1 m hop lifting off at 1 s."""

SLIP_ROW: dict[str, Any] = {
    **HOP_ROW,
    "exact_outcome": "slips",
    "exact_t_lift": None,
    "exact_hop_height": None,
    "exact_phases": "R S+ R",
    "outcome": "slips",
    "t_lift": None,
    "hop_height": None,
    "max_clearance": 2e-6,
    "phases": "R S+ R",
}
"""A run that slips and re-sticks, as the reference does."""

ROLL_ROW: dict[str, Any] = {
    **SLIP_ROW,
    "exact_outcome": "rolls",
    "exact_t_slip": None,
    "exact_phases": "R",
    "outcome": "rolls",
    "t_slip": None,
    "phases": "R",
}

PAINLEVE_ROW: dict[str, Any] = {
    **SLIP_ROW,
    "exact_outcome": "painleve",
    "exact_t_slip": 0.0,
    "exact_t_painleve": 0.18,
    "exact_phases": "S+",
    "outcome": "hops",
    "t_slip": 0.0,
    "t_lift": 0.19,
    "hop_height": 0.9,
    "max_clearance": 0.9,
    "phases": "S+ F",
}
"""A sliding start that reaches a Painlevé point at 0.18 s; the engine hops at 0.19 s."""


TWO_SLIPS_ROW: dict[str, Any] = {
    **SLIP_ROW,
    "exact_phases": "R S+ R S- R",
    "floor_phases": "R S+ R S- R",
    "phases": "R S+ R S- R",
    "exact_phase_times": "0.0 0.4 0.861 1.3 1.5",
    "floor_phase_times": "0.0 0.4 0.862 1.3 1.5",
    "phase_times": "0.0 0.4 0.861 1.3 1.5",
}
"""Slips, re-sticks, slips back and re-sticks as the reference does, every transition on
time; the reading at the run's timestep sees the first re-stick 1 ms late (its floor): a
re-stick's tolerances are 3 ms tight and 11 ms loose."""


def _late_restick(seconds: float) -> dict[str, Any]:
    """TWO_SLIPS_ROW with the run's first re-stick ``seconds`` after the exact one."""
    return {**TWO_SLIPS_ROW, "phase_times": f"0.0 0.4 {0.861 + seconds!r} 1.3 1.5"}


def _verdict(row: dict[str, Any]) -> tuple[Verdict | None, bool | None]:
    judgement = classify(row)
    return judgement.verdict, judgement.outcome_agrees


# --------------------------------------------------------------------------- the rows
def test_a_blip_does_not_agree_with_a_real_hop():
    """A 0.3 mm lift-off against a 1 m exact hop, as PyBullet and MuJoCo have them: the
    reading calls it chatter (no t_lift; tests/test_contact_reading.py), a missed hop."""
    row = {**HOP_ROW, "t_lift": None, "hop_height": None, "max_clearance": 3e-4}
    assert _verdict(row) == (Verdict.MISSED_HOP, False)


def test_a_hop_10_percent_low_and_20_ms_late_does_not_agree():
    """A 0.9 m hop lifting off 20 ms late against the 1 m exact hop agreed before issue 24
    (a factor 2 and 50 ms); the one tolerance table's loose tier is 5 % and 10 ms."""
    row = {**HOP_ROW, "t_lift": 1.02, "hop_height": 0.9, "max_clearance": 0.9}
    judgement = classify(row)
    assert judgement.flags == (Verdict.HOP_TOO_LOW, Verdict.LATE_LIFT_OFF)
    assert judgement.outcome_agrees is False


# --------------------------------------------------------------------------- every verdict
CASES: list[tuple[str, dict[str, Any], Verdict, bool]] = [
    ("agrees, hop", HOP_ROW, Verdict.AGREES, True),
    ("agrees, slip", SLIP_ROW, Verdict.AGREES, True),
    ("agrees, roll", ROLL_ROW, Verdict.AGREES, True),
    (
        "false-hop: 5 mm where the reference slips",
        {**SLIP_ROW, "outcome": "hops", "t_lift": 1.2, "hop_height": 5e-3, "phases": "R S+ F"},
        Verdict.FALSE_HOP,
        False,
    ),
    (
        "false-hop: where the reference rolls",
        {**ROLL_ROW, "outcome": "hops", "t_lift": 1.2, "hop_height": 5e-3, "phases": "R F"},
        Verdict.FALSE_HOP,
        False,
    ),
    (
        "missed-hop: slips where the reference hops",
        {**HOP_ROW, "outcome": "slips", "t_lift": None, "hop_height": None, "phases": "R S+ R"},
        Verdict.MISSED_HOP,
        False,
    ),
    (
        "missed-slip: rolls where the reference slips",
        {**SLIP_ROW, "outcome": "rolls", "t_slip": None, "phases": "R"},
        Verdict.MISSED_SLIP,
        False,
    ),
    (
        "false-slip: slips where the reference rolls",
        {**ROLL_ROW, "outcome": "slips", "t_slip": 0.7, "phases": "R S+"},
        Verdict.FALSE_SLIP,
        False,
    ),
    (
        "wrong-phases: the slip does not re-stick",
        {**SLIP_ROW, "phases": "R S+"},
        Verdict.WRONG_PHASES,
        True,
    ),
    (
        "wrong-phases: the right hop after an extra slip",
        {**HOP_ROW, "phases": "R S+ S- F"},
        Verdict.WRONG_PHASES,
        True,
    ),
    (
        "hop-too-low: 0.4 m against 1 m",
        {**HOP_ROW, "hop_height": 0.4, "max_clearance": 0.4},
        Verdict.HOP_TOO_LOW,
        False,
    ),
    (
        "hop-too-high: 2.5 m against 1 m",
        {**HOP_ROW, "hop_height": 2.5, "max_clearance": 2.5},
        Verdict.HOP_TOO_HIGH,
        False,
    ),
    ("early-lift-off: 100 ms", {**HOP_ROW, "t_lift": 0.9}, Verdict.EARLY_LIFT_OFF, False),
    ("late-lift-off: 60 ms", {**HOP_ROW, "t_lift": 1.06}, Verdict.LATE_LIFT_OFF, False),
    ("close: lift-off 5 ms late", {**HOP_ROW, "t_lift": 1.005}, Verdict.CLOSE, True),
    (
        "early-impact: 20 ms",
        {**HOP_ROW, "exact_t_impact": 1.9, "t_impact": 1.88},
        Verdict.EARLY_IMPACT,
        False,
    ),
    (
        "late-impact: still in the air 50 ms after the exact impact",
        {**HOP_ROW, "exact_t_impact": 1.9, "t_impact": None, "t_final": 1.95},
        Verdict.LATE_IMPACT,
        False,
    ),
    (
        "cone-violation: a 10 ms stick outside the cone",
        {**SLIP_ROW, "cone_stick_time_s": 0.01},
        Verdict.CONE_VIOLATION,
        True,
    ),
    (
        "creeps: slides 5 cm with friction inside the cone where the reference rolls",
        {**ROLL_ROW, "creep_distance_m": 0.05, "creep_max_speed": 0.5},
        Verdict.CREEPS,
        True,
    ),
    (
        "close: creeps 3 mm",
        {**ROLL_ROW, "creep_distance_m": 3e-3, "creep_max_speed": 0.02},
        Verdict.CLOSE,
        True,
    ),
    ("late-transition: re-stick 373 ms late", _late_restick(0.373), Verdict.LATE_TRANSITION, True),
    (
        "early-transition: re-stick 50 ms early",
        _late_restick(-0.05),
        Verdict.EARLY_TRANSITION,
        True,
    ),
    ("close: re-stick 6 ms late", _late_restick(0.006), Verdict.CLOSE, True),
    ("agrees: re-stick 2.5 ms late", _late_restick(0.0025), Verdict.AGREES, True),
    ("early-slip: 20 ms", {**SLIP_ROW, "t_slip": 0.38}, Verdict.EARLY_SLIP, True),
    ("late-slip: 20 ms", {**SLIP_ROW, "t_slip": 0.42}, Verdict.LATE_SLIP, True),
    ("diverged", {**HOP_ROW, "status": "diverged"}, Verdict.DIVERGED, False),
    *[
        (f"failed: {status}", {"status": status, "message": "m"}, Verdict.FAILED, False)
        for status in ("error", "timeout", "crashed", "unavailable")
    ],
]


@pytest.mark.parametrize(
    ("row", "verdict", "agrees"), [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_every_verdict(row, verdict, agrees):
    assert _verdict(row) == (verdict, agrees)


def test_a_hop_the_reading_cannot_see_at_the_window_end_is_no_hop_to_miss():
    """The exact solution lifts off just before the window ends and its samples there stay
    below the hop threshold (floor phases without F): neither a missed hop nor a false one."""
    unseen = {**HOP_ROW, "floor_phases": "R S+ R", "floor_t_last_phase": 0.5}
    rolls = {**unseen, "outcome": "slips", "t_lift": None, "hop_height": None}
    assert classify({**rolls, "phases": "R S+ R"}).verdict is Verdict.AGREES
    assert (
        classify({**HOP_ROW, **{k: v for k, v in rolls.items() if k != "floor_phases"}}).verdict
        is Verdict.MISSED_HOP
    )


def test_the_cases_cover_every_verdict():
    assert {case[2] for case in CASES} == set(Verdict)


def test_every_failed_check_is_a_flag_the_primary_first():
    row = {**HOP_ROW, "t_slip": 0.3, "hop_height": 0.4, "t_lift": 1.06, "phases": "R S+ S- F"}
    judgement = classify(row)
    assert judgement.flags == (
        Verdict.HOP_TOO_LOW,
        Verdict.LATE_LIFT_OFF,
        Verdict.EARLY_SLIP,
        Verdict.WRONG_PHASES,
    )
    assert judgement.verdict is Verdict.HOP_TOO_LOW and judgement.outcome_agrees is False
    assert judgement.reason == "hop 400 mm against 1e+03 mm: -60 %"
    columns = verdict_columns(row)
    assert columns["verdict_flags"] == "hop-too-low late-lift-off early-slip wrong-phases"


def test_an_outcome_failure_does_not_hide_the_other_checks():
    """A missed hop that also slips 46 ms late (the issue's row listed only the first)."""
    row = {**HOP_ROW, "t_lift": None, "hop_height": None, "t_slip": 0.446, "phases": "R S+ R"}
    row |= {"cone_stick_time_s": 0.02}
    judgement = classify(row)
    assert judgement.flags == (
        Verdict.MISSED_HOP,
        Verdict.LATE_SLIP,
        Verdict.WRONG_PHASES,
        Verdict.CONE_VIOLATION,
    )


def test_a_run_that_never_slips_where_the_exact_hoop_slips_then_hops_slips_late():
    """DART stock on a drawn scene (seed 5,701,130's random-45) stuck outside the cone and
    rolled to its end where the exact hoop slipped at 0.0117 s and hopped: its flags said
    missed-hop and wrong-phases, nothing of the slip it never made."""
    rolls = {**HOP_ROW, "outcome": "rolls", "t_slip": None, "t_lift": None, "hop_height": None}
    rolls |= {"max_clearance": 0.0, "phases": "R", "t_final": 1.5}
    judgement = classify(rolls)
    assert judgement.flags == (Verdict.MISSED_HOP, Verdict.LATE_SLIP, Verdict.WRONG_PHASES)
    assert judgement.verdict is Verdict.MISSED_HOP
    hops = {**HOP_ROW, "t_slip": None, "phases": "R F", "t_final": 2.0}  # lifts off rolling
    judgement = classify(hops)
    assert judgement.flags == (Verdict.LATE_SLIP, Verdict.WRONG_PHASES)
    assert judgement.reason == "never slips up to its end at 2 s (exact slip onset 0.4 s)"
    assert judgement.outcome_agrees is True  # it hops as the exact hoop does
    # A run whose window ends within the loose tolerance of the exact onset is not late.
    assert Verdict.LATE_SLIP not in classify({**rolls, "t_final": 0.405}).flags
    # Where the exact hoop only slips, the outcome check says it, once.
    missed = classify({**SLIP_ROW, "outcome": "rolls", "t_slip": None, "phases": "R"})
    assert missed.flags == (Verdict.MISSED_SLIP, Verdict.WRONG_PHASES)


def test_a_slip_onset_error_keeps_the_outcome():
    judgement = classify({**SLIP_ROW, "t_slip": 0.38})
    assert judgement.reason == "slip onset 20 ms early (0.38 s against 0.4 s, loose 10 ms)"


def test_a_wrong_phase_sequence_says_which_phase():
    judgement = classify({**SLIP_ROW, "phases": "R S+ S- R"})
    assert judgement.reason == "phase 3 is S- instead of R (R S+ S- R against R S+ R)"


def test_the_verdict_never_reads_the_kinematic_columns():
    """PyBullet tuned on hop-top rests 0.4 mm deep: its clearance rises 53 ms late while its
    contact force ends 1.3 ms late. The kin_* columns say so; the verdict reads the
    unprefixed (canonical) ones alone."""
    row = {**HOP_ROW, "t_lift": 1.0013}
    kin = {"kin_t_lift": 1.053, "kin_hop_height": 0.3, "kin_phases": "R S+ S- F"}
    kin |= {"kin_t_slip": 0.4 - 0.914, "kin_outcome": "slips"}
    assert classify({**row, **kin}) == classify(row)
    assert _verdict({**row, **kin}) == (Verdict.AGREES, True)


def test_outcome_agrees_exactly_where_no_outcome_check_failed():
    """outcome_agrees: the class, the hop's size and times; a slip onset, phase or cone error
    leaves it true."""
    for _, row, _, _ in CASES:
        verdict, agrees = _verdict(row)
        assert agrees is (verdict not in (*OUTCOME_FAILURES, Verdict.DIVERGED, Verdict.FAILED))


# --------------------------------------------------------------------------- every transition
def test_a_late_restick_is_named_and_timed():
    """The issue's row: agrees before, its re-stick 373 ms late; the reason names the
    transition, and the row's worst transition is it."""
    row = _late_restick(0.373)
    judgement = classify(row)
    assert judgement.flags == (Verdict.LATE_TRANSITION,)
    assert judgement.reason == (
        "re-stick 1 (S+ -> R) 373 ms late (1.234 s against 0.861 s, loose 11 ms)"
    )
    columns = verdict_columns(row)
    assert columns["max_transition"] == "re-stick 1"
    assert columns["max_transition_err_ms"] == pytest.approx(373.0)
    assert columns["max_transition_ratio"] == pytest.approx(373.0 / 11.0)


def test_a_restick_beyond_tight_makes_the_row_close_and_says_so():
    judgement = classify(_late_restick(0.006))
    assert (
        judgement.reason == "re-stick 1 (S+ -> R) 6 ms late (0.867 s against 0.861 s, tight 3 ms)"
    )


def test_every_timed_event_is_a_transition_of_the_row():
    """The worst transition is the largest error against its own loose tolerance, signed: a
    slip onset 8 ms early (loose 10 ms) outweighs a re-stick 8.5 ms late (loose 11 ms)."""
    row = {**_late_restick(0.0085), "t_slip": 0.392}
    row["phase_times"] = row["phase_times"].replace(" 0.4 ", " 0.392 ")
    judgement = classify(row)
    assert [event.name for event in judgement.timed] == [
        "slip onset",
        "re-stick 1",
        "slip onset 2",
        "re-stick 2",
    ]
    columns = verdict_columns(row)
    assert (columns["verdict"], columns["max_transition"]) == ("close", "slip onset")
    assert columns["max_transition_err_ms"] == pytest.approx(-8.0)
    assert columns["max_transition_ratio"] == pytest.approx(0.8)
    assert verdict_columns(ROLL_ROW)["max_transition"] is None  # nothing to time


def test_the_first_slip_and_the_lift_off_are_flagged_once():
    """They have their own checks (early-slip, late-lift-off): the transitions do not flag
    them again."""
    late = {**TWO_SLIPS_ROW, "t_slip": 0.42, "phase_times": "0.0 0.42 0.861 1.3 1.5"}
    assert classify(late).flags == (Verdict.LATE_SLIP,)
    hop = {**HOP_ROW, "t_lift": 1.06, "floor_phases": "R S+ F", "phase_times": "0.0 0.4 1.06"}
    hop |= {"floor_phase_times": "0.0 0.4 1.0", "exact_phase_times": "0.0 0.4 1.0"}
    assert classify(hop).flags == (Verdict.LATE_LIFT_OFF,)


def test_a_last_phase_at_the_window_end_is_not_timed():
    """The run slips again 10 ms before its window ends, where the exact solution (as read
    at the run's timestep) rolls on: the phases agree by the window-end rule, and that slip
    onset, which the exact solution does not have, is timed against nothing (the first slip
    onset is not its match)."""
    row = {**SLIP_ROW, "floor_phases": "R S+ R", "phases": "R S+ R S+", "t_final": 3.0}
    row |= {"phase_times": "0.0 0.4 0.861 2.99", "t_last_phase": 2.99}
    row |= {"floor_phase_times": "0.0 0.4 0.861", "exact_phase_times": "0.0 0.4 0.861"}
    judgement = classify(row)
    assert judgement.verdict is Verdict.AGREES
    assert [event.name for event in judgement.timed] == ["slip onset", "re-stick 1"]


def test_where_the_phases_differ_the_common_prefix_is_timed():
    """The run misses the second slip: wrong-phases first, and its first re-stick, which
    both sequences have, is still timed (here 50 ms late)."""
    row = {**_late_restick(0.05), "phases": "R S+ R", "phase_times": "0.0 0.4 0.911"}
    judgement = classify(row)
    assert judgement.flags == (Verdict.WRONG_PHASES, Verdict.LATE_TRANSITION)
    assert verdict_columns(row)["max_transition"] == "re-stick 1"


def test_painleve_transitions_are_timed_up_to_the_point_only():
    """The exact solution re-sticks, slips back and reaches a Painlevé point in that slip;
    the engine hops after it. Its re-stick (before the point) is timed; its lift-off (after
    it) is not, nor its first slip onset (as before)."""
    row = {**PAINLEVE_ROW, "exact_phases": "R S+ R S-", "floor_phases": "R S+ R S-"}
    row |= {"exact_t_slip": 0.05, "t_slip": 0.08, "exact_t_painleve": 0.3, "t_lift": 0.31}
    row |= {"exact_phase_times": "0.0 0.05 0.1 0.2", "floor_phase_times": "0.0 0.05 0.1 0.2"}
    row |= {"phases": "R S+ R S- F", "phase_times": "0.0 0.08 0.1 0.2 0.31"}
    assert [event.name for event in classify(row).timed] == ["re-stick 1", "slip onset 2"]
    assert classify(row).verdict is Verdict.AGREES
    late = {**row, "phase_times": "0.0 0.08 0.15 0.2 0.31"}
    assert classify(late).verdict is Verdict.LATE_TRANSITION


def test_a_row_stored_without_phase_times_is_judged_as_before():
    """Its later transitions cannot be timed, so its worst is not known: left empty rather
    than named from the first slip onset alone."""
    row = {k: v for k, v in _late_restick(0.373).items() if k != "phase_times"}
    columns = verdict_columns(row)
    assert columns["verdict"] == "agrees" and columns["max_transition"] is None


# --------------------------------------------------------------------------- hop rules
TIGHT, LOOSE = event_tolerances(Tier.TIGHT), event_tolerances(Tier.LOOSE)


@pytest.mark.parametrize(
    ("height", "t_lift", "expected"),
    [
        (1.0 + 0.9 * TIGHT.hop_height_rel, 1.0, Verdict.AGREES),
        (1.0 + 0.5 * (TIGHT.hop_height_rel + LOOSE.hop_height_rel), 1.0, Verdict.CLOSE),
        (1.0 + 1.1 * LOOSE.hop_height_rel, 1.0, Verdict.HOP_TOO_HIGH),
        (1.0 - 1.1 * LOOSE.hop_height_rel, 1.0, Verdict.HOP_TOO_LOW),
        (1.0, 1.0 + 0.9 * TIGHT.t_lift, Verdict.AGREES),
        (1.0, 1.0 - 0.5 * (TIGHT.t_lift + LOOSE.t_lift), Verdict.CLOSE),
        (1.0, 1.0 - 1.2 * LOOSE.t_lift, Verdict.EARLY_LIFT_OFF),
        (1.0, 1.0 + 1.2 * LOOSE.t_lift, Verdict.LATE_LIFT_OFF),
    ],
)
def test_a_hop_agrees_within_tight_and_is_close_within_loose(height, t_lift, expected):
    row = {**HOP_ROW, "hop_height": height, "max_clearance": height, "t_lift": t_lift}
    assert _verdict(row) == (expected, expected in (Verdict.AGREES, Verdict.CLOSE))


def test_the_detection_floor_widens_the_tolerance_on_both_sides():
    """The reference of hoop-1cm at dt 0.01 read its slip 1.29 ms late, inside one sample:
    on the 1 cm hoop the loose tolerance is 1 ms plus the step, so a timestep-free row that
    late fails, and the row that carries its floor agrees (the reference's own row, and an
    engine as far off)."""
    row = {**SLIP_ROW, "a": 0.01, "t_slip": 0.4 + 1.29e-3}
    assert _verdict(row)[0] is Verdict.LATE_SLIP
    assert _verdict({**row, "floor_err_t_slip_ms": 1.29}) == (Verdict.AGREES, True)


def test_phases_shorter_than_the_reading_are_absorbed():
    """The exact solution has a 2.17 ms roll the reading cannot see (a mode counts from
    5 ms): the engine is compared with the exact phases as read at its timestep."""
    row = {**SLIP_ROW, "exact_phases": "R S+ R S- R", "phases": "R S+ S- R"}
    assert _verdict(row)[0] is Verdict.WRONG_PHASES
    assert _verdict({**row, "floor_phases": "R S+ S- R"}) == (Verdict.AGREES, True)


def test_a_slip_the_reading_cannot_see_at_the_timestep_is_no_slip_to_miss():
    row = {**SLIP_ROW, "outcome": "rolls", "t_slip": None, "phases": "R", "floor_phases": "R"}
    assert _verdict(row) == (Verdict.AGREES, True)


def test_no_hop_in_the_canonical_columns_is_a_missed_hop():
    withheld = {**HOP_ROW, "t_lift": None, "hop_height": None, "max_clearance": 0.95}
    assert _verdict(withheld) == (Verdict.MISSED_HOP, False)


def test_lifts_at_start_is_a_hop_from_t_0():
    row = {
        **HOP_ROW,
        "exact_outcome": "lifts-at-start",
        "exact_t_slip": None,
        "exact_t_lift": 0.0,
        "exact_phases": "F",
        "outcome": "lifts-at-start",
        "t_slip": None,
        "t_lift": 0.0,
        "phases": "F",
    }
    assert _verdict(row) == (Verdict.AGREES, True)
    assert _verdict({**row, "outcome": "hops", "t_lift": 0.2, "phases": "R F"})[0] is (
        Verdict.LATE_LIFT_OFF
    )


# --------------------------------------------------------------------------- Painlevé
@pytest.mark.parametrize(
    ("changes", "verdict"),
    [
        ({}, Verdict.AGREES),
        ({"t_lift": 0.15}, Verdict.AGREES),  # within 50 ms of the point
        ({"outcome": "slips", "t_lift": None, "hop_height": None, "phases": "S+"}, Verdict.AGREES),
        ({"outcome": "lifts-at-start", "t_lift": 0.0, "phases": "F"}, Verdict.FALSE_HOP),
        ({"t_lift": 0.1}, Verdict.FALSE_HOP),
        ({"outcome": "rolls", "t_slip": None, "t_lift": None, "phases": "R"}, Verdict.MISSED_SLIP),
        ({"phases": "R S+ F"}, Verdict.WRONG_PHASES),
        ({"outcome": "painleve", "phases": "S+"}, Verdict.AGREES),  # the reference's own row
    ],
)
def test_painleve(changes, verdict):
    assert _verdict({**PAINLEVE_ROW, **changes})[0] is verdict


def test_painleve_time_from_the_exact_events():
    slip = Phase(PhaseKind.SLIP, 0.0, 0.18, 1)
    assert painleve_time(Events(Outcome.PAINLEVE, extra={"t_painleve": 0.2})) == 0.2
    assert painleve_time(Events(Outcome.PAINLEVE, phases=(slip,))) == 0.18
    assert painleve_time(Events(Outcome.PAINLEVE)) == 0.0
    assert painleve_time(Events(Outcome.SLIPS, phases=(slip,))) is None


@pytest.mark.parametrize("exact", ["degenerate", "error", None])
def test_no_exact_answer_no_verdict(exact):
    assert _verdict({**SLIP_ROW, "exact_outcome": exact}) == (None, None)


@pytest.mark.parametrize(
    ("exact_height", "judged"), [(7.2e-5, False), (1e-3, False), (1.2e-3, True)]
)
def test_an_exact_hop_below_the_hop_threshold_is_not_judged(exact_height, judged):
    """A lifts-at-start hop of 0.07 mm (lam chi just above 1): no engine hop that small is
    read as a hop, and the exact solution ends at its impact, so there is nothing to judge;
    the same row with an exact hop above the threshold is judged (here: missed)."""
    row = {
        **HOP_ROW,
        "exact_outcome": "lifts-at-start",
        "exact_t_lift": 0.0,
        "exact_hop_height": exact_height,
        "exact_phases": "F",
        "t_lift": 0.9,
        "hop_height": 1.5,
        "max_clearance": 1.5,
    }
    judgement = classify(row)
    assert (judgement.verdict is not None) is judged
    if not judged:
        assert judgement.outcome_agrees is None
        assert "below the 1 mm hop threshold" in judgement.reason


@pytest.mark.parametrize(
    ("phases", "t_last", "exact_t_last", "verdict"),
    [
        ("R S+ R S-", 2.6, 2.996, Verdict.AGREES),  # the exact re-stick 4 ms before the end
        ("R S+ R S-", 2.6, 2.94, Verdict.WRONG_PHASES),  # 60 ms: the engine missed it
        ("R S+ R S- R S+", 2.99, 2.7, Verdict.AGREES),  # the engine's slip 10 ms before the end
        ("R S+ R S- R S+", 2.9, 2.7, Verdict.WRONG_PHASES),
        ("R S+ S-", 2.6, 2.996, Verdict.WRONG_PHASES),  # not a trailing phase
    ],
)
def test_one_last_phase_at_the_window_end_may_differ(phases, t_last, exact_t_last, verdict):
    """The exact solution re-sticks 4 ms before the window's end and the engine after its
    last sample: the sequences differ by one last phase that the window cannot show."""
    row = {
        **SLIP_ROW,
        "exact_phases": "R S+ R S- R",
        "exact_t_last_phase": exact_t_last,
        "phases": phases,
        "t_last_phase": t_last,
        "t_final": 3.0,
    }
    assert _verdict(row)[0] is verdict


@pytest.mark.parametrize(("speed", "judged"), [(5e-5, False), (1e-3, False), (1.1e-3, True)])
def test_exact_slips_below_the_slip_threshold_are_not_judged(speed, judged):
    """Exact slips of 0.05 mm/s: an engine that reproduced them would still read as rolling,
    so its 'missed-slip' would be the detectors' blind spot."""
    row = {**SLIP_ROW, "exact_max_slip_speed": speed, "outcome": "rolls", "t_slip": None}
    row |= {"phases": "R"}
    judgement = classify(row)
    assert (judgement.verdict is not None) is judged
    if judged:
        assert judgement.verdict is Verdict.MISSED_SLIP
    else:
        assert "below the 1 mm/s slip threshold" in judgement.reason


def test_the_phases_agree_column_follows_the_verdicts_rule():
    """row_phases_agree (the runs table's phases_agree) is the verdict's phase rule: a prefix
    up to a Painlevé point, and the window-end tolerance carried to the row's hoop."""
    assert row_phases_agree({**PAINLEVE_ROW, "phases": "S+ F"}) is True
    assert row_phases_agree({**PAINLEVE_ROW, "phases": "R S+ F"}) is False
    row = {**SLIP_ROW, "exact_phases": "R S+ R", "phases": "R S+", "t_final": 3.0}
    row |= {"exact_t_last_phase": 2.98, "t_last_phase": 1.0}
    assert row_phases_agree(row) is True  # 20 ms before the end of a 1 m hoop's window
    assert row_phases_agree({**row, "a": 0.01}) is False  # 5 ms tolerance on a 1 cm hoop


def test_a_stored_row_with_nan_is_judged_alike():
    """Rows read back from Parquet or CSV carry NaN for a missing number."""
    row = {**SLIP_ROW, "outcome": "hops", "t_lift": 1.2, "hop_height": 5e-3, "phases": "R S+ F"}
    withheld = {**HOP_ROW, "t_lift": None, "hop_height": None, "max_clearance": 3e-4}
    frame = pd.DataFrame([row, SLIP_ROW, ROLL_ROW, withheld])
    assert frame["exact_hop_height"].isna().iloc[0] and frame["t_slip"].isna().iloc[2]
    verdicts = [verdict_columns(r)["verdict"] for r in frame.to_dict("records")]
    assert verdicts == ["false-hop", "agrees", "agrees", "missed-hop"]


# --------------------------------------------------------------------------- the row builder
def _task():
    suite = parse_suite(
        {"name": "t", "engines": ["pymunk"], "timesteps": [1e-4], "scenes": ["hop-bottom"]}
    )
    return suite.tasks()[0]


def _blip_run(task) -> Run:
    """0.6 s of rolling with a 0.3 mm, 16 ms lift-off at 0.3 s (MuJoCo's slip chatter)."""
    scene, spin = task.scene, 1.0
    t = np.arange(6000) * 1e-4
    duration = 2 * math.sqrt(2 * 3e-4 / scene.g)
    tau = t - 0.3
    clearance = np.where((tau > 0) & (tau < duration), scene.g * tau * (duration - tau) / 2, 0.0)
    y = scene.a + clearance
    theta = scene.theta0 + spin * t
    state = kinematics.com_state(
        scene, scene.a * spin * t, y, theta, scene.a * spin + 0 * t, np.gradient(y, t), spin + 0 * t
    )
    trajectory = Trajectory.from_state(
        scene, t=t, **state, normal_force=scene.g * (clearance <= 0), friction_force=0 * t
    )
    return Run(trajectory, RunInfo(engine="pymunk", engine_version=None, status=RunStatus.OK))


def test_the_row_of_a_blip_against_a_real_hop():
    """Judge, then row: the blip is no hop, its lift-off error is empty, its size is kept."""
    task = _task()
    exact = Events(Outcome.HOPS, t_lift=0.31, hop_height=0.43, t_impact=1.02)
    run = _blip_run(task)
    base = {**exact_columns(exact), "status": "ok", "a": task.scene.a, "g": task.scene.g}
    row = {**base, **judged_columns(base, judge(run, scene=task.scene), task.scene)}
    assert set(row) <= set(ROW_COLUMNS)
    assert row["outcome"] == "rolls"
    assert row["t_lift"] is None and row["err_t_lift_ms"] is None
    assert row["err_hop_height_rel"] is None and row["err_t_impact_ms"] is None
    assert row["max_clearance"] == pytest.approx(3e-4, rel=0.01)
    assert (row["verdict"], row["outcome_agrees"]) == ("missed-hop", False)
    assert row["consistent"] is True and row["event_flags"] == ""


def test_the_row_of_a_run_that_produced_nothing():
    """A crash is the engine's run failing; a timeout is the machine's time limit (issue 34):
    no verdict, its reason saying so."""
    row = failure_row(_task(), RunStatus.CRASHED, "worker died")
    assert (row["verdict"], row["outcome_agrees"]) == ("failed", False)
    row = failure_row(_task(), RunStatus.TIMEOUT, "over 60 s")
    assert "verdict" not in row and "outcome_agrees" not in row
    assert row["verdict_reason"] == TIMEOUT_NOTE and set(row) <= set(ROW_COLUMNS)


def test_the_hop_rules_scale_with_the_hoop():
    """On a 1 cm hoop (a in the row) a 0.33 mm hop is a hop and agrees with the exact one
    leaving 0.1 ms apart; read for the 1 m hoop (no a) the exact one is below the hop
    threshold, no hop to judge against. The times scale with sqrt(a / g): 2 ms late is
    beyond the 1 m hoop's loose 10 ms carried to the 1 cm hoop (1 ms)."""
    row = {**HOP_ROW, "exact_hop_height": 3.3e-4, "hop_height": 3.3e-4, "max_clearance": 3e-4}
    row |= {"t_lift": 1.0001}
    assert _verdict({**row, "a": 0.01}) == (Verdict.AGREES, True)
    assert _verdict(row) == (None, None)
    assert _verdict({**row, "exact_hop_height": 0.01}) == (Verdict.HOP_TOO_LOW, False)
    late = {**row, "a": 0.01, "t_lift": 1.002}
    assert _verdict(late) == (Verdict.LATE_LIFT_OFF, False)


def test_a_hop_cut_by_the_window_is_not_too_low():
    """The run ends in the air 3 mm up, the exact hop lands later at 1 m: its height is not
    known yet. Landed at 3 mm, it is too low."""
    cut = {**HOP_ROW, "hop_height": 3e-3, "max_clearance": 3e-3, "t_impact": None}
    assert _verdict(cut) == (Verdict.AGREES, True)
    assert _verdict({**cut, "t_impact": 1.05}) == (Verdict.HOP_TOO_LOW, False)
    assert _verdict({**cut, "hop_height": 2.5}) == (Verdict.HOP_TOO_HIGH, False)


def test_a_false_hop_is_sized_by_the_canonical_reading():
    row = {**ROLL_ROW, "outcome": "hops", "t_lift": 1.1, "hop_height": 4e-3, "phases": "R F"}
    row |= {"kin_t_lift": 1.1, "kin_hop_height": 1.34e-3}
    judgement = classify(row)
    assert judgement.verdict is Verdict.FALSE_HOP
    assert judgement.reason == "a 4 mm hop the reference does not have"
