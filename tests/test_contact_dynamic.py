"""Dynamic contact schemes against closed forms (``[contact] scheme``).

Every scene here names its ``scheme`` (the default is mass_redistribution since 15af481).
Five problems:

1. two bars colliding (the bars of ``test_contact_conservation``): the recorded contact force
   against the plateau F0 = A rho c v0 / 2 of the 1-D wave solution, for 2L/c: with
   ``mass_redistribution`` its peak stays bounded and its L1 error does not grow as the step
   falls, and it falls as the mesh refines; the ``stabilized`` scheme's peak grows (contrast);
2. a bar dropped on a rigid plane under gravity: the first benchmark of Doyen, Ern & Piperno
   (2011), contact stress and contact duration of both impacts of one bounce period;
3. a ball striking a rigid plane: Hertz impact theory (peak force and duration within 5 %)
   on the graded unstructured quarter ball ``tests/data/sphere_quarter.msh`` (rollers on its
   cut planes, v = 0.01 m/s, t_c/50 to t_c/200, alpha = 0 and -0.3); the energy, impulse and
   convergence in h of the whole ball ``tests/data/sphere.msh`` at 0.1 m/s;
4. two unstructured, non-matching spheres colliding (``sphere.msh``, ``sphere_upper.msh``):
   the LCP settles, the energy, impulse = momentum per body, every method, both detectors;
5. penalty at kappa up to 1e12 Pa/m, several steps: no energy gain.

Energies: ``kinetic_energy + elastic_energy`` from the history (t = 0 included), asserted as
max(E) <= E0 (1 + 1e-6). mass_redistribution gives back, at the end of a step, energy its
contact made in that step (history ``contact_energy_corrected``, J); the energy tests also
bound what it took back, over E0, and how it falls with h. Impulse = momentum: h x the
recorded contact force summed over the run against the change of 1^T M v per body
(:func:`impulse_momentum`). Where a scheme fails a bound, the test is
``xfail(strict=True)`` with the measured number: the bound stays, the defect is on record
(none now). Run with ``-s`` to see the tables.

What this file costs: docs/performance.md, "Measurements behind the code's choices". Runs
are cached per session (``functools.lru_cache``) and shared between tests: the xfail tests
and the checks against the next coarser step reuse the runs of the tests beside them.
"""

from __future__ import annotations

import functools
import os

import numpy as np
import pytest
from scipy.integrate import quad, trapezoid

import vfrs
from vfrs.enforcement import DETECTORS, METHODS
from test_contact_conservation import C, E0, GAP, L, MESHES, RHO, S, V0, bars_scene

slow = pytest.mark.slow
MR = "mass_redistribution"
DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data")
ENERGY_TOL = 1e-6  # max(E) <= E0 (1 + ENERGY_TOL)

#: The Hertz impact-duration constant: t_c = 2 HERTZ_I delta_max / v, HERTZ_I = int_0^1
#: dx / sqrt(1 - x^(5/2)) = 1.4716 (Johnson 1985, section 11.4: t_c = 2.94 delta_max / v).
HERTZ_I = quad(lambda x: 1.0 / np.sqrt(1.0 - x**2.5), 0.0, 1.0)[0]


def corrected(hs, scale) -> float | None:
    """What mass_redistribution's energy correction took back over the run (history
    ``contact_energy_corrected``, J, cumulative) over ``scale`` (J); None for another scheme."""
    c = hs.get("contact_energy_corrected")
    return None if c is None else float(c[-1] / scale)


def impulse_momentum(r) -> float:
    """Impulse = momentum, per body: the largest difference, over bodies and components, between
    h x the sum of the recorded contact force (``contact_force.<body>``: the step's impulse / h)
    and the body's momentum change 1^T M (v_end - v_0) (M the problem's mass, i.e. the
    redistributed one; v_0 the body's initial velocity, zero on its fixed DOFs), over the
    largest initial momentum |1^T M v_0| of a body. Components along which a body has a fixed
    DOF are left out (its support's reaction changes the momentum too)."""
    h, hs = r.scene.time.step, r.history
    M = r.problem.M.tocsr()
    v1 = np.asarray(r.v, dtype=float).ravel()
    fixed = np.zeros(r.problem.n_dofs, dtype=bool)
    fixed[np.asarray(r.problem.fixed, dtype=np.int64)] = True
    errors, scale = [], 0.0
    for part, body in zip(r.problem.bodies, r.scene.bodies):
        s = part.dofs
        v0 = np.tile(np.asarray(body.velocity, dtype=float), part.n_points)
        v0[fixed[s]] = 0.0
        Mb = M[s, s]
        p0, dp = Mb @ v0, Mb @ (v1[s] - v0)
        scale = max(scale, float(np.linalg.norm([p0[k::3].sum() for k in range(3)])))
        J = h * hs[f"contact_force.{part.name}"].sum(axis=0)
        for k in range(3):
            if not fixed[s][k::3].any():
                errors.append(abs(J[k] - dp[k::3].sum()))
    return max(errors) / scale


def contact_runs(t, on, h):
    """The contact intervals of a per-step history: runs of consecutive steps with ``on``;
    a step n stands for (t_n - h, t_n]. Returns [(start, end)], start = t_first - h."""
    idx = np.flatnonzero(on)
    if not idx.size:
        return []
    runs = np.split(idx, np.flatnonzero(np.diff(idx) > 1) + 1)
    return [(t[r[0]] - h, t[r[-1]]) for r in runs]


# =============================================================================================
# 1. Two bars: the recorded force history against the plateau F0 for 2L/c
# =============================================================================================
F0 = RHO * C * S * S * V0 / 2  # N: the contact force of the 1-D wave solution while the bars touch
T0 = GAP / V0  # s, the bars touch
TD = 2 * L / C  # s, the contact lasts 2L/c
BARS_END = T0 + 2.3 * L / C  # the bars part at T0 + 2L/c (+ 1-2 % on 40 cells)
STEPS = (1.0, 2.0, 4.0, 8.0)  # substeps: h = L / (n c) / substeps (1 = one cell transit)
KAPPA_STIFF = {"penalty": 1e12, "augmented_lagrange": 1e9, "penalty_volume": 1e13}
#: Every registered method that applies forces with every detector it can use (from the
#: registries: today penalty_volume with the interface mesh only).
BAR_CASES = [(m, d) for m in sorted(METHODS) if METHODS[m].applies_forces
             for d in sorted(DETECTORS) if METHODS[m].detections is None or d in METHODS[m].detections]


def bars(method, mesh="matching", scheme=MR, substeps=1.0, n=40, detection="bvh", kappa=None, alpha=0.0,
         precision=None) -> dict:
    """Run the two bars of ``test_contact_conservation`` (lumped mass, y and z held: a 1-D bar,
    E = 1e4 Pa, rho = 1000, L = 0.1 m, v0 = 0.1 m/s) until T0 + 2.3 L/c under ``scheme`` and
    return what the tests measure (:func:`bar_history`); each run once per session."""
    if method in KAPPA_STIFF and kappa is None:
        kappa = KAPPA_STIFF[method]
    return _bars(method, mesh, scheme, float(substeps), n, detection, kappa, alpha, precision)


@functools.lru_cache(maxsize=None)
def _bars(method, mesh, scheme, substeps, n, detection, kappa, alpha, precision=None) -> dict:
    d = bars_scene(method, *MESHES[mesh], alpha=alpha, n=n, substeps=substeps, detection=detection)
    d["contact"].pop("stabilized")
    d["contact"]["scheme"] = scheme
    if kappa is not None:
        d["contact"]["kappa"] = kappa
    if precision is not None:  # [contact] column_precision (tests/test_single_precision_columns.py)
        d["contact"]["column_precision"] = precision
    d["time"]["end"] = BARS_END
    r = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
    return {**bar_history(r), "momentum": impulse_momentum(r)}


