"""Self-oscillation of the M5 folds: frequency, amplitude growth, first crossing of the mid-plane.

Runs ``m5_phonation.toml`` (the paper's transversely isotropic ``vocal_fold`` tissue; or a
coarser, shorter variant) and measures, with :mod:`vfrs.summary`, from the medio-lateral
displacement of the medial node at mid-length (the probe) the fundamental frequency and the
peak-to-peak amplitude per cycle; from ``min_gap`` the time the folds first cross the
mid-plane (no contact here: they pass through each other). ``python examples/m5_phonation.py
[--resolution coarse] [--end 0.05] [--out out]`` writes ``OUT/m5_phonation.png`` (the README's
figure is ``docs/figures/m5_phonation.png``, made with the defaults) and prints the run's
results summary.
"""

import argparse
from pathlib import Path

import numpy as np

import vfrs
from vfrs import signals

SCENE = Path(__file__).with_name("m5_phonation.toml")


def simulate(resolution="medium", end=0.05, progress=False, scene=SCENE):
    d = vfrs.Scene.load(scene).to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = resolution
    d["time"]["end"] = end
    return vfrs.run(vfrs.Scene.from_dict(d), progress=progress)


def analyse(res, settle=0.005):
    """Fundamental frequency (Hz) of the probe's medio-lateral displacement after ``settle``
    s, its peak-to-peak amplitude in each cycle (m), and the first time min_gap < 0 (s or
    None)."""
    p = res.probe(res.scene.output.probes[0])
    t, ux = np.asarray(p["t"]), np.asarray(p["displacement"])[:, 0]
    f0 = signals.fundamental_frequency(t, ux, start=settle)
    amplitude = 2.0 * signals.cycle_amplitudes(t, ux, start=settle)
    gap, th = np.asarray(res.history["min_gap"]), np.asarray(res.history["t"])
    return f0, amplitude, signals.first_contact(th, gap < 0)


def figure(res, path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    f0, amp, t_cross = analyse(res)
    p = res.probe(res.scene.output.probes[0])
    h = res.history
    t = np.asarray(h["t"]) * 1e3
    fig, ax = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True)
    ax[0].plot(np.asarray(p["t"]) * 1e3, np.asarray(p["displacement"])[:, 0] * 1e3)
    ax[0].set_ylabel("medial node u_x (mm)")
    ax[0].set_title(f"M5 folds, vocal_fold tissue, Ps = 0.8 kPa, no contact: f0 = {f0:.0f} Hz, "
                    f"first mid-plane crossing at {t_cross * 1e3:.1f} ms", fontsize=10)
    ax[1].plot(t, np.asarray(h["glottal_area"]) * 1e6, label="glottal area (mm²)")
    ax[1].plot(t, np.asarray(h["flow_rate"]) * 1e5, label="flow rate (10 mL/s)")
    ax[1].legend(fontsize=8, loc="upper left")
    ax[2].plot(t, np.asarray(h["min_gap"]) * 1e3)
    ax[2].axhline(0, color="k", lw=0.5)
    ax[2].set_ylabel("min gap (mm)")
    ax[2].set_xlabel("t (ms)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", default="medium")
    ap.add_argument("--end", type=float, default=0.05)
    ap.add_argument("--out", default="out")
    args = ap.parse_args()
    res = simulate(args.resolution, args.end, progress=True)
    f0, amp, t_cross = analyse(res)
    out = Path(args.out)
    out.mkdir(exist_ok=True)
    figure(res, out / "m5_phonation.png")
    print(f"probe: f0 = {f0:.1f} Hz; peak-to-peak amplitude per cycle (mm): {np.round(amp * 1e3, 3).tolist()}")
    print(f"first mid-plane crossing: {t_cross * 1e3:.2f} ms; wrote {out / 'm5_phonation.png'}")
    print(res.results)
