"""Material parameters: elasticity matrices and admissibility checks."""

import numpy as np
import pytest

import vfrs


def test_isotropic_elasticity_matches_lame():
    E, nu = 10e3, 0.45
    D = vfrs.Isotropic(E=E, nu=nu).elasticity()
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    assert D[0, 0] == pytest.approx(lam + 2 * mu, rel=1e-14)
    assert D[0, 1] == pytest.approx(lam, rel=1e-14)
    assert D[5, 5] == pytest.approx(mu, rel=1e-14)


def test_transversely_isotropic_compliance_is_the_stated_one():
    m = vfrs.TransverselyIsotropic(E_p=2e3, E_z=40e3, nu_p=0.9, nu_pz=0.02, G_pz=10e3)
    S = np.linalg.inv(m.elasticity())
    assert 1 / S[0, 0] == pytest.approx(2e3, rel=1e-12)
    assert 1 / S[2, 2] == pytest.approx(40e3, rel=1e-12)
    assert -S[2, 0] * 2e3 == pytest.approx(0.02, rel=1e-12)  # nu_pz = -S31 E_p
    assert -S[0, 1] * 2e3 == pytest.approx(0.9, rel=1e-12)
    assert 1 / S[3, 3] == pytest.approx(10e3, rel=1e-12)
    assert 1 / S[5, 5] == pytest.approx(2e3 / (2 * 1.9), rel=1e-12)
    assert np.linalg.eigvalsh(m.elasticity()).min() > 0


@pytest.mark.parametrize(
    "make, message",
    [
        (lambda: vfrs.Isotropic(E=-1.0, nu=0.3), r"E = -1 must be positive"),
        (lambda: vfrs.Isotropic(E=1.0, nu=0.5), r"nu = 0.5 is out of range"),
        (lambda: vfrs.Isotropic(E=1.0, nu=0.3, rho=0.0), r"density rho = 0.0"),
        (lambda: vfrs.TransverselyIsotropic(E_p=1e3, E_z=1e5, nu_p=0.3, nu_pz=0.3, G_pz=1e3), r"not positive definite.*lower nu_pz"),
        (lambda: vfrs.TransverselyIsotropic(E_p=1e3, E_z=1e3, nu_p=1.2, nu_pz=0.0, G_pz=1e3), r"nu_p = 1.2"),
        (lambda: vfrs.TransverselyIsotropic(E_p=1e3, E_z=1e3, nu_p=0.3, nu_pz=0.0, G_pz=1e3, axis=(0, 0, 0)), r"fibre axis"),
        (lambda: vfrs.material_from_dict({"model": "mooney_rivlin", "E": 1.0}), r"unknown material model 'mooney_rivlin'"),
    ],
)
def test_inadmissible_parameters_raise(make, message):
    with pytest.raises(vfrs.MaterialError, match=message):
        make()


def test_registry_round_trip():
    m = vfrs.TransverselyIsotropic(E_p=2e3, E_z=40e3, nu_p=0.9, nu_pz=0.0, G_pz=10e3, rho=1040)
    assert vfrs.material_from_dict(m.to_dict()) == m
    assert set(vfrs.MATERIALS) == {"isotropic", "transversely_isotropic", "vocal_fold", "neo_hookean",
                                  "st_venant_kirchhoff", "fibre_reinforced"}
    v = vfrs.VocalFold(G_pz=40e3)
    assert vfrs.material_from_dict(v.to_dict()) == v
    assert np.array_equal(
        v.elasticity(), vfrs.TransverselyIsotropic(E_p=2e3, E_z=40e3, nu_p=0.9, nu_pz=0.0, G_pz=40e3).elasticity()
    )


def test_near_incompressibility_warns_with_the_locking_factor():
    with pytest.warns(vfrs.VfrsWarning, match=r"close to 0.5: linear tetrahedra lock.*1/\(1 - 2 nu\) = 500"):
        vfrs.Isotropic(E=1.0, nu=0.499)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        vfrs.Isotropic(E=1.0, nu=0.45)  # the tissue default: no warning


# ---- the registry: a material's fields are its typed parameters ---------------------------
def material_scene(material):
    return {"bodies": [{"name": "b", "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [1, 1, 1]},
                        "material": material, "fixed": ["zmin"]}],
            "time": {"mode": "static"}}


