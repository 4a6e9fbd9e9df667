"""Hard cases stay numerically stable (issue 8): the stability suite.

Each test asserts a physical bound (an exact answer, a balance, an energy bound, a smoothness
bound), not only that nothing raised. The quick subset runs by default; the long variants are
marked ``slow`` (``pytest --runslow``). The measured numbers are in docs/stability.md.

Cases (issue 8): penalty stiffness over 1e0..1e16 x E/h; near incompressibility; grazing
contact over edges and vertices; projection on edges/vertices, initial penetration, gap exactly
zero; asymmetric collision (stiffness 1:1, 10:1, 1000:1, non-matching meshes, offset); large
time step (v h > element size); repeated impacts (energy); high subglottal pressure on the M5
folds; failure is loud.

Known defects are ``xfail(strict=True)`` with the reason: when one is fixed the test XPASSes,
fails, and the mark should go.
"""

from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

import vfrs
from vfrs.contact import BvhEngine, InterfaceMeshEngine
from vfrs.enforcement import METHODS as REGISTERED

slow = pytest.mark.slow
METHODS = ("lagrange", "penalty", "augmented_lagrange")


def _contact(method, kappa=None, **kw):
    c = {"method": method, **kw}
    if kappa is not None:
        c["kappa"] = kappa
    elif method in ("penalty", "augmented_lagrange"):
        c["kappa"] = 1e9  # Pa/m (AL's default: 100 x the surfaces' stiffness scale; test_augmented_lagrange_defaults.py)
    return c


def _run(d):
    return vfrs.run(vfrs.Scene.from_dict(d), progress=False)


# ---------------------------------------------------------------------------------------------
# A block pressed onto a rigid plane (static): uniaxial stress, exact answers.
# ---------------------------------------------------------------------------------------------
BE, BNU, BH, BW, BD = 1e4, 0.3, 0.01, 0.01, 1e-4
BCELLS = (3, 3, 4)
BEH = BE / (BH / BCELLS[2])  # E / h, h the element size normal to the contact


