"""Detection for the ``[contact]`` effect: what a detector is, what it returns, its registry.

A detector finds the contact pairs between the bodies' contact surfaces at given positions.
It is one module in ``vfrs/enforcement/detectors/`` (plus its Rust module, if any) with one
class registered under the scene's ``[contact] detection``::

    @register_detector
    class MyDetector(Detector):
        name = "my_detector"
        Params = ...                      # its keys in [contact] (optional)

        def __init__(self, params, surfaces): ...     # setup: the contact surfaces
        def detect(self, x) -> DetectedPairs: ...     # pairs at positions x (n, 3)

and optionally ``begin_step(x)`` (once per step, at the start-of-step positions),
``intersection_volume(x, found, gap)`` and ``after_step(x, x_prev)`` (warnings). Rigid planes
(``[[obstacles]]``) have their own detector, :class:`PlaneDetector`.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..contact import ContactPairs, node_to_plane, tributary_areas
from ..errors import ContactError, VfrsWarning
from ..registry import Registry
from .base import NoParams

DETECTORS = Registry("contact detector", packages=("vfrs.enforcement.detectors",))
register_detector = DETECTORS.register


@dataclass
class DetectedPairs:
    """Pairs found in one detection round, with what the laws and the record need: the
    per-pair ``weight`` (1/2 between bodies: each contact patch is seen from both sides; 1 on
    planes) and ``offset`` (gap = G x - offset: the plane's position for plane pairs), and the
    positions ``x`` they were found at."""

    pairs: ContactPairs
    weight: np.ndarray
    offset: np.ndarray
    x: np.ndarray
    source: Any = None  # which detector found each pair (index into the effect's list); set in __post_init__

    def __post_init__(self):
        if self.source is None:
            self.source = np.zeros(len(self.pairs), dtype=np.int64)

    def __len__(self) -> int:
        return len(self.pairs)

    @classmethod
    def empty(cls, x) -> "DetectedPairs":
        return cls(ContactPairs.empty(), np.zeros(0), np.zeros(0), x)

    @classmethod
    def concatenate(cls, parts, x) -> "DetectedPairs":
        if not parts:
            return cls.empty(x)
        return cls(ContactPairs.concatenate([p.pairs for p in parts]), np.concatenate([p.weight for p in parts]),
                   np.concatenate([p.offset for p in parts]), x, np.concatenate([p.source for p in parts]))

    def select(self, mask) -> "DetectedPairs":
        return DetectedPairs(self.pairs.select(mask), self.weight[mask], self.offset[mask], self.x, self.source[mask])

    @property
    def tributary(self) -> np.ndarray:
        """The slave's tributary area times the pair weight (m^2): what a penalty in Pa/m acts on."""
        return self.pairs.area * self.weight

    def master_area(self) -> np.ndarray:
        """Area of each pair's master triangle at ``x`` (m^2; 0 for plane pairs)."""
        xm = self.x[np.maximum(self.pairs.master, 0)]
        a = 0.5 * np.linalg.norm(np.cross(xm[:, 1] - xm[:, 0], xm[:, 2] - xm[:, 0]), axis=1)
        return np.where(self.pairs.triangle >= 0, a, 0.0)

    def keys(self) -> list:
        """One key per pair: a surface pair is its slave and master triangle, a plane pair its
        slave and plane normal."""
        return [
            (sl, tr) if tr >= 0 else (sl, tr, tuple(nn))
            for sl, tr, nn in zip(self.pairs.slave.tolist(), self.pairs.triangle.tolist(),
                                  np.round(self.pairs.normal, 9).tolist())
        ]

    def slave_keys(self) -> list:
        """One key per pair that ignores which master triangle: its slave and detector (a
        plane pair: its :meth:`keys`)."""
        return [(sl, int(src)) if k[1] >= 0 else k for sl, src, k in zip(self.pairs.slave.tolist(), self.source, self.keys())]

    def merge(self, new: "DetectedPairs", n_points: int, by_slave: bool = False) -> "DetectedPairs":
        """These pairs (gaps refreshed at ``new.x`` with their frozen geometry) plus those of
        ``new`` not among them; ``by_slave``: not among them means a slave node (of a detector)
        these pairs do not have, whatever its master triangle (a node on the edge of two
        triangles keeps the one it had, rather than flip between them with round-off)."""
        if len(self) == 0:
            return new
        self.pairs.gap = self.pairs.constraint(n_points) @ new.x.ravel() - self.offset
        if (self.pairs.triangle >= 0).all() and (new.pairs.triangle >= 0).all():
            # Surface pairs only (no plane): the same keys as integers, compared in numpy.
            n_src = int(max(self.source.max(initial=0), new.source.max(initial=0))) + 1
            n_tri = int(max(self.pairs.triangle.max(initial=0), new.pairs.triangle.max(initial=0))) + 1

            def ints(d):
                k = d.pairs.slave.astype(np.int64) * n_src + d.source
                return k if by_slave else k * n_tri + d.pairs.triangle

            fresh = ~np.isin(ints(new), ints(self))
        else:
            keys = DetectedPairs.slave_keys if by_slave else DetectedPairs.keys
            old = set(keys(self))
            fresh = np.array([k not in old for k in keys(new)], dtype=bool)
        return DetectedPairs.concatenate([self, new.select(fresh)], new.x)


#: The contact surface a body uses when ``[contact] surface`` does not name one for it (its
#: whole boundary if its mesh has no such surface).
DEFAULT_SURFACE = "medial"


def contact_surface_errors(surface, pairs, surfaces_of: dict) -> list:
    """What is wrong with ``[contact] surface`` / ``pairs`` for bodies whose meshes have the
    surfaces ``surfaces_of`` (body name -> surface names): a list of (key, message), empty if
    nothing. Nothing falls back silently: an empty ``pairs``, a body that does not exist, a
    surface name that no body in contact has (a typo; the default ``"medial"`` may be absent:
    the whole boundary is used then), a body's named surface its mesh lacks."""
    import difflib

    errors = []
    names = list(surfaces_of)

    def near(word, choices):
        m = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
        return f"; did you mean {m[0]!r}?" if m else ""

    if pairs is not None:
        if len(pairs) == 0:
            errors.append(("pairs", "an empty list would turn contact off; remove the [contact] section instead, "
                                    "or list the pairs of bodies that may touch (omit pairs: every pair)"))
        for i, pair in enumerate(pairs):
            for b in pair:
                if b not in surfaces_of:
                    errors.append((f"pairs[{i}]", f"no body named {b!r}{near(b, names)}; bodies are {names}"))
            if len(pair) == 2 and pair[0] == pair[1]:
                errors.append((f"pairs[{i}]", f"[{pair[0]!r}, {pair[1]!r}]: a body with itself (self-contact) is "
                                              "not supported; pair two different bodies"))
    in_contact = sorted({b for q in (pairs or []) for b in q if b in surfaces_of}) if pairs else names
    if isinstance(surface, str):
        if surface != DEFAULT_SURFACE and in_contact and not any(surface in surfaces_of[b] for b in in_contact):
            have = sorted({n for b in in_contact for n in surfaces_of[b]})
            errors.append(("surface", f"no body in contact has a surface {surface!r}{near(surface, have)}; their "
                                      f"surfaces: {have} (or give a table body -> surface)"))
    elif isinstance(surface, dict):
        for b, name in surface.items():
            if b not in surfaces_of:
                errors.append((f"surface.{b}", f"no body named {b!r}{near(b, names)}; bodies are {names}"))
            elif name not in surfaces_of[b]:
                errors.append((f"surface.{b}", f"the mesh of body {b!r} has no surface {name!r}"
                                               f"{near(name, surfaces_of[b])}; it has {sorted(surfaces_of[b])}"))
    return errors


class ContactSurfaces:
    """The contact surfaces of a scene, in global node numbers: what detectors set up from.

    ``surface_of`` (body name -> (k, 3) triangles), ``body_pairs`` (pairs of body names that
    may touch), ``areas`` (tributary area per global node, 0 off the surfaces), ``nodes`` (all
    surface nodes), ``h_surface`` (mean surface edge), ``boundary_edges`` / ``boundary_nodes``
    (the rims of open surfaces), ``points`` (reference coordinates).
    """

    def __init__(self, problem, surface="medial", pairs=None):
        self.points = problem.points
        errors = contact_surface_errors(surface, pairs, {p.name: list(p.mesh.surfaces) for p in problem.bodies})
        if errors:
            raise ContactError("; ".join(f"[contact] {key}: {msg}" for key, msg in errors))
        self.surface_of = {}
        for p in problem.bodies:
            name = surface if isinstance(surface, str) else surface.get(p.name, DEFAULT_SURFACE)
            tri = p.mesh.surfaces.get(name)
            if tri is None:
                tri = p.mesh.boundary_faces()  # only for the default name (checked above)
            self.surface_of[p.name] = tri + p.node_offset
        if pairs is None:
            names = [p.name for p in problem.bodies]
            pairs = [[a, b] for i, a in enumerate(names) for b in names[i + 1:]]
        self.body_pairs = [tuple(p) for p in pairs]
        all_tri = np.concatenate(list(self.surface_of.values()))
        X = self.points
        self.areas = tributary_areas(X, all_tri)
        edges = np.linalg.norm(X[all_tri] - X[np.roll(all_tri, 1, axis=1)], axis=2)
        self.h_surface = float(edges.mean())
        self.nodes = np.unique(all_tri)
        rims = np.sort(all_tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        uniq, counts = np.unique(rims, axis=0, return_counts=True)
        rim = uniq[counts == 1]
        self.boundary_edges = set(map(tuple, rim.tolist()))
        self.boundary_nodes = set(rim.ravel().tolist())
        self.n_points = problem.n_points
        #: Every DOF of the contact surfaces (node-major), the rows a compliance keeps.
        self.dofs = (3 * self.nodes[:, None] + np.arange(3)).ravel()
        # Node adjacency along the surfaces' edges (for :meth:`nearby`).
        e = all_tri[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2)
        n = problem.n_points
        self._adjacency = sp.csr_matrix((np.ones(2 * len(e), dtype=np.int8), (np.r_[e[:, 0], e[:, 1]], np.r_[e[:, 1], e[:, 0]])),
                                        shape=(n, n))

    def nearby(self, dofs, rings: int = 2) -> np.ndarray:
        """Every DOF (all three components) of the surface nodes within ``rings`` surface edges
        of the nodes of ``dofs``, sorted: where contact spreads to from ``dofs`` next."""
        mark = np.zeros(self.n_points, dtype=bool)
        mark[np.asarray(dofs, dtype=np.int64) // 3] = True
        for _ in range(rings):
            mark |= (self._adjacency @ mark.astype(np.int8)) > 0
        nodes = np.flatnonzero(mark)
        return (3 * nodes[:, None] + np.arange(3)).ravel()


class Detector:
    """Base class of a detector between bodies (see the module docstring). ``search``: the
    distance within which it looks (rigid planes use it too)."""

    name = ""
    Params: type = NoParams
    #: Two directions between bodies share each contact patch: each pair carries half.
    pair_weight = 0.5

    def __init__(self, params, surfaces: ContactSurfaces):
        self.params = params
        self.surfaces = surfaces
        self.search = 0.5 * surfaces.h_surface

    def begin_step(self, x) -> None:
        """Once per step, at the start-of-step positions (which contact kept free of overlap)."""

    def detect(self, x) -> DetectedPairs:
        raise NotImplementedError

    def intersection_volume(self, x, found: DetectedPairs, gap) -> float:
        """Overlap volume (m^3) of this detector's pairs at ``x``; default: area x <-g>."""
        return float(np.sum(found.tributary * np.maximum(-gap, 0.0))) if len(gap) else 0.0

    def after_step(self, x, x_prev, t: float) -> None:
        """After each step at time ``t`` (e.g. a warning that a crossing may have been missed)."""

    def _pairs(self, pairs: ContactPairs, x) -> DetectedPairs:
        return DetectedPairs(pairs, np.full(len(pairs), self.pair_weight), np.zeros(len(pairs)), x)


class PlaneDetector(Detector):
    """Nodes of every contact surface against the scene's rigid planes (weight 1)."""

    name = "planes"
    pair_weight = 1.0

    def __init__(self, planes, surfaces: ContactSurfaces, search: float):
        super().__init__(NoParams(), surfaces)
        self.planes = list(planes)
        self.search = search

    def detect(self, x) -> DetectedPairs:
        s = self.surfaces
        parts = []
        for plane in self.planes:
            p = node_to_plane(x, s.nodes, plane.point, plane.normal, self.search, s.areas[s.nodes])
            parts.append(DetectedPairs(p, np.ones(len(p)), np.full(len(p), float(np.dot(plane.normal, plane.point))), x))
        return DetectedPairs.concatenate(parts, x)


def warn_once(flags: dict, key: str, message: str) -> None:
    """A VfrsWarning, the first time only (per run)."""
    if not flags.get(key):
        flags[key] = True
        warnings.warn(message, VfrsWarning, stacklevel=3)
