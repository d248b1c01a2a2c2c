r"""The longest silence of a command: run it piped, timestamp each line it writes, report gaps.

A command that works for minutes should never leave its user without a line for more than a
few seconds (docs/decisions.md, "Progress"). This runs each command given (a shell command
line, as the README and the guides write it, with ``dpfexplore`` run as ``python -m dpfexplore``
on this checkout's package, by the Python that runs the script) with standard output and
standard error on pipes, reads both as lines
arrive, and prints per command: its wall time, the longest gap between two lines (from the
start to the first line and from the last line to the exit count too), where that gap ended,
and the exit code.

Run from the repository root::

    .venv/bin/python scripts/silence.py "dpfexplore states gripper --sequential" \
        "dpfexplore design jobs/design-gripper.toml --plot --out /tmp/g --force"
    .venv/bin/python scripts/silence.py --from-docs --list     # the documented commands
    .venv/bin/python scripts/silence.py -v "dpfexplore sweep jobs/smoke.toml --out /tmp/s"

``-v`` also prints every line with its time. With ``NUMBA_CACHE_DIR=$(mktemp -d)`` in the
environment the commands run on an empty Numba cache (a first run after an install).
"""

from __future__ import annotations

import argparse
import itertools
import os
import re
import selectors
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def documented() -> list[str]:
    """The ``dpfexplore ...`` command lines of README.md and docs/guide/*.md (one per line)."""
    found: list[str] = []
    for path in [ROOT / "README.md", *sorted((ROOT / "docs" / "guide").glob("*.md"))]:
        lines = path.read_text(encoding="utf-8").splitlines()
        for i, line in enumerate(lines):
            match = re.match(r"^(?:\$ |\.venv/bin/)?(dpfexplore \S.*)$", line.strip())
            if match is None:
                continue
            command = match.group(1).split("  #")[0].strip()
            if "`" in command or command.endswith(("...", ":")) or " is " in command:
                continue  # prose or an output line, not a command
            while command.endswith("\\") and i + 1 < len(lines):
                i += 1
                command = command[:-1].rstrip() + " " + lines[i].strip()
            if command not in found:
                found.append(command)
    return found


def run(command: str, *, verbose: bool = False) -> dict:
    """Run ``command`` piped; the times of its lines, its longest silence and its exit code."""
    shell = re.sub(r"^dpfexplore\b", f"{sys.executable} -m dpfexplore", command)
    env = dict(os.environ, PYTHONPATH=str(ROOT))  # this checkout's package
    start = time.monotonic()
    proc = subprocess.Popen(
        shell, shell=True, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE
    )
    chooser = selectors.DefaultSelector()
    buffers = {}
    for name, stream in (("out", proc.stdout), ("err", proc.stderr)):
        os.set_blocking(stream.fileno(), False)
        chooser.register(stream, selectors.EVENT_READ, name)
        buffers[name] = b""
    times = []
    open_streams = 2
    while open_streams:
        for key, _ in chooser.select():
            chunk = key.fileobj.read()
            if not chunk:
                chooser.unregister(key.fileobj)
                open_streams -= 1
                continue
            buffers[key.data] += chunk
            *lines, buffers[key.data] = buffers[key.data].split(b"\n")
            for line in lines:
                at = time.monotonic() - start
                times.append(at)
                if verbose:
                    text = line.decode(errors="replace")[:150]
                    print(f"  {at:7.1f} {key.data} | {text}", flush=True)
    code = proc.wait()
    wall = time.monotonic() - start
    marks = [0.0, *times, wall]
    gaps = [(b - a, b) for a, b in itertools.pairwise(marks)]
    longest, ended = max(gaps)
    return {"wall": wall, "longest": longest, "ended": ended, "lines": len(times), "code": code}


def main() -> int:
    """Run the commands given (or listed) and print each one's longest silence."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("commands", nargs="*", help="command lines (default: --from-docs)")
    parser.add_argument("--from-docs", action="store_true", help="the documented commands")
    parser.add_argument("--list", action="store_true", help="only list the commands")
    parser.add_argument("-v", "--verbose", action="store_true", help="print every line")
    args = parser.parse_args()
    commands = args.commands or (documented() if args.from_docs else [])
    if args.list:
        print("\n".join(commands))
        return 0
    print(f"{'wall s':>7} {'silent s':>8} {'at s':>6} {'lines':>5} {'exit':>4}  command")
    for command in commands:
        result = run(command, verbose=args.verbose)
        print(
            f"{result['wall']:7.1f} {result['longest']:8.1f} {result['ended']:6.1f} "
            f"{result['lines']:5d} {result['code']:4d}  {command}",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
