"""Every row of docs/architecture.md's "Where a change goes" that registers a class has a test
that registers a dummy of that role from outside the package, in one file, and runs a scene
with it (issue 31, item 4). Here: an effect, a contact solver and a contact scheme. Elsewhere:
a contact method and a detector (tests/test_architecture.py), an integrator
(tests/test_integrator_role.py), a summary measure (tests/test_outputs.py), a material
(tests/test_materials.py), a mesh generator (tests/test_scene_meshes.py)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

import vfrs
from vfrs.effects import EFFECTS, Effect
from vfrs.enforcement.reduced import DenseProblem
from vfrs.enforcement.scheme import SCHEMES, ContactScheme
from vfrs.enforcement.solver import SOLVERS, ContactSolver
from vfrs.params import param
from test_conformance import bars, blocks

meshio = pytest.importorskip("meshio")


class UniformPull(Effect):
    """``[uniform_pull]``: a total force along z spread equally over one body's nodes."""

    name = "uniform_pull"

    @dataclass(frozen=True)
    class Params:
        body: str = param(doc="the body pulled")
        fz: float = param(doc="total force along z", unit="N")

    def setup(self, ctx):
        (part,) = [b for b in ctx.problem.bodies if b.name == self.params.body]
        self.f = np.zeros(ctx.problem.n_dofs)
        self.f[3 * part.node_offset + 2: 3 * (part.node_offset + part.n_points): 3] = self.params.fz / part.n_points

    def forces(self, state):
        return self.f

    def output_fields(self, fields: dict) -> dict:
        """Its nodal force, a field of the VTU snapshots."""
        return {"pull": self.f.reshape(-1, 3)}


class DenseContactSolver(ContactSolver):
    """W = G K^-1 G^T, dense, one solve per pair and round: no stored columns."""

    name = "dense_outside"
    provides = DenseProblem.provides

    def __init__(self, params, ctx, max_iterations, observed, column_bytes=None, prefetch=None):
        super().__init__(params, ctx, max_iterations, observed, column_bytes)
        self.factor, self.free = ctx.factor, ctx.problem.dofmap.free

    def problem(self, G, g0, step):
        Gf = G.tocsr()[:, self.free].toarray()
        X = np.column_stack([self.factor.solve(np.ascontiguousarray(row)) for row in Gf]) if len(Gf) else \
            np.zeros((len(self.free), 0))
        return DenseProblem(self.force_scale * (Gf @ X), g0, self.max_iterations)


class PlainOutside(ContactScheme):
    """The paper's plain scheme again, under another name: the usual mass, contact forces at
    t_{n+1} inside the HHT-alpha recursion (the protocol's defaults)."""

    name = "plain_outside"


@pytest.fixture
def outside():
    EFFECTS.register(UniformPull)
    SOLVERS.register(DenseContactSolver)
    SCHEMES.register(PlainOutside)
    yield
    EFFECTS.unregister("uniform_pull")
    SOLVERS.unregister("dense_outside")
    SCHEMES.unregister("plain_outside")


def _bar(pull: float | None) -> dict:
    d = {"bodies": [{"name": "bar", "mesh": {"builtin": "box", "size": [0.002, 0.002, 0.02], "cells": [2, 2, 8]},
                     "material": {"model": "isotropic", "E": 1e5, "nu": 0.3, "rho": 1000.0}, "fixed": ["zmin"]}],
         "time": {"mode": "static"}, "output": {"reactions": True, "energy": False}}
    if pull is not None:
        d["uniform_pull"] = {"body": "bar", "fz": pull}
    return d


def test_an_effect_from_outside_loads_the_bar_and_the_support_takes_it(outside):
    """The section is validated and written back like any effect's; the support's reaction
    balances the pull (to 1e-12), and the answer is linear in it."""
    scene = vfrs.Scene.from_dict(_bar(-1e-3))
    assert scene.to_dict()["uniform_pull"] == {"body": "bar", "fz": -1e-3}
    r1 = vfrs.run(scene, progress=False)
    r2 = vfrs.run(vfrs.Scene.from_dict(_bar(-2e-3)), progress=False)
    reaction = r1.history["reaction_force.bar.zmin"][-1]
    np.testing.assert_allclose(reaction, [0.0, 0.0, 1e-3], rtol=0, atol=1e-12 * 1e-3)
    assert np.abs(r1.u).max() > 0
    np.testing.assert_allclose(r2.u, 2 * r1.u, rtol=1e-12, atol=1e-12 * np.abs(r1.u).max())
    with pytest.raises(vfrs.SceneError, match=r"uniform_pull\.fz"):
        vfrs.Scene.from_dict({**_bar(None), "uniform_pull": {"body": "bar", "fz": "strong"}})


def test_a_contact_solver_from_outside_gives_the_stored_compliance_answer(outside):
    """Lagrange on two blocks pressed together (statics): the dense solver's contact force is
    the default compliance solver's to 1e-9."""
    def force(solver):
        r = vfrs.run(vfrs.Scene.from_dict(blocks({"solver": solver, "detection": "bvh"})), progress=False)
        return r.history["contact_force.up"][-1]

    ref, dense = force("compliance"), force("dense_outside")
    assert abs(ref[2]) > 0
    np.testing.assert_allclose(dense, ref, rtol=1e-9, atol=1e-9 * abs(ref[2]))
    # A solver written before [contact] column_precision keeps working (the key is passed only
    # when set); asked for single-precision columns it cannot keep, the scene is refused by name.
    with pytest.raises(vfrs.SceneError, match="'dense_outside' does not take column_dtype"):
        vfrs.run(vfrs.Scene.from_dict(blocks({"solver": "dense_outside", "detection": "bvh",
                                              "column_precision": "single"})), progress=False)


def test_a_scheme_from_outside_runs_the_impact_as_the_plain_scheme_does(outside):
    """Two bars, Lagrange: the scheme registered from outside (the protocol's defaults) gives
    the plain scheme's history bit for bit."""
    def history(scheme):
        return vfrs.run(vfrs.Scene.from_dict(bars({"method": "lagrange", "detection": "bvh", "scheme": scheme})),
                        progress=False).history

    plain, outside_ = history("plain"), history("plain_outside")
    assert np.abs(plain["contact_force.a"]).max() > 0
    for key in ("contact_force.a", "contact_force.b", "u_max" if "u_max" in plain else "t"):
        np.testing.assert_array_equal(outside_[key], plain[key])


def test_an_effects_field_and_a_new_state_field_reach_the_vtu_files(outside, tmp_path, monkeypatch):
    """The effect's output_fields hook puts its 'pull' into every snapshot (the per-node
    share of the total, along z), and a name added to scene.FIELDS (here the acceleration again,
    under another name) is a field [output] fields may ask for, written like the built-in ones."""
    from vfrs import scene as scene_module

    monkeypatch.setitem(scene_module.FIELDS, "acceleration_again", "a")
    d = _bar(-1e-3)
    d["output"].update({"every": 1, "fields": ["displacement", "acceleration_again"]})
    vfrs.run(vfrs.Scene.from_dict(d), out=tmp_path / "out", progress=False)
    files = sorted((tmp_path / "out" / "fields").glob("bar_*.vtu"))
    assert files
    data = meshio.read(files[-1]).point_data
    n = len(data["displacement"])
    np.testing.assert_allclose(data["pull"][:, 2], np.full(n, -1e-3 / n), rtol=1e-15)
    assert "acceleration_again" in data and np.all(np.isfinite(data["acceleration_again"]))
