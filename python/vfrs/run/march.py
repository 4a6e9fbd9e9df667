"""The one march loop of :func:`vfrs.run.run`: every integrator, every effect, per step the loads,
the integrator's step (which calls the effects' hooks), the bound check and the record; the
checkpoints it writes and the open end of ``until = "limit_cycle"``."""

from __future__ import annotations

import sys
import time
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..checkpoint import CHECKPOINT, RunStopped, check_state, restore_into, scene_hash, state_of, write_checkpoint
from ..dynamics import State, StepContext
from ..effects import SetupContext, setup_order
from ..errors import ConvergenceError
from ..output.writer import versions


class Clock:
    def __init__(self):
        self.seconds = defaultdict(float)

    def add(self, key, t0):
        t1 = time.perf_counter()
        self.seconds[key] += t1 - t0
        return t1


def progress_bar(total, enabled, desc):
    if not enabled or not sys.stderr.isatty() or total < 20:
        return None
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit="step", mininterval=0.5, leave=False)



class _Hooks:
    """The overridden hooks of the effects, each timed under its effect's name and marked on
    the step context so the forces it adds are attributed to it."""

    def __init__(self, effects, clock):
        self.clock = clock
        self.forces = [(e.name, e.forces) for e in effects if type(e).overrides("forces")]
        self.predict = self._wrapped(effects, "predict")
        self.correct = self._wrapped(effects, "correct")
        self.correcting = [e.name for e in effects if type(e).overrides("correct")]
        self.forcing = {name for name, _ in self.forces}
        # Each effect's own forces this step (probes and field output show them).
        self.effect_forces = {name: None for name in self.correcting}

    def _wrapped(self, effects, name):
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
                    self.clock.add(_e.name, t0)

            out.append(hook)
        return out

    def explicit(self, state, F) -> None:
        """Adds the effects' explicit forces for the step to F (all DOFs), in place."""
        for name, hook in self.forces:
            t0 = time.perf_counter()
            f = hook(state)
            self.effect_forces[name] = f
            if f is not None:
                F += f
            self.clock.add(name, t0)

    def merge_implicit(self, ctx) -> None:
        """Per effect with a ``correct`` hook: its explicit forces of this step (if it has a
        ``forces`` hook) plus what it added through ``step.add_force`` (None if neither)."""
        for name in self.correcting:
            f_imp = ctx.implicit_by_effect.get(name)
            f_exp = self.effect_forces.get(name) if name in self.forcing else None
            self.effect_forces[name] = f_imp if f_exp is None else (f_exp if f_imp is None else f_exp + f_imp)


@dataclass
class _Loads:
    """External loads (surface loads, gravity) at a time or load factor, cached while no ramp
    moves them."""

    problem: Any
    static: bool
    cache: dict = field(default_factory=dict)

    def at(self, t: float) -> np.ndarray:
        p = self.problem
        key = (t,) if self.static else tuple(ld.factor(t) for ld in p.loads)
        if self.cache.get("key") != key:
            self.cache["key"], self.cache["F"] = key, p.external_force(t, static=self.static)
        return self.cache["F"].copy()


def _check_bounded(u, step, t, size) -> None:
    """A displacement ten times the whole scene means the run has diverged (bodies may
    travel, so one scene size is not enough): stop with that, not with whatever breaks next
    (a degenerate contact triangle, NaN in a solve)."""
    umax = float(np.max(np.abs(u))) if u.size else 0.0
    if not np.isfinite(umax) or umax > 10.0 * size:
        raise ConvergenceError(
            f"step {step}, t = {t:.6g}: the solution diverged (largest displacement {umax:.3g} m, the "
            f"scene is {size:.3g} m across). Linear elasticity does not hold at such strains; lower the "
            "load (e.g. the subglottal pressure), stiffen the tissue, add damping or shorten the step."
        )


