"""Quadratic (ten-node) meshes as bodies (issue 47, items 2-3): reading Gmsh's ``tetra10`` in its
own node order, distorted and mixed-order meshes refused with the elements named, the built-in
generators at order 2 with the mid-edge nodes on the true geometry, the consistent loads of a
pressure on curved six-node faces, ``[[bodies]] order = 2`` through a static run against beam
theory, and the VTU output as quadratic cells."""

from __future__ import annotations

import numpy as np
import pytest

import vfrs
from vfrs import quadratic
from vfrs.errors import MeshError, SceneError
from vfrs.meshes.quadratic import EDGES, elevate, quadratic_mesh

# One tetrahedron in Gmsh's 2.2 ASCII format, its ten nodes in Gmsh's order (vertices, then the
# edges 0-1, 1-2, 2-0, 3-0, 3-2, 3-1: the last two swapped against VTK's 1-3, 2-3), each
# mid-edge node off its edge's midpoint by a distinct amount so that a mix-up shows, and its
# four faces as six-node triangles in a physical group "skin".
_VERTS = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
_GMSH_EDGES = [(0, 1), (1, 2), (2, 0), (3, 0), (3, 2), (3, 1)]


def _gmsh_file(path, orient=1):
    verts = _VERTS if orient > 0 else _VERTS[[0, 2, 1, 3]]
    mids = [0.5 * (verts[a] + verts[b]) + 0.01 * (k + 1) * np.array([1.0, 1.0, 1.0]) / np.sqrt(3)
            for k, (a, b) in enumerate(_GMSH_EDGES)]
    pts = np.vstack([verts, mids])
    lines = ["$MeshFormat", "2.2 0 8", "$EndMeshFormat", "$PhysicalNames", "2", '2 1 "skin"', '3 2 "all"',
             "$EndPhysicalNames", "$Nodes", str(len(pts))]
    lines += [f"{i + 1} {float(x)!r} {float(y)!r} {float(z)!r}" for i, (x, y, z) in enumerate(pts)]
    lines += ["$EndNodes", "$Elements", "5", "1 11 2 2 1 " + " ".join(str(i + 1) for i in range(10))]
    # the faces' corners and their Gmsh mid-edge nodes (1-based)
    mid = {frozenset(e): 5 + k for k, e in enumerate(_GMSH_EDGES)}
    for k, (a, b, c) in enumerate([(1, 2, 3), (0, 3, 2), (0, 1, 3), (0, 2, 1)]):
        m = [mid[frozenset((a, b))], mid[frozenset((b, c))], mid[frozenset((c, a))]]
        lines.append(f"{k + 2} 9 2 1 1 {a + 1} {b + 1} {c + 1} {m[0]} {m[1]} {m[2]}")
    lines += ["$EndElements", ""]
    path.write_text("\n".join(lines))
    return pts


@pytest.mark.parametrize("orient", [1, -1])
def test_gmsh_tetra10_read_in_its_node_order(tmp_path, orient):
    """Gmsh's tetra10 (whose last two mid-edge nodes are the edges 3-2 and 3-1) is read into VTK's
    order: every mid-edge node is the one nearest its own edge's midpoint; a negatively oriented
    element is flipped with its mid-edge nodes; the triangle6 group becomes a surface of 4 x 4
    flat sub-triangles covering the curved surface's area."""
    path = tmp_path / "one.msh"
    pts = _gmsh_file(path, orient)
    mesh = vfrs.read_mesh(path)
    assert mesh.order == 2 and mesh.flipped == (1 if orient < 0 else 0)
    t = mesh.tets[0]
    for k, (a, b) in enumerate(EDGES):
        centre = 0.5 * (pts[t[a]] + pts[t[b]])
        nearest = int(np.argmin(np.linalg.norm(pts[4:] - centre, axis=1))) + 4
        assert t[4 + k] == nearest
    assert quadratic.volumes(mesh.points, mesh.tets)[0] > 0
    skin = mesh.surface("skin")
    assert skin.shape == (16, 3)
    # outward: the flat sub-triangles' normals point away from the element's centroid
    x = mesh.points[skin]
    n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    assert (np.einsum("ij,ij->i", n, x.mean(axis=1) - mesh.points[t[:4]].mean(axis=0)) > 0).all()


