"""Issue 15, part B: every bad input answered by a VfrsError naming the file, key or element
(the table in docs/errors.md); nothing accepted silently wrong."""

from __future__ import annotations

import copy

import numpy as np
import pytest
import scipy.sparse as sp

import vfrs
from vfrs.errors import MeshError, SceneError, SolverError, VfrsError


@pytest.fixture(scope="module")
def K_free():
    mesh = vfrs.meshes.box((1.0, 1.0, 1.0), (2, 2, 2))
    K = vfrs.stiffness(mesh, vfrs.Isotropic(E=1.0, nu=0.3))
    d = vfrs.DofMap(mesh.n_dofs, (3 * mesh.surface_nodes("zmin")[:, None] + np.arange(3)).ravel())
    return d.reduce(K)


# ---- 1. linear algebra -----------------------------------------------------------------
@pytest.mark.parametrize("part", [sp.triu, sp.tril])
def test_cholesky_refuses_one_triangle(K_free, part):
    with pytest.raises(SolverError, match=r"not symmetric: entry \(2, 0\).*lower=True or upper=True"):
        vfrs.cholesky(part(K_free))


@pytest.mark.parametrize("blocks", [False, True])
@pytest.mark.parametrize("which", ["lower", "upper"])
def test_cholesky_mirrors_one_triangle_when_asked(K_free, which, blocks):
    A = sp.tril(K_free) if which == "lower" else sp.triu(K_free)
    b = np.arange(K_free.shape[0], dtype=float)
    x = vfrs.cholesky(A, blocks=blocks, **{which: True}).solve(b)
    assert np.linalg.norm(K_free @ x - b) < 1e-10 * np.linalg.norm(b)
    # the same solution as the full matrix, to round-off
    assert np.allclose(x, vfrs.cholesky(K_free).solve(b), rtol=1e-12, atol=0)


def test_cholesky_lower_and_upper_together(K_free):
    with pytest.raises(SolverError, match="not both"):
        vfrs.cholesky(K_free, lower=True, upper=True)


def test_cholesky_names_first_unsymmetric_value(K_free):
    A = K_free.tolil()
    A[0, 2] += 1e-3
    with pytest.raises(SolverError, match=r"entry \(2, 0\) = -0\.0801.* but \(0, 2\) = -0\.0791.*\(A \+ A\.T\) / 2"):
        vfrs.cholesky(A.tocsr())


def test_cholesky_refuses_nonfinite(K_free):
    A = K_free.copy()
    A.data[5] = np.nan
    with pytest.raises(SolverError, match="must be finite"):
        vfrs.cholesky(A)


def test_cholesky_accepts_assembly_roundoff():
    mesh = vfrs.meshes.box((1.0, 1.0, 1.0), (3, 3, 3), jitter=0.2, seed=3)
    K = vfrs.stiffness(mesh, vfrs.Isotropic(E=1e4, nu=0.45)) + vfrs.mass(mesh, 1000.0)
    vfrs.cholesky(K)  # symmetric to round-off: accepted


def test_core_reads_fortran_ordered_arrays_in_their_logical_order():
    """numpy's slice view (rust-numpy ``as_slice``) also hands out an F-ordered array's memory,
    column-major: read as rows it gave a compliance store's row [1, 2, 3] as [1, 10, 2].
    Arrays the core reads row-major are copied in logical order or refused by name."""
    from vfrs import _core

    store = np.array([[1.0, 2.0, 3.0], [10.0, 20.0, 30.0]])
    out = np.zeros((3, 1))
    _core.linalg.combine_rows(store, np.array([0]), np.ones((1, 1)), out)
    assert out.ravel().tolist() == [1.0, 2.0, 3.0]
    with pytest.raises(ValueError, match=r"store \(shape \[2, 3\]\) must be a C-contiguous array"):
        _core.linalg.combine_rows(np.asfortranarray(store), np.array([0]), np.ones((1, 1)), out)
    with pytest.raises(ValueError, match="out .* must be a C-contiguous array"):
        _core.linalg.combine_rows(store, np.array([0]), np.ones((1, 2)), np.zeros((2, 3)).T)
    with pytest.raises(ValueError, match="S .* must be a C-contiguous array"):
        _core.linalg.delassus(np.array([0, 1]), np.array([0]), np.ones(1), np.array([0, 1]),
                       np.asfortranarray(np.array([[1.0, 2.0], [3.0, 4.0]])), 2, 1.0)
    # An LCP with an unsymmetric matrix and points given F-ordered: the same answers as C order.
    W = np.array([[2.0, 0.5], [-0.3, 1.0]])
    q = np.array([-1.0, -2.0])
    lam = _core.lcp.lcp_lagrange(W, q)[0]
    assert np.array_equal(_core.lcp.lcp_lagrange(np.asfortranarray(W), q)[0], lam)
    assert not np.array_equal(_core.lcp.lcp_lagrange(np.ascontiguousarray(W.T), q)[0], lam)  # the order matters
    pts = np.array([[0.0, 0, 0], [2, 0, 0], [0, 1, 0], [0, 0, 1]])
    tri = np.array([[0, 1, 2], [0, 1, 3]])
    assert np.array_equal(_core.contact.tributary_areas(np.asfortranarray(pts), tri), _core.contact.tributary_areas(pts, tri))
    assert _core.contact.tributary_areas(pts, tri)[0] == pytest.approx(2.0 / 3.0)