def block_on_plane(method, kappa=None, nu=BNU, z0=0.0, d=BD, **contact):
    return {
        "bodies": [{
            "name": "block",
            "mesh": {"builtin": "box", "size": [BW, BW, BH], "cells": list(BCELLS), "origin": [0, 0, z0]},
            "material": {"model": "isotropic", "E": BE, "nu": nu, "rho": 1000.0},
            "fixed": [{"surface": "zmax", "components": ["z"], "displacement": [0, 0, -d]},
                      {"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}]}],
        "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
        "contact": _contact(method, kappa, detection="bvh", surface="zmin", **contact),
        "time": {"mode": "static"},
        "output": {"energy": False},
    }


def _penalty_exact(kappa):
    """Uniform compression with a penalty layer: springs E A/H and kappa A in series."""
    F = BE * BW * BW * BD / (BH + BE / kappa)
    return F, F / (kappa * BW * BW)


# -- 1. penalty stiffness over the whole range ------------------------------------------------
QUICK_DECADES = (0, 4, 8, 12, 14, 15, 16)


def _decade_params():
    return [pytest.param(k, marks=[] if k in QUICK_DECADES else [slow], id=f"1e{k}xE/h") for k in range(0, 17)]


@pytest.mark.parametrize("decade", _decade_params())
def test_penalty_stiffness_range(decade):
    """kappa = 10^decade x E/h: finite, matches the exact penalty answer, equilibrium residual
    small, the reduced operator's condition estimate bounded by the Lagrange one."""
    kappa = 10.0**decade * BEH
    r = _run(block_on_plane("penalty", kappa))
    h = r.history
    assert np.isfinite(r.u).all()
    F_exact, pen_exact = _penalty_exact(kappa)
    F = h["contact_force.block"][-1]
    assert abs(F[2] - F_exact) <= 1e-12 * F_exact
    assert np.abs(F[:2]).max() <= 1e-12 * F_exact
    # Penetration follows 1/kappa down to a round-off floor.
    assert abs(h["max_penetration"][-1] - pen_exact) <= 1e-6 * pen_exact + 1e-17
    # Equilibrium residual: K u is zero on free DOFs off the contact face and sums to the
    # contact force on it.
    p = r.problem
    R = (p.K @ r.u.ravel())
    free = np.asarray(p.free)
    on_face = np.isclose(p.points[:, 2], 0.0)
    free_off = free[~on_face[free // 3]]
    assert np.abs(R[free_off]).max() <= 1e-10 * F_exact
    Rz = R.reshape(-1, 3)[on_face, 2].sum()
    assert abs(Rz - F[2]) <= 1e-10 * F_exact
    # The reduced-space operator (W + 1/kappa) keeps the conditioning of Lagrange's W.
    cond_l = _run(block_on_plane("lagrange"))
    cond = h["condition"][-1]
    assert np.isfinite(cond) and cond <= 1.001 * cond_l.history["condition"][-1]


def test_penalty_penetration_monotone_in_one_over_kappa():
    """Penetration decreases with every decade of kappa (1e0..1e16 x E/h) until the floor
    (~1e-19 m here: d x 1e-15), and the condition estimate never grows past Lagrange's."""
    pens, conds = [], []
    for k in range(0, 17):
        h = _run(block_on_plane("penalty", 10.0**k * BEH)).history
        pens.append(h["max_penetration"][-1])
        conds.append(h["condition"][-1])
    pens = np.array(pens)
    floor = 1e-15 * BD
    for a, b in zip(pens[:-1], pens[1:]):
        assert b <= a * (1 + 1e-9) or b <= floor
    # 1/kappa scaling while above the floor
    k = np.arange(17)
    above = pens > 100 * floor
    slope = np.polyfit(k[above], np.log10(pens[above]), 1)[0]
    assert -1.01 < slope < -0.95
    c_l = _run(block_on_plane("lagrange")).history["condition"][-1]
    assert max(conds) <= 1.001 * c_l and min(conds) >= 1.0


def test_penalty_refactor_path_loses_accuracy_as_documented():
    """The plain refactoring path (the reference) is accurate for moderate kappa and loses
    about kappa x eps: documented in docs/stability.md (1e8 E/h: 1.5e-9; 1e14 E/h: 2.4e-2).
    The compliance path stays at 1e-15 over the same range (test above)."""
    for k, tol in ((4, 1e-10), (8, 1e-7)):
        kappa = 10.0**k * BEH
        F = _run(block_on_plane("penalty", kappa, solver="refactor")).history["contact_force.block"][-1][2]
        F_exact = _penalty_exact(kappa)[0]
        assert abs(F - F_exact) <= tol * F_exact


# -- 2. near incompressibility ----------------------------------------------------------------
def _hemisphere_on_plane(nu, method="lagrange", mode="static", **contact):
    t = {"mode": "static"} if mode == "static" else {"mode": "dynamic", "step": 1e-3, "end": 4e-3, "alpha": -0.3}
    fixed = {"surface": "flat", "displacement": [0, 0, -5e-4]}
    if mode != "static":
        fixed["ramp"] = 2e-3
    return {
        "bodies": [{"name": "ball", "mesh": {"builtin": "hemisphere", "radius": 5e-3, "cells": 6, "center": [0, 0, 5e-3]},
                    "material": {"model": "isotropic", "E": 1e4, "nu": nu, "rho": 1000.0}, "fixed": [fixed]}],
        "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
        "contact": _contact(method, detection="bvh", surface="curved", **contact),
        "time": t, "output": {"energy": False},
    }


def _cantilever_tip_ratio(nu):
    """Tip deflection of a 10x2x2-cell linear-tet cantilever under an end load, over the
    Euler-Bernoulli value F L^3 / (3 E I)."""
    L, b, E, P = 0.1, 0.01, 1e4, 1.0
    r = _run({"bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [L, b, b], "cells": [10, 2, 2]},
                          "material": {"model": "isotropic", "E": E, "nu": nu, "rho": 1000.0}, "fixed": ["xmin"],
                          "loads": [{"type": "traction", "surface": "xmax", "value": [0, 0, -P]}]}],
              "time": {"mode": "static"}})
    tip = -r.u[np.isclose(r.points[:, 0], L), 2].mean()
    return tip / (P * b * b * L**3 / (3 * E * b**4 / 12))


# Measured (docs/stability.md): tip / Euler-Bernoulli and contact force of the pressed
# hemisphere, both relative to nu = 0.3. Linear tets lock: the ranges bracket the measured
# values (x 1/1.3 .. x 1.3) so a change in the locking shows up here.
LOCKING = {0.45: (0.673, 1.238), 0.49: (0.274, 1.786), 0.499: (0.0746, 5.14)}


@pytest.mark.parametrize("nu", [0.45, 0.49, 0.499])
def test_near_incompressible(nu):
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        tip = _cantilever_tip_ratio(nu)
        r = _run(_hemisphere_on_plane(nu))
    warned = [x for x in w if issubclass(x.category, vfrs.VfrsWarning) and "close to 0.5" in str(x.message)]
    if nu >= 0.49:
        assert warned, "nu close to 0.5 must warn (VfrsWarning) about locking"
        assert f"nu = {nu}" in str(warned[0].message) and "lock" in str(warned[0].message)
    else:
        assert not warned
    assert np.isfinite(r.u).all() and np.isfinite(tip)
    h = r.history
    F = h["contact_force.ball"][-1][2]
    assert h["max_penetration"][-1] <= 1e-12
    tip0 = _cantilever_tip_ratio(0.3)
    F0 = _run(_hemisphere_on_plane(0.3)).history["contact_force.ball"][-1][2]
    tip_rel, F_rel = tip / tip0, F / F0
    lo_t, lo_f = LOCKING[nu]
    assert lo_t / 1.3 <= tip_rel <= min(lo_t * 1.3, 1.0)
    assert max(lo_f / 1.3, 1.0) <= F_rel <= lo_f * 1.3
    # bounded: even at nu = 0.499 the contact force stays below 10x the nu = 0.3 force
    assert F_rel < 10.0


# -- 3. grazing contact -----------------------------------------------------------------------
def _grazing(method, y_path, steps=40, p0=2e-5):
    """A hemisphere (radius 2 mm, pole down, 2e-5 m into the ground at t = 0) slides 6 mm
    (3 ground cells) across the top of a box: its pole node crosses edges and vertices."""
    R = 2e-3
    return {
        "bodies": [
            {"name": "ground", "mesh": {"builtin": "box", "size": [10e-3, 10e-3, 4e-3], "cells": [5, 5, 2], "origin": [-5e-3, -5e-3, -4e-3]},
             "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0}, "fixed": ["zmin"]},
            {"name": "ball", "mesh": {"builtin": "hemisphere", "radius": R, "cells": 4, "center": [-3e-3, y_path, R - p0]},
             "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0},
             "fixed": [{"surface": "flat", "displacement": [6e-3, 0, 0]}]}],
        "contact": _contact(method, detection="bvh", surface={"ball": "curved", "ground": "zmax"}, pairs=[["ball", "ground"]]),
        "time": {"mode": "static", "load_steps": steps},
        "output": {"energy": False},
    }


GRAZE_PATHS = {"vertices": -1e-3, "diagonals": 0.0, "generic": 0.3e-3}


@pytest.mark.parametrize("method,path", [
    pytest.param("lagrange", "vertices"),
    pytest.param("penalty", "generic"),
    pytest.param("lagrange", "diagonals", marks=slow),
    pytest.param("lagrange", "generic", marks=slow),
    pytest.param("penalty", "vertices", marks=slow),
    pytest.param("augmented_lagrange", "vertices", marks=slow),
    pytest.param("augmented_lagrange", "generic", marks=slow),
])
def test_grazing_contact_is_smooth(method, path):
    """Normal force while the pole slides over edges and vertices: no step jumps by more than
    6 % of the mean force, the whole history stays within +-15 % of its mean, the active set
    settles in <= 4 iterations every step (no cycling; strict would raise), forces balance
    (the tangential force: the test after this one)."""
    r = _run(_grazing(method, GRAZE_PATHS[path]))
    h = r.history
    Fb, Fg = h["contact_force.ball"], h["contact_force.ground"]
    Fz = Fb[:, 2]
    mean = Fz.mean()
    assert np.isfinite(Fb).all() and mean > 0
    assert (h["active_pairs"] >= 1).all()
    assert np.abs(np.diff(Fz)).max() <= 0.06 * mean
    assert np.abs(Fz - mean).max() <= 0.15 * mean
    assert h["iterations"].max() <= 4
    assert h["contact_settled"].min() == 1
    assert np.abs(Fb + Fg).max() <= 1e-12 * mean


@pytest.mark.parametrize("method,path", [
    pytest.param("lagrange", "vertices"),
    pytest.param("penalty", "generic"),
    pytest.param("lagrange", "diagonals", marks=slow),
    pytest.param("lagrange", "generic", marks=slow),
    pytest.param("penalty", "vertices", marks=[slow, pytest.mark.xfail(strict=True, reason=(
        "two-pass node-to-surface on a curved master: at the last step a ground vertex under the "
        "ball's side is pushed along the ball's facet normal (tilted 13 degrees); measured 3.6 % of "
        "the mean normal force (5.5e-6 N against 1.55e-4 N). It was 1.04 % while the pole node kept "
        "two pairs (one per master triangle) across the detection rounds, twice its penalty: with "
        "one pair it goes deeper and the ground vertex takes more"))]),
    pytest.param("augmented_lagrange", "vertices", marks=slow),
    pytest.param("augmented_lagrange", "generic", marks=slow),
])
def test_grazing_contact_has_almost_no_tangential_force(method, path):
    """Frictionless: the tangential force stays below 2 % of the mean normal force while the
    pole slides over edges and vertices (a pole vertex over a ground vertex gets the
    vertex-to-vertex normal, slightly tilted)."""
    h = _run(_grazing(method, GRAZE_PATHS[path])).history
    Fb = h["contact_force.ball"]
    assert np.abs(Fb[:, :2]).max() <= 0.02 * Fb[:, 2].mean()


# -- 4. projection on edges and vertices, initial penetration, gap exactly zero --------------
def test_projection_edges_vertices_and_exact_zero_gap():
    T = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]])
    cases = [  # point, gap, feature (None: face or edge, a tie)
        ([0.25, 0.25, 0.0], 0.0, 0),
        ([0.5, 0.0, 0.0], 0.0, None),       # on an edge
        ([0.5, 0.5, 0.0], 0.0, None),       # on the hypotenuse
        ([0.0, 0.0, 0.0], 0.0, 2),          # on a vertex
        ([1.0, 0.0, 0.0], 0.0, 2),
        ([0.3, 0.3, -1e-300], 0.0, 0),      # signed zero below
        ([0.5, -0.5, 0.0], 0.5, 1),         # beyond an edge, in plane
        ([0.5, -0.5, -0.5], -np.sqrt(0.5), 1),  # beyond an edge, behind the plane: negative
        ([-1.0, -1.0, 0.0], np.sqrt(2.0), 2),   # beyond a vertex
        ([-1.0, -1.0, 1.0], np.sqrt(3.0), 2),
        ([2.0, -1.0, 0.5], np.sqrt(1.0 + 1.0 + 0.25), 2),
    ]
    p = np.array([c[0] for c in cases])
    r = vfrs.contact.project(p, np.repeat(T[None], len(p), axis=0))
    for (pt, g, f), gap, feat in zip(cases, r.gap, r.feature):
        if g == 0.0:
            assert gap == 0.0, (pt, gap)  # exactly zero, not 1e-17
        else:
            assert abs(gap - g) <= 1e-15, (pt, gap)
        if f is None:
            assert feat in (0, 1)
        else:
            assert feat == f, (pt, feat)
    assert np.isfinite(r.normal).all()


def test_initial_penetration_static_exact():
    """A block starting 2e-5 m inside the plane and pressed 1e-4 m: Lagrange puts it back on
    the plane with the exact force E A (d + p0) / H in the first load step."""
    p0 = 2e-5
    h = _run(block_on_plane("lagrange", z0=-p0)).history
    F = h["contact_force.block"][-1][2]
    exact = BE * BW * BW * (BD + p0) / BH
    assert abs(F - exact) <= 1e-9 * exact
    assert h["max_penetration"][-1] <= 1e-15


def _penetrating_block(method, p0, stabilized=True):
    Hb = 0.01
    return {
        "bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [Hb, Hb, Hb], "cells": [2, 2, 3], "origin": [0, 0, -p0]},
                    "material": {"model": "isotropic", "E": 1e5, "nu": 0.3, "rho": 1000.0}}],
        "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
        "contact": _contact(method, detection="bvh", surface="zmin", stabilized=stabilized),
        "time": {"mode": "dynamic", "step": 2e-4, "end": 0.02, "alpha": -0.3},
        "output": {"every": 100000},
    }


