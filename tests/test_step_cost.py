"""What a time step does besides its solves, checked by structure and by bit identity (the
speed itself is measured in benchmarks/bench_m5.py, never asserted):

- the flow's forces from the wetted nodes only are the full model's, bit for bit;
- a step without contact pairs builds no sparse matrix, a step with pairs a bounded number;
- a step solves once with K_eff, pairs or not, and never with M.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

import vfrs
from vfrs.dynamics import build_problem

ROOT = Path(__file__).resolve().parent.parent
SCENE = ROOT / "examples" / "m5_collision.toml"


def _scene(end=0.003, contact=True):
    d = vfrs.Scene.load(SCENE).to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = "coarse"
    d["time"]["end"] = end
    if not contact:
        d.pop("contact")
    return vfrs.Scene.from_dict(d)


def _same_bits(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def test_flow_forces_from_the_wetted_nodes_are_the_full_models():
    from vfrs.effects import SetupContext
    from vfrs.flow import GlottalFlow

    scene = _scene(contact=False)
    p = build_problem(scene)
    flow = GlottalFlow(scene.effects["flow"])
    flow.setup(SetupContext(p, None))
    state = vfrs.dynamics.State(p)
    rng = np.random.default_rng(5)
    state.u[:] = 2e-5 * rng.standard_normal(p.n_dofs)
    state.t_next = 1e-3
    f = flow.forces(state)
    x = state.points
    fr, fl, _ = flow.model.forces(x[flow.right.nodes], x[flow.left.nodes])
    full = np.zeros(p.n_dofs)
    scale = flow._scale
    full[flow.right.dofs] = scale * fr.ravel()
    full[flow.left.dofs] = scale * fl.ravel()
    assert np.any(f) and _same_bits(f, full)


def test_flow_pressure_forces_in_rust_are_the_numpy_reference_bit_for_bit():
    """The flow's pressure load runs in Rust (vfrs._core.fem.PressureLoad): the same numbers as
    the numpy reference (vfrs.flow.consistent_pressure_forces) on both folds' wetted
    surfaces, displaced, under the model's own pressures and random ones; a closed surface
    under a uniform pressure has no net force (the reference's physics, checked on it)."""
    from vfrs.effects import SetupContext
    from vfrs.flow import GlottalFlow, consistent_pressure_forces

    scene = _scene(contact=False)
    p = build_problem(scene)
    flow = GlottalFlow(scene.effects["flow"])
    flow.setup(SetupContext(p, None))
    rng = np.random.default_rng(9)
    x = p.points + 2e-5 * rng.standard_normal(p.points.shape)
    st = flow.model.state(x[flow.right.nodes], x[flow.left.nodes])
    for fold, nodes in zip(flow.model.folds, (flow.right.nodes, flow.left.nodes)):
        xf = x[nodes]
        for pressure in (np.interp(xf[:, 1], st.y, st.pressure), 800.0 * rng.random(len(xf))):
            p_nodes = np.zeros(len(xf))
            p_nodes[fold.nodes] = pressure[fold.nodes]
            ref = consistent_pressure_forces(xf, fold.tri, p_nodes)
            assert np.any(ref) and _same_bits(fold.pressure_forces(xf, p_nodes), ref)
    mesh = p.bodies[0].mesh
    closed = mesh.boundary_faces()
    f = flow.model.folds[0].__class__(closed, np.arange(len(mesh.points)), None, 1.0).pressure_forces(
        mesh.points, np.full(len(mesh.points), 500.0))
    assert np.abs(f.sum(axis=0)).max() <= 1e-12 * np.abs(f).sum()


def _effects_with_tick(scene, step: dict) -> list:
    """The scene's effects and one that writes the step being taken into ``step["k"]``."""
    from vfrs.effects import EFFECTS, Effect

    class Tick(Effect):
        name = "tick"

        def forces(self, state):
            step["k"] = state.step
            return None

    return [EFFECTS[n](params) for n, params in scene.effects.items()] + [Tick(None)]


def _sparse_matrices_per_step(scene, monkeypatch) -> tuple:
    """(matrices built in each step with contact pairs, in each step without)."""
    import scipy.sparse._compressed as compressed

    built: dict = {}
    step = {"k": None}
    init = compressed._cs_matrix.__init__

    def counting(self, *args, **kwargs):
        built[step["k"]] = built.get(step["k"], 0) + 1
        init(self, *args, **kwargs)

    monkeypatch.setattr(compressed._cs_matrix, "__init__", counting)
    h = vfrs.run(scene, progress=False, effects=_effects_with_tick(scene, step)).history
    pairs = np.asarray(h["contact_pairs"]) if "contact_pairs" in h else np.zeros(len(h["t"]))
    steps = range(1, len(h["t"]))
    return ([built.get(k, 0) for k in steps if pairs[k] > 0], [built.get(k, 0) for k in steps if pairs[k] == 0])


def test_steps_build_no_sparse_matrix_without_contact_pairs(monkeypatch):
    warnings.simplefilter("ignore")
    with_pairs, without = _sparse_matrices_per_step(_scene(end=0.004), monkeypatch)
    assert with_pairs and without
    # Without pairs: nothing, except where the predictor found pairs the correction did not
    # keep (its constraint matrix and Delassus operator).
    assert np.median(without) == 0 and max(without) <= 8
    # With pairs: per detection round the constraint matrix, its columns on the compliance
    # and its transpose, and the same for the predictor (12 on average when measured; 20
    # before the CSR inputs were reused).
    assert max(with_pairs) <= 20 and np.mean(with_pairs) <= 14
    _, without = _sparse_matrices_per_step(_scene(end=0.002, contact=False), monkeypatch)
    assert max(without) == 0


def test_a_step_solves_once_with_k_eff_and_never_with_m(monkeypatch):
    """One forward/back substitution with K_eff per step, pairs or not: the correction and the
    stabilized predictor's shifts are products with compliance columns (solved only for DOFs
    new to the contact zone, and then for their own body's block only), never a solve with M
    after the initial acceleration."""
    import vfrs.linalg as linalg

    warnings.simplefilter("ignore")
    scene = _scene(end=0.004)
    calls: list = []
    step = {"k": 0}
    solve = linalg.BlockCholesky.solve

    def counting(self, b):
        calls.append((step["k"], self.n, np.ndim(b)))
        return solve(self, b)

    monkeypatch.setattr(linalg.BlockCholesky, "solve", counting)
    res = vfrs.run(scene, progress=False, effects=_effects_with_tick(scene, step))
    h = res.history
    pairs = np.asarray(h["contact_pairs"])
    steps = range(1, len(h["t"]))
    assert sum(pairs[k] > 0 for k in steps) >= 5  # the folds do collide in these 4 ms
    per_step = {k: [c for c in calls if c[0] == k] for k in steps}
    # Every call in a step is the step's own solve: one right-hand side, through the
    # block-concurrent factor of K_eff (the compliance columns go to a block's own factor).
    assert all(len(c) == 1 and c[0][2] == 1 for c in per_step.values()), {k: len(c) for k, c in per_step.items()}
    # The mass factor solved the initial acceleration only (before step 1).
    assert len([c for c in calls if c[0] == 0]) <= 1
    assert np.asarray(h["compliance_solves"])[-1] > 0


@pytest.mark.parametrize("scheme,compliances", [("mass_redistribution", ["of K_eff "]),
                                                 ("stabilized", ["of K_eff ", "of M "])])
def test_a_capped_compliance_departs_from_the_products_at_round_off_only(scheme, compliances):
    """[contact] column_memory caps the columns kept over the bodies: a step loading a DOF
    whose column is not stored solves instead of a product. The run warns once per compliance
    (K_eff's; the stabilized scheme's mass compliance too) and its contact force first differs
    from the uncapped run's at round-off (contact then amplifies it, as any change of summation
    order: docs/performance.md)."""
    from vfrs.errors import VfrsWarning, SceneError

    base = _scene(end=0.004)
    d = base.to_dict()
    d["contact"]["scheme"] = scheme
    base = vfrs.Scene.from_dict(d)
    d["contact"]["column_memory"] = 0.05  # MiB: a few columns per block
    with pytest.warns(VfrsWarning, match="column_memory") as caught:
        capped = vfrs.run(vfrs.Scene.from_dict(d), progress=False)
    labels = sorted({m for w in caught for m in ("of M ", "of K_eff ") if m in str(w.message)})
    assert labels == compliances
    ref = vfrs.run(base, progress=False)
    a = np.linalg.norm(np.asarray(ref.history["contact_force.right"]), axis=1)
    b = np.linalg.norm(np.asarray(capped.history["contact_force.right"]), axis=1)
    differ = np.flatnonzero(a != b)
    assert a.max() > 0 and differ.size, "the cap never engaged: make it smaller"
    first = differ[0]
    assert np.array_equal(a[:first], b[:first])
    assert abs(a[first] - b[first]) <= 1e-12 * a.max(), (first, abs(a[first] - b[first]) / a.max())
    d["contact"]["column_memory"] = -1.0
    with pytest.raises(SceneError, match="column_memory"):
        vfrs.Scene.from_dict(d)


def test_mass_products_skip_its_stored_zeros_with_the_same_bits():
    """The HHT right-hand side and the kinetic energy multiply the mass without the zeros it
    stores in the stiffness pattern (two thirds of its entries on a P1 mesh): a third of the
    reads, the same numbers bit for bit."""
    from vfrs.linalg import for_products

    p = build_problem(_scene(contact=False))
    M = p.M.tocsr()
    lean = for_products(M)
    assert lean.nnz * 3 == M.nnz and (lean.data != 0).all()
    rng = np.random.default_rng(11)
    for x in (rng.standard_normal(M.shape[0]), np.where(rng.random(M.shape[0]) < 0.5, 0.0, -1e-300),
              np.r_[np.zeros(M.shape[0] // 2), rng.standard_normal(M.shape[0] - M.shape[0] // 2)]):
        assert _same_bits(lean @ x, M @ x)


def test_node_blocked_products_have_scipys_bits():
    """The right-hand side's M x + K y and the energies' K u, M v run on the node-blocked
    matrices in Rust (the stiffness in 3 x 3 blocks, the mass as m (x) I_3): the same numbers
    bit for bit as scipy's CSR products, on the M5 matrices (all DOFs and free DOFs) and
    vectors with zeros and signed zeros; matrices of another kind go to scipy."""
    from vfrs.linalg import Product, for_products, sum_of_products

    p = build_problem(_scene(contact=False))
    free = p.dofmap.free
    rng = np.random.default_rng(5)
    for K, M in ((p.K.tocsr(), p.M.tocsr()), (p.K[free][:, free].tocsr(), p.M[free][:, free].tocsr())):
        M = for_products(M)
        PK, PM = Product(K), Product(M)
        assert PK.blocked and PM.blocked
        n = K.shape[0]
        for x, y in ((rng.standard_normal(n), rng.standard_normal(n) * 1e-7),
                     (np.where(rng.random(n) < 0.5, -0.0, 1e-300), np.r_[np.zeros(n // 2), rng.standard_normal(n - n // 2)])):
            assert _same_bits(PK @ x, K @ x) and _same_bits(PM @ y, M @ y)
            r = M @ y
            r += K @ x
            assert _same_bits(sum_of_products([(PM, y), (PK, x)]), r)
    # A matrix that is not node-blocked (here: one entry dropped from a block) is scipy's.
    K = p.K.tocsr().tolil()
    K[0, 1] = 0.0
    K = K.tocsr()
    K.eliminate_zeros()
    P = Product(K)
    x = rng.standard_normal(K.shape[0])
    assert not P.blocked and _same_bits(P @ x, K @ x)
    X = rng.standard_normal((K.shape[0], 2))  # not a vector: scipy's too
    assert _same_bits(Product(p.K) @ X, p.K.tocsr() @ X)


def test_the_integrator_and_the_record_use_the_blocked_products(monkeypatch):
    """A linear M5 run computes its right-hand side, energies and reactions in the
    node-blocked products (no CSR product with the stiffness or the mass per step: they are
    counted here)."""
    from vfrs import _core

    calls = []
    real = _core.linalg.sum_of_products

    def counted(terms, out):
        calls.append(len(terms))
        return real(terms, out)

    monkeypatch.setattr(_core.linalg, "sum_of_products", counted)
    res = vfrs.run(_scene(end=0.001, contact=False), progress=False)
    steps = len(res.history["t"]) - 1
    # per step: the right-hand side (two terms); per record (the steps' and the initial
    # state's): the elastic and the kinetic energy, and the reactions' M a and K v on the fixed
    # rows (their K u is the energy's).
    assert calls.count(2) == steps and calls.count(1) == 4 * (steps + 1)
