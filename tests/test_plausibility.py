"""Plausibility of a vocal-fold scene (issue 30, item 4): unit slips in sizes, pressures,
moduli and densities warn, naming the file, the key, the value with unit, the range and the
slip; ``[checks] strict = true`` makes them errors; scenes that are no vocal-fold scenes, and
every shipped example, load without a word."""

import warnings
from pathlib import Path

import pytest

import vfrs
from vfrs.errors import PlausibilityError, PlausibilityWarning, SceneError

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
DATA = Path(__file__).resolve().parent / "data"

M5_SCENE = """
title = "m5 folds"

[[bodies]]
name = "right"
mesh = {{ builtin = "m5", side = "right", resolution = "coarse", length = {length} }}
material = {{ model = "vocal_fold" }}
fixed = ["lateral", "anterior", "posterior"]

[[bodies]]
name = "left"
mesh = {{ builtin = "m5", side = "left", resolution = "coarse" }}
material = {{ model = "vocal_fold" }}
fixed = ["lateral", "anterior", "posterior"]

[flow]
subglottal_pressure = {ps}

[time]
step = 50e-6
end = 1e-3
{extra}
"""


def write(tmp_path, length="14e-3", ps="800.0", extra=""):
    path = tmp_path / "folds.toml"
    path.write_text(M5_SCENE.format(length=length, ps=ps, extra=extra))
    return path


