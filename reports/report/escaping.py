"""Strings read from a results folder are data: never markup, never a path.

A results folder may come from anyone (a colleague, a cluster, a download): its scene, engine
and variant names, messages and reasons reach ``report.md`` and the figures' file names. Every
such string goes through one of these functions:

- :func:`escape_text` for Markdown prose and headings, :func:`escape_cell` for a table cell
  (the same escaping: a cell's ``|`` is escaped in both);
- :func:`escape_html` for an HTML report;
- :func:`file_stem` for a file name made from a name.
"""

from __future__ import annotations

import hashlib
import html
import re

from hoopbench.reports.sweep.control_chars import visible_controls

__all__ = ["escape_cell", "escape_html", "escape_text", "file_stem"]

_MARKUP = re.compile(r"[\\`*\[\]|~$]|(?<![A-Za-z0-9])_|_(?![A-Za-z0-9])")
"""Characters that can start or end Markdown markup (GitHub's: tables, strikethrough, math).
An underscore inside a word (``collision_bias``) cannot, and stays as it is."""

_ENTITIES = {"&": "&amp;", "<": "&lt;", ">": "&gt;"}
"""As HTML entities: an HTML tag or autolink becomes text (``<script>``, ``<img onerror>``)."""

_LINE_BREAKS = re.compile(r"[\r\n\u2028\u2029\x0b\x0c\x85]+")


def escape_text(value: object) -> str:
    """``value`` as Markdown text that renders as itself: markup characters backslash-escaped,
    ``&``, ``<`` and ``>`` as entities, line breaks as one space (a break would end the
    table row or the heading), other control characters and bidirectional overrides as their
    codes (``\\x1b``)."""
    text = visible_controls(_LINE_BREAKS.sub(" ", str(value)))
    text = "".join(_ENTITIES.get(c, c) for c in text)
    return _MARKUP.sub(lambda m: "\\" + m.group(0), text)


def escape_cell(value: object) -> str:
    """``value`` as the text of one cell of a Markdown table (:func:`escape_text`: its ``|``
    cannot add a column, nor a line break end the row)."""
    return escape_text(value)


def escape_html(value: object) -> str:
    """``value`` as HTML text or attribute value (quotes included; control characters as
    their codes)."""
    return html.escape(visible_controls(value), quote=True)


_CLEAN_STEM = re.compile(r"[a-z0-9][a-z0-9_-]{0,63}")
"""A name used as it is in a file name: lower case (no two names meet on a file system that
ignores case), no dot, no separator."""

_HASH_CHARS = 16
"""Hex digits of the name's SHA-256 in a file name made from an unclean name (64 bits)."""


def file_stem(name: object) -> str:
    """A file name stem for ``name``: the name itself if it is clean (lower-case ASCII letters,
    digits, ``-`` and ``_``, as the catalogue's names), else a slug of it, a dot and a hash of
    the whole name. Never a separator or ``..``; two distinct names never share a stem (a
    clean stem has no dot, a hashed one has one)."""
    text = str(name)
    if _CLEAN_STEM.fullmatch(text):
        return text
    slug = re.sub(r"[^A-Za-z0-9_-]+", "-", text).strip("-")[:40] or "name"
    digest = hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest()[:_HASH_CHARS]
    return f"{slug}.{digest}"
