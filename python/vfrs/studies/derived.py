"""Derived columns of a sweep's table (:mod:`vfrs.studies.sweep`): a small expression language,
parsed with :mod:`ast` and checked node by node, evaluated without ``eval``.

Allowed: numbers, ``+ - * / ** % //``, unary ``-``/``+``, calls of :data:`FUNCTIONS` with
positional arguments, ``summary.<section>.<key>``, ``history.<column>``, ``params.<key>``,
``probes["probe_0.displacement"]`` (the arrays of ``probes.npz``: ``probe_<i>.displacement``,
``.velocity``, ... per step, ``t``) (or ``summary["..."]``), constant subscripts and slices. Anything else (names, attributes of other
objects or starting with ``_``, lambdas, comprehensions, keyword arguments) is refused when the
sweep file is read.

What an expression computes is bounded (:data:`MAX_INT_BITS`): ``9**9**9`` would take hours and
gigabytes as an exact integer, so a power or product of integers beyond a float's range, and
arithmetic on strings or lists (``"a" * 10**9``), is a :class:`~vfrs.errors.VfrsError` naming
the part of the expression, at once: when the sweep file is read if the part is constant, else
in the run's ``derived_errors`` cell.

>>> from vfrs.studies.derived import Namespace, check_expression, evaluate
>>> tree = check_expression("max(history.f) * 1e3")
>>> evaluate(tree, {"history": Namespace("history", {"f": [1.0, 2.0]}.__getitem__)})
2000.0
"""

from __future__ import annotations

import ast
import math
import operator
from typing import Any, Callable

import numpy as np

from ..errors import VfrsError


_BINOPS: dict = {ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
                 ast.Pow: operator.pow, ast.Mod: operator.mod, ast.FloorDiv: operator.floordiv}
_UNARY: dict = {ast.USub: operator.neg, ast.UAdd: operator.pos}
FUNCTIONS: dict[str, Callable] = {
    "abs": np.abs, "max": np.max, "min": np.min, "mean": np.mean, "sum": np.sum, "sqrt": np.sqrt,
    "log": np.log, "log10": np.log10, "exp": np.exp, "len": len, "first": lambda a: a[0], "last": lambda a: a[-1],
}
ROOTS = ("summary", "history", "params", "probes")
#: The largest integer a derived expression may compute, in bits: a float's range (2**1024),
#: beyond which a table column cannot hold it anyway.
MAX_INT_BITS = 1024


class Namespace:
    """``summary``, ``history`` or ``params`` in a derived expression: looked up by dotted key."""

    def __init__(self, name: str, lookup: Callable[[str], Any]):
        self.name, self.lookup = name, lookup


def _dotted(node) -> tuple[str, str] | None:
    """``summary.contact.peak_force.right`` -> ("summary", "contact.peak_force.right")."""
    parts = []
    while isinstance(node, ast.Attribute):
        parts.append(node.attr)
        node = node.value
    if isinstance(node, ast.Name) and node.id in ROOTS:
        return node.id, ".".join(reversed(parts))
    return None


def check_expression(text: str) -> ast.Expression:
    """Parses a derived expression; only numbers, + - * / ** % //, calls of :data:`FUNCTIONS`,
    ``summary.<section>.<key>``, ``history.<column>``, ``params.<key>`` (or ``x["key"]``) and
    constant subscripts are allowed."""
    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as e:
        raise ValueError(f"cannot parse {text!r}: {e.msg}") from None
    for node in ast.walk(tree):
        ok = isinstance(node, (ast.Expression, ast.BinOp, ast.UnaryOp, ast.Constant, ast.Call, ast.Attribute,
                               ast.Subscript, ast.Name, ast.Load, ast.Slice)) or type(node) in _BINOPS or type(node) in _UNARY
        if not ok:
            raise ValueError(f"{text!r}: {type(node).__name__} is not allowed in a derived column")
        if isinstance(node, ast.Constant) and not isinstance(node.value, (int, float, str)):
            raise ValueError(f"{text!r}: constant {node.value!r} is not allowed")
        if isinstance(node, ast.Name) and node.id not in ROOTS and node.id not in FUNCTIONS:
            raise ValueError(f"{text!r}: unknown name {node.id!r}; use {', '.join(ROOTS)} or a function of "
                             f"{sorted(FUNCTIONS)}")
        if isinstance(node, ast.Call) and (not isinstance(node.func, ast.Name) or node.func.id not in FUNCTIONS
                                           or node.keywords):
            raise ValueError(f"{text!r}: only calls of {sorted(FUNCTIONS)} with positional arguments")
        if isinstance(node, ast.Attribute) and (_dotted(node) is None or node.attr.startswith("_")):
            raise ValueError(f"{text!r}: attributes only on {', '.join(ROOTS)}, not starting with '_'")
    _check_constants(tree, text)
    return tree


