"""A systematic mesh family of the M5 folds (issue 45): ``m5(family="systematic", level=k)``.

Level ``k`` (0 to :data:`MAX_LEVEL`) divides every length of level 0 by ``RATIO**k`` (``RATIO``
= 1.5): along the medial curve, across the fold (the first layer under the medial surface
included) and along z. Each direction is a fixed map ``X(c)`` from a cell count ``c`` in
``[0, n0]`` to a position (level 0's ``n0`` cells, see :class:`Axis`); level k puts its nodes
at ``X(j / RATIO**k)``, ``j = 0 .. n0 RATIO**k``. The level-0 counts are multiples of
``2**MAX_LEVEL``, so every level's counts are whole and exactly ``RATIO**k`` times level 0's
(8, 12, 18, 27 per 8 cells of level 0). Where a map's cells are equal (the arcs, the medial
flat, the layers next to the medial surface, a contact zone along z) they are exactly
``RATIO`` times smaller per level; where they grow (by ``q`` per cell on level 0, ``q**(1 /
RATIO**k)`` on level k) the local size ``h(x) / RATIO**k`` is the same function of position on
every level and the cells follow it to within a few per cent (tests/test_m5_family.py states
the tolerance).

The medial curve is cut at its break points (the ends of the medial flat, the arcs' tangent
points, and the curve's ends at the inferior and superior cuts): each piece gets its own
whole number of cells, so the break points are nodes on every level. The arcs have equal
chords, enough that their faceting error (the largest distance between an arc and its
chords, ``R (1 - cos(angle / 2n))``) is at most :data:`FACET_FRACTION` of the half-gap
(``half_gap``, or :data:`REFERENCE_HALF_GAP` when the folds touch) on level 0, and
``RATIO**2`` times less per level. The straight inferior and superior surfaces are graded:
their cells grow by ``zone_ratio`` (unset: 1.2) away from the arcs. Across, the layers grow
by ``medial_ratio`` (unset: 1.35) from a first layer whose thickness, on level 0, is the
thinnest layer's: the first layer of level k is exactly ``RATIO**-k`` times level 0's.
Along z the cells are equal, or with ``contact_zone_z`` equal over that length around
mid-length and growing by ``zone_ratio`` outside it: the graded variants keep the ratio,
the break points and the faceting rule.

With ``psi != 0`` the narrowest point of the glottis lies inside an arc and is not forced to
a node: the mesh's half-gap then exceeds the asked one by at most the faceting error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import MeshError
from .base import bisect, libm

#: The ratio of every length from one level to the next.
RATIO = 1.5
#: The finest level; level-0 counts are multiples of 2**MAX_LEVEL (:data:`BASE`).
MAX_LEVEL = 3
BASE = 2**MAX_LEVEL
#: The arcs' faceting error on level 0 is at most this fraction of the half-gap.
FACET_FRACTION = 0.1
#: The half-gap the faceting error is compared with when ``half_gap`` is 0 (the M5 default).
REFERENCE_HALF_GAP = 50e-6
#: Level 0's largest cell along the medial curve over the arcs and the flat (metres).
ZONE_CELL = 0.25e-3
#: Level 0's largest cell along z (metres) without a contact zone along z.
Z_CELL = 1.75e-3
#: Level 0's layers from the medial surface to the lateral wall.
ACROSS_CELLS = 8
#: The growths unless ``medial_ratio`` / ``zone_ratio`` say otherwise (vfrs.meshes.m5's).
MEDIAL_GROWTH, ZONE_GROWTH = 1.35, 1.2
#: The quality floor (the smallest dihedral angle in degrees, the largest aspect ratio) below
#: which a level warns. The family's quality does not fall with the level (the same shapes,
#: smaller): 2.57-2.59 deg and 13.0-13.1 on levels 0 to 3 of the default folds, at least 1.7 deg and at
#: most 19 with the options tests/test_m5_family.py tries. Its worst elements are long along
#: z (1.75 mm on level 0, against 0.11-0.25 mm along the curve at the arcs and the flat),
#: where the rays to the lateral wall meet the curve obliquely (the inferior arc). The lever
#: is z: 16 level-0 cells along z (Z_CELL 0.875 mm) give 3.9 deg and 7.7 (median 11.6 deg
#: against 7.9) at twice the elements; levels 0-3 have 21 504 / 72 576 / 244 944 / 826 686
#: tetrahedra as they are (today's medium, fine and finer cost about the first three).
QUALITY_FLOOR = {"dihedral": 1.5, "aspect": 20.0}
FAMILIES = ("systematic",)


def level_count(n0: int, level: int) -> int:
    """Level ``level``'s cells for ``n0`` on level 0: ``n0 RATIO**level``, whole."""
    return n0 * 3**level // 2**level


