"""Element quality (vfrs.mesh.quality): dihedral angles and aspect ratios on elements whose
values are known by hand, a sliver flagged; the graded built-in meshes keep a stated floor."""

import math

import numpy as np
import pytest

import vfrs
from vfrs.mesh import POOR_DIHEDRAL, quality

REGULAR = np.array([[1.0, 1, 1], [-1, 1, -1], [1, -1, -1], [-1, -1, 1]])  # positively oriented


def test_regular_tetrahedron_has_70_53_degrees_and_ratio_1():
    q = quality(vfrs.Mesh(REGULAR, [[0, 1, 2, 3]]))
    # arccos(1/3) at all six edges
    np.testing.assert_allclose(q.min_dihedral, math.degrees(math.acos(1 / 3)), rtol=1e-12)
    np.testing.assert_allclose(q.max_dihedral, 70.528779365509308, rtol=1e-12)
    np.testing.assert_allclose(q.aspect, 1.0, rtol=1e-12)
    assert len(q.poor) == 0
    # Orientation, scale and position do not matter.
    q2 = quality((REGULAR * 3e-3 + 5.0, np.array([[0, 2, 1, 3]])))
    np.testing.assert_allclose([q2.worst_dihedral, q2.worst_aspect], [70.528779365509308, 1.0], rtol=1e-12)


def test_kuhn_tetrahedra_of_a_cube():
    # Each Kuhn tetrahedron of the unit cube, e.g. (0,0,0), (1,0,0), (1,1,0), (1,1,1), is a path
    # simplex: three dihedral angles of 90 degrees, two of 45 and one of 60. Its faces are right
    # triangles of areas 1/2, 1/2, sqrt(2)/2, sqrt(2)/2; V = 1/6, so the inradius is
    # 3 V / sum = 1 / (2 (1 + sqrt 2)), the longest edge sqrt 3, and the aspect ratio
    # sqrt 3 * 2 (1 + sqrt 2) / (2 sqrt 6) = 1 + 1/sqrt 2 = 1.7071.
    m = vfrs.meshes.box((2.0, 2.0, 2.0), (2, 2, 2))
    q = m.quality()
    np.testing.assert_allclose(q.min_dihedral, 45.0, rtol=1e-12)
    np.testing.assert_allclose(q.max_dihedral, 90.0, rtol=1e-12)
    np.testing.assert_allclose(q.aspect, 1 + 1 / math.sqrt(2), rtol=1e-12)
    one = quality((m.points, m.tets[:1]))
    x = m.points[m.tets[0]]
    n = [np.cross(x[b] - x[a], x[c] - x[a]) for a, b, c in vfrs.mesh.TET_FACES]
    angles = sorted(180 - math.degrees(math.acos(np.dot(n[f], n[g]) / np.linalg.norm(n[f]) / np.linalg.norm(n[g])))
                    for f in range(4) for g in range(f + 1, 4))
    np.testing.assert_allclose(angles, [45, 45, 60, 90, 90, 90], atol=1e-9)
    assert one.worst_dihedral == pytest.approx(45.0)
    p = q.percentiles()
    assert p["dihedral_min"] == pytest.approx(45.0) and p["aspect_max"] == pytest.approx(1.7071067811865475)
    assert p["poor"] == 0


def test_a_sliver_is_flagged():
    # Four vertices of a square, two lifted by eps: edges all about sqrt 2, volume ~ eps.
    eps = 0.02
    sliver = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, eps], [0, -1, eps]])
    tets = np.array([[0, 1, 2, 3]])
    if vfrs.mesh.signed_volumes(sliver, tets)[0] < 0:
        tets = tets[:, [0, 2, 1, 3]]
    m = vfrs.Mesh(np.vstack([sliver, REGULAR + 5]), np.vstack([tets, [[4, 5, 6, 7]]]))
    q = m.quality()
    assert q.min_dihedral[0] < 2.0 and q.max_dihedral[0] > 175.0 and q.aspect[0] > 20
    assert q.poor.tolist() == [0]
    assert f"1 of 2 elements below {POOR_DIHEDRAL:g} deg" in q.line()
    # A needle: fair angles at the base, a large aspect ratio.
    needle = quality((np.array([[0.0, 0, 0], [1, 0, 0], [0.5, 0.866, 0], [0.5, 0.29, 20]]), np.array([[0, 1, 2, 3]])))
    assert needle.worst_aspect > 10


def test_quality_of_100k_tetrahedra_is_quick():
    import time

    m = vfrs.meshes.box((1.0, 1.0, 1.0), (40, 40, 10))  # 96 000 tetrahedra
    t = time.perf_counter()
    q = m.quality()
    assert time.perf_counter() - t < 2.0  # about 0.1 s measured on 2 shared cores
    assert len(q.aspect) == 96000 and len(q.poor) == 0



def test_run_log_has_one_quality_line_per_body(tmp_path):
    scene = vfrs.Scene.from_dict({
        "bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [2, 2, 2]},
                    "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                    "fixed": [{"axis": "z", "at": 0.0}]}],
        "time": {"mode": "static"}})
    vfrs.run(scene, out=tmp_path / "out", progress=False)
    lines = [ln for ln in (tmp_path / "out" / "run.log").read_text().splitlines() if "quality:" in ln]
    assert len(lines) == 1
    assert ("mesh of body 'block': quality: min dihedral angle 45.0 deg (1 % of elements below 45.0, 5 % below 45.0, "
            "median 45.0), max aspect ratio 1.71 (median 1.71") in lines[0]
    assert lines[0].endswith("0 of 48 elements below 10 deg")
