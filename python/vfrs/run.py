"""``vfrs.run``: build what the scene asks for, march it, record, write.

Only the parts a scene names are built and called: without ``[flow]`` no flow code runs,
without ``[contact]`` no detection. ``res.effects`` lists what ran and ``res.timings`` what each
part cost.

One march loop serves every integrator (:mod:`vfrs.dynamics.integrators`, chosen by the
scene's ``[time] mode``): per step it gathers the loads (external forces and the effects'
explicit forces), asks the integrator to step (the integrator calls the effects' ``predict``
and ``correct`` hooks), checks the solution is bounded and records.
"""

from __future__ import annotations

import contextlib
import os
import sys
import time
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .checkpoint import (CHECKPOINT, Checkpointer, CheckpointError, RunStopped, check_state, read_checkpoint,
                         restore_into, resume_command, scene_hash, state_of, write_checkpoint)
from .dynamics import State, StepContext, build_problem
from .dynamics.problem import ramp
from .effects import EFFECTS, SetupContext
from .errors import ConvergenceError
from .history import Recorder
from .output import OutputFolder, OutputWriter, versions
from .result import Result
from .scene import Scene
from .scene.plausibility import check_supports


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


def what_runs(scene, problem, effect_names=None) -> list:
    """Names of the parts a scene runs, in order: ``elasticity``, ``inertia``, ``damping``,
    ``gravity``, ``surface_loads``, ``prescribed_displacement``, then its effects (or
    ``effect_names``)."""
    ran = ["elasticity"]
    if scene.time.dynamic:
        ran.append("inertia")
        if problem.damped:
            ran.append("damping")
    if problem.gravity is not None:
        ran.append("gravity")
    if problem.loads:
        ran.append("surface_loads")
    if problem.prescribed:
        ran.append("prescribed_displacement")
    return ran + list(scene.effects if effect_names is None else effect_names)


#: ``run(checkpoint_seconds=...)`` not given: the scene's ``[output] checkpoint_seconds``.
_SCENE_SECONDS = -1.0


