"""``vfrs.run``: build what the scene asks for, march it, record, write.

Only the parts a scene names are built and called: without ``[flow]`` no flow code runs,
without ``[contact]`` no detection. ``res.effects`` lists what ran and ``res.timings`` what each
part cost.

One march loop serves every integrator (:mod:`vfrs.dynamics.integrators`, chosen by the
scene's ``[time] mode``): per step it gathers the loads (external forces and the effects'
explicit forces), asks the integrator to step (the integrator calls the effects' ``predict``
and ``correct`` hooks), checks the solution is bounded and records.

The package: :func:`run` and :func:`resume` here (what is built, in which order);
``vfrs.run.march`` the loop and its checkpoints; ``vfrs.run.lifecycle`` the run
folder's side (locked, logged, and written when a run stops, fails or completes).
"""

from __future__ import annotations

import contextlib
import os
import time

from ..checkpoint import CHECKPOINT, Checkpointer, CheckpointError, RunStopped, read_checkpoint, scene_hash
from ..dynamics import build_problem
from ..effects import EFFECTS
from ..history import Recorder
from ..output.writer import versions
from ..result import Result
from ..scene import Scene
from ..scene.plausibility import check_supports
from .lifecycle import complete, failed, lock_folder, open_log, stopped, warnings_kept, warnings_logged
from .march import RESUME_READS, Clock, march

__all__ = ["run", "resume", "what_runs"]


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
    clock = Clock()
    seen: list = []  # every warning the run shows ("Category: message"), for its summary
    with warnings_kept(seen):
        meshes, problem, effects, prepared = _build(scene, effects, clock)
    signals = contextlib.ExitStack()  # with out: SIGTERM/SIGINT stop the run cleanly (Checkpointer)
    folder = lock_folder(signals, out, ckpt, overwrite, _resume)
    with signals:
        ran = what_runs(scene, problem, [e.name for e in effects])
        writer = open_log(out, scene, problem, meshes, ran, prepared, folder, ckpt, _resume)
        signals.enter_context(warnings_logged(writer, seen))
        rec = Recorder(scene, problem, effects)
        try:
            history, fields, probes, u, v = march(scene, problem, effects, clock, writer, progress, rec, ckpt, _resume)
        except RunStopped as stop:
            stopped(stop, rec, writer, folder)
            raise
        except BaseException as failure:
            exc = failed(failure, scene, problem, rec, writer, folder)
            if exc is not failure:
                raise exc from failure
            raise
        res = Result(scene, problem, history, ran, clock.seconds, fields, probes, u, v, out)
        complete(res, effects, rec, writer, folder, ckpt, clock, ran, t_start, seen)
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


def resume(out, progress: bool = True, checkpoint_every: int | None = None,
           checkpoint_seconds: float | None = None) -> Result:
    """Continues the run stopped (killed, SIGTERM, SIGINT, failed) in the folder ``out`` from
    its last checkpoint; the scene is ``out/scene.toml``, which must be the scene the run
    started with (same hash). History, probes and fields come out bit-identical to an
    uninterrupted run's. Checkpoint intervals: the run's own unless given."""
    out = os.fspath(out)
    data = read_checkpoint(out)
    lacks = [k for k in RESUME_READS if k not in data]
    if lacks:  # a doctored or foreign file: the resume would stop at the first missing key
        raise CheckpointError(f"{os.path.join(out, CHECKPOINT)}: not a checkpoint of a vfrs run (no {', '.join(lacks)}); "
                              "start the run again with --overwrite")
    path = os.path.join(out, "scene.toml")
    if not os.path.exists(path):
        raise CheckpointError(f"--resume {out}: no scene.toml there; the run cannot be resumed (start it again)")
    scene = Scene.load(path)
    if scene_hash(scene) != data["scene_hash"]:
        raise CheckpointError(f"--resume {out}: {path} is not the scene the run started with (its hash differs from "
                              "the checkpoint's): restore it, or start a new run with --overwrite")
    if data.get("versions") != versions():
        import warnings

        from ..errors import VfrsWarning

        warnings.warn(f"--resume {out}: the checkpoint was written with {data.get('versions')}, this is {versions()}: "
                      "the resumed steps may differ in round-off from an uninterrupted run", VfrsWarning, stacklevel=2)
    every = data["checkpoint_every"] if checkpoint_every is None else checkpoint_every
    seconds = data["checkpoint_seconds"] if checkpoint_seconds is None else checkpoint_seconds
    return run(scene, out=out, progress=progress, checkpoint_every=every, checkpoint_seconds=seconds, _resume=data)