def test_stiffness_refuses_inverted_configuration():
    mesh = vfrs.meshes.box((1.0, 1.0, 1.0), (2, 2, 2))
    p = mesh.points.copy()
    p[:, 0] *= -1.0
    with pytest.raises(MeshError, match=r"tetrahedron 0 \(nodes .*signed volume -0\.0208"):
        vfrs.stiffness(mesh, vfrs.Isotropic(E=1.0, nu=0.3), points=p)
    p = mesh.points.copy()
    p[3] = np.nan
    with pytest.raises(MeshError, match="node 3"):
        vfrs.stiffness(mesh, vfrs.Isotropic(E=1.0, nu=0.3), points=p)
    with pytest.raises(MeshError, match="shape"):
        vfrs.stiffness(mesh, vfrs.Isotropic(E=1.0, nu=0.3), points=mesh.points[:-1])
    # a valid moved configuration is still assembled
    K = vfrs.stiffness(mesh, vfrs.Isotropic(E=1.0, nu=0.3), points=mesh.points * 1.1)
    assert K.shape == (81, 81)


# ---- 2. files --------------------------------------------------------------------------
BEAM = {
    "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [0.1, 0.01, 0.01], "cells": [4, 1, 1]},
                "material": {"model": "isotropic", "E": 1e6, "nu": 0.3, "rho": 1000.0}, "fixed": ["xmin"],
                "loads": [{"type": "pressure", "surface": "xmax", "value": 1e3}]}],
    "time": {"mode": "dynamic", "step": 1e-4, "end": 1e-3},
}


def beam(**changes):
    """BEAM with ``changes`` ({"a.b.0.c": value}) applied."""
    s = copy.deepcopy(BEAM)
    for path, v in changes.items():
        keys = [int(k) if k.isdigit() else k for k in path.split(".")]
        o = s
        for k in keys[:-1]:
            o = o[k]
        o[keys[-1]] = v
    return s


def test_mesh_file_that_is_no_mesh(tmp_path, capsys):
    f = tmp_path / "junk.msh"
    f.write_text("hello, this is not a mesh\n")
    with pytest.raises(MeshError, match=r"junk\.msh: not a mesh file meshio can read"):
        vfrs.read_mesh(f)  # meshio calls sys.exit: caught
    scene = vfrs.Scene.from_dict(beam(**{"bodies.0.mesh": {"path": str(f)}, "bodies.0.loads": []}))
    with pytest.raises(SceneError, match=r"bodies\[0\]\.mesh\.path: .*junk\.msh: not a mesh file"):
        scene.build_meshes()
    assert "Couldn't read" not in capsys.readouterr().out  # meshio's print is in the message, not on stdout


def test_mesh_path_unknown_extension_or_folder(tmp_path):
    (tmp_path / "m.xyz").write_text("1 2 3\n")
    with pytest.raises(SceneError, match=r"bodies\[0\]\.mesh\.path: .*unknown mesh file extension \.xyz.*\.msh"):
        vfrs.Scene.from_dict(beam(**{"bodies.0.mesh": {"path": str(tmp_path / "m.xyz")}}))
    with pytest.raises(SceneError, match=r"bodies\[0\]\.mesh\.path: .*is a folder"):
        vfrs.Scene.from_dict(beam(**{"bodies.0.mesh": {"path": str(tmp_path)}}))
    with pytest.raises(MeshError, match="is a folder"):
        vfrs.read_mesh(tmp_path)


