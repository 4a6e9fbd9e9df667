"""``vfrs plot OUT``: the standard figures of a run, from its output folder.

Writes PNGs into ``OUT/plots/`` (or ``dest``), each only when the run has what it shows, and
says for each figure it did not draw why (:func:`draw_run`):

- ``glottal_area_flow.png`` ([flow]): glottal area and flow rate vs time, the analysis window
  (over which the summary's per-cycle values are measured) and the steps in contact shaded,
  both named in a legend;
- ``contact_force.png`` ([contact]): the total contact force on each body (its length and its
  medio-lateral component) vs time. Forces of two bodies that are equal and opposite to
  round-off are one line, labelled so; otherwise each body has its own line style;
- ``contact_pressure.png`` ([contact]): the sensor's pressure (the largest reading of a
  ``[contact] sensor_area`` sensor, the summary's ``peak_sensor_pressure``: the one to compare
  with measurements) in front of the range of peak impact stress measured in an excised canine
  hemilarynx (Jiang & Titze 1994); the largest nodal pressure (one node's) and the
  area-weighted mean pressure of the loaded nodes thinner;
- ``pressure_map.png`` ([contact]): the contact pressure on each body's contact surface at the
  step of the largest total contact force, as recorded at that step (``contact_peak.npz``,
  written when the run completes), seen along the surface's thinnest direction (the folds'
  medial surface in its (z, y) plane: anterior-posterior x inferior-superior, reference
  coordinates), with the surface's triangles in grey (zero pressure is black inside the
  grey mesh, outside the surface is white; the panels of one plane share their extent, so they
  are equally wide, and one colour bar). A run that did not complete has no
  ``contact_peak.npz``: the map is then the field snapshot nearest the peak, and its title
  says how far apart the two instants are;
- ``probes.png`` ([output] probes): the displacement of each probe node vs time;
- ``energy.png`` ([output] energy): the energy balance in J, mJ, uJ or nJ (whichever puts it
  between 1 and 1000): the work of the loads (input work) beside kinetic + elastic +
  dissipated by damping + taken by contact, each its change since the first record, and below
  the remainder input work - (their sum) (:func:`energy_balance`);
- ``reactions.png`` ([output] reactions): each support's force on its body vs time.

Titles are folded to the figure's width (:func:`wrapped`) and the legends of long series stand
outside the axes, so that no text leaves the canvas and no legend covers a curve.

From Python: ``vfrs.plot.plot_run("out/m5_collision")`` returns the paths written;
``draw_run`` returns (paths written, [(figure, why it was not drawn)]).
"""

from __future__ import annotations

import os

import numpy as np

from .analysis import force_length, read_npz
from .effects import EFFECTS
from .errors import MeshError, VfrsError
from .mesh import meshio_read
from .readers import damaged

#: Peak impact stress near the centre of the fold measured in an excised canine hemilarynx, Pa
#: (Jiang & Titze 1994, "Measurement of vocal fold intraglottal pressure and impact stress",
#: J. Voice 8, 132-144: about 0.5-5 kPa over the prephonatory settings tested; see docs/results.md).
PUBLISHED_IMPACT_STRESS = (0.5e3, 5.0e3)

#: Two bodies' contact forces whose sum and whose lengths' difference stay within this
#: fraction of the peak force are drawn as one line ("equal and opposite"): round-off.
EQUAL_AND_OPPOSITE = 1e-9


def require_matplotlib():
    """Imports matplotlib with the Agg backend, or raises VfrsError saying how to install it."""
    try:
        import matplotlib
    except ImportError:
        raise VfrsError("plotting needs matplotlib, which is not installed: pip install matplotlib "
                        "(it is a dependency of vfrs; an install with --no-deps leaves it out)") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def load_run(out):
    """The run in the output folder ``out`` (:func:`vfrs.analysis.load`), or VfrsError, one
    line saying what to do: no history.npz (no run there, or one stopped before it wrote its
    history: :func:`vfrs.readers.no_history`), or a file that cannot be read (truncated, not
    a zip, not JSON: :func:`vfrs.readers.damaged`)."""
    from .analysis import load

    return load(os.fspath(out))  # reads every array once: a damaged file is one line, not a traceback


