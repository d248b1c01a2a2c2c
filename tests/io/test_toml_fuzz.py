"""Mutated design and scene files: refused in one line naming the file, or read as written.

Each example mutates a valid small file (a span deleted, replaced or duplicated, hostile text
inserted, the file cut short) and reads it through the format's loader. The loader must either
refuse it with one ``ValueError`` line that names the file (a design's and a file that cannot
be read start with its path; a scene's key comes first, the file last), or return what the
file says: for a design, the design its ``[design]`` table makes; for a mutation that leaves the
document as it was (a comment, blank space), the unmutated answer. Nothing else may escape.
"""

from __future__ import annotations

import tomllib

from hypothesis import example, given, settings
from hypothesis import strategies as hs

from dpfexplore.inverse.kinds import load_scene
from dpfexplore.model.design import Design, load_design

DESIGN = """# a small design
[design]
H = [4.0, 4.5]
U_L = 7.0
U_sep = 2.0
t = 0.8
t_lim = 1.2
E = 26.0
"""

SCENE = """[scene]
kind = "position"
name = "fuzz"
material = "cheetah-95a"
seed = 0

[variables]
n_units = {min = 2, max = 3}
H = {min = 3.0, max = 5.0}
U_L = {min = 5.5, max = 10.0}
U_sep = {min = 1.0, max = 5.0}
t = {min = 0.5, max = 1.0}
t_lim = {min = 1.0, max = 2.0}

[[targets]]
point = [25.0, 20.0]

[objective]
state = "all_inverted"
tolerance = 1e-6

[optimiser]
candidates_per_n = 4
"""

#: Text a hostile or careless edit puts into a file.
HOSTILE = [
    "\n",
    '"',
    "'",
    "[",
    "]]",
    "{",
    "=",
    "#",
    "\\",
    "\x00",
    "\x7f",
    "\ud800",
    "é",
    "nan",
    "inf",
    "-inf",
    "1e400",
    "-0.0",
    "1" * 400,
    "1" * 5000,
    "[" * 2000 + "]" * 2000,
    'name = "a\\nb"',
    "E = 1" + "0" * 399,
    "H = []",
    "H = [" + ", ".join(["4.0"] * 40) + "]",
    "[design]",
    "[[design]]",
    "design = 3",
    "constants = '/dev/zero'",
    "constants = '.'",
    "material = 'steel'",
    "t = true",
    "t = 'x'",
    "t = 0",
    "t = -1.0",
    "U_L = [7.0, 7.0, 7.0]",
    "[targets]",
    "kind = 'walker'",
    "n_units = {min = 0, max = 300}",
    "candidates_per_n = 1000000000",
    "point = [1e300, 20]",
    "point = [nan, 20]",
]


@hs.composite
def mutated(draw, text: str) -> str:
    """``text`` after one to three edits."""
    for _ in range(draw(hs.integers(1, 3))):
        n = len(text)
        start = draw(hs.integers(0, n))
        stop = draw(hs.integers(start, min(n, start + 12)))
        piece = draw(
            hs.sampled_from(HOSTILE)
            | hs.text(alphabet="0123456789.-+e[]{}=,\"' \n#abc", max_size=8)
        )
        edit = draw(hs.sampled_from(["insert", "replace", "delete", "cut", "duplicate"]))
        if edit == "insert":
            text = text[:start] + piece + text[start:]
        elif edit == "replace":
            text = text[:start] + piece + text[stop:]
        elif edit == "delete":
            text = text[:start] + text[stop:]
        elif edit == "cut":
            text = text[:start]
        else:
            text = text[:stop] + text[start:stop] + text[stop:]
    return text


def _write(path, text: str) -> None:
    # a lone surrogate goes in as the bytes UTF-8 forbids: the reader must refuse them
    path.write_bytes(text.encode("utf-8", "surrogatepass"))


def _refused_in_one_line(exc: BaseException, path) -> None:
    assert isinstance(exc, ValueError), f"{type(exc).__name__}: {exc}"
    message = str(exc)
    assert "\n" not in message, message
    assert message.startswith(f"{path}: ") or message.endswith(f" (in {path})"), message


def refused_or_read(tmp_path_factory, text: str, original: str, name: str, load, key=repr) -> None:
    """``text`` written as ``name`` and loaded: refused in one line naming it, or read; read as
    ``original`` when it says the same (``key`` of both equal)."""
    path = tmp_path_factory.mktemp("fuzz") / name
    _write(path, text)
    try:
        read = load(path)
    except Exception as exc:
        _refused_in_one_line(exc, path)
        return
    if tomllib.loads(text) == tomllib.loads(original):
        unmutated = tmp_path_factory.mktemp("original") / name
        unmutated.write_text(original)
        assert key(read) == key(load(unmutated))


def _what_the_file_says(text: str, stem: str) -> Design:
    table = dict(tomllib.loads(text)["design"])
    table.setdefault("name", stem)
    return Design.from_dict(table)


@settings(max_examples=80)
@given(text=mutated(DESIGN))
@example(text=DESIGN.replace("E = 26.0", "E = 1" + "0" * 399))
@example(text=DESIGN.replace("E = 26.0", "E = " + "1" * 5000))
@example(text=DESIGN.replace("t = 0.8", "t = " + "[" * 2000 + "]" * 2000))
@example(text=DESIGN + "# a comment\n\n")
def test_a_mutated_design_file_is_refused_in_one_line_or_read_as_written(tmp_path_factory, text):
    path = tmp_path_factory.mktemp("design") / "finger.toml"
    _write(path, text)
    try:
        design = load_design(path)
    except Exception as exc:
        _refused_in_one_line(exc, path)
        return
    assert design == _what_the_file_says(text, path.stem)
    if tomllib.loads(text) == tomllib.loads(DESIGN):
        assert design == load_design_text(tmp_path_factory, DESIGN)


def load_design_text(tmp_path_factory, text: str) -> Design:
    path = tmp_path_factory.mktemp("original") / "finger.toml"
    path.write_text(text)
    return load_design(path)


@settings(max_examples=80)
@given(text=mutated(SCENE))
@example(text=SCENE.replace('name = "fuzz"', 'name = "a\\nb"'))
@example(text=SCENE.replace("candidates_per_n = 4", "candidates_per_n = " + "9" * 5000))
@example(text=SCENE + "# a comment\n")
def test_a_mutated_scene_file_is_refused_in_one_line_or_read(tmp_path_factory, text):
    refused_or_read(tmp_path_factory, text, SCENE, "scene.toml", load_scene, key=lambda spec: spec)
