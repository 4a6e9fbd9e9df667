"""Fuzzing (issue 15): scenes perturbed from valid templates, small meshes and matrices.

The invariant everywhere: a :class:`vfrs.VfrsError`, or a finite result; never another
exception, a NaN or a crash. Bounded: a fixed number of examples per strategy (``EXAMPLES``),
no deadline, derandomized (the same examples every run, so the suite stays deterministic);
``VFRS_FUZZ_EXAMPLES=N`` runs more (e.g. to hunt). The runs a perturbed scene makes are
limited to small meshes and few steps, and ``VFRS_MEMORY_LIMIT`` is set to 2 GB so that the
memory check is exercised, not the machine. ``pytest tests/test_fuzz.py
--hypothesis-show-statistics`` prints how many examples each strategy ran.
"""

from __future__ import annotations

import copy
import glob
import os
import warnings

import numpy as np
import pytest
import scipy.sparse as sp

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import vfrs  # noqa: E402
from vfrs.errors import PlausibilityWarning, VfrsError  # noqa: E402

EXAMPLES = int(os.environ.get("VFRS_FUZZ_EXAMPLES", "0")) or None
FUZZ = settings(deadline=None, derandomize=EXAMPLES is None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much])


def examples(n: int):
    return settings(FUZZ, max_examples=EXAMPLES or n)


@pytest.fixture(autouse=True)
def _memory_limit(monkeypatch):
    monkeypatch.setenv("VFRS_MEMORY_LIMIT", "2G")


HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


# ---- scene templates -------------------------------------------------------------------
def _block(name, origin, surface_fixed="xmin"):
    return {"name": name, "mesh": {"builtin": "box", "size": [0.02, 0.01, 0.01], "cells": [2, 1, 1], "origin": origin},
            "material": {"model": "isotropic", "E": 1e5, "nu": 0.3, "rho": 1000.0}, "fixed": [surface_fixed]}


TEMPLATES = [
    {"bodies": [{**_block("beam", [0.0, 0.0, 0.0]),
                 "loads": [{"type": "pressure", "surface": "xmax", "value": 100.0, "ramp": 1e-3}],
                 "damping": {"a0": 1.0, "a1": 1e-5}, "velocity": [0.0, 0.0, 0.01]}],
     "time": {"mode": "dynamic", "step": 1e-4, "end": 1e-3, "alpha": -0.1},
     "output": {"every": 2, "probes": [[0.02, 0.0, 0.0]], "fields": ["displacement"]}},
    {"bodies": [{**_block("beam", [0.0, 0.0, 0.0]),
                 "loads": [{"type": "traction", "axis": "x", "above": 0.02, "value": [10.0, 0.0, 0.0]}]}],
     "gravity": [0.0, 0.0, -9.81], "time": {"mode": "static", "load_steps": 2}},
    {"bodies": [_block("a", [0.0, 0.0, 0.0]), {**_block("b", [0.0, 0.0101, 0.0], "xmax"), "velocity": [0.0, -0.5, 0.0]}],
     "contact": {"method": "penalty", "kappa": 1e9, "surface": {"a": "ymax", "b": "ymin"}, "pairs": [["a", "b"]]},
     "time": {"mode": "dynamic", "step": 1e-4, "end": 5e-4}},
    {"bodies": [{**_block("a", [0.0, 0.0, 0.001]), "fixed": [], "velocity": [0.0, 0.0, -1.0]}],
     "obstacles": [{"type": "plane", "point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 1.0]}],
     "contact": {"method": "lagrange", "detection": "bvh", "surface": "zmin"},
     "time": {"mode": "dynamic", "step": 1e-4, "end": 5e-4}},
    {"bodies": [{"name": "ball", "mesh": {"builtin": "sphere", "radius": 0.01, "cells": 2},
                 "material": {"model": "vocal_fold"}, "fixed": [{"axis": "z", "below": 0.0, "components": ["z"]}],
                 "loads": [{"type": "pressure", "surface": "surface", "value": 10.0}]}],
     "time": {"mode": "static"}},
]
# The examples (m5 meshes): loaded only (too big to run in a fuzz loop).
EXAMPLE_FILES = sorted(glob.glob(os.path.join(HERE, "examples", "*.toml")))


def _example(path):
    from vfrs.scene import read_toml

    return read_toml(path)


WORDS = ["medial", "xmin", "xmax", "ymax", "surface", "static", "dynamic", "penalty", "lagrange",
         "augmented_lagrange", "bvh", "interface_mesh", "box", "sphere", "m5", "isotropic", "vocal_fold",
         "pressure", "traction", "x", "z", "a", "b", "beam", "", "../x", "coarse"]
values = st.one_of(
    st.booleans(),
    st.integers(-3, 60),
    st.integers(-2**70, 2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -1.0, 1e-300, 1e300, 1e308, float("nan"), float("inf"), 0.5, 4.5, 2**63, -0.0]),
    st.sampled_from(WORDS),
    st.text(max_size=6),
    st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), max_size=4),
    st.lists(st.integers(-2, 40), min_size=3, max_size=3),
    st.lists(st.sampled_from(WORDS), max_size=3),
    st.dictionaries(st.sampled_from(WORDS), st.integers(0, 3), max_size=2),
    st.just([]),
    st.just({}),
    st.none(),
)


