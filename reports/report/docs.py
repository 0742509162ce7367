"""docs/report.md's generated blocks: the parts of the page that restate the code, written
from the code's own docstrings and tables, so that the page cannot lag behind it.

``make docs`` (``python -m hoopbench.reports.report.docs docs/report.md``) rewrites every
block in place and keeps the hand-written prose around them; ``--check`` only says which
blocks are out of date. tests/test_docs_generated.py fails when a block differs from what
:func:`blocks` makes now. A block lies between two markers::

    <!-- BEGIN generated: NAME (make docs; do not edit) -->
    <!-- END generated: NAME -->

The blocks (:func:`blocks`):

- ``contact-thresholds``: the canonical reading's thresholds, one row per field of
  ``ContactSettings`` with its docstring, its value on the hoop the settings are stated for
  and how ``ContactSettings.for_hoop`` carries it to another hoop;
- ``contact-definitions``: the canonical reading's definitions, the module docstring of
  engines/judging/contact.py after its first paragraph (which says what the module is);
- ``exact-columns``, ``reading-columns``, ``floor-columns``, ``force-columns``: one row per
  column of ``EXACT_COLUMNS``, ``EVENT_COLUMNS``, ``FLOOR_COLUMNS`` and ``FORCE_COLUMNS``
  (engines/judging/columns.py) with its ``Col`` docstring;
- ``verdicts``: one row per ``Verdict`` member, in the enum's order, with its docstring;
- ``tolerances``: the tolerance table's tiers (engines/judging/tolerances.toml) key by key,
  and its ``[cone]``;
- ``answer-columns``: the columns of the report's answer.csv (answer_files.ANSWER_COLUMNS).

The docstrings' reST becomes Markdown (``code`` and :role:`name` become `code`; **bold**
stays). A field, member or column without a docstring is an error that names it: an entry
the page lists documents itself in the code.
"""

from __future__ import annotations

import argparse
import ast
import inspect
import math
import re
import sys
import textwrap
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import fields
from pathlib import Path

from hoopbench.engines.judging import contact
from hoopbench.engines.judging.columns import (
    EVENT_COLUMNS,
    EXACT_COLUMNS,
    FLOOR_COLUMNS,
    FORCE_COLUMNS,
    Col,
)
from hoopbench.engines.judging.contact import ContactSettings
from hoopbench.engines.judging.detectors import hoop_scale
from hoopbench.engines.judging.tolerances import Tier, tolerances
from hoopbench.engines.judging.verdict import PHASE_END_TOLERANCE, TIER_NAMES, Verdict
from hoopbench.reports.report.answer_files import ANSWER_COLUMNS

__all__ = [
    "BlockError",
    "attribute_docs",
    "blocks",
    "cell",
    "main",
    "markdown",
    "render",
    "stale_blocks",
]

BEGIN = "<!-- BEGIN generated: {name} (make docs; do not edit) -->"
END = "<!-- END generated: {name} -->"
_BLOCK = re.compile(
    r"<!-- BEGIN generated: (?P<name>[a-z-]+) \(make docs; do not edit\) -->\n"
    r"(?P<body>.*?)"
    r"<!-- END generated: (?P=name) -->",
    re.S,
)
_ANY_MARKER = re.compile(r"<!-- (?:BEGIN|END) generated: ([a-z-]+)")


class BlockError(ValueError):
    """The page's markers, or the code's docstrings, do not make a page."""


# ----------------------------------------------------------------------- reST to Markdown
_ROLE = re.compile(r":[a-z]+:`~?([^`]+)`")
_LITERAL = re.compile(r"``(.+?)``", re.S)
_CODE_SPAN = re.compile(r"(`[^`]*`)")
_SYMBOLS = tuple(
    (re.compile(pattern), symbol)
    for pattern, symbol in (
        (r"\bmu\b", "μ"),
        (r"\btheta\b", "θ"),
        (r"\bthetadot\b", "θ̇"),
        (" >= ", " ≥ "),
        (" <= ", " ≤ "),
    )
)
"""The docstrings' ASCII for the page's symbols, outside code (``mu_rolling`` stays)."""


