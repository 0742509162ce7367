"""``hoopbench tune``: a search over one engine's settings, error against cost, with Optuna.

Each trial draws a setting from the engine's declared space (space.py), runs it on every
training scene through the runner as ordinary runs (worker processes or a Dask cluster, time
limits, batches for an engine that steps many worlds at once, as ``compare`` runs them; rows
in ``trials/``, variant ``trial-N``), and scores them with engines/judging/score.py: the mean
error and the cost in us per simulated second, by the process's CPU time (the wall time kept
beside it); the clock is recorded in tune.json (``cost_clock``), and a search made before it
was recorded, scored by wall time, keeps that clock when resumed. Optuna's journal file
(``journal.log``) keeps every told trial, so a search stopped by Ctrl-C or by its budget goes
on with ``resume``. The first trial is hoopbench's ``tuned`` setting; ``stock`` and ``tuned``
also run as baselines. When the budget is spent, the Pareto set (and the baselines) run again
on held-out scenes (heldout.py) and the folder gets ``front.csv`` and ``settings.toml``.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import math
import signal
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import Executor
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import pandas as pd

from hoopbench.engines.judging.score import CostClock, cost_us_per_s, error_score
from hoopbench.engines.options import Profile
from hoopbench.engines.registry import engine_class
from hoopbench.engines.settings import DEFAULT_BATCH_SIZE, DEFAULT_TIMESTEP
from hoopbench.models.scene import Scene
from hoopbench.reports.compare.rows import FORMAT_VERSION
from hoopbench.reports.compare.suite import (
    batch_affinity,
    batch_key,
    batch_least,
    failure_row,
    run_task,
    run_task_batch,
    run_timeout,
    runs_frame,
)
from hoopbench.reports.compare.suite_file import DEFAULT_VARIANT, RunTask, Suite, VariantSpec
from hoopbench.reports.sweep import results
from hoopbench.reports.sweep.folder_files import (
    MAX_DATA_BYTES,
    folder_file,
    read_folder_bytes,
    read_folder_text,
)
from hoopbench.reports.sweep.runner import (
    Batching,
    RunnerError,
    RunSummary,
    WorkerPool,
    claim_folder,
    run_tasks,
)
from hoopbench.reports.tune.space import draw_settings, trial_params

if TYPE_CHECKING:  # Optuna is an extra (tune): imported when a search runs (_optuna)
    import optuna
    from optuna.trial import FrozenTrial

__all__ = [
    "COST_CLOCK_KEY",
    "DEFAULT_TRAINING_SCENES",
    "FRONT_NAME",
    "HELDOUT_DIR",
    "JOURNAL_NAME",
    "RESULT_NAMES",
    "SETTINGS_HASH_NAME",
    "SETTINGS_NAME",
    "SPEC_NAME",
    "TRIALS_DIR",
    "TRIALS_NAME",
    "Budget",
    "NoTrialError",
    "Runner",
    "SearchRecordError",
    "SearchResult",
    "Setting",
    "TuneSpec",
    "TuneUnavailableError",
    "check_resumable",
    "recorded_clock",
    "run_settings",
    "search",
    "setting_of",
    "setting_tasks",
    "settings_hash",
    "trials_frame",
]

DEFAULT_TRAINING_SCENES = (
    "seed-mu",
    "hop-top",
    "hop-low",
    "hop-bottom",
    "high-spin",
    "low-friction",
    "slip-reversal",
)
"""The catalogue scenes a search trains on by default: every one with events to time (seed
has mus != muk, which the engines cannot run; massless is degenerate; painleve ends at a
Painlevé point; seed-pi is seed-mu's postscript with mus != muk)."""

JOURNAL_NAME = "journal.log"
SPEC_NAME = "tune.json"
TRIALS_DIR = "trials"
HELDOUT_DIR = "heldout"
FRONT_NAME = "front.csv"
TRIALS_NAME = "trials.csv"
SETTINGS_NAME = "settings.toml"
SETTINGS_HASH_NAME = ".settings.toml.sha256"
"""The sha256 of the settings.toml the search last wrote: a resume that would replace a
settings.toml edited since is refused (the user's edits are not lost without a word)."""
RESULT_NAMES = (FRONT_NAME, TRIALS_NAME, SETTINGS_NAME, TRIALS_DIR, HELDOUT_DIR)
"""What a search that ran leaves besides its record (journal.log, tune.json, sweep.json)."""
COST_CLOCK_KEY = "cost_clock"
"""tune.json's key naming the clock of the search's costs (CostClock's value); a search made
before it has none: its costs are wall time."""
NEW_SEARCH_CLOCK = CostClock.CPU
"""The clock of a new search's costs: the CPU time moves far less with the machine's load."""
WALL_ATTR = "wall_us_per_s"
"""A told trial's user attribute: its wall time per simulated second, kept beside its cost
(None where no run gave one)."""
TRIAL_PREFIX = "trial-"
STUDY_NAME = "tune"


class TuneUnavailableError(RuntimeError):
    """Optuna is not installed."""


def _optuna() -> ModuleType:
    """Optuna, or TuneUnavailableError saying how to install it."""
    try:
        import optuna
        import optuna.storages.journal
    except ImportError:
        raise TuneUnavailableError(
            "hoopbench tune needs Optuna: pip install 'hoopbench[tune]'"
        ) from None
    return optuna


@dataclass(frozen=True)
class TuneSpec:
    """What a search is: a resumed search must be the same one."""

    engine: str
    scenes: tuple[Scene, ...]
    """The training scenes."""
    seed: int = 0
    """The sampler's seed."""
    heldout_seed: int = 20_261_128
    """The seed of the held-out scenes' draw (heldout.py); the search never sees it."""
    heldout_per_regime: int = 1
    """Held-out scenes drawn per regime (rolls, slips, slip reversals, hops)."""
    heldout_neighbours: int = 1
    """Held-out neighbours drawn per training scene (heldout.py): a search folder made before
    they existed has no such key and resumes with any value."""

    def __post_init__(self) -> None:
        # Checked when the search is described, before its folder is made: two equal
        # scenes were refused only after tune.json, sweep.json and journal.log were
        # written, as "run_id '58bd...' appears twice".
        names = [s.name for s in self.scenes if s.name]
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice or len(set(self.scenes)) < len(self.scenes):
            shown = ", ".join(map(repr, twice)) or "the same scene"
            raise ValueError(f"scenes: {shown} given twice: give each training scene once")

    def identity(self) -> dict[str, Any]:
        return {
            "kind": "tune",
            "engine": self.engine,
            "scenes": [s.to_dict() for s in self.scenes],
            "seed": self.seed,
            "heldout_seed": self.heldout_seed,
            "heldout_per_regime": self.heldout_per_regime,
            "heldout_neighbours": self.heldout_neighbours,
        }


@dataclass(frozen=True)
class Budget:
    trials: int | None = None
    """Trials told in all (a resumed search counts the earlier ones); None: no limit."""
    timeout_s: float | None = None
    """Seconds this session may start new trials for; None: no limit."""
    run_timeout_s: float | None = None
    """Time limit of one run, s; None: the suites' (60 s + 0.5 ms a step)."""


@dataclass(frozen=True)
class Setting:
    """A setting of the search: a trial's, or a baseline profile's (stock, tuned)."""

    name: str
    """``trial-N``, ``stock`` or ``tuned``."""
    timestep: float
    options: Mapping[str, Any]
    profile: Profile = Profile.TUNED
    train_error: float | None = None
    train_cost: float | None = None
    """us per simulated second, by the search's clock (its tune.json's cost_clock)."""
    train_wall: float | None = None
    """The same by the wall clock, kept beside it (None: not recorded)."""
    extra: Mapping[str, Any] = field(default_factory=dict)

    @property
    def variant(self) -> str:
        return DEFAULT_VARIANT if self.name in (str(p) for p in Profile) else self.name


def setting_tasks(engine: str, scenes: Sequence[Scene], setting: Setting) -> list[RunTask]:
    """The runs of one setting on some scenes, as a suite builds them (a suite's run ids)."""
    if setting.variant == DEFAULT_VARIANT:
        suite = Suite("tune", (engine,), (setting.timestep,), tuple(scenes), (), (setting.profile,))
        return suite.tasks()
    spec = VariantSpec(
        engine,
        setting.variant,
        options=setting.options,
        timesteps=(setting.timestep,),
        profile=setting.profile,
    )
    suite = Suite("tune", (engine,), (setting.timestep,), tuple(scenes), (spec,), (Profile.TUNED,))
    return [t for t in suite.tasks() if t.variant == setting.variant]


@dataclass(frozen=True)
class Runner:
    """Where and how a search's runs go: as a suite's runs go in ``compare``."""

    executor: Executor
    """The local WorkerPool, or a Dask cluster's executor (reports/sweep/cluster.py)."""
    engine: str
    run_timeout_s: float | None = None
    """Time limit of one run, s; None: the suites' (60 s + the engine's step cost bound)."""
    batch_size: int = DEFAULT_BATCH_SIZE
    """Runs per batch for an engine that steps many worlds at once (compare's batch_key:
    one setting's scenes share batches); 1: every run alone."""


def run_settings(
    tasks: Sequence[RunTask], out: Path, runner: Runner
) -> tuple[RunSummary, list[dict[str, Any]]]:
    """Run the tasks into ``out`` (resumed: stored runs are not run again) and return their
    rows."""
    meta = {
        results.FORMAT_KEY: FORMAT_VERSION,
        "engine_versions": {runner.engine: engine_class(runner.engine)().version()},
    }
    limit = run_timeout if runner.run_timeout_s is None else runner.run_timeout_s
    batching = Batching(run_task_batch, batch_key, runner.batch_size, batch_least, batch_affinity)
    summary = run_tasks(
        tasks,
        run_task,
        out,
        failure_row=failure_row,
        timeout=limit,
        executor=runner.executor,
        resume=True,
        meta=meta,
        quiet=True,
        batching=batching if runner.batch_size > 1 else None,
    )
    ids = {t.run_id for t in tasks}
    frame = runs_frame(out)
    rows = frame[frame["run_id"].isin(ids)].to_dict("records")
    return summary, rows


class _Replayed:
    """A told trial's parameters, asked again as draw_settings asks a live trial: each must lie
    in the engine's space as declared today (Optuna's FixedTrial only warns, so a journal line
    edited to a timestep of 5 s would reach the settings file)."""

    def __init__(self, number: int, params: Mapping[str, Any]) -> None:
        self.number = number
        self.params = params

    def _value(self, name: str) -> Any:
        if name not in self.params:
            raise ValueError(self._outside(name, "missing", "the engine's search space"))
        return self.params[name]

    def _outside(self, name: str, value: Any, space: str) -> str:
        return (
            f"{JOURNAL_NAME}: trial {self.number}'s {name} = {value} is not in {space}: the "
            "journal was edited or comes from another search space; it is not used"
        )

    def suggest_categorical(self, name: str, choices: Sequence[Any]) -> Any:
        value = self._value(name)
        if not any(value == c and isinstance(value, bool) == isinstance(c, bool) for c in choices):
            raise ValueError(self._outside(name, repr(value), f"its choices {list(choices)}"))
        return value

    def suggest_int(self, name: str, low: int, high: int, log: bool = False) -> int:
        value = self._value(name)
        if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
            raise ValueError(self._outside(name, repr(value), f"[{low}, {high}]"))
        return value

    def suggest_float(self, name: str, low: float, high: float, log: bool = False) -> float:
        value = self._value(name)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(self._outside(name, repr(value), f"[{low:g}, {high:g}]"))
        if not low <= value <= high:  # NaN too
            raise ValueError(self._outside(name, f"{value:g}", f"[{low:g}, {high:g}]"))
        return float(value)


def setting_of(engine: str, trial: FrozenTrial, clock: CostClock) -> Setting:
    """A told trial's setting (its options replayed from its parameters) in a search whose
    costs are by ``clock``; ValueError naming the trial and parameter if one lies outside the
    engine's space."""
    replayed: Any = _Replayed(trial.number, trial.params)
    options, timestep = draw_settings(replayed, engine_class(engine))
    values = trial.values or [None, None]
    return Setting(
        f"{TRIAL_PREFIX}{trial.number}",
        timestep,
        options,
        Profile.TUNED,
        values[0],
        values[1],
        _trial_wall(trial, clock),
    )


def _trial_wall(trial: FrozenTrial, clock: CostClock) -> float | None:
    """A told trial's wall cost, us per simulated s: kept beside its cost, or its cost itself
    in a wall-clock search (whose trials, made before the attribute, have none)."""
    wall = trial.user_attrs.get(WALL_ATTR)
    if isinstance(wall, int | float) and not isinstance(wall, bool):
        return float(wall)
    if clock is CostClock.WALL and trial.values:
        return float(trial.values[1])
    return None


COUNTED_FAILURES = ("refused", "failed_runs")
"""User attributes of a failed trial that counts toward the budget (the setting was tried);
a trial cut short by a signal has neither and does not count."""


def _finished(study: optuna.Study) -> int:
    """Trials that count toward the budget: told with values, or failed after a real try."""
    state = _optuna().trial.TrialState
    return sum(
        t.state is state.COMPLETE
        or (t.state is state.FAIL and any(k in t.user_attrs for k in COUNTED_FAILURES))
        for t in study.get_trials(deepcopy=False)
    )


def _journal_lines_checked(out: Path) -> None:
    """Every line of the journal a whole JSON object (Optuna's own replay skips a broken last
    line, then appends after it and can never read the journal again). Read through
    folder_files: a regular file inside the folder (a link out of it, a FIFO or a huge file is
    refused, FolderFileError), or not there yet."""
    data = read_folder_bytes(out, JOURNAL_NAME, MAX_DATA_BYTES)
    for number, line in enumerate((data or b"").splitlines(keepends=True), start=1):
        try:
            entry = json.loads(line) if line.endswith(b"\n") else None
        except ValueError:  # not JSON, not UTF-8
            entry = None
        if not isinstance(entry, dict):
            raise _unreadable_journal(out, f"line {number} is not a whole JSON object")


def _unreadable_journal(out: Path, why: str) -> ValueError:
    return ValueError(
        f"{out / JOURNAL_NAME}: {why}: not a journal Optuna can replay; the search is not "
        "resumed from it and it is unchanged (restore it, or start a new search in another "
        "folder)"
    )


def _open_study(spec: TuneSpec, out: Path, resume: bool, clock: CostClock) -> optuna.Study:
    optuna = _optuna()
    TrialState = optuna.trial.TrialState
    _journal_lines_checked(out)
    backend = optuna.storages.journal.JournalFileBackend(str(out / JOURNAL_NAME))
    try:  # Optuna replays the whole journal here, reading only: an entry it cannot apply fails
        storage = optuna.storages.JournalStorage(backend)
        storage.get_all_studies()
    except (ValueError, KeyError, TypeError, IndexError, AssertionError) as exc:
        # a missing key, an unknown op code (AssertionError "Should not reach.")
        raise _unreadable_journal(
            out, f"{type(exc).__name__}: {' '.join(str(exc).split())}"
        ) from None
    sampler = optuna.samplers.TPESampler(seed=spec.seed, n_startup_trials=5)
    study = optuna.create_study(
        study_name=STUDY_NAME,
        storage=storage,
        sampler=sampler,
        directions=["minimize", "minimize"],
        load_if_exists=resume,
    )
    for told in study.get_trials(deepcopy=False, states=(TrialState.COMPLETE,)):
        setting_of(spec.engine, told, clock)  # refused before anything runs if not the engine's
    for stale in study.get_trials(deepcopy=False, states=(TrialState.RUNNING,)):
        study.tell(stale.number, state=TrialState.FAIL)  # cut short by an earlier Ctrl-C
    if not study.trials:
        cls = engine_class(spec.engine)
        study.enqueue_trial(trial_params(cls, cls.defaults(Profile.TUNED), DEFAULT_TIMESTEP))
    return study


def _one_trial(
    study: optuna.Study, spec: TuneSpec, out: Path, runner: Runner, clock: CostClock
) -> RunSummary | None:
    """Ask, run and tell one trial, its cost by ``clock`` (its wall cost kept beside it as a
    user attribute); the runs' summary (None if the setting was refused)."""
    TrialState = _optuna().trial.TrialState
    trial = study.ask()
    try:
        options, timestep = draw_settings(trial, engine_class(spec.engine))
        setting = Setting(f"{TRIAL_PREFIX}{trial.number}", timestep, options)
        tasks = setting_tasks(spec.engine, spec.scenes, setting)
    except ValueError as exc:  # a combination the engine's own checks refuse
        trial.set_user_attr("refused", str(exc))
        study.tell(trial, state=TrialState.FAIL)
        return None
    try:
        summary, rows = run_settings(tasks, out / TRIALS_DIR, runner)
    except BaseException:
        study.tell(trial, state=TrialState.FAIL)
        raise
    cost = cost_us_per_s(rows, clock)
    if summary.interrupted is not None or len(rows) < len(tasks):
        study.tell(trial, state=TrialState.FAIL)  # cut short: does not count, tried again
        return summary
    if cost is None:  # no run gave a time: every one failed
        trial.set_user_attr("failed_runs", len(rows))
        study.tell(trial, state=TrialState.FAIL)
        return summary
    trial.set_user_attr(WALL_ATTR, cost_us_per_s(rows, CostClock.WALL))
    study.tell(trial, [error_score(rows), cost])
    return summary


def _budget_left(study: optuna.Study, budget: Budget, started: float) -> bool:
    if budget.trials is not None and _finished(study) >= budget.trials:
        return False
    return budget.timeout_s is None or time.monotonic() - started < budget.timeout_s


@dataclass(frozen=True)
class SearchResult:
    study: optuna.Study
    interrupted: bool
    baselines: tuple[Setting, ...]
    cost_clock: CostClock
    """The clock of the search's costs (its tune.json's)."""


def _baselines(
    spec: TuneSpec, out: Path, runner: Runner, clock: CostClock
) -> tuple[tuple[Setting, ...], bool]:
    """stock and tuned on the training scenes (at the default timestep), their costs by
    ``clock`` and by the wall clock, and whether a signal stopped them."""
    settings: list[Setting] = []
    cls = engine_class(spec.engine)
    for profile in (Profile.STOCK, Profile.TUNED):
        base = Setting(str(profile), DEFAULT_TIMESTEP, cls.defaults(profile), profile)
        tasks = setting_tasks(spec.engine, spec.scenes, base)
        summary, rows = run_settings(tasks, out / TRIALS_DIR, runner)
        if summary.interrupted is not None:
            return tuple(settings), True
        settings.append(
            Setting(
                base.name,
                base.timestep,
                base.options,
                profile,
                error_score(rows),
                cost_us_per_s(rows, clock),
                cost_us_per_s(rows, CostClock.WALL),
            )
        )
    return tuple(settings), False


@contextlib.contextmanager
def _signals_noted() -> Iterator[list[int]]:
    """SIGINT and SIGTERM between two trials' runs are noted (the list gets the signal), not
    raised: a KeyboardInterrupt inside Optuna's journal lock would leave it half released (its
    own cleanup then fails on the lock file it has just removed). The runner installs its own
    handler during the runs and puts this one back."""
    noted: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        yield noted
        return
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    for sig in previous:
        signal.signal(sig, lambda signum, frame: noted.append(signum))
    try:
        yield noted
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, signal.SIG_DFL if handler is None else handler)


