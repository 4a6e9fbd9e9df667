"""The ``vfrs`` command: ``vfrs run scene.toml -o out/``, ``vfrs info scene.toml``, ``vfrs plot out/``,
``vfrs modes scene.toml -o out/``, ``vfrs converge scene.toml -o out/``, ``vfrs bench accuracy``.

``--set key.path=value`` overrides a scene value before validation (the value is read as
TOML: ``--set time.end=0.01``, ``--set 'bodies[0].material.E=4e3'``), handy for sweeps.
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings

from .checkpoint import DEFAULT_SECONDS
from .errors import VfrsError, VfrsWarning
from .scene.overrides import apply_override as _apply_override, load_scene  # noqa: F401 (vfrs.cli.load_scene)


def cmd_run(args) -> int:
    from .checkpoint import RunStopped
    from .run import resume, run

    ck = {"checkpoint_every": args.checkpoint_every, "checkpoint_seconds": args.checkpoint_seconds}
    shown = len(_SHOWN)  # the warnings shown from here on are repeated after the summary
    study, hint = None, None
    try:
        if args.resume is not None:
            if args.scene is not None or args.out is not None or args.set or args.overwrite:
                raise VfrsError(f"--resume {args.resume}: give no scene, -o, --set or --overwrite with it (the run "
                                "continues with the scene.toml in its folder)")
            if args.errors_from or args.error_bars:
                raise VfrsError(f"--resume {args.resume}: error bars are added to a run started with them; run "
                                "again with --errors-from or --error-bars")
            res = _resume(args.resume, resume, progress=not args.no_progress, **ck)
            out = args.resume
        else:
            if args.scene is None:
                raise VfrsError("vfrs run: give a scene file (vfrs run SCENE.toml -o OUT), or --resume OUT")
            if args.errors_from and args.error_bars:
                raise VfrsError("give --errors-from STUDY or --error-bars, not both")
            scene = load_scene(args.scene, args.set)
            if args.out is None:
                print("vfrs: no -o given: nothing is saved (add -o OUT to keep the history, fields and checkpoints)",
                      file=sys.stderr)
            elif args.checkpoint_seconds is None:
                del ck["checkpoint_seconds"]  # the scene's [output] checkpoint_seconds (default 60 s)
            study, hint = _study_of(args, scene)
            res = run(scene, out=args.out, progress=not args.no_progress, overwrite=args.overwrite, **ck)
            out = args.out
            if res.results is not None and (study or args.error_bars):
                _add_error_bars(res, scene, args, study)
    except RunStopped as stop:
        print(f"vfrs: {stop}", file=sys.stderr)
        return stop.exit_code
    _keep_warnings(res.results, _SHOWN[shown:])
    if out and res.results is not None:
        res.results.save(os.path.join(out, "summary.json"))  # with its errors and every warning shown
    print(res.summary())
    if out:
        print(f"output: {out}")
    if res.results is not None and res.results.sections and not (study or args.error_bars):
        print(hint or _error_bars_hint(args.scene or os.path.join(args.resume, "scene.toml")))
    if res.results is not None and res.results.warnings:
        print(res.results.warnings_text())
    return 0


def _resume(out, resume, **kw):
    """``resume(out, **kw)``; a scene.toml there that does not load (cut short, edited) is one
    line saying what to do: the run needs the scene it started with."""
    from .output.reader import damaged
    from .errors import SceneError

    try:
        return resume(out, **kw)
    except SceneError as exc:
        path = os.path.join(out, "scene.toml")
        if not str(exc).startswith(path):
            raise
        raise SceneError(damaged(path, exc, "--resume needs the scene the run started with: restore it (a stopped "
                                 "run's history.npz holds a copy, its array 'scene'), or start the run again with "
                                 f"vfrs run SCENE -o {out} --overwrite")) from None


def _add_error_bars(res, scene, args, study) -> None:
    """The summary of ``res`` with each number's error: from the converge study in the folder
    ``study`` (--errors-from, else the scene's [output] errors_from), or (--error-bars) the
    step part, from a companion run at half the step."""
    from .studies.converge import with_step_errors, with_study_errors

    if study:
        res.results = with_study_errors(res.results, scene.to_dict(), study)
    else:
        print("vfrs: --error-bars: the companion run at half the step", file=sys.stderr)
        res.results = with_step_errors(scene, res.results, progress=not args.no_progress)


def _study_of(args, scene) -> tuple:
    """(the converge study whose errors the run prints, or None; the line said instead when
    the scene's own study, [output] errors_from, does not apply to this run: another scene
    (after --set) or a step or mesh that is not one of its rungs). --errors-from is used as
    given (its numbers then say '+- unknown' and why); --error-bars: no study."""
    from .studies.converge import display_path, load as load_study, why_not

    study = None if args.error_bars else args.errors_from or scene.output.errors_from
    if study is None:
        return None, None
    data = load_study(study)  # a folder without a study: said before the run, not after
    why = None if args.errors_from else why_not(scene.to_dict(), data)
    if why is None:
        return study, None
    return None, (f"error bars: none: the scene's converge study ([output] errors_from = {display_path(study)}) does "
                  f"not apply to this run: {why}; --errors-from STUDY with a study of this run, or --error-bars for the "
                  "step part")


def _error_bars_hint(scene_path) -> str:
    """The line vfrs run prints when its numbers have no error bars: how to get them."""
    return (f"error bars: none (the scene names no converge study); `vfrs converge {scene_path} -o STUDY` makes one, "
            f"then `vfrs run {scene_path} --errors-from STUDY` (or [output] errors_from = \"STUDY\" in the scene) prints "
            "each number with its error; --error-bars: the step part alone, from one more run at half the step")


#: Every warning shown by the vfrs command ("Category: message"), in order (:func:`_show_warning`).
_SHOWN: list = []


def _keep_warnings(summary, shown: list) -> None:
    """Adds to a run's summary the warnings the command showed outside the run (loading the
    scene: plausibility, locking), each once: vfrs run prints them after the summary and
    summary.json keeps them."""
    if summary is not None:
        summary.warnings = list(dict.fromkeys([*summary.warnings, *shown]))


def info_text(scene) -> str:
    """What a run of ``scene`` would do: bodies and sizes, effects, steps, outputs."""
    from .dynamics.problem import build_problem
    from .run import what_runs

    meshes = scene.build_meshes()
    problem = build_problem(scene, meshes)  # what vfrs.run builds
    lines = [f"scene: {scene.source}" + (f" ({scene.title})" if scene.title else "")]
    for b, m in zip(scene.bodies, meshes):
        fixed = ", ".join(c.name for c in b.fixed) or "none"
        loads = ", ".join(ld.name for ld in b.loads) or "none"
        mesh = b.mesh.get("builtin") or os.path.basename(b.mesh["path"])
        lines.append(
            f"body {b.name!r}: mesh {mesh}, {m.n_points} nodes, {m.n_tets} tetrahedra, {m.n_dofs} DOFs; "
            f"material {b.material_dict().get('model', 'per region')}; fixed: {fixed}; loads: {loads}"
        )
    sizes = problem.sizes()
    lines.append(f"total: {sizes['nodes']} nodes, {sizes['dofs']} DOFs, {sizes['free_dofs']} free")
    lines.append(f"effects that would run: {', '.join(what_runs(scene, problem))}")  # the run's own list
    t = scene.time
    lines.append(f"time: {t.integrator.describe(t.params, t.n_steps)}")
    o = scene.output
    lines.append(f"output: fields {', '.join(o.fields)} every {o.every} steps; {len(o.probes)} probes"
                 + (f"; goes on past the end until the last {o.until_cycles} glottal cycles repeat, at most to "
                    f"{o.until_cap * 1e3:g} ms" if getattr(o, "until", "end") == "limit_cycle" else ""))
    return "\n".join(lines)


def cmd_info(args) -> int:
    print(info_text(load_scene(args.scene, args.set)))
    return 0


def cmd_modes(args) -> int:
    from .modes import modes

    if args.n < 1:
        raise VfrsError(f"vfrs modes -n {args.n}: expected 1 or more modes per body")
    result = modes(load_scene(args.scene, args.set), n=args.n)
    print(result.table())
    if args.out:
        written = result.write(args.out)
        print(f"wrote {len(written)} files to {args.out} (<body>_modes.pvd: the mode shapes, one per timestep; "
              "modes.csv)")
    return 0


def cmd_plot(args) -> int:
    from .plot import draw_run, require_matplotlib

    require_matplotlib()
    written, skipped = draw_run(args.out, args.dest)  # a missing or damaged history.npz: one line
    for path in written:
        print(f"wrote {path}")
    for what, why in skipped:
        print(f"skipped {what}: {why}")
    return 0


def cmd_bench_accuracy(args) -> int:
    from .plot import require_matplotlib

    require_matplotlib()  # the report ends with plots: say so before minutes of runs, not after
    from .studies.accuracy import run_accuracy
    from .studies.accuracy.problems import PROBLEMS
    from .studies.sweep import check_engine

    problems = args.problem or None
    for p in problems or []:
        if p not in PROBLEMS:
            raise VfrsError(f"unknown problem {p!r}; choose from {sorted(PROBLEMS)}")
    check_engine(args.serial, args.workers, args.scheduler, args.scheduler_file)
    report = run_accuracy("quick" if args.quick else "full", problems=problems, out=args.out, progress=True,
                          workers=args.workers or (None if args.scheduler or args.scheduler_file else 1),
                          scheduler=args.scheduler, scheduler_file=args.scheduler_file, serial=args.serial,
                          runs=args.runs)
    for name in dict.fromkeys(r.problem for r in report.rows):
        print(report.recommendation(name))
    print(f"wrote {args.out}/accuracy.md, accuracy.csv, accuracy.json, pareto_*.png")
    return 0


RUN_DESCRIPTION = """\
Run a scene: build its bodies and the effects it names (flow, contact, ...), march it in
time (or solve it, static), and print the results summary: the contact force, pressure and
area, f0, quotients and flow, each over the whole run or the analysis window, then the
timings. With a converge study (--errors-from, or the scene's [output] errors_from) each
number is printed with its error; otherwise one line says how to get errors. The warnings
the run showed are repeated after the summary.

With -o OUT the run is kept in OUT: scene.toml (the resolved scene), history.npz/.csv,
probes, the fields for ParaView (.pvd/.vtu), summary.json, run.log and, while it runs,
checkpoints (vfrs run --resume OUT continues a stopped run); vfrs plot OUT draws its
figures. Without -o nothing is written (docs/running.md)."""

RUN_EPILOG = """\
example:
  vfrs run examples/m5_collision.toml -o out/m5_collision
  vfrs run examples/cantilever.toml --set time.end=0.01"""


def build_parser() -> argparse.ArgumentParser:
    from .studies.accuracy.problems import PROBLEMS

    ap = argparse.ArgumentParser(prog="vfrs", description="Vocal-fold collision with 3-D FEM: run and inspect scenes.")
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene (TOML), or continue a stopped run (--resume OUT)",
                       description=RUN_DESCRIPTION, epilog=RUN_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    r.add_argument("scene", nargs="?", help="scene file (.toml)")
    r.add_argument("-o", "--out", help="output folder (scene used, history.npz/.csv, .pvd/.vtu fields, run.log, "
                                       "checkpoints); a folder of another run is refused unless --overwrite")
    r.add_argument("--overwrite", action="store_true",
                   help="replace the run in the -o folder (removes only that run's own files)")
    r.add_argument("--resume", metavar="OUT", help="continue the run stopped in OUT from its last checkpoint")
    r.add_argument("--checkpoint-every", type=int, metavar="N", help="with -o: a checkpoint every N steps "
                                                                      "(default: the scene's [output] checkpoint_every, "
                                                                      "else by wall time)")
    r.add_argument("--checkpoint-seconds", type=float, metavar="S",
                   help=f"with -o: a checkpoint every S seconds of wall time (default: the scene's [output] "
                        f"checkpoint_seconds, {DEFAULT_SECONDS:g} s; 0: only on SIGTERM/SIGINT)")
    r.add_argument("--errors-from", metavar="STUDY", help="each number of the summary with its estimated error, "
                   "from the converge study in the folder STUDY (vfrs converge; the same scene at one of its steps "
                   "and meshes); default: the scene's [output] errors_from")
    r.add_argument("--error-bars", action="store_true", help="each number with the step part of its error, from a "
                   "companion run at half the step (about 2x the time more; the mesh part needs vfrs converge)")
    r.add_argument("--no-progress", action="store_true", help="no progress bar")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a scene value (TOML syntax)")
    r.set_defaults(process=cmd_run)
    i = sub.add_parser("info", help="what a run would do: bodies, sizes, effects, steps")
    i.add_argument("scene")
    i.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")
    i.set_defaults(process=cmd_info)
    mo = sub.add_parser("modes", help="the lowest eigenfrequencies and mode shapes of each body with its fixed "
                                      "conditions (no contact, flow or loads)")
    mo.add_argument("scene", help="scene file (.toml): its bodies, materials and fixed conditions (flow, contact and "
                    "loads are left out)")
    mo.add_argument("-n", type=int, default=10, metavar="N", help="modes per body (default 10)")
    mo.add_argument("-o", "--out", help="folder for the mode shapes (<body>_mode_NN.vtu, <body>_modes.pvd, modes.csv)")
    mo.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="override a scene value (TOML syntax)")
    mo.set_defaults(process=cmd_modes)
    pl = sub.add_parser("plot", help="the standard figures of a run from its output folder (PNGs in OUT/plots)")
    pl.add_argument("out", metavar="OUT", help="output folder of `vfrs run ... -o OUT`")
    pl.add_argument("-o", "--dest", help="folder for the PNGs (default OUT/plots)")
    pl.set_defaults(process=cmd_plot)
    sub.add_parser("sweep", help="many runs of one scene on dask.distributed, one table of results: "
                                 "vfrs sweep SWEEP.toml -o OUT (vfrs sweep -h; docs/sweeps.md)")
    sub.add_parser("converge", help="how close a scene's numbers are and what closer costs: the scene at steps h, "
                                    "h/2, h/4 and three meshes (vfrs converge SCENE -o OUT; vfrs converge -h; "
                                    "docs/converge.md)")
    b = sub.add_parser("bench", help="benchmarks: what accuracy costs in time")
    bsub = b.add_subparsers(dest="bench", required=True)
    acc = bsub.add_parser("accuracy", help="error vs wall time over contact methods, resolutions and time steps")
    acc.add_argument("--quick", action="store_true", help="a small grid (a few minutes on 2 cores)")
    quick = [n for n, p in PROBLEMS.items() if "quick" in p.modes]
    acc.add_argument("--problem", action="append", metavar="NAME",
                     help=f"one of {', '.join(PROBLEMS)} (repeatable; default: {', '.join(quick)} with --quick, all "
                          "otherwise)")
    acc.add_argument("-o", "--out", default="out/accuracy", help="output folder (default out/accuracy)")
    acc.add_argument("--workers", type=int, metavar="N", help="the runs on N dask workers (default 1: the wall "
                     "times are the product; side by side they slow each other); with --scheduler: wait for N")
    acc.add_argument("--scheduler", metavar="ADDR", help="run on an existing dask scheduler (tcp://host:8786)")
    acc.add_argument("--scheduler-file", metavar="PATH", help="an existing dask cluster's scheduler file")
    acc.add_argument("--serial", action="store_true", help="no dask: every run in this process")
    acc.add_argument("--runs", metavar="DIR", help="the run folders (default OUT/sweep; finished runs of the same "
                     "vfrs build are not run again)")
    acc.set_defaults(process=cmd_bench_accuracy)
    return ap


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv[:1] == ["sweep"]:  # its own parser and options (vfrs sweep -h)
        from .studies.sweep import main as sweep_main

        return sweep_main(argv[1:])
    if argv[:1] == ["converge"]:  # its own parser and options (vfrs converge -h)
        from .studies.converge import main as converge_main

        with warnings.catch_warnings():
            warnings.showwarning = _show_warning
            return converge_main(argv[1:])
    args = build_parser().parse_args(argv)
    with warnings.catch_warnings():
        warnings.showwarning = _show_warning
        return _process(args)


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """vfrs's own warnings as one line each, 'vfrs: warning: Category: message' (no
    source line of the package or of the console script); others as Python prints them."""
    _SHOWN.append(f"{category.__name__}: {message}")
    if issubclass(category, VfrsWarning):
        print(f"vfrs: warning: {category.__name__}: {message}", file=sys.stderr if file is None else file)
    else:
        print(warnings.formatwarning(message, category, filename, lineno, line), end="",
              file=sys.stderr if file is None else file)


def _process(args) -> int:
    try:
        return args.process(args)
    except VfrsError as e:
        print(f"vfrs: error: {e}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # `vfrs info x.toml | head`: not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:  # Ctrl-C outside a run with -o (or twice): no traceback
        print("vfrs: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