# x p0, after step 1. Augmented Lagrange: its own tolerance, gap_tol = 1e-7 m = 1e-3 p0 (the
# step-2 penetration was 1.7e-8 m before its reaction acted within its step only, 5.7e-8 m
# after; the bound here was 5e-4 p0, below gap_tol, from the earlier measurement).
PEN_TOL = {"lagrange": 1e-12, "augmented_lagrange": 1e-3, "penalty": 3e-2}


@pytest.mark.parametrize("method", METHODS)
def test_initial_penetration_dynamic(method):
    """Free block starting 1e-4 m inside the plane (no load, no velocity): the first step
    and the second resolve the overlap (Lagrange to round-off, AL / penalty to their
    tolerance), the energy put in is at most 2 x (1/2) E A p0^2 / h_el (squeezing one element
    layer by p0; measured 1.78 stabilized; the plain scheme puts in 9.0) and with alpha < 0 it
    never exceeds the level reached at the end of step 1. Energies include the penalty
    spring's (bounded above by 1/2 F max_penetration)."""
    p0, Hb, E, hel = 1e-4, 0.01, 1e5, 0.01 / 3
    h = _run(_penetrating_block(method, p0)).history
    pen = h["max_penetration"]
    assert pen[2:].max() <= PEN_TOL[method] * p0
    lo, hi = _energy_bounds(h, h["kinetic_energy"] + h["elastic_energy"], "block")  # no loads
    bound = 2.0 * 0.5 * E * Hb * Hb * p0**2 / hel
    assert np.isfinite(hi).all() and hi.max() <= bound
    # after step 1 the energy never exceeds its level at step 1 (HHT's kinetic + elastic is not
    # monotone step to step: +2 % from step 2 to 3 with Lagrange, so step 1, the peak, is the
    # reference; for penalty the step-1 level includes the springs' upper bound)
    assert hi[1:].max() <= hi[1] * (1 + 1e-6)


def test_initial_penetration_is_reported_at_t0():
    """The history's first row (t = 0, before any step) shows a penetration the body starts
    with (it used to show 0: no detection ran before the first step)."""
    h = _run(_penetrating_block("lagrange", 1e-4)).history
    assert h["max_penetration"][0] == pytest.approx(1e-4, rel=1e-6)


# ---------------------------------------------------------------------------------------------
# Two blocks (static): lower block on the ground, upper one pressed down; springs in series.
# ---------------------------------------------------------------------------------------------
TW, TH, TE = 10e-3, 5e-3, 1e4