def search(
    spec: TuneSpec,
    out: str | Path,
    budget: Budget,
    *,
    resume: bool = False,
    jobs: int = 2,
    executor: Executor | None = None,
    batch_size: int = DEFAULT_BATCH_SIZE,
    say: Callable[[str], None] | None = None,
    then: Callable[[SearchResult, Runner], None] | None = None,
) -> SearchResult:
    """Run (or go on with) the search into ``out``; ``then(result, runner)`` runs in the same
    folder claim and with the same executor once the budget is spent (the held-out
    validation). ``executor``: a Dask cluster's (else a local pool of ``jobs`` workers)."""
    out = Path(out)
    optuna = _optuna()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    if resume:
        check_resumable(out, spec)  # before the claim: a refused folder gets nothing
    with claim_folder(out, resume, spec.identity(), say):
        if resume:
            check_resumable(out, spec)  # again under the lock
        _write_spec(out, spec)
        clock = _stored_clock(out)
        study = _open_study(spec, out, resume, clock)
        started = time.monotonic()
        with _executor(executor, jobs) as runs_on, _signals_noted() as noted:
            runner = Runner(runs_on, spec.engine, budget.run_timeout_s, batch_size)
            try:
                baselines, stopped = _baselines(spec, out, runner, clock)
                while not stopped and not noted and _budget_left(study, budget, started):
                    summary = _one_trial(study, spec, out, runner, clock)
                    stopped = summary is not None and summary.interrupted is not None
                    if say is not None and not stopped:
                        say(_progress(study, clock))
                stopped = stopped or bool(noted)
            except KeyboardInterrupt:  # a signal where no handler of ours was installed
                baselines, stopped = (), True
            if not stopped:
                _check_a_trial_ran(study, budget, time.monotonic() - started)
            result = SearchResult(study, stopped, baselines, clock)
            if then is not None and not stopped:
                then(result, runner)
    return result


