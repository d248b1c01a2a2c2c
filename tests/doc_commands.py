"""The documentation's command blocks, read from the Markdown as a reader sees them.

Used by ``tests/test_doc_commands.py``; the conventions are in docs/decisions.md ("Recipes that
run as written"):

* a ```` ```console ```` block holds commands after a ``$ `` prompt, each followed by the output
  it prints (nothing below a command: its output is not quoted); a ```` ```bash ```` block holds
  commands only, one a line. A line ending in ``\\`` continues on the next; ``#`` starts a
  comment; ``&&`` chains commands.
* an HTML comment on the line before the block, ``<!-- doc-test: not run: REASON -->``, is the
  only way out of running a block, and the guide's own text says why beside it;
  ``<!-- doc-test: exit N: REASON -->`` expects exit code N (0 otherwise) of its commands.
* output is compared line by line (runs of spaces are equal): a line ``...`` stands for any
  lines, ``...`` inside a line for any text; a number that is a timing (followed by ``s`` or
  ``ms``, or right-aligned under an ``s`` in a table's unit row) matches any number; a value
  below 1e-8 in magnitude (a solver's residual) matches any such value; every other number must
  agree to the digits printed (within one unit of its last digit; integers exactly).
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

FENCE = re.compile(
    r"^(?P<indent>[ ]*)```(?P<lang>[\w-]*)[^\n]*\n(?P<body>.*?)^(?P=indent)```[ ]*$",
    re.M | re.S,
)
MARKER = re.compile(r"<!--\s*doc-test:\s*(?P<text>.*?)\s*-->\s*$")
COMMAND_LANGS = ("bash", "console", "sh", "shell")
NUMBER = r"[-+]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?"
TIME_UNIT = re.compile(r"^(?:s|ms|µs)(?:[,;:)]|$)")
#: Magnitudes below this are a solver's residuals: any two of them agree.
RESIDUAL = 1e-8


@dataclass
class Command:
    """One command of a block, with the output lines the text quotes below it."""

    text: str
    expected: list[str] = field(default_factory=list)


@dataclass
class Block:
    """A fenced command block of a Markdown file."""

    path: Path
    line: int
    lang: str
    marker: str | None
    commands: list[Command]

    @property
    def name(self) -> str:
        """``FILE:LINE`` of the block's fence."""
        return f"{self.path.name}:{self.line}"


def _strip_comment(line: str) -> str:
    """``line`` without a trailing ``# comment`` (quotes respected)."""
    quote = None
    for i, char in enumerate(line):
        if quote:
            if char == quote:
                quote = None
        elif char in "'\"":
            quote = char
        elif char == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip()
    return line.rstrip()


def _joined(lines: list[str]) -> list[str]:
    """Lines with ``\\`` continuations joined."""
    out: list[str] = []
    pending = ""
    for line in lines:
        if line.rstrip().endswith("\\"):
            pending += line.rstrip()[:-1].rstrip() + " "
            continue
        out.append((pending + line.strip()) if pending else line)
        pending = ""
    return out


def _and_chain(row: str) -> list[str]:
    """The commands of ``a && b && c``, a parenthesised group kept whole."""
    parts, depth, start = [], 0, 0
    for i, char in enumerate(row):
        depth += {"(": 1, ")": -1}.get(char, 0)
        if depth == 0 and row.startswith(" && ", i):
            parts.append(row[start:i])
            start = i + 4
    return [*parts, row[start:]]


def parse_blocks(path: Path) -> list[Block]:
    """Every command block of the Markdown file ``path``, in order."""
    text = path.read_text(encoding="utf-8")
    blocks = []
    for match in FENCE.finditer(text):
        lang = match.group("lang")
        if lang not in COMMAND_LANGS:
            continue
        line = text.count("\n", 0, match.start()) + 1
        before = text[: match.start()].rstrip("\n").rsplit("\n", 1)[-1]
        marker = MARKER.search(before)
        body = match.group("body").splitlines()
        commands: list[Command] = []
        if lang == "console":
            current: list[str] | None = None
            raw: list[tuple[str, list[str]]] = []
            for row in body:
                if row.startswith("$ "):
                    current = [row[2:]]
                    raw.append(("", current))
                elif current is not None and current[-1].rstrip().endswith("\\"):
                    current.append(row)
                elif raw:
                    raw[-1] = (raw[-1][0] + row + "\n", current)
            for output, parts in raw:
                command = _strip_comment(_joined(parts)[0])
                expected = output.rstrip("\n").split("\n") if output.strip() else []
                commands.append(Command(command, expected))
        else:
            for row in _joined(body):
                row = _strip_comment(row)
                if row.strip():
                    commands.extend(Command(part.strip()) for part in _and_chain(row))
        blocks.append(Block(path, line, lang, marker.group("text") if marker else None, commands))
    return blocks


