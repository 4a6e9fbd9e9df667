"""Effects run only when the scene names them, and their hooks can add forces or re-solve."""

import numpy as np
import pytest

import vfrs
from vfrs.effects import EFFECTS, Effect


def beam_dict(**extra):
    d = {
        "bodies": [{"name": "beam", "mesh": {"builtin": "box", "size": [0.02, 0.004, 0.004], "cells": [8, 2, 2]},
                    "material": {"model": "isotropic", "E": 10e3, "nu": 0.45, "rho": 1070.0},
                    "damping": {"a0": 0.0, "a1": 1e-4},
                    "fixed": ["xmin"],
                    "loads": [{"type": "traction", "surface": "xmax", "value": [0.0, 0.0, -50.0]}]}],
        "time": {"mode": "dynamic", "step": 1e-3, "end": 0.05, "alpha": -0.3},
        "output": {"every": 1000},
    }
    d.update(extra)
    return d


class Forbidden(Effect):
    """A test double: any call fails the test."""

    name = "flow"

    def __init__(self, config):
        raise AssertionError("the flow effect was built although the scene has no [flow]")

    def setup(self, problem):
        raise AssertionError("flow setup called")

    def forces(self, state):
        raise AssertionError("flow forces called")


class Recording(Effect):
    name = "flow"
    calls = []

    @classmethod
    def resolve(cls, table):
        cfg = {"gain": table.number("gain", 0.0)}
        table.done()
        return cfg

    def setup(self, problem):
        Recording.calls.append("setup")

    def forces(self, state):
        Recording.calls.append("forces")
        return None

    def record(self, state, history):
        history["flow_rate"].append(1.0)


def test_an_omitted_effect_is_never_built_or_called(monkeypatch):
    monkeypatch.setitem(EFFECTS, "flow", Forbidden)
    res = vfrs.run(vfrs.Scene.from_dict(beam_dict()), progress=False)
    assert "flow" not in res.effects and "flow" not in res.timings
    assert res.effects == ["elasticity", "inertia", "damping", "surface_loads"]


def test_a_named_effect_is_resolved_built_called_and_reported(monkeypatch):
    monkeypatch.setitem(EFFECTS, "flow", Recording)
    Recording.calls.clear()
    scene = vfrs.Scene.from_dict(beam_dict(flow={}))
    assert scene.to_dict()["flow"] == {"gain": 0.0}  # defaults from the effect's resolve
    res = vfrs.run(scene, progress=False)
    assert Recording.calls[0] == "setup" and Recording.calls.count("forces") == 51  # t = 0 and 50 steps
    assert "flow" in res.effects and res.timings["flow"] >= 0.0
    assert res.history["flow_rate"].shape == (51,)
    with pytest.raises(vfrs.SceneError, match=r"flow\.gian: unknown key; did you mean 'gain'\?"):
        vfrs.Scene.from_dict(beam_dict(flow={"gian": 1.0}))


@pytest.mark.parametrize("section", ["flow", "contact"])
def test_a_section_without_an_effect_is_a_clear_error(monkeypatch, section):
    monkeypatch.delitem(EFFECTS, section, raising=False)
    with pytest.raises(vfrs.SceneError, match=rf"<dict>: {section}: the '{section}' effect .* is not available yet"):
        vfrs.Scene.from_dict(beam_dict(**{section: {"method": "penalty"}}))


class TipLoad(Effect):
    """Explicit forces: the same traction as the scene's load, built by hand."""

    name = "flow"

    def setup(self, ctx):
        problem = ctx.problem
        mesh = problem.bodies[0].mesh
        tri = mesh.surface("xmax")
        x = mesh.points[tri]
        area = np.linalg.norm(np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0]), axis=1) / 2
        f = np.zeros((problem.n_points, 3))
        for k in range(3):
            np.add.at(f[:, 2], tri[:, k], -50.0 * area / 3)
        self.f = f.ravel()

    def forces(self, state):
        return self.f


def test_explicit_effect_forces_act_like_loads():
    with_load = vfrs.run(vfrs.Scene.from_dict(beam_dict()), progress=False)
    d = beam_dict()
    d["bodies"][0]["loads"] = []
    effect = TipLoad({})
    with_effect = vfrs.run(vfrs.Scene.from_dict(d), progress=False, effects=[effect])
    np.testing.assert_allclose(with_effect.u, with_load.u, rtol=1e-12, atol=1e-18)
    assert with_effect.effects[-1] == "flow"


