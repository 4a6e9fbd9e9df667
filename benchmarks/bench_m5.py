"""What a time step of the M5 collision costs, against one solve with the same factor.

``python benchmarks/bench_m5.py`` runs the README's collision scene (examples/m5_collision.toml)
at the coarse, medium and fine meshes with each contact method, each run in a fresh process
(so its peak memory is its own), and reports per run:

- the wall time per step, the median over the steps with active contact pairs and over those
  without, and its ratio to the run's own K_eff solve per step (``timings["solve"]`` over the
  steps: what a step pays for its solve, the factor partly evicted from cache by the rest of
  the step);
- one solve with the run's factor timed alone after the run (the bodies' blocks solved
  concurrently, as the step does);
- the same solve by CHOLMOD (scikit-sparse, METIS, OpenBLAS) on the same matrix, when it is
  installed, and vfrs's solve of one block against CHOLMOD's of the same block: the four
  solves timed interleaved (each repetition runs each once), the ratios the medians of the
  per-repetition ratios;
- the time by effect (``res.timings``), the solves per step, the peak memory (RSS) and the
  compliance columns' share of it;
- per method, the exponent of the cost per step against the number of free DOFs (a log-log
  fit over the levels).

``python benchmarks/bench_m5.py --breakdown medium --end 0.01`` runs one scene in this
process and prints where its steps go, by part (solves, products, flow, record, contact's
parts), split by steps with and without pairs (``results/m5/step_breakdown.md``).

Results: ``benchmarks/results/m5/bench_m5.json`` and ``.md``, and ``cost_vs_dofs.png``.
Timings are wall-clock on whatever machine runs it; read the ratios.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "m5_collision.toml"
METHODS = {"lagrange": {}, "penalty": {"kappa": 1e10}, "augmented_lagrange": {"kappa": 1e8, "max_augmentations": 8}}


def _paired(fns, repeat=60) -> np.ndarray:
    """Times of ``fns`` (one row each, a column per repetition), timed interleaved: each
    repetition runs every function once, in an order that rotates, so a drift of the
    machine's speed reaches them alike and their ratios can be taken per repetition."""
    for _ in range(3):
        for fn in fns:
            fn()
    t = np.zeros((len(fns), repeat))
    for r in range(repeat):
        for k in range(len(fns)):
            i = (k + r) % len(fns)
            t0 = time.perf_counter()
            fns[i]()
            t[i, r] = time.perf_counter() - t0
    return t


def one_run(level: str, method: str, end: float, scheme: str = "mass_redistribution") -> dict:
    """One collision run, measured (called in a child process)."""
    import warnings

    import vfrs
    from vfrs.effects import EFFECTS, Effect

    warnings.simplefilter("ignore")
    d = vfrs.Scene.load(SCENE).to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = level
    d["time"]["end"] = end
    d["contact"] = {k: v for k, v in d["contact"].items() if k in ("detection", "pairs", "surface")}
    d["contact"].update(method=method, strict=False, scheme=scheme, **METHODS[method])
    scene = vfrs.Scene.from_dict(d)

    class Clock(Effect):
        """Stamps the wall time at every record (once per step)."""

        name = "bench_clock"

        def setup(self, ctx):
            self.ctx = ctx
            self.stamps = []

        def record(self, state, history):
            self.stamps.append(time.perf_counter())

    effects = [EFFECTS[name](params) for name, params in scene.effects.items()]
    clock = Clock(None)
    res = vfrs.run(scene, progress=False, effects=effects + [clock])
    h = res.history
    per_step = np.diff(np.asarray(clock.stamps))
    active = np.asarray(h["active_pairs"])[1:] > 0
    F = clock.ctx.factor  # the integrator's factor of K_eff (effects get it, not the integrator)
    n = F.n
    b = np.random.default_rng(0).standard_normal(n)
    out = {
        "level": level, "method": method, "scheme": scheme, "free_dofs": int(n), "steps": int(len(per_step)),
        "steps_with_contact": int(active.sum()),
        "step_contact_s": float(np.median(per_step[active])) if active.any() else float("nan"),
        "step_free_s": float(np.median(per_step[~active])) if (~active).any() else float("nan"),
        "step_mean_s": float(per_step.mean()),
        "total_s": float(res.timings["total"]),
        "timings": {k: float(v) for k, v in res.timings.items()},
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "nnz_factor": int(F.nnz_factor),
        "peak_force_N": float(np.abs(np.asarray(h["contact_force.right"])[:, 0]).max()),
    }
    contact = next(e for e in effects if e.name == "contact")
    held = sum(x.nbytes for x in (contact.solver, contact.scheme) if x is not None)
    out["compliance_mb"] = held / 2**20
    out["compliance_solves"] = int(np.asarray(h["compliance_solves"])[-1])
    blocks = getattr(F, "factors", [F])
    blk = getattr(F, "blocks", [slice(0, n)])[0]
    b_blk = b[blk].copy()
    # vfrs's solves and CHOLMOD's of the same matrices, interleaved (bench_solve_m5 does the
    # same with more repetitions): the ratios are medians of per-repetition ratios.
    nan = float("nan")
    try:
        from sksparse.cholmod import cholesky as cholmod

        A = clock.ctx.effective_matrix.tocsc()
        cf, cb = cholmod(A), cholmod(A[blk, blk])
        t = _paired([lambda: F.solve(b), lambda: blocks[0].solve(b_blk), lambda: cf(b), lambda: cb(b_blk)])
        out["solve_vs_cholmod"] = float(np.median(t[0] / t[2]))
        out["block_vs_cholmod"] = float(np.median(t[1] / t[3]))
    except ImportError:
        t = _paired([lambda: F.solve(b), lambda: blocks[0].solve(b_blk)])
        t = np.vstack([t, np.full_like(t, nan)])
        out["solve_vs_cholmod"] = out["block_vs_cholmod"] = nan
    solve, block, c_solve, c_block = (float(np.median(x)) for x in t)
    out.update(solve_s=solve, block_solve_s=block, cholmod_solve_s=c_solve, cholmod_block_solve_s=c_block)
    # What a step pays for its own solve: the K_eff solves of the run over its steps.
    out["solve_run_s"] = float(res.timings["solve"]) / len(per_step)
    return out


