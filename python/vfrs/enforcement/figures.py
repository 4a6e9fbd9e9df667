"""The figures of the ``[contact]`` effect (:meth:`vfrs.effects.Effect.figures`, drawn by
``vfrs plot``, :mod:`vfrs.plot`):

- ``contact_force.png``: the total contact force on each body (its length and its
  medio-lateral component) vs time. Forces of two bodies that are equal and opposite to
  round-off are one line, labelled so; otherwise each body has its own line style;
- ``contact_pressure.png``: the sensor's pressure (the largest reading of a
  ``[contact] sensor_area`` sensor, the summary's ``peak_sensor_pressure``: the one to compare
  with measurements) in front of the range of peak impact stress measured in an excised canine
  hemilarynx (Jiang & Titze 1994); the largest nodal pressure (one node's) and the
  area-weighted mean pressure of the loaded nodes thinner;
- ``pressure_map.png``: the contact pressure on each body's contact surface at the
  step of the largest total contact force, as recorded at that step (``contact_peak.npz``,
  written when the run completes), seen along the surface's thinnest direction (the folds'
  medial surface in its (z, y) plane: anterior-posterior x inferior-superior, reference
  coordinates), with the surface's triangles in grey (zero pressure is black inside the
  grey mesh, outside the surface is white; the panels of one plane share their extent, so they
  are equally wide, and one colour bar). A run that did not complete has no
  ``contact_peak.npz``: the map is then the field snapshot nearest the peak, and its title
  says how far apart the two instants are.
"""

from __future__ import annotations

import os

import numpy as np

from ..output.reader import read_npz
from ..signals import force_length
from ..errors import MeshError, VfrsError
from ..figures import STYLES, figure_legend, wrapped
from ..mesh import meshio_read
from ..output.reader import damaged
from .outputs import ContactOutputs, surface_triangles
from .record import PEAK_FILE


#: Peak impact stress near the centre of the fold measured in an excised canine hemilarynx, Pa
#: (Jiang & Titze 1994, "Measurement of vocal fold intraglottal pressure and impact stress",
#: J. Voice 8, 132-144: about 0.5-5 kPa over the prephonatory settings tested; see docs/results.md).
PUBLISHED_IMPACT_STRESS = (0.5e3, 5.0e3)

#: Two bodies' contact forces whose sum and whose lengths' difference stay within this
#: fraction of the peak force are drawn as one line ("equal and opposite"): round-off.
EQUAL_AND_OPPOSITE = 1e-9


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



def contact_figures(run, figs) -> None:
    """The [contact] effect's figures of ``run`` (:meth:`vfrs.effects.Effect.figures`), each
    only when the history has its records, else skipped with why: ``contact_force.png``,
    ``contact_pressure.png`` and ``pressure_map.png``."""
    h, t, plt = run.history, figs.t, figs.plt
    has_contact = "contact" in run.scene.effects
    bodies = [k.split(".", 1)[1] for k in h if k.startswith("contact_force.")]
    if bodies:
        forces = {b: np.asarray(h[f"contact_force.{b}"]) for b in bodies}
        fig = contact_force_figure(plt, t, forces, figs.title, figs.time_label, figs.time_scale)
        figs.save(fig, "contact_force.png")
    else:
        figs.skip("contact force", "the run has no contact" if not has_contact else "the history has no contact_force")

    if "contact_pressure_max" in h:
        _pressure_curves(figs, run, figs.x, figs.time_label, figs.title)
    else:
        figs.skip("contact pressure", "the run has no contact" if not has_contact else
                  "the history has no contact_pressure_max")

    if bodies:
        _pressure_map(figs, run, bodies, figs.title)
    else:
        figs.skip("pressure map", "the run has no contact" if not has_contact else "the history has no contact_force")


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
    figure_legend(fig, [ax], "bottom")
    figs.save(fig, "contact_pressure.png")



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
    path = os.path.join(run.out, PEAK_FILE)
    return read_npz(path) if os.path.exists(path) else None


def _surface_triangles(run, b, mesh):
    """Body ``b``'s contact surface, as the [contact] effect says."""
    return surface_triangles(run.scene.effects["contact"], b, mesh)


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
        at = (f"load factor {t_peak:.4g}" if figs.static else f"t = {t_peak * 1e3:.3f} ms")
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
    draw_maps(figs, maps, title, when)


def _snapshot_maps(run, bodies):
    """The maps from the field snapshot nearest the peak force (a run without contact_peak.npz)."""
    k, t_snap, t_peak = snapshot_at_peak_force(run, bodies)
    settings = run.scene.effects["contact"]
    maps = []
    for b in bodies:
        mesh, _ = run.meshes[b]
        path = run.snapshots(b)[k][1]
        try:
            vtu = meshio_read(path)
        except MeshError as exc:  # a cut or foreign file: one line
            raise VfrsError(damaged(path, exc)) from None
        # as written; in a snapshot written before the field existed, from the contact force
        p = ContactOutputs.snapshot_fields(settings, b, mesh, vtu.point_data)["contact_pressure"]
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


def draw_maps(figs, maps, title, when) -> None:
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

