"""docs/report.md restates the code only where the code writes it: its generated blocks are
what reports/report/docs.py makes from the docstrings now (``make docs``), they render as
Markdown, and every column of a run's row is on the page."""

from __future__ import annotations

import fnmatch
import re
from pathlib import Path

import pytest
from markdown_it import MarkdownIt

from hoopbench.engines.judging.contact import ContactSettings
from hoopbench.engines.judging.verdict import Verdict
from hoopbench.reports.compare.suite import ROW_COLUMNS
from hoopbench.reports.report import docs

ROOT = Path(__file__).resolve().parent.parent
PAGE = ROOT / "docs" / "report.md"


def test_the_generated_blocks_are_what_the_code_makes_now():
    stale = docs.stale_blocks(PAGE.read_text(encoding="utf-8"))
    assert not stale, (
        f"docs/report.md lags the code's docstrings in its blocks {', '.join(stale)}: "
        "run make docs (and read the result)"
    )


def test_every_verdict_has_its_row():
    page = PAGE.read_text(encoding="utf-8")
    missing = [str(v) for v in Verdict if f"\n| `{v}` | " not in page]
    assert not missing, f"verdicts without a row in docs/report.md: {missing}: run make docs"


def test_every_threshold_the_definitions_name_has_its_row():
    """A threshold of ContactSettings that the canonical reading's definitions name (a field
    or a property made from them, as friction_level) is in the thresholds table."""
    named = set(re.findall(r"`(\w+)`", docs.contact_definitions()))
    thresholds = {name for name in named if hasattr(ContactSettings, name)}
    table = docs.contact_thresholds()
    missing = sorted(name for name in thresholds if f"| `{name}` |" not in table)
    assert thresholds and not missing, f"thresholds named without a row: {missing}"


def _mentioned(page: str) -> set[str]:
    """Every name in a code span of the page (``a``, ``b`` in `a`, `b`; patterns like
    ``kin_*`` as they are)."""
    spans = re.findall(r"`([^`\n]+)`", page)
    return {word for span in spans for word in re.split(r"[\s,]+", span) if word}


def test_every_column_of_a_row_is_on_the_page():
    """The hand-written column tables (identity, cost, sanity) cannot lag silently: a column
    added to a row must be named on the page (a ``kin_*`` pattern names its family)."""
    names = _mentioned(PAGE.read_text(encoding="utf-8"))
    patterns = [name for name in names if "*" in name]
    missing = [
        str(c)
        for c in ROW_COLUMNS
        if c not in names and not any(fnmatch.fnmatch(c, p) for p in patterns)
    ]
    assert not missing, f"columns of a run's row that docs/report.md never names: {missing}"


def _tables(tokens: list) -> list[list[int]]:
    """Per table, the number of cells of each row (the header first)."""
    tables: list[list[int]] = []
    for token in tokens:
        if token.type == "table_open":
            tables.append([])
        elif token.type == "tr_open":
            tables[-1].append(0)
        elif token.type in ("th_open", "td_open"):
            tables[-1][-1] += 1
    return tables


@pytest.mark.parametrize("name", sorted(docs.blocks()))
def test_each_block_renders_as_markdown(name):
    """reST gone (no ``double`` literal, no :role:); a table's every row has the header's
    columns (an unescaped ``|`` in a docstring would split a cell, and Markdown drops what
    lies beyond the header's last column)."""
    text = docs.blocks()[name]
    assert "``" not in text and not re.search(r":[a-z]+:`", text), text
    rows = [line for line in text.splitlines() if line.startswith("|")]
    widths = {len(re.findall(r"(?<!\\)\|", row)) for row in rows}
    assert len(widths) <= 1, (name, widths)
    tables = _tables(MarkdownIt("commonmark").enable("table").parse(text))
    assert sum(len(t) for t in tables) == len(rows) - len(tables)  # a delimiter row each


def test_the_definitions_keep_their_bold_and_bullets():
    html = MarkdownIt("commonmark").render(docs.blocks()["contact-definitions"])
    assert "<strong>slip</strong>" in html and "<li>" in html


def test_markdown_of_a_docstring():
    assert docs.markdown("``a`` and :func:`b`, :class:`~c.D`") == "`a` and `b`, `c.D`"
    assert docs.markdown("mu n >= f, ``mu_rolling``, mujoco") == "μ n ≥ f, `mu_rolling`, mujoco"
    assert docs.markdown("at ``x >= mu``") == "at `x >= mu`"
    assert docs.cell("|f| <= mu\n    n") == "\\|f\\| ≤ μ n"


def test_attribute_docs_read_the_string_below_each_member():
    verdicts = docs.attribute_docs(Verdict)
    assert verdicts["AGREES"].startswith("Every event within the tight tolerances")
    assert "CREEPS" in verdicts


def test_a_page_without_its_markers_is_refused():
    page = PAGE.read_text(encoding="utf-8")
    begin = docs.BEGIN.format(name="verdicts")
    with pytest.raises(docs.BlockError, match="missing"):
        docs.render(re.sub(r"<!-- (BEGIN|END) generated: verdicts[^>]*-->\n?", "", page))
    with pytest.raises(docs.BlockError, match="without its pair"):
        docs.render(page.replace(docs.END.format(name="verdicts"), ""))
    with pytest.raises(docs.BlockError, match="twice"):
        docs.render(page + f"\n{begin}\n{docs.END.format(name='verdicts')}\n")


def test_render_keeps_the_prose_and_is_idempotent():
    page = PAGE.read_text(encoding="utf-8")
    once = docs.render(page)
    assert docs.render(once) == once
    outside = docs._BLOCK.sub("", page)
    assert docs._BLOCK.sub("", once) == outside


def test_a_member_without_a_docstring_is_named(monkeypatch):
    real = docs.attribute_docs

    def without_agrees(cls: type) -> dict[str, str]:
        found = real(cls)
        return {k: v for k, v in found.items() if not (cls is Verdict and k == "AGREES")}

    monkeypatch.setattr(docs, "attribute_docs", without_agrees)
    with pytest.raises(docs.BlockError, match="Verdict member without a docstring: AGREES"):
        docs.verdict_table()