def _in_contact_spans(ax, t, active):
    from .analysis import contact_intervals

    for a, b in contact_intervals(t, active):
        ax.axvspan(a * 1e3, b * 1e3, color="tab:red", alpha=0.12, lw=0)


def equal_and_opposite(forces: dict) -> float | None:
    """For two bodies' contact forces {name: (n, 3)}: the largest of |F1 + F2| and
    ||F1| - |F2|| over the steps, relative to the peak force, when it is within
    :data:`EQUAL_AND_OPPOSITE` (round-off); else None (or not two bodies, or no force)."""
    if len(forces) != 2:
        return None
    F1, F2 = (np.asarray(F, dtype=float) for F in forces.values())
    peak = float(max(force_length(F1).max(initial=0.0), force_length(F2).max(initial=0.0)))
    if peak == 0.0:
        return None
    rel = float(max(np.abs(F1 + F2).max(initial=0.0),
                    np.abs(force_length(F1) - force_length(F2)).max(initial=0.0))) / peak
    return rel if rel <= EQUAL_AND_OPPOSITE else None


#: Line styles of the bodies' curves, in turn: a second curve on top of the first stays visible.
STYLES = ({"ls": "-", "lw": 2.2}, {"ls": (0, (5, 3)), "lw": 1.3}, {"ls": ":", "lw": 1.3}, {"ls": "-.", "lw": 1.0})

#: Width of a character of a title, in em (DejaVu Sans averages about 0.45 em over text with
#: digits; 0.5 leaves a margin): what :func:`wrapped` folds a figure's title lines to.
CHAR_WIDTH_EM = 0.5


def wrapped(text: str, width_inches: float, fontsize: float = 9.0) -> str:
    """``text`` with each of its lines folded to fit ``width_inches`` at ``fontsize`` points,
    at its "; " where it can, else at spaces (a summary's line with per-cycle values is longer
    than a figure is wide, and a title that does not fit is clipped by the canvas)."""
    import textwrap

    chars = max(20, int(width_inches * 72.0 / (CHAR_WIDTH_EM * fontsize)))
    out: list = []
    for line in text.split("\n"):
        current = ""
        for part in line.split("; "):
            joined = f"{current}; {part}" if current else part
            if len(joined) <= chars or not current:
                current = joined
            else:
                out.append(current + ";")
                current = part
        out.extend(textwrap.wrap(current, chars, break_on_hyphens=False) or [""])
    return "\n".join(out)


def _figure_legend(fig, axes, where: str = "right", **kw):
    """One legend for the figure, outside the axes (``where``: "right" or "bottom"; the figure's
    constrained layout makes room for it), from the labelled artists of ``axes`` without
    repeats: a legend inside the axes covers the curves of a long series."""
    handles, labels = [], []
    for ax in axes:
        for h, label in zip(*ax.get_legend_handles_labels()):
            if label not in labels:
                handles.append(h)
                labels.append(label)
    loc = "outside right upper" if where == "right" else "outside lower center"
    return fig.legend(handles, labels, loc=loc, fontsize=8, **kw)