class PinEnd(Effect):
    """Implicit forces, as a contact method would add them: Lagrange multipliers holding u_z = 0
    on the end face, solved in the space of the constrained DOFs with the factor of K_eff."""

    name = "contact"

    def setup(self, ctx):
        problem = ctx.problem
        nodes = problem.bodies[0].mesh.surface_nodes("xmax")
        self.dofs = 3 * nodes + 2
        self.n = problem.n_dofs
        G = np.zeros((self.n, len(self.dofs)))
        G[self.dofs, np.arange(len(self.dofs))] = 1.0
        self.G = G
        free = problem.dofmap.free
        # Responses to unit forces (the compliance a precomputed constraint correction keeps).
        self.R = problem.dofmap.expand(ctx.factor.solve(ctx.force_scale * G[free]))
        self.W = self.R[self.dofs]  # Delassus operator G K_eff^-1 G^T (scaled)
        self.predicted = 0

    def predict(self, step):
        assert step.u_tilde.shape == step.dofmap.free.shape
        self.predicted += 1

    def correct(self, step):
        u = step.dofmap.expand(step.u)
        lam = np.linalg.solve(self.W, -u[self.dofs])
        step.add_force(self.G @ lam, du_full=self.R @ lam)
        self.last = self.G @ lam


@pytest.mark.parametrize("alpha", [0.0, -0.3])
def test_implicit_forces_through_the_factor_equal_a_fixed_boundary(alpha):
    # The multipliers enter the HHT balance at t_{n+1} and, weighted by -alpha, at t_n: only
    # then does the constrained run equal the run with the DOFs eliminated, step after step.
    d = beam_dict()
    # Ramped from zero, so the initial acceleration is consistent with the pin in both runs.
    d["bodies"][0]["loads"] = [{"type": "pressure", "surface": "zmax", "value": 5.0, "ramp": 0.01}]
    d["time"]["alpha"] = alpha
    d["output"]["probes"] = [[0.02, 0.002, 0.0]]
    pin = PinEnd({})
    constrained = vfrs.run(vfrs.Scene.from_dict(d), progress=False, effects=[pin])
    d["bodies"][0]["fixed"].append({"surface": "xmax", "components": ["z"]})
    eliminated = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
    scale = np.abs(eliminated.u).max()
    np.testing.assert_allclose(constrained.u, eliminated.u, atol=1e-9 * scale)
    a = constrained.probe([0.02, 0.002, 0.0])["displacement"]
    b = eliminated.probe([0.02, 0.002, 0.0])["displacement"]
    np.testing.assert_allclose(a, b, atol=1e-9 * scale)
    assert pin.predicted == 50
    assert np.abs(pin.last).max() > 0
    # The forces an effect adds are attributed to it: probes, fields and timings.
    probe = constrained.probe([0.02, 0.002, 0.0])
    node = probe["node"]
    np.testing.assert_allclose(probe["contact_force"][-1], pin.last[3 * node: 3 * node + 3])
    assert probe["contact_force"][0].tolist() == [0.0, 0.0, 0.0]  # t = 0: nothing added yet
    np.testing.assert_allclose(constrained.fields["contact_force"][-1].ravel(), pin.last)
    assert constrained.timings["contact"] > 0 and "contact" in constrained.effects


class SpringEnd(PinEnd):
    """Implicit penalty forces f = -k u_z on the end face, solved in the constrained DOFs."""

    k = 50.0  # N/m per node

    def correct(self, step):
        u = step.dofmap.expand(step.u)[self.dofs]
        # f = -k (u + W f / k ...):  (I + k W) lam = -k u
        lam = np.linalg.solve(np.eye(len(self.dofs)) + self.k * self.W, -self.k * u)
        step.add_force(self.G @ lam, du_full=self.R @ lam)


def test_implicit_forces_enter_the_next_step_weighted_by_alpha():
    # The same springs built into K: a plain HHT-alpha loop is the reference. Forgetting the
    # -alpha F_c(t_n) term of the implicit forces would change this answer.
    from vfrs.dynamics import HHTAlpha

    d = beam_dict()
    d["bodies"][0]["loads"] = [{"type": "pressure", "surface": "zmax", "value": 5.0, "ramp": 0.01}]
    spring = SpringEnd({})
    res = vfrs.run(vfrs.Scene.from_dict(d), progress=False, effects=[spring])
    p = res.problem
    free = p.dofmap.free
    Gf = spring.G[free]
    import scipy.sparse as sp

    Ks = p.K_free + sp.csr_matrix(spring.k * Gf @ Gf.T)
    ref = HHTAlpha(p.M_free, Ks, 1e-3, -0.3, C=p.rayleigh[1] * p.K_free)
    u, v, a = (np.zeros(len(free)) for _ in range(3))
    F0 = p.external_force(0.0)[free]
    for k in range(1, 51):
        F1 = p.external_force(k * 1e-3)[free]
        ref.step(u, v, a, F0, F1)
        F0 = F1
    np.testing.assert_allclose(res.u.ravel()[free], u, atol=1e-9 * np.abs(u).max())
