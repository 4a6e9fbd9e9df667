"""What the ``[contact]`` effect gives the output, asked through the effect's hooks
(:class:`vfrs.effects.Effect`) by :mod:`vfrs.summary`, :mod:`vfrs.history` (the VTU
snapshots) and the effect's figures (:mod:`vfrs.enforcement.figures`): the ``contact``
section of the summary and its notes, the ``contact_pressure`` field of the snapshots, the
pressure of a snapshot written without it, the contact surfaces' triangles of a body, the
effect's work for the energy balance, and the names of its section known before a run
(:func:`vfrs.summary.summary_names`). The history keys read here are those
:class:`vfrs.enforcement.record.ContactRecorder` writes."""

from __future__ import annotations

import math

import numpy as np

from ..signals import contact_intervals, contact_time_per_cycle, cycle_peaks, first_contact, impulse_per_cycle, peak
from ..summary import Quantity, ROUNDOFF
from ..contact import tributary_areas
from .record import PEAK_FILE, nodal_pressure


def _largest_patch(t, h, key: str, bodies) -> tuple:
    """(largest value, its time, its body) of the per-body series ``key.<body>`` over the run."""
    best = (float("nan"), None, None)
    for b in bodies:
        val, when = peak(t, h[f"{key}.{b}"])
        if math.isfinite(val) and not (val <= best[0]):
            best = (val, when, b)
    return best


def contact_measures(run) -> dict:
    """Contact measures of a run with ``[contact]`` (``run``: a :class:`vfrs.summary.RunView`;
    empty dict without ``active_pairs``): ``first_contact`` (s),
    ``contact_duration`` (s: mean time in contact per glottal cycle over the window; without
    flow, per run of consecutive steps in contact), ``contact_quotient`` (contact time / cycle),
    ``peak_force.<body>`` (N, the largest total contact force on the body, with its time),
    ``contact_impulse.<body>`` (N s, the impulse of the contact force per glottal cycle, mean;
    without flow, per contact), ``closed_phase_pressure`` (Pa, with glottal cycles: the
    contact impulse over the time integral of the effective area, per cycle, mean), ``peak_contact_pressure`` (Pa, the largest nodal pressure,
    when, on which body, where: one node's, it refines with the mesh), ``peak_sensor_pressure``
    (Pa, the largest pressure on a sensor of face area ``[contact] sensor_area``: the nodal
    pressures within its radius averaged by their tributary areas; its disc holds 1 to 11
    nodes on practical meshes, so it has no limit), ``peak_disc_pressure`` (Pa, the same
    sensor as a measure with a limit: the P1 pressure integrated over its exact disc, history
    ``contact_pressure_disc``; the label says how many surface nodes its disc held when that
    is fewer than :data:`vfrs.contact.sensor.MIN_NODES`),
    ``mean_contact_pressure`` (Pa, area-weighted mean over the loaded nodes at the step of the
    largest total force), ``force_weighted_pressure`` (Pa, sum p^2 a / sum p a at that step),
    ``max_contact_area`` (m^2, the area of the contact patch: the largest over the run and the
    bodies of one body's surface triangles with a loaded vertex, so an interface between two
    bodies counts once; with its body), ``max_contact_area_summed`` (m^2, the same summed over
    all the contact surfaces at each step, the paper's definition: an interface between two
    bodies counts twice), ``max_effective_area`` and ``max_effective_area_summed`` (m^2,
    (sum p a)^2 / sum p^2 a over one body's surface, and over all of them), ``max_nodal_area``
    (m^2, the largest over the run and the bodies of one body's loaded nodes' tributary areas,
    history ``contact_area_nodal.<body>``: a rim element counts a third per loaded vertex),
    ``max_intersection_volume`` (m^3), ``max_penetration`` (m). Histories recorded before the
    per-body areas (``contact_area.<body>``) have only the summed ones.

    The mean over cycles (or contacts) carry each one's value (``per_cycle``). Which are over
    the window and which over the whole run: ``over``. Penetration and intersection volume
    below :data:`vfrs.summary.ROUNDOFF` of ``length_scale`` (m; default :func:`vfrs.summary.element_size` of the run) and
    its cube, forces and impulses below it of the largest body's, are marked as round-off
    (``roundoff``)."""
    h, scene, body_of_node = run.history, run.scene, run.body_of_node
    if "active_pairs" not in h:
        return {}
    length_scale, cyc = run.length_scale, run.cycles
    t = np.asarray(h["t"])
    c = np.asarray(h["active_pairs"]) > 0
    out: dict[str, Quantity] = {}
    _timing_measures(out, t, c, cyc)
    bodies = [k.split(".", 1)[1] for k in h if k.startswith("contact_force.")]
    k_peak, f_peak = _force_measures(out, h, t, bodies)
    _impulse_measures(out, h, t, c, cyc, bodies)
    _closed_phase_pressure(out, h, t, cyc, bodies)
    _peak_pressure_measures(out, h, t, scene, body_of_node)
    if k_peak is not None and f_peak > 0:
        _pressures_at_peak_force(out, h, t, k_peak)
    _area_measures(out, h, t, bodies)
    _overlap_measures(out, h, t, length_scale)
    return out


