"""Contact verification against closed forms (DESIGN.md, "Verification we trust more than our
own eyes"; issue 6, "Verification tests").

Every test compares a ``[contact]`` run with an analytical answer and a stated tolerance:

- Hertz: a paraboloid pressed onto a rigid plane (force-approach, contact radius), converging
  with refinement;
- Signorini: a block resting on a frictionless rigid plane under gravity (reaction m g,
  pressure rho g H);
- two elastic bars colliding (contact lasts 2 L / c, momentum exchange, energy balance with
  and without the contact-stabilized predictor);
- the contact patch test (uniform pressure through a flat interface, matching and
  non-matching meshes).

The per-method properties (penalty ~ 1/kappa, Lagrange exact, augmented Lagrange converging,
action = reaction, compliance = refactor) are in ``test_contact_methods.py``.

Nodal contact forces are taken, where the test says so, from the equilibrium of each body
(``K u`` at its contact nodes, assembled here with :func:`vfrs.stiffness`), not from the
effect's own bookkeeping, so that the check does not trust the code it checks. Run with ``-s``
to see the tables.
"""

from __future__ import annotations

import numpy as np
import pytest

import vfrs
from vfrs.contact import tributary_areas

E = 1e4  # Pa
RHO = 1000.0  # kg/m^3


def _material(nu, rho=RHO):
    return {"model": "isotropic", "E": E, "nu": nu, "rho": rho}


def _body_forces(result, body, nu):
    """Nodal forces K u of one body (static runs: the contact and support forces on it)."""
    part = next(p for p in result.problem.bodies if p.name == body)
    K = vfrs.stiffness(part.mesh, vfrs.Isotropic(E=E, nu=nu, rho=RHO))
    return part, (K @ result.u[part.nodes].ravel()).reshape(-1, 3)


# ---------------------------------------------------------------------------------------------
# Hertz
# ---------------------------------------------------------------------------------------------
HERTZ_W = 0.01  # quarter block W x W x W
HERTZ_R = 5 * HERTZ_W  # radius of curvature of the paraboloid face
HERTZ_NU = 0.3
HERTZ_A = 0.1 * HERTZ_W  # the Hertz contact radius the approach is chosen for
HERTZ_GRADING = 3.0


def paraboloid_block(width=1.0, radius=5.0, cells=8, grading=3.0):
    """A cube [0, width]^3 whose bottom face is the paraboloid z = (x^2 + y^2) / (2 radius),
    its top face flat at z = width; nodes graded towards the pole (0, 0, 0) by the tensor map
    x -> width (x / width)^grading on every axis (axis-aligned hexahedra stay hexahedra, so the
    Kuhn tetrahedra stay valid), then each node lifted by (1 - z / width) of the paraboloid's
    height. The quarter of a Hertz specimen: symmetry planes x = 0 and y = 0."""
    m = vfrs.meshes.box((1.0, 1.0, 1.0), (cells, cells, cells))
    p = m.points ** grading * width
    p[:, 2] += (1.0 - p[:, 2] / width) * (p[:, 0] ** 2 + p[:, 1] ** 2) / (2.0 * radius)
    m.points = p
    return m


@pytest.fixture
def hertz_mesh(monkeypatch):
    monkeypatch.setitem(vfrs.meshes.GENERATORS, "paraboloid_block", paraboloid_block)


def hertz_run(cells):
    """One Hertz level: returns the total force, the contact radius and their closed forms."""
    delta = HERTZ_A**2 / HERTZ_R
    scene = vfrs.Scene.from_dict({
        "bodies": [{
            "name": "ball",
            "mesh": {"builtin": "paraboloid_block", "width": HERTZ_W, "radius": HERTZ_R, "cells": cells, "grading": HERTZ_GRADING},
            "material": _material(HERTZ_NU),
            "fixed": [
                {"surface": "zmax", "components": ["z"], "displacement": [0, 0, -delta]},
                {"surface": "xmin", "components": ["x"]},
                {"surface": "ymin", "components": ["y"]},
            ],
        }],
        "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
        "contact": {"method": "lagrange", "detection": "bvh", "surface": "zmin", "search_distance": 10 * delta},
        "time": {"mode": "static"},
        "output": {"energy": False},
    })
    r = vfrs.run(scene, progress=False)
    part, f = _body_forces(r, "ball", HERTZ_NU)
    nodes = np.unique(part.mesh.surfaces["zmin"])
    fz = f[nodes, 2]
    x = part.mesh.points[nodes]
    F_effect = 4 * r.history["contact_force.ball"][-1][2]  # four quarters
    F = 4 * fz.sum()
    # Hertz pressure p0 sqrt(1 - r^2/a^2): <r^2> weighted by pressure is 2 a^2 / 5.
    a = np.sqrt(2.5 * np.sum(fz * (x[:, 0] ** 2 + x[:, 1] ** 2)) / fz.sum())
    E_star = E / (1 - HERTZ_NU**2)
    return {
        "cells": cells,
        "F": F,
        "F_effect": F_effect,
        "a": a,
        "F_hertz": 4 / 3 * E_star * np.sqrt(HERTZ_R) * delta**1.5,
        "a_hertz": np.sqrt(HERTZ_R * delta),
        "F_of_a": 4 / 3 * E_star * a**3 / HERTZ_R,
        "penetration": r.history["max_penetration"][-1],
        "active": int(r.history["active_pairs"][-1]),
        "delta": delta,
    }