def quiet_load(path_or_dict):
    """Loads a scene with every PlausibilityWarning turned into an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlausibilityWarning)
        if isinstance(path_or_dict, dict):
            return vfrs.Scene.from_dict(path_or_dict)
        return vfrs.Scene.load(path_or_dict)


def test_the_scene_of_the_tests_is_plausible(tmp_path):
    scene = quiet_load(write(tmp_path))
    assert scene.plausibility == [] and not scene.checks.strict


def test_a_fold_length_in_mm_typed_as_m_warns_with_file_key_range_and_slip(tmp_path):
    path = write(tmp_path, length="14")
    with pytest.warns(PlausibilityWarning) as caught:
        scene = vfrs.Scene.load(path)
    (w,) = caught
    msg = str(w.message)
    assert msg.startswith(f"{path}: bodies[0].mesh.length: length = 14 m: ")
    assert "10-25 mm" in msg and "did you mean 14 mm = 0.014?" in msg and "1 mm - 10 cm" in msg
    assert scene.plausibility == [msg]
    assert w.filename == __file__  # points at the caller's line, not inside vfrs


def test_a_subglottal_pressure_in_kpa_typed_as_pa_warns(tmp_path):
    path = write(tmp_path, ps="0.8")
    with pytest.warns(PlausibilityWarning) as caught:
        vfrs.Scene.load(path)
    (w,) = caught
    msg = str(w.message)
    assert msg.startswith(f"{path}: flow.subglottal_pressure: subglottal_pressure = 0.8 Pa: ")
    assert "0.3-2 kPa" in msg and "did you mean 0.8 kPa = 800?" in msg and "50 Pa - 5 kPa" in msg


@pytest.mark.parametrize("length, ps, key", [("14", "800.0", "bodies[0].mesh.length"),
                                             ("14e-3", "0.8", "flow.subglottal_pressure")])
def test_strict_makes_them_errors_with_the_same_message(tmp_path, length, ps, key):
    path = write(tmp_path, length=length, ps=ps, extra="[checks]\nstrict = true\n")
    with pytest.raises(PlausibilityError) as e:
        vfrs.Scene.load(path)
    assert isinstance(e.value, SceneError)
    assert str(e.value).startswith(f"{path}: {key}: ")
    assert "did you mean" in str(e.value) and "an error because [checks] strict = true" in str(e.value)


def test_strict_lists_every_finding_and_a_plausible_strict_scene_loads(tmp_path):
    with pytest.raises(PlausibilityError, match=r"bodies\[0\]\.mesh\.length: .*\(and 1 more: flow\.subglottal_pressure\)"):
        vfrs.Scene.load(write(tmp_path, length="14", ps="0.8", extra="[checks]\nstrict = true\n"))
    scene = quiet_load(write(tmp_path, extra="[checks]\nstrict = true\n"))
    assert scene.checks.strict
    d = scene.to_dict()
    assert d["checks"] == {"strict": True}
    assert vfrs.Scene.from_dict(d).to_dict() == d  # the resolved scene keeps the switch
    assert "checks" not in quiet_load(write(tmp_path)).to_dict()  # unset: the resolved scene as before


def test_checks_keys_are_validated_like_every_table(tmp_path):
    with pytest.raises(SceneError, match=r"checks\.strct: unknown key; did you mean 'strict'\?"):
        vfrs.Scene.load(write(tmp_path, extra="[checks]\nstrct = true\n"))
    with pytest.raises(SceneError, match=r"checks\.strict: expected true or false"):
        vfrs.Scene.load(write(tmp_path, extra="[checks]\nstrict = 1\n"))


@pytest.mark.parametrize("material, key, slip", [
    ({"model": "isotropic", "E": 4.0, "nu": 0.45}, "bodies[1].material.E", "did you mean 4 kPa = 4000?"),
    ({"model": "isotropic", "E": 200e9, "nu": 0.3, "rho": 7850.0}, "bodies[1].material.E",
     "check the value and its unit (the scene's unit is Pa) (flagged outside 100 Pa - 10 MPa"),
    ({"model": "vocal_fold", "rho": 1.07}, "bodies[1].material.rho", "did you mean 1.07 g/cm^3 (= kg/L) = 1070?"),
    ({"model": "vocal_fold", "rho": 1.07e6}, "bodies[1].material.rho", "1.07e+06 g/m^3 = 1070"),
    ({"model": "vocal_fold", "G_pz": 10e6 * 1e3}, "bodies[1].material.G_pz", "1000 times smaller"),
    ({"cover": {"model": "vocal_fold"}, "body": {"model": "isotropic", "E": 0.004, "nu": 0.45}},
     "bodies[1].material.body.E", "did you mean 0.004 MPa = 4000?"),
    ({"model": "isotropic", "E": 4e3, "nu": -0.3}, "bodies[1].material.nu",
     "nu = -0.3: tissue's Poisson ratios are positive"),
    ({"model": "vocal_fold", "nu_pz": -0.02}, "bodies[1].material.nu_pz",
     "did you mean 0.02, without the minus sign? (flagged below 0;"),
])
def test_fold_moduli_and_densities_far_out_of_range_warn(material, key, slip):
    d = quiet_load(EXAMPLES / "m5_phonation.toml").to_dict()
    d["bodies"][1]["material"] = material
    with pytest.warns(PlausibilityWarning) as caught:
        vfrs.Scene.from_dict(d)
    messages = [str(w.message) for w in caught]
    assert any(m.startswith(f"<dict>: {key}: ") and slip in m for m in messages), messages


def test_a_zero_fibre_stiffness_and_pressure_are_choices_not_slips():
    d = quiet_load(EXAMPLES / "m5_loud.toml").to_dict()
    for b in d["bodies"]:
        b["material"]["k1"] = 0.0  # no fibres
    d["flow"]["subglottal_pressure"] = 0.0  # flow off
    assert quiet_load(d).plausibility == []


@pytest.mark.parametrize("path", sorted(EXAMPLES.glob("*.toml")), ids=lambda p: p.name)
def test_every_example_scene_loads_without_a_plausibility_warning(path):
    scene = quiet_load(path)
    assert scene.plausibility == []


def test_the_main_job_and_the_loud_pressure_are_plausible():
    """The main job (m5_collision.toml, 0.8 kPa) and the loudest shipped pressure (3 kPa)."""
    for name in ("m5_collision.toml", "m5_loud.toml"):
        assert quiet_load(EXAMPLES / name).plausibility == []


def test_a_scene_that_is_no_vocal_fold_scene_is_not_checked():
    """Steel blocks (E = 200 GPa, rho = 7850 kg/m^3) a metre long: no fold, no flow, no word."""
    d = {"bodies": [{"name": "steel", "mesh": {"builtin": "box", "size": [1.0, 0.1, 0.1], "cells": [4, 1, 1]},
                     "material": {"model": "isotropic", "E": 200e9, "nu": 0.3, "rho": 7850.0},
                     "fixed": ["xmin"]}],
         "time": {"mode": "static"}}
    assert quiet_load(d).plausibility == []
    d["bodies"][0]["material"]["rho"] = 1.0
    assert quiet_load(d).plausibility == []


def test_a_fold_mesh_file_in_mm_read_as_metres_warns_once_built(tmp_path):
    """Two 10 x 10 x 5 (mm) blocks driven by [flow], read with length_unit = "m": 10 m
    across, once the meshes are built, with the length_unit that fits."""
    d = {"bodies": [{"name": n, "mesh": {"path": str(DATA / f), "length_unit": "m"},
                     "material": {"model": "vocal_fold"}, "fixed": ["bottom"]}
                    for n, f in (("right", "block_a.msh"), ("left", "block_b.msh"))],
         "flow": {"subglottal_pressure": 800.0, "bodies": ["right", "left"]},
         "time": {"step": 1e-4, "end": 1e-3}}
    scene = quiet_load(d)  # the file's sizes are unknown at load
    with pytest.warns(PlausibilityWarning) as caught:
        scene.build_meshes()
    msg = str(caught[0].message)
    assert msg.startswith("<dict>: bodies[0].mesh.length_unit: the mesh of body 'right' (block_a.msh, length_unit = 'm') "
                          "is 10 m across")
    assert "did you mean length_unit = 'mm' (10 mm = 0.01 m)?" in msg
    d["bodies"][0]["mesh"]["length_unit"] = d["bodies"][1]["mesh"]["length_unit"] = "mm"
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlausibilityWarning)
        vfrs.Scene.from_dict(d).build_meshes()


def test_the_run_writes_the_warning_to_run_log(tmp_path):
    """A static coarse fold of density 1.0 (g/cm^3 typed for kg/m^3): warned at load and
    the same line in run.log."""
    d = {"bodies": [{"name": "right", "mesh": {"builtin": "m5", "resolution": "coarse"},
                     "material": {"model": "vocal_fold", "rho": 1.0},
                     "fixed": ["lateral", "anterior", "posterior"]}],
         "time": {"mode": "static"}}
    with pytest.warns(PlausibilityWarning) as caught:
        scene = vfrs.Scene.from_dict(d)
    vfrs.run(scene, out=tmp_path / "out", progress=False)
    log = (tmp_path / "out" / "run.log").read_text()
    assert f"PlausibilityWarning: {caught[0].message}" in log
    assert "bodies[0].material.rho: rho = 1 kg/m^3" in log


@pytest.mark.filterwarnings("always::vfrs.errors.PlausibilityWarning")
def test_the_command_line_prints_a_warning_as_one_line(tmp_path, capsys):
    """`vfrs info` on the 14 m folds: each warning is one 'vfrs: warning: ...' line, without
    the console script's file and source line ('bin/vfrs:8: ... sys.exit(main())' before)."""
    from vfrs.cli import main

    assert main(["info", str(write(tmp_path, length="14"))]) == 0
    err = capsys.readouterr().err.splitlines()
    lines = [s for s in err if "PlausibilityWarning" in s]
    assert lines and all(s.startswith("vfrs: warning: PlausibilityWarning: ") for s in lines), err
    assert not any("sys.exit" in s or "warnings.warn" in s for s in err), err