class NoTrialError(RunnerError):
    """The budget ended before the search started any trial: a front of the baselines alone
    would read as a finished search."""


def _check_a_trial_ran(study: optuna.Study, budget: Budget, elapsed_s: float) -> None:
    """NoTrialError if no trial was ever started in the folder (the first, tuned's, is
    queued from the start): the timeout was spent on the baselines."""
    waiting = _optuna().trial.TrialState.WAITING
    if budget.timeout_s is None or any(
        t.state is not waiting for t in study.get_trials(deepcopy=False)
    ):
        return
    raise NoTrialError(
        f"the timeout ({budget.timeout_s:g} s) ended before the first trial: the baselines "
        f"(stock and tuned) took {elapsed_s:.0f} s; nothing was validated; resume with a "
        "longer timeout, or a number of trials"
    )


@contextlib.contextmanager
def _executor(executor: Executor | None, jobs: int) -> Iterator[Executor]:
    """``executor`` as it is (a cluster's: not ours to shut down), or a local worker pool for
    the whole search (its workers keep their imports and compiled kernels between trials)."""
    if executor is not None:
        yield executor
        return
    with WorkerPool(jobs, preload=["hoopbench.reports.compare.suite"]) as pool:
        yield pool


def _progress(study: optuna.Study, clock: CostClock) -> str:
    last = study.trials[-1]
    if last.state is not _optuna().trial.TrialState.COMPLETE or last.values is None:
        return f"trial {last.number}: {last.state.name.lower()}"
    error, cost = last.values
    return (
        f"trial {last.number}: error {error:.3g}, cost {cost:.3g} {clock.label} us per simulated s"
    )


