"""The progress lines' ETA from the calls' expected costs (reports/sweep/eta.py) and the
overall line of sweeps run in a row (reports/sweep/plan.py), on synthetic finished calls
and priors: no clock is asserted, only the arithmetic of the estimate. About 2 s."""

from __future__ import annotations

import gzip
import io
import json
import random
from collections import Counter, deque
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest
from test_runner import Job, job_failure_row, job_worker

from hoopbench.engines.base import CHUNK_STEPS
from hoopbench.engines.judging.columns import Col
from hoopbench.engines.warp_compile import LOCKS
from hoopbench.reports.bench.call_costs import (
    accuracy,
    compile_costs,
    fit,
    rounding,
    seconds_of,
)
from hoopbench.reports.bench.eta_replay import (
    _begin,
    _InFlight,
    _next_call,
    _Recorded,
    recorded_keys,
    replay,
)
from hoopbench.reports.bench.eta_replay import _Sweep as _ReplaySweep
from hoopbench.reports.bench.eta_replay import main as replay_main
from hoopbench.reports.compare.costs import (
    CALL_COST_PRIOR,
    COLD_CACHE_S,
    MAP,
    REPORT,
    call_cost,
    cold_caches,
    map_call_cost,
    priors,
    taken_world_steps,
)
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import MapTask
from hoopbench.reports.report_runs import report_plan
from hoopbench.reports.sweep import eta
from hoopbench.reports.sweep.eta import (
    CallCost,
    Costing,
    Rates,
    Running,
    Took,
    call_ends,
    call_firsts,
    key_holders,
    kind_factors,
    machine_factor,
    ran,
    remaining_seconds,
    warm_counts,
)
from hoopbench.reports.sweep.plan import Plan, PlannedSweep, current_plan
from hoopbench.reports.sweep.runner import run_tasks


@pytest.fixture
def raw_factors(monkeypatch):
    """A kind's factor as its calls measured it, none of the machine's blended in: for the
    tests of which factor a call takes (the blend has its own test)."""
    monkeypatch.setattr(eta, "KIND_CREDIBLE_S", 0.0)


CHEAP = CallCost(kinds=(("pymunk", "tuned", "default"), "pymunk"), steps=1000)
DEAR = CallCost(kinds=(("mjx", "tuned", "default"), "mjx"), steps=1000, worlds=8)
PRIOR = {
    "pymunk": Rates(fixed_s=0.2, step_s=1e-5),  # 1000 steps: 0.21 s
    "mjx": Rates(fixed_s=10.0, step_s=1e-3, world_step_s=1e-4, cold_s=50.0),  # 11.8 s warm
}


def test_a_call_costs_its_fixed_part_its_steps_and_its_world_steps():
    assert PRIOR["pymunk"].seconds(CHEAP) == pytest.approx(0.21)
    assert PRIOR["mjx"].seconds(DEAR) == pytest.approx(10.0 + 1000 * (1e-3 + 8 * 1e-4))
    assert PRIOR["mjx"].seconds(DEAR, cold=True) == pytest.approx(11.8 + 50.0)


def test_calls_at_a_finer_step_do_not_scale_the_dear_kind_down():
    """Issue 34: the finer suite's ETA was 0.14-0.25 of the time left. Cheap calls of 120,000
    steps ran as their fixed and per-step parts say (0.2 + 1.2 s): the machine is as fast as
    the priors, and MJX's call is expected at its prior. A prior per step alone, measured on
    calls of 1,000 steps (0.21 ms a step), said 25 s of them and scaled MJX by 0.056."""
    fine = CallCost(kinds=CHEAP.kinds, steps=120_000)
    finished = [Took(fine, 1.4), Took(fine, 1.4)]
    assert machine_factor(finished, PRIOR) == pytest.approx(1.0)
    warm = {DEAR.kinds[0]: 1}
    assert remaining_seconds([DEAR], [], finished, 1, PRIOR, warm) == pytest.approx(11.8)
    per_step_only = {"pymunk": Rates(0.0, 0.21e-3), "mjx": Rates(0.0, 11.8e-3)}
    assert machine_factor(finished, per_step_only) == pytest.approx(2.8 / 50.4)


def test_the_cheap_runs_finishing_first_do_not_make_the_eta_short():
    """Issue 34: 'eta 3m' took 27 min. 98 cheap runs done in 10 s, 2 dear ones left: by the
    count the sweep is 98 % done; by cost it has 2 minutes left on one worker."""
    prior = {"pymunk": Rates(0.1, 0.0), "mjx": Rates(60.0, 0.0)}
    finished = [Took(CHEAP, 0.1)] * 98 + [Took(DEAR, 60.0)]
    left = remaining_seconds([DEAR, DEAR], [], finished, workers=1, prior=prior)
    assert left == pytest.approx(120.0)
    by_count = (98 * 0.1 + 60.0) / 99 * 2
    assert by_count < left / 1.5  # what the old line said: far too short


def test_the_calls_left_are_laid_out_on_the_workers_in_order():
    prior = {"pymunk": Rates(0.0, 1e-3)}  # 1 ms a step: each call 1 s
    long = CallCost(kinds=CHEAP.kinds, steps=30_000)  # 30 s
    assert remaining_seconds([CHEAP] * 4, [], [], 2, prior) == pytest.approx(2.0)
    # One long call cannot be split: the sweep lasts at least as long as it.
    assert remaining_seconds([long, CHEAP, CHEAP], [], [], 2, prior) == pytest.approx(30.0)
    # A call in flight keeps its worker for what it has left.
    running = [Running(long, 20.0)]
    assert remaining_seconds([CHEAP], running, [], 2, prior) == pytest.approx(10.0)
    # Past its expected cost, a tenth of what it has run is left of it.
    assert remaining_seconds([], [Running(CHEAP, 5.0)], [], 2, prior) == pytest.approx(0.5)


def test_a_kind_measured_scales_its_own_prior_the_others_scale_by_the_machine(raw_factors):
    """pymunk ran 3 times its prior, MJX not yet: MJX is expected 3 times its prior (the
    machine is loaded); once an MJX call ran 1.5 times its prior, MJX is its own."""
    finished = [Took(CHEAP, 0.63), Took(CHEAP, 0.63)]
    warm = {DEAR.kinds[0]: 1}  # its worker has traced it: no cold part
    assert kind_factors(finished, PRIOR)["pymunk"] == pytest.approx(3.0)
    assert machine_factor(finished, PRIOR) == pytest.approx(3.0)
    assert remaining_seconds([DEAR], [], finished, 1, PRIOR, warm) == pytest.approx(3 * 11.8)
    finished.append(Took(DEAR, 1.5 * 11.8))
    assert remaining_seconds([DEAR], [], finished, 1, PRIOR, warm) == pytest.approx(1.5 * 11.8)
    assert machine_factor([], PRIOR) == 1.0


def test_a_line_makes_its_estimate_once_and_anew_once_a_call_has_ended(monkeypatch):
    """A progress line lays out the calls three times over the same finished calls (the
    sweep's ETA, the plan's, the report after them): the estimate from them is made once,
    and made again once another call has finished (else the ETA would not move)."""
    made: list[int] = []

    class Counted(eta._Estimate):
        def __init__(self, finished, prior):
            made.append(len(finished))
            super().__init__(finished, prior)

    monkeypatch.setattr(eta, "_Estimate", Counted)
    finished = [Took(CHEAP, 0.63), Took(CHEAP, 0.63)]
    warm = {DEAR.kinds[0]: 1}
    before = remaining_seconds([DEAR], [], finished, 1, PRIOR, warm)
    assert remaining_seconds([DEAR, CHEAP], [], finished, 2, PRIOR, warm) is not None
    assert made == [2]
    finished.append(Took(DEAR, 1.5 * 11.8))
    after = remaining_seconds([DEAR], [], finished, 1, PRIOR, warm)
    assert made == [2, 3]
    assert after != before  # the DEAR call measured moves it


def test_the_most_specific_kind_with_a_prior_or_a_measure_wins(raw_factors):
    solver = CallCost(kinds=(("newton", "tuned", "solver=mujoco"), "newton"), steps=100)
    plain = CallCost(kinds=(("newton", "tuned", "default"), "newton"), steps=100)
    prior = {"newton": Rates(0.0, 0.01), ("newton", "tuned", "solver=mujoco"): Rates(0.0, 0.05)}
    # The variant's own prior beats the engine's...
    assert remaining_seconds([solver], [], [], 1, prior) == pytest.approx(5.0)
    # ... and the plain variant measured twice its prior scales the other by the engine's
    # factor until the variant itself has a finished call.
    finished = [Took(plain, 2.0)]
    assert remaining_seconds([solver], [], finished, 1, prior) == pytest.approx(10.0)
    finished.append(Took(solver, 4.0))  # 0.8 of its prior: the variant's own factor
    assert remaining_seconds([solver], [], finished, 1, prior) == pytest.approx(4.0)
    # A kind no prior knows: every finished call's mean per step; nothing: no estimate.
    other = CallCost(kinds=(("dart", "tuned", "default"), "dart"), steps=100)
    assert remaining_seconds([other], [], finished, 1, {}) == pytest.approx(100 * 6.0 / 200)
    assert remaining_seconds([other], [], [], 1, {}) is None


