"""Every registered class runs the same contract as its siblings, read from the registries, so a
new contact method, detector, contact solver, scheme, material, mesh generator, integrator,
effect or summary measure is tested here the moment it is registered (nothing in this file names
one).

- every role's ``Params`` resolve from a scene table that gives only the required keys
  (:data:`SAMPLE` holds a value for each required key by name and unit) and round-trip
  through ``params_to_dict``;
- a contact method, a detector, a contact solver, a scheme and a dynamic integrator each run the
  two-bar impact of ``test_contact_conservation`` (1 x 1 cells on the faces, 20 along each bar)
  with the defaults for the other roles: a method that applies forces gives impulse = momentum
  on each body to 1e-9 of the momentum and the bars part; ``detect_only`` (no forces) finds
  pairs and records no force;
- a static integrator pushes one block onto another: the contact force on the two is equal
  and opposite (to 1e-9 of it) and not zero;
- a material's elasticity matrix (6 x 6, Voigt) is symmetric and positive definite;
- a mesh generator builds, with its defaults, a mesh of positively oriented tetrahedra whose
  named surfaces are non-empty, lie on the boundary and face outwards, and whose regions index
  its tetrahedra.
- an effect (``EFFECTS``) and a summary measure (``MEASURES``), on a run that names every
  effect (the main job with a vocal tract, coarse, 30 ms, the window the whole run): the summary
  names it declares (``summary_names(scene)``) are the ones it gives, each a ``Quantity`` with a
  unit; an effect's ``state()`` is storable in a checkpoint and ``restore`` of it gives it back;
  :func:`vfrs.summary.summary_names` is every name of the run's summary.

Measured (at f70a82a): impulse / momentum is 1 to 0.8e-13-1.2e-13 for every method, detector,
solver and scheme (the assertion allows 1e-9, as test_contact_conservation); the static
integrator's forces on the two blocks cancel to 4e-16 of the force (allowed: 1e-9). The whole
file runs in about 3 s.
"""

from __future__ import annotations

import dataclasses
from dataclasses import MISSING
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.checkpoint import Appended, flatten, items_of, unflatten
from vfrs.dynamics.integrators import INTEGRATORS
from vfrs.effects import EFFECTS
from vfrs.enforcement import DETECTORS, METHODS, SOLVERS
from vfrs.enforcement.scheme import SCHEMES
from vfrs.materials import MATERIALS
from vfrs.meshes import PARAMS as GENERATORS
from vfrs.params import param_keys, params_to_dict, read_params
from vfrs.params.table import Table
from vfrs.scene import read_toml
from vfrs.summary import DISPLAY, MEASURES, Quantity, RunView, summarize, summary_names

#: Values the contract gives to required keys, by (key, unit): a new class with a required key
#: not listed here fails with a message saying to add one.
SAMPLE = {
    ("kappa", "Pa/m"): 1e9, ("kappa", "N/m^3"): 1e13,
    ("E", "Pa"): 1e4, ("nu", ""): 0.3, ("k1", "Pa"): 1e3, ("k2", ""): 1.0,
    ("E_p", "Pa"): 2e3, ("E_z", "Pa"): 4e4, ("nu_p", ""): 0.4, ("nu_pz", ""): 0.1, ("G_pz", "Pa"): 1e4,
}

E, RHO, L, S, V0, GAP, N = 1e4, 1000.0, 0.1, 0.01, 0.1, 1e-4, 20
C = np.sqrt(E / RHO)
MASS = RHO * L * S * S


def required(cls, given: dict | None = None) -> dict:
    """The required keys of the Params dataclass ``cls`` (those without a default) with their
    values in ``given`` (for keys the scene fixes, such as a time step) or :data:`SAMPLE`."""
    given = given or {}
    out = {}
    for f in dataclasses.fields(cls):
        if f.name in given:
            out[f.name] = given[f.name]
        elif f.default is MISSING and f.default_factory is MISSING:
            key = (f.name, f.metadata.get("unit", ""))
            if key not in SAMPLE:
                pytest.fail(f"{cls.__qualname__}.{f.name} [{key[1]}] is required: add a sample value for {key} to "
                            "SAMPLE in tests/test_conformance.py")
            out[f.name] = SAMPLE[key]
    return out


def params_of(cls):
    """The Params dataclass of a registered class (a material's and a generator's Params is
    the class itself), or None."""
    p = getattr(cls, "Params", None)
    if p is None and dataclasses.is_dataclass(cls):
        p = cls
    return p if p is not None and dataclasses.is_dataclass(p) else None


