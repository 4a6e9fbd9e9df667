"""Statics through scenes: a bar under end traction, a block under gravity, a prescribed stretch.

With the three symmetry planes held by roller conditions (one component each), the exact
fields are linear for the bar and P1 reproduces them, so the checks are at round-off level.
"""

import numpy as np
import pytest

import vfrs

ROLLERS = [
    {"surface": "xmin", "components": ["x"]},
    {"surface": "ymin", "components": ["y"]},
    {"surface": "zmin", "components": ["z"]},
]


def bar(loads=(), fixed=ROLLERS, steps=1, nu=0.3, jitter=0.2, size=(0.05, 0.01, 0.02), gravity=(0, 0, 0), rho=1000.0):
    return vfrs.Scene.from_dict({
        "gravity": list(gravity),
        "bodies": [{"name": "bar",
                    "mesh": {"builtin": "box", "size": list(size), "cells": [6, 2, 3], "jitter": jitter},
                    "material": {"model": "isotropic", "E": 2e4, "nu": nu, "rho": rho},
                    "fixed": list(fixed), "loads": list(loads)}],
        "time": {"mode": "static", "load_steps": steps}})


def test_bar_under_end_traction_stretches_by_FL_over_EA():
    s = 300.0  # Pa on the end face
    res = vfrs.run(bar([{"type": "traction", "surface": "xmax", "value": [s, 0, 0]}]), progress=False)
    L, A, E = 0.05, 0.01 * 0.02, 2e4
    F = s * A
    end = res.problem.bodies[0].mesh.surface_nodes("xmax")
    np.testing.assert_allclose(res.u[end, 0], F * L / (E * A), rtol=1e-9)
    # Lateral contraction nu * strain, also exact (uniform stress is in the P1 space).
    top = res.problem.bodies[0].mesh.surface_nodes("zmax")
    np.testing.assert_allclose(res.u[top, 2], -0.3 * s / E * 0.02, rtol=1e-9)
    # The support at x = 0 pulls back with -F.
    R = res.history["reaction_force.bar.xmin"][-1]
    assert R[0] == pytest.approx(-F, rel=1e-9)


def test_pressure_on_the_end_is_a_compressive_traction():
    res = vfrs.run(bar([{"type": "pressure", "surface": "xmax", "value": 300.0}]), progress=False)
    end = res.problem.bodies[0].mesh.surface_nodes("xmax")
    np.testing.assert_allclose(res.u[end, 0], -300.0 * 0.05 / 2e4, rtol=1e-9)


def test_load_steps_scale_linearly_and_work_equals_twice_nothing_lost():
    res = vfrs.run(bar([{"type": "traction", "surface": "xmax", "value": [300.0, 0, 0]}], steps=4), progress=False)
    np.testing.assert_allclose(res.t, [0.25, 0.5, 0.75, 1.0])
    U = res.history["elastic_energy"]
    np.testing.assert_allclose(U / U[-1], res.t**2, rtol=1e-9)
    # Trapezoidal work of a linearly ramped load on a linear body equals the stored energy.
    assert res.history["external_work"][-1] == pytest.approx(U[-1], rel=1e-9)


def test_prescribed_displacement_gives_the_reaction_E_A_delta_over_L():
    delta = 1e-4
    fixed = ROLLERS + [{"surface": "xmax", "components": ["x"], "displacement": [delta, 0, 0], "name": "pull"}]
    res = vfrs.run(bar(fixed=fixed), progress=False)
    F = 2e4 * 0.01 * 0.02 * delta / 0.05
    # The support at the pulled end pulls along +x, the one at x = 0 holds back along -x.
    assert res.history["reaction_force.bar.pull"][-1][0] == pytest.approx(F, rel=1e-9)
    assert res.history["reaction_force.bar.xmin"][-1][0] == pytest.approx(-F, rel=1e-9)
    assert "prescribed_displacement" in res.effects


def test_selectors_fix_the_same_nodes_as_named_surfaces():
    load = [{"type": "traction", "axis": "x", "at": 0.05, "value": [300.0, 0, 0]}]
    sel = [{"axis": "x", "below": 0.0, "components": ["x"]}, {"axis": "y", "at": 0.0, "components": ["y"]},
           {"axis": "z", "below": 1e-9, "components": ["z"]}]
    a = vfrs.run(bar(load, fixed=sel, jitter=0.0), progress=False)
    b = vfrs.run(bar([{"type": "traction", "surface": "xmax", "value": [300.0, 0, 0]}], jitter=0.0), progress=False)
    np.testing.assert_allclose(a.u, b.u, rtol=1e-12, atol=1e-15)


def test_gravity_on_a_block_gives_rho_g_H_reactions():
    H, rho, g = 0.02, 1070.0, 9.81
    res = vfrs.run(bar(gravity=(0, 0, -g), rho=rho, jitter=0.0, nu=0.0), progress=False)
    R = res.history["reaction_force.bar.zmin"][-1]
    area = 0.05 * 0.01
    assert R[2] / area == pytest.approx(rho * g * H, rel=1e-10)  # total: the weight
    assert abs(R[0]) < 1e-12 and abs(R[1]) < 1e-12
    # and it is the weight whatever the mesh: consistent loads balance exactly.
    p = res.problem
    assert R[2] == pytest.approx(rho * g * p.bodies[0].mesh.volume, rel=1e-10)