def test_a_workers_first_call_of_a_kind_is_cold():
    """MJX's first call on a worker traces and compiles: 50 s more, once per worker."""
    assert remaining_seconds([DEAR] * 3, [], [], 2, PRIOR) == pytest.approx(61.8 + 11.8)
    # One worker has run it already: one cold call left.
    warm = {DEAR.kinds[0]: 1}
    assert remaining_seconds([DEAR] * 2, [], [], 2, PRIOR, warm) == pytest.approx(61.8)
    both = {DEAR.kinds[0]: 2}
    assert remaining_seconds([DEAR] * 2, [], [], 2, PRIOR, both) == pytest.approx(11.8)


def test_a_call_that_steps_nothing_costs_its_fixed_part():
    """A call that steps nothing (a map's classification) costs its fixed part."""
    point = CallCost(kinds=((MAP, "reference"),), steps=0)
    prior = {(MAP, "reference"): Rates(0.5, 0.0)}
    assert remaining_seconds([point] * 4, [], [], 2, prior) == pytest.approx(1.0)
    assert remaining_seconds([point], [], [Took(point, 1.0)], 1, prior) == pytest.approx(1.0)


def test_a_kind_measured_on_less_than_a_second_leans_on_the_machines_factor():
    """Issue 34: the map's classification, 100 points, 3.6 s. Its first 41 points solved
    their window (55 ms each, twice the prior), the rest mostly returned at once: its own
    factor said 1.6 s left where 0.95 s were (1.66 times). 2.3 s of calls that the priors
    said were 1.1 s weigh against a second at the machine's factor (1: pymunk ran as said);
    a kind measured on many seconds is its own."""
    prior = {(MAP, "reference"): Rates(0.028, 0.0), "pymunk": Rates(0.2, 1e-5)}
    prior["box2d"] = prior["pymunk"]
    point = CallCost(kinds=((MAP, "reference"),), steps=0)
    box2d = CallCost(kinds=(("box2d", "tuned", "default"), "box2d"), steps=1000)
    as_said = [Took(CHEAP, 0.21), Took(box2d, 0.21)] * 10  # the median engine's: 1
    finished = as_said + [Took(point, 0.055)] * 41
    own = 0.055 / 0.028
    blended = (41 * 0.055 + eta.KIND_CREDIBLE_S) / (41 * 0.028 + eta.KIND_CREDIBLE_S)
    assert 1.0 < blended < 0.8 * own
    assert kind_factors(finished, prior, machine_factor(finished, prior))[
        point.kinds[0]
    ] == pytest.approx(blended)
    left = remaining_seconds([point] * 58, [], finished, 2, prior, {point.kinds[0]: 2})
    assert left == pytest.approx(29 * 0.028 * blended)
    many = as_said + [Took(point, 0.055)] * 2000  # 56 s said
    factor = kind_factors(many, prior, machine_factor(many, prior))[point.kinds[0]]
    assert factor == pytest.approx(own, rel=0.02)


@dataclass(frozen=True)
class SuiteLike:
    engine: str
    n_steps: int
    profile: str = "tuned"
    variant: str = "default"


def test_a_batch_counts_once_at_its_longest_world_with_its_worlds():
    call = call_cost([SuiteLike("mjx", 3000), SuiteLike("mjx", 1000)])
    assert call.steps == 3000
    assert call.worlds == 2
    assert call.kinds == (("mjx", "tuned", "default"), "mjx")
    # MJX steps a call's worlds together until its last ends: the longest's, twice.
    assert call.world_steps == call.paid_world_steps == 6000


def test_a_mujoco_batch_costs_its_worlds_own_steps_summed():
    """MuJoCo's batch steps only its worlds still running: the stability suite's batch of
    three windows (150000, 100000 and 15000 steps) steps 265000 world-steps, not
    3 x 150000."""
    call = call_cost([SuiteLike("mujoco", n) for n in (150000, 100000, 15000)])
    assert (call.steps, call.worlds, call.world_steps) == (150000, 3, 265000)
    assert call_cost([SuiteLike("mujoco", 3000)]).world_steps == 3000


def test_a_call_that_says_no_world_steps_pays_its_longest_worlds_times_its_worlds():
    """A CallCost without world-steps (a calls file recorded before them): steps x worlds."""
    assert DEAR.world_steps is None and DEAR.paid_world_steps == 8000
    said = replace(DEAR, world_steps=2000)
    assert PRIOR["mjx"].seconds(said) == pytest.approx(10.0 + 1000 * 1e-3 + 2000 * 1e-4)


def _map_run(engine: str = "pybullet", **exact: float | None) -> MapTask:
    """A map engine run at 1e-4 s over a 3-s window (30000 steps) carrying these exact
    columns (none: planned before its point is classified)."""
    spec = MapSpec(nx=2, ny=1, engines=(engine,), timestep=1e-4, t_end=3.0)
    point = spec.points()[0]
    return MapTask("p", point, engine, 1e-4, spec.profile, tuple(exact.items()))


def test_a_map_batch_of_mujoco_worlds_costs_their_expected_steps_summed():
    """Issue 34: each world of a MuJoCo batch of the map's points stops at its own stop rule
    (MuJoCo steps only the worlds still running), so the batch costs about its worlds'
    expected steps summed: make report's 4 batches of 25 points, 345k-478k world-steps,
    were costed 750k each (their longest world's times 25), and the map's ETA at 75 % of
    its runs, its last batch (345k) left, read 1.26-1.31 times the time left. An engine
    that steps all of a call's worlds until the last ends (MJX) keeps the longest's."""
    lifts = _map_run("mujoco", exact_t_impact=0.0731, exact_t_settled=None)
    settles = _map_run("mujoco", exact_t_impact=None, exact_t_settled=1.234)
    rocks = _map_run("mujoco", exact_t_impact=None, exact_t_settled=None)
    batch = map_call_cost([lifts, settles, rocks])
    assert (batch.steps, batch.worlds) == (30000, 3)
    assert batch.world_steps == CHUNK_STEPS + 13 * CHUNK_STEPS + 30000  # 44000, not 90000
    rates = CALL_COST_PRIOR[(MAP, "mujoco")]
    assert rates.seconds(batch) == pytest.approx(
        rates.fixed_s + 30000 * rates.step_s + 44000 * rates.world_step_s
    )
    # Two batches: the one of worlds that stop early costs less, at the same longest world.
    cheap = map_call_cost([lifts, lifts, rocks])
    assert cheap.steps == batch.steps and rates.seconds(cheap) < rates.seconds(batch)
    mjx = [_map_run("mjx", **dict(task.exact)) for task in (lifts, settles, rocks)]
    assert map_call_cost(mjx).world_steps == 3 * 30000


def test_a_finished_calls_world_steps_are_its_rows_steps_by_the_same_rule():
    """What a finished call took (report-runs --calls' world_steps, the priors' fit): its
    rows' steps, summed for MuJoCo, the longest's times its worlds for MJX; unknown where a
    row records none."""
    rows = [{Col.N_STEPS: 1000}, {Col.N_STEPS: np.int64(30000)}, {Col.N_STEPS: 13000}]
    mujoco = [_map_run("mujoco")] * 3
    assert taken_world_steps(mujoco, rows) == 44000
    assert taken_world_steps([_map_run("mjx")] * 3, rows) == 90000
    assert taken_world_steps(mujoco, [*rows[:2], {Col.N_STEPS: None}]) is None
    assert taken_world_steps(mujoco, [*rows[:2], {Col.N_STEPS: float("nan")}]) is None
    assert taken_world_steps(mujoco, rows[:2]) is None


