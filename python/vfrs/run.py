"""``vfrs.run``: build what the scene asks for, step it, record, write.

Only the parts a scene names are built and called: without ``[flow]`` no flow code runs,
without ``[contact]`` no detection. ``res.effects`` lists what ran and ``res.timings`` what each
part cost.
"""

from __future__ import annotations

import sys
import time
from collections import defaultdict

import numpy as np

from .dynamics import HHTAlpha, StaticSolver, StepContext, build_problem
from .dynamics.problem import ramp
from .effects import EFFECTS
from .output import OutputWriter
from .result import Result
from .scene import Scene


class _Dot:
    """x . y without BLAS, into a scratch buffer owned by one run (runs in threads stay apart).

    OpenBLAS's threaded ddot competes with the solver's threads for the cores (measured on 2
    cores: 6 ms instead of 5 us for 30k entries, and 3x slower solves)."""

    def __init__(self):
        self.buffers = {}

    def __call__(self, x, y) -> float:
        buf = self.buffers.get(len(x))
        if buf is None:
            buf = self.buffers[len(x)] = np.empty(len(x))
        np.multiply(x, y, out=buf)
        return float(buf.sum())


class _State:
    """What ``forces`` and ``record`` hooks see: the configuration (all DOFs) at ``t``."""

    def __init__(self, problem, u, v, a):
        self.problem = problem
        self.u, self.v, self.a = u, v, a
        self.t = 0.0
        self.t_next = 0.0
        self.step = 0

    @property
    def points(self) -> np.ndarray:
        """Current coordinates (n_nodes, 3)."""
        return self.problem.points + self.u.reshape(-1, 3)


class _Clock:
    def __init__(self):
        self.seconds = defaultdict(float)

    def add(self, key, t0):
        t1 = time.perf_counter()
        self.seconds[key] += t1 - t0
        return t1


def _progress_bar(total, enabled, desc):
    if not enabled or not sys.stderr.isatty() or total < 20:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="step", mininterval=0.5, leave=False)


def run(scene, out=None, progress: bool = True, effects=None) -> Result:
    """Runs a scene (a :class:`vfrs.Scene` or a path to a TOML file).

    ``out``: a folder for the resolved scene, history, fields and log (None: nothing written).
    ``progress``: a tqdm bar on long runs when stderr is a terminal.
    ``effects``: instances to use instead of building them from the registry (tests, advanced use);
    by default one per section the scene names.

    >>> import vfrs
    >>> scene = vfrs.Scene.from_dict({
    ...     "bodies": [{"name": "bar",
    ...                 "mesh": {"builtin": "box", "size": [1.0, 0.1, 0.1], "cells": [4, 1, 1]},
    ...                 "material": {"model": "isotropic", "E": 1e6, "nu": 0.0, "rho": 1000.0},
    ...                 "fixed": [{"surface": "xmin", "components": ["x"]},
    ...                           {"surface": "ymin", "components": ["y"]},
    ...                           {"surface": "zmin", "components": ["z"]}],
    ...                 "loads": [{"type": "traction", "surface": "xmax", "value": [1e3, 0, 0]}]}],
    ...     "time": {"mode": "static"}})
    >>> res = vfrs.run(scene)
    >>> round(float(res.u[:, 0].max()), 6)   # F L / (E A) = 1e3 * 1 / 1e6
    0.001
    """
    t_start = time.perf_counter()
    if not isinstance(scene, Scene):
        scene = Scene.load(scene)
    clock = _Clock()
    t0 = time.perf_counter()
    meshes = scene.build_meshes()
    t0 = clock.add("mesh", t0)
    problem = build_problem(scene, meshes)
    t0 = clock.add("assembly", t0)
    if effects is None:
        effects = [EFFECTS[name](cfg) for name, cfg in scene.effects.items()]
    ran = ["elasticity"]
    if scene.time.mode == "dynamic":
        ran.append("inertia")
        if problem.damped:
            ran.append("damping")
    if problem.gravity is not None:
        ran.append("gravity")
    if problem.loads:
        ran.append("surface_loads")
    if problem.prescribed:
        ran.append("prescribed_displacement")
    ran += [e.name for e in effects]

    writer = OutputWriter(out, scene, problem) if out is not None else None
    if writer:
        writer.log(f"sizes: {problem.sizes()}")
        writer.log(f"time: {scene.time.to_dict()}")
        writer.log(f"effects: {', '.join(ran)}")
    loop = _dynamic if scene.time.mode == "dynamic" else _static
    rec = _Recorder(scene, problem, effects)
    try:
        history, fields, probes, u, v = loop(scene, problem, effects, clock, writer, progress, rec)
    except BaseException as exc:
        if writer:  # keep what was recorded up to the failure, and say why it stopped
            history, _, _ = rec.finish()
            if history:
                writer.write_history(history)
            writer.log(f"run failed after {len(history.get('t', []))} recorded steps: {type(exc).__name__}: {exc}")
            writer.close()
        raise
    res = Result(scene, problem, history, ran, clock.seconds, fields, probes, u, v, out)
    for e in effects:
        t0 = time.perf_counter()
        e.finish(res)
        clock.add(e.name, t0)
    if writer:
        t0 = time.perf_counter()
        writer.write_history(res.history)
        clock.add("output", t0)
    clock.seconds["total"] = time.perf_counter() - t_start
    res.timings = dict(clock.seconds)
    if writer:
        writer.close(res.summary())
    return res


