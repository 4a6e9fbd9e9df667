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


def set_key(data: dict, path: str, value) -> None:
    """Sets ``path`` in the scene dict as ``--set`` does (missing tables are created; the
    scene validation then refuses a key that is not in the schema)."""
    keys = key_path(path)
    node: Any = data
    for k in keys[:-1]:
        try:
            node = node[k] if isinstance(k, int) else node.setdefault(k, {})
        except (IndexError, KeyError, TypeError, AttributeError):
            raise ValueError(f"no {k!r} in the scene") from None
    try:
        node[keys[-1]] = copy.deepcopy(value)
    except (IndexError, TypeError):
        raise ValueError(f"no {keys[-1]!r} in the scene") from None
