"""What the tract's coupling changes in the main job (docs/acoustics.md, "What the coupling
changes in the main job"): run examples/m5_vowel_a.toml (medium mesh) with a coupling and a
structural step, then print the table's numbers of the run folders.

    python examples/voice_results/coupling_table.py run none 50e-6 0.2 /tmp/voice_runs/none_50
    python examples/voice_results/coupling_table.py run two_way 50e-6 0.2 /tmp/voice_runs/two_way_50
    python examples/voice_results/coupling_table.py run two_way 25e-6 0.2 /tmp/voice_runs/two_way_25
    python examples/voice_results/coupling_table.py table /tmp/voice_runs/none_50 /tmp/voice_runs/two_way_50 ...
    python examples/voice_results/coupling_table.py drive /tmp/voice_runs/none_50
    python examples/voice_results/coupling_table.py collect /tmp/voice_runs/two_way_50   (the committed voice)

``run`` prints the wall time and every warning; ``table`` the summary's phonation, contact and
acoustics values over the window (the run's second half), the tract input pressure's range, the
energy the contact scheme took back, and the flow pulses' skewing; ``drive`` runs the tract
alone, coupled two ways, with a run's glottal area, for a few tracts and losses.
"""

import sys
import time
import warnings

import numpy as np

import vfrs
import vfrs.signals as sig
from vfrs.summary import default_start
from vfrs.acoustics import Acoustics, build_tract
from vfrs.params import read_params
from vfrs.params.table import Table


def run(coupling, step, end, out):
    d = vfrs.Scene.load("examples/m5_vowel_a.toml").to_dict()
    d["acoustics"]["coupling"] = coupling
    d["time"]["step"] = float(step)
    d["time"]["end"] = float(end)
    d["output"]["every"] = max(1, int(round(20 * 50e-6 / float(step))))
    t0 = time.time()
    with warnings.catch_warnings(record=True) as w:
        warnings.simplefilter("always")
        vfrs.run(vfrs.Scene.from_dict(d), out=out, progress=False, overwrite=True)
    print(f"{out}: coupling={coupling} step={step} end={end}: {time.time() - t0:.0f} s wall")
    for x in w:
        print("WARNING", x.category.__name__, str(x.message)[:300])


def skewing(h):
    """For each glottal cycle in the window (the second half) the flow's peak; rise = from the
    last sample at or below min + 10 % of the range before it (back to the previous peak) to the
    peak; fall = from the peak to the first sample at or below that level after it (up to the
    next peak); min and range over the span to each neighbouring peak. Returns the rise / fall
    of each pulse."""
    t = np.asarray(h["t"]); u = np.asarray(h["flow_rate"]); g = np.asarray(h["glottal_area"])
    cyc = sig.cycle_starts(t, g, default_start(t))
    peaks = []
    for c0, c1 in zip(cyc[:-1], cyc[1:]):
        k = np.where((t >= c0) & (t < c1))[0]
        peaks.append(k[np.argmax(u[k])])
    q = []
    for i in range(1, len(peaks) - 1):
        lo_k = np.arange(peaks[i - 1], peaks[i] + 1)
        hi_k = np.arange(peaks[i], peaks[i + 1] + 1)
        level_lo = u[lo_k].min() + 0.1 * (u[peaks[i]] - u[lo_k].min())
        level_hi = u[hi_k].min() + 0.1 * (u[peaks[i]] - u[hi_k].min())
        below, after = lo_k[u[lo_k] <= level_lo], hi_k[u[hi_k] <= level_hi]
        if len(below) and len(after):
            q.append((t[peaks[i]] - t[below[-1]]) / (t[after[0]] - t[peaks[i]]))
    return np.asarray(q)


def table(outs):
    for out in outs:
        r = vfrs.load(out)
        h = r.history
        t = np.asarray(h["t"])
        start = default_start(t)
        cyc = sig.cycle_starts(t, np.asarray(h["glottal_area"]), start)
        sec = r.summary.sections
        lengths = np.diff(cyc) * 1e3
        print(f"== {out}\n  window {start * 1e3:.0f}-{t[-1] * 1e3:.0f} ms: {len(cyc) - 1} cycles, lengths "
              f"{lengths.min():.2f}-{lengths.max():.2f} ms")
        for name, keys in (("phonation", ("f0", "peak_flow", "mfdr", "max_glottal_area")),
                           ("contact", ("peak_force.right", "peak_sensor_pressure", "peak_contact_pressure")),
                           ("acoustics", ("spl", "h1_h2", "peak_tract_pressure"))):
            for k in keys:
                v = sec.get(name, {}).get(k)
                print(f"    {name}.{k} = {v.text() if v is not None else None}")
        tp = np.asarray(h["tract_pressure"])[t >= start]
        print(f"  tract input pressure in the window: {tp.min():.0f} .. {tp.max():.0f} Pa")
        ce = np.asarray(h["contact_energy_corrected"])
        print(f"  energy the contact scheme took back by the end: {ce[-1]:.3g} J")
        q = skewing(h)
        print(f"  skewing: rise/fall median {np.median(q):.2f} (quartiles {np.percentile(q, 25):.2f}-"
              f"{np.percentile(q, 75):.2f}, {len(q)} pulses)")


