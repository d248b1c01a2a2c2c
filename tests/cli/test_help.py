"""Every help screen: a whole description, plain text, help on every option, defaults shown."""

from __future__ import annotations

import argparse
import re

import pytest

from dpfexplore.cli import build_parser
from dpfexplore.cli.support.help import plain_text


def parsers(parser=None, path=("dpfexplore",)):
    parser = parser or build_parser()
    yield " ".join(path), parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from parsers(sub, (*path, name))


ALL = dict(parsers())


@pytest.mark.parametrize("command", sorted(ALL))
def test_help_screen(command):
    parser = ALL[command]
    description = (parser.description or "").strip()
    assert description, f"{command}: no description"
    assert description.endswith((".", ")")), f"{command}: description cut: {description[-60:]!r}"
    text = parser.format_help()
    assert not re.search(r"``|:(func|mod|class|meth|data|attr):`", text), text
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction | argparse._VersionAction):
            continue
        if isinstance(action, argparse._SubParsersAction):
            continue
        name = "/".join(action.option_strings) or action.dest
        assert action.help, f"{command} {name}: no help"
        valued = action.option_strings and action.nargs != 0
        if valued and action.default not in (None, False, True, [], argparse.SUPPRESS):
            shown = parser._get_formatter()._get_help_string(action)
            assert "default" in shown.lower(), f"{command} {name}: default not shown"


def test_plain_text():
    assert plain_text("see :func:`~dpfexplore.find_state` and ``x = 1``") == (
        "see dpfexplore.find_state and x = 1"
    )
    assert plain_text(":mod:`.numpy_model`") == "numpy_model"


def test_file_options_name_their_kind_alike():
    plots = [
        action
        for parser in ALL.values()
        for action in parser._actions
        if "--plot" in action.option_strings and action.nargs != 0
    ]
    assert plots and all(action.metavar == "FILE.png" for action in plots)
