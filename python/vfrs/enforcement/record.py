"""What the ``[contact]`` effect records per step (history keys, one value per step).

``contact_pairs``, ``active_pairs``, ``iterations`` (LCP iterations of the step's last
detection round), ``augmentations``, ``detections``, ``contact_settled``,
``contact_converged``, ``contact_work`` (J: the work of the contact forces on the bodies, with
the stabilized predictor's projections: the energy contact gave them), ``max_penetration`` (m), ``intersection_volume``
(m^3), ``condition``, ``contact_force.<body>`` (N: impulse / h, see docs/contact.md),
``contact_area`` (m^2: summed area of contact-surface triangles with any loaded vertex over
all the contact surfaces, the paper's definition: two bodies pressed together over an
interface of area A record 2 A), ``contact_area.<body>`` (m^2: the same on one body's surface,
the area of its contact patch: A; both count a one-element rim beyond the pressed region and
fall at first order as the mesh refines), ``contact_area_nodal`` and ``contact_area_nodal.<body>``
(m^2: the loaded nodes' tributary areas, summed: a rim element counts a third per loaded
vertex, :func:`loaded_area`), ``compliance_solves``, ``contact_force_probe.<k>``, and the contact
pressure (:func:`nodal_pressure`: the compressive normal part of each surface node's recorded
contact force over its tributary area): ``contact_pressure_max`` (Pa, the largest nodal
pressure), ``contact_pressure_max_node`` (its global node, -1 when nothing is loaded),
``contact_pressure_max_position`` (m, that node's reference coordinates),
``contact_pressure_mean`` (Pa, the area-weighted mean over the loaded nodes: their normal force
over their tributary area), ``contact_pressure_force_weighted`` (Pa) and
``contact_area_effective`` (m^2, over all the contact surfaces: 2 A for the interface above)
with ``contact_area_effective.<body>`` (m^2, over one body's surface): the mean pressure the
normal force is carried at and the area it is carried on (:func:`force_weighted`; they follow the pressure field smoothly, where the
loaded nodes' area and mean jump as nodes join), ``contact_pressure_sensor`` (Pa: the largest pressure a
flush-mounted sensor of face area ``[contact] sensor_area`` would read, the nodal pressure
averaged over the surface nodes within its radius, :func:`sensor_matrix`; the largest nodal
pressure is one node's and refines with the mesh; this node average has no limit either: its
disc holds 1 to 11 nodes on practical meshes and it sums their whole tributary areas) with its
``contact_pressure_sensor_node`` and ``contact_pressure_sensor_position``, and
``contact_pressure_disc`` (Pa: the largest reading of the same sensor as a measure with a
limit: the P1 interpolant of the nodal pressure integrated over the sensor's exact disc,
centred at each contact-surface node and facing along its normal, over the surface area under
the disc, :func:`vfrs.contact.sensor.surface_sensors`; a linear field reads exactly on any
mesh) with its ``contact_pressure_disc_node``, ``contact_pressure_disc_position`` and
``contact_pressure_disc_nodes`` (the surface nodes inside that disc; a disc holding fewer than
:data:`vfrs.contact.sensor.MIN_NODES` on a surface is warned about when the run starts, a
:class:`~vfrs.errors.ResolutionWarning`). Areas are those of the reference configuration, except on the
surfaces of finite-strain bodies, whose pressure is the true (Cauchy) one: force over the
tributary area at the current positions (a block compressed to 0.7 of its height has 1.23
times its reference contact area).

Besides the history, the recorder keeps the contact state of the step of the largest total
contact force so far (:meth:`ContactRecorder.peak_map`: its time, row, force, nodal pressure
and positions, copied in place when a step exceeds it), which the effect writes into
``contact_peak.npz`` when the run completes (``vfrs plot``'s pressure map).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..signals import force_length  # noqa: F401 (read as record.force_length too)
from ..contact import contact_area, tributary_areas
from ..contact.geometry import node_normals
from ..contact.sensor import surface_sensors
from ..materials import kinematics_of
from .pairs import DetectedPairs
from .quadratic_pressure import QuadraticPressure
from .surfaces import ContactSurfaces


#: The file of an output folder with the contact state at the peak force (:meth:`ContactRecorder.peak_map`).
PEAK_FILE = "contact_peak.npz"


def nodes_with_force(f) -> np.ndarray:
    """The nodes (increasing) where the nodal forces ``f`` (n, 3) have a nonzero component:
    from the few nonzero entries (``f.any(axis=1)`` would read every node row by row)."""
    nodes = np.flatnonzero(f.ravel()) // 3
    if nodes.size:
        first = np.empty(nodes.size, dtype=bool)
        first[0], first[1:] = True, nodes[1:] != nodes[:-1]
        nodes = nodes[first]
    return nodes


def nodal_pressure(force, x, triangles, areas, nodes=None) -> np.ndarray:
    """Contact pressure per node (Pa): the compressive normal component of the node's contact
    force, ``max(0, -f . n)``, over its tributary area ``a`` (a third of each adjacent surface
    triangle, reference configuration: ``ContactSurfaces.areas``); zero off the surfaces.

    ``force``: the recorded contact force (n_dofs,) or (n, 3), N; ``x``: positions (n, 3) for
    the outward normals ``n`` of ``triangles`` (the contact surfaces, global node numbers);
    ``nodes``: :func:`nodes_with_force` of ``force``, when the caller has it already. For P1 elements the nodal pressures of a uniform pressure are not exactly uniform (the
    nodal forces follow the mesh's load distribution); their area-weighted mean is exact.

    >>> import numpy as np
    >>> x = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    >>> tri = np.array([[0, 2, 1], [1, 2, 3]])          # facing -z (the bottom of a body)
    >>> f = np.tile([0.0, 0.0, 0.25], (4, 1))          # 1 N pushing up, spread evenly
    >>> nodal_pressure(f, x, tri, np.array([1, 2, 2, 1]) / 6).round(3).tolist()
    [1.5, 0.75, 0.75, 1.5]
    """
    f = np.asarray(force, dtype=float).reshape(-1, 3)
    areas = np.asarray(areas, dtype=float)
    out = np.zeros(len(f))
    if nodes is None:
        nodes = nodes_with_force(f)
    loaded = nodes[areas[nodes] > 0]
    if not loaded.size:
        return out
    # Normals at the loaded nodes only: from the triangles that touch one (all of a loaded
    # node's triangles are among them, so its normal is the same as from the whole surface).
    tri = np.asarray(triangles, dtype=np.int64).reshape(-1, 3)
    mark = np.zeros(len(f), dtype=bool)
    mark[loaded] = True
    n = node_normals(x, tri[mark[tri].any(axis=1)], len(f), nodes=loaded)
    fn = np.maximum(-np.einsum("ij,ij->i", f[loaded], n), 0.0)
    out[loaded] = fn / areas[loaded]
    return out


def sensor_matrix(points, triangles, areas, sensor_area: float):
    """The averaging of a nodal pressure over a sensor's face: a sparse matrix S (n x n, rows
    of the surfaces' nodes) with ``(S p)_i`` the area-weighted mean of ``p`` over the nodes of
    the same surface within the radius ``sqrt(sensor_area / pi)`` of node i (reference
    positions ``points``, tributary ``areas``): the pressure a flush-mounted sensor of face
    area ``sensor_area`` centred at node i would read. Surfaces are those of ``triangles``
    (each (k, 3) array one body's surface, global node numbers)."""
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=float)
    n = len(points)
    r = float(np.sqrt(sensor_area / np.pi))
    rows, cols, vals = [], [], []
    for tri in triangles:
        nodes = np.unique(np.asarray(tri, dtype=np.int64))
        if not nodes.size:
            continue
        pairs = cKDTree(points[nodes]).query_pairs(r, output_type="ndarray")  # i < j, each once
        i = np.concatenate([pairs[:, 0], pairs[:, 1], np.arange(nodes.size)])
        j = np.concatenate([pairs[:, 1], pairs[:, 0], np.arange(nodes.size)])
        w = areas[nodes[j]]
        total = np.bincount(i, w, minlength=nodes.size)
        keep = total[i] > 0
        rows.append(nodes[i[keep]])
        cols.append(nodes[j[keep]])
        vals.append(w[keep] / total[i[keep]])
    if not rows:
        return sp.csr_matrix((n, n))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))


