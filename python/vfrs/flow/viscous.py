"""The quasi-steady viscous slit flow between two folds (issue 46, item 1: the equations; not yet
a ``[flow] model`` of its own, which is the next step): Bernoulli's jet with the viscous loss of
a slit whose width varies along the fold's length, separating at the narrowest station (or
where the area has grown by a ratio) into a jet that keeps the supraglottal pressure.

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
(:func:`viscous_flow`). With ``mu = 0`` it is :func:`vfrs.flow.bernoulli.bernoulli_pressure`;
with ``rho = 0`` it is Poiseuille's flow ``U = (p_s - p_e) / (12 mu R)``. A station whose area
is at most ``closed_area`` closes the glottis: no flow, ``p_s`` below the first closed station
and ``p_e`` from it on.

Not modelled here (issue 46 lists them): entrance and exit losses, the glottal inertance
(unsteady term), a boundary-layer separation criterion, the pressure recovery into a vocal
tract; ``R`` uses the trapezoid rule along y (second order in the station spacing).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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


def viscous_flow(y, area, g3, subglottal_pressure, rho, mu=AIR_VISCOSITY, separation_ratio=1.0, closed_area=0.0,
                 exit_pressure=0.0) -> SlitFlow:
    """The viscous slit flow through the stations ``y`` (increasing) of areas ``area`` and
    cube integrals ``g3`` (:func:`slit_integrals`), driven by ``subglottal_pressure`` into the
    ``exit_pressure``; ``rho`` the air's density (kg/m^3), ``mu`` its viscosity (Pa s). The jet
    separates at the narrowest station (the downstream end of a stretch of equal narrowest
    areas: a straight slit's exit), or with ``separation_ratio`` > 1 at the first station
    downstream of it whose area is that many times the narrowest. No flow runs backwards (a
    drive of zero or less: ``U = 0``).

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
    if rho < 0 or mu < 0:
        raise ValueError(f"viscous_flow: rho and mu must be >= 0 (got rho = {rho!r}, mu = {mu!r})")
    drive = float(subglottal_pressure) - float(exit_pressure)
    p = np.full_like(area, float(exit_pressure))
    shut = np.flatnonzero(area <= closed_area)
    if shut.size:
        p[y < y[shut[0]]] = float(subglottal_pressure)
        return SlitFlow(0.0, p, float(y[shut[0]]), int(shut[0]), True, 0.0, 0.0)
    i_sep = int(np.argmin(area))
    while i_sep + 1 < len(area) and area[i_sep + 1] <= area[i_sep]:  # the downstream end of a narrowest
        i_sep += 1                                                  # stretch (a straight slit: its exit)
    if separation_ratio > 1.0:
        after = np.flatnonzero(area[i_sep:] >= separation_ratio * area[i_sep])
        i_sep = i_sep + int(after[0]) if after.size else len(area) - 1
    # R(y): the trapezoid rule on 1 / G3 from the first station
    inv = np.where(g3 > 0, 1.0 / np.where(g3 > 0, g3, 1.0), np.inf)
    steps = 0.5 * (inv[1:] + inv[:-1]) * np.diff(y)
    R = np.concatenate([[0.0], np.cumsum(steps)])
    a = 0.5 * rho / area[i_sep] ** 2
    b = 12.0 * mu * R[i_sep]
    if not np.isfinite(b):  # a station with a zero-width slit somewhere: no flow
        return SlitFlow(0.0, np.where(y < y[i_sep], float(subglottal_pressure), p), float(y[i_sep]), i_sep, True,
                        0.0, 0.0)
    if a == 0 and b == 0:
        raise ValueError("viscous_flow: nothing resists the flow (rho = 0 and no slit length before the separation)")
    if drive <= 0:
        U = 0.0  # no flow backwards: the glottis is driven from below
    elif a > 0:
        U = 2.0 * drive / (b + np.sqrt(b * b + 4.0 * a * drive))
    else:
        U = drive / b
    up = np.arange(len(area)) <= i_sep
    p[up] = float(subglottal_pressure) - 0.5 * rho * (U / area[up]) ** 2 - 12.0 * mu * U * R[up]
    p[i_sep] = float(exit_pressure)  # the jet's pressure at separation (round-off aside)
    return SlitFlow(float(U), p, float(y[i_sep]), i_sep, False, float(a * U * U), float(b * U))
