"""Self-oscillation of the M5 folds: frequency, amplitude growth, first crossing of the mid-plane.

Runs ``m5_phonation.toml`` (or a coarser, shorter variant) and measures, from the medio-
lateral displacement of the medial node at mid-length (the probe), the fundamental
frequency and the amplitude per cycle; from ``min_gap`` the time the folds first cross the
mid-plane. ``python examples/m5_phonation.py`` writes ``out/m5_phonation.png``.
"""

from pathlib import Path

import numpy as np

import vfrs

SCENE = Path(__file__).with_name("m5_phonation.toml")


def simulate(resolution="medium", end=0.05, progress=False):
    d = vfrs.Scene.load(SCENE).to_dict()
    for b in d["bodies"]:
        b["mesh"]["resolution"] = resolution
    d["time"]["end"] = end
    scene = vfrs.Scene.from_dict(d)
    return vfrs.run(scene, progress=progress)


def analyse(res, settle=0.005):
    """Fundamental frequency (Hz) from the probe's zero crossings after ``settle`` s, the
    peak-to-peak amplitude of each cycle (m), and the first time min_gap < 0 (s or None)."""
    p = res.probe(res.scene.output.probes[0]) if hasattr(res, "scene") else None
    if p is None:
        raise RuntimeError("the result has no probe")
    t, ux = np.asarray(p["t"]), np.asarray(p["displacement"])[:, 0]
    keep = t >= settle
    t, x = t[keep], ux[keep] - ux[keep].mean()
    up = np.flatnonzero((x[:-1] < 0) & (x[1:] >= 0))
    times = t[up] - x[up] * (t[up + 1] - t[up]) / (x[up + 1] - x[up])
    f0 = 1.0 / np.mean(np.diff(times)) if len(times) > 2 else float("nan")
    amplitude = np.array([np.ptp(x[a:b]) for a, b in zip(up[:-1], up[1:])])
    gap = np.asarray(res.history["min_gap"])
    th = np.asarray(res.history["t"])
    crossed = np.flatnonzero(gap < 0)
    return f0, amplitude, (float(th[crossed[0]]) if crossed.size else None)


if __name__ == "__main__":
    import matplotlib.pyplot as plt

    res = simulate(progress=True)
    f0, amp, t_cross = analyse(res)
    p = res.probe(res.scene.output.probes[0])
    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    ax[0].plot(np.asarray(p["t"]) * 1e3, np.asarray(p["displacement"])[:, 0] * 1e3)
    ax[0].set_ylabel("medial node u_x (mm)")
    ax[0].set_title(f"M5 folds, Ps = 0.8 kPa: f0 = {f0:.0f} Hz, first mid-plane crossing at {t_cross * 1e3:.1f} ms")
    ax[1].plot(np.asarray(res.history["t"]) * 1e3, np.asarray(res.history["min_gap"]) * 1e3)
    ax[1].axhline(0, color="k", lw=0.5)
    ax[1].set_ylabel("min gap (mm)")
    ax[1].set_xlabel("t (ms)")
    out = Path("out")
    out.mkdir(exist_ok=True)
    fig.savefig(out / "m5_phonation.png", dpi=120)
    print(f"f0 = {f0:.1f} Hz; cycle amplitudes (mm): {np.round(amp * 1e3, 3).tolist()}")
    print(f"first mid-plane crossing: {t_cross * 1e3:.2f} ms; wrote out/m5_phonation.png")
