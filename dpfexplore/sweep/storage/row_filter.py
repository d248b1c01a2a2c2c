"""Row filters written by users (``--where``), parsed safely and evaluated on the columns.

A filter is a condition over a dataset's columns, in Python syntax::

    n_units == 5 and status_label == "ok" and stiffness > 0.05
    abs(tip_x - 25) < 2 and H_1 in [3.0, 3.5]

It is never handed to :func:`eval`, :meth:`pandas.DataFrame.query` or anything else that runs
code: :func:`parse_filter` parses it with :mod:`ast` and accepts only

* column names of the dataset, number, string and ``True``/``False`` literals;
* comparisons ``== != < <= > >=`` (chains such as ``3 <= H_1 < 4`` too), ``in`` / ``not in`` a
  literal list, tuple or set;
* ``and``, ``or``, ``not`` (and pandas' ``&``, ``|``, ``~`` between conditions);
* arithmetic ``+ - * / ** %`` and unary ``-``/``+`` on numbers (in double precision);
* the functions of :data:`FUNCTIONS` (``abs``, ``sqrt``, ``hypot``, ``isnan``, ...).

Everything else - attribute access, calls of anything else, subscripts, ``@`` variables,
lambdas, comprehensions, names that are not columns - is refused with a one-line
:class:`FilterError` naming the offending part, before any data is read. The result must be a
condition (true or false per row): ``"tip_x"`` or ``"1"`` are refused too.

The parsed filter is evaluated by Arrow compute functions on the columns it names (only those,
plus the requested ones, are read from Parquet), one operation at a time in the order written:
not as a :class:`pyarrow.compute.Expression`, whose canonicalisation re-associates sums
(``-x + (1 + x) == 1`` came out true for ``x = 0.9``, false in Python and NumPy). Missing values
follow SQL: a comparison with a null (``H_3`` of a design with two units) is unknown, and an
unknown row is not selected, also under ``not``; NaN is a value and compares as IEEE 754 does
(``NaN != 1`` is true). The filter is deliberately *not* pushed into Parquet's row-group
statistics: Parquet statistics leave NaN out of a column's min/max, and Arrow 26 then prunes
row groups that hold matching NaN rows (``x != 1`` drops a group holding only 1.0 and NaN;
``tests/sweep/test_row_filter.py`` keeps that case).
"""

from __future__ import annotations

import ast
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import pyarrow as pa
import pyarrow.compute as pc

__all__ = ["FUNCTIONS", "FilterError", "RowFilter", "parse_filter"]

#: Longest filter accepted (characters): a guard against pathological inputs, far above any
#: hand-written condition.
MAX_LENGTH = 4000
#: Deepest nesting accepted (levels of the parsed expression): ``((a + b) * c) > d`` is 4.
#: Conditions joined by ``and``/``or`` (or ``&``/``|``), a chain ``a < b < c`` and a run of one
#: operator ``a + b + c`` are one level, however many terms.
MAX_DEPTH = 64
#: Longest part of a filter quoted in a message (characters).
_QUOTED = 120

_BOOL, _NUMBER, _TEXT = "condition", "number", "text"


class FilterError(ValueError):
    """A filter that is not allowed or cannot apply to the dataset (one-line message)."""


@dataclass(frozen=True)
class _Typed:
    evaluate: Callable[[pa.Table], Any]
    kind: str


def _call(function: Callable, *parts: Callable[[pa.Table], Any]) -> Callable[[pa.Table], Any]:
    """Evaluate ``parts`` on a table, then ``function`` on their values (eagerly)."""
    return lambda table: function(*(part(table) for part in parts))


def _fold(combine: Callable, parts: Sequence[Callable[[pa.Table], Any]]) -> Callable:
    """Evaluate ``parts`` on a table and combine them left to right, in a loop (no recursion)."""

    def evaluate(table: pa.Table) -> Any:
        value = parts[0](table)
        for part in parts[1:]:
            value = combine(value, part(table))
        return value

    return evaluate


