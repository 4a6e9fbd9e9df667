"""``vfrs plot OUT``: the standard figures of a run, from its output folder.

Writes PNGs into ``OUT/plots/`` (or ``dest``), each only when the run has what it shows:

- ``glottal_area_flow.png`` ([flow]): glottal area and flow rate vs time, the analysis window
  and the steps in contact shaded;
- ``contact_force.png`` ([contact]): the total contact force on each body (its length and its
  medio-lateral component) vs time;
- ``contact_pressure.png`` ([contact]): the largest nodal contact pressure and the area-weighted
  mean pressure of the loaded nodes vs time, with the range of peak impact stress measured in
  an excised canine hemilarynx (Jiang & Titze 1994) for scale;
- ``pressure_map.png`` ([contact] and field output): the contact pressure on each body's contact
  surface, seen along its thinnest direction (the folds' medial surface in its (z, y) plane:
  anterior-posterior x inferior-superior, reference coordinates), at the field snapshot
  nearest the instant of the largest total contact force (snapshots come every
  ``[output] every`` steps: the figure says how far apart the two instants are).

From Python: ``vfrs.plot.plot_run("out/m5_collision")`` returns the paths written.
"""

from __future__ import annotations

import os

import numpy as np

#: Peak impact stress near the centre of the fold measured in an excised canine hemilarynx, Pa
#: (Jiang & Titze 1994, "Measurement of vocal fold intraglottal pressure and impact stress",
#: J. Voice 8, 132-144: about 0.5-5 kPa over the prephonatory settings tested; see docs/results.md).
PUBLISHED_IMPACT_STRESS = (0.5e3, 5.0e3)


def require_matplotlib():
    """Imports matplotlib with the Agg backend, or raises VfrsError saying how to install it."""
    try:
        import matplotlib
    except ImportError:
        from .errors import VfrsError

        raise VfrsError("plotting needs matplotlib, which is not installed: pip install matplotlib "
                        "(it is a dependency of vfrs; an install with --no-deps leaves it out)") from None
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _in_contact_spans(ax, t, active):
    from .analysis import contact_intervals

    for a, b in contact_intervals(t, active):
        ax.axvspan(a * 1e3, b * 1e3, color="tab:red", alpha=0.12, lw=0)


def plot_run(out, dest=None) -> list:
    """Draws the standard figures of the run in the output folder ``out`` into ``dest``
    (default ``out/plots``); returns the paths written."""
    plt = require_matplotlib()
    from .analysis import load

    run = load(out)
    h = run.history
    t = np.asarray(h["t"])
    dest = os.path.join(run.out, "plots") if dest is None else os.fspath(dest)
    os.makedirs(dest, exist_ok=True)
    summary = run.summary
    title = run.scene.title or os.path.basename(os.path.abspath(run.out))
    written = []
    active = np.asarray(h["active_pairs"]) > 0 if "active_pairs" in h else None

    def save(fig, name):
        path = os.path.join(dest, name)
        fig.savefig(path, dpi=120)
        plt.close(fig)
        written.append(path)

    if "glottal_area" in h:
        fig, ax = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
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
        ph = summary.sections.get("phonation", {})
        bits = [f"{ph[k].what.split(' (')[0]} {ph[k].text()}" for k in ("f0", "open_quotient") if k in ph]
        ax[0].set_title(f"{title}\n" + "; ".join(bits) + ("; red: in contact, grey: analysis window" if active is not None
                                                         else "; grey: analysis window"), fontsize=9)
        fig.tight_layout()
        save(fig, "glottal_area_flow.png")

    bodies = [k.split(".", 1)[1] for k in h if k.startswith("contact_force.")]
    if bodies:
        fig, ax = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True)
        for b in bodies:
            F = np.asarray(h[f"contact_force.{b}"])
            ax[0].plot(t * 1e3, np.linalg.norm(F, axis=1) * 1e3, label=b)
            ax[1].plot(t * 1e3, F[:, 0] * 1e3, label=b)
        ax[0].set_ylabel("|total contact force| (mN)")
        ax[1].set_ylabel("medio-lateral F_x (mN)")
        ax[1].set_xlabel("t (ms)")
        ax[0].legend()
        ax[0].set_title(f"{title}\ncontact force on each body (the impulse contact gave it per step, over h)", fontsize=9)
        fig.tight_layout()
        save(fig, "contact_force.png")

    if "contact_pressure_max" in h:
        fig, ax = plt.subplots(figsize=(8, 4))
        lo, hi = PUBLISHED_IMPACT_STRESS
        ax.axhspan(lo * 1e-3, hi * 1e-3, color="tab:orange", alpha=0.12, lw=0,
                   label="peak impact stress, excised canine hemilarynx (Jiang & Titze 1994)")
        ax.plot(t * 1e3, np.asarray(h["contact_pressure_max"]) * 1e-3, label="largest nodal pressure")
        ax.plot(t * 1e3, np.asarray(h["contact_pressure_mean"]) * 1e-3, label="mean over the loaded nodes")
        ax.set_xlabel("t (ms)")
        ax.set_ylabel("contact pressure (kPa)")
        co = summary.sections.get("contact", {})
        peak = co.get("peak_contact_pressure")
        ax.set_title(f"{title}\npeak {peak.text()}" if peak is not None else title, fontsize=9)
        ax.legend(fontsize=8, loc="upper left")
        fig.tight_layout()
        save(fig, "contact_pressure.png")

    if bodies:
        path = _pressure_map(plt, run, bodies, title, dest)
        if path:
            written.append(path)
    return written


