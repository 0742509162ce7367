"""Findings are generated from the rows: each sentence follows the numbers it quotes."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from hoopbench.engines.judging.verdict import verdict_columns
from hoopbench.reports.compare.suite import LEFT_OUT_KEY
from hoopbench.reports.compare.suite_file import LeftOut
from hoopbench.reports.report.build import answer_left_out_of
from hoopbench.reports.report.findings import (
    README_BEGIN,
    README_END,
    findings,
    findings_markdown,
    findings_scoreboard,
    readme_markdown,
    update_readme,
)


def row(engine, scene="seed-mu", **values):
    base = {
        "engine": engine,
        "scene": scene,
        "variant": "default",
        "profile": "tuned",
        "timestep": 1e-4,
        "suite": "default",
        "status": "ok",
        "us_per_step": 10.0,
        "err_t_slip_ms": None,
        "err_hop_height_rel": None,
        "verdict": "agrees",
        "outcome_agrees": True,
        "message": "",
    }
    return {**base, **values}


def frame(*rows) -> pd.DataFrame:
    return pd.DataFrame(list(rows))


def test_the_closest_engine_is_the_one_with_the_smallest_error():
    runs = frame(
        row("reference", err_t_slip_ms=0.01),
        row("mujoco", err_t_slip_ms=2.4, us_per_step=37.0),
        row("pybullet", err_t_slip_ms=-0.14, us_per_step=80.0),
    )
    text = findings(runs)[0]
    assert text.startswith(
        "Slip onset on seed-mu (dt 0.0001, tuned): closest is pybullet, -0.14 ms"
    )
    assert "at 80 us/step" in text and "then mujoco +2.4 ms" in text
    assert "reference" not in text  # the reference is what the engines are measured against


def test_engines_tied_on_the_error_are_ranked_by_their_cpu_time_where_measured():
    """Issue 34: of two engines within the error's resolution, the one named is the cheaper
    by the process's CPU time (pybullet), not by the wall time, which the load moves
    (mujoco's is lower here)."""
    runs = frame(
        row("mujoco", err_t_slip_ms=0.1, us_per_step=30.0, cpu_us_per_step=20.0),
        row("pybullet", err_t_slip_ms=0.1, us_per_step=80.0, cpu_us_per_step=8.0),
    )
    text = findings(runs)[0]
    assert "closest is pybullet, +0.1 ms at 8 CPU us/step, tied with mujoco" in text
    wall = findings(runs.drop(columns=["cpu_us_per_step"]))[0]  # a table stored before
    assert "closest is mujoco, +0.1 ms at 30 us/step, tied with pybullet" in wall


def test_agreement_names_every_scene_that_went_wrong():
    """The phase sequence counts phases_agree (as the scoreboard does), not the verdict: a
    hop too low has the right phases and a wrong event."""
    runs = frame(
        row("pymunk", err_t_slip_ms=1.0, verdict="wrong-phases", outcome_agrees=True),
        row("pymunk", scene="hop-top", verdict="false-hop", outcome_agrees=False),
        row("pymunk", scene="hop-low", verdict="hop-too-low", phases_agree=True),
        row("pymunk", scene="hop-bottom", verdict="agrees", phases_agree=True),
        row("pymunk", scene="high-spin", verdict="close", phases_agree=True),
    )
    sentence = next(s for s in findings(runs) if s.startswith("pymunk (dt"))
    assert sentence == (
        "pymunk (dt 0.0001, tuned) gets the outcome right on 4 of 5 scenes, the whole "
        "phase sequence on 3 and every event on 1 (within the loose tolerances on 2) "
        "(false-hop on hop-top; hop-too-low on hop-low; wrong-phases on seed-mu)."
    )


def test_stock_and_tuned_each_get_their_own_sentences():
    runs = frame(
        row("mujoco", err_t_slip_ms=2.4),
        row("mujoco", profile="stock", err_t_slip_ms=-900.0, verdict="false-hop"),
    )
    text = findings(runs)
    assert any("(dt 0.0001, tuned)" in s and "+2.4 ms" in s for s in text)
    assert any("(dt 0.0001, stock)" in s and "-900 ms" in s for s in text)


def test_the_readme_block_is_replaced_between_its_markers(tmp_path):
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n\n{README_BEGIN}\nold\n{README_END}\n\nafter\n")
    update_readme(readme, "- new")
    assert readme.read_text() == f"# x\n\n{README_BEGIN}\n- new\n{README_END}\n\nafter\n"
    (tmp_path / "bare.md").write_text("no markers")
    with pytest.raises(ValueError, match="has no findings markers"):
        update_readme(tmp_path / "bare.md", "- new")


def test_the_stock_knobs_that_break_a_tuned_outcome_are_named():
    """A knob at its stock value alone (cone: pyramidal) that loses the tuned run's hop is
    named with its verdict and error; one that changes no outcome (tolerance) is listed apart;
    a variant that is not a stock value (noslip_iterations = 10) is not a stock knob."""
    hop = {"exact_t_lift": 1.17, "geometry": "sphere"}
    runs = frame(
        row("mujoco", "hop-top", options="{}", err_hop_height_rel=-0.011, **hop),
        row(
            "mujoco",
            "hop-top",
            variant="cone=pyramidal",
            options='{"cone": "pyramidal"}',
            err_hop_height_rel=-0.997,
            verdict="missed-hop",
            outcome_agrees=False,
            **hop,
        ),
        row(
            "mujoco",
            "hop-top",
            variant="tolerance=1e-8",
            options='{"tolerance": 1e-08}',
            err_hop_height_rel=-0.011,
            **hop,
        ),
        row(
            "mujoco",
            "hop-top",
            variant="noslip",
            options='{"noslip_iterations": 10}',
            verdict="missed-hop",
            outcome_agrees=False,
            **hop,
        ),
    )
    (text,) = [s for s in findings(runs) if "stock knob" in s]
    assert "cone = pyramidal on hop-top (missed-hop, -99.7 %)" in text
    assert text.endswith("tolerance = 1e-08 keeps every outcome.")
    assert "noslip" not in text


# --------------------------------------------------------------------------- scoreboard
SLIP = {"exact_t_slip": 0.5, "exact_hop_height": None}
HOP = {"exact_t_slip": 0.3, "exact_hop_height": 0.1, "exact_t_impact": 1.0}


def board_runs(**extra) -> pd.DataFrame:
    """Two engines, tuned, on a slip scene and two hop scenes, plus rows the scoreboard must
    not count: a stock run (its own line), a knob variant, another timestep, the reference
    and an unjudged run. The kin_* columns (the other reading) say otherwise throughout."""
    return frame(
        row("a", err_t_slip_ms=0.5, kin_err_t_slip_ms=3.0, phases_agree=True, **SLIP),
        row(
            "a",
            "hop-top",
            err_hop_height_rel=0.004,
            kin_err_hop_height_rel=0.2,
            err_t_lift_ms=-9.0,
            err_t_impact_ms=1.0,
            err_t_slip_ms=-1.5,
            kin_err_t_slip_ms=0.2,
            phases_agree=True,
            verdict="late-lift-off",
            **HOP,
        ),
        row(
            "a",
            "hop-low",
            kin_err_hop_height_rel=0.0,
            kin_err_t_lift_ms=1.0,
            verdict="missed-hop",
            outcome_agrees=False,
            phases_agree=False,
            **HOP,
        ),
        row("b", err_t_slip_ms=2.5, kin_err_t_slip_ms=0.1, phases_agree=False, **SLIP),
        row("a", profile="stock", err_t_slip_ms=0.1, phases_agree=True, **SLIP),
        row("a", variant="cone=pyramidal", err_t_slip_ms=0.1, **SLIP),
        row("a", timestep=1e-3, err_t_slip_ms=0.1, **SLIP),
        row("reference", err_t_slip_ms=0.0, **SLIP),
        row("a", "painleve", verdict=None, outcome_agrees=None, **extra),
    )


def test_the_scoreboard_counts_each_share_over_the_runs_that_can_be_right():
    """Every share by the canonical reading, with the verdict's tight tolerances (slip 2 ms
    plus a 0.1 ms step; hop height 2 %): hop-top's +0.4 % height is right, its -9 ms
    lift-off is not; a missed hop counts in n, not in k; the kin_* columns never count."""
    board = findings_scoreboard(board_runs()).set_index(["engine", "profile"])
    assert list(board.index) == [("a", "tuned"), ("b", "tuned"), ("a", "stock")]
    a = board.loc[("a", "tuned")]
    assert a["outcome"] == "2/3 (67 %)"
    assert a["phases"] == "2/3 (67 %)"
    assert a["agrees"] == "1/3 (33 %)"
    assert a["close"] == "1/3 (33 %)"
    assert a["slip"] == "2/3 (67 %)"
    assert a["hop_height"] == "1/2 (50 %)"
    assert a["lift"] == "0/2 (0 %)"
    assert a["impact"] == "1/2 (50 %)"
    b = board.loc[("b", "tuned")]
    assert b["slip"] == "0/1 (0 %)"
    assert b["hop_height"] == "-"
    assert "force_rms" not in board.columns


def test_the_scoreboard_shows_the_force_rms_only_when_the_table_has_it():
    """The median of the judged runs (the unjudged painleve run's 50 left out)."""
    rms = [0.1, 0.3, 0.9, 2, 5, 5, 5, 5, 50]
    board = findings_scoreboard(board_runs().assign(force_rms_n_g=rms))
    assert list(board["force_rms"]) == ["0.3", "2", "5"]
    text = findings_markdown(board_runs())
    assert text.startswith("| engine | profile | outcome right | phases right |")
    assert "median normal-force RMS" not in text


def seed(engine, canonical, kinematic, us=10.0):
    return row(engine, err_t_slip_ms=canonical, kin_err_t_slip_ms=kinematic, us_per_step=us)


def test_the_findings_read_the_canonical_reading_alone():
    """Before issue 24 a ranking by the slip velocity stood beside the contact force's; the
    Findings now quote one reading (the comparison is the report's own section)."""
    runs = frame(seed("mujoco", 0.02, 2.39), seed("pybullet", 0.3, 0.14), seed("drake", 0.6, 0.035))
    text = findings(runs)[0]
    assert text == (
        "Slip onset on seed-mu (dt 0.0001, tuned): closest is mujoco, +0.02 ms at 10 us/step; "
        "then pybullet +0.3 ms, drake +0.6 ms."
    )


def test_a_tie_is_said_and_does_not_make_an_order():
    """pybullet and pymunk tie (as printed): the closest is named with its tie."""
    runs = frame(seed("pybullet", 0.1194, 0.1), seed("pymunk", 0.1193, 0.2), seed("drake", 1, 3))
    text = findings(runs)[0]
    assert (
        "closest is pymunk, +0.119 ms at 10 us/step, tied with pybullet; then drake +1 ms" in text
    )


def test_of_engines_tied_the_cheapest_is_named():
    """MJX and MuJoCo C give seed-mu's slip onset to the same digits, MJX at 36 times the
    cost: the closest named is MuJoCo, the one a reader would pick."""
    runs = frame(
        seed("mjx", 0.0194, 0.1, us=397.0),
        seed("mujoco", 0.0194, 0.1, us=11.0),
        seed("drake", 0.219, 3),
    )
    text = findings(runs)[0]
    assert "closest is mujoco, +0.0194 ms at 11 us/step, tied with mjx; then drake" in text


def test_errors_closer_than_one_timestep_tie():
    """+0.0194 ms against +0.119 ms at dt 0.1 ms is one step: a tie, not a ranking; a hop
    height ties within the height one step of lift-off makes (sqrt(2 g h) dt / h)."""
    runs = frame(seed("mujoco", 0.0194, 0.1), seed("dart", 0.119, 0.2), seed("drake", 0.219, 3))
    text = findings(runs)[0]
    assert "closest is mujoco, +0.0194 ms at 10 us/step, tied with dart; then drake" in text
    hop = {"scene": "hop-bottom", "exact_t_lift": 1.0, "exact_hop_height": 0.1, "g": 9.8}
    # one step of lift-off at 1.4 m/s: 0.14 mm of 0.1 m, 0.14 %
    runs = frame(
        row("mujoco", **hop, err_hop_height_rel=0.00038),
        row("pymunk", **hop, err_hop_height_rel=-0.0015),
        row("rapier", **hop, err_hop_height_rel=0.0087),
    )
    text = next(s for s in findings(runs) if s.startswith("Hop height on hop-bottom"))
    assert "closest is mujoco, +0.038 % at 10 us/step, tied with pymunk; then rapier" in text


def test_an_event_error_is_read_as_the_verdict_reads_it():
    """MuJoCo's pyramidal cone on hop-top: -99.7 % by the clearance (a blip), about -10 %
    by the canonical reading, which the verdict reads: the sentence gives the verdict's
    number."""
    from hoopbench.reports.report.findings import event_error

    row = {"exact_t_lift": 1.17, "exact_hop_height": 0.38, "kin_err_hop_height_rel": -0.997}
    row |= {"err_hop_height_rel": -0.1}
    assert event_error(row) == "-10 %"
    slip = {"exact_t_lift": None, "exact_t_slip": 0.987, "kin_err_t_slip_ms": -914.0}
    assert event_error({**slip, "err_t_slip_ms": 1.32}) == "+1.32 ms"


def timed_row(engine: str, restick: float, slip: float = 0.4, **values):
    """A run of a scene that slips, re-sticks, slips back and re-sticks (exact slip at 0.4 s,
    re-sticks at 0.861 s and 1.5 s, the floor on them), its first slip at ``slip`` s and its
    second re-stick at ``restick`` s, judged as the verdict judges it."""
    columns = {
        "status": "ok",
        "exact_outcome": "slips",
        "exact_t_slip": 0.4,
        "exact_phases": "R S+ R S- R",
        "floor_phases": "R S+ R S- R",
        "outcome": "slips",
        "t_slip": slip,
        "max_clearance": 0.0,
        "phases": "R S+ R S- R",
        "phase_times": f"0.0 {slip!r} 0.861 1.3 {restick!r}",
        "floor_phase_times": "0.0 0.4 0.861 1.3 1.5",
        "exact_phase_times": "0.0 0.4 0.861 1.3 1.5",
        **values,
    }
    columns |= verdict_columns(columns)
    return row(engine, err_t_slip_ms=1e3 * (slip - 0.4), **columns)


def test_the_later_transitions_off_are_named_beyond_loose_and_counted_beyond_tight():
    """A re-stick 34 ms early (beyond loose: named), one 6 ms late and one 4 ms early
    (beyond tight only: counted, the largest named), one 1 ms late (within tight) in a run
    whose first slip onset is 5 ms late (close, but not a later transition)."""
    runs = frame(
        timed_row("pymunk", 1.466),
        timed_row("drake", 1.506),
        timed_row("dart", 1.496),
        timed_row("rapier", 1.501, slip=0.405),
    )
    assert list(runs["verdict"]) == ["early-transition", "close", "close", "close"]
    sentence = next(s for s in findings(runs) if s.startswith("Later transitions"))
    assert sentence == (
        "Later transitions (re-sticks, later slip onsets, slip reversals; dt 0.0001, tuned), "
        "timed on 4 runs: beyond the loose tolerance on 1 (pymunk on seed-mu, re-stick 2 "
        "-34 ms), beyond the tight one only on 2 (the largest: drake on seed-mu, re-stick 2 "
        "+6 ms)."
    )
    calm = next(s for s in findings(runs.iloc[3:]) if s.startswith("Later transitions"))
    assert calm.endswith(
        "timed on 1 runs: every one within the tight tolerance (the largest: rapier on "
        "seed-mu, re-stick 2 +1 ms)."
    )


def test_a_transition_verdict_is_said_with_its_transition():
    """Where the verdict is a later transition's, the run's error is that transition's, not
    its first slip onset's (on time)."""
    from hoopbench.reports.report.findings import event_error

    assert event_error(timed_row("pymunk", 1.466)) == "re-stick 2 -34 ms"
    assert event_error(timed_row("drake", 1.506)) == "+0 ms"  # close: the slip onset


def test_an_engine_sliding_off_mu_is_named_with_its_effective_coefficient():
    """Issue 33: DART stock's sliding friction is not mu (0.56-2.43): a finding names the
    engine and its mu_effective_ratio; engines at mu (within 2 %) are not named."""
    runs = frame(
        row("dart", mu_effective_ratio=0.81),
        row("dart", scene="slip-reversal", mu_effective_ratio=0.74),
        row("drake", mu_effective_ratio=0.985),
        row("pymunk", mu_effective_ratio=1.0),
    )
    sentence = next(s for s in findings(runs) if s.startswith("Sliding friction off mu"))
    assert "dart slides at 0.78 mu (0.74-0.81, 2 runs that slip)" in sentence
    assert "drake" not in sentence and "pymunk" not in sentence
    calm = frame(row("drake", mu_effective_ratio=0.985))
    assert not [s for s in findings(calm) if s.startswith("Sliding friction")]


def test_the_runs_left_out_for_want_of_a_gpu_are_said_under_the_answer(tmp_path):
    """The finer suite leaves MJX's runs at 1e-4 s to a GPU: the README's answer (and the
    report's, the same section) says under its table which runs a suite left out, from the
    results folders' meta.json, as data (a reason's markup is escaped); the stability
    suite, which the answer does not read, is not named; with nothing left out, nothing."""
    runs = frame(row("reference"), row("mujoco"), row("mujoco", scene="hop-top"))
    reason = "MJX on a CPU <b>costs</b> | 100 CPU-s"
    for suite in ("finer", "stability"):
        folder = tmp_path / suite
        folder.mkdir()
        item = LeftOut("mjx", "default", 8, reason).to_dict()
        (folder / "meta.json").write_text(json.dumps({"suite": suite, LEFT_OUT_KEY: [item]}))
    left_out = answer_left_out_of([tmp_path / "finer", tmp_path / "stability"])
    assert left_out == [("finer", LeftOut("mjx", "default", 8, reason))]
    text = readme_markdown(runs, (), left_out)
    (line,) = [x for x in text.splitlines() if x.startswith("Left out on this machine")]
    assert line.startswith(
        "Left out on this machine for want of a GPU, so not in the rows above: mjx, 8 runs of "
        "the finer suite (MJX on a CPU &lt;b&gt;costs&lt;/b&gt; \\| 100 CPU-s)."
    )
    lines = text.splitlines()
    header = next(i for i, x in enumerate(lines) if x.startswith("| rank |"))
    after = next(i for i in range(header, len(lines)) if not lines[i].startswith("|"))
    assert lines[after : after + 2] == ["", line]  # right under the answer's table
    assert "Left out on this machine" not in readme_markdown(runs)