def markdown(text: str) -> str:
    """A docstring's reST as Markdown: ``code`` and :func:`name` as `code`; **bold**,
    bullets and paragraphs are the same in both. Outside code, mu, theta and thetadot are
    written μ, θ and θ̇, >= and <= as ≥ and ≤."""
    text = _ROLE.sub(lambda m: f"`{m[1]}`", _LITERAL.sub(lambda m: f"`{m[1]}`", text))
    pieces = _CODE_SPAN.split(text)
    for i in range(0, len(pieces), 2):  # the even pieces lie outside code spans
        for pattern, symbol in _SYMBOLS:
            pieces[i] = pattern.sub(symbol, pieces[i])
    return "".join(pieces)


def cell(text: str) -> str:
    """A docstring as one Markdown table cell: one line, its ``|`` escaped."""
    return " ".join(markdown(text).split()).replace("|", "\\|")


def _assigned(statement: ast.stmt) -> str | None:
    """The one name ``statement`` assigns (``NAME = ...`` or ``NAME: type = ...``), or None."""
    if isinstance(statement, ast.AnnAssign):
        target: ast.expr = statement.target
    elif isinstance(statement, ast.Assign) and len(statement.targets) == 1:
        target = statement.targets[0]
    else:
        return None
    return target.id if isinstance(target, ast.Name) else None


def attribute_docs(cls: type) -> dict[str, str]:
    """The docstrings of ``cls``'s attributes (a string right below an assignment, as the
    dataclasses and enums here document their fields and members), by attribute name."""
    (node,) = ast.parse(textwrap.dedent(inspect.getsource(cls))).body
    if not isinstance(node, ast.ClassDef):
        raise BlockError(f"{cls.__qualname__}: its source is no class")
    docs = {}
    for statement, following in zip(node.body, node.body[1:], strict=False):
        name = _assigned(statement)
        if (
            name is not None
            and isinstance(following, ast.Expr)
            and isinstance(following.value, ast.Constant)
            and isinstance(following.value.value, str)
        ):
            docs[name] = inspect.cleandoc(following.value.value)
    return docs


def _documented(docs: Mapping[str, str], names: Iterable[str], what: str) -> list[str]:
    """The docstrings of ``names`` in order; an error naming every one without."""
    names = list(names)
    missing = [name for name in names if not docs.get(name)]
    if missing:
        raise BlockError(f"{what} without a docstring: {', '.join(missing)} (write one)")
    return [docs[name] for name in names]


