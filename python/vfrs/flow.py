"""Quasi-steady Bernoulli glottal flow between two folds.

The glottal area A(y) at a station y (flow direction) is the integral along z of the gap
between the right fold's and the left fold's medial surfaces in the current configuration,
with no symmetry assumed. Upstream of flow separation the pressure follows Bernoulli with
the subglottal pressure Ps at rest upstream and zero (supraglottal) pressure at separation:

    p(y) = Ps (1 - (A_sep / A(y))^2),   y <= y_sep;      p = 0 above.

Separation is at the minimum area (``separation_ratio`` = 1), or at the first station
downstream of the minimum where A reaches ``separation_ratio`` x A_min. With the glottis
closed at some station (A = 0), p = Ps below the lowest closure and 0 above it. The
pressure acts as the traction -p n on the medial surfaces and is turned into consistent
nodal forces (exact for pressure linear over a triangle).

With an ``[acoustics]`` section coupled two ways, the vocal tract (:mod:`vfrs.acoustics`) gives
the pressures below and above the glottis in the same step, which replace Ps and 0 above:
p = p_sup + (p_sub - p_sup) (1 - (A_sep / A)^2) upstream of separation, p_sup downstream (the
tract connected to the :class:`GlottisPort` this effect offers in the setup context); without it, or with
``coupling = "none"``, the flow is computed exactly as without a tract.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from . import _core
from .signals import (cycle_amplitudes, cycle_peaks, fundamental_frequency, max_flow_declination_rate, open_quotients,
                      peak, window)
from .summary import Quantity
from .errors import VfrsError


@dataclass
class FlowState:
    """What the flow model computed for one configuration."""

    y: np.ndarray  # stations (m)
    area: np.ndarray  # glottal area A(y) (m^2)
    pressure: np.ndarray  # p(y) (Pa)
    min_area: float
    y_separation: float
    closed: bool
    min_gap: float  # smallest x_right - x_left over the (y, z) samples; < 0: the folds overlap
    drop: float | None = None  # p_sub - p_sup from a coupled vocal tract (Pa); None: the flow alone


def bernoulli_pressure(y, area, subglottal_pressure, separation_ratio=1.0, closed_area=0.0):
    """Pressure at the stations ``y`` (increasing) for glottal areas ``area``.

    >>> import numpy as np
    >>> y = np.linspace(0, 1, 5); A = np.array([4.0, 3.0, 2.0, 1.0, 2.0])
    >>> bernoulli_pressure(y, A, 800.0)[0].round(1).tolist()
    [750.0, 711.1, 600.0, 0.0, 0.0]
    """
    y = np.asarray(y, dtype=float)
    area = np.asarray(area, dtype=float)
    p = np.zeros_like(area)
    shut = np.flatnonzero(area <= closed_area)
    if shut.size:
        below = y < y[shut[0]]
        p[below] = subglottal_pressure
        return p, y[shut[0]], True
    i_min = int(np.argmin(area))
    a_min = area[i_min]
    i_sep = i_min
    if separation_ratio > 1.0:
        after = np.flatnonzero(area[i_min:] >= separation_ratio * a_min)
        i_sep = i_min + int(after[0]) if after.size else len(area) - 1
    a_sep = area[i_sep]
    up = np.arange(len(area)) <= i_sep
    p[up] = subglottal_pressure * (1.0 - (a_sep / area[up]) ** 2)
    return p, y[i_sep], False


def _linear_weights(z, zc):
    """Matrix L (len(z) x len(zc)) with L @ f(zc) = np.interp(z, zc, f(zc))."""
    order = np.argsort(zc)
    L = np.zeros((len(z), len(zc)))
    for j in range(len(zc)):
        e = np.zeros(len(zc))
        e[order[j]] = 1.0
        L[:, order[j]] = np.interp(z, zc[order], e[order])
    return L


def _two_point(L) -> tuple:
    """The entries of an interpolation matrix ``L`` with at most two per row, as (first
    column, its weight, second column, its weight) per row (a row with one entry: the same
    column twice, the second weight 0)."""
    L = np.asarray(L, dtype=float)
    if len(L) and np.count_nonzero(L, axis=1).max() > 2:
        raise ValueError("interpolation weights with more than two entries in a row")
    rows = np.arange(len(L))
    j0 = np.argmax(L != 0, axis=1)
    rest = L.copy()
    rest[rows, j0] = 0.0
    j1 = np.where(rest.any(axis=1), np.argmax(rest != 0, axis=1), j0)
    return j0, L[rows, j0], j1, rest[rows, j1]


def _apply_weights(xs, two_point) -> np.ndarray:
    """``xs @ L.T`` for ``two_point = _two_point(L)``, as elementwise numpy operations over
    L's entries in column order: the same bits on every CPU (a BLAS product picks its kernel,
    and with it fused multiply-adds, by CPU)."""
    j0, w0, j1, w1 = two_point
    out = xs[:, j0] * w0
    out += xs[:, j1] * w1
    return out


def consistent_pressure_forces(points, triangles, p_nodes):
    """Nodal forces (n, 3) of the traction -p n on triangles (outward normals), with p
    linear over each triangle given by its vertex values: f_a = -(2 p_a + p_b + p_c) N / 24,
    N = (x2 - x1) x (x3 - x1) = 2 area n."""
    x = points[triangles]
    N = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    pt = p_nodes[triangles]
    s = pt.sum(axis=1)
    n = len(points)
    f = np.zeros((n, 3))
    for a in range(3):
        w = -(pt[:, a] + s) / 24.0
        for c in range(3):  # bincount sums duplicates like np.add.at, several times faster
            f[:, c] += np.bincount(triangles[:, a], weights=w * N[:, c], minlength=n)
    return f


@dataclass
class MedialSurface:
    """One fold's wetted surface as the flow model slices it: ``tri`` (triangles), ``nodes``,
    ``grid`` (the medial nodes as an (s, z) grid, or None), ``sign`` (+1 right, -1 left) and
    ``z_weights`` (linear interpolation from the grid's columns to the z samples)."""

    tri: np.ndarray
    nodes: np.ndarray
    grid: np.ndarray | None
    sign: float
    z_weights: np.ndarray | None = None
    z_columns: tuple | None = None  # z_weights' entries (vfrs.flow._two_point)
    _load: Any = field(default=None, repr=False, compare=False)  # Rust pressure load of ``tri`` (made on first use)

    def pressure_forces(self, points, p_nodes) -> np.ndarray:
        """:func:`consistent_pressure_forces` on ``tri`` (bit for bit), in Rust, the triangles
        around each node listed once."""
        if self._load is None or self._load[1] != len(points):
            self._load = (_core.fem.PressureLoad(np.ascontiguousarray(self.tri, dtype=np.int64), len(points)), len(points))
        out = np.empty((len(points), 3))
        self._load[0].forces(np.ascontiguousarray(points, dtype=np.float64),
                             np.ascontiguousarray(p_nodes, dtype=np.float64), out)
        return out


class BernoulliFlow:
    """Bernoulli glottal flow between a right fold (x > 0) and a left fold (x < 0).

    ``right``, ``left``: meshes with a ``medial`` surface. Built-in M5 folds carry a
    ``medial_grid`` (medial nodes as an (s, z) grid) that makes slicing cheap; other meshes
    are sliced by linear interpolation over their medial nodes' (y, z) positions.
    ``n_stations`` stations in y span the overlap of both medial surfaces; ``n_z`` samples
    along z integrate the gap.
    """

    def __init__(self, right, left, subglottal_pressure, separation_ratio=1.0, n_stations=120, n_z=None):
        if not np.isfinite(subglottal_pressure) or subglottal_pressure < 0:
            raise VfrsError(f"subglottal_pressure = {subglottal_pressure} Pa must be finite and >= 0")
        if separation_ratio < 1.0:
            raise VfrsError(f"separation_ratio = {separation_ratio} must be >= 1 (1: separation at the minimum area)")
        self.ps = float(subglottal_pressure)
        self.separation_ratio = float(separation_ratio)
        self.folds = []
        for mesh, sign in ((right, 1.0), (left, -1.0)):
            tri = mesh.surface("medial")
            nodes = np.unique(tri)
            grid = getattr(mesh, "medial_grid", None)
            self.folds.append(MedialSurface(tri, nodes, grid, sign))
        ys = [right.points[np.unique(right.surface("medial")), 1], left.points[np.unique(left.surface("medial")), 1]]
        zs = [right.points[np.unique(right.surface("medial")), 2], left.points[np.unique(left.surface("medial")), 2]]
        y_lo, y_hi = max(y.min() for y in ys), min(y.max() for y in ys)
        z_lo, z_hi = max(z.min() for z in zs), min(z.max() for z in zs)
        if not (y_hi > y_lo and z_hi > z_lo):
            raise VfrsError("the two medial surfaces do not face each other (no common y-z range)")
        self.y = np.linspace(y_lo, y_hi, int(n_stations))
        if n_z is None:
            grid = self.folds[0].grid
            n_z = grid.shape[1] if grid is not None else 16
        self.z = np.linspace(z_lo, z_hi, int(n_z))
        for fold, mesh in zip(self.folds, (right, left)):
            if fold.grid is not None:
                zc = mesh.points[fold.grid, 2].mean(axis=0)
                fold.z_weights = _linear_weights(self.z, zc)
                fold.z_columns = _two_point(fold.z_weights)

    def _medial_x(self, fold, x):
        """x of the fold's medial surface on the (y stations, z samples) grid."""
        grid = fold.grid
        if grid is not None:
            cols = x[grid]  # (ns + 1, nz + 1, 3): y increases along s
            xs = np.empty((len(self.y), cols.shape[1]))
            for k in range(cols.shape[1]):
                xs[:, k] = np.interp(self.y, cols[:, k, 1], cols[:, k, 0])
            # Along z, linear interpolation between the grid's columns at their rest
            # positions (the flow is one-dimensional in y; z motion is second order).
            return _apply_weights(xs, fold.z_columns)
        from scipy.interpolate import LinearNDInterpolator

        p = x[fold.nodes]
        f = LinearNDInterpolator(p[:, 1:3], p[:, 0])
        Y, Z = np.meshgrid(self.y, self.z, indexing="ij")
        v = f(Y, Z)
        # Outside the hull (rare, at the corners): nearest row value.
        if np.isnan(v).any():
            v = np.where(np.isnan(v), np.nanmean(v, axis=1, keepdims=True), v)
        return v

    def state(self, x_right, x_left, tract=None) -> FlowState:
        """Area and pressure along y for current node positions (n, 3) of each fold.

        ``tract``: called with the area at separation (m^2, 0 closed), returns the pressures
        (p_sub, p_sup) below and above the glottis of a coupled vocal tract (the [acoustics]
        effect), which replace Ps and 0: p = p_sup + (p_sub - p_sup) (1 - (A_sep / A)^2)
        upstream of separation, p_sup above; or None (the flow alone)."""
        xr = self._medial_x(self.folds[0], x_right)
        xl = self._medial_x(self.folds[1], x_left)
        width = xr - xl
        gap = np.maximum(width, 0.0)
        trapezoid = getattr(np, "trapezoid", None) or getattr(np, "trapz")  # numpy 2 renamed it
        area = trapezoid(gap, self.z, axis=1)
        p, y_sep, closed = bernoulli_pressure(self.y, area, self.ps, self.separation_ratio)
        drop = None
        if tract is not None:
            pressures = tract(0.0 if closed else float(np.interp(y_sep, self.y, area)))
            if pressures is not None:
                p_sub, p_sup = pressures
                drop = p_sub - p_sup
                p = p_sup + bernoulli_pressure(self.y, area, drop, self.separation_ratio)[0]
        return FlowState(self.y, area, p, float(area.min()), float(y_sep), closed, float(width.min()), drop)

    def compacted(self) -> tuple:
        """(a copy of this model that takes the positions of the wetted nodes only, and per
        fold the indices of those nodes among the fold's). The copy's :meth:`forces` gives the
        forces at those nodes (the others get none): the same numbers as this model's at
        them, without the work over the folds' other nodes."""
        import copy

        out = copy.copy(self)
        out.folds, kept = [], []
        for fold in self.folds:
            nodes = fold.nodes if fold.grid is None else np.union1d(fold.nodes, fold.grid.ravel())
            where = np.searchsorted(nodes, fold.nodes)
            out.folds.append(MedialSurface(np.searchsorted(nodes, fold.tri), where,
                                           None if fold.grid is None else np.searchsorted(nodes, fold.grid),
                                           fold.sign, fold.z_weights, fold.z_columns))
            kept.append(nodes)
        return out, kept

    def forces(self, x_right, x_left, tract=None):
        """Consistent nodal forces (n, 3) on each fold, and the :class:`FlowState` (``tract``:
        see :meth:`state`)."""
        st = self.state(x_right, x_left, tract)
        out = []
        for fold, x in zip(self.folds, (x_right, x_left)):
            p_nodes = np.zeros(len(x))
            p_nodes[fold.nodes] = np.interp(x[fold.nodes, 1], st.y, st.pressure)
            out.append(fold.pressure_forces(x, p_nodes))
        return out[0], out[1], st


# -- the [flow] effect -------------------------------------------------------------------------

from .effects import Effect, register_effect  # noqa: E402
from .params import param  # noqa: E402

#: kg/m^3: the default of ``[flow] density``, the air's (the reported flow rate's, and a coupled
#: vocal tract's).
AIR_DENSITY = 1.2


@dataclass
class GlottisPort:
    """The typed link the [flow] effect offers a vocal tract in the setup context
    (:meth:`vfrs.effects.SetupContext.offer`): the air's ``density`` (kg/m^3, ``[flow]
    density``: the glottal jet's and the tract's, one for both) and the tract's ``glottis(t,
    A_sep, P_lung) -> (p_sub, p_sup) or None``, which the tract connects (:meth:`connect`) and
    the flow calls once per step, at its load's time (None: no tract, the flow alone)."""

    density: float = AIR_DENSITY
    tract: Callable[[float, float, float], tuple | None] | None = None

    def connect(self, glottis) -> None:
        """The tract's ``glottis(t, A_sep, P_lung)`` (:meth:`vfrs.acoustics.Acoustics.glottis`)."""
        self.tract = glottis


# -- what the [flow] effect gives the output ------------------------------------------------

def phonation_measures(run) -> dict:
    """Glottal measures of a run with ``[flow]`` (``run``: a :class:`vfrs.summary.RunView`;
    empty dict without a glottal area): ``f0`` (Hz, from the glottal area), ``amplitude`` (m,
    half the peak-to-peak medio-lateral displacement of the first probe per glottal cycle,
    mean; Results with probes only), ``open_quotient`` and ``closed_quotient``,
    ``max_glottal_area`` and ``min_glottal_area`` (m^2), ``peak_flow`` (m^3/s), ``mfdr``
    (m^3/s^2, maximum flow declination rate); over the window from ``run.window_start``
    (default: the second half of the run), the extremes over its whole cycles
    (:func:`_extremes`). Means over cycles carry each cycle's value (``per_cycle``; for ``f0``
    each cycle's 1 / length). See :mod:`vfrs.summary` for the conventions."""
    h, probe, hysteresis, open_level = run.history, run.probe, run.hysteresis, run.open_level
    if "glottal_area" not in h:
        return {}
    start = run.window_start
    t, area, q = np.asarray(h["t"]), np.asarray(h["glottal_area"]), np.asarray(h["flow_rate"])
    out: dict[str, Quantity] = {}
    cyc = run.cycles
    f0 = fundamental_frequency(t, area, start, hysteresis=hysteresis)
    out["f0"] = Quantity(f0, "Hz", "fundamental frequency (glottal area)",
                         per_cycle=tuple((1.0 / np.diff(cyc)).tolist()) if len(cyc) >= 2 else None, over="window")
    if probe is not None:
        tp, disp, pos = probe
        amp = cycle_amplitudes(tp, disp[:, 0], start, cycles=cyc)  # per glottal cycle
        out["amplitude"] = Quantity(float(amp.mean()) if amp.size else float("nan"), "m",
                                    "amplitude (medio-lateral, probe 0)", position=tuple(float(c) for c in pos),
                                    per_cycle=tuple(amp.tolist()), over="window")
    out.update(_extremes(t, area, q, start, cyc, open_level))
    return out


def whole_cycles(start, cycles) -> tuple:
    """The part of the window the per-cycle extremes are taken over: from the first to the
    last cycle start (whole cycles) with two or more, else the window (``start``, None)."""
    return (float(cycles[0]), float(cycles[-1])) if len(cycles) >= 2 else (start, None)


def _extremes(t, area, q, start, cycles, open_level: float) -> dict:
    """``open_quotient``, ``closed_quotient``, ``max_glottal_area``, ``min_glottal_area``,
    ``peak_flow`` and ``mfdr`` of :func:`phonation_measures`. The extremes are over the window's
    whole glottal cycles (:func:`whole_cycles`): a value at the window's edge (the last sample,
    a closing cut off mid-way) is no cycle's extreme. Without two cycle starts they are the
    window's, and :meth:`FlowOutputs.notes` says which of them sit at its edge (bounds). The
    open level is min + ``open_level`` of the range of these extremes."""
    a, b = whole_cycles(start, cycles)
    out: dict[str, Quantity] = {}
    tw, aw = window(t, area, a, b)
    if len(aw):
        lo, hi = float(aw.min()), float(aw.max())
        oq = open_quotients(t, area, lo + open_level * (hi - lo), start, cycles=cycles)
        oq_mean = float(oq.mean()) if oq.size else float("nan")
        out["open_quotient"] = Quantity(oq_mean, "1", f"open quotient (area > min + {open_level:g} range)",
                                        per_cycle=tuple(oq.tolist()), over="window")
        out["closed_quotient"] = Quantity(1.0 - oq_mean, "1", "closed quotient (1 - open quotient)",
                                          per_cycle=tuple((1.0 - oq).tolist()), over="window")
        out["max_glottal_area"] = Quantity(hi, "m^2", "maximum glottal area", t=float(tw[int(np.argmax(aw))]),
                                           over="window")
        out["min_glottal_area"] = Quantity(lo, "m^2", "minimum glottal area", t=float(tw[int(np.argmin(aw))]),
                                           over="window")
    q_max, t_q = peak(t, q, a, b)
    out["peak_flow"] = Quantity(q_max, "m^3/s", "peak flow rate", t=t_q, over="window")
    mfdr, t_m = max_flow_declination_rate(t, q, start, within=(a, math.inf if b is None else b))
    out["mfdr"] = Quantity(mfdr, "m^3/s^2", "maximum flow declination rate", t=t_m, over="window")
    return out


EDGE_EXTREMES = ("max_glottal_area", "min_glottal_area", "peak_flow", "mfdr")


def edge_note(run, phonation: dict) -> list:
    """Without two glottal cycle starts the extremes are the window's (:func:`_extremes`); one
    at the window's first or last sample was still growing there: a bound, not the signal's
    extreme, and the note says so (one line, or none)."""
    if len(run.cycles) >= 2:
        return []
    tw, _ = window(run.t, run.history["glottal_area"], run.window_start)
    if not len(tw):
        return []
    at_edge = [phonation[k].what for k in EDGE_EXTREMES
               if k in phonation and phonation[k].t is not None and phonation[k].t in (float(tw[0]), float(tw[-1]))]
    if not at_edge:
        return []
    return [f"fewer than two glottal cycles in the window: {', '.join(at_edge)} sit{'s' if len(at_edge) == 1 else ''} "
            "at its first or last sample, still growing there: a bound (lower for a maximum, upper for a minimum), "
            "not an extreme of the oscillation"]


class FlowOutputs:
    """The [flow] effect's output hooks (:class:`vfrs.effects.Effect`): the ``phonation``
    section of the summary, the glottal area as the cycle signal, each glottal cycle's period
    and peak area for the periodicity test, the note on cycles that do not repeat, and the
    names of its section known before a run."""

    cycle_signal: str | None = "glottal_area"

    @classmethod
    def measures(cls, run) -> dict:
        ph = phonation_measures(run)
        return {"phonation": ph} if ph else {}

    @classmethod
    def cycle_values(cls, run) -> dict:
        """``period`` (s) and ``peak_area`` (m^2, the largest glottal area) of each glottal
        cycle of the window."""
        if "glottal_area" not in run.history:
            return {}
        cyc = run.cycles
        return {"period": ("period", np.diff(cyc)),
                "peak_area": ("peak glottal area", cycle_peaks(run.t, run.history["glottal_area"], cyc))}

    @classmethod
    def notes(cls, run, sections) -> list:
        """A window whose glottal cycles do not repeat (the periodicity test,
        :meth:`vfrs.summary.RunView.periodicity`, fails: fewer cycles than it compares, or
        they spread by more than its tolerance); extremes at the window's edge (:func:`edge_note`)."""
        if "phonation" not in sections or "glottal_area" not in run.history:
            return []
        notes = edge_note(run, sections["phonation"])
        lengths = np.diff(run.cycles)
        test = run.periodicity()
        if len(lengths) and test is not None and not test.periodic:
            few = test.tested < test.needed and test.within  # too few to tell, none yet seen to differ
            notes.insert(0, f"the {len(lengths)} glottal cycle{'s' if len(lengths) != 1 else ''} in the window last "
                         f"{lengths.min() * 1e3:.2f}-{lengths.max() * 1e3:.2f} ms: the oscillation "
                         + (f"is not shown to repeat ({test.needed} cycles needed)" if few else "does not repeat")
                         + ", so f0, the per-cycle means and the contact peaks follow this run's trajectory, which "
                         "the mesh changes (the step hardly: docs/convergence.md)")
        return notes

    @classmethod
    def summary_names(cls, scene) -> dict:
        """The names :func:`phonation_measures` gives (``amplitude`` with an ``[output]`` probe)."""
        return {"phonation": ["f0", *(["amplitude"] if scene.output.probes else []), "open_quotient",
                              "closed_quotient", "max_glottal_area", "min_glottal_area", "peak_flow", "mfdr"]}


@register_effect
class GlottalFlow(FlowOutputs, Effect):
    """The ``[flow]`` section: Bernoulli pressure on the medial surfaces of two folds.

    Keys: see :class:`GlottalFlow.Params`. Coupling is explicit: the pressure at the end of a
    step comes from the configuration at its start. History: ``glottal_area`` (minimum area,
    m^2), ``flow_rate`` (m^3/s, with the air's ``density``), ``glottis_closed`` (0/1),
    ``min_gap`` (m: the smallest distance between the medial surfaces across the mid-plane;
    negative when they overlap, i.e. the folds have crossed, which without contact
    enforcement is how collision shows).
    """

    name = "flow"
    # Checkpoints: nothing carries over from one step to the next (the pressure of a step
    # comes from the configuration at its start), so the default state() / restore() hold.

    @dataclass(frozen=True)
    class Params:
        subglottal_pressure: float = param(doc="subglottal pressure", unit="Pa", nonnegative=True)
        model: str = param("bernoulli", doc="flow model", choices=("bernoulli",))
        separation_ratio: float = param(1.0, doc="separation where A reaches this x A_min (1: at the minimum)",
                                        low=1.0, high=10.0)
        surface: str = param("medial", doc="the wetted surface of both folds")
        ramp: float = param(0.0, doc="the pressure rises smoothly over this time", unit="s", nonnegative=True)
        stations: int = param(120, doc="y stations of the 1-D flow", minimum=8)
        bodies: list | None = param(None, doc="[right, left] (default: the two bodies with the surface, right = larger x)")
        density: float = param(AIR_DENSITY, doc="air density (the flow rate's, and a vocal tract's: [acoustics])",
                               unit="kg/m^3", positive=True)

        def __post_init__(self):
            b = self.bodies
            if b is not None and (not isinstance(b, list) or len(b) != 2 or not all(isinstance(x, str) for x in b)):
                raise ValueError(f"bodies: expected two body names [right, left], got {b!r}")

    def setup(self, ctx) -> None:
        from .dynamics.problem import ramp

        problem = ctx.problem
        self._ramp = ramp
        cfg = self.params
        parts = {p.name: p for p in problem.bodies}
        if cfg.bodies is not None:
            missing = [b for b in cfg.bodies if b not in parts]
            if missing:
                raise VfrsError(f"[flow] bodies: no body named {missing[0]!r}; bodies are {sorted(parts)}")
            right, left = (parts[b] for b in cfg.bodies)
        else:
            with_surface = [p for p in problem.bodies if cfg.surface in p.mesh.surfaces]
            if len(with_surface) != 2:
                raise VfrsError(
                    f"[flow] needs exactly two bodies with a {cfg.surface!r} surface, found "
                    f"{[p.name for p in with_surface]}; name them with bodies = [right, left]"
                )
            right, left = sorted(
                with_surface, key=lambda p: -p.mesh.points[np.unique(p.mesh.surface(cfg.surface)), 0].mean()
            )
        self.right, self.left = right, left
        self.model = BernoulliFlow(
            _with_medial(right.mesh, cfg.surface),
            _with_medial(left.mesh, cfg.surface),
            cfg.subglottal_pressure,
            cfg.separation_ratio,
            n_stations=cfg.stations,
        )
        self.n_dofs = problem.n_dofs
        self.last = None
        # Per step only the wetted nodes' positions are gathered and only their forces
        # computed (the model's numbers at them; the folds' other nodes get no force).
        self._compact, kept = self.model.compacted()
        self._points = problem.points
        self._nodes = [body.node_offset + k for body, k in zip((right, left), kept)]
        self._dofs = [(3 * n[:, None] + np.arange(3)).ravel() for n in self._nodes]
        # A vocal tract ([acoustics], vfrs.acoustics) connects its glottis(t, A_sep, P_lung) to this port
        self.port = GlottisPort(cfg.density)
        ctx.offer(self.port)

    def forces(self, state):
        u = state.u.reshape(-1, 3)
        xr, xl = (self._points[n] + u[n] for n in self._nodes)
        scale = self._ramp(state.t_next, self.params.ramp)[0]
        glottis = self.port.tract
        if glottis is None:
            fr, fl, st = self._compact.forces(xr, xl)
        else:  # the tract's pressures below and above the glottis, at this load's time (ramped lungs)
            lungs = scale * self.model.ps
            fr, fl, st = self._compact.forces(xr, xl, lambda a_sep: glottis(state.t_next, a_sep, lungs))
            if st.drop is not None:
                scale = 1.0  # those pressures are the ramped ones
        self.last = st
        f = np.zeros(self.n_dofs)
        f[self._dofs[0]] = scale * fr.ravel()
        f[self._dofs[1]] = scale * fl.ravel()
        self._scale = scale
        return f

    def record(self, state, history) -> None:
        st = self.last
        if st is None:
            history.setdefault("glottal_area", []).append(np.nan)
            history.setdefault("flow_rate", []).append(np.nan)
            history.setdefault("glottis_closed", []).append(0)
            history.setdefault("min_gap", []).append(np.nan)
            return
        a_sep = 0.0 if st.closed else float(np.interp(st.y_separation, st.y, st.area))
        history.setdefault("glottal_area", []).append(st.min_area)
        # the pressure drop across the glottis: the (ramped) lung pressure, or what a coupled tract
        # left (the jet reverses if it is negative)
        drop = self.model.ps * getattr(self, "_scale", 1.0) if st.drop is None else st.drop
        history.setdefault("flow_rate", []).append(a_sep * math.copysign(math.sqrt(2.0 * abs(drop) / self.port.density), drop))
        history.setdefault("glottis_closed", []).append(int(st.closed))
        history.setdefault("min_gap", []).append(st.min_gap)


def _with_medial(mesh, surface):
    """The flow model reads the ``medial`` surface; alias another name to it."""
    if surface == "medial":
        return mesh
    import copy

    m = copy.copy(mesh)
    m.surfaces = dict(mesh.surfaces, medial=mesh.surface(surface))
    return m
