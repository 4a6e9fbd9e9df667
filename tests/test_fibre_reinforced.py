"""The fibre-reinforced (transversely isotropic hyperelastic) law as a scene material, verified.

``model = "fibre_reinforced"``: a compressible neo-Hookean matrix plus an exponential (HGO-type)
fibre family along the reference axis a0, active in tension only (``vfrs._core.hyperelastic.fibre_reinforced``):

    W = mu/2 (I1 - 3) - mu ln J + lam/2 (ln J)^2 + [I4 > 1] k1 / (2 k2) (exp(k2 (I4 - 1)^2) - 1),
    I4 = |F a0|^2.

Each test checks physics against an exact answer and can fail:
(a) a rigid 90 degree rotation prescribed on the boundary leaves no force and no energy; then a
    stretch along the rotated fibre costs the fibre energy (the axis is material: it turned
    with the body);
(b) uniaxial stretch along the fibre against the closed form (stiffer than across it);
    across it, and (c) compression along it, the fibre is off: the neo-Hookean closed form;
(d) Newton dynamics: a swing records Newton iterations, and alpha = 0 conserves energy to
    second order in h across the fibre's switch;
(e) bad input is refused with the key path.
"""

import numpy as np
import pytest
from test_finite_strain import block_scene, neo_hookean_uniaxial, solve_once
from test_finite_strain_dynamics import EXAMPLES, free_scene, march, spin_and_stretch, total_energy

import vfrs
from vfrs.dynamics import build_problem
from vfrs.dynamics.newton import NewtonOptions, NewtonParams, newton_solve
from vfrs.finite_strain import FiniteStrainModel

E, NU = 10e3, 0.3
MU, LAM = E / (2 * (1 + NU)), E * NU / ((1 + NU) * (1 - 2 * NU))
K1, K2 = 5e3, 2.0
L, A = 0.01, 1e-4  # the 1 cm cube of block_scene


def fibre(axis, **kw):
    return {"model": "fibre_reinforced", "E": E, "nu": NU, "k1": K1, "k2": K2, "axis": list(axis), **kw}


def fibre_energy(i4, k1=K1, k2=K2):
    return k1 / (2 * k2) * np.expm1(k2 * (i4 - 1) ** 2) if i4 > 1 else 0.0


def neo_hookean_energy(F, mu=MU, lam=LAM):
    lnj = np.log(np.linalg.det(F))
    return mu / 2 * (np.sum(F * F) - 3) - mu * lnj + lam / 2 * lnj**2


# ---- (a) rigid rotation, then a stretch of the rotated fibre ---------------------------------
def test_rigid_rotation_leaves_no_stress_and_the_fibre_axis_turns_with_the_body():
    """A 3 x 3 x 3-cell block (fibre a0 = (1, 1, 1)/sqrt(3), oblique to the rotation axis z),
    every boundary node rotated about the block's centre by 22.5 ... 90 degrees in four load
    steps: Newton must keep the interior on the rigid motion with internal force and strain
    energy zero to round-off (bounds 1e-12 of L, E L^2, E V). Then, from the quarter turn, a
    homogeneous stretch by 1.2 along y is prescribed (F = S R, S = diag(1, 1.2, 1)) with fibre
    a0 = x, which the quarter turn has carried onto y: the energy must be
    V (W_NH(S) + W_f(1.2^2)) (relative error < 1e-10), not V W_NH(S) (a fibre held fixed in
    space along x would not be stretched): the reference fibre axis is material."""
    c = np.full(3, L / 2)
    params = NewtonParams(residual_tolerance=1e-10)

    def solve(axis, maps):
        problem = build_problem(block_scene(fibre(axis), ["xmin", "xmax", "ymin", "ymax", "zmin", "zmax"]))
        model, X = FiniteStrainModel(problem), problem.points
        u = np.zeros(problem.n_dofs)
        for k, F in enumerate(maps):
            exact = ((X - c) @ F.T + c - X).ravel()
            info = newton_solve(model, u, np.zeros(problem.n_dofs), exact[problem.fixed], NewtonOptions(params, f"step {k}"))
            assert info.iterations <= 8
        f, energy = model.force(u)
        return np.abs(u - exact).max() / L, f, energy, problem

    def rot(th):
        return np.array([[np.cos(th), -np.sin(th), 0.0], [np.sin(th), np.cos(th), 0.0], [0.0, 0.0, 1.0]])

    turns = [rot(np.pi / 2 * k / 4) for k in range(1, 5)]
    err_u, f, energy, problem = solve([1.0, 1.0, 1.0], turns)
    err_f, err_w = np.abs(f).max() / (E * L**2), abs(energy) / (E * L**3)
    print(f"rotation 90 deg: |u - u_rigid|/L = {err_u:.2e}, |f_int|/(E L^2) = {err_f:.2e}, W/(E V) = {err_w:.2e}")
    assert err_u < 1e-12 and err_f < 1e-12 and err_w < 1e-12
    exact = ((problem.points - c) @ turns[-1].T + c - problem.points).ravel()
    assert 0.5 * exact @ (problem.K @ exact) / (E * L**3) > 0.1  # a linear body's spurious energy

    S = np.diag([1.0, 1.2, 1.0])
    stretches = [np.diag([1.0, 1.0 + 0.2 * k / 4, 1.0]) @ turns[-1] for k in range(1, 5)]
    err_u, f, energy, _ = solve([1.0, 0.0, 0.0], turns + stretches)
    expected = (neo_hookean_energy(S) + fibre_energy(1.2**2)) * L**3
    matrix_only = neo_hookean_energy(S) * L**3
    print(f"stretch 1.2 along the turned fibre: energy {energy:.10e} J, closed form {expected:.10e} J "
          f"(relative {abs(energy - expected) / expected:.1e}); matrix alone {matrix_only:.4e} J; "
          f"|u - u_exact|/L = {err_u:.1e}")
    assert err_u < 1e-12
    assert abs(energy - expected) < 1e-10 * expected
    assert expected > 1.5 * matrix_only


