"""The systematic mesh family of the M5 folds (issue 45, item 1): vfrs.meshes.m5_family.

Every level divides every length by RATIO = 1.5: the first layer under the medial surface and
the equal cells (arcs, flat, a contact zone along z) exactly (to 1e-9), the graded cells to
within GRADED_TOL of the size the coarser level has at the same place; the profile's break
points are nodes on every level; the arcs' faceting error (measured against the true
profile) is below 10 % of the half-gap; the quality keeps the family's floor; and the
meshes without the family are the ones before it existed, bit for bit."""

import hashlib
import math
import warnings

import numpy as np
import pytest

import vfrs
from vfrs.errors import MeshError
from vfrs.meshes import PARAMS, m5
from vfrs.meshes.m5 import m5_profile
from vfrs.meshes.m5_family import FACET_FRACTION, QUALITY_FLOOR, RATIO

#: Graded cells (the straight inferior and superior surfaces, the layers beyond the first, a
#: graded z) against the coarser level's size at the same place (linear between its cells'
#: midpoints): within this relative tolerance of RATIO, from level 0 to 1 and from 1 to 2.
#: Measured: 5.1 % and 1.6 % (the layers next to the first, where the size function has a
#: kink) with the default growths, 6.9 % and 2.1 % with growths of 1.5; a second-order
#: difference (the size function is the same, the cells sample it), falling by ~3 per level.
GRADED_TOL = (0.075, 0.025)
#: The graded variants and other profiles the family is tried with.
VARIANTS = [dict(medial_ratio=1.2), dict(medial_ratio=1.5, zone_ratio=1.5), dict(contact_zone_z=10e-3, zone_ratio=1.2),
            dict(psi=10.0), dict(psi=-10.0), dict(zone_ratio=1.0)]

DEFAULTS = dict(T=3.0e-3, R_O=0.987e-3, R_L=1.5e-3, half_gap=0.05e-3, inferior_height=5.0e-3, superior_height=2.0e-3)


@pytest.fixture(scope="module")
def default_levels():
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no quality warning on any level
        return [m5("right", family="systematic", level=k) for k in range(3)]


def _grid(m):
    ns, nr, nz = m.family_info["cells"]
    return m.points.reshape(ns + 1, nr + 1, nz + 1, 3)


def _digest(m):
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(m.points, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(m.tets, dtype="<i8").tobytes())
    for group in (m.surfaces, m.regions):
        for k in sorted(group):
            h.update(k.encode())
            h.update(np.ascontiguousarray(group[k], dtype="<i8").tobytes())
    return h.hexdigest()[:32]


# Taken with the code before the family existed (48bf868), the same digest function.
BEFORE = [
    (dict(side="right", resolution="coarse"), "8469a10031ef393bdd6b9752fe1ce0b2"),
    (dict(side="left", resolution="coarse"), "e6c467c62bda220b558202794ad53509"),
    (dict(side="right", resolution="medium"), "b7a6712f84429b31199f793cd41bb2fb"),
    (dict(side="left", resolution="medium"), "9f83455a0ed9907b0c20d4a5117af3b8"),
    (dict(side="right", resolution="fine"), "566b61ba792bc92af04c8c69347ebec5"),
    (dict(side="right", cells=(72, 18, 30)), "024fc6d5ad897591e3e9936f5b41c572"),
    (dict(side="right", resolution="medium", medial_ratio=1.2), "7b4daeb35bba1dc05f71215244f084ed"),
    (dict(side="right", resolution="medium", contact_zone=3e-3, contact_zone_z=10e-3, zone_ratio=1.2, medial_ratio=1.2),
     "27bcc84fbd89aea2df104db4ed5b2dc7"),
    (dict(side="left", resolution="coarse", psi=-10.0, grading=0.0), "4e88f420dbaa3163af1ba19214d219b7"),
    (dict(side="right", resolution="coarse", psi=20.0, half_gap=0.0), "9bf8247b14420ba50cd33b9e7db474ac"),
]


@pytest.mark.parametrize("kw,digest", BEFORE)
def test_without_the_family_the_meshes_are_unchanged(kw, digest):
    assert _digest(m5(**kw)) == digest


def test_the_family_keys_are_left_out_of_a_resolved_scene_when_unset():
    d = PARAMS["m5"]().to_dict()
    assert not {"family", "level"} & set(d) and d["resolution"] == "medium"
    p = PARAMS["m5"](family="systematic", level=1)
    d = p.to_dict()
    assert d["family"] == "systematic" and d["level"] == 1 and "resolution" not in d
    assert PARAMS["m5"].from_dict(d) == p
    m = p.build()
    assert p.estimate() == (m.n_points, m.n_tets) == (14365, 72576)


