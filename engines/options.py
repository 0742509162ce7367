"""How an engine declares its options and settings variants.

An engine module lists its options as :class:`Option` values: the real engine name, the
default hoopbench uses, why, and the check on a value. Everything else (validation of a
run's settings, ``hoopbench settings``, the suites' variants, the README table) is derived
from these declarations, so a default or an allowed range is written down once.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from types import MappingProxyType
from typing import Any

from hoopbench.models.checks import (
    check_choice,
    check_flag,
    check_integer,
    check_real,
    shown_value,
)

__all__ = [
    "C_INT_MAX",
    "SAME",
    "Check",
    "Option",
    "Profile",
    "Scale",
    "SearchSpace",
    "Space",
    "Variant",
    "check_profile",
    "choice",
    "flag",
    "int_range",
    "integer",
    "linear_range",
    "log_range",
    "number",
    "one_of",
    "optional",
    "real_tuple",
]


class Profile(StrEnum):
    """Which option values a run uses."""

    TUNED = "tuned"
    """hoopbench's defaults, each chosen for this problem, with its reason."""
    STOCK = "stock"
    """The engine's own documented defaults: what a new user gets out of the box."""


def check_profile(name: str, value: Any) -> Profile:
    """The profile named ``value`` (exact spelling); ValueError naming ``name``, the allowed
    profiles and the value. The one check of a profile, wherever one is given."""
    try:
        return Profile(value)
    except (ValueError, TypeError):
        allowed = ", ".join(p.value for p in Profile)
        raise ValueError(f"{name} must be one of {allowed}, got {value!r}") from None


class _Same:
    def __repr__(self) -> str:
        return "SAME"


SAME: Any = _Same()
"""An option's ``stock`` value when hoopbench keeps the engine's own default."""

Check = Callable[[str, Any], Any]
"""(option name, value) -> the value converted; ValueError naming the value and the allowed."""


class Scale(StrEnum):
    """How a search draws an option's values (``hoopbench tune``)."""

    LINEAR = "linear"
    """A real number, uniform between the bounds."""
    LOG = "log"
    """A positive real number, uniform in its logarithm: for values over decades."""
    INT = "int"
    """A whole number, uniform between the bounds."""
    LOG_INT = "log-int"
    """A positive whole number, uniform in its logarithm."""
    CHOICE = "choice"
    """One of a few values."""


@dataclass(frozen=True)
class Space:
    """The values of one option (or one component of a tuple option) a search may try."""

    scale: Scale
    low: float = 0.0
    """Smallest value (LINEAR, LOG, INT, LOG_INT), in the option's unit."""
    high: float = 0.0
    """Largest value, in the option's unit."""
    choices: tuple[Any, ...] = ()
    """The values of a CHOICE."""
    or_none: bool = False
    """The search also tries None (the engine's own behaviour, for an optional option)."""

    def __post_init__(self) -> None:
        if self.scale is Scale.CHOICE:
            if not self.choices:
                raise ValueError("a choice space needs its choices")
        elif not self.low <= self.high or (
            self.scale in (Scale.LOG, Scale.LOG_INT) and not self.low > 0
        ):
            raise ValueError(f"bad {self.scale} space [{self.low}, {self.high}]")

    def contains(self, value: Any) -> bool:
        """Whether the search can draw ``value``."""
        if self.scale is Scale.CHOICE and value in self.choices:
            return True
        if value is None or self.scale is Scale.CHOICE:
            return value is None and self.or_none
        if self.scale in (Scale.INT, Scale.LOG_INT) and value != int(value):
            return False
        return bool(self.low <= value <= self.high)

    def describe(self) -> str:
        """The space in a few words, e.g. 'log 1e-05..0.1' or 'one of a, b'."""
        if self.scale is Scale.CHOICE:
            text = "one of " + ", ".join(str(c) for c in self.choices)
        else:
            text = f"{self.scale} {self.low:g}..{self.high:g}"
        return text + (" or None" if self.or_none else "")


def log_range(low: float, high: float, *, or_none: bool = False) -> Space:
    """Reals from ``low`` to ``high``, drawn uniformly in their logarithm."""
    return Space(Scale.LOG, low, high, or_none=or_none)