@dataclass(frozen=True)
class Axis:
    """A graded 1-D line ``[0, length]`` of ``n0`` cells on level 0: size ``h0`` over the zone
    ``[a, b]``, ``h0 + g d`` at a distance ``d`` outside it (``g = ln q``: neighbouring cells
    differ by ``q``). The count of cells up to ``x`` is the integral of 1 / size; its inverse
    ``X(c)`` places the nodes, ``X(j / RATIO**k)`` on level k."""

    length: float
    n0: int
    h0: float
    g: float
    a: float
    b: float
    scale: float  # the solved count over n0 (1 to round-off): exactly n0 cells

    @classmethod
    def make(cls, length: float, n0: int, growth: float = 1.0, zone=None) -> "Axis":
        """``n0`` cells growing by ``growth`` away from ``zone`` (a tuple ``(a, b)``), the
        finest size what fills the length; equal cells without a zone or growth."""
        g = math.log(growth) if growth > 1.0 else 0.0
        if zone is None or g == 0.0:
            return cls(length, n0, length / n0, 0.0, 0.0, length, 1.0)
        a, b = max(0.0, zone[0]), min(length, zone[1])
        h0 = bisect(lambda h: _total(length, h, g, a, b) - n0 > 0, length / n0 * 1e-9, length / n0, 400)
        return cls(length, n0, h0, g, a, b, _total(length, h0, g, a, b) / n0)

    @classmethod
    def from_end(cls, length: float, n0: int, h0: float, end: str) -> "Axis":
        """``n0`` cells, the first at the ``end`` ("first": x = 0, "last": x = length) of size
        ``h0``, the others growing away from it by what fills the length (equal cells of
        length / n0 when those are at most h0)."""
        if length / n0 <= h0 * (1 + 1e-12):
            return cls(length, n0, length / n0, 0.0, 0.0, length, 1.0)
        a, b = (0.0, h0) if end == "first" else (length - h0, length)
        rest = length - h0
        # 1 + ln(1 + g rest / h0) / g falls from 1 + rest / h0 (> n0) as g grows.
        g = bisect(lambda g: _side(rest, h0, g) - (n0 - 1) > 0, 1e-12, 10.0, 400)
        return cls(length, n0, h0, g, a, b, _total(length, h0, g, a, b) / n0)

    def nodes(self, level: int) -> np.ndarray:
        """Level ``level``'s node positions (``n0 RATIO**level + 1``; the ends exact)."""
        n = level_count(self.n0, level)
        c_left = _side(self.a, self.h0, self.g)
        c_zone = (self.b - self.a) / self.h0
        out = []
        for j in range(n + 1):
            c = j * 2**level / 3**level * self.scale
            if c <= c_left:
                out.append(self.a - _side_inverse(c_left - c, self.h0, self.g))
            elif c <= c_left + c_zone:
                out.append(self.a + (c - c_left) * self.h0)
            else:
                out.append(self.b + _side_inverse(c - c_left - c_zone, self.h0, self.g))
        x = np.clip(np.array(out), 0.0, self.length)
        x[0], x[-1] = 0.0, self.length
        return x


def _side(d, h0, g):
    """Cells over a distance ``d`` from a zone's edge (size h0 + g x)."""
    return d / h0 if g == 0.0 else math.log1p(g * d / h0) / g


def _side_inverse(t, h0, g):
    return t * h0 if g == 0.0 else h0 / g * math.expm1(g * t)


def _total(length, h0, g, a, b):
    return _side(a, h0, g) + (b - a) / h0 + _side(length - b, h0, g)