@pytest.mark.parametrize("kw,key", [(dict(level=1), "level"), (dict(family="systematic"), "level"),
                                    (dict(family="systematic", level=4), "level"),
                                    (dict(family="dyadic", level=0), "family"),
                                    (dict(family="systematic", level=0, cells=(4, 4, 4)), "cells"),
                                    (dict(family="systematic", level=0, contact_zone=3e-3), "contact_zone")])
def test_bad_family_options_name_their_key(kw, key):
    with pytest.raises(MeshError, match=key):
        m5("right", **kw)
    with pytest.raises(MeshError, match=key):
        PARAMS["m5"](**kw).check()


def test_counts_grow_by_the_ratio_cubed(default_levels):
    cells = [m.family_info["cells"] for m in default_levels] + [vfrs.meshes.m5_family.family_cells(
        3, length=14e-3, half_gap=50e-6, medial_ratio=None, contact_zone_z=None, zone_ratio=None, T=3e-3, psi=0.0,
        R_O=0.987e-3, exit_angle=40.0, R_L=1.5e-3, inferior_angle=50.0, depth=8e-3, inferior_height=5e-3,
        superior_height=2e-3)]
    assert cells == [(56, 8, 8), (84, 12, 12), (126, 18, 18), (189, 27, 27)]
    assert [m.n_tets for m in default_levels] == [21504, 72576, 244944]


def _first_layers(m):
    """Per medial node at z = 0: the first layer's thickness along its ray to the lateral wall
    and that thickness over the ray's length."""
    P = _grid(m)[:, :, 0, :2]
    t = np.linalg.norm(P[:, 1] - P[:, 0], axis=1)
    return t, t / np.linalg.norm(P[:, -1] - P[:, 0], axis=1)


def test_the_first_layer_shrinks_by_the_ratio_exactly(default_levels):
    first = []
    for m in default_levels:
        t, r1 = _first_layers(m)
        assert np.ptp(r1) < 1e-9 * r1[0]  # one normalized layer along the whole curve
        first.append(t[m.family_info["breaks"]])  # at the break points: the same places on every level
    for coarse, fine in zip(first, first[1:]):
        np.testing.assert_allclose(coarse / fine, RATIO, rtol=1e-9)
    # Mid-flat, along the ray: 327 / 218 / 145 um (the old ladder: 785 / 273 / 77 / 12 um).
    mid_flat = [t[0][(m.family_info["breaks"][2] + m.family_info["breaks"][3]) // 2]
                for t, m in zip([_first_layers(m) for m in default_levels], default_levels)]
    np.testing.assert_allclose(np.array(mid_flat) * 1e6, [327.22, 218.15, 145.43], atol=0.01)


def _sizes(x):
    return (x[:-1] + x[1:]) / 2, np.diff(x)


def _ratio_error(x_coarse, x_fine):
    """The largest |h_coarse(place) / h_fine - RATIO| / RATIO over the fine cells, h_coarse
    linear between the coarse cells' midpoints (and beyond the end ones)."""
    mc, hc = _sizes(np.asarray(x_coarse))
    mf, hf = _sizes(np.asarray(x_fine))
    if len(mc) == 1:
        at = np.full_like(mf, hc[0])
    else:
        at = np.interp(mf, mc, hc)
        lo, hi = mf < mc[0], mf > mc[-1]
        at[lo] = hc[0] + (mf[lo] - mc[0]) * (hc[1] - hc[0]) / (mc[1] - mc[0])
        at[hi] = hc[-1] + (mf[hi] - mc[-1]) * (hc[-1] - hc[-2]) / (mc[-1] - mc[-2])
    return float(np.max(np.abs(at / hf / RATIO - 1)))


def _axes(m):
    """Node positions along every axis of the mesh: each piece of the medial curve (arc
    length along the mesh's polyline at z = 0), the normalized layers across, z."""
    P = _grid(m)
    b = m.family_info["breaks"]
    medial = P[:, 0, 0, :2]
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(medial, axis=0), axis=1))]
    out = {name: s[b[k]:b[k + 1] + 1] - s[b[k]] for k, name in enumerate(m.family_info["pieces"])}
    ray = P[0, :, 0, :2]
    d = np.linalg.norm(ray - ray[0], axis=1)
    out["across"] = d / d[-1]
    out["z"] = P[0, 0, :, 2]
    return out