def bar_history(r) -> dict:
    """Peak / F0, the L1 error, E_max / E0 and whether the bars parted, from the recorded
    force on bar b (``contact_force.b``, x).

    The recorded F_n is the impulse of step (t_n - h, t_n] over h; the exact force is F0 on
    [T0, T0 + 2L/c] and 0 elsewhere; the L1 error is the exact integral of |F - F_exact| over
    time with F piecewise constant per step (a step that straddles a jump of F_exact counts
    |F_n - F0| on one part and |F_n| on the other), over F0 2L/c. (Comparing F_n with
    F_exact(t_n) instead gives 0.039 / 0.035 / 0.032 at h = 1, 1/2, 1/4 cell transits on the
    matching bars: the numbers first measured.)"""
    h, hs = r.scene.time.step, r.history
    t, F = hs["t"], hs["contact_force.b"][:, 0]
    lo, hi = np.clip(t - h, T0, T0 + TD), np.clip(t, T0, T0 + TD)
    f = (hi - lo) / h  # the share of step n inside the plateau
    l1 = float(np.sum(f * np.abs(F - F0) + (1 - f) * np.abs(F)) * h / (F0 * TD))
    energy = (hs["kinetic_energy"] + hs["elastic_energy"]) / E0
    return {"peak": float(F.max() / F0), "l1": l1, "E_max": float(energy.max()), "parted": bool(F[-1] == 0.0),
            "corrected": corrected(hs, E0)}


def _bar_params():
    out = []
    for method, detection in BAR_CASES:
        for mesh in ("matching", "4x4-3x3"):
            quick = (method, detection, mesh) == ("lagrange", "bvh", "4x4-3x3")
            out.append(pytest.param(method, detection, mesh, marks=[] if quick else [slow],
                                    id=f"{method}-{detection}-{mesh}"))
    return out


@pytest.mark.parametrize("method,detection,mesh", _bar_params())
def test_bars_force_history_as_h_falls(method, detection, mesh):
    """mass_redistribution, 40 cells per bar, h = 1, 1/2, 1/4, 1/8 cell transits L/(40 c),
    every method (penalty kappa 1e12 Pa/m, Uzawa 1e9, penalty_volume 1e13 N/m^3) and
    detector: peak <= 1.4 F0 at every h; L1 error <= 0.045 at every h and not growing as h
    falls (each within 2e-4 of the one before, or below it); energy never above E0
    (1 + 1e-6); the bars part; what mass_redistribution's energy correction took back (pairs
    releasing within a step) at most 5e-4 E0 at every h, and at h/8 at most a quarter of what
    it took at one cell transit.

    Measured (E_max / E0 - 1 at most 3.3e-14 everywhere; the same before the correction). Taken
    back (contact_energy_corrected / E0) at h = 1, 1/2, 1/4, 1/8 cell transits: 2.6e-4 to
    2.9e-4 / 2.7e-5 to 5.8e-5 / 3.2e-5 to 6.3e-5 / 2.4e-6 to 3.5e-5 over the 14 cases (Lagrange,
    BVH: 2.7e-4 / 4.0e-5 / 3.3e-5 / 6.3e-6 matching, 2.9e-4 / 5.0e-5 / 5.5e-5 / 2.6e-5 4x4-3x3;
    the largest at h/8, 3.5e-5, is Uzawa, BVH, 4x4-3x3): not round-off, it falls from h to
    h/2 and h/8 but not from h/2 to h/4 (up to +15 %). The closest bound: 2.9e-4 of 5e-4.

    ==================================  ==============================  ==============================
    method, detector                    matching: peak / F0; L1         4x4-3x3: peak / F0; L1
    ==================================  ==============================  ==============================
    lagrange, bvh                       1.324 1.310 1.309 1.306;        1.338 1.325 1.325 1.322;
                                        .0421 .0341 .0320 .0319         .0427 .0344 .0322 .0321
    lagrange, interface_mesh            1.324 1.310 1.309 1.306;        1.338 1.324 1.325 1.322;
                                        .0417 .0336 .0315 .0314         .0422 .0338 .0315 .0314
    penalty 1e12, bvh                   as lagrange, bvh (to 1e-4)      as lagrange, bvh (to 1e-4)
    penalty 1e12, interface_mesh        as lagrange, interface_mesh     as lagrange, interface_mesh
    augmented_lagrange 1e9, bvh         1.324 1.310 1.309 1.306;        1.338 1.325 1.325 1.322;
                                        .0421 .0341 .0320 .0319         .0426 .0343 .0321 .0320
    augmented_lagrange, interface_mesh  1.324 1.310 1.309 1.306;        1.338 1.324 1.325 1.322;
                                        .0418 .0336 .0315 .0314         .0422 .0338 .0316 .0314
    penalty_volume 1e13, interface_mesh as lagrange, interface_mesh     as lagrange, interface_mesh
    ==================================  ==============================  ==============================

    The closest bound is the L1 error at h = one cell transit: 0.0427 of 0.045.
    """
    rows = [bars(method, mesh, MR, s, detection=detection) for s in STEPS]
    print(f"\n{method} {detection} {mesh}: peak/F0 " + " ".join(f"{m['peak']:.4f}" for m in rows)
          + "; L1 " + " ".join(f"{m['l1']:.4f}" for m in rows)
          + "; E_max/E0 - 1 " + " ".join(f"{m['E_max'] - 1:.1e}" for m in rows)
          + "; corrected/E0 " + " ".join(f"{m['corrected']:.1e}" for m in rows))
    for m in rows:
        assert m["parted"]
        assert m["peak"] <= 1.4
        assert m["l1"] <= 0.045
        assert m["E_max"] <= 1 + ENERGY_TOL
        assert m["corrected"] <= 5e-4
    for a, b in zip(rows, rows[1:]):
        assert b["l1"] <= a["l1"] + 2e-4
    assert rows[-1]["corrected"] <= 0.25 * rows[0]["corrected"]


@pytest.mark.parametrize("mesh", ["matching", pytest.param("4x4-3x3", marks=slow)])
def test_bars_force_history_as_mesh_refines(mesh):
    """mass_redistribution, Lagrange (BVH), 20 / 40 / 80 cells per bar at the same Courant
    number (h = one cell transit L / (n c)): the L1 error of the force history falls by at
    least a quarter at each refinement; the peak stays <= 1.4 F0; what the energy correction
    took back falls at each refinement.

    Measured: matching L1 0.0771 / 0.0421 / 0.0241, peak 1.329 / 1.324 / 1.325 F0; 4x4-3x3
    L1 0.0765 / 0.0427 / 0.0243, peak 1.341 / 1.338 / 1.337 F0 (the error falls about as
    n^-0.85). Taken back by the energy correction / E0: matching 6.0e-4 / 2.7e-4 / 7.7e-5,
    4x4-3x3 5.3e-4 / 2.9e-4 / 8.4e-5.
    """
    rows = [bars("lagrange", mesh, MR, 1.0, n=n) for n in (20, 40, 80)]
    print(f"\nrefinement {mesh}: L1 " + " ".join(f"{m['l1']:.4f}" for m in rows)
          + "; peak/F0 " + " ".join(f"{m['peak']:.4f}" for m in rows)
          + "; corrected/E0 " + " ".join(f"{m['corrected']:.1e}" for m in rows))
    for a, b in zip(rows, rows[1:]):
        assert b["l1"] < 0.75 * a["l1"]
        assert b["corrected"] < a["corrected"]
    assert all(m["peak"] <= 1.4 for m in rows)