def test_scene_file_binary_or_folder(tmp_path):
    (tmp_path / "bin.toml").write_bytes(bytes(range(256)))
    with pytest.raises(SceneError, match=r"bin\.toml: not a text file"):
        vfrs.Scene.load(tmp_path / "bin.toml")
    (tmp_path / "dir.toml").mkdir()
    with pytest.raises(SceneError, match=r"dir\.toml: is a folder"):
        vfrs.Scene.load(tmp_path / "dir.toml")


# ---- 3. numbers and sizes --------------------------------------------------------------
@pytest.mark.parametrize("key, value, match", [
    ("time.end", 1e308, r"time\.end: 1e\+308 .* beyond"),
    ("time.end", 1e50, r"time\.end: end = 1e\+50 s is 1e\+54 steps"),
    ("time.step", 1e-300, r"time\.end: .* steps"),
    ("bodies.0.loads.0.value", 1e308, r"bodies\[0\]\.loads\[0\]\.value: 1e\+308 \(pressure"),
    ("bodies.0.loads.0.value", float("nan"), r"bodies\[0\]\.loads\[0\]\.value: expected a finite number"),
    ("bodies.0.loads.0.value", 10**400, r"bodies\[0\]\.loads\[0\]\.value: expected a finite number.* 401 digits"),
    ("bodies.0.material.E", float("inf"), r"bodies\[0\]\.material\.E: expected a finite"),
    ("bodies.0.mesh.size", [0.1, float("nan"), 0.01], r"bodies\[0\]\.mesh\.size: expected an array of 3 finite"),
    ("bodies.0.mesh.origin", [0.1, 10**400, 0.01], r"bodies\[0\]\.mesh\.origin: expected an array of 3 finite"),
    ("gravity", [0.0, -1e200, 0.0], r"gravity: .* beyond"),
    ("bodies.0.mesh.cells", [2**63, 1, 1], r"bodies\[0\]\.mesh\.cells: the mesh would have 36,893,488,147,419,103,236 nodes"),
    ("bodies.0.mesh.cells", [4.5, 1, 1], r"bodies\[0\]\.mesh\.cells: expected an array of 3 integers"),
    ("time.end", 1.0, None),  # 1e4 steps: fine
])
def test_numbers_refused_at_load(key, value, match):
    s = beam(**{key: value})
    if match is None:
        vfrs.Scene.from_dict(s)
        return
    with pytest.raises(SceneError, match=match):
        vfrs.Scene.from_dict(s)


def test_static_load_steps_bounded():
    with pytest.raises(SceneError, match=r"time\.load_steps: .* at most"):
        vfrs.Scene.from_dict(beam(**{"time": {"mode": "static", "load_steps": 2**63}}))


def test_memory_estimate_fails_fast(monkeypatch):
    import time

    s = vfrs.Scene.from_dict(beam(**{"bodies.0.mesh.cells": [216, 216, 216]}))  # 10 million cells
    est = s.size_estimate()
    assert est["nodes"] == 217**3 and est["dofs"] == 3 * 217**3
    monkeypatch.setenv("VFRS_MEMORY_LIMIT", "64G")
    t = time.perf_counter()
    with pytest.raises(SceneError, match=r"bodies\[0\]\.mesh: the scene needs about .* GB \(10,218,313 nodes.*"
                                         r"but 64 GB are available \(VFRS_MEMORY_LIMIT\)"):
        vfrs.run(s)
    assert time.perf_counter() - t < 5.0  # nothing allocated
    # the limit is the machine's available memory unless overridden; 0 turns the check off
    monkeypatch.setenv("VFRS_MEMORY_LIMIT", "0")
    assert vfrs.Scene.from_dict(BEAM).check_size()["nodes"] == 20
    monkeypatch.setenv("VFRS_MEMORY_LIMIT", "lots")
    with pytest.raises(SceneError, match="VFRS_MEMORY_LIMIT"):
        vfrs.Scene.from_dict(BEAM).check_size()
    monkeypatch.delenv("VFRS_MEMORY_LIMIT")
    from vfrs.scene.sizes import memory_limit

    limit, origin = memory_limit()
    assert limit is None or limit > 0


