"""The geometry of ten-node (P2) tetrahedra and their six-node faces (issue 47): Jacobians at the
quadrature points, volumes, the mid-edge node of each edge, the faces' four flat sub-triangles
and the consistent nodal forces of a pressure on a curved face.

Node order (VTK's ``VTK_QUADRATIC_TETRA``, meshio's ``tetra10``, ``vfrs._core.fem.QuadraticAssembler``):
the vertices 0-3, then the mid-edge nodes of the edges 0-1, 1-2, 0-2, 0-3, 1-3, 2-3. A six-node
face (meshio's ``triangle6``) is ``(a, b, c, ab, bc, ca)``: its vertices, then the mid-edge nodes
of a-b, b-c, c-a.

How an order-2 body is seen downstream. Its named surfaces hold each six-node face as the four
flat triangles through its six nodes (:data:`SUB_TRIANGLES`: the three corner triangles, then the
middle one), all oriented like the face: contact detection, the sensors, the contact area and the
flow's slicing work on these, a piecewise-linear surface through every node (its distance to the
curved face is O(h^2), the order of a P2 surface). Loads are consistent with the quadratic face:
:func:`face_forces` integrates the parent face's six shape functions over the curved face, over
each sub-triangle's part of it, so the four parts sum to the whole face's forces.

>>> import numpy as np
>>> p = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
>>> from vfrs.meshes.quadratic import elevate
>>> p2, t2 = elevate(p, np.array([[0, 1, 2, 3]]))
>>> round(float(volumes(p2, t2)[0]), 12)
0.166666666667
"""

from __future__ import annotations

import numpy as np

from .errors import MeshError

#: The vertices of each mid-edge node 4..9.
EDGES = np.array([[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]])

#: The four flat triangles of a six-node face ``(a, b, c, ab, bc, ca)``, local indices, each
#: oriented like the face: the corners at a, b, c, then the middle triangle.
SUB_TRIANGLES = np.array([[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]])

# The reference positions (r, s) of a six-node face's nodes.
_FACE_NODES = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.5, 0.0], [0.5, 0.5], [0.0, 0.5]])

_A4, _B4 = 0.5854101966249685, 0.1381966011250105
#: The stiffness rule of the P2 element (degree 2, barycentric), as in the Rust core.
RULE_4 = np.array([[_A4, _B4, _B4, _B4], [_B4, _A4, _B4, _B4], [_B4, _B4, _A4, _B4], [_B4, _B4, _B4, _A4]])
_P1, _P2, _C3, _D3 = 0.0927352503108912, 0.3108859192633006, 0.4544962958743504, 0.0455037041256496
_Q1, _Q2 = 1 - 3 * _P1, 1 - 3 * _P2
#: The mass rule of the P2 element (degree 5, fourteen points; weights sum to 1), as in the Rust core.
RULE_14 = np.array([[_Q1, _P1, _P1, _P1], [_P1, _Q1, _P1, _P1], [_P1, _P1, _Q1, _P1], [_P1, _P1, _P1, _Q1],
                    [_Q2, _P2, _P2, _P2], [_P2, _Q2, _P2, _P2], [_P2, _P2, _Q2, _P2], [_P2, _P2, _P2, _Q2],
                    [_C3, _C3, _D3, _D3], [_C3, _D3, _C3, _D3], [_C3, _D3, _D3, _C3], [_D3, _C3, _C3, _D3],
                    [_D3, _C3, _D3, _C3], [_D3, _D3, _C3, _C3]])
RULE_14_WEIGHTS = 0.6 * np.array([0.1224884051939366] * 4 + [0.1878132095300264] * 4 + [0.0709100346284691] * 6)

# Dunavant's seven-point rule on the triangle (degree 5): (r, s) and weights summing to 1.
_a1, _b1 = 0.0597158717897698, 0.4701420641051151
_a2, _b2 = 0.7974269853530873, 0.1012865073234563
_TRI7 = np.array([[1 / 3, 1 / 3], [_b1, _b1], [_a1, _b1], [_b1, _a1], [_b2, _b2], [_a2, _b2], [_b2, _a2]])
_TRI7_W = np.array([0.225] + [0.1323941527885062] * 3 + [0.1259391805448271] * 3)


def tet_gradients(l) -> np.ndarray:
    """The ten shape functions' derivatives d/dxi (10, 3) at the barycentric point ``l``
    (xi = (L1, L2, L3))."""
    dndl = np.zeros((10, 4))
    for i in range(4):
        dndl[i, i] = 4 * l[i] - 1
    for k, (i, j) in enumerate(EDGES):
        dndl[4 + k, i], dndl[4 + k, j] = 4 * l[j], 4 * l[i]
    return dndl[:, 1:] - dndl[:, :1]


