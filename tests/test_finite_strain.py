"""Finite strain in statics (issue 14, first slice): verification of the Newton path.

Each test checks physics against an exact answer (or a scaling law) and can fail:
(a) a rigid 90 degree rotation prescribed on the boundary leaves no force and no energy;
(b) uniaxial stretch to 1.5 against the closed form of the compressible neo-Hookean law;
(c) Newton converges quadratically (the residual ratios), modified Newton linearly;
(d) small strains reproduce the linear static solution, the difference growing like the load squared;
(e) bad input gets the project's errors (file, key path, what to do);
(f) a cantilever under a tip load at large deflection against the elastica (Mattiasson 1981).
"""

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

import vfrs
from vfrs.dynamics import build_problem
from vfrs.dynamics.newton import NewtonOptions, NewtonParams, newton_solve
from vfrs.finite_strain import FiniteStrainModel

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
E, NU = 10e3, 0.3
MU, LAM = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))


def block_scene(material, fixed, loads=(), load_steps=1, size=(0.01, 0.01, 0.01), cells=(3, 3, 3), newton=None):
    time = {"mode": "static", "load_steps": load_steps}
    if newton is not None:
        time["newton"] = newton
    return vfrs.Scene.from_dict({
        "bodies": [{"name": "block", "mesh": {"builtin": "box", "size": list(size), "cells": list(cells)},
                    "material": material, "fixed": list(fixed), "loads": list(loads)}],
        "time": time})


NEO = {"model": "neo_hookean", "E": E, "nu": NU}
SVK = {"model": "st_venant_kirchhoff", "E_p": 2e3, "E_z": 40e3, "nu_p": 0.9, "nu_pz": 0.0, "G_pz": 10e3}
ALL_FACES = ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"]


# ---- (a) rigid rotation ---------------------------------------------------------------------
@pytest.mark.parametrize("material", [NEO, SVK], ids=["neo_hookean", "svk_vocal_fold_constants"])
def test_rigid_rotation_of_90_degrees_leaves_no_force_and_no_energy(material):
    """Every boundary node of a 3 x 3 x 3-cell block (8 interior nodes free) is rotated about
    the block's centre axis parallel to z, by 22.5, 45, 67.5 and 90 degrees in four load steps
    (the prescribed values are the exact rotation at each step, u = (R - I)(X - c)). Newton
    must find the interior nodes on the same rigid motion, with internal force and strain
    energy zero to round-off: bounds 1e-12 (u / L), 1e-12 (|f_int| / (E L^2)) and 1e-12
    (energy / (E V)). The same motion costs a linear body an energy of order E V (checked, so
    the bounds discriminate: small-strain kinematics fail this test)."""
    scene = block_scene(material, ALL_FACES)
    problem = build_problem(scene)
    model = FiniteStrainModel(problem)
    X = problem.points
    c = X.mean(axis=0)
    L = 0.01
    u = np.zeros(problem.n_dofs)
    params = NewtonParams(residual_tolerance=1e-10)
    for k in range(1, 5):
        th = np.pi / 2 * k / 4
        R = np.array([[np.cos(th), -np.sin(th), 0.0], [np.sin(th), np.cos(th), 0.0], [0.0, 0.0, 1.0]])
        exact = ((X - c) @ R.T + c - X).ravel()
        info = newton_solve(model, u, np.zeros(problem.n_dofs), exact[problem.fixed], NewtonOptions(params, f"rotation step {k}"))
        assert info.iterations <= 6
    f, energy = model.force(u)
    err_u = np.abs(u - exact).max() / L
    err_f = np.abs(f).max() / (E * L**2)
    stiff = 2e3 if material is SVK else E
    err_w = abs(energy) / (stiff * L**3)
    print(f"rotation 90 deg ({material['model']}): |u - u_rigid|/L = {err_u:.2e}, |f_int|/(E L^2) = {err_f:.2e}, "
          f"W/(E V) = {err_w:.2e}, Newton iterations in the last step {info.iterations}")
    assert err_u < 1e-12
    assert err_f < 1e-12
    assert err_w < 1e-12
    K = problem.K
    assert 0.5 * exact @ (K @ exact) / (stiff * L**3) > 0.1  # the linear body's spurious energy