def test_a_map_call_costs_the_steps_to_where_its_stop_rule_ends_it():
    """Issue 34: a map's engine run stops at its first impact or once settled (its
    StopRule); costed by its whole window, the grid's first rows (rocking or slipping the
    whole window, up to 0.68 CPU-s a PyBullet point) and its later ones (lifting off at
    once, 0.04-0.09) looked alike, and the factor the first measured made the ETA 1.2-1.5
    times the time left. Its steps are those to the chunk in which the rule stops a run
    that follows the exact motion."""
    rocks = _map_run(exact_t_impact=None, exact_t_settled=None)
    window = rocks.n_steps
    assert window == 30000
    assert map_call_cost([rocks]).steps == window
    lifts = _map_run(exact_t_impact=0.0731, exact_t_settled=None)
    assert map_call_cost([lifts]).steps == CHUNK_STEPS  # its impact's chunk: 0.1 s
    settles = _map_run(exact_t_impact=None, exact_t_settled=1.234)
    assert map_call_cost([settles]).steps == 13 * CHUNK_STEPS
    both = _map_run(exact_t_impact=2.05, exact_t_settled=1.234)  # the earlier ends it
    assert map_call_cost([both]).steps == 13 * CHUNK_STEPS
    assert map_call_cost([_map_run()]).steps == window  # not classified yet: its window
    assert map_call_cost([lifts, rocks]).steps == window  # a batch: its longest world's
    assert map_call_cost([_map_run()]).kinds == (
        (MAP, "pybullet", "tuned", 1e-4),
        (MAP, "pybullet"),
    )


def test_every_engine_the_map_and_the_report_have_a_prior():
    from hoopbench.engines.registry import engine_names

    assert set(engine_names()) <= set(CALL_COST_PRIOR)
    assert {(MAP, "reference"), (MAP, "mujoco"), (MAP, "pybullet"), (MAP, "pymunk")} <= set(
        CALL_COST_PRIOR
    )
    assert REPORT in CALL_COST_PRIOR
    assert all(r.fixed_s + r.step_s + r.world_step_s > 0 for r in CALL_COST_PRIOR.values())


def test_cold_caches_are_the_engines_whose_compiled_code_folder_is_empty(tmp_path, monkeypatch):
    monkeypatch.setenv("HOOPBENCH_CACHE", str(tmp_path))
    assert {"mjx", "newton", "mjwarp"} <= cold_caches()
    (tmp_path / "jax" / "sub").mkdir(parents=True)  # a folder alone compiles nothing
    assert "mjx" in cold_caches()
    (tmp_path / "jax" / "sub" / "entry").write_bytes(b"x")
    assert "mjx" not in cold_caches()
    assert "pymunk" not in cold_caches()  # compiles nothing: never cold
    # a run killed mid-compile leaves Warp's compile locks and nothing compiled
    locks = tmp_path / "warp" / "1.0" / LOCKS
    locks.mkdir(parents=True)
    (locks / "module_abc.lock").write_bytes(b"")
    assert "newton" in cold_caches()
    (tmp_path / "warp" / "1.0" / "module_abc").mkdir()
    (tmp_path / "warp" / "1.0" / "module_abc" / "module.o").write_bytes(b"x")
    assert "newton" not in cold_caches()


def test_a_cache_under_a_folder_named_like_the_locks_is_read_as_any_other(tmp_path, monkeypatch):
    monkeypatch.setenv("HOOPBENCH_CACHE", str(tmp_path / LOCKS))
    (tmp_path / LOCKS / "warp" / "module_abc").mkdir(parents=True)
    (tmp_path / LOCKS / "warp" / "module_abc" / "module.o").write_bytes(b"x")
    assert "newton" not in cold_caches()


MJW_TUNED = CallCost(kinds=(("mjwarp", "tuned", "default"), "mjwarp"), steps=3000, worlds=2)
MJW_STOCK = CallCost(kinds=(("mjwarp", "stock", "default"), "mjwarp"), steps=3000, worlds=2)
MJX_TUNED = CallCost(kinds=(("mjx", "tuned", "default"), "mjx"), steps=3000, worlds=8)


def test_a_cold_cache_compiles_an_engines_kernels_once_a_worker_whichever_kind():
    """Issue 34, caches cold: MuJoCo Warp's first call in a worker compiled Warp's kernels
    (18.5 and 32.8 s); its other kind's first call in that worker took 0.3-0.7 s."""
    assert priors() == CALL_COST_PRIOR
    cold = priors({"mjwarp"})
    compile_s = COLD_CACHE_S["mjwarp"]
    warm_priors = remaining_seconds([MJW_TUNED, MJW_STOCK], [], [], 1, CALL_COST_PRIOR)
    # One worker, both kinds: the kernels once, on the first call.
    assert remaining_seconds([MJW_TUNED, MJW_STOCK], [], [], 1, cold) == pytest.approx(
        warm_priors + compile_s
    )
    # A worker that has run the engine (another kind) compiles nothing more.
    warm = {"mjwarp": 1, MJW_TUNED.kinds[0]: 1}
    assert remaining_seconds([MJW_STOCK], [], [], 1, cold, warm) == pytest.approx(
        remaining_seconds([MJW_STOCK], [], [], 1, CALL_COST_PRIOR, warm)
    )
    # Two workers that have not: each compiles on its first call.
    both = remaining_seconds([MJW_TUNED, MJW_STOCK], [], [], 2, cold)
    alone = remaining_seconds([MJW_STOCK], [], [], 1, CALL_COST_PRIOR)
    assert both == pytest.approx(alone + compile_s)


def test_calls_that_keep_to_one_worker_pay_an_engines_first_call_once():
    """A batched engine's calls keep to the worker that has run one (the runner's batch
    affinity): two workers, MuJoCo Warp's two kinds on a cold cache compile its kernels once
    (on the first call), as on one worker; the calls that spread compile them twice."""
    cold = priors({"mjwarp"})
    first_s = cold["mjwarp"].first_s  # the kernels compiled (and loaded)
    tuned, stock = replace(MJW_TUNED, affinity="mjwarp"), replace(MJW_STOCK, affinity="mjwarp")
    spread = call_ends([MJW_TUNED, MJW_STOCK], [], [], 2, cold)
    kept = call_ends([tuned, stock], [], [], 2, cold)
    assert spread is not None and kept is not None
    # Each call on a worker of its own, starting now: its end is its seconds.
    one_worker = remaining_seconds([MJW_TUNED, MJW_STOCK], [], [], 1, cold)
    assert sum(kept[1]) == pytest.approx(one_worker)
    assert sum(spread[1]) == pytest.approx(one_worker + first_s)
    # A worker has run the engine: no worker's first call is left to pay.
    warm = {"mjwarp": 1, MJW_TUNED.kinds[0]: 1}
    assert remaining_seconds([stock], [], [], 2, cold, warm) == pytest.approx(
        remaining_seconds([stock], [], [], 2, CALL_COST_PRIOR, warm)
    )


def test_a_batched_engines_calls_queue_on_its_worker_while_others_take_the_other():
    """The pool keeps a batched engine's calls on the worker that runs it and hands the other
    worker the calls behind them (WorkerPool.submit_keyed): a cold make report's map
    classification started with three of MuJoCo's 5-s stability calls left, ran on the other
    worker at once and ended in 3.4 s, where an ETA that laid MuJoCo's calls on either worker
    said 5-8 s. Here: one such call in flight (5 s left) and two pending, then ten cheap
    calls that keep to no worker."""
    batch = Rates(fixed_s=5.0, step_s=0.0)
    prior = {"mujoco": batch, "pymunk": Rates(fixed_s=0.1, step_s=0.0)}
    mujoco = CallCost(kinds=(("mujoco", "tuned", "default"), "mujoco"), steps=0, affinity="mujoco")
    point = CallCost(kinds=(("pymunk", "tuned", "default"), "pymunk"), steps=0)
    running = [Running(mujoco, ran=0.0)]
    ends = call_ends([mujoco, mujoco, *[point] * 10], running, [], 2, prior)
    assert ends is not None
    assert ends[0] == [pytest.approx(5.0)]
    assert ends[1][2:] == [pytest.approx(0.1 * k) for k in range(1, 11)]
    # Then, nothing else left, the other worker takes the engine's next call (as the pool
    # does after STEAL_AFTER_S) while its own worker runs the last.
    assert ends[1][:2] == [pytest.approx(1.0 + 5.0), pytest.approx(10.0)]
    # Nothing else pending: no worker idles in the layout either.
    ends = call_ends([mujoco, mujoco], running, [], 2, prior)
    assert ends is not None and sorted(ends[1]) == [pytest.approx(5.0), pytest.approx(10.0)]


