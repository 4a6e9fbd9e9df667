"""Tetrahedral meshes with named surfaces and regions; reading and writing through meshio."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import _core, quadratic
from .errors import MeshError
from .mesh_quality import POOR_DIHEDRAL, MeshQuality, quality  # noqa: F401 (re-exported: vfrs.mesh.quality)

# Faces of a positively oriented tet (a, b, c, d), each ordered so that its normal
# (x2 - x1) x (x3 - x1) points out of the element.
TET_FACES = np.array([[1, 2, 3], [0, 3, 2], [0, 1, 3], [0, 2, 1]])

LENGTH_UNITS = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6}


@dataclass
class Mesh:
    """Tetrahedra, linear or quadratic, with named boundary surfaces and element regions.

    ``points`` (n, 3) in metres; ``tets`` (m, 4) positively oriented, or (m, 10) for ten-node
    (P2) tetrahedra (VTK's node order, see :mod:`vfrs.quadratic`: ``order`` is then 2); ``surfaces``
    maps a name to (k, 3) node triangles ordered so that their normal points out of the body;
    ``regions`` maps a name to element indices. On a quadratic mesh a surface may be given as
    six-node faces (k, 6) or as their corner triangles (k, 3); it is kept as the faces' four flat
    sub-triangles each (:func:`vfrs.quadratic.subdivide`), which is what detection, sensors and
    areas use, while loads integrate the curved faces (:meth:`quadratic_faces`).

    >>> import numpy as np, vfrs
    >>> m = vfrs.Mesh(np.eye(4, 3, k=-1), [[0, 1, 2, 3]])
    >>> round(m.volume, 6)
    0.166667
    """

    points: np.ndarray
    tets: np.ndarray
    surfaces: dict = field(default_factory=dict)
    regions: dict = field(default_factory=dict)
    #: read_mesh: how many negatively oriented tetrahedra it flipped (said in run.log)
    flipped: int = field(default=0, compare=False)
    #: read_mesh(merge_nodes=True): how many duplicate nodes it merged into another (said in run.log)
    merged: int = field(default=0, compare=False)

    def __post_init__(self) -> None:
        self.points = np.ascontiguousarray(self.points, dtype=np.float64)
        tets = np.asarray(self.tets)
        if tets.ndim != 2 or tets.shape[1] not in (4, 10):
            raise MeshError(f"tets must have shape (m, 4) (linear) or (m, 10) (quadratic), got {tets.shape}")
        if not np.issubdtype(tets.dtype, np.integer):
            raise MeshError(f"tets must hold integer node indices, got dtype {tets.dtype}")
        self.tets = np.ascontiguousarray(tets, dtype=np.int64)
        if self.points.ndim != 2 or self.points.shape[1] != 3:
            raise MeshError(f"points must have shape (n, 3), got {self.points.shape}")
        _core.fem.validate_mesh(self.points, np.ascontiguousarray(self.tets[:, :4]))
        self._quadratic: tuple | None = None
        if self.order == 2:
            self._quadratic = (quadratic.mid_nodes(self.tets), None)
            quadratic.check_jacobians(self.points, self.tets)
        n = len(self.points)
        for name, tri in list(self.surfaces.items()):
            tri = np.ascontiguousarray(tri, dtype=np.int64)
            if self._quadratic is not None:
                tri = self._flat_triangles(name, tri)
            tri = tri.reshape(-1, 3)
            if tri.size and (tri.min() < 0 or tri.max() >= n):
                raise MeshError(f"surface {name!r} refers to node {int(tri.max())}, but the mesh has {n} nodes")
            self.surfaces[name] = tri
        for name, el in list(self.regions.items()):
            el = np.ascontiguousarray(el, dtype=np.int64).ravel()
            if el.size and (el.min() < 0 or el.max() >= len(self.tets)):
                raise MeshError(f"region {name!r} refers to element {int(el.max())}, but the mesh has {len(self.tets)}")
            self.regions[name] = el
        self._assembler: Any = None
        # the CSC pattern as numpy index arrays, filled by vfrs.assembly on first use
        self._pattern_arrays: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def order(self) -> int:
        """1 for linear (four-node) tetrahedra, 2 for quadratic (ten-node) ones."""
        return 2 if self.tets.shape[1] == 10 else 1

    def _flat_triangles(self, name: str, tri: np.ndarray) -> np.ndarray:
        """A quadratic mesh's surface as flat sub-triangles: six-node faces and corner
        triangles are subdivided, sub-triangles (holding mid-edge nodes) kept."""
        if tri.size and (tri.min() < 0 or tri.max() >= len(self.points)):
            raise MeshError(f"surface {name!r} refers to node {int(tri.max())}, but the mesh has {len(self.points)} nodes")
        lookup = self._quadratic[0] if self._quadratic is not None else {}
        if tri.ndim == 2 and tri.shape[1] == 6:
            return quadratic.subdivide(tri)
        tri = tri.reshape(-1, 3)
        corner = np.isin(tri, self.tets[:, :4]).all(axis=1)
        if corner.all() and len(tri):
            try:
                return quadratic.subdivide(quadratic.face6(tri, lookup))
            except MeshError as e:
                raise MeshError(f"surface {name!r}: {e}") from None
        return tri

    def mid_edge_nodes(self) -> dict:
        """(order 2) {(i, j) with i < j: the mid-edge node of the vertices' edge i-j}."""
        if self._quadratic is None:
            raise MeshError("mid_edge_nodes: the mesh is linear (order 1)")
        return self._quadratic[0]

    def quadratic_faces(self) -> "quadratic.QuadraticFaces":
        """(order 2) The boundary's six-node faces, to integrate loads on its flat sub-triangles
        with the curved faces' shape functions (:class:`vfrs.quadratic.QuadraticFaces`)."""
        if self._quadratic is None:
            raise MeshError("quadratic_faces: the mesh is linear (order 1)")
        lookup, faces = self._quadratic
        if faces is None:
            faces = quadratic.QuadraticFaces(quadratic.face6(self._boundary_corner_faces(), lookup))
            self._quadratic = (lookup, faces)
        return faces

    @property
    def n_points(self) -> int:
        return len(self.points)

    @property
    def n_tets(self) -> int:
        return len(self.tets)

    @property
    def n_dofs(self) -> int:
        return 3 * len(self.points)

    @property
    def volume(self) -> float:
        return float(self.signed_volumes().sum())

    def signed_volumes(self, points=None) -> np.ndarray:
        """Signed element volumes at ``points`` (default: the reference configuration); of a
        quadratic element its curved volume (:func:`vfrs.quadratic.volumes`)."""
        x = self.points if points is None else points
        return quadratic.volumes(x, self.tets) if self.order == 2 else signed_volumes(x, self.tets)

    def boundary_faces(self) -> np.ndarray:
        """All boundary triangles (faces used by one element), oriented outward; of a quadratic
        mesh the four flat sub-triangles of each six-node face."""
        if self.order == 2:
            return quadratic.subdivide(self.quadratic_faces().faces)
        return self._boundary_corner_faces()

    def _boundary_corner_faces(self) -> np.ndarray:
        """The faces of the elements' vertices used by one element, oriented outward."""
        faces = self.tets[:, :4][:, TET_FACES].reshape(-1, 3)
        key = np.sort(faces, axis=1)
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        return faces[counts[inverse.ravel()] == 1]

    def surface(self, name: str) -> np.ndarray:
        """Triangles of a named surface; the error lists the names that exist."""
        try:
            return self.surfaces[name]
        except KeyError:
            raise MeshError(f"the mesh has no surface {name!r}; it has {sorted(self.surfaces)}") from None

    def surface_nodes(self, name: str) -> np.ndarray:
        return np.unique(self.surface(name))

    def assembler(self) -> Any:
        """The fixed sparse pattern of this mesh (built once, cached): ``vfrs._core.fem.Assembler``,
        or ``QuadraticAssembler`` for ten-node tetrahedra (the same calls)."""
        if self._assembler is None:
            kind = _core.fem.QuadraticAssembler if self.order == 2 else _core.fem.Assembler
            self._assembler = kind(self.n_points, self.tets)
        return self._assembler

    def quality(self) -> "MeshQuality":
        """Element quality: dihedral angles and aspect ratios, see :func:`quality`."""
        return quality(self)

    def refined(self, times: int = 1) -> Mesh:
        """This mesh refined uniformly ``times`` times: see :func:`refine`."""
        return refine(self, times)

    def write(self, path, point_data=None, cell_data=None, compression: str | None = None):
        """Writes the mesh (and optional per-node / per-element fields) with meshio.

        The format follows the extension (``.vtu`` for ParaView, ``.msh``, ``.xdmf``, ...);
        the tetrahedra only (the named surfaces are not written). ``compression`` (``.vtu``
        only): ``"zlib"`` (meshio's default), ``"lzma"`` or ``"none"``. A run's field snapshots
        are written by :class:`vfrs.output.vtu.FieldFileWriter` instead (the same format, the mesh
        encoded once).
        """
        import meshio

        cells = [("tetra10" if self.order == 2 else "tetra", self.tets)]
        cd = {k: [np.asarray(v)] for k, v in (cell_data or {}).items()}
        m = meshio.Mesh(self.points, cells, point_data=dict(point_data or {}), cell_data=cd)
        path = os.fspath(path)
        if compression is not None and path.lower().endswith(".vtu"):
            if compression not in ("zlib", "lzma", "none"):
                raise MeshError(f"compression {compression!r}: choose 'zlib', 'lzma' or 'none'")
            meshio.vtu.write(path, m, binary=True, compression=None if compression == "none" else compression)
        else:
            m.write(path)


def refine(mesh: Mesh, times: int = 1) -> Mesh:
    """Uniform refinement, ``times`` times: every tetrahedron split into eight.

    One new node per edge, at its midpoint, shared by the elements and surface triangles
    around it (numbered after the old nodes, in the order the edges are first met); the
    interior octahedron split along its shortest diagonal. Every named surface triangle
    becomes four (the same midpoints, the same outward normal) and every region takes the
    eight children of its elements; the volume, the surfaces' areas and the regions'
    volumes are kept to round-off, each child has 1/8 of its parent's volume (in Rust:
    ``vfrs._core.fem.refine_tets``). ``times = 0`` returns the mesh itself.

    >>> import numpy as np, vfrs
    >>> m = vfrs.Mesh(np.eye(4, 3, k=-1), [[0, 1, 2, 3]]).refined(2)
    >>> m.n_points, m.n_tets, round(m.volume, 12)
    (35, 64, 0.166666666667)
    """
    if isinstance(times, bool) or not isinstance(times, (int, np.integer)) or times < 0:
        raise MeshError(f"refine: times must be an integer >= 0, got {times!r}")
    if times and mesh.order == 2:
        raise MeshError("refine: the mesh is quadratic (ten-node tetrahedra); refine the linear mesh, then make it "
                        "quadratic (order = 2 in a scene, vfrs.meshes.quadratic.elevate in Python)")
    for _ in range(int(times)):
        names = list(mesh.surfaces)
        tris = [mesh.surfaces[k] for k in names]
        sizes = [len(t) for t in tris]
        all_tri = np.concatenate(tris) if tris else np.zeros((0, 3), dtype=np.int64)
        points, tets, new_tri = _core.fem.refine_tets(mesh.points, mesh.tets, np.ascontiguousarray(all_tri, dtype=np.int64))
        cuts = np.cumsum([4 * n for n in sizes])[:-1]
        surfaces = dict(zip(names, np.split(new_tri, cuts)))
        regions = {k: (8 * el[:, None] + np.arange(8)).ravel() for k, el in mesh.regions.items()}
        mesh = Mesh(points, tets, surfaces=surfaces, regions=regions, flipped=mesh.flipped, merged=mesh.merged)
    return mesh


def signed_volumes(points, tets) -> np.ndarray:
    """Signed volumes det(b - a, c - a, d - a) / 6 of tetrahedra (negative when inverted)."""
    return _core.fem.signed_volumes(
        np.ascontiguousarray(points, dtype=np.float64), np.ascontiguousarray(tets, dtype=np.int64)
    )


def rigid_modes(points) -> np.ndarray:
    """The six rigid-body motions of nodes at ``points`` as the columns of a (3n, 6) array over
    their DOFs (x, y, z per node): translations along x, y, z, then rotations about x, y, z
    through the points' mean."""
    X = np.asarray(points, dtype=float)
    X = X - X.mean(axis=0)
    R = np.zeros((3 * len(X), 6))
    for k in range(3):
        R[k::3, k] = 1.0
    R[1::3, 3], R[2::3, 3] = -X[:, 2], X[:, 1]  # rotation about x: (0, -z, y)
    R[0::3, 4], R[2::3, 4] = X[:, 2], -X[:, 0]  # about y: (z, 0, -x)
    R[0::3, 5], R[1::3, 5] = -X[:, 1], X[:, 0]  # about z: (-y, x, 0)
    return R


def held_rigid_modes(points, held) -> int:
    """How many of the six rigid-body motions of nodes at ``points`` (:func:`rigid_modes`) the
    DOFs ``held`` (a boolean mask over their 3n DOFs) hold: the rank of those rows, 0 to 6."""
    held = np.asarray(held, dtype=bool)
    return int(np.linalg.matrix_rank(rigid_modes(points)[held])) if held.any() else 0


def read_mesh(path, length_unit: str = "m", orient: bool = True, merge_nodes: bool = False) -> Mesh:
    """Reads a tetrahedral mesh with meshio (any format it reads: Gmsh .msh, .vtu, .xdmf ...).

    Gmsh physical groups / meshio cell sets become ``surfaces`` (triangle sets) and
    ``regions`` (tetrahedron sets). Ten-node tetrahedra (``tetra10``, with ``triangle6``
    surfaces) make a quadratic mesh (``order`` 2); a file that mixes them with linear ones is
    refused, and so is a distorted quadratic element (a Jacobian not positive at a quadrature
    point: the elements are named). ``length_unit`` scales the coordinates to metres. With
    ``orient`` (default), negatively oriented tetrahedra are flipped (two vertices swapped),
    since generators differ in convention; flat ones still raise :class:`MeshError`, and so do
    flipped ones that then overlap a neighbour (a tangled mesh: :func:`check_overlaps`). With
    ``merge_nodes``, nodes at one position (within 1e-9 of the mesh size: an unmerged seam)
    become one, in tetrahedra and named triangles alike, and ``Mesh.merged`` says how many
    went; without it they are a :class:`MeshError` (:func:`check_tets`).
    """
    path = os.fspath(path)
    check_mesh_path(path)
    if length_unit not in LENGTH_UNITS:
        raise MeshError(f"unknown length unit {length_unit!r}; choose one of {sorted(LENGTH_UNITS)}")
    m = meshio_read(path)
    points = np.asarray(m.points, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] not in (2, 3) or len(points) == 0:
        raise MeshError(f"{path}: no points of a 3-D mesh (points of shape {points.shape})")
    if points.shape[1] == 2:
        raise MeshError(f"{path}: the mesh is 2-D; vfrs needs 3-D tetrahedra")
    if not np.all(np.isfinite(points)):
        k = int(np.flatnonzero(~np.isfinite(points).all(axis=1))[0])
        raise MeshError(f"{path}: node {k} is at {points[k].tolist()}; every coordinate must be finite")
    points = points * LENGTH_UNITS[length_unit]
    tet_blocks = [i for i, c in enumerate(m.cells) if c.type in ("tetra", "tetra10")]
    if not tet_blocks:
        raise MeshError(f"{path}: no tetrahedra (found cell types {[c.type for c in m.cells]})")
    kinds = sorted({m.cells[i].type for i in tet_blocks})
    if len(kinds) > 1:
        counts = {k: sum(len(m.cells[i].data) for i in tet_blocks if m.cells[i].type == k) for k in kinds}
        raise MeshError(f"{path}: the mesh mixes linear and quadratic tetrahedra ({counts['tetra']} tetra, "
                        f"{counts['tetra10']} tetra10); a body has one order: mesh it all with one (in Gmsh: "
                        "Mesh.ElementOrder = 1 or 2 for every volume)")
    tet_offset = {}
    parts = []
    off = 0
    for i in tet_blocks:
        tet_offset[i] = off
        parts.append(np.asarray(m.cells[i].data, dtype=np.int64))
        off += len(parts[-1])
    tets = np.concatenate(parts)
    node_map = None
    if merge_nodes:
        points, node_map = _merged(points)
        tets = node_map[tets]
    check_tets(path, points, tets)
    flipped = 0
    if orient:
        v = signed_volumes(points, np.ascontiguousarray(tets[:, :4]))
        neg = v < 0
        # swapping vertices 1 and 2 swaps the mid-edge nodes of 0-1 and 0-2, and of 1-3 and 2-3
        tets[neg] = tets[neg][:, [0, 2, 1, 3, 6, 5, 4, 7, 9, 8][:tets.shape[1]]]
        flipped = int(neg.sum())
        check_overlaps(path, tets[:, :4], neg)
    surfaces, regions = {}, {}
    for name, per_block in _cell_sets(m).items():
        tri, el = [], []
        for i, idx in enumerate(per_block):
            if idx is None or len(idx) == 0:
                continue
            block = m.cells[i]
            if block.type in ("triangle", "triangle6"):  # of a six-node face its corners: see Mesh
                t = np.asarray(block.data, dtype=np.int64)[idx][:, :3]
                tri.append(t if node_map is None else node_map[t])
            elif block.type in ("tetra", "tetra10"):
                el.append(tet_offset[i] + np.asarray(idx, dtype=np.int64))
        if tri:
            surfaces[name] = orient_outward(points, tets[:, :4], np.concatenate(tri))
        if el:
            regions[name] = np.concatenate(el)
    merged = 0 if node_map is None else len(node_map) - len(points)
    return Mesh(points, tets, surfaces=surfaces, regions=regions, flipped=flipped, merged=merged)


def _position_keys(points):
    """Integer keys equal for nodes within 1e-9 of the mesh's extent (None: one point)."""
    extent = float(np.ptp(points, axis=0).max()) if len(points) else 0.0
    return np.round(points / (1e-9 * extent)).astype(np.int64) if extent > 0 else None


def _merged(points):
    """(the points with each group of coincident nodes kept once, at its first node; the old
    index -> new index map)."""
    key = _position_keys(points)
    if key is None:
        return points, np.arange(len(points))
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    keep = np.sort(first)  # the first node of each position, in file order
    new_of_group = np.empty(len(first), dtype=np.int64)
    new_of_group[np.argsort(first)] = np.arange(len(first))  # groups numbered in the order of their first node
    return points[keep], new_of_group[inverse.ravel()]


def _listing(idx, n: int = 5) -> str:
    idx = [int(i) for i in idx]
    return ", ".join(map(str, idx[:n])) + (f", ... ({len(idx)} in all)" if len(idx) > n else "")


def check_tets(path, points, tets) -> None:
    """What a mesh file must not hold, each a :class:`MeshError` naming the file and the
    elements or nodes (0-based, as read): a tetrahedron listed twice (it would count its
    stiffness and mass twice), nodes no tetrahedron uses (their rows of K are empty: the
    factorization would fail with a generic 'not positive definite'), and distinct nodes at
    one position used by tetrahedra (an unmerged seam: the parts it separates are not
    connected)."""
    sorted_tets = np.sort(tets[:, :4], axis=1)
    _, first, counts = np.unique(sorted_tets, axis=0, return_index=True, return_counts=True)
    if (counts > 1).any():
        dup = np.flatnonzero(~np.isin(np.arange(len(tets)), first))
        raise MeshError(f"{path}: {len(dup)} tetrahedra repeat another one (the same four vertices): elements "
                        f"{_listing(dup)}; remove the repeats (each would count its stiffness and mass twice)")
    used = np.zeros(len(points), dtype=bool)
    used[tets.ravel()] = True
    if not used.all():
        idle = np.flatnonzero(~used)
        raise MeshError(f"{path}: {len(idle)} nodes belong to no tetrahedron: nodes {_listing(idle)}; remove them "
                        "(in Gmsh: Mesh.SaveAll = 0 and Coherence Mesh) or give the mesh without them")
    key = _position_keys(points)
    if key is not None:
        _, inverse, counts = np.unique(key, axis=0, return_inverse=True, return_counts=True)
        twins = np.flatnonzero(counts[inverse.ravel()] > 1)
        if len(twins):
            k = int(twins[0])
            same = twins[inverse.ravel()[twins] == inverse.ravel()[k]]
            raise MeshError(f"{path}: {len(twins)} nodes share their position with another node (unmerged "
                            f"duplicates, within 1e-9 of the mesh size), e.g. nodes {_listing(same)} at "
                            f"{points[k].tolist()}: the parts they separate are not connected; merge them "
                            "(in Gmsh: Coherence Mesh, or Geometry.Tolerance) before reading, or read the mesh with "
                            "merge_nodes = true (mesh = { path = ..., merge_nodes = true })")


def overlapping(tets) -> np.ndarray:
    """The elements of positively oriented ``tets`` that share an interior face with an element
    on the same side of it (they overlap: both list the face with one orientation, so both
    outward normals point one way), or share a face with two or more others; sorted."""
    faces = tets[:, TET_FACES].reshape(-1, 3)
    key = np.sort(faces, axis=1)
    # The face's orientation: even (1) or odd (0) permutation of its sorted nodes; a cyclic
    # rotation keeps it, so after rotating the smallest node first the two others say it.
    first = np.argmin(faces, axis=1)
    rows = np.arange(len(faces))
    even = (faces[rows, (first + 1) % 3] < faces[rows, (first + 2) % 3]).astype(np.int64)
    order = np.lexsort((even, key[:, 2], key[:, 1], key[:, 0]))
    k, e = key[order], even[order]
    same_face = (k[1:] == k[:-1]).all(axis=1)
    bad = same_face & (e[1:] == e[:-1])  # two neighbours listing the face one way: on one side
    shared = np.zeros(len(faces), dtype=np.int64)  # how many others each face is shared with
    np.add.at(shared, order[1:], same_face)
    np.add.at(shared, order[:-1], same_face)
    bad_faces = np.concatenate([order[1:][bad], order[:-1][bad], np.flatnonzero(shared > 1)])
    return np.unique(bad_faces // 4)


def check_overlaps(path, tets, flipped) -> None:
    """A :class:`MeshError` when the elements of ``tets`` (positively oriented, ``flipped``:
    those that were negative in the file) overlap (:func:`overlapping`): a tangled mesh, e.g.
    a node moved through a face, whose inverted elements flipping would have passed off as
    sound. A file written consistently reversed (every element, or every element of a
    connected part) has none. The message names the overlapping elements of the file's
    minority orientation (the inverted ones), then the neighbours they overlap."""
    bad = overlapping(tets)
    if not len(bad):
        return
    negative = 2 * int(flipped.sum()) <= len(flipped)  # the minority orientation of the file
    minority = flipped if negative else ~flipped
    culprits, others = bad[minority[bad]], bad[~minority[bad]]
    if not len(culprits):
        culprits, others = bad, bad[:0]
    said = (f"{len(culprits)} tetrahedra are oriented {'negatively' if negative else 'positively'} in the file, "
            f"against their neighbours ({int(minority.sum())} of the {len(tets)} are), and overlap them: elements "
            f"{_listing(culprits)}" if len(others) else f"{len(culprits)} tetrahedra overlap a neighbour: elements "
            f"{_listing(culprits)}")
    also = f", overlapping elements {_listing(others)}" if len(others) else ""
    raise MeshError(f"{path}: the mesh is tangled: {said}{also} (an interior face with both its elements on one side; "
                    "flipping them would hide a node moved through a face). Untangle the mesh or remesh it (in "
                    "Gmsh: Mesh > 3D, then Optimize 3D), checking the nodes of these elements (0-based, as read)")


def mesh_extensions() -> list:
    """The file extensions meshio reads (``.msh``, ``.vtu``, ...)."""
    import meshio

    return sorted(meshio.extension_to_filetypes)


def check_mesh_path(path) -> None:
    """A :class:`MeshError` unless ``path`` is an existing file with an extension meshio reads."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise MeshError(f"mesh file {path!r} does not exist")
    if os.path.isdir(path):
        raise MeshError(f"{path!r} is a folder, not a mesh file; give the path of a file (e.g. folds.msh)")
    exts = mesh_extensions()
    low = path.lower()
    if not any(low.endswith(e) for e in exts):
        ext = os.path.splitext(path)[1] or "(none)"
        raise MeshError(f"{path}: unknown mesh file extension {ext}; vfrs reads meshes with meshio, whose "
                        f"formats are known by extension: {' '.join(exts)} (Gmsh: .msh, ParaView: .vtu)")


def meshio_read(path):
    """``meshio.read``, whose failures (it may print and call ``sys.exit`` on a file it cannot
    parse) become a :class:`MeshError` naming the file."""
    import contextlib
    import io

    import meshio

    said = io.StringIO()
    try:
        with contextlib.redirect_stdout(said), contextlib.redirect_stderr(said):
            return meshio.read(path)
    except (SystemExit, Exception) as e:  # meshio.ReadError, parsing errors, sys.exit
        detail = " ".join(said.getvalue().split()) or (f"{type(e).__name__}: {e}" if not isinstance(e, SystemExit) else "")
        raise MeshError(f"{path}: not a mesh file meshio can read ({detail or 'no detail'}); check the file's "
                        "format matches its extension (e.g. a Gmsh .msh written by gmsh -3)") from None


def _cell_sets(m) -> dict:
    """Named cell sets; from gmsh:physical tags when meshio did not fill cell_sets."""
    sets = {k: list(v) for k, v in (m.cell_sets or {}).items() if not k.startswith("gmsh:")}
    if sets or "gmsh:physical" not in m.cell_data:
        return sets
    for name, (tag, _dim) in ((k, v[:2]) for k, v in m.field_data.items()):
        sets[name] = [np.flatnonzero(np.asarray(d) == tag) for d in m.cell_data["gmsh:physical"]]
    return sets


def orient_outward(points, tets, tri):
    """Orders boundary triangles like the face of the element they belong to, whose
    normal points out of it (``TET_FACES``). Triangles that are no element's face are left
    as given."""
    tri = np.asarray(tri, dtype=np.int64).reshape(-1, 3)
    if len(tri) == 0:
        return tri
    faces = tets[:, TET_FACES].reshape(-1, 3)
    n = np.int64(len(points))

    def key(f):
        f = np.sort(f, axis=1)
        return (f[:, 0] * n + f[:, 1]) * n + f[:, 2]

    fk = key(faces)
    order = np.argsort(fk, kind="stable")
    tk = key(tri)
    pos = np.minimum(np.searchsorted(fk[order], tk), len(fk) - 1)
    hit = fk[order][pos] == tk
    out = tri.copy()
    out[hit] = faces[order[pos[hit]]]
    return out
