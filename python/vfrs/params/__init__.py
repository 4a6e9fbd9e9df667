"""Typed parameters of registered classes: a dataclass per class, read from its scene table.

A registered class (a contact method, a detector, a contact solver, an effect) declares its
scene keys as a dataclass ``Params`` whose fields carry their checks in the metadata made by
:func:`param`. :func:`read_params` fills it from a :class:`~vfrs.params.table.Table` (type
and range checks, errors naming the key path); :func:`params_to_dict` writes it back for the
resolved scene (unset optional values are left out: TOML has no null).

>>> from dataclasses import dataclass
>>> from vfrs.params.table import Table
>>> @dataclass(frozen=True)
... class P:
...     kappa: float = param(doc="penalty", unit="Pa/m", positive=True)
...     growth: float = param(10.0, low=1.0, high=1e6)
>>> p = read_params(P, Table({"kappa": 1e9}, "contact", "<dict>"))
>>> p, params_to_dict(p)
(P(kappa=1000000000.0, growth=10.0), {'kappa': 1000000000.0, 'growth': 10.0})
"""

from __future__ import annotations

import dataclasses
import numbers
import typing
from dataclasses import MISSING

if typing.TYPE_CHECKING:  # the scene package imports the registered classes: read it lazily
    from .table import Table

__all__ = ["param", "read_params", "params_to_dict", "param_keys", "describe_params", "check_params", "Vec3", "Int3"]

#: Field types of fixed-length arrays: read with their length checked, written as lists.
Vec3 = tuple[float, float, float]
Int3 = tuple[int, int, int]


