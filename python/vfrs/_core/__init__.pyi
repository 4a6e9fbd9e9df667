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
