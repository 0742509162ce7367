"""Measure: what make report's calls cost (the priors of
:data:`hoopbench.reports.compare.costs.CALL_COST_PRIOR`), and how close its ETAs came.

Nothing here asserts a time. Three parts:

* ``stamp``: copies stdin to stdout, each line after the seconds since it started
  (``make report 2>&1 | python -m hoopbench.reports.bench.call_costs stamp > LOG``).
* ``accuracy LOG``: from such a log, each step's ETA (a suite's or the map's own) and the
  overall one (``make report: step k of n ...``), over the real time left, at the first line
  at or past 10, 25, 50 and 75 % of its runs. A step's real end is its last line; the
  overall's, the log's last line (the report step included). A line belongs to the step its
  overall part names first (steps overlap: 'step 3 of 4 (stability, with finer)'). An ETA
  is printed to the second ('1h02m': the minute): the ratio is that of the value within
  its rounding nearest the time left (the map's 2-s classification said 'eta 1s' with
  0.48 s left: 2.08 by the printed second, 1.04 within its rounding).
* ``fit CALLS``: the rates that fit the whole calls ``hoopbench report-runs --calls CALLS``
  wrote (one JSON object a line: kinds, steps, worlds, seconds, cold, first, new and
  world_steps: the :class:`~hoopbench.reports.sweep.eta.Took`'s), by each call's most
  general kind: non-negative least squares of each call's seconds, relative to them (a 0.3 s
  call weighs as much as a 60 s one; none more than a call of the kind's mean), on a fixed
  part, a part per step, per world-step (an engine whose calls have several worlds: the
  world-steps the call took, as the ETA costs them, costs.batch_world_steps; a calls file
  recorded before them, steps times worlds: CallCost.paid_world_steps), a
  worker's first call's extra (a kind with cold calls) and a worker's first call of the
  engine's (where its cold calls were not all that). Printed as the Python of
  CALL_COST_PRIOR, with the machine and load.
* ``compile COLD WARM``: what the calls of a make report with cold caches (``--calls`` of a
  run with a new HOOPBENCH_CACHE) took more than the same calls with warm caches, by kinds,
  steps and worlds, where it is more than half a second, with how many of the cold run's
  were their worker's first of the engine and the machine's first of the kind: what
  :data:`~hoopbench.reports.compare.costs.COLD_CACHE_S` says (an engine's compile where
  only its first calls paid, a kind's where its new ones did).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import sys
import time
from collections.abc import Hashable, Iterable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from scipy.optimize import nnls

from hoopbench.reports.report_runs import MAP_STEP
from hoopbench.reports.sweep.eta import CallCost, Rates

FRACTIONS = (0.10, 0.25, 0.50, 0.75)
_DURATION = re.compile(r"(?:(\d+)h)?(?:(\d+)m)?(?:(\d+)s)?$")
_STEP = re.compile(r"\[(\d+)/(\d+)\] .*?, eta (\S+?)(?:;|$)")
_OVERALL = re.compile(r"make report: step (\d+) of \d+ \(([^)]*)\), runs (\d+)/(\d+), eta (\S+)$")
_START = re.compile(r"make report: (suite \d+ of \d+ \((\w+)\)|the hop map)")


def rounding(text: str) -> tuple[float, float]:
    """The seconds an ETA as printed may stand for: '42s' 41.5-42.5, '1h02m' 3720-3780."""
    value = seconds_of(text)
    return (value, value + 60.0) if "h" in text else (max(value - 0.5, 0.0), value + 0.5)


def seconds_of(text: str) -> float:
    """'1h02m', '3m05s', '42s' -> s."""
    match = _DURATION.match(text)
    if match is None or not text:
        raise ValueError(f"not a duration: {text!r}")
    hours, minutes, secs = (int(g) if g else 0 for g in match.groups())
    return 3600.0 * hours + 60.0 * minutes + secs


def read_log(path: Path) -> list[tuple[float, str]]:
    """A stamped log's lines: (s since the start, line)."""
    lines = []
    for raw in path.read_text().splitlines():
        stamp, _, line = raw.partition("\t")
        lines.append((float(stamp), line))
    return lines


Point = tuple[float, float, str]
"""(fraction of the runs done, time of the line, its ETA as printed)."""


