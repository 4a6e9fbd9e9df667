"""Where the steady main job's memory goes at the end of a run, and what the compliance-column
cap buys.

``python benchmarks/bench_memory.py`` runs the main job (examples/m5_steady.toml: two M5 folds
of the systematic mesh family, Bernoulli flow, Lagrange contact, 50 us steps) to ``--end``
(default 100 ms, its open end removed) on mesh levels 0, 1 and 2, each run in a fresh process
(so its peak memory is its own), and reports per run:

- the wall time, the steps, the peak RSS (``ru_maxrss``), the RSS once the run is set up and
  every 10 ms of simulated time;
- at the last step, what holds the memory (the census, :func:`census`): the factor of K_eff
  (the bytes of its values, 8 nnz(L), and all it keeps, measured after the run as the RSS a
  second factorization of the same matrix keeps), the sparse matrices (K, M, K_eff, ... by
  name, and the node-blocked copies the products keep in Rust, counted from their CSR), the
  compliance columns (the bytes actually stored over their blocks, their count and the cap;
  the observed rows; S), the history, the field snapshots, every other array or Python object
  reachable from the run, the interpreter and its libraries (the RSS before the run), the
  memory freed but kept by the allocator (what ``malloc_trim`` gives back) and what is left:
  unaccounted = RSS - the sum;
- which of the stored columns a product ever read (the rest were prefetched around the
  contact zone and never loaded).

Then the lever: the same run with the compliance columns capped lower (``[contact]
column_memory``, ``--caps``): wall time, peak RSS, the products done as a solve instead
(fallback solves), and the largest difference of every recorded series against the run with
the scene's cap (max |capped - default| over max |default|, per series).

``--levels 0 --end 0.005 --caps none`` is the small run tests/test_bench_memory.py repeats;
``--report`` writes memory.md again from memory.json.
Results: ``benchmarks/results/converged_answer/memory.json`` and ``memory.md`` (a run replaces
the rows of the same level, end and cap; the others are kept). Wall times are the machine's
(its model and the load average before and after each run are recorded); the bytes are the code's.
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import os
import resource
import subprocess
import sys
import time
import types
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "m5_steady.toml"
OUT = ROOT / "benchmarks" / "results" / "converged_answer"
MB = 2.0**20
THREADS = ("RAYON_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
#: Series of the solver's work and diagnostics, not the answer: they may differ under another cap.
BOOKKEEPING = ("compliance_solves", "condition", "iterations", "detections", "augmentations", "contact_settled",
               "contact_converged")
#: Series that are zero to round-off on every run (docs: "maximum penetration 0 mm on every run").
ROUNDOFF = ("max_penetration", "intersection_volume")
#: The motion's series: what the folds do, whichever pairs carry the contact force.
MOTION = ("glottal_area", "flow_rate", "kinetic_energy", "elastic_energy", "external_work", "min_gap")
#: Right-hand sides per block solve of the compliance (``Compliance.chunk``'s default).
CHUNK = 64


def _status_mb(key: str) -> float:
    """``VmRSS`` / ``VmHWM`` of this process (MB), from /proc/self/status."""
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def _peak_mb() -> float:
    """The peak RSS of this process so far (MB, ``ru_maxrss``; since the last :func:`_reset_peak`)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _reset_peak() -> bool:
    """Resets the peak RSS to the current RSS (Linux: ``/proc/self/clear_refs``), so that the
    census's own work does not count in the run's peak."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


def _trim() -> bool:
    """Gives the allocator's free pages back to the system (glibc ``malloc_trim``)."""
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
        return True
    except (OSError, AttributeError):
        return False


def scene_dict(level: int, end: float, column_memory: float | None = None) -> dict:
    """The main job on mesh ``level`` to ``end`` (its open end and error study removed)."""
    import vfrs

    d = vfrs.Scene.load(SCENE).to_dict()
    d["time"]["end"] = end
    for key in ("until", "until_cycles", "until_cap", "errors_from"):
        d["output"].pop(key, None)
    for b in d["bodies"]:
        b["mesh"]["level"] = level
    if column_memory is not None:
        d["contact"]["column_memory"] = column_memory
    return d


