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
    # At load, with the key (issue 15: not first when the mesh is built).
    with pytest.raises(vfrs.SceneError, match=r"<dict>: bodies\[0\]\.mesh\.cells: 3 must be even"):
        vfrs.Scene.from_dict({
            "bodies": [{"name": "ball", "mesh": {"builtin": "sphere", "radius": 0.01, "cells": 3},
                        "material": {"model": "isotropic", "E": 1e3, "nu": 0.3}, "fixed": ["surface"]}],
            "time": {"mode": "static"}})


# ---- the generators' typed Params: validated at scene load, written back resolved ------------
BOX_SCENE = {
    "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [0.02, 0.004, 0.004], "cells": [4, 1, 1]},
                "material": {"model": "isotropic", "E": 1e3, "nu": 0.3}, "fixed": ["xmin"]}],
    "time": {"mode": "static"},
}


def with_mesh(mesh):
    import copy

    d = copy.deepcopy(BOX_SCENE)
    d["bodies"][0]["mesh"] = mesh
    return d


def test_every_generator_has_params_with_its_function_defaults():
    import dataclasses
    import inspect

    from vfrs.meshes import PARAMS

    assert sorted(PARAMS) == sorted(GENERATORS) == ["box", "hemisphere", "m5", "paraboloid_block", "sphere"]
    for name, cls in PARAMS.items():
        assert GENERATORS[name] is cls.generator
        sig = inspect.signature(cls.generator).parameters
        assert {f.name: f.default for f in dataclasses.fields(cls)} == {k: p.default for k, p in sig.items()}
        p = cls()
        assert p.to_dict()["builtin"] == name
        assert type(p).from_dict(p.to_dict()) == p  # the resolved data builds the same Params


@pytest.mark.parametrize("mesh, message", [
    ({"builtin": "box", "cells": [4.5, 1, 1]}, r"bodies\[0\]\.mesh\.cells: expected an array of 3 integers"),
    ({"builtin": "box", "cells": 4.5}, r"bodies\[0\]\.mesh\.cells: expected an array of 3 integers .*got 4\.5"),
    ({"builtin": "box", "cells": [0, 1, 1]}, r"bodies\[0\]\.mesh\.cells: expected an array of 3 integers >= 1"),
    ({"builtin": "box", "size": ["long", 1, 1]}, r"bodies\[0\]\.mesh\.size: expected an array of 3 finite numbers"),
    ({"builtin": "box", "size": [1.0, -1.0, 1.0]}, r"bodies\[0\]\.mesh\.size: expected an array of 3 numbers positive"),
    ({"builtin": "box", "seed": "7"}, r"bodies\[0\]\.mesh\.seed: expected an integer, got a string"),
    ({"builtin": "sphere", "cells": 4.5}, r"bodies\[0\]\.mesh\.cells: expected an integer, got a number \(4\.5\)"),
    ({"builtin": "sphere", "radius": "1 cm"}, r"bodies\[0\]\.mesh\.radius: expected a number \(radius, m\), got a string"),
    ({"builtin": "sphere", "radius": 0.0}, r"bodies\[0\]\.mesh\.radius: expected a positive number \(radius, m\)"),
    ({"builtin": "hemisphere", "pole": "-zz"}, r"bodies\[0\]\.mesh\.pole: '-zz' is not one of \['\+x', .*; did you mean '-z'\?"),
    ({"builtin": "m5", "resolution": "ultra"}, r"bodies\[0\]\.mesh\.resolution: 'ultra' is not one of \['coarse', 'fine', 'medium'\]"),
    ({"builtin": "m5", "psi": 60.0}, r"bodies\[0\]\.mesh\.psi: expected a number in \[-40, 40\] \(glottal angle.*degrees\)"),
    ({"builtin": "paraboloid_block", "radius": 1.0, "cells": [8, 8, 8]}, r"bodies\[0\]\.mesh\.cells: expected an integer, got an array"),
])
def test_a_generator_option_of_the_wrong_type_fails_at_load_with_its_key_path(mesh, message):
    with pytest.raises(vfrs.SceneError, match=r"<dict>: " + message):
        vfrs.Scene.from_dict(with_mesh(mesh))