def _ratios(points: Sequence[Point], end: float) -> list[float | None]:
    """The ETA over the real time left at each FRACTIONS (the ETA within its rounding
    nearest the time left)."""
    out: list[float | None] = []
    for fraction in FRACTIONS:
        found = next((p for p in points if p[0] >= fraction), None)
        left = None if found is None else end - found[1]
        if found is None or not left or left <= 0:
            out.append(None)
            continue
        low, high = rounding(found[2])
        out.append(min(max(left, low), high) / left)
    return out


def accuracy(lines: Sequence[tuple[float, str]]) -> dict[str, list[float | None]]:
    """Step name (and 'overall') -> ETA / real time left at FRACTIONS (module docstring)."""
    steps: dict[str, list[Point]] = {}
    ends: dict[str, float] = {}
    overall: list[Point] = []
    name = "?"
    for t, line in lines:
        started = _START.search(line)
        if started is not None and "->" in line:
            name = started.group(2) or "map"
            continue
        step = _STEP.search(line)
        if step is None:
            continue
        done, total = int(step.group(1)), int(step.group(2))
        whole = _OVERALL.search(line)
        own = name if whole is None else _step_name(whole.group(2))
        # The map's two stages count apart: its reference stage is a step of its own.
        key = own if not (own == "map" and "reference" in line) else "map (reference)"
        steps.setdefault(key, []).append((done / total, t, step.group(3)))
        ends[key] = t
        if whole is not None:
            runs, all_runs = int(whole.group(3)), int(whole.group(4))
            overall.append((runs / all_runs, t, whole.group(5)))
    out = {key: _ratios(points, ends[key]) for key, points in steps.items()}
    if overall and lines:
        out["overall"] = _ratios(overall, lines[-1][0])
    return out


def _step_name(words: str) -> str:
    """The step a line is of, from its overall part's '(stability, with finer)': as the
    start lines name it ('map' for the map)."""
    own = words.split(", with ")[0]
    return "map" if own == MAP_STEP else own


def _kind(value: object) -> Hashable:
    """A kind read back from JSON (its tuples came back as lists)."""
    if isinstance(value, list):
        return tuple(_kind(v) for v in value)
    assert isinstance(value, Hashable)
    return value


def fit(records: Iterable[dict[str, object]]) -> dict[Hashable, Rates]:
    """The rates of each most general kind (module docstring)."""
    groups: dict[Hashable, list[dict[str, object]]] = {}
    for record in records:
        kinds = record["kinds"]
        assert isinstance(kinds, list)
        groups.setdefault(_kind(kinds[-1]), []).append(record)
    rates: dict[Hashable, Rates] = {}
    for kind, calls in groups.items():
        took = np.array([float(c["seconds"]) for c in calls])  # type: ignore[arg-type]
        steps = np.array([float(c["steps"]) for c in calls])  # type: ignore[arg-type]
        worlds = np.array([float(c["worlds"]) for c in calls])  # type: ignore[arg-type]
        world_steps = np.array([_world_steps(c) for c in calls])
        cold = np.array([1.0 if c["cold"] else 0.0 for c in calls])
        first = np.array([1.0 if c.get("first") else 0.0 for c in calls])
        columns = [np.ones_like(took), steps, world_steps, cold, first]
        used = [
            True,
            bool(steps.any()),
            bool((worlds > 1).any()),
            bool(cold.any() and not cold.all()),
            # Apart from the cold part only where some cold calls were not the worker's first
            # of the engine (the kind's own first calls on a worker that had the engine).
            bool(first.any() and not first.all() and (cold != first).any()),
        ]
        a = np.column_stack([c for c, u in zip(columns, used, strict=True) if u])
        # Relative to each call's seconds, but none weighs more than a call of the kind's
        # mean: the map's points that return at once (2 ms among 0.2 s calls) pulled the
        # fixed part to 2 ms, and the ETA's sums need the mean.
        weight = 1.0 / np.maximum(took, took.mean())
        solution, _ = nnls(a * weight[:, None], took * weight)
        values = iter(solution)
        fixed, step, world_step, extra, once = (float(next(values)) if u else 0.0 for u in used)
        rates[kind] = Rates(fixed, step, world_step, extra, once)
    return rates


