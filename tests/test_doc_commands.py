"""Every command block of the README and the guides runs as written, printing what they quote.

The blocks run in one scratch working directory (the repository's ``jobs/``, ``scripts/`` and
``dpfexplore/`` linked in, a fresh ``results/``), in the order a reader meets them: the README,
the index page, then the guides in the order of the site's table of contents, so that a block
may use what an earlier block wrote. ``dpfexplore ...`` runs in-process through
:func:`dpfexplore.cli.main`, ``python -c CODE`` through ``exec`` and ``python scripts/X.py``
through :mod:`runpy`. The set-up commands (``python3 -m venv``, ``pip install``, ``source``, the
test suite, the docs build, ruff) are what CI itself runs: they are recognised, checked against
``.ci/run`` and the tests that run them, and not run again here. How blocks are marked and
output compared: ``tests/doc_commands.py`` and docs/decisions.md.
"""

from __future__ import annotations

import contextlib
import io
import re
import runpy
import shlex
import sys
from pathlib import Path

import pytest
from doc_commands import Block, output_mismatch, parse_blocks

from dpfexplore.cli import main

ROOT = Path(__file__).parents[1]
GUIDE = ROOT / "docs" / "guide"


def _documents() -> list[Path]:
    """README, index, then the guides in the toctree's order (others after, by name)."""
    toctree = re.findall(r"^guide/(\S+)$", (ROOT / "docs" / "index.md").read_text(), re.M)
    ordered = [GUIDE / f"{name}.md" for name in toctree if (GUIDE / f"{name}.md").exists()]
    rest = sorted(set(GUIDE.glob("*.md")) - set(ordered))
    return [ROOT / "README.md", ROOT / "docs" / "index.md", *ordered, *rest]


BLOCKS: list[Block] = [block for doc in _documents() for block in parse_blocks(doc)]

#: Set-up commands: what CI runs itself (the pattern, and where it is run).
SET_UP = {
    r"\(command -v chromium >/dev/null \|\| \(apt-get update && apt-get install -y chromium "
    r"chromium-driver\)\)": ".ci/run",
    r"python3 -m venv \.venv": ".ci/run",
    r"\.venv/bin/pip install -e (\.|\"\.\[test\]\")": ".ci/run",
    r"pip install -e \"\.\[explore\]\"": "pyproject.toml (the explore extra, in the test extra)",
    r"source \.venv/bin/activate": ".ci/run (the harness calls the installed entry point)",
    r"(\.venv/bin/)?python -m pytest": ".ci/run",
    r"(\.venv/bin/)?python -m pytest tests/test_docs\.py": "tests/test_docs.py",
    r"(\.venv/bin/)?python -m sphinx -b html docs docs/_build/html": "tests/test_docs.py",
    r"\.venv/bin/ruff (format|check) dpfexplore tests docs": "tests/test_style.py",
    r"pip install 'dpfexplore\[crosscheck\]'": "pyproject.toml (the crosscheck extra)",
}


def set_up_of(command: str) -> str | None:
    """Where CI runs ``command`` if it is a set-up command, else None."""
    for pattern, where in SET_UP.items():
        if re.fullmatch(pattern, command.strip()):
            return where
    return None


def _runnable(command: str) -> bool:
    words = shlex.split(command)
    return bool(words) and (
        words[0] in ("dpfexplore", ".venv/bin/dpfexplore")
        or words[:2] == ["python", "-c"]
        or (words[0] == "python" and len(words) > 1 and words[1].startswith("scripts/"))
    )


def test_every_command_is_run_or_is_set_up():
    assert len(BLOCKS) > 20
    for block in BLOCKS:
        for command in block.commands:
            assert set_up_of(command.text) or _runnable(command.text), (
                f"{block.name}: {command.text!r} is neither a command the harness runs nor a "
                "set-up command CI runs"
            )


def test_set_up_commands_are_what_ci_runs():
    """The set-up lines are not run here: CI runs them (.ci/run), or the named test does."""
    ci = (ROOT / ".ci" / "run").read_text()
    seen = set()
    for block in BLOCKS:
        for command in block.commands:
            where = set_up_of(command.text)
            if where is None:
                continue
            seen.add(where)
            if where == ".ci/run":
                # the same tool invocation as CI's line (CI's install adds the test extra)
                head = " ".join(command.text.split()[:3])
                assert head in ci, (block.name, command.text)
            else:
                assert (ROOT / where.split(" ")[0]).exists(), where
    assert ".ci/run" in seen and "tests/test_docs.py" in seen


@pytest.fixture(scope="module")
def workspace(tmp_path_factory):
    """The scratch working directory every block runs in, in order."""
    root = tmp_path_factory.mktemp("doc-commands")
    for name in ("jobs", "scripts", "dpfexplore"):
        (root / name).symlink_to(ROOT / name, target_is_directory=True)
    (root / "results").mkdir()
    return root