# ---- (b), (c) uniaxial stretch along / across the fibre, compression along it --------------
def fibre_uniaxial(stretch, mu=MU, lam=LAM, k1=K1, k2=K2):
    """Closed form of the compressible fibre-reinforced block stretched by l along its fibre
    (a0 = e_1), lateral faces free.

    Principal stretches (l, s, s) (transverse isotropy about a0), J = l s^2, I4 = l^2. The
    fibre term depends on l only, so the lateral Kirchhoff stresses are the neo-Hookean ones,
    tau_2 = tau_3 = mu (s^2 - 1) + lam ln J = 0: s is the neo-Hookean lateral stretch (scalar
    root find, :func:`test_finite_strain.neo_hookean_uniaxial`). The nominal (1st
    Piola-Kirchhoff) stress is dW/dl:

        P = [mu (l^2 - 1) + lam ln J] / l + 2 l W_f'(I4),
        W_f'(I4) = k1 (I4 - 1) exp(k2 (I4 - 1)^2) for I4 > 1, 0 otherwise,

    i.e. the neo-Hookean P plus the fibre's 2 k1 l (l^2 - 1) exp(k2 (l^2 - 1)^2) in tension;
    in compression (l < 1) the fibre is off and P is the neo-Hookean P. Returns (s, P, W)."""
    s, P, _, W = neo_hookean_uniaxial(stretch, mu, lam)
    i4 = stretch**2
    if i4 > 1:
        P += 2 * stretch * k1 * (i4 - 1) * np.exp(k2 * (i4 - 1) ** 2)
    return s, P, W + fibre_energy(i4, k1, k2)


def pull(material, stretch, load_steps=4):
    """The 1 cm cube (3 x 3 x 3 cells), symmetry conditions on xmin, ymin, zmin, the face xmax
    moved to x = stretch L in load steps. Returns (reaction / A, lateral stretches (y, z),
    energy, Newton iterations) per load step."""
    scene = block_scene(material, [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]},
                                   {"surface": "zmin", "components": ["z"]},
                                   {"surface": "xmax", "components": ["x"], "displacement": [(stretch - 1) * L, 0, 0],
                                    "name": "pull"}], load_steps=load_steps)
    d = scene.to_dict()
    d["output"] = {"probes": [[L, L, L]]}
    res = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
    h = res.history
    corner = res.probe([L, L, L])["displacement"]
    return (h["reaction_force.block.pull"][:, 0] / A, 1 + corner[:, 1:] / L, h["elastic_energy"],
            h["newton_iterations"])


