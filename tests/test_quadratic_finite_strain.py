"""Finite strain on ten-node (P2) tetrahedra through Python
(vfrs._core.hyperelastic.QuadraticFiniteStrainAssembler): a clamped P2 cantilever under a tip
load, solved by Newton with the assembler's internal force and consistent tangent. A small load
gives the linear P2 solution up to O(load) (the relative difference halves with the load); a
moderately large one converges quadratically in a few iterations from rest, in one step."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spl

import vfrs
from vfrs import _core
from vfrs.meshes.quadratic import elevate

E, NU = 1.0e6, 0.3
L, H = 1.0, 0.1  # the beam: L along x, an H x H section centred on the x axis
CELLS = (12, 2, 2)
#: the tip load that bends the linear beam by about L / 1000 (P L^3 / 3 E I = 0.04 m/N * P)
SMALL = 0.025


def cantilever():
    """(assembler, points, free DOFs, the unit tip load): the P2 beam clamped at x = 0 (every
    DOF), a downward load of 1 N spread over the tip face by its triangles' consistent P2
    weights (a third of each triangle's area to each of its mid-edge nodes, none to the
    vertices)."""
    m = vfrs.meshes.box((L, H, H), CELLS, origin=(0.0, -H / 2, -H / 2))
    q = np.asarray(m.points)
    p, t = elevate(q, np.asarray(m.tets, dtype=np.int64))
    face = np.asarray(m.surfaces["xmax"])
    area = 0.5 * np.linalg.norm(np.cross(q[face[:, 1]] - q[face[:, 0]], q[face[:, 2]] - q[face[:, 0]]), axis=1)
    index = {tuple(np.round(x, 12)): i for i, x in enumerate(p)}
    w = np.zeros(len(p))
    for i, j in ((0, 1), (1, 2), (0, 2)):
        mids = [index[tuple(np.round(x, 12))] for x in 0.5 * (q[face[:, i]] + q[face[:, j]])]
        np.add.at(w, mids, area / 3.0)
    load = np.zeros(3 * len(p))
    load[2::3] = -w / w.sum()
    clamped = np.flatnonzero(np.isclose(p[:, 0], 0.0))
    free = np.setdiff1d(np.arange(3 * len(p)), (3 * clamped[:, None] + np.arange(3)).ravel())
    return _core.hyperelastic.QuadraticFiniteStrainAssembler(p, t), p, t, free, load


def linear_solution(p, t, free, f):
    """u of the linear P2 beam (QuadraticAssembler's stiffness of the same E, nu) under f."""
    asm = _core.fem.QuadraticAssembler(len(p), t)
    indptr, indices = asm.pattern()
    n = 3 * len(p)
    K = sp.csc_matrix((asm.stiffness(p, _core.fem.elasticity_isotropic(E, NU)[None]), indices, indptr), shape=(n, n))
    u = np.zeros(n)
    u[free] = spl.spsolve(K[free][:, free].tocsc(), f[free])
    return u


def newton(fs, law, free, f, tol=1e-10, max_iter=12):
    """Newton from rest on the free DOFs, in one load step: (u, the relative residual norms
    |f_int - f|_free / |f| of every iterate, the last included)."""
    n = f.size
    indptr, indices = fs.pattern()
    u = np.zeros(n)
    history = []
    for _ in range(max_iter):
        f_int, values, _energy = fs.force_and_tangent(u, [law])
        r = (f_int - f)[free]
        history.append(float(np.linalg.norm(r) / np.linalg.norm(f)))
        if history[-1] < tol:
            break
        K = sp.csc_matrix((values, indices, indptr), shape=(n, n))
        u[free] -= spl.spsolve(K[free][:, free].tocsc(), r)
    return u, history


def test_a_small_tip_load_gives_the_linear_p2_solution_to_first_order_in_the_load():
    """The neo-Hookean (E, nu) beam under tip loads of 0.025 N and half that (tip deflection
    about L / 1000): the relative difference from the linear P2 solution |u - u_lin| / |u_lin|
    (all DOFs) is O(load) -- mostly the axial shortening, even in the load, which linear theory
    lacks -- so it halves with the load: measured 5.39e-4 and 2.69e-4, ratio 2.000. Newton
    stops at 1e-8 of the load here: its round-off floor is about 1e-11 N (1.6e-9 of the
    0.025 N load, reached in 3 iterations)."""
    fs, p, t, free, unit = cantilever()
    law = _core.hyperelastic.neo_hookean_from_young(E, NU)
    differences = []
    for load in (SMALL, SMALL / 2):
        u, history = newton(fs, law, free, load * unit, tol=1e-8)
        assert history[-1] < 1e-8 and len(history) <= 4, history
        u_lin = linear_solution(p, t, free, load * unit)
        assert abs(np.mean(u_lin[2::3][np.isclose(p[:, 0], L)]) / (-load * 0.04) - 1) < 0.05  # ~ P L^3 / 3 E I
        differences.append(np.linalg.norm(u - u_lin) / np.linalg.norm(u_lin))
    ratio = differences[0] / differences[1]
    assert 1e-4 < differences[0] < 1e-2, differences
    assert 1.9 < ratio < 2.1, (differences, ratio)


def test_a_moderately_large_tip_load_converges_quadratically_in_newton():
    """A tip load of 2.5 N, 100 times the small one (the linear tip deflection is L / 10), from
    rest in one Newton step: converged (relative residual < 1e-10) in at most 6 iterations
    (measured 5: 1, 385, 3.7, 1.4e-3, 2.4e-5, 2.4e-11), and once the residual is below 1e-2
    each is at most C times the square of the one before, C = 50 (measured 13 and 0.04). The
    tip deflects 1 % less than the linear beam's (the beam's lever arm shortens as it bends)."""
    fs, p, t, free, unit = cantilever()
    law = _core.hyperelastic.neo_hookean_from_young(E, NU)
    u, history = newton(fs, law, free, 2.5 * unit)
    assert history[-1] < 1e-10, history
    assert len(history) - 1 <= 6, history
    tail = [(a, b) for a, b in zip(history, history[1:]) if a < 1e-2]
    assert len(tail) >= 2 and all(b <= 50.0 * a * a for a, b in tail), history
    tip = np.isclose(p[:, 0], L)
    deflection = np.mean(u[2::3][tip])
    linear = np.mean(linear_solution(p, t, free, 2.5 * unit)[2::3][tip])
    assert 0.95 < deflection / linear < 0.999, (deflection, linear)


def test_order_two_scene_stretches_like_the_closed_form():
    """examples/stretch_neo_hookean.toml with ``order = 2`` (the block as ten-node tetrahedra,
    finite strain through vfrs.run): the homogeneous stretch to 1.5 is exact on P2 as on P1: at
    every load step the reaction over the reference area is the closed-form nominal stress, the
    lateral stretch the closed-form one and the energy W V, to 1e-9 (the closed form of
    tests/test_finite_strain.py)."""
    import tomllib
    from pathlib import Path

    from test_finite_strain import neo_hookean_uniaxial

    d = tomllib.loads((Path(__file__).parent.parent / "examples" / "stretch_neo_hookean.toml").read_text())
    d["bodies"][0]["order"] = 2
    d["output"]["every"] = 1000
    res = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
    assert res.problem.bodies[0].mesh.order == 2
    h, L, A = res.history, 0.01, 1e-4
    corner = res.probe([L, L, L])["displacement"]
    for k, lam in enumerate(h["t"]):
        s, P, _, W = neo_hookean_uniaxial(1.0 + 0.5 * lam)
        assert abs(h["reaction_force.block.pull"][k, 0] / A - P) / P < 1e-9
        assert abs(1 + corner[k, 1] / L - s) / s < 1e-9
        assert abs(h["elastic_energy"][k] - W * L**3) / (W * L**3) < 1e-9
