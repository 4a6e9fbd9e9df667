"""Foundation benchmark: assembly and sparse Cholesky, vfrs against its peers.

One script, one run, side by side on box meshes of about 40k and 180k tetrahedra:

* assembly of K and M: vfrs vs scikit-fem (ElementVector(ElementTetP1()), linear_elasticity
  and mass forms);
* first factorization (ordering + symbolic + numeric), refactorization (same pattern, new
  values) and one solve: vfrs.cholesky (orderings auto / amd / nested_dissection: faer's
  symbolic analysis, vfrs's own supernodal numeric factorization and solve) vs
  scipy.sparse.linalg.splu, CHOLMOD (scikit-sparse; METIS, CHOLMOD's default choice, AMD) and
  MKL Pardiso (pypardiso, SPD mode), each where importable; nnz(L) for each.

Each solver runs in a fresh process (thread pools of one library must not slow another);
the solvers are run in interleaved rounds (``--rounds``, default 2) and each time is the
minimum over rounds and repeats (1 factorization and 2 refactorizations/solves per round). The load average before and
after each mesh is in the JSON: on a shared machine other processes skew the numbers. No asserts: this reports, it does not judge.

    python benchmarks/bench_foundation.py            # 40k and 180k tets
    python benchmarks/bench_foundation.py --quick    # 40k tets only (smoke run)

Writes benchmarks/results/foundation.json (``--out`` to change).
"""

from __future__ import annotations

import argparse
import gc
import json
import multiprocessing as mp
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy
import scipy.sparse as sp
import scipy.sparse.linalg as spla

import vfrs

E, NU, RHO = 10e3, 0.45, 1070.0
SIZE = (0.01, 0.01, 0.01)  # a 1 cm cube, vocal-fold scale
DT = 1e-4  # the refactor matrix is the Newmark effective stiffness K + 4/dt^2 M
MESHES = {"40k": (19, 19, 19), "180k": (31, 31, 31)}
SPLU_MAX_DOFS = 40_000  # above this splu is skipped unless --splu-large (time, memory)


def best(fn, repeat):
    """(min wall time over `repeat` calls, last result)."""
    t, out = np.inf, None
    for _ in range(repeat):
        out = None
        gc.collect()
        t0 = time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - t0)
    return t, out


def timed(r, name, fn, repeat):
    """Runs `fn` `repeat` times; stores the minimum wall time in r[name + "_s"] and the
    minimum process CPU time (all threads) in r[name + "_cpu_s"]; returns the last result."""
    t, c, out = np.inf, np.inf, None
    for _ in range(repeat):
        out = None
        gc.collect()
        c0, t0 = time.process_time(), time.perf_counter()
        out = fn()
        t = min(t, time.perf_counter() - t0)
        c = min(c, time.process_time() - c0)
    r[name + "_s"], r[name + "_cpu_s"] = t, c
    return out


def rel_residual(A, x, b):
    return float(np.linalg.norm(A @ x - b) / np.linalg.norm(b))


# ---------------------------------------------------------------------------------- assembly


