"""Built-in vocal folds: an M5-type coronal profile extruded along z, meshed with tetrahedra.

The profile follows the parameters that define the M5 shape of Scherer et al. (2001, J.
Acoust. Soc. Am. 109, 1616-1630): medial-surface thickness ``T``, glottal angle ``psi``
(convergent > 0, divergent < 0, the medial surface inclined by psi/2 from the flow axis),
exit radius ``R_O`` rounding the glottal exit, and the exit angle (40 degrees) at which the
superior surface leaves the exit. The inferior surface (conus elasticus) rises from the
lateral wall at ``inferior_angle`` and joins the medial surface through ``R_L``. It is a
reconstruction from these parameters, not a copy of the published drawing: where M5's
construction has further fixed constants, this generator uses the straight and circular
pieces named here (see docs: `m5_profile`).

Geometry (right fold, x > 0; the left fold is its mirror image about x = 0):
``half_gap`` is the prephonatory half-width at the narrowest point of the glottis; the
lateral wall is at ``x = half_gap + depth``; the fold spans ``0 <= z <= length`` (anterior
to posterior).

The mesh is a mapped structured grid (along the medial curve ``s``, from the medial surface to
the lateral wall ``r``, along ``z``), each hexahedral cell split into six tetrahedra like
:func:`vfrs.meshes.box`, so it is conforming and deterministic. Cells are graded towards
the medial surface, where contact and flow act.

Named surfaces: ``medial`` (wetted by the flow; the contact surface), ``lateral``,
``anterior`` (z = 0), ``posterior`` (z = length), ``inferior`` and ``superior`` (the bottom
and top cuts). Regions: ``cover`` (within ``cover_thickness`` of the medial surface) and
``body``; also ``all``.
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import MeshError
from ..mesh import Mesh
from ..params import Int3, param
from .base import GeneratorParams, libm, option_error, register_generator, zone_nodes_through
from .box import KUHN
from .m5_family import FAMILIES, MAX_LEVEL, QUALITY_FLOOR, family_cells, family_grid, fillet_geometry, profile_frame

#: Across the fold (medial -> lateral) each cell is this many times thicker than the one
#: before it, unless ``medial_ratio`` says otherwise.
MEDIAL_RATIO = 1.35
#: Outside a contact zone neighbouring cells grow by this ratio, unless ``zone_ratio`` says.
ZONE_RATIO = 1.2
#: The largest ``zone_ratio``: beyond it the cells next to each other differ too much in size
#: (and the thin layers under long cells make flat tetrahedra).
MAX_ZONE_RATIO = 1.5

RESOLUTIONS = {
    # cells along the medial curve, across (medial -> lateral), along z
    "coarse": (20, 5, 8),
    "medium": (32, 8, 14),
    "fine": (48, 12, 20),
}


# The generator's keys, their defaults, units and checks: the one place the defaults are
# written; m5_profile() and m5() take theirs from here (register_generator checks they agree).
@dataclass(frozen=True)
class M5Params(GeneratorParams):
    """``builtin = "m5"``: see :func:`m5` and :func:`m5_profile`."""

    name: ClassVar[str] = "m5"
    side: str = param("right", doc="which fold: right (x > 0) or left (mirrored)", choices=("right", "left"))
    resolution: str = param("medium", doc="cells from RESOLUTIONS, unless `cells` is given", choices=tuple(RESOLUTIONS))
    cells: Int3 | None = param(None, doc="cells along the medial curve, medial to lateral, along z", minimum=2)
    length: float = param(14.0e-3, doc="anterior-posterior length", unit="m", positive=True)
    cover_thickness: float = param(0.5e-3, doc="depth of the cover region", unit="m", nonnegative=True)
    grading: float = param(0.5, doc="clustering towards the medial surface, in [0, 0.9)", nonnegative=True)
    T: float = param(3.0e-3, doc="medial-surface thickness", unit="m", positive=True)
    psi: float = param(0.0, doc="glottal angle, convergent > 0", unit="degrees", low=-40.0, high=40.0)
    R_O: float = param(0.987e-3, doc="exit radius", unit="m", positive=True)
    exit_angle: float = param(40.0, doc="angle of the superior surface", unit="degrees", low=10.0, high=80.0)
    R_L: float = param(1.5e-3, doc="radius from the inferior onto the medial surface", unit="m", positive=True)
    inferior_angle: float = param(50.0, doc="angle of the inferior surface", unit="degrees", low=10.0, high=80.0)
    half_gap: float = param(0.05e-3, doc="prephonatory half-width of the glottis", unit="m", nonnegative=True)
    depth: float = param(8.0e-3, doc="medial surface to lateral wall", unit="m", positive=True)
    inferior_height: float = param(5.0e-3, doc="inferior cut below the medial surface", unit="m", positive=True)
    superior_height: float = param(2.0e-3, doc="superior cut above the medial surface", unit="m", positive=True)
    # Grading toward the contact zone (issue 32): unset, the mesh is today's, bit for bit, and
    # the resolved scene (its hash, a sweep's run ids) does not change.
    medial_ratio: float | None = param(None, doc=f"growth of the cells from the medial surface to the lateral wall, "
                                       f"in [1, 2] (unset: {MEDIAL_RATIO}; 1: equal)", low=1.0, high=2.0)
    contact_zone: float | None = param(None, doc="length along the medial curve, centred on the narrowest point, of "
                                       "the finest equal cells; they grow by zone_ratio outside it (unset: the sine "
                                       "map of grading)", unit="m", positive=True)
    contact_zone_z: float | None = param(None, doc="length along z, centred at mid-length, of the finest equal "
                                         "cells; they grow by zone_ratio outside it (unset: equal cells along z)",
                                         unit="m", positive=True)
    zone_ratio: float | None = param(None, doc=f"growth of neighbouring cells outside the contact zone, in [1, "
                                     f"{MAX_ZONE_RATIO}] (unset: {ZONE_RATIO})", low=1.0, high=MAX_ZONE_RATIO)
    # The systematic family (issue 45, vfrs.meshes.m5_family): unset, nothing changes.
    family: str | None = param(None, doc="a mesh family whose levels divide every length by 1.5 "
                               "(vfrs.meshes.m5_family; `resolution`, `cells`, `grading` unused)",
                               choices=("systematic",))
    level: int | None = param(None, doc="the family's level, 0 (coarsest) to 3", minimum=0)

    def check(self) -> None:
        if not 0 <= self.grading < 0.9:
            raise option_error("grading", f"{self.grading:g} is outside [0, 0.9)")
        if self.medial_ratio is not None and not 1.0 <= self.medial_ratio <= 2.0:
            raise option_error("medial_ratio", f"{self.medial_ratio:g} is outside [1, 2]")
        if self.zone_ratio is not None and not 1.0 <= self.zone_ratio <= MAX_ZONE_RATIO:
            raise option_error("zone_ratio", f"{self.zone_ratio:g} is outside [1, {MAX_ZONE_RATIO}]")
        for key in ("contact_zone", "contact_zone_z"):
            v = getattr(self, key)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise option_error(key, f"{v:g} must be a positive length (metres)")
        _check_family(self.family, self.level, self.cells, self.contact_zone, option_error)
        # The profile is cheap (a few hundred points): the geometric checks of the keys
        # together (an exit arc that does not fit below the superior cut, ...) run now.
        m5_profile(T=self.T, psi=self.psi, R_O=self.R_O, exit_angle=self.exit_angle, R_L=self.R_L,
                   inferior_angle=self.inferior_angle, half_gap=self.half_gap, depth=self.depth,
                   inferior_height=self.inferior_height, superior_height=self.superior_height)

    def estimate(self) -> tuple[int, int]:
        if self.family is not None:
            ns, nr, nz = _family_cells(**self.arguments())
            return (ns + 1) * (nr + 1) * (nz + 1), 6 * ns * nr * nz
        ns, nr, nz = (int(c) for c in (self.cells if self.cells is not None else RESOLUTIONS[self.resolution]))
        return (ns + 1) * (nr + 1) * (nz + 1), 6 * ns * nr * nz

    def to_dict(self) -> dict:
        """The resolved mesh; without ``resolution`` when ``cells`` or ``family`` is given (unused then)."""
        d = super().to_dict()
        if self.cells is not None or self.family is not None:
            del d["resolution"]
        return d


def m5_profile(
    T=M5Params.T,
    psi=M5Params.psi,
    R_O=M5Params.R_O,
    exit_angle=M5Params.exit_angle,
    R_L=M5Params.R_L,
    inferior_angle=M5Params.inferior_angle,
    half_gap=M5Params.half_gap,
    depth=M5Params.depth,
    inferior_height=M5Params.inferior_height,
    superior_height=M5Params.superior_height,
    n=400,
):
    """The medial curve of the right fold as ``n`` points (x, y), from the inferior cut up to
    the superior cut (y increases along it), and the profile's lateral wall x.

    Pieces, bottom to top: a straight inferior surface at ``inferior_angle`` (degrees from
    the horizontal) from the lateral-inferior corner; an arc of radius ``R_L`` onto the
    medial surface; the straight medial surface of height ``T`` inclined by ``psi/2``; an
    arc of radius ``R_O`` (the glottal exit); a straight superior surface leaving at
    ``exit_angle`` from the horizontal, up to ``superior_height`` above the medial surface,
    then horizontal to the lateral wall.
    """
    for name, v in dict(T=T, R_O=R_O, R_L=R_L, depth=depth, inferior_height=inferior_height, superior_height=superior_height).items():
        if not (np.isfinite(v) and v > 0):
            raise MeshError(f"m5: {name} = {v} must be positive (metres)")
    if not (np.isfinite(half_gap) and half_gap >= 0):
        raise MeshError(f"m5: half_gap = {half_gap} must be >= 0 (metres)")
    if not -40.0 <= psi <= 40.0:
        raise MeshError(f"m5: glottal angle psi = {psi} degrees is outside [-40, 40]")
    if not 10.0 <= exit_angle <= 80.0 or not 10.0 <= inferior_angle <= 80.0:
        raise MeshError("m5: exit_angle and inferior_angle must lie in [10, 80] degrees")
    t_m, t_s, t_i, top, bottom = profile_frame(T, psi, exit_angle, inferior_angle, half_gap)
    # Exit arc: turns from t_m to the superior direction t_s (lateral and up).
    exit_arc = _fillet(top, t_m, t_s, R_O, n // 4)
    # Inferior arc: turns from the inferior direction t_i (medial and up) into t_m.
    inf_arc = _fillet(bottom, t_i, t_m, R_L, n // 4)
    y_top = top[1] + superior_height
    y_bot = bottom[1] - inferior_height
    # Straight runs to the cuts.
    p_sup = exit_arc[-1]
    if p_sup[1] >= y_top:
        raise MeshError("m5: superior_height is too small for the exit arc; increase it")
    sup_end = p_sup + t_s * (y_top - p_sup[1]) / t_s[1]
    p_inf = inf_arc[0]
    inf_start = p_inf - t_i * (p_inf[1] - y_bot) / t_i[1]
    lateral = half_gap + depth
    if max(sup_end[0], inf_start[0]) >= lateral * 0.95:
        raise MeshError("m5: depth is too small for this profile (the sloped surfaces reach the lateral wall)")
    pieces = [
        _segment(inf_start, inf_arc[0], n // 6),
        inf_arc,
        _segment(inf_arc[-1], exit_arc[0], n // 6),
        exit_arc,
        _segment(exit_arc[-1], sup_end, n // 6),
    ]
    curve = np.concatenate([p if k == 0 else p[1:] for k, p in enumerate(pieces)])
    # The fillets cut the corner that was placed at the half-gap: shift so that the curve's
    # narrowest point is exactly at x = half_gap.
    curve[:, 0] += half_gap - curve[:, 0].min()
    return curve, lateral


def _segment(a, b, n):
    t = np.linspace(0.0, 1.0, max(n, 2))[:, None]
    return (1 - t) * a + t * b


def _fillet(corner, t_in, t_out, radius, n):
    """Arc of ``radius`` tangent to the line arriving at ``corner`` along ``t_in`` and the
    line leaving it along ``t_out``; returns points from the first to the second tangency."""
    arc = fillet_geometry(corner, t_in, t_out, radius)
    if arc is None:
        return np.array([corner, corner])
    turn, sign, centre, start = arc
    ang = start + sign * np.linspace(0.0, turn, max(n, 3))
    return centre + radius * np.column_stack([libm(math.cos, ang), libm(math.sin, ang)])


def _resample(curve, ns, grading):
    """ns + 1 points along the curve, denser near the middle (the medial surface) when
    grading > 0, with one point exactly at the narrowest point (minimum x), so that the
    mesh's half-gap is the one asked for."""
    seg = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    s = np.r_[0.0, np.cumsum(seg)]
    u = np.linspace(0.0, 1.0, ns + 1)
    # Cluster towards u = 0.5 smoothly: a sine map keeps the ends and the order.
    u = u - grading * libm(math.sin, 2 * np.pi * u) / (2 * np.pi)
    target = u * s[-1]
    narrow = np.flatnonzero(curve[:, 0] <= curve[:, 0].min() + 1e-12 * abs(curve[:, 0]).max())
    s_narrow = s[narrow[len(narrow) // 2]]
    i = int(np.argmin(np.abs(target - s_narrow)))
    if 0 < i < ns:
        target[i] = s_narrow
    return np.column_stack([np.interp(target, s, curve[:, 0]), np.interp(target, s, curve[:, 1])])


def m5(
    side=M5Params.side,
    resolution=M5Params.resolution,
    cells=M5Params.cells,
    length=M5Params.length,
    cover_thickness=M5Params.cover_thickness,
    grading=M5Params.grading,
    T=M5Params.T,
    psi=M5Params.psi,
    R_O=M5Params.R_O,
    exit_angle=M5Params.exit_angle,
    R_L=M5Params.R_L,
    inferior_angle=M5Params.inferior_angle,
    half_gap=M5Params.half_gap,
    depth=M5Params.depth,
    inferior_height=M5Params.inferior_height,
    superior_height=M5Params.superior_height,
    medial_ratio=M5Params.medial_ratio,
    contact_zone=M5Params.contact_zone,
    contact_zone_z=M5Params.contact_zone_z,
    zone_ratio=M5Params.zone_ratio,
    family=M5Params.family,
    level=M5Params.level,
) -> Mesh:
    """One vocal fold (``side`` "right", x > 0, or "left", mirrored) as a tetrahedral mesh.

    ``resolution``: "coarse", "medium" or "fine" (see ``RESOLUTIONS``), or ``cells`` =
    (along the medial curve, medial to lateral, along z). The profile keywords (``T``,
    ``psi``, ``R_O``, ``exit_angle``, ``R_L``, ``inferior_angle``, ``half_gap``, ``depth``,
    ``inferior_height``, ``superior_height``; metres and degrees) are those of
    :func:`m5_profile`.

    Grading (all unset by default: today's mesh, bit for bit). Across the fold the cells grow
    geometrically from the medial surface by ``medial_ratio`` (unset: 1.35). Along the medial
    curve the nodes follow a sine map clustering them towards the curve's middle by
    ``grading`` (0: equal cells), unless ``contact_zone`` (metres) is given: then the cells
    within half of it on either side of the narrowest point of the glottis (where the folds
    touch first; a node lies on it) are equal and the finest, and outside they grow by
    ``zone_ratio`` (unset: 1.2, at most 1.5) from each to the next (``grading`` is unused).
    ``contact_zone_z`` does the same along z around mid-length (unset: equal cells along z).
    At the same ``cells``, the elements in the zone are then smaller than on the uniform mesh,
    those far from it larger (:func:`vfrs.meshes.base.zone_nodes`). Element quality:
    :func:`vfrs.mesh_quality.quality`; the graded options keep the smallest dihedral angle above the
    floor tests/test_mesh_quality.py states.

    ``family = "systematic"`` with ``level`` 0 to 3: the mesh family of
    :mod:`vfrs.meshes.m5_family` (every length 1.5 times smaller per level, the profile's break
    points nodes on every level, the arcs' faceting error bounded; ``medial_ratio``,
    ``zone_ratio`` and ``contact_zone_z`` grade it; ``resolution``, ``cells``, ``grading`` and
    ``contact_zone`` are unused). The mesh then carries ``family_info`` (a dict: its cells,
    first layer, faceting error, quality).

    >>> right = m5("right", "coarse")
    >>> left = m5("left", "coarse")
    >>> bool(abs(right.volume - left.volume) < 1e-15), sorted(right.surfaces)[:3]
    (True, ['anterior', 'inferior', 'lateral'])
    """
    ns, nr, nz = _m5_cells(side, resolution, cells, length, grading)
    _m5_check_grading(medial_ratio, contact_zone, contact_zone_z, zone_ratio)
    profile = dict(T=T, psi=psi, R_O=R_O, exit_angle=exit_angle, R_L=R_L, inferior_angle=inferior_angle,
                   half_gap=half_gap, depth=depth, inferior_height=inferior_height, superior_height=superior_height)
    curve, lateral = m5_profile(**profile)
    if family is not None or level is not None:
        _check_family(family, level, cells, contact_zone, lambda key, message: MeshError(f"m5: {key}: {message}"))
        prof, info = family_grid(level, length, medial_ratio=medial_ratio, contact_zone_z=contact_zone_z,
                                 zone_ratio=zone_ratio, **profile)
        ns, nr, nz = info["cells"]
        mesh = _m5_mesh(prof.reshape(-1, 3), prof, ns, nr, nz, side, cover_thickness)
        _family_quality(mesh, info)
        fine_grid = dict(level=level, length=length, medial_ratio=medial_ratio, contact_zone_z=contact_zone_z,
                         zone_ratio=zone_ratio, **profile)
        setattr(mesh, "midpoint", _family_midpoint(fine_grid, (ns, nr, nz), side))  # read by order = 2
        return mesh
    points, prof = _m5_points(curve, lateral, ns, nr, nz, length, grading, medial_ratio, contact_zone,
                              contact_zone_z, zone_ratio)
    return _m5_mesh(points, prof, ns, nr, nz, side, cover_thickness)


def _m5_mesh(points, prof, ns, nr, nz, side, cover_thickness) -> Mesh:
    """The fold's mesh from its grid points (right fold) and ``prof`` (the coronal profile grid
    (ns+1, nr+1, 2), or the points' grid (ns+1, nr+1, nz+1, 3) when it changes along z)."""
    tets, cell_j = _m5_tets(ns, nr, nz)
    surfaces = _m5_surfaces(ns, nr, nz)
    if side == "left":
        points = points * [-1.0, 1.0, 1.0]
    # The mapping may reverse orientation: fix the sign once for all elements.
    from ..mesh import orient_outward, signed_volumes

    if signed_volumes(points, tets[:1])[0] < 0:
        tets = tets[:, [0, 2, 1, 3]]
    if prof.ndim == 3:  # one profile for every z: whole layers are cover
        depth_of_layer = np.linalg.norm(prof[:, 1:, :] - prof[:, :1, :], axis=2).mean(axis=0)  # (nr,)
        n_cover = int(np.searchsorted(depth_of_layer, cover_thickness * (1 - 1e-9)) + 1)
        cover = np.flatnonzero(cell_j < min(n_cover, nr))
    else:  # graded toward the contact zone: each cell by the depth of its face nearer the medial surface
        depth = np.linalg.norm(prof - prof[:, :1], axis=3)  # (ns+1, nr+1, nz+1)
        inner = (depth[:-1, :-1, :-1] + depth[1:, :-1, :-1] + depth[:-1, :-1, 1:] + depth[1:, :-1, 1:]) / 4
        cover = np.flatnonzero(np.repeat((inner < cover_thickness * (1 - 1e-9)).ravel(), 6))
    mesh = Mesh(points, tets)
    mesh.surfaces = {name: orient_outward(mesh.points, mesh.tets, tri) for name, tri in surfaces.items()}
    mesh.regions = {"cover": cover, "body": np.setdiff1d(np.arange(len(tets)), cover), "all": np.arange(len(tets))}
    # The medial nodes as an (s, z) grid: lets the flow model slice the glottis quickly.
    setattr(mesh, "medial_grid", np.arange(len(points)).reshape(ns + 1, nr + 1, nz + 1)[:, 0, :])  # read by vfrs.flow
    return mesh


def _family_midpoint(kw, cells, side):
    """``midpoint(a, b)`` of the family's mesh: where the mid-edge node of the edge between
    nodes a and b lies on the true geometry (the arcs, not their chords), from the grid with a
    node between every two neighbours (:func:`vfrs.meshes.m5_family.family_grid_midpoints`,
    computed on the first call)."""
    from .m5_family import family_grid_midpoints

    ns, nr, nz = cells
    fine = []

    def midpoint(a, b):
        if not fine:
            g = family_grid_midpoints(**kw)
            fine.append(g * [-1.0, 1.0, 1.0] if side == "left" else g)
        ia, ja, ka = a // ((nr + 1) * (nz + 1)), (a // (nz + 1)) % (nr + 1), a % (nz + 1)
        ib, jb, kb = b // ((nr + 1) * (nz + 1)), (b // (nz + 1)) % (nr + 1), b % (nz + 1)
        return fine[0][ia + ib, ja + jb, ka + kb]

    return midpoint


def _check_family(family, level, cells, contact_zone, error) -> None:
    """The family options together with the others; ``error(key, message)`` makes the exception."""
    if family is None:
        if level is not None:
            raise error("level", "is a level of a mesh family: give `family` too")
        return
    if family not in FAMILIES:
        raise error("family", f"{family!r}: choose one of {list(FAMILIES)}")
    if level is None or isinstance(level, bool) or not isinstance(level, (int, np.integer)) or not 0 <= level <= MAX_LEVEL:
        raise error("level", f"{level!r}: the family {family!r} has levels 0 to {MAX_LEVEL}")
    for key, v in (("cells", cells), ("contact_zone", contact_zone)):
        if v is not None:
            raise error(key, f"is not used by the family {family!r} (it grades along the medial curve itself)")


def _family_cells(side, resolution, cells, length, cover_thickness, grading, medial_ratio, contact_zone,
                  contact_zone_z, zone_ratio, family, level, **profile):
    """The cells of a family's level (:func:`vfrs.meshes.m5_family.family_cells`)."""
    return family_cells(level, length=length, medial_ratio=medial_ratio, contact_zone_z=contact_zone_z,
                        zone_ratio=zone_ratio, **profile)


def _family_quality(mesh, info) -> None:
    """Adds the mesh's quality to the family's ``info`` (``mesh.family_info``); a warning when
    it is below :data:`vfrs.meshes.m5_family.QUALITY_FLOOR`."""
    import warnings

    from ..errors import VfrsWarning

    q = mesh.quality()
    info = {**info, "worst_dihedral": q.worst_dihedral, "worst_aspect": q.worst_aspect}
    setattr(mesh, "family_info", info)
    if q.worst_dihedral < QUALITY_FLOOR["dihedral"] or q.worst_aspect > QUALITY_FLOOR["aspect"]:
        warnings.warn(f"m5 family level {info['level']}: smallest dihedral angle {q.worst_dihedral:.2f} deg, "
                      f"largest aspect ratio {q.worst_aspect:.2f}: beyond the family's floor {QUALITY_FLOOR}",
                      VfrsWarning, stacklevel=3)


def _m5_cells(side, resolution, cells, length, grading) -> tuple[int, int, int]:
    """The checked options of :func:`m5` and its cells (along the medial curve, medial to
    lateral, along z)."""
    if side not in ("right", "left"):
        raise MeshError(f"m5: side must be 'right' or 'left', got {side!r}")
    if cells is None:
        if resolution not in RESOLUTIONS:
            raise MeshError(f"m5: unknown resolution {resolution!r}; choose one of {sorted(RESOLUTIONS)} or give cells")
        cells = RESOLUTIONS[resolution]
    ns, nr, nz = (int(c) for c in cells)
    if min(ns, nr, nz) < 2:
        raise MeshError(f"m5: cells must be >= 2 each, got {cells}")
    if not (np.isfinite(length) and length > 0):
        raise MeshError(f"m5: length = {length} must be positive (metres)")
    if not 0 <= grading < 0.9:
        raise MeshError(f"m5: grading = {grading} must lie in [0, 0.9)")
    return ns, nr, nz


def _m5_check_grading(medial_ratio, contact_zone, contact_zone_z, zone_ratio) -> None:
    """The grading options of :func:`m5` (None: unset), checked."""
    def number(v):
        return isinstance(v, (int, float, np.floating)) and not isinstance(v, bool) and math.isfinite(v)

    if medial_ratio is not None and not (number(medial_ratio) and 1.0 <= medial_ratio <= 2.0):
        raise MeshError(f"m5: medial_ratio = {medial_ratio} must lie in [1, 2]")
    if zone_ratio is not None and not (number(zone_ratio) and 1.0 <= zone_ratio <= MAX_ZONE_RATIO):
        raise MeshError(f"m5: zone_ratio = {zone_ratio} must lie in [1, {MAX_ZONE_RATIO}]")
    for name, v in (("contact_zone", contact_zone), ("contact_zone_z", contact_zone_z)):
        if v is not None and not (number(v) and v > 0):
            raise MeshError(f"m5: {name} = {v} must be a positive length (metres)")


def _resample_zone(curve, ns, zone, ratio):
    """ns + 1 points along the curve: equal cells over ``zone`` (a length along the curve)
    centred on the narrowest point (minimum x; a node exactly there), growing by ``ratio``
    outside it (:func:`vfrs.meshes.base.zone_nodes_through`)."""
    seg = np.linalg.norm(np.diff(curve, axis=0), axis=1)
    s = np.r_[0.0, np.cumsum(seg)]
    narrow = np.flatnonzero(curve[:, 0] <= curve[:, 0].min() + 1e-12 * abs(curve[:, 0]).max())
    s_narrow = float(s[narrow[len(narrow) // 2]])
    target = zone_nodes_through(float(s[-1]), s_narrow, zone / 2, ns, ratio)
    return np.column_stack([np.interp(target, s, curve[:, 0]), np.interp(target, s, curve[:, 1])])


def _zone_weight(nodes, zone):
    """Per node of a graded line (positions, or points (n, 2) along the medial curve): the
    finest cell size over the node's own (the mean of the cells on either side), 1 in the
    zone, falling outside it; all 1 without a zone."""
    if zone is None:
        return np.ones(len(nodes))
    nodes = np.asarray(nodes, dtype=float)
    h = np.linalg.norm(np.diff(nodes, axis=0), axis=1) if nodes.ndim == 2 else np.diff(nodes)
    local = np.r_[h[0], (h[:-1] + h[1:]) / 2, h[-1]]
    return np.minimum(1.0, h.min() / local)


def _m5_points(curve, lateral, ns, nr, nz, length, grading, medial_ratio=None, contact_zone=None,
               contact_zone_z=None, zone_ratio=None):
    """The grid's points ((ns+1)(nr+1)(nz+1), 3), right fold, and the coronal profile grid
    ``prof`` ((ns+1, nr+1, 2)) they extrude; graded toward a contact zone, the profile changes
    along z and ``prof`` is the points' grid itself ((ns+1, nr+1, nz+1, 3))."""
    q = ZONE_RATIO if zone_ratio is None else float(zone_ratio)
    if contact_zone is None:
        medial = _resample(curve, ns, grading)  # (ns + 1, 2)
    else:
        medial = _resample_zone(curve, ns, float(contact_zone), q)
    y_lat = np.linspace(medial[0, 1], medial[-1, 1], ns + 1)
    wall = np.column_stack([np.full(ns + 1, lateral), y_lat])
    # Across the fold: geometric spacing, finest at the medial surface.
    ratio = MEDIAL_RATIO if medial_ratio is None else float(medial_ratio)
    w = np.array([ratio**k for k in range(nr)])
    r = np.r_[0.0, np.cumsum(w) / w.sum()]
    prof = medial[:, None, :] * (1 - r)[None, :, None] + wall[:, None, :] * r[None, :, None]  # (ns+1, nr+1, 2)
    if contact_zone_z is None:
        z = np.linspace(0.0, length, nz + 1)
    else:
        z = zone_nodes_through(float(length), length / 2, float(contact_zone_z) / 2, nz, q)
    P = np.empty((ns + 1, nr + 1, nz + 1, 3))
    if contact_zone is not None or contact_zone_z is not None:
        # The thin layers at the medial surface are wanted where contact happens only: the
        # growth across falls from `ratio` in the zone toward 1 (equal layers) as the cells
        # along s and z grow outside it (by the finest size over the local one, on each
        # axis), so a cell far from the zone is not a thin plate under long edges.
        ratio_ik = 1.0 + (ratio - 1.0) * _zone_weight(medial, contact_zone)[:, None] * _zone_weight(z, contact_zone_z)[None, :]
        w = np.ones((ns + 1, nz + 1, nr))
        for j in range(1, nr):  # products, not pow: the same bits on every CPU
            w[:, :, j] = w[:, :, j - 1] * ratio_ik
        r_ik = np.concatenate([np.zeros((ns + 1, nz + 1, 1)), np.cumsum(w, axis=2) / w.sum(axis=2)[..., None]], axis=2)
        r_ijk = r_ik.transpose(0, 2, 1)  # (ns+1, nr+1, nz+1)
        for c in range(2):
            P[..., c] = medial[:, None, None, c] * (1 - r_ijk) + wall[:, None, None, c] * r_ijk
        P[..., 2] = z[None, None, :]
        return P.reshape(-1, 3), P
    P[..., 0] = prof[:, :, None, 0]
    P[..., 1] = prof[:, :, None, 1]
    P[..., 2] = z[None, None, :]
    return P.reshape(-1, 3), prof


def _m5_tets(ns, nr, nz):
    """The grid's tetrahedra (six per hexahedral cell) and each one's cell layer ``j``
    (medial to lateral)."""
    def nid(i, j, k):
        return (i * (nr + 1) + j) * (nz + 1) + k

    i, j, k = (a.ravel() for a in np.meshgrid(np.arange(ns), np.arange(nr), np.arange(nz), indexing="ij"))
    corners = np.stack([nid(i + (c & 1), j + ((c >> 1) & 1), k + ((c >> 2) & 1)) for c in range(8)], axis=1)
    tets = corners[:, KUHN].reshape(-1, 4)
    return tets, np.repeat(j, 6)


def _m5_surfaces(ns, nr, nz) -> dict:
    """The grid's six named boundary faces as triangles (two per quad, not yet oriented)."""
    n_points = (ns + 1) * (nr + 1) * (nz + 1)

    def quads(fixed_axis, value):
        g = np.arange(n_points).reshape(ns + 1, nr + 1, nz + 1)
        idx = [slice(None)] * 3
        idx[fixed_axis] = value
        g = g[tuple(idx)]
        a, b = np.meshgrid(np.arange(g.shape[0] - 1), np.arange(g.shape[1] - 1), indexing="ij")
        a, b = a.ravel(), b.ravel()
        q = np.stack([g[a, b], g[a + 1, b], g[a + 1, b + 1], g[a, b + 1]], axis=1)
        return np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])

    return {
        "inferior": quads(0, 0),
        "superior": quads(0, ns),
        "medial": quads(1, 0),
        "lateral": quads(1, nr),
        "anterior": quads(2, 0),
        "posterior": quads(2, nz),
    }


def family_table(levels=(0, 1, 2, 3), **kw) -> str:
    """The family's levels (``m5(family="systematic", level=k, **kw)``) one line each: cells,
    nodes, tetrahedra, the first layer under the middle of the medial flat, the cells along the
    flat, the arcs' faceting error against its tolerance, the worst dihedral angle and aspect
    ratio against :data:`vfrs.meshes.m5_family.QUALITY_FLOOR`."""
    lines = []
    for k in levels:
        m = m5(kw.pop("side", "right"), family="systematic", level=k, **kw)
        i = getattr(m, "family_info")  # set by _family_quality (not a Mesh field)
        ns, nr, nz = i["cells"]
        P = m.points.reshape(ns + 1, nr + 1, nz + 1, 3)
        lo, hi = i["breaks"][2:4] if len(i["breaks"]) == 6 else (0, ns)
        mid = (lo + hi) // 2
        first = float(np.linalg.norm(P[mid, 1, 0] - P[mid, 0, 0]))
        ok = i["worst_dihedral"] >= QUALITY_FLOOR["dihedral"] and i["worst_aspect"] <= QUALITY_FLOOR["aspect"]
        lines.append(f"level {k}: cells {ns} x {nr} x {nz}, {m.n_points} nodes, {m.n_tets} tets; first layer "
                     f"{first * 1e6:.1f} um, flat cells {(P[hi, 0, 0, 1] - P[lo, 0, 0, 1]) / (hi - lo) * 1e6:.1f} um, "
                     f"z cells {P[0, 0, 1, 2] * 1e6:.0f} um (first); faceting "
                     f"{max(i['facet_error'].values(), default=0.0) * 1e6:.3f} um (tolerance "
                     f"{i['facet_tolerance'] * 1e6:.1f}); worst dihedral {i['worst_dihedral']:.2f} deg, aspect "
                     f"{i['worst_aspect']:.2f} ({'above' if ok else 'BELOW'} the floor {QUALITY_FLOOR})")
    return "\n".join(lines)


def m5_pair(resolution=M5Params.resolution, **kw):
    """Both folds: ``(right, left)``."""
    return m5("right", resolution, **kw), m5("left", resolution, **kw)


# M5Params is defined first (its fields hold every default); m5 is bound to it once defined.
register_generator(m5)(M5Params)
