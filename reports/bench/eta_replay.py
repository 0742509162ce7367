"""Measure: make report's ETAs replayed from the calls a real one recorded (``hoopbench
report-runs --calls CALLS``), without running anything.

make report's plan (its three suites and its map, as :func:`report_plan` works them out)
runs again on ``--workers`` simulated workers: each sweep begins once the runner has
submitted every call of the one before (its calls with an affinity key whenever they come,
the others while fewer than twice the workers' are in flight: runner._Calls._submit; the
map's engine runs once its classification has ended), a free worker takes the first call
submitted that is its own, as the pool hands them (eta.own_call), and each call lasts the
seconds a recorded call of its kinds, steps and worlds took (a worker's first call of an
engine takes the longest such recorded call: it is where a cold cache compiled; the others
in the order they were recorded). After each call
the sweep's and the overall ETA are worked out by :class:`~hoopbench.reports.sweep.plan.Plan`
as the progress lines would, and printed as ETA over the simulated time left at 10, 25, 50
and 75 % of each step's runs, read as the stamped log's are
(:mod:`hoopbench.reports.bench.call_costs` ``accuracy``: within the printed second).

A replay tells how the ETA's model reads calls that cost what they cost, in an order close
to the real one; it does not reproduce the real run's timing (no gaps between calls, no
drawing). The map's engine runs are costed as the runner costs them, by the steps to where
each stops on its point's exact motion: the replay classifies the map's points first (about
5 CPU-s). Until they begin, its plan costs them as make report's does, without the exact
columns (``MapTask.expected_steps``): so the ETA of the steps before reads as it read live,
the map's part of it too long by what the classification then finds. A calls file written
before that costing (by the window) finds no recorded call of them: ``--map-by-window``
replays one with the map's runs costed as it was, at today's priors. ``--cold`` takes the
engines whose compiled-code caches were empty (make report with a new HOOPBENCH_CACHE: ``mjx
newton mjwarp``). ``--shuffle-map SEED`` hands the map's engine runs alone (not its batches,
not its classification) their recorded seconds in a seeded random order instead of the
grid's (x outer, y inner), each worker's first call still the longest: it tells what of the
map's ETA comes from the grid order, whose first points (rolling and slipping starts) cost
several times the later ones (most lifting off at once), so that a kind's factor measured on
them says too much of the rest (docs/cli.md). ``--keys-as-recorded`` gives each batched
engine's affinity key to the worker that ran its first call in the recorded run (the file's
``worker``, workers numbered as their first calls started), not to the simulated worker that
happens to be free first: where one worker held both MuJoCo's and MJX's keys, their last
calls ran one after the other on it while the other worker ran the map's, which a replay
with the keys apart does not show.

    python -m hoopbench.reports.bench.eta_replay /tmp/mr11-calls.jsonl --cold mjx newton mjwarp
"""

from __future__ import annotations

import argparse
import json
import math
import random
import sys
from collections import deque
from collections.abc import Hashable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from hoopbench.engines.judging.columns import Col
from hoopbench.engines.run import REFERENCE_ENGINE
from hoopbench.reports.bench.call_costs import FRACTIONS, _kind, _ratios
from hoopbench.reports.compare.costs import MAP as MAP_KIND
from hoopbench.reports.compare.costs import priors
from hoopbench.reports.compare.suite import DEFAULT_BATCH_SIZE
from hoopbench.reports.hop_map.spec import MapSpec
from hoopbench.reports.hop_map.stages import MapTask, classified_tasks, planned_tasks
from hoopbench.reports.report_runs import MAP_STEP, REPORT_SUITES, report_plan
from hoopbench.reports.sweep.eta import (
    CallCost,
    Running,
    Took,
    call_firsts,
    key_holders,
    own_call,
    ran,
)
from hoopbench.reports.sweep.plan import Plan, duration_text
from hoopbench.reports.sweep.runner import IN_FLIGHT_PER_WORKER

MAP = MapSpec(nx=10, ny=10, engines=("mujoco", "pybullet", "pymunk"))
"""make report's map (the Makefile's MAP_ARGS: --grid 10x10 --engines mujoco pybullet
pymunk)."""

LINE_INTERVAL_S = 1.0
"""The runner's plain progress lines: at most one a second (and the last)."""

Key = tuple[tuple[Hashable, ...], float, int]


@dataclass(frozen=True)
class _InFlight:
    """A call a simulated worker runs."""

    call: CallCost
    start: float
    flags: tuple[bool, bool, bool]
    """(cold, first, new): :func:`~hoopbench.reports.sweep.eta.call_firsts`."""
    seconds: float