def _run(command: str) -> tuple[int, str, str]:
    """Run one documented command; its exit code and what it printed."""
    words = shlex.split(command)
    out, err = io.StringIO(), io.StringIO()
    code = 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            if words[0].endswith("dpfexplore"):
                code = main(words[1:])
            elif words[:2] == ["python", "-c"]:
                exec(compile(words[2], "<doc -c>", "exec"), {"__name__": "__main__"})
            else:
                argv, sys.argv = sys.argv, words[1:]
                try:
                    runpy.run_path(words[1], run_name="__main__")
                finally:
                    sys.argv = argv
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
    return code, out.getvalue(), err.getvalue()


def _not_run(block: Block) -> bool:
    """Marked ``not run: REASON`` beside the block (the guide's text says why)."""
    return block.marker is not None and block.marker.startswith("not run: ")


#: The blocks the harness runs: all but those marked not run and those of set-up lines only.
RUN = [
    block
    for block in BLOCKS
    if not _not_run(block) and any(not set_up_of(c.text) for c in block.commands)
]


def test_a_block_not_run_says_why():
    """Every block left out is marked with its reason."""
    left_out = [block for block in BLOCKS if _not_run(block)]
    for block in left_out:
        assert len(block.marker) > 20, (block.name, block.marker)
    for block in BLOCKS:
        assert (
            block.marker is None
            or _not_run(block)
            or re.fullmatch(r"exit (\d+): .{10,}", block.marker)
        ), (block.name, block.marker)


@pytest.mark.parametrize("block", RUN, ids=[b.name for b in RUN])
def test_block_runs_as_written(block, workspace, monkeypatch):
    found = re.fullmatch(r"exit (\d+): .{10,}", block.marker or "")
    exit_code = int(found.group(1)) if found else 0  # a documented exit code, the text says why
    monkeypatch.chdir(workspace)
    for command in block.commands:
        if set_up_of(command.text):
            continue  # CI's own set-up (test_set_up_commands_are_what_ci_runs)
        code, out, err = _run(command.text)
        assert code == exit_code, f"{block.name}: {command.text}\n{err[-3000:]}"
        if command.expected:
            problem = output_mismatch(command.expected, out.splitlines())
            assert problem is None, f"{block.name}: {command.text}\n{problem}"


# ------------------------------------------------------------------- the harness's own rules


def test_output_rules():
    # a timing (followed by s or ms) matches any number; a result must agree to its digits
    assert output_mismatch(["total 0.80 s; query 0.27 ms"], ["total 9.12 s; query 3.5 ms"]) is None
    assert output_mismatch(["tip 35.0000"], ["tip 35.0001"]) is None  # one unit of the last digit
    assert output_mismatch(["tip 35.0000"], ["tip 35.0002"]) is not None
    assert output_mismatch(["480 rows"], ["481 rows"]) is not None  # counts exactly
    assert output_mismatch(["2.657"], ["2.657166896"]) is None  # quoted to fewer digits
    # residuals below 1e-8 agree with each other, not with a real error
    assert output_mismatch(["error 8.22e-13"], ["error 8.17e-13"]) is None
    assert output_mismatch(["error 8.22e-13"], ["error 8.17e-05"]) is not None
    # a number right-aligned under a table's "s" is a timing; under "N/mm" it is a result
    table = ["  N/mm   wall", "  N/mm      s", "0.1234   0.46"]
    assert output_mismatch(table, ["  N/mm   wall", "  N/mm      s", "0.1234   9.99"]) is None
    assert output_mismatch(table, ["  N/mm   wall", "  N/mm      s", "0.1244   0.46"]) is not None
    # "..." stands for lines, or for text within a line
    assert output_mismatch(["{", "...", "}"], ["{", "a", "b", "}"]) is None
    assert output_mismatch(["a ... z"], ["a b c z"]) is None
    assert output_mismatch(["a", "b"], ["a"]) is not None


def test_blocks_are_read_as_written(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(
        "text\n\n```console\n$ dpfexplore a --x 1 \\\n    --y 2   # comment\nout 1\nout 2\n"
        "$ dpfexplore b\n```\n\n<!-- doc-test: not run: a reason of some length -->\n"
        "```bash\npython3 -m venv .venv && .venv/bin/pip install -e .\n```\n\n```python\nx\n```\n"
    )
    first, second = parse_blocks(page)
    assert [c.text for c in first.commands] == ["dpfexplore a --x 1 --y 2", "dpfexplore b"]
    assert first.commands[0].expected == ["out 1", "out 2"] and first.commands[1].expected == []
    assert second.marker == "not run: a reason of some length"
    assert [set_up_of(c.text) for c in second.commands] == [".ci/run", ".ci/run"]
    page.write_text("```bash\n(a || (b && c)) && d && (e)\n```\n")
    (group,) = parse_blocks(page)
    assert [c.text for c in group.commands] == ["(a || (b && c))", "d", "(e)"]