def test_memory_estimate_counts_meshes_read_from_files(tmp_path, monkeypatch):
    mesh = vfrs.meshes.box((1.0, 1.0, 1.0), (3, 3, 3))
    mesh.write(tmp_path / "b.vtu")
    s = vfrs.Scene.from_dict(beam(**{"bodies.0.mesh": {"path": str(tmp_path / "b.vtu")}, "bodies.0.fixed": [],
                                     "bodies.0.loads": []}))
    assert s.size_estimate()["unknown"] == 1
    monkeypatch.setenv("VFRS_MEMORY_LIMIT", "100k")
    with pytest.raises(SceneError, match=r"64 nodes"):
        s.build_meshes()


# ---- 4. mesh-generator options, at load ------------------------------------------------
@pytest.mark.parametrize("mesh, match", [
    ({"builtin": "box", "jitter": 0.5}, r"bodies\[0\]\.mesh\.jitter: 0\.5 is outside \[0, 0\.3\)"),
    ({"builtin": "box", "jitter": "a"}, r"bodies\[0\]\.mesh\.jitter: expected a number"),
    ({"builtin": "box", "seed": -1}, r"bodies\[0\]\.mesh\.seed: expected an integer >= 0"),
    ({"builtin": "sphere", "cells": 3}, r"bodies\[0\]\.mesh\.cells: 3 must be even"),
    ({"builtin": "hemisphere", "cells": 5}, r"bodies\[0\]\.mesh\.cells: 5 must be even"),
    ({"builtin": "paraboloid_block", "grading": 0.5}, r"bodies\[0\]\.mesh\.grading: 0\.5 must be >= 1"),
    ({"builtin": "m5", "grading": 0.95}, r"bodies\[0\]\.mesh\.grading: 0\.95 is outside"),
    ({"builtin": "m5", "psi": "a"}, r"bodies\[0\]\.mesh\.psi: expected a number"),
    ({"builtin": "m5", "superior_height": 1e-5}, r"bodies\[0\]\.mesh: m5: superior_height is too small"),
    ({"builtin": "m5", "cells": [2**40, 2**40, 2]}, r"bodies\[0\]\.mesh\.cells: the mesh would have"),
])
def test_generator_options_checked_at_load(mesh, match, tmp_path):
    with pytest.raises(SceneError, match=match):
        vfrs.Scene.from_dict(beam(**{"bodies.0.mesh": mesh}))


@pytest.mark.parametrize("name", ["box", "sphere", "hemisphere", "paraboloid_block", "m5"])
def test_generator_estimate_is_exact(name):
    p = vfrs.meshes.PARAMS[name](**({"resolution": "coarse"} if name == "m5" else {}))
    m = p.build()
    assert p.estimate() == (m.n_points, m.n_tets)


# ---- 5. silent fallbacks ---------------------------------------------------------------
def two_blocks(contact):
    s = beam(**{"bodies.0.loads": [], "time.end": 2e-4})
    b2 = copy.deepcopy(s["bodies"][0])
    b2["name"], b2["mesh"]["origin"] = "b2", [0.0, 0.0101, 0.0]
    s["bodies"].append(b2)
    s["contact"] = {"method": "penalty", "kappa": 1e9, **contact}
    return s


@pytest.mark.parametrize("contact, at_load, match", [
    ({"surface": "ymaxx"}, False, r"contact\.surface: no body in contact has a surface 'ymaxx'; did you mean 'ymax'\?; "
                                  r"their surfaces: \['xmax', 'xmin', 'ymax'"),
    ({"surface": {"beem": "ymax"}}, True, r"contact\.surface\.beem: no body named 'beem'; did you mean 'beam'\?"),
    ({"surface": {"beam": "ymaxx"}}, False, r"contact\.surface\.beam: the mesh of body 'beam' has no surface 'ymaxx'; "
                                            r"did you mean 'ymax'\?"),
    ({"pairs": []}, True, r"contact\.pairs: an empty list would turn contact off; remove the \[contact\] section"),
    ({"pairs": [["beam", "b3"]]}, True, r"contact\.pairs\[0\]: no body named 'b3'"),
    ({"pairs": [["beam", "beam"]]}, True, r"contact\.pairs\[0\]: .*self-contact"),
])
def test_contact_fallbacks_are_errors(contact, at_load, match):
    s = two_blocks(contact)
    if at_load:
        with pytest.raises(SceneError, match=match):
            vfrs.Scene.from_dict(s)
        return
    scene = vfrs.Scene.from_dict(s)
    with pytest.raises(SceneError, match=match):
        scene.build_meshes()  # before vfrs.run writes anything