def test_stabilized_scheme_peak_grows_as_h_falls():
    """Contrast, the old defect: the ``stabilized`` scheme (usual lumped mass) records the
    impact as a spike of about (nodal mass x velocity) / h, so its peak doubles each time the
    step halves once the spike dominates. Lagrange, matching bars, 40 cells, h = 1, 1/2, 1/4,
    1/8 cell transits.

    Measured: peak / F0 = 1.100 / 1.099 / 1.802 / 3.398 (mass_redistribution on the same bars:
    1.324 / 1.310 / 1.309 / 1.306). Asserts: the peak grows by more than 1.5x from h/2 to
    h/4 and by more than 1.7x from h/4 to h/8 (the spike law says 2x). (Its L1 error stays
    small, 0.039 / 0.036 / 0.034 / 0.036: a one-step spike weighs little in L1; the peak is the
    measure that shows the defect.)"""
    p = [bars("lagrange", "matching", "stabilized", s)["peak"] for s in STEPS]
    print("\nstabilized, peak/F0 at h = 1, 1/2, 1/4, 1/8: " + " ".join(f"{x:.3f}" for x in p))
    assert p[2] > 1.5 * p[1]
    assert p[3] > 1.7 * p[2]


# =============================================================================================
# 2. A bar dropped on a rigid plane: Doyen, Ern & Piperno (2011), first benchmark
# =============================================================================================
DEP_L, DEP_E, DEP_RHO, DEP_G, DEP_A = 10.0, 900.0, 1.0, 10.0, 1.0  # the paper's numbers (units unstated); A = 1 x 1
DEP_C = np.sqrt(DEP_E / DEP_RHO)  # 30
DEP_TW = DEP_L / DEP_C  # 1/3: a wave crosses the bar
DEP_TF = 3 * DEP_TW  # the fall lasts three crossings: h0 = g TF^2 / 2 = 5 (periodic motion)
DEP_H0 = DEP_G * DEP_TF**2 / 2
DEP_VF = DEP_G * DEP_TF  # 10, the speed at impact
DEP_T1 = DEP_TF  # first impact ...
DEP_T2 = DEP_T1 + 2 * DEP_TW  # ... until
DEP_T3 = DEP_T2 + 2 * DEP_TF  # second impact (flight up and down at vf) ...
DEP_T4 = DEP_T3 + 2 * DEP_TW  # ... until; then rigid flight back to h0 (period 16 TW)
DEP_PEAK = DEP_RHO * DEP_C * DEP_A * (DEP_VF + 2 * DEP_G * DEP_TW)  # 500: rho c vf + 2 rho g L
# The impulse of one impact: m (2 vf + 2 g L/c) (the bar leaves at vf; gravity acts meanwhile).
DEP_IMPULSE = DEP_RHO * DEP_C * DEP_A * (2 * DEP_VF * DEP_TW + 2 * DEP_G * DEP_TW**2)


def dep_force(t):
    """The exact contact force (N, on the bar, up) of the first bounce period: during each
    impact the bottom is at rest and the stress there is sigma = -rho c (vf + g tau), tau the
    time since the impact began (first impact) or until it ends (second impact, the time
    reverse of the first); zero in flight."""
    t = np.asarray(t, dtype=float)
    F = np.zeros_like(t)
    k = (t >= DEP_T1) & (t <= DEP_T2)
    F[k] = DEP_RHO * DEP_C * DEP_A * (DEP_VF + DEP_G * (t[k] - DEP_T1))
    k = (t >= DEP_T3) & (t <= DEP_T4)
    F[k] = DEP_RHO * DEP_C * DEP_A * (DEP_VF + DEP_G * (DEP_T4 - t[k]))
    return F


def dep_series_strain(tau, terms=20000):
    """u_x(0, tau) during the first impact from the paper's series solution (as transcribed in
    NLstep, see test_dep_bar_drop_contact_stress_and_duration): the rigid-impact part H,
    u_x = -vf / c, plus the gravity part S1 = sum_n a_n sin(nu_n x) (1 - cos(c nu_n tau)),
    nu_n = (n - 1/2) pi / L, a_n = -2 g / (c^2 L nu_n^3)."""
    nu = (np.arange(1, terms + 1) - 0.5) * np.pi / DEP_L
    a = -2 * DEP_G / (DEP_C**2 * DEP_L * nu**3)
    return -DEP_VF / DEP_C + np.sum(a * nu * (1 - np.cos(DEP_C * nu * np.asarray(tau)[:, None])), axis=1)


@functools.lru_cache(maxsize=None)
def dep_run(n=40, substeps=1.0, method="lagrange", scheme=MR, alpha=0.0) -> dict:
    """The bar (L x 1 x 1, n cells along z, lumped mass, nu = 0, x held on xmin and y on ymin:
    a 1-D bar) released at rest, undeformed, with its bottom at z = h0 above the plane z = 0,
    under gravity g along -z, until T4 + TW/2; h = L / (n c) / substeps."""
    h = DEP_L / DEP_C / n / substeps
    bar = {"name": "bar",
           "mesh": {"builtin": "box", "size": [1.0, 1.0, DEP_L], "cells": [1, 1, n], "origin": [0, 0, DEP_H0]},
           "material": {"model": "isotropic", "E": DEP_E, "nu": 0.0, "rho": DEP_RHO}, "mass": "lumped",
           "fixed": [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}]}
    contact = {"method": method, "detection": "bvh", "surface": "zmin", "scheme": scheme}
    scene = {"gravity": [0, 0, -DEP_G], "bodies": [bar],
             "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}], "contact": contact,
             "time": {"mode": "dynamic", "step": h, "end": DEP_T4 + DEP_TW / 2, "alpha": alpha},
             "output": {"every": 10**6}}
    r = vfrs.run(vfrs.Scene.from_dict(scene), progress=False)
    hs = r.history
    t, F = hs["t"], hs["contact_force.bar"][:, 2]
    # The exact L1 error: |F_n - F_exact| over each step (t_n - h, t_n], trapezoidal with 256
    # intervals per step, over the exact impulse of both impacts.
    s = t[:, None] - h * np.linspace(1.0, 0.0, 257)[None, :]
    l1 = trapezoid(np.abs(F[:, None] - dep_force(s)), s, axis=1).sum() / (2 * DEP_IMPULSE)
    # The contact stress inside each impact, away from its ends: over the steps in its middle
    # half, the largest pointwise error (against the exact force at the step's midpoint: it is
    # linear there) and the error of the mean; over its middle 80 %, the slope of a fitted line
    # against the exact ramp +-rho c g A (gravity loading the bar while it stands).
    pointwise, mean, slope = [], [], []
    for (a, b), sign in (((DEP_T1, DEP_T2), 1), ((DEP_T3, DEP_T4), -1)):
        k = (t - h >= a + 0.25 * (b - a)) & (t <= a + 0.75 * (b - a))
        exact = dep_force(t[k] - h / 2)
        pointwise.append(float(np.max(np.abs(F[k] / exact - 1))))
        mean.append(float(F[k].mean() / exact.mean() - 1))
        k = (t - h >= a + 0.1 * (b - a)) & (t <= a + 0.9 * (b - a))
        fit = np.polyfit(t[k] - h / 2, F[k], 1)[0]
        slope.append(float(fit / (sign * DEP_RHO * DEP_C * DEP_G * DEP_A) - 1))
    m = DEP_RHO * DEP_A * DEP_L
    total = hs["kinetic_energy"] + hs["elastic_energy"] - hs["external_work"]  # + potential: -work of gravity
    return {"h": h, "impacts": contact_runs(t, F > 0, h), "l1": float(l1), "pointwise": pointwise, "mean": mean,
            "slope": slope, "peak": float(F.max() / DEP_PEAK),
            "E_gain": float((total.max() - total[0]) / (m * DEP_G * DEP_H0)),
            "corrected": corrected(hs, m * DEP_G * DEP_H0)}


