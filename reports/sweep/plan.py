"""One progress line over several sweeps (``make report``'s three suites and its map,
:mod:`hoopbench.reports.report_runs`), run in a row or overlapping on one shared pool.

The command that runs them makes a :class:`Plan` of every sweep's calls before the first
starts, and sets it as :data:`current_plan` while they run; each sweep's progress lines
then end with the plan's: which step of how many (and which others are running), the runs
done of all the steps', and an ETA for them all. Every sweep adds its finished calls to
the plan's, so the costs a suite measured scale the priors of the sweeps after it (the same
engines at other timesteps).

Overlapping sweeps (``report-runs``: each sweep in its own thread, every thread's calls on
the plan's one pool) start in plan order: a sweep begins calling once the one before it has
nothing left queued (:meth:`Plan.wait_turn`), so its calls queue behind the earlier one's
and a worker the earlier sweep's tail would leave idle runs them. The ETA then lays out
every running sweep's calls (theirs in flight, then theirs waiting, in plan order), then
the calls of the sweeps not begun, on the shared workers
(:func:`hoopbench.reports.sweep.eta.call_ends`); a sweep's own ETA is when the last of its
calls ends in that layout (a later sweep's calls, begun or not, queue behind its own, but a
worker takes them first where its own are a batched engine's that keeps to the other
worker), the overall one when the last of all ends, and after them what runs without
workers (the report: ``after``). A progress line takes both from one layout.
"""

from __future__ import annotations

import threading
from collections import deque
from collections.abc import Hashable, Mapping, Sequence
from contextvars import ContextVar
from dataclasses import dataclass
from typing import Any, Protocol

from hoopbench.reports.sweep.eta import (
    CallCost,
    Rates,
    Running,
    Took,
    call_ends,
    key_holders,
    remaining_seconds,
    warm_counts,
)

__all__ = [
    "Active",
    "Plan",
    "PlannedSweep",
    "current_lane",
    "current_plan",
    "duration_text",
]


@dataclass(frozen=True)
class PlannedSweep:
    """A sweep of a plan, as planned before it starts."""

    step: str
    """The step it belongs to, as the line names it: 'default', 'the hop map'."""
    runs: int
    """Runs it will run."""
    calls: tuple[CallCost, ...]
    """Its calls (runs alone and batches) in the order they are submitted."""


class Active(Protocol):
    """A sweep running under a plan, as the plan reads it."""

    @property
    def done(self) -> int:
        """Runs it has done."""

    def left(
        self,
    ) -> tuple[list[Running], list[CallCost], set[tuple[Hashable, Hashable]]] | None:
        """Its calls running, its calls not started (in submission order), and (worker,
        kind) at every level of the calls run (:func:`~hoopbench.reports.sweep.eta.ran`);
        None without costs."""


