"""The type stubs python/vfrs/_core/*.pyi describe the built extension vfrs._core exactly,
submodule by submodule (vfrs._core.fem, .linalg, .contact, ...).

Two checks that can fail:
- ``mypy.stubtest`` compares every name, parameter (name, kind, default), property and
  ``@final`` marker of the stub with the runtime objects (pyo3 exposes ``__text_signature__``).
- stubtest cannot see return types, so every function, method, property and constructor of the
  stub is called once on a tiny input here and its result checked against the stub's return
  annotation (tuple arity, array dtype, scalar type). A new binding without a sample call fails.
"""

from __future__ import annotations

import subprocess
import sys
import types
import typing
from pathlib import Path
from typing import Any

import numpy as np

import vfrs._core as core

ROOT = Path(__file__).resolve().parent.parent
STUBS = ROOT / "python" / "vfrs" / "_core"
#: The extension's submodules, one stub file each (rust/vfrs-py/src/lib.rs registers them).
SUBMODULES = ("contact", "errors", "fem", "hyperelastic", "lcp", "linalg")


def test_stubtest_reports_no_errors():
    r = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "vfrs._core"],  # and its submodules
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_submodules_are_the_stubs_and_import_by_name():
    """Every submodule the extension has is a stub file, and ``import vfrs._core.<name>``
    works (the extension enters its submodules in sys.modules)."""
    import importlib

    runtime = {n for n, v in vars(core).items() if isinstance(v, types.ModuleType)}
    assert runtime == set(SUBMODULES) == {p.stem for p in STUBS.glob("*.pyi")} - {"__init__"}
    for m in SUBMODULES:
        assert importlib.import_module(f"vfrs._core.{m}") is getattr(core, m)
        assert getattr(core, m).__name__ == f"vfrs._core.{m}"


def _stub_module() -> types.ModuleType:
    """Every submodule's stub executed into one namespace (their names do not clash)."""
    mod = types.ModuleType("_core_stub")
    for m in SUBMODULES:
        path = STUBS / f"{m}.pyi"
        exec(compile("from __future__ import annotations\n" + path.read_text(), str(path), "exec"), mod.__dict__)
    return mod


def _runtime(name: str) -> Any:
    """The runtime object of a stub name, from the submodule that holds it."""
    (obj,) = [getattr(getattr(core, m), name) for m in SUBMODULES if hasattr(getattr(core, m), name)]
    return obj


def _stub_callables(stub: types.ModuleType) -> dict[str, Any]:
    """Qualified name -> function of everything callable the stub declares for the runtime."""
    out: dict[str, Any] = {}
    for name, obj in vars(stub).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != stub.__name__:
            continue
        if isinstance(obj, types.FunctionType):
            out[name] = obj
        elif isinstance(obj, type) and not issubclass(obj, BaseException):
            for attr, v in vars(obj).items():
                if attr == "__new__":
                    out[f"{name}.__new__"] = v.__func__ if isinstance(v, staticmethod) else v
                elif attr.startswith("_"):
                    continue
                elif isinstance(v, property):
                    out[f"{name}.{attr}"] = v.fget
                elif isinstance(v, types.FunctionType):
                    out[f"{name}.{attr}"] = v
    return out


def _conforms(value: Any, hint: Any) -> bool:
    if hint is Any:
        return True
    if hint is None or hint is type(None):
        return value is None
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, types.UnionType):
        return any(_conforms(value, a) for a in args)
    if origin is tuple:
        return isinstance(value, tuple) and len(value) == len(args) and all(map(_conforms, value, args))
    if origin is dict:
        return isinstance(value, dict) and all(
            _conforms(k, args[0]) and _conforms(v, args[1]) for k, v in value.items()
        )
    if origin is np.ndarray:
        if not isinstance(value, np.ndarray):
            return False
        (scalar,) = typing.get_args(args[1])
        return scalar is Any or value.dtype == np.dtype(scalar)
    if hint is float:
        return type(value) is float
    if hint is int:
        return type(value) is int
    if isinstance(hint, type) and hint.__module__ == "_core_stub":
        return isinstance(value, _runtime(hint.__name__))
    return isinstance(value, hint)