def check_params_contract(cls, given: dict | None = None):
    """``cls``'s Params resolve from the required keys alone and round-trip."""
    P = params_of(cls)
    if P is None:
        return None
    p = read_params(P, Table(required(P, given), "test", "<conformance>"))
    again = read_params(P, Table(params_to_dict(p), "test", "<conformance>"))
    assert again == p, (p, again)
    assert set(params_to_dict(p)) <= set(param_keys(P))
    return p


def params(registry):
    return [pytest.param(name, id=name) for name in sorted(registry)]


# ------------------------------------------------------------------------------------------
# The scenes of the contract
# ------------------------------------------------------------------------------------------

def bars(contact: dict, time: dict | None = None, material: dict | None = None) -> dict:
    """Bar a at V0 onto bar b at rest (the 1-D impact of test_contact_conservation, coarser)."""
    h = L / C / N

    def bar(name, x0, v):
        return {"name": name, "mesh": {"builtin": "box", "size": [L, S, S], "cells": [N, 1, 1], "origin": [x0, 0, 0]},
                "material": material or {"model": "isotropic", "E": E, "nu": 0.0, "rho": RHO}, "mass": "lumped",
                "velocity": [v, 0, 0],
                "fixed": [{"surface": "ymin", "components": ["y"]}, {"surface": "zmin", "components": ["z"]}]}

    return {"bodies": [bar("a", -L - GAP / 2, V0), bar("b", GAP / 2, 0.0)],
            "contact": {"surface": {"a": "xmax", "b": "xmin"}, **contact},
            "time": {"mode": "dynamic", "step": h, "end": 3 * L / C, "alpha": 0.0, **(time or {})},
            "output": {"every": 10**6}}


def blocks(contact: dict, time: dict | None = None, material: dict | None = None) -> dict:
    """Two blocks, the upper pushed 0.1 mm into the lower (test_architecture's)."""
    def blk(name, z0, cells, fixed):
        return {"name": name, "mesh": {"builtin": "box", "size": [0.01, 0.01, 0.005], "cells": cells, "origin": [0, 0, z0]},
                "material": material or {"model": "isotropic", "E": 1e4, "nu": 0.3, "rho": 1000.0}, "fixed": fixed}
    return {"bodies": [blk("low", -0.005, [3, 3, 2], ["zmin"]),
                       blk("up", 2e-5, [4, 4, 2], [{"surface": "zmax", "displacement": [0, 0, -1e-4]}])],
            "contact": {"surface": {"low": "zmax", "up": "zmin"}, "method": "lagrange", **contact},
            "time": {"mode": "static", **(time or {})}, "output": {"energy": False}}


def contact_of(method: str, **roles) -> dict:
    """The [contact] table of ``method``: its required keys, a detector it may use."""
    cls = METHODS[method]
    c = {"method": method, **required(cls.Params)}
    allowed = cls.detections
    if "detection" not in roles and allowed is not None:
        c["detection"] = sorted(allowed)[0]
    c.update(roles)
    if c.get("detection") is not None:
        c.update(required(DETECTORS[c["detection"]].Params) if params_of(DETECTORS[c["detection"]]) else {})
    return c


def run(scene: dict):
    return vfrs.run(vfrs.Scene.from_dict(scene), progress=False)


def assert_impulse_is_momentum(r, where: str) -> None:
    """The recorded contact force, summed over the steps times h, is each bar's momentum change
    (measured from the velocities), and the bars have parted."""
    h, hs, p = r.scene.time.step, r.history, r.problem
    Mv = (p.M @ r.v.ravel()).reshape(-1, 3)
    for b in p.bodies:
        dp = Mv[b.nodes, 0].sum() - (MASS * V0 if b.name == "a" else 0.0)
        impulse = h * hs[f"contact_force.{b.name}"][:, 0].sum()
        assert abs(dp) > 0.5 * MASS * V0, f"{where}: bar {b.name} gained too little momentum ({dp:g})"
        assert impulse / dp == pytest.approx(1.0, abs=1e-9), f"{where}: bar {b.name} impulse {impulse:g}, dp {dp:g}"
    assert not np.abs(hs["contact_force.a"][-1]).any(), f"{where}: the bars are still in contact at the end"


def assert_contract(contact: dict, where: str, **scene) -> None:
    r = run(bars(contact, **scene))
    if METHODS[contact["method"]].applies_forces:
        assert_impulse_is_momentum(r, where)
    else:
        assert r.history["contact_pairs"].max() > 0, f"{where}: no pairs found"
        assert not np.abs(r.history["contact_force.a"]).any(), f"{where}: a method without forces recorded a force"


def a_method_for(solver: str | None = None) -> str:
    """The first registered method that applies forces (and that ``solver`` can solve)."""
    for name in sorted(METHODS):
        cls = METHODS[name]
        if cls.applies_forces and (solver is None or cls.uses <= SOLVERS[solver].provides):
            return name
    pytest.fail(f"no registered method that applies forces for solver {solver!r}")


