"""Declarative node and face selectors: a named surface, or a slab along an axis. No eval.

``{surface = "xmin"}`` (or just ``"xmin"``) selects the nodes of a named mesh surface;
``{axis = "z", below = 0.0}``, ``{axis = "x", above = 1e-3}``, ``{axis = "y", at = 0.0}``
select the nodes whose coordinate is below / above / at a value (inclusive, within ``tol``,
default 1e-6 of the mesh's bounding-box diagonal); ``below`` and ``above`` together select a band.

>>> import vfrs
>>> from vfrs.scene.selectors import select_nodes
>>> mesh = vfrs.meshes.box((1.0, 1.0, 1.0), (2, 2, 2))
>>> len(select_nodes(mesh, {"axis": "z", "at": 0.0})), len(select_nodes(mesh, {"surface": "zmin"}))
(9, 9)
"""

from __future__ import annotations

import numpy as np

AXES = {"x": 0, "y": 1, "z": 2}
SELECTOR_KEYS = ("surface", "axis", "below", "above", "at", "tol")


def read_selector(t) -> dict:
    """Reads the selector keys of a :class:`~vfrs.params.table.Table` into a resolved dict."""
    surface = t.string("surface", None)
    axis = t.string("axis", None, choices=AXES)
    below, above, at = t.number("below", None), t.number("above", None), t.number("at", None)
    tol = t.number("tol", None, positive=True)
    if surface is not None:
        if axis is not None or below is not None or above is not None or at is not None:
            raise t.error("give either `surface` or `axis` with `below`/`above`/`at`, not both")
        return {"surface": surface}
    if axis is None:
        raise t.error("expected a selector: `surface = \"name\"` or `axis = \"x\"|\"y\"|\"z\"` with `below`, `above` or `at`")
    if at is not None and (below is not None or above is not None):
        raise t.error("`at` cannot be combined with `below` or `above`")
    if at is None and below is None and above is None:
        raise t.error(f"axis {axis!r} needs `below`, `above` or `at`", "axis")
    sel = {"axis": axis}
    for k, v in (("below", below), ("above", above), ("at", at), ("tol", tol)):
        if v is not None:
            sel[k] = v
    return sel


def _tol(mesh, sel) -> float:
    if "tol" in sel:
        return sel["tol"]
    return 1e-6 * float(np.linalg.norm(np.ptp(mesh.points, axis=0)))


def node_mask(mesh, sel) -> np.ndarray:
    """Boolean mask over the mesh nodes selected by ``sel``."""
    mask = np.zeros(mesh.n_points, dtype=bool)
    if "surface" in sel:
        mask[mesh.surface_nodes(sel["surface"])] = True
        return mask
    c = mesh.points[:, AXES[sel["axis"]]]
    tol = _tol(mesh, sel)
    mask[:] = True
    if "at" in sel:
        mask &= np.abs(c - sel["at"]) <= tol
    if "below" in sel:
        mask &= c <= sel["below"] + tol
    if "above" in sel:
        mask &= c >= sel["above"] - tol
    return mask


def select_nodes(mesh, sel) -> np.ndarray:
    """Indices of the nodes selected by ``sel``."""
    return np.flatnonzero(node_mask(mesh, sel))


def select_faces(mesh, sel) -> np.ndarray:
    """Outward boundary triangles selected by ``sel``: a named surface, or the boundary faces
    whose three nodes are all selected."""
    if "surface" in sel:
        return mesh.surface(sel["surface"])
    faces = mesh.boundary_faces()
    return faces[node_mask(mesh, sel)[faces].all(axis=1)]


def describe(sel) -> str:
    """A short label: ``xmin`` or ``z<=0``."""
    if "surface" in sel:
        return sel["surface"]
    a = sel["axis"]
    if "at" in sel:
        return f"{a}={sel['at']:g}"
    parts = []
    if "above" in sel:
        parts.append(f"{a}>={sel['above']:g}")
    if "below" in sel:
        parts.append(f"{a}<={sel['below']:g}")
    return ",".join(parts)