def test_distorted_and_mixed_quadratic_meshes_are_refused(tmp_path):
    """A mid-edge node dragged across its element (negative Jacobian at a quadrature point) is a
    MeshError naming the element; a file with linear and quadratic tetrahedra is refused; a
    non-conforming pair (one edge, two mid-edge nodes) is refused."""
    box = vfrs.meshes.box((1.0, 1.0, 1.0), (2, 2, 2))
    p2, t2 = elevate(box.points, box.tets)
    bad = p2.copy()
    e = 5
    a, b = t2[e, EDGES[0]]
    bad[t2[e, 4]] = bad[a] + 1.2 * (bad[b] - bad[a]) + 0.8 * (box.points.mean(axis=0) - bad[a])
    with pytest.raises(MeshError, match=rf"distorted.*elements {e}\b|distorted.*elements .*\b{e}\b"):
        vfrs.Mesh(bad, t2)
    import meshio

    mixed = tmp_path / "mixed.vtu"
    meshio.Mesh(p2, [("tetra10", t2[:10]), ("tetra", t2[10:, :4])]).write(mixed)
    with pytest.raises(MeshError, match="mixes linear and quadratic"):
        vfrs.read_mesh(mixed)
    other = t2.copy()
    extra = len(p2)
    other[0, 4] = extra
    with pytest.raises(MeshError, match="non-conforming"):
        vfrs.Mesh(np.vstack([p2, p2[t2[0, 4]] + 1e-3]), other)


def test_sphere_at_order_two_lies_on_the_sphere():
    """The ball at order 2: every mid-edge node of the surface is on the sphere (the mapping's
    image, not the chord's midpoint), and the volume error falls from P1's O(h^2) to far below."""
    R = 1.0
    errors = {}
    for cells in (4, 8):
        lin = vfrs.meshes.sphere(R, cells=cells)
        quad = quadratic_mesh(lin)
        assert quad.order == 2 and quad.curved
        nodes = np.unique(quad.surface("surface"))
        assert np.abs(np.linalg.norm(quad.points[nodes], axis=1) - R).max() < 1e-12
        exact = 4 / 3 * np.pi * R**3
        errors[cells] = (abs(lin.volume - exact) / exact, abs(quad.volume - exact) / exact)
    (p1_4, p2_4), (p1_8, p2_8) = errors[4], errors[8]
    assert 3.0 < p1_4 / p1_8 < 5.0  # P1: second order
    assert p2_8 < p1_8 / 50 and p2_4 / p2_8 > 10  # P2: far smaller and faster


def test_pressure_on_a_curved_dome_is_its_projected_area():
    """A uniform pressure on the hemisphere's curved dome (order 2) gives the net force p pi R^2
    along the axis (the projected area) to 1e-4, and no net lateral force; on the closed ball it
    gives no net force at all: the forces are consistent with the curved six-node faces."""
    R, p = 1.0, 1000.0
    dome = quadratic_mesh(vfrs.meshes.hemisphere(R, cells=8))
    f = dome.quadratic_faces().forces(dome.points, dome.surface("curved"), pressure=np.full(dome.n_points, p))
    total = f.sum(axis=0)
    assert abs(total[2] - p * np.pi * R**2) / (p * np.pi * R**2) < 1e-4  # dome below: pushed up (+z)
    assert np.abs(total[:2]).max() < 1e-9 * p
    ball = quadratic_mesh(vfrs.meshes.sphere(R, cells=4))
    g = ball.quadratic_faces().forces(ball.points, ball.surface("surface"), pressure=np.full(ball.n_points, p))
    assert np.abs(g.sum(axis=0)).max() < 1e-10 * p


def _beam_scene(order, cells):
    L, H, E, nu, q = 0.1, 0.01, 1e5, 0.3, 10.0
    return {"title": "cantilever, static",
            "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [L, H, H], "cells": list(cells)},
                        "material": {"model": "isotropic", "E": E, "nu": nu, "rho": 1000.0},
                        "fixed": ["xmin"], "loads": [{"type": "traction", "surface": "xmax", "value": [0, 0, -q]}],
                        **({"order": 2} if order == 2 else {})}],
            "time": {"mode": "static"}, "output": {"every": 1000, "energy": False}}, (L, H, E, nu, q)


def test_order_two_body_in_a_scene_matches_beam_theory():
    """``[[bodies]] order = 2``: a clamped cantilever (L/H = 10, nu = 0.3) under a tip traction,
    static, through vfrs.run: the tip deflection is within 1.5 % of Timoshenko's on a 20 x 2 x 2
    mesh (measured 1.1 %; the fully clamped face stiffens the 3-D beam against the beam theory by
    about 0.5 %, tests/test_quadratic_elements.py), where the linear body on the same mesh is about
    50 % too stiff. The resolved scene
    says order = 2 (and a scene without the key does not)."""
    out = {}
    for order in (1, 2):
        d, (L, H, E, nu, q) = _beam_scene(order, (20, 2, 2))
        sc = vfrs.Scene.from_dict(d)
        assert ("order" in sc.to_dict()["bodies"][0]) == (order == 2)
        res = vfrs.run(sc, progress=False)
        mesh = res.problem.bodies[0].mesh
        tip = np.isclose(mesh.points[:, 0], L)
        out[order] = float(-res.displacement("beam")[tip, 2].mean())
    P, I, A, G = q * H * H, H**4 / 12, H * H, E / (2 * (1 + nu))
    exact = P * L**3 / (3 * E * I) + P * L / ((10 * (1 + nu) / (12 + 11 * nu)) * G * A)
    assert abs(out[2] - exact) / exact < 0.015
    assert out[1] < 0.6 * exact