# ------------------------------------------------------------------------------------------
# The contract of each role
# ------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name", params(METHODS))
def test_contact_method(name):
    check_params_contract(METHODS[name])
    assert_contract(contact_of(name), f"method {name}")


@pytest.mark.parametrize("name", params(DETECTORS))
def test_detector(name):
    check_params_contract(DETECTORS[name])
    method = next((m for m in sorted(METHODS) if METHODS[m].applies_forces
                   and (METHODS[m].detections is None or name in METHODS[m].detections)), None)
    assert method is not None, f"no method uses detector {name}"
    assert_contract(contact_of(method, detection=name), f"detector {name} with method {method}")


@pytest.mark.parametrize("name", params(SOLVERS))
def test_contact_solver(name):
    check_params_contract(SOLVERS[name])
    method = a_method_for(name)
    assert_contract(contact_of(method, solver=name), f"solver {name} with method {method}")


@pytest.mark.parametrize("name", params(SCHEMES))
def test_scheme(name):
    check_params_contract(SCHEMES[name])
    method = a_method_for()
    assert_contract(contact_of(method, scheme=name), f"scheme {name} with method {method}")


def _mode(cls) -> str:
    return getattr(cls, "mode", None) or cls.name


def _material_for(kinematics: str) -> dict:
    """A scene material of ``kinematics`` ("linear" or "finite"): the first registered one."""
    for name in sorted(MATERIALS):
        cls = MATERIALS[name]
        if getattr(cls, "kinematics", "linear") == kinematics:
            fixed = {k: v for k, v in (("E", E), ("nu", 0.0)) if k in param_keys(cls)}  # the bars' own
            return {"model": name, **required(cls, fixed), "rho": RHO}
    pytest.fail(f"no registered material of kinematics {kinematics!r}")


@pytest.mark.parametrize("name", params(INTEGRATORS))
def test_integrator(name):
    cls = INTEGRATORS[name]
    check_params_contract(cls, given={"step": L / C / N, "end": 3 * L / C})
    material = _material_for(getattr(cls, "kinematics", "linear"))
    where = f"integrator {name} ([time] mode = {_mode(cls)!r}, material {material['model']})"
    if cls.dynamic:
        r = run(bars(contact_of("lagrange"), time={"mode": _mode(cls)}, material=material))
        assert_impulse_is_momentum(r, where)
    else:
        r = run(blocks({}, time={"mode": _mode(cls)}, material=material))
        up, low = r.history["contact_force.up"][-1], r.history["contact_force.low"][-1]
        assert up[2] > 0, f"{where}: no contact force ({up})"
        np.testing.assert_allclose(up, -low, rtol=0, atol=1e-9 * abs(up[2]), err_msg=where)


@pytest.mark.parametrize("name", params(MATERIALS))
def test_material(name):
    mat = check_params_contract(MATERIALS[name])
    D = np.asarray(mat.elasticity())
    assert D.shape == (6, 6)
    np.testing.assert_allclose(D, D.T, rtol=0, atol=1e-12 * np.abs(D).max(), err_msg=f"material {name}: D not symmetric")
    assert np.linalg.eigvalsh(D).min() > 0, f"material {name}: D is not positive definite"


def _rotation(f) -> tuple:
    """A triangle's nodes rotated to start at the smallest (its orientation kept)."""
    k = f.index(min(f))
    return tuple(f[k:] + f[:k])


@pytest.mark.parametrize("name", params(GENERATORS))
def test_mesh_generator(name):
    p = check_params_contract(GENERATORS[name])
    mesh = p.build()
    assert mesh.n_tets > 0 and (mesh.signed_volumes() > 0).all(), f"generator {name}: a tetrahedron is inverted"
    assert mesh.surfaces, f"generator {name}: no named surfaces"
    # every boundary face as the element orders it (outward), by its sorted nodes
    outward = {tuple(sorted(f)): _rotation(f) for f in mesh.boundary_faces().tolist()}
    for sname, tri in mesh.surfaces.items():
        assert len(tri), f"generator {name}: surface {sname} is empty"
        faces = [tuple(sorted(f)) for f in tri.tolist()]
        assert all(f in outward for f in faces), f"generator {name}: surface {sname} is not on the boundary"
        assert all(outward[f] == _rotation(t) for f, t in zip(faces, tri.tolist())), (
            f"generator {name}: surface {sname} has triangles facing inwards")
    for rname, tets in mesh.regions.items():
        tets = np.asarray(tets)
        assert tets.size == 0 or (tets.min() >= 0 and tets.max() < mesh.n_tets), f"generator {name}: region {rname}"


