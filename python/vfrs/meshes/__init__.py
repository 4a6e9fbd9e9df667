"""Built-in mesh generators, in a registry keyed by name (the scene's ``builtin``)."""

from .box import box
from .sphere import hemisphere, sphere

GENERATORS = {"box": box, "sphere": sphere, "hemisphere": hemisphere}

__all__ = ["box", "sphere", "hemisphere", "GENERATORS"]
