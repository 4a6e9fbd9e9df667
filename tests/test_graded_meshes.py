"""Meshes graded toward where contact happens (issue 32, item 4): the M5 fold's contact zone
and medial_ratio, the box's grade_toward. Unset, the meshes are the old ones bit for bit; set,
the elements at the contact zone are smaller at the same cells, neighbouring cells differ by
at most the stated ratio, and the smallest dihedral angle keeps a stated floor."""

import hashlib
import itertools

import numpy as np
import pytest

import vfrs
from vfrs.meshes.base import MAX_GROWTH, zone_nodes, zone_nodes_through
from vfrs.meshes.m5 import RESOLUTIONS, m5

#: The settings docs/running.md recommends for the folds: the zone is the medial surface's
#: thickness T along the curve and 10 of the 14 mm along z.
GRADED = dict(contact_zone=3e-3, contact_zone_z=10e-3, zone_ratio=1.2, medial_ratio=1.2)
#: Floors of the smallest dihedral angle (degrees). The default folds have 6.7 / 6.0 / 2.4 on
#: the coarse / medium / fine cells (thin layers at the medial surface under long cells, thick
#: ones at the lateral wall): GRADED stays above 6 and above the default at every resolution;
#: any zone option (zone >= 1 mm, zone_ratio <= 1.5, medial_ratio <= 1.35, psi 0 or 20) above
#: ANY_FLOOR, no worse than the default fine mesh.
GRADED_FLOOR = 6.0
ANY_FLOOR = 2.3


def _digest(m):
    return hashlib.sha256(m.points.tobytes() + m.tets.tobytes()).hexdigest()[:16]


def test_unset_keys_leave_the_meshes_and_the_resolved_scene_unchanged():
    # The digests of the meshes before the grading keys existed (example histories depend on them).
    assert _digest(m5("right", "coarse")) == "b325e1a1fee95854"
    assert _digest(m5("right", "medium")) == "425279a6de26e31b"
    assert _digest(m5("right", "medium", medial_ratio=1.35)) == "425279a6de26e31b"
    assert _digest(vfrs.meshes.box((2.0, 1.0, 0.5), (4, 3, 2), jitter=0.2, seed=3)) == "6773d202bfd35006"
    p = vfrs.meshes.PARAMS["m5"]()
    assert not {"medial_ratio", "contact_zone", "contact_zone_z", "zone_ratio"} & set(p.to_dict())
    assert not {"grade_toward", "ratio"} & set(vfrs.meshes.PARAMS["box"]().to_dict())