@dataclass(frozen=True)
class Piece:
    """A straight piece or an arc of the medial curve, from ``start`` to ``end`` (x, y)."""

    name: str
    start: tuple
    end: tuple
    centre: tuple | None = None
    radius: float = 0.0
    angle: float = 0.0  # the polar angle of start about the centre
    turn: float = 0.0  # the signed angle swept

    @property
    def length(self) -> float:
        if self.centre is None:
            return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])
        return self.radius * abs(self.turn)

    def at(self, t) -> np.ndarray:
        """Points at the fractions ``t`` of the length (0: start, 1: end, exactly)."""
        t = np.asarray(t, dtype=float)
        if self.centre is None:
            p = (1 - t)[:, None] * np.array(self.start) + t[:, None] * np.array(self.end)
        else:
            ang = self.angle + self.turn * t
            p = np.array(self.centre) + self.radius * np.column_stack([libm(math.cos, ang), libm(math.sin, ang)])
        p[t == 0.0], p[t == 1.0] = self.start, self.end
        return p

    def min_x(self) -> float:
        """The smallest x on the piece."""
        x = min(self.start[0], self.end[0])
        if self.centre is not None:  # the arc's leftmost point, angle pi (mod 2 pi), if it is swept
            lo, hi = sorted((self.angle, self.angle + self.turn))
            if math.floor((hi - math.pi) / (2 * math.pi)) >= math.ceil((lo - math.pi) / (2 * math.pi)):
                x = min(x, self.centre[0] - self.radius)
        return x

    def shifted(self, dx: float) -> "Piece":
        def move(p):
            return None if p is None else (p[0] + dx, p[1])

        return Piece(self.name, move(self.start), move(self.end), move(self.centre), self.radius, self.angle, self.turn)


def fillet_geometry(corner, t_in, t_out, radius):
    """The arc of ``radius`` tangent to the line arriving at ``corner`` along ``t_in`` and the
    line leaving it along ``t_out``: ``(turn, sign, centre, start)`` (the angle it turns, +1
    anticlockwise, its centre, the polar angle of its first tangent point), None without a
    turn."""
    cos_turn = min(max(float(t_in[0] * t_out[0] + t_in[1] * t_out[1]), -1.0), 1.0)
    turn = math.acos(cos_turn)
    if turn < 1e-9:
        return None
    d = radius * math.tan(turn / 2)
    a = corner - d * t_in
    # Centre on the inner side of the turn.
    sign = np.sign(t_in[0] * t_out[1] - t_in[1] * t_out[0])
    normal = sign * np.array([-t_in[1], t_in[0]])
    centre = a + radius * normal
    return turn, sign, centre, math.atan2(a[1] - centre[1], a[0] - centre[0])


def _arc(name, corner, t_in, t_out, radius):
    """The arc of :func:`vfrs.meshes.m5._fillet` as a :class:`Piece` (None: no turn), with
    the same end points to the bit."""
    arc = fillet_geometry(corner, t_in, t_out, radius)
    if arc is None:
        return None
    turn, sign, centre, start = arc
    ends = start + sign * np.array([0.0, turn])
    p = centre + radius * np.column_stack([libm(math.cos, ends), libm(math.sin, ends)])
    return Piece(name, tuple(p[0]), tuple(p[1]), tuple(centre), float(radius), float(start), float(sign * turn))


def profile_frame(T, psi, exit_angle, inferior_angle, half_gap):
    """The M5 profile's directions and corners (:func:`vfrs.meshes.m5.m5_profile`): the
    medial surface's direction upwards ``t_m`` (x decreases with y when convergent), the
    superior ``t_s`` (lateral and up) and inferior ``t_i`` (medial and up) directions, and the
    medial surface's ``top`` and ``bottom`` corners (the narrowest point is the top if
    convergent, the bottom if divergent)."""
    half = np.radians(psi) / 2
    t_m = np.array([-math.sin(half), math.cos(half)])
    if psi >= 0:
        top = np.array([half_gap, 0.0])
        bottom = top - T * t_m
    else:
        bottom = np.array([half_gap, 0.0])
        top = bottom + T * t_m
    ea, ia = np.radians(exit_angle), np.radians(inferior_angle)
    t_s = np.array([math.cos(ea), math.sin(ea)])
    t_i = np.array([-math.cos(ia), math.sin(ia)])
    return t_m, t_s, t_i, top, bottom


