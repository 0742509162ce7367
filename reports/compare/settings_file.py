"""The settings file ``hoopbench tune`` writes (its Pareto set) and ``compare --settings``,
``simulate --settings`` and ``hb.run(settings=...)`` read.

A TOML file: the engine, its version, the search's provenance, and one ``[[settings]]`` table
per setting, the most accurate on the training scenes first::

    engine = "pymunk"
    engine_version = "7.3.1"
    [provenance]
    training_scenes = ["seed-mu"]
    ...
    [tiers]
    agrees = "none"
    close = "trial-7"
    close_scenes = "13/22"
    [[settings]]
    name = "trial-7"
    timestep = 0.0001
    profile = "tuned"
    train_error = 0.4
    train_tier = "close"
    heldout_tier = "close"
    [settings.options]
    iterations = 80

``[tiers]`` names, per accuracy tier (engines/judging/verdict.TIER_NAMES: ``agrees`` for the
tight tier, ``close`` for the loose one), the cheapest of the settings of the file within it
on the most scenes (all, where one is), with ``TIER_scenes = "k/n"``: on how many of its n
scenes, training and held-out, it is within the tier; "none" where no setting is within it on
any scene. ``FILE#close`` picks it. A file written before the counts names, per tier, the
cheapest setting within it on every scene, or "none", and reads as it did; one written before
the tiers has no such table and reads as before (its settings by name only).

An option whose value is None (the engine's own behaviour) is written as the string "none"
(TOML has no null). Every name and value is checked against the engine's declarations when
the file is read: an unknown key, engine or option, or a bad value, is a SettingsFileError
naming it.
"""

from __future__ import annotations

import hashlib
import json
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from hoopbench.engines.judging.verdict import TIER_NAMES
from hoopbench.engines.options import Profile, check_profile
from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.engines.settings import RunSettings
from hoopbench.reports.compare.suite_file import DEFAULT_VARIANT, Suite, SuiteError, VariantSpec
from hoopbench.reports.sweep.folder_files import read_input_file

__all__ = [
    "NONE_TEXT",
    "TIER_CHOICES",
    "SettingsFile",
    "SettingsFileError",
    "TierChoice",
    "TunedSetting",
    "load_choice",
    "load_settings",
    "pick_setting",
    "settings_identity",
    "settings_meta",
    "settings_mismatch",
    "settings_text",
    "split_choice",
    "tier_note",
    "with_settings",
]

NONE_TEXT = "none"
"""How a None option value is written (TOML has no null)."""

TIER_CHOICES = tuple(str(name) for name in TIER_NAMES.values())
"""What ``FILE#TIER`` may name: ``agrees`` (the tight tier), ``close`` (the loose one)."""

_TOP_KEYS = ("engine", "engine_version", "provenance", "tiers", "settings")
_SETTING_KEYS = ("name", "timestep", "profile", "options")
"""Required keys of a setting; any other key is a number the search measured (kept as is)."""


class SettingsFileError(ValueError):
    """A settings file that cannot be used: one line naming the file and the key."""


@dataclass(frozen=True)
class TunedSetting:
    """One setting of a settings file."""

    name: str
    timestep: float
    """s."""
    options: Mapping[str, Any]
    """Option values over the profile's (the search's full set of searched options)."""
    profile: Profile = Profile.TUNED
    measured: Mapping[str, Any] = field(default_factory=dict)
    """What the search measured (train_error, heldout_error, cost_us_per_s, ...)."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))
        object.__setattr__(self, "measured", MappingProxyType(dict(self.measured)))

    def run_settings(self) -> RunSettings:
        return RunSettings(timestep=self.timestep, options=self.options, profile=self.profile)


@dataclass(frozen=True)
class TierChoice:
    """The setting ``[tiers]`` names for a tier: the cheapest of those within it on the most
    scenes."""

    setting: str
    scenes_within: int
    """How many of its scenes, training and held-out, are within the tier."""
    scenes: int
    """How many scenes it ran, training and held-out."""


@dataclass(frozen=True)
class SettingsFile:
    engine: str
    engine_version: str | None
    settings: tuple[TunedSetting, ...]
    provenance: Mapping[str, Any] = field(default_factory=dict)
    tiers: Mapping[str, str | None] = field(default_factory=dict)
    """Tier name (TIER_CHOICES) -> the setting [tiers] names for it, None where it says
    "none"; empty for a file written before the tiers."""
    tier_scenes: Mapping[str, tuple[int, int]] = field(default_factory=dict)
    """Tier name -> (scenes within the tier, scenes) of the setting named for it; empty for a
    file written before the counts."""
    sha256: str | None = None
    """The file's content hash (what a results folder made with it records)."""
    file_name: str | None = None
    """The file's name, for the reader (its content is what counts)."""


