"""Built-in sphere and hemisphere meshes: valid, conforming, converging to the exact shape."""

import numpy as np
import pytest

import vfrs
from vfrs.meshes import GENERATORS, hemisphere, sphere


def surface_area(mesh, tri):
    x = mesh.points[tri]
    return np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1).sum() / 2


def test_registered():
    assert GENERATORS["sphere"] is sphere and GENERATORS["hemisphere"] is hemisphere


@pytest.mark.parametrize("cells", [2, 4, 8])
def test_sphere_is_valid_and_its_surface_is_the_whole_boundary(cells):
    m = sphere(0.01, center=(1.0, 2.0, 3.0), cells=cells)
    assert m.signed_volumes().min() > 0
    assert len(m.surface("surface")) == len(m.boundary_faces())
    r = np.linalg.norm(m.points[m.surface_nodes("surface")] - [1.0, 2.0, 3.0], axis=1)
    np.testing.assert_allclose(r, 0.01, rtol=1e-12)  # boundary nodes on the sphere


def test_sphere_volume_and_area_converge_at_second_order():
    cells = [4, 8, 16]
    vol_err = [abs(sphere(1.0, cells=c).volume / (4 / 3 * np.pi) - 1) for c in cells]
    slope = np.polyfit(np.log(1.0 / np.array(cells)), np.log(vol_err), 1)[0]
    assert 1.7 < slope < 2.3, vol_err
    m = sphere(1.0, cells=16)
    assert surface_area(m, m.surface("surface")) == pytest.approx(4 * np.pi, rel=0.01)


@pytest.mark.parametrize("pole", ["-z", "+z", "+x", "-x", "+y", "-y"])
def test_hemisphere_points_its_dome_along_pole(pole):
    m = hemisphere(2.0, center=(0.5, 0.0, 0.0), cells=8, pole=pole)
    assert m.signed_volumes().min() > 0
    axis = "xyz".index(pole[1])
    sign = 1.0 if pole[0] == "+" else -1.0
    rel = (m.points - [0.5, 0.0, 0.0])[:, axis] * sign
    assert rel.min() > -1e-12 and rel.max() == pytest.approx(2.0)
    flat = m.points[m.surface_nodes("flat")] - [0.5, 0.0, 0.0]
    np.testing.assert_allclose(flat[:, axis], 0.0, atol=1e-12)
    # Surfaces: the flat disc and the dome cover the boundary exactly once, normals outward.
    assert len(m.surface("flat")) + len(m.surface("curved")) == len(m.boundary_faces())
    tri = m.surface("flat")
    x = m.points[tri]
    n = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    assert (n[:, axis] * sign < 0).all()  # the disc's outward normal points away from the dome
    assert surface_area(m, m.surface("flat")) == pytest.approx(np.pi * 4.0, rel=0.03)


def test_bad_arguments_are_mesh_errors():
    with pytest.raises(vfrs.MeshError, match="even integer"):
        sphere(1.0, cells=3)
    with pytest.raises(vfrs.MeshError, match="pole must be one of"):
        hemisphere(1.0, pole="up")
    with pytest.raises(vfrs.MeshError, match="radius must be positive"):
        hemisphere(-1.0)


def test_a_scene_reports_generator_errors_at_the_mesh_key():
    scene = vfrs.Scene.from_dict({
        "bodies": [{"name": "ball", "mesh": {"builtin": "sphere", "radius": 0.01, "cells": 3},
                    "material": {"model": "isotropic", "E": 1e3, "nu": 0.3}, "fixed": ["surface"]}],
        "time": {"mode": "static"}})
    with pytest.raises(vfrs.SceneError, match=r"<dict>: bodies\[0\]\.mesh: sphere cells must be an even integer"):
        scene.build_meshes()