def _check_constants(tree: ast.Expression, text: str) -> None:
    """Each arithmetic of constants only (``9**9**9``) evaluated now, within the bounds of
    :func:`_arithmetic`: one that exceeds them is refused when the expression is read (other
    failures, such as ``1/0``, are left to the run's ``derived_errors``)."""
    for node in ast.walk(tree):
        if isinstance(node, (ast.BinOp, ast.UnaryOp)) and all(
                isinstance(n, (ast.BinOp, ast.UnaryOp, ast.Constant, ast.operator, ast.unaryop)) for n in ast.walk(node)):
            try:
                evaluate(ast.Expression(node), {})
            except VfrsError as e:
                raise VfrsError(f"{text!r}: {e}") from None
            except (ArithmeticError, TypeError, ValueError):
                pass


def _is_int(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


def _arithmetic(node: ast.AST, op, *args):
    """``op(*args)`` of the operation ``node``, bounded: no arithmetic on strings, lists or
    tables (``"a" * 10**9`` would repeat them), no integer beyond :data:`MAX_INT_BITS` bits
    (a power's size is estimated before it is computed); else a VfrsError naming ``node``."""
    part = ast.unparse(node)
    for a in args:
        if isinstance(a, (str, bytes, list, tuple, dict, Namespace)):
            raise VfrsError(f"{part}: arithmetic on {type(a).__name__} {str(a)[:40]!r}; a derived column computes with "
                            "numbers and arrays")
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Pow) and all(_is_int(a) for a in args):
        base, exponent = args
        if abs(base) > 1 and exponent > 0:
            bits = exponent * math.log2(abs(base)) if exponent.bit_length() < 1000 else math.inf
            if bits > MAX_INT_BITS:
                size = f"about {bits:.3g}" if math.isfinite(bits) else f"more than 2**{exponent.bit_length() - 1}"
                raise VfrsError(f"{part}: {base} ** {exponent} would be an integer of {size} bits, more than a "
                                f"derived column computes ({MAX_INT_BITS} bits, a float's range); write a smaller "
                                "power")
    value = op(*args)
    if _is_int(value) and value.bit_length() > MAX_INT_BITS:
        raise VfrsError(f"{part}: an integer of {value.bit_length()} bits, more than a derived column computes "
                        f"({MAX_INT_BITS} bits, a float's range)")
    return value


def references(tree: ast.AST) -> list[tuple[str, str]]:
    """The names an expression reads, in order, each once: ``(root, key)`` for
    ``summary.contact.peak_force.right`` (``("summary", "contact.peak_force.right")``),
    ``history.t[-1]`` (``("history", "t")``) and ``params["bodies[0].mesh.resolution"]``;
    what a sweep checks against the names its runs will have before any run starts.

    >>> references(check_expression("summary.phonation.f0 / params['x'] + max(history.t)"))
    [('summary', 'phonation.f0'), ('params', 'x'), ('history', 't')]
    """
    found: list[tuple[str, str]] = []

    def visit(node) -> None:
        ref = _dotted(node) if isinstance(node, ast.Attribute) else None
        if (ref is None and isinstance(node, ast.Subscript) and isinstance(node.value, ast.Name)
                and node.value.id in ROOTS and isinstance(node.slice, ast.Constant)):
            ref = (node.value.id, str(node.slice.value))
        if ref is not None:
            if ref not in found:
                found.append(ref)
            return
        for child in ast.iter_child_nodes(node):
            visit(child)

    visit(tree)
    return found


def evaluate(tree: ast.Expression, names: dict[str, Namespace]):
    def ev(node):
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant):
            return node.value
        if isinstance(node, ast.BinOp):
            return _arithmetic(node, _BINOPS[type(node.op)], ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp):
            return _arithmetic(node, _UNARY[type(node.op)], ev(node.operand))
        if isinstance(node, ast.Call):
            return FUNCTIONS[node.func.id](*[ev(a) for a in node.args])
        if isinstance(node, ast.Attribute):
            root, key = _dotted(node)
            return names[root].lookup(key)
        if isinstance(node, ast.Name):
            return names[node.id]
        if isinstance(node, ast.Subscript):
            base, index = ev(node.value), ev(node.slice)
            if isinstance(base, Namespace):
                return base.lookup(str(index))
            return base[index]
        if isinstance(node, ast.Slice):
            return slice(*(None if x is None else ev(x) for x in (node.lower, node.upper, node.step)))
        raise ValueError(f"{type(node).__name__} is not allowed")

    value = ev(tree)
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value.item()
    if isinstance(value, np.generic):
        value = value.item()
    return value