def _table(header: Sequence[str], rows: Iterable[Sequence[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def _number(value: float) -> str:
    """``value`` in the fewest digits it needs, an exponent as ``1e-6``."""
    text = f"{value:.6g}"
    return re.sub(r"e([+-])0*(\d+)", lambda m: f"e{m[1].lstrip('+')}{m[2]}", text)


# ------------------------------------------------------------------- the canonical reading
_SCALES = {
    "length": ("a", "m", 1e3, "mm"),
    "speed": ("√(g a)", "m/s", 1e3, "mm/s"),
    "duration": ("√(a/g)", "s", 1e3, "ms"),
    "acceleration": ("g", "m/s²", 1.0, "m/s²"),
}
"""How a threshold scales: what it scales with, its SI unit, and as shown (a factor and a
unit)."""

_UNIT_PREFIX = re.compile(r"^(m/s\^2|m/s|ms|m|s|deg)\s*:\s*")
"""A docstring's leading unit (``s: the averaging window``), which a table shows apart."""


def _split_unit(doc: str) -> tuple[str, str]:
    """A docstring's leading unit (``-`` without one) and the rest, capitalised."""
    match = _UNIT_PREFIX.match(doc)
    unit, text = (match[1].replace("^2", "²"), doc[match.end() :]) if match else ("-", doc)
    return unit, text[:1].upper() + text[1:]


def _scale(value: float, moved: float, factors: Mapping[str, float], name: str) -> str | None:
    """Which of ``factors`` carried ``value`` to ``moved`` (None: not scaled)."""
    if value == 0.0 or math.isclose(moved, value, rel_tol=1e-12):
        return None
    for kind, factor in factors.items():
        if math.isclose(moved, value * factor, rel_tol=1e-9):
            return kind
    raise BlockError(f"ContactSettings.{name}: for_hoop scales it by {moved / value:g}, no size")


_DERIVED = ("friction_level",)
"""ContactSettings' thresholds made from its fields (properties), shown after them."""


def contact_thresholds() -> str:
    """The canonical reading's thresholds: name, value on the settings' own hoop, what it
    scales with, and its docstring."""
    base = ContactSettings()
    other = base.for_hoop(4.0 * base.a, 9.0 * base.g)  # every kind of size moves differently
    length, speed, duration = hoop_scale(other.a, other.g, base.a, base.g)
    factors = dict(zip(_SCALES, (length, speed, duration, speed / duration), strict=True))
    docs = {
        **attribute_docs(ContactSettings),
        **{name: inspect.getdoc(getattr(ContactSettings, name)) or "" for name in _DERIVED},
    }
    names = [f.name for f in fields(base) if f.name not in ("a", "g")] + list(_DERIVED)
    rows = []
    for name, doc in zip(names, _documented(docs, names, "ContactSettings field"), strict=True):
        value = float(getattr(base, name))
        kind = _scale(value, float(getattr(other, name)), factors, name)
        if kind is None:
            shown, scales = _number(value), "not scaled"
        else:
            scales, _, factor, unit = _SCALES[kind]
            shown = f"{_number(value * factor)} {unit}"
        rows.append((f"`{name}`", shown, scales, cell(_split_unit(doc)[1])))
    header = (
        "threshold",
        f"a = {_number(base.a)} m, g = {_number(base.g)} m/s²",
        "scales with",
        "meaning",
    )
    return _table(header, rows)


def contact_definitions() -> str:
    """engines/judging/contact.py's module docstring after its first paragraph."""
    doc = inspect.cleandoc(contact.__doc__ or "")
    paragraphs = doc.split("\n\n")
    if len(paragraphs) < 2:
        raise BlockError("engines/judging/contact.py: the module docstring states no definitions")
    return markdown("\n\n".join(paragraphs[1:]))


# ----------------------------------------------------------------- columns, verdicts, tiers
def column_table(columns: Sequence[Col]) -> str:
    """One row per column with its unit and its ``Col`` docstring."""
    docs = attribute_docs(Col)
    meanings = _documented(docs, (c.name for c in columns), "Col member")
    rows = []
    for column, doc in zip(columns, meanings, strict=True):
        unit, text = _split_unit(doc)
        rows.append((f"`{column}`", unit, cell(text)))
    return _table(("column", "unit", "meaning"), rows)


def verdict_table() -> str:
    """One row per verdict, in the enum's order, with its docstring; then the one size the
    docstrings name by its constant."""
    docs = attribute_docs(Verdict)
    meanings = _documented(docs, (v.name for v in Verdict), "Verdict member")
    rows = ((f"`{v}`", cell(m)) for v, m in zip(Verdict, meanings, strict=True))
    table = _table(("verdict", "meaning"), rows)
    end = _number(PHASE_END_TOLERANCE * 1e3)
    return f"{table}\n\n`PHASE_END_TOLERANCE`: {end} ms on the 1 m hoop, scaled with √(a/g)."


_TOLERANCE_NAMES = {
    "t_slip_s": "slip onset",
    "t_lift_s": "lift-off",
    "t_impact_s": "impact",
    "hop_height_rel": "hop height",
    "creep_distance_m": "creep distance",
    "steps": "timesteps added to each time",
}
"""What a reader calls each key of a tier (a key not here is shown by its name alone)."""


def _tolerance(key: str, value: float) -> str:
    """A tolerance as shown: times in ms, lengths in mm, relative ones in %."""
    shown: Mapping[str, Callable[[float], str]] = {
        "_s": lambda v: f"{_number(v * 1e3)} ms",
        "_m": lambda v: f"{_number(v * 1e3)} mm",
        "_rel": lambda v: f"{_number(v * 1e2)} %",
    }
    for suffix, show in shown.items():
        if key.endswith(suffix):
            return show(value)
    return _number(value)


def tolerance_table() -> str:
    """The tiers key by key (1 m hoop), then ``[cone]``."""
    table = tolerances()
    tiers = [table[str(tier)] for tier in Tier]
    keys = list(dict.fromkeys(key for tier in tiers for key in tier))
    header = ["tolerance", *(f"{tier} (`{TIER_NAMES[tier]}`)" for tier in Tier)]
    rows = []
    for key in keys:
        name = _TOLERANCE_NAMES.get(key)
        label = f"`{key}`" if name is None else f"{name} (`{key}`)"
        rows.append([label, *(_tolerance(key, t[key]) if key in t else "-" for t in tiers)])
    cone = ", ".join(f"`{key}` = {_tolerance(key, v)}" for key, v in table["cone"].items())
    return f"{_table(header, rows)}\n\n`[cone]`, both tiers: {cone}."


def blocks() -> dict[str, str]:
    """Every generated block, by name, as the code makes it now."""
    return {
        "contact-thresholds": contact_thresholds(),
        "contact-definitions": contact_definitions(),
        "exact-columns": column_table(EXACT_COLUMNS),
        "reading-columns": column_table(EVENT_COLUMNS),
        "floor-columns": column_table(FLOOR_COLUMNS),
        "force-columns": column_table(FORCE_COLUMNS),
        "verdicts": verdict_table(),
        "tolerances": tolerance_table(),
        "answer-columns": answer_columns(),
    }


def answer_columns() -> str:
    """answer.csv's columns (answer.json's rows' keys), with their meanings
    (answer_files.ANSWER_COLUMNS)."""
    return _table(("column", "meaning"), ([f"`{n}`", cell(m)] for n, m in ANSWER_COLUMNS))


# ------------------------------------------------------------------------------- the page
def _bodies(page: str, names: Iterable[str]) -> dict[str, str]:
    """The page's blocks by name; an error for a marker without its pair, a block twice, an
    unknown block or a missing one."""
    found: dict[str, str] = {}
    for match in _BLOCK.finditer(page):
        if match["name"] in found:
            raise BlockError(f"block {match['name']} appears twice")
        found[match["name"]] = match["body"]
    markers = set(_ANY_MARKER.findall(page))
    unpaired = sorted(markers - found.keys())
    if unpaired or sum(1 for _ in _ANY_MARKER.finditer(page)) != 2 * len(found):
        raise BlockError(f"a BEGIN or END marker without its pair: {unpaired or sorted(found)}")
    expected = list(names)
    unknown = sorted(found.keys() - set(expected))
    missing = [name for name in expected if name not in found]
    if unknown or missing:
        raise BlockError(f"blocks unknown: {unknown}; missing: {missing}")
    return found


def render(page: str, generated: Mapping[str, str] | None = None) -> str:
    """``page`` with every block's body replaced by ``generated`` (:func:`blocks`)."""
    generated = blocks() if generated is None else generated
    _bodies(page, generated)
    return _BLOCK.sub(
        lambda m: (
            f"{BEGIN.format(name=m['name'])}\n{generated[m['name']]}\n{END.format(name=m['name'])}"
        ),
        page,
    )


def stale_blocks(page: str, generated: Mapping[str, str] | None = None) -> list[str]:
    """The names of ``page``'s blocks that differ from ``generated`` (:func:`blocks`)."""
    generated = blocks() if generated is None else generated
    bodies = _bodies(page, generated)
    return [name for name, body in bodies.items() if body != generated[name] + "\n"]


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m hoopbench.reports.report.docs",
        description="Rewrite the generated blocks of docs/report.md from the code.",
    )
    parser.add_argument("page", type=Path, help="the page, docs/report.md")
    parser.add_argument("--check", action="store_true", help="only say which blocks are stale")
    args = parser.parse_args(argv)
    page = args.page.read_text(encoding="utf-8")
    try:
        stale = stale_blocks(page)
        if args.check:
            if stale:
                print(f"{args.page}: out of date: {', '.join(stale)}: run make docs")
            return 1 if stale else 0
        args.page.write_text(render(page), encoding="utf-8")
    except BlockError as error:
        print(f"{args.page}: {error}", file=sys.stderr)
        return 2
    print(f"{args.page}: {len(stale)} block(s) rewritten" + (f": {', '.join(stale)}" * bool(stale)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
