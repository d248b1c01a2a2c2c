"""A constants set file read within bounds, and its fields checked before any is used.

:func:`read_set_json` reads at most :data:`MAX_SET_BYTES` of a regular file
(:func:`dpfexplore.io.files.read_bounded`: a directory, FIFO or device is refused before anything
is read) and parses it as strict JSON: ``NaN``, ``Infinity`` and numbers beyond the range of a
float are refused where they stand, and nesting deeper than the parser's recursion limit is
refused, not raised. :func:`fields_problem` then checks the parsed document's shape (every
field of its type, numbers finite and within :data:`MAX_COEFFICIENT` or
:data:`~dpfexplore.model.set_checks.claims.DOMAIN_LIMITS`, nesting within
:data:`MAX_NESTING`), so that nothing after it meets a value it cannot hold (a 400-digit
integer converted to a float, a list where a table belongs). What the fields claim (a physical
set over its domain) is :mod:`~dpfexplore.model.set_checks.claims`'s part.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ...io.files import SIZE_LIMITS
from ..closed_form import MAX_POWER, ConstantsSetError
from ..quantities import SET_FORMS
from .claims import DOMAIN_LIMITS, MAX_COEFFICIENT

__all__ = ["MAX_NESTING", "MAX_SET_BYTES", "MAX_TERMS", "fields_problem", "read_set_json"]

#: Largest constants set file read, bytes (the reason in :data:`dpfexplore.io.files.SIZE_LIMITS`).
MAX_SET_BYTES = SIZE_LIMITS["constants set"].bytes
#: Deepest nesting of lists and tables in a set file (the format itself needs 4).
MAX_NESTING = 32
#: Most terms a closed form may hold: every ``(p, q)`` with ``|p|, |q| <= MAX_POWER``.
MAX_TERMS = (2 * MAX_POWER + 1) ** 2
#: Most vertices of a hull.
MAX_HULL_VERTICES = 10_000
#: Longest set name (characters).
MAX_NAME = 200


def read_set_json(path: str | Path) -> Any:
    """The JSON document of a constants set file (strict JSON, bounded read).

    Raises
    ------
    ConstantsSetError
        One line naming the file: missing or unreadable, not a regular file, larger than
        :data:`MAX_SET_BYTES`, not UTF-8, not JSON, ``NaN``/``Infinity`` or a number beyond
        the range of a float, nesting beyond the parser's limit.
    """
    from ...io.files import BoundedReadError, read_bounded

    path = Path(path)
    try:
        raw = read_bounded(path, MAX_SET_BYTES)
    except BoundedReadError as exc:
        raise ConstantsSetError(str(exc)) from None
    except (OSError, ValueError) as exc:  # ValueError: a path with a NUL byte
        reason = getattr(exc, "strerror", None) or exc
        raise ConstantsSetError(f"{path}: cannot read ({reason})") from None
    try:
        return json.loads(
            raw.decode("utf-8"), parse_constant=_not_a_number, parse_float=_finite_float
        )
    except _NumberError as exc:
        raise ConstantsSetError(f"{path}: not a constants set ({exc})") from None
    except RecursionError:
        raise ConstantsSetError(f"{path}: not a constants set (JSON nested too deeply)") from None
    except (UnicodeDecodeError, ValueError) as exc:
        text = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ConstantsSetError(f"{path}: not a constants set (not JSON: {text})") from None


class _NumberError(ValueError):
    """A number strict JSON does not have, or a float cannot hold."""


def _not_a_number(text: str) -> float:
    raise _NumberError(f"{text} is not a number")


def _finite_float(text: str) -> float:
    value = float(text)
    if value in (float("inf"), float("-inf")):
        raise _NumberError(f"{text[:32]}{'...' if len(text) > 32 else ''} is beyond a float")
    return value


def fields_problem(data: Mapping[str, Any]) -> str | None:
    """What is wrong with the fields of a set document (one line), or None.

    Checks the types and magnitudes of ``name``, each closed form's terms, ``domain``,
    ``provenance`` and ``hull``, and the nesting of the whole document. Required keys and the
    format are the reader's (:meth:`~dpfexplore.model.constants_set.ConstantsSet.from_dict`);
    ``validation`` is checked as a verdict there.
    """
    depth = _nesting(data)
    if depth > MAX_NESTING:
        return f"nested more than {MAX_NESTING} deep"
    name = data.get("name")
    if not isinstance(name, str) or not 0 < len(name) <= MAX_NAME or not name.isprintable():
        return f"name must be a line of text of 1-{MAX_NAME} characters"
    for form in SET_FORMS:
        problem = _form_problem(data.get(form.name))
        if problem:
            return f"{form.name}.{problem}"
    problem = _domain_problem(data.get("domain"))
    if problem:
        return problem
    provenance = data.get("provenance")
    if provenance is not None and not isinstance(provenance, Mapping):
        return f"provenance must be a table, not {_kind(provenance)}"
    hull = data.get("hull")
    if hull is not None and not (
        isinstance(hull, list)
        and 3 <= len(hull) <= MAX_HULL_VERTICES
        and all(isinstance(v, list) and len(v) == 2 and all(_finite(x) for x in v) for v in hull)
    ):
        return (
            f"hull must be a list of 3-{MAX_HULL_VERTICES} [H/r_b, t/r_b] vertices (finite numbers)"
        )
    return None


def _form_problem(form: Any) -> str | None:
    if not isinstance(form, Mapping) or not isinstance(form.get("terms"), list):
        return "terms: need a table with a list of terms"
    terms = form["terms"]
    if len(terms) > MAX_TERMS:
        return f"terms: {len(terms)} terms, more than the {MAX_TERMS} distinct powers allow"
    for i, term in enumerate(terms):
        if not isinstance(term, Mapping) or not {"pi1", "pi3", "coefficient"} <= set(term):
            return f"terms[{i}]: need {{pi1, pi3, coefficient}}"
        for key in ("pi1", "pi3"):
            p = term[key]
            if not _integer(p) or abs(p) > MAX_POWER:
                return f"terms[{i}].{key}: must be an integer in -{MAX_POWER}..{MAX_POWER}"
        c = term["coefficient"]
        if not _finite(c) or abs(c) > MAX_COEFFICIENT:
            return (
                f"terms[{i}].coefficient: must be a number within ±{MAX_COEFFICIENT:g} "
                "(a physical set's are below 1e3)"
            )
    return None


def _domain_problem(domain: Any) -> str | None:
    if not isinstance(domain, Mapping):
        return f"domain must be a table of ranges, not {_kind(domain)}"
    for key, value in domain.items():
        if key not in DOMAIN_LIMITS:
            return f"domain.{str(key)[:40]}: unknown range; known: {', '.join(DOMAIN_LIMITS)}"
        low, high, unit = DOMAIN_LIMITS[key]
        if not (
            isinstance(value, list)
            and len(value) == 2
            and all(_finite(v) and low <= v <= high for v in value)
            and value[0] <= value[1]
        ):
            return f"domain.{key} must be [low, high] with {low:g} <= low <= high <= {high:g}" + (
                f" {unit}" if unit else ""
            )
    return None


def _integer(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def _finite(value: Any) -> bool:
    """A JSON number a float holds (a bool is not one; an int of any size is compared exactly)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return False
    if isinstance(value, int):
        return abs(value) < 2**1023
    return value - value == 0.0  # false for NaN and ±inf


def _kind(value: Any) -> str:
    return {dict: "a table", list: "a list", str: "text", bool: "a boolean"}.get(
        type(value), "a number" if isinstance(value, int | float) else "null"
    )


def _nesting(value: Any) -> int:
    """Depth of lists and tables in ``value`` (iterative: a deep document cannot overflow it)."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, Mapping):
            children = item.values()
        elif isinstance(item, list | tuple):
            children = item
        else:
            continue
        deepest = max(deepest, depth)
        if deepest > MAX_NESTING:
            return deepest
        stack.extend((child, depth + 1) for child in children)
    return deepest