def test_a_cold_cache_compiles_a_kinds_program_once_on_the_machine():
    """MJX's XLA program of a kind lands in the cache every worker reads: the finer suite's
    tuned call on the other worker took 10.8 s, as warm (10.6)."""
    cold = priors({"mjx"})
    compile_s = COLD_CACHE_S[("mjx", "tuned", "default")]
    warm_priors = remaining_seconds([MJX_TUNED], [], [], 1, CALL_COST_PRIOR)
    assert remaining_seconds([MJX_TUNED], [], [], 1, cold) == pytest.approx(warm_priors + compile_s)
    # Two workers, two calls of it at once: one compiles.
    assert remaining_seconds([MJX_TUNED] * 2, [], [], 2, cold) == pytest.approx(
        warm_priors + compile_s
    )
    # Another worker has run it: this worker's first call traces (cold) but compiles nothing.
    warm = {MJX_TUNED.kinds[0]: 1, "mjx": 1}
    assert remaining_seconds([MJX_TUNED], [], [], 2, cold, warm) == pytest.approx(warm_priors)
    other = CallCost(kinds=(("mjx", "tuned", "solref=0.02"), "mjx"), steps=3000, worlds=8)
    assert remaining_seconds([other], [], [], 1, cold) == pytest.approx(
        remaining_seconds([other], [], [], 1, CALL_COST_PRIOR)
    )


def test_a_calls_firsts_are_its_workers_and_the_machines():
    """Worker 1 has run MuJoCo Warp's tuned kind: its stock call is cold (its kind's first
    there) and new (no worker has run it), not first (the engine's kernels are there); on
    worker 2 the tuned kind's call is cold and first, not new."""
    warm = ran(MJW_TUNED, 1)
    assert call_firsts(MJW_STOCK, 1, warm) == (True, False, True)
    assert call_firsts(MJW_TUNED, 2, warm) == (True, True, False)
    assert call_firsts(MJW_TUNED, 1, warm) == (False, False, False)
    assert warm_counts(warm | ran(MJW_STOCK, 2)) == Counter(
        {"mjwarp": 2, MJW_TUNED.kinds[0]: 1, MJW_STOCK.kinds[0]: 1}
    )


def _engine_x(tasks):
    return CallCost(kinds=((tasks[0].kind, "x"), "x"), steps=1)


def test_the_runner_records_each_calls_firsts_on_its_worker(tmp_path):
    """One worker runs an 'ok' call, a 'sleep' call and an 'ok' call, both kinds of engine
    x: the first is the worker's first of its kind and of the engine and the machine's
    first of its kind; the second only of its kind and the machine's; the third none. About
    1 s (one worker process)."""
    plan = Plan("make report", [PlannedSweep("default", 3, ())], {"x": Rates(0.01, 0.0)}, 1)
    jobs = [Job("ok-0"), Job("sleep-1", "sleep"), Job("ok-2")]
    token = current_plan.set(plan)
    try:
        run_tasks(jobs, job_worker, tmp_path / "out", jobs=1, max_in_flight=1, quiet=True,
                  failure_row=job_failure_row, costing=Costing(_engine_x, plan.prior))  # fmt: skip
    finally:
        current_plan.reset(token)
    firsts = [(d.cold, d.first, d.new) for d in plan.finished]
    assert firsts == [(True, True, True), (True, False, True), (False, False, False)]


def test_a_compile_is_no_sample_of_a_kinds_cold_calls():
    """Issue 34, caches cold: MuJoCo Warp's stock call compiled Warp's kernels in its worker
    (32.8 s, 80 times what its prior says a call pays once); that kind's first call on the
    other worker, whose kernels were there, was expected at that factor (32 s) and took
    0.3 s: the default suite's ETA read 2.0 times the time left."""
    cold = priors({"mjwarp"})
    compiled = Took(MJW_STOCK, 32.8, cold=True, first=True, new=True)
    as_said = Took(MJW_TUNED, CALL_COST_PRIOR["mjwarp"].seconds(MJW_TUNED))  # machine: 1
    warm = {"mjwarp": 2, MJW_TUNED.kinds[0]: 2, MJW_STOCK.kinds[0]: 1}
    expected = remaining_seconds([MJW_STOCK], [], [], 2, CALL_COST_PRIOR, warm)
    assert expected is not None and expected < 1.0
    left = remaining_seconds([MJW_STOCK], [], [compiled, as_said], 2, cold, warm)
    assert left == pytest.approx(expected)


def _kinds(tasks):
    job = tasks[0]
    return CallCost(kinds=(job.kind,), steps=1)


SLEEP_PRIOR = {"sleep": Rates(3600.0, 0.0), "ok": Rates(0.0, 0.0)}


def test_the_progress_line_says_the_costed_eta(tmp_path):
    """Two 'sleep' calls left after the first 'ok' one, each a known hour: the line says
    2 hours, where the count of calls would say a few milliseconds."""
    jobs = [Job("ok-0"), Job("sleep-1", "sleep"), Job("sleep-2", "sleep")]
    log = io.StringIO()
    costing = Costing(cost=_kinds, prior=SLEEP_PRIOR)
    run_tasks(jobs, job_worker, tmp_path / "out", jobs=1, max_in_flight=1, quiet=False,
              stream=log, failure_row=job_failure_row, costing=costing)  # fmt: skip
    first = log.getvalue().splitlines()[0]
    assert first.startswith("[1/3] ok-0: ok"), first
    assert first.endswith("eta 2h00m"), first


def _broken(tasks):
    raise RuntimeError("a cost model's bug")


def test_a_broken_cost_model_leaves_the_sweep_and_the_count_eta(tmp_path):
    log = io.StringIO()
    summary = run_tasks([Job(f"ok-{k}") for k in range(3)], job_worker, tmp_path / "out",
                        jobs=1, quiet=False, stream=log, costing=Costing(_broken, {}))  # fmt: skip
    assert summary.completed and summary.total == 3
    assert log.getvalue().splitlines()[-1].endswith("eta 0s")


@dataclass
class ActiveSweep:
    """A sweep running under a plan: its runs done, its calls running and waiting."""

    done: int = 0
    running: tuple[Running, ...] = ()
    pending: tuple[CallCost, ...] = ()
    warm: frozenset = frozenset()
    """(worker, kind) of the calls its workers have run (eta.ran)."""

    def left(self):
        return list(self.running), list(self.pending), set(self.warm)


def _plan() -> Plan:
    sleep = CallCost(kinds=("sleep",), steps=1)
    later = PlannedSweep("finer", 2, (sleep, sleep))  # 2 hours on 1 worker
    first = PlannedSweep("default", 3, ())
    report = CallCost(kinds=(REPORT,), steps=0)
    return Plan("make report", [first, later], {**SLEEP_PRIOR, REPORT: Rates(600.0, 0.0)}, 1,
                after=(report,))  # fmt: skip


def test_the_overall_line_counts_every_sweeps_runs_and_time(tmp_path):
    """A plan of two sweeps and a report: the first sweep's lines end with the overall line,
    its runs of all five and an ETA of its own 2 hours left, the next sweep's 2 hours from
    its prior, and the report's 10 minutes; the next sweep's lines count on from 3."""
    plan = _plan()
    jobs = [Job("ok-0"), Job("sleep-1", "sleep"), Job("sleep-2", "sleep")]
    costing = Costing(cost=_kinds, prior=SLEEP_PRIOR)
    log = io.StringIO()
    token = current_plan.set(plan)
    try:
        run_tasks(jobs, job_worker, tmp_path / "a", jobs=1, max_in_flight=1, quiet=False,
                  stream=log, failure_row=job_failure_row, costing=costing)  # fmt: skip
        run_tasks([Job("ok-3"), Job("ok-4")], job_worker, tmp_path / "b", jobs=1, quiet=False,
                  stream=log, failure_row=job_failure_row, costing=costing)  # fmt: skip
    finally:
        current_plan.reset(token)
    lines = log.getvalue().splitlines()
    assert lines[0].endswith(
        "eta 2h00m; make report: step 1 of 2 (default), runs 1/5, eta 4h10m"
    ), lines[0]
    assert "; make report: step 2 of 2 (finer), runs 5/5, eta " in lines[-1], lines
    assert len(plan.finished) == 5  # both sweeps' calls: the second learns from the first


def test_a_progress_line_lays_out_the_calls_once(tmp_path, monkeypatch):
    """A line shows its sweep's ETA and the plan's: both come from one layout of the calls
    (Plan.etas), each about 8 ms on a slow machine; they were laid out once each."""
    plan, layouts = _plan(), []
    ends = Plan._ends
    monkeypatch.setattr(Plan, "_ends", lambda self: layouts.append(self) or ends(self))
    log = io.StringIO()
    token = current_plan.set(plan)
    try:
        run_tasks([Job("ok-0"), Job("ok-1"), Job("ok-2")], job_worker, tmp_path, jobs=1,
                  quiet=False, stream=log, failure_row=job_failure_row,
                  costing=Costing(cost=_kinds, prior=SLEEP_PRIOR))  # fmt: skip
    finally:
        current_plan.reset(token)
    lines = [line for line in log.getvalue().splitlines() if "; make report: " in line]
    assert len(lines) >= 2 and all(", eta " in line.split("; make report: ")[1] for line in lines)
    assert len(layouts) == len(lines), log.getvalue()