def profile_pieces(T, psi, R_O, exit_angle, R_L, inferior_angle, half_gap, depth, inferior_height,
                   superior_height):
    """The medial curve of :func:`vfrs.meshes.m5.m5_profile` (checked there) as exact pieces,
    bottom to top: ``inferior``, ``inferior_arc``, ``medial`` (the flat), ``exit_arc``,
    ``superior`` (an arc without a turn is left out); and the lateral wall's x, the inferior
    and superior cuts' y. The curve is shifted so that its narrowest point is at half_gap."""
    t_m, t_s, t_i, top, bottom = profile_frame(T, psi, exit_angle, inferior_angle, half_gap)
    exit_arc = _arc("exit_arc", top, t_m, t_s, R_O)
    inf_arc = _arc("inferior_arc", bottom, t_i, t_m, R_L)
    y_top, y_bot = top[1] + superior_height, bottom[1] - inferior_height
    p_sup = np.array(exit_arc.end) if exit_arc else top
    p_top = np.array(exit_arc.start) if exit_arc else top
    p_inf = np.array(inf_arc.start) if inf_arc else bottom
    p_bot = np.array(inf_arc.end) if inf_arc else bottom
    sup_end = p_sup + t_s * (y_top - p_sup[1]) / t_s[1]
    inf_start = p_inf - t_i * (p_inf[1] - y_bot) / t_i[1]
    pieces = [Piece("inferior", tuple(inf_start), tuple(p_inf)), inf_arc, Piece("medial", tuple(p_bot), tuple(p_top)),
              exit_arc, Piece("superior", tuple(p_sup), tuple(sup_end))]
    pieces = [p for p in pieces if p is not None and p.length > 0]
    dx = half_gap - min(p.min_x() for p in pieces)
    return [p.shifted(dx) for p in pieces], half_gap + depth, float(y_bot), float(y_top)


def facet_tolerance(half_gap: float) -> float:
    """The largest faceting error level 0 allows (metres)."""
    return FACET_FRACTION * (half_gap if half_gap > 0 else REFERENCE_HALF_GAP)


def _piece_axes(pieces, half_gap, growth):
    """Each piece's :class:`Axis` along its length: equal cells on the arcs (enough chords for
    the faceting rule, none longer than ZONE_CELL) and the flat; the straight surfaces grow by
    ``growth`` away from the flat-and-arcs zone, starting at their neighbour's cell size."""
    tol = facet_tolerance(half_gap)

    def whole(need):
        return BASE * max(1, math.ceil(need / BASE - 1e-9))

    n0 = {}
    for p in pieces:
        if p.name in ("inferior", "superior"):
            continue
        need = p.length / ZONE_CELL
        if p.centre is not None:
            need = max(need, abs(p.turn) / (2 * math.acos(1 - tol / p.radius)))
        n0[p.name] = whole(need)
    axes = {}
    for k, p in enumerate(pieces):
        if p.name not in ("inferior", "superior"):
            axes[p.name] = Axis.make(p.length, n0[p.name])
            continue
        nb = pieces[k + 1] if p.name == "inferior" else pieces[k - 1]
        h = min(nb.length / n0[nb.name] if nb.name in n0 else ZONE_CELL, p.length)
        g = math.log(growth) if growth > 1.0 else 0.0
        need = 1.0 + _side(max(p.length - h, 0.0), h, g)
        axes[p.name] = Axis.from_end(p.length, whole(need), h, "last" if p.name == "inferior" else "first")
    return axes


def family_axes(length, half_gap, medial_ratio, contact_zone_z, zone_ratio, **profile):
    """The family's pieces and its maps: ``(pieces, axes along the curve by piece name, the
    across axis (normalized, 0 at the medial surface), the z axis, lateral, y_bot, y_top)``."""
    pieces, lateral, y_bot, y_top = profile_pieces(half_gap=half_gap, **profile)
    q_s = ZONE_GROWTH if zone_ratio is None else float(zone_ratio)
    q_r = MEDIAL_GROWTH if medial_ratio is None else float(medial_ratio)
    axes = _piece_axes(pieces, half_gap, q_s)
    g_r = math.log(q_r) if q_r > 1.0 else 0.0
    h_r = bisect(lambda h: 1.0 + _side(1.0 - h, h, g_r) - ACROSS_CELLS > 0, 1e-9, 1.0 / ACROSS_CELLS, 400)
    across = Axis.from_end(1.0, ACROSS_CELLS, h_r, "first")
    nz0 = BASE * max(1, math.ceil(length / Z_CELL / BASE - 1e-9))
    if contact_zone_z is None:
        z = Axis.make(float(length), nz0)
    else:
        zone = (length / 2 - contact_zone_z / 2, length / 2 + contact_zone_z / 2)
        z = Axis.make(float(length), nz0, q_s, zone)
    return pieces, axes, across, z, lateral, y_bot, y_top


def family_cells(level, **kw) -> tuple:
    """(along the medial curve, across, along z) cells of ``level``; ``kw`` as
    :func:`family_axes`."""
    pieces, axes, across, z, *_ = family_axes(**kw)
    return (sum(level_count(a.n0, level) for a in axes.values()), level_count(across.n0, level), level_count(z.n0, level))


