"""What a detection round returns: :class:`DetectedPairs`, the pairs with their weights,
offsets and the positions they were found at."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..contact import ContactPairs


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
    #: quadratic contact surfaces: the pairs were found on transformed mid-edge nodes
    #: (vfrs.enforcement.quadratic_surfaces.MidNodeTransform); :meth:`constraint` maps their rows back
    transform: Any = None

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
                   np.concatenate([p.offset for p in parts]), x, np.concatenate([p.source for p in parts]),
                   next((p.transform for p in parts if p.transform is not None), None))

    def select(self, mask) -> "DetectedPairs":
        return DetectedPairs(self.pairs.select(mask), self.weight[mask], self.offset[mask], self.x, self.source[mask],
                             self.transform)

    def constraint(self, n_points: int):
        """The pairs' constraint matrix G on the DOFs (``G @ x``: the gaps; ``G.T @ lam``: the
        forces), through the transform of quadratic surfaces when there is one."""
        G = self.pairs.constraint(n_points)
        return self.transform.apply(G) if self.transform else G

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
        self.pairs.gap = self.constraint(n_points) @ new.x.ravel() - self.offset
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