def param(default=MISSING, *, doc: str = "", unit: str = "", positive: bool = False, nonnegative: bool = False,
          low: float | None = None, high: float | None = None, minimum: int | None = None, choices=None):
    """A dataclass field with its scene checks: ``doc`` and ``unit`` for messages and docs,
    ``positive``/``nonnegative``/``low``/``high`` for numbers, ``minimum`` for integers,
    ``choices`` for strings (a collection, or a callable returning one)."""
    meta = dict(doc=doc, unit=unit, positive=positive, nonnegative=nonnegative, low=low, high=high,
                minimum=minimum, choices=choices)
    if isinstance(default, (list, dict)):
        value = default
        return dataclasses.field(default_factory=lambda: type(value)(value), metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def _types(cls) -> dict:
    try:
        return typing.get_type_hints(cls)
    except Exception:  # annotations naming types this module cannot see: fall back to strings
        return {f.name: f.type for f in dataclasses.fields(cls)}


def _kind(tp) -> str:
    """The scene reader for a field annotation: number, integer, boolean, string or raw."""
    text = tp if isinstance(tp, str) else getattr(tp, "__name__", str(tp))
    args = typing.get_args(tp)
    if typing.get_origin(tp) is tuple and args and Ellipsis not in args:  # Vec3, Int3: fixed length
        return "integers" if all(a is int for a in args) else ("vector" if all(a is float for a in args) else "raw")
    if args:  # Optional[X] / X | None
        inner = [a for a in args if a is not type(None)]
        if len(inner) == 1:
            return _kind(inner[0])
        return "raw"
    text = text.replace(" | None", "").replace("Optional[", "").rstrip("]")
    return {"float": "number", "int": "integer", "bool": "boolean", "str": "string"}.get(text, "raw")


def check_params(cls) -> None:
    """Raises TypeError if a field of the Params dataclass ``cls`` has a type the scene cannot
    read (a registry calls it when a class registers, so the mistake shows at import)."""
    types = _types(cls)
    for f in dataclasses.fields(cls):
        if _kind(types.get(f.name, f.type)) == "raw":
            raise TypeError(f"{cls.__name__}.{f.name}: a scene cannot read type {f.type!r} "
                            "(use float, int, bool, str, Vec3, Int3 or one of them | None)")


def param_keys(cls) -> list:
    """The scene keys a Params class reads."""
    return [f.name for f in dataclasses.fields(cls)]


def read_params(cls, table: Table):
    """An instance of the Params dataclass ``cls`` from ``table`` (only its own keys are read;
    the caller calls ``table.done()`` once every part has read its keys)."""
    from .table import REQUIRED

    types = _types(cls)
    values = {}
    for f in dataclasses.fields(cls):
        m = f.metadata
        if f.default is not MISSING:
            default = f.default
        elif f.default_factory is not MISSING:
            default = f.default_factory()
        else:
            default = REQUIRED
        kind = _kind(types.get(f.name, f.type))
        if default is REQUIRED and not table.has(f.name):
            from .table import suggest

            close = [k for k in table.data if k not in table.read and suggest(k, [f.name])]
            if close:
                raise table.error(f"missing; {close[0]!r} looks like a typo of it", f.name)
        what = f" ({m.get('doc') or f.name}{', ' + m['unit'] if m.get('unit') else ''})" if m else ""
        if kind == "number":
            v = table.number(f.name, default, positive=m.get("positive", False), nonnegative=m.get("nonnegative", False),
                             low=m.get("low"), high=m.get("high"), what=what)
        elif kind == "integer":
            v = table.integer(f.name, default, minimum=m.get("minimum")) if (default is not None or table.has(f.name)) \
                else table.raw(f.name, None)
        elif kind in ("vector", "integers"):
            v = _read_array(table, f.name, default, types.get(f.name, f.type), kind == "integers", m, what)
        elif kind == "boolean":
            v = table.boolean(f.name, default)
        elif kind == "string":
            choices = m.get("choices")
            v = table.string(f.name, default, choices=choices() if callable(choices) else choices)
        else:
            v = table.raw(f.name, default)
        values[f.name] = v
    try:
        return cls(**values)
    except (TypeError, ValueError) as e:  # a __post_init__ check
        raise table.error(str(e)) from None


def _array_type(tp):
    """The tuple type of a Vec3/Int3 field, also inside ``X | None``."""
    if typing.get_origin(tp) is tuple:
        return tp
    inner = [a for a in typing.get_args(tp) if a is not type(None)]
    return inner[0] if len(inner) == 1 else tp


def _read_array(table, key, default, tp, integers, m, what):
    """A fixed-length array of numbers (``Vec3``) or integers (``Int3``), as a tuple; ``None``
    (unset) only where the default is ``None``. ``positive``/``nonnegative`` (numbers) and
    ``minimum`` (integers) apply to every component."""
    n = len(typing.get_args(_array_type(tp)))
    if default is None and table.data.get(key) is None:
        table.raw(key, None)
        return None
    if not integers:
        v = table.vector(key, list(default) if isinstance(default, tuple) else default, length=n)
        for x in v:
            if (m.get("positive") and not x > 0) or (m.get("nonnegative") and x < 0):
                sign = "positive" if m.get("positive") else ">= 0"
                raise table.error(f"expected an array of {n} numbers {sign}{what}, got {v!r}", key)
        return tuple(v)
    v = table.raw(key, list(default) if isinstance(default, tuple) else default, f"an array of {n} integers")
    if (
        not isinstance(v, (list, tuple))
        or len(v) != n
        or any(isinstance(x, bool) or not isinstance(x, numbers.Integral) for x in v)
    ):
        raise table.error(f"expected an array of {n} integers{what}, got {v!r}", key)
    low = m.get("minimum")
    if low is not None and any(x < low for x in v):
        raise table.error(f"expected an array of {n} integers >= {low}{what}, got {list(v)!r}", key)
    return tuple(int(x) for x in v)

def params_to_dict(p) -> dict:
    """The resolved values of a Params instance, ``None`` (unset) left out."""
    out = {}
    for f in dataclasses.fields(p):
        v = getattr(p, f.name)
        if v is None:
            continue
        out[f.name] = list(v) if isinstance(v, tuple) else v
    return out


def describe_params(cls) -> str:
    """One line per key: name, default, unit, doc (for docstrings and ``vfrs info``)."""
    lines = []
    for f in dataclasses.fields(cls):
        m = f.metadata
        if f.default is not MISSING:
            default = repr(f.default)
        elif f.default_factory is not MISSING:
            default = repr(f.default_factory())
        else:
            default = "required"
        unit = f" [{m['unit']}]" if m.get("unit") else ""
        lines.append(f"{f.name} = {default}{unit}: {m.get('doc', '')}".rstrip(": "))
    return "\n".join(lines)