# --------------------------------------------------------------------------- output matching


def _timing_columns(lines: list[str]) -> set[int]:
    """End columns of ``s``/``ms`` in a table's unit row (a row of units only)."""
    ends: set[int] = set()
    units = re.compile(r"^(?:mm²?|N|N/mm|N·mm|MPa|s|ms|1|%|deg|rad)$")
    for line in lines:
        tokens = list(re.finditer(r"\S+", line))
        if tokens and all(units.match(t.group()) for t in tokens):
            ends |= {t.end() for t in tokens if t.group() in ("s", "ms")}
    return ends


def _agree(expected: str, actual: str) -> bool:
    e, a = float(expected), float(actual)
    if abs(e) < RESIDUAL and abs(a) < RESIDUAL:
        return True
    mantissa, _, exponent = expected.lower().lstrip("+-").partition("e")
    if "." not in mantissa and not exponent:
        return e == a
    decimals = len(mantissa.partition(".")[2])
    unit = 10.0 ** (int(exponent or 0) - decimals)
    return abs(e - a) <= 1.01 * unit


def _line_pattern(line: str, timing_ends: set[int]):
    """A regex for an expected line and, per number it captures, whether it is a timing."""
    parts, timings = [], []
    position = 0
    pieces = re.finditer(rf"(?P<dots>\.\.\.)|(?P<num>{NUMBER})|(?P<space>\s+)|(?P<other>.)", line)
    for piece in pieces:
        if piece.group("dots") is not None:
            parts.append(".*?")
        elif piece.group("num") is not None:
            rest = line[piece.end() :].lstrip()
            timing = (
                piece.end() in timing_ends
                or (line[piece.end() : piece.end() + 1] == " " and bool(TIME_UNIT.match(rest)))
            ) and not line[:position].rstrip().endswith(("[", "("))
            parts.append(f"({NUMBER})")
            timings.append(timing)
        elif piece.group("space") is not None:
            parts.append(r"\s+")
        else:
            parts.append(re.escape(piece.group("other")))
        position = piece.end()
    return re.compile(r"\s*" + "".join(parts) + r"\s*"), timings


def _line_matches(expected: str, actual: str, timing_ends: set[int]) -> bool:
    pattern, timings = _line_pattern(expected, timing_ends)
    found = pattern.fullmatch(actual)
    if found is None:
        return False
    wanted = re.findall(NUMBER, re.sub(r"\.\.\.", " ", expected))
    if len(wanted) != len(timings):  # a number split by the tokenizer: compare as text
        return True
    for want, got, timing in zip(wanted, found.groups(), timings, strict=True):
        if not timing and not _agree(want, got):
            return False
    return True


def output_mismatch(expected: list[str], actual: list[str]) -> str | None:
    """None when ``actual`` (the printed lines) matches ``expected``; else what differs."""
    timing_ends = _timing_columns(expected)
    actual = [line for line in actual if line.strip()]
    expected = [line for line in expected if line.strip()]

    def match(i: int, j: int) -> bool:
        if i == len(expected):
            return j == len(actual)
        if expected[i].strip() == "...":
            return any(match(i + 1, k) for k in range(j, len(actual) + 1))
        return (
            j < len(actual)
            and _line_matches(expected[i], actual[j], timing_ends)
            and match(i + 1, j + 1)
        )

    if match(0, 0):
        return None
    for i, (want, got) in enumerate(zip(expected, actual, strict=False)):
        if want.strip() == "...":
            break
        if not _line_matches(want, got, timing_ends):
            return f"line {i + 1}: expected\n  {want}\nprinted\n  {got}"
    return "expected:\n" + "\n".join(expected) + "\nprinted:\n" + "\n".join(actual)
