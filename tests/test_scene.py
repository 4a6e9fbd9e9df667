"""Scenes: resolved round trips, and invalid scenes rejected with the file, the key and a hint."""

import copy
from vfrs._compat import tomllib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import vfrs
from vfrs.scene.toml_writer import dumps
from vfrs.materials import NEARLY_INCOMPRESSIBLE

BASE = {
    "bodies": [{"name": "beam",
                "mesh": {"builtin": "box", "size": [0.02, 0.004, 0.004], "cells": [4, 1, 1]},
                "material": {"model": "isotropic", "E": 10e3, "nu": 0.45, "rho": 1070.0},
                "fixed": ["xmin"]}],
    "time": {"mode": "dynamic", "step": 1e-3, "end": 1e-2},
}


def scene_with(path, value, base=BASE):
    """A copy of ``base`` with the value at a key path replaced (``None`` deletes it)."""
    d = copy.deepcopy(base)
    node = d
    for k in path[:-1]:
        node = node[k]
    if value is None:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return d


def write(tmp_path, d, name="scene.toml"):
    p = tmp_path / name
    p.write_text(dumps(d))
    return p


def test_defaults_are_resolved_and_round_trip():
    s = vfrs.Scene.from_dict(BASE)
    d = s.to_dict()
    assert d["time"] == {"mode": "dynamic", "step": 1e-3, "end": 1e-2, "alpha": -0.3}
    assert d["bodies"][0]["mesh"] == {"builtin": "box", "size": [0.02, 0.004, 0.004], "cells": [4, 1, 1],
                                      "origin": [0.0, 0.0, 0.0], "jitter": 0.0, "seed": 0}
    assert d["bodies"][0]["fixed"][0] == {"name": "xmin", "surface": "xmin", "components": ["x", "y", "z"],
                                         "displacement": [0.0, 0.0, 0.0], "ramp": 0.0}
    assert d["output"]["every"] == 10 and d["gravity"] == [0.0, 0.0, 0.0]
    assert vfrs.Scene.from_dict(d).to_dict() == d
    # through TOML text too
    assert vfrs.Scene.from_dict(tomllib.loads(s.to_toml())).to_dict() == d


def test_example_scenes_round_trip_through_files(tmp_path):
    for path in ["examples/cantilever.toml", "examples/bar_static.toml", "examples/sphere_drop.toml"]:
        s = vfrs.Scene.load(path)
        s.save(tmp_path / "resolved.toml")
        again = vfrs.Scene.load(tmp_path / "resolved.toml")
        assert again.to_dict() == s.to_dict(), path


def test_material_per_region_and_selectors_resolve():
    d = scene_with(["bodies", 0, "material"], {"all": {"model": "transversely_isotropic", "E_p": 2e3, "E_z": 40e3,
                                                       "nu_p": 0.9, "nu_pz": 0.0, "G_pz": 10e3}})
    d["bodies"][0]["fixed"] = [{"axis": "x", "below": 0.0, "components": ["z", "x"], "displacement": [1e-4, 0, 0]}]
    s = vfrs.Scene.from_dict(d)
    m = s.to_dict()["bodies"][0]["material"]["all"]
    assert m["model"] == "transversely_isotropic" and m["rho"] == 1070.0 and m["axis"] == [0.0, 0.0, 1.0]
    c = s.bodies[0].fixed[0]
    assert c.components == ("x", "z") and c.name == "x<=0" and c.prescribed
    assert vfrs.Scene.from_dict(s.to_dict()).to_dict() == s.to_dict()


@settings(max_examples=40, deadline=None)
@given(
    # nu below the locking warning's threshold (that warning is a pytest error here; its own tests are in
    # test_materials): hypothesis drew nu = 0.49 exactly once and failed on the warning, not the round trip
    E=st.floats(1.0, 1e9), nu=st.floats(0.0, NEARLY_INCOMPRESSIBLE, exclude_max=True), rho=st.floats(1.0, 1e4),
    alpha=st.floats(-1 / 3, 0.0), every=st.integers(1, 100),
    g=st.lists(st.floats(-20, 20), min_size=3, max_size=3),
)
def test_round_trip_is_identity_for_any_valid_values(E, nu, rho, alpha, every, g):
    d = copy.deepcopy(BASE)
    d["bodies"][0]["material"] = {"model": "isotropic", "E": E, "nu": nu, "rho": rho}
    d["time"]["alpha"] = alpha
    d["output"] = {"every": every}
    d["gravity"] = g
    r = vfrs.Scene.from_dict(d).to_dict()
    assert vfrs.Scene.from_dict(r).to_dict() == r
    assert vfrs.Scene.from_dict(tomllib.loads(dumps(r))).to_dict() == r


