"""The filter language of ``--where`` (and of constraints): a restricted grammar over frame columns.

A filter is data, never code: it is parsed into a small tree and evaluated over the columns with
numpy; nothing is executed as Python, no attribute, call, subscript or name other than a column is
accepted. The grammar::

    expr     := expr ("or" | "|") expr | expr ("and" | "&") expr | ("not" | "~") expr
              | sum (("<" | "<=" | ">" | ">=" | "==" | "!=") sum)+     # chains like 0 < x < 1
              | sum ("in" | "not in") "[" literal ("," literal)* "]"
              | sum
    sum      := term (("+" | "-") term)* ;  term := factor (("*" | "/" | "%") factor)*
    factor   := ("-" | "+") factor | atom ("**" factor)?
    atom     := NUMBER | STRING | "true" | "false" | COLUMN | `ANY COLUMN NAME` | "(" expr ")"

Columns are the frame's (metrics, link lengths such as ```1-3```, crank, status, …); a name with
characters other than letters, digits and ``_`` is written in backticks. A column whose name is a
Python keyword (``yield``) is a column like any other: ``yield >= 0.95``. Numbers are float64 and
``**`` is float64's power, exact where the result is finite (``10**100`` is 1e100) and ±inf beyond
(``10**10**10`` is ``inf``, not a computation that never ends). Bounds: 1,000 characters, 200 nodes.
Anything else is a one-line UserError saying what is not allowed.
"""

from __future__ import annotations

import ast
import keyword
import math
import re

import numpy as np

from ..errors import UserError

MAX_LENGTH = 1000
MAX_NODES = 200

_CMP = {ast.Lt: np.less, ast.LtE: np.less_equal, ast.Gt: np.greater, ast.GtE: np.greater_equal,
        ast.Eq: np.equal, ast.NotEq: np.not_equal}
_BIN = {ast.Add: np.add, ast.Sub: np.subtract, ast.Mult: np.multiply, ast.Div: np.true_divide,
        ast.Mod: np.mod, ast.Pow: np.power}
_BACKTICK = re.compile(r"`([^`]*)`")
_STRING = re.compile(r"(\"[^\"]*\"|'[^']*')")
#: Python keywords that are words of the grammar, or start an expression the grammar refuses by name
#: (a lambda, a conditional, a comprehension, an identity test); any other keyword written bare (``yield``,
#: ``class`` …) can only be a column name.
_GRAMMAR_WORDS = {"and", "or", "not", "in", "True", "False", "None", "is", "if", "else", "lambda", "for", "async",
                  "await"}
_KEYWORD = re.compile(r"\b(" + "|".join(k for k in keyword.kwlist if k not in _GRAMMAR_WORDS) + r")\b")


class FilterError(UserError):
    """A filter that is not in the grammar, or names an unknown column."""


def _fail(text: str, why: str):
    raise FilterError(f"where: {why} in {text!r} (allowed: columns, numbers, strings, comparisons, + - * / % **, "
                      f"and/or/not, in [...])")


def parse_filter(text: str):
    """Parse ``text`` into a checked tree: (ast.Expression, {placeholder: column name}).

    Raises FilterError (one line) for anything outside the grammar."""
    if not isinstance(text, str):
        raise FilterError(f"where: expected a text filter, got {type(text).__name__}")
    if len(text) > MAX_LENGTH:
        raise FilterError(f"where: a filter of {len(text):,} characters is too long (at most {MAX_LENGTH:,})")
    names: dict[str, str] = {}

    def quote(m):
        key = f"_col{len(names)}_"
        names[key] = m.group(1)
        return f" {key} "

    src = _BACKTICK.sub(quote, text)
    if "`" in src:
        _fail(text, "an unmatched backtick")
    # pandas-style operators: & | ~ mean and, or, not (outside string literals)
    parts = _STRING.split(src)
    for i in range(0, len(parts), 2):
        p = parts[i].replace("&", " and ").replace("|", " or ").replace("~", " not ")
        p = _KEYWORD.sub(quote, p)  # a column called like a Python keyword (yield) is a column
        parts[i] = re.sub(r"\btrue\b", "True", re.sub(r"\bfalse\b", "False", p))
    src = "".join(parts)
    try:
        tree = ast.parse(src.strip(), mode="eval")
    except (SyntaxError, ValueError, RecursionError, MemoryError) as exc:
        why = exc.msg if isinstance(exc, SyntaxError) else type(exc).__name__
        _fail(text, f"cannot parse it ({why})")
    count = sum(1 for _ in ast.walk(tree))
    if count > MAX_NODES:
        raise FilterError(f"where: a filter of {count} terms is too complex (at most {MAX_NODES})")
    _check(tree.body, text)
    return tree, names


