"""Error bars of a single run: from a converge study's folder (``vfrs run --errors-from``,
:func:`with_study_errors`) or from a companion run at half the step (``vfrs run
--error-bars``, :func:`with_step_errors`: Roache's two-run GCI, the step part only)."""

from __future__ import annotations

import json
import math
import os

from ...errors import VfrsError
from .plan import STEP_RATIO, scene_key, scene_value, step_ladder
from .report import CONVERGE_FILE


def load(out) -> dict:
    """``converge.json`` of a study folder, or VfrsError saying what is missing."""
    path = os.path.join(os.fspath(out), CONVERGE_FILE)
    try:
        with open(path) as fh:
            return json.load(fh)
    except FileNotFoundError:
        raise VfrsError(f"{out}: no {CONVERGE_FILE} here: run `vfrs converge SCENE -o {out}` first") from None
    except ValueError as e:
        raise VfrsError(f"{path}: cannot be read ({e}); run `vfrs converge` into the folder again") from None


def errors_for(scene_dict: dict, study: dict) -> dict | None:
    """The errors a study (``converge.json`` as read by :func:`load`) gives a run of
    ``scene_dict`` (a resolved scene): {quantity: error row} when the scene is the study's up
    to its step and mesh and sits on one of its rungs, else None."""
    if scene_key(scene_dict) != study.get("scene_key"):
        return None

    def on(rungs):
        for r in rungs:
            if all(scene_value(scene_dict, k) == v for k, v in r["changes"].items()):
                return r["index"]
        return None

    i, j = on(study["meshes"]), on(study["steps"])
    if i is None or j is None:
        return None
    base = study.get("base", {})
    if study.get("design", "grid") == "cross" and (i, j) != (base.get("mesh"), base.get("step")):
        return None  # the cross design estimates the base run's errors only
    return {e["quantity"]: e for e in study["errors"] if e["mesh_level"] == i and e["step_level"] == j}


def with_study_errors(summary, scene_dict: dict, folder):
    """``summary`` (a run's :class:`vfrs.summary.Summary`) with each number's error from the
    converge study in ``folder`` (step part + mesh part at the run's own rungs); every number
    unknown, and a note saying why, when the study is of another scene or the run's step or
    mesh is not one of its rungs."""
    study = load(folder)
    errors = errors_for(scene_dict, study)
    folder = display_path(folder)
    source = f"the converge study in {folder} (step part + mesh part, GCI with Fs = 1.25)"
    if errors is not None:
        return summary.with_errors(errors, source)
    return summary.with_errors({}, folder, f"unknown: {why_not(scene_dict, study)}")


def why_not(scene_dict: dict, study: dict) -> str | None:
    """Why a study (``converge.json`` as read by :func:`load`) gives a run of ``scene_dict`` no
    errors, in words; None when it gives them."""
    if errors_for(scene_dict, study) is not None:
        return None
    if scene_key(scene_dict) != study.get("scene_key"):
        return ("it studies another scene (the scenes differ in more than the step, the mesh level and the output "
                "intervals)")
    if study.get("design", "grid") == "cross":
        base = study["base"]
        mesh, step = study["meshes"][base["mesh"]]["name"], study["steps"][base["step"]]["name"]
        return (f"it is a cross study (--design cross): it gives the base run's errors only (mesh {mesh}, step "
                f"{step}); run there, or make the grid study (--design grid) for this run's step and mesh")
    return ("this run's step or mesh is not one of its rungs (steps " + ", ".join(
        f"{r['h'] * 1e6:.4g} us" for r in study["steps"] if math.isfinite(r.get("h", math.nan)))
        + "; meshes " + ", ".join(r["name"] for r in study["meshes"]) + ")")


def display_path(folder) -> str:
    """``folder`` as a reader wants it: relative to the working folder when inside it (a
    scene's [output] errors_from is kept absolute)."""
    path = os.fspath(folder)
    rel = os.path.relpath(path) if os.path.isabs(path) else path
    return path if rel.startswith("..") else rel


#: Roache's factor of safety for an estimate from two runs, and the order assumed for it: the
#: contact scheme's (an impact costs HHT-alpha its second order; docs/converge.md).
FS_TWO_RUNS = 3.0
ASSUMED_ORDER = 1.0


def step_companion(scene):
    """The scene with its step halved (``[output] every`` doubled): what ``vfrs run
    --error-bars`` runs beside it."""
    from ...scene import Scene

    data = scene.to_dict()
    if data.get("time", {}).get("mode") != "dynamic":
        raise VfrsError(f"{scene.source}: --error-bars halves the time step: a static scene has none (use vfrs "
                        "converge for the mesh part)")
    ladder = step_ladder(data, 2)
    from ...scene.keypath import set_key

    for k, v in ladder[1].changes.items():
        set_key(data, k, v)
    return Scene.from_dict(data, source=f"{scene.source} (step halved)")


def two_run_errors(summary, companion, ratio: float = STEP_RATIO, order: float = ASSUMED_ORDER,
                   fs: float = FS_TWO_RUNS) -> dict:
    """{quantity: error} of a run from a companion run at the step divided by ``ratio``:
    Roache's two-run GCI of the coarser run, ``fs |phi_h - phi_h/r| r^p / (r^p - 1) / |phi_h|``
    with the assumed order ``p``."""
    out = {}
    f = ratio ** order
    for name, items in summary.sections.items():
        for key, q in items.items():
            other = companion.sections.get(name, {}).get(key)
            if other is None or not (math.isfinite(q.value) and math.isfinite(other.value)):
                continue
            if q.value == other.value:
                out[f"{name}.{key}"] = {"relative": 0.0, "bound": True, "step_part": 0.0}
            elif q.value != 0:
                rel = fs * abs(q.value - other.value) * f / (f - 1) / abs(q.value)
                out[f"{name}.{key}"] = {"relative": rel, "bound": True, "step_part": rel}
    return out


def with_step_errors(scene, summary, progress: bool = False):
    """``summary`` with the step part of each number's error, from a companion run of
    ``scene`` at half its step (:func:`two_run_errors`); the mesh part stays unknown."""
    from ...run import run

    companion = run(step_companion(scene), progress=progress).results
    if companion is None:
        raise VfrsError("--error-bars: the companion run at half the step has no summary")
    return summary.with_errors(two_run_errors(summary, companion), "a companion run at half the step",
                               f"the step part only (two runs: Fs = {FS_TWO_RUNS:g}, order {ASSUMED_ORDER:g} "
                               "assumed); the mesh part is not included: vfrs converge gives both")