def _restore(data, state, integ, effects, rec, writer):
    """Every part back to the checkpoint ``data``: (L_prev, the next step)."""
    state.restore(data["state"])
    restore_into(integ, data["integrator"])
    for e in effects:
        restore_into(e, data["effects"].get(e.name))
    rec.restore(data["recorder"])
    if writer:
        restore_into(writer, data["writer"])
        writer.files.add(CHECKPOINT)
        writer.log(f"resumed from the checkpoint after step {data['step']} (t = {data['t']:.6g})")
        history, _, _ = rec.finish()
        writer.write_history(history)  # drops rows recorded after the checkpoint by the stopped run
        writer.write_probes(rec, history["t"])
    return data["L_prev"].copy(), int(data["step"]) + 1


class _Recorded(Mapping):
    """The history recorded so far (a :class:`vfrs.history.Recorder`'s lists) as arrays, each
    made when first read: what :class:`_UntilLimitCycle` hands the periodicity test, which
    reads a few of the columns. ``cache``: the arrays of an earlier view of the same lists,
    extended by the rows recorded since (the lists only grow during a march)."""

    def __init__(self, lists, cache: dict | None = None):
        self.lists = lists
        self.arrays: dict = {}
        self.cache = {} if cache is None else cache

    def __getitem__(self, key):
        if key not in self.arrays:
            if key not in self.lists:  # (a defaultdict must not grow a column here)
                raise KeyError(key)
            rows, old = self.lists[key], self.cache.get(key)
            try:
                if old is None or len(old) > len(rows) or not len(old):
                    arr = np.asarray(rows, dtype=float)
                else:
                    arr = np.concatenate([old, np.asarray(rows[len(old):], dtype=float).reshape(-1, *old.shape[1:])])
                self.cache[key] = arr
            except (ValueError, TypeError):  # ragged per-step records: as the history's arrays hold them
                from ..history import as_arrays

                arr = as_arrays({key: rows})[key]
            self.arrays[key] = arr
        return self.arrays[key]

    def __contains__(self, key):
        return key in self.lists

    def __iter__(self):
        return iter(self.lists)

    def __len__(self):
        return len(self.lists)


#: ``[output] until = "limit_cycle"``: past ``[time] end``, the periodicity test runs every
#: this many seconds of simulated time (a run that reaches its limit cycle ends at most this
#: late; one test on the main job's history costs about a millisecond, a step 5-60 ms).
UNTIL_CHECK = 1e-3


class _UntilLimitCycle:
    """``[output] until = "limit_cycle"``: the run goes on past ``[time] end`` (step
    ``n_end``) until the periodicity test of the summary (:meth:`vfrs.summary.RunView.periodicity`:
    the last ``until_cycles`` cycles of the window, the second half of the run so far, repeat
    in every value the effects give per cycle) holds on the history recorded so far, tested
    every :data:`UNTIL_CHECK` s of simulated time, or until ``until_cap`` (step ``n_cap``). The
    test reads the history only, so a resumed run ends where the uninterrupted one does, and
    the summary's ``window.periodic`` of the run's own history is the verdict that ended it."""

    def __init__(self, scene, n_end: int):
        import math

        out, h = scene.output, float(scene.time.step)
        self.n_end, self.cycles, self.cap, self.tolerance = n_end, out.until_cycles, out.until_cap, out.until_tolerance
        self.n_cap = max(n_end, math.ceil(out.until_cap / h - 1e-9))
        self.every = max(1, round(UNTIL_CHECK / h))
        self.reached = False
        self.columns: dict = {}  # the history's arrays at the last test (_Recorded's cache)

    def done(self, k: int, rec) -> bool:
        """Whether step ``k`` (recorded) is the run's last: a passed test, or the cap (tested
        too, so that run.log and the summary agree)."""
        at_cap = k >= self.n_cap
        if not at_cap and (k < self.n_end or (k - self.n_end) % self.every):
            return False
        from ..summary import RunView

        test = RunView(_Recorded(rec.history, self.columns), last_cycles=self.cycles,
                       tolerance=self.tolerance).periodicity()
        self.reached = test is not None and test.periodic
        return self.reached or at_cap

    def log(self, writer, k: int, t: float, t_end: float) -> None:
        if writer is None:
            return
        if self.reached:
            writer.log(f'until = "limit_cycle": the last {self.cycles} cycles repeat (within {100 * self.tolerance:g} %) '
                       f"at t = {t:.6g} s (step {k}; [time] end {t_end:.6g} s); the run ends there")
        else:
            writer.log(f'until = "limit_cycle": the cap, until_cap = {self.cap:.6g} s (step {k}), reached before the '
                       f"last {self.cycles} cycles repeated; the run ends there and its summary says so")


