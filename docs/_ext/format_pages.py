"""Reference pages of the file formats, generated from the readers themselves.

``docs/formats/job-file.md``, ``scene-file.md`` and ``dataset.md`` are written by
:func:`write_pages` and compared with a fresh rendering by ``tests/test_format_pages.py``, so a
page cannot drift from the code:

* every key of a job or scene file, table by table, is what the one TOML field reader
  (:mod:`dpfexplore.io.toml_fields`) was asked to accept while the shipped files of that
  format (``jobs/*.toml``) were read: ``check_keys`` gives each table's required and optional
  keys, the typed readers (``integer``, ``positive``, ``choice``, ``boolean``, ``string``, ...)
  the type, bounds, unit and default of the keys they read; the shipped files give an example
  value;
* the annotated layout beside it (units and defaults in its comments) is the reader module's
  own docstring (:mod:`dpfexplore.sweep.job_file`, :mod:`dpfexplore.inverse.scene_file`, each
  scene kind's ``spec`` module), and the test checks that it names every key the reader
  accepts;
* the dataset's columns (name, Arrow type, unit, description) are the schema a sweep writes
  for ``jobs/smoke.toml``, which computes every output
  (:func:`dpfexplore.sweep.chunks.dataset_schema`).

Run ``python docs/_ext/format_pages.py`` from the repository to write the pages again.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import inspect
import re
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
PAGES = ROOT / "docs" / "formats"
READERS = (
    "check_keys",
    "known_keys",
    "integer",
    "integer_in",
    "positive",
    "positive_number",
    "boolean",
    "string",
    "choice",
    "interval",
    "bound",
    "numbers",
)


class Trace:
    """What the reader was asked: per table its keys, per key how it was read and a value."""

    def __init__(self) -> None:
        self.tables: dict[str, dict[str, bool]] = {}  # where -> key -> required
        self.reads: dict[str, str] = {}  # dotted key -> how it is read
        self.examples: dict[str, Any] = {}

    def record(self, name: str, kwargs: dict) -> None:
        """One call of reader ``name`` (its arguments by name)."""
        if name == "check_keys":
            table, where = kwargs["table"], kwargs["where"]
            keys = self.tables.setdefault(_general(where), {})
            for key in kwargs.get("required", ()):
                keys[key] = True
            for key in kwargs.get("optional", ()):
                keys.setdefault(key, False)
            if isinstance(table, dict):
                for key, value in table.items():
                    if not isinstance(value, dict):
                        self.examples.setdefault(_dotted(_general(where), key), value)
            return
        if name == "known_keys":
            keys = self.tables.setdefault(_general(kwargs["where"]), {})
            for key in sorted(kwargs["known"]):
                keys.setdefault(key, False)
            return
        if name in ("interval", "bound", "numbers"):
            dotted = _general(kwargs["where"])
        else:
            dotted = _dotted(_general(kwargs["where"]), kwargs["key"])
        text = _describe(name, kwargs)
        earlier = self.reads.setdefault(dotted, text)
        if earlier != text:  # a default that depends on the file (a job's name: its stem)
            self.reads[dotted] = earlier.split(";")[0] + "; default depends on the file"


def _dotted(where: str, key: str) -> str:
    return f"{where}.{key}" if where else key


def _general(where: str) -> str:
    """A dotted key with list positions and per-unit entries made general (``[i]``)."""
    return re.sub(r"\[\d+\]", "[i]", where)


def _describe(name: str, kwargs: dict) -> str:
    if name in ("integer", "integer_in"):
        text = f"integer {kwargs['low']}…{kwargs['high']}"
    elif name in ("positive", "positive_number"):
        text = "number ≥ 0" if kwargs.get("allow_zero") else "number > 0"
    elif name == "boolean":
        text = "true or false"
    elif name == "string":
        text = "string"
    elif name == "choice":
        text = "one of " + ", ".join(f'"{c}"' for c in kwargs["choices"])
    elif name == "interval":
        text = "{min, max}"
    elif name == "bound":
        text = "a number or {min, max}"
    else:
        length = kwargs.get("length")
        text = "list of numbers" + (f" ({length})" if length else "")
        if kwargs.get("one"):
            text = "a number or a " + text
    if kwargs.get("unit"):
        text += f", {kwargs['unit']}"
    if kwargs.get("default") is not None:
        text += f"; default {kwargs['default']!r}".replace("'", '"')
    return text


@contextlib.contextmanager
def traced() -> Iterator[Trace]:
    """Record every call of the field readers while the block reads files."""
    from dpfexplore.io import toml_fields

    trace = Trace()
    originals = {name: getattr(toml_fields, name) for name in READERS}

    def wrap(name, function):
        @functools.wraps(function)
        def reader(*args, **kwargs):
            bound = inspect.signature(function).bind(*args, **kwargs)
            bound.apply_defaults()
            trace.record(name, dict(bound.arguments))
            return function(*args, **kwargs)

        return reader

    wrapped = {name: wrap(name, f) for name, f in originals.items()}
    patched = []
    for module in list(sys.modules.values()):
        if not getattr(module, "__name__", "").startswith("dpfexplore"):
            continue
        for name, function in originals.items():
            if getattr(module, name, None) is function:
                setattr(module, name, wrapped[name])
                patched.append((module, name, function))
    try:
        yield trace
    finally:
        for module, name, function in patched:
            setattr(module, name, function)


def _example(value: Any) -> str:
    text = repr(value).replace("'", '"').replace("True", "true").replace("False", "false")
    return f"`{text}`" if len(text) <= 40 else f"`{text[:37]}…`"


def _tables(trace: Trace) -> str:
    lines = []
    for where, keys in trace.tables.items():
        heading = f"[{where}]" if where else "top level"
        lines += [f"### `{heading}`", "", "| key | | value |  example |", "|---|---|---|---|"]
        for key, required in keys.items():
            dotted = _dotted(where, key)
            example = trace.examples.get(dotted)
            read = trace.reads.get(dotted, "")
            if dotted in trace.tables:
                read = "a table (below)" + (" or a value" if example is not None else "")
            lines.append(
                f"| `{key}` | {'required' if required else 'optional'} | {read} | "
                f"{_example(example) if example is not None else ''} |"
            )
        lines.append("")
    return "\n".join(lines)


def _layout(module_name: str) -> str:
    """The literal blocks (``::``) of a reader module's docstring: the annotated layout."""
    doc = inspect.getdoc(importlib.import_module(module_name)) or ""
    blocks = re.findall(r"::\n\n((?:    .*\n|\n)+)", doc + "\n")
    return "\n\n".join(
        "\n".join(line[4:] for line in block.rstrip().splitlines()) for block in blocks
    )