# ---- invalid scenes: each names the file, the key path and what was expected ---------------
@pytest.mark.parametrize("path,value,message", [
    (["time", "stepp"], 1e-3, r"scene\.toml: time\.stepp: unknown key; did you mean 'step'\?"),
    (["tiem"], {"step": 1.0}, r"scene\.toml: tiem: unknown key; did you mean 'time'\? Valid keys here: \[.*'bodies'"),
    (["contcat"], {"method": "penalty"}, r"scene\.toml: contcat: unknown key; did you mean 'contact'\?"),
    (["bodies", 0, "materail"], {}, r"bodies\[0\]\.materail: unknown key; did you mean 'material'\?"),
    (["time", "step"], "fast", r"time\.step: expected a number \(time step, s\), got a string \('fast'\)"),
    (["bodies", 0, "material", "rho"], -5.0, r"bodies\[0\]\.material\.rho: expected a positive number \(density, kg/m\^3\), got -5"),
    (["time", "alpha"], -0.5, r"time\.alpha: expected a number in \[-0\.333333, 0\] \(HHT-alpha\), got -0\.5"),
    (["time", "alpha"], 0.1, r"time\.alpha: expected a number in \[-0\.333333, 0\]"),
    (["bodies", 0, "mesh"], {"path": "no_such.msh"}, r"bodies\[0\]\.mesh\.path: mesh file '.*no_such\.msh' does not exist"),
    (["bodies", 0, "mesh", "builtin"], "bax", r"bodies\[0\]\.mesh\.builtin: 'bax' is not one of .*; did you mean 'box'\?"),
    (["bodies", 0, "mesh", "cels"], [1, 1, 1], r"bodies\[0\]\.mesh\.cels: unknown key; did you mean 'cells'\?"),
    (["bodies", 0, "material", "model"], "mooney_rivlin", r"bodies\[0\]\.material\.model: 'mooney_rivlin' is not one of \[.*'isotropic'.*\]"),
    (["bodies", 0, "material", "nu"], 0.5, r"bodies\[0\]\.material: .*nu"),
    (["bodies", 0, "material", "E"], None, r"bodies\[0\]\.material\.E: missing; expected a number"),
    (["time"], None, r"scene\.toml: time: missing; expected a table"),
    (["bodies"], [], r"bodies: expected at least one \[\[bodies\]\] table"),
    (["bodies", 0, "fixed"], [{"axis": "w", "below": 0.0}], r"bodies\[0\]\.fixed\[0\]\.axis: 'w' is not one of \['x', 'y', 'z'\]"),
    (["bodies", 0, "fixed"], [{"axis": "x"}], r"bodies\[0\]\.fixed\[0\]\.axis: axis 'x' needs `below`, `above` or `at`"),
    (["bodies", 0, "fixed"], [{"surface": "xmin", "components": ["x", "q"]}], r"fixed\[0\]\.components: expected distinct components"),
    (["bodies", 0, "loads"], [{"type": "force", "surface": "xmax", "value": 1.0}], r"loads\[0\]\.type: 'force' is not one of \['pressure', 'traction'\]"),
    (["bodies", 0, "loads"], [{"type": "traction", "surface": "xmax", "value": 1.0}], r"loads\[0\]\.value: expected an array of 3 finite numbers"),
    (["gravity"], [0, 0], r"gravity: expected an array of 3 finite numbers"),
    (["time", "end"], 1e-5, r"time\.end: end = 1e-05 s is shorter than one step"),
    (["output"], {"fields": ["displacment"]}, r"output\.fields\[0\]: 'displacment' is not a field; .*did you mean 'displacement'\?"),
    (["obstacles"], [{"point": [0, 0, 0], "normal": [0, 0, 1]}], r"obstacles: rigid obstacles act only through contact"),
])
def test_invalid_scene_errors_name_file_key_and_expectation(tmp_path, path, value, message):
    p = write(tmp_path, scene_with(path, value))
    with pytest.raises(vfrs.SceneError, match=message):
        vfrs.Scene.load(p)