def test_a_later_sweep_is_expected_at_the_factor_the_finished_calls_measured():
    """The first suite's sleep calls took half their prior: the next suite's sleep calls,
    not started, are expected at half theirs (and the report at the machine's factor)."""
    plan = _plan()
    plan.attach(plan.begin(3), ActiveSweep(done=1))
    plan.finished.append(Took(CallCost(kinds=("sleep",), steps=1), 1800.0))
    assert plan.later_seconds() == pytest.approx(2 * 1800.0 + 300.0)
    assert plan.text(0) == "make report: step 1 of 2 (default), runs 1/5, eta 1h05m"


def test_the_fit_finds_the_fixed_and_per_step_parts():
    """Calls made by known rates (0.3 s + 20 us a step, 2 s more cold) give them back."""
    calls = [
        {"kinds": ["x"], "steps": s, "worlds": 1, "seconds": 0.3 + 2e-5 * s + 2.0 * c, "cold": c}
        for s, c in ((1000, True), (1000, False), (30000, False), (120000, False), (6000, True))
    ]
    rates = fit(calls)["x"]
    assert rates.fixed_s == pytest.approx(0.3)
    assert rates.step_s == pytest.approx(2e-5)
    assert rates.cold_s == pytest.approx(2.0)
    assert json.loads(json.dumps(calls[0]))["kinds"] == ["x"]


def test_the_fit_reads_the_world_steps_a_call_took_else_its_steps_times_its_worlds():
    """A MuJoCo map batch's seconds follow the world-steps its rows took (3 us each, 0.5 s
    a call), not its longest world's times its worlds; a calls file recorded before world
    steps were gives steps x worlds (the ETA's CallCost.paid_world_steps)."""
    taken = ((3000, 25000), (2000, 18000), (3000, 60000), (1000, 9000), (3000, 41000))
    calls = [
        {"kinds": ["x"], "steps": s, "worlds": 20, "seconds": 0.5 + 3e-6 * w,
         "cold": False, "world_steps": w}
        for s, w in taken
    ]  # fmt: skip
    rates = fit(calls)["x"]
    assert rates.fixed_s == pytest.approx(0.5)
    assert rates.step_s == pytest.approx(0.0, abs=1e-12)
    assert rates.world_step_s == pytest.approx(3e-6)
    old = [{k: v for k, v in c.items() if k != "world_steps"} for c in calls[:2]]
    old += [{**c, "world_steps": None} for c in calls[2:]]
    old[0]["steps"], old[1]["steps"], old[2]["worlds"] = 1000, 5000, 3
    said = [c["steps"] * c["worlds"] for c in old]
    rates = fit([{**c, "seconds": 0.5 + 3e-6 * w} for c, w in zip(old, said, strict=True)])["x"]
    assert rates.world_step_s == pytest.approx(3e-6)


def test_the_runner_records_the_world_steps_each_calls_rows_say(tmp_path):
    """Costing.taken reads a finished call's rows; report-runs --calls writes it."""
    plan = Plan("make report", [PlannedSweep("default", 3, ())], {"x": Rates(0.01, 0.0)}, 1)
    token = current_plan.set(plan)
    try:
        run_tasks([Job(f"ok-{k}") for k in (1, 2, 3)], job_worker, tmp_path / "out", jobs=1,
                  quiet=True, failure_row=job_failure_row,
                  costing=Costing(_engine_x, plan.prior, taken=_rows_n))  # fmt: skip
    finally:
        current_plan.reset(token)
    assert sorted(d.world_steps for d in plan.finished) == [100.0, 200.0, 300.0]
    from hoopbench.reports.cli import _write_calls

    _write_calls(plan.finished, tmp_path / "calls.jsonl")
    written = [json.loads(line) for line in (tmp_path / "calls.jsonl").read_text().splitlines()]
    assert sorted(r["world_steps"] for r in written) == [100.0, 200.0, 300.0]


def _rows_n(tasks, rows):
    """A Costing's taken: a hundred world-steps per unit of the rows' n (job_worker's)."""
    assert len(tasks) == len(rows)
    return 100.0 * sum(row["n"] for row in rows)


def test_the_fit_finds_what_a_workers_first_call_of_the_engine_pays():
    """MuJoCo Warp with warm caches: a worker's first call of the engine loads its kernels
    (about 2 s), a kind's first call on a worker that has them pays 0.1 s more."""
    calls = [
        {"kinds": [[k], "x"], "steps": s, "worlds": 1, "cold": c, "first": f,
         "seconds": 0.3 + 2e-5 * s + 0.1 * c + 2.0 * f}
        for k, s, c, f in (("a", 1000, True, True), ("b", 1000, True, False),
                           ("a", 3000, False, False), ("b", 6000, False, False),
                           ("b", 9000, True, True), ("a", 2000, True, False),
                           ("a", 500, False, False))
    ]  # fmt: skip
    rates = fit(calls)["x"]
    assert rates.first_s == pytest.approx(2.0)
    assert rates.cold_s == pytest.approx(0.1)
    assert rates.fixed_s == pytest.approx(0.3)


def test_the_compile_is_what_the_cold_runs_calls_took_more_than_the_warm_ones():
    """MuJoCo Warp's first call in each worker compiled (18.5 and 32.8 s, warm 2.4 and
    2.8): their group says 46 s more over 2 calls, 2 of them their worker's first of the
    engine; pymunk's call, 0.1 s more, is left out."""

    def call(kind, engine, seconds, first=False, new=False):
        return {
            "kinds": [[kind, "tuned", "default"], engine],
            "steps": 3000,
            "worlds": 2,
            "seconds": seconds,
            "cold": first or new,
            "first": first,
            "new": new,
        }

    warm = [
        call("mjwarp", "mjwarp", 2.4),
        call("mjwarp", "mjwarp", 2.8),
        call("pymunk", "pymunk", 0.8),
    ]
    cold = [call("mjwarp", "mjwarp", 18.5, True, True), call("mjwarp", "mjwarp", 32.8, True),
            call("pymunk", "pymunk", 0.9)]  # fmt: skip
    [(key, n, before, took, first, new)] = compile_costs(cold, warm)
    assert key == ((("mjwarp", "tuned", "default"), "mjwarp"), 3000.0, 2)
    assert (n, first, new) == (2, 2, 1)
    assert took - before == pytest.approx(46.1)


def test_the_accuracy_is_read_from_a_stamped_log():
    """Lines at 10 % and 50 % of a suite: ETA over the real time left until its last line;
    the overall one's until the log's last (the report step after the runs)."""
    lines = [
        (0.0, "make report: suite 1 of 1 (default) -> out/default"),
        (
            10.0,
            "[1/10] a: ok; no failures; elapsed 10s, eta 1m30s; make report: step 1 of 1 "
            "(default), runs 1/10, eta 3m00s",
        ),
        (50.0, "[5/10] b: ok; no failures; elapsed 50s, eta 25s"),
        (100.0, "[10/10] c: ok; no failures; elapsed 1m40s, eta 0s"),
        (130.0, "make report: the report of the 3 suites -> out"),  # the report's 30 s
    ]
    table = accuracy(lines)
    # 'eta 25s' stands for 24.5-25.5 s: the nearest to the 50 s left is 25.5.
    assert table["default"][:3] == [pytest.approx(1.0), pytest.approx(25.5 / 50),
                                    pytest.approx(25.5 / 50)]  # fmt: skip
    assert table["overall"][0] == pytest.approx(179.5 / 120)
    assert seconds_of("1h02m") == 3720.0


def test_report_runs_runs_make_reports_steps_in_order_under_one_plan(tmp_path, monkeypatch):
    """Each step as its own command (compare, map), in make report's order and options,
    each with the plan set; a step that fails stops the rest with its exit code. The plan
    is worked out from the real suites (about 1 s)."""
    import argparse

    from hoopbench.reports import cli

    seen: list[tuple[list[str], int]] = []

    def fake_main(argv):
        plan = current_plan.get()
        seen.append((argv, plan.total if plan is not None else -1))
        return 3 if argv[0] == "map" else 0

    monkeypatch.setattr(cli, "main", fake_main)
    args = argparse.Namespace(
        out=str(tmp_path), map="--grid 2x2 --engines pymunk", calls=None, report=None
    )
    assert cli._cmd_report_runs(args) == 3
    argvs = [argv for argv, _ in seen]
    assert argvs == [
        ["compare", "--suite", "default", "--out", str(tmp_path / "default"),
         "--trajectories", "default"],
        ["compare", "--suite", "finer", "--out", str(tmp_path / "finer")],
        ["compare", "--suite", "stability", "--out", str(tmp_path / "stability")],
        ["map", "--grid", "2x2", "--engines", "pymunk", "--out", str(tmp_path / "map")],
    ]  # fmt: skip
    totals = {total for _, total in seen}
    assert len(totals) == 1 and totals.pop() > 8  # one plan, the map's 4 + 4 runs in it
    assert current_plan.get() is None