class Plan:
    """Sweeps run in a row or overlapping, and the calls of them that have finished
    (mutable: the progress of one command, read and written by its sweeps' threads)."""

    def __init__(
        self,
        title: str,
        sweeps: Sequence[PlannedSweep],
        prior: Mapping[Hashable, Rates],
        workers: int,
        after: Sequence[CallCost] = (),
    ) -> None:
        self.title = title
        """What runs them, as the line starts: 'make report'."""
        self.sweeps = list(sweeps)
        self.prior = dict(prior)
        """Every sweep's priors (their kinds do not overlap where their costs differ)."""
        self.workers = workers
        self.after = tuple(after)
        """What runs once the sweeps are done, one after the other (the report)."""
        self.finished: list[Took] = []
        """Every finished call of every sweep so far."""
        self.warm: set[tuple[Hashable, Hashable]] = set()
        """(worker pid, kind) at every level of every call run: on a shared pool a worker
        stays warm from one sweep to the next."""
        self.index = -1
        """The last sweep begun."""
        self.steps = list(dict.fromkeys(sweep.step for sweep in self.sweeps))
        self.pool: Any = None
        """The executor every sweep of the plan submits to (report-runs'), else None: each
        sweep its own."""
        self.stop: Any = None
        """The flag the main thread's signal handlers set (its ``signal``), when the sweeps
        run in other threads; else None: each sweep handles its own signals."""
        self.failed = False
        """A sweep failed or was stopped: those not begun do not begin."""
        self.lock = threading.RLock()
        self._begun: set[int] = set()
        self._active: dict[int, Active] = {}
        self._done: dict[int, int] = {}
        self._drained = [threading.Event() for _ in self.sweeps]

    @property
    def total(self) -> int:
        """Runs of every sweep (those started: as they counted them)."""
        return sum(sweep.runs for sweep in self.sweeps)

    def begin(self, runs: int) -> int:
        """A sweep starts, with ``runs`` runs to run (a resumed one skips the stored): the
        next of this thread's lane (:data:`current_lane`), else the one after the last
        begun. Its index."""
        lane = current_lane.get()
        with self.lock:
            index = lane.popleft() if lane else self.index + 1
            self.index = max(self.index, index)
            if index < len(self.sweeps):
                planned = self.sweeps[index]
                self.sweeps[index] = PlannedSweep(planned.step, runs, planned.calls)
            else:  # a sweep the plan did not foresee: counted as a step of its own
                index = len(self.sweeps)
                self.sweeps.append(PlannedSweep("more", runs, ()))
                self.steps.append("more")
                self._drained.append(threading.Event())
            self._begun.add(index)
            return index

    def attach(self, index: int, sweep: Active) -> None:
        """Sweep ``index`` runs: its runs done and calls left count in the lines."""
        with self.lock:
            self._active[index] = sweep

    def drained(self, index: int) -> None:
        """Sweep ``index`` has nothing left queued: the next may begin calling."""
        if 0 <= index < len(self._drained):
            self._drained[index].set()

    def end(self, index: int, done: int) -> None:
        """Sweep ``index`` has ended, ``done`` runs done. (What runs it says when the next
        may begin, once it knows whether it failed: :meth:`drained`.)"""
        with self.lock:
            self._active.pop(index, None)
            self._done[index] = done

    def wait_turn(self, index: int) -> bool:
        """Wait until the sweep before ``index`` has nothing left queued; False when a
        sweep failed or a signal came meanwhile (then ``index`` does not run)."""
        before = self._drained[index - 1] if 0 < index <= len(self._drained) else None
        while before is not None and not before.wait(0.1):
            if self._stopped():
                return False
        return not self._stopped()

    def _stopped(self) -> bool:
        return self.failed or (self.stop is not None and self.stop.signal is not None)

    def later_seconds(self) -> float | None:
        """Expected s of the sweeps not begun and of what comes after them."""
        with self.lock:
            total = 0.0
            for k, sweep in enumerate(self.sweeps):
                if k in self._begun:
                    continue
                left = remaining_seconds(sweep.calls, [], self.finished, self.workers, self.prior)
                if left is None:
                    return None
                total += left
            after = self._after_seconds()
            return None if after is None else total + after

    def _after_seconds(self) -> float | None:
        if not self.after:
            return 0.0
        return remaining_seconds(self.after, [], self.finished, 1, self.prior)

    def _ends(self) -> dict[int, float] | None:
        """Sweep index -> when its last call is expected to end, s from now: the running
        sweeps' calls, then those of the sweeps not begun, laid out on the shared workers in
        plan order."""
        running: list[Running] = []
        pending: list[CallCost] = []
        owners: tuple[list[int], list[int]] = ([], [])
        warm: set[tuple[Hashable, Hashable]] = set()
        for k in sorted(self._active):
            left = self._active[k].left()
            if left is None:
                return None
            running += left[0]
            pending += left[1]
            owners[0].extend([k] * len(left[0]))
            owners[1].extend([k] * len(left[1]))
            warm |= left[2]
        for k, sweep in enumerate(self.sweeps):
            if k not in self._begun:
                pending += sweep.calls
                owners[1].extend([k] * len(sweep.calls))
        counts, holders = warm_counts(warm), key_holders(warm)
        ends = call_ends(pending, running, self.finished, self.workers, self.prior, counts, holders)
        if ends is None:
            return None
        last: dict[int, float] = {}
        for owner, end in zip([*owners[0], *owners[1]], [*ends[0], *ends[1]], strict=True):
            last[owner] = max(last.get(owner, 0.0), end)
        return last

    def etas(self, index: int) -> tuple[float | None, float | None]:
        """(:meth:`sweep_left`, :meth:`seconds_left`) from one layout of the calls: a
        progress line shows both, and each layout costs about 8 ms on a slow machine (370
        lines of a make report laid out twice: 2.9 of the parent's CPU-s, beside workers
        that want both cores)."""
        with self.lock:
            ends = self._ends()
            after = self._after_seconds()
        if ends is None:
            return None, None
        whole = None if after is None else max([0.0, *ends.values()]) + after
        return ends.get(index, 0.0), whole

    def sweep_left(self, index: int) -> float | None:
        """Seconds until sweep ``index``'s last call ends, the sweeps sharing the workers:
        the later ones' calls, begun or not, queue behind its own, but for those a worker
        takes first because its own are another worker's (a batched engine's, eta.own_call).
        The sweeps not begun count: their calls keep a worker busy that would otherwise take
        a batched engine's calls from the worker that holds its key (a cold make report's
        stability suite said 34 s of 53 when they were left out)."""
        return self.etas(index)[0]

    def seconds_left(self) -> float | None:
        """Seconds until every sweep and what comes after them have ended."""
        return self.etas(0)[1]  # the whole is the same whichever sweep asks

    def text(self, index: int, with_eta: bool = True, left: float | None = None) -> str:
        """'make report: step 2 of 4 (finer), runs 500/1244, eta 3m10s' for a line of sweep
        ``index``; with other steps running, 'step 3 of 4 (stability, with finer)'. The runs
        done of all, and the seconds left of all (``left`` when already worked out,
        :meth:`etas`; left out while a cost is unknown)."""
        with self.lock:
            step = self.sweeps[index].step
            others = [self.sweeps[k].step for k in sorted(self._active) if k != index]
            others = [name for name in dict.fromkeys(others) if name != step]
            runs = sum(self._done.values()) + sum(a.done for a in self._active.values())
            k = self.steps.index(step) + 1
            also = f", with {' and '.join(others)}" if others else ""
            text = f"{self.title}: step {k} of {len(self.steps)} ({step}{also})"
            text += f", runs {runs}/{self.total}"
        if with_eta and left is None:
            left = self.seconds_left()
        return text if left is None or not with_eta else f"{text}, eta {duration_text(left)}"


def duration_text(seconds: float) -> str:
    """'1h02m', '3m05s', '42s'."""
    seconds = round(seconds)
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    if hours:
        return f"{hours}h{minutes:02d}m"
    return f"{minutes}m{secs:02d}s" if minutes else f"{secs}s"


current_plan: ContextVar[Plan | None] = ContextVar("current_plan", default=None)
"""The plan of the sweeps running (set by the command that runs them), else None."""
current_lane: ContextVar[deque[int] | None] = ContextVar("current_lane", default=None)
"""The plan's sweeps a thread runs, in order (report-runs sets it in each step's thread: the
map's two stages are one lane), else None: each sweep is the one after the last begun."""