# ---- (b) uniaxial stretch -------------------------------------------------------------------
def neo_hookean_uniaxial(stretch, mu=MU, lam=LAM):
    """Closed form of the compressible neo-Hookean block in uniaxial stretch.

    W = mu/2 (I1 - 3) - mu ln J + lam/2 (ln J)^2 with principal stretches (l, s, s): the
    Kirchhoff stresses are tau_i = l_i dW/dl_i = mu (l_i^2 - 1) + lam ln J, J = l s^2. Free
    lateral faces: tau_2 = tau_3 = 0, i.e. mu (s^2 - 1) + lam ln(l s^2) = 0, solved for s by
    brentq (the left side rises monotonically in s, from -inf at s -> 0 to +inf). Axial Cauchy stress sigma = tau_1 / J = mu (l^2 - s^2) / J (using tau_2 = 0);
    nominal (1st Piola-Kirchhoff) stress P = tau_1 / l = sigma s^2, the force per reference
    area. Returns (s, P, sigma, W)."""
    s = brentq(lambda s: mu * (s * s - 1) + lam * np.log(stretch * s * s), 1e-3, 1e3, xtol=1e-15, rtol=1e-15)
    J = stretch * s * s
    tau1 = mu * (stretch**2 - 1) + lam * np.log(J)
    W = mu / 2 * (stretch**2 + 2 * s * s - 3) - mu * np.log(J) + lam / 2 * np.log(J) ** 2
    return s, tau1 / stretch, tau1 / J, W


def test_uniaxial_stretch_to_1_5_matches_the_closed_form_neo_hookean_law():
    """examples/stretch_neo_hookean.toml: a 1 cm cube (3 x 3 x 3 cells, 162 tetrahedra), symmetry
    conditions on xmin, ymin, zmin, the end face pulled to stretch 1.5 in four load steps,
    lateral faces free. The deformation is homogeneous, so P1 is exact: at every load step the
    reaction / reference area equals the closed-form nominal stress, the lateral stretch the
    closed-form s and the recorded energy W V, each to 1e-9 relative (measured: about 1e-15).
    Sanity of the closed form: Cauchy stress > nominal (the section shrinks), and the linear
    law's E (l - 1) is far off (> 10 %), so a linear solution would fail."""
    res = vfrs.run(EXAMPLES / "stretch_neo_hookean.toml", progress=False)
    h = res.history
    L, A = 0.01, 1e-4
    corner = res.probe([L, L, L])["displacement"]
    errs = []
    for k, lam in enumerate(h["t"]):
        stretch = 1.0 + 0.5 * lam
        s, P, sigma, W = neo_hookean_uniaxial(stretch)
        assert corner[k, 0] / L == pytest.approx(stretch - 1, rel=1e-12)
        e_P = abs(h["reaction_force.block.pull"][k, 0] / A - P) / P
        e_s = abs(1 + corner[k, 1] / L - s) / s
        e_z = abs(1 + corner[k, 2] / L - s) / s
        e_W = abs(h["elastic_energy"][k] - W * L**3) / (W * L**3)
        errs.append(max(e_P, e_s, e_z, e_W))
        assert max(e_P, e_s, e_z, e_W) < 1e-9, (k, e_P, e_s, e_z, e_W)
    s, P, sigma, W = neo_hookean_uniaxial(1.5)
    print(f"stretch 1.5: s = {s:.12f}, P = {P:.6f} Pa, sigma = {sigma:.6f} Pa; worst relative error over the "
          f"load steps {max(errs):.2e}; Newton iterations per load step {h['newton_iterations'].astype(int).tolist()}")
    assert sigma > P
    assert abs(E * 0.5 - P) / P > 0.1
    assert np.all(h["newton_iterations"] <= 6)
    assert np.all(h["newton_residual"] < 1e-10)