def test_static_mode_rejects_dynamic_keys():
    d = scene_with(["time"], {"mode": "static", "step": 1e-3})
    with pytest.raises(vfrs.SceneError, match=r"<dict>: time\.step: unknown key\. Valid keys here: \['load_steps', 'mode'\]"):
        vfrs.Scene.from_dict(d)


def test_duplicate_body_names():
    d = copy.deepcopy(BASE)
    d["bodies"].append(copy.deepcopy(d["bodies"][0]))
    with pytest.raises(vfrs.SceneError, match=r"bodies\[1\]\.name: body name 'beam' is used twice"):
        vfrs.Scene.from_dict(d)


def test_unknown_surface_is_reported_when_the_mesh_is_built():
    s = vfrs.Scene.from_dict(scene_with(["bodies", 0, "fixed"], ["xmni"]))
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.fixed\[0\]\.surface: the mesh of body 'beam' has no surface 'xmni'; did you mean 'xmin'\?"):
        vfrs.run(s, progress=False)


def test_a_selector_that_selects_nothing_is_an_error():
    s = vfrs.Scene.from_dict(scene_with(["bodies", 0, "fixed"], [{"axis": "z", "below": -1.0}]))
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.fixed\[0\]: the selector .* selects no node"):
        s.build_meshes()


def test_bad_toml_and_missing_file(tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text("[time\nstep = 1")
    with pytest.raises(vfrs.SceneError, match=r"bad\.toml: not valid TOML"):
        vfrs.Scene.load(p)
    with pytest.raises(vfrs.SceneError, match=r"nope\.toml: scene file does not exist"):
        vfrs.Scene.load(tmp_path / "nope.toml")


def test_mesh_paths_are_relative_to_the_scene_file(tmp_path):
    (tmp_path / "meshes").mkdir()
    vfrs.meshes.box((1.0, 1.0, 1.0), (2, 2, 2)).write(tmp_path / "meshes" / "cube.vtu")
    d = scene_with(["bodies", 0, "mesh"], {"path": "meshes/cube.vtu", "length_unit": "mm"})
    d["bodies"][0]["fixed"] = [{"axis": "x", "below": 0.0}]
    s = vfrs.Scene.load(write(tmp_path, d))
    assert s.bodies[0].mesh["path"] == str(tmp_path / "meshes" / "cube.vtu")
    (mesh,) = s.build_meshes()
    assert np.ptp(mesh.points, axis=0) == pytest.approx([1e-3] * 3)


def test_sphere_and_hemisphere_generators_are_in_the_registry():
    s = vfrs.Scene.from_dict(scene_with(["bodies", 0, "mesh"], {"builtin": "hemisphere", "radius": 0.01, "cells": 4}))
    s.bodies[0].fixed[0].selector = {"surface": "flat"}
    (mesh,) = s.build_meshes()
    assert sorted(mesh.surfaces) == ["curved", "flat"]
    assert s.to_dict()["bodies"][0]["mesh"] == {"builtin": "hemisphere", "radius": 0.01, "center": [0.0, 0.0, 0.0],
                                                "cells": 4, "pole": "-z"}


@pytest.mark.parametrize("module", [
    "vfrs.scene", "vfrs.scene.selectors", "vfrs.scene.toml_writer", "vfrs.meshes.sphere", "vfrs.meshes.base",
    "vfrs.materials", "vfrs.linalg", "vfrs.output.vtu",
    "vfrs.dynamics.hht", "vfrs.dynamics.static", "vfrs.dynamics.problem", "vfrs.run",
    "vfrs.studies.sweep.spec", "vfrs.studies.sweep.table", "vfrs.studies.extra",
])
def test_docstring_examples_run(module):
    import doctest
    import importlib

    mod = importlib.import_module(module)
    if module == "vfrs.run":  # the module, not the function re-exported as vfrs.run
        import sys

        mod = sys.modules["vfrs.run"]
    result = doctest.testmod(mod, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0