class SearchRecordError(RunnerError):
    """A search folder that cannot be resumed as asked: its record is not whole, it holds
    another search, or resuming would replace what the user wrote."""


def check_resumable(out: Path, spec: TuneSpec) -> None:
    """SearchRecordError unless ``out`` is nothing yet or a search that ``spec`` can go on
    with: no link where the search writes a folder; journal.log and tune.json there once it
    has results (a compact copy, as shipped under reports/tune/searches, keeps only its
    results: resumed, a new search would replace them); tune.json naming this search; the
    settings file as the search wrote it. Nothing is written."""
    if not out.is_dir():
        return
    for name in (TRIALS_DIR, HELDOUT_DIR):
        if (out / name).is_symlink() or ((out / name).exists() and not (out / name).is_dir()):
            raise SearchRecordError(
                f"{out / name} is not a folder of the search (a link or a file): a resume "
                "writes its runs there; remove it, or resume a copy of the search"
            )
    has_results = any((out / name).exists() for name in RESULT_NAMES)
    journal = folder_file(out, JOURNAL_NAME, MAX_DATA_BYTES)
    if journal is None and has_results:
        raise SearchRecordError(
            f"{out} holds no {JOURNAL_NAME} (a compact copy of a search keeps only its results): "
            "it cannot be resumed; start a new search in another folder (--out)"
        )
    text = read_folder_text(out, SPEC_NAME)
    if text is None:
        if journal is not None:
            raise SearchRecordError(
                f"{out} holds no {SPEC_NAME}: which search its journal belongs to is not "
                "known, so it cannot be resumed; start a new search in another folder (--out)"
            )
        return
    _check_same_search(out, spec, text)
    _check_settings_unedited(out)