_SKIP = (type, types.ModuleType, types.FunctionType, types.BuiltinFunctionType, types.CodeType, types.FrameType)


class Walk:
    """Bytes reachable from named roots, each array's data and each object counted once (under
    the first root that reaches it): ``sys.getsizeof`` of every object, the data of every
    array's base (``sizes`` overrides it: a store allocated large whose pages are only partly
    written). Functions, classes and modules are not entered (their globals reach everything)."""

    def __init__(self, sizes: dict | None = None):
        self.seen: set = set()
        self.sizes = dict(sizes or {})
        self.by_root: dict = {}
        self.big: list = []  # (MB, path) of arrays of 1 MB or more
        self.matrices: list = []  # (name, MB) of scipy sparse matrices
        self.rust: dict = {}  # type name -> count of objects whose memory Python cannot see
        self.products: list = []  # (path, estimated MB) of node-blocked products kept in Rust

    def skip(self, *objs) -> None:
        self.seen.update(id(o) for o in objs)

    def root(self, label: str, obj, path: str | None = None) -> float:
        """Adds what ``obj`` reaches (not yet counted) under ``label``; returns it (MB)."""
        import scipy.sparse as sp

        from vfrs.linalg import Product

        total = 0
        stack = [(obj, path or label)]
        while stack:
            o, p = stack.pop()
            if id(o) in self.seen or isinstance(o, _SKIP):
                continue
            self.seen.add(id(o))
            if isinstance(o, np.ndarray):
                base = _base(o)
                total += sys.getsizeof(o) - (o.nbytes if o.flags.owndata else 0)
                if ("buf", id(base)) not in self.seen:
                    self.seen.add(("buf", id(base)))
                    n = self.sizes.get(id(base), base.nbytes)
                    total += n
                    if n >= MB:
                        self.big.append((n / MB, p))
                continue
            total += sys.getsizeof(o)
            if sp.issparse(o):  # the bytes of its arrays not counted yet (a matrix may share another's)
                bases = {id(b): b for b in map(_base, (o.data, o.indices, o.indptr)) if ("buf", id(b)) not in self.seen}
                self.matrices.append((p, sum(b.nbytes for b in bases.values()) / MB))
            if isinstance(o, Product) and o._rust is not None:
                self.products.append((p, _blocked_bytes(o.matrix) / MB))
            if type(o).__module__.startswith("vfrs._core"):
                self.rust[type(o).__name__] = self.rust.get(type(o).__name__, 0) + 1
            if isinstance(o, types.MethodType):
                stack.append((o.__self__, p))
            elif isinstance(o, dict):
                stack.extend((v, f"{p}.{k}" if isinstance(k, str) else f"{p}[{k!r}]") for k, v in o.items())
                stack.extend((k, p) for k in o if not isinstance(k, str))
            elif hasattr(o, "__dict__") and not isinstance(o, (list, tuple, set, frozenset)):
                stack.append((vars(o), p))
                stack.extend((getattr(o, s), f"{p}.{s}") for s in getattr(type(o), "__slots__", ()) if hasattr(o, s))
            else:
                stack.extend((c, p + "[]") for c in gc.get_referents(o))
        mb = total / MB
        self.by_root[label] = self.by_root.get(label, 0.0) + mb
        return mb

    def leftovers(self) -> float:
        """Arrays no root reached that a live object holds (found through the collector)."""
        found = []
        for o in gc.get_objects():  # frames too: the march's own arrays
            if id(o) in self.seen or isinstance(o, _SKIP[:-1]):
                continue
            for c in gc.get_referents(o):
                if isinstance(c, np.ndarray) and id(c) not in self.seen:
                    found.append((c, f"<{type(o).__name__}>"))
        total = 0.0
        for a, p in found:
            total += self.root("other live arrays (found by the collector)", a, p)
        return total


def _base(a: np.ndarray) -> np.ndarray:
    """The array that owns ``a``'s data (``a`` itself, or the base of its views)."""
    while isinstance(a.base, np.ndarray):
        a = a.base
    return a


