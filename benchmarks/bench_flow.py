"""What the glottal flow models and the tract coupling cost per structural step (issue 46: the
viscous model and interactive coupling at most 5 % of a medium step).

Runs the main job (examples/m5_steady.toml) on level 1 of the systematic family (the medium
mesh: 86 190 DOFs) for 20 ms at 50 us, once with each flow model, and the /a/ voice
(examples/m5_vowel_a.toml on the same mesh and step) with the viscous model coupled two ways and
interactively; each run's own timings give the seconds per step of the whole step and of the
[flow] and [acoustics] effects. The tract advances inside the [flow] effect's call (its samples
up to the step and its junction: the flow asks it for the pressures), so its cost is in the
flow's time; the [acoustics] effect's own is its record. Three repetitions of each, the median
kept.

    python benchmarks/bench_flow.py            (about 5 min on 2 cores)

Writes benchmarks/results/flow/bench_flow.json: per configuration the steps, the median seconds
per step of the step, flow and acoustics, and the shares of the step.
"""

from __future__ import annotations

import json
import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("RAYON_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import vfrs  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "benchmarks" / "results" / "flow" / "bench_flow.json"
END, STEP, LEVEL, REPEATS = 0.02, 50e-6, 1, 3


def scene(name: str, model: str, coupling: str | None) -> dict:
    d = vfrs.Scene.load(ROOT / "examples" / name).to_dict()
    for b in d["bodies"]:
        b["mesh"].pop("resolution", None)
        b["mesh"].update(family="systematic", level=LEVEL)
    d["flow"]["model"] = model
    if coupling is not None:
        d["acoustics"]["coupling"] = coupling
    d["time"].update(step=STEP, end=END)
    d["output"] = {"every": 1000}
    return d


CONFIGS = {
    "steady, bernoulli": ("m5_steady.toml", "bernoulli", None),
    "steady, viscous": ("m5_steady.toml", "viscous", None),
    "vowel /a/, viscous, two_way": ("m5_vowel_a.toml", "viscous", "two_way"),
    "vowel /a/, viscous, interactive": ("m5_vowel_a.toml", "viscous", "interactive"),
}


def one_run(name: str, model: str, coupling: str | None) -> dict:
    res = vfrs.run(vfrs.Scene.from_dict(scene(name, model, coupling)), progress=False)
    steps = len(res.history["t"]) - 1
    t = res.timings
    return {"steps": steps, "step": t["step"] / steps, "flow": t.get("flow", 0.0) / steps,
            "acoustics": t.get("acoustics", 0.0) / steps}


def main(out: Path = OUT) -> None:
    rows = {}
    for label, cfg in CONFIGS.items():
        runs = [one_run(*cfg) for _ in range(REPEATS)]
        med = {k: statistics.median(r[k] for r in runs) for k in ("step", "flow", "acoustics")}
        rows[label] = {"steps": runs[0]["steps"], "seconds_per_step": med,
                       "flow_share": med["flow"] / med["step"], "acoustics_share": med["acoustics"] / med["step"]}
        print(f"{label}: step {med['step'] * 1e3:.2f} ms, flow {med['flow'] * 1e3:.3f} ms "
              f"({100 * rows[label]['flow_share']:.2f} %), acoustics {med['acoustics'] * 1e3:.3f} ms "
              f"({100 * rows[label]['acoustics_share']:.2f} %)", flush=True)
    base, visc = rows["steady, bernoulli"], rows["steady, viscous"]
    inter = rows["vowel /a/, viscous, interactive"]
    summary = {
        # what the viscous model costs beyond Bernoulli's, as a share of the medium step
        "viscous_flow_extra_share": (visc["seconds_per_step"]["flow"] - base["seconds_per_step"]["flow"])
        / base["seconds_per_step"]["step"],
        # what the interactively coupled tract adds to the viscous flow's call, and its record
        "interactive_tract_share": (inter["seconds_per_step"]["flow"] - visc["seconds_per_step"]["flow"]
                                    + inter["seconds_per_step"]["acoustics"]) / inter["seconds_per_step"]["step"],
        # the viscous flow with the interactive tract, all of it
        "viscous_interactive_share": inter["flow_share"] + inter["acoustics_share"],
    }
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps({"what": __doc__.split("\n\n")[0], "end": END, "step": STEP, "level": LEVEL,
                               "repeats": REPEATS, "machine": os.uname().machine, "cpus": os.cpu_count(),
                               "date": time.strftime("%Y-%m-%d"), "rows": rows, "summary": summary}, indent=2) + "\n")
    print(json.dumps(summary))


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT)