def _check(node, text: str) -> None:
    if isinstance(node, ast.BoolOp):
        for v in node.values:
            _check(v, text)
    elif isinstance(node, ast.UnaryOp):
        if not isinstance(node.op, (ast.Not, ast.USub, ast.UAdd)):
            _fail(text, f"the operator {type(node.op).__name__} is not allowed")
        _check(node.operand, text)
    elif isinstance(node, ast.BinOp):
        if type(node.op) not in _BIN:
            _fail(text, f"the operator {type(node.op).__name__} is not allowed")
        _check(node.left, text)
        _check(node.right, text)
    elif isinstance(node, ast.Compare):
        _check(node.left, text)
        for op, right in zip(node.ops, node.comparators):
            if isinstance(op, (ast.In, ast.NotIn)):
                if not isinstance(right, (ast.List, ast.Tuple)) or not right.elts:
                    _fail(text, "'in' takes a list of numbers or strings, such as [1, 2]")
                for e in right.elts:
                    if not _literal(e):
                        _fail(text, "'in' takes a list of numbers or strings, such as [1, 2]")
            elif type(op) not in _CMP:
                _fail(text, f"the comparison {type(op).__name__} is not allowed")
            else:
                _check(right, text)
    elif isinstance(node, ast.Name):
        pass
    elif _literal(node):
        pass
    else:
        what = {ast.Call: "a call", ast.Attribute: "an attribute", ast.Subscript: "a subscript",
                ast.Lambda: "a lambda", ast.NamedExpr: "an assignment"}.get(type(node), type(node).__name__)
        _fail(text, f"{what} is not allowed")


def _literal(node) -> bool:
    if isinstance(node, ast.Constant):
        return isinstance(node.value, (int, float, str, bool)) and not isinstance(node.value, complex)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
        return isinstance(node.operand, ast.Constant) and isinstance(node.operand.value, (int, float))
    return False


def _literal_value(node):
    if isinstance(node, ast.UnaryOp):
        v = _number(node.operand.value)
        return -v if isinstance(node.op, ast.USub) else v
    v = node.value
    return v if isinstance(v, str) else _number(v)


def _number(v) -> float:
    try:
        return float(v)
    except OverflowError:
        return math.inf if v > 0 else -math.inf


def filter_columns(text: str) -> list:
    """The column names filter ``text`` refers to, in the order they appear (repeats removed)."""
    tree, names = parse_filter(text)
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name):
            col = names.get(node.id, node.id)
            if col not in out:
                out.append(col)
    return out


def evaluate_filter(df, text: str) -> np.ndarray:
    """Boolean mask (len(df),) of the rows of ``df`` where filter ``text`` holds (see the module
    docstring for the grammar). NaN compares false. Raises FilterError for a filter outside the
    grammar, an unknown column, or one that is not true/false per row."""
    tree, ev, n = _evaluator(df, text)
    result = ev(tree.body)
    arr = np.asarray(result)
    if arr.dtype != bool:
        raise FilterError(f"where: {text!r} is not a filter (it must be true or false for each row, such as "
                          f"'bob < 0.2')")
    return np.array(np.broadcast_to(arr, (n,)), dtype=bool)