def _hooks(effects, name, clock):
    """The overridden ``name`` hooks, each timed under its effect's name and marked on the
    step context so the forces it adds are attributed to it."""
    out = []
    for e in effects:
        if not type(e).overrides(name):
            continue

        def hook(ctx, _e=e, _f=getattr(e, name)):
            t0 = time.perf_counter()
            ctx.current_effect = _e.name
            try:
                _f(ctx)
            finally:
                ctx.current_effect = None
                clock.add(_e.name, t0)

        out.append(hook)
    return out


def _merge_implicit(ctx, correcting, forcing, effect_forces) -> None:
    """Per effect with a ``correct`` hook: its explicit forces of this step (if it has a
    ``forces`` hook) plus what it added through ``step.add_force`` (None if neither)."""
    for name in correcting:
        f_imp = ctx.implicit_by_effect.get(name)
        f_exp = effect_forces.get(name) if name in forcing else None
        effect_forces[name] = f_imp if f_exp is None else (f_exp if f_imp is None else f_exp + f_imp)


def _setup_effects(problem, effects, clock, integrator, force_scale) -> None:
    """Hands the factored problem to the effects (each setup timed under its name)."""
    problem.factor = integrator.factor
    problem.force_scale = force_scale
    problem.integrator = integrator
    for e in effects:
        t0 = time.perf_counter()
        e.setup(problem)
        clock.add(e.name, t0)


def _check_bounded(u, step, t, size) -> None:
    """A displacement ten times the whole scene means the run has diverged (bodies may
    travel, so one scene size is not enough): stop with that, not with whatever breaks next
    (a degenerate contact triangle, NaN in a solve)."""
    umax = float(np.max(np.abs(u))) if u.size else 0.0
    if not np.isfinite(umax) or umax > 10.0 * size:
        from .errors import ConvergenceError

        raise ConvergenceError(
            f"step {step}, t = {t:.6g}: the solution diverged (largest displacement {umax:.3g} m, the "
            f"scene is {size:.3g} m across). Linear elasticity does not hold at such strains; lower the "
            "load (e.g. the subglottal pressure), stiffen the tissue, add damping or shorten the step."
        )


