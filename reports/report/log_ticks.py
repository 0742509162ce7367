"""Every log axis of the report's figures shows at least :data:`LABELLED_TICKS` labelled ticks,
whatever its range (issue: error_vs_time.png's seed-mu panels spanned 0.135-0.66 s, held no
power of ten, and showed no number at all on their time axes).

matplotlib's log axes label their major ticks, the powers of ten; an axis that spans less than
a decade or so holds one or none. Its minor ticks (2, 3, ... 9 times a power) are labelled by
matplotlib's default on such a narrow axis, but all of them or a fixed subset, which overlap
on a narrow panel (precision.py switched them off for that). The rule here, for every log
axis of every figure (:func:`plotting.save` applies it, one place): the minor ticks are never
labelled; the major ticks are the axis's own where :data:`LABELLED_TICKS` of them lie in view,
else the sparsest set of :data:`SUB_DECADES` (1 and 3, then 1, 2 and 5, then 1, 2, 3 and 5
times a power) that puts that many in view, else (an axis such as 6-9.5 or 0.55-0.58) the
fewest round numbers of a linear scale (``MaxNLocator``) that do: 6 and 8, not 6, 7, 8 and 9.
The sparsest set keeps the labels apart.
On an axis whose ticks the rule chose, one notation for every label in view (``10⁰`` beside
``3`` read as two kinds of number): where the axis's own formatter is not a log formatter
(best_settings' plain numbers), its own; else plain numbers (``0.5``, ``1``, ``3``) where every
tick in view lies from :data:`PLAIN_LOW` to below :data:`PLAIN_HIGH`, else matplotlib's
notation for a log axis (``10⁻⁶`` and ``3×10⁻⁶``). Each label is the tick's value, with the
fewest digits that write it exactly (``0.575``, not ``0.58``).
"""

from __future__ import annotations

import math
from functools import cache
from typing import Any

import numpy as np

__all__ = ["LABELLED_TICKS", "SUB_DECADES", "readable_log_axes"]

LABELLED_TICKS = 2
"""The fewest labelled ticks a log axis shows in its view: two give its scale."""

SUB_DECADES: tuple[tuple[float, ...], ...] = (
    (1.0, 3.0),
    (1.0, 2.0, 5.0),
    (1.0, 2.0, 3.0, 5.0),
)
"""The multiples of each power of ten tried in turn, sparsest first, on an axis whose own
ticks leave fewer than :data:`LABELLED_TICKS` in view."""

LINEAR_BINS = 5
"""The most ``MaxNLocator`` bins tried on an axis too narrow for :data:`SUB_DECADES` (the
fewest that put two ticks in view are taken): at 5 its step is at most twice a fifth of the
range (its steps 1, 2, 2.5, 5, 10 are at most a factor 2 apart), so two ticks lie in view."""

PLAIN_LOW = 0.01
"""The smallest tick written as a plain number (``0.01``) on an axis whose ticks the rule chose."""

PLAIN_HIGH = 1000.0
"""Ticks from here up are written as powers of ten (``10³``), not plain numbers."""

_MAX_DIGITS = 6
"""The most significant digits a tick's mantissa is written with (labels that still match
are of an axis narrower than any figure here draws)."""


def readable_log_axes(fig: Any) -> None:
    """Every log axis of ``fig`` (its colour bars' too) labelled by the module's rule; an axis
    done already (axes that share one) is left as it is."""
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_scale() == "log":
                _readable(axis)


def _readable(axis: Any) -> None:
    from matplotlib.ticker import LogFormatter, NullFormatter

    locator_class, formatter_class = _classes()
    locator = axis.get_major_locator()
    if isinstance(locator, locator_class):
        return
    formatter = axis.get_major_formatter()
    axis.set_major_locator(locator_class(locator))
    axis.set_major_formatter(formatter_class(formatter, isinstance(formatter, LogFormatter)))
    axis.set_minor_formatter(NullFormatter())  # the labels are the majors'


def sub_decade_ticks(vmin: float, vmax: float) -> np.ndarray:
    """The ticks of the rule's fallbacks on an axis from ``vmin`` to ``vmax`` whose own
    ticks leave fewer than :data:`LABELLED_TICKS` in view: the first set of
    :data:`SUB_DECADES` that puts that many in view, else round numbers of a linear scale."""
    from matplotlib.ticker import MaxNLocator

    low, high = sorted((vmin, vmax))
    decades = 10.0 ** np.arange(math.floor(math.log10(low)), math.ceil(math.log10(high)) + 1)
    for subs in SUB_DECADES:
        ticks = np.outer(decades, subs).ravel()
        if in_view(ticks, low, high) >= LABELLED_TICKS:
            return ticks
    for bins in range(1, LINEAR_BINS + 1):  # the fewest round numbers: labels apart
        locator = MaxNLocator(nbins=bins, steps=[1, 2, 2.5, 5, 10])
        rounds = np.asarray(locator.tick_values(low, high))
        if in_view(rounds, low, high) >= LABELLED_TICKS:
            break
    return rounds[rounds > 0]


