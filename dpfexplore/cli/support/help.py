"""How every ``dpfexplore`` help screen is written: plain text, whole paragraphs, defaults shown.

Descriptions and option help often come from docstrings written for Sphinx; a terminal shows
them as plain text (``x`` and :func:`a.b` become x and a.b). Paragraphs and ``*`` bullets are
wrapped one by one instead of run together, every option that has a value by default says it,
and a subcommand without a description takes its one-line help as one.
"""

from __future__ import annotations

import argparse
import re
import textwrap

__all__ = ["ArgumentParser", "plain_text"]

_ROLE = re.compile(r":[a-z]+:`[~.]*([^`<]*?)(?:\s*<[^>]*>)?`")
_LITERAL = re.compile(r"``([^`]*)``")
_LINK = re.compile(r"`([^`<]*?)(?:\s*<[^>]*>)?`_?")


def plain_text(text: str | None) -> str | None:
    """``text`` with reStructuredText roles, literals and links written as plain words."""
    if not text:
        return text
    text = _ROLE.sub(r"\1", text)
    text = _LITERAL.sub(r"\1", text)
    return _LINK.sub(r"\1", text)


def _shows_default(action: argparse.Action) -> bool:
    if action.default in (None, False, True, argparse.SUPPRESS) or action.default == []:
        return False
    if not action.option_strings or action.nargs == 0:
        return False
    help_text = action.help or ""
    return "%(default)" not in help_text and "default" not in help_text.lower()


class HelpFormatter(argparse.HelpFormatter):
    """Paragraph- and bullet-aware wrapping; ``(default: ...)`` on options that have one."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        blocks = []
        for paragraph in re.split(r"\n\s*\n", text.strip()):
            items = re.split(r"\n\s*(?=[*-] )", paragraph)
            for item in items:
                bullet = item.lstrip().startswith(("* ", "- "))
                words = " ".join(item.split())
                blocks.append(
                    textwrap.fill(
                        words,
                        width,
                        initial_indent=indent,
                        subsequent_indent=indent + ("  " if bullet else ""),
                    )
                )
            blocks.append("")
        return "\n".join(blocks).rstrip() + "\n"

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if _shows_default(action):
            text += " (default: %(default)s)"
        return text


class _SubParsers(argparse._SubParsersAction):
    def add_parser(self, name: str, **kwargs):
        if kwargs.get("description") is None and kwargs.get("help"):
            summary = plain_text(kwargs["help"]).strip()
            kwargs["description"] = summary[:1].upper() + summary[1:].rstrip(".") + "."
        return super().add_parser(name, **kwargs)


class ArgumentParser(argparse.ArgumentParser):
    """The parser class of the CLI and, through ``add_subparsers``, of all its subcommands."""

    def __init__(self, *args, **kwargs) -> None:
        kwargs.setdefault("formatter_class", HelpFormatter)
        kwargs["description"] = plain_text(kwargs.get("description"))
        super().__init__(*args, **kwargs)
        self.register("action", "parsers", _SubParsers)

    def error(self, message: str):
        """Bad arguments: one line and exit code 2, as every other input error.

        argparse prints the whole usage first; ``--help`` shows it when wanted.
        """
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")

    def add_argument(self, *args, **kwargs):
        """As argparse's, with the help text made plain (no reStructuredText markup)."""
        if isinstance(kwargs.get("help"), str):
            kwargs["help"] = plain_text(kwargs["help"])
        return super().add_argument(*args, **kwargs)