def _quoted(text: str) -> str:
    """``text`` quoted for a message, shortened to its start and end when long."""
    if len(text) <= _QUOTED:
        return repr(text)
    half = _QUOTED // 2
    return repr(f"{text[:half]} ... {text[-half:]}")


def _depth(tree: ast.AST) -> int:
    """Nesting depth of an expression, found without recursion."""
    deepest, stack = 0, [(tree, 1)]
    while stack:
        node, depth = stack.pop()
        deepest = max(deepest, depth)
        for child in ast.iter_child_nodes(node):
            flat = isinstance(node, ast.BoolOp | ast.Compare | ast.List | ast.Tuple | ast.Set)
            flat = flat or (child is getattr(node, "left", None) and _same_run(node, child))
            stack.append((child, depth if flat else depth + 1))
    return deepest


def _same_run(node: ast.AST, left: ast.AST) -> bool:
    """Whether ``left`` continues the run of one operator that ``node`` ends (``a + b + c``)."""
    return (
        isinstance(node, ast.BinOp)
        and isinstance(left, ast.BinOp)
        and type(left.op) is type(node.op)
        and not isinstance(node.op, ast.Pow)  # right-associative: a ** b ** c nests rightwards
    )


def _run(node: ast.BinOp) -> list[ast.AST]:
    """The operands of a run of one operator, left to right: ``a + b + c`` -> ``[a, b, c]``."""
    operands = [node.right]
    while _same_run(node, node.left):
        node = node.left
        operands.append(node.right)
    operands.append(node.left)
    return operands[::-1]


def _constant(value: pa.Scalar, kind: str) -> _Typed:
    return _Typed(lambda table: value, kind)


def _unary_numeric(function: Callable) -> Callable[[list[_Typed]], _Typed]:
    def apply(args: list[_Typed]) -> _Typed:
        return _Typed(_call(function, args[0].evaluate), _NUMBER)

    return apply


def _predicate(function: Callable) -> Callable[[list[_Typed]], _Typed]:
    def apply(args: list[_Typed]) -> _Typed:
        return _Typed(_call(function, args[0].evaluate), _BOOL)

    return apply


def _hypot_values(x: Any, y: Any) -> Any:
    return pc.sqrt(pc.add(pc.multiply(x, x), pc.multiply(y, y)))


def _hypot(args: list[_Typed]) -> _Typed:
    return _Typed(_call(_hypot_values, args[0].evaluate, args[1].evaluate), _NUMBER)


def _python_modulo(a: Any, b: Any) -> Any:
    """``a % b`` with Python's sign convention: ``a - b * floor(a / b)``."""
    return pc.subtract(a, pc.multiply(b, pc.floor(pc.divide(a, b))))


#: name -> (argument kinds, builder): the only functions a filter may call.
FUNCTIONS: dict[str, tuple[tuple[str, ...], Callable[[list[_Typed]], _Typed]]] = {
    "abs": ((_NUMBER,), _unary_numeric(pc.abs)),
    "sqrt": ((_NUMBER,), _unary_numeric(pc.sqrt)),
    "exp": ((_NUMBER,), _unary_numeric(pc.exp)),
    "log": ((_NUMBER,), _unary_numeric(pc.ln)),
    "log10": ((_NUMBER,), _unary_numeric(pc.log10)),
    "hypot": ((_NUMBER, _NUMBER), _hypot),
    "isnan": ((_NUMBER,), _predicate(pc.is_nan)),
    "isfinite": ((_NUMBER,), _predicate(pc.is_finite)),
    "isnull": ((None,), _predicate(pc.is_null)),
    "notnull": ((None,), _predicate(pc.is_valid)),
}