def loaded_area(areas, surface_nodes, loaded_nodes) -> float:
    """The summed tributary ``areas`` of the ``loaded_nodes`` among ``surface_nodes`` (both
    increasing): the area of the contact patch with each rim element (loaded and unloaded
    vertices) counted a third per loaded vertex, where the triangles with any loaded vertex
    (``contact_area``) count it whole. Under a clamped Hertzian field it converges faster than
    that rim area (tests/test_sensor.py: -3.8 and -1.0 % on 32 and 64 cells against +9.4 and
    +5.9 %), from below; on the coarsest meshes it is as far off as the rim, on the other side.

    >>> loaded_area(np.array([1.0, 2.0, 3.0, 4.0]), np.array([0, 1, 2]), np.array([1, 2, 3]))
    5.0
    """
    mine = loaded_nodes[np.isin(loaded_nodes, surface_nodes, assume_unique=True)]
    return float(np.asarray(areas)[mine].sum())


def warn_sparse_sensors(sensors, sensor_area: float) -> None:
    """A :class:`~vfrs.errors.ResolutionWarning` for each surface whose sensor discs
    (:func:`vfrs.contact.sensor.surface_sensors`) hold fewer than ``MIN_NODES`` surface nodes
    (median over the discs centred at its nodes)."""
    import warnings

    from ..contact.sensor import MIN_NODES
    from ..errors import ResolutionWarning

    for name, median in sensors.sparse().items():
        warnings.warn(f"[contact] sensor_area = {sensor_area:g} m^2: a sensor disc on the contact surface of body "
                      f"{name!r} holds {median:g} surface nodes (median; fewer than {MIN_NODES}), so its reading "
                      "(contact_pressure_disc) is resolved by few elements: refine the mesh there (a higher `level` "
                      "of the m5 family) or compare a larger sensor_area", ResolutionWarning, stacklevel=4)


