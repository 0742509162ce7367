"""Every command and every option of ``hoopbench`` says in its --help what it is for."""

from __future__ import annotations

import argparse
from functools import cache

import pytest

from hoopbench.reports import cli


@cache
def _subcommands() -> argparse._SubParsersAction:
    """The parser's subcommands, built once (building imports every engine's adapter)."""
    parser = cli._parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return sub


def _commands() -> dict[str, argparse.ArgumentParser]:
    return dict(_subcommands().choices)


def _said(action: argparse.Action) -> bool:
    return bool(action.help and action.help.strip()) and action.help != argparse.SUPPRESS


def test_every_command_has_help():
    sub = _subcommands()
    helped = {a.dest for a in sub._choices_actions if _said(a)}
    assert helped == set(sub.choices)


@pytest.mark.parametrize("command", sorted(_commands()))
def test_every_option_has_help(command):
    """An option listed bare in --help (`--engine {...}` and nothing after it) leaves the user
    to guess; each one says what it is, its unit and its default where it has them."""
    bare = [
        "/".join(a.option_strings) or a.dest for a in _commands()[command]._actions if not _said(a)
    ]
    assert not bare, f"hoopbench {command}: no help text for {bare}"