def contact_force_figure(plt, t, forces: dict, title: str = "", time_label: str = "t (ms)", scale: float = 1e3):
    """The figure of ``contact_force.png``: ``forces`` {body: (n, 3) N} against ``t``. Two
    bodies' forces that are equal and opposite to round-off (:func:`equal_and_opposite`) are
    one line in the top panel labelled "a = b (equal and opposite)", and mirror images in the
    bottom one; otherwise each body has its own line style (solid, dashed, dotted, ...), so a
    curve drawn over another stays visible."""
    fig, ax = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
    names = list(forces)
    same = equal_and_opposite(forces)
    x = np.asarray(t, dtype=float) * scale
    for i, b in enumerate(names):
        F = np.asarray(forces[b], dtype=float)
        style = STYLES[i % len(STYLES)]
        if same is None or i == 0:
            label = (f"{names[0]} = {names[1]} (equal and opposite, to {max(same, 1e-16):.0e} of the peak)"
                     if same is not None else b)
            ax[0].plot(x, force_length(F) * 1e3, label=label, color=f"C{i}", **style)
        ax[1].plot(x, F[:, 0] * 1e3, label=b, color=f"C{i}", **style)
    ax[0].set_ylabel("|total contact force| (mN)")
    ax[1].set_ylabel("medio-lateral F_x (mN)")
    ax[1].set_xlabel(time_label)
    ax[0].legend(fontsize=8)
    ax[1].legend(fontsize=8)
    ax[0].set_title(wrapped(f"{title}\ncontact force on each body (the impulse contact gave it per step, over h)", 7),
                    fontsize=9)
    fig.tight_layout()
    return fig


class _Figures:
    """What one ``vfrs plot`` wrote and skipped."""

    def __init__(self, plt, dest):
        self.plt, self.dest = plt, dest
        self.written: list = []
        self.skipped: list = []

    def save(self, fig, name) -> None:
        path = os.path.join(self.dest, name)
        fig.savefig(path, dpi=120)
        self.plt.close(fig)
        self.written.append(path)

    def skip(self, what: str, why: str) -> None:
        self.skipped.append((what, why))


def plot_run(out, dest=None) -> list:
    """Draws the standard figures of the run in the output folder ``out`` into ``dest``
    (default ``out/plots``); returns the paths written."""
    return draw_run(out, dest)[0]


def draw_run(out, dest=None) -> tuple:
    """Draws every standard figure the run in ``out`` has the data for into ``dest`` (default
    ``out/plots``): returns (paths written, [(figure, why it was not drawn)])."""
    plt = require_matplotlib()
    run = load_run(out)
    h = run.history
    t = np.asarray(h["t"])
    dest = os.path.join(run.out, "plots") if dest is None else os.fspath(dest)
    os.makedirs(dest, exist_ok=True)
    figs = _Figures(plt, dest)
    title = run.scene.title or os.path.basename(os.path.abspath(run.out))
    static = run.scene.time.mode == "static"
    x, time_label = (t, "load factor") if static else (t * 1e3, "t (ms)")
    active = np.asarray(h["active_pairs"]) > 0 if "active_pairs" in h else None
    has_contact = "contact" in run.scene.effects

    if "glottal_area" in h:
        _glottal(figs, run, t, active, title)
    else:
        figs.skip("glottal area and flow", "the run has no [flow]")

    bodies = [k.split(".", 1)[1] for k in h if k.startswith("contact_force.")]
    if bodies:
        forces = {b: np.asarray(h[f"contact_force.{b}"]) for b in bodies}
        fig = contact_force_figure(plt, t, forces, title, time_label, 1.0 if static else 1e3)
        figs.save(fig, "contact_force.png")
    else:
        figs.skip("contact force", "the run has no contact" if not has_contact else "the history has no contact_force")

    if "contact_pressure_max" in h:
        _pressure_curves(figs, run, x, time_label, title)
    else:
        figs.skip("contact pressure", "the run has no contact" if not has_contact else
                  "the history has no contact_pressure_max")

    if bodies:
        _pressure_map(figs, run, bodies, title)
    else:
        figs.skip("pressure map", "the run has no contact" if not has_contact else "the history has no contact_force")

    if "radiated_pressure" in h:
        _voice(figs, run, t, title)
    else:
        figs.skip("voice", "the run has no [acoustics]")

    _probes(figs, run, x, time_label, title, static)
    _energy(figs, run, x, time_label, title)
    _reactions(figs, run, x, time_label, title)
    return figs.written, figs.skipped