def test_uniaxial_stretch_along_the_fibre_matches_the_closed_form_and_is_stiffer_than_across():
    """Stretch to 1.5 in four load steps (fibre k1 = 5 kPa, k2 = 2 on an E = 10 kPa, nu = 0.3
    matrix). Along the fibre (a0 = x): at each load step the nominal stress, the lateral
    stretches and the strain energy match :func:`fibre_uniaxial` to 1e-9 relative (the
    deformation is homogeneous, P1 is exact). Across the fibre (a0 = y, the pull along x):
    the fibre lies in the contracting lateral direction (I4 = s^2 < 1), so it is off and the
    response is the neo-Hookean closed form, to 1e-9. Along is stiffer (the fibre's share of
    the stress at 1.5 is checked to be most of it)."""
    along, across = fibre([1, 0, 0]), fibre([0, 1, 0])
    Pa, sa, Wa, it = pull(along, 1.5)
    Pc, sc, Wc, _ = pull(across, 1.5)
    worst = 0.0
    for k in range(4):
        l = 1 + 0.5 * (k + 1) / 4
        s, P, W = fibre_uniaxial(l)
        s0, P0, _, W0 = neo_hookean_uniaxial(l, MU, LAM)
        errs = [abs(Pa[k] - P) / P, *(abs(sa[k] - s) / s), abs(Wa[k] - W * L**3) / (W * L**3),
                abs(Pc[k] - P0) / P0, *(abs(sc[k] - s0) / s0), abs(Wc[k] - W0 * L**3) / (W0 * L**3)]
        worst = max(worst, *errs)
        assert max(errs) < 1e-9, (k, errs)
        assert Pa[k] > 1.5 * Pc[k]
    s, P, _ = fibre_uniaxial(1.5)
    P0 = neo_hookean_uniaxial(1.5, MU, LAM)[1]
    print(f"stretch 1.5: along the fibre P = {P:.6f} Pa (vfrs {Pa[-1]:.6f}), across P = {P0:.6f} Pa "
          f"(vfrs {Pc[-1]:.6f}), ratio {Pa[-1] / Pc[-1]:.2f}; lateral stretch {s:.12f}; worst relative error "
          f"{worst:.1e}; Newton iterations along {it.astype(int).tolist()}")
    assert P - P0 > 0.5 * P


def test_compression_along_the_fibre_is_the_neo_hookean_matrix_alone():
    """Compression along the fibre to 0.7 (a0 = x, four load steps): I4 = l^2 < 1, the fibre
    is off, so reaction, lateral stretch and energy equal the neo-Hookean closed form (to 1e-9)
    and the fibre-reinforced run equals a ``neo_hookean`` run of the same matrix to 1e-12; the
    same run with the fibre along x in tension (stretch 1.3) is far from it (the test's
    comparison discriminates)."""
    Pf, sf, Wf, _ = pull(fibre([1, 0, 0]), 0.7)
    Pn, sn, Wn, _ = pull({"model": "neo_hookean", "E": E, "nu": NU}, 0.7)
    for k in range(4):
        l = 1 - 0.3 * (k + 1) / 4
        s0, P0, _, W0 = neo_hookean_uniaxial(l, MU, LAM)
        assert abs(Pf[k] - P0) < 1e-9 * abs(P0)
        assert np.abs(sf[k] - s0).max() < 1e-9 * s0
        assert abs(Wf[k] - W0 * L**3) < 1e-9 * W0 * L**3
    diff = max(np.abs(Pf - Pn).max() / np.abs(Pn).max(), np.abs(sf - sn).max(), np.abs(Wf - Wn).max() / Wn.max())
    Pt, _, _, _ = pull(fibre([1, 0, 0]), 1.3, load_steps=1)
    Pt0 = neo_hookean_uniaxial(1.3, MU, LAM)[1]
    P07 = neo_hookean_uniaxial(0.7, MU, LAM)[1]
    print(f"compression 0.7: P = {Pf[-1]:.6f} Pa, neo-Hookean closed form {P07:.6f} Pa, "
          f"fibre-reinforced vs neo_hookean run {diff:.1e}; tension 1.3: {Pt[-1]:.1f} Pa vs matrix {Pt0:.1f} Pa")
    assert diff < 1e-12
    assert Pt[-1] > 1.5 * Pt0


