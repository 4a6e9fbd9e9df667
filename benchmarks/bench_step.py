"""Cost of one HHT-alpha step of a no-contact run against one solve with the factor of K_eff.

The floor of an implicit step with a direct solver is one forward/back substitution; the
step adds two sparse products (M and K) for the right-hand side, the load vectors and the
history (energies: two more products; reactions: the fixed rows). Both are measured in the
same run: the loop's wall time per step against the time spent inside the solves of the same
steps (so a busy machine slows both alike); an isolated solve is shown for reference.
Goal: a step <= 1.5 x one solve.

    python benchmarks/bench_step.py [--cells 60 12 12] [--steps 200]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

import vfrs


def scene(cells, steps, energy, reactions):
    L = 0.02
    return vfrs.Scene.from_dict({
        "title": "bench_step",
        "bodies": [{"name": "block", "mesh": {"builtin": "box", "size": [L, L / 5, L / 5], "cells": list(cells)},
                    "material": {"model": "transversely_isotropic", "E_p": 2e3, "E_z": 40e3, "nu_p": 0.9,
                                 "nu_pz": 0.0, "G_pz": 10e3, "rho": 1070.0},
                    "damping": {"a0": 0.0, "a1": 1e-4},
                    "fixed": ["xmin"],
                    "loads": [{"type": "pressure", "surface": "ymin", "value": 800.0, "ramp": 1e-3}]}],
        "time": {"mode": "dynamic", "step": 50e-6, "end": steps * 50e-6, "alpha": -0.3},
        "output": {"every": 10**9, "energy": energy, "reactions": reactions},
    })


def solve_time(factor, n, repeats=30):
    b = np.random.default_rng(0).standard_normal(n)
    for _ in range(3):
        factor.solve(b)
    t0 = time.perf_counter()
    for _ in range(repeats):
        factor.solve(b)
    return (time.perf_counter() - t0) / repeats


def measure(cells, steps, energy, reactions):
    res = vfrs.run(scene(cells, steps, energy, reactions), progress=False)
    tm = res.timings
    loop = tm["total"] - tm["mesh"] - tm["assembly"] - tm["factorization"] - tm.get("output", 0.0)
    per_step = loop / steps
    in_loop_solve = tm["solve"] / steps
    isolated = solve_time(res.problem.factor, len(res.problem.free))
    return res, per_step, in_loop_solve, isolated


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cells", type=int, nargs=3, default=[60, 12, 12])
    ap.add_argument("--steps", type=int, default=200)
    args = ap.parse_args(argv)
    print(f"mesh: box {args.cells} cells, {args.steps} steps, HHT alpha = -0.3, Rayleigh a1 = 1e-4")
    rows = []
    for energy, reactions, label in [(False, False, "bare step"), (True, True, "step + energy + reactions (default)")]:
        res, step, solve, isolated = measure(args.cells, args.steps, energy, reactions)
        f = res.problem.factor
        rows.append((label, step, solve))
        print(f"  free DOFs {len(res.problem.free)}, nnz(L) {f.nnz_factor}, factorization {res.timings['factorization']:.3f} s")
        print(f"  {label:38s} step {step * 1e3:7.2f} ms | solve in the loop {solve * 1e3:7.2f} ms"
              f" (isolated {isolated * 1e3:6.2f} ms) | step/solve {step / solve:5.2f}")
    return rows


if __name__ == "__main__":
    main()