def test_the_fit_is_not_pulled_to_nothing_by_calls_that_return_at_once():
    """A map's points: half return in 2 ms, half take 0.2 s (the ETA's sums need about 0.1
    s a call). Weighed relative to each call alone, the fit said 2-4 ms (the map's first
    stage then showed 'eta 0s' with 9 s left)."""
    calls = [
        {"kinds": [["map", "reference"]], "steps": 0, "worlds": 1, "seconds": t, "cold": False}
        for t in (0.002, 0.2) * 5
    ]
    assert fit(calls)[("map", "reference")].fixed_s > 0.03


def test_cold_calls_scale_what_a_call_pays_once_not_its_steps(raw_factors):
    """Issue 34, caches cold: the default suite's MJX call of 3,000 steps compiled for 20 s
    beyond its prior (4 s fixed + 3 s of steps took 27 s); the finer suite's call of
    30,000 steps is mostly stepping. Its factor (27 / 7) on the finer call said 3.9 times
    its 34 s; from what a call pays once it is 4 x 6 + 30 = 54 s cold, 34 s on a worker
    that has compiled it, and only a warm call of the kind is a sample of its stepping."""
    prior = {"mjx": Rates(4.0, 1e-3), "pymunk": Rates(0.2, 1e-5)}
    short = CallCost(kinds=(("mjx", "tuned", "default"), "mjx"), steps=3000)
    finer = CallCost(kinds=short.kinds, steps=30_000)
    cheap = [Took(CHEAP, 0.21), Took(CHEAP, 0.21)]  # warm, as the prior says: machine 1
    finished = [*cheap, Took(short, 27.0, cold=True)]
    assert machine_factor(finished, prior) == pytest.approx(1.0)
    # On a worker that has not run the kind (its own compile to pay), then on one that has.
    assert remaining_seconds([finer], [], finished, 1, prior) == pytest.approx(54.0)
    warm = {short.kinds[0]: 1}
    assert remaining_seconds([finer], [], finished, 1, prior, warm) == pytest.approx(34.0)
    # Another variant's first call: its own compile is not foreseen from this one's (Newton
    # compiled Warp's kernels once a worker, whichever variant came first).
    other = CallCost(kinds=(("mjx", "tuned", "precision=float64"), "mjx"), steps=3000)
    assert remaining_seconds([other], [], finished, 1, prior) == pytest.approx(7.0)
    finished.append(Took(short, 2 * 7.0))  # a warm call: twice its prior, all of it
    assert remaining_seconds([finer], [], finished, 1, prior, warm) == pytest.approx(68.0)


def test_the_machine_factor_is_the_median_engines_not_the_one_whose_prior_is_off():
    """The default suite's Drake calls took 1.8 times their prior, the others' as theirs:
    the machine is as fast as the priors (a sum over calls said 1.3 on the idle machine the
    priors were fitted on), and a cold call is no sample of it while warm ones are."""
    prior = {"drake": Rates(1.0, 0.0), "pymunk": Rates(1.0, 0.0), "box2d": Rates(1.0, 0.0)}
    calls = {e: CallCost(kinds=((e, "tuned", "default"), e), steps=1) for e in prior}
    finished = [Took(calls["drake"], 1.8)] * 10 + [Took(calls["pymunk"], 1.0)] * 2
    finished += [Took(calls["box2d"], 1.0), Took(calls["box2d"], 9.0, cold=True)]
    assert machine_factor(finished, prior) == pytest.approx(1.0)
    assert machine_factor([Took(calls["box2d"], 9.0, cold=True)], prior) == pytest.approx(9.0)


def test_an_eta_is_read_within_its_rounding():
    """The map's 2-s classification: 'eta 1s' with 0.48 s left is within its second (1.04),
    not 2.08 times the time left; '2h00m' stands for 2h00m-2h01m."""
    lines = [
        (0.0, "make report: the hop map (--grid 2x2) -> out/map"),
        (1.0, "[1/4] a reference: ok; no failures; elapsed 1s, eta 1s"),
        (1.48, "[4/4] b reference: ok; no failures; elapsed 1s, eta 0s"),
    ]
    assert accuracy(lines)["map (reference)"][0] == pytest.approx(0.5 / 0.48)
    assert rounding("2h00m") == (7200.0, 7260.0)


def test_overlapping_steps_lines_count_for_the_step_they_name_first():
    """With the finer suite begun, the default suite's last lines still count for it."""
    overall = "make report: step {} of 2 ({}), runs {}/4, eta {}"
    lines = [
        (0.0, "make report: suite 1 of 2 (default) -> out/default"),
        (1.0, "[1/2] a: ok; no failures; elapsed 1s, eta 9s; "
              + overall.format(1, "default", 1, "9s")),
        (2.0, "make report: suite 2 of 2 (finer) -> out/finer"),
        (3.0, "[1/2] b: ok; no failures; elapsed 1s, eta 4s; "
              + overall.format(2, "finer, with default", 2, "7s")),
        (10.0, "[2/2] c: ok; no failures; elapsed 9s, eta 0s; "
               + overall.format(1, "default, with finer", 3, "0s")),
        (7.0, "[2/2] d: ok; no failures; elapsed 5s, eta 0s; "
              + overall.format(2, "finer", 4, "0s")),
    ]  # fmt: skip
    table = accuracy(lines)
    assert table["default"][0] == pytest.approx(1.0)  # 9 s said at 1 s, its last line at 10 s
    assert table["finer"][0] == pytest.approx(1.0)  # 4 s said at 3 s, its last line at 7 s


def test_report_runs_then_writes_the_report_with_its_drawing_processes_started(
    tmp_path, monkeypatch
):
    """--report: once every step has succeeded, the report of the suites, the map and the
    given folders, as make report's second command wrote it, with the drawing processes
    started once the last step had nothing queued (here no process starts: start is only
    counted); a failed step leaves the report out, and nothing stays set."""
    import argparse

    from hoopbench.reports import cli
    from hoopbench.reports.report.drawing_processes import StartedDrawing, started_drawing

    starts: list[StartedDrawing] = []
    monkeypatch.setattr(StartedDrawing, "start", lambda self: starts.append(self))
    seen: list[tuple[list[str], StartedDrawing | None]] = []
    failing = {"map": 0}

    def fake_main(argv):
        seen.append((argv, started_drawing.get()))
        return failing.get(argv[0], 0)

    monkeypatch.setattr(cli, "main", fake_main)
    out = tmp_path / "r"
    given = [tmp_path / "searches" / "a", tmp_path / "bench"]
    for folder in given:  # folders that hold results (checked before the steps)
        (folder / "runs").mkdir(parents=True)
    args = argparse.Namespace(out=str(out), map="--grid 2x2 --engines pymunk", calls=None,
                              report=[str(folder) for folder in given])  # fmt: skip
    assert cli._cmd_report_runs(args) == 0
    assert seen[-1][0] == ["report", "--results", *(str(out / n) for n in
                           ("default", "finer", "stability", "map")),
                           *map(str, given), "--out", str(out)]  # fmt: skip
    started = seen[-1][1]
    assert starts == [started] and started is not None
    assert all(step_started is started for _, step_started in seen)  # the map's figures too
    assert started_drawing.get() is None
    seen.clear()
    failing["map"] = 3
    assert cli._cmd_report_runs(args) == 3
    assert [argv[0] for argv, _ in seen] == ["compare", "compare", "compare", "map"]


def test_report_runs_refuses_a_report_folder_without_results_before_any_step(
    tmp_path, monkeypatch, capsys
):
    """make report's searches are checked as `hoopbench report` checks them, before the
    sweeps: a folder that holds no results is one line and exit 2, not an error minutes
    later, and nothing is written."""
    from hoopbench.reports import cli

    ran: list[str] = []
    monkeypatch.setattr(cli, "_run_steps", lambda *a, **k: ran.append("steps") or 0)
    out, missing = tmp_path / "r", tmp_path / "no-such-search"
    argv = ["report-runs", "--out", str(out), "--map=", "--report", str(missing)]
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"hoopbench: error: --report {str(missing)!r} holds no results (no runs/ "
                   "folder): run hoopbench compare first"]  # fmt: skip
    assert ran == [] and not out.exists()