def _paths(node, prefix=()):
    """Every (container, key) of a nested dict/list."""
    out = []
    if isinstance(node, dict):
        for k, v in node.items():
            out.append((node, k))
            out.extend(_paths(v, prefix + (k,)))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            out.append((node, i))
            out.extend(_paths(v, prefix + (i,)))
    return out


def _mutate(data, draw, scene):
    paths = _paths(scene)
    if not paths:
        return
    container, key = paths[draw(st.integers(0, len(paths) - 1))]
    kind = draw(st.sampled_from(["replace", "replace", "scale", "delete", "rename", "add", "wrap"]))
    if kind == "replace":
        container[key] = draw(values)
    elif kind == "scale":
        v = container[key]
        f = draw(st.sampled_from([0.0, -1.0, 1e-300, 1e300, 0.5, 2.0, 1e6, 1e-6, 3.0]))
        if isinstance(v, bool):
            container[key] = not v
        elif isinstance(v, int):
            container[key] = int(v * f) if abs(v * f) < 2**80 else 2**80
        elif isinstance(v, float):
            container[key] = v * f
        elif isinstance(v, list) and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
            container[key] = [type(x)(x * f) if abs(x * f) < 1e300 else x * f for x in v]
    elif kind == "delete":
        del container[key]
    elif kind == "rename" and isinstance(container, dict):
        v = container.pop(key)
        container[str(key)[:-1] + draw(st.sampled_from(["", "s", "_", "x"]))] = v
    elif kind == "add" and isinstance(container, dict):
        container[draw(st.sampled_from(WORDS + ["kappa", "cells", "path", "ramp"]))] = draw(values)
    elif kind == "wrap":
        container[key] = [container[key]]


def _finite_result(res):
    assert np.all(np.isfinite(res.u)), "NaN/inf displacement"
    assert np.all(np.isfinite(res.v)), "NaN/inf velocity"
    for k, v in res.history.items():
        a = np.asarray(v)
        # NaN by design, documented: the position of the peak pressure when nothing is loaded
        if a.dtype.kind == "f" and not k.endswith("_position"):
            assert np.all(np.isfinite(a)), f"NaN/inf in history {k!r}"


def _load_and_maybe_run(data, run: bool):
    try:
        with warnings.catch_warnings():
            # a mutated vocal-fold scene with a length or pressure far outside the physiological
            # range warns of a unit slip: an answer, not a failure (strict scenes raise instead)
            warnings.simplefilter("ignore", PlausibilityWarning)
            scene = vfrs.Scene.from_dict(data)
    except VfrsError:
        return "refused at load"
    if not run:
        return "loaded"
    est = scene.size_estimate()
    if est["unknown"] or est["nodes"] > 3000 or est["tetrahedra"] > 12000 or scene.time.n_steps > 40:
        return "too big to run here"
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = vfrs.run(scene)
    except VfrsError:
        return "refused at run"
    _finite_result(res)
    return "ran"