class _Recorder:
    """Per-step history, probes and field snapshots, shared by the dynamic and static loops."""

    def __init__(self, scene, problem, effects):
        self.scene, self.problem, self.effects = scene, problem, effects
        self.out = scene.output
        self.history = defaultdict(list)
        self.record_hooks = [(e.name, e.record) for e in effects if type(e).overrides("record")]
        self.probe_nodes = sorted({problem.nearest_node(p) for p in self.out.probes})
        self.probe_dofs = {n: np.arange(3 * n, 3 * n + 3) for n in self.probe_nodes}
        self.probes = {n: defaultdict(list) for n in self.probe_nodes}
        self.snapshots = defaultdict(list)
        if self.out.reactions:
            fixed = problem.fixed
            self.K_rows = problem.K[fixed]
            self.M_rows = problem.M[fixed]
            self.C_rows = None if problem.C is None else problem.C[fixed]
        self.work = 0.0
        self.dot = _Dot()

    def record(self, state, effect_forces, F_full, clock, dynamic=True):
        t0 = time.perf_counter()
        p, h = self.problem, self.history
        h["t"].append(state.t)
        u, v, a = state.u, state.v, state.a
        if self.out.energy:
            h["kinetic_energy"].append(0.5 * self.dot(v, p.M @ v) if dynamic else 0.0)
            h["elastic_energy"].append(0.5 * self.dot(u, p.K @ u))
            h["external_work"].append(self.work)
        if self.out.reactions and p.groups:
            r = self.K_rows @ u - F_full[p.fixed]
            if dynamic:
                r += self.M_rows @ a
                if p.damped:
                    r += self.C_rows @ v if self.C_rows is not None else (
                        p.rayleigh[0] * (self.M_rows @ v) + p.rayleigh[1] * (self.K_rows @ v))
            for g in p.groups:
                # M a + C v + K u = F + R on the fixed DOFs: R is the support's force on the body.
                h[f"reaction_force.{g.body}.{g.name}"].append(np.bincount(g.components, r[g.positions], minlength=3))
        for n, dofs in self.probe_dofs.items():
            rec = self.probes[n]
            rec["displacement"].append(u[dofs].copy())
            rec["velocity"].append(v[dofs].copy())
            for name, f in effect_forces.items():
                rec[f"{name}_force"].append(f[dofs].copy() if f is not None else np.zeros(3))
        clock.add("record", t0)
        for name, hook in self.record_hooks:
            t0 = time.perf_counter()
            hook(state, h)
            clock.add(name, t0)

    def snapshot(self, step, state, effect_forces, writer, clock, force=False):
        if not (force or step % self.out.every == 0):
            return
        t0 = time.perf_counter()
        n = self.problem.n_points
        fields = {}
        for name in self.out.fields:
            vec = {"displacement": state.u, "velocity": state.v, "acceleration": state.a}[name]
            fields[name] = vec.reshape(n, 3).copy()
        for name, f in effect_forces.items():
            fields[f"{name}_force"] = np.zeros((n, 3)) if f is None else f.reshape(n, 3).copy()
        self.snapshots["t"].append(state.t)
        for k, v in fields.items():
            self.snapshots[k].append(v)
        if writer:
            writer.write_fields(step, state.t, fields)
        clock.add("output", t0)

    def finish(self):
        history = {}
        for k, v in self.history.items():
            try:
                history[k] = np.asarray(v, dtype=float)
            except (ValueError, TypeError):  # ragged per-step records (e.g. lists of pairs)
                arr = np.empty(len(v), dtype=object)
                arr[:] = [np.asarray(x) for x in v]
                history[k] = arr
        probes = {n: {k: np.asarray(v) for k, v in rec.items()} for n, rec in self.probes.items()}
        fields = {}
        for k, v in self.snapshots.items():
            if k == "t":
                fields[k] = np.asarray(v, dtype=float)
            else:
                # effect forces may appear after the first snapshot: pad with zeros
                fields[k] = np.asarray(v)
        return history, fields, probes


