"""Built-in mesh generators, in a registry keyed by name (the scene's ``builtin``)."""

from .box import box
from .m5 import m5, m5_pair
from .paraboloid import paraboloid_block
from .sphere import hemisphere, sphere

GENERATORS = {"box": box, "sphere": sphere, "hemisphere": hemisphere, "m5": m5, "paraboloid_block": paraboloid_block}

__all__ = ["box", "sphere", "hemisphere", "m5", "m5_pair", "paraboloid_block", "GENERATORS"]
