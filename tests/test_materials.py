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
        (lambda: vfrs.material_from_dict({"model": "neo_hookean", "E": 1.0}), r"unknown material model 'neo_hookean'"),
    ],
)
def test_inadmissible_parameters_raise(make, message):
    with pytest.raises(vfrs.MaterialError, match=message):
        make()


def test_registry_round_trip():
    m = vfrs.TransverselyIsotropic(E_p=2e3, E_z=40e3, nu_p=0.9, nu_pz=0.0, G_pz=10e3, rho=1040)
    assert vfrs.material_from_dict(m.to_dict()) == m
    assert set(vfrs.MATERIALS) == {"isotropic", "transversely_isotropic", "vocal_fold"}
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