def _glottal(figs, run, t, active, title) -> None:
    """Glottal area and flow rate; grey: the summary's analysis window, red: the steps in contact
    (both named in the legend below the axes)."""
    from matplotlib.patches import Patch

    h, summary, plt = run.history, run.summary, figs.plt
    fig, ax = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True, layout="constrained")
    ax[0].plot(t * 1e3, np.asarray(h["glottal_area"]) * 1e6)
    ax[0].set_ylabel("glottal area (mm²)")
    ax[1].plot(t * 1e3, np.asarray(h["flow_rate"]) * 1e6, color="tab:green")
    ax[1].set_ylabel("flow rate (mL/s)")
    ax[1].set_xlabel("t (ms)")
    w = summary.window
    for a in ax:
        if w:
            a.axvspan(w["start"] * 1e3, w["end"] * 1e3, color="0.85", alpha=0.4, lw=0)
        if active is not None:
            _in_contact_spans(a, t, active)
    keys = []
    if w:
        keys.append(Patch(color="0.85", alpha=0.4, lw=0, label=(
            f"analysis window, {w['start'] * 1e3:.4g}-{w['end'] * 1e3:.4g} ms: the summary's f0, open quotient and "
            "other per-cycle values are measured over it")))
    if active is not None:
        keys.append(Patch(color="tab:red", alpha=0.12, lw=0, label="in contact (a contact pair active)"))
    if keys:
        fig.legend(handles=keys, loc="outside lower center", fontsize=8)
    ph = summary.sections.get("phonation", {})
    bits = [f"{ph[k].what.split(' (')[0]} {ph[k].text()}" for k in ("f0", "open_quotient") if k in ph]
    ax[0].set_title(wrapped(f"{title}\n" + "; ".join(bits), 7), fontsize=9)
    figs.save(fig, "glottal_area_flow.png")


def _voice(figs, run, t, title) -> None:
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

    path = os.path.join(run.out, "voice.npz")
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


def _pressure_curves(figs, run, x, time_label, title) -> None:
    """The sensor's pressure (history ``contact_pressure_sensor``, the summary's
    ``peak_sensor_pressure``: the one to compare with measurements) in front of the measured
    band of peak impact stress; the largest nodal pressure (one node's, it grows as the mesh
    refines) and the mean over the loaded nodes thinner."""
    h, plt = run.history, figs.plt
    fig, ax = plt.subplots(figsize=(8, 4.4), layout="constrained")
    sensor = "contact_pressure_sensor" in h
    lo, hi = PUBLISHED_IMPACT_STRESS
    ax.axhspan(lo * 1e-3, hi * 1e-3, color="tab:orange", alpha=0.15, lw=0, zorder=0,
               label=f"measured peak impact stress {lo * 1e-3:g}-{hi * 1e-3:g} kPa, excised canine hemilarynx "
                     f"(Jiang & Titze 1994){': compare the sensor' if sensor else ''}")
    if sensor:
        area = getattr(run.scene.effects.get("contact"), "sensor_area", None)
        face = f"{area * 1e6:g} mm² sensor" if area else "sensor"
        ax.plot(x, np.asarray(h["contact_pressure_sensor"]) * 1e-3, color="C0", lw=1.8, zorder=3,
                label=f"largest pressure on a {face} (the summary's sensor pressure)")
    ax.plot(x, np.asarray(h["contact_pressure_max"]) * 1e-3, color="0.45", lw=0.9, zorder=2,
            label="largest nodal pressure (one node's: it grows as the mesh refines)")
    ax.plot(x, np.asarray(h["contact_pressure_mean"]) * 1e-3, color="C1", lw=0.9, ls="--", zorder=2,
            label="mean over the loaded nodes")
    ax.set_xlabel(time_label)
    ax.set_ylabel("contact pressure (kPa)")
    co = run.summary.sections.get("contact", {})
    peak = co.get("peak_sensor_pressure" if sensor else "peak_contact_pressure")
    ax.set_title(wrapped(f"{title}\n{peak.what} {peak.text()}" if peak is not None else title, 7), fontsize=9)
    _figure_legend(fig, [ax], "bottom")
    figs.save(fig, "contact_pressure.png")