def snapshot_at_peak_force(run, bodies):
    """(index into the snapshots, its time, the peak force's time): the field snapshot nearest
    the step of the largest total contact force (over the bodies)."""
    h = run.history
    t = np.asarray(h["t"])
    norms = np.max([np.linalg.norm(np.asarray(h[f"contact_force.{b}"]), axis=1) for b in bodies], axis=0)
    t_peak = float(t[int(np.argmax(norms))])
    times = np.array([s[0] for s in run.snapshots(bodies[0])])
    k = int(np.argmin(np.abs(times - t_peak)))
    return k, float(times[k]), t_peak


def _pressure_map(plt, run, bodies, title, dest):
    import meshio
    from matplotlib.tri import Triangulation

    from .enforcement.record import nodal_pressure
    from .contact import tributary_areas

    if not run.snapshots(bodies[0]):
        return None
    k, t_snap, t_peak = snapshot_at_peak_force(run, bodies)
    surface = run.scene.effects["contact"].common.surface
    maps = []
    for b in bodies:
        mesh, _ = run.meshes[b]
        name = surface if isinstance(surface, str) else surface.get(b, "medial")
        tri = mesh.surfaces.get(name)
        if tri is None:
            tri = mesh.boundary_faces()
        vtu = meshio.read(run.snapshots(b)[k][1])
        if "contact_pressure" in vtu.point_data:
            p = np.asarray(vtu.point_data["contact_pressure"])
        else:  # written before the pressure field existed: compute it from the force
            x = mesh.points + np.asarray(vtu.point_data.get("displacement", 0.0))
            p = nodal_pressure(vtu.point_data["contact_force"], x, tri, tributary_areas(mesh.points, tri))
        maps.append((b, mesh.points, tri, p))
    vmax = max(float(m[3].max()) for m in maps) * 1e-3 or 1.0
    fig, axes = plt.subplots(len(maps), 1, figsize=(9, 2.4 * len(maps) + 1.4), squeeze=False)
    axes = axes.T
    im = None
    labels = ("x, medio-lateral", "y, inferior → superior", "z, anterior → posterior")
    for ax, (b, X, tri, p) in zip(axes[0], maps):
        used = np.unique(tri)
        # The surface seen along its thinnest direction: the two axes it spreads most along
        # (for the folds' medial surface z and y).
        i, j = sorted(np.argsort(np.ptp(X[used], axis=0))[1:])[::-1]
        tr = Triangulation(X[:, i] * 1e3, X[:, j] * 1e3, tri)
        im = ax.tripcolor(tr, p * 1e-3, shading="gouraud", cmap="inferno", vmin=0.0, vmax=vmax)
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
    fig.colorbar(im, ax=axes[0].tolist(), label="contact pressure (kPa)")
    fig.suptitle(f"{title}\ncontact pressure on the contact surfaces (reference coordinates) at t = {t_snap * 1e3:.2f} ms:\n"
                 f"the field snapshot nearest the peak total contact force (t = {t_peak * 1e3:.2f} ms)", fontsize=9)
    path = os.path.join(dest, "pressure_map.png")
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path
