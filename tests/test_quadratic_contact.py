"""Contact on quadratic (ten-node) bodies (issue 47, item 3): the contact patch test on matching
and non-matching interfaces, the pressure recovered from the nodal forces of six-node faces,
and the Hertz benchmark at order 2 against order 1.

Contact on a quadratic body works on its faces' flat sub-triangles (node-to-surface, two passes,
every node a slave: corners and mid-edge nodes alike). The consistent forces of a uniform
pressure on a flat six-node face are 0 at its corners and p A / 3 at its mid-edge nodes; the
nodal pressure is recovered by projecting the nodal forces onto the faces' pressure field
(:mod:`vfrs.enforcement.quadratic_pressure`)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import vfrs

sys.path.insert(0, str(Path(__file__).parent))
import test_contact_verification as verification  # noqa: E402  (the P1 Hertz problem, reused)

E, NU, W, H, D = 1e4, 0.3, 0.01, 0.01, 1e-4


def _patch(cells_lower, cells_upper, method="lagrange"):
    def block(name, z0, cells, fixed):
        return {"name": name, "order": 2,
                "mesh": {"builtin": "box", "size": [W, W, H], "cells": list(cells), "origin": [0, 0, z0]},
                "material": {"model": "isotropic", "E": E, "nu": NU, "rho": 1000.0},
                "fixed": fixed + [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}]}

    contact = {"method": method, "detection": "bvh", "surface": {"lower": "zmax", "upper": "zmin"}}
    if method == "penalty":
        contact["kappa"] = 1e12
    scene = vfrs.Scene.from_dict({
        "bodies": [block("lower", 0.0, cells_lower, [{"surface": "zmin", "components": ["z"]}]),
                   block("upper", H, cells_upper, [{"surface": "zmax", "components": ["z"], "displacement": [0, 0, -D]}])],
        "contact": contact, "time": {"mode": "static"}, "output": {"energy": False}})
    with pytest.warns(vfrs.errors.ResolutionWarning):  # 1 mm^2 sensor discs on 3-4 cells
        r = vfrs.run(scene, progress=False)
    p = E * D / (2 * H)
    X = r.problem.points
    exact = np.column_stack([NU * p * X[:, 0] / E, NU * p * X[:, 1] / E, -p * X[:, 2] / E])
    out = {"u": np.abs(r.u - exact).max() / D, "total": r.history["contact_force.upper"][-1][2] / (p * W * W)}
    worst = 0.0
    for part in r.problem.bodies:
        K = vfrs.stiffness(part.mesh, vfrs.Isotropic(E=E, nu=NU, rho=1000.0))
        f = (K @ r.u[part.nodes].ravel()).reshape(-1, 3)
        tri = part.mesh.surfaces["zmax" if part.name == "lower" else "zmin"]
        consistent = part.mesh.quadratic_faces().forces(part.mesh.points, tri, pressure=np.full(part.mesh.n_points, p))
        nodes = np.unique(tri)
        worst = max(worst, np.abs(np.abs(f[nodes]) - np.abs(consistent[nodes])).max() / np.abs(consistent[nodes]).max())
    out["nodal"] = worst
    for key in ("contact_pressure_sensor", "contact_pressure_disc", "contact_pressure_max"):
        out[key] = r.history[key][-1] / p
    out["area"] = r.history["contact_area_effective"][-1] / (2 * W * W)  # both bodies' surfaces
    return out


@pytest.mark.parametrize("method", ["lagrange", "penalty"])
def test_patch_matching_quadratic(method):
    """Two P2 blocks with matching interfaces (3 x 3 x 2 cells each) pressed together: the
    displacement is the exact uniaxial field (1e-9 of d; penalty at kappa = 1e12 Pa/m in series:
    1e-4), every interface node carries the consistent P2 load of the uniform pressure (0 at the
    corners, p A / 3 at the mid-edge nodes; measured 2e-12), and the projected pressure reads p
    on the sensor, the exact disc, the maximum and the effective area (1e-9). Force over the
    flat sub-triangles' tributary area would read 0 and 4 p / 3 side by side."""
    out = _patch((3, 3, 2), (3, 3, 2), method)
    tol = 1e-9 if method == "lagrange" else 1e-4
    assert out["u"] < tol and abs(out["total"] - 1) < tol and out["nodal"] < tol
    for key in ("contact_pressure_sensor", "contact_pressure_disc", "contact_pressure_max", "area"):
        assert abs(out[key] - 1) < tol, (key, out[key])


@pytest.mark.xfail(strict=True, reason=(
    "node-to-surface contact on quadratic faces fails the patch test on non-matching interfaces: "
    "4x4x2 against 3x3x2 P2 cells, Lagrange, measured displacement error 2.7e-2 of d, total force "
    "0.9943 p W^2, nodal forces 40-59 % off the consistent P2 load, the sensor reading 3.8 p. The "
    "consistent loads of a six-node face (0 at corners) are not in the span of the two-pass "
    "node-to-sub-triangle constraints; a mortar rule (integrals over the faces) is needed"))
def test_patch_nonmatching_quadratic():
    out = _patch((4, 4, 2), (3, 3, 2))
    assert out["u"] < 1e-6 and abs(out["total"] - 1) < 1e-6


def _hertz(order, cells):
    original = vfrs.Scene.from_dict

    def at_order(d, *a, **k):
        for b in d["bodies"]:
            if order == 2:
                b["order"] = 2
        return original(d, *a, **k)

    vfrs.Scene.from_dict = at_order  # type: ignore[method-assign]
    try:
        L = verification.hertz_run(cells)
    finally:
        vfrs.Scene.from_dict = original  # type: ignore[method-assign]
    return L["F"] / L["F_hertz"] - 1, L["a"] / L["a_hertz"] - 1


def test_hertz_quadratic_beats_linear_at_equal_nodes():
    """Hertz (the P1 test's problem: paraboloid R = 5 W on a rigid plane, a_H = 0.1 W, Lagrange)
    at order 2, the mid-edge nodes of the curved face on the paraboloid. Measured force errors
    +16.6 / +10.5 / +7.9 % at 4 / 6 / 8 cells (P2 on 8 cells has the nodes of P1 on 16, where P1
    is +14.6 %; P1 on 8 cells +29.7 %); contact radius +10.1 / +6.9 / +4.7 %. Asserted: the
    force error falls at each refinement; at 8 cells below 9 % and below P1's at the same cells
    and at the same nodes; the radius below 6 % at 8 cells."""
    errs = [_hertz(2, c) for c in (4, 6, 8)]
    F = [e[0] for e in errs]
    assert F[0] > F[1] > F[2] > 0
    p1_same_cells, _ = _hertz(1, 8)
    p1_same_nodes, _ = _hertz(1, 16)
    assert F[2] < 0.09 and F[2] < p1_same_nodes < p1_same_cells
    assert abs(errs[2][1]) < 0.06


@pytest.mark.xfail(strict=True, reason=(
    "the P2 Hertz force stalls near +6 %: measured +7.9 / +6.4 / +6.0 % at 8 / 12 / 16 cells "
    "(P1: +14.6 / +9.8 % at 16 / 24 cells, extrapolating to -0.6 %). Node-to-plane contact gives each "
    "node a force >= 0, while the consistent loads of a six-node face at the rim of the patch are "
    "negative at its corners"))
def test_hertz_quadratic_converges():
    F, _ = _hertz(2, 12)
    assert abs(F) < 0.03