def test_the_elongation_example_matches_the_closed_form():
    """examples/elongate_fibre_reinforced.toml: the fold-like parameter set of docs/model.md
    (E = 2 kPa, nu = 0.45, k1 = 9.5 kPa; k2 = 1 illustrative), fibres along z, elongated to
    1.3 in three load steps: reaction / area and lateral stretches match
    :func:`fibre_uniaxial` to 1e-9 at each load step, and the fibres carry most of the load
    (the matrix alone: under a tenth of it)."""
    res = vfrs.run(EXAMPLES / "elongate_fibre_reinforced.toml", progress=False)
    h = res.history
    corner = 1 + res.probe([L, L, L])["displacement"] / L
    mu, lam = 2e3 / (2 * 1.45), 2e3 * 0.45 / (1.45 * 0.1)
    for k in range(len(h["t"])):
        stretch = 1 + 0.3 * h["t"][k]
        s, P, _ = fibre_uniaxial(stretch, mu, lam, 9.5e3, 1.0)
        assert corner[k, 2] == pytest.approx(stretch, rel=1e-12)
        assert abs(h["reaction_force.block.pull"][k, 2] / A - P) < 1e-9 * P
        assert np.abs(corner[k, :2] - s).max() < 1e-9 * s
    P0 = neo_hookean_uniaxial(1.3, mu, lam)[1]
    print(f"elongation 1.3: nominal stress {P / 1e3:.3f} kPa (matrix alone {P0 / 1e3:.3f} kPa), "
          f"lateral stretch {s:.6f}, Newton iterations {h['newton_iterations'].astype(int).tolist()}")
    assert P0 < 0.1 * P


@pytest.mark.parametrize("axis", [[0, 0, 1], [1, 0, 1], [1, 0, 0]], ids=["along", "oblique", "across"])
def test_newton_converges_quadratically_with_the_fibre_term(axis):
    """A sheared block as in tests/test_finite_strain.py (1 x 1 x 2 cm, 2 x 2 x 4 cells,
    clamped at zmin) with its top moved by (5, 2, 4) mm (20 % stretch with shear) in one load
    step, fibres along the stretch (z), oblique and across it: the tangent includes the
    fibre's, so full Newton converges quadratically, e_k+1 / e_k^2 < 10 over the asymptotic
    range (e_k < 0.1, e_k+1 > 1e-14, as for neo-Hookean); at least two ratios must count.
    (At the 50 % stretch of the neo-Hookean test, with fibres along it, the forces are 1.8e3
    times the relative residual's reference, whose round-off floor then rises to 1.5e-13 and
    leaves only two iterates in the asymptotic range, ratios 0.065 and 0.065.)"""
    scene = block_scene(fibre(axis), ["zmin", {"surface": "zmax", "displacement": [5e-3, 2e-3, 4e-3]}],
                        size=(0.01, 0.01, 0.02), cells=(2, 2, 4),
                        newton={"method": "full", "residual_tolerance": 1e-12, "increment_tolerance": 1e-12})
    info = solve_once(scene)
    e = info.relative_residuals[1:]  # after the predictor (e_0 = 0: the start of the step is in balance)
    q = [b / a**2 for a, b in zip(e[:-1], e[1:]) if a < 0.1 and b > 1e-14]
    print(f"fibre {axis}: relative residuals", [f"{x:.1e}" for x in e], "ratios e_k+1/e_k^2", [f"{x:.3g}" for x in q])
    assert len(q) >= 2
    assert max(q) < 10.0
    assert e[-1] < 1e-12