def _probes(figs, run, x, time_label, title, static) -> None:
    path = os.path.join(run.out, "probes.npz")
    if not run.scene.output.probes:
        figs.skip("probe displacements", "the scene has no [output] probes")
        return
    if not os.path.exists(path):
        figs.skip("probe displacements", f"{path} is missing")
        return
    try:
        z = read_npz(path)
    except VfrsError as exc:
        figs.skip("probe displacements", str(exc))
        return
    ids = sorted({int(k.split(".")[0].split("_")[1]) for k in z if k.startswith("probe_") and k.endswith(".displacement")})
    if not ids:
        figs.skip("probe displacements", f"{path} holds no displacement")
        return
    tp = np.asarray(z["t"], dtype=float)
    xp = tp if static else tp * 1e3
    plt = figs.plt
    fig, axes = plt.subplots(len(ids), 1, figsize=(8, 2.2 * len(ids) + 1.2), sharex=True, squeeze=False,
                             layout="constrained")
    for ax, i in zip(axes[:, 0], ids):
        d = np.asarray(z[f"probe_{i}.displacement"], dtype=float)
        for c, name in enumerate("xyz"):
            ax.plot(xp[:len(d)], d[:, c] * 1e3, label=f"u_{name}", color=f"C{c}", **STYLES[c])
        pos = np.asarray(z.get(f"probe_{i}.position", np.full(3, np.nan)), dtype=float) * 1e3
        body = str(z[f"probe_{i}.body"]) if f"probe_{i}.body" in z else "?"
        ax.set_ylabel("displacement (mm)")
        ax.set_title(f"probe {i}: node of {body} at ({pos[0]:.3g}, {pos[1]:.3g}, {pos[2]:.3g}) mm", fontsize=9)
    axes[-1, 0].set_xlabel(time_label)
    _figure_legend(fig, axes[:, 0])
    fig.suptitle(wrapped(f"{title}\ndisplacement of the probe nodes", 7), fontsize=9)
    figs.save(fig, "probes.png")


#: The history's energy keys and their labels, in the order drawn.
ENERGIES = (("kinetic_energy", "kinetic"), ("elastic_energy", "elastic"), ("external_work", "work of the loads"),
            ("damping_work", "dissipated by damping"), ("contact_work", "work of contact"))


def energy_unit(largest: float) -> tuple:
    """(factor, unit) that puts an energy of size ``largest`` (J) between 1 and 1000: J, mJ, uJ, nJ."""
    for factor, unit in ((1.0, "J"), (1e3, "mJ"), (1e6, "uJ"), (1e9, "nJ")):
        if abs(largest) * factor >= 1.0:
            return factor, unit
    return 1e9, "nJ"


def energy_balance(h) -> dict | None:
    """The terms of the energy balance of a history with ``external_work``, each its change
    since the first record (J per step): "input work" (the loads'), "kinetic", "elastic",
    "dissipated" (by damping, when recorded), "contact" (when recorded: the energy contact
    took, minus ``contact_work``, the work contact did on the bodies) and "remainder", input
    work - (the sum of the others): what the record does not name (round-off with HHT alpha =
    0, tests/test_energy_record.py; with alpha < 0 the integrator's numerical dissipation).
    None without the work of the loads or the energies."""
    if not all(k in h for k in ("external_work", "kinetic_energy", "elastic_energy")):
        return None
    keys = {"input work": ("external_work", 1.0), "kinetic": ("kinetic_energy", 1.0),
            "elastic": ("elastic_energy", 1.0), "dissipated": ("damping_work", 1.0), "contact": ("contact_work", -1.0)}
    terms = {}
    for name, (k, sign) in keys.items():
        if k in h:
            v = np.asarray(h[k], dtype=float)
            terms[name] = sign * (v - v[0])
    terms["remainder"] = terms["input work"] - sum(v for k, v in terms.items() if k != "input work")
    return terms