def breakdown(level: str, end: float) -> str:
    """Where the README main job's steps go, by part (``--breakdown LEVEL``): in-process timers
    around the parts, each part's own time (a part called inside another counts for itself),
    per step, split by steps with and without active pairs. Returns the table as text."""
    import collections
    import warnings

    import vfrs
    import vfrs.dynamics.hht as hht
    import vfrs.enforcement.effect as eff
    import vfrs.enforcement.lcp as lcp
    import vfrs.enforcement.compliance_matrix as cm
    import vfrs.enforcement.schemes.mass_redistribution as redist
    import vfrs.enforcement.schemes.stabilized as stab
    import vfrs.flow as flow
    import vfrs.history as history
    import vfrs.linalg as linalg
    from vfrs.contact.geometry import ContactPairs
    from vfrs.effects import EFFECTS, Effect

    warnings.simplefilter("ignore")
    acc: dict = collections.defaultdict(lambda: collections.defaultdict(float))
    step, stack, since = {"k": 0}, [], []

    def timed(owner, name, label):
        f = getattr(owner, name)

        def w(*a, **k):
            t0 = time.perf_counter()
            if stack:
                acc[step["k"]][stack[-1]] += t0 - since[-1]
            stack.append(label)
            since.append(t0)
            try:
                return f(*a, **k)
            finally:
                t1 = time.perf_counter()
                acc[step["k"]][stack.pop()] += t1 - since.pop()
                if stack:
                    since[-1] = t1
                if owner is history.Recorder:
                    acc[step["k"]]["_end"] = t1

        setattr(owner, name, w)

    parts = [(linalg.BlockCholesky, "solve", "triangular solves of the step (K_eff)"),
             (hht.HHTAlpha, "rhs", "HHT right-hand side (M x + K y)"),
             (history.Recorder, "record", "record (energies, reactions, probes, flow record)"),
             (flow.GlottalFlow, "forces", "flow"),
             (stab.StabilizedScheme, "predict", "contact predictor"),
             (redist.MassRedistributionScheme, "after_correct", "energy check (mass_redistribution)"),
             (eff.ContactEffect, "correct", "contact correction"),
             (eff.ContactEffect, "detect", "contact detection"),
             (eff.ContactEffect, "record", "contact record"),
             (cm.Compliance, "ensure", "compliance columns (solves for DOFs new to the zone)"),
             (cm.Compliance, "solve", "compliance products (whole field: correction, predictor shifts)"),
             (cm.Compliance, "response", "compliance response (contact-surface rows)"),
             (cm.Compliance, "delassus", "Delassus operator"),
             (lcp, "lagrange", "LCP"),
             (ContactPairs, "constraint", "constraint matrix")]
    for owner, name, label in parts:
        timed(owner, name, label)

    class Tick(Effect):
        name = "bench_tick"

        def forces(self, state):
            step["k"] = state.step
            acc[state.step]["_start"] = time.perf_counter()

    d = vfrs.Scene.load(SCENE).to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = level
    d["time"]["end"] = end
    scene = vfrs.Scene.from_dict(d)
    res = vfrs.run(scene, progress=False, effects=[Tick(None)] + [EFFECTS[n](p) for n, p in scene.effects.items()])
    active = np.asarray(res.history["active_pairs"])
    lines = [f"{level}, {end} s: ms per step (mean; the step's median in the last row)", "",
             "| part | steps with pairs | steps without |", "|---|---|---|"]
    cols = []
    for with_pairs in (True, False):
        ks = [k for k in range(2, len(active)) if (active[k] > 0) == with_pairs and "_end" in acc[k]]
        cols.append(ks)
    for _, _, label in parts:
        lines.append(f"| {label} | " + " | ".join(f"{np.mean([acc[k][label] for k in ks]) * 1e3:.2f}" if ks else "-"
                                                 for ks in cols) + " |")
    rest = [[acc[k]["_end"] - acc[k]["_start"] - sum(acc[k][p[2]] for p in parts) for k in ks] for ks in cols]
    lines.append("| the rest (loop, loads, HHT vector work, state sync) | "
                 + " | ".join(f"{np.mean(r) * 1e3:.2f}" if r else "-" for r in rest) + " |")
    lines.append("| step (median) | " + " | ".join(
        f"{np.median([acc[k]['_end'] - acc[k]['_start'] for k in ks]) * 1e3:.2f} ({len(ks)} steps)" if ks else "-"
        for ks in cols) + " |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", nargs="+", default=["coarse", "medium", "fine"])
    ap.add_argument("--methods", nargs="+", default=list(METHODS))
    ap.add_argument("--schemes", nargs="+", default=["mass_redistribution", "stabilized"],
                    help="dynamic contact schemes: each level and method runs with each (the default's cost "
                         "against the stabilized scheme's, measured in the same run)")
    ap.add_argument("--end", type=float, default=0.05, help="simulated time (s)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "m5"))
    ap.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    ap.add_argument("--breakdown", metavar="LEVEL", help="only: where one run's steps go, by part (--end: its length)")
    args = ap.parse_args(argv)
    if args.breakdown:
        print(breakdown(args.breakdown, args.end))
        return 0
    if args.child:
        print(json.dumps(one_run(args.child[0], args.child[1], float(args.child[2]), args.child[3])))
        return 0
    rows = []
    for level in args.levels:
        for method, scheme in ((m, sc) for m in args.methods for sc in args.schemes):
            cmd = [sys.executable, __file__, "--child", level, method, str(args.end), scheme]
            r = subprocess.run(cmd, capture_output=True, text=True, env=os.environ)
            if r.returncode != 0:
                print(r.stderr[-2000:], file=sys.stderr)
                raise SystemExit(f"{level} {method} {scheme} failed")
            row = json.loads(r.stdout.strip().splitlines()[-1])
            rows.append(row)
            print(f"{level:6s} {method:18s} {scheme:19s} dofs {row['free_dofs']:6d}  step with contact {row['step_contact_s'] * 1e3:7.2f} ms"
                  f" ({row['step_contact_s'] / row['solve_run_s']:.2f} solves), without {row['step_free_s'] * 1e3:6.2f} ms"
                  f" ({row['step_free_s'] / row['solve_run_s']:.2f}); solve in the run {row['solve_run_s'] * 1e3:.2f} ms,"
                  f" alone {row['solve_s'] * 1e3:.2f} ms (CHOLMOD "
                  f"{row['cholmod_solve_s'] * 1e3:.2f}, paired ratio {row['solve_vs_cholmod']:.2f}; one block "
                  f"{row['block_vs_cholmod']:.2f}x CHOLMOD's); run {row['total_s']:.1f} s; RSS {row['peak_rss_mb']:.0f} MB, compliance "
                  f"{row['compliance_mb']:.1f} MB", flush=True)
    fits = {}
    for method in args.methods:
        mine = [r for r in rows if r["method"] == method and r["scheme"] == args.schemes[0]]
        if len(mine) >= 2:
            x = np.log([r["free_dofs"] for r in mine])
            fits[method] = {k: float(np.polyfit(x, np.log([r[k] for r in mine]), 1)[0])
                            for k in ("step_mean_s", "step_contact_s", "solve_run_s", "solve_s")}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    (out / "bench_m5.json").write_text(json.dumps({"end_s": args.end, "rows": rows, "exponents": fits}, indent=1))
    lines = ["| level | method | scheme | free DOFs | step with contact (ms) | / the step's solve | step without (ms) | "
             "/ the step's solve | the step's solve (ms) | one solve alone (ms) | CHOLMOD alone (ms) | "
             "solve vfrs / CHOLMOD | block vfrs / CHOLMOD | run (s) | peak RSS (MB) | compliance (MB) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['level']} | {r['method']} | {r['scheme']} | {r['free_dofs']} | {r['step_contact_s'] * 1e3:.2f} | "
                     f"{r['step_contact_s'] / r['solve_run_s']:.2f} | {r['step_free_s'] * 1e3:.2f} | "
                     f"{r['step_free_s'] / r['solve_run_s']:.2f} | {r['solve_run_s'] * 1e3:.2f} | {r['solve_s'] * 1e3:.2f} | "
                     f"{r['cholmod_solve_s'] * 1e3:.2f} | "
                     f"{r['solve_vs_cholmod']:.2f} | {r['block_vs_cholmod']:.2f} | {r['total_s']:.1f} | {r['peak_rss_mb']:.0f} | "
                     f"{r['compliance_mb']:.1f} |")
    lines += ["", "Where the run's time goes (s, ``res.timings``; ``step`` includes ``solve`` and the effects' "
              "implicit hooks, ``contact`` the detection, the compliance columns, the LCPs and the recording):", "",
              "| level | method | scheme | steps with contact | compliance solves | step | solve | contact | flow | record "
              "| total |",
              "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        t = r["timings"]
        lines.append(f"| {r['level']} | {r['method']} | {r['scheme']} | {r['steps_with_contact']} | {r['compliance_solves']} | "
                     + " | ".join(f"{t.get(k, 0.0):.2f}" for k in ("step", "solve", "contact", "flow", "record", "total"))
                     + " |")
    if len(args.schemes) > 1:
        base = args.schemes[-1]
        lines += ["", f"Cost of a step with contact, each scheme over {base} (the same level and method, "
                  "measured in this run; per step and per its own solve):", "",
                  "| level | method | scheme | step with contact | in solves of its step |", "|---|---|---|---|---|"]
        for r in rows:
            if r["scheme"] == base:
                continue
            b = next((q for q in rows if (q["level"], q["method"], q["scheme"]) == (r["level"], r["method"], base)), None)
            if b is None:
                continue
            lines.append(f"| {r['level']} | {r['method']} | {r['scheme']} | {r['step_contact_s'] / b['step_contact_s']:.2f} | "
                         f"{(r['step_contact_s'] / r['solve_run_s']) / (b['step_contact_s'] / b['solve_run_s']):.2f} |")
    lines += ["", "Exponent of the cost per step against the free DOFs (log-log fit over the levels, "
              f"{args.schemes[0]}):", ""]
    for m, f in fits.items():
        lines.append(f"- {m}: mean step {f['step_mean_s']:.2f}, step with contact {f['step_contact_s']:.2f}, "
                     f"the step's solve {f['solve_run_s']:.2f}, one solve alone {f['solve_s']:.2f}")
    (out / "bench_m5.md").write_text("\n".join(lines) + "\n")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        for method in args.methods:
            mine = [r for r in rows if r["method"] == method and r["scheme"] == args.schemes[0]]
            ax.loglog([r["free_dofs"] for r in mine], [r["step_mean_s"] * 1e3 for r in mine], "o-", label=f"{method}: mean step")
        ref = [r for r in rows if r["method"] == args.methods[0] and r["scheme"] == args.schemes[0]]
        ax.loglog([r["free_dofs"] for r in ref], [r["solve_run_s"] * 1e3 for r in ref], "k--",
                  label="the step's K_eff solve")
        ax.set_xlabel("free DOFs")
        ax.set_ylabel("wall time per step (ms)")
        ax.set_title("M5 collision: cost per step vs mesh size")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(out / "cost_vs_dofs.png", dpi=110)
    except ImportError:
        pass
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
