"""How the report draws (issue 34, the report step): its figures in a FigurePool beside the
tables, every drawing finished before report.md lists the folder, the page's figures made
side by side as they would be one by one, and the page's numbers rounded as before.

Cost: about 10 s (two worker processes started four times, stability-only reports; a
fresh interpreter's fork server importing the drawing modules).
"""

from __future__ import annotations

import math
import os
import shutil
import signal
import subprocess
import sys
import time
from concurrent.futures import Future
from functools import partial
from pathlib import Path

import numpy as np
from test_stability import rows

from hoopbench.reports.report.drawing_processes import StartedDrawing, interruptible
from hoopbench.reports.report.markdown import FigurePool, write_markdown
from hoopbench.reports.report.page import _image_sources, page_fragments, page_jobs, write_page
from hoopbench.reports.report.page_html import rounded


def _seen(path: str, within_s: float = 20.0) -> bool:
    """Whether ``path`` appears within ``within_s`` (a liveness bound, not a measure)."""
    end = time.monotonic() + within_s
    while time.monotonic() < end:
        if Path(path).exists():
            return True
        time.sleep(0.02)
    return False


def test_a_submitted_drawing_runs_beside_the_caller(tmp_path):
    """The call waits for a file the caller makes only after submitting it: drawn here, at
    submit, it would never see it."""
    go = tmp_path / "go"
    with FigurePool(2) as pool:
        future = pool.submit(_seen, str(go))
        go.touch()
        assert future.result() is True
        assert [f.result() for f in [pool.submit(pow, 2, k) for k in range(4)]] == [1, 2, 4, 8]


class _Late(Future):
    """A drawing that finishes when its result is asked for: its file is there only if
    report.md waited for it."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = path

    def result(self, timeout: float | None = None) -> Path:
        self.path.write_bytes(b"GIF89a")
        return self.path


def test_report_md_lists_the_drawings_it_awaited(tmp_path):
    late = tmp_path / "hop-top.gif"
    text = write_markdown(rows(), tmp_path, generated="now", awaited=[_Late(late)]).read_text()
    files = text.split("\n## Files\n", 1)[1]
    assert "(hop-top.gif)" in files


def test_the_page_rounds_to_five_significant_digits():
    values = np.array([[1.234567, -0.000123456789], [math.nan, math.inf]])
    assert rounded(values) == [1.2346, -0.00012346, None, None]
    assert rounded([123456.7, -0.0, 2.5e-300], digits=2) == [120000.0, -0.0, 2.5e-300]
    assert [type(v) for v in rounded([1.0, 2])] == [float, float]


class RecordingPool(FigurePool):
    """A pool that notes what it is asked to make, by function name, in the order asked."""

    def __init__(self, workers: int = 2) -> None:
        super().__init__(workers)
        self.made: list[str] = []

    def submit(self, function, *args):
        self.made.append(function.__name__)
        return super().submit(function, *args)


def test_the_page_makes_its_figures_side_by_side_as_it_would_alone(tmp_path):
    """The figures report.md shows, made in the pool: the same page as made one by one."""
    alone, side = tmp_path / "alone", tmp_path / "side"
    alone.mkdir()
    write_markdown(rows(), alone, generated="now")
    shutil.copytree(alone, side)
    write_page(rows(), alone)
    with RecordingPool() as pool:
        write_page(rows(), side, pool=pool)
    assert pool.made == ["_figure_html"]  # the stability matrix: the one figure it shows
    assert (side / "report.html").read_text() == (alone / "report.html").read_text()


def test_the_page_knows_which_figures_report_md_shows():
    text = "\n".join(
        [
            "# r",
            "![a [b] c](one.png)",
            "",
            "| x | y |",
            "|---|---|",
            "| ![in a table](two.png) | 1 |",
            "",
            "`![code](three.png)` and \\![escaped](four.png)",
        ]
    )
    assert _image_sources(text) == {"one.png", "two.png"}


_IN_A_WORKER = """
import sys
from hoopbench.reports.report.markdown import DRAWING_MODULES, FigurePool
with FigurePool(2, preload=["hoopbench.reports.report.page"]) as pool:
    wanted = [*DRAWING_MODULES, "hoopbench.reports.report.page"]
    check = "[m for m in %r if m not in __import__('sys').modules]" % (wanted,)
    print(pool.submit(eval, check).result())
