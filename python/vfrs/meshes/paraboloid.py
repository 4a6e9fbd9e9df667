"""A Hertz specimen: a block whose bottom face is a paraboloid, graded towards its pole."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import MeshError
from ..mesh import Mesh
from ..params import param
from .base import GeneratorParams, libm, option_error, register_generator
from .box import box


def paraboloid_block(width=1.0, radius=5.0, cells=8, grading=3.0) -> Mesh:
    """A cube [0, width]^3 whose bottom face is the paraboloid z = (x^2 + y^2) / (2 radius)
    and whose top face is flat at z = width: the quarter of a Hertz specimen (symmetry planes
    x = 0 and y = 0; near the pole the paraboloid is a sphere of ``radius``).

    Nodes are graded towards the pole by the tensor map x -> width (x / width)^grading on
    every axis (axis-aligned hexahedra stay hexahedra, so the Kuhn tetrahedra stay valid), then
    each node is lifted by (1 - z / width) of the paraboloid's height. Surfaces as
    :func:`vfrs.meshes.box` (``zmin`` is the curved face).

    >>> m = paraboloid_block(0.01, 0.05, cells=4)
    >>> m.n_tets, round(float(m.points[:, 2].min()), 12)
    (384, 0.0)
    """
    if not (width > 0 and radius > 0 and grading >= 1.0 and int(cells) >= 1):
        raise MeshError(f"paraboloid_block: need width > 0, radius > 0, grading >= 1, cells >= 1; got "
                        f"{width}, {radius}, {grading}, {cells}")
    m = box((1.0, 1.0, 1.0), (int(cells),) * 3)
    p = libm(math.pow, m.points, np.full(m.points.shape, float(grading))) * width
    p[:, 2] += (1.0 - p[:, 2] / width) * (p[:, 0] ** 2 + p[:, 1] ** 2) / (2.0 * radius)
    # Re-validated: the map keeps every element positively oriented.
    mesh = Mesh(p, m.tets, surfaces=m.surfaces, regions=m.regions)

    def midpoint(a, b):  # read by order = 2: edges' midpoints, those on the curved face lifted onto it
        x = 0.5 * (p[a] + p[b])
        on = (m.points[a, 2] == 0.0) & (m.points[b, 2] == 0.0)
        x[on, 2] = (x[on, 0] ** 2 + x[on, 1] ** 2) / (2.0 * radius)
        return x

    setattr(mesh, "midpoint", midpoint)
    return mesh


@register_generator(paraboloid_block)
@dataclass(frozen=True)
class ParaboloidBlockParams(GeneratorParams):
    """``builtin = "paraboloid_block"``: see :func:`paraboloid_block`."""

    name: ClassVar[str] = "paraboloid_block"
    width: float = param(1.0, doc="edge of the cube", unit="m", positive=True)
    radius: float = param(5.0, doc="radius of curvature at the pole", unit="m", positive=True)
    cells: int = param(8, doc="hexahedra per edge", minimum=1)
    grading: float = param(3.0, doc="exponent of the grading towards the pole, >= 1", positive=True)

    def check(self) -> None:
        if not self.grading >= 1.0:
            raise option_error("grading", f"{self.grading:g} must be >= 1 (1: uniform)")

    def estimate(self) -> tuple[int, int]:
        c = int(self.cells)
        return (c + 1) ** 3, 6 * c**3