# ---- (c) quadratic convergence --------------------------------------------------------------
def sheared_block(newton):
    """A 1 x 1 x 2 cm neo-Hookean block (2 x 2 x 4 cells) clamped at zmin, its top face moved
    by (5, 2, 10) mm (50 % stretch with shear) in one load step: an inhomogeneous large
    deformation."""
    return block_scene(NEO, ["zmin", {"surface": "zmax", "displacement": [5e-3, 2e-3, 10e-3]}],
                       size=(0.01, 0.01, 0.02), cells=(2, 2, 4), newton=newton)


def solve_once(scene):
    problem = build_problem(scene)
    model = FiniteStrainModel(problem)
    u = np.zeros(problem.n_dofs)
    info = newton_solve(model, u, problem.external_force(1.0, static=True), problem.fixed_values(1.0, static=True),
                        NewtonOptions(scene.time.newton, "one load step"))
    return info


def quadratic_ratios(e):
    """e_k+1 / e_k^2 of the relative residuals, over the asymptotic range (e_k < 0.1) and above
    round-off (e_k+1 > 1e-14)."""
    return [b / a**2 for a, b in zip(e[:-1], e[1:]) if a < 0.1 and b > 1e-14]


def test_newton_converges_quadratically_and_modified_newton_linearly():
    """Full Newton in one load step: near the solution the relative residual e_k+1 <= C e_k^2;
    measured ratios are printed, bound C = 10, and at least two ratios must be in the
    asymptotic range (else the test proves nothing). Modified Newton (refactor only when the
    residual ratio exceeds 0.5) on the same problem converges to the same solution but
    linearly: its ratios e_k+1 / e_k^2 grow past 1e3, which is what an inconsistent tangent
    would also give full Newton, so the bound discriminates."""
    full = solve_once(sheared_block({"method": "full", "residual_tolerance": 1e-13, "increment_tolerance": 1e-13}))
    e = full.relative_residuals[1:]  # after the predictor (the start of the step is in balance: e_0 = 0)
    q = quadratic_ratios(e)
    print("full Newton: relative residuals", [f"{x:.2e}" for x in e], "ratios e_k+1/e_k^2", [f"{x:.3g}" for x in q],
          f"factorizations {full.factorizations}, line-search steps {full.steps}")
    assert len(q) >= 2
    assert max(q) < 10.0
    assert e[-1] < 1e-13
    mod = solve_once(sheared_block({"method": "modified", "residual_tolerance": 1e-13, "increment_tolerance": 1e-13,
                                    "max_iterations": 60}))
    em = mod.relative_residuals[1:]
    qm = [b / a**2 for a, b in zip(em[:-1], em[1:]) if b > 1e-14]
    print("modified Newton: relative residuals", [f"{x:.2e}" for x in em], f"factorizations {mod.factorizations} "
          f"(full: {full.factorizations}), largest e_k+1/e_k^2 {max(qm):.3g}")
    assert max(qm) > 1e3
    assert mod.factorizations < full.factorizations
    assert mod.iterations > full.iterations


def test_line_search_carries_newton_where_full_steps_fail():
    """A 1 x 1 x 3 cm neo-Hookean column (3 x 3 x 9 cells) clamped at zmin, a dead shear
    traction of 200 Pa on its top in one load step (tip deflection 1.4 cm, about half the
    length). Full Newton steps leave the stable path: the tangent of the third iterate is not
    positive definite and the step stops, saying so. With the line search (on the residual
    along the Newton direction) the step converges (measured: 11 iterations) to the solution
    reached in 4 load steps (same tip to 1e-8 relative)."""
    def column(line_search, load_steps):
        return block_scene(NEO, ["zmin"], loads=[{"type": "traction", "surface": "zmax", "value": [200.0, 0.0, 0.0]}],
                           size=(0.01, 0.01, 0.03), cells=(3, 3, 9), load_steps=load_steps,
                           newton={"line_search": line_search})

    with pytest.raises(vfrs.ConvergenceError, match=r"load step 1/1 .*K_T is not positive definite.*Try more load steps"):
        vfrs.run(column(False, 1), progress=False)
    one = vfrs.run(column(True, 1), progress=False)
    four = vfrs.run(column(True, 4), progress=False)
    tip1, tip4 = np.abs(one.u[:, 0]).max(), np.abs(four.u[:, 0]).max()
    print(f"200 Pa in one load step with the line search: {int(one.history['newton_iterations'][0])} iterations, tip "
          f"{tip1 * 1e3:.4f} mm; in 4 load steps {four.history['newton_iterations'].astype(int).tolist()}, tip {tip4 * 1e3:.4f} mm")
    assert tip1 > 0.01
    assert tip1 == pytest.approx(tip4, rel=1e-8)
    assert np.abs(one.u - four.u).max() < 1e-8 * tip4