# ---- (d) Newton dynamics --------------------------------------------------------------------
def test_a_fibre_reinforced_column_swings_with_newton():
    """examples/swing_neo_hookean.toml with the fibre law (fibres along the column, z; k1 =
    5 kPa, k2 = 2 on the E = 10 kPa matrix), 30 ms: the bending stretches the fibres on one
    side (on) and shortens them on the other (off). Every step converges (relative residual
    <= 1e-8, Newton iterations recorded, at least 1 per step), and the fibres stiffen the
    column in bending: the tip deflects less than the neo-Hookean column's over the same time
    (measured below)."""
    def swing(material):
        d = vfrs.Scene.load(EXAMPLES / "swing_neo_hookean.toml").to_dict()
        d["bodies"][0]["material"] = material
        d["time"]["end"] = 0.03
        res = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
        return res.history, res.probe([0.01, 0.01, 0.04])["displacement"][:, 0]

    h, tip = swing(fibre([0, 0, 1], rho=1000.0))
    _, tip0 = swing({"model": "neo_hookean", "E": E, "nu": NU, "rho": 1000.0})
    it = h["newton_iterations"]
    print(f"fibre-reinforced column: largest tip deflection {tip.max() * 1e3:.2f} mm "
          f"(neo-Hookean {tip0.max() * 1e3:.2f} mm), Newton iterations per step {it[1:].mean():.2f} "
          f"(max {int(it.max())}), largest relative residual {h['newton_residual'][1:].max():.1e}")
    assert it[0] == 0 and it[1:].min() >= 1
    assert (h["newton_residual"][1:] <= 1e-8).all()
    assert tip.max() > 0.005  # a large deflection (over 1/8 of the column)
    assert tip.max() < 0.95 * tip0.max()


BAR = {"model": "fibre_reinforced", "E": 1e3, "nu": 0.3, "k1": 500.0, "k2": 2.0, "axis": [1.0, 0.0, 0.0], "rho": 1.0}


def bar_energy_errors(steps, material=BAR):
    """The free bar of tests/test_finite_strain_dynamics.py (1 x 0.2 x 0.2 m, 5 x 1 x 1 cells,
    rho = 1 kg/m^3) spun at 5 rad/s about z while stretching axially, alpha = 0, 0.32 s, for
    each time step: (RMS and largest |E - E_0| / E_0, shortest and longest bar length)."""
    out = []
    for h in steps:
        def rec(p, s):
            x = p.points + s.u.reshape(-1, 3)
            ends = x[p.points[:, 0] > 1 - 1e-9].mean(0) - x[p.points[:, 0] < 1e-9].mean(0)
            return total_energy(p, s), np.linalg.norm(ends)

        _, _, _, r = march(free_scene(material, h, 0.32), spin_and_stretch(), rec)
        En, length = np.array([q[0] for q in r]), [q[1] for q in r]
        out.append((np.sqrt(np.mean((En / En[0] - 1) ** 2)), np.abs(En / En[0] - 1).max(), min(length), max(length)))
    return out


def test_alpha_zero_conserves_energy_to_second_order_across_the_fibre_switch():
    """The bar of :func:`bar_energy_errors` with fibres along it (k1 = 500 Pa, k2 = 2 on the
    E = 1 kPa, nu = 0.3 matrix: in tension the axial modulus goes from 1.35 to 3.35 kPa): its
    length oscillates about the rest length (0.961-1.024 m, checked), so in every element the
    fibre switches on and off twice a period, where the tangent jumps by 4 k1 (W is C1, not
    C2). With alpha = 0 the energy error must still be second order in h: RMS of
    (E - E_0)/E_0 for h = 1, 0.5, 0.25 ms measured 1.63e-3, 4.45e-4, 1.10e-4 (ratios 3.67,
    4.06; bound 3.5-4.5, a first-order error would give 2), i.e. RMS / h^2 = 1630-1780 s^-2
    (bound 2000 s^-2, set from these measurements). Larger than the neo-Hookean bar's (5.1e-5
    at 1 ms; see the strict xfail below): the trapezoidal rule integrates the work of a force
    with a kink exactly only when the kink falls on a step end; a step that crosses I4 = 1
    makes an error of order 4 k1 (v h)^2, of either sign. At h = 2 ms (ratio 2.73 to 1 ms) the
    run is not yet in the asymptotic range."""
    steps = (1e-3, 5e-4, 2.5e-4)
    errs = bar_energy_errors(steps)
    rms = [e[0] for e in errs]
    print("RMS relative energy error", [f"{x:.3e}" for x in rms],
          "ratios", [f"{a / b:.3f}" for a, b in zip(rms, rms[1:])], "largest", [f"{e[1]:.2e}" for e in errs],
          "RMS / h^2", [f"{x / h**2:.0f}" for x, h in zip(rms, steps)],
          f"bar length {errs[0][2]:.4f}-{errs[0][3]:.4f} m")
    assert errs[0][2] < 0.99 and errs[0][3] > 1.01  # the fibres are stretched (on) and shortened (off)
    for a, b in zip(rms, rms[1:]):
        assert 3.5 < a / b < 4.5
    for x, h in zip(rms, steps):
        assert x < 2000 * h**2