def march(scene, problem, effects, clock, writer, progress, rec, ckpt=None, resumed=None):
    """The one time (or load) march: every integrator, every effect.

    ``ckpt``: when to write checkpoints (and stop on a signal); ``resumed``: a checkpoint to
    continue from (the start is rebuilt as in the first run, then every part takes its state
    back). With ``[output] until = "limit_cycle"`` the last step is open
    (:class:`_UntilLimitCycle`)."""
    integ, hooks, loads, state, ctx, L_prev, k_start = _start(scene, problem, effects, clock, writer, rec, resumed)
    free = problem.free
    size = float(np.linalg.norm(np.ptp(problem.points, axis=0)))
    u_prev = np.empty(len(free))
    saves = None if ckpt is None else _Checkpoints(ckpt, scene, state, integ, effects, rec, writer, clock)
    until = _UntilLimitCycle(scene, integ.n_steps) if scene.output.until == "limit_cycle" else None
    n_last = integ.n_steps if until is None else until.n_cap
    desc = scene.title or "vfrs"
    if until is not None:  # the bar's total is the cap: say that the end is open
        desc += f" (open end: until {until.cycles} cycles repeat, at most {until.cap * 1e3:g} ms)"
    bar = progress_bar(n_last - k_start + 1, progress, desc)
    try:
        for k in range(k_start, n_last + 1):
            state.t, state.t_next, state.step = integ.time(k - 1), integ.time(k), k
            t0 = time.perf_counter()
            F = loads.at(state.t_next)  # the loads at t_next: external, then the effects' explicit forces
            clock.add("loads", t0)
            hooks.explicit(state, F)
            L = F[free]  # a copy (fancy indexing)
            t0 = time.perf_counter()
            if rec.out.energy:
                u_prev[:] = state.u_free
            integ.step(state, F, ctx, hooks)  # the integrator calls the effects' predict and correct
            state.velocity_jump = None if ctx.velocity_jump is None else problem.dofmap.expand(ctx.velocity_jump)
            t0 = clock.add("step", t0)
            _check_bounded(state.u_free, k, state.t_next, size)
            if ctx.implicit_full is not None:
                F = F + ctx.implicit_full
            hooks.merge_implicit(ctx)
            if rec.out.energy:
                L_sum = L_prev + L
                rec.work += 0.5 * (rec.dot(L_sum, state.u_free) - rec.dot(L_sum, u_prev))
            L_prev = L
            state.t = state.t_next
            clock.add("step", t0)
            rec.record(state, hooks.effect_forces, F, clock, dynamic=integ.dynamic)
            last = k == n_last if until is None else until.done(k, rec)
            rec.snapshot(k, state, hooks.effect_forces, writer, clock, force=last)
            if bar:
                bar.update()
            if last:
                if until is not None:
                    until.log(writer, k, state.t, integ.time(integ.n_steps))
                break
            if saves is not None:
                saves.after_step(k, k_start, L_prev)  # may raise RunStopped (SIGTERM/SIGINT)
    finally:
        if bar:
            bar.close()
    clock.seconds["solve"] += integ.solve_seconds
    history, fields, probes = rec.finish()
    return history, fields, probes, state.u.reshape(-1, 3).copy(), state.v.reshape(-1, 3).copy()