# ---- (d) small strains ----------------------------------------------------------------------
def cantilever(material, load):
    """A 1 x 1 x 4 cm column clamped at zmin, a dead traction (load, 0, load/2) Pa on zmax."""
    return block_scene(material, ["zmin"], loads=[{"type": "traction", "surface": "zmax", "value": [load, 0.0, load / 2]}],
                       size=(0.01, 0.01, 0.04), cells=(2, 2, 6),
                       newton=None if material["model"] == "isotropic" else {"residual_tolerance": 1e-10})


def test_small_strains_reproduce_the_linear_static_solution_to_first_order():
    """Same mesh, same loads: neo-Hookean by Newton against the existing linear static path
    (isotropic, the same E and nu). The difference is O(strain) relative to u_lin, and, being
    the first nonlinear term, grows like the load squared: doubling the load multiplies
    |u_nh - u_lin| by 4 (bound 4 +- 0.1; measured 3.998). The strain scale of this bending
    problem is the tip rotation theta = max|u_lin| / length (3.1e-3 and 6.3e-3 here); the
    relative difference must stay below theta (measured 0.77 theta)."""
    diffs, rels = [], []
    for load in (1.0, 2.0):
        lin = vfrs.run(cantilever({"model": "isotropic", "E": E, "nu": NU}, load), progress=False)
        nh = vfrs.run(cantilever(NEO, load), progress=False)
        du = np.linalg.norm(nh.u - lin.u)
        diffs.append(du)
        rels.append(du / np.linalg.norm(lin.u))
        theta = np.abs(lin.u).max() / 0.04
        assert 0.1 * theta < rels[-1] < theta  # first order in the strain: neither zero nor larger
        assert nh.history["newton_iterations"][-1] <= 4
    print(f"|u_nh - u_lin| / |u_lin| = {rels[0]:.3e} (load 1 Pa), {rels[1]:.3e} (2 Pa); "
          f"ratio of the differences {diffs[1] / diffs[0]:.4f} (load squared: 4)")
    assert diffs[1] / diffs[0] == pytest.approx(4.0, abs=0.1)


