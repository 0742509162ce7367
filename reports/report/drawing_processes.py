"""A report's drawing processes, started before the report needs them.

``hoopbench report-runs --report`` runs make report's report in its own process once the
sweeps end. It starts the report's drawing processes once the map's last runs are queued:
their start (a fork from the sweeps' fork server and the drawing modules' imports, about
1 CPU-s each) then runs while those runs end, not while the report's first figures wait for
it, and the map's own three figures are drawn in them side by side, not one after the other.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import contextmanager
from contextvars import ContextVar

__all__ = [
    "FIGURE_WORKERS",
    "StartedDrawing",
    "drawing_workers",
    "interruptible",
    "started_drawing",
]

FIGURE_WORKERS = 2
"""Processes that draw a report's figures (the machines this runs on have 2 cores)."""


def drawing_workers(workers: int = FIGURE_WORKERS) -> int:
    """The drawing processes ``workers`` asks for, on this machine's cores (at least 1: with
    1, each call is drawn in the caller)."""
    return max(1, min(workers, os.cpu_count() or 1))


class StartedDrawing:
    """Drawing processes started ahead of a report (mutable: started, lent, then taken once).
    Before the report they draw what it awaits from others (the map's figures: :meth:`lent`);
    the report's FigurePool then takes them (:meth:`take`) and shuts them down with itself;
    not taken (a step failed, a signal came), :meth:`close` does."""

    def __init__(self, ready: Callable[[], object], workers: int = FIGURE_WORKERS) -> None:
        self.ready = ready
        """Run once in each process as it starts: the imports its drawings will need (a
        module-level function: it is pickled)."""
        self.workers = drawing_workers(workers)
        self._processes: ProcessPoolExecutor | None = None
        self._closed = False
        self._lock = threading.Lock()

    def start(self) -> None:
        """Start the processes, each running ``ready`` (none with fewer than 2 workers: the
        report then draws in its own process; none once taken or closed)."""
        with self._lock:
            if self._processes is not None or self._closed or self.workers < 2:
                return
            context = multiprocessing.get_context("forkserver")
            processes = ProcessPoolExecutor(
                max_workers=self.workers,
                mp_context=context,
                initializer=_started,
                initargs=(self.ready,),
            )
            try:
                for _ in range(self.workers):  # a process starts per call, up to workers
                    processes.submit(os.getpid)
            except OSError:  # no process could start: the report will say so, starting its own
                processes.shutdown(wait=False, cancel_futures=True)
                return
            self._processes = processes

    def lent(self) -> ProcessPoolExecutor | None:
        """The processes, for drawings awaited before the report; None when not started, or
        taken."""
        with self._lock:
            return self._processes

    def take(self) -> ProcessPoolExecutor | None:
        """The processes (None when not started), once: from then on the taker shuts them
        down, and nothing starts them again."""
        with self._lock:
            processes, self._processes, self._closed = self._processes, None, True
            return processes

    def close(self) -> None:
        """Shut the processes down unless they were taken."""
        processes = self.take()
        if processes is not None:
            processes.shutdown(wait=True, cancel_futures=True)


_drawing = False
"""A drawing call runs in this process (:func:`interruptible`)."""


def _started(ready: Callable[[], object]) -> None:
    """A started drawing process's first act: Ctrl-C, which reaches the whole process group,
    interrupts only its drawing calls (:func:`interruptible`: a report's, as in the report's
    own processes); idle, or drawing the map's figures during the sweeps, it ignores it (the
    sweeps' signal handler stops them: the map's figures are finished, as they were before)."""
    signal.signal(signal.SIGINT, _interrupt_a_drawing)
    ready()


def _interrupt_a_drawing(signum: int, frame: object) -> None:
    if _drawing:
        raise KeyboardInterrupt


@contextmanager
def interruptible() -> Iterator[None]:
    """Within: a drawing call that Ctrl-C interrupts, in a started process too (elsewhere
    Python's own handler does already)."""
    global _drawing
    was, _drawing = _drawing, True
    try:
        yield
    finally:
        _drawing = was


started_drawing: ContextVar[StartedDrawing | None] = ContextVar("started_drawing", default=None)
"""The drawing processes started for the report to come (report-runs --report sets it), else
None: a report starts its own at its first figure."""
