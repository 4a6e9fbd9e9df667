"""The ``sweep`` extra: dask.distributed (a sweep's runs as tasks of a cluster) and pyarrow
(the Parquet tables of a sweep, of ``vfrs converge`` and of the accuracy report), which the
base install leaves out: ``pip install "vfrs[sweep]"``. A scene runs without them."""

from __future__ import annotations

import importlib
from types import ModuleType

from ..errors import VfrsError

#: What installs the extra, as every message about a missing module of it says.
INSTALL = 'pip install "vfrs[sweep]"'


def sweep_extra(module: str, what: str) -> ModuleType:
    """The module ``module`` (``"distributed"``, ``"pyarrow.parquet"``) of the ``sweep`` extra,
    or a one-line :class:`~vfrs.errors.VfrsError`: ``what`` needs it, and how to install it.

    >>> sweep_extra("pyarrow", "a Parquet table").__name__
    'pyarrow'
    """
    try:
        return importlib.import_module(module)
    except ImportError:
        top = module.partition(".")[0]
        raise VfrsError(f"{what} needs {'dask.distributed' if top == 'distributed' else top}, which the base install "
                        f"leaves out: {INSTALL}") from None
