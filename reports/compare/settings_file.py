"""The settings file ``hoopbench tune`` writes (its Pareto set) and ``compare --settings``,
``simulate --settings`` and ``hb.run(settings=...)`` read.

A TOML file: the engine, its version, the search's provenance, and one ``[[settings]]`` table
per setting, the most accurate on the training scenes first::

    engine = "pymunk"
    engine_version = "7.3.1"
    [provenance]
    training_scenes = ["seed-mu"]
    ...
    [[settings]]
    name = "trial-7"
    timestep = 0.0001
    profile = "tuned"
    train_error = 0.4
    [settings.options]
    iterations = 80

An option whose value is None (the engine's own behaviour) is written as the string "none"
(TOML has no null). Every name and value is checked against the engine's declarations when
the file is read: an unknown key, engine or option, or a bad value, is a SettingsFileError
naming it.
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any

from hoopbench.engines.options import Profile, check_profile
from hoopbench.engines.registry import engine_class, engine_names
from hoopbench.engines.settings import RunSettings
from hoopbench.reports.compare.suite_file import DEFAULT_VARIANT, Suite, SuiteError, VariantSpec
from hoopbench.reports.sweep.folder_files import read_input_file

__all__ = [
    "NONE_TEXT",
    "SettingsFile",
    "SettingsFileError",
    "TunedSetting",
    "load_settings",
    "pick_setting",
    "settings_text",
    "with_settings",
]

NONE_TEXT = "none"
"""How a None option value is written (TOML has no null)."""

_TOP_KEYS = ("engine", "engine_version", "provenance", "settings")
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
class SettingsFile:
    engine: str
    engine_version: str | None
    settings: tuple[TunedSetting, ...]
    provenance: Mapping[str, Any] = field(default_factory=dict)


def _fail(path: Path, text: str) -> SettingsFileError:
    return SettingsFileError(f"settings file {str(path)!r}: {text}")


def _option_value(value: Any) -> Any:
    if value == NONE_TEXT:
        return None
    return tuple(value) if isinstance(value, list) else value


def _setting(path: Path, engine: str, k: int, table: Any) -> TunedSetting:
    where = f"settings[{k}]"
    if not isinstance(table, dict):
        raise _fail(path, f"{where} must be a table")
    missing = [key for key in _SETTING_KEYS if key not in table]
    if missing:
        raise _fail(path, f"{where} lacks {', '.join(missing)}")
    name, options = table["name"], table["options"]
    if not isinstance(name, str) or not name.strip() or name == DEFAULT_VARIANT:
        raise _fail(path, f"{where}.name must be a name other than 'default', got {name!r}")
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
    try:
        # a FIFO, a device or a huge file is refused (FolderFileError, a ValueError)
        data = tomllib.loads(read_input_file(path).decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise _fail(path, f"not TOML: {exc}") from None
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
    return SettingsFile(engine, version if isinstance(version, str) else None, settings, provenance)


def pick_setting(loaded: SettingsFile, name: str | None = None) -> TunedSetting:
    """The setting named ``name`` (default: the first, the most accurate in training)."""
    if name is None:
        return loaded.settings[0]
    for setting in loaded.settings:
        if setting.name == name:
            return setting
    known = ", ".join(s.name for s in loaded.settings)
    raise SettingsFileError(f"no setting named {name!r} in the settings file (it has {known})")


def with_settings(suite: Suite, loaded: SettingsFile) -> Suite:
    """The suite with each setting of the file as a variant of its engine (at the setting's
    own timestep). SuiteError if the suite does not run that engine."""
    if loaded.engine not in suite.engines:
        raise SuiteError(
            f"the settings file is for {loaded.engine}, which suite {suite.name!r} does not run "
            f"(it has {', '.join(suite.engines)})"
        )
    taken = {v.name for v in suite.variants if v.engine == loaded.engine}
    clash = [s.name for s in loaded.settings if s.name in taken]
    if clash:
        raise SuiteError(f"setting name(s) {', '.join(clash)} already name variants of the suite")
    added = tuple(
        VariantSpec(
            loaded.engine, s.name, options=s.options, timesteps=(s.timestep,), profile=s.profile
        )
        for s in loaded.settings
    )
    return Suite(
        suite.name,
        suite.engines,
        suite.timesteps,
        suite.scenes,
        suite.variants + added,
        suite.profiles,
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
) -> str:
    """The settings file's text (what :func:`load_settings` reads back)."""
    lines = [
        "# Written by `hoopbench tune`: the Pareto set of a search over this engine's settings,",
        "# the most accurate on the training scenes first. docs/tune.md explains the numbers.",
        f"engine = {_toml_value(engine)}",
    ]
    if engine_version is not None:
        lines.append(f"engine_version = {_toml_value(engine_version)}")
    lines += ["", "[provenance]"]
    lines += [f"{_key(k)} = {_toml_value(v)}" for k, v in provenance.items()]
    for setting in settings:
        lines += ["", "[[settings]]", f"name = {_toml_value(setting.name)}"]
        lines.append(f"timestep = {_toml_value(float(setting.timestep))}")
        lines.append(f"profile = {_toml_value(str(setting.profile))}")
        lines += [f"{_key(k)} = {_toml_value(v)}" for k, v in setting.measured.items()]
        lines.append("[settings.options]")
        lines += [f"{_key(k)} = {_toml_value(v)}" for k, v in setting.options.items()]
    return "\n".join(lines) + "\n"