# -- effects and summary measures: read from EFFECTS and MEASURES ------------------------------

#: The scene that names every registered effect: the main job with a vocal tract ([flow],
#: [contact], [acoustics]) on the coarse folds, 30 ms (about 6 s): long enough for the glottal
#: cycles every per-cycle measure needs when the window is the whole run (``start = 0``).
ALL_EFFECTS_SCENE, ALL_EFFECTS_END = Path(__file__).parents[1] / "examples" / "m5_vowel_a.toml", 0.03


@pytest.fixture(scope="module")
def all_effects():
    """(the scene, the result, the effect instances after the run, the run's RunView over the
    whole run)."""
    d = read_toml(ALL_EFFECTS_SCENE)
    for body in d["bodies"]:
        body["mesh"]["resolution"] = "coarse"
    d["time"]["end"] = ALL_EFFECTS_END
    scene = vfrs.Scene.from_dict(d, source=str(ALL_EFFECTS_SCENE), base_dir=str(ALL_EFFECTS_SCENE.parent))
    assert set(scene.effects) == set(EFFECTS), (
        f"effects {sorted(set(EFFECTS) - set(scene.effects))} are registered but not in {ALL_EFFECTS_SCENE.name}: "
        "give this contract a scene that names every effect")
    effects = [EFFECTS[name](params) for name, params in scene.effects.items()]
    res = vfrs.run(scene, progress=False, effects=effects)
    return scene, res, {e.name: e for e in effects}, RunView(res, start=0.0)


def _names(sections: dict) -> dict:
    return {section: sorted(items) for section, items in sections.items() if items}


def assert_quantities(sections: dict, who: str) -> None:
    """{section: {name: Quantity}} with a unit the summary knows how to show, and what it is."""
    for section, items in sections.items():
        for key, q in items.items():
            assert isinstance(q, Quantity), f"{who}: {section}.{key} is a {type(q).__name__}, not a Quantity"
            assert isinstance(q.unit, str) and q.unit and q.what, f"{who}: {section}.{key} without unit or what"
            assert q.unit in DISPLAY or q.unit in ("dB",), f"{who}: {section}.{key}: unit {q.unit!r} is no SI unit"


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_effect_summary(name, all_effects):
    """An effect declares the summary names it gives (``summary_names(scene)``), gives exactly
    those on a run that has what they need, each a Quantity with a unit."""
    scene, _, _, view = all_effects
    given = EFFECTS[name].measures(view)
    assert given, f"effect {name}: no summary section on a run that names it"
    assert_quantities(given, f"effect {name}")
    assert _names(given) == _names(EFFECTS[name].summary_names(scene)), f"effect {name}: declared != given"


@pytest.mark.parametrize("name", sorted(MEASURES))
def test_measure_summary(name, all_effects):
    """The same for a registered summary measure."""
    scene, _, _, view = all_effects
    given = MEASURES[name].measures(view)
    assert given, f"measure {name}: nothing on a run of the main job"
    assert_quantities(given, f"measure {name}")
    assert _names(given) == _names(MEASURES[name].summary_names(scene)), f"measure {name}: declared != given"


def test_the_summary_names_are_the_summarys(all_effects):
    """:func:`vfrs.summary.summary_names` (what a sweep's derived columns may read, known before
    any run) is every name of the summary of a run of that scene."""
    scene, res, _, _ = all_effects
    have = {section: sorted(items) for section, items in summarize(res, start=0.0).to_dict().items()
            if isinstance(items, dict)}
    assert have == _names(summary_names(scene))


def _equal(a, b) -> bool:
    if isinstance(a, Appended) or isinstance(b, Appended):
        return _equal(items_of(a), items_of(b))
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)
    return a == b or (a != a and b != b)


class _Rows:
    """Takes the place of a checkpoint's journal: the items of each Appended list by path."""

    def __init__(self):
        self.items: dict = {}

    def append(self, path, items, epoch) -> None:
        self.items[path] = items.copy() if isinstance(items, np.ndarray) else list(items)


@pytest.mark.parametrize("name", sorted(EFFECTS))
def test_effect_state_round_trips(name, all_effects):
    """An effect's ``state()`` after a run is what a checkpoint stores (no pickle: a
    CheckpointError names what is not), and ``restore`` of the stored state gives the same
    state back."""
    _, _, effects, _ = all_effects
    e = effects[name]
    state = e.state()
    arrays, rows = {}, _Rows()
    stored = unflatten(flatten(state, name, arrays, rows), arrays, rows.items.__getitem__)
    e.restore(stored)
    assert _equal(e.state(), state), f"effect {name}: restore(state()) changed the state"
