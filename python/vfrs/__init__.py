"""vfrs: collision of the vocal folds with a 3-D finite-element model.

Compares how contact is enforced (penalty, Lagrange multipliers, augmented Lagrange) on a
Rust core: P1 tetrahedral assembly, sparse Cholesky (faer), contact geometry.

>>> import vfrs
>>> mesh = vfrs.meshes.box((0.01, 0.002, 0.002), (10, 2, 2))
>>> K = vfrs.stiffness(mesh, vfrs.Isotropic(E=10e3, nu=0.45, rho=1070))
>>> K.shape
(297, 297)
"""

from . import _core, contact, enforcement, flow, meshes
from ._version import __version__
from .assembly import mass, stiffness
from .errors import (
    ContactError,
    ConvergenceError,
    MaterialError,
    MeshError,
    PlausibilityError,
    PlausibilityWarning,
    ResolutionWarning,
    SceneError,
    SolverError,
    VfrsError,
    VfrsWarning,
)
from ._core.errors import FiniteStrainError
from .linalg import Cholesky, DofMap, cholesky
from .materials import (MATERIALS, FibreReinforced, Isotropic, NeoHookean, StVenantKirchhoff, TransverselyIsotropic,
                        VocalFold, material_from_dict)
from .mesh import Mesh, read_mesh, signed_volumes
from .scene import Scene
from .result import Result
from .run import resume, run
from .modes import modes
from .summary import load


__all__ = [
    "Mesh",
    "read_mesh",
    "signed_volumes",
    "Isotropic",
    "TransverselyIsotropic",
    "VocalFold",
    "NeoHookean",
    "StVenantKirchhoff",
    "FibreReinforced",
    "MATERIALS",
    "material_from_dict",
    "stiffness",
    "mass",
    "cholesky",
    "Cholesky",
    "DofMap",
    "meshes",
    "VfrsError",
    "MeshError",
    "MaterialError",
    "SolverError",
    "ContactError",
    "SceneError",
    "ConvergenceError",
    "PlausibilityWarning",
    "ResolutionWarning",
    "PlausibilityError",
    "FiniteStrainError",
    "Scene",
    "Result",
    "run",
    "resume",
    "modes",
    "load",
]