def _world_steps(record: dict[str, Any]) -> float:
    """A recorded call's world-steps: those it took, else (a calls file recorded before
    them) its steps times its worlds, as the ETA reads a call that says none."""
    taken = record.get("world_steps")
    world_steps = None if taken is None else float(taken)
    call = CallCost((), float(record["steps"]), int(record["worlds"]), world_steps)
    return call.paid_world_steps


CallKey = tuple[Hashable, float, int]


def compile_costs(
    cold: Iterable[dict[str, Any]], warm: Iterable[dict[str, Any]], least_s: float = 0.5
) -> list[tuple[CallKey, int, float, float, int, int]]:
    """(kinds, steps, worlds), calls, warm s, cold s, first calls, new calls in the cold run,
    for each group of calls whose cold seconds exceed the warm ones by more than
    ``least_s`` (module docstring)."""
    sums: list[dict[CallKey, list[float]]] = [{}, {}]
    for run, records in zip(sums, (cold, warm), strict=True):
        for r in records:
            key = (_kind(r["kinds"]), float(r["steps"]), int(r["worlds"]))
            found = run.setdefault(key, [0.0, 0.0, 0.0, 0.0])
            found[0] += 1
            found[1] += float(r["seconds"])
            found[2] += bool(r.get("first"))
            found[3] += bool(r.get("new"))
    out = []
    for key, (n, took, first, new) in sums[0].items():
        before = sums[1].get(key, [0.0, 0.0])[1]
        if took - before > least_s:
            out.append((key, int(n), before, took, int(first), int(new)))
    return sorted(out, key=lambda row: str(row[0]))


def print_compile(cold: Path, warm: Path) -> None:
    rows = compile_costs(_records(cold), _records(warm))
    print("kinds | steps | worlds | calls | warm s | cold s | more s | first | new")
    for (kinds, steps, worlds), n, before, took, first, new in rows:
        print(
            f"{kinds!r} | {steps:g} | {worlds} | {n} | {before:.2f} | {took:.2f} | "
            f"{took - before:.2f} | {first} | {new}"
        )


def _records(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return "unknown CPU"


def _number(value: float) -> str:
    return f"{value:.2g}" if value else "0.0"


def print_fit(path: Path) -> None:
    records = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
    rates = fit(records)
    load = [r.get("load") for r in records if r.get("load") is not None]
    print(f"# {len(records)} calls of {path}, {_cpu_model()}, {os.cpu_count()} cores")
    if load:
        print(f"# load average (1 min) at the calls' ends: {min(load):.1f}-{max(load):.1f}")
    for kind, r in sorted(rates.items(), key=lambda item: str(item[0])):
        n = sum(1 for rec in records if _kind(rec["kinds"][-1]) == kind)
        parts = [_number(r.fixed_s), _number(r.step_s)]
        if r.world_step_s or r.cold_s or r.first_s:
            parts.append(_number(r.world_step_s))
        if r.cold_s or r.first_s:
            parts.append(_number(r.cold_s))
        if r.first_s:
            parts.append(_number(r.first_s))
        print(f"    {kind!r}: Rates({', '.join(parts)}),  # {n} calls")


def print_accuracy(path: Path) -> None:
    table = accuracy(read_log(path))
    print("step | " + " | ".join(f"{f:.0%}" for f in FRACTIONS))
    for name, ratios in table.items():
        cells = ["—" if r is None else f"{r:.2f}" for r in ratios]
        print(f"{name} | " + " | ".join(cells))


def stamp(source: Iterable[str]) -> None:
    start = time.monotonic()
    for line in source:
        sys.stdout.write(f"{time.monotonic() - start:.2f}\t{line.rstrip()}\n")
        sys.stdout.flush()


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="part", required=True)
    sub.add_parser("stamp", help="stdin to stdout, each line after its time")
    sub.add_parser("accuracy", help="the ETAs' accuracy in a stamped log").add_argument("log")
    sub.add_parser("fit", help="the rates of report-runs --calls").add_argument("calls")
    compiled = sub.add_parser("compile", help="what cold caches cost more, call by call")
    compiled.add_argument("cold")
    compiled.add_argument("warm")
    args = parser.parse_args(argv)
    if args.part == "stamp":
        stamp(sys.stdin)
    elif args.part == "accuracy":
        print_accuracy(Path(args.log))
    elif args.part == "compile":
        print_compile(Path(args.cold), Path(args.warm))
    else:
        print_fit(Path(args.calls))
    return 0


if __name__ == "__main__":
    sys.exit(main())
