"""Engine releases: one engine's runs on another release than the installed one.

A suite's ``[engine_versions]`` (``mujoco = ["3.3.7", "4.0.0"]``) or ``hoopbench compare
--engine-version mujoco==3.3.7`` runs that engine on each release named. Each release lives in
its own cached folder, built from the package index on first use and reused after, keyed by
engine, release and Python (:func:`env_dir`: ``$XDG_CACHE_HOME/hoopbench/engines/
mujoco-3.3.7-py311``; ``HOOPBENCH_ENGINE_CACHE`` moves the root). A run of a release goes to
a child process (:mod:`hoopbench.reports.compare.release_child`) that puts the folder first
on ``sys.path`` before the engine is imported, so hoopbench's own adapter loads against that
release while numpy, scipy and the rest stay the main environment's.

Why a folder and not a virtual environment per release: ``pip install --target`` of the
engine alone is 3-10 s and 17-22 MB for a MuJoCo 3.x release, 65 MB for 4.0.0 with its parts
(measured, 2026-11-28), where a venv would need hoopbench's whole stack beside each release
(not measured); and the rows must be judged by the same hoopbench, numpy and scipy for every
release, so that only the engine differs. What the folder gets
(:func:`install`): the engine's distribution, and each of its requirements that the main
environment lacks or does not satisfy, or that pins one release (``mujoco-core==4.0.0``: the
release's own parts), never one of hoopbench's own requirements (numpy, ...): a release that
needs another numpy says so in its probe instead of replacing the one the rows are judged with.

A release that cannot be installed, imported, or run by the adapter is one line
(:class:`ReleaseUnusableError`), found before the sweep by :func:`probe`; its runs are left out
and the other releases run.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import pickle
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass
from importlib.metadata import PackageNotFoundError, PathDistribution, requires
from importlib.metadata import version as installed_version
from pathlib import Path
from typing import Any

from packaging.requirements import InvalidRequirement, Requirement
from packaging.utils import canonicalize_name

from hoopbench.engines.registry import engine_class, engine_names

__all__ = [
    "CACHE_ENV",
    "Release",
    "ReleaseUnusableError",
    "cache_root",
    "ensure_env",
    "env_dir",
    "parse_release",
    "probe",
    "release_variant",
    "run_in_release",
]

CACHE_ENV = "HOOPBENCH_ENGINE_CACHE"
"""Environment variable: the folder holding the releases' folders (else the user cache)."""

PYTHON_TAG = f"py{sys.version_info.major}{sys.version_info.minor}"
"""The Python a release folder is built for: its wheels are this Python's."""

DONE_NAME = ".hoopbench-release.json"
"""Written last into a release folder: what it holds; a folder without it is rebuilt."""

PIP_TIMEOUT_S = 600.0
"""A pip install that takes longer is a failure of that release (a build from source)."""

RELEASE_PREFIX = "release="
"""A release's runs are the variant ``release=VERSION`` of the engine's defaults."""

MAX_EXTRA_PACKAGES = 12
"""Requirements installed beside an engine, at most: a release wanting more is refused."""

_VERSION = re.compile(r"^[0-9][0-9A-Za-z.+!-]*$")


class ReleaseUnusableError(RuntimeError):
    """A release that cannot run here: one line naming the release and what is missing."""


@dataclass(frozen=True)
class Release:
    """One engine at one release of its package."""

    engine: str
    version: str

    @property
    def spec(self) -> str:
        """``ENGINE==VERSION``, as given on the command line."""
        return f"{self.engine}=={self.version}"

    @property
    def distribution(self) -> str:
        """The package the index holds the engine under (the adapter's distribution)."""
        return engine_class(self.engine).distribution

    @property
    def variant(self) -> str:
        return release_variant(self.version)


def release_variant(version: str) -> str:
    """The variant name of a release's runs (the run's key holds it: resume and isolation)."""
    return f"{RELEASE_PREFIX}{version}"


def check_version(engine: str, version: Any, where: str) -> Release:
    """A Release from an engine name and a version string; ValueError naming ``where``."""
    if engine not in engine_names():
        raise ValueError(f"{where}: unknown engine {engine!r}; known: {', '.join(engine_names())}")
    if engine == "reference":
        raise ValueError(f"{where}: the reference is hoopbench's own: it has no releases")
    if not isinstance(version, str) or not _VERSION.match(version):
        raise ValueError(f"{where}: a release is a version like '3.3.7', got {version!r}")
    return Release(engine, version)


def parse_release(text: str) -> Release:
    """``ENGINE==VERSION`` (``--engine-version``); ValueError for anything else."""
    engine, sep, version = text.partition("==")
    if not sep:
        raise ValueError(f"--engine-version: give ENGINE==VERSION (mujoco==3.3.7), got {text!r}")
    return check_version(engine.strip(), version.strip(), "--engine-version")


