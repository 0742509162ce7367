"""The search's error score (engines/judging/score.py): the shared tolerance table's loose
tier as the unit, failures at the cap."""

from __future__ import annotations

import pytest

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.judging.score import (
    FLAG_SCORE,
    SCORE_CAP,
    CostClock,
    cheapest_of_most,
    cost_us_per_s,
    error_score,
    row_error,
    scenes_within,
    tier_reached,
)
from hoopbench.engines.judging.tolerances import Tier, event_tolerances


def _row(**changes: object) -> dict[str, object]:
    row: dict[str, object] = {
        Col.STATUS: "ok",
        Col.VERDICT: "agrees",
        Col.VERDICT_FLAGS: "",
        Col.A: 1.0,
        Col.G: 9.8,
        Col.TIMESTEP: 1e-4,
    }
    row.update(changes)
    return row


def test_an_event_error_is_counted_in_loose_tolerances() -> None:
    loose = event_tolerances(Tier.LOOSE, timestep=1e-4)
    half = 0.5e3 * loose.t_lift  # ms
    assert row_error(_row(**{Col.ERR_T_LIFT_MS: half})) == pytest.approx(0.5)
    twice = 2 * loose.hop_height_rel
    row = _row(**{Col.VERDICT: "hop-too-low", Col.ERR_HOP_HEIGHT_REL: -twice})
    assert row_error(row) == pytest.approx(2.0)
    assert row_error(_row()) == 0.0


def test_the_detection_floor_widens_the_tolerance_as_the_verdict_does() -> None:
    loose = event_tolerances(Tier.LOOSE, timestep=1e-4)
    row = _row(
        **{Col.ERR_T_SLIP_MS: 2e3 * loose.t_slip, Col.FLOOR_ERR_T_SLIP_MS: 1e3 * loose.t_slip}
    )
    assert row_error(row) == pytest.approx(1.0)


def test_every_timed_transition_counts() -> None:
    """A re-stick 30 ms early on a row whose first slip, lift-off and impact are on time:
    beyond loose by its own ratio, as the verdict (early-transition) says."""
    row = _row(**{Col.VERDICT: "early-transition", Col.ERR_T_SLIP_MS: 0.1})
    assert row_error({**row, Col.MAX_TRANSITION_RATIO: 3.0}) == pytest.approx(3.0)
    assert row_error(row) < 1.0  # stored before the transitions were timed: as then


@pytest.mark.parametrize(
    "verdict", ["missed-hop", "false-hop", "missed-slip", "false-slip", "diverged", "failed"]
)
def test_an_event_missed_or_invented_or_no_run_is_the_worst(verdict: str) -> None:
    assert row_error(_row(**{Col.VERDICT: verdict})) == SCORE_CAP


def test_a_failed_status_or_no_verdict_is_the_worst() -> None:
    assert row_error(_row(**{Col.STATUS: "timeout"})) == SCORE_CAP
    assert row_error(_row(**{Col.VERDICT: None})) == SCORE_CAP


@pytest.mark.parametrize("flag", ["wrong-phases", "creeps", "cone-violation"])
def test_a_failure_no_error_measures_is_beyond_loose(flag: str) -> None:
    row = _row(**{Col.VERDICT: "close", Col.VERDICT_FLAGS: flag, Col.ERR_T_SLIP_MS: 0.1})
    assert row_error(row) == FLAG_SCORE


def test_errors_are_capped_and_averaged_over_scenes() -> None:
    huge = _row(**{Col.VERDICT: "late-slip", Col.ERR_T_SLIP_MS: 1e6})
    assert row_error(huge) == SCORE_CAP
    assert error_score([huge, _row()]) == pytest.approx(SCORE_CAP / 2)
    assert error_score([]) == SCORE_CAP


def test_the_cost_is_the_clock_s_time_per_simulated_second() -> None:
    rows = [
        _row(**{Col.WALL_TIME_S: 0.5, Col.CPU_TIME_S: 0.25, Col.N_STEPS: 10_000}),
        _row(**{Col.WALL_TIME_S: 1.5, Col.CPU_TIME_S: 0.5, Col.N_STEPS: 30_000}),
        _row(**{Col.STATUS: "timeout"}),
    ]
    assert cost_us_per_s(rows, CostClock.WALL) == pytest.approx(1e6 * 2.0 / 4.0)
    assert cost_us_per_s(rows, CostClock.CPU) == pytest.approx(1e6 * 0.75 / 4.0)
    assert cost_us_per_s([_row()], CostClock.CPU) is None
    # a row timed by the wall clock alone gives no CPU cost
    wall_only = {Col.WALL_TIME_S: 0.5, Col.N_STEPS: 10_000, Col.TIMESTEP: 1e-4}
    assert cost_us_per_s([_row(**wall_only)], CostClock.CPU) is None


def test_a_tier_is_reached_when_every_run_is_within_it() -> None:
    agrees, close = _row(), _row(**{Col.VERDICT: "close"})
    assert tier_reached([agrees, agrees]) is Tier.TIGHT
    assert tier_reached([agrees, close]) is Tier.LOOSE
    assert tier_reached([close, _row(**{Col.VERDICT: "late-slip"})]) is None
    assert tier_reached([agrees, _row(**{Col.VERDICT: None})]) is None  # an unjudged run
    assert tier_reached([]) is None


def test_the_cheapest_of_a_tier_is_the_cheapest_of_those_within_it_on_most_scenes() -> None:
    assert cheapest_of_most([("a", 5, 10.0), ("b", 7, 100.0), ("c", 7, 50.0)]) == "c"
    assert cheapest_of_most([("a", 7, None), ("b", 7, 100.0)]) == "b"  # unmeasured last
    assert cheapest_of_most([("a", 7, float("nan")), ("b", 7, float("inf"))]) == "a"  # tie
    assert cheapest_of_most([("a", 0, 1.0)]) is None
    assert cheapest_of_most([]) is None


def test_scenes_within_a_tier_counts_the_tiers_verdicts() -> None:
    rows = [_row(), _row(**{Col.VERDICT: "close"}), _row(**{Col.VERDICT: "late-slip"})]
    rows.append(_row(**{Col.VERDICT: float("nan")}))
    assert scenes_within(rows, Tier.TIGHT) == 1
    assert scenes_within(rows, Tier.LOOSE) == 2