def job_trace() -> Trace:
    """The reader's calls while every shipped job file is read."""
    from dpfexplore.sweep.job_file import load_job

    with traced() as trace:
        for path in sorted((ROOT / "jobs").glob("*.toml")):
            text = path.read_text(encoding="utf-8")
            if re.search(r"^\[job\]", text, re.M):
                load_job(path)
    return trace


def scene_trace() -> Trace:
    """The reader's calls while every shipped scene file is read."""
    from dpfexplore.inverse.kinds import load_scene

    with traced() as trace:
        for path in sorted((ROOT / "jobs").glob("*.toml")):
            if re.search(r"^\[scene\]", path.read_text(encoding="utf-8"), re.M):
                load_scene(path)
    return trace


HEADER = (
    "<!-- generated by docs/_ext/format_pages.py from the readers; do not edit: "
    "tests/test_format_pages.py compares it with a fresh rendering -->\n\n"
)


def render_job() -> str:
    """The job file's reference page."""
    trace = job_trace()
    return (
        HEADER + "# Job file format\n\n"
        "A sweep's job (`dpfexplore sweep JOB.toml`, `dpfexplore.sweep.job_file`). Lengths in mm, "
        "`E` and pressure in MPa, times in s. A key outside these tables, a missing required key "
        "or a value of the wrong kind is refused in one line naming the dotted key.\n\n"
        "## Keys, table by table\n\n"
        "What the reader accepts (`dpfexplore.io.toml_fields`); *value* is how the reader "
        "checks it where it says (type, bounds, unit, default); *example* is a value from a "
        "shipped job (`jobs/`). `constants` takes a file, a saved identification "
        "(`results/constants/NAME`), `paper` or a packaged set's name.\n\n"
        + _tables(trace)
        + "\n## Layout, with units and defaults\n\n"
        "From `dpfexplore/sweep/job_file.py`:\n\n```text\n"
        + _layout("dpfexplore.sweep.job_file")
        + "\n```\n\nThe sweep's output columns: [the dataset format](dataset.md).\n"
    )


