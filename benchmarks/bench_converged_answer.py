"""What the steady main job's answer costs at 10 / 5 / 3 / 2 %: the cheapest setting, its wall
time and peak memory, and the same in CHOLMOD solves of its K_eff (a ratio that travels).

``python benchmarks/bench_converged_answer.py`` (the steady main job, examples/m5_steady.toml):

1. **Select** (no run): from the scene's committed converge studies, a mesh study (the
   systematic family's levels at the scene's step, ``--meshes``) and one or more step studies
   (level 0 at a ladder of steps, ``--steps``), every setting (mesh level i, step h) gets, for
   every smooth number of the summary, the error ``mesh part (level i, at the scene's step) +
   step part (step h, on level 0)`` against the extrapolated limit. The two parts are taken as
   additive and separable (the step part measured on level 0 is taken for every level; the
   mesh part measured at the scene's step for every step): an assumption, said in the results.
   A part that is only the band of an oscillatory or divergent study (not a GCI bound) is used
   as the estimate and the setting is marked "band". For each target, the cheapest setting
   (by its wall time) whose every smooth number is within it, or none; and for none, the
   setting closest to it and the numbers that keep it out.
2. **Measure** (``--levels``, a window of ``--window`` s of the main job per mesh level, each in
   a fresh process): wall time per step, peak RSS, and the solve of the run's K_eff by vfrs
   and by CHOLMOD (scikit-sparse; ``benchmarks/README.md`` says how to install it), timed
   interleaved in the same process: a setting's wall time is also given in CHOLMOD solves of
   its own K_eff, which a reader can time on any machine.

The smooth numbers: those the summary tags ``[smooth]`` (impulses, time means, band-limited
peaks; :data:`vfrs.summary.quantity.KINDS`) and the untagged means over the window's cycles (f0,
amplitude, quotients, contact duration: :data:`CYCLE_MEANS`). Extremes (one-step peaks, the
larger of two events) are not asked to converge. ``--over window`` keeps the numbers of the
limit cycle only (leaves out the first closure's transient).

Results: ``benchmarks/results/converged_answer/answer.json`` and ``answer.md``; each run
appends a line to ``history.csv`` (commit, date, target, setting, wall, memory, CHOLMOD ratio),
so the cost of the 3 % answer can be followed across commits.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_m5 import _paired  # noqa: E402  (timed interleaved, after warm-up runs)

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "m5_steady.toml"
STUDIES = ROOT / "examples" / "converge_results"
OUT = ROOT / "benchmarks" / "results" / "converged_answer"
TARGETS = (0.10, 0.05, 0.03, 0.02)

#: The summary's smooth numbers of the steady main job (tagged ``[smooth]``), by where they
#: are taken: over the limit cycle's window, or over the run (the first closure).
SMOOTH = {"phonation.mean_flow": "window", "contact.contact_impulse.right": "window",
          "contact.contact_impulse.left": "window", "contact.band_limited_peak_force": "window",
          "contact.band_limited_peak_sensor_pressure": "window", "contact.closed_phase_pressure": "window",
          "contact.first_closure_hump1_peak": "run", "contact.first_closure_hump2_peak": "run",
          "contact.first_closure_impulse": "run"}
#: Untagged numbers that are means over the window's cycles (``per_cycle`` in the summary).
CYCLE_MEANS = ("phonation.f0", "phonation.amplitude", "phonation.open_quotient", "phonation.closed_quotient",
               "contact.contact_duration", "contact.contact_quotient")


def smooth_numbers(over: str = "all") -> list:
    """The numbers a converged answer must hold: ``over`` "all", or "window" (the limit
    cycle's only)."""
    names = [q for q, o in SMOOTH.items() if over == "all" or o == over] + list(CYCLE_MEANS)
    return sorted(names)


# ------------------------------------------------------------------------------------------
# Select: the cheapest setting per target, from the committed studies
# ------------------------------------------------------------------------------------------

def _study(folder: Path) -> dict:
    return json.loads((folder / "converge.json").read_text())


def _errors(study: dict, axis: str) -> dict:
    """{(level, quantity): (relative, bound, value)} of a one-axis study (``axis`` "mesh" or
    "step": the level of that axis)."""
    key = "mesh_level" if axis == "mesh" else "step_level"
    out = {}
    for e in study["errors"]:
        rel = e["relative"]
        out[(e[key], e["quantity"])] = (math.nan if rel is None else float(rel), bool(e["bound"]), e["value"])
    return out


def _walls(study: dict, axis: str) -> dict:
    key = "mesh_level" if axis == "mesh" else "step_level"
    return {r[key]: (float(r["wall_time"]), float(r.get("peak_rss_mb") or math.nan)) for r in study["runs"]}


def settings(meshes: dict, steps: list, names: list, h0: float) -> list:
    """Every (mesh level, step) with its errors (one per name), whether all are bounds, and its
    wall time: the mesh study's at the scene's step ``h0`` (the one it ran at), else estimated
    as wall(i, h0) wall(0, h) / wall(0, h0), the ratio from the step study that ran h (its
    runs were timed in one sitting)."""
    mesh_err, mesh_wall = _errors(meshes, "mesh"), _walls(meshes, "mesh")
    by_h: dict = {}
    # At a step two ladders ran, the one reaching the finer steps: its limit is extrapolated
    # from finer runs (a ladder's coarsest rung gets Roache's coarse-grid GCI).
    for st in sorted(steps, key=lambda st: min(float(r["h"]) for r in st["steps"])):
        err, wall = _errors(st, "step"), _walls(st, "step")
        at_h0 = [r["index"] for r in st["steps"] if math.isclose(float(r["h"]), h0)]
        for rung in st["steps"]:
            j, h = rung["index"], float(rung["h"])
            if any(math.isclose(h, other) for other in by_h):
                continue
            # the cost of step h relative to the scene's step, within one study (one sitting's load)
            ratio = wall[j][0] / wall[at_h0[0]][0] if at_h0 else math.nan
            by_h[h] = {"parts": {q: err.get((j, q), (math.nan, False, None)) for q in names}, "ratio": ratio}
    rows = []
    for i, (w_i, rss_i) in sorted(mesh_wall.items()):
        for h, sp in sorted(by_h.items(), reverse=True):
            errs, bound = {}, True
            for q in names:
                em, bm, _ = mesh_err.get((i, q), (math.nan, False, None))
                es, bs, _ = sp["parts"][q]
                errs[q] = em + es
                bound = bound and bm and bs
            recorded = math.isclose(h, h0)
            wall = w_i * (1.0 if recorded else sp["ratio"])
            rows.append({"mesh_level": i, "step": h, "errors": errs, "worst": max(errs.values()),
                         "worst_number": max(errs, key=lambda q: errs[q]), "bound": bound,
                         "wall_s": wall, "wall_recorded": recorded, "peak_rss_mb": rss_i,
                         "dofs": meshes["meshes"][i]["dofs"]})
    return rows


def select(rows: list, targets=TARGETS) -> list:
    """Per target: the cheapest setting whose every number is within it (``setting``), or None
    with the closest one (the smallest worst error) and the numbers above the target there."""
    out = []
    for tol in targets:
        ok = [r for r in rows if r["worst"] <= tol]
        best = min(ok, key=lambda r: r["wall_s"]) if ok else None
        near = best or min(rows, key=lambda r: r["worst"])
        over = {q: e for q, e in near["errors"].items() if not e <= tol}
        out.append({"target": tol, "setting": _label(best) if best else None, "closest": _label(near),
                    "worst": near["worst"], "worst_number": near["worst_number"], "bound": near["bound"], "wall_s": near["wall_s"],
                    "wall_recorded": near["wall_recorded"], "peak_rss_mb": near["peak_rss_mb"],
                    "mesh_level": near["mesh_level"], "step": near["step"], "above_target": over,
                    "errors_there": near["errors"]})
    return out


def _label(r: dict) -> str:
    return f"level {r['mesh_level']}, {r['step'] * 1e6:.4g} us"


# ------------------------------------------------------------------------------------------
# Measure: a window of the main job per level, and CHOLMOD on its K_eff
# ------------------------------------------------------------------------------------------

def window_scene(scene: Path, level: int, end: float, lever: dict | None = None) -> dict:
    """The scene at mesh ``level`` run to ``end`` (s), without the limit-cycle ending and its
    study (the window measures the cost per step, not the answer); ``lever``: {"section.key":
    value} set on top (a lever's setting, e.g. {"contact.column_precision": "single"})."""
    import vfrs

    d = vfrs.Scene.load(scene).to_dict()
    for b in d["bodies"]:
        b["mesh"]["level"] = level
    d["time"]["end"] = end
    for k in ("until", "until_cycles", "until_cap", "errors_from"):
        d["output"].pop(k, None)
    for key, value in (lever or {}).items():
        section, name = key.split(".", 1)
        d.setdefault(section, {})[name] = value
    return d


def measure_level(scene: Path, level: int, end: float, repeat: int = 3, lever: dict | None = None) -> dict:
    """One window of the scene at ``level`` in this process: wall, steps, peak RSS, timings,
    then the factor and the solve of its K_eff by vfrs and by CHOLMOD, interleaved."""
    import warnings

    import vfrs
    from vfrs.effects import EFFECTS, Effect
    from vfrs.linalg import cholesky

    warnings.simplefilter("ignore")
    sc = vfrs.Scene.from_dict(window_scene(scene, level, end, lever))

    class Keep(Effect):
        name = "bench_keep"

        def setup(self, ctx):
            self.ctx = ctx

    keep = Keep(None)
    effects = [EFFECTS[name](params) for name, params in sc.effects.items()]
    t0 = time.perf_counter()
    res = vfrs.run(sc, progress=False, effects=effects + [keep])
    wall = time.perf_counter() - t0
    out = {"level": level, "end_s": end, "wall_s": wall, "steps": len(res.t) - 1,
           "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
           "timings": {k: float(v) for k, v in res.timings.items()}, "free_dofs": int(keep.ctx.factor.n)}
    out["step_s"] = out["timings"]["step"] / out["steps"]
    A = keep.ctx.effective_matrix.tocsc()
    b = np.random.default_rng(0).standard_normal(A.shape[0])
    F = keep.ctx.factor
    fns = [lambda: cholesky(A, blocks=True), lambda: F.solve(b)]
    try:
        from sksparse.cholmod import cholesky as cholmod

        C = cholmod(A)
        fns += [lambda: cholmod(A), lambda: C(b)]
        x, xc = F.solve(b), C(b)
        out["solution_difference"] = float(np.abs(x - xc).max() / np.abs(xc).max())
    except ImportError:
        out["cholmod"] = "not installed (benchmarks/README.md: how to install scikit-sparse)"
    tf = _paired(fns[0::2], repeat)
    ts = _paired(fns[1::2], 10 * repeat)
    out["factor_s"], out["solve_s"] = float(np.median(tf[0])), float(np.median(ts[0]))
    if len(fns) == 4:
        out["cholmod_factor_s"], out["cholmod_solve_s"] = float(np.median(tf[1])), float(np.median(ts[1]))
        out["factor_vs_cholmod"] = float(np.median(tf[0] / tf[1]))
        out["solve_vs_cholmod"] = float(np.median(ts[0] / ts[1]))
    return out


def _child(scene: Path, level: int, end: float, lever: dict) -> dict:
    """:func:`measure_level` in a fresh process (its peak RSS its own)."""
    env = dict(os.environ)
    cmd = [sys.executable, __file__, "--child", str(level), "--window", repr(end), "--scene", str(scene),
           "--lever", json.dumps(lever)]
    done = subprocess.run(cmd, capture_output=True, text=True, env=env, check=False)
    if done.returncode != 0:
        return {"level": level, "status": "failed", "stderr": done.stderr[-2000:]}
    return {**json.loads(done.stdout.strip().splitlines()[-1]), "status": "ok"}


# ------------------------------------------------------------------------------------------
# The report
# ------------------------------------------------------------------------------------------

def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _machine() -> dict:
    model = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return {"cpu": model, "cores": os.cpu_count(), "load_average": list(os.getloadavg())}


def answer(scene: Path, meshes: Path, steps: list, over: str) -> dict:
    """The selection (no run) of the scene's committed studies."""
    import vfrs

    h0 = float(vfrs.Scene.load(scene).to_dict()["time"]["step"])
    studies = [_study(meshes)] + [_study(s) for s in steps]
    names = [q for q in smooth_numbers(over) if _has_value(studies, q)]
    rows = settings(studies[0], studies[1:], names, h0)
    cycle = [q for q in smooth_numbers("window") if q in names]
    limit_cycle = select(settings(studies[0], studies[1:], cycle, h0)) if over == "all" else None
    return {"limit_cycle_answers": limit_cycle, "scene": _rel(scene), "meshes_study": _rel(meshes), "step_studies": [_rel(s) for s in steps],
            "scene_step": h0, "over": over, "numbers": names,
            "no_value": [q for q in smooth_numbers(over) if q not in names],
            "run_end_s": _run_ends(meshes, studies[0]), "settings": rows, "answers": select(rows)}


def _has_value(studies: list, name: str) -> bool:
    """Whether some run of the studies has a value of ``name`` (the first closure's second hump
    has none on the main job: it closes in one hump)."""
    return any(e["quantity"] == name and e["value"] is not None for st in studies for e in st["errors"])


def _run_ends(meshes: Path, study: dict) -> dict:
    """{mesh level: simulated time the run ended at (s)} of the mesh study in ``meshes`` (its
    converge.json read as ``study``; its runs end when their last cycles repeat: a finer mesh
    may need more cycles)."""
    ids = {r["id"]: r["mesh_level"] for r in study["runs"]}
    with open(meshes / "summary.csv", newline="") as fh:
        return {ids[r["id"]]: float(r["run.t_end [s]"]) for r in csv.DictReader(fh) if r["id"] in ids}


def _rel(p: Path) -> str:
    try:
        return str(Path(p).resolve().relative_to(ROOT))
    except ValueError:
        return str(p)


def cost_now(res: dict, measured: list) -> None:
    """Adds to each answer its wall time projected on this machine now, from the window
    measured at its level: set-up + (its run's steps) x (the window's cost per step), and its
    wall in CHOLMOD solves of that level's K_eff (recorded and projected)."""
    by_level = {m["level"]: m for m in measured if m.get("status") == "ok"}
    for a in res["answers"] + (res.get("limit_cycle_answers") or []):
        m = by_level.get(a["mesh_level"])
        if m is None:
            continue
        steps = res["run_end_s"][a["mesh_level"]] / a["step"]
        setup = m["wall_s"] - m["timings"]["step"]
        a["wall_now_s"] = setup + steps * m["step_s"]
        a["run_steps"] = round(steps)
        if "cholmod_solve_s" in m:
            a["cholmod_solve_s"] = m["cholmod_solve_s"]
            a["wall_in_cholmod_solves"] = a["wall_s"] / m["cholmod_solve_s"]
            a["wall_now_in_cholmod_solves"] = a["wall_now_s"] / m["cholmod_solve_s"]


def markdown(res: dict) -> str:
    lines = [f"# The cost of a converged answer: {res['scene']}"
             + (f" (lever: {_lever_name(res['lever'])})" if res.get("lever") else ""), "",
             f"At {res['commit'][:10]} on {res['date']}, {res['machine']['cpu']} ({res['machine']['cores']} cores, "
             f"load {', '.join(f'{x:.2f}' for x in res['machine']['load_average'])} at the start). Studies: "
             f"{res['meshes_study']} (mesh) and {', '.join(res['step_studies'])} (step). Error of a setting = mesh "
             "part (its level, at the scene's step) + step part (its step, on level 0): assumed additive and "
             "separable. Numbers (smooth, " + ("every one" if res["over"] == "all" else "the limit cycle's")
             + "): " + ", ".join(res["numbers"]) + "."
             + (f" No value on any run: {', '.join(res['no_value'])}." if res["no_value"] else ""), "",
             ] + _answer_table(res["answers"])
    if res.get("limit_cycle_answers"):
        lines += ["", "The limit cycle's smooth numbers only (the first closure's left out):", ""]
        lines += _answer_table(res["limit_cycle_answers"])
    lines += ["", "Each number's error (mesh part + step part) at the scene's step, per level (band: an oscillatory or "
              "divergent study's band, not a bound):", "", "| number | " + " | ".join(
                  f"level {r['mesh_level']}" for r in _at_step(res)) + " |", "|---|" + "---|" * len(_at_step(res))]
    for q in res["numbers"]:
        lines.append(f"| {q} | " + " | ".join(f"{r['errors'][q]:.1%}" for r in _at_step(res)) + " |")
    lines += ["", "Windows measured here (each level of the main job to the window's end, a fresh process; K_eff "
              "factored and solved by vfrs and by CHOLMOD, interleaved):", "",
              "| level | free DOFs | window | wall | per step | solve (vfrs) | solve (CHOLMOD) | vfrs/CHOLMOD solve | "
              "factor (vfrs) | factor (CHOLMOD) | vfrs/CHOLMOD factor | peak RSS |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for m in res["measured"]:
        if m.get("status") != "ok":
            lines.append(f"| {m['level']} | failed | | | | | | | | | | |")
            continue
        lines.append(f"| {m['level']} | {m['free_dofs']:,} | {m['end_s'] * 1e3:.0f} ms | {m['wall_s']:.1f} s | "
                     f"{m['step_s'] * 1e3:.1f} ms | {m['solve_s'] * 1e3:.2f} ms | {m.get('cholmod_solve_s', math.nan) * 1e3:.2f} ms"
                     f" | {m.get('solve_vs_cholmod', math.nan):.2f} | {m['factor_s']:.2f} s | "
                     f"{m.get('cholmod_factor_s', math.nan):.2f} s | {m.get('factor_vs_cholmod', math.nan):.2f} | "
                     f"{m['peak_rss_mb']:.0f} MB |")
    return "\n".join(lines) + "\n"


def _answer_table(answers: list) -> list:
    lines = ["| target | cheapest setting within it | closest setting | its worst error (number) | bound? | wall "
             "(study) | wall (this machine, projected) | in CHOLMOD solves | peak RSS (study, end of run) |",
             "|---|---|---|---|---|---|---|---|---|"]
    for a in answers:
        lines.append(f"| {a['target']:.0%} | {a['setting'] or 'none'} | {a['closest']} | {a['worst']:.1%} ({a['worst_number']}) | "
                     f"{'yes' if a['bound'] else 'band'} | {a['wall_s']:.0f} s{'' if a['wall_recorded'] else ' (est.)'}"
                     f" | {a.get('wall_now_s', math.nan):.0f} s | {a.get('wall_now_in_cholmod_solves', math.nan):.3g} | "
                     f"{a['peak_rss_mb']:.0f} MB |")
    lines += ["", "Above the target at the closest setting:", ""]
    for a in answers:
        lines.append(f"- {a['target']:.0%}: " + (", ".join(f"{q} {e:.1%}" for q, e in sorted(
            a["above_target"].items(), key=lambda kv: -kv[1] if kv[1] == kv[1] else 0)) or "none"))
    return lines


def _at_step(res: dict) -> list:
    """The settings at the scene's own step, coarsest level first."""
    return [r for r in res["settings"] if math.isclose(r["step"], res["scene_step"])]


HISTORY_FIELDS = ("commit", "date", "target", "setting", "closest", "worst", "wall_s", "wall_now_s",
                  "wall_now_in_cholmod_solves", "peak_rss_mb", "over", "lever")


def _lever_name(lever: dict) -> str:
    """``contact.column_precision=single`` for {"contact.column_precision": "single"}; "" for none."""
    return "+".join(f"{k}={v}" for k, v in sorted(lever.items()))


def append_history(res: dict, path: Path) -> None:
    """One row per target of ``res`` appended to the history (a file with fewer columns is
    rewritten with the new ones first, its rows' new columns empty)."""
    rows = []
    if path.exists():
        with open(path, newline="") as fh:
            rows = list(csv.DictReader(fh))
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=HISTORY_FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k) or "" for k in HISTORY_FIELDS})
        for a in res["answers"]:
            w.writerow({"commit": res["commit"][:10], "date": res["date"], "target": a["target"],
                        "setting": a["setting"] or "none", "closest": a["closest"], "worst": f"{a['worst']:.4g}",
                        "wall_s": f"{a['wall_s']:.1f}", "wall_now_s": f"{a.get('wall_now_s', math.nan):.1f}",
                        "wall_now_in_cholmod_solves": f"{a.get('wall_now_in_cholmod_solves', math.nan):.4g}",
                        "peak_rss_mb": f"{a['peak_rss_mb']:.0f}", "over": res["over"],
                        "lever": _lever_name(res["lever"])})


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", type=Path, default=SCENE)
    ap.add_argument("--meshes", type=Path, default=STUDIES / "m5_steady_meshes", help="the mesh study")
    ap.add_argument("--steps", type=Path, nargs="+", default=None, help="step studies (level 0)")
    ap.add_argument("--over", choices=("all", "window"), default="all",
                    help="all: every smooth number; window: the limit cycle's only")
    ap.add_argument("--levels", type=int, nargs="*", default=[0, 1, 2], help="levels to measure a window of")
    ap.add_argument("--window", type=float, default=0.02, help="simulated seconds per measured window")
    ap.add_argument("--select-only", action="store_true", help="no run: the selection from the studies")
    ap.add_argument("--lever", default="{}", help='a lever\'s scene setting on the measured windows, as JSON, '
                    'e.g. \'{"contact.column_precision": "single"}\' (results: answer_<lever>.json)')
    ap.add_argument("--child", type=int, default=None, help=argparse.SUPPRESS)
    ap.add_argument("-o", "--out", type=Path, default=OUT)
    args = ap.parse_args(argv)
    if args.child is not None:
        print(json.dumps(measure_level(args.scene, args.child, args.window, lever=json.loads(args.lever))))
        return 0
    steps = args.steps or sorted(p for p in STUDIES.glob("m5_steady_steps*") if (p / "converge.json").exists())
    res = answer(args.scene, args.meshes, steps, args.over)
    res.update(commit=_commit(), date=datetime.date.today().isoformat(), machine=_machine(), window_s=args.window)
    res["lever"] = json.loads(args.lever)
    res["measured"] = [] if args.select_only else [_child(args.scene, lv, args.window, res["lever"]) for lv in args.levels]
    for m in res["measured"]:
        print(f"level {m['level']}: " + (f"{m['wall_s']:.1f} s, {m['peak_rss_mb']:.0f} MB, solve vs CHOLMOD "
                                          f"{m.get('solve_vs_cholmod', math.nan):.2f}" if m["status"] == "ok"
                                          else m["stderr"]), flush=True)
    cost_now(res, res["measured"])
    res["machine"]["load_average_end"] = list(os.getloadavg())
    text = markdown(res)
    print(text)
    if not args.select_only:
        args.out.mkdir(parents=True, exist_ok=True)
        stem = "answer" + ("_" + _lever_name(res["lever"]).replace(".", "_").replace("=", "_") if res["lever"] else "")
        (args.out / f"{stem}.json").write_text(json.dumps(res, indent=1, default=float) + "\n")
        (args.out / f"{stem}.md").write_text(text)
        append_history(res, args.out / "history.csv")
    return 0


if __name__ == "__main__":
    sys.exit(main())