@examples(500)
@given(data=st.data())
def test_fuzz_scene_templates_load_and_run(data):
    t = data.draw(st.integers(0, len(TEMPLATES) - 1), label="template")
    scene = copy.deepcopy(TEMPLATES[t])
    for _ in range(data.draw(st.integers(1, 3), label="mutations")):
        _mutate(data, data.draw, scene)
    outcome = _load_and_maybe_run(scene, run=True)
    hypothesis.event(outcome)


@examples(300)
@given(data=st.data())
def test_fuzz_example_scenes_load(data):
    path = data.draw(st.sampled_from(EXAMPLE_FILES), label="example")
    scene = _example(path)
    for _ in range(data.draw(st.integers(1, 3), label="mutations")):
        _mutate(data, data.draw, scene)
    hypothesis.event(_load_and_maybe_run(scene, run=False))


@examples(60)
@given(text=st.one_of(st.binary(max_size=200), st.text(max_size=200)))
def test_fuzz_scene_files(tmp_path_factory, text):
    f = tmp_path_factory.mktemp("scene") / "s.toml"
    if isinstance(text, bytes):
        f.write_bytes(text)
    else:
        f.write_text(text, encoding="utf-8", errors="surrogatepass") if "\ud800" not in text else f.write_bytes(b"\xff")
    try:
        vfrs.Scene.load(f)
    except VfrsError:
        pass


@examples(80)
@given(ext=st.sampled_from([".msh", ".vtu", ".vtk", ".xdmf", ".stl", ".obj", ".mesh", ".inp", ".xyz", ""]),
       content=st.one_of(st.binary(max_size=300),
                         st.sampled_from([b"$MeshFormat\n4.1 0 8\n$EndMeshFormat\n", b"# vtk DataFile Version 4.2\n",
                                          b"<VTKFile type='UnstructuredGrid'></VTKFile>", b""])))
def test_fuzz_mesh_files(tmp_path_factory, ext, content):
    f = tmp_path_factory.mktemp("mesh") / f"m{ext}"
    f.write_bytes(content)
    try:
        m = vfrs.read_mesh(f)
    except VfrsError:
        return
    assert np.all(np.isfinite(m.points)) and np.all(m.signed_volumes() > 0)


# ---- meshes ----------------------------------------------------------------------------
coords = st.floats(-1e3, 1e3, allow_nan=False, width=64)
bad_coords = st.one_of(coords, st.sampled_from([float("nan"), float("inf"), 1e300, 0.0]))


@st.composite
def meshes(draw):
    """Points and tetrahedra arrays: mostly valid (a jittered box), sometimes perturbed."""
    kind = draw(st.sampled_from(["box", "box", "random"]))
    if kind == "box":
        cells = draw(st.tuples(st.integers(1, 3), st.integers(1, 2), st.integers(1, 2)))
        m = vfrs.meshes.box((1.0, 0.5, 0.5), cells, jitter=draw(st.sampled_from([0.0, 0.2])), seed=draw(st.integers(0, 5)))
        points, tets = m.points.copy(), m.tets.copy()
        for _ in range(draw(st.integers(0, 2))):
            what = draw(st.sampled_from(["point", "index", "swap", "none"]))
            if what == "point":
                points[draw(st.integers(0, len(points) - 1)), draw(st.integers(0, 2))] = draw(bad_coords)
            elif what == "index":
                tets[draw(st.integers(0, len(tets) - 1)), draw(st.integers(0, 3))] = draw(st.integers(-3, len(points) + 3))
            elif what == "swap":
                k = draw(st.integers(0, len(tets) - 1))
                tets[k, [0, 1]] = tets[k, [1, 0]]
        return points, tets
    n = draw(st.integers(0, 8))
    points = np.array(draw(st.lists(st.tuples(bad_coords, bad_coords, bad_coords), min_size=n, max_size=n)), dtype=float).reshape(-1, 3)
    m = draw(st.integers(0, 4))
    tets = np.array(draw(st.lists(st.tuples(*[st.integers(-1, n + 1)] * 4), min_size=m, max_size=m)), dtype=np.int64).reshape(-1, 4)
    return points, tets


# nu = 0.49 is drawn on purpose: the locking warning is expected.
@pytest.mark.filterwarnings("ignore:nu = 0.49 is close to 0.5:vfrs.errors.VfrsWarning")
@examples(400)
@given(mesh=meshes(), E=st.sampled_from([1.0, 1e6]), nu=st.sampled_from([0.0, 0.3, 0.49]),
       moved=st.one_of(st.none(), st.floats(-2.0, 2.0)))