def test_contact_surface_errors_also_from_the_detector_setup():
    from vfrs.dynamics import build_problem
    from vfrs.enforcement.surfaces import ContactSurfaces

    scene = vfrs.Scene.from_dict(two_blocks({}))
    problem = build_problem(scene)
    with pytest.raises(vfrs.ContactError, match=r"\[contact\] surface: no body in contact has a surface 'ymx'"):
        ContactSurfaces(problem, "ymx", None)
    with pytest.raises(vfrs.ContactError, match=r"\[contact\] pairs: an empty list"):
        ContactSurfaces(problem, "ymax", [])


def test_contact_default_surface_may_be_absent():
    # "medial" is the default: a mesh without it contacts with its whole boundary (documented).
    # These blocks have no interior node: the default scheme (mass_redistribution) has nowhere
    # to put their contact nodes' mass and says so, naming the bodies and what to change; the
    # stabilized scheme runs them.
    with pytest.raises(SceneError, match=r"contact surface of body 'b2', 'beam' leaves no node to carry the mass.*"
                                         r"smaller contact surface"):
        vfrs.run(vfrs.Scene.from_dict(two_blocks({"surface": "medial"})))
    res = vfrs.run(vfrs.Scene.from_dict(two_blocks({"surface": "medial", "scheme": "stabilized"})))
    assert np.all(np.isfinite(res.u))
    res = vfrs.run(vfrs.Scene.from_dict(two_blocks({"surface": {"beam": "ymax", "b2": "ymin"}})))
    assert np.all(np.isfinite(res.u))


def test_fractional_cells_is_an_error():
    with pytest.raises(SceneError, match=r"bodies\[0\]\.mesh\.cells: expected an array of 3 integers"):
        vfrs.Scene.from_dict(beam(**{"bodies.0.mesh.cells": [4.5, 1, 1]}))
    with pytest.raises(SceneError, match=r"bodies\[0\]\.mesh\.cells: expected an integer"):
        vfrs.Scene.from_dict(beam(**{"bodies.0.mesh": {"builtin": "sphere", "cells": 4.5}}))


# ---- 6. probes -------------------------------------------------------------------------
@pytest.mark.parametrize("point, match", [
    ([float("nan"), 0.0, 0.0], r"output\.probes\[1\]: expected an array of 3 finite numbers"),
    ([float("inf"), 0.0, 0.0], r"output\.probes\[1\]: expected an array of 3 finite numbers"),
    ([1e200, 0.0, 0.0], r"output\.probes\[1\]: .* beyond"),
])
def test_probe_not_finite_at_load(point, match):
    with pytest.raises(SceneError, match=match):
        vfrs.Scene.from_dict(beam(**{"output": {"probes": [[0.1, 0.0, 0.0], point]}}))


def test_probe_far_from_every_body():
    from vfrs.dynamics import build_problem

    scene = vfrs.Scene.from_dict(beam(**{"output": {"probes": [[0.1, 0.0, 0.0], [100.0, 0.0, 0.0]]}}))
    with pytest.raises(SceneError, match=r"output\.probes\[1\]: the point \[100\.0, 0\.0, 0\.0\] is 99\.9 m from the "
                                         r"nearest node \(node \d+ of body 'beam'.*outside every body"):
        build_problem(scene)
    with pytest.raises(SceneError, match=r"output\.probes\[1\]"):
        vfrs.run(scene)


def test_probe_snapped_node_and_distance():
    from vfrs.dynamics import build_problem

    # on a corner, inside (between nodes), just outside the surface: accepted
    probes = [[0.1, 0.0, 0.0], [0.05, 0.004, 0.006], [0.1 + 1e-3, 0.005, 0.005]]
    problem = build_problem(vfrs.Scene.from_dict(beam(**{"output": {"probes": probes}})))
    snapped = problem.probe_nodes()
    assert len(snapped) == 3
    for (node, dist), p in zip(snapped, probes):
        assert dist == pytest.approx(np.linalg.norm(problem.points[node] - p))
        assert dist == pytest.approx(np.linalg.norm(problem.points - p, axis=1).min())
    assert snapped[0][1] == 0.0


