"""How the main job's committed converge studies were made (docs/convergence.md, "Steady
phonation"): examples/converge_results/m5_steady_steps (level 0 at 50 / 25 / 12.5 us),
m5_steady_meshes (levels 0 / 1 / 2 at 50 us) and m5_steady, the cross study of both that
examples/m5_steady.toml names.

1. The runs (hours: level 2 is about 50 min on one core), each study into a folder of its own:

       vfrs converge examples/m5_steady.toml --meshes 1 -o STEPS
       vfrs converge examples/m5_steady.toml --steps 1 -o MESHES

2. A summary number added after the runs, computed from each run's own history by this
   checkout's code, without running anything again (``add``): each run's ``summary.json``
   gains it, and the study's tables and figures are rebuilt from the runs (the study's notes
   say which numbers were added, and by which commit):

       python examples/steady_study.py add STEPS contact.closed_phase_pressure
       python examples/steady_study.py add MESHES contact.closed_phase_pressure

3. The committed folders (without the runs) and the cross study, which runs nothing:

       python examples/steady_study.py commit STEPS examples/converge_results/m5_steady_steps
       python examples/steady_study.py commit MESHES examples/converge_results/m5_steady_meshes
       vfrs converge examples/m5_steady.toml --design cross -o examples/converge_results/m5_steady \\
           --take examples/converge_results/m5_steady_steps --take examples/converge_results/m5_steady_meshes

``tests/test_steady_study.py`` checks the committed tables against today's scene and code;
``tests/test_steady_phonation.py`` re-runs the base run (level 0, 50 us) and compares, the
added number included.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

from vfrs.studies import converge as cv
from vfrs.studies.sweep import collect, summary_columns, write_table
from vfrs.summary import summarize

SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "m5_steady.toml")
#: What a committed study folder holds (no runs, no Parquet copies).
KEPT = ("converge.csv", "converge.json", "converge.md", "converge.txt", "errors.csv", "meshes.csv", "summary.csv",
        "figures")


def _commit() -> str:
    try:
        return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                              check=True, cwd=os.path.dirname(SCENE)).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "an unknown commit"


def _plan_of(study: dict):
    """The plan the study was made with: its ladders' lengths on today's scene."""
    steps, meshes = len(study["steps"]), len(study["meshes"])
    return cv.plan(_scene(), steps=steps, meshes=meshes)


def _scene():
    """Today's scene, named as the studies name it (relative to the working folder: run from
    the repository's root)."""
    import vfrs

    rel = os.path.relpath(SCENE)
    return vfrs.Scene.load(SCENE if rel.startswith("..") else rel)


def add(folder: str, names: list) -> None:
    """Adds the summary numbers ``names`` (``section.key``), computed from each run's history by
    this checkout, to the runs' ``summary.json`` in ``folder/runs`` and rebuilds the study."""
    study = cv.load(folder)
    rows = []
    for run in study["runs"]:
        path = os.path.join(folder, "runs", run["id"])
        with open(os.path.join(path, "summary.json")) as fh:
            saved = json.load(fh)
        fresh = summarize(path).to_dict()
        for name in names:
            section, key = name.split(".", 1)
            saved.setdefault(section, {})[key] = fresh[section][key]
        with open(os.path.join(path, "summary.json"), "w") as fh:
            json.dump(saved, fh, indent=1)
        rows.append(collect(path, {}))
    p = _plan_of(study)
    for n in study.get("notes", []):  # the study's own notes, each once
        p.notes += [] if n in p.notes else [n]
    note = f"added after the runs, from each run's history by the code at {_commit()}: {', '.join(names)}"
    p.notes += [] if note in p.notes else [note]
    write_table(rows, folder, summary_columns(["mesh", "step"], []))
    cv.finish(p, rows, folder)


def commit(folder: str, target: str) -> None:
    """Copies a study's tables and figures (not its runs) to ``target``."""
    os.makedirs(target, exist_ok=True)
    for name in KEPT:
        src, dst = os.path.join(folder, name), os.path.join(target, name)
        if os.path.isdir(src):
            shutil.rmtree(dst, ignore_errors=True)
            shutil.copytree(src, dst)
        else:
            shutil.copy2(src, dst)


def main(argv: list) -> int:
    if len(argv) >= 3 and argv[0] == "add":
        add(argv[1], argv[2:])
    elif len(argv) == 3 and argv[0] == "commit":
        commit(argv[1], argv[2])
    else:
        print(__doc__)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