def test_fuzz_meshes_assemble(mesh, E, nu, moved):
    points, tets = mesh
    try:
        m = vfrs.Mesh(points, tets)
    except VfrsError:
        hypothesis.event("refused")
        return
    mat = vfrs.Isotropic(E=E, nu=nu, rho=1000.0)
    try:
        K = vfrs.stiffness(m, mat, points=None if moved is None else m.points * [moved, 1.0, 1.0])
    except VfrsError:
        hypothesis.event("stiffness refused")
        return
    M = vfrs.mass(m, mat)
    assert np.all(np.isfinite(K.data)) and np.all(np.isfinite(M.data))
    assert abs(K - K.T).max() <= 1e-12 * max(abs(K).max(), 1e-300)
    assert np.all(np.isfinite(m.signed_volumes())) and np.all(m.signed_volumes() > 0)
    assert m.boundary_faces().shape[1] == 3
    hypothesis.event("assembled")


@examples(60)
@given(cells=st.tuples(*[st.one_of(st.integers(-2, 4), st.sampled_from([2**63, 0]))] * 3),
       size=st.tuples(*[bad_coords] * 3), jitter=st.sampled_from([0.0, 0.29, 0.3, -0.1, float("nan")]))
def test_fuzz_box_generator(cells, size, jitter):
    try:
        m = vfrs.meshes.box(size, cells, jitter=jitter)
    except VfrsError:
        return
    assert np.all(np.isfinite(m.points)) and np.all(m.signed_volumes() > 0)


# ---- matrices --------------------------------------------------------------------------
@st.composite
def matrices(draw):
    n = draw(st.integers(1, 8))
    kind = draw(st.sampled_from(["spd", "spd", "spd_triangle", "random", "blocks"]))
    vals = st.one_of(st.floats(-10.0, 10.0), st.sampled_from([0.0, float("nan"), float("inf"), 1e-300, 1e300]))
    if kind == "random":
        dense = np.array(draw(st.lists(vals, min_size=n * n, max_size=n * n))).reshape(n, n)
        return sp.csr_matrix(dense), {}
    B = np.array(draw(st.lists(st.floats(-3.0, 3.0), min_size=n * n, max_size=n * n))).reshape(n, n)
    A = B @ B.T + draw(st.sampled_from([0.0, 1e-12, 0.1, 1.0])) * np.eye(n)
    if kind == "blocks":
        A = np.kron(np.eye(2), A)
    if draw(st.booleans()):  # a perturbed entry
        i, j = draw(st.integers(0, len(A) - 1)), draw(st.integers(0, len(A) - 1))
        A[i, j] = draw(vals)
    A = sp.csr_matrix(A)
    if kind == "spd_triangle":
        which = draw(st.sampled_from(["lower", "upper"]))
        A = sp.tril(A) if which == "lower" else sp.triu(A)
        return A.tocsr(), ({which: True} if draw(st.booleans()) else {})
    return A, {"blocks": True} if kind == "blocks" else {}


@examples(400)
@given(Akw=matrices(), b_scale=st.sampled_from([1.0, 1e-200, 1e200]))
def test_fuzz_cholesky(Akw, b_scale):
    A, kw = Akw
    b = b_scale * np.linspace(1.0, 2.0, A.shape[0])
    try:
        f = vfrs.cholesky(A, **kw)
        x = f.solve(b)
    except VfrsError:
        hypothesis.event("refused")
        return
    assert np.all(np.isfinite(x)), f"solve gave {x} for {A.toarray()} ({kw})"
    hypothesis.event("solved")


@examples(100)
@given(n=st.integers(1, 12), fixed=st.lists(st.integers(-3, 15), max_size=14))
def test_fuzz_dofmap(n, fixed):
    try:
        d = vfrs.DofMap(n, fixed)
    except VfrsError:
        return
    assert set(d.free.tolist()) | set(d.fixed.tolist()) == set(range(n))
    A = sp.identity(n, format="csr")
    assert d.reduce(A).shape == (d.n_free, d.n_free)