def _timing_measures(out: dict, t, c, cyc) -> None:
    """``first_contact``, ``contact_duration`` and (with glottal cycles) ``contact_quotient``."""
    t1 = first_contact(t, c)
    out["first_contact"] = Quantity(float("nan") if t1 is None else t1, "s", "first contact", over="run")
    if len(cyc) >= 2:
        per = contact_time_per_cycle(t, c, cyc)
        out["contact_duration"] = Quantity(float(per.mean()), "s", "contact duration per glottal cycle",
                                           per_cycle=tuple(per.tolist()), over="window")
        quot = per / np.diff(cyc)
        out["contact_quotient"] = Quantity(float(np.mean(quot)), "1", "contact quotient (contact time / cycle)",
                                           per_cycle=tuple(quot.tolist()), over="window")
    else:
        iv = contact_intervals(t, c)
        d = np.diff(iv, axis=1).ravel()
        out["contact_duration"] = Quantity(float(d.mean()) if d.size else 0.0, "s", "contact duration per contact",
                                           per_cycle=tuple(d.tolist()), over="run", per="contact")


def _force_measures(out: dict, h, t, bodies) -> tuple:
    """``peak_force.<body>``; returns (the step of the largest body's peak force or None, that
    peak force, -1.0 when no body has a finite one)."""
    k_peak, f_peak = None, -1.0
    peaks = {}
    for b in bodies:
        F = np.asarray(h[f"contact_force.{b}"])
        peaks[b] = peak(t, F)
        val = peaks[b][0]
        if np.isfinite(val) and val > f_peak:
            f_peak, k_peak = val, int(np.argmax(np.linalg.norm(F, axis=1)))
    force_scale = ROUNDOFF * f_peak if f_peak > 0 else None
    for b in bodies:
        val, when = peaks[b]
        out[f"peak_force.{b}"] = Quantity(val, "N", f"peak contact force on {b}", t=when, over="run",
                                          roundoff=force_scale, scale=None if force_scale is None else
                                          f"{ROUNDOFF:g} of the largest body's peak contact force", kind="extreme")
    return k_peak, f_peak


def _impulse_measures(out: dict, h, t, c, cyc, bodies) -> None:
    """``contact_impulse.<body>``: per glottal cycle, or without cycles per contact episode."""
    impulses: dict[str, tuple] = {}
    for b in bodies:
        F = np.asarray(h[f"contact_force.{b}"])
        if len(cyc) >= 2:
            imp = impulse_per_cycle(t, F, cyc)
            impulses[b] = (imp, f"contact impulse per glottal cycle on {b}", "window", None)
        else:  # per contact episode
            iv = contact_intervals(t, c)
            imp = impulse_per_cycle(t, F, np.append(iv[:, 0], iv[-1, 1])) if len(iv) else np.zeros(0)
            impulses[b] = (imp, f"contact impulse per contact on {b}", "run", "contact")
    means = {b: float(v[0].mean()) if v[0].size else 0.0 for b, v in impulses.items()}
    largest = max(means.values(), default=0.0)
    for b, (imp, what, over, per_what) in impulses.items():
        out[f"contact_impulse.{b}"] = Quantity(means[b], "N s", what, per_cycle=tuple(imp.tolist()), over=over,
                                               per=per_what, roundoff=ROUNDOFF * largest if largest > 0 else None,
                                               scale=f"{ROUNDOFF:g} of the largest body's" if largest > 0 else None,
                                               kind="smooth")