@pytest.mark.parametrize("substeps", [1.0, 2.0, pytest.param(4.0, marks=slow)])
def test_dep_bar_drop_contact_stress_and_duration(substeps):
    """Doyen, Ern & Piperno, "Time-integration schemes for the finite element dynamic
    Signorini problem", SIAM J. Sci. Comput. 33(1):223-249, 2011: the first 1-D benchmark, an
    elastic bar dropped on a rigid plane under gravity; mass_redistribution, Lagrange,
    alpha = 0, 40 cells.

    What was read. First hand (docslib.org and vdocuments.mx copies; only their first page is
    readable through the search tool): the abstract, "two one-dimensional benchmark problems
    with analytical solutions ... focusing first on spurious oscillations triggered by contact
    and then on energy behavior after multiple impacts". Second hand: the benchmark's data and
    exact solution, from NLstep (Krack & Gross, University of Stuttgart, GPL-3; its
    bouncing-bar example, which uses the paper as reference, "following closely the notation
    in [2], Section 3.1-3.2, Eq. (28)-(31)"): L = 10, E = 900, rho = 1, gravity g = 10 (the
    paper's numbers, units unstated); the bar falls undeformed from rest; NLstep sets the drop
    height so that the fall lasts three wave crossings, TF = 3 L/c, h0 = g TF^2 / 2 = 5, which
    makes the motion periodic with period 16 L/c (impact, flight at vf = g TF, second impact,
    rigid flight back to h0). The bottom displacement there: during an impact u = H + S1 with
    H = -vf min(x/c, TW - |tau - TW|) and S1 = sum_n a_n sin(nu_n x)(1 - cos(c nu_n tau)),
    nu_n = (n - 1/2) pi/L, a_n = -2 g / (c^2 L nu_n^3); the second impact is the time reverse of
    the first. Not read: the paper's figures and its own statement of h0. Mine (d'Alembert,
    and checked here against the series at 50 times to 1e-3): the contact stress during the
    first impact is sigma(tau) = E u_x(0, tau) = -rho c (vf + g tau), 0 < tau < 2L/c, i.e. the
    force ramps from rho c vf A = 300 to 500 and drops to zero at 2L/c; the second impact
    ramps from 500 to 300; each lasts exactly 2L/c; the second begins at T3 = T1 + 2L/c + 2 vf/g.

    Asserts (h = 1, 1/2, 1/4 cell transits): exactly two impacts; each begins within one step
    of T1 = 1, T3 = 11/3; each lasts 2L/c within 6 %; over the middle half of each impact the
    mean recorded force within 1 % of the exact, and pointwise within 1 % in the first impact;
    the slope of the force over the middle 80 % of each impact within 10 % of +-rho c g A; the
    peak within 10 % of 500; the L1 error of the history (over the exact impulse of both
    impacts) <= 0.10. Not asserted: the second impact pointwise. The bar leaves the first
    impact carrying a stress wave with a sharp front, which P1 elements disperse in flight, so
    the exact cancellation at the second landing is lost: the force there oscillates about the
    exact ramp by +-22 / 28 % at 40 / 80 cells (the same with the stabilized scheme: 22 / 18 %),
    and only its mean and slope converge.

    Measured (h = 1, 1/2, 1/4 cell transits): impacts begin at 1.0000 / 3.6583, 1.0000 /
    3.6667, 1.0000 / 3.6688 (exact 1, 3.6667: within a step); duration / (2L/c) - 1 = 3.75 /
    5.0 %, 3.1 / 3.1 %, 3.1 / 3.4 % (first / second impact); middle half pointwise (first
    impact) 0.44 / 0.23 / 0.14 %, mean 0.31 / 0.37 %, 0.15 / -0.44 %, 0.08 / -0.28 %; slope
    -0.8 / +6.5 %, -0.5 / -2.5 %, -0.4 / -1.9 %; peak / 500 = 1.061 / 1.008 / 1.037; L1 0.0943 /
    0.0798 / 0.0770 (the closest bounds: the second impact's duration, 5.0 % of 6 %, and its
    slope, 6.5 % of 10 %, at h = one cell transit).
    """
    tau = np.linspace(0.01, 1.99, 50) * DEP_TW
    assert np.allclose(dep_series_strain(tau), -(DEP_VF + DEP_G * tau) / DEP_C, rtol=1e-3, atol=0)
    m = dep_run(40, substeps)
    h = m["h"]
    starts = [a for a, _ in m["impacts"]]
    durations = [(b - a) / (2 * DEP_TW) - 1 for a, b in m["impacts"]]
    print(f"\nDEP bar drop, 40 cells, h = TW/40/{substeps:g}: impacts start {np.round(starts, 4).tolist()} "
          f"(exact {DEP_T1:.4f}, {DEP_T3:.4f}), duration/(2L/c) - 1 {np.round(durations, 4).tolist()}; middle half: "
          f"pointwise {np.round(m['pointwise'], 4).tolist()}, mean {np.round(m['mean'], 4).tolist()}; slope "
          f"{np.round(m['slope'], 4).tolist()}; peak/500 {m['peak']:.4f}, L1 {m['l1']:.4f}, "
          f"energy gain {m['E_gain']:.2e} m g h0")
    assert len(m["impacts"]) == 2
    assert abs(starts[0] - DEP_T1) <= 1.001 * h and abs(starts[1] - DEP_T3) <= 1.001 * h
    assert max(abs(d) for d in durations) <= 0.06
    assert m["pointwise"][0] <= 0.01
    assert max(abs(x) for x in m["mean"]) <= 0.01
    assert max(abs(x) for x in m["slope"]) <= 0.10
    assert abs(m["peak"] - 1) <= 0.10
    assert m["l1"] <= 0.10


def test_dep_bar_drop_as_mesh_refines():
    """The same drop at 20 / 40 / 80 cells, h = one cell transit: the L1 error of the
    contact-force history falls at each refinement (by at least 5 %), and the impacts' length
    error at 80 cells is within 3 % of 2L/c and no larger than at 20.

    Measured: L1 0.1054 / 0.0943 / 0.0711; largest duration error 5.0 / 5.0 / 2.5 % (the
    contact ends 1-2 cell transits late: the release front is smeared over cells)."""
    rows = [dep_run(n, 1.0) for n in (20, 40, 80)]
    dur = [max(abs((b - a) / (2 * DEP_TW) - 1) for a, b in m["impacts"]) for m in rows]
    print("\nDEP refinement 20/40/80: L1 " + " ".join(f"{m['l1']:.4f}" for m in rows)
          + "; duration error " + " ".join(f"{d:.4f}" for d in dur))
    assert all(len(m["impacts"]) == 2 for m in rows)
    for a, b in zip(rows, rows[1:]):
        assert b["l1"] < 0.95 * a["l1"]
    assert dur[2] <= 0.03 and dur[2] <= dur[0]


@pytest.mark.parametrize("substeps", [1.0, pytest.param(2.0, marks=slow), pytest.param(4.0, marks=slow)])
def test_dep_bar_drop_energy(substeps):
    """The total energy (kinetic + elastic + potential, i.e. minus the work of gravity) of the
    dropped bar never rises above its initial value by more than 1e-6 of m g h0 (the energy
    the bar brings to the impact; the initial total is 0); what mass_redistribution's energy
    correction took back is at most 2.5e-3 m g h0 and falls at least by half each time h
    halves.

    The energy is constant through each impact (the bottom does not move); in the steps the
    bar leaves the plane the last contact force stays in the HHT recursion (trapezoidal rule,
    alpha = 0) and does work on the separating bottom node, which the correction now gives
    back. Measured (h = 1, 1/2, 1/4 cell transits): E_gain 0 / 0 / 0 (2.3e-11 at 1/8); taken
    back 1.70e-3 / 5.03e-4 / 1.44e-4 m g h0 (3.79e-5 at 1/8: O(h^1.8); 2.53e-3 and 4.18e-4 at
    20 and 80 cells, one cell transit). The closest bound: 1.70e-3 of 2.5e-3 at one transit.

    Before the correction: gains 8.85e-4 / 3.14e-4 / 5.35e-5 of m g h0 (2.0e-5 at 1/8), an
    xfail then. (The stabilized scheme never rises: E_gain 0 at the three steps.)"""
    m = dep_run(40, substeps)
    print(f"\nDEP energy gain h = TW/40/{substeps:g}: {m['E_gain']:.2e} m g h0, corrected {m['corrected']:.2e} m g h0")
    assert m["E_gain"] <= ENERGY_TOL
    assert m["corrected"] <= 2.5e-3
    if substeps > 1:
        assert m["corrected"] <= 0.5 * dep_run(40, substeps / 2)["corrected"]


