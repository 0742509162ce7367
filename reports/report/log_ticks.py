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
A tick that is not a power of ten is written as the axis's own formatter writes it where that
is not a log formatter (best_settings' plain numbers), else as ``2×10⁻¹`` (matplotlib's own
way of writing a labelled minor tick; ``3``, not ``3×10⁰``), with as many digits as tell the
labels apart.
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
    (plotting.save writes it as ``2×10⁻¹``), its mantissa to ``digits`` significant digits;
    between 1 and 10 the mantissa alone."""
    exponent = math.floor(math.log10(value))
    mantissa = f"{value / 10.0**exponent:.{digits}g}"
    if mantissa == "10":  # rounded up to the next power
        mantissa, exponent = "1", exponent + 1
    if exponent == 0:  # 3, not 3×10⁰
        return rf"$\mathdefault{{{mantissa}}}$"
    return rf"$\mathdefault{{{mantissa}\times10^{{{exponent}}}}}$"


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
        """Powers of ten as the axis's own formatter writes them; other ticks so too, or, in
        place of a log formatter (which writes them blank or rounded), as ``2×10⁻¹``."""

        def __init__(self, own: Formatter, sci: bool) -> None:
            self.own, self.sci, self.digits = own, sci, 1

        def set_locs(self, locs: Any) -> None:
            self.own.set_locs(locs)
            self.digits = _digits(list(locs))

        def __call__(self, x: float, pos: int | None = None) -> str:
            if _is_decade(x) or not self.sci:
                return str(self.own(x, pos))
            return _sci(x, self.digits)

    return ReadableLocator, ReadableFormatter


def _digits(locs: list[float]) -> int:
    """The fewest significant digits (to :data:`_MAX_DIGITS`) that write every tick of
    ``locs`` that is not a power of ten differently."""
    values = [v for v in locs if v > 0 and not _is_decade(v)]
    for digits in range(1, _MAX_DIGITS):
        if len({_sci(v, digits) for v in values}) == len(values):
            return digits
    return _MAX_DIGITS