def test_result_probe_reports_distance_and_refuses_far_points():
    """Result.probe(point) snaps like [output] probes: the distance is returned, a point outside
    every body or not finite is an error (it used to snap silently to some node)."""
    scene = vfrs.Scene.from_dict(beam(**{"output": {"probes": [[0.1, 0.0, 0.0]]}}))
    res = vfrs.run(scene, progress=False)
    p = res.probe([0.1 + 1e-4, 0.0, 0.0])
    assert p["distance"] == pytest.approx(1e-4)
    with pytest.raises(SceneError, match=r"Result\.probe\(point\): the point \[100\.0, 0\.0, 0\.0\] is .* outside every body"):
        res.probe([100.0, 0.0, 0.0])
    with pytest.raises(SceneError, match=r"Result\.probe\(point\): expected a finite point"):
        res.probe([float("nan"), 0.0, 0.0])


def test_example_probes_are_on_their_bodies():
    import glob
    import os

    from vfrs.dynamics import build_problem

    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    for f in sorted(glob.glob(os.path.join(here, "examples", "*.toml"))):
        scene = vfrs.Scene.load(f)
        if scene.output.probes and all(b.mesh.get("resolution") != "fine" for b in scene.bodies):
            for node, dist in build_problem(scene).probe_nodes():
                assert dist < 1e-3, (f, node, dist)


# ---- 7. static runs diverging ----------------------------------------------------------
@pytest.mark.parametrize("value", [1e90, 1e40])
def test_static_run_with_absurd_load_is_an_error(value):
    # Before issue 12 a static run could end with infinite energy and exit 0.
    s = beam(**{"time": {"mode": "static", "load_steps": 2}, "bodies.0.loads.0.value": value})
    with pytest.raises(vfrs.ConvergenceError, match=r"step 1, .*the solution diverged"):
        vfrs.run(vfrs.Scene.from_dict(s))


def test_static_run_ends_finite():
    res = vfrs.run(vfrs.Scene.from_dict(beam(**{"time": {"mode": "static"}})))
    assert np.all(np.isfinite(res.u))
    assert all(np.all(np.isfinite(np.asarray(v, dtype=float))) for k, v in res.history.items() if "energy" in k)


def test_none_in_a_scene_dict_is_unset():
    # found by tests/test_fuzz.py: a None (no TOML null, but a dict may hold one) was a KeyError
    with pytest.raises(SceneError, match=r"bodies\[0\]\.material\.model: missing; expected one of"):
        vfrs.Scene.from_dict(beam(**{"bodies.0.material.model": None}))
    with pytest.raises(SceneError, match=r"bodies\[0\]\.mesh\.builtin: missing; expected one of"):
        vfrs.Scene.from_dict(beam(**{"bodies.0.mesh.builtin": None}))
    assert vfrs.Scene.from_dict(beam(**{"output": {"every": None}})).output.every == 10


def test_fixed_nodes_pushed_into_each_other_are_named():
    """Two blocks whose whole bodies are moved into each other by prescribed displacements:
    every DOF of the penetrating pairs is fixed, so no contact force can act (a Lagrange
    multiplier of 1e10 N and more came out before, silently). A ContactError names the step,
    a node and the depth."""
    def block(name, z0, dz):
        return {"name": name, "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [1, 1, 2],
                                       "origin": [0, 0, z0]},
                "material": {"model": "isotropic", "E": 1e4, "nu": 0.3},
                "fixed": [{"surface": s, "displacement": [0, 0, dz]} for s in ("zmin", "zmax")]}
    scene = vfrs.Scene.from_dict({
        "bodies": [block("low", 0.0, 1e-4), block("high", 0.01 + 1e-5, -1e-4)],
        "contact": {"method": "lagrange", "detection": "bvh", "surface": {"low": "zmax", "high": "zmin"}},
        "time": {"mode": "static", "load_steps": 2}})
    with pytest.raises(vfrs.errors.ContactError, match=r"step 1, .*penetrate with every DOF fixed.*m deep"):
        vfrs.run(scene, progress=False)
