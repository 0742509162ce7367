"""The progress lines' ETA from the calls' expected costs (reports/sweep/eta.py), on
synthetic finished calls: no clock is asserted, only the arithmetic of the estimate."""

from __future__ import annotations

import io
from dataclasses import dataclass

import pytest
from test_runner import Job, job_failure_row, job_worker

from hoopbench.reports.compare.costs import STEP_COST_PRIOR, call_cost
from hoopbench.reports.sweep.eta import (
    CallCost,
    Costing,
    Took,
    machine_factor,
    remaining_seconds,
    seconds_per_step,
)
from hoopbench.reports.sweep.runner import run_tasks

CHEAP = CallCost(kinds=(("pymunk", "tuned", "default"), "pymunk"), steps=1000)
DEAR = CallCost(kinds=(("mjx", "tuned", "default"), "mjx"), steps=1000)


def test_each_kind_costs_its_own_seconds_per_step():
    finished = [Took(CHEAP, 0.1), Took(CHEAP, 0.3), Took(DEAR, 60.0)]
    measured = seconds_per_step(finished)
    assert measured["pymunk"] == pytest.approx(0.4 / 2000)
    assert measured["mjx"] == pytest.approx(60.0 / 1000)
    assert measured[("mjx", "tuned", "default")] == pytest.approx(60.0 / 1000)


def test_the_cheap_runs_finishing_first_do_not_make_the_eta_short():
    """Issue 34: 'eta 3m' took 27 min. 98 cheap runs done in 10 s, 2 dear ones left: by the
    count the sweep is 98 % done; by cost it has 2 minutes left on one worker."""
    finished = [Took(CHEAP, 0.1)] * 98 + [Took(DEAR, 60.0)]
    left = remaining_seconds([DEAR, DEAR], [], finished, workers=1, prior={})
    assert left == pytest.approx(120.0)
    by_count = (98 * 0.1 + 60.0) / 99 * 2
    assert by_count < left / 1.5  # what the old line said: far too short


def test_the_calls_left_are_laid_out_on_the_workers_in_order():
    finished = [Took(CHEAP, 1.0)]  # 1 ms a step: each call 1 s
    long = CallCost(kinds=CHEAP.kinds, steps=30_000)  # 30 s
    assert remaining_seconds([CHEAP] * 4, [], finished, 2, {}) == pytest.approx(2.0)
    # One long call cannot be split: the sweep lasts at least as long as it.
    assert remaining_seconds([long, CHEAP, CHEAP], [], finished, 2, {}) == pytest.approx(30.0)
    # A call in flight keeps its worker for what it has left.
    running = [(long, 20.0)]
    assert remaining_seconds([CHEAP], running, finished, 2, {}) == pytest.approx(10.0)
    # Past its expected cost, a tenth of what it has run is left of it.
    assert remaining_seconds([], [(CHEAP, 5.0)], finished, 2, {}) == pytest.approx(0.5)


def test_the_most_specific_kind_known_wins_then_priors_then_the_mean():
    solver = CallCost(kinds=(("newton", "tuned", "solver=mujoco"), "newton"), steps=100)
    plain = CallCost(kinds=(("newton", "tuned", "default"), "newton"), steps=100)
    finished = [Took(plain, 1.0)]  # newton: 10 ms a step, measured on its default variant
    prior = {("newton", "tuned", "solver=mujoco"): 0.5}
    # The variant's own prior beats the engine's measure of another variant...
    assert remaining_seconds([solver], [], finished, 1, prior) == pytest.approx(50.0)
    # ... until the variant itself has a finished call.
    finished.append(Took(solver, 3.0))
    assert remaining_seconds([solver], [], finished, 1, prior) == pytest.approx(3.0)
    # An engine never seen: its prior, else every finished call's mean cost per step.
    other = CallCost(kinds=(("dart", "tuned", "default"), "dart"), steps=100)
    assert remaining_seconds([other], [], finished, 1, {"dart": 0.2}) == pytest.approx(20.0)
    assert remaining_seconds([other], [], finished, 1, {}) == pytest.approx(100 * 4.0 / 200)
    # Nothing finished and nothing known: no estimate (the line falls back on the count).
    assert remaining_seconds([other], [], [], 1, {}) is None


def test_the_priors_scale_with_how_slow_the_machine_runs_now():
    """A loaded machine ran the cheap calls 3 times slower than their prior: the dear kind
    not measured yet is expected 3 times slower than its prior too."""
    prior = {"pymunk": 1e-4, "mjx": 1e-2}
    finished = [Took(CHEAP, 0.3), Took(CHEAP, 0.3)]
    assert machine_factor(finished, prior) == pytest.approx(3.0)
    assert remaining_seconds([DEAR], [], finished, 1, prior) == pytest.approx(30.0)
    assert machine_factor([], prior) == 1.0


def test_a_cold_call_counts_only_while_no_warm_one_is_known():
    """MJX's first call on a worker traces and compiles (71 s), its later ones 8 s."""
    mjx_float64 = CallCost(kinds=(("mjx", "tuned", "precision=float64"), "mjx"), steps=1000)
    finished = [Took(DEAR, 71.0, cold=True)]
    assert remaining_seconds([DEAR], [], finished, 1, {}) == pytest.approx(71.0)
    finished.append(Took(mjx_float64, 8.0))  # warm, of another variant of the engine
    assert remaining_seconds([DEAR], [], finished, 1, {}) == pytest.approx(8.0)


@dataclass(frozen=True)
class SuiteLike:
    engine: str
    n_steps: int
    profile: str = "tuned"
    variant: str = "default"


def test_a_batch_counts_once_at_its_longest_world():
    call = call_cost([SuiteLike("mjx", 3000), SuiteLike("mjx", 1000)])
    assert call.steps == 3000
    assert call.kinds == (("mjx", "tuned", "default"), "mjx")


def test_every_engine_has_a_prior():
    from hoopbench.engines.registry import engine_names

    assert set(engine_names()) <= set(STEP_COST_PRIOR)
    assert all(rate > 0 for rate in STEP_COST_PRIOR.values())


def _kinds(tasks):
    job = tasks[0]
    return CallCost(kinds=(job.kind,), steps=1)


def test_the_progress_line_says_the_costed_eta(tmp_path):
    """Two 'sleep' calls left after the first 'ok' one, each a known hour: the line says
    2 hours, where the count of calls would say a few milliseconds."""
    jobs = [Job("ok-0"), Job("sleep-1", "sleep"), Job("sleep-2", "sleep")]
    log = io.StringIO()
    costing = Costing(cost=_kinds, prior={"sleep": 3600.0, "ok": 0.0})
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