def _fail(path: Path, text: str) -> SettingsFileError:
    return SettingsFileError(f"settings file {str(path)!r}: {text}")


def _option_value(value: Any) -> Any:
    if value == NONE_TEXT:
        return None
    return tuple(value) if isinstance(value, list) else value


_TAKEN_NAMES = (DEFAULT_VARIANT, *TIER_CHOICES)
"""Names a setting may not have: the engine's default variant and the tiers' names."""


def _setting(path: Path, engine: str, k: int, table: Any) -> TunedSetting:
    where = f"settings[{k}]"
    if not isinstance(table, dict):
        raise _fail(path, f"{where} must be a table")
    missing = [key for key in _SETTING_KEYS if key not in table]
    if missing:
        raise _fail(path, f"{where} lacks {', '.join(missing)}")
    name, options = table["name"], table["options"]
    if not isinstance(name, str) or not name.strip() or name in _TAKEN_NAMES:
        taken = ", ".join(map(repr, _TAKEN_NAMES))
        raise _fail(path, f"{where}.name must be a name other than {taken}, got {name!r}")
    if not isinstance(options, dict):
        raise _fail(path, f"{where}.options must be a table")
    measured = {key: v for key, v in table.items() if key not in _SETTING_KEYS}
    try:
        setting = TunedSetting(
            name=name,
            timestep=table["timestep"],
            options={key: _option_value(v) for key, v in options.items()},
            profile=check_profile(f"{where}.profile", table["profile"]),
            measured=measured,
        )
        engine_class(engine).resolve(setting.run_settings())  # unknown options, bad values
    except ValueError as exc:
        raise _fail(path, f"{where} ({name}): {exc}") from None
    return setting


def load_settings(path: str | Path) -> SettingsFile:
    """Read and check a settings file. SettingsFileError (a ValueError) for a bad one;
    OSError for a file that cannot be read."""
    path = Path(path)
    # a FIFO, a device or a huge file is refused (FolderFileError, a ValueError)
    raw = read_input_file(path)
    try:
        # ValueError: not UTF-8, not TOML, or an integer past int()'s 4300 digits
        data = tomllib.loads(raw.decode("utf-8"))
    except ValueError as exc:
        raise _fail(path, f"not TOML: {exc}") from None
    except RecursionError:  # tomllib parses nested arrays recursively
        raise _fail(path, "not a settings file: its arrays or tables nest too deep") from None
    unknown = sorted(set(data) - set(_TOP_KEYS))
    if unknown:
        raise _fail(path, f"unknown key(s) {', '.join(map(repr, unknown))}")
    engine = data.get("engine")
    if engine not in engine_names():
        raise _fail(path, f"engine must be one of {', '.join(engine_names())}, got {engine!r}")
    tables = data.get("settings")
    if not isinstance(tables, list) or not tables:
        raise _fail(path, "needs at least one [[settings]] table")
    settings = tuple(_setting(path, engine, k, t) for k, t in enumerate(tables))
    names = [s.name for s in settings]
    if len(set(names)) != len(names):
        raise _fail(path, "two settings share a name")
    version = data.get("engine_version")
    provenance = data.get("provenance", {})
    tiers, tier_scenes = _tiers(path, data.get("tiers", {}), names)
    return SettingsFile(
        engine,
        version if isinstance(version, str) else None,
        settings,
        provenance,
        tiers,
        tier_scenes,
        hashlib.sha256(raw).hexdigest(),
        path.name,
    )