@pytest.mark.xfail(strict=True, reason="the tension-only switch: with alpha = 0 the fibre bar's energy error at "
                   "h = 1 ms is 2.5e-3 (largest) against the neo-Hookean bar's bound of 2e-4 (measured 9.7e-5 there); "
                   "second order but 30x larger (a step crossing I4 = 1 integrates the kinked force with an O(4 k1 "
                   "(v h)^2) error); a smoothed switch or an energy-conserving scheme would remove it")
def test_alpha_zero_energy_error_is_as_small_as_the_neo_hookean_bars():
    rms, peak, _, _ = bar_energy_errors((1e-3,))[0]
    print(f"fibre bar, h = 1 ms: RMS {rms:.2e}, largest {peak:.2e} (neo-Hookean bound 2e-4)")
    assert peak < 2e-4


# ---- (e) bad input --------------------------------------------------------------------------
@pytest.mark.parametrize("change, message", [
    ({"k1": -1.0}, r"bodies\[0\]\.material\.k1: expected a number >= 0"),
    ({"k2": 0.0}, r"bodies\[0\]\.material\.k2: expected a positive number"),
    ({"axis": [0.0, 0.0, 0.0]}, r"bodies\[0\]\.material: fibre axis = \[0\.0, 0\.0, 0\.0\] must be a finite nonzero"),
    ({"axis": [0.0, 1.0]}, r"bodies\[0\]\.material\.axis"),
    ({"nu": 0.5}, r"bodies\[0\]\.material: material parameter nu = 0\.5 is out of range"),
    ({"k": 1.0}, r"bodies\[0\]\.material\.k: unknown key"),
    ({"k2": None}, r"bodies\[0\]\.material\.k2: missing; expected a number"),
])
def test_bad_fibre_reinforced_input_is_refused_with_the_key_path(change, message):
    material = {k: v for k, v in {**fibre([0, 0, 1]), **change}.items() if v is not None}
    d = {"bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": [1, 1, 1]},
                     "material": material, "fixed": ["zmin"]}], "time": {"mode": "static"}}
    with pytest.raises(vfrs.SceneError, match=message):
        vfrs.Scene.from_dict(d)


def test_the_linear_equivalent_is_the_matrix_and_the_tangent_at_rest_agrees():
    """elasticity() (the linear K made at setup, e.g. for Rayleigh damping) is the isotropic
    matrix's D, and the Rust tangent at u = 0 equals that K to round-off: the fibre is off at
    I4 = 1 exactly (zero stiffness at zero strain from the compression side). Just past rest
    in tension along the fibre, the axial tangent gains 4 k1 (checked on a one-cell block by
    a finite difference of the internal force)."""
    problem = build_problem(block_scene(fibre([1, 0, 0]), ["xmin"], cells=(1, 1, 1)))
    model = FiniteStrainModel(problem)
    u = np.zeros(problem.n_dofs)
    model.force_and_tangent(u)
    K0 = problem.K.toarray()
    KT = model.tangent_full().toarray()
    assert np.abs(KT - K0).max() < 1e-12 * np.abs(K0).max()
    D = vfrs.materials.FibreReinforced(E=E, nu=NU, k1=K1, k2=K2).elasticity()
    assert np.allclose(D, vfrs.Isotropic(E=E, nu=NU).elasticity(), rtol=1e-15, atol=0)
    # homogeneous stretch eps along x: the axial stress of the fibre-reinforced body exceeds the matrix's by 4 k1 eps
    X = problem.points
    for eps, extra in ((1e-6, 4 * K1), (-1e-6, 0.0)):
        u = (np.c_[eps * X[:, 0], 0 * X[:, 0], 0 * X[:, 0]]).ravel()
        f, _ = model.force(u)
        fx = f[0::3][X[:, 0] > L - 1e-12].sum() / A  # axial force per area on xmax (laterals not free: sigma_xx)
        sig_matrix = (LAM + 2 * MU) * eps
        print(f"eps = {eps:+.0e}: axial stress {fx:.6e} Pa, matrix {sig_matrix:.6e} Pa, "
              f"fibre 4 k1 eps {extra * eps:.6e} Pa")
        assert abs(fx - sig_matrix - extra * eps) < 1e-4 * (LAM + 2 * MU + extra) * abs(eps)
