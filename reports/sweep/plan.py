"""One progress line over several sweeps run in a row (``make report``'s three suites and
its map, :mod:`hoopbench.reports.report_runs`).

The command that runs them makes a :class:`Plan` of every sweep's calls before the first
starts, and sets it as :data:`current_plan` while they run; each sweep's progress lines
then end with the plan's: which step of how many, the runs done of all the steps', and an
ETA for them all. The ETA of the sweep running is its own
(:func:`hoopbench.reports.sweep.eta.remaining_seconds`); each later sweep's is its calls'
expected costs laid out on the workers, and after them what runs without workers (the
report: ``after``). Every sweep adds its finished calls to the plan's, so the costs a suite
measured scale the priors of the sweeps after it (the same engines at other timesteps).
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from contextvars import ContextVar
from dataclasses import dataclass

from hoopbench.reports.sweep.eta import CallCost, Rates, Took, remaining_seconds

__all__ = ["Plan", "PlannedSweep", "current_plan", "duration_text"]


@dataclass(frozen=True)
class PlannedSweep:
    """A sweep of a plan, as planned before it starts."""

    step: str
    """The step it belongs to, as the line names it: 'default', 'the hop map'."""
    runs: int
    """Runs it will run."""
    calls: tuple[CallCost, ...]
    """Its calls (runs alone and batches) in the order they are submitted."""


class Plan:
    """Sweeps run in a row, and the calls of them that have finished (mutable: the
    progress of one command)."""

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
        self.index = -1
        """The sweep running (or the last one run)."""
        self.done_before = 0
        """Runs done in the sweeps before it."""
        self.steps = list(dict.fromkeys(sweep.step for sweep in self.sweeps))

    @property
    def total(self) -> int:
        """Runs of every sweep (those started: as they counted them)."""
        return sum(sweep.runs for sweep in self.sweeps)

    def begin(self, runs: int) -> None:
        """The next sweep starts, with ``runs`` runs to run (a resumed one skips the stored)."""
        self.index += 1
        if self.index < len(self.sweeps):
            planned = self.sweeps[self.index]
            self.sweeps[self.index] = PlannedSweep(planned.step, runs, planned.calls)
        else:  # a sweep the plan did not foresee: counted as a step of its own
            self.sweeps.append(PlannedSweep("more", runs, ()))
            self.steps.append("more")

    def end(self, done: int) -> None:
        """The sweep running has ended, ``done`` runs done."""
        self.done_before += done

    def later_seconds(self) -> float | None:
        """Expected s of the sweeps after the running one and of what comes after them."""
        total = 0.0
        for sweep in self.sweeps[self.index + 1 :]:
            left = remaining_seconds(sweep.calls, [], self.finished, self.workers, self.prior)
            if left is None:
                return None
            total += left
        if self.after:
            left = remaining_seconds(self.after, [], self.finished, 1, self.prior)
            if left is None:
                return None
            total += left
        return total

    def text(self, done_here: int, left_here: float | None) -> str:
        """'make report: step 2 of 4 (finer), runs 500/1244, eta 3m10s': the step running,
        the runs done of all, and the seconds left of all (``left_here`` the running
        sweep's; without it, or without a later one's, the ETA is left out)."""
        step = self.sweeps[min(self.index, len(self.sweeps) - 1)].step if self.sweeps else ""
        k = self.steps.index(step) + 1 if step in self.steps else 0
        text = (
            f"{self.title}: step {k} of {len(self.steps)} ({step}), "
            f"runs {self.done_before + done_here}/{self.total}"
        )
        later = self.later_seconds()
        if left_here is None or later is None:
            return text
        return f"{text}, eta {duration_text(left_here + later)}"


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
