"""Does the coupled voice converge? (issue 46, item 4; docs/acoustics.md, "The coupled voice
with the viscous flow"): examples/m5_vowel_a.toml on the systematic M5 family (levels 0 and 1)
with a flow model and a coupling, at a structural step, then the table of the numbers the issue
names, from the run folders.

    python examples/voice_results/vowel_study.py run viscous interactive 0 25e-6 OUT/visc_L0_25
    python examples/voice_results/vowel_study.py run viscous interactive 0 25e-6 OUT/ex_L0_25 extrapolate
    python examples/voice_results/vowel_study.py table OUT/visc_L0_25 OUT/visc_L0_12.5 ...
    python examples/voice_results/vowel_study.py csv FILE OUT/visc_L0_25 ...

The scene is examples/m5_vowel_a.toml with the mesh replaced by level ``LEVEL`` of the
systematic family (every length / 1.5 per level) and ``[flow] model`` and ``[acoustics]
coupling`` set (and ``[flow] extrapolate = true`` with a last argument ``extrapolate``); 0.2 s
as the scene says. ``table`` prints, over the run's second half: f0 of
the glottal area (the summary's, a mean over detected cycles, and the autocorrelation's, the
lag of the best match over the whole window), the autocorrelation's peak (1: periodic), MFDR,
SPL, H1-H2, and the band-limited peak contact force (1 kHz).
"""

from __future__ import annotations

import csv
import pathlib
import sys
import time
import warnings

import numpy as np

import vfrs
from vfrs.summary import default_start

SCENE = pathlib.Path(__file__).resolve().parents[1] / "m5_vowel_a.toml"
NAMES = ("f0", "f0_autocorrelation", "periodicity", "mfdr", "spl", "h1_h2", "peak_contact_force")


def scene(model: str, coupling: str, level: int, step: float, extrapolate: bool = False) -> dict:
    d = vfrs.Scene.load(SCENE).to_dict()
    if extrapolate:
        d["flow"]["extrapolate"] = True
    for b in d["bodies"]:
        b["mesh"].pop("resolution", None)
        b["mesh"].update(family="systematic", level=int(level))
    d["flow"]["model"] = model
    d["acoustics"]["coupling"] = coupling
    d["time"]["step"] = float(step)
    d["output"]["every"] = max(1, int(round(80 * 50e-6 / float(step))))
    return d


FAILED = "failed.txt"


def run(model, coupling, level, step, out, flag="") -> None:
    """One run into ``out``; a run that stops with an error leaves ``out/failed.txt`` (the
    error's message), which :func:`table` and :func:`write_csv` report."""
    t0 = time.time()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        try:
            vfrs.run(vfrs.Scene.from_dict(scene(model, coupling, int(level), float(step), flag == "extrapolate")),
                     out=out, progress=False, overwrite=True)
        except vfrs.VfrsError as e:
            pathlib.Path(out).mkdir(parents=True, exist_ok=True)
            (pathlib.Path(out) / FAILED).write_text(f"{type(e).__name__}: {e}\n")
            print(f"{out}: FAILED: {type(e).__name__}: {e}")
    print(f"{out}: model={model} coupling={coupling} level={level} step={step} {flag}: {time.time() - t0:.0f} s wall")
    for x in w:
        print("WARNING", x.category.__name__, str(x.message)[:300])


def autocorrelation_f0(t, x, start) -> tuple:
    """(f0, peak): the lag of the largest normalised autocorrelation of ``x`` over t >= start
    between 1/400 and 1/60 s (a parabola through its neighbours), as a frequency, and its value."""
    m = t >= start
    x = x[m] - x[m].mean()
    dt = float(np.median(np.diff(t[m])))
    r = np.fft.irfft(np.abs(np.fft.rfft(x, 2 * len(x))) ** 2)[: len(x)]
    r = r / r[0]
    lo, hi = int(1 / 400 / dt), int(1 / 60 / dt)
    k = lo + int(np.argmax(r[lo:hi]))
    a, b, c = r[k - 1], r[k], r[k + 1]
    return 1.0 / (dt * (k + 0.5 * (a - c) / (a - 2 * b + c))), float(b)


def numbers(out) -> dict:
    failed = pathlib.Path(out) / FAILED
    if failed.exists():
        return {n: float("nan") for n in NAMES} | {"failed": failed.read_text().strip()}
    r = vfrs.load(out)
    h, sec = r.history, r.summary.sections
    t = np.asarray(h["t"])
    f0_ac, peak = autocorrelation_f0(t, np.asarray(h["glottal_area"]), default_start(t))
    contact = sec.get("contact", {})
    force = contact.get("band_limited_peak_force")
    return {"f0": float(sec["phonation"]["f0"]), "f0_autocorrelation": f0_ac, "periodicity": peak,
            "mfdr": float(sec["phonation"]["mfdr"]), "spl": float(sec["acoustics"]["spl"]),
            "h1_h2": float(sec["acoustics"].get("h1_h2", float("nan"))),
            "peak_contact_force": float(force) if force is not None else float("nan")}


def table(outs) -> None:
    print("run".ljust(40) + "".join(n.rjust(19) for n in NAMES))
    for out in outs:
        v = numbers(out)
        print(str(out)[-40:].ljust(40) + (v["failed"][:150] if "failed" in v else
                                          "".join(f"{v[n]:19.5g}" for n in NAMES)))


def write_csv(path, outs) -> None:
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["run", *NAMES, "failed"])
        for out in outs:
            v = numbers(out)
            w.writerow([str(out).rstrip("/").split("/")[-1], *(f"{v[n]:.6g}" for n in NAMES), v.get("failed", "")])


if __name__ == "__main__":
    cmd, args = sys.argv[1], sys.argv[2:]
    if cmd == "run":
        run(*args)
    elif cmd == "table":
        table(args)
    elif cmd == "csv":
        write_csv(args[0], args[1:])
    else:
        raise SystemExit(__doc__)