@dataclass
class _Sweep:
    """A planned sweep as the replay runs it (the plan's :class:`Active`)."""

    queue: deque[CallCost]
    done: int = 0
    running: dict[int, _InFlight] = field(default_factory=dict)
    """Worker -> the call it runs."""
    warm: set[tuple[Hashable, Hashable]] = field(default_factory=set)
    now: float = 0.0
    line: float = -float("inf")
    """When its last progress line was printed."""

    def left(self) -> tuple[list[Running], list[CallCost], set[tuple[Hashable, Hashable]]]:
        warm = set(self.warm)
        running = []
        for worker, flight in self.running.items():
            ran_s = self.now - flight.start
            running.append(Running(flight.call, ran_s, *flight.flags, worker=worker))
            warm |= ran(flight.call, worker)
        return running, list(self.queue), warm

    def submitted(self, limit: int) -> int:
        """How many of its calls not started the runner has submitted to the pool
        (runner._Calls._submit: in order, a call with an affinity key whenever it comes, one
        without while fewer than ``limit`` such are in flight, queued or running)."""
        open_ = sum(1 for flight in self.running.values() if not flight.call.affine)
        for index, call in enumerate(self.queue):
            if not call.affine:
                if open_ >= limit:
                    return index
                open_ += 1
        return len(self.queue)

    def drained(self, limit: int) -> bool:
        """Whether the runner has submitted all its calls (the next sweep may begin)."""
        return self.submitted(limit) == len(self.queue)


class MissingCallError(LookupError):
    """A call the replay's plan makes that the calls file does not hold."""


MISSING_HINT = (
    "a calls file recorded before the map's engine runs were costed by their stop "
    "(2026-11-29) needs --map-by-window; else it is of other suites or another map"
)
"""What :func:`main` says of a :class:`MissingCallError`."""


class _Recorded:
    """The recorded calls' seconds by kinds, steps and worlds; with ``shuffle``, the map's
    engine runs alone in its random order (module docstring)."""

    def __init__(
        self, records: Sequence[dict[str, Any]], shuffle: random.Random | None = None
    ) -> None:
        self.left: dict[Key, list[float]] = {}
        for record in records:
            kinds = tuple(_kind(k) for k in record["kinds"])
            key = (kinds, float(record["steps"]), int(record["worlds"]))
            self.left.setdefault(key, []).append(float(record["seconds"]))
        for key, seconds in self.left.items():
            if shuffle is not None and _map_engine_run(key):
                shuffle.shuffle(seconds)

    def take(self, call: CallCost, first: bool) -> float:
        found = self.left.get((tuple(call.kinds), float(call.steps), call.worlds))
        if not found:
            raise MissingCallError(f"no recorded call of {call}")
        pick = max(range(len(found)), key=found.__getitem__) if first else 0
        return found.pop(pick)


def _map_engine_run(key: Key) -> bool:
    """Whether calls of ``key`` are the map's engine runs alone (kind ('map', engine))."""
    engine = key[0][-1] if key[0] else None
    if not isinstance(engine, tuple) or len(engine) != 2 or engine[0] != MAP_KIND:
        return False
    return engine[1] != REFERENCE_ENGINE and key[2] == 1


def replay(
    records: Sequence[dict[str, Any]],
    cold: Sequence[str],
    workers: int,
    report_s: float,
    shuffle_map: int | None = None,
    map_by_window: bool = False,
    keys_as_recorded: bool = False,
) -> dict[str, list[float | None]]:
    """Step name (and 'overall') -> ETA / time left at FRACTIONS (module docstring;
    ``shuffle_map``: the seed of ``--shuffle-map``; ``map_by_window``: the map's engine
    runs costed by their window, as calls files written before their stop was read;
    ``keys_as_recorded``: ``--keys-as-recorded``)."""
    suites = [name for name, _ in REPORT_SUITES]
    # The calls run: the map's engine runs as the runner costs them once its points are
    # classified, from their exact columns. The plan costs them as make report's does before
    # that, without them (MapTask.expected_steps): its layout of the steps not begun.
    window = _by_window(planned_tasks(MAP)[1]) if map_by_window else None
    ahead = report_plan(suites, MAP, workers, DEFAULT_BATCH_SIZE, window)
    run = (
        ahead
        if window
        else report_plan(suites, MAP, workers, DEFAULT_BATCH_SIZE, classified_tasks(MAP))
    )
    plan = Plan("make report", ahead.sweeps, priors(cold), workers, after=ahead.after)
    recorded = _Recorded(records, None if shuffle_map is None else random.Random(shuffle_map))
    sweeps = [_Sweep(deque(s.calls), warm=plan.warm) for s in run.sweeps]
    names = [_name(k, s.step) for k, s in enumerate(plan.sweeps)]
    points: dict[str, list[tuple[float, float, str]]] = {name: [] for name in names}
    ends: dict[str, float] = {}
    overall: list[tuple[float, float, str]] = []
    free = dict.fromkeys(range(workers), 0.0)
    pinned = recorded_keys(records, workers, _affinities(plan)) if keys_as_recorded else {}
    begun = -1
    now = 0.0
    while True:
        begun = _begin(plan, sweeps, begun, workers)
        _start_calls(sweeps, free, now, plan.warm, recorded, begun, pinned)
        busy = [(f.start + f.seconds, k, w) for k, s in enumerate(sweeps)
                for w, f in s.running.items()]  # fmt: skip
        if not busy:
            break
        now, k, worker = min(busy)
        sweep = sweeps[k]
        flight = sweep.running.pop(worker)
        call = flight.call
        plan.finished.append(Took(call, flight.seconds, *flight.flags))
        plan.warm |= ran(call, worker)
        free[worker] = now
        sweep.done += call.worlds
        if not sweep.queue and not sweep.running:
            plan.end(k, sweep.done)
        for s in sweeps:
            s.now = now
        if now - sweep.line < LINE_INTERVAL_S and (sweep.queue or sweep.running):
            continue  # the runner's plain lines: at most one a second, and the last
        sweep.line = now
        own, whole = plan.etas(k)  # as a progress line does
        if own is not None:
            points[names[k]].append((sweep.done / plan.sweeps[k].runs, now, duration_text(own)))
            ends[names[k]] = now
        if whole is not None:
            runs = sum(s.done for s in sweeps)
            overall.append((runs / plan.total, now, duration_text(whole)))
    out = {name: _ratios(pts, ends[name]) for name, pts in points.items() if pts}
    out["overall"] = _ratios(overall, now + report_s)
    return out


