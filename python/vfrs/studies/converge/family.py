"""The mesh ladder of a converge study on the systematic M5 family (issue 45,
:mod:`vfrs.meshes.m5_family`): which scenes take it (:func:`family_kind`), its rungs
(:func:`family_rungs`: ``bodies[i].mesh.family = "systematic"``, ``level = k``), their nominal size
(:func:`nominal_size`) and the element size of a scene's contact surface
(:func:`contact_surface_size`), which the plan prints for every mesh rung."""

from __future__ import annotations

import math

import numpy as np

from ...meshes.m5_family import MAX_LEVEL, RATIO

#: The family the ladder uses (``bodies[i].mesh.family``).
FAMILY = "systematic"
#: Keys of an m5 mesh the family's rungs leave out: ``resolution`` is unused by the family (its
#: resolved mesh leaves it out), ``contact_zone`` is refused by it (the family grades along the
#: medial curve itself: equal cells on the arcs and the flat, growing on the straight surfaces).
DROPPED = ("resolution", "contact_zone")
#: How much the legacy ladder's first element layer (under the middle of the medial flat, at z =
#: 0) shrinks per level: 806 -> 280 -> 79 um from coarse to medium to fine (2.9x, 3.6x) and on to
#: 12.7 um on the 72 x 18 x 30 "finer" mesh (6.2x); tests/test_converge_family.py measures it.
LEGACY_SHRINK = (2.9, 3.6, 6.2)


def family_kind(data: dict) -> tuple:
    """``(kind, why)`` of a resolved scene: ``kind`` is ``"family"`` when every body is a
    built-in m5 mesh of the family at one level, ``"legacy"`` when every body is a built-in
    m5 mesh set by ``resolution`` (no ``cells``), else None, and ``why`` then says which body
    keeps it from the family (None otherwise)."""
    kinds = set()
    for b, body in enumerate(data["bodies"]):
        mesh = body.get("mesh", {})
        where = f"bodies[{b}].mesh"
        if mesh.get("builtin") != "m5":
            return None, f"{where} is not the built-in m5 mesh"
        if int(mesh.get("refine", 0) or 0):
            return None, f"{where}.refine = {mesh['refine']} (the family's levels are not refined)"
        if mesh.get("family") is not None:
            kinds.add(("family", mesh.get("level")))
        elif mesh.get("cells") is not None:
            return None, f"{where}.cells is set (the family replaces a mesh set by `resolution` or is given by `level`)"
        else:
            kinds.add(("legacy", None))
    if len(kinds) != 1:
        return None, "the bodies' meshes are not all on one family level, or all set by `resolution`"
    return next(iter(kinds))[0], None


def family_rungs(data: dict, levels: int) -> list:
    """The family's rungs for a scene :func:`family_kind` accepts, coarsest first, as ``(name,
    changes, drops)``: ``levels`` consecutive levels, the scene's own in the middle where it
    can be (levels 0 to ``levels - 1`` for a scene set by ``resolution``). Each sets every
    body's ``mesh.family`` and ``mesh.level`` and drops the keys of :data:`DROPPED` the scene
    has."""
    meshes = [b["mesh"] for b in data["bodies"]]
    own = meshes[0].get("level") if meshes[0].get("family") is not None else None
    first = 0 if own is None else min(max(int(own) - (levels - 1) // 2, 0), MAX_LEVEL + 1 - levels)
    drops = tuple(f"bodies[{b}].mesh.{k}" for b, m in enumerate(meshes) for k in DROPPED if k in m)
    return [(f"level {k}", level_changes(len(meshes), k), drops) for k in range(first, first + levels)]


def level_changes(n_bodies: int, level: int) -> dict:
    """The key paths that put every body's mesh on the family's ``level``."""
    out: dict = {}
    for b in range(n_bodies):
        out[f"bodies[{b}].mesh.family"] = FAMILY
        out[f"bodies[{b}].mesh.level"] = level
    return out


def rung_level(rung) -> int | None:
    """The family level a rung sets, None for a rung that is not the family's."""
    if rung.changes.get("bodies[0].mesh.family") != FAMILY:
        return None
    return int(rung.changes["bodies[0].mesh.level"])


def nominal_size(h0: float, level: int) -> float:
    """The family's nominal element size of ``level`` (metres): level 0's representative size
    ``h0`` divided by ``RATIO**level``, so consecutive rungs differ by exactly 1.5."""
    return h0 / RATIO**level


def contact_surface_size(data: dict, meshes: list) -> dict | None:
    """The element size of the scene's contact surface: every edge of the triangles of the
    surface ``[contact] surface`` names on each body in contact (``pairs``; the whole boundary
    of a body whose mesh lacks the default surface), counted once. ``{"surfaces": {body:
    name}, "edges": count, "mean": m, "max": m}`` (metres), None without a ``[contact]``
    section."""
    from ...scene.contact_keys import DEFAULT_SURFACE

    contact = data.get("contact")
    if not contact:
        return None
    names = [b["name"] for b in data["bodies"]]
    pairs = contact.get("pairs")
    in_contact = {n for p in pairs for n in p} if pairs else set(names)
    surface = contact.get("surface", DEFAULT_SURFACE)
    lengths, used = [], {}
    for name, mesh in zip(names, meshes):
        if name not in in_contact:
            continue
        want = surface if isinstance(surface, str) else surface.get(name, DEFAULT_SURFACE)
        tri = mesh.surfaces.get(want)
        used[name] = want if tri is not None else "boundary"
        tri = mesh.boundary_faces() if tri is None else tri
        edges = np.unique(np.sort(tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
        lengths.append(np.linalg.norm(mesh.points[edges[:, 0]] - mesh.points[edges[:, 1]], axis=1))
    if not lengths:
        return None
    all_edges = np.concatenate(lengths)
    return {"surfaces": used, "edges": int(len(all_edges)), "mean": float(all_edges.mean()),
            "max": float(all_edges.max())}


def size_ratio(coarse: float | None, fine: float | None) -> float:
    """coarse / fine, NaN where either is missing or not positive."""
    if coarse is None or fine is None or not (coarse > 0 and fine > 0):
        return math.nan
    return coarse / fine
