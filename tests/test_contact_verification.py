"""Contact verification against closed forms (docs/design.md, "Verification"; issue 6,
"Verification tests").

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


from vfrs.meshes import paraboloid_block  # noqa: E402  (the Hertz specimen, now built in)


@pytest.fixture
def hertz_mesh():
    assert vfrs.meshes.GENERATORS["paraboloid_block"] is paraboloid_block


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

    Measured (P1 tets): F error +29.7 %, +19.1 %, +14.6 % at 8, 12, 16 cells; contact radius
    within 2.2 % from 12 cells on. Finer meshes (issue 47: benchmarks/bench_p2.py,
    benchmarks/results/p2/p1_vs_p2.csv) show that the force does not converge at O(h) to the
    half-space formula, as this test said until then (an O(h) extrapolation from 8 and 16 cells
    gave -0.6 %): P1 is +9.8 % at 24 and +8.3 % at 32 cells, P2 +7.4 % and +6.7 % at 12 and 16
    cells, both toward the finite block's own limit, about +6.5 % above the half-space (the
    block's size, a / W = 0.1, is not negligible). Tolerances: the force error falls at each
    refinement, by less each time (converging); < 16 % at 16 cells; contact radius within 3 %
    at 12 and 16 cells; F(a) relation within 10 % at 16 cells.
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
    assert errF[0] - errF[1] > errF[1] - errF[2] > 0, errF  # converging: each refinement changes less
    assert abs(erra[1]) < 0.03 and abs(erra[2]) < 0.03, erra
    assert errFa[0] > errFa[1] > errFa[2] and abs(errFa[2]) < 0.1, errFa


@pytest.mark.slow
def test_hertz_finer(hertz_mesh):
    """Hertz at 24 cells (about 35 s): force error below 11 % (measured +9.8 %) and above the
    finite block's limit (about +6.5 %, see test_hertz_converges: an O(h) extrapolation from 12
    and 24 cells, +0.6 %, is not that limit), radius within 2.5 % (measured +1.6 %), F(a) within
    6 % (measured +4.7 %)."""
    levels = [hertz_run(c) for c in (12, 24)]
    _hertz_table(levels)
    fine = levels[1]
    assert 0.06 < fine["F"] / fine["F_hertz"] - 1 < 0.11
    assert abs(fine["a"] / fine["a_hertz"] - 1) < 0.025
    assert abs(fine["F"] / fine["F_of_a"] - 1) < 0.06


# ---------------------------------------------------------------------------------------------
# Signorini: a block resting on a rigid plane under gravity
# ---------------------------------------------------------------------------------------------
SIG_W, SIG_H, SIG_G, SIG_N = 0.01, 0.01, 9.81, 4


def _signorini_scene(nu, mode="contact", stabilized=False, step=1e-3):
    """The block [0, W]^2 x [0, H] with rollers on xmin (x) and ymin (y); z is carried by a
    frictionless rigid plane z = 0 (``mode="contact"``, dynamic, settling under mass-
    proportional damping) or, for the reference, by a roller support on zmin (static)."""
    c = np.sqrt(E / RHO)
    omega1 = np.pi / 2 * c / SIG_H  # first axial mode of the block standing on its base
    xs = np.linspace(0.0, SIG_W, SIG_N + 1)
    body = {
        "name": "block",
        "mesh": {"builtin": "box", "size": [SIG_W, SIG_W, SIG_H], "cells": [SIG_N] * 3},
        "material": _material(nu),
        "mass": "lumped",
        "fixed": [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}],
    }
    d = {"gravity": [0, 0, -SIG_G], "bodies": [body], "output": {"every": 10**6}}
    if mode == "contact":
        body["damping"] = {"a0": 2 * omega1, "a1": 0.0}  # critical for the first mode
        d["obstacles"] = [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}]
        d["contact"] = {"method": "lagrange", "detection": "bvh", "surface": "zmin", "stabilized": stabilized}
        d["time"] = {"mode": "dynamic", "step": step, "end": 0.1, "alpha": -0.3}
        d["output"]["probes"] = [[x, y, 0.0] for x in xs for y in xs]
    else:
        body["fixed"].append({"surface": "zmin", "components": ["z"]})
        d["time"] = {"mode": "static"}
    return vfrs.Scene.from_dict(d)


@pytest.mark.parametrize("nu", [0.0, 0.3])
def test_signorini_block_under_gravity(nu):
    """Signorini: a block resting on a frictionless rigid plane under its weight carries
    reaction = m g and contact pressure rho g H (uniaxial stress, any nu).

    How the block is held: a block supported only by contact has a singular K in statics
    (the effect's reduced solve needs K factored), so the run is dynamic: the block starts
    at rest touching the plane, gravity switches on, and mass-proportional damping (critical
    for the first axial mode, a0 = 2 omega_1) lets it settle within 0.1 s (100 steps,
    alpha = -0.3). Rollers on xmin (x) and ymin (y) remove the in-plane rigid motions and are
    also symmetry planes: they do not carry any z force. The plain (paper's) scheme is used;
    the stabilized default leaves a latent velocity on resting contact nodes (see
    ``test_signorini_stabilized_default_rests``).

    Checks: total contact force = m g (1e-9), no tangential force; sum of nodal forces /
    area = rho g H (1e-9); the settled displacement equals a static run with a roller
    support on zmin instead of contact (1e-8), and the nodal contact forces equal that run's
    nodal support reactions (1e-8): the contact is exactly a support. Nodal pressures
    f_i / a_i vs rho g H: P1 nodal forces carry the Kuhn split's load distribution, so they
    are not pointwise uniform; with nu = 0 (a 1-D problem) interior nodes are within 2 %
    (measured 1.4 %) and edges/corners within 5 % (4.0 %); with nu = 0.3 the Poisson bulge
    (a bilinear field P1 cannot represent) spreads them to 6 % inside, 23 % at corners
    (reported, not asserted beyond the support equivalence above).
    """
    r = vfrs.run(_signorini_scene(nu), progress=False)
    mg = RHO * SIG_W * SIG_W * SIG_H * SIG_G
    p_exact = RHO * SIG_G * SIG_H
    F = r.history["contact_force.block"][-1]
    assert F[2] == pytest.approx(mg, rel=1e-9)
    assert np.abs(F[:2]).max() < 1e-12 * mg
    assert np.abs(r.v).max() < 1e-9  # settled
    assert r.history["max_penetration"][-1] < 1e-12 * SIG_H

    mesh = r.problem.bodies[0].mesh
    areas = tributary_areas(mesh.points, mesh.surfaces["zmin"])
    probes = r.scene.output.probes
    nodes = np.array([r.node(p) for p in probes])
    fz = np.array([r.history[f"contact_force_probe.{k}"][-1][2] for k in range(len(probes))])
    assert len(set(nodes.tolist())) == len(nodes) == len(np.unique(mesh.surfaces["zmin"]))
    assert fz.sum() / (SIG_W * SIG_W) == pytest.approx(p_exact, rel=1e-9)

    ref = vfrs.run(_signorini_scene(nu, mode="support"), progress=False)
    np.testing.assert_allclose(r.u, ref.u, rtol=0, atol=1e-8 * np.abs(ref.u).max())
    part, Ku = _body_forces(ref, "block", nu)
    reaction = Ku - ref.problem.gravity.reshape(-1, 3)[part.nodes]
    np.testing.assert_allclose(fz, reaction[nodes, 2], rtol=0, atol=1e-8 * np.abs(fz).max())

    err = (fz / (areas[nodes] * p_exact) - 1).reshape(SIG_N + 1, SIG_N + 1)
    inner = np.abs(err[1:-1, 1:-1]).max()
    print(f"\nSignorini nu={nu}: F/mg-1 {F[2] / mg - 1:.1e}, nodal pressure error interior {inner:.3f}, all {np.abs(err).max():.3f}")
    if nu == 0.0:
        assert inner < 0.02
        assert np.abs(err).max() < 0.05


def test_signorini_stabilized_default_rests():
    """The same block with the default contact-stabilized predictor comes to rest with
    reaction m g. (It once did not: projecting only u~ left the base nodes a steady
    v_z = -(1 - gamma) h g from the start-of-step acceleration, and the damping a0 M v of that
    phantom velocity took 2.5 % of the weight off the contact. The predictor now also
    projects the normal velocity of the pairs it closes.)"""
    r = vfrs.run(_signorini_scene(0.0, stabilized=True), progress=False)
    mg = RHO * SIG_W * SIG_W * SIG_H * SIG_G
    assert np.abs(r.v).max() < 1e-9
    assert r.history["contact_force.block"][-1][2] == pytest.approx(mg, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# Two bars colliding
# ---------------------------------------------------------------------------------------------
BAR_L, BAR_S, BAR_V0, BAR_N, BAR_GAP = 0.1, 0.01, 0.1, 40, 1e-4
BAR_C = np.sqrt(E / RHO)


def bars_run(method="lagrange", alpha=0.0, stabilized=True, solver="compliance", kappa=None, detection="bvh", end=3.0, substeps=1.0,
             **extra):
    """Two identical bars (L = 0.1 m, 0.01 x 0.01 m, E = 1e4 Pa, rho = 1000, nu = 0, lumped
    mass, 40 elements, y and z held on ymin/zmin), a gap of 1e-4 m, bar a at v0 = 0.1 m/s
    towards bar b at rest; h = L / c / 40 / substeps (substeps = 1: a wave crosses one
    element per step); ``end`` in units of L / c. Contact between a's xmax and b's xmin."""
    h = BAR_L / BAR_C / BAR_N / substeps

    def bar(name, x0, v):
        return {"name": name, "mesh": {"builtin": "box", "size": [BAR_L, BAR_S, BAR_S], "cells": [BAR_N, 1, 1], "origin": [x0, 0, 0]},
                "material": _material(0.0), "mass": "lumped", "velocity": [v, 0, 0],
                "fixed": [{"surface": "ymin", "components": ["y"]}, {"surface": "zmin", "components": ["z"]}]}

    contact = {"method": method, "detection": detection, "surface": {"a": "xmax", "b": "xmin"},
               "stabilized": stabilized, "solver": solver, **extra}
    if detection == "bvh":
        contact["search_distance"] = 2e-3
    if kappa is not None:
        contact["kappa"] = kappa
    d = {"bodies": [bar("a", -BAR_L - BAR_GAP / 2, BAR_V0), bar("b", BAR_GAP / 2, 0.0)],
         "contact": contact,
         "time": {"mode": "dynamic", "step": h, "end": end * BAR_L / BAR_C, "alpha": alpha},
         "output": {"every": 10**6}}
    return vfrs.run(vfrs.Scene.from_dict(d), progress=False)


def _bar_summary(r):
    hst = r.history
    h = r.scene.time.step
    E0 = 0.5 * RHO * BAR_L * BAR_S * BAR_S * BAR_V0**2
    energy = (hst["kinetic_energy"] + hst["elastic_energy"]) / E0
    on = np.flatnonzero(np.abs(hst["contact_force.a"][:, 0]) > 0)
    duration = (hst["t"][on[-1]] - hst["t"][on[0]] + h) if on.size else 0.0
    vel = {p.name: r.v[p.nodes, 0].mean() / BAR_V0 for p in r.problem.bodies}
    return {"duration": duration / (2 * BAR_L / BAR_C), "E_max": energy.max(), "E_end": energy[-1],
            "va": vel["a"], "vb": vel["b"], "contact_steps": on.size}


@pytest.mark.parametrize("alpha", [0.0, -0.3])
def test_bars_impact_stabilized(alpha):
    """Two identical bars: the contact lasts 2 L / c, then bar a stops and bar b leaves at
    v0 (the 1-D wave solution); the energy may only be lost (alpha <= 0 dissipates, the
    stabilized predictor never adds energy).

    Measured at 40 elements, h = L/(40 c): duration 2L/c + 1.25 %; energy max E0 (to
    round-off), end 0.992 E0 (alpha = 0) and 0.981 E0 (alpha = -0.3); mean velocities a
    0.03 v0, b 0.97 v0. Tolerances: duration within 3 %; energy never above E0 (1 + 1e-9);
    end energy above 0.97 E0; |v_a| < 0.05 v0, v_b within 5 % of v0; total momentum kept to
    1 %."""
    s = _bar_summary(bars_run(alpha=alpha))
    print(f"\nbars stabilized alpha={alpha}: {s}")
    assert abs(s["duration"] - 1) < 0.03
    assert s["E_max"] <= 1 + 1e-9
    assert 0.97 < s["E_end"] <= 1.0
    assert abs(s["va"]) < 0.05 and abs(s["vb"] - 1) < 0.05
    assert abs(s["va"] + s["vb"] - 1) < 0.01


def test_bars_impact_plain_scheme_gains_energy():
    """Why the stabilized predictor is the default: with alpha = 0 the paper's plain scheme
    (gap enforced at t_n+1 inside Newmark) makes the contact chatter and gains energy at the
    impact. Measured: energy up to 123 E0, contact 2L/c + 5 %, bar b leaves at 1.09 v0.
    Asserts a gain above 10 E0."""
    s = _bar_summary(bars_run(alpha=0.0, stabilized=False))
    print(f"\nbars plain alpha=0: {s}")
    assert s["E_max"] > 1.5  # docs/design.md, "Energy in dynamic contact": +100 % to +400 % in 1-D


@pytest.mark.parametrize("substeps", [1.0, 2.5])
def test_bars_impact_plain_scheme_with_hht_damping(substeps):
    """The plain scheme with alpha = -0.3: at one element per step (h = L / (40 c)) the HHT
    dissipation hides the chatter (measured: max E0 to round-off, end 0.984 E0, duration
    2L/c + 1.25 %); at h = L / (100 c) it gains energy like alpha = 0 (measured: 521 E0,
    contact 2L/c + 14 %, bar a bounces back at -0.38 v0), as the 1-D check of docs/design.md
    ("Energy in dynamic contact") found for
    alpha = -0.1 and -0.3, while the stabilized default at the same h keeps E <= E0 (max
    1 + 2e-15, end 0.990 E0, duration + 1.0 %). Asserts: h = L/(40 c): E <= E0 (1e-9); h = L/(100 c): plain
    gains above 10 E0, stabilized E <= E0 (1e-9) and duration within 3 %."""
    plain = _bar_summary(bars_run(alpha=-0.3, stabilized=False, substeps=substeps))
    print(f"\nbars plain alpha=-0.3 substeps={substeps}: {plain}")
    if substeps == 1.0:
        assert plain["E_max"] <= 1 + 1e-9
        assert abs(plain["duration"] - 1) < 0.03
        return
    assert plain["E_max"] > 1.5
    stab = _bar_summary(bars_run(alpha=-0.3, stabilized=True, substeps=substeps))
    print(f"bars stabilized alpha=-0.3 substeps={substeps}: {stab}")
    assert stab["E_max"] <= 1 + 1e-9
    assert abs(stab["duration"] - 1) < 0.03


# ---------------------------------------------------------------------------------------------
# Contact patch test
# ---------------------------------------------------------------------------------------------
PATCH_W, PATCH_H, PATCH_D, PATCH_NU = 0.01, 0.01, 1e-4, 0.3


def patch_run(cells_lower, cells_upper, method="lagrange", kappa=None, jitter=0.0):
    """Two blocks W x W x H stacked at z = H (lower on z in [0, H], upper on [H, 2H]); lower
    zmin held in z, upper zmax pushed down by d; rollers on xmin (x) and ymin (y) of both.
    The exact solution is uniaxial compression, sigma_zz = -p with p = E d / (2 H) (penalty
    in series: p = E d / (2 H + E / kappa)), which P1 represents exactly on any mesh."""

    def block(name, z0, cells, fixed):
        return {"name": name,
                "mesh": {"builtin": "box", "size": [PATCH_W, PATCH_W, PATCH_H], "cells": list(cells), "origin": [0, 0, z0], "jitter": jitter},
                "material": _material(PATCH_NU),
                "fixed": fixed + [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}]}

    contact = {"method": method, "detection": "bvh", "surface": {"lower": "zmax", "upper": "zmin"}}
    if kappa is not None:
        contact["kappa"] = kappa
    scene = vfrs.Scene.from_dict({
        "bodies": [block("lower", 0.0, cells_lower, [{"surface": "zmin", "components": ["z"]}]),
                   block("upper", PATCH_H, cells_upper, [{"surface": "zmax", "components": ["z"], "displacement": [0, 0, -PATCH_D]}])],
        "contact": contact, "time": {"mode": "static"}, "output": {"energy": False}})
    r = vfrs.run(scene, progress=False)
    p = E * PATCH_D / (2 * PATCH_H + (E / kappa if method == "penalty" else 0.0))
    out = {"p": p, "result": r}
    for name, face in (("lower", "zmax"), ("upper", "zmin")):
        part, f = _body_forces(r, name, PATCH_NU)
        nodes = np.unique(part.mesh.surfaces[face])
        a = tributary_areas(part.mesh.points, part.mesh.surfaces[face])[nodes]
        out[name] = np.abs(np.abs(f[nodes, 2]) / (a * p) - 1).max()  # nodal pressure error
        out[name + "_tangential"] = np.abs(f[nodes, :2]).max() / (p * a.min())
        out[name + "_total"] = r.history[f"contact_force.{name}"][-1]
    return out


def _patch_exact_u(r, p):
    """Uniaxial stress: u_z = -p z / E (whole stack, z from the fixed base), lateral
    expansion u_x = nu p x / E, u_y = nu p y / E."""
    X = r.problem.points
    return np.column_stack([PATCH_NU * p * X[:, 0] / E, PATCH_NU * p * X[:, 1] / E, -p * X[:, 2] / E])


@pytest.mark.parametrize("cells_lower,cells_upper,jitter", [
    ((3, 3, 2), (3, 3, 2), 0.0),   # matching
    ((4, 4, 2), (3, 3, 2), 0.0),   # non-matching
    ((5, 5, 2), (3, 3, 2), 0.2),   # non-matching, jittered interiors
    ((6, 6, 2), (4, 4, 2), 0.0),
])
def test_patch_lagrange(cells_lower, cells_upper, jitter):
    """Contact patch test with Lagrange multipliers: uniform pressure through a flat
    interface. The effect enforces contact between bodies two-pass (each body's nodes
    against the other's triangles, both directions); with exact multipliers that passes
    the patch test on matching and non-matching meshes alike (one-pass node-to-surface
    would not: the master nodes would get the slave forces interpolated, not p x area).

    Measured: nodal pressure error 7e-13 (matching), 1e-11 (non-matching). Asserts: every
    interface node of both bodies carries p x its tributary area within 1e-9, no tangential
    force (1e-9 p a), totals p W^2 and opposite (1e-9), and the displacement is the exact
    uniaxial field (1e-9 of d)."""
    out = patch_run(cells_lower, cells_upper, jitter=jitter)
    p = out["p"]
    print(f"\npatch lagrange {cells_lower}/{cells_upper} jitter {jitter}: nodal pressure error lower {out['lower']:.1e}, upper {out['upper']:.1e}")
    assert out["lower"] < 1e-9 and out["upper"] < 1e-9
    assert out["lower_tangential"] < 1e-9 and out["upper_tangential"] < 1e-9
    np.testing.assert_allclose(out["upper_total"], [0, 0, p * PATCH_W**2], rtol=0, atol=1e-9 * p * PATCH_W**2)
    np.testing.assert_allclose(out["lower_total"], -out["upper_total"], rtol=0, atol=1e-12 * p * PATCH_W**2)
    r = out["result"]
    np.testing.assert_allclose(r.u, _patch_exact_u(r, p), rtol=0, atol=1e-9 * PATCH_D)


def test_patch_penalty():
    """Contact patch test with the penalty method (kappa in Pa/m, per tributary area, two
    passes weighted one half each). Matching meshes: every node pair balances, the pressure
    is uniform and equal to E d / (2 H + E / kappa) to round-off (measured 6e-15; asserted
    1e-10). Non-matching meshes (4x4 against 3x3 cells): the two half-weight passes do not
    reproduce p x area node by node; the error is bounded and falls as kappa grows (measured
    4.5e-2 at kappa = 1e8, 1.5e-5 at 1e12; asserted < 0.1 and at least 100 times smaller at
    1e12); the total normal force (measured 2.9e-4, 5.4e-8) and the tangential total (0 at
    both; it was 3e-6 of p W^2 at 1e12 while a node on an edge between two master triangles
    could keep a pair with each across the detection rounds) stay within the nodal error,
    and the two bodies' totals are opposite (1e-12)."""
    match = patch_run((3, 3, 2), (3, 3, 2), "penalty", kappa=1e8)
    assert match["lower"] < 1e-10 and match["upper"] < 1e-10
    errs = []
    for kappa in (1e8, 1e12):
        out = patch_run((4, 4, 2), (3, 3, 2), "penalty", kappa=kappa)
        p = out["p"]
        errs.append(max(out["lower"], out["upper"]))
        total_err = abs(out["upper_total"][2] / (p * PATCH_W**2) - 1)
        tangential = np.abs(out["upper_total"][:2]).max() / (p * PATCH_W**2)
        print(f"\npatch penalty non-matching kappa {kappa:.0e}: nodal {errs[-1]:.2e}, total {total_err:.2e}, tangential total {tangential:.1e}")
        assert total_err <= errs[-1]
        assert tangential <= errs[-1]
        np.testing.assert_allclose(out["lower_total"] + out["upper_total"], 0, atol=1e-12 * p * PATCH_W**2)
    print(f"\npatch penalty: matching {max(match['lower'], match['upper']):.1e}; non-matching kappa 1e8 {errs[0]:.2e}, 1e12 {errs[1]:.2e}")
    assert errs[0] < 0.1
    assert errs[1] < errs[0] / 100