_SCENES_SUFFIX = "_scenes"
"""Of a [tiers] key giving the named setting's count: ``close_scenes = "13/22"``."""


def _count_text(text: str) -> bool:
    """A whole number of scenes as ASCII digits, short enough for int() ("²" is a digit to
    str.isdigit, and int() refuses more than 4300 digits)."""
    return 0 < len(text) <= _COUNT_DIGITS and text.isascii() and text.isdigit()


_COUNT_DIGITS = 9
"""At most this many digits in a [tiers] count: no search runs a billion scenes."""


def _count(path: Path, key: str, value: Any) -> tuple[int, int]:
    """A [tiers] count "k/n" (0 <= k <= n, n >= 1) checked."""
    within, _, scenes = str(value).partition("/") if isinstance(value, str) else ("", "", "")
    if not (_count_text(within) and _count_text(scenes) and int(within) <= int(scenes) > 0):
        raise _fail(path, f"tiers.{key} must be 'k/n' scenes (0 <= k <= n), got {value!r}")
    return int(within), int(scenes)


def _tiers(
    path: Path, table: Any, names: Sequence[str]
) -> tuple[dict[str, str | None], dict[str, tuple[int, int]]]:
    """The [tiers] table checked: known tiers, each naming a setting of the file or "none",
    and each count "k/n" of a tier it names a setting for, k at least 1."""
    if not isinstance(table, dict):
        raise _fail(path, "tiers must be a table")
    known = {*TIER_CHOICES, *(f"{t}{_SCENES_SUFFIX}" for t in TIER_CHOICES)}
    unknown = sorted(set(table) - known)
    if unknown:
        raise _fail(path, f"unknown tier(s) {', '.join(map(repr, unknown))} in [tiers]")
    tiers: dict[str, str | None] = {}
    for tier in TIER_CHOICES:
        if tier not in table:
            continue
        name = table[tier]
        if name != NONE_TEXT and name not in names:
            raise _fail(path, f"tiers.{tier} must name a setting of the file or be 'none'")
        tiers[tier] = None if name == NONE_TEXT else name
    counts: dict[str, tuple[int, int]] = {}
    for tier in TIER_CHOICES:
        key = f"{tier}{_SCENES_SUFFIX}"
        if key not in table:
            continue
        counts[tier] = _count(path, key, table[key])
        if tiers.get(tier) is None or counts[tier][0] == 0:
            raise _fail(path, f"tiers.{key} counts the scenes of a setting tiers.{tier} names")
    return tiers, counts


def split_choice(text: str | Path) -> tuple[str, str]:
    """``FILE#NAME`` -> (FILE, NAME), NAME "" without one. A text that names a file as it is
    is that file (``a#b.toml``); otherwise NAME is what follows the last ``#``."""
    text = str(text)
    if "#" not in text or Path(text).exists():
        return text, ""
    path, _, name = text.rpartition("#")
    return path, name


def load_choice(text: str | Path) -> tuple[SettingsFile, str | None]:
    """A ``FILE`` or ``FILE#NAME`` (NAME a setting's name or a tier, TIER_CHOICES): the file,
    checked, and the name (None without one). SettingsFileError for a NAME the file does not
    have (pick_setting)."""
    path, name = split_choice(text)
    loaded = load_settings(path)
    if name:
        pick_setting(loaded, name)
    return loaded, name or None