def _check_ratios(levels):
    """Per pair of consecutive levels: each axis's largest relative deviation from RATIO."""
    pairs = []
    for coarse, fine in zip(levels, levels[1:]):
        a, b = _axes(coarse), _axes(fine)
        assert a.keys() == b.keys()
        for name in a:
            assert len(b[name]) - 1 == (len(a[name]) - 1) * 3 // 2  # exactly RATIO times the cells
        pairs.append({name: _ratio_error(a[name], b[name]) for name in a})
    return pairs


def test_cells_along_every_axis_shrink_by_the_ratio(default_levels):
    pairs = _check_ratios(default_levels)
    for worst in pairs:
        # Equal cells: exactly; the arcs' chords (their length is 2 R sin(angle / 2), not linear
        # in the angle) to the angle's square over 24: 3e-4 on level 0.
        assert max(worst["medial"], worst["z"]) < 1e-12
        assert max(worst["inferior_arc"], worst["exit_arc"]) < 1e-3
    for tol, worst in zip(GRADED_TOL, pairs):
        assert max(worst.values()) < tol, worst
    for name in ("inferior", "superior", "across"):  # second order: at least RATIO**2 less per level
        assert pairs[1][name] < pairs[0][name] / RATIO**2, (name, pairs)


@pytest.mark.parametrize("kw", VARIANTS)
def test_graded_variants_keep_the_ratio_the_break_points_and_the_faceting(kw):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        levels = [m5("right", family="systematic", level=k, **kw) for k in range(2)]
    worst = _check_ratios(levels)[0]
    assert max(worst.values()) < GRADED_TOL[0], worst
    for m in levels:
        assert _facet_error(m, **{k: v for k, v in kw.items() if k == "psi"}) < FACET_FRACTION * 50e-6
        q = m.quality()
        assert q.worst_dihedral > 1.7 and q.worst_aspect < 19.0
        t, r1 = _first_layers(m)
        assert np.ptp(r1) < 1e-9 * r1[0]
    r = [_first_layers(m)[1][0] for m in levels]
    assert r[0] / r[1] == pytest.approx(RATIO, rel=1e-9)


def _break_points(half_gap=DEFAULTS["half_gap"]):
    """The default profile's (psi = 0) six break points in closed form, bottom to top: the
    inferior edge, the inferior arc's tangent points, the flat's top end, the exit arc's end,
    the superior edge."""
    T, R_O, R_L = DEFAULTS["T"], DEFAULTS["R_O"], DEFAULTS["R_L"]
    d_L, d_O = R_L * math.tan(math.radians(20.0)), R_O * math.tan(math.radians(25.0))  # half the turns 40, 50
    c50, s50, c40, s40 = (f(math.radians(a)) for a in (50.0, 40.0) for f in (math.cos, math.sin))
    return np.array([
        [half_gap + DEFAULTS["inferior_height"] * c50 / s50, -T - DEFAULTS["inferior_height"]],
        [half_gap + d_L * c50, -T - d_L * s50],
        [half_gap, -T + d_L],
        [half_gap, -d_O],
        [half_gap + d_O * c40, d_O * s40],
        [half_gap + DEFAULTS["superior_height"] * c40 / s40, DEFAULTS["superior_height"]],
    ])


def test_the_break_points_are_nodes_on_every_level(default_levels):
    points = _break_points()
    for m in default_levels:
        medial = _grid(m)[:, 0, 0, :2]
        d = np.linalg.norm(medial[None, :, :] - points[:, None, :], axis=2)
        assert d.min(axis=1).max() < 1e-12, d.min(axis=1)
        np.testing.assert_allclose(medial[m.family_info["breaks"]], points, atol=1e-12)
    # The old ladder has none of the flat's ends as a node (it would fail this test).
    old = m5("right", "medium").points.reshape(33, 9, 15, 3)[:, 0, 0, :2]
    assert np.linalg.norm(old[None] - points[2:4, None], axis=2).min() > 1e-6


def _facet_error(m, **profile):
    """The largest distance from the true profile (m5_profile, 10 000 points per arc) to the
    mesh's medial polyline at z = 0."""
    curve, _ = m5_profile(**profile, n=40000)
    poly = _grid(m)[:, 0, 0, :2]
    a, b = poly[:-1], poly[1:]
    ab = b - a
    worst = 0.0
    for chunk in np.array_split(curve, 20):
        ap = chunk[:, None, :] - a[None]
        t = np.clip((ap * ab[None]).sum(axis=2) / (ab * ab).sum(axis=1)[None], 0.0, 1.0)
        dist = np.linalg.norm(ap - t[..., None] * ab[None], axis=2).min(axis=1)
        worst = max(worst, float(dist.max()))
    return worst