def _closed_phase_pressure(out: dict, h, t, cyc, bodies) -> None:
    """``closed_phase_pressure`` (with glottal cycles and the effective areas recorded): the
    mean contact pressure of the closed phase, per cycle the contact impulse over the time
    integral of the effective contact area, ``int |F| dt / int A_eff dt`` (history
    ``contact_force.<body>`` and ``contact_area_effective.<body>``, ``A_eff = (sum p a)^2 /
    sum p^2 a``, of the body with the largest mean impulse): a smooth functional, the pressure
    averaged over the contact zone and the time in contact; the mean over the window's cycles
    with contact. The loaded nodes' area in its place jumps as light nodes join and leave
    (on the main job's level 0 its per-cycle values spread 13 % over cycles whose impulse
    repeats to 0.3 %; with the effective area 0.6 %)."""
    keys = [b for b in bodies if f"contact_area_effective.{b}" in h]
    if len(cyc) < 2 or not keys:
        return
    imp = {b: impulse_per_cycle(t, h[f"contact_force.{b}"], cyc) for b in keys}
    b = max(keys, key=lambda k: float(imp[k].mean()))
    area_time = impulse_per_cycle(t, h[f"contact_area_effective.{b}"], cyc)
    touched = area_time > 0
    if not touched.any():
        return
    per = imp[b][touched] / area_time[touched]
    out["closed_phase_pressure"] = Quantity(float(per.mean()), "Pa", "mean contact pressure of the closed phase "
                                            f"(impulse / time-integrated effective area, {b})", per_cycle=tuple(per.tolist()),
                                            over="window", kind="smooth")


def _peak_pressure_measures(out: dict, h, t, scene, body_of_node) -> None:
    """``peak_contact_pressure`` (one node's) and ``peak_sensor_pressure`` (a sensor's)."""
    if "contact_pressure_max" in h:
        out["peak_contact_pressure"] = _peak_of(h, t, "contact_pressure_max", "peak nodal contact pressure",
                                                body_of_node)
    if "contact_pressure_sensor" in h:
        area = getattr(scene.effects.get("contact"), "sensor_area", None) if scene is not None else None
        face = f"{area * 1e6:g} mm^2 sensor" if area else "sensor"
        out["peak_sensor_pressure"] = _peak_of(h, t, "contact_pressure_sensor", f"peak contact pressure on a {face}",
                                               body_of_node)
    if "contact_pressure_disc" in h:
        k = int(np.argmax(np.asarray(h["contact_pressure_disc"])))
        inside = int(np.asarray(h["contact_pressure_disc_nodes"])[k])
        from ..contact.sensor import MIN_NODES

        few = f"; its disc held {inside} surface nodes, fewer than {MIN_NODES}" if 0 < inside < MIN_NODES else ""
        out["peak_disc_pressure"] = _peak_of(h, t, "contact_pressure_disc",
                                             f"peak contact pressure over the exact disc of the {face}{few}",
                                             body_of_node)


def _peak_of(h, t, key: str, label: str, body_of_node) -> Quantity:
    """The largest value of the pressure record ``key`` with its step's time, and the node
    (``key``_node), body and position (``key``_position) where it was, when any node was loaded."""
    p = np.asarray(h[key])
    k = int(np.argmax(p))
    node = int(np.asarray(h[f"{key}_node"])[k])
    loaded = node >= 0 and p[k] > 0
    pos = tuple(float(v) for v in np.asarray(h[f"{key}_position"])[k]) if loaded else None
    body = body_of_node(node) if (loaded and body_of_node is not None) else None
    return Quantity(float(p[k]), "Pa", label, t=float(t[k]) if loaded else None, body=body, position=pos, over="run",
                    kind="extreme")


