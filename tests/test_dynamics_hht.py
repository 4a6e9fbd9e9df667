"""HHT-alpha against its closed form: algorithmic damping and period error of one mode, energy.

The reference is the amplification matrix of HHT-alpha for x'' + w^2 x = 0, built here from the
defining equations (not from the K_eff form the integrator uses); its principal eigenvalue pair
rho exp(+-i theta) gives the algorithmic damping ratio -ln(rho)/theta and the period ratio
(h w)/theta. The run is a finite-element cantilever started in its first eigenmode, so the
modal coordinate phi^T M u follows that recurrence exactly.
"""

import numpy as np
import pytest
import scipy.sparse.linalg as sla

import vfrs
from vfrs.dynamics import HHTAlpha, build_problem


def amplification(alpha, Omega):
    """Exact one-step map of (u, h v, h^2 a) for x'' + w^2 x = 0, h w = Omega."""
    beta, gamma = (1 - alpha) ** 2 / 4, 0.5 - alpha
    W2 = Omega**2
    # Unknowns X1 = (u1, h v1, h^2 a1); equations, in units where h = 1:
    #   a1 + (1+alpha) W2 u1 - alpha W2 u0 = 0
    #   u1 - beta a1 = u0 + v0 + (1/2 - beta) a0
    #   v1 - gamma a1 = v0 + (1 - gamma) a0
    L = np.array([[(1 + alpha) * W2, 0, 1], [1, 0, -beta], [0, 1, -gamma]])
    R = np.array([[alpha * W2, 0, 0], [1, 1, 0.5 - beta], [0, 1, 1 - gamma]])
    return np.linalg.solve(L, R)


def closed_form(alpha, Omega):
    lam = np.linalg.eigvals(amplification(alpha, Omega))
    principal = lam[np.argmax(np.abs(lam.imag))]
    rho, theta = abs(principal), abs(np.angle(principal))
    return -np.log(rho) / theta, Omega / theta  # damping ratio, period ratio T_bar / T


def fitted(x):
    """rho, theta of x_n = c rho^n cos(n theta + phi) by linear prediction (least squares)."""
    A = np.column_stack([x[1:-1], x[:-2]])
    c1, c2 = np.linalg.lstsq(A, x[2:], rcond=None)[0]
    rho = np.sqrt(-c2)
    theta = np.arccos(c1 / (2 * rho))
    return rho, theta


@pytest.fixture(scope="module")
def cantilever():
    mesh = vfrs.meshes.box((0.02, 0.004, 0.004), (10, 2, 2))
    scene = vfrs.Scene.from_dict({
        "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [0.02, 0.004, 0.004], "cells": [10, 2, 2]},
                    "material": {"model": "isotropic", "E": 10e3, "nu": 0.45, "rho": 1070.0},
                    "fixed": ["xmin"]}],
        "time": {"mode": "dynamic", "step": 1e-3, "end": 1e-2}})
    p = build_problem(scene, [mesh])
    w2, phi = sla.eigsh(p.K_free, k=1, M=p.M_free, sigma=0, which="LM", tol=1e-14)
    phi = phi[:, 0] / np.sqrt(phi[:, 0] @ (p.M_free @ phi[:, 0]))
    return p, float(np.sqrt(w2[0])), phi


@pytest.mark.parametrize("alpha", [0.0, -0.05, -0.1, -0.3, -1 / 3])
@pytest.mark.parametrize("Omega", [0.05, 0.3, 1.0])
def test_single_mode_damping_and_period_match_closed_form(cantilever, alpha, Omega):
    p, w, phi = cantilever
    hht = HHTAlpha(p.M_free, p.K_free, step=Omega / w, alpha=alpha)
    u, v, a = phi.copy(), np.zeros_like(phi), -(w**2) * phi
    x = []
    Mphi = p.M_free @ phi
    for _ in range(160):
        hht.step(u, v, a, np.zeros_like(u), np.zeros_like(u))
        x.append(Mphi @ u)
    rho, theta = fitted(np.array(x[40:]))  # after the spurious root has died out
    xi, period = -np.log(rho) / theta, Omega / theta
    xi_ref, period_ref = closed_form(alpha, Omega)
    assert period == pytest.approx(period_ref, rel=1e-3)
    if alpha == 0.0:
        assert abs(xi) < 1e-9  # trapezoidal rule: no algorithmic damping
    else:
        assert xi == pytest.approx(xi_ref, rel=1e-3)
    # The closed form behaves as the literature says (Hilber, Hughes & Taylor 1977): the
    # damping of well-resolved modes is of third order in h w, so low modes are barely touched.
    if Omega == 0.05 and alpha < 0:
        assert closed_form(alpha, 0.1)[0] / xi_ref == pytest.approx(8.0, rel=0.05)


def test_alpha_zero_conserves_energy_over_1000_steps():
    scene = vfrs.Scene.from_dict({
        "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [0.02, 0.004, 0.004], "cells": [8, 2, 2]},
                    "material": {"model": "isotropic", "E": 10e3, "nu": 0.45, "rho": 1070.0},
                    "velocity": [0.0, 0.01, -0.02], "fixed": ["xmin"]}],
        "time": {"mode": "dynamic", "step": 2e-3, "end": 2.0, "alpha": 0.0},
        "output": {"every": 1000}})
    res = vfrs.run(scene, progress=False)
    E = res.history["kinetic_energy"] + res.history["elastic_energy"]
    assert len(E) == 1001
    assert E[0] > 0 and res.history["elastic_energy"].max() > 0.3 * E[0]
    assert np.abs(E / E[0] - 1).max() < 1e-10


def test_alpha_zero_energy_equals_work_of_a_sudden_load():
    # Trapezoidal rule with a load: kinetic + elastic = work of the load, step by step.
    scene = vfrs.Scene.load("examples/cantilever.toml").to_dict()
    scene["bodies"][0]["damping"] = {"a0": 0.0, "a1": 0.0}
    scene["time"].update(alpha=0.0, end=0.05)
    res = vfrs.run(vfrs.Scene.from_dict(scene), progress=False)
    h = res.history
    E = h["kinetic_energy"] + h["elastic_energy"]
    assert h["external_work"][-1] > 0
    np.testing.assert_allclose(E, h["external_work"], rtol=1e-9, atol=1e-12 * E.max())


@pytest.mark.parametrize("alpha", [-0.1, -0.3])
def test_negative_alpha_only_dissipates(alpha):
    scene = vfrs.Scene.from_dict({
        "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [0.02, 0.004, 0.004], "cells": [8, 2, 2]},
                    "material": {"model": "isotropic", "E": 10e3, "nu": 0.45, "rho": 1070.0},
                    "velocity": [0.0, 0.0, -0.02], "fixed": ["xmin"]}],
        "time": {"mode": "dynamic", "step": 2e-3, "end": 0.4, "alpha": alpha},
        "output": {"every": 1000}})
    E = vfrs.run(scene, progress=False).history
    E = E["kinetic_energy"] + E["elastic_energy"]
    assert E[-1] < 0.95 * E[0]
    # HHT-alpha's energy is not monotone step by step (it damps through the alpha-weighted
    # balance), but it never rises above its start.
    assert E.max() <= E[0] * (1 + 1e-12)


def test_rejects_alpha_outside_range():
    import scipy.sparse as sp

    with pytest.raises(vfrs.SolverError, match=r"alpha = -0.5 must be in \[-1/3, 0\]"):
        HHTAlpha(sp.eye(2, format="csr"), sp.eye(2, format="csr"), step=0.1, alpha=-0.5)