def test_the_faceting_error_is_below_a_tenth_of_the_half_gap(default_levels):
    errors = [_facet_error(m) for m in default_levels]
    assert max(errors) < FACET_FRACTION * 50e-6
    # 1.47, 0.65, 0.29 um: the square of the ratio per level; the module's own account agrees.
    np.testing.assert_allclose(np.array(errors) * 1e6, [1.468, 0.652, 0.290], atol=2e-3)
    for m, e in zip(default_levels, errors):
        assert max(m.family_info["facet_error"].values()) == pytest.approx(e, rel=1e-3)
    # The old medium mesh: 31 um, more than half the half-gap.
    old = m5("right", "medium")
    old.family_info = {"cells": (32, 8, 14)}
    assert _facet_error(old) > 25e-6


def test_the_quality_floor_holds_on_every_level(default_levels):
    got = []
    for m in default_levels:
        q = m.quality()
        got.append((q.worst_dihedral, q.worst_aspect))
        assert m.family_info["worst_dihedral"] == q.worst_dihedral
    # The same shapes, smaller: 2.59 / 2.59 / 2.58 deg, aspect 12.97 / 13.03 / 13.08.
    np.testing.assert_allclose(got, [(2.59, 12.97), (2.59, 13.03), (2.58, 13.08)], atol=0.01)
    assert min(d for d, _ in got) > QUALITY_FLOOR["dihedral"] and max(a for _, a in got) < QUALITY_FLOOR["aspect"]


def test_both_sides_and_the_surfaces():
    right = m5("right", family="systematic", level=0)
    left = m5("left", family="systematic", level=0)
    np.testing.assert_array_equal(left.points, right.points * [-1.0, 1.0, 1.0])
    assert abs(right.volume - left.volume) < 1e-15 and right.volume > 0
    # The medial surface: a node at x = half_gap along the whole flat, none nearer the mid-plane.
    medial = np.unique(right.surfaces["medial"])
    assert right.points[medial, 0].min() == pytest.approx(50e-6, abs=1e-15)
    assert set(right.surfaces) == {"inferior", "superior", "medial", "lateral", "anterior", "posterior"}
    assert 0 < len(right.regions["cover"]) < right.n_tets


def test_the_family_table_prints_each_level_against_the_floor():
    from vfrs.meshes.m5 import family_table

    lines = family_table(levels=(0, 1)).splitlines()
    assert len(lines) == 2 and all("above the floor" in ln for ln in lines)
    assert lines[0].startswith("level 0: cells 56 x 8 x 8, 4617 nodes, 21504 tets; first layer 327.2 um")
    assert "faceting 1.468 um (tolerance 5.0)" in lines[0] and "worst dihedral 2.59 deg" in lines[1]


#: The graded variants of the default profile (psi = 0, so its break points are _break_points()).
GRADED = [dict(medial_ratio=1.2), dict(medial_ratio=1.5, zone_ratio=1.5), dict(contact_zone_z=10e-3, zone_ratio=1.2)]


@pytest.mark.parametrize("kw", GRADED)
def test_graded_variants_scale_on_every_level(kw):
    """Levels 0, 1 and 2 of each graded variant: the break points are nodes on every level, the
    first layer shrinks by exactly 1.5 per level (at the break points), the other cells by 1.5
    to GRADED_TOL per pair of levels, and a contact zone along z has equal cells exactly 1.5
    times smaller per level; `grading` (unused by the family) changes nothing."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        levels = [m5("right", family="systematic", level=k, **kw) for k in range(3)]
    points = _break_points()
    first = []
    for m in levels:
        medial = _grid(m)[:, 0, 0, :2]
        np.testing.assert_allclose(medial[m.family_info["breaks"]], points, atol=1e-12)
        first.append(_first_layers(m)[0][m.family_info["breaks"]])
    for coarse, fine in zip(first, first[1:]):
        np.testing.assert_allclose(coarse / fine, RATIO, rtol=1e-9)
    for tol, worst in zip(GRADED_TOL, _check_ratios(levels)):
        assert max(worst.values()) < tol, worst
    if "contact_zone_z" in kw:
        zone = []
        for m in levels:
            z = _grid(m)[0, 0, :, 2]
            inside = np.diff(z)[(z[:-1] >= 2e-3 - 1e-12) & (z[1:] <= 12e-3 + 1e-12)]
            assert len(inside) >= 4 and np.ptp(inside) < 1e-12 * inside[0]
            zone.append(inside[0])
        np.testing.assert_allclose(np.array(zone[:-1]) / zone[1:], RATIO, rtol=1e-9)
    assert _digest(m5("right", family="systematic", level=1, grading=0.0, **kw)) == _digest(levels[1])