def _hertz_table(levels):
    print("\nHertz, paraboloid R = 5 W on a rigid plane, a_Hertz = 0.1 W, nu = 0.3, Lagrange")
    print(f"{'cells':>5} {'F/F_H-1':>9} {'a/a_H-1':>9} {'F/F(a)-1':>9} {'active':>6}")
    for L in levels:
        print(f"{L['cells']:5d} {L['F'] / L['F_hertz'] - 1:+9.4f} {L['a'] / L['a_hertz'] - 1:+9.4f} "
              f"{L['F'] / L['F_of_a'] - 1:+9.4f} {L['active']:6d}")


def test_hertz_converges(hertz_mesh):
    """Hertz: a paraboloid of curvature radius R = 5 W (a quarter W x W x W block with
    symmetry planes x = 0, y = 0, top face pushed down by delta, free to slide) on a rigid
    frictionless plane; delta = a_H^2 / R with a_H = 0.1 W.

    Closed forms (half-space, E* = E / (1 - nu^2)): F = 4/3 E* sqrt(R) delta^(3/2),
    a = sqrt(R delta), and F = 4/3 E* a^3 / R. The contact radius is measured without
    thresholds from the nodal contact forces: Hertz's pressure has <r^2> = 2 a^2 / 5.

    Why not a hemisphere: a body of size L adds a compliance of order F / (E L), a relative
    change of order a / L in the approach; with the built-in hemisphere a / R = sqrt(delta / R)
    is 0.1 to 0.2 at contact patches its uniform meshes resolve, i.e. 5-15 % model error
    before any discretization error. Here a / W = 0.1 and the graded mesh puts ~7 elements
    across a at 16 cells.

    Measured (P1 tets, O(h) in the force): F error +29.7 %, +19.1 %, +14.6 % at 8, 12, 16
    cells; Richardson extrapolation to h = 0 -0.6 %; contact radius within 2.2 % from 12
    cells on. Tolerances: the force error falls at each refinement; < 16 % at 16 cells; the
    O(h)-extrapolated force within 2 %; contact radius within 3 % at 12 and 16 cells;
    F(a) relation within 10 % at 16 cells.
    """
    levels = [hertz_run(c) for c in (8, 12, 16)]
    _hertz_table(levels)
    errF = [L["F"] / L["F_hertz"] - 1 for L in levels]
    erra = [L["a"] / L["a_hertz"] - 1 for L in levels]
    errFa = [L["F"] / L["F_of_a"] - 1 for L in levels]
    for L in levels:
        # The effect's total force is the body's equilibrium: same number two ways.
        assert L["F_effect"] == pytest.approx(L["F"], rel=1e-9)
        assert L["penetration"] < 1e-10 * L["delta"]
    assert errF[0] > errF[1] > errF[2] > 0, errF
    assert errF[2] < 0.16
    # O(h) convergence: F(h) = F0 + c h; extrapolate from 8 and 16 cells.
    F0 = 2 * levels[2]["F"] - levels[0]["F"]
    assert abs(F0 / levels[2]["F_hertz"] - 1) < 0.02, F0 / levels[2]["F_hertz"] - 1
    assert abs(erra[1]) < 0.03 and abs(erra[2]) < 0.03, erra
    assert errFa[0] > errFa[1] > errFa[2] and abs(errFa[2]) < 0.1, errFa


@pytest.mark.slow
def test_hertz_finer(hertz_mesh):
    """Hertz at 24 cells (about 35 s): force error below 11 % (measured +9.8 %), the
    extrapolation from 12 and 24 cells within 2 % (measured +0.6 %), radius within 2.5 %
    (measured +1.6 %), F(a) within 6 % (measured +4.7 %)."""
    levels = [hertz_run(c) for c in (12, 24)]
    _hertz_table(levels)
    fine = levels[1]
    assert fine["F"] / fine["F_hertz"] - 1 < 0.11
    F0 = 2 * fine["F"] - levels[0]["F"]
    assert abs(F0 / fine["F_hertz"] - 1) < 0.02
    assert abs(fine["a"] / fine["a_hertz"] - 1) < 0.025
    assert abs(fine["F"] / fine["F_of_a"] - 1) < 0.06
