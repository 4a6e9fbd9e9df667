"""The run folder's side of a run: the folder locked, run.log begun, the warnings kept, and the
end of a run written (stopped by a signal, failed, or complete with its summary)."""

from __future__ import annotations

import contextlib
import os
import time

import numpy as np

from ..checkpoint import CHECKPOINT, RunStopped, resume_command
from ..output.writer import OutputFolder, OutputWriter
from ..result import Result


def lock_folder(signals, out, ckpt, overwrite, resume) -> OutputFolder | None:
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


def open_log(out, scene, problem, meshes, ran, prepared, folder, ckpt, resume) -> OutputWriter | None:
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
def warnings_kept(seen: list):
    """Every warning shown meanwhile is also added to ``seen`` (``"Category: message"``)."""
    with warnings_logged(None, seen):
        yield


def _shown(scene, seen: list) -> list:
    """The warnings of a run for its summary: the scene's plausibility warnings (shown when it
    was loaded), then those the run showed, each once."""
    return list(dict.fromkeys([*(f"PlausibilityWarning: {m}" for m in scene.plausibility), *seen]))


@contextlib.contextmanager
def warnings_logged(writer: OutputWriter | None, seen: list):
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


def stopped(stop: RunStopped, rec, writer, folder) -> None:
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


def failed(failure: BaseException, scene, problem, rec, writer, folder) -> BaseException:
    """A failed run: what was recorded up to the failure written, the log says why it
    stopped, the folder kept or given back. Returns the exception to raise (``failure``, or
    :func:`explained`'s clearer one, which the caller raises from ``failure``)."""
    exc = explained(failure, scene, problem)
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


def complete(res: Result, effects, rec, writer, folder, ckpt, clock, ran, t_start, seen: list) -> None:
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
    res.results = summary_of(res, writer, stacklevel=4)  # the warning points at run's caller, as before
    clock.add("analysis", t0)
    clock.seconds["total"] = time.perf_counter() - t_start
    res.timings = dict(clock.seconds)
    if res.results is not None:
        res.results.run.update(effects=list(ran), wall_time=clock.seconds["total"])
        res.results.warnings = _shown(res.scene, seen)
    if writer:
        if res.results is not None:
            writer.write_summary(res.results)
        # The manifest says complete before the checkpoint goes: a kill between the two leaves a
        # complete run with a spare checkpoint (--resume: "complete"), never a folder with
        # neither a checkpoint nor a complete manifest.
        writer.write_manifest("complete")
        ck = os.path.join(writer.out, CHECKPOINT)
        if os.path.exists(ck):  # the run is complete: its checkpoint is no longer needed
            os.remove(ck)
        if ckpt is not None:
            ckpt.journal.remove()
        writer.close(res.summary(effects=False))  # the effects are in run.log from the start
        if folder is not None:
            folder.complete()


def explained(exc: BaseException, scene, problem) -> BaseException:
    """A factorization of a static integrator (no mass) that is not positive definite, with the body whose rigid-body
    motions no fixed DOF holds named (the solver alone can only say 'near row k of the
    permuted matrix'); any other exception as it is."""
    from ..errors import SolverError
    from ..mesh import held_rigid_modes

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


def signal_name(signum: int) -> str:
    import signal

    return signal.Signals(signum).name


def summary_of(res, writer, stacklevel=3):
    """The run's results summary (:func:`vfrs.summary.summarize`). A failure of the analysis
    loses nothing already written: it is reported (warning, run.log, ``stacklevel`` as in
    :func:`warnings.warn`) and the summary is None."""
    from ..summary import summarize

    try:
        return summarize(res)
    except Exception as exc:  # noqa: BLE001 - the run's output is complete; say why the summary is missing
        import warnings

        from ..errors import VfrsWarning

        msg = f"the results summary could not be computed: {type(exc).__name__}: {exc}"
        warnings.warn(msg, VfrsWarning, stacklevel=stacklevel)
        if writer:
            writer.log(msg)
        return None
