"""Built-in mesh generators, in a registry keyed by name (the scene's ``builtin``)."""

from .box import box

GENERATORS = {"box": box}

__all__ = ["box", "GENERATORS"]
