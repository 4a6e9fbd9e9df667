"""Several bodies in one scene are independent problems in one DOF space (until contact)."""

import copy

import numpy as np
import pytest

import vfrs


def body(name, origin, damping, mass="consistent", E=10e3):
    return {"name": name,
            "mesh": {"builtin": "box", "size": [0.02, 0.008, 0.004], "cells": [6, 2, 1], "origin": origin},
            "material": {"model": "isotropic", "E": E, "nu": 0.45, "rho": 1070.0},
            "damping": damping, "mass": mass, "fixed": ["xmin"],
            "loads": [{"type": "traction", "surface": "xmax", "value": [0.0, 0.0, -50.0]}]}


TIME = {"mode": "dynamic", "step": 1e-3, "end": 0.05, "alpha": -0.2}


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_two_bodies_with_different_damping_equal_two_separate_runs(mass):
    a = body("a", [0.0, 0.0, 0.0], {"a0": 0.0, "a1": 1e-3}, mass)
    b = body("b", [0.0, 0.0, 0.01], {"a0": 5.0, "a1": 0.0}, mass, E=20e3)
    both = vfrs.run(vfrs.Scene.from_dict({"bodies": [a, b], "time": TIME}), progress=False)
    alone_a = vfrs.run(vfrs.Scene.from_dict({"bodies": [copy.deepcopy(a)], "time": TIME}), progress=False)
    alone_b = vfrs.run(vfrs.Scene.from_dict({"bodies": [copy.deepcopy(b)], "time": TIME}), progress=False)
    assert both.problem.C is not None  # non-uniform damping: an explicit C
    scale = np.abs(alone_a.u).max()
    np.testing.assert_allclose(both.displacement("a"), alone_a.u, atol=1e-10 * scale)
    np.testing.assert_allclose(both.displacement("b"), alone_b.u, atol=1e-10 * scale)
    ka = both.history["kinetic_energy"]
    np.testing.assert_allclose(ka, alone_a.history["kinetic_energy"] + alone_b.history["kinetic_energy"], rtol=1e-8)
    assert set(k for k in both.history if k.startswith("reaction_force")) == {
        "reaction_force.a.xmin", "reaction_force.b.xmin"}


def test_probe_finds_the_body_of_the_nearest_node():
    a = body("a", [0.0, 0.0, 0.0], {"a0": 0.0, "a1": 0.0})
    b = body("b", [0.0, 0.0, 0.01], {"a0": 0.0, "a1": 0.0})
    res = vfrs.run(vfrs.Scene.from_dict({"bodies": [a, b], "time": TIME,
                                         "output": {"probes": [[0.02, 0.004, 0.014]]}}), progress=False)
    p = res.probe([0.02, 0.004, 0.014])
    assert p["body"] == "b" and p["node"] >= res.problem.bodies[1].node_offset
    assert p["displacement"].shape == (51, 3)