def _start(scene, problem, effects, clock, writer, rec, resumed):
    """The march's start: the integrator (factored), the effects set up, their timed hooks,
    the state at t = 0 (a dynamic run's recorded), or every part back at ``resumed``.
    Returns (integrator, hooks, loads, state, step context, the loads on the free DOFs at the
    start of the next step, the next step)."""
    t0 = time.perf_counter()
    integ = scene.time.integrator(problem, scene.time)
    t0 = clock.add("factorization", t0)
    setup = SetupContext(problem, integ.constants, integ.factor, integ.effective_matrix, integ.mass)
    for e in setup_order(effects):  # an effect after those whose ports it takes
        e.setup(setup)
        t0 = clock.add(e.name, t0)
    hooks = _Hooks(effects, clock)
    loads = _Loads(problem, static=not integ.dynamic)
    state = State(problem)
    ctx = StepContext(integ.factor, problem.dofmap, integ.force_scale, problem)

    F = loads.at(0.0)
    t0 = clock.add("loads", t0)
    if integ.dynamic:  # the initial condition is a state of its own (statics start unloaded)
        hooks.explicit(state, F)
        t0 = time.perf_counter()
    integ.start(state, F)
    clock.add("initial_acceleration", t0)
    if integ.dynamic:
        rec.record(state, hooks.effect_forces, F, clock, dynamic=True)
        rec.snapshot(0, state, hooks.effect_forces, None if resumed else writer, clock)
    L_prev = F[problem.free].copy()  # the loads alone at the start of the step, for external_work
    k_start = 1
    if resumed is not None:
        L_prev, k_start = _restore(resumed, state, integ, effects, rec, writer)
    return integ, hooks, loads, state, ctx, L_prev, k_start


#: What a resume reads from a checkpoint: the keys of :meth:`_Checkpoints.data`.
RESUME_READS = ("scene_hash", "versions", "step", "t", "L_prev", "checkpoint_every", "checkpoint_seconds", "state",
                "integrator", "effects", "recorder", "writer")


class _Checkpoints:
    """The march's checkpoints (:class:`vfrs.checkpoint.Checkpointer` says when): what one
    holds, writing one, and the stop on SIGTERM/SIGINT."""

    def __init__(self, ckpt, scene, state, integ, effects, rec, writer, clock):
        self.ckpt, self.state, self.integ, self.effects = ckpt, state, integ, effects
        self.rec, self.writer, self.clock = rec, writer, clock
        self.hash = scene_hash(scene)

    def data(self, k, L_prev) -> dict:
        """Everything a resume needs after step ``k``."""
        ckpt, state, writer = self.ckpt, self.state, self.writer
        return {"scene_hash": self.hash, "versions": versions(), "step": k, "t": state.t,
                "L_prev": L_prev.copy(), "checkpoint_every": ckpt.every, "checkpoint_seconds": ckpt.seconds,
                "state": state.state(), "integrator": state_of(self.integ),
                "effects": {e.name: state_of(e) for e in self.effects}, "recorder": self.rec.state(),
                "writer": state_of(writer)}

    def write(self, k, L_prev) -> None:
        """Writes the checkpoint after step ``k``: the state, and the rows recorded since the
        last one appended to history.csv and the checkpoint's lists (nothing is rewritten)."""
        ckpt, writer = self.ckpt, self.writer
        t0 = time.perf_counter()
        if writer:  # first: history.csv then holds at least the checkpoint's rows
            writer.append_history(self.rec)
        size_ = write_checkpoint(ckpt.out, self.data(k, L_prev), ckpt.journal)
        if writer:
            writer.files.add(CHECKPOINT)
            writer.files.update(ckpt.journal.files())
            writer.write_manifest()
            writer.log(f"checkpoint after step {k} (t = {self.state.t:.6g}): {size_ / 1e6:.3g} MB written, "
                       f"{time.perf_counter() - t0:.3g} s")
        ckpt.wrote()
        self.clock.add("checkpoint", t0)

    def after_step(self, k, k_start, L_prev) -> None:
        """After step ``k`` (not the last): on SIGTERM/SIGINT a checkpoint, then
        :class:`RunStopped`; else a checkpoint if one is due, or history.csv appended when due."""
        ckpt, writer = self.ckpt, self.writer
        if k == 1:  # a state() that a checkpoint cannot store is told now, not at the first checkpoint
            t0 = time.perf_counter()
            check_state(self.data(k, L_prev))
            self.clock.add("checkpoint", t0)
        if ckpt.stop_signal is not None:
            self.write(k, L_prev)
            raise RunStopped(ckpt.stop_signal, k, self.state.t, ckpt.out)
        if ckpt.due(k):
            self.write(k, L_prev)
        elif writer and (k == k_start or ckpt.history_due()):  # history.csv from the first step on
            t0 = time.perf_counter()
            writer.append_history(self.rec)
            ckpt.last_history = time.monotonic()
            self.clock.add("output", t0)