# ---- (e) bad input --------------------------------------------------------------------------
@pytest.mark.parametrize("material, time, message", [
    ({"model": "neo_hookean", "E": E, "nu": NU, "mu": 5.0}, None,
     r"<dict>: bodies\[0\]\.material\.mu: unknown key\. Valid keys here: \['E', 'model', 'nu', 'rho'\]"),
    ({"model": "neo_hookean", "E": E, "nu": NU, "rhoo": 1e3}, None,
     r"bodies\[0\]\.material\.rhoo: unknown key; did you mean 'rho'\?"),
    ({"model": "neo_hookean", "E": -1e3, "nu": NU}, None,
     r"<dict>: bodies\[0\]\.material: material parameter E = -1000 must be positive"),
    ({"model": "neo_hokean", "E": E, "nu": NU}, None,
     r"bodies\[0\]\.material\.model: 'neo_hokean' is not one of .*did you mean 'neo_hookean'\?"),
    ({"model": "st_venant_kirchhoff", "E_p": 2e3, "E_z": 40e3, "nu_p": 0.9, "nu_pz": 0.0}, None,
     r"bodies\[0\]\.material\.G_pz: missing; expected a number"),
    (NEO, {"mode": "dynamic", "step": 1e-3, "end": 1e-2, "newton": {"method": "quasi"}},
     r"time\.newton\.method: 'quasi' is not one of \['full', 'modified'\]"),
    (NEO, {"mode": "static", "newton": {"method": "quasi"}},
     r"time\.newton\.method: 'quasi' is not one of \['full', 'modified'\]"),
    (NEO, {"mode": "static", "newton": {"residual_tol": 1e-6}},
     r"time\.newton\.residual_tol: unknown key; did you mean 'residual_tolerance'\?"),
    ({"model": "isotropic", "E": E, "nu": NU}, {"mode": "static", "newton": {}},
     r"time\.newton: Newton options apply to finite-strain bodies only"),
    ({"cover": NEO, "body": {"model": "isotropic", "E": E, "nu": NU}}, None,
     r"<dict>: bodies\[0\]\.material: the regions of one body mix linear and finite-strain materials"),
])
def test_bad_finite_strain_input_is_refused_with_the_key_path(material, time, message):
    d = {"bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [1, 1, 1]},
                     "material": material, "fixed": ["zmin"]}],
         "time": time or {"mode": "static"}}
    with pytest.raises(vfrs.SceneError, match=message):
        vfrs.Scene.from_dict(d)


def test_newton_failure_names_the_load_step_the_residuals_and_what_to_try():
    """Stretch to 1.5 in one load step with two Newton iterations allowed: a ConvergenceError
    naming the load step, the residual history and the remedies. Compressing the block to a
    tenth of its length in one step leaves the iterates where K_T is not positive definite:
    the error says so, with the residuals, and suggests more load steps; with 10 load steps
    the same compression converges, to the closed form (stretch 0.1: lateral stretch and
    nominal stress to 1e-9)."""
    fixed = [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]},
             {"surface": "zmin", "components": ["z"]}]
    scene = block_scene(NEO, fixed + [{"surface": "xmax", "components": ["x"], "displacement": [0.005, 0, 0]}],
                        cells=(2, 2, 2), newton={"method": "modified", "max_iterations": 2})
    with pytest.raises(vfrs.ConvergenceError, match=r"load step 1/1 \(load factor 1\): Newton \(modified\) did not "
                       r"converge in 2 iterations; relative residuals \|r\|/.* N: \[0, .*\]\. Try more load steps "
                       r"\(\[time\] load_steps\), method = 'full'"):
        vfrs.run(scene, progress=False)
    crush = fixed + [{"surface": "xmax", "components": ["x"], "displacement": [-0.009, 0, 0], "name": "push"}]
    with pytest.raises(vfrs.ConvergenceError, match=r"load step 1/1 .*(inverts an element|K_T is not positive definite)"
                       r".*relative residuals .*Try more load steps"):
        vfrs.run(block_scene(NEO, crush, cells=(2, 2, 2)), progress=False)
    res = vfrs.run(block_scene(NEO, crush, cells=(2, 2, 2), load_steps=10), progress=False)
    s, P, _, _ = neo_hookean_uniaxial(0.1)
    lateral = 1 + res.probe([0.01, 0.01, 0.01])["displacement"][-1, 1] / 0.01
    nominal = res.history["reaction_force.block.push"][-1, 0] / 1e-4
    print(f"compression to 0.1 in 10 load steps: Newton iterations {res.history['newton_iterations'].astype(int).tolist()}, "
          f"lateral stretch {lateral:.12f} (closed form {s:.12f}), nominal stress {nominal:.6f} Pa ({P:.6f})")
    assert lateral == pytest.approx(s, rel=1e-9)
    assert nominal == pytest.approx(P, rel=1e-9)
    # A tolerance below round-off: the residual stagnates (about 7e-12 of the load at strains
    # of 1e-3, where the neo-Hookean stress mu (F - F^-T) + ... loses digits); said as such.
    floor = cantilever(NEO, 1.0)
    d = floor.to_dict()
    d["time"]["newton"].update(residual_tolerance=1e-14, max_iterations=8)
    with pytest.raises(vfrs.ConvergenceError, match=r"the residual stagnates at .* round-off floor.*Try a larger "
                       r"\[time.newton\] residual_tolerance"):
        vfrs.run(vfrs.Scene.from_dict(d), progress=False)