SCENE_KINDS = ("position", "position_stiffness", "gripper", "pickplace", "walker")
LEG_MODULE = "dpfexplore.solvers.legs.leg"
#: The modules whose docstring layouts document each format (every key the reader accepts).
LAYOUTS = {
    "job-file.md": ("dpfexplore.sweep.job_file",),
    "scene-file.md": (
        "dpfexplore.inverse.scene_file",
        *(f"dpfexplore.inverse.scenes.{kind}.spec" for kind in SCENE_KINDS),
        LEG_MODULE,
    ),
}


def render_scene() -> str:
    """The scene file's reference page."""
    trace = scene_trace()
    kinds = []
    for kind in SCENE_KINDS:
        layout = _layout(f"dpfexplore.inverse.scenes.{kind}.spec")
        if layout:
            kinds.append(
                f"### `{kind}`\n\nFrom `dpfexplore/inverse/scenes/{kind}/spec.py`:\n\n"
                f"```text\n{layout}\n```\n"
            )
    return (
        HEADER + "# Scene file format\n\n"
        "What `dpfexplore design SCENE.toml` designs for (`dpfexplore.inverse.scene_file` and "
        "each kind's `spec` module). Lengths in mm, `E` in MPa, pressure in MPa, times in s. A "
        "key outside these tables, a missing required key or a value of the wrong kind is "
        "refused in one line naming the dotted key.\n\n"
        "## Keys, table by table\n\n"
        "What the reader accepts while reading the shipped scenes (`jobs/design-*.toml`); "
        "*value* is how the reader checks it where it says; *example* is a shipped value.\n\n"
        + _tables(trace)
        + "\n## Layout of the shared tables, with units and defaults\n\n"
        "From `dpfexplore/inverse/scene_file.py`:\n\n```text\n"
        + _layout("dpfexplore.inverse.scene_file")
        + "\n```\n\n## Each kind's own tables\n\n"
        + "\n".join(kinds)
    )


def render_dataset() -> str:
    """The sweep dataset's columns."""
    from dpfexplore.sweep.chunks import dataset_schema
    from dpfexplore.sweep.evaluation import StaticsEvaluator
    from dpfexplore.sweep.job_file import load_job
    from dpfexplore.sweep.storage.schema import describe_schema

    spec = load_job(ROOT / "jobs" / "smoke.toml")
    frame = describe_schema(dataset_schema(spec, StaticsEvaluator(spec.compute)))
    rows = ["| column | type | unit | description |", "|---|---|---|---|"]
    for row in frame.itertuples(index=False):
        values = row._asdict()
        name, kind, unit, text = (str(v).replace("|", "\\|") for v in list(values.values())[:4])
        rows.append(f"| `{name}` | {kind} | {unit} | {text} |")
    return (
        HEADER + "# Sweep dataset format\n\n"
        "A sweep directory (`dpfexplore sweep`) is a Parquet dataset: one row per design and "
        "state, committed chunk by chunk. Every column carries its unit and description in its "
        "Arrow field metadata, and the schema metadata key `dpfexplore` holds the job, seed, "
        "constants set and versions (the sweeps guide). `dpfexplore query --where` and "
        "`--columns` name these columns. The columns of `jobs/smoke.toml`, which computes every "
        "output (`_1` … `_N` are per unit, up to the job's largest `N`; a job computes only "
        "what its `[compute]` table asks for):\n\n" + "\n".join(rows) + "\n"
    )


PAGE_RENDERERS = {
    "job-file.md": render_job,
    "scene-file.md": render_scene,
    "dataset.md": render_dataset,
}


def write_pages() -> list[Path]:
    """Write every page into ``docs/formats/``; the paths written."""
    PAGES.mkdir(exist_ok=True)
    written = []
    for name, render in PAGE_RENDERERS.items():
        (PAGES / name).write_text(render(), encoding="utf-8")
        written.append(PAGES / name)
    return written


if __name__ == "__main__":
    for path in write_pages():
        print(path)