def two_blocks(method, detection, ratio=1.0, gap=2e-5, d=1e-4, offset=0.0, kappa=None):
    def blk(name, z0, E, cells, top, x0):
        fx = [{"surface": "xmin", "components": ["x"]}, {"surface": "ymin", "components": ["y"]}]
        fx.append({"surface": "zmax", "components": ["z"], "displacement": [0, 0, -d]} if top
                  else {"surface": "zmin", "components": ["z"]})
        return {"name": name, "mesh": {"builtin": "box", "size": [TW, TW, TH], "cells": cells, "origin": [x0, 0, z0], "jitter": 0.2},
                "material": {"model": "isotropic", "E": E, "nu": 0.3, "rho": 1000.0}, "fixed": fx}
    return {
        "bodies": [blk("low", -TH, TE * ratio, [3, 3, 2], False, 0.0), blk("up", gap, TE, [4, 4, 2], True, offset)],
        "contact": _contact(method, 1e12 if method != "lagrange" and kappa is None else kappa,
                            detection=detection, surface={"low": "zmax", "up": "zmin"}),
        "time": {"mode": "static", "load_steps": 2},
        "output": {"energy": False},
    }


def _series_force(ratio, gap, d):
    return (d - gap) * TW * TW / (TH / (TE * ratio) + TH / TE)


def test_gap_exactly_zero():
    """Surfaces exactly touching: with no load the force is exactly zero (no NaN, no active
    pair); pressed, the exact series force; the interface mesh, which cannot be built on
    touching surfaces, says so (naming node and triangle)."""
    for method in METHODS:
        r = _run(two_blocks(method, "bvh", ratio=10.0, gap=0.0, d=0.0))
        h = r.history
        assert np.isfinite(r.u).all()
        assert (h["contact_force.up"] == 0).all() and (h["active_pairs"] == 0).all()
        assert np.abs(r.u).max() == 0.0
        r = _run(two_blocks(method, "bvh", ratio=10.0, gap=0.0, d=1e-4))
        F, exact = r.history["contact_force.up"][-1][2], _series_force(10.0, 0.0, 1e-4)
        assert abs(F - exact) <= (1e-9 if method == "lagrange" else 1e-5) * exact
    with pytest.raises(vfrs.VfrsError, match=r"node \d+ is on or behind triangle \d+ at rest \(gap 0"):
        _run(two_blocks("lagrange", "interface_mesh", gap=0.0))


# -- 5. asymmetric collision ------------------------------------------------------------------
def _both_directions_see_it(r, d, detection):
    """At the contact-free configuration (upper block moved down rigidly by d), each
    detection direction on its own finds penetrating pairs."""
    prob = r.problem
    X = prob.points
    low, up = prob.bodies
    Xc = X.copy()
    Xc[up.nodes, 2] -= d
    surf = {p.name: p.mesh.surfaces[s] + p.node_offset for p, s in ((low, "zmax"), (up, "zmin"))}
    if detection == "bvh":
        seen = {}
        for s, m in (("low", "up"), ("up", "low")):
            pairs = BvhEngine(surf[m], slave_nodes=np.unique(surf[s])).detect(Xc, 1e-3)
            seen[s] = int((pairs.gap < 0).sum())
        return seen
    im = InterfaceMeshEngine(X, surf["low"], surf["up"])
    inv = im.inverted(Xc)
    return {"low": int((inv & (im.sides == 0)).sum()), "up": int((inv & (im.sides == 1)).sum())}


ASYM = [
    pytest.param("lagrange", "bvh", 10.0, 0.0, id="lagrange-bvh-10to1"),
    pytest.param("lagrange", "interface_mesh", 1000.0, 0.0, id="lagrange-im-1000to1"),
    pytest.param("penalty", "bvh", 1000.0, 0.0, id="penalty-bvh-1000to1"),
    pytest.param("lagrange", "bvh", 1000.0, 0.0, id="lagrange-bvh-1000to1", marks=slow),
    pytest.param("lagrange", "interface_mesh", 10.0, 0.0, id="lagrange-im-10to1", marks=slow),
    pytest.param("lagrange", "interface_mesh", 1.0, 0.0, id="lagrange-im-1to1", marks=slow),
    pytest.param("penalty", "interface_mesh", 1000.0, 0.0, id="penalty-im-1000to1", marks=slow),
    pytest.param("augmented_lagrange", "bvh", 1000.0, 0.0, id="al-bvh-1000to1", marks=slow),
    pytest.param("augmented_lagrange", "interface_mesh", 10.0, 0.0, id="al-im-10to1", marks=slow),
]


@pytest.mark.parametrize("method,detection,ratio,offset", ASYM)
def test_asymmetric_collision(method, detection, ratio, offset):
    """Lower block 1x/10x/1000x stiffer than the upper one, non-matching jittered meshes (3x3
    against 4x4 cells): both detection directions see the overlap, the forces on the two
    bodies balance, and the force is the exact series-spring value."""
    gap, d = 2e-5, 1e-4
    r = _run(two_blocks(method, detection, ratio, gap, d, offset))
    seen = _both_directions_see_it(r, d, detection)
    assert seen["low"] > 0 and seen["up"] > 0, seen
    h = r.history
    Fl, Fu = h["contact_force.low"][-1], h["contact_force.up"][-1]
    exact = _series_force(ratio, gap, d)
    assert np.abs(Fl + Fu).max() <= 1e-12 * exact
    assert abs(Fu[2] - exact) <= (1e-9 if method == "lagrange" else 1e-5) * exact
    assert np.abs(Fu[:2]).max() <= 1e-6 * exact
    assert h["max_penetration"][-1] <= (1e-12 if method == "lagrange" else 1e-9)


BVH_EDGE_BUG = (
    "BVH detection: a slave node whose closest point is on a boundary edge/vertex of the (open) "
    "master patch gets a negative gap as soon as it is below the face's plane, although it is "
    "beside the master body, not inside it (vfrs.contact.project: point [0.5, -0.5, -0.5] on the "
    "unit triangle -> gap -0.707, feature 1). Overhanging/narrower blocks then get spurious "
    "lateral forces: offset 0.35 cell -> Fx = -4.11 N, Fz = 0.406 N (interface mesh: Fx 5e-8 N, "
    "Fz 0.01447 N)")


