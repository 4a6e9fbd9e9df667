"""Differences between the Python versions vfrs supports (pyproject: >= 3.10).

``tomllib`` is in the standard library from 3.11; on 3.10 the same API comes from ``tomli``
(a dependency there). Import it from here: ``from vfrs._compat import tomllib``.
"""

from __future__ import annotations

import sys

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

__all__ = ["tomllib"]