# --------------------------------------------------------------------------- the folders
def cache_root() -> Path:
    """Where the releases' folders are: $HOOPBENCH_ENGINE_CACHE, else
    $XDG_CACHE_HOME/hoopbench/engines, else ~/.cache/hoopbench/engines."""
    own = os.environ.get(CACHE_ENV)
    if own:
        return Path(own)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "hoopbench" / "engines"


def env_dir(release: Release) -> Path:
    """The folder of one release: engine, version and Python in its name."""
    return cache_root() / f"{release.engine}-{release.version}-{PYTHON_TAG}"


@contextlib.contextmanager
def _locked(path: Path) -> Iterator[None]:
    """Hold ``path`` (a lock file) while a release folder is built: two workers of one sweep,
    or two sweeps, asking for the same release build it once."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def ensure_env(release: Release, say: Callable[[str], None] | None = None) -> Path:
    """The release's folder, built on first use (ReleaseUnusableError if pip cannot)."""
    folder = env_dir(release)
    if (folder / DONE_NAME).is_file():
        return folder
    with _locked(folder.with_name(folder.name + ".lock")):
        if (folder / DONE_NAME).is_file():
            return folder
        if say is not None:
            say(f"{release.spec}: installing into {folder} (once; reused after)")
        building = Path(tempfile.mkdtemp(prefix=folder.name + ".", dir=folder.parent))
        try:
            record = install(release, building)
            (building / DONE_NAME).write_text(json.dumps(record, indent=1, sort_keys=True))
            shutil.rmtree(folder, ignore_errors=True)
            building.rename(folder)
        finally:
            shutil.rmtree(building, ignore_errors=True)
    return folder


def _pip(spec: str, target: Path, release: Release) -> None:
    """pip install one distribution, without its requirements, into ``target``, merged with
    what is there: pip's ``--target`` skips a top-level folder that exists (mujoco-core
    4.0.0 installs into the ``mujoco`` folder of mujoco 4.0.0, and went missing: measured),
    so each goes into a folder of its own first."""
    with tempfile.TemporaryDirectory(prefix="pip-", dir=target) as scratch:
        _pip_into(spec, Path(scratch), release)
        for item in Path(scratch).iterdir():
            if item.is_dir():
                shutil.copytree(item, target / item.name, symlinks=True, dirs_exist_ok=True)
            else:
                shutil.copy2(item, target / item.name)


def _pip_into(spec: str, target: Path, release: Release) -> None:
    command = [
        *(sys.executable, "-m", "pip", "install", "--quiet", "--disable-pip-version-check"),
        *("--no-deps", "--only-binary", ":all:", "--target", str(target), spec),
    ]
    try:
        done = subprocess.run(
            command, capture_output=True, text=True, timeout=PIP_TIMEOUT_S, check=False
        )
    except subprocess.TimeoutExpired:
        raise ReleaseUnusableError(
            f"{release.spec}: cannot be installed: pip took over {PIP_TIMEOUT_S:g} s for {spec}"
        ) from None
    if done.returncode != 0:
        raise ReleaseUnusableError(
            f"{release.spec}: cannot be installed: {_pip_error(done.stderr, spec)}"
        )


def _pip_error(stderr: str, spec: str) -> str:
    """pip's own one-line reason (its last ERROR line), else its last line."""
    errors = [line[len("ERROR: ") :] for line in stderr.splitlines() if line.startswith("ERROR: ")]
    lines = [line for line in stderr.splitlines() if line.strip()]
    text = errors[-1] if errors else (lines[-1] if lines else f"pip failed for {spec}")
    return text.strip()


def _protected() -> set[str]:
    """hoopbench's own requirements (numpy, scipy, ...): never shadowed by a release folder."""
    names: set[str] = set()
    for text in requires("hoopbench") or []:
        with contextlib.suppress(InvalidRequirement):
            req = Requirement(text)
            if req.marker is None or req.marker.evaluate({"extra": ""}):
                names.add(canonicalize_name(req.name))
    return names


def _needs_install(req: Requirement, protected: set[str]) -> tuple[bool, str | None]:
    """Whether a requirement goes into the release's folder, and a note if it cannot."""
    name = canonicalize_name(req.name)
    pins = [s for s in req.specifier if s.operator in ("==", "===") and "*" not in s.version]
    try:
        have: str | None = installed_version(req.name)
    except PackageNotFoundError:
        have = None
    satisfied = have is not None and req.specifier.contains(have, prereleases=True)
    if name in protected:
        note = None if satisfied else f"needs {req}, runs with the main environment's {have}"
        return False, note
    return (not satisfied) or bool(pins), None


