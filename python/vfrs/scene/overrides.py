"""``--set key.path=value``: a scene file read with overrides (``vfrs run``, ``vfrs info``,
``vfrs modes``, ``vfrs converge``). The value is read as TOML (``--set time.end=0.01``,
``--set 'bodies[0].material.E=4e3'``); a bare word is taken as a string."""

from __future__ import annotations

import os

from .._compat import tomllib
from ..errors import VfrsError
from .keypath import set_key


def apply_override(data: dict, assignment: str) -> None:
    """Sets ``key.path=value`` in the scene dict ``data``; VfrsError naming the assignment."""
    if "=" not in assignment:
        raise VfrsError(f"--set {assignment!r}: expected key.path=value")
    path, raw = assignment.split("=", 1)
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw  # a bare word: take it as a string
    try:
        set_key(data, path, value)
    except ValueError as e:
        raise VfrsError(f"--set {assignment!r}: {e}") from None


def load_scene(path, overrides=()):
    """Reads a scene file, applies ``--set`` overrides, validates."""
    from . import Scene, read_toml

    if not overrides:
        return Scene.load(path)
    data = read_toml(path)
    for o in overrides:
        apply_override(data, o)
    return Scene.from_dict(data, source=os.fspath(path), base_dir=os.path.dirname(os.path.abspath(path)))