def bench_assembly(mesh, rep):
    mat = vfrs.Isotropic(E=E, nu=NU, rho=RHO)
    res = {}
    # First call builds the sparsity pattern (cached on the mesh); later calls only refill values.
    t0 = time.perf_counter()
    K = vfrs.stiffness(mesh, mat)
    M = vfrs.mass(mesh, RHO)
    res["vfrs_first_s"] = time.perf_counter() - t0
    res["vfrs_s"], _ = best(lambda: (vfrs.stiffness(mesh, mat), vfrs.mass(mesh, RHO)), rep)

    try:
        import skfem
        from skfem.models.elasticity import lame_parameters, linear_elasticity
    except ImportError as e:
        res["skfem"] = f"not importable: {e}"
        return K, M, res
    from skfem.helpers import dot

    @skfem.BilinearForm
    def mass_form(u, v, w):
        return RHO * dot(u, v)

    def sk_setup():
        m = skfem.MeshTet(np.ascontiguousarray(mesh.points.T), np.ascontiguousarray(mesh.tets.T))
        return skfem.Basis(m, skfem.ElementVector(skfem.ElementTetP1()), intorder=2)

    res["skfem_basis_s"], basis = best(sk_setup, 1)
    form = linear_elasticity(*lame_parameters(E, NU))

    def sk_assemble():
        return form.assemble(basis), mass_form.assemble(basis)

    res["skfem_s"], (Ks, Ms) = best(sk_assemble, max(1, rep // 2))
    res["ratio_skfem_over_vfrs"] = res["skfem_s"] / res["vfrs_s"]
    res["ratio_skfem_incl_basis_over_vfrs_first"] = (res["skfem_s"] + res["skfem_basis_s"]) / res[
        "vfrs_first_s"
    ]
    # scikit-fem orders DOFs node-major for ElementVector too ([u0x, u0y, u0z, u1x, ...]).
    res["check_K_rel_diff"] = float(abs(Ks - K).max() / abs(K).max())
    res["check_M_rel_diff"] = float(abs(Ms - M).max() / abs(M).max())
    return K, M, res


# ---------------------------------------------------------------------------------- solvers


def bench_vfrs(A, A2, b, ordering, rep_factor, rep):
    r = {}
    f = timed(r, "factor", lambda: vfrs.cholesky(A, ordering=ordering), rep_factor)
    r["ordering_used"] = f.ordering
    r["nnz_L"] = int(f.nnz_factor)
    _ = timed(r, "refactor", lambda: f.refactor(A2), rep)
    x = timed(r, "solve", lambda: f.solve(b), rep)
    r["residual"] = rel_residual(A2, x, b)
    del f
    return r


def bench_splu(A, A2, b, rep_factor, rep):
    r = {"permc_spec": "COLAMD (default)"}
    Ac, A2c = A.tocsc(), A2.tocsc()
    lu = timed(r, "factor", lambda: spla.splu(Ac), rep_factor)
    r["nnz_L"] = int(lu.L.nnz)
    r["nnz_LU"] = int(lu.L.nnz + lu.U.nnz)
    # SuperLU has no numeric-only refactorization in scipy: a refactor is a new splu.
    lu = timed(r, "refactor", lambda: spla.splu(A2c), 1)
    r["refactor_note"] = "no numeric-only refactor in scipy; a full splu"
    x = timed(r, "solve", lambda: lu.solve(b), rep)
    r["residual"] = rel_residual(A2, x, b)
    del lu
    return r


def bench_cholmod(A, A2, b, ordering, rep_factor, rep):
    from sksparse.cholmod import analyze, cholesky

    Ac, A2c = A.tocsc(), A2.tocsc()
    r = {}
    _ = timed(r, "analyze", lambda: analyze(Ac, ordering_method=ordering), 1)
    f = timed(r, "factor", lambda: cholesky(Ac, ordering_method=ordering), rep_factor)
    _ = timed(r, "refactor", lambda: f.cholesky_inplace(A2c), rep)
    x = timed(r, "solve", lambda: f(b), rep)
    r["residual"] = rel_residual(A2, x, b)
    # L() converts (a copy, supernodal -> simplicial); count it after the timings.
    r["nnz_L"] = int(f.L().nnz)
    del f
    return r


def bench_pardiso(A, A2, b, rep_factor, rep):
    from pypardiso import PyPardisoSolver

    # SPD mode (mtype 2) reads the upper triangle in CSR.
    Au = sp.triu(A, format="csr")
    Au.sort_indices()
    A2u = sp.triu(A2, format="csr")
    A2u.sort_indices()
    if not (np.array_equal(Au.indptr, A2u.indptr) and np.array_equal(Au.indices, A2u.indices)):
        raise RuntimeError("refactor matrix has another pattern")
    r = {"mtype": 2}
    zero = np.zeros((A.shape[0], 1))
    bb = np.asfortranarray(b.reshape(-1, 1))

    def factor():
        s = PyPardisoSolver(mtype=2)
        s.set_phase(12)  # analysis (METIS ordering) + numeric factorization
        s._call_pardiso(Au, zero)
        return s

    s = timed(r, "factor", factor, rep_factor)
    r["nnz_L"] = int(s.get_iparm(18))  # iparm(18): nonzeros in the factor

    def refactor():
        s.set_phase(22)
        s._call_pardiso(A2u, zero)

    _ = timed(r, "refactor", refactor, rep)

    def solve():
        s.set_phase(33)
        return s._call_pardiso(A2u, bb)

    x = timed(r, "solve", solve, rep)
    r["residual"] = rel_residual(A2, x.ravel(), b)
    s.free_memory(everything=True)
    return r



def _worker(conn, data, kind, arg, rep_factor, rep):
    try:
        z = np.load(data)
        n = int(z["n"])
        A = sp.csr_matrix((z["a"], z["indices"], z["indptr"]), shape=(n, n))
        A2 = sp.csr_matrix((z["a2"], z["indices"], z["indptr"]), shape=(n, n))
        b = z["b"]
        if kind == "vfrs":
            r = bench_vfrs(A, A2, b, arg, rep_factor, rep)
        elif kind == "splu":
            r = bench_splu(A, A2, b, rep_factor, rep)
        elif kind == "cholmod":
            r = bench_cholmod(A, A2, b, arg, rep_factor, rep)
        else:
            r = bench_pardiso(A, A2, b, rep_factor, rep)
    except ImportError as e:
        r = {"skipped": f"not importable: {e}"}
    except Exception as e:  # noqa: BLE001  (a peer failing must not stop the run)
        r = {"skipped": f"{type(e).__name__}: {e}"}
    conn.send(r)
    conn.close()


def run_isolated(data, kind, arg, rep_factor, rep, timeout):
    """Runs one solver benchmark in a fresh process; gives up after `timeout` seconds."""
    ctx = mp.get_context("spawn")
    recv, send = ctx.Pipe(duplex=False)
    p = ctx.Process(target=_worker, args=(send, data, kind, arg, rep_factor, rep))
    p.start()
    send.close()
    try:
        if recv.poll(timeout):
            r = recv.recv()
        else:
            r = {"skipped": f"stopped after the {timeout:.0f} s cap"}
    except EOFError:
        r = {"skipped": f"worker died (exit code {p.exitcode}; out of memory?)"}
    if p.is_alive():
        p.kill()
    p.join()
    return r


def run_mesh(label, cells, args):
    small = label == "40k"
    rep = 2
    rep_factor = 1
    out = {"cells": list(cells), "loadavg_start": os.getloadavg()}
    mesh = vfrs.meshes.box(SIZE, cells)
    out["n_tets"] = int(mesh.n_tets)
    out["n_nodes"] = int(len(mesh.points))
    print(f"\n=== mesh {label}: cells {cells}, {mesh.n_tets} tets, {len(mesh.points)} nodes ===", flush=True)

    K, M, out["assembly"] = bench_assembly(mesh, rep)
    a = out["assembly"]
    print(f"assembly K+M: vfrs {a['vfrs_s']:.4f} s (first call {a['vfrs_first_s']:.4f} s)", flush=True)
    if "skfem_s" in a:
        print(
            f"              scikit-fem {a['skfem_s']:.3f} s (+ basis {a['skfem_basis_s']:.3f} s); "
            f"K diff {a['check_K_rel_diff']:.1e}, M diff {a['check_M_rel_diff']:.1e}",
            flush=True,
        )

    fixed_nodes = np.unique(mesh.surfaces["xmin"])
    fixed = (3 * fixed_nodes[:, None] + np.arange(3)).ravel()
    dm = vfrs.DofMap(mesh.n_dofs, fixed)
    A = dm.reduce(K)
    Mff = dm.reduce(M)
    # Same pattern, other values: the effective stiffness K + 4/dt^2 M on A's pattern.
    if np.array_equal(A.indptr, Mff.indptr) and np.array_equal(A.indices, Mff.indices):
        A2 = A.copy()
        A2.data = A.data + (4.0 / DT**2) * Mff.data
        out["refactor_matrix"] = "K_ff + 4/dt^2 M_ff, dt = %g" % DT
    else:
        A2 = A.copy()
        A2.data = 1.7 * A.data
        out["refactor_matrix"] = "1.7 K_ff (M_ff has another stored pattern)"
    n = A.shape[0]
    out["n_free_dofs"] = int(n)
    out["nnz_A"] = int(A.nnz)
    b = np.random.default_rng(1).standard_normal(n)
    print(f"K_ff: n = {n}, nnz = {A.nnz}; refactor matrix: {out['refactor_matrix']}", flush=True)
    del K, M

    # Each solver runs in a fresh process: the BLAS/OpenMP/rayon thread pools of one library
    # (OpenBLAS and MKL threads spin after a call) must not slow the next one down, and
    # memory is returned between runs.
    tmp = tempfile.mkdtemp(prefix="vfrs-bench-")
    data = os.path.join(tmp, "system.npz")
    np.savez(data, indptr=A.indptr, indices=A.indices, a=A.data, a2=A2.data, b=b, n=n)
    cases = [(f"vfrs/{o}", "vfrs", o) for o in args.orderings]
    if n <= SPLU_MAX_DOFS or args.splu_large:
        cases.append(("splu", "splu", None))
    cases += [(f"cholmod/{o}", "cholmod", o) for o in args.cholmod_orderings]
    cases.append(("pardiso", "pardiso", None))
    solvers = {}
    # Rounds interleave the solvers, so a slow spell of the machine hits them alike; each
    # metric is the minimum over the rounds (splu, slow, runs in the first round only).
    for rnd in range(args.rounds):
        print(f"  round {rnd + 1}/{args.rounds}", flush=True)
        for name, kind, arg in cases:
            if kind == "splu" and rnd > 0:
                continue
            if "skipped" in solvers.get(name, {}):
                continue
            print(f"    {name} ...", end="", flush=True)
            s = run_isolated(data, kind, arg, rep_factor, rep, args.timeout)
            if "skipped" in s:
                solvers[name] = s
                print(f" skipped: {s['skipped']}", flush=True)
                continue
            print(
                f" factor {s['factor_s']:.3f} s, refactor {s['refactor_s']:.3f} s, "
                f"solve {s['solve_s']:.4f} s, nnz(L) {s['nnz_L']:.3e}",
                flush=True,
            )
            if name in solvers:
                for k in ("factor", "refactor", "solve"):
                    for key in (k + "_s", k + "_cpu_s"):
                        solvers[name][key] = min(solvers[name][key], s[key])
                solvers[name]["rounds"] += 1
            else:
                solvers[name] = dict(s, rounds=1)
    if "splu" not in solvers:
        solvers["splu"] = {
            "skipped": f"n = {n} > {SPLU_MAX_DOFS}: splu (COLAMD) on this mesh takes very long and "
            "much memory; rerun with --splu-large to time it (capped by --timeout)"
        }
        print(f"  splu skipped on this mesh (n = {n} > {SPLU_MAX_DOFS}; --splu-large to run it)")
    os.remove(data)
    os.rmdir(tmp)
    out["solvers"] = solvers
    out["loadavg_end"] = os.getloadavg()
    return out


# ---------------------------------------------------------------------------------- report


def ratios(res):
    """vfrs ('auto') time / peer time for factor, refactor, solve; < 1 means vfrs is faster."""
    sol = res["solvers"]
    ours = sol.get("vfrs/auto")
    out = {}
    if not ours or "skipped" in ours:
        return out
    for name, s in sol.items():
        if name.startswith("vfrs/") or "skipped" in s:
            continue
        keys = ("factor_s", "refactor_s", "solve_s", "factor_cpu_s", "refactor_cpu_s", "solve_cpu_s")
        out[name] = {k: ours[k] / s[k] for k in keys}
        out[name]["nnz_L"] = ours["nnz_L"] / s["nnz_L"]
    return out


def print_table(results):
    labels = list(results)
    print("\n" + "=" * 100)
    print("Assembly of K and M (seconds; scikit-fem excludes its Basis construction)")
    print(f"{'mesh':>6} {'tets':>8} {'vfrs':>9} {'vfrs 1st':>9} {'skfem':>9} {'skfem/vfrs':>11}")
    for L in labels:
        r, a = results[L], results[L]["assembly"]
        sk = a.get("skfem_s")
        print(
            f"{L:>6} {r['n_tets']:>8} {a['vfrs_s']:>9.4f} {a['vfrs_first_s']:>9.4f} "
            f"{sk if sk is not None else float('nan'):>9.3f} {a.get('ratio_skfem_over_vfrs', float('nan')):>10.0f}x"
        )
    print("\nSparse factorization of K_ff (seconds; nnz(L) of the factor as stored)")
    print(
        f"{'mesh':>6} {'solver':<26} {'factor':>9} {'refactor':>9} {'solve':>8} {'nnz(L)':>11} "
        f"{'vfrs/peer: fact':>15} {'refact':>7} {'solve':>6} {'nnzL':>6}"
    )
    for L in labels:
        rs = ratios(results[L])
        for name, s in results[L]["solvers"].items():
            if "skipped" in s:
                print(f"{L:>6} {name:<26} skipped: {s['skipped'][:60]}")
                continue
            tag = name + (f" ({s['ordering_used']})" if name == "vfrs/auto" else "")
            line = (
                f"{L:>6} {tag:<26} {s['factor_s']:>9.3f} {s['refactor_s']:>9.3f} {s['solve_s']:>8.4f} "
                f"{s['nnz_L']:>11.3e}"
            )
            if name in rs:
                q = rs[name]
                line += f" {q['factor_s']:>15.2f} {q['refactor_s']:>7.2f} {q['solve_s']:>6.2f} {q['nnz_L']:>6.2f}"
            print(line)
    print("\n(vfrs/peer: wall time of vfrs 'auto' divided by the peer's; below 1 vfrs is faster.")
    print(" Process CPU times (all threads) and their ratios are in the JSON: with --threads 1 they")
    print(" are the numbers least disturbed by other load on the machine.)")
    print("splu: nnz(L) is L only (nnz(L)+nnz(U) in the JSON); its 'refactor' is a new splu.")
    print("Targets (issue 2): assembly >= 100x scikit-fem; vfrs factor <= 1.5x CHOLMOD and")
    print(">= 10x faster than splu (vfrs/splu <= 0.1); refactor <= 1.5x CHOLMOD's.")
    for L in labels:
        rs = ratios(results[L])
        a = results[L]["assembly"]
        chol = next((rs[k] for k in ("cholmod/metis", "cholmod/default") if k in rs), None)
        parts = []
        if "ratio_skfem_over_vfrs" in a:
            parts.append(f"assembly {a['ratio_skfem_over_vfrs']:.0f}x")
        if chol:
            parts.append(f"factor/CHOLMOD(METIS) {chol['factor_s']:.2f} (CPU time {chol['factor_cpu_s']:.2f})")
            parts.append(f"refactor/CHOLMOD {chol['refactor_s']:.2f} (CPU time {chol['refactor_cpu_s']:.2f})")
        if "splu" in rs:
            parts.append(f"splu/factor {1 / rs['splu']['factor_s']:.1f}x")
        print(f"  {L}: " + ", ".join(parts))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="only the 40k-tet mesh (smoke run)")
    p.add_argument("--splu-large", action="store_true", help="also time splu on the 180k-tet mesh")
    p.add_argument("--rounds", type=int, default=2, help="interleaved rounds over the solvers")
    p.add_argument(
        "--threads",
        type=int,
        default=None,
        help="threads for every solver (RAYON/OMP/OPENBLAS/MKL_NUM_THREADS); default: all",
    )
    p.add_argument("--timeout", type=float, default=900.0, help="cap per solver run, seconds")
    p.add_argument("--out", default=str(Path(__file__).parent / "results" / "foundation.json"))
    p.add_argument("--orderings", nargs="+", default=["auto", "amd", "nested_dissection"])
    p.add_argument("--cholmod-orderings", nargs="+", default=["metis", "default", "amd"])
    args = p.parse_args()
    if args.threads:
        # Inherited by the solver processes (spawned after this).
        for var in ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ[var] = str(args.threads)

    env = {
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "cpus": os.cpu_count(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "vfrs": vfrs.__version__,
        "RAYON_NUM_THREADS": os.environ.get("RAYON_NUM_THREADS"),
        "OMP_NUM_THREADS": os.environ.get("OMP_NUM_THREADS"),
        "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
        "MKL_NUM_THREADS": os.environ.get("MKL_NUM_THREADS"),
        "date_utc": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "command": " ".join([Path(sys.executable).name] + sys.argv),
    }
    for mod in ("skfem", "sksparse", "pypardiso", "mkl"):
        try:
            m = __import__(mod)
            env[mod] = getattr(m, "__version__", "importable")
        except ImportError:
            env[mod] = None
    print(json.dumps(env))

    labels = ["40k"] if args.quick else list(MESHES)
    results = {}
    for L in labels:
        results[L] = run_mesh(L, MESHES[L], args)
        results[L]["ratios_vfrs_auto_over_peer"] = ratios(results[L])
    print_table(results)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"env": env, "results": results}, indent=2) + "\n")
    print(f"\nwrote {out}")


if __name__ == "__main__":
    main()