def in_view(ticks: np.ndarray, vmin: float, vmax: float) -> int:
    """How many of ``ticks`` lie from ``vmin`` to ``vmax`` (either order)."""
    low, high = sorted((vmin, vmax))
    return int(((ticks >= low) & (ticks <= high)).sum())


def _is_decade(value: float) -> bool:
    return value > 0 and math.isclose(10.0 ** round(math.log10(value)), value, rel_tol=1e-9)


def _sci(value: float, digits: int) -> str:
    """``value`` as matplotlib writes a labelled minor tick: ``$\\mathdefault{2\\times10^{-1}}$``
    (plotting.save writes it as ``2×10⁻¹``), its mantissa to ``digits`` significant digits; a
    power of ten as ``10^{-1}``."""
    exponent = math.floor(math.log10(value))
    mantissa = f"{value / 10.0**exponent:.{digits}g}"
    if mantissa == "10":  # rounded up to the next power
        mantissa, exponent = "1", exponent + 1
    if mantissa == "1":
        return rf"$\mathdefault{{10^{{{exponent}}}}}$"
    return rf"$\mathdefault{{{mantissa}\times10^{{{exponent}}}}}$"


def _plain(value: float, digits: int) -> str:
    """``value`` as a plain number to ``digits`` significant digits: ``0.575``, ``3``, ``30``."""
    text = np.format_float_positional(value, precision=digits, fractional=False, trim="-")
    return rf"$\mathdefault{{{text}}}$"


def _writes_exactly(value: float, digits: int) -> bool:
    """Whether ``digits`` significant digits write ``value`` as itself (a tick at 0.575 is not
    labelled 0.58)."""
    return math.isclose(float(f"{value:.{digits - 1}e}"), value, rel_tol=1e-9)


@cache
def _classes() -> tuple[type, type]:
    """The rule's locator and formatter, made on first use (plotting.py: no report module
    imports matplotlib at its top)."""
    from matplotlib.ticker import Formatter, Locator

    class ReadableLocator(Locator):
        """The axis's own ticks where enough lie in view, else :func:`sub_decade_ticks`."""

        def __init__(self, own: Locator) -> None:
            self.own = own

        def __call__(self) -> Any:
            if self.axis is None:  # not an axis's yet: as its own locator would
                return self.own()
            vmin, vmax = self.axis.get_view_interval()
            return self.tick_values(vmin, vmax)

        def tick_values(self, vmin: float, vmax: float) -> Any:
            own = self.own.tick_values(vmin, vmax)
            if in_view(np.asarray(own), vmin, vmax) >= LABELLED_TICKS:
                return own
            return sub_decade_ticks(vmin, vmax)

    class ReadableFormatter(Formatter):
        """The axis's own formatter's labels where its ticks are all powers of ten, or where
        it is not a log formatter; else, on ticks the rule chose, one notation for all of
        them (:func:`_plain` or :func:`_sci`), each written exactly (the module docstring)."""

        def __init__(self, own: Formatter, sci: bool) -> None:
            self.own, self.sci, self.digits, self.write = own, sci, 1, _sci
            self.chosen = False  # the rule chose the ticks: not all powers of ten

        def set_locs(self, locs: Any) -> None:
            self.own.set_locs(locs)
            shown = _in_view(list(locs), self.axis)
            self.chosen = not all(_is_decade(v) for v in shown)
            self.digits = _digits(shown)
            plain = all(PLAIN_LOW <= v < PLAIN_HIGH for v in shown)
            self.write = _plain if plain else _sci

        def __call__(self, x: float, pos: int | None = None) -> str:
            if not (self.sci and self.chosen) or x <= 0:
                return str(self.own(x, pos))
            return self.write(x, self.digits)

    return ReadableLocator, ReadableFormatter


def _in_view(locs: list[float], axis: Any) -> list[float]:
    """The positive ticks of ``locs`` in ``axis``'s view (all of them without an axis)."""
    if axis is None:
        return [v for v in locs if v > 0]
    low, high = sorted(axis.get_view_interval())
    return [v for v in locs if v > 0 and low <= v <= high]


def _digits(locs: list[float]) -> int:
    """The fewest significant digits (to :data:`_MAX_DIGITS`) that write every tick of
    ``locs`` as itself."""
    for digits in range(1, _MAX_DIGITS):
        if all(_writes_exactly(v, digits) for v in locs):
            return digits
    return _MAX_DIGITS
