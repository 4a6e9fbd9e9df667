"""A small TOML writer for resolved scenes (the standard library reads TOML but does not write it).

Top-level scalars first, then ``[tables]``, then ``[[arrays of tables]]``; anything nested
deeper is written inline. Round-trips through :mod:`tomllib`.

>>> from vfrs._compat import tomllib
>>> d = {"title": "t", "time": {"step": 1e-5}, "bodies": [{"name": "a", "mesh": {"cells": [1, 2, 3]}}]}
>>> tomllib.loads(dumps(d)) == d
True
"""

from __future__ import annotations

import math


def _key(k: str) -> str:
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return _string(k)


def _string(s: str) -> str:
    out = s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\t", "\\t")
    return f'"{out}"'


def _value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, dict):
        # TOML has no null: an unset option (None) is left out, and reads back as unset.
        v = {k: x for k, x in v.items() if x is not None}
        return "{ " + ", ".join(f"{_key(k)} = {_value(x)}" for k, x in v.items()) + " }" if v else "{}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_value(x) for x in v) + "]"
    if hasattr(v, "tolist"):
        return _value(v.tolist())
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _is_table_array(v) -> bool:
    return isinstance(v, list) and len(v) > 0 and all(isinstance(x, dict) for x in v)


def dumps(d: dict) -> str:
    lines = []
    scalars = {k: v for k, v in d.items() if not isinstance(v, dict) and not _is_table_array(v)}
    tables = {k: v for k, v in d.items() if isinstance(v, dict)}
    arrays = {k: v for k, v in d.items() if _is_table_array(v)}
    for k, v in scalars.items():
        if v is not None:
            lines.append(f"{_key(k)} = {_value(v)}")
    for k, v in tables.items():
        lines.append("")
        lines.append(f"[{_key(k)}]")
        for kk, vv in v.items():
            if vv is not None:
                lines.append(f"{_key(kk)} = {_value(vv)}")
    for k, v in arrays.items():
        for item in v:
            lines.append("")
            lines.append(f"[[{_key(k)}]]")
            for kk, vv in item.items():
                if vv is not None:
                    lines.append(f"{_key(kk)} = {_value(vv)}")
    return "\n".join(lines).lstrip("\n") + "\n"
