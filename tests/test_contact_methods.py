"""Properties of the contact methods (issue 6, "Methods"): penalty penetration ~ 1/kappa,
Lagrange exact, augmented Lagrange converging to Lagrange, action = reaction at every step of
every method, the reduced (compliance) path equal to the refactoring reference.

The static problem is a block pressed onto a rigid plane: W x W x H = 10 mm cube, E = 1e4 Pa,
nu = 0.3, zmax pushed down by d = 0.1 mm, rollers on xmin (x) and ymin (y), contact of zmin
with the plane z = 0. Uniaxial strain-free compression: the exact contact force is
E W^2 d / H (Lagrange) and E W^2 d / (H + E / kappa) for the penalty (a spring kappa per unit
area in series with the block), the penalty penetration E d / (kappa H + E).
"""

from __future__ import annotations

import numpy as np
import pytest

import vfrs

from test_contact_verification import bars_run

E, NU, W, H, D = 1e4, 0.3, 0.01, 0.01, 1e-4
F_EXACT = E * W * W * D / H


def block_run(method, kappa=None, solver="compliance", cells=(3, 3, 4), **extra):
    contact = {"method": method, "detection": "bvh", "surface": "zmin", "solver": solver, **extra}
    if kappa is not None:
        contact["kappa"] = kappa
    scene = vfrs.Scene.from_dict({
        "bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [W, W, H], "cells": list(cells)},
                    "material": {"model": "isotropic", "E": E, "nu": NU, "rho": 1000.0},
                    "fixed": [{"surface": "zmax", "components": ["z"], "displacement": [0, 0, -D]},
                              {"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}]}],
        "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
        "contact": contact,
        "time": {"mode": "static"},
        "output": {"energy": False},
    })
    return vfrs.run(scene, progress=False)


def test_lagrange_exact():
    """Lagrange: the force is E W^2 d / H (measured 1e-12 relative; asserted 1e-10), the
    penetration at solver precision (measured 1.6e-16 m = 1.6e-14 H; asserted below
    1e-12 H), every node of the face active, no tangential force."""
    r = block_run("lagrange")
    F = r.history["contact_force.block"][-1]
    assert F[2] == pytest.approx(F_EXACT, rel=1e-10)
    assert np.abs(F[:2]).max() < 1e-12 * F_EXACT
    assert r.history["max_penetration"][-1] < 1e-12 * H
    assert r.history["active_pairs"][-1] == 4 * 4


def test_penalty_penetration_scales_as_one_over_kappa():
    """Penalty over five decades of kappa (1e8 to 1e12 Pa/m, i.e. 100 to 1e6 times the
    block's E / H): force (asserted 1e-9) and penetration (asserted 1e-6: at 1e12 the
    penetration is 1e-10 m, near the round-off of positions) match the series-spring closed
    forms, and the fitted log-log slope of penetration against kappa is -1 within 0.005
    (closed form: -0.998 over this range, -kappa H / (kappa H + E) pointwise)."""
    kappas = np.array([1e8, 1e9, 1e10, 1e11, 1e12])
    pen = []
    for k in kappas:
        r = block_run("penalty", kappa=k)
        F = r.history["contact_force.block"][-1][2]
        assert F == pytest.approx(E * W * W * D / (H + E / k), rel=1e-9)
        pen.append(r.history["max_penetration"][-1])
        assert pen[-1] == pytest.approx(E * D / (k * H + E), rel=1e-6)
    slope = np.polyfit(np.log(kappas), np.log(pen), 1)[0]
    print(f"\npenalty: penetration {np.array(pen)}, fitted slope {slope:.4f}")
    assert abs(slope + 1) < 0.005


# kappa_0 = 1, the paper's value, on purpose: the scale warning is expected.
@pytest.mark.filterwarnings("ignore:.*far below the contact stiffness scale:vfrs.errors.VfrsWarning")
def test_augmented_lagrange_approaches_lagrange():
    """Augmented Lagrange (Uzawa) with kappa_0 = 1e6 Pa/m (E / H) and the gap tolerance set
    below round-off, so that only max_augmentations stops it: the force error against the
    Lagrange answer falls strictly at N = 1, 2, 4, 8 (measured 0.5, 4.5e-2, 3.8e-4, below
    1e-9) and the final one is below 1e-6. With the paper's kappa_0 = 1 (given: no longer the
    default, which is 100 x the surfaces' stiffness scale) and the default gap tolerance 1e-7 m
    the error is non-increasing in N = 1, 2, 4, 8, 16 and below 1e-3 at 16, where the gap
    tolerance stops the augmentations (measured 3.4e-4, 10 augmentations); the runs that stop
    short of gap_tol say so (contact_converged = 0; strict = false here, so they record instead
    of raising)."""
    lag = block_run("lagrange").history["contact_force.block"][-1][2]
    errs = []
    for n in (1, 2, 4, 8):
        r = block_run("augmented_lagrange", kappa=1e6, max_augmentations=n, gap_tol=1e-30, strict=False)
        errs.append(abs(r.history["contact_force.block"][-1][2] / lag - 1))
        assert r.history["augmentations"][-1] == n
    print(f"\naugmented Lagrange kappa0 1e6: errors {errs}")
    assert all(a > b for a, b in zip(errs, errs[1:])), errs
    assert errs[-1] < 1e-6
    paper = []
    for n in (1, 2, 4, 8, 16):
        r = block_run("augmented_lagrange", kappa=1.0, max_augmentations=n, strict=False)
        assert r.history["contact_converged"][-1] == (1 if n == 16 else 0)  # gap_tol reached only at 16
        paper.append(abs(r.history["contact_force.block"][-1][2] / lag - 1))
    print(f"augmented Lagrange kappa0 1 (the paper's): errors {paper}")
    assert all(a >= b for a, b in zip(paper, paper[1:])), paper
    assert paper[-1] < 1e-3


def test_refactor_and_compliance_paths_agree_static():
    """The reference path (refactor K + G^T k G) and the reduced compliance path give the same
    displacement (asserted 1e-10 relative; measured 3e-15)."""
    a = block_run("penalty", kappa=1e7)
    b = block_run("penalty", kappa=1e7, solver="refactor")
    assert np.abs(a.u - b.u).max() < 1e-10 * np.abs(a.u).max()


# Two bodies in dynamics: the bars of test_contact_verification (impact and separation).
BALANCE_CASES = [
    ("lagrange", "bvh", None),
    ("lagrange", "interface_mesh", None),
    ("penalty", "bvh", 1e9),
    ("penalty", "interface_mesh", 1e9),
    ("penalty_volume", "interface_mesh", 1e13),
    ("augmented_lagrange", "bvh", 1e6),
    ("detect_only", "bvh", None),
]


@pytest.mark.parametrize("method,detection,kappa", BALANCE_CASES)
def test_action_equals_reaction_every_step(method, detection, kappa):
    """Action = reaction: at every step of a two-body impact the contact forces on the two
    bars sum to zero (asserted 1e-12 of the peak force), for every method and detection;
    detect_only applies none. The forcing methods must actually have pushed (peak force
    above 10 % of the elastic-wave value rho c v0 A / 2)."""
    # (strict = false: Uzawa from kappa_0 = 1e6 Pa/m does not reach gap_tol in 4 augmentations;
    # the balance holds whatever the multipliers)
    r = bars_run(method=method, detection=detection, kappa=kappa, alpha=-0.3, end=2.5, strict=False)
    Fa, Fb = r.history["contact_force.a"], r.history["contact_force.b"]
    peak = np.abs(Fa).max()
    if method == "detect_only":
        assert peak == 0 and np.abs(Fb).max() == 0
        assert np.max(r.history["contact_pairs"]) > 0  # it did detect
        return
    wave = 1000.0 * np.sqrt(1e4 / 1000.0) * 0.1 * 0.01**2 / 2
    print(f"\n{method}/{detection}: peak {peak:.3e} N (wave {wave:.3e}), max |Fa + Fb| {np.abs(Fa + Fb).max():.1e}")
    assert peak > 0.1 * wave
    assert np.abs(Fa + Fb).max() <= 1e-12 * peak


def test_refactor_and_compliance_paths_agree_dynamic():
    """The same two-bar penalty impact (kappa = 1e9 Pa/m, alpha = -0.3) through the reduced
    compliance path and the refactoring reference: contact force histories and final
    displacements agree to 1e-8 relative."""
    a = bars_run(method="penalty", kappa=1e9, alpha=-0.3, solver="compliance", end=2.5)
    b = bars_run(method="penalty", kappa=1e9, alpha=-0.3, solver="refactor", end=2.5)
    Fa, Fb = a.history["contact_force.a"], b.history["contact_force.a"]
    scale = np.abs(Fb).max()
    assert scale > 0
    rel_f = np.abs(Fa - Fb).max() / scale
    rel_u = np.abs(a.u - b.u).max() / np.abs(b.u).max()
    print(f"\ncompliance vs refactor (dynamic penalty): force {rel_f:.1e}, displacement {rel_u:.1e}")
    assert rel_f < 1e-8
    assert rel_u < 1e-8


def test_penalty_volume_holds_a_body_on_a_rigid_plane():
    """penalty_volume against a rigid plane: a node's overlap volume is its tributary area a
    times its penetration, so the pair stiffness is kappa_V a and the block is a spring of
    kappa_V per unit area in series, like the penalty: F = E W^2 d / (H + E / kappa_V) (1e-9).
    Plane pairs used to get the stiffness of a master triangle they do not have, zero: the
    block went through the plane with no force."""
    kappa = 1e12
    r = block_run("penalty_volume", kappa=kappa, detection="interface_mesh")
    F = r.history["contact_force.block"][-1]
    assert F[2] == pytest.approx(E * W * W * D / (H + E / kappa), rel=1e-9)
    assert r.history["max_penetration"][-1] == pytest.approx(E * D / (kappa * H + E), rel=1e-6)
