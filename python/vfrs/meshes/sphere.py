"""Balls and hemispheres of tetrahedra: a structured cube mapped radially onto the sphere.

Each point p of the cube [-1, 1]^3 moves to ``p * max|p_i| / |p|`` (the cube's shells become
spheres), which keeps the Kuhn tetrahedra of :func:`vfrs.meshes.box` positively oriented and
conforming. Elements near the cube's corners are the most distorted (still valid).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import MeshError
from ..mesh import Mesh, orient_outward
from ..params import Vec3, param
from .base import GeneratorParams, option_error, register_generator
from .box import box

_DIRS = {"+x": (0, 1.0), "-x": (0, -1.0), "+y": (1, 1.0), "-y": (1, -1.0), "+z": (2, 1.0), "-z": (2, -1.0)}


def _to_ball(p):
    r2 = np.linalg.norm(p, axis=1)
    rinf = np.abs(p).max(axis=1)
    scale = np.divide(rinf, r2, out=np.ones_like(r2), where=r2 > 0)
    return p * scale[:, None]


def sphere(radius: float = 1.0, center=(0.0, 0.0, 0.0), cells: int = 8) -> Mesh:
    """A ball of ``radius`` around ``center``; ``cells`` hexahedra across a diameter (6 tets each).

    Surfaces: ``surface`` (the sphere). Region: ``all``.

    >>> m = sphere(1.0, cells=8)
    >>> abs(m.volume - 4 / 3 * np.pi) / (4 / 3 * np.pi) < 0.05
    True
    """
    if not radius > 0:
        raise MeshError(f"sphere radius must be positive, got {radius}")
    if int(cells) < 2 or int(cells) % 2:
        raise MeshError(f"sphere cells must be an even integer >= 2, got {cells}")
    cube = box((2.0, 2.0, 2.0), (cells, cells, cells), origin=(-1.0, -1.0, -1.0))
    pts = _to_ball(cube.points) * radius + np.asarray(center, dtype=float)
    faces = cube.boundary_faces()
    mesh = Mesh(pts, cube.tets)
    mesh.surfaces = {"surface": orient_outward(mesh.points, mesh.tets, faces)}
    mesh.regions = {"all": np.arange(mesh.n_tets)}
    setattr(mesh, "midpoint", _mapped_midpoint(cube.points, lambda q: _to_ball(q) * radius + np.asarray(center, float)))
    return mesh


def _mapped_midpoint(cube_points, mapping):
    """``midpoint(a, b)`` (read by ``order = 2``): the edge's midpoint, except on the sphere's
    surface (both vertices on the cube's outer shell, on one face of the cube), where it is the
    image under the mesh's ``mapping`` of the cube edge's midpoint: on the sphere, not on the
    chord. (Mapping every mid-edge node would follow the radial map's kinks along the cube's
    diagonals and distort the elements there.)"""
    def midpoint(a, b):
        pa, pb = cube_points[a], cube_points[b]
        x = 0.5 * (mapping(pa) + mapping(pb))
        shell = (np.abs(pa).max(axis=1) > 1 - 1e-12) & (np.abs(pb).max(axis=1) > 1 - 1e-12)
        one_face = ((np.abs(pa) > 1 - 1e-12) & (np.abs(pb) > 1 - 1e-12) & (np.sign(pa) == np.sign(pb))).any(axis=1)
        on = shell & one_face
        x[on] = mapping(0.5 * (pa[on] + pb[on]))
        return x

    return midpoint


def hemisphere(radius: float = 1.0, center=(0.0, 0.0, 0.0), cells: int = 8, pole: str = "-z") -> Mesh:
    """Half a ball: the flat face through ``center``, the dome's pole along ``pole`` ("-z" etc).

    ``cells`` hexahedra across the diameter (half as many from the flat face to the pole).
    Surfaces: ``flat`` (the disc), ``curved`` (the dome). Region: ``all``. The default points
    the dome down, as for a Hertz contact with a plane below.

    >>> m = hemisphere(1.0, cells=8)
    >>> sorted(m.surfaces), bool(m.points[:, 2].max() <= 1e-12)
    (['curved', 'flat'], True)
    """
    if not radius > 0:
        raise MeshError(f"hemisphere radius must be positive, got {radius}")
    if int(cells) < 2 or int(cells) % 2:
        raise MeshError(f"hemisphere cells must be an even integer >= 2, got {cells}")
    if pole not in _DIRS:
        raise MeshError(f"hemisphere pole must be one of {sorted(_DIRS)}, got {pole!r}")
    n = int(cells)
    cube = box((2.0, 2.0, 1.0), (n, n, n // 2), origin=(-1.0, -1.0, -1.0))  # z in [-1, 0]
    p = _to_ball(cube.points)
    p[np.abs(cube.points[:, 2]) < 1e-12, 2] = 0.0
    # Rotate the -z pole onto the requested direction (a proper rotation keeps orientation).
    axis, sign = _DIRS[pole]
    if (axis, sign) != (2, -1.0):
        R = _rotation_from_minus_z(axis, sign)
        p = p @ R.T
    pts = p * radius + np.asarray(center, dtype=float)
    R = _rotation_from_minus_z(axis, sign) if (axis, sign) != (2, -1.0) else np.eye(3)

    def mapping(q):
        b = _to_ball(q)
        b[np.abs(q[:, 2]) < 1e-12, 2] = 0.0
        return (b @ R.T) * radius + np.asarray(center, dtype=float)

    flat = cube.surfaces["zmax"]
    faces = cube.boundary_faces()
    on_flat = np.isin(np.sort(faces, axis=1).view([("", faces.dtype)] * 3), np.sort(flat, axis=1).view([("", flat.dtype)] * 3)).ravel()
    mesh = Mesh(pts, cube.tets)
    mesh.surfaces = {
        "flat": orient_outward(mesh.points, mesh.tets, flat),
        "curved": orient_outward(mesh.points, mesh.tets, faces[~on_flat]),
    }
    mesh.regions = {"all": np.arange(mesh.n_tets)}
    setattr(mesh, "midpoint", _mapped_midpoint(cube.points, mapping))
    return mesh


def _rotation_from_minus_z(axis: int, sign: float) -> np.ndarray:
    """A rotation taking (0, 0, -1) to the unit vector ``sign * e_axis``."""
    a = np.array([0.0, 0.0, -1.0])
    b = np.zeros(3)
    b[axis] = sign
    if np.allclose(a, -b):  # +z: half turn about x
        return np.diag([1.0, -1.0, -1.0])
    v = np.cross(a, b)
    c = float(a @ b)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


@register_generator(sphere)
@dataclass(frozen=True)
class SphereParams(GeneratorParams):
    """``builtin = "sphere"``: see :func:`sphere`."""

    name: ClassVar[str] = "sphere"
    radius: float = param(1.0, doc="radius", unit="m", positive=True)
    center: Vec3 = param((0.0, 0.0, 0.0), doc="centre", unit="m")
    cells: int = param(8, doc="hexahedra across a diameter, even", minimum=2)

    def check(self) -> None:
        if self.cells % 2:
            raise option_error("cells", f"{self.cells} must be even (hexahedra across a diameter)")

    def estimate(self) -> tuple[int, int]:
        c = int(self.cells)
        return (c + 1) ** 3, 6 * c**3


@register_generator(hemisphere)
@dataclass(frozen=True)
class HemisphereParams(GeneratorParams):
    """``builtin = "hemisphere"``: see :func:`hemisphere`."""

    name: ClassVar[str] = "hemisphere"
    radius: float = param(1.0, doc="radius", unit="m", positive=True)
    center: Vec3 = param((0.0, 0.0, 0.0), doc="centre of the flat face", unit="m")
    cells: int = param(8, doc="hexahedra across the diameter, even", minimum=2)
    pole: str = param("-z", doc="direction of the dome's pole", choices=tuple(_DIRS))

    def check(self) -> None:
        if self.cells % 2:
            raise option_error("cells", f"{self.cells} must be even (hexahedra across the diameter)")

    def estimate(self) -> tuple[int, int]:
        c = int(self.cells)
        return (c + 1) ** 2 * (c // 2 + 1), 6 * c * c * (c // 2)