def test_linear_scenes_do_not_touch_the_newton_path():
    """A linear static scene keeps the linear integrator (no Newton records in its history)."""
    scene = block_scene({"model": "isotropic", "E": E, "nu": NU}, ["zmin"],
                        loads=[{"type": "pressure", "surface": "zmax", "value": 10.0}])
    res = vfrs.run(scene, progress=False)
    assert "newton_iterations" not in res.history
    assert "newton" not in scene.to_dict()["time"]
    nh = block_scene(NEO, ["zmin"])
    assert nh.to_dict()["time"]["newton"] == {"method": "full", "residual_tolerance": 1e-8, "increment_tolerance": 1e-8,
                                              "max_iterations": 25, "refactor_ratio": 0.5, "line_search": True}
    assert vfrs.Scene.from_dict(nh.to_dict()).to_dict() == nh.to_dict()


def test_a_stopped_newton_run_resumes_bit_identically(tmp_path):
    """The column of the line-search test, 200 Pa in 6 load steps: SIGTERM after load step 3
    (from a record hook, in-process), then resume: history (Newton iterations included) and
    fields equal to one uninterrupted run, bit for bit. The integrator carries nothing between
    load steps (each starts by assembling and factoring K_T at the last converged state)."""
    scene = block_scene(NEO, ["zmin"], loads=[{"type": "traction", "surface": "zmax", "value": [200.0, 0.0, 0.0]}],
                        size=(0.01, 0.01, 0.03), cells=(2, 2, 6), load_steps=6)
    assert_resumes_bit_identically(scene, tmp_path, 3)


def assert_resumes_bit_identically(scene, tmp_path, step: int) -> None:
    """Runs the scene once, then again (with the scene's effects) stopped by SIGTERM after
    ``step`` (from a record hook, in-process) and resumed: history and fields must equal the first run's bit for bit."""
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from test_checkpoint import _Terminate

    from vfrs.checkpoint import RunStopped

    from vfrs.effects import EFFECTS

    ref = vfrs.run(scene, out=tmp_path / "ref", progress=False)
    effects = [EFFECTS[name](params) for name, params in scene.effects.items()] + [_Terminate(step)]
    with pytest.raises(RunStopped) as stop:
        vfrs.run(scene, out=tmp_path / "run", progress=False, effects=effects, checkpoint_seconds=None)
    assert stop.value.step == step
    res = vfrs.resume(tmp_path / "run", progress=False)
    assert list(ref.history) == list(res.history)
    for k, v in ref.history.items():
        assert np.array_equal(v, res.history[k], equal_nan=v.dtype.kind == "f"), k  # NaN: no pressure peak
    for k, v in ref.fields.items():
        assert np.array_equal(v, res.fields[k]), k


# ---- (f) the elastica of a tip-loaded cantilever --------------------------------------------
#: Mattiasson, K. (1981). Numerical results from large deflection beam and frame problems
#: analysed by means of elliptic integrals. Int. J. Numer. Meth. Eng. 17, 145-153: the
#: cantilever under a vertical dead tip load P, tip deflections over L, by P L^2 / (E I):
#: (vertical, horizontal).
MATTIASSON = {1: (0.30172, 0.05643), 2: (0.49346, 0.16064), 3: (0.60325, 0.25442), 4: (0.66996, 0.32894),
              5: (0.71379, 0.38763), 6: (0.74457, 0.43459), 7: (0.76737, 0.47293), 8: (0.78498, 0.50483),
              9: (0.79906, 0.53182), 10: (0.81061, 0.55500)}


