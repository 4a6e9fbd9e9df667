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