# =============================================================================================
# 3. A sphere striking a rigid plane: Hertz impact theory
# =============================================================================================
SPH_E, SPH_NU, SPH_RHO, SPH_V, SPH_R = 1e6, 0.3, 1000.0, 0.1, 5e-3
SPH_GAP = 1e-5  # m, the plane above the top pole of sphere.msh (contact at 0.1 ms; the quarter ball: scaled by v)
SPHERE = os.path.join(DATA, "sphere.msh")  # radius 5 mm, centre (0, 0, -5) mm, fine (0.3 mm) at the top pole


@functools.lru_cache(maxsize=None)
def mesh_mass(path):
    """rho x the volume of the mesh (2.0 % below the sphere's: the faceted surface)."""
    return SPH_RHO * float(np.abs(vfrs.read_mesh(path, length_unit="mm").signed_volumes()).sum())


def hertz_impact(m, R, E_star, v):
    """Hertz impact of a body of mass m and radius of curvature R on a rigid flat (or two
    bodies: m, R and E* their effective values) at speed v (Hertz's quasi-static impact
    theory as in Johnson, Contact Mechanics, Cambridge 1985, section 11.4, "impact of elastic
    bodies" -- cited from memory, the book could not be opened here; the static law is the
    one test_contact_verification.test_hertz_converges checks, and the constant I is computed
    here by quadrature): F = 4/3 E* sqrt(R) delta^(3/2); the largest approach
    delta_m = (15 m v^2 / (16 E* sqrt(R)))^(2/5); the peak force F_m = 4/3 E* sqrt(R) delta_m^(3/2);
    the contact duration t_c = 2 I delta_m / v, I = int_0^1 dx / sqrt(1 - x^(5/2)) = 1.4716
    (t_c = 2.94 delta_m / v = 2.87 (m^2 / (R E*^2 v))^(1/5))."""
    delta = (15 * m * v**2 / (16 * E_star * np.sqrt(R))) ** 0.4
    return {"delta": delta, "F": 4 / 3 * E_star * np.sqrt(R) * delta**1.5, "tc": 2 * HERTZ_I * delta / v}


SPHERE_Q = os.path.join(DATA, "sphere_quarter.msh")  # its quarter x, y >= 0, graded in the volume toward the pole
QUARTER_V = 0.01  # m/s: Hertz's contact radius a = 0.05 R (see test_sphere_hertz_peak_force_and_duration)


def sphere_hertz(mesh="full"):
    """Hertz's impact of the ball of ``mesh`` ("full": sphere.msh at SPH_V; "quarter":
    sphere_quarter.msh, four times its mass, at QUARTER_V) on the rigid plane."""
    if mesh == "quarter":
        return hertz_impact(4 * mesh_mass(SPHERE_Q), SPH_R, SPH_E / (1 - SPH_NU**2), QUARTER_V)
    return hertz_impact(mesh_mass(SPHERE), SPH_R, SPH_E / (1 - SPH_NU**2), SPH_V)


@functools.lru_cache(maxsize=None)
def sphere_run(method="lagrange", alpha=0.0, per_tc=100, scheme=MR, mesh="full") -> dict:
    """A ball (lumped mass, E = 1 MPa, nu = 0.3, rho = 1000) moving up onto the rigid plane
    (normal -z) a gap above its top pole, which it reaches at 0.1 ms; h = t_Hertz / per_tc,
    until 0.1 ms + 1.15 t_Hertz. ``mesh = "full"``: sphere.msh (free) at v = 0.1 m/s, gap
    0.01 mm. ``mesh = "quarter"``: sphere_quarter.msh at v = 0.01 m/s, gap 1 um, on rollers
    (x held on its cut plane x = 0, y on y = 0: the quarter of a free ball); its force and mass
    are counted four times."""
    H = sphere_hertz(mesh)
    quarter = mesh == "quarter"
    v, k = (QUARTER_V, 4) if quarter else (SPH_V, 1)
    gap = SPH_GAP * v / SPH_V  # m: contact at 0.1 ms
    ball = {"name": "ball", "mesh": {"path": SPHERE_Q if quarter else SPHERE, "length_unit": "mm"},
            "material": {"model": "isotropic", "E": SPH_E, "nu": SPH_NU, "rho": SPH_RHO}, "mass": "lumped",
            "velocity": [0, 0, v]}
    if quarter:
        ball["fixed"] = [{"surface": "xsym", "components": ["x"]}, {"surface": "ysym", "components": ["y"]}]
    contact = {"method": method, "detection": "bvh", "surface": "curved" if quarter else "surface", "scheme": scheme}
    if method == "penalty":
        contact["kappa"] = 1e12  # Pa/m: 300 E/h at sphere.msh's pole (h = 0.3 mm), 100 E/h at the quarter's (0.1 mm)
    scene = {"bodies": [ball], "obstacles": [{"type": "plane", "point": [0, 0, gap], "normal": [0, 0, -1]}],
             "contact": contact, "output": {"every": 10**6},
             "time": {"mode": "dynamic", "step": H["tc"] / per_tc, "end": gap / v + 1.15 * H["tc"], "alpha": alpha}}
    r = vfrs.run(vfrs.Scene.from_dict(scene), progress=False)
    h, hs = r.scene.time.step, r.history
    F = -k * hs["contact_force.ball"][:, 2]
    runs = contact_runs(hs["t"], F > 0, h)
    energy = hs["kinetic_energy"] + hs["elastic_energy"]
    m = k * mesh_mass(SPHERE_Q if quarter else SPHERE)
    pz = k * float((r.problem.M @ r.v.ravel())[2::3].sum())  # the ball's momentum after the impact
    return {"peak": float(F.max() / H["F"]), "runs": runs, "duration": (runs[-1][1] - runs[0][0]) / H["tc"],
            "E_max": float(energy.max() / energy[0] - 1), "restitution": -pz / (m * v),
            "impulse": float(h * F.sum() / (m * v)), "momentum": impulse_momentum(r),
            "corrected": corrected(hs, energy[0])}


def _quarter_params():
    out = []
    for method in ("lagrange", "penalty"):
        for alpha in (0.0, -0.3):
            for per_tc in (50, 100, 200):
                quick = (method, alpha, per_tc) in (("lagrange", 0.0, 100), ("lagrange", -0.3, 50))
                out.append(pytest.param(method, alpha, per_tc, marks=[] if quick else [slow],
                                        id=f"{method}-a{alpha}-tc/{per_tc}"))
    return out