def elastica(k: float) -> tuple:
    """Tip deflections (vertical, horizontal) / L of the inextensible elastica under a dead
    tip load with k = P L^2 / (E I): theta'' = -k cos(theta) on s in [0, 1], theta(0) = 0,
    theta'(1) = 0 (no moment at the tip), by shooting on theta'(0)."""
    def end(m):
        rhs = lambda s, y: [y[1], -k * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])]  # noqa: E731
        return solve_ivp(rhs, (0.0, 1.0), [0.0, m, 0.0, 0.0], rtol=1e-12, atol=1e-12).y[:, -1]

    m = brentq(lambda m: end(m)[1], 0.0, k, xtol=1e-14)  # the root moment / EI lies in (0, P L / EI)
    _, _, x, y = end(m)
    return y, 1.0 - x


def test_the_elastica_reference_reproduces_mattiasson():
    """The shooting solution agrees with Mattiasson's table (5 digits) within 1e-5 at every k."""
    for k, (v, h) in MATTIASSON.items():
        ev, eh = elastica(k)
        assert abs(ev - v) < 1e-5 and abs(eh - h) < 1e-5, (k, ev, eh)


def test_cantilever_at_large_deflection_matches_the_elastica():
    """A 1 m cantilever, 5 x 5 cm section (slenderness 20), neo-Hookean with nu = 0, E = 1 MPa,
    clamped at xmin, a dead vertical traction on xmax (40 x 2 x 2 cells of P1 tetrahedra).
    P1 tetrahedra lock in bending, so the beam's stiffness is measured on the same mesh, not
    assumed: a linear static run (isotropic, same E, nu) under a small tip load gives
    E I_eff = P L^3 / (3 delta) (measured 1.82 times E b t^3 / 12). The Newton statics in 10
    load steps at P = k E I_eff / L^2, k = 1, 2, 4, 7, 10, give the mean tip displacement of
    the end face, vertical and horizontal, which must match the elastica at that stiffness
    (:func:`elastica`, checked against Mattiasson 1981) within 1 % each (measured: at most
    0.5 %, vertical at k = 10; largest bending strain about 0.11, at the root at k = 10). Linear theory at the
    same loads is far off: its tip deflection k/3 L is 35 % too large at k = 2 and 4 times at
    k = 10, and it has no horizontal displacement: the check discriminates."""
    L, b, t, E_ = 1.0, 0.05, 0.05, 1e6

    def beam(material, P, load_steps=1):
        return vfrs.Scene.from_dict({
            "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [L, b, t], "cells": [40, 2, 2]},
                        "material": dict(material, E=E_, nu=0.0), "fixed": ["xmin"],
                        "loads": [{"type": "traction", "surface": "xmax", "value": [0.0, 0.0, -P / (b * t)]}]}],
            "time": {"mode": "static", "load_steps": load_steps}, "output": {"every": 1000}})

    def tip(res):
        return res.u[res.problem.points[:, 0] > L - 1e-9].mean(axis=0)

    P0 = 1e-3
    EI = P0 * L**3 / (3 * -tip(vfrs.run(beam({"model": "isotropic"}, P0), progress=False))[2])
    print(f"E I_eff = {EI:.4g} N m^2 = {EI / (E_ * b * t**3 / 12):.3f} E b t^3 / 12 (locking)")
    for k in (1, 2, 4, 7, 10):
        res = vfrs.run(beam({"model": "neo_hookean"}, k * EI / L**2, load_steps=10), progress=False)
        u = tip(res)
        v, h = elastica(k)
        ev, eh = -u[2] / L / v - 1, -u[0] / L / h - 1
        print(f"k = {k}: tip vertical {-u[2]:.5f} (elastica {v:.5f}, {ev:+.2%}), horizontal {-u[0]:.5f} "
              f"({h:.5f}, {eh:+.2%}); linear theory {k / 3:.4f}, 0; Newton iterations "
              f"{res.history['newton_iterations'].astype(int).tolist()}")
        assert abs(ev) < 0.01 and abs(eh) < 0.01
        if k >= 2:
            assert k / 3 / v - 1 > 0.3  # linear theory, at least 30 times the bound off
