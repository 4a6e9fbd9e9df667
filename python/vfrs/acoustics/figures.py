"""The figures of the ``[acoustics]`` effect (:meth:`vfrs.effects.Effect.figures`, drawn by
``vfrs plot``, :mod:`vfrs.plot`): ``voice_waveform.png`` (the radiated and the tract's input
pressure vs time), ``voice_spectrum.png`` (the radiated pressure's spectrum over the analysis
window, the harmonics of f0 and the tract's formants marked) and ``voice_spectrogram.png``."""

from __future__ import annotations

import os

import numpy as np

from ..output.reader import read_npz
from ..figures import wrapped
from .voice import PRESSURE_FILE


def voice_figures(run, figs) -> None:
    """The [acoustics] effect's figures of ``run``, or skipped with why (no radiated pressure)."""
    if "radiated_pressure" in run.history:
        voice_figure(figs, run, figs.t, figs.title)
    else:
        figs.skip("voice", "the run has no [acoustics]")


def voice_figure(figs, run, t, title) -> None:
    """The [acoustics] effect's sound: the radiated and tract input pressures, the radiated
    spectrum over the analysis window with the harmonics of f0 and the tract's formants
    marked, and the spectrogram of voice.npz's pressure (else the history's)."""
    h, summary, plt = run.history, run.summary, figs.plt
    p = np.asarray(h["radiated_pressure"], dtype=float)
    ac, ph = summary.sections.get("acoustics", {}), summary.sections.get("phonation", {})
    fig, ax = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    ax[0].plot(t * 1e3, p)
    ax[0].set_ylabel("radiated pressure (Pa)")
    ax[1].plot(t * 1e3, np.asarray(h["tract_pressure"], dtype=float) * 1e-3, color="tab:purple")
    ax[1].set_ylabel("tract input pressure (kPa)")
    ax[1].set_xlabel("t (ms)")
    spl = ac.get("spl")
    ax[0].set_title(wrapped(f"{title}\n" + (f"{spl.what} {spl.text()}" if spl is not None else "radiated pressure"), 7),
                    fontsize=9)
    fig.tight_layout()
    figs.save(fig, "voice_waveform.png")

    w = summary.window
    keep = (t >= w["start"]) & (t <= w["end"]) if w else np.ones(len(t), dtype=bool)
    x = p[keep] - p[keep].mean()
    if len(x) < 16:
        figs.skip("voice spectrum", "fewer than 16 steps in the analysis window")
        return
    dt = float(np.median(np.diff(t[keep])))
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x)))) * 2.0 / np.hanning(len(x)).sum()
    freqs = np.fft.rfftfreq(len(x), dt)
    fig, ax1 = plt.subplots(figsize=(8, 4))
    with np.errstate(divide="ignore"):
        ax1.plot(freqs, 20.0 * np.log10(spec / 20e-6), lw=0.8)
    top = min(5000.0, freqs[-1])
    f0 = ph.get("f0")
    if f0 is not None and np.isfinite(float(f0)) and float(f0) > 0:
        for k in range(1, int(top / float(f0)) + 1):
            ax1.axvline(k * float(f0), color="0.8", lw=0.6, zorder=0)
    for k in range(1, 5):
        fk = ac.get(f"F{k}")
        if fk is not None:
            ax1.axvline(float(fk), color="tab:red", ls="--", lw=1.0)
            ax1.text(float(fk), 1.0, f" F{k}", color="tab:red", fontsize=8, transform=ax1.get_xaxis_transform(),
                     va="top")
    ax1.set_xlim(0, top)
    ax1.set_xlabel("frequency (Hz)")
    ax1.set_ylabel("radiated pressure (dB re 20 uPa)")
    h12 = ac.get("h1_h2")
    ax1.set_title(wrapped(f"{title}\nspectrum over the analysis window; grey: harmonics of f0, red: formants of the "
                          "tract" + (f"; H1-H2 {h12.text()}" if h12 is not None else ""), 7), fontsize=9)
    fig.tight_layout()
    figs.save(fig, "voice_spectrum.png")

    path = os.path.join(run.out, PRESSURE_FILE)
    if os.path.exists(path):
        z = read_npz(path)
        sig, rate = np.asarray(z["p"], dtype=float), float(z["rate"])
    else:
        sig, rate = p, 1.0 / dt
    if len(sig) < 256:
        figs.skip("voice spectrogram", "fewer than 256 samples")
        return
    fig, ax2 = plt.subplots(figsize=(8, 4))
    nfft = 1024 if len(sig) >= 4096 else 256
    ax2.specgram(sig, NFFT=nfft, Fs=rate, noverlap=nfft * 3 // 4, cmap="magma")
    ax2.set_ylim(0, min(5000.0, rate / 2))
    ax2.set_xlabel("t (s)")
    ax2.set_ylabel("frequency (Hz)")
    ax2.set_title(wrapped(f"{title}\nspectrogram of the radiated pressure", 7), fontsize=9)
    fig.tight_layout()
    figs.save(fig, "voice_spectrogram.png")