def test_order_two_scene_errors():
    """order other than 1 or 2 is refused at its key; order = 2 on the M5 ladder meshes (no true
    geometry for the mid-edge nodes) is refused, naming the systematic family."""
    d, _ = _beam_scene(2, (4, 1, 1))
    d["bodies"][0]["order"] = 3
    with pytest.raises(SceneError, match=r"bodies\[0\].order"):
        vfrs.Scene.from_dict(d)
    d = {"title": "fold", "bodies": [{"name": "right", "mesh": {"builtin": "m5", "resolution": "coarse"},
                                     "material": {"model": "isotropic", "E": 4e3, "nu": 0.45, "rho": 1070.0},
                                     "fixed": ["lateral"], "order": 2}], "time": {"mode": "static"}}
    with pytest.raises(SceneError, match="systematic family"):
        vfrs.Scene.from_dict(d).build_meshes()


def test_m5_order_two_medial_grid_and_vtu(tmp_path):
    """The M5 fold at order 2 keeps a medial grid for the flow with every medial node on it (the
    mid-edge nodes between the vertices), and its VTU holds quadratic tetrahedra (VTK type 24)
    that meshio reads back as tetra10 with the same nodes."""
    lin = vfrs.meshes.m5("right", family="systematic", level=0)
    quad = quadratic_mesh(lin)
    grid = quad.medial_grid
    assert grid.shape == tuple(2 * n - 1 for n in lin.medial_grid.shape)
    assert np.array_equal(np.unique(grid), np.unique(quad.surface("medial")))
    from vfrs.output.vtu import FieldFileWriter

    path = tmp_path / "fold.vtu"
    FieldFileWriter(quad.points, quad.tets).write(path, {"u": np.zeros((quad.n_points, 3))})
    import meshio

    back = meshio.read(path)
    assert back.cells[0].type == "tetra10"
    assert np.array_equal(back.cells[0].data, quad.tets)


def test_size_estimate_counts_the_quadratic_nodes():
    """The scene's size estimate (checked against the machine's memory before anything is built)
    counts an order-2 body's mid-edge nodes: an upper bound on its nodes (8 per vertex; the box
    has 6.7-7.3), more matrix bytes per node than a linear body's."""
    d, _ = _beam_scene(2, (8, 8, 8))
    lin, _ = _beam_scene(1, (8, 8, 8))
    quad, est1 = vfrs.Scene.from_dict(d), vfrs.Scene.from_dict(lin).size_estimate()
    est2 = quad.size_estimate()
    built = quad.build_meshes()[0]
    assert built.n_points <= est2["nodes"] <= 1.3 * built.n_points
    assert est2["matrix_bytes"] / est2["nodes"] > 1.5 * est1["matrix_bytes"] / est1["nodes"]


def test_modes_of_an_order_two_body():
    """``vfrs modes`` (vfrs.modes.modes) of the clamped beam at order 2: the first bending
    frequency within 1.5 % of Euler-Bernoulli's on 20 x 2 x 2 cells (measured -0.07 %), where P1
    on the same cells is more than 20 % high (measured +29 %)."""
    from vfrs.modes import modes

    L, H, E, rho = 0.1, 0.01, 1e5, 1000.0
    exact = 1.875104**2 / (2 * np.pi) * np.sqrt(E * H**2 / 12 / (rho * L**4))
    f = {}
    for order in (1, 2):
        d, _ = _beam_scene(order, (20, 2, 2))
        f[order] = modes(vfrs.Scene.from_dict(d), n=1).bodies[0].frequencies[0]
    assert abs(f[2] / exact - 1) < 0.015 and f[1] / exact > 1.2


def test_converge_plan_of_an_order_two_fold(capsys):
    """``vfrs converge --plan`` of two M5 folds at order 2 (``--meshes 1``: the plan of all three
    levels builds level 2's 2.1 million DOFs, 20 s): the family's level at order 2 with its DOFs,
    the quadratic meshes' own."""
    from vfrs.studies.accuracy.folds import folds_scene
    from vfrs.studies.converge import main

    d = folds_scene("L0 P2", {"method": "lagrange"}, 150.0, {"mode": "dynamic", "step": 1e-4, "end": 1e-3}, {"pulse": 6e-3})
    import os
    import tempfile

    path = os.path.join(tempfile.mkdtemp(), "press.toml")
    with open(path, "w") as fh:
        fh.write(vfrs.Scene.from_dict(d).to_toml())
    assert main([path, "--plan", "--meshes", "1"]) in (0, None)
    out = capsys.readouterr().out
    assert "195942 DOFs" in out