"""


def test_a_drawing_worker_starts_with_the_drawing_modules_imported():
    """Its fork server imported them once (each worker had imported them itself, about 2
    CPU-s each). In a fresh interpreter: a process has one fork server, and a sweep's may
    have started this one's. Some of them the call would import anyway (_draw_plain imports
    matplotlib.pyplot, which imports PIL.Image), not pyarrow.parquet, PIL.GifImagePlugin
    nor the caller's page module."""
    done = subprocess.run(
        [sys.executable, "-c", _IN_A_WORKER], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == "[]"


class DrawingPool(FigurePool):
    """A pool that notes what it draws (not what it is asked for), by function name."""

    def __init__(self, workers: int = 1) -> None:
        super().__init__(workers)
        self.drawn: list[str] = []

    def _submit(self, function, *args):
        self.drawn.append(function.__name__)
        return super()._submit(function, *args)


def test_the_page_s_figures_start_after_report_md_s_and_are_drawn_once(tmp_path):
    """build.py starts the page's figures with report.md's (write_markdown's ``then``), after
    all of them, so that the drawing processes go on with them while report.md is written;
    write_page, asking the pool for them again, gets those and draws nothing twice. The page
    is the one made without them. One process: each call drawn as submitted, in order."""
    alone, early = tmp_path / "alone", tmp_path / "early"
    alone.mkdir()
    early.mkdir()
    write_markdown(rows(), alone, generated="now")
    write_page(rows(), alone)
    fragments = page_fragments(rows(), (), ())
    with DrawingPool() as pool:
        then = list(page_jobs(fragments).values())
        write_markdown(rows(), early, generated="now", pool=pool, then=then)
        before_page = list(pool.drawn)
        write_page(rows(), early, pool=pool, fragments=fragments)
    assert before_page[:3] == ["_force_section", "_seed_section", "_stability_matrix_section"]
    assert before_page[3:] == ["_figure_html"] * len(then) and len(then) == 3
    assert pool.drawn == before_page  # nothing drawn twice
    assert (early / "report.html").read_text() == (alone / "report.html").read_text()


def _interrupted(started: str) -> str:
    """A drawing that runs until Ctrl-C reaches it (at most 20 s): how it ended."""
    with interruptible():
        Path(started).touch()
        try:
            time.sleep(20.0)
        except KeyboardInterrupt:
            return "interrupted"
    return "slept"


def _ready(folder: str) -> None:
    """A started drawing process's imports, here: its pid, as a file in ``folder``."""
    (Path(folder) / f"{os.getpid()}.pid").touch()


def _started_pids(folder: Path, processes: int) -> set[int]:
    """The pids of the started processes, once ``processes`` have started (a liveness bound
    of 60 s: a loaded machine's fork server may take 20)."""
    end = time.monotonic() + 60.0
    while len(list(folder.glob("*.pid"))) < processes and time.monotonic() < end:
        time.sleep(0.02)
    return {int(p.stem) for p in folder.glob("*.pid")}


def _alive(pid: int) -> bool:
    """Whether process ``pid`` runs (not gone, not a zombie its parent has yet to reap)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "\nState:\tZ" not in status


def test_drawing_processes_started_ahead_ignore_ctrl_c_until_they_draw(tmp_path):
    """report-runs --report starts the report's drawing processes while the map's last runs
    end: idle, Ctrl-C (which reaches the whole process group, during the sweeps too) leaves
    them alive, as the sweeps stop by their own handler; a report's drawing in them stops
    as it would in the report's own. The report's FigurePool draws in them, once taken."""
    started = StartedDrawing(ready=partial(_ready, str(tmp_path)), workers=2)
    started.start()
    assert started.lent() is not None
    pids = _started_pids(tmp_path, 2)
    assert len(pids) == 2
    for pid in pids:
        os.kill(pid, signal.SIGINT)
    time.sleep(0.5)  # an idle process with Python's own handler dies of it meanwhile
    assert all(_alive(pid) for pid in pids)
    with FigurePool(2, processes=started.take()) as pool:
        assert started.lent() is None and started.take() is None
        assert {pool.submit(os.getpid).result() for _ in range(8)} <= pids
        running = pool.submit(_interrupted, str(tmp_path / "started"))
        assert _seen(str(tmp_path / "started"), within_s=60.0)
        for pid in pids:
            os.kill(pid, signal.SIGINT)
        assert running.result(timeout=15.0) == "interrupted"
    started.close()  # taken: nothing to shut down


def test_a_section_s_figures_start_as_the_section_is_made(tmp_path, monkeypatch):
    """build.py: the searches' (and maps') figures are submitted when their section is made,
    so that a process the animation leaves free draws them while the report makes its next
    sections, not once report.md's own are queued. One process: each drawn as submitted."""
    from hoopbench.reports.report import build

    pools: list[RecordingPool] = []

    def recording(*args, **kwargs):
        pools.append(RecordingPool(1))
        return pools[-1]

    made_by_then: list[list[str]] = []
    write = build.write_markdown

    def markdown_seen(*args, **kwargs):
        made_by_then.append(list(pools[0].made))
        return write(*args, **kwargs)

    monkeypatch.setattr(build, "FigurePool", recording)
    monkeypatch.setattr(build, "write_markdown", markdown_seen)
    search = Path(__file__).parents[1] / "reports" / "tune" / "searches" / "pymunk"
    build.build_report([search], tmp_path / "out")
    assert made_by_then == [["_figure"]]  # the Best settings figure, drawn already
    assert (tmp_path / "out" / "best-settings-pymunk.png").stat().st_size > 0


def test_make_report_s_report_says_what_it_is_doing_in_a_log(monkeypatch):
    """report-runs --report (make report, its stderr a log): the report's lines follow the
    sweeps' progress lines there too; `hoopbench report` alone says them on a terminal only."""
    from hoopbench.reports.cli import _report_steps
    from hoopbench.reports.report.drawing_processes import started_drawing

    monkeypatch.setattr(sys.stderr, "isatty", lambda: False)
    assert _report_steps() is None
    token = started_drawing.set(StartedDrawing(_ready, workers=1))  # as report-runs sets it
    try:
        assert _report_steps() is not None
    finally:
        started_drawing.reset(token)