def _energy(figs, run, x, time_label, title) -> None:
    h = run.history
    keys = [(k, label) for k, label in ENERGIES if k in h]
    if not keys:
        figs.skip("energies", "the history has none ([output] energy = false)")
        return
    terms = energy_balance(h)
    if terms is None:  # no balance to draw: the energies there are
        terms = {label: np.asarray(h[k], dtype=float) for k, label in keys}
    factor, unit = energy_unit(max(float(np.abs(v).max(initial=0.0)) for v in terms.values()))
    plt = figs.plt
    balance = "remainder" in terms
    fig, axes = plt.subplots(2 if balance else 1, 1, figsize=(8, 6.4 if balance else 4.6), sharex=True, squeeze=False,
                             layout="constrained", height_ratios=[2, 1] if balance else None)
    ax = axes[0, 0]
    parts = [k for k in terms if k not in ("input work", "remainder")]
    if balance:
        ax.plot(x, terms["input work"] * factor, color="k", lw=2.4, label="input work (the loads')")
        ax.plot(x, sum(terms[k] for k in parts) * factor, color="0.6", lw=1.0, ls=(0, (4, 2)),
                label=" + ".join(parts))
    for i, k in enumerate(parts):
        label = {"kinetic": "kinetic", "elastic": "elastic", "dissipated": "dissipated by damping",
                 "contact": "taken by contact (- its work)"}.get(k, k) if balance else k
        ax.plot(x, terms[k] * factor, label=label, color=f"C{i}", **STYLES[i % len(STYLES)])
    ax.set_ylabel(f"energy ({unit})")
    head = (f"energy balance: input work = {' + '.join(parts)} (changes since the first record)"
            if balance else "energies and work")
    fig.suptitle(wrapped(f"{title}\n{head}", 7.5), fontsize=9)
    if balance:
        _remainder_panel(axes[1, 0], run, x, terms["remainder"], factor, unit, parts)
    axes[-1, 0].set_xlabel(time_label)
    _figure_legend(fig, axes[:, 0], "bottom", ncol=2)
    figs.save(fig, "energy.png")


def _remainder_panel(ax, run, x, remainder, factor, unit, parts) -> None:
    """The energy balance's remainder, labelled with what it is."""
    alpha = float(getattr(run.scene.time, "alpha", 0.0) or 0.0)
    what = (f"HHT alpha = {alpha:g}: the integrator's numerical dissipation" if alpha < 0 and
            run.scene.time.mode != "static" else "round-off when the record closes")
    ax.axhline(0.0, color="0.7", lw=0.6)
    ax.plot(x, remainder * factor, color="k", lw=1.2, label=f"remainder ({what})")
    ax.set_ylabel(f"remainder ({unit})")
    ax.set_title(f"input work - ({' + '.join(parts)})", fontsize=9)


def _reactions(figs, run, x, time_label, title) -> None:
    h = run.history
    keys = [k for k in h if k.startswith("reaction_force.")]
    if not keys:
        why = ("[output] reactions = false" if not run.scene.output.reactions
               else "the scene fixes no DOF, so there is no support force")
        figs.skip("reactions", why)
        return
    plt = figs.plt
    fig, axes = plt.subplots(len(keys), 1, figsize=(8, 2.2 * len(keys) + 1.2), sharex=True, squeeze=False,
                             layout="constrained")
    for ax, k in zip(axes[:, 0], keys):
        R = np.asarray(h[k], dtype=float)
        for c, name in enumerate("xyz"):
            ax.plot(x, R[:, c] * 1e3, label=f"R_{name}", color=f"C{c}", **STYLES[c])
        ax.set_ylabel("force (mN)")
        _, body, group = k.split(".", 2)
        ax.set_title(f"support {group!r} on {body}", fontsize=9)
    axes[-1, 0].set_xlabel(time_label)
    _figure_legend(fig, axes[:, 0])
    fig.suptitle(wrapped(f"{title}\nthe supports' forces on the bodies (reactions)", 7), fontsize=9)
    figs.save(fig, "reactions.png")