def _pressures_at_peak_force(out: dict, h, t, k_peak: int) -> None:
    """``mean_contact_pressure`` and ``force_weighted_pressure`` at step ``k_peak``."""
    if "contact_pressure_mean" in h:
        out["mean_contact_pressure"] = Quantity(float(np.asarray(h["contact_pressure_mean"])[k_peak]), "Pa",
                                                "mean contact pressure at the peak force", t=float(t[k_peak]),
                                                over="run")
    if "contact_pressure_force_weighted" in h:
        out["force_weighted_pressure"] = Quantity(float(np.asarray(h["contact_pressure_force_weighted"])[k_peak]),
                                                  "Pa", "force-weighted pressure at the peak force",
                                                  t=float(t[k_peak]), over="run")


def _area_measures(out: dict, h, t, bodies) -> None:
    """The contact areas: one body's patch (an interface counts once), and summed over all the
    contact surfaces (the paper's; an interface between two bodies counts twice)."""
    for key, name, what in (("contact_area", "max_contact_area", "maximum contact area (one body's patch)"),
                            ("contact_area_effective", "max_effective_area",
                             "maximum effective contact area (one body's)"),
                            ("contact_area_nodal", "max_nodal_area", "maximum loaded nodes' area (one body's)")):
        mine = [b for b in bodies if f"{key}.{b}" in h]
        if mine:
            val, when, body = _largest_patch(t, h, key, mine)
            out[name] = Quantity(val, "m^2", what, t=when if val > 0 else None, body=body if val > 0 else None,
                                 over="run", kind="extreme")
    for key, name, what in (("contact_area", "max_contact_area_summed",
                             "maximum contact area, both surfaces summed (paper)"),
                            ("contact_area_effective", "max_effective_area_summed",
                             "maximum effective contact area, both surfaces summed")):
        if key in h:
            val, when = peak(t, h[key])
            out[name] = Quantity(val, "m^2", what, t=when if val > 0 else None, over="run", kind="extreme")


def _overlap_measures(out: dict, h, t, length_scale) -> None:
    """``max_intersection_volume`` and ``max_penetration``, with their round-off limits."""
    h_el = length_scale if length_scale else None
    for key, name, unit, what, limit in (
            ("intersection_volume", "max_intersection_volume", "m^3", "maximum intersection volume",
             None if h_el is None else (ROUNDOFF * h_el**3, f"{ROUNDOFF:g} of the mean tetrahedron edge cubed")),
            ("max_penetration", "max_penetration", "m", "maximum penetration",
             None if h_el is None else (ROUNDOFF * h_el, f"{ROUNDOFF:g} of the mean tetrahedron edge"))):
        if key in h:
            val, when = peak(t, h[key])
            out[name] = Quantity(val, unit, what, t=when if val > 0 else None, over="run",
                                 roundoff=None if limit is None else limit[0], scale=None if limit is None else limit[1],
                                 kind="extreme")




def contact_per_cycle(run) -> dict:
    """For the periodicity test, in each glottal cycle of the window: ``peak_force``, the
    largest total contact force on any body (N, an extreme), and ``impulse``, the largest
    body's contact impulse (N s, :func:`vfrs.signals.impulse_per_cycle`, a smooth functional:
    issue 45 asks a limit cycle to repeat it); nothing without cycles or without contact in them."""
    h, cyc = run.history, run.cycles
    bodies = [k for k in h if k.startswith("contact_force.")]
    if len(cyc) < 2 or not bodies:
        return {}
    per = np.max([cycle_peaks(run.t, h[k], cyc) for k in bodies], axis=0)
    if not per.max() > 0:
        return {}
    imp = np.max([impulse_per_cycle(run.t, h[k], cyc) for k in bodies], axis=0)
    return {"peak_force": ("peak contact force", per), "impulse": ("contact impulse", imp)}