_ARITHMETIC = {
    ast.Add: pc.add,
    ast.Sub: pc.subtract,
    ast.Mult: pc.multiply,
    ast.Div: pc.divide,
    ast.Pow: pc.power,
    ast.Mod: _python_modulo,  # Arrow has no float modulo
}
_COMPARISONS = {
    ast.Eq: pc.equal,
    ast.NotEq: pc.not_equal,
    ast.Lt: pc.less,
    ast.LtE: pc.less_equal,
    ast.Gt: pc.greater,
    ast.GtE: pc.greater_equal,
}
_LOGICAL = {ast.And: pc.and_kleene, ast.Or: pc.or_kleene}
_BITWISE_LOGICAL = {ast.BitAnd: pc.and_kleene, ast.BitOr: pc.or_kleene}
_UNKNOWN = pa.scalar(None, pa.bool_())


def _kind_of(dtype: pa.DataType) -> str | None:
    if pa.types.is_dictionary(dtype):
        dtype = dtype.value_type
    if pa.types.is_boolean(dtype):
        return _BOOL
    if pa.types.is_integer(dtype) or pa.types.is_floating(dtype):
        return _NUMBER
    if pa.types.is_string(dtype) or pa.types.is_large_string(dtype):
        return _TEXT
    return None


@dataclass(frozen=True)
class RowFilter:
    """A parsed, checked filter: its text, the columns it reads and its evaluation."""

    text: str
    columns: tuple[str, ...]
    evaluate: Callable[[pa.Table], Any]

    def apply(self, table: pa.Table) -> pa.Table:
        """The rows of ``table`` (which holds :attr:`columns`) for which the filter is true."""
        mask = self.evaluate(table)
        if isinstance(mask, pa.Scalar):  # a condition on literals only: all rows or none
            return table if mask.is_valid and mask.as_py() else table.slice(0, 0)
        return table.filter(mask)