@pytest.mark.parametrize("detection,offset,narrow", [
    pytest.param("interface_mesh", 0.35 * TW / 4, False, id="im-overhang-0.35cell"),
    pytest.param("interface_mesh", 0.3 * TW, False, id="im-overhang-30pc", marks=slow),
    # Fixed: pairs beside an open patch (plane projection outside the rim triangle) are dropped.
    pytest.param("bvh", 0.35 * TW / 4, False, id="bvh-overhang-0.35cell"),
    pytest.param("bvh", 0.5e-3, True, id="bvh-inside-footprint"),
])
def test_asymmetric_offset_blocks(detection, offset, narrow):
    """Upper block shifted sideways (overhanging the lower one, or narrower and inside its
    footprint): no exact answer, but the forces balance, both directions see the overlap, the
    frictionless contact force is normal (|Fx|, |Fy| <= 1e-3 Fz) and lies between half the
    overlap share of the full-contact series force and 1.05 x that force."""
    ratio, gap, d = 10.0, 2e-5, 1e-4
    sd = two_blocks("lagrange", detection, ratio, gap, d, offset)
    share = (TW - offset) / TW
    if narrow:
        sd["bodies"][1]["mesh"]["size"] = [0.8 * TW, TW, TH]
        share = 0.8
    r = _run(sd)
    seen = _both_directions_see_it(r, d, detection)
    assert seen["low"] > 0 and seen["up"] > 0
    h = r.history
    Fl, Fu = h["contact_force.low"][-1], h["contact_force.up"][-1]
    full = _series_force(ratio, gap, d)
    assert np.abs(Fl + Fu).max() <= 1e-12 * max(full, np.abs(Fu).max())
    assert np.abs(Fu[:2]).max() <= 1e-3 * Fu[2]
    assert 0.5 * share * full <= Fu[2] <= 1.05 * full
    assert h["max_penetration"][-1] <= 1e-12


@pytest.mark.parametrize("ratio", [10.0, 1000.0], ids=["10to1", "1000to1"])
def test_asymmetric_m5_folds(ratio):
    """Coarse M5 folds at Ps = 3 kPa, the left fold 10x / 1000x stiffer (10 kPa against 100 kPa /
    10 MPa), interface mesh, Lagrange, 7 ms: the soft right fold crosses the mid-plane and is
    stopped by the stiff one, which barely moves (measured with the default mass_redistribution:
    contact from 6.2 / 5.9 ms, the right fold reaches x = -0.461 / -0.463 mm, wrapping around
    the stiff fold's rounded edge; the left fold stays at -50 um; forces balance to 3e-16;
    stabilized: from 6.15 / 5.9 ms, -0.530 / -0.541 mm); forces balance, penetration at
    round-off. (With a 4 kPa soft fold, as before, the folds do not meet within 3 ms under the
    default scheme on this mesh: the massless medial nodes answer the 3 kPa flow at once and
    the soft fold opens; linear tissue at that load diverges after 4.2-4.5 ms anyway.)"""
    d = _m5_high_pressure("lagrange", 7e-3, E=1e4)
    d["bodies"][1]["material"]["E"] = 1e4 * ratio
    d["output"] = {"every": 1, "fields": ["displacement"]}
    r = _run(d)
    h = r.history
    X, U = r.problem.points, r.fields["displacement"]
    right, left = r.problem.bodies
    assert np.isfinite(U).all() and len(h["t"]) == 141
    on = np.flatnonzero(h["active_pairs"] > 0)
    assert on.size
    Fr, Fl = h["contact_force.right"], h["contact_force.left"]
    scale = np.abs(Fr).max()
    assert np.abs(Fr + Fl).max() <= 1e-9 * scale
    assert Fr[:, 0].min() >= -1e-12 * scale
    assert h["max_penetration"].max() <= 1e-12
    xr = (X[right.nodes, 0] + U[on][:, right.nodes, 0]).min()
    xl = (X[left.nodes, 0] + U[on][:, left.nodes, 0]).max()
    half_gap = 0.05e-3
    assert xr < -0.2 * half_gap  # the soft fold crosses the mid-plane
    assert xl <= -half_gap + 0.1 * half_gap / ratio**0.5  # the stiff one stays (nearly) put
    # (no overlap is the penetration bound above: the soft fold wraps around the stiff one's
    # rounded edge, so its most medial node lies beyond the stiff fold's most medial one)


# -- 6. large time step: v h > element size ---------------------------------------------------
def _fast_blocks(method, detection, v, h, steps=8):
    H = 5e-3

    def blk(name, z0, vel, fixed):
        return {"name": name, "mesh": {"builtin": "box", "size": [10e-3, 10e-3, H], "cells": [2, 2, 2], "origin": [0, 0, z0]},
                "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0}, "velocity": [0, 0, vel], "fixed": fixed}
    return {
        "bodies": [blk("low", -H, 0.0, ["zmin"]), blk("up", 0.5e-3, -v, [])],
        "contact": _contact(method, detection=detection, surface={"low": "zmax", "up": "zmin"}),
        "time": {"mode": "dynamic", "step": h, "end": steps * h, "alpha": -0.3},
        "output": {"every": 1000},
    }


def _crossing_outcome(method, detection, v, h):
    """Returns (caught, result): caught = the upper block never ends up inside the lower one
    and a contact force acted; a raise with a message counts as 'says it cannot'."""
    r = _run(_fast_blocks(method, detection, v, h))
    X = r.problem.points + r.u
    low, up = r.problem.bodies
    hs = r.history
    through = X[up.nodes, 2].min() < X[low.nodes, 2].max() - 1e-9
    acted = np.abs(hs["contact_force.up"][:, 2]).max() > 0
    return (acted and not through), r


ELEM = 2.5e-3  # element size along the approach


# Steps far too large for the impact speed, on purpose: the energy correction says so.
@pytest.mark.filterwarnings("ignore:.*the step is too large for this impact speed:vfrs.errors.VfrsWarning")
@pytest.mark.parametrize("method,ratio", [
    pytest.param("lagrange", 2.0, id="lagrange-vh=2elem"),
    pytest.param("penalty", 2.0, id="penalty-vh=2elem", marks=slow),
    pytest.param("augmented_lagrange", 2.0, id="al-vh=2elem", marks=slow),
    pytest.param("lagrange", 8.0, id="lagrange-vh=8elem", marks=slow),
])
def test_large_step_interface_mesh_catches_crossing(method, ratio):
    """v h = 2 (8) element sizes in one step: the interface mesh's node-triangle tets invert
    whatever the depth, so the crossing is caught: contact acts in the first step, the blocks
    end separated, the upper one moves back up."""
    v = 1.0
    caught, r = _crossing_outcome(method, "interface_mesh", v, ratio * ELEM / v)
    assert caught
    assert r.history["contact_force.up"][1, 2] > 0
    assert r.v[r.problem.bodies[1].nodes, 2].mean() > 0
    assert r.history["max_penetration"].max() <= (1e-12 if method == "lagrange" else 1e-5)


@pytest.mark.xfail(strict=True, reason=(
    "BVH detection projects slave nodes within search_distance of the master surface only; a node "
    "that jumps past the master face in one step (v h = 2 element sizes) is not found and the upper "
    "block passes through the lower one (it warns, see the next test; use the interface mesh)"))
def test_large_step_bvh_catches_crossing():
    v = 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vfrs.VfrsWarning)
        caught, _ = _crossing_outcome("lagrange", "bvh", v, 2.0 * ELEM / v)
    assert caught


