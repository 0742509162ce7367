"""The report's answer (reports/report/answer.py): per engine, the cheapest setting meeting
each accuracy tier on every scene, its cost, what it always gets wrong, and the scenes the
timestep limits. Rows made by hand, so that each number is known."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

import hoopbench as hb
from hoopbench.engines.base import DivergenceLimits, check_divergence
from hoopbench.engines.judging.score import CostClock
from hoopbench.engines.run import Divergence
from hoopbench.reports.report.answer import (
    ACCURACY_TIERS,
    RANK_RULE,
    answer,
    answer_markdown,
    at_best,
    best_search,
    ranked,
    timestep_limits,
)
from hoopbench.reports.report.answer_files import write_answer_files
from hoopbench.reports.report.best_settings import BestSettings
from hoopbench.reports.tune.tiers import cheapest_by_tier

SCENES = ("seed-mu", "hop-top", "low-friction")


def run(engine, scene, verdict, *, dt=1e-4, profile="tuned", variant="default", us=10.0):
    return {
        "run_id": f"{engine}-{scene}-{dt}-{profile}-{variant}",
        "engine": engine,
        "scene": scene,
        "profile": profile,
        "variant": variant,
        "timestep": dt,
        "status": "diverged" if verdict == "diverged" else "ok",
        "verdict": verdict,
        "us_per_step": us,
    }


def setting(engine, verdicts, **kwargs) -> list[dict]:
    return [run(engine, s, v, **kwargs) for s, v in zip(SCENES, verdicts, strict=True)]


def test_the_tiers_are_tight_agrees_and_loose_agrees_or_close():
    tiers = {tier.name: tier.verdicts for tier in ACCURACY_TIERS}
    assert tiers == {"tight": {"agrees"}, "loose": {"agrees", "close"}}


def test_the_cheapest_setting_meeting_a_tier_on_every_scene_and_its_cost():
    rows = pd.DataFrame(
        [
            *setting("mujoco", ["agrees"] * 3, dt=1e-4, us=10.0),  # 0.1 s per simulated s
            *setting("mujoco", ["agrees"] * 3, dt=1e-3, us=20.0),  # 0.02: the cheapest
            *setting("mujoco", ["agrees", "close", "agrees"], dt=2e-3, us=20.0),  # loose, 0.01
            *setting("mujoco", ["agrees", "early-slip", "agrees"], dt=5e-3, us=5.0),
            run("reference", "seed-mu", "agrees"),
        ]
    )
    (line,) = answer(rows).engines
    tight, loose = line.cheapest
    assert (tight.setting.timestep, tight.us_per_step, tight.scenes_met) == (1e-3, 20.0, 3)
    assert tight.cost_per_sim_s == pytest.approx(0.02)
    assert (loose.setting.timestep, loose.cost_per_sim_s) == (2e-3, pytest.approx(0.01))
    assert line.always_wrong == ()
    text = answer_markdown(answer(rows))
    assert (
        "| 1 | mujoco | tuned, default, dt 0.001 | 0.02 | 20 | - | tuned, default, dt 0.002 |"
        in text
    )


def test_each_tier_says_how_near_its_edge_the_setting_is():
    """The loose tier's setting: a re-stick 6 ms late on seed-mu (0.6 of loose, close), a
    slip onset 3 ms early on hop-top (0.3, agrees): the worst is the farthest against its
    loose tolerance; for the tight tier, of its runs that agree, hop-top's. low-friction,
    which the timestep limits (left out of the answer's scenes), does not count, however far
    off."""

    def timed(scene, verdict, name, error, ratio, **kwargs):
        row = run("mujoco", scene, verdict, **kwargs)
        return {**row, "max_transition": name, "max_transition_err_ms": error} | {
            "max_transition_ratio": ratio
        }

    rows = pd.DataFrame(
        [
            timed("seed-mu", "close", "re-stick 2", 6.0, 0.6),
            timed("hop-top", "agrees", "slip onset", -3.0, 0.3),
            timed("low-friction", "late-transition", "re-stick 1", 50.0, 5.0),
            run("pybullet", "low-friction", "agrees", dt=2.5e-5),
        ]
    )
    result = answer(rows)
    assert result.scenes == ("seed-mu", "hop-top")
    mujoco = next(line for line in result.engines if line.engine == "mujoco")
    tight, loose = mujoco.cheapest
    assert tight.scenes_met == 1 and tight.worst is not None and loose.worst is not None
    assert (loose.worst.scene, loose.worst.name, loose.worst.ratio) == (
        "seed-mu",
        "re-stick 2",
        0.6,
    )
    assert (tight.worst.scene, tight.worst.name, tight.worst.ratio) == (
        "hop-top",
        "slip onset",
        0.3,
    )
    text = answer_markdown(result)
    assert "| re-stick 2 on seed-mu, +6 ms (0.6 of loose) |" in text


def test_an_engine_meeting_no_tier_everywhere_shows_its_best_and_what_it_always_misses():
    rows = pd.DataFrame(
        [
            *setting("pymunk", ["agrees", "missed-hop", "agrees"], dt=1e-4, us=2.0),
            *setting("pymunk", ["agrees", "diverged", "early-slip"], dt=1e-3, us=2.0),
            *setting("pymunk", ["agrees", "agrees", "agrees"], profile="stock", variant="x")[:1],
            *setting("mujoco", ["agrees"] * 3),
        ]
    )
    result = answer(rows)
    pymunk = next(line for line in result.engines if line.engine == "pymunk")
    tight, _ = pymunk.cheapest
    assert (tight.setting.timestep, tight.scenes_met) == (1e-4, 2)  # 2 of 3 beats 1 of 3
    assert pymunk.always_wrong == (("hop-top", ("diverged", "missed-hop")),)
    assert pymunk.settings_tried == 3
    assert "tuned, default, dt 0.0001 (only 2/3 scenes)" in answer_markdown(result)
    assert "hop-top (blows up, misses the hop)" in answer_markdown(result)


def test_a_diverged_run_is_said_by_its_cause(tmp_path):
    """MuJoCo stock's soft contact lets the landing hoop of high-spin sink 5.2 cm (dt 1e-4),
    past the divergence limit: the run is stopped, but it does not blow up. The words say the
    cause the message begins with; the files keep the verdict's name."""
    rows = pd.DataFrame(
        [
            *setting("mujoco", ["agrees", "diverged", "early-slip"]),
            *setting("box2d", ["agrees"] * 3),
        ]
    )
    rows["message"] = [None, "penetration 0.052 m exceeds 0.05 a", *[None] * 4]
    result = answer(rows)
    assert "hop-top (sinks deep into the floor)" in answer_markdown(result)
    assert "blows up" not in answer_markdown(result)
    write_answer_files(result, tmp_path)
    table = pd.read_csv(tmp_path / "answer.csv").set_index("engine")
    assert table.loc["mujoco", "wrong_everywhere"] == "hop-top: diverged; low-friction: early-slip"
    words = {
        "energy rose to 11.1 times its initial value": "gains energy",
        "non-finite X, Y": "blows up",
        "the free body left the x-z plane (y 2e-05 m, tilt 0.001 rad)": "leaves the plane",
        "MuJoCo mjWARN_BADQACC, the engine reset its state": "blows up",  # the engine's own
    }
    for message, said in words.items():
        rows["message"] = [None, message, *[None] * 4]
        assert f"hop-top ({said})" in answer_markdown(answer(rows)), message


def test_the_divergence_checks_messages_begin_with_their_cause():
    """check_divergence's messages are what the answer's words read the cause from."""
    scene = hb.scene("hop-top")
    rest = scene.a * (1 + scene.lam)  # the centre of mass, the weight on top
    still = {"X": np.zeros(2), "Y": np.full(2, rest), "Xdot": np.zeros(2)}
    still |= {"Ydot": np.zeros(2), "theta": np.zeros(2), "thetadot": np.zeros(2)}
    sunk = {**still, "Y": np.array([rest, rest - 0.5 * scene.a])}
    fast = {**still, "Xdot": np.array([0.0, 1e3])}
    nan = {**still, "X": np.array([0.0, np.nan])}
    limits = DivergenceLimits()
    causes = [Divergence.of(check_divergence(scene, s, limits)) for s in (sunk, fast, nan)]
    assert causes == [Divergence.PENETRATION, Divergence.ENERGY_RISE, Divergence.NON_FINITE]


def test_a_scene_every_engine_fails_until_a_finer_timestep_is_the_timesteps_limit():
    rows = pd.DataFrame(
        [
            *setting("mujoco", ["agrees", "agrees", "wrong-phases"]),
            *setting("pybullet", ["agrees", "agrees", "wrong-phases"], dt=1e-3),
            *setting("pybullet", ["agrees", "agrees", "wrong-phases"]),
            run("pybullet", "low-friction", "agrees", dt=2.5e-5),
            run("pymunk", "low-friction", "close", dt=2.5e-5),
            run("pymunk", "low-friction", "agrees", dt=1e-5),
        ]
    )
    (limit,) = timestep_limits(rows)
    assert (limit.scene, limit.agreeing_timestep, limit.finest) == ("low-friction", 2.5e-5, 1e-5)
    assert limit.agreeing == ("pybullet (tuned)", "pymunk (tuned)")
    result = answer(rows)
    assert result.scenes == ("seed-mu", "hop-top")  # the limited scene is left out
    mujoco = next(line for line in result.engines if line.engine == "mujoco")
    assert mujoco.cheapest[0].scenes_met == 2 and mujoco.always_wrong == ()
    text = answer_markdown(result)
    assert "low-friction: no engine meets the loose tier at dt 0.0001 s or coarser" in text
    assert "at 2.5e-05 s pybullet (tuned), pymunk (tuned) do" in text
    # one engine meeting it at the default timestep: no limit, the scene is an engine's
    rows.loc[len(rows)] = run("drake", "low-friction", "agrees")
    assert timestep_limits(rows) == ()


def test_unavailable_and_unjudged_runs_say_nothing_about_a_setting():
    rows = pd.DataFrame(
        [
            *setting("mujoco", ["agrees"] * 3),
            {**run("dart", "seed-mu", None), "status": "unavailable"},
            run("mujoco", "not-a-catalogue-scene", "false-hop"),
        ]
    )
    result = answer(rows)
    assert [line.engine for line in result.engines] == ["mujoco"]
    assert result.scenes == SCENES


def test_one_scene_is_said_as_one():
    rows = pd.DataFrame([run("mujoco", "seed-mu", "agrees"), run("pybullet", "seed-mu", "close")])
    text = answer_markdown(answer(rows))
    assert "on the 1 catalogue scene (seed-mu)" in text and "all 1" not in text


def search(engine, rows, training=("seed-mu", "hop-top"), clock=CostClock.WALL) -> BestSettings:
    """A search read back, as best_settings gives it: its front rows, with tier counts, its
    costs by ``clock`` (wall: as every search shipped so far)."""
    front = pd.DataFrame(rows)
    return BestSettings(
        engine=engine,
        front=front,
        trials=pd.DataFrame(),
        training_scenes=training,
        tuned_heldout=None,
        at_tuned_cost=None,
        at_ten_times=None,
        cheapest=cheapest_by_tier(front),
        cost_clock=clock,
    )


def front_row(name, agrees, close, *, n=6, cost=5e5, dt=1e-4, heldout_tier="close"):
    return {
        "setting": name,
        "kind": "pareto",
        "timestep": dt,
        "train_cost_us_per_s": cost,
        "heldout_tier": heldout_tier,
        "agrees_scenes": agrees,
        "close_scenes": close,
        "n_scenes": n,
    }


def test_each_engine_at_its_best_weighs_the_shipped_search():
    """The suite meets the tight tier on 2/3 scenes and the loose on 3/3; the search's setting
    is within both on 6/6 of its scenes (4 held out), so it is the engine's best for tight;
    for loose both cover every scene, and the suite's is named (measured by this report; the
    search's cost is never compared with it)."""
    rows = pd.DataFrame(setting("drake", ["agrees", "close", "agrees"], us=10.0))
    found = search("drake", [front_row("trial-34", 6, 6, heldout_tier="agrees")])
    result = answer(rows, [found])
    tight, loose = at_best(result)
    assert tight.from_search and tight.search.setting == "trial-34"
    assert (tight.search.scenes_met, tight.search.scenes, tight.search.heldout) == (6, 6, 4)
    assert not loose.from_search and loose.suite.scenes_met == 3
    text = answer_markdown(result)
    assert (
        "| drake | tight | trial-34 (dt 0.0001) | 6/6 scenes, 4 of them held out (held-out tier: "
        "agrees) | 0.5 (wall, the search's) | search: drake's settings.toml#agrees; the suite's "
        "best: 2/3 catalogue "
        "scenes |" in text
    )
    assert (
        "| drake | loose | tuned, default, dt 0.0001 | 3/3 catalogue scenes | 0.1 (wall) |" in text
    )


def test_a_tie_in_share_names_the_suites_setting_whatever_the_search_s_cost():
    """Both within loose on every scene: the search's 0.05 wall s per simulated s is no
    cheaper than the suites' 0.1 CPU s (two clocks, two machines): the suites' setting, and
    the cell says the search's clock."""
    rows = pd.DataFrame(
        [{**r, "cpu_us_per_step": r["us_per_step"]} for r in setting("drake", ["close"] * 3)]
    )
    for clock in CostClock:
        found = search("drake", [front_row("trial-3", 0, 6, cost=5e4)], clock=clock)
        (loose,) = at_best(answer(rows, [found]))
        assert not loose.from_search and loose.suite.scenes_met == 3
        assert loose.search.clock is clock and loose.search.cost_per_sim_s == pytest.approx(0.05)


def test_the_searches_best_prefers_a_cpu_costed_search_and_compares_costs_within_a_clock():
    """Three searches within loose on all their scenes: the wall-costed one is the cheapest
    by its number, but wall and CPU costs are not compared: of the CPU-costed ones, the
    cheaper; the table's cell says the clock."""
    rows = pd.DataFrame(setting("mujoco", ["agrees", "early-slip", "agrees"]))
    found = [
        search("pymunk", [front_row("trial-1", 0, 6, cost=1e4)], clock=CostClock.WALL),
        search("rapier", [front_row("trial-2", 0, 6, cost=9e5)], clock=CostClock.CPU),
        search("box2d", [front_row("trial-3", 0, 6, cost=3e5)], clock=CostClock.CPU),
    ]
    result = answer(rows, found)
    best = best_search(result, 1)
    assert (best.engine, best.clock) == ("box2d", CostClock.CPU)
    text = answer_markdown(result)
    assert (
        "| box2d | loose | trial-3 (dt 0.0001) |" in text and "| 0.3 (CPU, the search's) |" in text
    )
    assert "| 0.01 (wall, the search's) |" in text


def test_an_engine_of_a_search_alone_is_at_its_best_but_not_in_the_suites_table():
    rows = pd.DataFrame(setting("mujoco", ["agrees"] * 3))
    found = search("newton", [front_row("trial-7", 0, 2, cost=1.5e6)])
    text = answer_markdown(answer(rows, [found]))
    assert "| newton | none |" not in text
    assert "| newton | loose | trial-7 (dt 0.0001) | 2/6 scenes" in text
    assert "| newton | tight |" not in text  # no setting of the search agrees anywhere


def _chosen(result) -> list[tuple[str, list[str | None]]]:
    """Each engine's chosen setting per tier: the answer table without its measured costs."""
    return [
        (line.engine, [None if c is None else c.setting.label for c in line.cheapest])
        for line in result.engines
    ]


def test_costs_within_the_noise_choose_the_same_settings_whichever_measured_less():
    """Two runs of the same suites, their measured costs swapped within the noise (10 and 12
    CPU us/step, a factor 1.2 < COST_NOISE_FACTOR): the same settings each time, by the
    stated rule (the larger timestep, then stock before tuned, then fewer options changed),
    not by which happened to measure cheaper. A cost outside the noise still wins."""

    def frame(first: float, second: float, third: float) -> pd.DataFrame:
        rows = [
            *setting("rapier", ["agrees"] * 3, profile="tuned", us=first),
            *setting("rapier", ["agrees"] * 3, profile="stock", us=second),
            *setting("newton", ["agrees"] * 3, dt=1e-3, us=first),
            *setting("newton", ["agrees"] * 3, dt=1e-3, variant="x", us=second),
            *setting("mjx", ["close"] * 3, dt=1e-4, us=first),  # 0.1 s per simulated s
            *setting("mjx", ["close"] * 3, dt=1e-3, us=10 * second),  # 0.1 or 0.12
            *setting("dart", ["agrees"] * 3, profile="stock", us=third),
            *setting("dart", ["agrees"] * 3, profile="tuned", us=10.0),
        ]
        return pd.DataFrame([{**r, "cpu_us_per_step": r["us_per_step"]} for r in rows])

    one, two = answer(frame(10.0, 12.0, 30.0)), answer(frame(12.0, 10.0, 30.0))
    assert one.clock == two.clock == "CPU"
    assert _chosen(one) == _chosen(two)
    chosen = dict(_chosen(one))
    assert chosen["rapier"][0] == "stock, default, dt 0.0001"  # stock before tuned
    assert chosen["newton"][0] == "tuned, default, dt 0.001"  # fewer options changed
    assert chosen["mjx"][1] == "tuned, default, dt 0.001"  # the larger timestep
    assert chosen["dart"][0] == "tuned, default, dt 0.0001"  # 3x: outside the noise
    text = answer_markdown(one)
    assert "CPU us/step" in text and "within a factor 2 of the cheapest count as equal" in text


def test_two_reports_measured_costs_choose_the_same_setting():
    """Newton's stock and tuned calls at dt 1e-3 (8 worlds in one call of 18-28 ms) as two
    ``make report`` runs alone on one machine measured them (score.COST_NOISE_FACTOR):
    5.94 and 7.29 CPU us/step, then 9.24 and 5.99. The same setting both times: stock, by
    the tie rule; with a factor 1.5 the second report named tuned."""

    def frame(stock: float, tuned: float) -> pd.DataFrame:
        rows = [
            *setting(
                "newton", ["agrees", "missed-hop", "missed-hop"], dt=1e-3, profile="stock", us=stock
            ),
            *setting(
                "newton", ["agrees", "missed-hop", "missed-hop"], dt=1e-3, profile="tuned", us=tuned
            ),
        ]
        return pd.DataFrame([{**r, "cpu_us_per_step": r["us_per_step"]} for r in rows])

    first, second = answer(frame(5.94, 7.29)), answer(frame(9.24, 5.99))
    assert _chosen(first) == _chosen(second) == [("newton", ["stock, default, dt 0.001"] * 2)]


def test_the_cost_is_the_cpu_time_where_the_rows_carry_it():
    rows = pd.DataFrame(
        [
            *({**r, "cpu_us_per_step": 30.0} for r in setting("mujoco", ["agrees"] * 3, us=5.0)),
            *(
                {**r, "cpu_us_per_step": 10.0}
                for r in setting("mujoco", ["agrees"] * 3, profile="stock", us=50.0)
            ),
        ]
    )
    (line,) = answer(rows).engines
    tight, _ = line.cheapest
    assert (tight.setting.profile, tight.us_per_step, tight.clock) == ("stock", 10.0, "CPU")
    assert answer(rows.drop(columns=["cpu_us_per_step"])).clock == "wall"


def test_a_run_the_time_limit_ended_is_the_machines_failure_not_the_engines():
    """An MJX run that timed out under load (stored with verdict failed before issue 34, or
    with none since): not among what the engine always gets wrong, its setting short of that
    scene as if it had not run it, and named in the answer's text."""
    rows = pd.DataFrame(
        [
            *setting("mjx", ["agrees", "agrees", "failed"], dt=1e-4),
            *setting("mjx", ["agrees", "agrees", None], dt=1e-3),
            *setting("mujoco", ["agrees"] * 3),  # low-friction can be met: not the timestep's
        ]
    )
    rows.loc[(rows["scene"] == "low-friction") & (rows["engine"] == "mjx"), "status"] = "timeout"
    result = answer(rows)
    assert result.scenes == SCENES
    line = result.engines[0]
    assert line.engine == "mjx" and line.always_wrong == ()
    tight, _ = line.cheapest
    assert tight.scenes_met == 2
    assert len(result.timed_out) == 2
    assert result.timed_out[0] == ("mjx (tuned) dt 0.0001", "low-friction")
    text = answer_markdown(result)
    assert "2 run(s) ended by the sweep's time limit, the machine's failure" in text
    assert "mjx (tuned) dt 0.001 on low-friction" in text


def test_engines_whose_costs_are_within_the_noise_rank_by_name():
    """DART and Drake meet the same scenes; Drake's loose cost measured 1.27-1.64 times
    DART's over seven reports on one machine. Within the noise (COST_NOISE_FACTOR) either
    may measure cheaper, and the table ranks them by name both ways; 3 times apart, by cost."""

    def order(dart_us: float, drake_us: float) -> list[str]:
        rows = [
            *setting("drake", ["agrees", "close", "missed-hop"], us=drake_us),
            *setting("dart", ["agrees", "close", "missed-hop"], us=dart_us),
            *setting("box2d", ["agrees", "agrees", "close"], us=50.0),
        ]
        frame = pd.DataFrame([{**r, "cpu_us_per_step": r["us_per_step"]} for r in rows])
        return [line.engine for line in ranked(answer(frame))]

    assert order(10.0, 13.0) == order(13.0, 10.0) == ["box2d", "dart", "drake"]
    assert order(30.0, 10.0) == ["box2d", "drake", "dart"]
    assert "within a factor 2 of the cheapest of theirs count as equal, by name" in RANK_RULE
