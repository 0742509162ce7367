"""Control characters from outside shown as text, never obeyed.

A scene name, a lock file's content or an error message may hold an escape sequence (that
retitles or clears a terminal, or paints a fake line), a bell, a NUL, or a bidirectional
override (U+202E turns the rest of a line around). Every string that came from a file, a name
or an error message goes through one of:

- :func:`terminal_text` before it is printed (stderr, stdout); :func:`say` prints a line
  through it;
- :func:`visible_controls`, which the report's escaping (reports/report/escaping.py) applies
  to every string of report.md and report.html.

Both spell each such character as its code (``\\x1b``, ``\\u202e``): the reader sees that
something was there, and nothing acts on it.
"""

from __future__ import annotations

import re
import sys
from typing import TextIO

__all__ = ["CONTROLS", "say", "terminal_text", "visible_controls"]

CONTROLS = re.compile(
    "[\x00-\x08\x0b-\x1f\x7f-\x9f\u061c\u200e\u200f\u202a-\u202e\u2066-\u2069\ufff9-\ufffb]"
)
"""C0 controls but tab and line feed, DEL, C1 controls (a lone CSI, U+009B, starts an escape
sequence too), and the bidirectional marks, embeddings, overrides and isolates."""


def _code(match: re.Match[str]) -> str:
    char = match.group(0)
    return f"\\x{ord(char):02x}" if ord(char) < 0x100 else f"\\u{ord(char):04x}"


def visible_controls(value: object) -> str:
    """``str(value)`` with every control character of :data:`CONTROLS` as its code."""
    return CONTROLS.sub(_code, str(value))


def terminal_text(value: object) -> str:
    """``value`` as text safe to print on a terminal (:func:`visible_controls`)."""
    return visible_controls(value)


def say(text: object, stream: TextIO | None = None) -> None:
    """Print ``text`` on stderr (or ``stream``) through :func:`terminal_text`, flushed: every
    line of ours that may quote a file, a name or an argument."""
    print(terminal_text(text), file=sys.stderr if stream is None else stream, flush=True)
