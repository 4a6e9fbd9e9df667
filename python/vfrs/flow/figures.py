"""The figure of the ``[flow]`` effect (:meth:`vfrs.effects.Effect.figures`, drawn by
``vfrs plot``, :mod:`vfrs.plot`): ``glottal_area_flow.png``, the glottal area and flow rate vs
time, the analysis window (over which the summary's per-cycle values are measured) and the
steps in contact (a contact pair active, when the history records them) shaded, both named in
a legend."""

from __future__ import annotations

import numpy as np

from ..figures import wrapped


def glottal_figures(run, figs) -> None:
    """The [flow] effect's figure of ``run``, or skipped with why (no glottal area)."""
    h = run.history
    if "glottal_area" not in h:
        figs.skip("glottal area and flow", "the run has no [flow]")
        return
    active = np.asarray(h["active_pairs"]) > 0 if "active_pairs" in h else None
    glottal_figure(figs, run, figs.t, active, figs.title)


def in_contact_spans(ax, t, active):
    from ..signals import contact_intervals

    for a, b in contact_intervals(t, active):
        ax.axvspan(a * 1e3, b * 1e3, color="tab:red", alpha=0.12, lw=0)


def glottal_figure(figs, run, t, active, title) -> None:
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
            in_contact_spans(a, t, active)
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
