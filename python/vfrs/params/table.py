"""Checked reading of one scene table: every error names the file, the key path and what was expected.

A :class:`Table` wraps a dict at a key path (``bodies[0].material``). Each ``get`` marks the key
as read; :meth:`Table.done` reports the keys nobody read, with the nearest valid key from
:mod:`difflib`. Nothing is evaluated: values are only type-checked and converted.
"""

from __future__ import annotations

import difflib
import math

from ..errors import SceneError

REQUIRED = object()
#: The largest magnitude a scene number may have: a product of two stays finite, and no
#: quantity in SI units comes near it.
MAX_MAGNITUDE = 1e100


def _finite(x) -> bool:
    try:
        return math.isfinite(x)
    except OverflowError:  # an integer too large for a float
        return False


def _type_name(v) -> str:
    if isinstance(v, bool):
        return "a boolean"
    if isinstance(v, int):
        return "an integer"
    if isinstance(v, float):
        return "a number"
    if isinstance(v, str):
        return "a string"
    if isinstance(v, dict):
        return "a table"
    if isinstance(v, (list, tuple)):
        return "an array"
    return type(v).__name__


def join(where: str, key) -> str:
    if isinstance(key, int):
        return f"{where}[{key}]"
    return f"{where}.{key}" if where else str(key)


class Table:
    """A scene table being read. ``source`` is the file name (or ``"<dict>"``)."""

    def __init__(self, data, where: str, source: str):
        self.source = source
        self.where = where
        if not isinstance(data, dict):
            raise self.error(f"expected a table, got {_type_name(data)} ({data!r})")
        self.data = data
        self.read: set[str] = set()

    def error(self, message: str, key=None) -> SceneError:
        path = join(self.where, key) if key is not None else (self.where or "(top level)")
        return SceneError(f"{self.source}: {path}: {message}")

    def has(self, key) -> bool:
        return key in self.data

    def raw(self, key, default=REQUIRED, expected="a value"):
        self.read.add(key)
        if key not in self.data or self.data[key] is None:  # None (from a dict; TOML has no null): unset
            if default is REQUIRED:
                raise self.error(f"missing; expected {expected}", key)
            return default
        return self.data[key]

    def number(self, key, default=REQUIRED, *, positive=False, nonnegative=False, low=None, high=None, what=""):
        v = self.raw(key, default, "a number")
        if v is None:
            return None
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.error(f"expected a number{what}, got {_type_name(v)} ({v!r})", key)
        try:
            v = float(v)
        except OverflowError:  # an integer beyond a float
            raise self.error(f"expected a finite number{what}, got an integer of {len(str(v))} digits", key) from None
        if not math.isfinite(v):
            raise self.error(f"expected a finite number{what}, got {v}", key)
        if abs(v) > MAX_MAGNITUDE:
            raise self.error(f"{v:g}{what} is beyond +-{MAX_MAGNITUDE:g}: products of such numbers overflow; "
                             "give SI units", key)
        if positive and not v > 0:
            raise self.error(f"expected a positive number{what}, got {v:g}", key)
        if nonnegative and v < 0:
            raise self.error(f"expected a number >= 0{what}, got {v:g}", key)
        if (low is not None and v < low) or (high is not None and v > high):
            raise self.error(f"expected a number in [{low:g}, {high:g}]{what}, got {v:g}", key)
        return v

    def integer(self, key, default=REQUIRED, *, minimum=None, choices=None, what=""):
        v = self.raw(key, default, "an integer" if choices is None else f"one of {list(choices)}")
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.error(f"expected an integer{what}, got {_type_name(v)} ({v!r})", key)
        if minimum is not None and v < minimum:
            raise self.error(f"expected an integer >= {minimum}{what}, got {v}", key)
        if choices is not None and v not in choices:
            raise self.error(f"{v} is not one of {list(choices)}{what}", key)
        return int(v)

    def boolean(self, key, default=REQUIRED):
        v = self.raw(key, default, "true or false")
        if v is None and default is None:  # an optional switch left unset
            return None
        if not isinstance(v, bool):
            raise self.error(f"expected true or false, got {_type_name(v)} ({v!r})", key)
        return v

    def string(self, key, default=REQUIRED, *, choices=None):
        v = self.raw(key, default, "a string" if choices is None else f"one of {sorted(choices)}")
        if v is None:
            return None
        if not isinstance(v, str):
            raise self.error(f"expected a string, got {_type_name(v)} ({v!r})", key)
        if choices is not None and v not in choices:
            raise self.error(f"{v!r} is not one of {sorted(choices)}{suggest(v, choices)}", key)
        return v

    def vector(self, key, default=REQUIRED, *, length=3):
        v = self.raw(key, default, f"an array of {length} numbers")
        if v is None:
            return None
        if (
            not isinstance(v, (list, tuple))
            or len(v) != length
            or any(isinstance(x, bool) or not isinstance(x, (int, float)) or not _finite(x) for x in v)
        ):
            raise self.error(f"expected an array of {length} finite numbers, got {v!r}", key)
        if any(abs(x) > MAX_MAGNITUDE for x in v):
            raise self.error(f"{v!r} has a number beyond +-{MAX_MAGNITUDE:g}: products of such numbers overflow; "
                             "give SI units", key)
        return [float(x) for x in v]

    def array(self, key, default=REQUIRED):
        v = self.raw(key, default, "an array")
        if not isinstance(v, (list, tuple)):
            raise self.error(f"expected an array, got {_type_name(v)} ({v!r})", key)
        return list(v)

    def table(self, key, default=REQUIRED) -> "Table":
        v = self.raw(key, default, "a table")
        return Table(v, join(self.where, key), self.source)

    def done(self, allowed=None):
        """Raises for the first key that was not read (a typo, most likely)."""
        allowed = set(self.read if allowed is None else allowed)
        for k in self.data:
            if k not in allowed:
                raise self.error(f"unknown key{suggest(k, allowed) or '.'} Valid keys here: {sorted(allowed)}", k)


def suggest(word, choices) -> str:
    """``"; did you mean 'x'?"`` for the nearest choice, or an empty string."""
    near = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f"; did you mean {near[0]!r}?" if near else ""