class _Compiler:
    def __init__(self, text: str, schema: pa.Schema) -> None:
        self.text = text
        self.schema = schema
        self.used: dict[str, None] = {}

    def fail(self, node: ast.AST, why: str) -> FilterError:
        part = ast.get_source_segment(self.text, node) or type(node).__name__
        return FilterError(f"--where {_quoted(self.text)}: {why}: {_quoted(part)}")

    def compile(self, node: ast.AST) -> _Typed:
        method = getattr(self, f"_{type(node).__name__.lower()}", None)
        if method is None:
            raise self.fail(node, f"{_describe(node)} is not allowed in a filter")
        return method(node)

    def expect(self, node: ast.AST, kind: str) -> Callable[[pa.Table], Any]:
        typed = self.compile(node)
        if typed.kind != kind:
            raise self.fail(node, f"expected a {kind}, got a {typed.kind}")
        return typed.evaluate

    def _name(self, node: ast.Name) -> _Typed:
        name = node.id
        if name not in self.schema.names:
            raise self.fail(
                node, f"unknown column (columns: {', '.join(self.schema.names)}); not a column"
            )
        dtype = self.schema.field(name).type
        kind = _kind_of(dtype)
        if kind is None:
            raise self.fail(node, f"column of type {dtype} cannot be filtered on")
        self.used[name] = None
        if pa.types.is_dictionary(dtype):
            target = dtype.value_type
        elif kind == _NUMBER:
            # Double precision throughout: Python's `/` and no silent integer wrap-around.
            target = pa.float64()
        else:
            target = dtype
        return _Typed(lambda table: pc.cast(table.column(name), target), kind)

    def _constant(self, node: ast.Constant) -> _Typed:
        value = node.value
        if isinstance(value, bool):
            return _constant(pa.scalar(value), _BOOL)
        if isinstance(value, int | float):
            try:
                return _constant(pa.scalar(float(value)), _NUMBER)
            except OverflowError:
                raise self.fail(node, "a number beyond double precision") from None
        if isinstance(value, str):
            return _constant(pa.scalar(value), _TEXT)
        if value is None:
            raise self.fail(node, "None is not a value here; use isnull(column)")
        raise self.fail(node, f"a literal of type {type(value).__name__} is not allowed")

    def _boolop(self, node: ast.BoolOp) -> _Typed:
        combine = _LOGICAL[type(node.op)]
        parts = [self.expect(value, _BOOL) for value in node.values]
        return _Typed(_fold(combine, parts), _BOOL)

    def _unaryop(self, node: ast.UnaryOp) -> _Typed:
        if isinstance(node.op, ast.Not | ast.Invert):
            return _Typed(_call(pc.invert, self.expect(node.operand, _BOOL)), _BOOL)
        operand = self.expect(node.operand, _NUMBER)
        if isinstance(node.op, ast.USub):
            return _Typed(_call(pc.negate, operand), _NUMBER)
        return _Typed(operand, _NUMBER)  # unary +

    def _binop(self, node: ast.BinOp) -> _Typed:
        # A run of one operator is evaluated left to right in a loop, as Python groups it.
        if type(node.op) in _BITWISE_LOGICAL:  # pandas-style `a & b`, `a | b` between conditions
            combine = _BITWISE_LOGICAL[type(node.op)]
            return _Typed(_fold(combine, [self.expect(n, _BOOL) for n in _run(node)]), _BOOL)
        if type(node.op) not in _ARITHMETIC:
            raise self.fail(node, f"the operator {_describe(node.op)} is not allowed")
        operands = [self.expect(n, _NUMBER) for n in _run(node)]
        return _Typed(_fold(_ARITHMETIC[type(node.op)], operands), _NUMBER)

    def _compare(self, node: ast.Compare) -> _Typed:
        left = self.compile(node.left)
        if isinstance(node.ops[0], ast.In | ast.NotIn):
            if len(node.ops) > 1:
                raise self.fail(node, "`in` cannot be chained")
            negate = isinstance(node.ops[0], ast.NotIn)
            return _Typed(self._membership(left, node.comparators[0], negate=negate), _BOOL)
        parts = []
        for op, right_node in zip(node.ops, node.comparators, strict=True):
            if type(op) not in _COMPARISONS:
                raise self.fail(node, f"the comparison {_describe(op)} is not allowed")
            right = self.compile(right_node)
            if left.kind != right.kind:
                raise self.fail(node, f"cannot compare a {left.kind} with a {right.kind}")
            parts.append(_call(_COMPARISONS[type(op)], left.evaluate, right.evaluate))
            left = right
        return _Typed(_fold(pc.and_kleene, parts), _BOOL)

    def _membership(
        self, left: _Typed, node: ast.AST, *, negate: bool
    ) -> Callable[[pa.Table], Any]:
        if not isinstance(node, ast.List | ast.Tuple | ast.Set):
            raise self.fail(node, "`in` takes a literal list such as [3, 4]")
        values = []
        for element in node.elts:
            typed = self.compile(element)
            if not isinstance(element, ast.Constant) and not (
                isinstance(element, ast.UnaryOp)
                and isinstance(element.op, ast.USub)
                and isinstance(element.operand, ast.Constant)
            ):
                raise self.fail(element, "`in` takes literal values only")
            if typed.kind != left.kind:
                raise self.fail(element, f"cannot compare a {left.kind} with a {typed.kind}")
            value = ast.literal_eval(element)
            if left.kind == _NUMBER:
                try:
                    value = float(value)
                except OverflowError:
                    raise self.fail(element, "a number beyond double precision") from None
            values.append(value)
        value_type = {_NUMBER: pa.float64(), _TEXT: pa.string(), _BOOL: pa.bool_()}[left.kind]
        value_set = pa.array(values, type=value_type)

        def member(column: Any) -> Any:
            inside = pc.is_in(column, value_set=value_set)
            if negate:
                inside = pc.invert(inside)
            # is_in says false for a null; a comparison with a null is unknown (module doc)
            return pc.if_else(pc.is_valid(column), inside, _UNKNOWN)

        return _call(member, left.evaluate)

    def _call(self, node: ast.Call) -> _Typed:
        if not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS:
            raise self.fail(
                node.func, f"only these functions may be called: {', '.join(FUNCTIONS)}"
            )
        if node.keywords:
            raise self.fail(node, "functions take positional arguments only")
        kinds, build = FUNCTIONS[node.func.id]
        if len(node.args) != len(kinds):
            raise self.fail(node, f"{node.func.id} takes {len(kinds)} argument(s)")
        args = []
        for kind, arg in zip(kinds, node.args, strict=True):
            if isinstance(arg, ast.Starred):
                raise self.fail(arg, "unpacking is not allowed")
            typed = self.compile(arg)
            if kind is not None and typed.kind != kind:
                raise self.fail(arg, f"expected a {kind}, got a {typed.kind}")
            args.append(typed)
        return build(args)


