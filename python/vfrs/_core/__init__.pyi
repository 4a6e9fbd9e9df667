"""Type stubs for the Rust extension ``vfrs._core`` (bindings in rust/vfrs-py/src), one file per
submodule (``vfrs._core.fem``, ``.linalg``, ``.contact``, ...), as the extension registers them.

Checked against the built extension by tests/test_stubs.py: ``mypy.stubtest`` compares the
names, parameters, defaults, properties and ``@final`` markers; a sample call of every
function and method checks the return types. pyo3 constructors are ``__new__`` (``#[new]``),
``#[getter]``s are properties, and pyo3 classes without ``subclass`` are final.
"""

from . import contact as contact
from . import errors as errors
from . import fem as fem
from . import hyperelastic as hyperelastic
from . import lcp as lcp
from . import linalg as linalg

__all__ = ["contact", "errors", "fem", "hyperelastic", "lcp", "linalg"]
# (the flat names below: until every caller names its submodule)
__all__ += ["project", "constraint_matrix", "tributary_areas", "contact_area", "plane_detect", "BvhDetector", "InterfaceMesh", "VfrsError", "MeshError", "MaterialError", "SolverError", "ContactError", "FiniteStrainError", "signed_volumes", "validate_mesh", "elasticity_isotropic", "elasticity_transversely_isotropic", "Assembler", "PressureLoad", "HyperelasticMaterial", "FiniteStrainAssembler", "neo_hookean", "neo_hookean_from_young", "st_venant_kirchhoff", "fibre_reinforced", "lcp_solve", "lcp_lagrange", "lcp_penalty", "Cholesky", "DofMap", "combine_rows", "delassus", "Blocked", "sum_of_products", "csr_matvec", "csr_rmatvec"]

# Until every caller names its submodule, the extension has the same objects at the top level.
from .contact import *  # noqa: F403
from .errors import *  # noqa: F403
from .fem import *  # noqa: F403
from .hyperelastic import *  # noqa: F403
from .lcp import *  # noqa: F403
from .linalg import *  # noqa: F403