def test_a_missing_required_parameter_is_named_with_its_key_path():
    m = {"model": "transversely_isotropic", "E_p": 2e3, "E_z": 40e3, "nu_p": 0.9, "nu_pz": 0.0}
    with pytest.raises(vfrs.SceneError, match=r"<dict>: bodies\[0\]\.material\.G_pz: missing; expected a number"):
        vfrs.Scene.from_dict(material_scene(m))
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.material\.E: expected a number \(Young's modulus, Pa\), got a string"):
        vfrs.Scene.from_dict(material_scene({"model": "isotropic", "E": "soft", "nu": 0.3}))
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.material\.axis: expected an array of 3 finite numbers"):
        vfrs.Scene.from_dict(material_scene({"model": "vocal_fold", "axis": [0, 1]}))


def test_a_registered_material_class_is_usable_from_a_scene_without_touching_another_file():
    from dataclasses import dataclass
    from typing import ClassVar

    from vfrs.materials import Material, register_material, unregister_material
    from vfrs.params import param

    @register_material
    @dataclass(frozen=True)
    class Stiffened(Material):
        """Isotropic, with E scaled by a factor (a throwaway test material)."""

        name: ClassVar[str] = "test_stiffened"
        E: float = param(doc="Young's modulus", unit="Pa", positive=True)
        factor: float = param(2.0, doc="stiffening factor", positive=True)
        nu: float = param(0.3, doc="Poisson's ratio")
        rho: float = param(1000.0, doc="density", unit="kg/m^3", positive=True)

        def elasticity(self):
            return vfrs.Isotropic(E=self.E * self.factor, nu=self.nu, rho=self.rho).elasticity()

    try:
        assert "test_stiffened" in vfrs.MATERIALS
        s = vfrs.Scene.from_dict(material_scene({"model": "test_stiffened", "E": 1e3}))
        assert s.bodies[0].material == Stiffened(E=1e3)
        d = s.to_dict()
        assert d["bodies"][0]["material"] == {"model": "test_stiffened", "E": 1e3, "factor": 2.0, "nu": 0.3, "rho": 1000.0}
        assert vfrs.Scene.from_dict(d).to_dict() == d
        assert vfrs.material_from_dict(d["bodies"][0]["material"]) == Stiffened(E=1e3)
        with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.material\.factor: expected a positive number \(stiffening factor\)"):
            vfrs.Scene.from_dict(material_scene({"model": "test_stiffened", "E": 1e3, "factor": 0.0}))
        K = vfrs.stiffness(s.build_meshes()[0], s.bodies[0].material)
        K_iso = vfrs.stiffness(s.build_meshes()[0], vfrs.Isotropic(E=2e3, nu=0.3, rho=1000.0))
        assert abs(K - K_iso).max() == 0.0
    finally:
        unregister_material("test_stiffened")
    assert set(vfrs.MATERIALS) == {"isotropic", "transversely_isotropic", "vocal_fold", "neo_hookean",
                                  "st_venant_kirchhoff", "fibre_reinforced"}
    with pytest.raises(vfrs.SceneError, match=r"bodies\[0\]\.material\.model: 'test_stiffened' is not one of"):
        vfrs.Scene.from_dict(material_scene({"model": "test_stiffened", "E": 1e3}))


def test_register_material_refuses_incomplete_classes():
    from dataclasses import dataclass
    from typing import ClassVar

    from vfrs.materials import Material, register_material
    from vfrs.params import param

    with pytest.raises(TypeError, match="needs its own class attribute `name`"):
        @register_material
        @dataclass(frozen=True)
        class Nameless(vfrs.Isotropic):  # would silently replace 'isotropic'
            pass

    with pytest.raises(TypeError, match="a scene cannot read type"):
        @register_material
        @dataclass(frozen=True)
        class Odd(Material):
            name: ClassVar[str] = "test_odd"
            E: dict = param(doc="Young's modulus")

            def elasticity(self):
                raise AssertionError

    with pytest.raises(ValueError, match="'isotropic' is already registered"):
        @register_material
        @dataclass(frozen=True)
        class Other(Material):
            name: ClassVar[str] = "isotropic"
            E: float = param()

            def elasticity(self):
                raise AssertionError
    assert vfrs.MATERIALS["isotropic"] is vfrs.Isotropic