def pick_setting(loaded: SettingsFile, name: str | None = None) -> TunedSetting:
    """The setting named ``name``, or the one a tier's name names (TIER_CHOICES); default:
    the first, the most accurate in training."""
    if name is None:
        return loaded.settings[0]
    if name in TIER_CHOICES:
        name = _tier_setting(loaded, name)
    for setting in loaded.settings:
        if setting.name == name:
            return setting
    known = ", ".join(s.name for s in loaded.settings)
    raise SettingsFileError(f"no setting named {name!r} in the settings file (it has {known})")


def _tier_setting(loaded: SettingsFile, tier: str) -> str:
    """The name of the setting ``[tiers]`` gives for ``tier``; SettingsFileError if the file
    has no tiers or no setting reached it."""
    if tier not in loaded.tiers:
        raise SettingsFileError(
            f"the settings file names no setting for the tier {tier!r} (written before the "
            f"tiers, or edited): name a setting ({', '.join(s.name for s in loaded.settings)})"
        )
    chosen = loaded.tiers[tier]
    if chosen is None:
        # Without counts "none" may be the older rule's (within the tier on every scene).
        how = "any training or held-out" if loaded.tier_scenes else "every training and held-out"
        raise SettingsFileError(
            f"no setting of the settings file is within the tier {tier!r} on {how} scene (its "
            "[tiers] says none)"
        )
    return chosen


def tier_note(loaded: SettingsFile, name: str | None) -> str | None:
    """What to tell a user whose ``FILE#TIER`` names a setting within the tier on some of
    its scenes only (no setting of the file is within it on all); None otherwise."""
    if name is None or name not in loaded.tier_scenes:
        return None
    within, scenes = loaded.tier_scenes[name]
    if within == scenes:
        return None
    return (
        f"#{name} is {loaded.tiers[name]}, within the tier on only {within}/{scenes} of its "
        "training and held-out scenes: no setting of the file is within it on all"
    )


def with_settings(suite: Suite, loaded: SettingsFile, name: str | None = None) -> Suite:
    """The suite with each setting of the file (only the one ``name`` picks, if given:
    pick_setting) as a variant of its engine (at the setting's own timestep). SuiteError if
    the suite does not run that engine."""
    if loaded.engine not in suite.engines:
        raise SuiteError(
            f"the settings file is for {loaded.engine}, which suite {suite.name!r} does not run "
            f"(it has {', '.join(suite.engines)})"
        )
    chosen = loaded.settings if name is None else (pick_setting(loaded, name),)
    taken = {v.name for v in suite.variants if v.engine == loaded.engine}
    clash = [s.name for s in chosen if s.name in taken]
    if clash:
        raise SuiteError(f"setting name(s) {', '.join(clash)} already name variants of the suite")
    added = tuple(
        VariantSpec(
            loaded.engine, s.name, options=s.options, timesteps=(s.timestep,), profile=s.profile
        )
        for s in chosen
    )
    return Suite(
        suite.name,
        suite.engines,
        suite.timesteps,
        suite.scenes,
        suite.variants + added,
        suite.profiles,
    )


# --------------------------------------------------------------------------- identity
SETTINGS_SHA256_KEY = "settings_sha256"
SETTINGS_CHOICE_KEY = "settings_choice"
SETTINGS_FILE_KEY = "settings_file"


def settings_identity(loaded: SettingsFile | None, name: str | None = None) -> dict[str, Any]:
    """What a results folder records of its ``--settings FILE[#NAME]`` (runner's sweep.json):
    the file's content hash and the NAME, None for both without a file (so that a resume
    with one, or without, differs); the file's own name goes to meta.json
    (:func:`settings_meta`), as a file renamed is the same settings."""
    return {
        SETTINGS_SHA256_KEY: None if loaded is None else loaded.sha256,
        SETTINGS_CHOICE_KEY: name,
    }


def settings_meta(loaded: SettingsFile | None, name: str | None = None) -> dict[str, Any]:
    """The settings file a results folder was made with, for meta.json (empty without)."""
    if loaded is None:
        return {}
    shown = loaded.file_name if name is None else f"{loaded.file_name}#{name}"
    return {SETTINGS_FILE_KEY: shown, SETTINGS_SHA256_KEY: loaded.sha256}