def jacobians(points, tets10, rule=RULE_4) -> np.ndarray:
    """det(dx/dxi) (m, q) of every element at every point of ``rule`` (barycentric rows); six
    times the volume density: a straight-sided element has six times its volume at every point."""
    x = np.asarray(points, dtype=float)[np.asarray(tets10)]  # (m, 10, 3)
    dN = np.stack([tet_gradients(l) for l in rule])  # (q, 10, 3)
    J = np.einsum("mad,qak->mqdk", x, dN)
    return np.linalg.det(J)


def volumes(points, tets10) -> np.ndarray:
    """The elements' volumes (m,): det J integrated by the degree-5 rule (det J of a curved P2
    element is a cubic: exact)."""
    return jacobians(points, tets10, RULE_14) @ RULE_14_WEIGHTS / 6.0


def check_jacobians(points, tets10, what: str = "the mesh") -> None:
    """A :class:`MeshError` naming the elements whose Jacobian is not positive at a point of
    the rules the assembly uses (the stiffness's four, the mass's fourteen): a mid-edge node far
    from its edge, or an element inverted."""
    tets10 = np.asarray(tets10)
    if not len(tets10):
        return
    bad = np.zeros(len(tets10), dtype=bool)
    worst = np.full(len(tets10), np.inf)
    for rule in (RULE_4, RULE_14):
        d = jacobians(points, tets10, rule)
        scale = np.abs(d).max(axis=1)
        bad |= ~(d > 1e-12 * scale[:, None]).all(axis=1)
        worst = np.minimum(worst, d.min(axis=1) / np.where(scale > 0, scale, 1.0))
    if bad.any():
        k = np.flatnonzero(bad)
        shown = ", ".join(str(int(e)) for e in k[:5]) + (f", ... ({len(k)} in all)" if len(k) > 5 else "")
        e = int(k[0])
        raise MeshError(f"{what}: {len(k)} ten-node tetrahedra are distorted (the Jacobian is not positive at a "
                        f"quadrature point: a mid-edge node far from its edge, or the element inverted): elements "
                        f"{shown}; element {e} (nodes {tets10[e].tolist()}) reaches {worst[e]:.3g} of its largest "
                        "Jacobian. Move the mid-edge nodes toward their edges' midpoints (in Gmsh: "
                        "Mesh.HighOrderOptimize = 2) or mesh with linear tetrahedra")


def mid_nodes(tets10) -> dict:
    """{(i, j) with i < j: the mid-edge node of the edge i-j}; a :class:`MeshError` when two
    elements give one edge different mid-edge nodes (a non-conforming mesh)."""
    tets10 = np.asarray(tets10, dtype=np.int64)
    ends = np.sort(tets10[:, EDGES], axis=2).reshape(-1, 2)
    mids = tets10[:, 4:].reshape(-1)
    key = np.unique(np.column_stack([ends, mids]), axis=0)
    pair = key[:, :2]
    clash = (pair[1:] == pair[:-1]).all(axis=1)
    if clash.any():
        i, j = (int(v) for v in pair[1:][clash][0])
        raise MeshError(f"the ten-node tetrahedra give the edge {i}-{j} two different mid-edge nodes (a "
                        f"non-conforming mesh: {int(clash.sum())} such edges); every element around an edge "
                        "must share its mid-edge node")
    return {(int(a), int(b)): int(m) for a, b, m in key}


def face6(triangles, lookup: dict) -> np.ndarray:
    """Six-node faces (k, 6) of corner triangles (k, 3), their mid-edge nodes from ``lookup``
    (:func:`mid_nodes`); a :class:`MeshError` for a triangle edge that is no element's edge."""
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    out = np.empty((len(tri), 6), dtype=np.int64)
    out[:, :3] = tri
    for c, (i, j) in enumerate(((0, 1), (1, 2), (2, 0))):
        for r, (a, b) in enumerate(zip(tri[:, i].tolist(), tri[:, j].tolist())):
            m = lookup.get((min(a, b), max(a, b)))
            if m is None:
                raise MeshError(f"surface triangle {tri[r].tolist()}: its edge {a}-{b} is no edge of a ten-node "
                                "tetrahedron (a surface of a quadratic mesh must be made of its elements' faces)")
            out[r, 3 + c] = m
    return out


def subdivide(faces) -> np.ndarray:
    """The four flat triangles (4k, 3) of each six-node face (k, 6), face by face
    (:data:`SUB_TRIANGLES`)."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 6)
    return faces[:, SUB_TRIANGLES].reshape(-1, 3)


def _face_shape(rs):
    """The six-node triangle's shape functions (6,) and their derivatives (6, 2) at (r, s)."""
    r, s = rs
    L = np.array([1 - r - s, r, s])
    dL = np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]])
    N = np.concatenate([L * (2 * L - 1), [4 * L[0] * L[1], 4 * L[1] * L[2], 4 * L[2] * L[0]]])
    dN = np.zeros((6, 2))
    for i in range(3):
        dN[i] = (4 * L[i] - 1) * dL[i]
    for c, (i, j) in enumerate(((0, 1), (1, 2), (2, 0))):
        dN[3 + c] = 4 * (L[i] * dL[j] + L[j] * dL[i])
    return N, dN


