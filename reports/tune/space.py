"""An engine's search space in Optuna's terms: the settings a trial draws, and back.

The space is the engines' own declaration (engines/options.py ``Option.space``) and the
timestep's (engines/settings.py ``TIMESTEP_SPACE``). Parameter names: an option's name; a tuple
option's searched components ``name[k]``; an optional option's ``name=None`` (drawn first:
True means the option is None, the engine's own behaviour); the timestep ``timestep``.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from hoopbench.engines.options import Option, Scale, Space
from hoopbench.engines.settings import TIMESTEP_SPACE

if TYPE_CHECKING:  # Optuna is an extra (tune): imported where a search runs
    import optuna

__all__ = ["TIMESTEP", "draw_settings", "searched_options", "trial_params"]

TIMESTEP = "timestep"
"""The timestep's parameter name."""


def searched_options(engine_cls: type) -> tuple[Option, ...]:
    """The engine's options a search varies."""
    return tuple(o for o in engine_cls.options if o.space is not None)  # type: ignore[attr-defined]


def _none_name(name: str) -> str:
    return f"{name}=None"


def _draw(trial: optuna.Trial, name: str, space: Space) -> Any:
    """One value of ``space`` for parameter ``name``."""
    if space.or_none and trial.suggest_categorical(_none_name(name), [False, True]):
        return None
    if space.scale is Scale.CHOICE:
        return trial.suggest_categorical(name, list(space.choices))
    if space.scale in (Scale.INT, Scale.LOG_INT):
        return trial.suggest_int(
            name, int(space.low), int(space.high), log=space.scale is Scale.LOG_INT
        )
    return trial.suggest_float(name, space.low, space.high, log=space.scale is Scale.LOG)


def draw_settings(trial: optuna.Trial, engine_cls: type) -> tuple[dict[str, Any], float]:
    """The options and the timestep (s) of one trial."""
    options: dict[str, Any] = {}
    for option in searched_options(engine_cls):
        if isinstance(option.space, Space):
            options[option.name] = _draw(trial, option.name, option.space)
            continue
        assert option.space is not None
        parts = list(option.default)
        for k, space in enumerate(option.space):
            if space is not None:
                parts[k] = _draw(trial, f"{option.name}[{k}]", space)
        options[option.name] = tuple(parts)
    return options, float(_draw(trial, TIMESTEP, TIMESTEP_SPACE))


def _params(name: str, space: Space, value: Any) -> dict[str, Any]:
    if space.or_none:
        return {_none_name(name): True} if value is None else {_none_name(name): False, name: value}
    return {name: value}


def trial_params(engine_cls: type, options: Mapping[str, Any], timestep: float) -> dict[str, Any]:
    """The parameters that :func:`draw_settings` turns into ``options`` and ``timestep``: to
    enqueue a known setting (``tuned``) as a trial. Options outside the space are left out."""
    params = _params(TIMESTEP, TIMESTEP_SPACE, timestep)
    for option in searched_options(engine_cls):
        value = options.get(option.name, option.default)
        if not option.in_space(value):
            continue
        if isinstance(option.space, Space):
            params.update(_params(option.name, option.space, value))
            continue
        assert option.space is not None
        for k, space in enumerate(option.space):
            if space is not None:
                params.update(_params(f"{option.name}[{k}]", space, value[k]))
    return params