def run(scene, out=None, progress: bool = True, effects=None, *, overwrite: bool = False,
        checkpoint_every: int | None = None, checkpoint_seconds: float | None = _SCENE_SECONDS,
        _resume: dict | None = None) -> Result:
    """Runs a scene (a :class:`vfrs.Scene` or a path to a TOML file).

    ``out``: a folder for the resolved scene, history, fields and log (None: nothing written).
    A folder holding another run's files is refused unless ``overwrite`` (which replaces that
    run's own files only, and only once the new run has completed: a failing run gives the
    folder back as it found it); a folder another run is writing to is refused at once (it
    holds the folder's lock); continue a stopped run with :func:`resume`.
    ``progress``: a tqdm bar on long runs when stderr is a terminal.
    ``effects``: instances to use instead of building them from the registry (tests, advanced use);
    by default one per section the scene names.
    ``checkpoint_every``: with ``out``, a checkpoint every so many steps; else every
    ``checkpoint_seconds`` of wall time (0 or None: only on SIGTERM/SIGINT). Both default to
    the scene's ``[output] checkpoint_every`` (0: by wall time) and ``checkpoint_seconds`` (60 s).
    With ``out``, SIGTERM and SIGINT (in the main thread) end the run after the current step
    with its history and a checkpoint written: :class:`vfrs.checkpoint.RunStopped`.

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
    ckpt = _checkpointer(scene, out, checkpoint_every, checkpoint_seconds)
    # Meshes and problem before the output folder is touched: a bad surface name, a probe
    # outside every body or a mesh too large for memory must not cost the old run's files
    # (--overwrite) or leave an empty run behind.
    clock = _Clock()
    seen: list = []  # every warning the run shows ("Category: message"), for its summary
    with _warnings_kept(seen):
        meshes, problem, effects, prepared = _build(scene, effects, clock)
    signals = contextlib.ExitStack()  # with out: SIGTERM/SIGINT stop the run cleanly (Checkpointer)
    folder = _lock_folder(signals, out, ckpt, overwrite, _resume)
    with signals:
        ran = what_runs(scene, problem, [e.name for e in effects])
        writer = _open_log(out, scene, problem, meshes, ran, prepared, folder, ckpt, _resume)
        signals.enter_context(_warnings_logged(writer, seen))
        rec = Recorder(scene, problem, effects)
        try:
            history, fields, probes, u, v = _march(scene, problem, effects, clock, writer, progress, rec, ckpt, _resume)
        except RunStopped as stop:
            _stopped(stop, rec, writer, folder)
            raise
        except BaseException as failure:
            exc = _failed(failure, scene, problem, rec, writer, folder)
            if exc is not failure:
                raise exc from failure
            raise
        res = Result(scene, problem, history, ran, clock.seconds, fields, probes, u, v, out)
        _complete(res, effects, rec, writer, folder, ckpt, clock, ran, t_start, seen)
        return res


def _checkpointer(scene, out, every, seconds) -> Checkpointer | None:
    """With ``out``: when to write checkpoints, the scene's ``[output] checkpoint_every`` /
    ``checkpoint_seconds`` unless given to :func:`run` (the options are checked here, before
    anything is built); without ``out``: None."""
    if out is None:
        return None
    if every is None and scene.output.checkpoint_every:
        every = scene.output.checkpoint_every
    if seconds is _SCENE_SECONDS:
        seconds = scene.output.checkpoint_seconds
    return Checkpointer(out, every, seconds)


def _build(scene, effects, clock):
    """The meshes, the problem and the effects (one per section the scene names unless
    ``effects`` is given), and the log lines of what the effects changed in the problem."""
    t0 = time.perf_counter()
    meshes = scene.build_meshes()
    t0 = clock.add("mesh", t0)
    problem = build_problem(scene, meshes)
    check_supports(scene, problem)  # a fold free to drift away: warned (an error when strict), in run.log
    if effects is None:
        effects = [EFFECTS[name](params) for name, params in scene.effects.items()]
    # What the effects change in the problem before the integrator factors it (the mass, for
    # the contact scheme mass_redistribution); before the output folder too, for the same reason.
    dynamic = scene.time.dynamic
    prepared = [line for e in effects for line in (e.prepare(problem, dynamic) or [])]
    clock.add("assembly", t0)
    return meshes, problem, effects, prepared


def _lock_folder(signals, out, ckpt, overwrite, resume) -> OutputFolder | None:
    """With ``out``: the output folder, locked for the whole run, and the checkpointer's
    SIGTERM/SIGINT handlers, both entered on ``signals``; a resumed run's lists cut back to
    its checkpoint. Without: None."""
    if out is None or ckpt is None:
        return None
    mode = "resume" if resume is not None else ("overwrite" if overwrite else "new")
    folder = signals.enter_context(OutputFolder(out, mode))  # locked for the whole run
    signals.enter_context(ckpt)
    if resume is not None:  # the folder is ours: cut the lists' files back to the checkpoint
        ckpt.journal.resume(resume["_rows"])
    return folder


def _open_log(out, scene, problem, meshes, ran, prepared, folder, ckpt, resume) -> OutputWriter | None:
    """With ``out``: the writer of the output folder, its run.log begun with what the run is
    (sizes, time, effects, warnings, mesh repairs, checkpoint interval). Without: None."""
    writer = OutputWriter(out, scene, problem, resume=resume is not None) if out is not None else None
    if writer and folder is not None:
        folder.files = writer.files
    if writer:
        writer.log(f"sizes: {problem.sizes()}")
        writer.log(f"time: {scene.time.to_dict()}")
        writer.log(f"effects: {', '.join(ran)}")
        for line in scene.plausibility:  # vfrs.scene.plausibility: likely unit slips, as warned
            writer.log(f"PlausibilityWarning: {line}")
        for body, mesh in zip(scene.bodies, meshes):
            if mesh.flipped:
                writer.log(f"mesh of body {body.name!r}: {mesh.flipped} of {mesh.n_tets} tetrahedra were negatively "
                           "oriented in the file and were flipped (two vertices swapped)")
            if mesh.merged:
                writer.log(f"mesh of body {body.name!r}: {mesh.merged} duplicate nodes merged (merge_nodes = true)")
            if body.mesh.get("refine"):
                writer.log(f"mesh of body {body.name!r}: refined {body.mesh['refine']} time(s), every tetrahedron into "
                           f"eight (refine = {body.mesh['refine']}): {mesh.n_tets} tetrahedra, {mesh.n_points} nodes")
        for line in prepared:
            writer.log(line)
        if ckpt is not None:
            writer.log("checkpoints: " + (f"every {ckpt.every} steps" if ckpt.every else
                                          f"every {ckpt.seconds:g} s of wall time" if ckpt.seconds else
                                          "on SIGTERM/SIGINT only") + f" ({CHECKPOINT})")
    return writer


@contextlib.contextmanager
def _warnings_kept(seen: list):
    """Every warning shown meanwhile is also added to ``seen`` (``"Category: message"``)."""
    with _warnings_logged(None, seen):
        yield


def _shown(scene, seen: list) -> list:
    """The warnings of a run for its summary: the scene's plausibility warnings (shown when it
    was loaded), then those the run showed, each once."""
    return list(dict.fromkeys([*(f"PlausibilityWarning: {m}" for m in scene.plausibility), *seen]))


@contextlib.contextmanager
def _warnings_logged(writer: OutputWriter | None, seen: list):
    """While a run runs, every warning it shows is added to ``seen`` (for its summary) and,
    with an output folder, is a line of its run.log (``warning: VfrsWarning: ...``), so that a
    run's warnings stay with the run: a sweep's workers print them to a stderr that no run
    folder keeps. Shown as before; the filters (``error`` under pytest, once per text by
    default) are not touched."""
    import warnings

    shown = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        seen.append(f"{category.__name__}: {message}")
        if writer is not None and not writer.closed:
            writer.log(f"warning: {category.__name__}: {message}")
        shown(message, category, filename, lineno, file, line)

    warnings.showwarning = show
    try:
        yield
    finally:
        warnings.showwarning = shown


def _stopped(stop: RunStopped, rec, writer, folder) -> None:
    """A run stopped by a signal: history, probes and the log's last line written, the folder
    left to the resumable run (the caller re-raises ``stop``)."""
    if writer:  # history.npz and probes.npz once, at the stop (checkpoints do not rewrite them)
        history, _, _ = rec.finish()
        writer.write_history(history)
        writer.write_probes(rec, history["t"])
        writer.log(f"stopped by {signal_name(stop.signum)} after step {stop.step} (t = {stop.t:.6g}); history and "
                   f"checkpoint written. Resume with: {resume_command(writer.out)}")
        writer.write_manifest("stopped")
        writer.close()
    if folder is not None:  # a resumable run now owns the folder
        folder.complete()


def _failed(failure: BaseException, scene, problem, rec, writer, folder) -> BaseException:
    """A failed run: what was recorded up to the failure written, the log says why it
    stopped, the folder kept or given back. Returns the exception to raise (``failure``, or
    :func:`_explained`'s clearer one, which the caller raises from ``failure``)."""
    exc = _explained(failure, scene, problem)
    if writer:  # keep what was recorded up to the failure, and say why it stopped
        history, _, _ = rec.finish()
        if history:
            writer.write_history(history)
            writer.write_probes(rec, history["t"])
        writer.log(f"run failed after {len(history.get('t', []))} recorded steps: {type(exc).__name__}: {exc}")
        if os.path.exists(os.path.join(writer.out, CHECKPOINT)):
            writer.log(f"the last checkpoint can be resumed: {resume_command(writer.out)}")
        writer.write_manifest("failed")
        writer.close()
    if folder is not None and writer:
        # A resumed run's files stay; a new run's stay if it got past its first step and
        # replaced nothing; otherwise the folder is given back as it was found.
        steps = len(history.get("t", [])) if history else 0
        folder.failed(writer.files, keep_run=folder.mode == "resume" or (folder.mode == "new" and steps > 1))
    return exc


def _complete(res: Result, effects, rec, writer, folder, ckpt, clock, ran, t_start, seen: list) -> None:
    """A completed run: the effects' finish, history and probes written, the results summary
    (with the warnings shown, ``seen``), the timings; the checkpoint removed and the folder released."""
    for e in effects:
        t0 = time.perf_counter()
        e.finish(res)
        clock.add(e.name, t0)
    if writer:
        t0 = time.perf_counter()
        writer.write_history(res.history)
        writer.write_probes(rec, res.history["t"])
        writer.flush()  # the last snapshots' background writes
        clock.add("output", t0)
    t0 = time.perf_counter()
    res.results = _results(res, writer, stacklevel=4)  # the warning points at run's caller, as before
    clock.add("analysis", t0)
    clock.seconds["total"] = time.perf_counter() - t_start
    res.timings = dict(clock.seconds)
    if res.results is not None:
        res.results.run.update(effects=list(ran), wall_time=clock.seconds["total"])
        res.results.warnings = _shown(res.scene, seen)
    if writer:
        if res.results is not None:
            writer.write_summary(res.results)
        ck = os.path.join(writer.out, CHECKPOINT)
        if os.path.exists(ck):  # the run is complete: its checkpoint is no longer needed
            os.remove(ck)
        if ckpt is not None:
            ckpt.journal.remove()
        writer.write_manifest("complete")
        writer.close(res.summary(effects=False))  # the effects are in run.log from the start
        if folder is not None:
            folder.complete()


def _explained(exc: BaseException, scene, problem) -> BaseException:
    """A factorization of a static integrator (no mass) that is not positive definite, with the body whose rigid-body
    motions no fixed DOF holds named (the solver alone can only say 'near row k of the
    permuted matrix'); any other exception as it is."""
    from .errors import SolverError
    from .mesh import held_rigid_modes

    if not (isinstance(exc, SolverError) and "not positive definite" in str(exc)) or scene.time.dynamic:
        return exc
    fixed = np.zeros(problem.n_dofs, dtype=bool)
    fixed[problem.fixed] = True
    loose = []
    for body in problem.bodies:
        held = fixed[body.dofs]
        rank = held_rigid_modes(body.mesh.points, held)
        if rank < 6:
            loose.append(f"body {body.name!r} ({int(held.sum())} fixed DOFs hold {rank} of its 6 rigid-body motions)")
    if not loose:
        return exc
    return SolverError(f"{scene.source}: the stiffness is not positive definite: {'; '.join(loose)}. A static "
                       "scene must fix every body's rigid-body motions: add [[bodies]] fixed conditions (for instance "
                       "rollers on three symmetry planes), or run it dynamic. (The solver said: {exc})".replace(
                           "{exc}", str(exc)))


def resume(out, progress: bool = True, checkpoint_every: int | None = None,
           checkpoint_seconds: float | None = None) -> Result:
    """Continues the run stopped (killed, SIGTERM, SIGINT, failed) in the folder ``out`` from
    its last checkpoint; the scene is ``out/scene.toml``, which must be the scene the run
    started with (same hash). History, probes and fields come out bit-identical to an
    uninterrupted run's. Checkpoint intervals: the run's own unless given."""
    out = os.fspath(out)
    data = read_checkpoint(out)
    path = os.path.join(out, "scene.toml")
    if not os.path.exists(path):
        raise CheckpointError(f"--resume {out}: no scene.toml there; the run cannot be resumed (start it again)")
    scene = Scene.load(path)
    if scene_hash(scene) != data["scene_hash"]:
        raise CheckpointError(f"--resume {out}: {path} is not the scene the run started with (its hash differs from "
                              "the checkpoint's): restore it, or start a new run with --overwrite")
    if data.get("versions") != versions():
        import warnings

        from .errors import VfrsWarning

        warnings.warn(f"--resume {out}: the checkpoint was written with {data.get('versions')}, this is {versions()}: "
                      "the resumed steps may differ in round-off from an uninterrupted run", VfrsWarning, stacklevel=2)
    every = data["checkpoint_every"] if checkpoint_every is None else checkpoint_every
    seconds = data["checkpoint_seconds"] if checkpoint_seconds is None else checkpoint_seconds
    return run(scene, out=out, progress=progress, checkpoint_every=every, checkpoint_seconds=seconds, _resume=data)


def signal_name(signum: int) -> str:
    import signal

    return signal.Signals(signum).name


def _results(res, writer, stacklevel=3):
    """The run's results summary (:func:`vfrs.analysis.summarize`). A failure of the analysis
    loses nothing already written: it is reported (warning, run.log, ``stacklevel`` as in
    :func:`warnings.warn`) and the summary is None."""
    from .analysis import summarize

    try:
        return summarize(res)
    except Exception as exc:  # noqa: BLE001 - the run's output is complete; say why the summary is missing
        import warnings

        from .errors import VfrsWarning

        msg = f"the results summary could not be computed: {type(exc).__name__}: {exc}"
        warnings.warn(msg, VfrsWarning, stacklevel=stacklevel)
        if writer:
            writer.log(msg)
        return None


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
        key = (t,) if self.static else tuple(ramp(t, ld.ramp)[0] for ld in p.loads)
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
                from .history import _arrays

                arr = _arrays({key: rows})[key]
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
    ``n_end``) until the periodicity test of the summary (:meth:`vfrs.analysis.RunView.periodicity`:
    the last ``until_cycles`` cycles of the window, the second half of the run so far, repeat
    in every value the effects give per cycle) holds on the history recorded so far, tested
    every :data:`UNTIL_CHECK` s of simulated time, or until ``until_cap`` (step ``n_cap``). The
    test reads the history only, so a resumed run ends where the uninterrupted one does, and
    the summary's ``window.periodic`` of the run's own history is the verdict that ended it."""

    def __init__(self, scene, n_end: int):
        import math

        out, h = scene.output, float(scene.time.step)
        self.n_end, self.cycles, self.cap = n_end, out.until_cycles, out.until_cap
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
        from .analysis import RunView

        test = RunView(_Recorded(rec.history, self.columns), last_cycles=self.cycles).periodicity()
        self.reached = test is not None and test.periodic
        return self.reached or at_cap

    def log(self, writer, k: int, t: float, t_end: float) -> None:
        if writer is None:
            return
        if self.reached:
            writer.log(f'until = "limit_cycle": the last {self.cycles} cycles repeat at t = {t:.6g} s (step {k}; '
                       f"[time] end {t_end:.6g} s); the run ends there")
        else:
            writer.log(f'until = "limit_cycle": the cap, until_cap = {self.cap:.6g} s (step {k}), reached before the '
                       f"last {self.cycles} cycles repeated; the run ends there and its summary says so")


def _march(scene, problem, effects, clock, writer, progress, rec, ckpt=None, resumed=None):
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
    bar = _progress_bar(n_last - k_start + 1, progress, desc)
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
    for e in effects:
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