def linear_range(low: float, high: float, *, or_none: bool = False) -> Space:
    """Reals from ``low`` to ``high``, drawn uniformly."""
    return Space(Scale.LINEAR, low, high, or_none=or_none)


def int_range(low: int, high: int, *, log: bool = False) -> Space:
    """Whole numbers from ``low`` to ``high`` (drawn uniformly in their logarithm if ``log``)."""
    return Space(Scale.LOG_INT if log else Scale.INT, low, high)


def one_of(*choices: Any) -> Space:
    """One of ``choices``."""
    return Space(Scale.CHOICE, choices=tuple(choices))


SearchSpace = Space | tuple[Space | None, ...]
"""An option's search space: one Space, or one per component of a tuple option (None: that
component keeps its default)."""


@dataclass(frozen=True)
class Option:
    """One engine option, by its real engine name."""

    name: str
    default: Any
    """hoopbench's default value."""
    check: Check
    reason: str
    """Why the default has this value (measurements where there are any)."""
    stock: Any = SAME
    """The engine's own default (the ``stock`` profile); SAME when hoopbench keeps it."""
    space: SearchSpace | None = None
    """The values a search over the engine's settings tries (``hoopbench tune``); None for an
    option that cannot change the events (``outside_search`` says why)."""
    outside_search: str = ""
    """Why an option without a space stays out of the search (it changes only the cost or
    the bookkeeping)."""

    def in_space(self, value: Any) -> bool:
        """Whether a search over this option can draw ``value`` (False without a space)."""
        if self.space is None:
            return False
        if isinstance(self.space, Space):
            return self.space.contains(value)
        if not isinstance(value, tuple | list) or len(value) != len(self.space):
            return False
        default = tuple(self.default)
        return all(
            part == default[k] if space is None else space.contains(part)
            for k, (space, part) in enumerate(zip(self.space, value, strict=True))
        )

    def value(self, profile: Profile) -> Any:
        """The option's value in a profile."""
        if profile is Profile.STOCK and self.stock is not SAME:
            return self.stock
        return self.default


@dataclass(frozen=True)
class Variant:
    """Settings an engine offers to suites beside its defaults, to study one knob."""

    name: str
    """Label in the runs table, e.g. 'cone=pyramidal'."""
    geometry: str = "sphere"
    options: Mapping[str, Any] = field(default_factory=dict)
    """Options that differ from the defaults."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "options", MappingProxyType(dict(self.options)))


def number(
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
) -> Check:
    """A finite real number within the bounds."""

    def check(name: str, value: Any) -> float:
        return check_real(
            name, value, low=low, high=high, low_open=low_open, high_open=high_open, unit=unit
        )

    return check


C_INT_MAX = 2**31 - 1
"""Largest integer option: the engines hand them to C code (MuJoCo's XML parser, Chipmunk,
Bullet) as a C int, which a larger value overflows inside the engine instead of here."""


def integer(*, low: int | None = None, high: int | None = None) -> Check:
    """A whole number within the bounds, and within a C int (C_INT_MAX)."""

    def check(name: str, value: Any) -> int:
        out = check_integer(name, value, low=low, high=high)
        if not -C_INT_MAX - 1 <= out <= C_INT_MAX:
            raise ValueError(
                f"{name} must be an integer that fits a C int (at most {C_INT_MAX}), "
                f"got {shown_value(value)}"
            )
        return out

    return check


def choice(*allowed: str) -> Check:
    """One of the given spellings (case-insensitive)."""

    def check(name: str, value: Any) -> str:
        return check_choice(name, value, allowed)

    return check


def flag() -> Check:
    """0 or 1."""
    return check_flag


def optional(inner: Check) -> Check:
    """None, or what ``inner`` accepts."""

    def check(name: str, value: Any) -> Any:
        return None if value is None else inner(name, value)

    return check


def real_tuple(lengths: Sequence[int], what: str) -> Check:
    """A tuple of finite numbers of one of the given lengths; ``what`` names its parts."""

    def check(name: str, value: Any) -> tuple[float, ...]:
        if not isinstance(value, tuple | list) or len(value) not in lengths:
            raise ValueError(f"{name} must be {what}, got {value!r}")
        return tuple(check_real(f"{name} component", v) for v in value)

    return check
