"""The search space of ``hoopbench tune``: every engine option that can change events declares
the values a search may try, next to its default and reason; the rest say why they stay out."""

from __future__ import annotations

import pytest

from hoopbench.engines.options import Option, Profile, Space
from hoopbench.engines.registry import engine_classes
from hoopbench.engines.settings import DEFAULT_TIMESTEP, TIMESTEP_SPACE

OPTIONS = [
    pytest.param(cls, option, id=f"{name}-{option.name}")
    for name, cls in sorted(engine_classes().items())
    for option in cls.options
]


@pytest.mark.parametrize(("cls", "option"), OPTIONS)
def test_an_option_is_searched_or_says_why_not(cls: type, option: Option) -> None:
    # A new engine's Option declares space=... (what `hoopbench tune` may try, inside the
    # option's own check) or outside_search="why not" (docs/engines.md).
    assert (option.space is None) == bool(option.outside_search), (
        f"{cls.name}.{option.name}: declare space=... or outside_search='why not', one of them"
    )


@pytest.mark.parametrize(("cls", "option"), OPTIONS)
def test_the_default_lies_in_the_space(cls: type, option: Option) -> None:
    if option.space is None:
        return
    assert option.in_space(option.default), (option.name, option.default, option.space)


def _corners(option: Option) -> list[object]:
    """The default with each searched part at each end of its space."""

    def ends(space: Space) -> list[object]:
        values: list[object] = list(space.choices) or [space.low, space.high]
        if space.scale in ("int", "log-int"):
            values = [int(v) for v in values]  # type: ignore[call-overload]
        return values + ([None] if space.or_none else [])

    if option.space is None:
        return []
    if isinstance(option.space, Space):
        return ends(option.space)
    corners: list[object] = []
    for k, space in enumerate(option.space):
        for value in [] if space is None else ends(space):
            parts = list(option.default)
            parts[k] = value
            corners.append(tuple(parts))
    return corners


@pytest.mark.parametrize(("cls", "option"), OPTIONS)
def test_the_space_passes_the_options_own_check(cls: type, option: Option) -> None:
    for value in _corners(option):
        assert option.in_space(value)
        option.check(option.name, value)  # raises for a space wider than the option allows


def test_the_timestep_is_searched_and_its_default_inside() -> None:
    assert TIMESTEP_SPACE.contains(DEFAULT_TIMESTEP)
    assert str(TIMESTEP_SPACE.scale) == "log"


def test_stock_values_mostly_lie_in_the_space() -> None:
    """Stock values outside the space are listed here, each with its reason."""
    outside = {
        ("mujoco", "solreffriction"),  # (0, 0): 'same as solref', not a time constant
        ("mjx", "solreffriction"),  # MuJoCo's option, read from the same MJCF
        ("mjwarp", "solreffriction"),  # likewise
    }
    found = set()
    for name, cls in engine_classes().items():
        for option in cls.options:
            if option.space is not None and not option.in_space(option.value(Profile.STOCK)):
                found.add((name, option.name))
    assert found == outside


def test_hoopbench_settings_shows_each_options_search(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    from hoopbench.reports.cli import main

    assert main(["settings", "--engine", "mujoco", "--json"]) == 0
    search = json.loads(capsys.readouterr().out)["engines"]["mujoco"]["search"]
    assert search["iterations"] == "log-int 10..200"
    assert (
        search["solimp"]
        == "(linear 0.8..0.95; linear 0.95..0.9999; log 0.0001..0.01; default; default)"
    )
    assert search["ring_segments"].startswith("not searched: ")
