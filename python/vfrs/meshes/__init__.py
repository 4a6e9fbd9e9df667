"""Built-in mesh generators, in a registry keyed by name (the scene's ``builtin``).

Each generator is a function (``box``, ``sphere``, ...) and a typed Params dataclass
(``BoxParams``, ...) registered in :data:`PARAMS` (see :mod:`vfrs.meshes.base`);
:data:`GENERATORS` maps the same names to the functions.
"""

from .base import GENERATORS, PARAMS, GeneratorParams, register_generator
from .box import BoxParams, box
from .m5 import M5Params, m5, m5_pair
from .paraboloid import ParaboloidBlockParams, paraboloid_block
from .sphere import HemisphereParams, SphereParams, hemisphere, sphere

__all__ = [
    "box", "sphere", "hemisphere", "m5", "m5_pair", "paraboloid_block", "GENERATORS", "PARAMS",
    "GeneratorParams", "register_generator", "BoxParams", "SphereParams", "HemisphereParams", "M5Params",
    "ParaboloidBlockParams",
]
