"""Dynamic contact on quadratic (ten-node) bodies (issue 47, item 3): the conservation claims of
tests/test_contact_conservation.py and tests/test_contact_dynamic.py, at order 2, for every
method that applies forces, on matching and non-matching structured meshes and on the
unstructured Gmsh spheres, with the default scheme (mass redistribution) and the stabilized
one; and a checkpointed P2 run that resumes bit for bit.

The bars: the two-bar impact of test_contact_conservation (L = 0.1 m, E = 1e4 Pa, rho = 1000,
lumped mass: HRZ on P2) with 20 P2 cells along each bar (the nodes of 40 P1 cells) at
h = L / (40 c). Measured with mass redistribution, every method (Lagrange, penalty, Uzawa,
penalty_volume), matching and 4 x 4 against 3 x 3 end faces, alpha = 0 and -0.3: impulse /
momentum 1 to 1e-12, E_max = E0 to round-off, E_end 0.990-0.998 E0, contact duration 1.0125 to
1.0375 of 2 L / c (P1 at 40 cells: within 3 %)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import vfrs

sys.path.insert(0, str(Path(__file__).parent))
import test_contact_conservation as conservation  # noqa: E402
import test_contact_dynamic as dynamic  # noqa: E402

slow = pytest.mark.slow


def _bars(method, mesh, scheme, alpha=0.0):
    d = conservation.bars_scene(method, *conservation.MESHES[mesh], n=20, substeps=2, alpha=alpha)
    d["contact"].pop("stabilized", None)
    d["contact"]["scheme"] = scheme
    for b in d["bodies"]:
        b["order"] = 2
    r = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
    assert all(b.mesh.order == 2 for b in r.problem.bodies)
    return conservation.measure(r)


def _assert_conserved(m, duration=0.04):
    assert not m["in contact at the end"]
    for b in "ab":
        assert m[f"impulse/dp {b}"] == pytest.approx(1.0, abs=1e-9)
    assert m["E_max"] <= 1 + 1e-6
    assert m["E_end"] >= 0.95
    assert abs(m["duration"] - 1) < duration


def _mr_params():
    out = []
    for method in conservation.METHODS:
        for mesh in ("matching", "4x4-3x3"):
            for alpha in (0.0, -0.3):
                quick = alpha == 0.0 or (method, mesh) == ("lagrange", "4x4-3x3")
                out.append(pytest.param(method, mesh, alpha, marks=[] if quick else [slow],
                                        id=f"{method}-{mesh}-a{alpha}"))
    return out


@pytest.mark.parametrize("method,mesh,alpha", _mr_params())
def test_mass_redistribution_conserves_on_quadratic_bars(method, mesh, alpha):
    """Mass redistribution (the default) on P2 bars: impulse = momentum (1e-9), the energy never
    above E0 (1 + 1e-6), at least 0.95 E0 at the end, the contact lasts 2 L / c within 4 %
    (measured 1.0125-1.0375: the step-counted duration resolves h / (2 L / c) = 1.25 %)."""
    m = _bars(method, mesh, "mass_redistribution", alpha)
    print(f"\nP2 mass_redistribution {method} {mesh} alpha={alpha}: {m}")
    _assert_conserved(m)


def _stabilized_params():
    out = []
    for method in conservation.METHODS:
        for mesh in ("matching", "4x4-3x3"):
            marks = [] if method in ("lagrange", "penalty") else [slow]
            if (method, mesh) == ("penalty", "matching"):
                marks = marks + [pytest.mark.xfail(strict=True, reason=(
                    "the stabilized scheme with penalty on P2 bars gains energy: measured E_max 1.068 E0 "
                    "(matching end faces, alpha = 0, h = L / 40c; 4.2 E0 on 4x4 against 3x3 at h = L / 20c), "
                    "where mass redistribution, the default, keeps E0 to round-off"))]
            out.append(pytest.param(method, mesh, marks=marks, id=f"{method}-{mesh}"))
    return out


@pytest.mark.parametrize("method,mesh", _stabilized_params())
def test_stabilized_scheme_on_quadratic_bars(method, mesh):
    """The stabilized scheme on P2 bars, alpha = 0: the same claims. Measured: Lagrange, Uzawa,
    penalty_volume and penalty on 4x4 against 3x3 keep E0 to round-off (E_end 0.984-0.992);
    penalty on matching faces does not (the strict xfail)."""
    m = _bars(method, mesh, "stabilized")
    print(f"\nP2 stabilized {method} {mesh}: {m}")
    _assert_conserved(m, duration=0.06)


def test_two_unstructured_quadratic_spheres():
    """The two non-matching unstructured Gmsh balls of test_contact_dynamic colliding, at order 2
    (the file meshes elevated with straight mid-edge nodes: the facets stay flat), Lagrange on
    the interface mesh, mass redistribution, alpha = 0, h = t_c / 50: every LCP settles, the
    balls touch and part, action = reaction (1e-10), the energy never above E0 (1 + 1e-6), impulse
    = momentum (1e-9 of a ball's momentum). Measured: E_max / E0 - 1 = 5.8e-14, momentum 4.2e-13,
    balance 1.2e-15, peak force 1.050 of Hertz's for two balls (P1: 1.138-1.151), 58 active pairs
    at most."""
    original = vfrs.Scene.from_dict

    def at_order_two(d, *a, **k):
        for b in d["bodies"]:
            b["order"] = 2
        return original(d, *a, **k)

    vfrs.Scene.from_dict = at_order_two  # type: ignore[method-assign]
    try:
        m = dynamic.two_spheres_run.__wrapped__("lagrange", "interface_mesh", 0.0, 50)
    finally:
        vfrs.Scene.from_dict = original  # type: ignore[method-assign]
    print(f"\nP2 two spheres: {m}")
    assert m["converged"] and m["max_active"] > 0 and m["parted"]
    assert m["balance"] < 1e-10 and m["E_max"] <= 1e-6 and m["momentum"] < 1e-9
    assert 1.0 < m["peak"] < 1.1


def test_quadratic_contact_run_stops_and_resumes_bit_for_bit(tmp_path):
    """Two P2 blocks pressed together dynamically (the blocks of test_architecture, augmented
    Lagrange on the BVH): SIGTERM from inside the run at step 17, then resume: the same history
    and fields as one run."""
    from test_architecture import blocks
    from test_checkpoint import _Terminate

    from vfrs.checkpoint import RunStopped
    from vfrs.effects import EFFECTS
    from vfrs.run import resume

    d = blocks({"method": "augmented_lagrange", "kappa": 1e9, "detection": "bvh"})
    for b in d["bodies"]:
        b["order"] = 2
    d["time"] = {"mode": "dynamic", "step": 2e-3, "end": 0.05}
    d["output"] = {"energy": True, "every": 5}
    scene = vfrs.Scene.from_dict(d)
    ref = vfrs.run(scene, out=tmp_path / "ref", progress=False)
    assert ref.history["active_pairs"].max() > 0
    out = tmp_path / "run"
    effects = [EFFECTS[n](p) for n, p in scene.effects.items()] + [_Terminate(17)]
    with pytest.raises(RunStopped):
        vfrs.run(scene, out=out, progress=False, effects=effects, checkpoint_seconds=None)
    res = resume(out, progress=False)
    for k, v in ref.history.items():
        assert np.array_equal(v, res.history[k], equal_nan=True), k
    for k, v in ref.fields.items():
        assert np.array_equal(v, res.fields[k]), k
