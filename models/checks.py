"""Value checks shared by every layer: one wording for every bad-input error.

Each check takes the parameter's name and the value, returns the value converted (float,
int or the canonical spelling of a choice) and raises ValueError that names the parameter,
the allowed values and the value given. Booleans are never numbers here: ``True`` for a
timestep is a mistake, not 1.0.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

__all__ = [
    "check_choice",
    "check_finite",
    "check_flag",
    "check_integer",
    "check_real",
    "interval_text",
    "shown_value",
]


def interval_text(low: float | None, high: float | None, low_open: bool, high_open: bool) -> str:
    """'in (0, 1]', '>= 0', '> 0', or 'a finite number' when unbounded."""
    if low is not None and high is not None:
        return f"in {'(' if low_open else '['}{low:g}, {high:g}{')' if high_open else ']'}"
    if low is not None:
        return f"{'>' if low_open else '>='} {low:g}"
    if high is not None:
        return f"{'<' if high_open else '<='} {high:g}"
    return "finite"


def check_finite(name: str, value: Any) -> float:
    """Any finite real number, as float (the scene's parameters, whose ranges differ)."""
    if isinstance(value, bool):
        raise ValueError(f"{name} must be a real number, got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {shown_value(value)}") from None
    except OverflowError:  # an integer of hundreds of digits
        raise ValueError(f"{name} must be finite, got {shown_value(value)}") from None
    if not math.isfinite(out):
        raise ValueError(f"{name} must be finite, got {out}")
    return out


def check_real(
    name: str,
    value: Any,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    unit: str = "",
) -> float:
    """A finite real number within the bounds, as float."""
    allowed = interval_text(low, high, low_open, high_open)
    suffix = f" {unit}" if unit else ""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"{name} must be a number {allowed}{suffix}, got {value!r}")
    try:
        out = float(value)
    except (TypeError, ValueError, OverflowError):
        shown = shown_value(value)
        raise ValueError(f"{name} must be a number {allowed}{suffix}, got {shown}") from None
    too_low = low is not None and (out <= low if low_open else out < low)
    too_high = high is not None and (out >= high if high_open else out > high)
    if not math.isfinite(out) or too_low or too_high:
        raise ValueError(f"{name} must be a number {allowed}{suffix}, got {value!r}")
    return out


def check_integer(name: str, value: Any, *, low: int | None = None, high: int | None = None) -> int:
    """A whole number (3 or 3.0, not 3.5 or True) within the bounds, as int."""
    allowed = interval_text(low, high, False, False)
    ok = not isinstance(value, bool) and isinstance(value, numbers.Real)
    if ok and not isinstance(value, numbers.Integral):
        ok = math.isfinite(float(value)) and float(value).is_integer()
    if ok:
        out = int(value)
        ok = (low is None or out >= low) and (high is None or out <= high)
    if not ok:
        raise ValueError(f"{name} must be an integer {allowed}, got {shown_value(value)}")
    return out


_SHOWN_DIGITS = 40
"""An integer of more digits is shown by its length: the line stays one line."""


def shown_value(value: Any) -> str:
    """``value!r``, an integer of hundreds of digits as its first digits and its length."""
    text = repr(value)
    if isinstance(value, int) and len(text) > _SHOWN_DIGITS:
        return f"{text[:12]}... ({len(text.lstrip('-'))} digits)"
    return text


def check_choice(name: str, value: Any, allowed: Sequence[str]) -> str:
    """One of ``allowed`` (case-insensitive), in its canonical spelling."""
    by_lower = {a.lower(): a for a in allowed}
    if not isinstance(value, str) or value.lower() not in by_lower:
        raise ValueError(f"{name} must be one of {', '.join(allowed)}, got {value!r}")
    return by_lower[value.lower()]


def check_flag(name: str, value: Any) -> int:
    """0 or 1 (an engine's on/off switch), as int."""
    if isinstance(value, bool) or value not in (0, 1) or isinstance(value, float):
        raise ValueError(f"{name} must be 0 or 1, got {value!r}")
    return int(value)