def test_large_step_bvh_says_so():
    """While the BVH misses such crossings (the strict xfail above), the run says so: a
    VfrsWarning naming the motion and the search distance."""
    v = 1.0
    with pytest.warns(vfrs.VfrsWarning, match=r"moved .* more than the BVH search distance"):
        _crossing_outcome("lagrange", "bvh", v, 2.0 * ELEM / v)


@pytest.mark.parametrize("method,ratio", [
    pytest.param("lagrange", 0.4, id="lagrange-vh=0.4elem"),
    pytest.param("lagrange", 2.0, id="lagrange-vh=2elem"),
    pytest.param("lagrange", 8.0, id="lagrange-vh=8elem", marks=slow),
    pytest.param("augmented_lagrange", 2.0, id="al-vh=2elem", marks=slow),
    pytest.param("penalty", 0.4, id="penalty-vh=0.4elem"),
    pytest.param("penalty", 2.0, id="penalty-vh=2elem"),
    pytest.param("penalty", 8.0, id="penalty-vh=8elem", marks=slow),
])
def test_large_step_energy_bounded(method, ratio):
    """The impact must not return more energy than came in: kinetic + elastic <= E0 (1 + 1e-6),
    even with v h of several element sizes, for every method (the default scheme,
    mass_redistribution, alpha = -0.3). Measured: E0 to round-off at 0.4, 2 and 8 elements;
    the release of a layer crushed within one step makes energy (the last contact force acts
    over the rebound), which the scheme takes back: 0.03 / 0.60 / 4.0 E0 at v h = 0.4 / 2 / 8
    elements (history contact_energy_corrected), the upper block leaving at 0.90 / 0.75 / 0.19 v,
    with the "step is too large" warning at 2 and 8. (Before the energy correction: 1.17 E0 at 2
    elements. The stabilized scheme: Lagrange E0 to round-off at 0.4, 2 and 8 elements, it was
    1.24 E0 and 4.3 E0 at 2 and 8 while the constraint's reaction stayed in the HHT recursion
    into the next step; penalty 1.18 E0 at 2 elements and a ConvergenceError at 8.)"""
    v = 1.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vfrs.VfrsWarning)
        r = _run(_fast_blocks(method, "interface_mesh", v, ratio * ELEM / v))
    h = r.history
    tot = h["kinetic_energy"] + h["elastic_energy"]
    assert tot.max() <= tot[0] * (1 + 1e-6)


@pytest.mark.parametrize("scheme", ["mass_redistribution", "stabilized"])
def test_large_step_energy_warns(scheme):
    """With v h above the element size the run says the step is too large for this impact
    speed (a VfrsWarning): in the default scheme when the release of the crushed layer makes
    more energy than the deformation and the bodies' relative motion can give back (the free
    block's rebound is slowed, a momentum change the fixed block's support takes); in the
    stabilized scheme when its predictor moves contact nodes by more than half an element."""
    v = 1.0
    d = _fast_blocks("lagrange", "interface_mesh", v, 2.0 * ELEM / v)
    d["contact"]["scheme"] = scheme
    with pytest.warns(vfrs.VfrsWarning, match=r"step is too large for this impact speed"):
        _run(d)


# -- 7. repeated impacts: bouncing block ------------------------------------------------------
def _bouncing(method, stabilized, alpha, end, kappa=None):
    Hb = 0.01
    return {
        "gravity": [0, 0, -9.81],
        "bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [Hb, Hb, Hb], "cells": [2, 2, 3], "origin": [0, 0, 1e-3]},
                    "material": {"model": "isotropic", "E": 1e5, "nu": 0.3, "rho": 1000.0}, "velocity": [0, 0, -0.2]}],
        "obstacles": [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}],
        "contact": _contact(method, kappa, detection="bvh", surface="zmin", stabilized=stabilized),
        "time": {"mode": "dynamic", "step": 2e-4, "end": end, "alpha": alpha},
        "output": {"every": 1, "fields": ["displacement"]},
    }


def _energy_bounds(h, e, body):
    """(lower, upper) bounds of the total energy e + the penalty springs' energy. The springs
    hold sum_i lam_i^2 / (2 k_i) = sum_i lam_i g_i / 2 <= F max_penetration / 2 (all pairs on
    one rigid plane, F the body's normal contact force); 0 for Lagrange."""
    F = np.abs(h[f"contact_force.{body}"][:, 2])
    return e, e + 0.5 * F * h["max_penetration"]


def _energy_excess(r):
    """max_t (KE + elastic - W_gravity) - E0, over E0. W_gravity from the displacement
    snapshots (every step): history's external_work also counts the contact forces' work,
    which would hide a contact energy error."""
    h = r.history
    p = r.problem
    fg = p.M @ np.tile([0.0, 0.0, -9.81], p.n_points)
    U = r.fields["displacement"].reshape(len(r.fields["t"]), -1)
    assert len(U) == len(h["t"])
    _, tot = _energy_bounds(h, h["kinetic_energy"] + h["elastic_energy"] - U @ fg, "block")
    return (tot.max() - tot[0]) / tot[0], tot


def _impacts(r):
    on = r.history["contact_force.block"][:, 2] > 0
    return int(np.sum(on[1:] & ~on[:-1]))


@pytest.mark.parametrize("method,stabilized,alpha,end,kappa", [
    pytest.param("lagrange", True, -0.3, 0.1, None, id="lagrange-stab-a-0.3"),
    pytest.param("penalty", True, -0.3, 0.1, 1e8, id="penalty1e8-stab-a-0.3"),
    pytest.param("penalty", False, -0.3, 0.1, 1e9, id="penalty-plain-a-0.3"),
    pytest.param("lagrange", True, -0.1, 0.2, None, id="lagrange-stab-a-0.1", marks=slow),
    pytest.param("lagrange", False, -0.3, 0.2, None, id="lagrange-plain-a-0.3", marks=slow),
    pytest.param("penalty", True, -0.3, 0.2, 1e9, id="penalty-stab-a-0.3", marks=slow),
    pytest.param("penalty", True, -0.3, 0.2, 1e11, id="penalty1e11-stab-a-0.3", marks=slow),
    pytest.param("augmented_lagrange", True, -0.3, 0.2, None, id="al-stab-a-0.3", marks=slow),
    pytest.param("augmented_lagrange", False, -0.3, 0.2, None, id="al-plain-a-0.3", marks=slow),
])
def test_repeated_impacts_energy(method, stabilized, alpha, end, kappa):
    """A block dropped on a plane bounces several times; with alpha < 0 the total energy
    (kinetic + elastic + gravity potential + an upper bound of the penalty springs' energy)
    never exceeds the initial one by more than 1e-6 E0. (With a soft penalty, 1e7 Pa/m, the
    bound 1/2 F max_penetration is too loose while the block rocks: 7 % over E0 while the
    lower bound stays at E0, so soft penalties are not in this list.)"""
    r = _run(_bouncing(method, stabilized, alpha, end, kappa))
    excess, tot = _energy_excess(r)
    assert np.isfinite(tot).all()
    assert _impacts(r) >= 2
    assert excess <= 1e-6