# Lagrange: at the release step the energy correction takes 1.5e-12 J from the ball's rigid
# motion (the plane takes the momentum) and warns that the step is too large for the impact
# speed, also at tc/100: a conservative warning for a body on a fixed obstacle (issue 30 note).
@pytest.mark.filterwarnings("ignore:.*taking it back slowed the free bodies:vfrs.errors.VfrsWarning")
@pytest.mark.parametrize("method,alpha,per_tc", _quarter_params())
def test_sphere_hertz_peak_force_and_duration(method, alpha, per_tc):
    """Hertz impact (formulas in :func:`hertz_impact`) of a ball on a rigid plane, on the graded
    unstructured quarter ball ``sphere_quarter.msh`` (1224 nodes, 5162 tetrahedra; pole size
    0.1 mm, 1.0 mm from 4 mm off the pole on; rollers on its cut planes), mass_redistribution,
    Lagrange and penalty (1e12 Pa/m), alpha = 0 and -0.3, h = t_c/50, t_c/100, t_c/200;
    E = 1 MPa, nu = 0.3, rho = 1000, R = 5 mm, v = 0.01 m/s, E* = E / (1 - nu^2) against the
    rigid plane, m = 4 x rho x the quarter mesh's volume (1.3 % below the ball's): Hertz's
    delta_m = 13.1 um, contact radius a = sqrt(R delta_m) = 0.256 mm = 0.051 R, peak force
    4.92 mN, t_c = 3.86 ms.

    Asserts, at each alpha and step: one contact interval; the peak force (4 x the recorded
    force on the quarter) and the contact duration (whole steps with a force, as in
    :func:`contact_runs`) within 5 % of Hertz's; the energy never above E0 (1 + 1e-6); the
    ball rebounds at v within 1 %; and what the energy correction took back is at most
    1.5e-3 E0 and falls at least by half each time h halves (it removes the gain of pairs
    releasing within a step, O(h^2)). Impulse = momentum on these runs:
    test_sphere_quarter_impulse_momentum (an xfail).

    Measured (peak / F_H - 1, duration / t_H - 1 at h = t_c/50, /100, /200):

    ===================  ==========================  ==========================
    case                 peak                        duration
    ===================  ==========================  ==========================
    lagrange, alpha 0    +2.80 / +3.01 / +3.01 %     -4.0 / -3.0 / -3.5 %
    lagrange, -0.3       +2.75 / +2.91 / +2.98 %     -4.0 / -3.0 / -3.5 %
    penalty, alpha 0     +2.77 / +2.97 / +2.98 %     -4.0 / -3.0 / -3.5 %
    penalty, -0.3        +2.71 / +2.87 / +2.94 %     -4.0 / -3.0 / -3.5 %
    ===================  ==========================  ==========================

    E_max / E0 - 1 <= 2.7e-15 in every case; restitution 0.9996 / 0.9998 / 0.9999; taken back
    by the correction (contact_energy_corrected / E0): Lagrange 8.7e-4 / 2.2e-4 / 6.8e-5
    (alpha 0), 8.0e-4 / 2.2e-4 / 6.9e-5 (-0.3); penalty 7.0e-4 / 1.8e-4 / 3.7e-5, 6.6e-4 /
    1.7e-4 / 3.8e-5 (a factor 3.2 to 4.9 per halving of h). The closest bounds: the duration
    at t_c/50, -4.0 % of 5 % (one step is 2 %), and the correction at t_c/50, 8.7e-4 of
    1.5e-3. (The ball is on rollers, so it has fixed DOFs, and the correction scales its whole
    velocity, its rigid motion along z included, without recording it: see
    test_sphere_quarter_impulse_momentum.)

    Contrast, the ``stabilized`` scheme on the same mesh and steps: the same peaks (+2.7 to
    +3.0 %) and durations (-2 to -4 %), but E_max / E0 - 1 = 1.2e-4 / 2e-16 / 9.8e-6 (Lagrange,
    alpha 0), round-off at -0.3; penalty 0 / 1.7e-2 / 4.3e-2 (alpha 0), 1e-15 / 4.0e-4 / 1.2e-2
    (-0.3).

    Why v = 0.01 m/s. Hertz's theory is the limit a / R -> 0 (a half-space, the approach
    measured from far away) of a quasi-static impact. At v = 0.1 m/s (a / R = 0.13, the ball of
    sphere.msh below) the finite element ball's peak force converges to about 5 % above
    Hertz's, not to Hertz's. Quarter balls graded in the volume, made with this mesh's
    settings (the interior size reached 5 mm off the pole; 4 mm for the 7413 nodes), at
    v = 0.1 m/s, Lagrange, alpha = 0, h = t_c/100 (pole size / fine radius / interior size,
    mm: nodes: peak, duration): 0.15 / 0.8 / 1.0: 693: +7.0 %, -6 %; 0.1 / 1.0 / 1.0: 1427:
    +6.4 %, -5 %; 0.05 / 1.0 / 1.0: 5351: +6.1 %, -5 %; 0.1 / 1.5 / 0.6: 3806: +5.5 %, -5 %;
    0.07 / 1.5 / 0.5: 7413: +5.5 %, -5 %; 0.1 / 2.0 / 0.4: 8120: +5.4 %, -5 % (26 s for that
    one run). The same mesh relative to a (pole a / 4.3, fine within 2 a, interior 1.2 mm from
    5 mm on; 836 / 1087 / 1270 nodes) at v = 0.1 / 0.01 / 0.001 m/s (a / R = 0.13 / 0.051 /
    0.020): peak +6.5 / +3.7 / +2.5 %, duration -6 / -3 / -2 %; at v = 0.01 finer meshes give
    +2.8 %, -2 % (3207 nodes) and +2.5 %, -2 % (7145). What is left, 2-3 % at a / R = 0.05,
    is mostly Hertz's half-space idealisation. An estimate of its size (mine; order of
    magnitude only): a point load F on a half-space moves the point at depth z on its axis by
    F (1 + nu)(3 - 2 nu) / (2 pi E z), which at z = R and Hertz's peak force is 0.094 delta_m
    at a / R = 0.13 and 0.037 delta_m at 0.051; measuring the approach from the centre instead
    of from infinity makes the ball stiffer by (1 - that)^(-3/2), i.e. peak force +6 % and
    +2 %, duration -6 % and -2 %. (History: on sphere.msh, the whole ball refined on its
    surface only, 1.3 mm inside, v = 0.1 m/s, this test was an xfail: peak +12.7 %, duration
    -13.0 % at t_c/100.)
    """
    m = sphere_run(method, alpha, per_tc, MR, "quarter")
    print(f"\nHertz impact, quarter ball, {method} alpha={alpha} h=t_c/{per_tc}: peak/F_H - 1 {m['peak'] - 1:+.4f}, "
          f"duration/t_H - 1 {m['duration'] - 1:+.4f}, E_max/E0 - 1 {m['E_max']:.1e}, corrected/E0 "
          f"{m['corrected']:.2e}, restitution {m['restitution']:.5f}, impulse - momentum {m['momentum']:.1e}")
    assert len(m["runs"]) == 1
    assert abs(m["peak"] - 1) <= 0.05
    assert abs(m["duration"] - 1) <= 0.05
    assert m["E_max"] <= ENERGY_TOL
    assert abs(m["restitution"] - 1) < 0.01
    assert m["corrected"] <= 1.5e-3
    if per_tc > 50:
        assert m["corrected"] <= 0.5 * sphere_run(method, alpha, per_tc // 2, MR, "quarter")["corrected"]


@pytest.mark.parametrize("method,alpha,per_tc", _quarter_params())
def test_sphere_quarter_impulse_momentum(method, alpha, per_tc):
    """The runs of test_sphere_hertz_peak_force_and_duration: impulse = momentum along z
    (:func:`impulse_momentum`: h x the recorded contact force against the change of 1^T M v,
    M the redistributed mass) to 1e-9 of m v. Along z the quarter ball is free: the rollers
    hold x on its cut plane x = 0 and y on y = 0, so only contact changes its z momentum.

    Measured impulse - momentum / (m v): 6.6e-14 to 9.2e-13 for both methods, both alphas and
    the three steps. (The staged energy correction of 15af481 broke it: its first stage scaled
    a body with fixed DOFs whole, its rigid motion along the rollers included, unrecorded:
    4.7e-4 / 1.2e-4 / 3.6e-5 at t_c/50, /100, /200; now that stage keeps the rigid motions the
    fixed DOFs allow, and a later stage that changes them records it.) The free ball
    (test_sphere_energy) and the two balls (test_two_spheres_energy) hold it to 1.1e-12."""
    m = sphere_run(method, alpha, per_tc, MR, "quarter")
    print(f"\nquarter ball {method} alpha={alpha} h=t_c/{per_tc}: impulse - momentum (z) {m['momentum']:.1e} m v")
    assert m["momentum"] <= 1e-9


def test_sphere_impact_converged_in_h():
    """What the time step does to the whole ball's impact (sphere.msh, free, v = 0.1 m/s) with
    mass_redistribution (Lagrange, alpha = 0, h = t_c/50, t_c/100, t_c/200): one contact
    interval; the peak force moves by less than 1 % and the contact duration by at most one
    step across the steps (the history converges; the distance to Hertz, +12.7 % in force, is
    the coarse mesh's and a / R = 0.13's, see test_sphere_hertz_peak_force_and_duration); the
    ball rebounds at v within 1 % (elastic impact: coefficient of restitution 1) and the impulse
    is m v (1 + e) to 1e-9 (the recorded force is the whole impulse). "Less than 1 %" for the
    duration means within one step of the coarsest (t_c/50): the duration is counted in whole
    steps.

    Measured: peak / F_H 1.1277 / 1.1265 / 1.1256; duration / t_H 0.860 / 0.870 / 0.875;
    restitution 0.9981 / 0.9985 / 0.9986; impulse - m v (1 + e) below 1.2e-13 of m v. (Before
    the energy correction: restitution 0.9983 / 0.9986 / 0.9986, the same peaks and durations.)"""
    rows = [sphere_run("lagrange", 0.0, n) for n in (50, 100, 200)]
    print("\nsphere impact t_c/50, /100, /200: peak/F_H " + " ".join(f"{m['peak']:.4f}" for m in rows)
          + "; duration/t_H " + " ".join(f"{m['duration']:.4f}" for m in rows)
          + "; restitution " + " ".join(f"{m['restitution']:.4f}" for m in rows))
    peaks, durations = [m["peak"] for m in rows], [m["duration"] for m in rows]
    assert all(len(m["runs"]) == 1 for m in rows)
    assert max(peaks) / min(peaks) - 1 < 0.01
    assert max(durations) - min(durations) <= 1 / 50 + 1e-9  # one step at t_c/50: the resolution
    for m in rows:
        assert abs(m["restitution"] - 1) < 0.01
        assert m["impulse"] == pytest.approx(1 + m["restitution"], abs=1e-9)


def _sphere_energy_params():
    out = []
    for method in ("lagrange", "penalty"):
        for alpha in (0.0, -0.3):
            for per_tc in (50, 100, 200):
                quick = (method, per_tc) == ("lagrange", 50) or (method, alpha, per_tc) == ("lagrange", 0.0, 100)
                out.append(pytest.param(method, alpha, per_tc, marks=[] if quick else [slow],
                                        id=f"{method}-a{alpha}-tc/{per_tc}"))
    return out


@pytest.mark.parametrize("method,alpha,per_tc", _sphere_energy_params())
def test_sphere_energy(method, alpha, per_tc):
    """The whole ball (sphere.msh, free, v = 0.1 m/s) on the plane, mass_redistribution,
    Lagrange and penalty (1e12 Pa/m), alpha = 0 and -0.3, h = t_c/50, t_c/100, t_c/200: the
    energy (kinetic + elastic) never above E0 (1 + 1e-6); impulse = momentum per component
    (x, y, z) to 1e-9 of m v (:func:`impulse_momentum`, with the redistributed mass); what the
    energy correction took back at most 1.5e-3 E0 and at least halving each time h halves.

    Measured E_max / E0 - 1 (h = t_c/50, /100, /200): Lagrange alpha = 0: 0, 0, 2e-16;
    alpha = -0.3: 0, 4e-15, 0; penalty alpha = 0: 0, 0, 2e-16; alpha = -0.3: 0, 4e-15, 0.
    Taken back by the correction (contact_energy_corrected / E0): Lagrange 9.3e-4 / 3.1e-4 /
    7.5e-5 (alpha 0), 8.4e-4 / 3.2e-4 / 7.6e-5 (-0.3); penalty 9.3e-4 / 2.9e-4 / 7.8e-5,
    8.3e-4 / 3.0e-4 / 7.7e-5 (a factor 2.6-3.2, then 3.7-4.2, per halving: O(h^2), pairs
    releasing within a step). Impulse = momentum to 4.7e-13; the recorded force has no x or y
    component (the correction keeps the free ball's rigid motion).

    Before the correction: E_max / E0 - 1 = 3.46e-5 (Lagrange) and 2.13e-5 (penalty) at
    alpha = 0, t_c/100 (xfails then), round-off otherwise: the gain came in the step the ball
    left the plane (the last contact force stays in the HHT recursion and does work on the
    separating nodes, as in the dropped bar); whether a step showed it depended on where the
    release fell in it (at t_c/50 with the analytical mass instead of the mesh's, i.e. h 0.8 %
    longer, Lagrange gained 1.39e-4)."""
    m = sphere_run(method, alpha, per_tc)
    print(f"\nsphere energy {method} alpha={alpha} h=t_c/{per_tc}: E_max/E0 - 1 = {m['E_max']:.2e}, corrected/E0 "
          f"{m['corrected']:.2e}, impulse - momentum {m['momentum']:.1e}")
    assert m["E_max"] <= ENERGY_TOL
    assert m["momentum"] <= 1e-9
    assert m["corrected"] <= 1.5e-3
    if per_tc > 50:
        assert m["corrected"] <= 0.5 * sphere_run(method, alpha, per_tc // 2)["corrected"]


# =============================================================================================
# 4. Two unstructured, non-matching spheres colliding
# =============================================================================================
SPHERE_UP = os.path.join(DATA, "sphere_upper.msh")  # the same ball turned 90 degrees, 0.05 mm above
TWO_KAPPA = {"penalty": 1e12, "augmented_lagrange": 1e10, "penalty_volume": 1e14}
TWO_CASES = BAR_CASES  # every method, both detectors (penalty_volume: the interface mesh only)
def two_spheres_hertz():
    """Two equal balls: effective mass m/2, radius R/2, E* = E / (2 (1 - nu^2))."""
    return hertz_impact(mesh_mass(SPHERE) / 2, SPH_R / 2, SPH_E / (2 * (1 - SPH_NU**2)), SPH_V)


@functools.lru_cache(maxsize=None)
def two_spheres_run(method, detection, alpha=0.0, per_tc=50, scheme=MR, precision=None) -> dict:
    """sphere.msh moving up at 0.05 m/s, sphere_upper.msh down at 0.05 m/s (closing at 0.1 m/s,
    0.05 mm apart: they touch at 0.5 ms), consistent mass, strict (an LCP that does not settle
    raises), h = t_Hertz / per_tc, until 0.5 ms + 1.1 t_Hertz."""
    H = two_spheres_hertz()
    mat = {"model": "isotropic", "E": SPH_E, "nu": SPH_NU, "rho": SPH_RHO}
    bodies = [{"name": "low", "mesh": {"path": SPHERE, "length_unit": "mm"}, "material": mat,
               "velocity": [0, 0, SPH_V / 2]},
              {"name": "up", "mesh": {"path": SPHERE_UP, "length_unit": "mm"}, "material": mat,
               "velocity": [0, 0, -SPH_V / 2]}]
    contact = {"method": method, "detection": detection, "surface": "surface", "scheme": scheme, "strict": True}
    if method in TWO_KAPPA:
        contact["kappa"] = TWO_KAPPA[method]
    if method == "augmented_lagrange":
        contact["max_augmentations"] = 12
    if precision is not None:  # [contact] column_precision (tests/test_single_precision_columns.py)
        contact["column_precision"] = precision
    scene = {"bodies": bodies, "contact": contact, "output": {"every": 10**6},
             "time": {"mode": "dynamic", "step": H["tc"] / per_tc, "end": 0.5e-3 + 1.1 * H["tc"], "alpha": alpha}}
    r = vfrs.run(vfrs.Scene.from_dict(scene), progress=False)
    hs = r.history
    energy = hs["kinetic_energy"] + hs["elastic_energy"]
    Fu, Fl = hs["contact_force.up"], hs["contact_force.low"]
    return {"E_max": float(energy.max() / energy[0] - 1), "E_end": float(energy[-1] / energy[0]),
            "converged": bool((hs["contact_converged"] == 1).all()), "max_active": int(hs["active_pairs"].max()),
            "parted": bool(not Fu[-1].any()), "balance": float(np.abs(Fu + Fl).max() / np.abs(Fu).max()),
            "peak": float(Fu[:, 2].max() / H["F"]), "corrected": corrected(hs, energy[0]),
            "momentum": impulse_momentum(r)}


def _two_params():
    out = []
    for method, detection in TWO_CASES:
        for alpha in (0.0, -0.3):
            for per_tc in ((50, 100, 200) if (method, detection) == ("lagrange", "interface_mesh") else (50,)):
                quick = (method, detection, alpha, per_tc) == ("lagrange", "interface_mesh", 0.0, 50)
                out.append(pytest.param(method, detection, alpha, per_tc, marks=[] if quick else [slow],
                                        id=f"{method}-{detection}-a{alpha}-tc/{per_tc}"))
    return out


@pytest.mark.parametrize("method,detection,alpha,per_tc", _two_params())
def test_two_spheres_settle(method, detection, alpha, per_tc):
    """Two non-matching graded balls colliding, mass_redistribution, every method and
    detector, alpha = 0 and -0.3, h = t_c/50 (and t_c/100, t_c/200 for Lagrange on the
    interface mesh): with strict = true a run that finishes had every step's LCP settle; also
    every step's re-detection settled (contact_converged = 1: LCP converged and the loaded
    pairs stopped changing within max_detections rounds); they touched and parted; action =
    reaction (1e-10).

    Measured: every run settles (at most 10 active pairs), action = reaction to 2.4e-15, peak
    force 1.138-1.151 of Hertz's for two balls (the mesh and a / R, as for the single ball;
    1.136-1.146 when this test was written, before the energy correction and the sparser
    consistent M')."""
    m = two_spheres_run(method, detection, alpha, per_tc)
    print(f"\ntwo spheres {method} {detection} alpha={alpha} h=t_c/{per_tc}: {m}")
    assert m["converged"] and m["max_active"] > 0 and m["parted"]
    assert m["balance"] < 1e-10


@pytest.mark.parametrize("method,detection,alpha,per_tc", _two_params())
def test_two_spheres_energy(method, detection, alpha, per_tc):
    """The same collisions: the energy never above E0 (1 + 1e-6); impulse = momentum per body
    and component to 1e-9 of a ball's momentum (:func:`impulse_momentum`: the correction moves
    momentum between the balls and records it as contact impulse); what the energy correction
    took back at most 5e-3 E0 and not growing as h falls (Lagrange, interface mesh).

    On curved, non-matching faceted surfaces node-to-surface pairs are not conservative (a
    pair's frozen geometry turns as its node slides from facet to facet): the energy fell
    while the contact patch grew and rose while it shrank, and the correction now gives back
    every step's gain. Measured: E_max / E0 - 1 <= 1.2e-13 in every case; impulse = momentum
    to 1.1e-12; taken back (contact_energy_corrected / E0) at t_c/50: BVH 3.5e-3 to 4.0e-3
    (Lagrange 3.93e-3 / 3.90e-3 at alpha 0 / -0.3, penalty 3.52e-3 / 3.52e-3, Uzawa 4.02e-3 /
    3.88e-3), the interface mesh 3.0e-3 to 3.4e-3 (Lagrange 3.21e-3 / 3.21e-3, penalty
    2.97e-3 / 2.98e-3, Uzawa 3.23e-3 / 3.35e-3, penalty_volume 3.20e-3 / 3.20e-3); Lagrange,
    interface mesh, at t_c/50, /100, /200: 3.21e-3 / 2.16e-3 / 1.96e-3 (alpha 0), 3.21e-3 /
    2.19e-3 / 1.97e-3 (-0.3): it falls but levels off near 2e-3 (the facets' part does not
    vanish with h; the releases' part does). The closest bound: 4.02e-3 of 5e-3 (1.24x).
    E_end 0.9977-0.9998 E0.

    Before the correction (xfails then): E_max / E0 - 1 = 1.2e-3 to 2.8e-3; BVH 2.0e-3 to
    2.8e-3, the interface mesh 1.2e-3 to 1.9e-3; alpha = -0.3 removed up to 25 % of it; it did
    not fall with h (Lagrange, interface mesh: 1.74e-3, 1.67e-3, 1.85e-3 at t_c/50, /100,
    /200; Lagrange, BVH, alpha = 0, h = 20 us: 3e-3). (The stabilized scheme on the same case,
    Lagrange, BVH, alpha = 0, h = 20 us, as measured then: 2.9e7 E0 at 2.87 ms and still
    rising, 1.09e8 E0 at the end, 3.58 ms; its re-detection did not settle in 12 of the 180
    steps, from 1.72 ms on; every LCP settled.)"""
    m = two_spheres_run(method, detection, alpha, per_tc)
    print(f"\ntwo spheres energy {method} {detection} alpha={alpha} h=t_c/{per_tc}: E_max/E0 - 1 = {m['E_max']:.2e}, "
          f"corrected/E0 {m['corrected']:.2e}, impulse - momentum {m['momentum']:.1e}")
    assert m["E_max"] <= ENERGY_TOL
    assert m["momentum"] <= 1e-9
    assert m["corrected"] <= 5e-3
    if per_tc > 50:
        assert m["corrected"] <= two_spheres_run(method, detection, alpha, per_tc // 2)["corrected"]


# =============================================================================================
# 5. Penalty at any kappa, any step: no energy gain
# =============================================================================================
def _kappa_params():
    out = []
    for kappa in (1e10, 1e11, 1e12):
        for s in (1.0, 2.0, 4.0) + ((8.0,) if kappa == 1e12 else ()):
            quick = kappa == 1e11 and s in (1.0, 2.0)
            out.append(pytest.param(kappa, s, marks=[] if quick else [slow], id=f"kappa{kappa:.0e}-h/{s:g}"))
    return out


@pytest.mark.parametrize("kappa,substeps", _kappa_params())
def test_penalty_stiff_no_energy_gain(kappa, substeps):
    """Penalty at kappa = 1e10, 1e11, 1e12 Pa/m (2.5e3 to 2.5e5 x E / cell length) on the bars
    of test_contact_conservation with non-matching end faces (4 x 4 against 3 x 3 cells, BVH),
    mass_redistribution, alpha = 0, h = 1, 1/2, 1/4 cell transits (and 1/8 at 1e12, shared
    with test_bars_force_history_as_h_falls): the energy never above E0 (1 + 1e-6), the bars
    part, and what the energy correction took back is at most 5e-4 E0 (as for the other
    methods on these bars).

    Measured: E_max / E0 - 1 = 2.2e-16 / 6.7e-16 / 0 (/ 2.2e-16 at h/8) at every kappa (the
    same before the correction), peak 1.338 / 1.324 / 1.325 (/ 1.322) F0, the same for the
    three kappas to 2e-4; taken back 2.9e-4 / 5.0e-5 / 5.6e-5 E0 (/ 2.6e-5 at h/8), the same
    for the three kappas to 1e-6. (The
    stabilized scheme on these bars does not gain either: E_max = E0 +
    2e-16 .. 7e-16 at kappa 1e10 .. 1e12, h = 1, 1/2, 1/4; the gains quoted for it, 1.17 E0 at
    1e10 up to 5.3 E0 at 1e11, were measured on a bar not identified.)"""
    m = bars("penalty", "4x4-3x3", MR, substeps, kappa=kappa)
    print(f"\npenalty kappa={kappa:.0e} h/{substeps:g}: E_max/E0 - 1 = {m['E_max'] - 1:.1e}, peak/F0 {m['peak']:.4f}, "
          f"corrected/E0 {m['corrected']:.2e}")
    assert m["parted"]
    assert m["E_max"] <= 1 + ENERGY_TOL
    assert m["corrected"] <= 5e-4