def force_weighted(pressure, areas) -> tuple:
    """(force-weighted mean pressure, effective area) of a nodal pressure field:
    p_F = sum p^2 a / sum p a (the mean pressure the force is carried at) and
    A_F = (sum p a)^2 / sum p^2 a (the area it is carried on; p_F A_F = sum p a, the normal
    force). Both equal the patch's pressure and area under a uniform pressure (for a Hertz
    distribution A_F = 8/9 of the contact area), and unlike the area of the loaded nodes and
    the mean over them they do not jump when a node with almost no pressure joins the contact:
    they follow the pressure field smoothly. (0, 0) when nothing is loaded.

    >>> force_weighted(np.array([2.0, 2.0, 0.0]), np.array([1.0, 3.0, 5.0]))
    (2.0, 4.0)
    """
    pa = pressure * areas
    f, f2 = float(pa.sum()), float((pa * pressure).sum())
    return (f2 / f, f * f / f2) if f2 > 0 else (0.0, 0.0)


def pressure_summary(pressure, areas, points) -> tuple:
    """(max, node, reference position, area-weighted mean over the loaded nodes) of a nodal
    pressure field; (0, -1, NaN x 3, 0) when no node is loaded."""
    loaded = pressure > 0
    if not loaded.any():
        return 0.0, -1, np.full(3, np.nan), 0.0
    k = int(np.argmax(pressure))
    mean = float(np.sum(pressure[loaded] * areas[loaded]) / np.sum(areas[loaded]))
    return float(pressure[k]), k, np.asarray(points[k], dtype=float).copy(), mean


@dataclass
class ContactStep:
    """The outcome of one step's contact correction."""

    found: DetectedPairs  # the last round's pairs
    lam: np.ndarray
    info: Any  # SolveInfo of the last round, or None
    detections: int
    settled: bool
    converged: bool
    G: Any = None  # the last round's constraint matrix, if it built one


