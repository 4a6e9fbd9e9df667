"""Key paths into a scene dict (``"bodies[0].mesh.resolution"``), as ``vfrs run --set`` and
the axes of ``vfrs sweep`` name scene values."""

from __future__ import annotations

import copy
import re
from typing import Any


def key_path(path: str) -> list:
    """``"bodies[0].mesh.resolution"`` -> ``["bodies", 0, "mesh", "resolution"]``."""
    keys: list = []
    if not isinstance(path, str) or not path.strip():
        raise ValueError(f"cannot read the key path {path!r}")
    for part in path.strip().split("."):
        m = re.fullmatch(r"([^\[\]]+)((?:\[\d+\])*)", part)
        if not m:
            raise ValueError(f"cannot read the key path {path!r}")
        keys.append(m.group(1))
        keys += [int(i) for i in re.findall(r"\[(\d+)\]", m.group(2))]
    return keys


def _path_text(keys: list) -> str:
    """``["bodies", 0, "mesh"]`` -> ``"bodies[0].mesh"``."""
    out = ""
    for k in keys:
        out += f"[{k}]" if isinstance(k, int) else (f".{k}" if out else str(k))
    return out


def _no_step(keys: list, i: int, node) -> ValueError:
    """Why step ``keys[i]`` of a key path cannot be taken from ``node`` (what ``keys[:i]``
    names): an index out of range names the list, its length and the valid indices."""
    k, where = keys[i], _path_text(keys[:i]) or "the scene"
    if isinstance(k, int) and isinstance(node, list):
        valid = f"valid indices 0 to {len(node) - 1}" if node else "it is empty: no index is valid"
        return ValueError(f"index {k} is out of range: the list {where} has {len(node)} "
                          f"element{'' if len(node) == 1 else 's'} ({valid})")
    if isinstance(k, int):
        kind = "a table" if isinstance(node, dict) else f"a value ({node!r})"
        return ValueError(f"{where} is {kind}, not a list: it takes no index [{k}]")
    if isinstance(node, list):
        return ValueError(f"{where} is a list ({len(node)} element{'' if len(node) == 1 else 's'}): give an index, e.g. "
                          f"{_path_text(keys[:i] + [0] + keys[i:])}")
    return ValueError(f"{where} is a value ({node!r}), not a table: it has no key {k!r}")


def set_key(data: dict, path: str, value) -> None:
    """Sets ``path`` in the scene dict as ``--set`` does (missing tables are created; the
    scene validation then refuses a key that is not in the schema). A path that cannot be
    followed is a ValueError saying why, for the caller to prefix with the path (an index out
    of range: the list, its length and the valid indices)."""
    keys = key_path(path)
    node: Any = data
    for i, k in enumerate(keys[:-1]):
        try:
            node = node[k] if isinstance(k, int) else node.setdefault(k, {})
        except (IndexError, KeyError, TypeError, AttributeError):
            raise _no_step(keys, i, node) from None
    try:
        if isinstance(keys[-1], int) != isinstance(node, list):
            raise TypeError
        node[keys[-1]] = copy.deepcopy(value)
    except (IndexError, TypeError):
        raise _no_step(keys, len(keys) - 1, node) from None