def _cell_sizes_at_contact(m, cells):
    """(along s, along z, across) of the medial cell at the narrowest point and mid-length."""
    ns, nr, nz = cells
    P = m.points.reshape(ns + 1, nr + 1, nz + 1, 3)
    x = P[:, 0, nz // 2, 0]
    cand = np.flatnonzero(x <= x.min() + 1e-12)
    i, k = cand[len(cand) // 2], nz // 2
    return tuple(float(np.linalg.norm(P[i + di, dj, k + dk] - P[i, 0, k])) for di, dj, dk in ((1, 0, 0), (0, 0, 1), (0, 1, 0)))


@pytest.mark.parametrize("res", list(RESOLUTIONS))
def test_at_equal_cells_the_elements_at_the_contact_zone_are_smaller(res):
    cells = RESOLUTIONS[res]
    uniform, graded = m5("right", res), m5("right", res, **GRADED)
    assert graded.n_tets == uniform.n_tets and graded.n_points == uniform.n_points
    hs_u, hz_u, _ = _cell_sizes_at_contact(uniform, cells)
    hs_g, hz_g, _ = _cell_sizes_at_contact(graded, cells)
    assert hs_g < 0.5 * hs_u and hz_g < hz_u
    # The narrowest point is a node: the half-gap is the one asked for.
    assert graded.points[graded.surface_nodes("medial"), 0].min() == pytest.approx(0.05e-3, rel=1e-9)
    # The same fold: volume and medial area within the discretisation's 1 %.
    assert graded.volume == pytest.approx(uniform.volume, rel=1e-2)
    assert (graded.signed_volumes() > 0).all()
    assert len(graded.regions["cover"]) + len(graded.regions["body"]) == graded.n_tets
    assert len(graded.regions["cover"]) > 0 and len(graded.regions["body"]) > 0


@pytest.mark.parametrize("res", list(RESOLUTIONS))
def test_graded_settings_keep_the_quality_floor(res):
    q_u = m5("right", res).quality()
    q_g = m5("right", res, **GRADED).quality()
    assert q_g.worst_dihedral > GRADED_FLOOR
    assert q_g.worst_dihedral > q_u.worst_dihedral and q_g.worst_aspect < q_u.worst_aspect


@pytest.mark.parametrize("res", list(RESOLUTIONS))
def test_any_zone_option_keeps_the_floor(res):
    worst = min(
        m5("right", res, contact_zone=cz, contact_zone_z=czz, zone_ratio=zr, medial_ratio=mr, psi=psi).quality().worst_dihedral
        for cz, czz, zr, mr, psi in itertools.product([1e-3, 6e-3], [None, 6e-3], [1.2, 1.5], [None, 1.0], [0.0, 20.0]))
    assert worst > ANY_FLOOR


@pytest.mark.parametrize("ratio", [1.0, 1.2, 1.5])
def test_zone_nodes_are_equal_in_the_zone_and_grow_by_at_most_the_ratio(ratio):
    x = zone_nodes_through(15.0, 8.0, 1.5, 32, ratio)
    assert len(x) == 33 and x[0] == 0.0 and x[-1] == 15.0 and 8.0 in x
    h = np.diff(x)
    assert (h > 0).all()
    growth = np.maximum(h[1:] / h[:-1], h[:-1] / h[1:])
    assert growth.max() <= max(ratio, 1.0) * 1.1 + 1e-12  # the split at the centre: whole cells each side
    assert h.max() / h.min() <= MAX_GROWTH * 1.1
    zone = (x[:-1] >= 6.5 - 1e-12) & (x[1:] <= 9.5 + 1e-12)
    if ratio > 1:
        assert np.ptp(h[zone]) / h[zone].mean() < 0.1 and h[zone].max() <= h.min() * 1.1
    y = zone_nodes(14.0, 2.0, 12.0, 14, 1.3)
    np.testing.assert_allclose(y, 14.0 - y[::-1], atol=1e-12)  # a centred zone: symmetric
    np.testing.assert_array_equal(zone_nodes(1.0, -1.0, 2.0, 4, 1.3), [0.0, 0.25, 0.5, 0.75, 1.0])


def test_zone_keys_are_read_from_the_scene_and_checked():
    d = {"builtin": "m5", "resolution": "coarse", "contact_zone": 3e-3, "contact_zone_z": 10e-3, "zone_ratio": 1.3,
         "medial_ratio": 1.2}
    p = vfrs.meshes.PARAMS["m5"].from_dict(d)
    p.check()
    assert p.to_dict()["contact_zone"] == 3e-3
    assert _digest(p.build()) == _digest(m5("right", "coarse", contact_zone=3e-3, contact_zone_z=10e-3, zone_ratio=1.3,
                                            medial_ratio=1.2))
    for key, bad in (("zone_ratio", 1.6), ("medial_ratio", 0.9), ("contact_zone", -1e-3)):
        with pytest.raises(vfrs.MeshError, match=key):
            vfrs.meshes.PARAMS["m5"].from_dict({**d, key: bad}).check()
        with pytest.raises(vfrs.MeshError, match=key):
            m5("right", "coarse", **{key: bad})


def _scene(mesh):
    return vfrs.Scene.from_dict({
        "bodies": [{"name": "b", "mesh": mesh, "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
                    "fixed": [{"axis": "z", "at": 0.0}]}],
        "time": {"mode": "static"}})


def test_scene_reads_the_keys_and_names_a_bad_one():
    s = _scene({"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [2, 2, 4], "grade_toward": "zmax", "ratio": 1.5})
    assert s.to_dict()["bodies"][0]["mesh"]["grade_toward"] == "zmax"
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.mesh\.grade_toward"):
        _scene({"builtin": "box", "grade_toward": "top"})
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.mesh\.zone_ratio"):
        _scene({"builtin": "m5", "resolution": "coarse", "zone_ratio": 3.0})


@pytest.mark.parametrize("face", ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"])
def test_box_graded_toward_a_face(face):
    size, cells = (2.0, 1.0, 0.5), (4, 6, 5)
    m = vfrs.meshes.box(size, cells, grade_toward=face, ratio=1.5)
    u = vfrs.meshes.box(size, cells)
    assert m.n_tets == u.n_tets and m.volume == pytest.approx(1.0, rel=1e-12)
    a = "xyz".index(face[0])
    levels = np.unique(m.points[:, a])
    h = np.diff(levels)
    if face.endswith("max"):
        h = h[::-1]
    assert len(h) == cells[a] and levels[0] == 0.0 and levels[-1] == size[a]
    np.testing.assert_allclose(h[1:] / h[:-1], 1.5, rtol=1e-9)  # thinnest at the face, each 1.5x the last
    assert h[0] < size[a] / cells[a]
    # Surfaces still cover the boundary once; the face keeps its area.
    named = np.concatenate(list(m.surfaces.values()))
    assert len(named) == len(m.boundary_faces())
    x = m.points[m.surface(face)]
    area = np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum() / 2
    assert area == pytest.approx(np.prod(size) / size[a], rel=1e-12)
    # Each element is a Kuhn tetrahedron of its rectangular cell: the worst is that of the
    # most elongated layer's cell, alone.
    hc = np.array(size) / cells
    worst = min(vfrs.meshes.box(tuple(np.where(np.arange(3) == a, hk, hc)), (1, 1, 1)).quality().worst_dihedral for hk in h)
    assert m.quality().worst_dihedral == pytest.approx(worst, rel=1e-9)
    with pytest.raises(vfrs.MeshError, match="ratio"):
        vfrs.meshes.box(size, cells, grade_toward=face, ratio=2.5)


def test_the_study_script_prints_its_table(monkeypatch, capsys):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "benchmarks" / "bench_graded_meshes.py"
    spec = importlib.util.spec_from_file_location("bench_graded_meshes", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    monkeypatch.setattr(bench, "CELLS", {"coarse": RESOLUTIONS["coarse"]})
    bench.main(["--set", "zone_ratio=1.3"])
    out = capsys.readouterr().out
    assert "'zone_ratio': 1.3" in out
    rows = [ln for ln in out.splitlines() if ln.startswith("| coarse")]
    assert len(rows) == 2 and "| default | 1134 | 4800 | 0.914 | 1.750 |" in rows[0] and "| graded | 1134 | 4800 |" in rows[1]