def _check_same_search(out: Path, spec: TuneSpec, text: str) -> None:
    try:
        stored = json.loads(text)
    except ValueError:
        stored = None
    if not isinstance(stored, dict):
        raise SearchRecordError(f"{out / SPEC_NAME} is not a JSON object: cannot be resumed")
    asked = spec.identity()
    differ = [k for k in asked if k in stored and stored[k] != asked[k]]
    if not differ:
        return
    said = ", ".join(
        f"{k} {stored[k]!r} (asked: {asked[k]!r})" if k != "scenes" else "its scenes"
        for k in differ
    )
    raise SearchRecordError(
        f"{out} holds another search ({said} differ, says {SPEC_NAME}): resume it with its own "
        "options, or start a new search in another folder"
    )


def settings_hash(text: str) -> str:
    """The sha256 recorded for a settings file the search writes."""
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _check_settings_unedited(out: Path) -> None:
    """SearchRecordError if settings.toml differs from the file the search last wrote (a
    search made before the hash was kept cannot tell, and goes on)."""
    recorded = read_folder_text(out, SETTINGS_HASH_NAME)
    current = read_folder_bytes(out, SETTINGS_NAME)
    if recorded is None or current is None:
        return
    if hashlib.sha256(current).hexdigest() != recorded.strip():
        raise SearchRecordError(
            f"{out / SETTINGS_NAME} was edited after the search wrote it, and a resume "
            "rewrites it: move your copy elsewhere (compare and simulate read it from any "
            "folder) and resume again"
        )