class ContactRecorder:
    """Appends the contact diagnostics of a step to the history."""

    def __init__(self, problem, surfaces: ContactSurfaces, detectors, probe_nodes, sensor_area: float = 1e-6):
        self.problem, self.surfaces, self.detectors = problem, surfaces, detectors
        self.triangles = np.concatenate(list(surfaces.surface_of.values()))
        self._surface_nodes = {name: np.unique(tri) for name, tri in surfaces.surface_of.items()}
        self.sensor_area = float(sensor_area)
        self.sensor = sensor_matrix(problem.points, list(surfaces.surface_of.values()), surfaces.areas, sensor_area)
        self.discs = surface_sensors(problem.points, surfaces.surface_of, sensor_area)
        warn_sparse_sensors(self.discs, sensor_area)
        self.probe_nodes = probe_nodes
        # The surfaces of finite-strain bodies and their nodes: their pressure is over the current area.
        finite = [surfaces.surface_of[b.name] for b in problem.bodies if kinematics_of(b.config.material) == "finite"]
        self._deformed = np.concatenate(finite) if finite else None
        self._deformed_nodes = None if self._deformed is None else np.unique(self._deformed)
        # quadratic bodies: their nodal forces projected onto the six-node faces' pressure field
        self.quadratic = QuadraticPressure(problem, surfaces.surface_of)
        self._work_state: tuple | None = None
        self._contact_work = 0.0
        # The step of the largest total contact force so far (see :meth:`peak_map`): its
        # force, time, history row, nodal pressure and positions, copied in place when a
        # step exceeds it (no allocation on other steps).
        self._peak_force = 0.0
        self._peak_t = 0.0
        self._peak_row = -1
        self._peak_body = ""
        self._peak_pressure = np.zeros(problem.n_points)
        self._peak_positions = np.zeros((problem.n_points, 3))

    def state(self) -> dict:
        """The running contact work, the last step's positions and force, and the peak map so
        far (for a checkpoint; arrays, numbers and strings only)."""
        ws = self._work_state
        return {"work_state": None if ws is None else (ws[0].copy(), ws[1].copy()), "contact_work": self._contact_work,
                "peak_force": self._peak_force, "peak_t": self._peak_t, "peak_row": self._peak_row,
                "peak_body": self._peak_body, "peak_pressure": self._peak_pressure.copy(),
                "peak_positions": self._peak_positions.copy()}

    def restore(self, state: dict) -> None:
        ws = state["work_state"]
        self._work_state = None if ws is None else (ws[0].copy(), ws[1].copy(), bool(ws[1].any()))
        self._contact_work = state["contact_work"]
        if "peak_row" in state:  # (a checkpoint written before the peak map was kept has none)
            self._peak_force = float(state["peak_force"])
            self._peak_t = float(state["peak_t"])
            self._peak_row = int(state["peak_row"])
            self._peak_body = str(state["peak_body"])
            np.copyto(self._peak_pressure, state["peak_pressure"])
            np.copyto(self._peak_positions, state["peak_positions"])

    def peak_map(self) -> dict | None:
        """The contact state at the step of the largest total contact force (the largest
        :func:`force_length` of a body's ``contact_force`` over the bodies and the steps; the
        first such step), recorded when it happened: ``t`` (s), ``row`` (its history row),
        ``force`` (N, that length), ``body`` (whose), ``pressure`` (Pa, per node, as
        :func:`nodal_pressure`; its largest value is the row's ``contact_pressure_max``) and
        ``positions`` (m, (n, 3), all nodes at that instant). None when no force was ever
        recorded. What ``contact_peak.npz`` holds (:data:`PEAK_FILE`)."""
        if self._peak_row < 0:
            return None
        return {"t": np.float64(self._peak_t), "row": np.int64(self._peak_row), "force": np.float64(self._peak_force),
                "body": np.array(self._peak_body), "pressure": self._peak_pressure.copy(),
                "positions": self._peak_positions.copy()}

    def record(self, h: dict, outcome: ContactStep, force: np.ndarray, solves: int, balance=None,
               extra_work: float = 0.0) -> None:
        """Appends the step's diagnostics. ``force``: the recorded contact force (impulse / h);
        ``balance``: the contact force in the step's balance at t_{n+1} (default ``force``),
        whose trapezoidal work with the last step's is the contact work; ``extra_work``: the
        energy the scheme's own changes of the step added (the stabilized predictor's
        projection; with HHT alpha = 0 the sum is exactly the energy contact gave the bodies).
        The parts below append the keys in this order (the history's key order)."""
        found, info = outcome.found, outcome.info
        x = found.x
        gap = self._gaps(outcome)
        self._record_counts(h, outcome)
        loaded = bool(force.any())
        self._record_work(h, x, force if balance is None else balance, extra_work)
        h.setdefault("max_penetration", []).append(float(np.maximum(-gap, 0.0).max()) if len(gap) else 0.0)
        self._record_volume(h, outcome, gap)
        h.setdefault("condition", []).append(info.condition if info else 1.0)
        f = force.reshape(-1, 3)
        peak_body = self._record_body_forces(h, f, loaded)
        # The nodes with a force, for the area and the pressure (none: nothing to read)
        loaded_nodes = nodes_with_force(f) if loaded else np.zeros(0, dtype=np.int64)
        self._record_areas(h, x, loaded_nodes)
        # Cumulative right-hand sides solved for the compliance columns (the reduced space's
        # cost: one solve per contact DOF the first time a pair touches it).
        h.setdefault("compliance_solves", []).append(solves)
        for i, n in enumerate(self.probe_nodes):
            h.setdefault(f"contact_force_probe.{i}", []).append(f[n].copy())
        self._record_pressure(h, f, x, loaded, loaded_nodes, peak_body)

    def _gaps(self, outcome: ContactStep) -> np.ndarray:
        """Gaps at the final positions, with the pairs' frozen geometry."""
        found = outcome.found
        if not len(found):
            return np.zeros(0)
        G = outcome.G if outcome.G is not None else found.constraint(self.problem.n_points)
        return G @ found.x.ravel() - found.offset

    @staticmethod
    def _record_counts(h: dict, outcome: ContactStep) -> None:
        """The pair counts and the solver's and the detection loop's counters of the step."""
        found, lam, info = outcome.found, outcome.lam, outcome.info
        h.setdefault("contact_pairs", []).append(len(found))
        h.setdefault("active_pairs", []).append(int((lam > 0).sum()))
        h.setdefault("iterations", []).append(info.iterations if info else 0)
        h.setdefault("augmentations", []).append(info.augmentations if info else 0)
        h.setdefault("detections", []).append(outcome.detections)
        h.setdefault("contact_settled", []).append(int(outcome.settled))
        h.setdefault("contact_converged", []).append(int(outcome.converged))

    def _record_work(self, h: dict, x: np.ndarray, fb: np.ndarray, extra_work: float) -> None:
        """Work of the contact forces ``fb`` in the balance on the bodies (trapezoidal in time,
        the rule HHT-alpha with alpha = 0 applies), plus what the scheme's own changes added:
        lets an energy balance separate contact from the loads and the damping."""
        loaded_b = bool(fb.any())
        if self._work_state is not None:
            x_old, f_old, loaded_old = self._work_state
            if loaded_b or loaded_old:  # else every term is a zero and the sum adds nothing
                self._contact_work += 0.5 * float(np.sum((f_old + fb) * (x.ravel() - x_old)))
        self._contact_work += extra_work
        self._work_state = (x.ravel().copy(), fb.copy(), loaded_b)
        h.setdefault("contact_work", []).append(self._contact_work)

    def _record_volume(self, h: dict, outcome: ContactStep, gap: np.ndarray) -> None:
        """The intersection volume of the step's pairs, summed over the detectors."""
        found = outcome.found
        volume = 0.0
        if len(found) or outcome.detections > 1:
            for i, d in enumerate(self.detectors):
                mine = found.source == i
                volume += d.intersection_volume(found.x, found.select(mine), gap[mine])
        # else: the first detection round found nothing at these positions (no overlap)
        h.setdefault("intersection_volume", []).append(volume)

    def _record_body_forces(self, h: dict, f: np.ndarray, loaded: bool) -> str | None:
        """Each body's total contact force; returns the body whose force is a new largest
        (updating the largest so far), if any."""
        peak_body = None
        for part in self.problem.bodies:
            fb_body = f[part.nodes].sum(axis=0) if loaded else np.zeros(3)
            h.setdefault(f"contact_force.{part.name}", []).append(fb_body)
            if loaded:
                a, b, c = fb_body.tolist()
                length = math.sqrt(a * a + b * b + c * c)  # force_length's operations, on floats
                if length > self._peak_force:
                    self._peak_force, peak_body = length, part.name
        return peak_body

    def _record_areas(self, h: dict, x: np.ndarray, loaded_nodes: np.ndarray) -> None:
        """Each body's contact patch and their sum over the surfaces (the paper's)."""
        area = nodal = 0.0
        for name, tri in self.surfaces.surface_of.items():
            mine = contact_area(x, tri, loaded_nodes) if loaded_nodes.size else 0.0
            h.setdefault(f"contact_area.{name}", []).append(mine)  # this body's contact patch
            area += mine
        h.setdefault("contact_area", []).append(area)  # summed over the surfaces: the paper's
        for name, nodes in self._surface_nodes.items():
            mine = loaded_area(self.surfaces.areas, nodes, loaded_nodes) if loaded_nodes.size else 0.0
            h.setdefault(f"contact_area_nodal.{name}", []).append(mine)
            nodal += mine
        h.setdefault("contact_area_nodal", []).append(nodal)

    def _record_pressure(self, h: dict, f: np.ndarray, x: np.ndarray, loaded: bool, loaded_nodes: np.ndarray,
                         peak_body: str | None) -> None:
        """The contact pressure's measures of the step (and the peak map, when ``peak_body``
        has a new largest force)."""
        p = self.problem
        if loaded:
            areas = self.surfaces.areas
            if self._deformed is not None:
                current = tributary_areas(x, self._deformed)
                nodes = self._deformed_nodes
                areas = areas.copy()
                areas[nodes] = current[nodes]
            pressure = nodal_pressure(f, x, self.triangles, areas, nodes=loaded_nodes)
            if self.quadratic:
                pressure = self.quadratic.apply(pressure, areas)
            p_max, node, where, p_mean = pressure_summary(pressure, areas, p.points)
            sensed = self.sensor @ pressure
            s_node = int(np.argmax(sensed))
            s_max, s_where = float(sensed[s_node]), p.points[s_node].copy()
            p_force, a_force = force_weighted(pressure, areas)
            self._record_disc(h, pressure)
            a_body = [force_weighted(pressure[n], areas[n])[1] for n in self._surface_nodes.values()]
            if peak_body is not None:  # the largest force so far: keep this step's map
                self._peak_t, self._peak_row, self._peak_body = float(h["t"][-1]), len(h["t"]) - 1, peak_body
                np.copyto(self._peak_pressure, pressure)
                np.copyto(self._peak_positions, x.reshape(-1, 3))
        else:  # no node loaded: what pressure_summary gives for a zero pressure field
            p_max, node, where, p_mean = 0.0, -1, np.full(3, np.nan), 0.0
            s_max, s_node, s_where = 0.0, -1, np.full(3, np.nan)
            p_force, a_force = 0.0, 0.0
            a_body = [0.0] * len(self._surface_nodes)
            self._record_disc(h, None)
        h.setdefault("contact_pressure_max", []).append(p_max)
        h.setdefault("contact_pressure_max_node", []).append(node)
        h.setdefault("contact_pressure_max_position", []).append(where)
        h.setdefault("contact_pressure_mean", []).append(p_mean)
        h.setdefault("contact_pressure_force_weighted", []).append(p_force)
        h.setdefault("contact_area_effective", []).append(a_force)
        for name, a in zip(self._surface_nodes, a_body):
            h.setdefault(f"contact_area_effective.{name}", []).append(a)
        h.setdefault("contact_pressure_sensor", []).append(s_max)
        h.setdefault("contact_pressure_sensor_node", []).append(s_node if s_max > 0 else -1)
        h.setdefault("contact_pressure_sensor_position", []).append(s_where if s_max > 0 else np.full(3, np.nan))

    def _record_disc(self, h: dict, pressure) -> None:
        """The largest exact-disc sensor reading of the nodal ``pressure`` (None: nothing
        loaded), with its node, position and the surface nodes inside its disc."""
        d = self.discs
        k, value = -1, 0.0
        if pressure is not None and len(d.nodes):
            read = d.S @ pressure
            k = int(np.argmax(read))
            value = float(read[k])
        if k >= 0 and value > 0:
            node = int(d.nodes[k])
            where, inside = self.problem.points[node].copy(), int(d.inside[k])
        else:
            node, value, where, inside = -1, 0.0, np.full(3, np.nan), 0
        h.setdefault("contact_pressure_disc", []).append(value)
        h.setdefault("contact_pressure_disc_node", []).append(node)
        h.setdefault("contact_pressure_disc_position", []).append(where)
        h.setdefault("contact_pressure_disc_nodes", []).append(inside)