def test_the_resolved_mesh_is_the_params_with_unset_options_left_out():
    s = vfrs.Scene.from_dict(with_mesh({"builtin": "m5", "side": "left", "resolution": "coarse", "psi": 10}))
    mesh = s.to_dict()["bodies"][0]["mesh"]
    assert mesh["psi"] == 10.0 and isinstance(mesh["psi"], float) and "cells" not in mesh  # cells unset: None
    assert mesh["T"] == 3.0e-3 and mesh["side"] == "left"
    s = vfrs.Scene.from_dict(with_mesh({"builtin": "m5", "resolution": "fine", "cells": [20, 5, 8]}))
    mesh = s.to_dict()["bodies"][0]["mesh"]
    assert mesh["cells"] == [20, 5, 8] and "resolution" not in mesh  # only what the generator uses
    assert vfrs.Scene.from_dict(s.to_dict()).to_dict() == s.to_dict()


def test_a_new_generator_is_one_registered_params_class():
    """A throwaway generator registered from here is usable from a scene dict, resolved and
    built, without touching any other file; unregistered afterwards."""
    from dataclasses import dataclass
    from typing import ClassVar

    from vfrs.meshes import PARAMS, GeneratorParams, register_generator
    from vfrs.params import param

    def slab(thickness=0.01, cells=2) -> vfrs.Mesh:
        return vfrs.meshes.box((0.02, 0.02, thickness), (cells, cells, 1))

    @register_generator(slab)
    @dataclass(frozen=True)
    class SlabParams(GeneratorParams):
        name: ClassVar[str] = "test_slab"
        thickness: float = param(0.01, doc="thickness", unit="m", positive=True)
        cells: int = param(2, doc="cells per side", minimum=1)

    try:
        s = vfrs.Scene.from_dict(with_mesh({"builtin": "test_slab", "cells": 3}))
        assert s.to_dict()["bodies"][0]["mesh"] == {"builtin": "test_slab", "thickness": 0.01, "cells": 3}
        (mesh,) = s.build_meshes()
        assert mesh.n_tets == 3 * 3 * 6
        with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.mesh\.thickness: expected a positive number \(thickness, m\)"):
            vfrs.Scene.from_dict(with_mesh({"builtin": "test_slab", "thickness": -1.0}))
    finally:
        PARAMS.unregister("test_slab")
    assert "test_slab" not in GENERATORS
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.mesh\.builtin: 'test_slab' is not one of"):
        vfrs.Scene.from_dict(with_mesh({"builtin": "test_slab"}))


def test_params_that_do_not_match_their_function_are_refused_at_registration():
    from dataclasses import dataclass
    from typing import ClassVar

    from vfrs.meshes import PARAMS, GeneratorParams, register_generator
    from vfrs.params import param

    def gen(size=1.0, cells=2):
        raise AssertionError("never called")

    with pytest.raises(TypeError, match=r"default 3 differs from gen\(\)'s 2"):
        @register_generator(gen)
        @dataclass(frozen=True)
        class Wrong(GeneratorParams):
            name: ClassVar[str] = "test_wrong"
            size: float = param(1.0)
            cells: int = param(3)

    with pytest.raises(TypeError, match=r"fields \['size'\] are not the arguments \['size', 'cells'\]"):
        @register_generator(gen)
        @dataclass(frozen=True)
        class Missing(GeneratorParams):
            name: ClassVar[str] = "test_wrong"
            size: float = param(1.0)

    with pytest.raises(TypeError, match=r"a scene cannot read type"):
        @register_generator(gen)
        @dataclass(frozen=True)
        class Untyped(GeneratorParams):
            name: ClassVar[str] = "test_wrong"
            size: list = param(1.0)
            cells: int = param(2)
    assert "test_wrong" not in PARAMS