def install(release: Release, target: Path) -> dict[str, Any]:
    """Install the release and the requirements it needs (module docstring) into ``target``;
    what went in, and the notes of requirements left to the main environment."""
    protected = _protected() - {canonicalize_name(release.distribution)}
    _pip(f"{release.distribution}=={release.version}", target, release)
    installed = [f"{release.distribution}=={release.version}"]
    notes: list[str] = []
    queue = [release.distribution]
    seen = {canonicalize_name(release.distribution)}
    while queue:
        found = _requirements_in(target, queue.pop())
        for req in found:
            name = canonicalize_name(req.name)
            if name in seen:
                continue
            seen.add(name)
            wanted, note = _needs_install(req, protected)
            if note:
                notes.append(f"{req.name}: {note}")
            if not wanted:
                continue
            if len(installed) > MAX_EXTRA_PACKAGES:
                raise ReleaseUnusableError(
                    f"{release.spec}: cannot be installed: more than {MAX_EXTRA_PACKAGES} "
                    "packages beside the main environment's"
                )
            _pip(str(req), target, release)
            installed.append(str(req))
            queue.append(req.name)
    return {"release": release.spec, "python": PYTHON_TAG, "installed": installed, "notes": notes}


def _requirements_in(target: Path, name: str) -> list[Requirement]:
    """The requirements (no extras) of distribution ``name`` as installed in ``target``."""
    wanted = canonicalize_name(name)
    for info in target.glob("*.dist-info"):
        dist = PathDistribution(info)
        if canonicalize_name(dist.metadata["Name"] or "") != wanted:
            continue
        out = []
        for text in dist.requires or []:
            with contextlib.suppress(InvalidRequirement):
                req = Requirement(text)
                if req.marker is None or req.marker.evaluate({"extra": ""}):
                    out.append(req)
        return out
    return []


def env_record(folder: Path) -> Mapping[str, Any]:
    """What :func:`install` wrote into a release folder."""
    data: Mapping[str, Any] = json.loads((folder / DONE_NAME).read_text())
    return data


# --------------------------------------------------------------------------- the child process
CHILD_MODULE = "hoopbench.reports.compare.release_child"


def run_in_release(
    release: Release, tasks: list[Any], *, probe_only: bool = False
) -> list[dict[str, Any]]:
    """Run ``tasks`` (RunTasks of the release's engine) in a child process that imports the
    release: their rows. ReleaseUnusableError if the child cannot start or run them; a run's
    own failure is its row, as in the main environment."""
    folder = ensure_env(release)
    with tempfile.TemporaryDirectory(prefix="hoopbench-release-") as tmp:
        out = Path(tmp) / "rows.pickle"
        command = [sys.executable, "-m", CHILD_MODULE, str(folder), release.engine, release.version]
        command += [str(out), "probe" if probe_only else "run"]
        done = subprocess.run(command, input=pickle.dumps(tasks), capture_output=True, check=False)
        if not out.is_file():
            raise ReleaseUnusableError(f"{release.spec}: {_child_failure(done)}")
        rows: list[dict[str, Any]] = pickle.loads(out.read_bytes())
    return rows


def _child_failure(done: subprocess.CompletedProcess[bytes]) -> str:
    """The one line of a child that gave no rows: its own last line, or how it died."""
    lines = [line for line in done.stderr.decode(errors="replace").splitlines() if line.strip()]
    if done.returncode < 0:
        return f"the run's process died of signal {-done.returncode}"
    return lines[-1].strip() if lines else f"the run's process exited {done.returncode}"


def probe(release: Release, task: Any) -> str:
    """Install the release (once), import it and run ``task`` (a short run of the suite) in
    it: the version imported, or ReleaseUnusableError naming the release and what is missing
    (the probe run's own error, a missing module, a version that is not the one asked)."""
    try:
        rows = run_in_release(release, [task], probe_only=True)
    except ReleaseUnusableError:
        raise
    except OSError as exc:
        raise ReleaseUnusableError(f"{release.spec}: cannot be set up: {exc}") from None
    row = rows[0]
    if row.get("status") not in ("ok",):
        message = str(row.get("message") or row.get("status")).splitlines()
        text = " ".join(line.strip() for line in message if line.strip())
        raise ReleaseUnusableError(f"{release.spec}: the adapter cannot run it: {text}")
    found = str(row.get("engine_version"))
    if found != release.version:
        raise ReleaseUnusableError(f"{release.spec}: imported {found} instead")
    return found


def with_env_note(release: Release) -> str:
    """One line on what a release folder holds beside the engine (for the sweep's notes)."""
    record = env_record(env_dir(release))
    extra = [p for p in record.get("installed", [])[1:]]
    notes = list(record.get("notes", []))
    parts = [f"{release.spec}: {env_dir(release)}"]
    if extra:
        parts.append(f"with {', '.join(extra)}")
    if notes:
        parts.append(f"({'; '.join(notes)})")
    return " ".join(parts)