def _describe(node: ast.AST) -> str:
    names = {
        ast.Attribute: "attribute access",
        ast.Subscript: "indexing",
        ast.Lambda: "a lambda",
        ast.ListComp: "a comprehension",
        ast.SetComp: "a comprehension",
        ast.DictComp: "a comprehension",
        ast.GeneratorExp: "a generator",
        ast.NamedExpr: "assignment",
        ast.JoinedStr: "an f-string",
        ast.IfExp: "a conditional expression",
        ast.Dict: "a dict",
        ast.MatMult: "@",
        ast.FloorDiv: "//",
        ast.LShift: "<<",
        ast.RShift: ">>",
        ast.BitXor: "^",
        ast.Is: "is",
        ast.IsNot: "is not",
    }
    return names.get(type(node), type(node).__name__)


def parse_filter(text: str, schema: pa.Schema | Sequence[pa.Field]) -> RowFilter:
    """Parse and check a user's filter against a dataset schema; nothing is evaluated.

    Parameters
    ----------
    text : str
        The condition, e.g. ``"n_units == 5 and stiffness > 0.05"`` (grammar: module docstring).
    schema : pyarrow.Schema or sequence of pyarrow.Field
        The columns it may name, with their types.

    Returns
    -------
    RowFilter
        How to evaluate it, and the columns it reads.

    Raises
    ------
    FilterError
        One line naming the offending part: disallowed syntax, an unknown column, mismatched
        types, or a result that is not a condition.
    """
    if not isinstance(schema, pa.Schema):
        schema = pa.schema(list(schema))
    if not isinstance(text, str) or not text.strip():
        raise FilterError("--where: the filter is empty")
    if len(text) > MAX_LENGTH:
        raise FilterError(f"--where: the filter is longer than {MAX_LENGTH} characters")
    if "@" in text:
        raise FilterError(
            f"--where {_quoted(text)}: '@' (a Python variable) is not allowed: filters see "
            "only columns"
        )
    try:
        tree = ast.parse(text.strip(), mode="eval")
    except SyntaxError as exc:
        raise FilterError(f"--where {_quoted(text)}: not a valid condition ({exc.msg})") from None
    except (ValueError, RecursionError, MemoryError):
        raise FilterError(f"--where {_quoted(text)}: not a valid condition") from None
    if _depth(tree.body) > MAX_DEPTH:
        raise FilterError(
            f"--where {_quoted(text)}: nested too deeply (more than {MAX_DEPTH} levels; "
            "join conditions with and/or instead)"
        )
    compiler = _Compiler(text.strip(), schema)
    try:
        typed = compiler.compile(tree.body)
    except RecursionError:
        raise FilterError(f"--where {_quoted(text)}: nested too deeply") from None
    if typed.kind != _BOOL:
        raise FilterError(
            f"--where {_quoted(text)}: a filter must be a condition (true or false per row), "
            f"such as 'stiffness > 0.05'; this is a {typed.kind}"
        )
    return RowFilter(text, tuple(compiler.used), typed.evaluate)