def _main_job(*sets):
    """The main job, coarse, one step (setup is what is checked), with ``sets`` (--set)."""
    from vfrs.cli import load_scene

    base = ["bodies[0].mesh.resolution='coarse'", "bodies[1].mesh.resolution='coarse'", "time.end=50e-6"]
    return load_scene(str(EXAMPLES / "m5_collision.toml"), [*base, *sets])


@pytest.mark.parametrize("fixed, free, holds", [
    ("[]", 6, "fixed = [] holds none"),
    ("[{ surface = 'lateral', components = ['x'] }]", 3, "its 189 fixed DOFs hold 3")])  # rollers: x, rot y, rot z
def test_a_fold_without_support_warns_at_setup_naming_the_body(tmp_path, fixed, free, holds):
    """The main job with the right fold's supports taken away (issue 43: it drifted away, the
    glottal area 1.4 -> 8.5 mm^2 and the summary's cycle measures n/a): warned when the run
    sets up, naming the body, what holds it (nothing else: no springs; contact only pushes)
    and how to fix it; once, in run.log too. The left fold, clamped on three faces, gets none."""
    scene = _main_job(f"bodies[0].fixed={fixed}")
    assert scene.plausibility == []  # the supports are known once the problem is built
    with pytest.warns(PlausibilityWarning) as caught:
        vfrs.run(scene, out=tmp_path / "out", progress=False)
    # (the main job's medium mesh also gets a ResolutionWarning about its 1 mm^2 sensor disc)
    (msg,) = [str(w.message) for w in caught if issubclass(w.category, PlausibilityWarning)]
    assert msg.startswith(f"{EXAMPLES / 'm5_collision.toml'}: bodies[0].fixed: body 'right' can move as a rigid body: "
                          f"{free} of its 6 rigid-body motions are free ({holds}) and nothing else resists them "
                          "(vfrs has no spring supports; contact only pushes it back, it does not hold it), so the "
                          "flow will carry it away")
    assert 'fix its lateral wall: fixed = ["lateral"]' in msg and "'left'" not in msg
    assert (tmp_path / "out" / "run.log").read_text().count(f"PlausibilityWarning: {msg}") == 1


def test_supported_folds_set_up_without_a_word_and_strict_refuses_a_loose_one():
    with warnings.catch_warnings():
        warnings.simplefilter("error", PlausibilityWarning)
        vfrs.run(_main_job(), progress=False)
    with pytest.raises(PlausibilityError, match=r"bodies\[1\]\.fixed: body 'left' can move as a rigid body: .*an "
                                                r"error because \[checks\] strict = true"):
        vfrs.run(_main_job("bodies[1].fixed=[]", "checks.strict=true"), progress=False)
