"""What the tract radiates, as sound: ``voice.wav`` and ``voice.npz`` (:func:`write_voice`) and
the radiated pressure's spectrum (:func:`h1_h2`)."""

from __future__ import annotations

import math
import os

import numpy as np

P_REF = 20e-6  # Pa, the reference of the sound pressure level
WAV_FILE, PRESSURE_FILE = "voice.wav", "voice.npz"


def h1_h2(t, p, t0, t1, n_cycles) -> float:
    """H1 - H2 (dB) of ``p`` over [t0, t1] (``n_cycles`` whole cycles): the spectrum's
    magnitude at f0 and at 2 f0 (Hann window, the bins of those frequencies)."""
    keep = (t >= t0) & (t < t1)
    x = p[keep] - p[keep].mean()
    if len(x) < 8:
        return float("nan")
    dt = float(np.median(np.diff(t[keep])))
    f0 = n_cycles / (t1 - t0)
    n = 8 * len(x)  # zero-padded: the harmonics fall near bins
    spec = np.abs(np.fft.rfft(x * np.hanning(len(x)), n))
    freqs = np.fft.rfftfreq(n, dt)

    def at(f):
        band = (freqs > f - 0.25 * f0) & (freqs < f + 0.25 * f0)
        return float(spec[band].max()) if band.any() else float("nan")

    h1, h2 = at(f0), at(2.0 * f0)
    return 20.0 * math.log10(h1 / h2) if h1 > 0 and h2 > 0 else float("nan")



def resample_pressure(p, T: float, t_end: float, rate: int) -> np.ndarray:
    """The pressure ``p`` sampled every ``T`` s from t = 0, on ``round(t_end rate)`` samples at
    ``rate``: when the tract's rate is higher, its spectrum above 0.45 ``rate`` is removed
    first (FFT), then it is linearly interpolated."""
    n = int(round(t_end * rate))
    x = np.asarray(p, dtype=float)
    if len(x) == 0 or n == 0:
        return np.zeros(n)
    if 1.0 / T > rate:
        spec = np.fft.rfft(x)
        spec[np.fft.rfftfreq(len(x), T) > 0.45 * rate] = 0.0
        x = np.fft.irfft(spec, len(x))
    return np.interp(np.arange(n) / rate, np.arange(len(x)) * T, x)


def write_voice(out: str, p_rad, T: float, t_end: float, rate: int, distance: float) -> float:
    """Writes ``voice.wav`` (16-bit PCM at ``rate``, normalised: its peak at 0.9 of full scale)
    and ``voice.npz`` (``p_tract`` Pa at the tract's rate ``fs_tract``, ``p`` Pa at ``rate``,
    ``full_scale`` Pa that the WAV's full scale stands for, ``distance`` m) into ``out``;
    returns the full scale."""
    from scipy.io import wavfile

    p = resample_pressure(p_rad, T, t_end, rate)
    peak = float(np.max(np.abs(p))) if len(p) else 0.0
    full_scale = peak / 0.9 if peak > 0 else 1.0
    pcm = np.round(p / full_scale * 32767.0).astype(np.int16)
    wavfile.write(os.path.join(out, WAV_FILE), rate, pcm)
    np.savez(os.path.join(out, PRESSURE_FILE), p_tract=np.asarray(p_rad, dtype=float), fs_tract=1.0 / T, p=p,
             rate=rate, full_scale=full_scale, distance=distance)
    return full_scale
