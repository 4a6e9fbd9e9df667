"""Triangular solves on the M5 matrices: vfrs's own supernodal solve against CHOLMOD, same matrix,
same process.

For each mesh resolution (medium, fine) the M5 collision scene is built as the time step
builds it; its effective HHT matrix K_eff splits into one block per fold (the folds share no
DOF), and the time step factors each block with ``vfrs.linalg.Cholesky``. For each block this
reports:

* nnz(L): vfrs's stored values (supernodes keep their full square diagonal block), its
  lower triangle (what CHOLMOD counts: ``factor.L().nnz``, relaxed-supernode zeros included
  in both) and CHOLMOD's (scikit-sparse, default analysis: METIS or AMD, supernodal);
* the time of a solve with 1, 2 and 8 right-hand sides (a C-ordered (n, k) array, as the
  time step passes them), the vfrs factor the integrator built against CHOLMOD's factor of
  the same block, interleaved: each repetition times one vfrs and one CHOLMOD solve back to
  back (alternating which goes first), ``--reps`` repetitions per round, ``--rounds`` rounds
  over the right-hand-side counts. Times are medians over all repetitions; the ratio is the
  median of the per-repetition ratios vfrs / CHOLMOD (a load spike on this shared machine
  hits both solves of a pair alike, so paired ratios are steadier than a ratio of medians);
* the relative difference of the two solutions.

No asserts: this reports. CHOLMOD runs with its BLAS's default threads (OpenBLAS); vfrs's
solve of a block is sequential (its factorization: vfrs's numeric supernodal LL^T on faer's
symbolic analysis, ``rust/vfrs-core/src/cholesky/``). The load average before and after each
resolution is in the JSON.

    python benchmarks/bench_solve_m5.py                     # medium and fine, ~3 min
    python benchmarks/bench_solve_m5.py --res medium --reps 10 --rounds 1   # smoke run

Writes benchmarks/results/solve_m5.json (``--out`` to change).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

import vfrs
from vfrs.dynamics import build_problem
from vfrs.dynamics.integrators import HHTIntegrator

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "m5_collision.toml"
NRHS = (1, 2, 8)


def build(resolution: str):
    """(integrator, K_eff as CSC) for the M5 collision scene at `resolution`."""
    d = vfrs.Scene.load(SCENE).to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = resolution
    scene = vfrs.Scene.from_dict(d)
    integ = HHTIntegrator(build_problem(scene), scene.time)
    return integ, integ.effective_matrix.tocsc()


def time_block(f, fc, n: int, reps: int, rounds: int, rng) -> dict:
    rhs = {k: rng.standard_normal(n) if k == 1 else rng.standard_normal((n, k)) for k in NRHS}
    out: dict = {}
    for k, b in rhs.items():
        x_f, x_c = f.solve(b), fc(b)
        out[k] = {
            "vfrs": [],
            "cholmod": [],
            "ratio": [],
            "rel_diff": float(np.linalg.norm(x_f - x_c) / np.linalg.norm(x_c)),
        }
        for _ in range(3):  # warm-up
            f.solve(b), fc(b)
    for _ in range(rounds):
        for k, b in rhs.items():
            rec = out[k]
            gc.collect()
            for rep in range(reps):
                pair = {}
                order = ("vfrs", "cholmod") if rep % 2 == 0 else ("cholmod", "vfrs")
                for who in order:
                    fn = f.solve if who == "vfrs" else fc
                    t0 = time.perf_counter()
                    fn(b)
                    pair[who] = time.perf_counter() - t0
                rec["vfrs"].append(pair["vfrs"])
                rec["cholmod"].append(pair["cholmod"])
                rec["ratio"].append(pair["vfrs"] / pair["cholmod"])
    res = {}
    for k, rec in out.items():
        res[str(k)] = {
            "vfrs_ms": 1e3 * float(np.median(rec["vfrs"])),
            "cholmod_ms": 1e3 * float(np.median(rec["cholmod"])),
            "ratio": float(np.median(rec["ratio"])),
            "ratio_q25_q75": [float(q) for q in np.quantile(rec["ratio"], [0.25, 0.75])],
            "samples": len(rec["ratio"]),
            "rel_diff": rec["rel_diff"],
        }
    return res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--res", nargs="+", default=["medium", "fine"])
    ap.add_argument("--reps", type=int, default=30, help="paired repetitions per round and RHS count")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--blocks", type=int, nargs="*", default=None, help="fold blocks to time (default: all)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "solve_m5.json"))
    args = ap.parse_args(argv)
    try:
        from sksparse.cholmod import cholesky as cholmod
    except ImportError:
        print("scikit-sparse (CHOLMOD) is not importable: see benchmarks/README.md", file=sys.stderr)
        return 1

    rng = np.random.default_rng(5)
    results = []
    for res in args.res:
        load0 = os.getloadavg()
        t0 = time.perf_counter()
        integ, K = build(res)
        F = integ.factor
        blocks = list(getattr(F, "blocks", [slice(0, K.shape[0])]))
        factors = list(getattr(F, "factors", [F]))
        print(f"{res}: built in {time.perf_counter() - t0:.1f} s, {len(blocks)} block(s)", flush=True)
        for bi, (blk, f) in enumerate(zip(blocks, factors)):
            if args.blocks is not None and bi not in args.blocks:
                continue
            A = K[blk, blk].tocsc()
            n = A.shape[0]
            fc = cholmod(A)
            row = {
                "resolution": res,
                "block": bi,
                "n": n,
                "nnz_A": int(A.nnz),
                "ordering": f.ordering,
                "nnz_L_vfrs_stored": int(f.nnz_factor),
                "nnz_L_vfrs_lower": int(f.nnz_factor_lower),
                "nnz_L_cholmod": int(fc.L().nnz),
                "solve": time_block(f, fc, n, args.reps, args.rounds, rng),
            }
            results.append(row)
            for k, s in row["solve"].items():
                print(
                    f"  block {bi} n={n} k={k}: vfrs {s['vfrs_ms']:7.2f} ms  CHOLMOD {s['cholmod_ms']:7.2f} ms"
                    f"  ratio {s['ratio']:.2f} [{s['ratio_q25_q75'][0]:.2f}, {s['ratio_q25_q75'][1]:.2f}]"
                    f"  rel.diff {s['rel_diff']:.1e}",
                    flush=True,
                )
        results.append({"resolution": res, "loadavg_start": load0, "loadavg_end": os.getloadavg()})

    table = ["| mesh | block | n | nnz(L) vfrs stored / lower | nnz(L) CHOLMOD | RHS | vfrs ms | CHOLMOD ms | vfrs / CHOLMOD |",
             "|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        if "solve" not in r:
            continue
        for k, s in r["solve"].items():
            low = "-" if r["nnz_L_vfrs_lower"] is None else f"{r['nnz_L_vfrs_lower']:,}"
            table.append(
                f"| {r['resolution']} | {r['block']} | {r['n']:,} | {r['nnz_L_vfrs_stored']:,} / {low} | "
                f"{r['nnz_L_cholmod']:,} | {k} | {s['vfrs_ms']:.2f} | {s['cholmod_ms']:.2f} | {s['ratio']:.2f} |"
            )
    print("\n".join(table))
    doc = {
        "benchmark": "bench_solve_m5",
        "scene": str(SCENE.relative_to(ROOT)),
        "reps": args.reps,
        "rounds": args.rounds,
        "machine": {
            "platform": platform.platform(),
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
        },
        "results": results,
        "table": table,
    }
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
