"""The rooms hold: a contact method or a detector is one class registered by name, the
effect and the march loop know the roles only through their protocols, and the resolved
[contact] section shows only what the chosen method, detector and solver read."""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.contact import project
from vfrs.contact.geometry import ContactPairs
from vfrs.enforcement import DETECTORS, METHODS, ContactMethod, DetectedPairs, Detector, SolveInfo
from vfrs.params import param

PKG = Path(vfrs.__file__).parent


def blocks(contact):
    """Two blocks with non-matching faces (3 x 3 against 4 x 4 cells), the upper pushed 0.1 mm."""
    def blk(name, z0, cells, fixed):
        return {"name": name, "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.005], "cells": cells, "origin": [0, 0, z0]},
                "material": {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0}, "fixed": fixed}
    return {"bodies": [blk("low", -0.005, [3, 3, 2], ["zmin"]),
                       blk("up", 2e-5, [4, 4, 2], [{"surface": "zmax", "displacement": [0, 0, -1e-4]}])],
            "contact": {"surface": {"low": "zmax", "up": "zmin"}, **contact},
            "time": {"mode": "static"}, "output": {"energy": False}}


def force(contact):
    return vfrs.run(vfrs.Scene.from_dict(blocks(contact)), progress=False).history["contact_force.up"][-1]


class HalfPenalty(ContactMethod):
    """A method written outside the package: penalty on half the tributary area."""

    name = "half_penalty"
    uses = frozenset({"penalty"})

    @dataclass(frozen=True)
    class Params:
        kappa: float = param(doc="penalty", unit="Pa/m", positive=True)

    def solve(self, problem, pairs, scale=1.0, final=True):
        lam, info = problem.penalty(scale * 0.5 * self.params.kappa * pairs.tributary)
        return lam, SolveInfo.of(info)


class Brute(Detector):
    """A detector written outside the package: every slave node against every master
    triangle, the closest one within the search distance."""

    name = "brute"

    def detect(self, x):
        s, parts = self.surfaces, []
        for a, b in s.body_pairs:
            for sl, ma in ((a, b), (b, a)):
                tri, nodes = s.surface_of[ma], np.unique(s.surface_of[sl])
                k, t = np.repeat(nodes, len(tri)), np.tile(np.arange(len(tri)), len(nodes))
                r = project(x[k], x[tri[t]])
                d = np.abs(r.gap).reshape(len(nodes), len(tri))
                best = np.argmin(d, axis=1)
                keep = d[np.arange(len(nodes)), best] <= self.search
                i = (np.arange(len(nodes)) * len(tri) + best)[keep]
                parts.append(self._pairs(ContactPairs(nodes[keep], best[keep], tri[best[keep]], r.xi[i], r.zeta[i],
                                                      r.normal[i], r.gap[i], s.areas[nodes[keep]],
                                                      r.feature[i].astype(np.uint8)), x))
        return DetectedPairs.concatenate(parts, x)


@pytest.fixture
def plugins():
    METHODS.register(HalfPenalty)
    DETECTORS.register(Brute)
    yield
    METHODS.unregister("half_penalty")
    DETECTORS.unregister("brute")


def test_a_method_and_a_detector_are_one_class_each(plugins):
    """Registered from outside the package, usable from a scene at once: half the area at
    2 kappa is the penalty at kappa (to round-off), and the brute-force detector finds the
    pairs the BVH finds (same force to 1e-6: their edge/vertex normals differ slightly)."""
    ref = force({"method": "penalty", "kappa": 1e9, "detection": "bvh"})
    half = force({"method": "half_penalty", "kappa": 2e9, "detection": "bvh"})
    brute = force({"method": "half_penalty", "kappa": 2e9, "detection": "brute"})
    np.testing.assert_allclose(half, ref, rtol=1e-12, atol=1e-15)
    assert brute[2] == pytest.approx(ref[2], rel=1e-6)
    assert "half_penalty" in vfrs.Scene.from_dict(blocks({"method": "half_penalty", "kappa": 1.0})).to_dict()["contact"]["method"]


def test_the_resolved_contact_shows_only_the_chosen_roles_keys():
    lagrange = vfrs.Scene.from_dict(blocks({"method": "lagrange"})).to_dict()["contact"]
    assert "kappa" not in lagrange and "gap_tol" not in lagrange and "search_distance" not in lagrange
    al = vfrs.Scene.from_dict(blocks({"method": "augmented_lagrange", "kappa": 1e9, "detection": "bvh",
                                      "search_distance": 1e-3})).to_dict()["contact"]
    assert {"kappa", "growth", "reduction", "max_augmentations", "gap_tol", "kappa_max", "search_distance"} <= set(al)
    assert vfrs.Scene.from_dict({**blocks({}), "contact": al}).to_dict()["contact"] == al  # round trip