def test_the_replay_gives_a_workers_first_call_of_the_engine_the_longest_recorded():
    """eta_replay: of two recorded calls of one kind, steps and worlds (32.8 s, where a cold
    cache compiled, and 0.3 s), a worker's first call of the engine takes the compile."""
    record = {"kinds": [["mjwarp", "stock", "default"], "mjwarp"], "steps": 3000, "worlds": 2}
    recorded = _Recorded([{**record, "seconds": 0.3}, {**record, "seconds": 32.8}])
    assert recorded.take(MJW_STOCK, first=True) == 32.8
    assert recorded.take(MJW_STOCK, first=False) == 0.3


@pytest.mark.parametrize(
    ("text", "said"),
    [
        (None, "is not a readable calls file"),
        ("not json\n", "is not a readable calls file"),
        ("[1, 2]\n", "holds a line that is no call record: [1, 2]"),
        (  # a field the replay reads that is no number
            '{"kinds": [["mujoco", "stock", "default"], "mujoco"], "steps": 7, "worlds": "many", '
            '"seconds": 0.1}\n',
            "holds a line that is no call record",
        ),
        (  # when it started (--keys-as-recorded orders the workers by it)
            '{"kinds": [["mujoco", "stock", "default"], "mujoco"], "steps": 7, "worlds": 1, '
            '"seconds": 0.1, "started": "soon"}\n',
            "holds a line that is no call record",
        ),
        (  # a record of no call make report makes: an older file, or other suites
            '{"kinds": [["mujoco", "stock", "default"], "mujoco"], "steps": 7, "worlds": 1, '
            '"seconds": 0.1}\n',
            "no recorded call of CallCost",
        ),
    ],
)
def test_the_replay_refuses_a_calls_file_it_cannot_replay_in_one_line(tmp_path, capsys, text, said):
    """eta_replay FILE: a file it cannot read, or that lacks a call make report makes (a
    calls file from before the map's runs were costed by their stop, without
    --map-by-window), is exit 2 and one line naming the file, not a traceback."""
    calls = tmp_path / "calls.jsonl"
    if text is not None:
        calls.write_text(text)
    assert replay_main([str(calls), "--map-by-window"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1, err
    assert err.startswith(f"eta_replay: calls {str(calls)!r}") and said in err, err


def test_the_replays_shuffle_reorders_the_maps_engine_runs_alone():
    """eta_replay --shuffle-map: the map's engine runs alone take their recorded seconds in a
    seeded random order (the grid's first points, rolling starts, cost several times the
    later ones, which lift off and stop at their first impact); the map's batches, its
    classification and the suites' calls keep the recorded order."""

    def records(kinds: list[object], worlds: int) -> list[dict[str, object]]:
        return [
            {"kinds": kinds, "steps": 30000, "worlds": worlds, "seconds": float(k)}
            for k in range(20)
        ]

    run = [["map", "pybullet", "tuned", 1e-4], ["map", "pybullet"]]
    batch = [["map", "mujoco", "tuned", 1e-4], ["map", "mujoco"]]
    point = [["map", "reference", "None", None], ["map", "reference"]]
    suite = [["pybullet", "tuned", "default"], "pybullet"]
    recorded = _Recorded(
        records(run, 1) + records(batch, 25) + records(point, 1) + records(suite, 1),
        random.Random(1),
    )
    in_order = [float(k) for k in range(20)]
    runs, *others = recorded.left.values()
    assert sorted(runs) == in_order and runs != in_order
    assert others == [in_order] * 3
    assert list(_Recorded(records(run, 1)).left.values()) == [in_order]


def test_the_replay_hands_a_batched_engines_calls_to_the_worker_that_ran_it():
    """eta_replay takes calls as the pool does: worker 2 passes over MJX's calls that worker
    1 has begun and takes the call of no affinity behind them, unless nothing else is left."""
    mjx = replace(MJX_TUNED, affinity="mjx")
    sweep = _ReplaySweep(deque([mjx, mjx, MJW_TUNED]))
    taken = ran(mjx, 1)
    assert _next_call([sweep], 2, taken, False, 4) == (0, 2)
    assert _next_call([sweep], 1, taken, False, 4) == (0, 0)
    alone = _ReplaySweep(deque([mjx]))
    assert _next_call([alone], 2, taken, False, 4) is None
    assert _next_call([alone], 2, taken, True, 4) == (0, 0)


def test_a_batched_engines_calls_keep_to_the_worker_that_holds_its_key_between_its_calls():
    """The pool keeps a batched engine's calls on the worker that has run one, whether or
    not it runs one now (WorkerPool._own_call: the worker's keys). A cold make report's map
    classification (100 points, 6 s on one worker) began while worker 1, which had run
    MJX's calls, ran MuJoCo's 5.9-s stability call with one of MJX's 5.6-s calls queued
    behind it: the layout that knew only the running calls' engines handed MJX's call to
    worker 2, the classification's, and said 13 s of a 6-s stage (2.6-14 times the time
    left). Here: MuJoCo's call 2 s from its end on worker 1, a point just begun on worker
    2, then MJX's call and 30 points: they end on worker 2 in 3.1 s, MJX's on worker 1 in
    7 s (the layout that gave MJX's call to worker 2: the points in 5 s)."""
    mujoco = CallCost(kinds=(("mujoco", "tuned", "default"), "mujoco"), steps=0, affinity="mujoco")
    mjx = CallCost(kinds=(("mjx", "tuned", "default"), "mjx"), steps=0, affinity="mjx")
    point = CallCost(kinds=(("map", "reference"),), steps=0)
    prior = {
        "mujoco": Rates(5.0, 0.0),
        "mjx": Rates(5.0, 0.0),
        ("map", "reference"): Rates(0.1, 0.0),
    }
    warm = ran(mjx, 1) | ran(mujoco, 1) | ran(point, 2)
    assert eta.key_holders(warm) == {"mjx": {1}, "mujoco": {1}}
    sweeps = [PlannedSweep("stability", 2, (mujoco, mjx)), PlannedSweep("map", 31, (point,) * 31)]
    plan = Plan("make report", sweeps, prior, 2)
    running = (Running(mujoco, ran=3.0, worker=1),)
    plan.attach(plan.begin(2), ActiveSweep(running=running, pending=(mjx,), warm=warm))
    running = (Running(point, ran=0.0, worker=2),)
    plan.attach(plan.begin(31), ActiveSweep(running=running, pending=(point,) * 30))
    assert plan.sweep_left(1) == pytest.approx(3.1)
    assert plan.sweep_left(0) == pytest.approx(2.0 + 5.0)
    # The runner's layout of its own calls: the same rule (the workers' keys, eta.ran).
    holders = eta.key_holders(warm)
    running = (Running(mujoco, ran=3.0, worker=1), Running(point, ran=0.0, worker=2))
    left = remaining_seconds([mjx, *[point] * 30], running, [], 2, prior, None, holders)
    assert left == pytest.approx(7.0)


def test_a_steps_eta_counts_the_later_steps_calls_that_keep_the_other_worker_busy():
    """A cold make report (2026-11-29 23:48 UTC): one worker held MuJoCo's and MJX's keys
    and ran the stability suite's last calls of both one after the other (344-390 s) while
    the other ran the map's, a step not begun when the stability suite's ETA was made: the
    layout of the running steps alone had the other worker take the batched calls ("it
    would not idle") and said 34 s of 53 (0.66). Laid out with the later steps' calls, the
    other worker takes those, its own. Here: MuJoCo's call 2 s from its end on worker 1,
    two more of 5 s pending, a cheap call ending on worker 2; then the map's 100 points."""
    mujoco = CallCost(kinds=(("mujoco", "tuned", "default"), "mujoco"), steps=0, affinity="mujoco")
    point = CallCost(kinds=(("map", "reference"),), steps=0)
    prior = {"mujoco": Rates(5.0, 0.0), ("map", "reference"): Rates(0.1, 0.0)}
    warm = ran(mujoco, 1) | ran(point, 2)
    sweeps = [
        PlannedSweep("stability", 4, (mujoco, mujoco, mujoco, point)),
        PlannedSweep("map", 100, (point,) * 100),
    ]
    plan = Plan("make report", sweeps, prior, 2)
    running = (Running(mujoco, ran=3.0, worker=1), Running(point, ran=0.0, worker=2))
    plan.attach(plan.begin(4), ActiveSweep(running=running, pending=(mujoco, mujoco), warm=warm))
    assert plan.sweep_left(0) == pytest.approx(2.0 + 5.0 + 5.0)  # not 7.0: stolen at 0.1 s


def test_the_maps_mujoco_batches_queue_on_the_worker_that_holds_mujocos_key():
    """The pool keys a batch by its engine (compare.suite.batch_affinity): the map's MuJoCo
    batches, costed as their own kind ('map', 'mujoco'), hold MuJoCo's key with the suites'.
    The layout took that kind for the key: it handed a map batch to a worker that did not
    hold MuJoCo's key while the one that did was busy (live, 3 of a make report's 4 map
    batches ran on the holder). Here: worker 1 holds the key and has 1 s left, worker 2 is
    free; a 5-s map batch, then a 3-s single run."""
    suite = CallCost(kinds=(("mujoco", "tuned", "default"), "mujoco"), steps=0, affinity="mujoco")
    batch = CallCost(kinds=(("map", "mujoco", "tuned", 1e-4), ("map", "mujoco")), steps=0,
                     worlds=25, affinity="mujoco")  # fmt: skip
    single = CallCost(kinds=(("pybullet", "tuned", "default"), "pybullet"), steps=0)
    prior = {"mujoco": Rates(3.0, 0.0), ("map", "mujoco"): Rates(5.0, 0.0),
             "pybullet": Rates(3.0, 0.0)}  # fmt: skip
    warm = ran(suite, 1)
    running = [Running(suite, ran=2.0, worker=1)]
    ends = call_ends([batch, single], running, [], 2, prior, warm_counts(warm), key_holders(warm))
    assert ends == ([1.0], [6.0, 3.0])  # not [5.0, 4.0]: the batch on the free worker


def test_every_mujoco_call_of_make_report_holds_one_key():
    """The plan's calls carry the runner's affinity key (report_runs, the runner's _cost),
    not their most general kind: the suites' and the map's MuJoCo batches one key."""
    plan = report_plan(["stability"], MapSpec(nx=3, ny=3, engines=("mujoco",)), 2, 8)
    keys = {(call.kinds[-1], call.affinity) for sweep in plan.sweeps for call in sweep.calls
            if call.worlds > 1}  # fmt: skip
    assert ("mujoco", "mujoco") in keys and (("map", "mujoco"), "mujoco") in keys
    assert {key for kind, key in keys if "mujoco" in str(kind)} == {"mujoco"}


def test_the_replay_can_put_each_batched_engines_key_where_the_recorded_run_held_it():
    """eta_replay --keys-as-recorded: the worker that ran an engine's first batch in the
    recorded run holds its key from the start (workers numbered as their first calls
    started), so that a free worker does not take that engine's calls as its own. The
    replay of that cold make report with the keys apart read its stability suite 1.03 at
    75 %, where its log read 0.66; with the keys as recorded, 0.65."""
    records = [
        {"kinds": [["pymunk", "tuned", "default"], "pymunk"], "worlds": 1, "worker": 900,
         "started": 0.0},
        {"kinds": [["mjx", "tuned", "default"], "mjx"], "worlds": 8, "worker": 100,
         "started": 1.0},
        {"kinds": [["mujoco", "tuned", "default"], "mujoco"], "worlds": 2, "worker": 100,
         "started": 2.0},
        {"kinds": [["map", "mujoco", "tuned", 1e-4], ["map", "mujoco"]], "worlds": 25,
         "worker": 900, "started": 3.0},
        {"kinds": [["mujoco", "tuned", "default"], "mujoco"], "worlds": 3, "worker": 900,
         "started": 4.0},
    ]  # fmt: skip
    keys = recorded_keys(records, workers=2)
    assert keys == {"mjx": {1}, "mujoco": {1}, ("map", "mujoco"): {0}}
    # The map's batches hold MuJoCo's key, as the pool keys them: the first batch of either.
    keys = recorded_keys(records, workers=2, affinities={("map", "mujoco"): "mujoco"})
    assert keys == {"mjx": {1}, "mujoco": {1}}
    mujoco = CallCost(kinds=(("mujoco", "tuned", "default"), "mujoco"), steps=0, affinity="mujoco")
    sweep = _ReplaySweep(deque([mujoco, CHEAP]))
    assert _next_call([sweep], 0, set(), False, 4, keys) == (0, 1)  # not its key: the cheap one
    assert _next_call([sweep], 1, set(), False, 4, keys) == (0, 0)
    assert _next_call([sweep], 0, set(), False, 4) == (0, 0)  # no key held: anyone's


def test_the_replay_begins_a_sweep_once_the_runner_has_submitted_the_one_before():
    """A sweep's calls with an affinity key go to the pool past the runner's limit of calls
    in flight (runner._Calls._submit), so the next sweep begins, and queues behind them,
    while they wait: a cold make report's map began with MuJoCo's and MJX's stability calls
    still queued. The replay that began it once the sweep before had 4 calls left to start
    ran those first and read the map's classification ETA 1.07-1.12 where the real one was
    2.6-14 times off."""
    mjx = replace(MJX_TUNED, affinity="mjx")
    sweep = _ReplaySweep(deque([mjx, *[CHEAP] * 4, mjx, mjx, CHEAP]))
    assert sweep.submitted(4) == 7 and not sweep.drained(4)
    stability = _ReplaySweep(deque([*[mjx] * 6, CHEAP, CHEAP]))
    plan = Plan("make report", [PlannedSweep("stability", 8, tuple(stability.queue)),
                                PlannedSweep("map", 1, (CHEAP,))], PRIOR, 2)  # fmt: skip
    assert _begin(plan, [stability, _ReplaySweep(deque([CHEAP]))], -1, workers=2) == 1
    # What the runner has not submitted, the pool cannot hand out: worker 2 finds none of
    # its own calls while the runner's one call of no key in flight (the limit) runs.
    flight = _InFlight(CHEAP, 0.0, (False, False, False), 1.0)
    sweep = _ReplaySweep(deque([mjx, CHEAP]), running={1: flight})
    assert sweep.submitted(1) == 1
    assert _next_call([sweep], 2, ran(mjx, 1), False, 1) is None


def test_an_engine_whose_cold_calls_ran_faster_than_the_machine_is_its_own(raw_factors):
    """Issue 34, caches warm, Intel Xeon: MJX's compiled stepping ran 1.56 times its EPYC
    prior where the median engine ran 1.9-2.0, and its four cold calls of the default suite
    (their cold part in their priors) 1.55. The finer suite's 30,000-step call, MJX's first
    warm one, was expected at the machine's factor: its step's ETA read 1.2 times the time
    left throughout. A cold call that ran longer says nothing of its engine's stepping (a
    compile its prior took as done), one that ran shorter says it runs faster here."""
    prior = {"mjx": Rates(1.0, 1e-3, cold_s=2.0), "pymunk": Rates(0.2, 1e-5)}
    short = CallCost(kinds=(("mjx", "tuned", "default"), "mjx"), steps=3000)
    finer = CallCost(kinds=short.kinds, steps=30_000)
    cheap = [Took(CHEAP, 2 * 0.21), Took(CHEAP, 2 * 0.21)]  # warm, the machine's factor: 2
    said = prior["mjx"].seconds(short, cold=True)  # 6 s
    warm = {short.kinds[0]: 1}
    faster = [*cheap, Took(short, 1.5 * said, cold=True)]
    assert remaining_seconds([finer], [], faster, 1, prior, warm) == pytest.approx(31.0 * 1.5)
    # Its next cold call, a kind of its own to compile, stays at the machine's factor.
    other = CallCost(kinds=(("mjx", "tuned", "precision=float64"), "mjx"), steps=3000)
    assert remaining_seconds([other], [], faster, 1, prior) == pytest.approx(2 * said)
    slower = [*cheap, Took(short, 3.0 * said, cold=True)]
    assert remaining_seconds([finer], [], slower, 1, prior, warm) == pytest.approx(31.0 * 2)


COLD_CALLS = Path(__file__).parent / "data" / "make-report-calls-xeon-cold.jsonl.gz"
"""The calls of a cold make report on 2 idle cores of an Intel Xeon at 2.1 GHz (2026-11-30,
``hoopbench report-runs --calls``; 3:41, MuJoCo Warp left out for want of a GPU)."""


def test_a_cold_make_reports_replayed_etas_are_within_one_and_a_half_of_the_time_left():
    """Its default suite's and the overall ETA (about 10 s): with MJX's compile priors
    measured on the EPYC while MJX's finer call still ran (6.9, 21.9, 20.6 and 11.6 s more
    at the machine's factor, 1.9) the default suite's ETA at a tenth of its runs was 1.56
    times the time left."""
    with gzip.open(COLD_CALLS, "rt") as lines:
        records = [json.loads(line) for line in lines]
    ratios = replay(records, ["mjx", "newton"], workers=2, report_s=20.0)
    for step in ("default", "overall"):
        for ratio in ratios[step]:
            assert ratio is not None and 1 / 1.5 <= ratio <= 1.5, (step, ratios[step])