def snapshot_at_peak_force(run, bodies):
    """(index into the snapshots, its time, the peak force's time): the field snapshot nearest
    the step of the largest total contact force (over the bodies)."""
    h = run.history
    t = np.asarray(h["t"])
    norms = np.max([force_length(h[f"contact_force.{b}"]) for b in bodies], axis=0)
    t_peak = float(t[int(np.argmax(norms))])
    times = np.array([s[0] for s in run.snapshots(bodies[0])])
    k = int(np.argmin(np.abs(times - t_peak)))
    return k, float(times[k]), t_peak


def peak_map(run):
    """The contents of the run's ``contact_peak.npz`` (:meth:`vfrs.enforcement.record.ContactRecorder.peak_map`),
    or None when the run has none (it did not complete, or no contact force was recorded)."""
    path = os.path.join(run.out, EFFECTS["contact"].peak_file)
    return read_npz(path) if os.path.exists(path) else None


def _surface_triangles(run, b, mesh):
    """Body ``b``'s contact surface, as the [contact] effect says."""
    return EFFECTS["contact"].surface_triangles(run.scene.effects["contact"], b, mesh)


def _pressure_map(figs, run, bodies, title) -> None:
    try:
        peak = peak_map(run)
    except VfrsError as exc:
        figs.skip("pressure map", str(exc))
        return
    maps = []
    if peak is not None:
        p_all = np.asarray(peak["pressure"], dtype=float)
        for b in bodies:
            mesh, off = run.meshes[b]
            maps.append((b, mesh.points, _surface_triangles(run, b, mesh), p_all[off:off + mesh.n_points]))
        t_peak, force, who = float(peak["t"]), float(peak["force"]), str(peak["body"])
        at = (f"load factor {t_peak:.4g}" if run.scene.time.mode == "static" else f"t = {t_peak * 1e3:.3f} ms")
        when = (f"at the step of the largest total contact force, {at} "
                f"(|F| = {force * 1e3:.3g} mN on {who}), recorded at that step")
    else:
        if not any(np.asarray(run.history[f"contact_force.{b}"]).any() for b in bodies):
            figs.skip("pressure map", "no contact force was recorded in the run")
            return
        if not run.snapshots(bodies[0]):
            figs.skip("pressure map", "the run has no contact_peak.npz (written when a run completes) and no field "
                      "snapshots")
            return
        maps, when = _snapshot_maps(run, bodies)
    _draw_maps(figs, maps, title, when)


def _snapshot_maps(run, bodies):
    """The maps from the field snapshot nearest the peak force (a run without contact_peak.npz)."""
    k, t_snap, t_peak = snapshot_at_peak_force(run, bodies)
    contact, settings = EFFECTS["contact"], run.scene.effects["contact"]
    maps = []
    for b in bodies:
        mesh, _ = run.meshes[b]
        path = run.snapshots(b)[k][1]
        try:
            vtu = meshio_read(path)
        except MeshError as exc:  # a cut or foreign file: one line
            raise VfrsError(damaged(path, exc)) from None
        # as written; in a snapshot written before the field existed, from the contact force
        p = contact.snapshot_fields(settings, b, mesh, vtu.point_data)["contact_pressure"]
        maps.append((b, mesh.points, _surface_triangles(run, b, mesh), p))
    when = (f"at t = {t_snap * 1e3:.3f} ms, the field snapshot nearest the peak total contact force "
            f"(t = {t_peak * 1e3:.3f} ms; no contact_peak.npz: the run did not complete)")
    return maps, when


def boundary_edges(tri) -> np.ndarray:
    """The edges (k, 2) used by one triangle only: the outline of a triangulated surface."""
    tri = np.asarray(tri, dtype=np.int64)
    e = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    return edges[counts == 1]