def _samples() -> dict[str, Any]:
    """One call of every binding on a tiny input: qualified name -> result."""
    out: dict[str, Any] = {}
    # one positively oriented tetrahedron
    pts = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    tets = np.array([[0, 1, 2, 3]], dtype=np.int64)
    out["signed_volumes"] = core.fem.signed_volumes(pts, tets)
    out["validate_mesh"] = core.fem.validate_mesh(pts, tets)
    out["refine_tets"] = core.fem.refine_tets(pts, tets, np.array([[1, 2, 3]], dtype=np.int64))
    d = core.fem.elasticity_isotropic(1e3, 0.3)
    out["elasticity_isotropic"] = d
    out["elasticity_transversely_isotropic"] = core.fem.elasticity_transversely_isotropic(
        2e3, 40e3, 0.9, 0.0, 10e3, [0.0, 0.0, 1.0]
    )
    asm = core.fem.Assembler(4, tets)
    out["Assembler.__new__"] = asm
    out["Assembler.nnz"] = asm.nnz
    indptr, indices = asm.pattern()
    out["Assembler.pattern"] = (indptr, indices)
    rho = np.array([1070.0])
    out["Assembler.stiffness"] = asm.stiffness(pts, d[None], None)
    mass = asm.mass(pts, rho, np.zeros(1, dtype=np.int64))
    out["Assembler.mass"] = mass
    out["Assembler.lumped_mass"] = asm.lumped_mass(pts, rho)
    from vfrs.meshes.quadratic import elevate

    pts10, tets10 = elevate(pts, tets)
    qa = core.fem.QuadraticAssembler(10, tets10)
    out["QuadraticAssembler.__new__"] = qa
    out["QuadraticAssembler.nnz"] = qa.nnz
    out["QuadraticAssembler.pattern"] = qa.pattern()
    out["QuadraticAssembler.stiffness"] = qa.stiffness(pts10, d[None], None)
    out["QuadraticAssembler.mass"] = qa.mass(pts10, rho, np.zeros(1, dtype=np.int64))
    out["QuadraticAssembler.lumped_mass"] = qa.lumped_mass(pts10, rho)

    # finite strain (issue 14): the three laws on the same tet, a uniaxial stretch along z
    nh = core.hyperelastic.neo_hookean(384.6, 576.9)
    out["neo_hookean"] = nh
    out["HyperelasticMaterial.kind"] = nh.kind
    nh_e = core.hyperelastic.neo_hookean_from_young(1e3, 0.3)  # small-strain limit: the material of d
    out["neo_hookean_from_young"] = nh_e
    out["st_venant_kirchhoff"] = core.hyperelastic.st_venant_kirchhoff(d)
    fib = core.hyperelastic.fibre_reinforced(384.6, 576.9, 250.0, 2.0, [0.0, 0.0, 1.0])
    out["fibre_reinforced"] = fib
    fsa = core.hyperelastic.FiniteStrainAssembler(pts, tets)
    out["FiniteStrainAssembler.__new__"] = fsa
    out["FiniteStrainAssembler.nnz"] = fsa.nnz
    out["FiniteStrainAssembler.pattern"] = fsa.pattern()
    assert all(np.array_equal(a, b) for a, b in zip(fsa.pattern(), (indptr, indices)))
    u = np.zeros(12)
    u[2::3] = 0.2 * pts[:, 2]
    out["FiniteStrainAssembler.internal_force"] = fsa.internal_force(u, [nh])
    out["FiniteStrainAssembler.tangent"] = fsa.tangent(np.zeros(12), [nh_e])
    assert np.allclose(out["FiniteStrainAssembler.tangent"], out["Assembler.stiffness"], rtol=0, atol=1e-9)
    out["FiniteStrainAssembler.force_and_tangent"] = fsa.force_and_tangent(u, [nh, fib], np.ones(1, dtype=np.int64))
    out["FiniteStrainAssembler.energy"] = fsa.energy(u, [fib])
    # the same calls on the ten-node tetrahedron (P2): the pattern and the small-strain limit of
    # QuadraticAssembler's
    qfs = core.hyperelastic.QuadraticFiniteStrainAssembler(pts10, tets10)
    out["QuadraticFiniteStrainAssembler.__new__"] = qfs
    out["QuadraticFiniteStrainAssembler.nnz"] = qfs.nnz
    out["QuadraticFiniteStrainAssembler.pattern"] = qfs.pattern()
    assert all(np.array_equal(a, b) for a, b in zip(qfs.pattern(), qa.pattern()))
    u10 = np.zeros(30)
    u10[2::3] = 0.2 * pts10[:, 2]
    out["QuadraticFiniteStrainAssembler.internal_force"] = qfs.internal_force(u10, [nh])
    out["QuadraticFiniteStrainAssembler.tangent"] = qfs.tangent(np.zeros(30), [nh_e])
    assert np.allclose(out["QuadraticFiniteStrainAssembler.tangent"], out["QuadraticAssembler.stiffness"], rtol=0,
                       atol=1e-9)
    out["QuadraticFiniteStrainAssembler.force_and_tangent"] = qfs.force_and_tangent(
        u10, [nh, fib], np.ones(1, dtype=np.int64)
    )
    out["QuadraticFiniteStrainAssembler.energy"] = qfs.energy(u10, [fib])

    chol = core.linalg.Cholesky(12, indptr, indices, mass)
    out["Cholesky.__new__"] = chol
    out["Cholesky.refactor"] = chol.refactor(2 * mass)
    out["Cholesky.refactor_with_pattern"] = chol.refactor_with_pattern(indptr, indices, mass)
    out["Cholesky.solve"] = chol.solve(np.ones(12))
    out["Cholesky.unit_columns"] = chol.unit_columns(np.array([0, 5], dtype=np.int64))
    out["Cholesky.unit_columns_into"] = chol.unit_columns_into(np.array([0, 5], dtype=np.int64), np.ones((2, 12)))
    out["Cholesky.n"] = chol.n
    out["Cholesky.nnz_factor"] = chol.nnz_factor
    out["Cholesky.nnz_factor_lower"] = chol.nnz_factor_lower
    out["Cholesky.ordering"] = chol.ordering

    dm = core.linalg.DofMap(12, np.array([0, 1, 2], dtype=np.int64))
    out["DofMap.__new__"] = dm
    out["DofMap.free"] = dm.free
    out["DofMap.n_dofs"] = dm.n_dofs
    out["DofMap.reduce_pattern"] = dm.reduce_pattern(indptr, indices)
    comb = np.zeros((2, 1))
    out["combine_rows"] = core.linalg.combine_rows(np.ones((3, 2)), np.array([0, 2], dtype=np.int64), np.ones((2, 1)), comb)
    out["combine_rows_single"] = core.linalg.combine_rows_single(np.ones((3, 2), dtype=np.float32),
                                                                 np.array([0, 2], dtype=np.int64), np.ones((2, 1)), comb)
    out["delassus"] = core.linalg.delassus(np.array([0, 1], dtype=np.int64), np.array([0], dtype=np.int64), np.ones(1),
                                    np.array([0], dtype=np.int64), np.ones((1, 1)), 1, 1.0)
    A2, q2 = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-1.0, 1.0])
    out["lcp_solve"] = core.lcp.lcp_solve(A2, q2)
    out["lcp_lagrange"] = core.lcp.lcp_lagrange(A2, q2)
    out["lcp_penalty"] = core.lcp.lcp_penalty(A2, q2, np.ones(2))
    # the tet's stiffness (12 x 12, full 3 x 3 blocks) as a node-blocked matrix
    Kt = asm.stiffness(pts, d[None], None)
    blocked = core.linalg.Blocked.from_csr("full", 12, indptr, indices, np.asarray(Kt, dtype=float))
    assert blocked is not None and core.linalg.Blocked.from_csr("kron", 12, indptr, indices, np.asarray(Kt, dtype=float)) is None
    out["Blocked.shape"] = blocked.shape
    out["sum_of_products"] = core.linalg.sum_of_products([(blocked, np.ones(12))], np.zeros(12))
    out["csr_matvec"] = core.linalg.csr_matvec(12, indptr, indices, np.asarray(Kt, dtype=float), np.ones(12))
    out["csr_rmatvec"] = core.linalg.csr_rmatvec(12, indptr, indices, np.asarray(Kt, dtype=float), np.ones(12))
    load = core.fem.PressureLoad(np.array([[0, 1, 2]], dtype=np.int64), 4)
    out["PressureLoad.__new__"] = load
    out["PressureLoad.forces"] = load.forces(pts, np.ones(4), np.zeros((4, 3)))

    # two facing unit squares across a gap of 0.1 along x: a (x > 0, normal -x), b (normal +x)
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], dtype=float)
    p2 = np.vstack([np.c_[np.full(4, 0.05), sq], np.c_[np.full(4, -0.05), sq]])
    a = np.array([[0, 3, 2], [0, 2, 1]], dtype=np.int64)
    b = np.array([[4, 5, 6], [4, 6, 7]], dtype=np.int64)
    crossed = p2.copy()
    crossed[0, 0] = -0.2
    out["project"] = core.contact.project(crossed[[0]], p2[b[:1]])
    areas = core.contact.tributary_areas(p2, a)
    out["tributary_areas"] = areas
    out["contact_area"] = core.contact.contact_area(p2, a, np.arange(8) == 0)
    nodes = np.arange(4, dtype=np.int64)
    out["plane_detect"] = core.contact.plane_detect(crossed, nodes, areas[:4], [0.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.5)

    im = core.contact.InterfaceMesh(p2, a, b, 0.5, 0.5)
    out["InterfaceMesh.__new__"] = im
    for prop in ("tets", "triangles", "sides", "weights", "n_rebuilds"):
        out[f"InterfaceMesh.{prop}"] = getattr(im, prop)
    out["InterfaceMesh.signed_volumes"] = im.signed_volumes(p2)
    out["InterfaceMesh.inversion"] = im.inversion(crossed)
    pairs = im.detect(crossed)
    assert len(pairs["slave"]) > 0
    out["InterfaceMesh.detect"] = pairs
    out["InterfaceMesh.max_slip"] = im.max_slip(p2)
    out["InterfaceMesh.update"] = im.update(p2)
    out["InterfaceMesh.rebuild"] = im.rebuild(p2)
    out["constraint_matrix"] = core.contact.constraint_matrix(
        pairs["slave"], pairs["master"], pairs["xi"], pairs["zeta"], pairs["normal"], 8
    )

    bvh = core.contact.BvhDetector(a, np.arange(4, 8, dtype=np.int64), areas[4:], best_first=True)
    out["BvhDetector.__new__"] = bvh
    out["BvhDetector.detect"] = bvh.detect(p2, 0.5)
    out["BvhDetector.detect_count"] = bvh.detect_count(p2, 0.5)
    return out


def test_return_types_match_stub():
    stub = _stub_module()
    declared = _stub_callables(stub)
    samples = _samples()
    assert set(declared) == set(samples), ("no sample call", set(declared) - set(samples), "not in stub", set(samples) - set(declared))
    wrong = []
    for name, fn in declared.items():
        hint = typing.get_type_hints(fn, globalns=vars(stub))["return"]
        if not _conforms(samples[name], hint):
            wrong.append(f"{name}: stub says {hint}, got {samples[name]!r:.200}")
    assert not wrong, "\n".join(wrong)