# -- 8. high subglottal pressure on the M5 folds ----------------------------------------------
def _m5_high_pressure(method, end, E=4e3, **contact):
    def body(side):
        return {"name": side, "mesh": {"builtin": "m5", "side": side, "resolution": "coarse", "half_gap": 0.05e-3},
                "material": {"model": "isotropic", "E": E, "nu": 0.45, "rho": 1070.0},
                "damping": {"a0": 0.0, "a1": 1e-5}, "fixed": ["lateral", "anterior", "posterior"]}
    kappa = {"penalty": 1e9, "augmented_lagrange": 1e9, "penalty_volume": 1e12}.get(method)
    if method == "augmented_lagrange":
        # 4 augmentations from 1e9 Pa/m end above gap_tol at step 122 of the 10 kPa case
        # (2.4e-7 m), which the step reports as not converged; 6 reach it.
        contact.setdefault("max_augmentations", 8)
    return {
        "bodies": [body("right"), body("left")],
        "flow": {"model": "bernoulli", "subglottal_pressure": 3000.0, "ramp": 1e-3},
        "contact": _contact(method, kappa, detection="interface_mesh", pairs=[["right", "left"]], surface="medial", **contact),
        "time": {"mode": "dynamic", "step": 50e-6, "end": end, "alpha": -0.3},
        "output": {"every": 1000},
    }


M5_PEN = {"lagrange": 1e-12, "augmented_lagrange": 1e-6, "penalty": 1e-5, "penalty_volume": 1e-5}
M5_CASES = [  # scheme, E (Pa), end (s), steps, contact episodes, bound on |u| (m)
    ("E4kPa-3ms-stabilized", "stabilized", 4e3, 3e-3, 61, 1, 5e-3),
    ("E10kPa-12ms", "mass_redistribution", 1e4, 12e-3, 241, 2, 4e-3),
    ("E10kPa-12ms-stabilized", "stabilized", 1e4, 12e-3, 241, 3, 4e-3),
]


def _m5_params():
    out = []
    for cid, scheme, E, end, n, episodes, umax in M5_CASES:
        for method in sorted(m for m in REGISTERED if REGISTERED[m].applies_forces):  # every method with forces
            marks = [] if (method == "lagrange" and "stabilized" not in cid) else [slow]
            out.append(pytest.param(method, scheme, E, end, n, episodes, umax, marks=marks, id=f"{method}-{cid}"))
    return out


@pytest.mark.parametrize("method,scheme,E,end,n_steps,episodes,umax", _m5_params())
def test_m5_high_pressure(method, scheme, E, end, n_steps, episodes, umax):
    """Ps = 3 kPa on the coarse M5 folds. E = 10 kPa, 12 ms: they collide at 5.65 and 11.65 ms
    in the default scheme (stabilized: a brief first closure at 1.15 ms, then 5.7 and 11.6 ms).
    E = 4 kPa, 3 ms, stabilized: the folds close at ~1.3 ms and stay closed to ~2.1 ms (in the
    default scheme they do not close within 3 ms on this mesh: the massless medial nodes answer
    the flow at once and the soft folds open; on the medium mesh they close at 1.3 ms).
    Runs to the end with every method (strict: any non-converged step would raise); the
    contact forces on the two folds balance and push them apart (x); penetration within the
    method's tolerance; displacements bounded. (With E = 4 kPa the coupled run diverges after
    4.2-4.5 ms whatever the contact method or scheme, detect_only too: docs/stability.md.)"""
    d = _m5_high_pressure(method, end, E=E)
    d["contact"]["scheme"] = scheme
    r = _run(d)
    h = r.history
    assert np.isfinite(r.u).all()
    assert len(h["t"]) == n_steps
    on = h["active_pairs"] > 0
    assert int(np.sum(on[1:] & ~on[:-1])) >= episodes
    Fr, Fl = h["contact_force.right"], h["contact_force.left"]
    scale = np.abs(Fr).max()
    assert scale > 0
    assert np.abs(Fr + Fl).max() <= 1e-9 * scale
    assert Fr[:, 0].min() >= -1e-12 * scale  # right fold (x > 0) pushed towards +x only
    assert h["max_penetration"].max() <= M5_PEN[method]
    assert h["contact_settled"].min() == 1
    assert np.abs(r.u).max() <= umax


# -- 9. failure is loud -----------------------------------------------------------------------
@pytest.mark.parametrize("method", METHODS)
def test_failure_is_loud(method):
    """max_iterations = 1 on a hemisphere pressed onto a plane (its first active-set guess
    holds pulling pairs): ConvergenceError naming the step, the time, the method, the nodes
    and what to try. (The stabilized scheme: its predictor's LCP with the mass compliance needs
    more than one iteration here; under the default mass_redistribution the first guess of
    this press is right and nothing fails. The error path is the same for every scheme.)"""
    with pytest.raises(vfrs.ConvergenceError) as ei:
        _run(_hemisphere_on_plane(0.3, method, mode="dynamic", max_iterations=1, scheme="stabilized"))
    msg = str(ei.value)
    assert re.search(r"step [1-9]\d*, t = [0-9.e-]+: " + method + r" did not converge", msg), msg
    assert re.search(r"nodes involved \[\d+(, \d+)*\]", msg), msg
    assert "Try" in msg and "max_iterations" in msg and "strict = false" in msg


@pytest.mark.parametrize("method,extra", [
    ("lagrange", {}), ("penalty", {}), ("augmented_lagrange", {}), ("penalty", {"solver": "refactor"})],
    ids=["lagrange", "penalty", "augmented_lagrange", "penalty-refactor"])
