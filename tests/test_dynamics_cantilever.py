"""A cantilever in free vibration: the period of the run against eigsh and Euler-Bernoulli.

The beam is L x 2t x t (thin along z), so its first mode is bending in z, well separated
from bending in y (a square section has two nearly equal modes whose beat spoils a period
measurement). A tip traction along -z applied suddenly at t = 0 makes the tip swing about its
static deflection; the period is a least-squares sinusoid fit to the tip displacement.
nu = 0 so that the 3-D beam is an Euler-Bernoulli beam up to shear and rotary inertia
(about (t/L)^2 = 1 %).
"""

import numpy as np
import pytest
import scipy.sparse.linalg as sla
from scipy.optimize import least_squares

import vfrs

L, T_Z, E, RHO = 0.1, 0.01, 1e6, 1000.0
F_EB = 1.8751040687**2 / (2 * np.pi * L**2) * np.sqrt(E * T_Z**2 / (12 * RHO))  # first mode, Hz
TIP = [L, T_Z, T_Z / 2]


def scene(cells, alpha=-0.05, periods=3.0, steps_per_period=60):
    period = 1.0 / F_EB
    return vfrs.Scene.from_dict({
        "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [L, 2 * T_Z, T_Z], "cells": list(cells)},
                    "material": {"model": "isotropic", "E": E, "nu": 0.0, "rho": RHO},
                    "fixed": ["xmin"],
                    "loads": [{"type": "traction", "surface": "xmax", "value": [0.0, 0.0, -10.0]}]}],
        "time": {"mode": "dynamic", "step": period / steps_per_period, "end": periods * period, "alpha": alpha},
        "output": {"every": 10**6, "probes": [TIP], "energy": False, "reactions": False}})


def fitted_period(t, z):
    """Period of c + A cos(w t) + B sin(w t) fitted to z; w starts at the FFT peak."""
    s = z - z.mean()
    n = 16 * len(s)
    f = np.fft.rfftfreq(n, t[1] - t[0])
    w0 = 2 * np.pi * f[np.argmax(np.abs(np.fft.rfft(s, n))[1:]) + 1]

    def residual(p):
        c, A, B, w = p
        return c + A * np.cos(w * t) + B * np.sin(w * t) - z

    return 2 * np.pi / least_squares(residual, [z.mean(), -np.ptp(z) / 2, 0.0, w0], x_scale="jac").x[3]


def first_frequency(problem):
    w2 = sla.eigsh(problem.K_free, k=1, M=problem.M_free, sigma=0, which="LM")[0][0]
    return np.sqrt(w2) / (2 * np.pi)


def run_period(cells):
    res = vfrs.run(scene(cells), progress=False)
    p = res.probe(TIP)
    return fitted_period(p["t"], p["displacement"][:, 2]), res.problem


def test_period_matches_eigsh_on_the_same_mesh():
    period, problem = run_period((20, 4, 2))
    f_fe = first_frequency(problem)
    # Required: 3 %. HHT-alpha's own period error at h w = 2 pi / 60 is about 0.1 %.
    assert period * f_fe == pytest.approx(1.0, rel=5e-3)


def test_period_matches_euler_bernoulli_on_a_fine_mesh():
    period, problem = run_period((80, 2, 8))
    assert period * F_EB == pytest.approx(1.0, rel=0.03)
    assert period * first_frequency(problem) == pytest.approx(1.0, rel=5e-3)


def test_first_frequency_converges_to_euler_bernoulli_at_second_order():
    # Linear tetrahedra are too stiff in bending; the error shrinks like h^2 (fitted slope).
    errors, sizes = [], []
    for n in (1, 2, 4):
        mesh = vfrs.meshes.box((L, 2 * T_Z, T_Z), (20 * n, 2, 2 * n))
        problem = vfrs.dynamics.build_problem(scene((20 * n, 2, 2 * n)), [mesh])
        errors.append(first_frequency(problem) / F_EB - 1)
        sizes.append(1.0 / n)
    assert all(e > 0 for e in errors)  # stiff from above
    slope = np.polyfit(np.log(sizes), np.log(errors), 1)[0]
    assert 1.6 < slope < 2.4, (errors, slope)
