"""``[flow] model = "viscous"``: Bernoulli's jet with the viscous loss of a slit whose width
varies along the fold's length, an entrance loss and (optionally) the glottal inertance,
separating at the narrowest station (or where the area has grown by a ratio) into a jet that
keeps the supraglottal pressure; no pressure where the folds touch.

Along the flow (y, inferior to superior) each station is a slit across z (anterior-posterior)
of width ``g(y, z) >= 0`` (medio-lateral, the gap between the folds). Its area and its cube
integral are

    A(y) = int g dz,        G3(y) = int g^3 dz,

exactly for a gap that is piecewise linear in z (:func:`slit_integrals`). In lubrication
theory a slit's flow per unit length is ``-(g^3 / 12 mu) dp/dy``, so a volume flow ``U``
through the station loses ``12 mu U / G3(y)`` of pressure per unit length (Poiseuille; the
Ishizaka-Flanagan viscous term ``12 mu L U / h^3`` for a rectangular slit of depth L). With
Bernoulli's inertial term and the subglottal pressure ``p_s`` upstream of the first station
(the trachea's area large against the glottis), the pressure at a station up to separation is

    p(y) = p_s - rho U^2 / (2 A(y)^2) - 12 mu U R(y),      R(y) = int_{y_0}^{y} dy' / G3(y'),

and the jet separates at ``y_sep`` into the supraglottal pressure ``p_e`` (0 here), which fixes
``U`` by the quadratic ``rho U^2 / (2 A_sep^2) + 12 mu R(y_sep) U = p_s - p_e``
(:func:`viscous_flow`). With ``mu = 0`` it is
:func:`vfrs.flow.models.bernoulli.bernoulli_pressure`; with ``rho = 0`` it is Poiseuille's flow
``U = (p_s - p_e) / (12 mu R)``. A station whose area is at most ``closed_area`` closes the
glottis: no flow, ``p_s`` below the first closed station and ``p_e`` from it on (the closed
glottis exactly: no flow through it, the subglottal pressure up to the first closed station).

Two optional terms join the equation. An entrance loss ``k_e rho U^2 / (2 A_0^2)``
(``A_0`` the first station's area; van den Berg et al.'s entrance coefficient 1.375, which
Ishizaka & Flanagan adopted, is k_e = 0.375 beyond Bernoulli's 1: second-hand, as the
introduction of the M5 uniform-glottis study PMC3078031 states it; that study measured
entrance loss coefficients of 0.69-17.6 on the M5 model, falling with pressure and diameter)
lowers every station's pressure by the same amount. The glottal inertance: accelerating the air in the glottis takes ``I(y) dU/dt``, ``I(y) = rho int_{y_0}^{y}
dy' / A(y')``, with ``dU/dt = (U - U_prev) / dt`` over the step (implicit in ``U``: the equation
stays a quadratic, its linear coefficient grows by ``I(y_sep) / dt``).

The pressure acts only where the gap is open: a node's pressure is its station's times the
open fraction of the (y, z) cell it sits in (``pressure_on_contact = true``: on the whole medial
surface, Bernoulli's way). With a vocal tract coupled ([acoustics]) the tract solves ``U`` in its
incident waves with this model's losses (:class:`vfrs.flow.model.GlottalLoss`) and returns the
pressure below the glottis and in the jet (with ``coupling = "interactive"``, below the tract's
input pressure by the Ishizaka-Flanagan pressure recovery), from which the pressure here follows.
Separation by ``separation = "boundary_layer"``: where Thwaites' boundary layer, grown from
the first station, separates (:func:`boundary_layer_ratio`; the criterion Pelorson and
co-workers applied to the glottis, second-hand: not read here). Not modelled: the inertance
together with a coupled tract (a SceneError); ``R`` and ``I`` use the trapezoid rule along y (second order in
the station spacing).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...params import param
from ..model import FlowModel, GlottalLoss, register_model
from ..slices import FlowState

#: The dynamic viscosity of air at 37 degrees C (Pa s): 1.89e-5 (1.85e-5 at 25 C; the value
#: voice-science models use, e.g. Ishizaka & Flanagan 1972 take 1.86e-5).
AIR_VISCOSITY = 1.89e-5


@dataclass
class SlitFlow:
    """A configuration's viscous slit flow: ``flow`` (the volume flow U, m^3/s), ``pressure``
    at the stations (Pa), the separation station's ``y_separation`` and ``index``, ``closed``
    (a station shut), and the parts of the pressure drop at separation: ``inertial``
    (``rho U^2 / 2 A_sep^2``) and ``viscous`` (``12 mu U R(y_sep)``), which sum to
    ``p_s - p_e``."""

    flow: float
    pressure: np.ndarray
    y_separation: float
    index: int
    closed: bool
    inertial: float
    viscous: float


def slit_integrals(z, gap) -> tuple:
    """(A, G3) per station: the integrals over z of the gap and of its cube, exact for a gap
    that is linear between the samples ``z`` (increasing, shape (m,)); ``gap``: (n, m), one row
    per station, negative values (the folds overlapping) taken as 0 (a sample where the gap
    changes sign is split at the zero crossing, so a partly closed segment counts only its open
    part).

    >>> z = np.array([0.0, 1.0])
    >>> A, G3 = slit_integrals(z, np.array([[1.0, 3.0]]))    # g = 1 + 2 z: A = 2, G3 = (81 - 1) / 8 = 10
    >>> float(A[0]), float(G3[0])
    (2.0, 10.0)
    """
    z = np.asarray(z, dtype=float)
    g = np.atleast_2d(np.asarray(gap, dtype=float))
    if z.ndim != 1 or g.shape[1] != z.size or z.size < 2 or np.any(np.diff(z) <= 0):
        raise ValueError("slit_integrals: z must be increasing samples (at least 2), one per column of gap")
    a, b = g[:, :-1], g[:, 1:]
    dz = np.diff(z)[None, :]
    # the open part of each segment: where a and b differ in sign, only the positive side's
    # fraction of the segment, from the positive end to the zero crossing
    pa, pb = np.maximum(a, 0.0), np.maximum(b, 0.0)
    crossing = (a > 0) != (b > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        frac = np.where(crossing, np.maximum(a, b) / np.abs(b - a), 1.0)
    length = dz * frac
    lo, hi = np.minimum(pa, pb), np.maximum(pa, pb)  # over the open part the gap goes linearly lo -> hi
    area = 0.5 * (lo + hi) * length
    # int of a linear g from lo to hi over length l: l (hi^4 - lo^4) / (4 (hi - lo)) = l (hi + lo)(hi^2 + lo^2) / 4
    cube = length * (hi + lo) * (hi * hi + lo * lo) / 4.0
    return area.sum(axis=1), cube.sum(axis=1)


#: Stations within this relative amount of the narrowest area are one narrowest stretch (the
#: round-off of a straight slit's areas), whose downstream end the jet separates at.
NARROWEST = 1e-9


def separation_index(area, separation_ratio=1.0) -> int:
    """The station the jet separates at: the downstream end of the stretch of narrowest areas
    (within :data:`NARROWEST` of the minimum, consecutive: a straight slit's exit), or with
    ``separation_ratio`` > 1 the first station downstream of it whose area is that many times
    the narrowest (the last station if none)."""
    i_sep = int(np.argmin(area))
    narrowest = area[i_sep] * (1.0 + NARROWEST)
    while i_sep + 1 < len(area) and area[i_sep + 1] <= narrowest:
        i_sep += 1
    if separation_ratio > 1.0:
        after = np.flatnonzero(area[i_sep:] >= separation_ratio * area[i_sep])
        i_sep = i_sep + int(after[0]) if after.size else len(area) - 1
    return i_sep


def running_integral(y, f) -> np.ndarray:
    """int_{y_0}^{y_k} f dy at every station (trapezoid rule; an infinite ``f`` makes it inf on)."""
    with np.errstate(invalid="ignore"):
        steps = 0.5 * (f[1:] + f[:-1]) * np.diff(y)
    return np.concatenate([[0.0], np.cumsum(steps)])


def _reciprocal(x) -> np.ndarray:
    return np.where(x > 0, 1.0 / np.where(x > 0, x, 1.0), np.inf)


@dataclass(frozen=True)
class Separation:
    """Where the jet separates: ``index`` (the last station the flow is attached at: the
    pressure profile holds up to it, the exit pressure after it), ``y``, ``area``, and the
    running integrals ``R`` (int dy / G3) and ``L`` (int dy / A) up to it."""

    index: int
    y: float
    area: float
    R: float
    L: float


def separation(y, area, inv_g3, separation_ratio=1.0, R=None, L=None) -> Separation:
    """The :class:`Separation` of stations ``y`` with areas ``area`` and ``inv_g3`` = 1 / G3:
    at the station of :func:`separation_index` with a ratio of 1; with a ratio > 1 where the
    area, linear between the stations, reaches that many times the narrowest (so that the
    jet's area is the ratio's exactly at any station spacing; the integrands linear there too).
    ``R``, ``L``: the running integrals of ``inv_g3`` and ``1 / area`` when the caller has them."""
    R = running_integral(y, inv_g3) if R is None else R
    L = running_integral(y, 1.0 / area) if L is None else L
    i = separation_index(area, separation_ratio)
    if separation_ratio <= 1.0 or i == 0:
        return Separation(i, float(y[i]), float(area[i]), float(R[i]), float(L[i]))
    target = separation_ratio * float(np.min(area[: i + 1]))
    if area[i] < target or area[i - 1] >= target:  # none reaches it (the last station), or the station itself
        return Separation(i, float(y[i]), float(area[i]), float(R[i]), float(L[i]))
    w = (target - area[i - 1]) / (area[i] - area[i - 1])
    dy = w * (y[i] - y[i - 1])

    def partial(F, f):  # F up to station i - 1, plus the trapezoid of f (linear) over the part dy
        return float(F[i - 1] + 0.5 * dy * (2.0 * f[i - 1] + w * (f[i] - f[i - 1])))

    return Separation(i - 1, float(y[i - 1] + dy), target, partial(R, inv_g3), partial(L, 1.0 / area))


#: Thwaites' separation value of the boundary layer's shape parameter lambda (Pelorson et al.'s
#: criterion for the glottis uses Thwaites' method; the value is the textbook one).
THWAITES_LAMBDA = -0.09


def boundary_layer_ratio(y, area, critical=THWAITES_LAMBDA) -> float:
    """The ratio A_sep / A_min at which Thwaites' boundary layer, grown from the first station
    with the core velocity U / A(y), separates: the first place downstream of the narrowest
    station where lambda = theta^2 / nu dV/dy, which for a one-dimensional channel is
    ``-0.45 A^4 A' int_{y_0}^{y} A^-5 dy`` (independent of the flow and the viscosity),
    falls to ``critical``, interpolated linearly between the stations; ``inf`` (separation at
    the last station) where it never does. In a channel diverging linearly from its narrowest
    end lambda = -0.1125 ((A / A_0)^4 - 1), so the jet separates at A = 1.8^(1/4) A_0 = 1.158 A_0
    whatever the angle.

    >>> y = np.linspace(0.0, 1e-3, 401)
    >>> round(boundary_layer_ratio(y, 1e-6 * (1.0 + 2.0 * y / 1e-3)), 4)
    1.1583
    """
    y = np.asarray(y, dtype=float)
    area = np.asarray(area, dtype=float)
    lam = -0.45 * area ** 4 * np.gradient(area, y) * running_integral(y, area ** -5.0)
    i_min = separation_index(area)
    after = np.flatnonzero(lam[i_min + 1:] <= critical)
    if not after.size:
        return float("inf")
    i = i_min + 1 + int(after[0])
    w = (critical - lam[i - 1]) / (lam[i] - lam[i - 1]) if lam[i] != lam[i - 1] else 1.0
    a_sep = area[i - 1] + min(max(w, 0.0), 1.0) * (area[i] - area[i - 1])
    return float(max(a_sep / area[i_min], 1.0))


def viscous_flow(y, area, g3, subglottal_pressure, rho, mu=AIR_VISCOSITY, separation_ratio=1.0, closed_area=0.0,
                 exit_pressure=0.0, entrance_loss=0.0, inertance=None) -> SlitFlow:
    """The viscous slit flow through the stations ``y`` (increasing) of areas ``area`` and
    cube integrals ``g3`` (:func:`slit_integrals`), driven by ``subglottal_pressure`` into the
    ``exit_pressure``; ``rho`` the air's density (kg/m^3), ``mu`` its viscosity (Pa s);
    ``entrance_loss`` k_e; ``inertance``: (dt, U_prev) to include the glottal inertance over a
    step of dt from the flow U_prev, or None. Separation: :func:`separation`. No flow runs
    backwards (a drive of zero or less, inertia aside: ``U = 0``).

    >>> y = np.linspace(0.0, 3e-3, 4); A = np.array([4e-6, 3e-6, 2e-6, 3e-6])
    >>> s = viscous_flow(y, A, np.full(4, 1e-12), 800.0, rho=1.2, mu=0.0)   # Bernoulli
    >>> round(s.flow * 1e6, 3), s.pressure.round(1).tolist()
    (73.03, [600.0, 444.4, 0.0, 0.0])
    """
    y = np.asarray(y, dtype=float)
    area = np.asarray(area, dtype=float)
    g3 = np.asarray(g3, dtype=float)
    if not (y.shape == area.shape == g3.shape) or y.ndim != 1 or y.size < 1:
        raise ValueError("viscous_flow: y, area and g3 must be 1-D arrays of the same length")
    if rho < 0 or mu < 0 or entrance_loss < 0:
        raise ValueError(f"viscous_flow: rho, mu and entrance_loss must be >= 0 (got {rho!r}, {mu!r}, {entrance_loss!r})")
    ps, pe = float(subglottal_pressure), float(exit_pressure)
    p = np.full_like(area, pe)
    shut = np.flatnonzero(area <= closed_area)
    if shut.size:
        p[y < y[shut[0]]] = ps
        return SlitFlow(0.0, p, float(y[shut[0]]), int(shut[0]), True, 0.0, 0.0)
    inv_g3 = _reciprocal(g3)
    R = running_integral(y, inv_g3)
    L = running_integral(y, 1.0 / area)
    sep = separation(y, area, inv_g3, separation_ratio, R, L)
    if not np.isfinite(sep.R):  # a station with a zero-width slit before separation: no flow
        return SlitFlow(0.0, np.where(y < sep.y, ps, p), sep.y, sep.index, True, 0.0, 0.0)
    a = 0.5 * rho * (1.0 / sep.area ** 2 + entrance_loss / area[0] ** 2)
    b = 12.0 * mu * sep.R
    drive = ps - pe
    if inertance is not None:
        dt, u_prev = inertance
        b += rho * sep.L / dt
        drive += rho * sep.L * u_prev / dt
    if a == 0 and b == 0:
        raise ValueError("viscous_flow: nothing resists the flow (rho = 0 and no slit length before the separation)")
    if drive <= 0:
        U = 0.0  # no flow backwards: the glottis is driven from below
    elif a > 0:
        U = 2.0 * drive / (b + np.sqrt(b * b + 4.0 * a * drive))
    else:
        U = drive / b
    up = np.arange(len(area)) <= sep.index
    p[up] = (ps - 0.5 * rho * (U / area[up]) ** 2 - 0.5 * rho * entrance_loss * (U / area[0]) ** 2
             - 12.0 * mu * U * R[up])
    if inertance is not None:
        p[up] -= rho * L[up] * (U - inertance[1]) / inertance[0]
    if sep.y == y[sep.index]:
        p[sep.index] = pe  # the jet's pressure at separation (round-off aside)
    return SlitFlow(float(U), p, sep.y, sep.index, False, float(a * U * U), float(12.0 * mu * sep.R * U))


@register_model
class ViscousModel(FlowModel):
    """Bernoulli's jet with the viscous loss of a slit whose width varies along z, an entrance
    loss and optionally the glottal inertance; no pressure where the folds touch (docs/model.md,
    "Glottal flow")."""

    name = "viscous"

    @dataclass(frozen=True)
    class Params:
        viscosity: float = param(AIR_VISCOSITY, doc="the air's dynamic viscosity (37 C)", unit="Pa s",
                                 nonnegative=True)
        entrance_loss: float = param(0.0, doc="entrance loss k_e: the flow loses k_e rho U^2 / 2 A_0^2 entering the "
                                     "glottis (A_0: the first station's area; van den Berg's 1.375 is 0.375)", low=0.0,
                                     high=5.0)
        inertance: bool = param(False, doc="the glottal inertance: the air in the glottis takes I dU/dt, "
                                "I = rho int dy / A (not with a coupled vocal tract)")
        closed_gap: float = param(0.0, doc="a gap up to this is closed: the slit's width is the gap less it (match "
                                  "it to a contact offset)", unit="m", nonnegative=True)
        pressure_on_contact: bool = param(False, doc="the pressure acts on the whole medial surface, where the folds "
                                          "touch too (Bernoulli's way); false: only where the gap is open")
        separation: str = param("ratio", doc="where the jet separates: 'ratio' (separation_ratio x A_min) or "
                                "'boundary_layer' (Thwaites' lambda reaches separation_lambda)",
                                choices=("ratio", "boundary_layer"))
        separation_lambda: float = param(THWAITES_LAMBDA, doc="Thwaites' lambda at separation ('boundary_layer')",
                                         low=-1.0, high=0.0)

    def __init__(self, params, common):
        super().__init__(params, common)
        self._last: tuple | None = None  # (t, U) of the last call
        self._base: tuple | None = None  # (t, U) of the last call at an earlier time: the step's start

    @classmethod
    def check(cls, params, common, effects: dict, error) -> None:
        acoustics = effects.get("acoustics")
        if params.inertance and acoustics is not None and getattr(acoustics, "coupling", "none") != "none":
            raise error("inertance = true is not built for a flow coupled to a vocal tract ([acoustics] coupling = "
                        f"{acoustics.coupling!r}): the tract solves the flow sample by sample without it; set "
                        "inertance = false or coupling = \"none\"", "flow.inertance")

    def _inertance(self, t):
        """(dt, U_prev) for the step to ``t``, or None (no inertance, or the first call)."""
        if not self.params.inertance or t is None:
            return None
        if self._last is not None and t > self._last[0]:
            self._base = self._last
        base = self._base
        return None if base is None or t <= base[0] else (t - base[0], base[1])

    def state(self, y, z, width, drive, tract, t) -> FlowState:
        cfg = self.params
        gap = width - cfg.closed_gap  # < 0 closed: slit_integrals counts each segment's open part
        area, g3 = slit_integrals(z, gap)
        closed = bool((area <= 0.0).any())
        ratio = self.separation_ratio
        if cfg.separation == "boundary_layer" and not closed:
            ratio = min(boundary_layer_ratio(y, area, cfg.separation_lambda), 1e6)
        p_exit, p_drop = 0.0, None
        if tract is not None:
            loss, a_sep = GlottalLoss(), 0.0
            if not closed:
                sep = separation(y, area, _reciprocal(g3), ratio)
                if np.isfinite(sep.R):
                    loss = GlottalLoss(0.5 * self.density * cfg.entrance_loss / area[0] ** 2, 12.0 * cfg.viscosity * sep.R)
                    a_sep = sep.area
            pressures = tract(a_sep, loss)
            if pressures is not None:
                drive, p_exit = pressures
                p_drop = drive - p_exit
        s = viscous_flow(y, area, g3, drive, self.density, cfg.viscosity, ratio,
                         exit_pressure=p_exit, entrance_loss=cfg.entrance_loss, inertance=self._inertance(t))
        if t is not None:
            self._last = (t, s.flow)
        wet = None if cfg.pressure_on_contact else (gap > 0.0).astype(float)
        return FlowState(y, area, s.pressure, float(area.min()), s.y_separation, s.closed, float(width.min()), p_drop,
                         flow=s.flow, wet=wet, z=z)

    def memory(self) -> dict:
        return {"last": self._last, "base": self._base}

    def recall(self, memory: dict) -> None:
        self._last, self._base = memory.get("last"), memory.get("base")