def filter_margins(df, text: str, *, scales: bool = False):
    """The signed margins of a filter that is one comparison, or a chain of them, of numbers with
    ``<``, ``<=``, ``>`` or ``>=`` (``clearance >= 1``, ``0 < x < 1``): a list with one (len(df),) array
    per comparison, ``right - left`` for ``<``/``<=`` and ``left - right`` for ``>``/``>=``, so that a
    margin >= 0 holds ``<=``/``>=`` (> 0 holds ``<``/``>``); NaN where a side is NaN. None for any other
    filter (and/or/not, ==, in): those are true or false with no margin (the polish of ``explorer
    optimize`` keeps them by refusing steps that break them). With ``scales``, a list of (margin,
    scale) pairs, scale = max(|left|, |right|) per row (the size the margin is measured against)."""
    tree, ev, n = _evaluator(df, text)
    node = tree.body
    if not isinstance(node, ast.Compare) or not all(isinstance(op, (ast.Lt, ast.LtE, ast.Gt, ast.GtE))
                                                     for op in node.ops):
        return None
    out = []
    left = ev(node.left)
    for op, comp in zip(node.ops, node.comparators):
        right = ev(comp)
        a = np.broadcast_to(np.asarray(left, dtype=np.float64), (n,))
        b = np.broadcast_to(np.asarray(right, dtype=np.float64), (n,))
        with np.errstate(invalid="ignore"):
            m = np.array(b - a if isinstance(op, (ast.Lt, ast.LtE)) else a - b)
            out.append((m, np.maximum(np.abs(a), np.abs(b))) if scales else m)
        left = right
    return out


def _evaluator(df, text: str):
    """(tree, ev, n): the parsed filter and a function evaluating a node of it over the rows of ``df``."""
    tree, names = parse_filter(text)
    n = len(df)

    def column(name: str):
        col = names.get(name, name)
        if col not in df.columns:
            known = ", ".join(str(c) for c in df.columns)
            raise FilterError(f"where: unknown column {col!r} in {text!r} (columns: {known})")
        import pandas as pd
        s = df[col]
        if pd.api.types.is_bool_dtype(s):
            return s.to_numpy(dtype=bool)
        if pd.api.types.is_numeric_dtype(s):
            return s.to_numpy(dtype=np.float64, na_value=np.nan)
        return s.astype(object).to_numpy()  # text: object, str (pandas 3) or categorical columns

    def ev(node):
        if isinstance(node, ast.BoolOp):
            vals = [_bool(ev(v)) for v in node.values]
            out = vals[0]
            for v in vals[1:]:
                out = (out & v) if isinstance(node.op, ast.And) else (out | v)
            return out
        if isinstance(node, ast.UnaryOp):
            v = ev(node.operand)
            if isinstance(node.op, ast.Not):
                return ~_bool(v)
            return -_num(v) if isinstance(node.op, ast.USub) else _num(v)
        if isinstance(node, ast.BinOp):
            left, right = _num(ev(node.left)), _num(ev(node.right))
            # float64 throughout: ** costs the same whatever the exponent and overflows to ±inf
            with np.errstate(all="ignore"):
                return _BIN[type(node.op)](left, right)
        if isinstance(node, ast.Compare):
            out = np.ones(n, dtype=bool)
            left = ev(node.left)
            for op, comp in zip(node.ops, node.comparators):
                if isinstance(op, (ast.In, ast.NotIn)):
                    values = [_literal_value(e) for e in comp.elts]
                    hit = np.zeros(n, dtype=bool)
                    for v in values:
                        hit |= _equal(left, v, n)
                    out &= hit if isinstance(op, ast.In) else ~hit
                    continue
                right = ev(comp)
                with np.errstate(invalid="ignore"):
                    if isinstance(op, (ast.Eq, ast.NotEq)):
                        res = _equal(left, right, n)
                        res = res if isinstance(op, ast.Eq) else ~res
                    else:
                        res = _CMP[type(op)](_num(left), _num(right))
                out &= np.broadcast_to(res, (n,))
                left = right
            return out
        if isinstance(node, ast.Name):
            return column(node.id)
        return _literal_value(node)

    def _text(v):
        return isinstance(v, str) or (isinstance(v, np.ndarray) and v.dtype == object)

    def _num(v):
        if _text(v):
            raise FilterError(f"where: arithmetic or an ordering on text in {text!r}")
        return np.asarray(v, dtype=np.float64)

    def _bool(v):
        a = np.asarray(v)
        if a.dtype != bool:
            raise FilterError(f"where: {text!r} combines values that are not true/false with and/or/not")
        return np.broadcast_to(a, (n,))

    def _equal(a, b, n):
        if _text(a) or _text(b):
            eq = np.asarray(a, dtype=object) == np.asarray(b, dtype=object)
        else:
            eq = np.equal(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
        return np.broadcast_to(eq, (n,))

    return tree, ev, n
