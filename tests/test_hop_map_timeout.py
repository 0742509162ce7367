"""A hop map cell the sweep's time limit ended is the machine's failure, not the engine's
(issue 34), as in a suite: no verdict, its reason saying so, left out of the judged points."""

from __future__ import annotations

import pandas as pd

from hoopbench.engines.run import RunStatus
from hoopbench.reports.compare.suite import TIMEOUT_NOTE
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import (
    _engine_task,
    _reference_row,
    _stored_exact,
    map_failure_row,
    reference_tasks,
)
from hoopbench.reports.hop_map.table import agreement_table

SPEC = MapSpec(nx=1, ny=1, engines=("pymunk",), timestep=1e-3, t_end=1.0)


def test_a_timed_out_cell_is_not_judged_and_a_crashed_one_fails():
    """Cheap: one exact classification, no engine run (about 1 s)."""
    reference = reference_tasks(SPEC)[0]
    exact = _stored_exact(_reference_row(reference))
    task = _engine_task(SPEC, reference.point, "pymunk", exact, None)
    timed_out = map_failure_row(task, RunStatus.TIMEOUT, "timed out after 61 s")
    crashed = map_failure_row(task, RunStatus.CRASHED, "worker died")
    assert timed_out["verdict"] is None and timed_out["outcome_agrees"] is None
    assert timed_out["verdict_reason"] == TIMEOUT_NOTE
    assert "machine's failure" in TIMEOUT_NOTE
    assert crashed["verdict"] == "failed" and crashed["outcome_agrees"] is False
    table = agreement_table(pd.DataFrame([timed_out, crashed]))
    overall = table[table["regime"] == "all"].iloc[0]
    assert (overall["points"], overall["judged"]) == (2, 1)