def _write_spec(out: Path, spec: TuneSpec) -> None:
    """tune.json: a new search's; a resumed one's keeps what it recorded and gains the keys
    of options added since it was made (their values this session's)."""
    text = read_folder_text(out, SPEC_NAME)  # checked, not followed out of the folder
    if text is None:
        data = {
            **spec.identity(),
            COST_CLOCK_KEY: str(NEW_SEARCH_CLOCK),
            "created": datetime.now(UTC).isoformat(timespec="seconds"),
        }
    else:
        try:
            stored = json.loads(text)
        except ValueError:
            return  # not ours to overwrite: the report names what is wrong with it
        if not isinstance(stored, dict):
            return
        missing = {k: v for k, v in spec.identity().items() if k not in stored}
        if not missing:
            return
        data = {**stored, **missing}
    results.atomic_write(
        out / SPEC_NAME, lambda tmp: tmp.write_text(json.dumps(data, indent=2) + "\n")
    )


def recorded_clock(stored: Mapping[str, Any]) -> CostClock:
    """The clock of a search's costs from its tune.json (a JSON object): its cost_clock, or
    the wall clock where it has none (every search made before the key, as every shipped
    one, was scored by wall time); ValueError for a value that is no clock."""
    value = stored.get(COST_CLOCK_KEY, str(CostClock.WALL))
    if not isinstance(value, str) or value not in {str(c) for c in CostClock}:
        known = " or ".join(repr(str(c)) for c in CostClock)
        raise ValueError(f"{COST_CLOCK_KEY} must be {known}, got {value!r}")
    return CostClock(value)