def _assembler_bytes(mesh) -> int:
    """Bytes of the Rust assembler of a P1 mesh (``vfrs_core::fem::Assembler``: its DOF
    pattern, usize row indices and column pointers; the node adjacency; the elements around
    each node, (usize, u8) pairs; the tets, four usize each), counted from the mesh."""
    n, n_el = mesh.n_points, len(mesh.tets)
    nnz = len(mesh._pattern_arrays[1])
    return 8 * nnz + 8 * (3 * n + 1) + 8 * (nnz // 9 + n + 1) + 16 * (4 * n_el) + 8 * (n + 1) + 32 * n_el


def _blocked_bytes(A) -> int:
    """Bytes of the Rust copy :class:`vfrs.linalg.Product` keeps of ``A``
    (``vfrs_core::linalg::spmv::Blocked``): full 3 x 3 blocks (nine f64 values and a u32 block
    column each) or, for ``m (x) I_3``, one f64 value and a u32 column per node pair; a usize
    pointer per node row."""
    A = A.tocsr()
    rows = np.repeat(np.arange(A.shape[0] // 3), np.diff(A.indptr).reshape(-1, 3).sum(axis=1))
    blocks = np.unique(rows.astype(np.int64) * (A.shape[1] // 3) + A.indices // 3).size if A.nnz else 0
    ptr = 8 * (A.shape[0] // 3 + 1)
    if A.nnz == 9 * blocks:
        return 9 * 8 * blocks + 4 * blocks + ptr
    return 12 * (A.nnz // 3) + ptr


def _compliance_parts(c) -> dict:
    """The compliance store's parts (bytes as :attr:`Compliance.nbytes` counts them) and counts;
    ``cap_columns``: per block, how many of its columns the cap holds were they all the block's
    (the cap is over all blocks together)."""
    stored = int(c._stored_bytes())
    observed_rows = int(sum(8 * n * X.shape[1] for X, n in zip(c._Xb, c._X_count)))
    rows = [F.shape[1] for F in c._F]
    return {
        "contact_dofs": int(c.size), "observed_dofs": 0 if c.observed is None else int(len(c.observed)),
        "stored_columns": int(sum(c._F_count)), "stored_per_block": [int(n) for n in c._F_count],
        "block_rows": [int(r) for r in rows],
        "cap_mib": None if c.max_bytes is None else c.max_bytes / MB,
        "cap_columns": None if c.max_bytes is None else [int(c.max_bytes // (8 * r)) for r in rows],
        "capped": bool(c.capped), "fallback_solves": int(c.fallback_solves), "column_solves": int(c.solves),
        "stored_mb": stored / MB, "observed_rows_mb": observed_rows / MB, "S_mb": c._S.nbytes / MB,
        "nbytes_mb": c.nbytes / MB, "S_capacity": int(c._S.shape[0]),
    }


def _touched(c) -> dict:
    """The compliance's stores as resident bytes (id of the array -> bytes): the stores are
    allocated for every observed DOF and only the rows of stored columns are ever written."""
    sizes = {id(F): 8 * n * F.shape[1] for F, n in zip(c._F, c._F_count)}
    sizes.update({id(X): 8 * n * X.shape[1] for X, n in zip(c._Xb, c._X_count)})
    return sizes


def census(ctx, state, effects) -> dict:
    """What holds the memory of the run at this point (called at its last step)."""
    from vfrs.dynamics.integrators import Integrator
    from vfrs.history import Recorder

    rss, hwm = _status_mb("VmRSS"), _status_mb("VmHWM")
    trimmed = _trim()
    rss_trimmed = _status_mb("VmRSS")
    contact = next(e for e in effects if e.name == "contact")
    live = gc.get_objects()  # this run's integrator and recorder (a test's process may hold others)
    integ = next(o for o in live if isinstance(o, Integrator) and o.factor is ctx.factor)
    rec = next(o for o in live if isinstance(o, Recorder) and any(e is contact for e in o.effects))
    del live
    c = contact.solver.compliance
    walk = Walk(_touched(c))
    factors = [ctx.factor] + list(getattr(ctx.factor, "factors", []))
    mass = getattr(ctx.mass, "_factor", None)
    walk.skip(*factors, *([mass] if mass is not None else []))  # their memory: measured after the run
    walk.root("compliance of K_eff (columns, observed rows, S)", contact.solver.compliance, "compliance")
    walk.root("history (per-step lists)", rec.history, "history")
    walk.root("history (per-step lists)", rec.probes, "probes")
    walk.root("field snapshots", rec.snapshots, "snapshots")
    walk.root("problem (K, M, C, their free parts, meshes)", ctx.problem, "problem")
    walk.root("integrator (HHT: M, K, K_eff, work vectors)", integ, "integrator")
    walk.root("setup context", ctx, "ctx")
    walk.root("recorder (rest)", rec, "recorder")
    walk.root("state", state, "state")
    for e in effects:
        walk.root(f"effect {e.name}", e, e.name)
    walk.leftovers()
    meshes = [b.mesh for b in ctx.problem.bodies]
    return {
        "t": float(state.t), "rss_mb": rss, "rss_trimmed_mb": rss_trimmed if trimmed else None,
        "hwm_mb": hwm,
        "by_root_mb": walk.by_root,
        "matrices_mb": sorted(walk.matrices, key=lambda x: -x[1]),
        "rust_products_mb": sorted(walk.products, key=lambda x: -x[1]),
        "rust_assemblers_mb": sum(_assembler_bytes(m) for m in meshes if m._assembler is not None) / MB,
        "rss_anon_mb": _status_mb("RssAnon"), "rss_file_mb": _status_mb("RssFile"),
        "rust_objects": walk.rust,
        "big_arrays_mb": sorted(walk.big, key=lambda x: -x[0])[:25],
        "compliance": _compliance_parts(c),
        "factor": {"nnz_factor": int(ctx.factor.nnz_factor),
                   "nnz_factor_lower": int(sum(f.nnz_factor_lower for f in factors[1:] or factors)),
                   "values_mb": 8 * ctx.factor.nnz_factor / MB,
                   "mass_factor_values_mb": None if mass is None else 8 * mass.nnz_factor / MB},
    }


def _measure_factor(A) -> tuple:
    """RSS (MB) a second factorization of ``A`` keeps, as the run's (blocks, default ordering):
    its values, indices, symbolic analysis, plan and workspaces, and the Python side's arrays."""
    from vfrs.linalg import cholesky

    if not _trim():
        return None, None
    before = _status_mb("VmRSS")
    F = cholesky(A, blocks=True)
    for f in getattr(F, "factors", [F]):  # the solve's workspace as a compliance's chunks grow it
        f.unit_columns(np.arange(CHUNK))
        f.solve(np.ones(f.n))
    _trim()
    kept = _status_mb("VmRSS") - before
    return kept, int(F.nnz_factor)


def one_run(level: int, end: float, column_memory: float | None = None, history: str | None = None,
            measure_factor: bool = True) -> dict:
    """One run of the main job, measured (called in a child process: the peak RSS is its own)."""
    import warnings

    import vfrs
    from vfrs.effects import EFFECTS, Effect

    rss_import = {k: _status_mb(k) for k in ("VmRSS", "RssAnon", "RssFile")}
    scene = vfrs.Scene.from_dict(scene_dict(level, end, column_memory))
    every = scene.output.every

    class Census(Effect):
        """The RSS every ``[output] every`` steps, what the products load, and the census at
        the run's last step."""

        name = "bench_census"

        def setup(self, ctx):
            self.ctx = ctx
            self.timeline = [(0.0, _status_mb("VmRSS"), _status_mb("VmHWM"), 0, 0.0)]
            self.result = None
            comp = contact.solver.compliance
            self.loaded: set = set()
            solve = comp.solve

            def watched(b):
                B = np.asarray(b).reshape(len(b), -1)
                self.loaded.update(comp.free[np.flatnonzero(np.any(B != 0.0, axis=1))].tolist())
                return solve(b)

            comp.solve = watched

        def record(self, state, history):
            if state.step % every == 0 and state.step:
                comp = contact.solver.compliance
                self.timeline.append((float(state.t), _status_mb("VmRSS"), _status_mb("VmHWM"), int(comp.size),
                                      comp._stored_bytes() / MB))
            if state.t >= end - 0.5 * self.ctx.constants.h:
                self.peak_march = _peak_mb()
                self.result = census(self.ctx, state, effects)
                _trim()
                self.reset = _reset_peak()

    effects = [EFFECTS[name](params) for name, params in scene.effects.items()]
    contact = next(e for e in effects if e.name == "contact")
    probe = Census(None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        t0 = time.perf_counter()
        res = vfrs.run(scene, progress=False, effects=effects + [probe])
        wall = time.perf_counter() - t0
    # The run's peak: the march's (before the census) or, when the census's own memory could
    # be left out of it, what came after (the history's arrays, the summary), if more.
    peak = max(probe.peak_march, _peak_mb()) if probe.reset else _peak_mb()
    rss_after = _status_mb("VmRSS")
    h = res.history
    comp = contact.solver.compliance
    stored = comp.dofs[comp.slot_of[comp.dofs] >= 0]
    out = {
        "level": level, "end_s": end, "column_memory_mib": float(contact.params.common.column_memory),
        "default_cap": column_memory is None,
        "free_dofs": int(probe.ctx.factor.n), "steps": int(len(h["t"]) - 1),
        "steps_with_contact": int((np.asarray(h["active_pairs"])[1:] > 0).sum()),
        "wall_s": wall, "timings": {k: float(v) for k, v in res.timings.items()},
        "peak_rss_mb": peak, "peak_march_mb": probe.peak_march, "peak_without_census": probe.reset,
        "rss_import_mb": rss_import, "rss_after_run_mb": rss_after,
        "timeline": probe.timeline, "census": probe.result,
        "loaded_columns": len(probe.loaded), "stored_and_loaded": int(np.isin(stored, list(probe.loaded)).sum()),
        "warnings": sorted({f"{w.category.__name__}: {str(w.message)[:160]}" for w in caught}),
        "threads": {k: os.environ.get(k) for k in THREADS},
    }
    if history:
        np.savez(history, **{k: np.asarray(v, dtype=float) for k, v in h.items() if np.asarray(v).dtype != object})
    if measure_factor:
        out["factor_kept_mb"], nnz = _measure_factor(probe.ctx.effective_matrix)
        out["factor_kept_same_nnz"] = nnz == out["census"]["factor"]["nnz_factor"]
    return out


def compare(path: str, base: str) -> dict:
    """Every recorded series of a capped run against the default cap's: per series
    max |a - b| / max |b| (0 where both are zero); the largest over the answer's series (all but
    the work counts, the series that are zero to round-off and the nodes and positions of a
    maximum, which are given apart: at how many steps they differ) and over the motion's."""
    a, b = np.load(path), np.load(base)
    diffs, identical, missing = {}, 0, sorted(set(a.files) ^ set(b.files))
    for k in sorted(set(a.files) & set(b.files)):
        x, y = a[k], b[k]
        if x.shape != y.shape:
            diffs[k] = float("inf")
            continue
        identical += bool(np.array_equal(x, y, equal_nan=True))
        scale = np.nanmax(np.abs(y)) if y.size else 0.0
        d = np.nanmax(np.abs(x - y)) if y.size else 0.0
        diffs[k] = float(d / scale) if scale > 0 else (0.0 if d == 0 else float("inf"))
    where = {k for k in diffs if k.endswith(("_node", "_position"))}
    answer = {k: v for k, v in diffs.items() if k not in BOOKKEEPING + ROUNDOFF and k not in where}
    worst = max(answer, key=answer.__getitem__) if answer else None
    motion = [diffs[k] for k in MOTION if k in diffs]
    return {"series": len(diffs), "identical": identical, "missing": missing,
            "max_rel_diff": answer[worst] if worst else 0.0, "worst_series": worst,
            "motion_max_rel_diff": max(motion) if motion else None,
            "largest": sorted(answer.items(), key=lambda kv: -kv[1])[:8],
            "where_steps_differ": {k: int((np.abs(a[k] - b[k]) > 1e-9 * np.abs(b[k]).max()).reshape(len(b[k]), -1)
                                          .any(axis=1).sum()) for k in sorted(where) if a[k].shape == b[k].shape},
            "roundoff_abs_diff": {k: float(np.nanmax(np.abs(a[k] - b[k]))) for k in ROUNDOFF if k in diffs},
            "bookkeeping": {k: diffs[k] for k in BOOKKEEPING if k in diffs}}


def breakdown(r: dict) -> dict:
    """The run's memory at its last step by kind (MB), unaccounted = RSS - the sum."""
    c = r["census"]
    roots = dict(c["by_root_mb"])
    comp = c["compliance"]
    matrices = sum(mb for _, mb in c["matrices_mb"])
    compliance_walk = roots.pop("compliance of K_eff (columns, observed rows, S)", 0.0)
    parts = {
        "libraries mapped from files (RssFile)": c["rss_file_mb"],
        "interpreter heap at import (RssAnon)": r["rss_import_mb"]["RssAnon"],
        "factor of K_eff (all it keeps, measured)": r.get("factor_kept_mb") or c["factor"]["values_mb"],
        "sparse matrices (scipy)": matrices,
        "Rust copies (blocked products, assemblers)": sum(mb for _, mb in c["rust_products_mb"]) + c["rust_assemblers_mb"],
        "compliance: columns over their blocks": comp["stored_mb"],
        "compliance: observed rows + S": comp["observed_rows_mb"] + comp["S_mb"],
        "compliance: index maps": max(0.0, compliance_walk - comp["nbytes_mb"]),
        "history": roots.pop("history (per-step lists)", 0.0),
        "field snapshots": roots.pop("field snapshots", 0.0),
        "other Python objects and arrays": sum(roots.values()) - matrices,
    }
    if c["rss_trimmed_mb"] is not None:
        parts["freed, kept by the allocator"] = c["rss_mb"] - c["rss_trimmed_mb"]
    parts["unaccounted"] = c["rss_mb"] - sum(parts.values())
    return parts


def _machine() -> dict:
    model = subprocess.run("lscpu | grep 'Model name'", shell=True, capture_output=True, text=True).stdout.strip()
    mem = next((line.split(":")[1].strip() for line in Path("/proc/meminfo").read_text().splitlines()
                if line.startswith("MemTotal")), "")
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, capture_output=True, text=True).stdout.strip()
    return {"cpu": model.split(":", 1)[-1].strip(), "cores": os.cpu_count(), "memory": mem,
            "python": sys.version.split()[0], "commit": commit}


def _loadavg() -> str:
    return " ".join(Path("/proc/loadavg").read_text().split()[:3])


def _key(r: dict) -> tuple:
    return (r["level"], r["end_s"], r["column_memory_mib"])


def markdown(data: dict) -> str:
    m = data["machine"]
    lines = ["# Memory of the steady main job (examples/m5_steady.toml)", "",
             f"Machine: {m['cpu']}, {m['cores']} cores, {m['memory']}; Python {m['python']}; vfrs at {m['commit']}; "
             f"threads {data['threads']}. Each run in a fresh process; `python benchmarks/bench_memory.py` "
             "(its docstring says what is measured). Peak RSS: `ru_maxrss` of the run, the census's own memory at "
             "the last step left out (the peak is reset after it: /proc/self/clear_refs). Max history difference: "
             "per recorded series max |capped - default| / max |default|, the largest over the answer's series "
             "(not the solver's counts and diagnostics, the node and position of a maximum, or the series that are "
             "zero to round-off), and over the motion's (glottal area, flow, energies, min gap).", "",
             "| level | end (ms) | free DOFs | column_memory (MiB) | steps | wall (s) | peak RSS (MB) | RSS at the end (MB) "
             "| contact DOFs | stored columns (the cap's, all blocks) | fallback solves | max history difference | load before / after |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in data["runs"]:
        c = r["census"]["compliance"]
        cmp_ = r.get("vs_default")
        diff = ("(the default)" if r["default_cap"] else
                "-" if cmp_ is None else f"{cmp_['max_rel_diff']:.1e} ({cmp_['worst_series']}); motion "
                f"{cmp_['motion_max_rel_diff']:.1e}; {cmp_['identical']}/{cmp_['series']} series identical"
                + ("; every column stored, no fallback solve: a round-off control" if not c["fallback_solves"] else ""))
        cap = f"at most {min(c['cap_columns'])}" if c["cap_columns"] else "no cap"
        lines.append(f"| {r['level']} | {r['end_s'] * 1e3:g} | {r['free_dofs']} | {r['column_memory_mib']:g}"
                     f"{'' if not r['default_cap'] else ' (scene)'} | {r['steps']} | {r['wall_s']:.1f} | "
                     f"{r['peak_rss_mb']:.0f} | {r['census']['rss_mb']:.0f} | {c['contact_dofs']} | "
                     f"{c['stored_columns']} ({cap}) | {c['fallback_solves']} | {diff} | "
                     f"{r['load_before']} / {r['load_after']} |")
    names = list(breakdown(data["runs"][0]))
    lines += ["", "What holds the RSS at the last step (MB; census at the run's end, before the history is "
              "turned into arrays):", "",
              "| level | end (ms) | cap (MiB) | " + " | ".join(names) + " | RSS |",
              "|---|---|---|" + "---|" * (len(names) + 1)]
    for r in data["runs"]:
        b = breakdown(r)
        lines.append(f"| {r['level']} | {r['end_s'] * 1e3:g} | {r['column_memory_mib']:g} | "
                     + " | ".join(f"{b.get(n, 0.0):.1f}" for n in names) + f" | {r['census']['rss_mb']:.0f} |")
    lines += ["", "The factor and the columns in detail:", "",
              "| level | end (ms) | cap (MiB) | nnz(L) | L values (MB) | factor kept (MB, measured) | contact DOFs "
              "| observed DOFs | stored columns | of them ever loaded | loaded columns | columns (MB) | observed rows (MB) "
              "| S (MB, capacity) | column solves |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in data["runs"]:
        c, f = r["census"]["compliance"], r["census"]["factor"]
        kept = r.get("factor_kept_mb")
        lines.append(f"| {r['level']} | {r['end_s'] * 1e3:g} | {r['column_memory_mib']:g} | {f['nnz_factor']} | "
                     f"{f['values_mb']:.1f} | {'-' if kept is None else f'{kept:.1f}'} | {c['contact_dofs']} | "
                     f"{c['observed_dofs']} | {c['stored_columns']} | {r['stored_and_loaded']} | {r['loaded_columns']} | "
                     f"{c['stored_mb']:.1f} | {c['observed_rows_mb']:.1f} | {c['S_mb']:.1f} ({c['S_capacity']}) | "
                     f"{c['column_solves']} |")
    lines += ["", "The sparse matrices and Rust product copies (MB) at the last step, by where the run holds them:", ""]
    for r in data["runs"]:
        if not r["default_cap"]:
            continue
        items = "; ".join(f"{p} {mb:.1f}" for p, mb in r["census"]["matrices_mb"] if mb >= 0.05)
        rust = "; ".join(f"{p} {mb:.1f}" for p, mb in r["census"]["rust_products_mb"])
        lines.append(f"- level {r['level']}, {r['end_s'] * 1e3:g} ms: {items}. Rust copies: {rust}.")
    lines += ["", "RSS over the run (MB: once set up, then every 10 ms of simulated time; peak so far in brackets):", ""]
    for r in data["runs"]:
        tl = ", ".join(f"{t * 1e3:.0f} ms {rss:.0f} ({hwm:.0f})" for t, rss, hwm, _, _ in r["timeline"])
        lines.append(f"- level {r['level']}, {r['end_s'] * 1e3:g} ms, cap {r['column_memory_mib']:g} MiB: {tl}")
    return "\n".join(lines) + "\n"


def _parse_caps(items) -> dict:
    """``LEVEL=MiB,MiB`` -> {level: [MiB, ...]}; ``none``: no capped runs."""
    caps: dict = {}
    for item in items:
        if item == "none":
            continue
        level, values = item.split("=")
        caps[int(level)] = [float(v) for v in values.split(",")]
    return caps


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--end", type=float, default=0.1, help="simulated time (s)")
    ap.add_argument("--caps", nargs="+", default=["1=128,256", "2=256,512"],
                    help="LEVEL=MiB,MiB: the capped runs ([contact] column_memory) beside the scene's cap; 'none': none")
    ap.add_argument("--out", default=str(OUT))
    ap.add_argument("--scratch", default="/tmp/vfrs_bench_memory", help="where the runs' histories are kept")
    ap.add_argument("--reuse-default", action="store_true",
                    help="capped runs only: compare with the scene's cap's run already in the JSON and --scratch")
    ap.add_argument("--report", action="store_true", help="only: write memory.md again from memory.json (no run)")
    ap.add_argument("--child", nargs=4, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.report:
        (Path(args.out) / "memory.md").write_text(markdown(json.loads((Path(args.out) / "memory.json").read_text())))
        return 0
    if args.child:
        level, end, cap, hist = args.child
        print(json.dumps(one_run(int(level), float(end), None if cap == "default" else float(cap),
                                 None if hist == "none" else hist)))
        return 0
    out, scratch = Path(args.out), Path(args.scratch)
    out.mkdir(parents=True, exist_ok=True)
    scratch.mkdir(parents=True, exist_ok=True)
    path = out / "memory.json"
    env = dict(os.environ)
    for k in THREADS:
        env.setdefault(k, "1")
    machine = _machine()
    caps = _parse_caps(args.caps)
    for level in args.levels:
        base = scratch / f"L{level}_{args.end:g}_default.npz"
        done = path.exists() and any(q["default_cap"] and (q["level"], q["end_s"]) == (level, args.end)
                                     for q in json.loads(path.read_text())["runs"])
        for cap in ([] if args.reuse_default and done and base.exists() else [None]) + caps.get(level, []):
            hist = scratch / f"L{level}_{args.end:g}_{'default' if cap is None else f'{cap:g}'}.npz"
            cmd = [sys.executable, __file__, "--child", str(level), str(args.end),
                   "default" if cap is None else str(cap), str(hist)]
            load_before = _loadavg()
            r = subprocess.run(cmd, capture_output=True, text=True, env=env)
            if r.returncode != 0:
                print(r.stderr[-3000:], file=sys.stderr)
                raise SystemExit(f"level {level} cap {cap} failed")
            row = json.loads(r.stdout.strip().splitlines()[-1])
            row.update(load_before=load_before, load_after=_loadavg())
            if cap is not None and base.exists():
                row["vs_default"] = compare(str(hist), str(base))
            # Read again before writing: another invocation may have added rows meanwhile.
            data = json.loads(path.read_text()) if path.exists() else {"runs": []}
            data.update(machine=machine, threads={k: env[k] for k in THREADS})
            data["runs"] = [q for q in data["runs"] if _key(q) != _key(row)] + [row]
            data["runs"].sort(key=lambda q: (q["end_s"], q["level"], not q["default_cap"], q["column_memory_mib"]))
            path.write_text(json.dumps(data, indent=1))
            (out / "memory.md").write_text(markdown(data))
            b = breakdown(row)
            print(f"level {level} cap {row['column_memory_mib']:g} MiB: {row['steps']} steps, wall {row['wall_s']:.1f} s, "
                  f"peak RSS {row['peak_rss_mb']:.0f} MB, at the end {row['census']['rss_mb']:.0f} MB: "
                  + ", ".join(f"{k} {v:.0f}" for k, v in b.items())
                  + (f"; vs default {row['vs_default']['max_rel_diff']:.2e} ({row['vs_default']['worst_series']})"
                     if "vs_default" in row else ""), flush=True)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