def _settings_words(identity: Mapping[str, Any]) -> str:
    digest, name = identity.get(SETTINGS_SHA256_KEY), identity.get(SETTINGS_CHOICE_KEY)
    if digest is None:
        return "without --settings"
    return f"with the settings file of sha256 {str(digest)[:12]}" + (f"#{name}" if name else "")


def settings_mismatch(stored: Mapping[str, Any], identity: Mapping[str, Any]) -> str | None:
    """runner.check_identity's words when a resume's settings file (or none) is not the
    one the folder was made with; None when the settings agree (or the folder, made before
    they were recorded, does not say)."""
    keys = (SETTINGS_SHA256_KEY, SETTINGS_CHOICE_KEY)
    if not all(k in stored for k in keys) or all(stored[k] == identity.get(k) for k in keys):
        return None
    return (
        f"was made {_settings_words(stored)}, not {_settings_words(identity)}: resume it "
        "with the same --settings file, or choose a new folder"
    )


# --------------------------------------------------------------------------- writing
def _toml_value(value: Any) -> str:
    """A TOML literal of a plain value (None as NONE_TEXT)."""
    if value is None:
        return json.dumps(NONE_TEXT)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            return json.dumps(str(value))  # TOML's nan/inf would read back as floats
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a TOML basic string
    if isinstance(value, Sequence):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    raise TypeError(f"no TOML value for {value!r}")


def _key(name: str) -> str:
    return name if name.replace("_", "").replace("-", "").isalnum() else json.dumps(name)


def settings_text(
    engine: str,
    engine_version: str | None,
    provenance: Mapping[str, Any],
    settings: Sequence[TunedSetting],
    tiers: Mapping[str, TierChoice | None] | None = None,
) -> str:
    """The settings file's text (what :func:`load_settings` reads back); ``tiers``: tier name
    (TIER_CHOICES) -> the setting named for it, or None where none is."""
    lines = [
        "# Written by `hoopbench tune`: the Pareto set of a search over this engine's settings,",
        "# the most accurate on the training scenes first. docs/tune.md explains the numbers.",
        f"engine = {_toml_value(engine)}",
    ]
    if engine_version is not None:
        lines.append(f"engine_version = {_toml_value(engine_version)}")
    lines += ["", "[provenance]"]
    lines += [f"{_key(k)} = {_toml_value(v)}" for k, v in provenance.items()]
    if tiers is not None:
        lines += ["", *_tiers_lines(tiers)]
    for setting in settings:
        lines += ["", "[[settings]]", f"name = {_toml_value(setting.name)}"]
        lines.append(f"timestep = {_toml_value(float(setting.timestep))}")
        lines.append(f"profile = {_toml_value(str(setting.profile))}")
        lines += [f"{_key(k)} = {_toml_value(v)}" for k, v in setting.measured.items()]
        lines.append("[settings.options]")
        lines += [f"{_key(k)} = {_toml_value(v)}" for k, v in setting.options.items()]
    return "\n".join(lines) + "\n"


def _tiers_lines(tiers: Mapping[str, TierChoice | None]) -> list[str]:
    lines = [
        "# Per accuracy tier (engines/judging/tolerances.toml: agrees = every event within the",
        "# tight tolerances, close = within the loose ones), the cheapest setting below among",
        "# those whose runs are within the tier on the most scenes, training and held-out",
        "# together (on all of them, where one is); TIER_scenes says on how many of how many.",
        '# "none": no setting is within that tier on any scene. Run one with',
        "# --settings 'FILE#close'.",
        "[tiers]",
    ]
    for tier in TIER_CHOICES:
        choice = tiers.get(tier)
        lines.append(f"{tier} = {_toml_value(None if choice is None else choice.setting)}")
        if choice is not None:
            count = f"{choice.scenes_within}/{choice.scenes}"
            lines.append(f"{tier}{_SCENES_SUFFIX} = {_toml_value(count)}")
    return lines