def _dynamic(scene, problem, effects, clock, writer, progress, rec):
    tm = scene.time
    h, alpha = tm.step, tm.alpha
    free, fixed = problem.free, problem.fixed
    t0 = time.perf_counter()
    integ = HHTAlpha(problem.M_free, problem.K_free, h, alpha,
                     rayleigh=problem.rayleigh or (0.0, 0.0), C=problem.C_free)
    t0 = clock.add("factorization", t0)
    _setup_effects(problem, effects, clock, integ, 1.0 + alpha)

    n = problem.n_dofs
    u_full, v_full, a_full = np.zeros(n), np.zeros(n), np.zeros(n)
    v_full[:] = np.concatenate([np.tile(p.config.velocity, p.n_points) for p in problem.bodies])
    u_full[fixed] = problem.fixed_values(0.0)
    v_full[fixed] = problem.fixed_values(0.0, 1)
    state = _State(problem, u_full, v_full, a_full)
    u, v = u_full[free].copy(), v_full[free].copy()
    force_hooks = [(e.name, e.forces) for e in effects if type(e).overrides("forces")]
    predict_hooks = _hooks(effects, "predict", clock)
    correct_hooks = _hooks(effects, "correct", clock)
    correcting = [e.name for e in effects if type(e).overrides("correct")]
    forcing = {e.name for e in effects if type(e).overrides("forces")}
    ctx = StepContext(integ.factor, problem.dofmap, 1.0 + alpha, problem)
    effect_forces = {name: None for name in correcting}

    cache = {}

    def external(t, out_free, state):
        t0 = time.perf_counter()
        key = tuple(ramp(t, ld.ramp)[0] for ld in problem.loads)
        if cache.get("key") != key:  # loads change only while ramping
            cache["key"], cache["F"] = key, problem.external_force(t)
            cache["F_free"] = cache["F"][free]
        F = cache["F"].copy() if force_hooks else cache["F"]
        t0 = clock.add("loads", t0)
        if not force_hooks:
            out_free[:] = cache["F_free"]
            return F
        for name, hook in force_hooks:
            f = hook(state)
            effect_forces[name] = f
            if f is not None:
                F += f
            t0 = clock.add(name, t0)
        out_free[:] = F[free]
        return F

    def prescribed_rhs(t_prev, t1):
        if not problem.prescribed:
            return None
        r = np.zeros(len(free))
        for g, _, kd, cd, md in problem.prescribed:
            r0, r1 = ramp(t_prev, g.ramp), ramp(t1, g.ramp)
            r -= r1[2] * md + (1 + alpha) * (r1[1] * cd + r1[0] * kd) - alpha * (r0[1] * cd + r0[0] * kd)
        return r

    F0, F1 = np.zeros(len(free)), np.zeros(len(free))
    state.t, state.t_next = 0.0, 0.0
    F_full = external(0.0, F0, state)
    # Initial acceleration from the balance at t = 0 (prescribed motion included).
    t0 = time.perf_counter()
    rhs0 = F0.copy()
    if problem.prescribed:
        ap = problem.fixed_values(0.0, 2)
        for g, dfix, kd, cd, md in problem.prescribed:
            r = ramp(0.0, g.ramp)
            rhs0 -= r[2] * md + r[1] * cd + r[0] * kd
        a_full[fixed] = ap
    a = integ.initial_acceleration(u, v, rhs0)
    a_full[free] = a
    clock.add("initial_acceleration", t0)
    rec.record(state, effect_forces, F_full, clock)
    rec.snapshot(0, state, effect_forces, writer, clock)

    n_steps = tm.n_steps
    size = float(np.linalg.norm(np.ptp(problem.points, axis=0)))
    bar = _progress_bar(n_steps, progress, scene.title or "vfrs")
    u_prev = np.empty_like(u)
    # The loads alone at both ends of the step, for external_work (F0/F1 also carry the
    # contact forces that stay in the HHT recursion; their work is the contact effect's).
    L0, L1 = F0.copy(), np.empty_like(F1)
    try:
        for k in range(1, n_steps + 1):
            t_prev, t1 = (k - 1) * h, k * h
            state.t, state.t_next, state.step = t_prev, t1, k
            F_full = external(t1, F1, state)
            L1[:] = F1
            t0 = time.perf_counter()
            extra = prescribed_rhs(t_prev, t1)
            ctx.begin(t_prev, t1, F1)
            u_prev[:] = u
            integ.step(u, v, a, F0, F1, extra, ctx, predict_hooks, correct_hooks)
            t0 = clock.add("step", t0)
            _check_bounded(u, k, t1, size)
            if ctx.implicit_full is not None:
                F_full = F_full + ctx.implicit_full
            if correcting:
                _merge_implicit(ctx, correcting, forcing, effect_forces)
            if rec.out.energy:
                rec.work += 0.5 * (rec.dot(L0, u) + rec.dot(L1, u) - rec.dot(L0, u_prev) - rec.dot(L1, u_prev))
            L0, L1 = L1, L0
            u_full[free], v_full[free], a_full[free] = u, v, a
            if problem.prescribed:
                u_full[fixed] = problem.fixed_values(t1)
                v_full[fixed] = problem.fixed_values(t1, 1)
                a_full[fixed] = problem.fixed_values(t1, 2)
            state.t = t1
            clock.add("step", t0)
            rec.record(state, effect_forces, F_full, clock)
            rec.snapshot(k, state, effect_forces, writer, clock, force=(k == n_steps))
            F0, F1 = F1, F0
            if bar:
                bar.update()
    finally:
        if bar:
            bar.close()
    clock.seconds["solve"] += integ.solve_seconds
    history, fields, probes = rec.finish()
    return history, fields, probes, u_full.reshape(-1, 3).copy(), v_full.reshape(-1, 3).copy()