def _family_lines(level, length, half_gap, medial_ratio, contact_zone_z, zone_ratio, midpoints=False, **profile):
    """The grid's lines of ``level``: the medial curve's nodes (n, 2), their points on the
    lateral wall (n, 2), the across and z nodes, the pieces, their axes and the info of
    :func:`family_grid`. With ``midpoints``, each line has a node between every two: on the
    medial curve the piece's own point half-way along its length between them (on the arc,
    not the chord), elsewhere the mean of the two (the wall, the across and z lines are
    straight or linear in their parameter)."""
    pieces, axes, across, z_axis, lateral, y_bot, y_top = family_axes(
        length, half_gap, medial_ratio, contact_zone_z, zone_ratio, **profile)
    curve, s, breaks, facet = [], [], [0], {}
    s0 = 0.0
    for k, p in enumerate(pieces):
        x = axes[p.name].nodes(level)
        pts = p.at(x / p.length)
        if midpoints:
            mid = p.at(0.5 * (x[:-1] + x[1:]) / p.length)
            both = np.empty((2 * len(x) - 1, 2))
            both[0::2], both[1::2] = pts, mid
            pts = both
        if p.centre is not None:
            n = len(x) - 1
            facet[p.name] = p.radius * (1 - math.cos(abs(p.turn) / (2 * n)))
        curve.append(pts if k == 0 else pts[1:])
        s.append((s0 + x) if k == 0 else (s0 + x)[1:])
        s0 += p.length
        breaks.append(breaks[-1] + len(x) - 1)
    medial, s = np.concatenate(curve), np.concatenate(s)
    # Each medial node's point on the lateral wall, equally spaced by its level-0 cell count
    # along the curve (a fixed function of its place: the same on every level; spacing the
    # wall by arc length instead makes thin slabs under the fine arc cells: 2.2 deg).
    count = np.arange(len(s)) * 2**level / 3**level
    wall = np.column_stack([np.full(len(s), lateral), y_bot + (y_top - y_bot) * (count / count[-1])])
    r = across.nodes(level)
    z = z_axis.nodes(level)
    info = {"level": level, "ratio": RATIO, "cells": (len(s) - 1, len(r) - 1, len(z) - 1),
            "pieces": {p.name: level_count(axes[p.name].n0, level) for p in pieces}, "breaks": breaks,
            "facet_error": facet, "facet_tolerance": facet_tolerance(half_gap), "first_layer": float(r[1]),
            "half_gap": half_gap}
    if midpoints:
        wall, r, z = (_with_means(a) for a in (wall, r, z))
    return medial, wall, r, z, info


def _with_means(a):
    """``a`` (n, ...) with the mean of every two neighbours between them (2 n - 1, ...)."""
    a = np.asarray(a, dtype=float)
    out = np.empty((2 * len(a) - 1,) + a.shape[1:])
    out[0::2], out[1::2] = a, 0.5 * (a[:-1] + a[1:])
    return out


def _grid(medial, wall, r, z):
    P = np.empty((len(medial), len(r), len(z), 3))
    for c in range(2):
        P[..., c] = (medial[:, None, c] * (1 - r)[None, :] + wall[:, None, c] * r[None, :])[:, :, None]
    P[..., 2] = z[None, None, :]
    return P


def family_grid(level, length, half_gap, medial_ratio, contact_zone_z, zone_ratio, **profile):
    """The right fold's grid points ``(ns+1, nr+1, nz+1, 3)`` of ``level`` and what it is made
    of (a dict: the cells, each piece's cells, the break points' indices along the curve, the
    arcs' faceting error, the tolerance, the first layer's normalized thickness)."""
    medial, wall, r, z, info = _family_lines(level, length, half_gap, medial_ratio, contact_zone_z, zone_ratio,
                                             **profile)
    return _grid(medial, wall, r, z), info


def family_grid_midpoints(level, length, half_gap, medial_ratio, contact_zone_z, zone_ratio, **profile):
    """The grid of :func:`family_grid` with a node between every two neighbours along each
    line, ``(2 ns + 1, 2 nr + 1, 2 nz + 1, 3)``: its even entries are :func:`family_grid`'s
    points, bit for bit; an entry odd along the medial curve lies on the curve's own piece
    (the true arc); the quadratic tetrahedra's mid-edge nodes are its entries half-way between
    their edges' vertices (:func:`vfrs.meshes.quadratic.m5_quadratic`)."""
    medial, wall, r, z, _ = _family_lines(level, length, half_gap, medial_ratio, contact_zone_z, zone_ratio,
                                          midpoints=True, **profile)
    return _grid(medial, wall, r, z)