def contact_notes(run, sections) -> list:
    """The peak nodal contact pressure is one node's; the contact area and the mean pressure
    jump as single nodes join the contact."""
    out = []
    if "peak_contact_pressure" in sections.get("contact", {}):
        out.append("the peak nodal contact pressure is one node's: it grows as the mesh refines (the edge of the "
                   "contact zone); the sensor's, over its face, is the one to compare with measurements")
    if "max_contact_area" in sections.get("contact", {}):
        out.append("the contact area (triangles with a loaded vertex) and the mean pressure over the loaded nodes "
                   "jump as single nodes join the contact; the force-weighted pressure and the effective area "
                   "follow the pressure field smoothly")
    return out


def surface_triangles(settings, body: str, mesh) -> np.ndarray:
    """The contact surface of ``body`` (its ``mesh``) under the resolved ``[contact]``
    ``settings``: the named surface, or the whole boundary when the mesh has no such surface."""
    surface = settings.common.surface
    name = surface if isinstance(surface, str) else surface.get(body, "medial")
    tri = mesh.surfaces.get(name)
    return mesh.boundary_faces() if tri is None else tri


class ContactOutputs:
    """The [contact] effect's output hooks (:class:`vfrs.effects.Effect`)."""

    files = (PEAK_FILE,)
    work_key: str | None = "contact_work"

    @classmethod
    def measures(cls, run) -> dict:
        co = contact_measures(run)
        return {"contact": co} if co else {}

    @classmethod
    def notes(cls, run, sections) -> list:
        return contact_notes(run, sections)

    @classmethod
    def cycle_values(cls, run) -> dict:
        return contact_per_cycle(run)

    @classmethod
    def summary_names(cls, scene) -> dict:
        """The names :func:`contact_measures` gives: each body's peak force and impulse, and the
        contact quotient with glottal cycles (an effect of the scene with a ``cycle_signal``)."""
        from ..effects import EFFECTS

        cycles = any(getattr(EFFECTS[name], "cycle_signal", None) for name in scene.effects)
        bodies = [b.name for b in scene.bodies]
        return {"contact": ["first_contact", "contact_duration", *(["contact_quotient"] if cycles else []),
                            *(f"peak_force.{b}" for b in bodies), *(f"contact_impulse.{b}" for b in bodies),
                            *(["closed_phase_pressure"] if cycles else []), "peak_contact_pressure", "peak_sensor_pressure", "peak_disc_pressure",
                            "mean_contact_pressure", "force_weighted_pressure", "max_contact_area",
                            "max_effective_area", "max_nodal_area",
                            "max_contact_area_summed", "max_effective_area_summed", "max_intersection_volume",
                            "max_penetration"]}

    def output_fields(self, fields: dict) -> dict:
        """``contact_pressure`` (Pa): the compressive normal part of each contact-surface
        node's ``contact_force`` over its tributary area (reference), normals at the displaced
        positions (:func:`vfrs.enforcement.record.nodal_pressure`, as the history's
        ``contact_pressure_max``); nothing when the snapshot has no ``contact_force``."""
        force = fields.get("contact_force")
        if force is None:
            return {}
        points = self.problem.points  # type: ignore[attr-defined]
        x = points + fields["displacement"] if "displacement" in fields else points
        areas = self.surfaces.areas  # type: ignore[attr-defined]
        pressure = nodal_pressure(force, x, self.recorder.triangles, areas)  # type: ignore[attr-defined]
        quadratic = self.recorder.quadratic  # type: ignore[attr-defined]  # quadratic bodies: projected
        return {"contact_pressure": quadratic.apply(pressure, areas) if quadratic else pressure}

    @classmethod
    def snapshot_fields(cls, settings, body: str, mesh, point_data: dict) -> dict:
        """``contact_pressure`` of one body's snapshot (``point_data`` read from its VTU): as
        written, or, in a snapshot written before the field existed, from its
        ``contact_force`` over the tributary areas of the body's contact surface."""
        if "contact_pressure" in point_data:
            return {"contact_pressure": np.asarray(point_data["contact_pressure"])}
        tri = surface_triangles(settings, body, mesh)
        x = mesh.points + np.asarray(point_data.get("displacement", 0.0))
        return {"contact_pressure": nodal_pressure(point_data["contact_force"], x, tri, tributary_areas(mesh.points, tri))}