def test_a_key_of_another_method_is_refused_by_name():
    with pytest.raises(vfrs.SceneError, match=r"contact\.kappa: 'kappa' is a parameter of method .*'penalty'.*"
                                               r"not of method = 'lagrange'"):
        vfrs.Scene.from_dict(blocks({"method": "lagrange", "kappa": 1e9}))
    with pytest.raises(vfrs.SceneError, match=r"'search_distance' is a parameter of detection 'bvh'"):
        vfrs.Scene.from_dict(blocks({"method": "lagrange", "detection": "interface_mesh", "search_distance": 1e-3}))
    with pytest.raises(vfrs.SceneError, match=r"contact\.kappa: missing; 'kapa' looks like a typo of it"):
        vfrs.Scene.from_dict(blocks({"method": "penalty", "kapa": 1e9}))
    with pytest.raises(vfrs.SceneError, match=r"contact\.gap_tl: unknown key; did you mean 'gap_tol'"):
        vfrs.Scene.from_dict(blocks({"method": "augmented_lagrange", "gap_tl": 1e-8}))


def test_a_solver_refuses_a_method_it_cannot_run():
    with pytest.raises(vfrs.SceneError, match=r"solver = 'refactor' cannot solve the lagrange problems"):
        vfrs.Scene.from_dict(blocks({"method": "lagrange", "solver": "refactor"}))


def test_the_refactor_path_runs_uzawa_too():
    """Every method with a penalty law runs on the refactoring path (Uzawa included, which
    the old path refused) and agrees with the compliance path on the normal force to 1e-6
    (measured 1e-9). The tangential parts are artefacts of the non-matching faces, below 1e-4
    of the normal force on both paths (measured 4e-5): at round-off the two paths break a BVH
    tie differently (slave 48 or 66 on triangle 9 in the second detection round), and Uzawa,
    which stops at gap_tol, settles on each pair set with slightly different multipliers."""
    c = {"method": "augmented_lagrange", "kappa": 1e8, "max_augmentations": 8}
    a, b = force(c), force({**c, "solver": "refactor"})
    assert a[2] == pytest.approx(b[2], rel=1e-6)
    assert np.abs(a[:2]).max() < 1e-4 * a[2] and np.abs(b[:2]).max() < 1e-4 * b[2]


def _branch(names, classes):
    """Code that branches on one of ``names`` (a comparison with the string) or on one of
    ``classes`` (isinstance)."""
    n, c = "|".join(sorted(map(re.escape, names))), "|".join(sorted(map(re.escape, classes)))
    return re.compile(rf"""(==|!=|\bin\b|\bis\b)\s*[\(\[{{]?\s*["']({n})["']|isinstance\([^,]+,\s*\(?({c})\b""")


def _wiring() -> list:
    """Every module of the floors below the tools on runs (tests/test_import_graph.py's
    FLOORS: the ground, geometry, the scene, physics, a run and its output): the code that
    wires the roles together. The tools (plot, converge, the accuracy report, the CLI) may name
    a setting they report on."""
    from test_import_graph import FLOORS, _floor, _modules

    tools = [t for t, _ in FLOORS].index("tools on runs")
    files = [p for m, p in _modules().items()
             if p is not None and (_floor(m) if _floor(m) is not None else tools) < tools]
    return sorted(str(p.relative_to(PKG)) for p in files)


@pytest.mark.parametrize("path", _wiring())
def test_the_wiring_names_no_method_detector_solver_or_integrator(path):
    """Below the tools, no module branches on a contact method, detector, solver, scheme or
    integrator by its registered name or class (all read from the registries): they go through
    the protocols (the old contact effect did in 13 places). A plug-in's own file may name
    itself, no other."""
    from registered import plugin_names, role_names

    names, classes = role_names()
    own = plugin_names().get((PKG / path).resolve(), set())
    code = "\n".join(line for line in (PKG / path).read_text().splitlines() if not line.lstrip().startswith("#"))
    code = re.sub(r'"""(.*?)"""', "", code, flags=re.S)  # docstrings may name them
    assert not _branch(names - own, classes - own).findall(code), path


def test_the_branch_pattern_finds_a_branch():
    pattern = _branch({"lagrange", "static"}, {"BvhDetector"})
    assert pattern.findall('if method == "lagrange":') and pattern.findall("isinstance(d, BvhDetector)")
    assert pattern.findall('mode in ("static", "x")') and not pattern.findall('name = "lagrange"')


@pytest.mark.parametrize("method,detection", [("penalty", "bvh"), ("half_penalty", "brute"), ("lagrange", "bvh")])
def test_a_slave_keeps_one_pair_through_the_detection_rounds(plugins, monkeypatch, method, detection):
    """Non-matching faces put slave nodes on edges between two master triangles, where
    round-off picks the triangle. A loaded slave keeps its pair, geometry frozen, through the
    step's detection rounds; a later round that assigns it to the other triangle must not add
    a second pair (before: six of the 41 slaves here ended the step with two loaded pairs,
    and a penalty pushed each of them with twice its force law)."""
    from vfrs.enforcement.effect import ContactEffect

    seen = []
    record = ContactEffect.record

    def spy(self, state, history):
        if self.outcome is not None:
            seen.append(self.outcome)
        return record(self, state, history)

    monkeypatch.setattr(ContactEffect, "record", spy)
    kappa = {"penalty": 1e9, "half_penalty": 2e9}.get(method)
    force({"method": method, "detection": detection, **({"kappa": kappa} if kappa else {})})
    last = seen[-1]
    keys = last.found.slave_keys()
    assert len(last.found) == 41 and len(set(keys)) == len(keys)