def _stored_clock(out: Path) -> CostClock:
    """The clock of the search in ``out`` (its tune.json, written or checked just before):
    a resumed search keeps its own, so one study never mixes clocks."""
    text = read_folder_text(out, SPEC_NAME)
    try:
        stored = json.loads(text) if text is not None else None
    except ValueError:
        stored = None
    if not isinstance(stored, dict):
        raise SearchRecordError(f"{out / SPEC_NAME} is not a JSON object: cannot be resumed")
    try:
        return recorded_clock(stored)
    except ValueError as exc:
        raise SearchRecordError(f"{out / SPEC_NAME}: {exc}") from None


def trials_frame(study: optuna.Study, clock: CostClock) -> pd.DataFrame:
    """One line per trial: number, state, error, cost (by ``clock``), wall cost and
    parameters."""
    lines = []
    for trial in study.get_trials(deepcopy=False):
        values = trial.values or [math.nan, math.nan]
        wall = _trial_wall(trial, clock)
        lines.append(
            {
                "trial": trial.number,
                "state": trial.state.name.lower(),
                "train_error": values[0],
                "train_cost_us_per_s": values[1],
                "train_wall_us_per_s": math.nan if wall is None else wall,
                "params": json.dumps(trial.params, sort_keys=True),
            }
        )
    return pd.DataFrame(lines)