def drive(out):
    r = vfrs.load(out)
    t = np.asarray(r.history["t"])
    area = np.asarray(r.history["glottal_area"])
    for keys in ({"vowel": "a", "losses": "boundary_layer"}, {"vowel": "a"}, {"vowel": "a", "losses": "none"},
                 {"vowel": "uniform"}, {"vowel": "a", "wall_damping": 4 * 408.0}, {"vowel": "a", "piriform": False}):
        tr = build_tract(read_params(Acoustics.Params, Table(keys, "acoustics", "<drive>")), coupled=True)
        ps, us = [], []
        for tk, ak in zip(t, area):
            u, _, p_sup = tr.advance(tk, ak, 800.0 * min(tk / 2e-3, 1.0))  # the scene's 2 ms ramp
            ps.append(p_sup)
            us.append(u)
        ps, us = np.array(ps), np.array(us)
        w = t >= 0.1
        mfdr = -np.min(np.diff(us[w]) / np.diff(t[w])) * 1e3
        print(keys, f"p_sup {ps[w].min():.0f}..{ps[w].max():.0f} Pa, U peak {us[w].max() * 1e6:.0f} mL/s, "
              f"MFDR {mfdr:.0f} L/s^2, Z1 U_peak = {tr.Z[0] * us[w].max():.0f} Pa")


def collect(out, here="examples/voice_results"):
    """The committed voice from a 0.2 s two-way run at 50 us (``run two_way 50e-6 0.2 OUT``): its
    voice.wav, the spectrum ``vfrs plot`` draws of it, and the first 10 ms of the radiated
    pressure at the tract's rate (voice.npz ``p_tract``, floor(0.01 fs) + 1 samples, 12 digits),
    which tests/test_acoustics.py re-runs, and the glottal area over the analysis window."""
    import shutil

    from vfrs.plot import plot_run

    shutil.copyfile(f"{out}/voice.wav", f"{here}/m5_vowel_a_0.2s.wav")
    plot_run(out)  # what `vfrs plot OUT` draws, into OUT/plots
    shutil.copyfile(f"{out}/plots/voice_spectrum.png", f"{here}/m5_vowel_a_spectrum.png")
    v = np.load(f"{out}/voice.npz")
    fs, p = float(v["fs_tract"]), np.asarray(v["p_tract"])
    n = int(np.floor(0.01 * fs)) + 1
    with open(f"{here}/m5_vowel_a_first_10ms.csv", "w") as fh:
        fh.write(f"# examples/m5_vowel_a.toml (medium mesh, end = 0.2 s): the radiated pressure 30 cm from the lips, "
                 f"its first 10 ms at the tract's rate {fs:.4f} Hz (voice.npz p_tract); the WAV's full scale: "
                 f"{float(v['full_scale']):.12e} Pa\n")
        fh.write("sample,p_Pa\n")
        for k in range(n):
            fh.write(f"{k},{p[k]:.12e}\n")
    r = vfrs.load(out)
    t, g = np.asarray(r.history["t"]), np.asarray(r.history["glottal_area"])
    w = t >= 0.1 - 1e-12
    with open(f"{here}/m5_vowel_a_glottal_area_100_200ms.csv", "w") as fh:
        fh.write("# the same run's glottal area (history glottal_area) over its analysis window, 100-200 ms, every "
                 "structural step; tests/test_acoustics.py feeds it to the summary's cycle detection\n")
        fh.write("t_s,glottal_area_m2\n")
        for tk, gk in zip(t[w], g[w]):
            fh.write(f"{tk:.9f},{gk:.12e}\n")
    print(f"wrote {here}: the WAV, the spectrum, {n} samples of p_tract (full scale {float(v['full_scale']):.4g} Pa), "
          f"{int(w.sum())} samples of the glottal area")


if __name__ == "__main__":
    cmd, rest = sys.argv[1], sys.argv[2:]
    {"run": lambda: run(*rest), "table": lambda: table(rest), "drive": lambda: drive(rest[0]),
     "collect": lambda: collect(rest[0])}[cmd]()