def _by_window(tasks: Sequence[MapTask]) -> list[MapTask]:
    """The map's engine tasks each costed by its whole window (--map-by-window): exact
    columns that say no impact and no settling, so that its stop rule never ends it."""
    return [replace(task, exact=((Col.EXACT_T_IMPACT, None),)) for task in tasks]


def _begin(plan: Plan, sweeps: list[_Sweep], begun: int, workers: int) -> int:
    """Begin the sweeps whose turn has come (the one before has submitted all its calls:
    Plan.wait_turn; the map's engine runs once its classification has ended)."""
    while begun + 1 < len(sweeps):
        before = sweeps[begun] if begun >= 0 else None
        if before is not None and not before.drained(_limit(workers)):
            break
        is_map_engines = begun >= 0 and plan.sweeps[begun].step == MAP_STEP
        if is_map_engines and (before is None or before.queue or before.running):
            break
        begun += 1
        plan.attach(plan.begin(plan.sweeps[begun].runs), sweeps[begun])
    return begun


def _start_calls(
    sweeps: list[_Sweep],
    free: dict[int, float],
    now: float,
    warm: set[tuple[Hashable, Hashable]],
    recorded: _Recorded,
    begun: int,
    pinned: dict[Hashable, set[int]] | None = None,
) -> None:
    """Each idle worker takes the next call of the earliest begun sweep with one left, as
    the pool hands them: first a call of its own (of no affinity, of an engine it has run or
    no other worker has), else the first (the pool's wait of 0.2 s before it is left out)."""
    busy = {w for s in sweeps for w in s.running}
    for steal in (False, True):
        for worker in sorted(free):
            if worker in busy:
                continue
            taken = set(warm)
            for s in sweeps:
                for w, flight in s.running.items():
                    taken |= ran(flight.call, w)
            limit = _limit(len(free))
            found = _next_call(sweeps[: begun + 1], worker, taken, steal, limit, pinned)
            if found is None:
                continue
            k, index = found
            call = sweeps[k].queue[index]
            del sweeps[k].queue[index]
            flags = call_firsts(call, worker, taken)
            sweeps[k].running[worker] = _InFlight(call, now, flags, recorded.take(call, flags[1]))
            busy.add(worker)


def _next_call(
    sweeps: Sequence[_Sweep],
    worker: int,
    taken: set[tuple[Hashable, Hashable]],
    steal: bool,
    limit: int,
    pinned: dict[Hashable, set[int]] | None = None,
) -> tuple[int, int] | None:
    """(sweep, index in its queue) of the call ``worker`` takes (:func:`_start_calls`), of
    those the runner has submitted to the pool; ``pinned``: an affinity key -> the worker
    that holds it before any has run its calls (:func:`recorded_keys`)."""
    owners: dict[Hashable, set[Hashable]] = {key: set(w) for key, w in (pinned or {}).items()}
    owners.update(key_holders(taken))  # an affinity key -> the workers that hold it
    for k, sweep in enumerate(sweeps):
        for index in range(sweep.submitted(limit)):
            if steal or own_call(sweep.queue[index], worker, owners):
                return k, index
    return None