def _sub_rules():
    """For each of the four sub-triangles: the shape functions (7, 6), derivatives (7, 6, 2) and
    weights (7,) of the seven-point rule mapped onto its part of the reference face (weights
    summing to 1/8, the part's share of the reference area 1/2)."""
    out = []
    for sub in SUB_TRIANGLES:
        c = _FACE_NODES[sub]
        pts = c[0] + _TRI7[:, :1] * (c[1] - c[0]) + _TRI7[:, 1:] * (c[2] - c[0])
        shapes = [_face_shape(p) for p in pts]
        out.append((np.stack([s[0] for s in shapes]), np.stack([s[1] for s in shapes]), _TRI7_W / 8.0))
    return out


#: For each flat sub-triangle of a six-node face: the face's shape functions (7, 6), their
#: derivatives (7, 6, 2) and the weights (7,) of a degree-5 rule on its part of the reference face.
SUB_RULES = _sub_rules()


def area_vectors(x, rows, dN) -> np.ndarray:
    """The curved faces' normal times area element, (f, q, 3), at the points of a sub-rule
    (``dN``: the shape functions' derivatives (q, 6, 2)) of the faces ``rows`` (f, 6) at the
    positions ``x``: outward, its length the area per unit reference area."""
    xe = x[rows]  # (f, 6, 3)
    dr, ds = np.einsum("fad,qa->fqd", xe, dN[:, :, 0]), np.einsum("fad,qa->fqd", xe, dN[:, :, 1])
    return np.cross(dr, ds)


class QuadraticFaces:
    """Where each flat sub-triangle of a quadratic mesh's boundary sits on its six-node face,
    so that a load given on sub-triangles (a named surface, a selection of boundary triangles)
    is integrated with the face's quadratic shape functions."""

    def __init__(self, faces6):
        self.faces = np.asarray(faces6, dtype=np.int64).reshape(-1, 6)
        sub = subdivide(self.faces)
        self._keys = {tuple(sorted(t)): k for k, t in enumerate(sub.tolist())}

    def locate(self, triangles) -> tuple:
        """(face rows, sub-triangle index 0-3) of each flat triangle; a :class:`MeshError` for one
        that is no sub-triangle of the boundary."""
        face, part = [], []
        for t in np.asarray(triangles, dtype=np.int64).reshape(-1, 3).tolist():
            k = self._keys.get(tuple(sorted(t)))
            if k is None:
                raise MeshError(f"triangle {t} is no part of a six-node face of the quadratic mesh's boundary")
            face.append(k // 4)
            part.append(k % 4)
        return np.asarray(face, dtype=np.int64), np.asarray(part, dtype=np.int64)

    def load(self, triangles) -> "FaceLoad":
        """The load integration on the parts of the curved faces that the flat ``triangles``
        cover, located once (:class:`FaceLoad`)."""
        face, part = self.locate(triangles)
        return FaceLoad([self.faces[face[part == k]] for k in range(4)])

    def forces(self, points, triangles, pressure=None, traction=None) -> np.ndarray:
        """:meth:`FaceLoad.forces` of :meth:`load` ``(triangles)``."""
        return self.load(triangles).forces(points, pressure, traction)


class FaceLoad:
    """Consistent nodal forces on parts of six-node faces: ``rows[k]`` are the faces (f, 6) whose
    sub-triangle k is loaded."""

    def __init__(self, rows):
        self.rows = rows

    def forces(self, points, pressure=None, traction=None) -> np.ndarray:
        """Nodal forces (n, 3) of a pressure (the traction -p n, ``pressure`` per node (n,),
        interpolated by the face's shape functions) or of a constant ``traction`` (3,) per unit
        area, in the configuration ``points`` (the area element and the normal of the curved
        face there: a follower load when ``points`` is the deformed configuration)."""
        x = np.asarray(points, dtype=float)
        f = np.zeros((len(x), 3))
        for rows, (N, dN, w) in zip(self.rows, SUB_RULES):
            if not len(rows):
                continue
            normal = area_vectors(x, rows, dN)  # (f, q, 3): the area element times the outward normal
            if pressure is not None:
                pq = np.asarray(pressure, dtype=float)[rows] @ N.T  # (f, q)
                t = -pq[:, :, None] * normal
            else:
                t = np.linalg.norm(normal, axis=2)[:, :, None] * np.asarray(traction, dtype=float)
            fe = np.einsum("qa,fqd,q->fad", N, t, w)  # (f, 6, 3)
            for d in range(3):
                f[:, d] += np.bincount(rows.ravel(), weights=fe[:, :, d].ravel(), minlength=len(x))
        return f
