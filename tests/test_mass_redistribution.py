"""The contact scheme ``mass_redistribution``: what it does to the mass matrix, and what it
keeps (python/vfrs/enforcement/schemes/mass_redistribution.py, docs/contact.md).

- The contact-surface nodes' rows and columns of M are zero, M stays symmetric positive
  definite on the other free DOFs, and the total mass and the momentum of every uniform
  velocity are M's exactly (T reproduces constants); lumped masses stay diagonal.
- The centre of mass and the rotational inertia move by what the run log reports (measured
  on one M5 fold: 47 um and -0.81 % coarse, 9.2 um and -0.11 % medium).
- Without contact the folds' first six eigenfrequencies (the scene's clamping) move by at most
  0.8 % on the coarse mesh and 0.11 % on the medium one (measured: coarse 103.99 -> 103.37 Hz
  for the first, -0.59 .. +0.79 % for the six; medium 100.68 -> 100.61 Hz, -0.07 .. +0.11 %):
  the change falls with the mesh, as the mass moved (4.7 % -> 1.7 % of the fold's) does.
- M' keeps M's sparsity (the factor of K_eff does not grow: the medium main job's has the same
  6,069,312 entries with both masses).
- A body falls at g undeformed (gravity follows the new mass), and a block resting on a plane
  under its weight stays at rest with the exact reaction.
- A body whose every node is on its contact surface has nothing to carry the mass: a
  SceneError naming the body and what to change.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as sla

import vfrs
from vfrs.dynamics import build_problem
from vfrs.enforcement.schemes.mass_redistribution import interpolation, redistributed_mass
from vfrs.errors import SceneError


def fold(resolution="coarse", mass="consistent"):
    d = vfrs.Scene.load("examples/m5_collision.toml").to_dict()
    body = d["bodies"][0]
    body["mesh"]["resolution"] = resolution
    body["mass"] = mass
    return build_problem(vfrs.Scene.from_dict({"bodies": [body], "time": d["time"]}))


def medial(p):
    return np.unique(p.bodies[0].mesh.surfaces["medial"])


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_massless_rows_total_mass_and_momentum(mass):
    p = fold(mass=mass)
    M = p.M.tocsr()
    Mn, massless, (rep,) = redistributed_mass(p, medial(p))
    dofs = (3 * massless[:, None] + np.arange(3)).ravel()
    assert massless.size == rep.massless == 147
    assert abs(Mn[dofs]).max() == 0 and abs(Mn[:, dofs]).max() == 0
    assert abs(Mn - Mn.T).max() == 0
    one = np.tile([1.0, 0.0, 0.0], p.n_points)  # a uniform velocity along x
    assert one @ (Mn @ one) == pytest.approx(one @ (M @ one), rel=1e-13)  # total mass
    for k in range(3):  # the momentum of a uniform velocity along each axis
        e = np.tile(np.eye(3)[k], p.n_points)
        assert (Mn @ e).sum() == pytest.approx((M @ e).sum(), rel=1e-13)
    if mass == "lumped":
        assert (Mn - sp.diags(Mn.diagonal())).nnz == 0
    keep = np.setdiff1d(np.arange(p.n_dofs), dofs)
    assert Mn[keep][:, keep].diagonal().min() > 0
    # the x-moments reported
    X = p.points
    Mx, Mnx = M[0::3, 0::3], Mn[0::3, 0::3]
    c0 = X.T @ (Mx @ np.ones(len(X))) / rep.mass
    c1 = X.T @ (Mnx @ np.ones(len(X))) / rep.mass
    assert rep.centroid_shift == pytest.approx(np.linalg.norm(c1 - c0), rel=1e-9)
    print(f"\n{mass}: {rep.describe()}")


def test_interpolation_rows_are_convex_and_skip_the_surface():
    p = fold()
    T, massless = interpolation(p, medial(p))
    T = T.tocsr()
    assert np.allclose(np.asarray(T.sum(axis=1)).ravel(), 1.0, rtol=0, atol=1e-14)
    assert T.data.min() > 0
    assert T[:, massless].nnz == 0  # no massless node takes a massless node's velocity
    rest = np.setdiff1d(np.arange(p.n_points), massless)
    assert (T[rest][:, rest] - sp.identity(len(rest))).nnz == 0


def _frequencies(p, M):
    w = sla.eigsh(p.K_free, k=6, M=M, sigma=0.0, which="LM")[0]
    return np.sqrt(np.sort(w)) / (2 * np.pi)


@pytest.mark.slow
def test_eigenfrequencies_move_little_and_less_on_finer_meshes():
    change = {}
    for res, bound in (("coarse", 0.01), ("medium", 0.002)):
        p = fold(res)
        f = _frequencies(p, p.M_free)
        p.set_mass(redistributed_mass(p, medial(p))[0])
        g = _frequencies(p, p.M_free)
        change[res] = np.abs(g / f - 1).max()
        print(f"\n{res}: {np.round(f, 2)} -> {np.round(g, 2)} Hz, largest change {change[res]:.2%}")
        assert change[res] < bound
    assert change["medium"] < change["coarse"] / 3


def _box(cells, surface, gravity=(0.0, 0.0, 0.0), end=0.02, z0=0.0, contact=True):
    d = {"bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.01], "cells": cells,
                                                "origin": [0, 0, z0]},
                     "material": {"model": "isotropic", "E": 1e5, "nu": 0.3, "rho": 1000.0}}],
         "gravity": list(gravity),
         "time": {"mode": "dynamic", "step": 1e-4, "end": end, "alpha": 0.0}, "output": {"every": 10**6}}
    if contact:
        d["obstacles"] = [{"type": "plane", "point": [0, 0, 0], "normal": [0, 0, 1]}]
        d["contact"] = {"method": "lagrange", "detection": "bvh", "surface": surface, "scheme": "mass_redistribution"}
    return d


def test_free_fall_is_rigid():
    """3 x 3 x 3 cells, the bottom face massless, 1 m above the plane: after 20 ms of free fall
    every node has moved by g t^2 / 2 and no strain builds up (gravity is M' g)."""
    r = vfrs.run(vfrs.Scene.from_dict(_box([3, 3, 3], "zmin", (0, 0, -9.81), z0=1.0)), progress=False)
    t = r.history["t"][-1]
    uz = r.u[:, 2]
    assert np.allclose(uz, -0.5 * 9.81 * t**2, rtol=1e-9, atol=0)
    assert r.history["elastic_energy"].max() < 1e-12 * r.history["kinetic_energy"][-1]


def test_block_at_rest_on_a_plane():
    """The Signorini block of test_contact_verification (4 x 4 x 4 cells, lumped mass, rollers
    on xmin and ymin, resting on a frictionless plane under its weight, settling under
    mass-proportional damping), with its base massless: it comes to rest (|v| < 1e-9 m/s)
    with the reaction m g to 1e-9 and no penetration. (The settled displacement differs from
    a roller support's by the weight of the base layer, which now rests on the layer above.)"""
    from test_contact_verification import RHO, SIG_G, SIG_H, SIG_W, _signorini_scene

    d = _signorini_scene(0.0).to_dict()
    d["contact"]["scheme"] = "mass_redistribution"
    r = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
    mg = RHO * SIG_W * SIG_W * SIG_H * SIG_G
    assert r.history["contact_force.block"][-1][2] == pytest.approx(mg, rel=1e-9)
    assert np.abs(r.v).max() < 1e-9
    assert r.history["max_penetration"][-1] < 1e-12 * SIG_H


def test_a_body_entirely_on_its_contact_surface_is_refused():
    d = _box([1, 1, 1], "boundary")
    d["contact"]["surface"] = "zmin"
    d["bodies"][0]["mesh"]["cells"] = [1, 1, 1]
    # every node of a 1 x 1 x 1 box is on its boundary: take the whole boundary as the surface
    d["contact"].pop("surface")
    with pytest.raises(SceneError, match=r"body 'block'.*no node to carry the mass"):
        vfrs.run(vfrs.Scene.from_dict(d), progress=False)


def test_the_new_mass_keeps_the_sparsity():
    """M' has no entry where M has none (so K_eff keeps K's pattern and its factor does not
    grow), and its diagonal on the kept DOFs is at least M's."""
    p = fold()
    M = p.M.tocsr()
    Mn, massless, _ = redistributed_mass(p, medial(p))
    pattern = (abs(M) > 0).astype(np.int8)
    new = (abs(Mn) > 0).astype(np.int8)
    assert (new - new.multiply(pattern)).nnz == 0
    dofs = (3 * massless[:, None] + np.arange(3)).ravel()
    keep = np.setdiff1d(np.arange(p.n_dofs), dofs)
    assert np.all(Mn.diagonal()[keep] >= M.diagonal()[keep])