def _limit(workers: int) -> int:
    """Calls without an affinity key a sweep has in flight at most on the plan's pool
    (runner._pool_for)."""
    return IN_FLIGHT_PER_WORKER * workers


def _name(index: int, step: str) -> str:
    """A sweep's name as the accuracy table names its step."""
    if step != MAP_STEP:
        return step
    return "map (reference)" if index == len(REPORT_SUITES) else "map"


def _affinities(plan: Plan) -> dict[Hashable, Hashable]:
    """A call's most general kind -> the affinity key of its calls, in ``plan``'s calls."""
    return {
        call.kinds[-1]: call.affinity
        for sweep in plan.sweeps
        for call in sweep.calls
        if call.kinds and call.affine
    }


def recorded_keys(
    records: Sequence[dict[str, Any]],
    workers: int,
    affinities: Mapping[Hashable, Hashable] | None = None,
) -> dict[Hashable, set[int]]:
    """An affinity key (``affinities``' of the most general kind of a recorded call of more
    than one world, else that kind) -> the worker that ran its first such call in the
    recorded run, workers numbered 0 .. ``workers`` - 1 as their first calls started
    (records without a ``worker`` are passed over). The map's MuJoCo batches, kind
    ('map', 'mujoco'), hold MuJoCo's key, as the suites' do."""
    order: dict[Any, int] = {}
    keys: dict[Hashable, set[int]] = {}
    for record in sorted(records, key=lambda r: float(r.get("started") or 0.0)):
        worker = record.get("worker")
        if worker is None:
            continue
        slot = order.setdefault(worker, len(order) % max(workers, 1))
        if int(record["worlds"]) > 1:
            kind = _kind(record["kinds"][-1])
            keys.setdefault((affinities or {}).get(kind, kind), {slot})
    return keys


RECORD_KEYS = ("kinds", "steps", "worlds", "seconds")
"""What the replay reads of a calls file's record (report-runs --calls writes more)."""

RECORD_NUMBERS = ("steps", "worlds", "seconds", "started")
"""The record's fields the replay reads as numbers (``started``, --keys-as-recorded's, may be
null or absent)."""


class BadCallsError(ValueError):
    """A calls file the replay cannot read: the one line :func:`main` prints."""


def read_records(path: str) -> list[dict[str, Any]]:
    """The records of a ``report-runs --calls`` file (BadCallsError naming it if it holds none)."""
    try:
        lines = Path(path).read_text().splitlines()
        records = [json.loads(line) for line in lines if line.strip()]
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise BadCallsError(f"calls {path!r} is not a readable calls file: {exc}") from None
    for record in records:
        if not _is_record(record):
            text = f"{record!r:.80}"
            raise BadCallsError(f"calls {path!r} holds a line that is no call record: {text}")
    return records


def _is_record(record: object) -> bool:
    """Whether ``record`` holds what the replay reads: RECORD_KEYS, its kinds a list and
    RECORD_NUMBERS finite numbers (``started`` null or absent too)."""
    if not (isinstance(record, dict) and all(key in record for key in RECORD_KEYS)):
        return False
    numbers = [record.get(key) for key in RECORD_NUMBERS]
    numbers[-1] = 0.0 if numbers[-1] is None else numbers[-1]
    return isinstance(record["kinds"], list) and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) for v in numbers
    )


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("calls", help="report-runs --calls' file")
    parser.add_argument("--cold", nargs="*", default=[], help="engines whose caches were cold")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--report-s", type=float, default=17.0, help="the report step's s")
    parser.add_argument(
        "--shuffle-map", type=int, metavar="SEED", help="the map's runs' seconds in random order"
    )
    parser.add_argument(
        "--map-by-window",
        action="store_true",
        help="the map's engine runs costed by their window (a calls file from before their stop)",
    )
    parser.add_argument(
        "--keys-as-recorded",
        action="store_true",
        help="each batched engine's key on the worker that held it in the recorded run",
    )
    args = parser.parse_args(argv)
    try:
        records = read_records(args.calls)
        table = replay(
            records, args.cold, args.workers, args.report_s, args.shuffle_map,
            args.map_by_window, args.keys_as_recorded,
        )  # fmt: skip
    except BadCallsError as exc:
        print(f"eta_replay: {exc}", file=sys.stderr)
        return 2
    except MissingCallError as exc:
        print(f"eta_replay: calls {args.calls!r}: {exc}: {MISSING_HINT}", file=sys.stderr)
        return 2
    print("step | " + " | ".join(f"{f:.0%}" for f in FRACTIONS))
    for name, ratios in table.items():
        cells = ["—" if r is None else f"{r:.2f}" for r in ratios]
        print(f"{name} | " + " | ".join(cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