def test_gravity_in_dynamics_settles_on_the_static_answer_with_damping():
    sc = bar(gravity=(0, 0, -9.81), jitter=0.0).to_dict()
    sc["bodies"][0]["damping"] = {"a0": 300.0, "a1": 0.0}  # every mode decays like exp(-a0 t / 2)
    sc["time"] = {"mode": "dynamic", "step": 2e-3, "end": 0.3, "alpha": -0.1}
    dyn = vfrs.run(vfrs.Scene.from_dict(sc), progress=False)
    st = vfrs.run(bar(gravity=(0, 0, -9.81), jitter=0.0), progress=False)
    np.testing.assert_allclose(dyn.u, st.u, atol=1e-6 * np.abs(st.u).max())


def test_prescribed_motion_in_dynamics_carries_the_body_and_the_support_pays_m_a():
    # The xmin face is driven along x by d r(t) (smoothstep ramp over T = 0.2 s, much longer
    # than the bar's axial period 4 L / c = 2 ms): the bar follows nearly rigidly, and the
    # support's force is the bar's mass times the prescribed acceleration d r''(t). The rest is
    # ringing from the jerk at the ramp's ends, about m d r'''(0) / w = 1.5 % of the peak.
    d, T = 1e-3, 0.2
    sc = vfrs.Scene.from_dict({
        "bodies": [{"name": "bar", "mesh": {"builtin": "box", "size": [0.05, 0.01, 0.01], "cells": [2, 2, 2]},
                    "material": {"model": "isotropic", "E": 1e7, "nu": 0.3, "rho": 1000.0},
                    "fixed": [{"surface": "xmin", "displacement": [d, 0.0, 0.0], "ramp": T, "name": "drive"}]}],
        "time": {"mode": "dynamic", "step": 1e-3, "end": 0.25, "alpha": -0.1}})
    res = vfrs.run(sc, progress=False)
    from vfrs.dynamics.problem import ramp

    r = np.array([ramp(t, T) for t in res.t])
    np.testing.assert_allclose(res.u[:, 0], d, rtol=2e-3)  # at rest at d after the ramp
    m = 1000.0 * 0.05 * 0.01 * 0.01
    R = res.history["reaction_force.bar.drive"][:, 0]
    expected = m * d * r[:, 2]
    # 2 % here; leaving out the inertial coupling M_fp a_p of the driven face gives 8 % on
    # this coarse mesh (half the mass sits next to the face).
    assert np.abs(R - expected).max() < 0.04 * np.abs(expected).max()
    assert "prescribed_displacement" in res.effects


@pytest.mark.parametrize("mode", ["static", "dynamic"])
def test_surfaces_sharing_an_edge_move_it_once(mode):
    """Two fixed surfaces that share nodes (xmin and ymin share an edge) and prescribe the same
    displacement move those nodes by it once: a rigid translation, u = d at every node, no
    stress. (The shared DOFs were prescribed by both groups and moved by 2 d: a block
    translated by 0.15 mm this way diverged in statics once contact pressed on it.)"""
    d = [1e-4, -2e-5, 3e-5]
    body = {"name": "b", "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [2, 2, 2]},
            "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
            "fixed": [{"surface": "xmin", "displacement": d}, {"surface": "ymin", "displacement": d}]}
    time = {"mode": "static"} if mode == "static" else {"mode": "dynamic", "step": 1e-3, "end": 0.2, "alpha": -0.3}
    if mode == "dynamic":  # ramped, and the ringing damped out (every mode decays like exp(-150 t))
        body["fixed"] = [{**f, "ramp": 0.02} for f in body["fixed"]]
        body["damping"] = {"a0": 300.0, "a1": 0.0}
    res = vfrs.run(vfrs.Scene.from_dict({"bodies": [body], "time": time}), progress=False)
    np.testing.assert_allclose(res.u, np.tile(d, (len(res.u), 1)), rtol=1e-9 if mode == "static" else 1e-6,
                               atol=0)


def test_supports_sharing_an_edge_split_its_reaction_once():
    """Two clamped faces that share an edge (xmin and zmin, all components): each of the
    edge's fixed DOFs is the first group's (the one that names it first, as its prescribed
    motion is), so the groups' reactions add up to the total support force: minus the weight,
    to round-off. (They counted the edge in both groups, 1.6 mN too much on the M5 folds' walls.)"""
    rho, g = 1070.0, 9.81
    clamped = [{"surface": "xmin"}, {"surface": "zmin"}]
    res = vfrs.run(bar(fixed=clamped, gravity=(0, 0, -g), rho=rho, jitter=0.0), progress=False)
    weight = rho * g * 0.05 * 0.01 * 0.02
    total = res.history["reaction_force.bar.xmin"][-1] + res.history["reaction_force.bar.zmin"][-1]
    np.testing.assert_allclose(total, [0.0, 0.0, weight], rtol=0, atol=1e-12 * weight)