def test_failure_is_loud_static(method, extra):
    """Static runs name the load step (was 'step -1'), and the refactoring penalty path raises
    too when it runs out of iterations (it returned a force 18 % too high, silently)."""
    with pytest.raises(vfrs.ConvergenceError) as ei:
        _run(_hemisphere_on_plane(0.3, method, max_iterations=1, **extra))
    msg = str(ei.value)
    assert re.search(r"step 1, t = 1: " + method + r" did not converge", msg), msg
    assert re.search(r"nodes involved \[\d+(, \d+)*\]", msg), msg
    assert "Try" in msg


# A step too large for the impact speed, on purpose: the predictor's warning is expected.
@pytest.mark.filterwarnings("ignore:.*the stabilized predictor moved contact nodes:vfrs.errors.VfrsWarning")
def test_strict_false_continues_and_stays_finite():
    """strict = false: the run continues past the non-converged steps (documented) and the
    numbers stay finite and bounded by the converged run's force scale."""
    ok = _run(_hemisphere_on_plane(0.3, "lagrange", mode="dynamic", scheme="stabilized"))
    r = _run(_hemisphere_on_plane(0.3, "lagrange", mode="dynamic", max_iterations=1, strict=False, scheme="stabilized"))
    F, F_ok = r.history["contact_force.ball"][:, 2], ok.history["contact_force.ball"][:, 2]
    assert np.isfinite(r.u).all()
    assert np.abs(F).max() <= 2.0 * np.abs(F_ok).max()


# A step too large for the impact speed, on purpose: the predictor's warning is expected.
@pytest.mark.filterwarnings("ignore:.*the stabilized predictor moved contact nodes:vfrs.errors.VfrsWarning")
def test_strict_false_records_the_unconverged_steps():
    r = _run(_hemisphere_on_plane(0.3, "lagrange", mode="dynamic", max_iterations=1, strict=False, scheme="stabilized"))
    flags = [k for k in r.history if "converged" in k]
    assert flags and (np.asarray(r.history[flags[0]]) == 0).any()


def test_augmented_lagrange_defaults_reach_gap_tol():
    """No kappa given: it starts at 100 x the surfaces' contact stiffness scale K_ii / a_i
    (2.18e7 Pa/m here, so 2.18e9 Pa/m), with no warning, and the hemisphere's 0.5 mm press
    reaches gap_tol in 2 of the default 10 augmentations (measured penetration 3.9e-9 m).
    The defaults used to be the paper's kappa_0 = 1 Pa/m and 4 augmentations, which raised in
    step 1 (the next test)."""
    d = _hemisphere_on_plane(0.3, "augmented_lagrange")
    d["contact"].pop("kappa")
    with warnings.catch_warnings():
        warnings.simplefilter("error", vfrs.VfrsWarning)
        warnings.simplefilter("ignore", vfrs.ResolutionWarning)  # its 1 mm^2 sensor disc holds 1 node: not this test's
        h = _run(d).history
    assert (h["contact_converged"] == 1).all()
    assert h["augmentations"][-1] <= 5
    assert h["max_penetration"][-1] <= 1e-7  # gap_tol default


def test_augmented_lagrange_papers_kappa0_reaches_gap_tol_or_says_so():
    """The paper's kappa_0 = 1, read as 1 Pa/m and given explicitly, warns that it is far below
    the stiffness scale; the growth rule takes it to 1e8 Pa/m in the default 10 augmentations
    and a pair still penetrates by 5.8e-7 m (with the paper's N = 4: 1e4 Pa/m, nearly all the
    0.5 mm). Either the step reaches gap_tol or it is not converged and strict (the default)
    raises, naming the worst gap."""
    d = _hemisphere_on_plane(0.3, "augmented_lagrange", kappa=1.0)
    try:
        with pytest.warns(vfrs.VfrsWarning, match=r"kappa = 1 Pa/m is far below the contact stiffness scale"):
            h = _run(d).history
    except vfrs.ConvergenceError as e:
        assert re.search(r"penetrates by [0-9.e-]+ m > gap_tol", str(e)), str(e)
        return
    assert h["max_penetration"][-1] <= 1e-7  # gap_tol default


def test_augmented_lagrange_unconverged_is_recorded():
    """strict = false: the steps that end above gap_tol are marked contact_converged = 0 and
    the run continues (the paper's kappa_0 = 1 Pa/m, given: 5.8e-7 m left after 10
    augmentations)."""
    d = _hemisphere_on_plane(0.3, "augmented_lagrange", kappa=1.0, strict=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", vfrs.VfrsWarning)
        h = _run(d).history
    assert h["max_penetration"][-1] > 1e-7
    assert (h["contact_converged"][1:] == 0).all()

def test_divergence_is_named_not_a_geometry_error():
    """Soft folds (E = 4 kPa) at 3 kPa leave linear elasticity after ~4.5 ms with every method,
    detect_only included; displacements pass the scene size and grow to metres. The run must
    stop saying it diverged (step, time, displacement, what to try), not with a degenerate
    contact triangle."""
    d = _m5_high_pressure("detect_only", 8e-3)
    with pytest.raises(vfrs.ConvergenceError, match=r"step \d+, t = .*diverged.*largest displacement.*subglottal"):
        _run(d)


@pytest.mark.slow
@pytest.mark.xfail(strict=True, raises=vfrs.errors.ConvergenceError, reason=(
    "known defect: loud phonation (examples/m5_loud.toml: fibre-reinforced finite-strain folds, Ps = 3 kPa, "
    "h = 25 us, modified Newton, contact inside the iteration) under the default contact scheme, mass "
    "redistribution, stops at a hard collision: coarse mesh at t = 35.875 ms (step 1435), medium at 23.075 ms "
    "(relative residuals 0.1-0.6 for 25 iterations; that step's contact made 5.24e-4 J, more than the bodies' "
    "motion held to take back). With the stabilized scheme the same scenes run their 50 ms, which is why the "
    "example names it. At 0.8 kPa the fibre-reinforced folds needed 31 iterations at one step (t = 32.9 ms)"))
def test_loud_phonation_runs_under_the_default_contact_scheme():
    """The coarse mesh (47 s to the failure; the medium one, 258 s, fails the same way)."""
    from pathlib import Path

    examples = Path(__file__).resolve().parent.parent / "examples"
    d = vfrs.Scene.load(examples / "m5_loud.toml").to_dict()
    d["contact"]["scheme"] = "mass_redistribution"
    for b in d["bodies"]:
        b["mesh"]["resolution"] = "coarse"
    d["time"]["end"] = 0.036
    res = vfrs.run(vfrs.Scene.from_dict(d, base_dir=str(examples)), progress=False)
    assert res.history["t"][-1] == pytest.approx(0.036)
    assert np.isfinite(res.history["kinetic_energy"]).all()