def _draw_maps(figs, maps, title, when) -> None:
    """One panel per body's map, the panels of equal size (the same extent where they show the
    same plane, one colour bar for all)."""
    plt = figs.plt
    vmax = max(float(m[3].max()) for m in maps) * 1e-3 or 1.0
    fig, axes = plt.subplots(len(maps), 1, figsize=(9, 2.4 * len(maps) + 1.6), squeeze=False, layout="constrained")
    axes = axes[:, 0].tolist()
    drawn = [_draw_map(ax, b, X, tri, p, vmax) for ax, (b, X, tri, p) in zip(axes, maps)]
    _same_extent(axes, [plane for _, _, plane in drawn])
    p_top = max(top for _, top, _ in drawn)
    fig.colorbar(drawn[0][0], ax=axes, label="contact pressure (kPa)")
    fig.suptitle(wrapped(f"{title}\ncontact pressure on the contact surfaces (reference coordinates; grey: the "
                         f"surface's triangles and outline), largest {p_top * 1e-3:.3g} kPa,\n{when}", 8.6), fontsize=9)
    figs.save(fig, "pressure_map.png")


def _draw_map(ax, b, X, tri, p, vmax) -> tuple:
    """Body ``b``'s contact pressure ``p`` on its surface ``tri`` in ``ax``: (the colour mapping,
    the largest pressure, the plane (i, j) it is seen in)."""
    from matplotlib.collections import LineCollection
    from matplotlib.tri import Triangulation

    labels = ("x, medio-lateral", "y, inferior → superior", "z, anterior → posterior")
    used = np.unique(tri)
    # The surface seen along its thinnest direction: the two axes it spreads most along
    # (for the folds' medial surface z and y).
    i, j = sorted(np.argsort(np.ptp(X[used], axis=0))[1:])[::-1]
    tr = Triangulation(X[:, i] * 1e3, X[:, j] * 1e3, tri)
    im = ax.tripcolor(tr, p * 1e-3, shading="gouraud", cmap="inferno", vmin=0.0, vmax=vmax)
    # The surface: its triangles' edges in light grey, its outline darker (zero pressure is
    # black inside it; outside it the axes stay white).
    ax.triplot(tr, color="0.6", lw=0.25)
    out_edges = boundary_edges(tri)
    segs = np.stack([X[out_edges][:, :, i], X[out_edges][:, :, j]], axis=2) * 1e3
    ax.add_collection(LineCollection(list(segs), colors="0.35", linewidths=0.9))
    k_max = used[int(np.argmax(p[used]))]
    if p[k_max] > 0:
        ax.plot(X[k_max, i] * 1e3, X[k_max, j] * 1e3, "c+", ms=12, mew=2)
    ax.set_title(f"{b}: max {p[k_max] * 1e-3:.3g} kPa (+)", fontsize=9)
    loaded = used[p[used] > 0]
    if loaded.size:  # the contact zone with a margin, not the whole wetted surface
        margin = max(0.25 * np.ptp(X[loaded, j]), 1e-3)
        lo, hi = X[used, j].min(), X[used, j].max()
        ax.set_ylim(max(lo, X[loaded, j].min() - margin) * 1e3, min(hi, X[loaded, j].max() + margin) * 1e3)
    ax.set_xlim(X[used, i].min() * 1e3, X[used, i].max() * 1e3)
    ax.set_xlabel(f"{labels[i]} (mm)")
    ax.set_ylabel(f"{labels[j]} (mm)")
    ax.set_aspect("equal")
    return im, float(p[k_max]), (int(i), int(j))


def _same_extent(axes, planes) -> None:
    """Panels that show the same plane get the union of their extents: with equal aspect, a
    panel with a taller extent was narrower."""
    for plane in set(planes):
        group = [ax for ax, p in zip(axes, planes) if p == plane]
        x = [v for ax in group for v in ax.get_xlim()]
        y = [v for ax in group for v in ax.get_ylim()]
        for ax in group:
            ax.set_xlim(min(x), max(x))
            ax.set_ylim(min(y), max(y))
