"""A structured box of tetrahedra (each hexahedral cell split into six, conforming)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import MeshError
from ..mesh import Mesh
from ..params import Int3, Vec3, param
from .base import GeneratorParams, option_error, register_generator

# Kuhn split of the unit cube (vertex k at bits x=k&1, y=k&2, z=k&4) into 6 tets around the
# main diagonal 0-7; it conforms across cells because every cell is split the same way.
KUHN = np.array([[0, 1, 3, 7], [0, 1, 7, 5], [0, 5, 7, 4], [0, 3, 2, 7], [0, 2, 6, 7], [0, 6, 4, 7]])


#: The faces a box can be graded toward (``grade_toward``) and the growth ratio unless given.
FACES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
GRADE_RATIO = 1.2


def box(size=(1.0, 1.0, 1.0), cells=(4, 4, 4), origin=(0.0, 0.0, 0.0), jitter: float = 0.0, seed: int = 0,
        grade_toward=None, ratio=None) -> Mesh:
    """A box ``origin + [0, size]`` with ``cells`` hexahedra per axis, 6 tets each.

    Surfaces: ``xmin``, ``xmax``, ``ymin``, ``ymax``, ``zmin``, ``zmax`` (outward triangles).
    ``jitter`` moves interior nodes randomly by up to that fraction of a cell (an
    unstructured-looking mesh for tests); deterministic for a given ``seed``.

    ``grade_toward`` (one of the surface names; unset: equal cells): the layers of cells
    parallel to that face are thinnest at it and each ``ratio`` (unset: 1.2; in [1, 2]) times
    thicker than the one before it, away from the face (the cells' number is kept: at equal
    ``cells`` the layer at the face is thinner than on the equal-celled box). Every element
    is a Kuhn tetrahedron of a rectangular cell, so its shape is that cell's
    (:func:`vfrs.mesh_quality.quality`). The jitter is then a fraction of the thinnest layer.

    >>> m = box((2.0, 1.0, 1.0), (4, 2, 2))
    >>> m.n_tets, round(m.volume, 12)
    (96, 2.0)
    """
    size, cells, growth = _checked(size, cells, jitter, grade_toward, ratio)
    nx, ny, nz = cells
    axes = [np.linspace(0.0, s, c + 1) for s, c in zip(size, cells)]
    h = size / cells
    if grade_toward is not None:
        g_axis = "xyz".index(grade_toward[0])
        axes[g_axis] = _geometric(float(size[g_axis]), int(cells[g_axis]), float(growth))
        if grade_toward.endswith("max"):
            axes[g_axis] = size[g_axis] - axes[g_axis][::-1]
            axes[g_axis][0] = 0.0
        h = h.copy()
        h[g_axis] = np.diff(axes[g_axis]).min()
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    points = np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])

    def nid(i, j, k):
        return (i * (ny + 1) + j) * (nz + 1) + k

    i, j, k = (g.ravel() for g in np.meshgrid(np.arange(nx), np.arange(ny), np.arange(nz), indexing="ij"))
    corners = np.stack([nid(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)) for c in range(8)], axis=1)
    tets = corners[:, KUHN].reshape(-1, 4)

    if jitter > 0:
        rng = np.random.default_rng(seed)
        interior = np.all((points > 1e-12 * size) & (points < size * (1 - 1e-12)), axis=1)
        points[interior] += rng.uniform(-jitter, jitter, (interior.sum(), 3)) * h
    points = points + np.asarray(origin, dtype=float)

    surfaces = _faces(cells)
    mesh = Mesh(points, tets)
    # Orient every face outward, and check each lies on the boundary.
    from ..mesh import orient_outward

    mesh.surfaces = {k: orient_outward(mesh.points, mesh.tets, v) for k, v in surfaces.items()}
    mesh.regions = {"all": np.arange(len(tets))}
    return mesh


def _checked(size, cells, jitter, grade_toward, ratio) -> tuple:
    """(size, cells, growth ratio) of :func:`box` as arrays, or a MeshError naming the bad argument."""
    try:
        size = np.asarray(size, dtype=float)
        cells_in = [c for c in cells]
        if any(isinstance(c, (bool, float)) or int(c) != c for c in cells_in) or not all(1 <= int(c) < 2**31 for c in cells_in):
            raise ValueError
        cells = np.asarray([int(c) for c in cells_in], dtype=np.int64)
    except (TypeError, ValueError, OverflowError):
        raise MeshError(f"box cells must be 3 integers in [1, 2^31), got {cells!r}") from None
    if size.shape != (3,) or (size <= 0).any() or not np.isfinite(size).all():
        raise MeshError(f"box size must be 3 positive lengths, got {size.tolist()}")
    if cells.shape != (3,) or (cells < 1).any():
        raise MeshError(f"box cells must be 3 integers >= 1, got {cells.tolist()}")
    if isinstance(jitter, bool) or not isinstance(jitter, (int, float, np.floating)) or not 0 <= jitter < 0.3:
        raise MeshError(f"jitter must be in [0, 0.3) of a cell to keep elements valid, got {jitter}")
    if grade_toward is not None and grade_toward not in FACES:
        raise MeshError(f"box grade_toward must be one of {list(FACES)}, got {grade_toward!r}")
    growth = GRADE_RATIO if ratio is None else ratio
    if isinstance(growth, bool) or not isinstance(growth, (int, float, np.floating)) or not 1.0 <= growth <= 2.0:
        raise MeshError(f"box ratio must be in [1, 2], got {ratio!r}")
    return size, cells, growth


def _faces(cells) -> dict:
    """The six faces of a box of ``cells`` (node numbering of :func:`box`), two triangles a cell face."""
    nx, ny, nz = cells
    surfaces = {}
    for axis, name in enumerate("xyz"):
        for side, tag in ((0, "min"), (1, "max")):
            n_other = [c for a, c in enumerate(cells) if a != axis]
            idx: list[slice | int] = [slice(None)] * 3
            idx[axis] = int(cells[axis]) if side else 0
            grid = np.arange((nx + 1) * (ny + 1) * (nz + 1)).reshape(nx + 1, ny + 1, nz + 1)[tuple(idx)]
            a, b = (g.ravel() for g in np.meshgrid(np.arange(n_other[0]), np.arange(n_other[1]), indexing="ij"))
            q = np.stack([grid[a, b], grid[a + 1, b], grid[a + 1, b + 1], grid[a, b + 1]], axis=1)
            tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
            surfaces[f"{name}{tag}"] = tri
    return surfaces


def _geometric(length: float, n: int, ratio: float) -> np.ndarray:
    """``n + 1`` positions from 0 to ``length`` (ends exact) whose cells grow by ``ratio``."""
    w = np.ones(n)
    for k in range(1, n):  # products, not pow: the same bits on every CPU
        w[k] = w[k - 1] * ratio
    x = np.r_[0.0, np.cumsum(w) / w.sum()] * length
    x[-1] = length
    return x


@register_generator(box)
@dataclass(frozen=True)
class BoxParams(GeneratorParams):
    """``builtin = "box"``: see :func:`box`."""

    name: ClassVar[str] = "box"
    size: Vec3 = param((1.0, 1.0, 1.0), doc="edge lengths", unit="m", positive=True)
    cells: Int3 = param((4, 4, 4), doc="hexahedra per axis", minimum=1)
    origin: Vec3 = param((0.0, 0.0, 0.0), doc="the corner with the lowest coordinates", unit="m")
    jitter: float = param(0.0, doc="random move of the interior nodes, in [0, 0.3) of a cell", nonnegative=True)
    seed: int = param(0, doc="random seed of the jitter", minimum=0)
    grade_toward: str | None = param(None, doc="the face the cell layers are thinnest at (unset: equal cells)",
                                     choices=FACES)
    ratio: float | None = param(None, doc=f"growth of the layers away from grade_toward, in [1, 2] (unset: "
                                f"{GRADE_RATIO})", low=1.0, high=2.0)

    def check(self) -> None:
        if not 0 <= self.jitter < 0.3:
            raise option_error("jitter", f"{self.jitter:g} is outside [0, 0.3) of a cell (larger moves can invert elements)")
        if not 0 <= self.seed < 2**63:
            raise option_error("seed", f"{self.seed} is outside [0, 2^63)")
        if self.ratio is not None and not 1.0 <= self.ratio <= 2.0:
            raise option_error("ratio", f"{self.ratio:g} is outside [1, 2]")

    def estimate(self) -> tuple[int, int]:
        nx, ny, nz = (int(c) for c in self.cells)
        return (nx + 1) * (ny + 1) * (nz + 1), 6 * nx * ny * nz