def _static(scene, problem, effects, clock, writer, progress, rec):
    free, fixed = problem.free, problem.fixed
    t0 = time.perf_counter()
    solver = StaticSolver(problem.K_free)
    t0 = clock.add("factorization", t0)
    _setup_effects(problem, effects, clock, solver, 1.0)
    n = problem.n_dofs
    u_full, v_full, a_full = np.zeros(n), np.zeros(n), np.zeros(n)
    state = _State(problem, u_full, v_full, a_full)
    force_hooks = [(e.name, e.forces) for e in effects if type(e).overrides("forces")]
    predict_hooks = _hooks(effects, "predict", clock)
    correct_hooks = _hooks(effects, "correct", clock)
    correcting = [e.name for e in effects if type(e).overrides("correct")]
    forcing = {e.name for e in effects if type(e).overrides("forces")}
    ctx = StepContext(solver.factor, problem.dofmap, 1.0, problem)
    effect_forces = {name: None for name in correcting}
    N = scene.time.load_steps
    bar = _progress_bar(N, progress, scene.title or "vfrs")
    u_prev = np.zeros(len(free))
    F_prev = np.zeros(len(free))
    try:
        for k in range(1, N + 1):
            lam_prev, lam = (k - 1) / N, k / N
            state.t, state.t_next, state.step = lam_prev, lam, k
            t0 = time.perf_counter()
            F_full = problem.external_force(lam, static=True)
            t0 = clock.add("loads", t0)
            for name, hook in force_hooks:
                f = hook(state)
                effect_forces[name] = f
                if f is not None:
                    F_full += f
                t0 = clock.add(name, t0)
            F = F_full[free].copy()
            rhs = F.copy()
            up = problem.fixed_values(lam, static=True)
            for g, dfix, kd, cd, md in problem.prescribed:
                rhs -= lam * kd
            ctx.begin(lam_prev, lam, F.copy())  # F stays the loads alone (external_work)
            ctx.u_tilde = ctx.v_tilde = None
            for hook in predict_hooks:
                hook(ctx)
            u = solver.solve(rhs, ctx, correct_hooks)
            t0 = clock.add("solve", t0)
            if ctx.implicit_full is not None:
                F_full = F_full + ctx.implicit_full
            if correcting:
                _merge_implicit(ctx, correcting, forcing, effect_forces)
            if rec.out.energy:
                rec.work += 0.5 * rec.dot(F_prev + F, u - u_prev)
            u_prev, F_prev = u.copy(), F
            u_full[free] = u
            u_full[fixed] = up
            state.t = lam
            rec.record(state, effect_forces, F_full, clock, dynamic=False)
            rec.snapshot(k, state, effect_forces, writer, clock, force=(k == N))
            if bar:
                bar.update()
    finally:
        if bar:
            bar.close()
    history, fields, probes = rec.finish()
    return history, fields, probes, u_full.reshape(-1, 3).copy(), v_full.reshape(-1, 3).copy()
