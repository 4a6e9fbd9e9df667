"""Estimators for comparing the model with published measurements (issue 33, "Against
measurements"): the closed forms that turn kinematics into a collision speed and a Hertz
contact pressure, Titze's phonation threshold pressure, and the two fits a trend comparison
needs (a power law ``y = a x^b`` for "roughly the square root of lung pressure", a straight
line for "linear in vibration amplitude"), each with confidence bounds.

Where each formula comes from, and how much of its source was read, is in
docs/validation/sources.md; the points and trends read from the literature are in
docs/validation/data/. In short:

- :func:`sinusoid_peak_speed` is ``v = 2 pi f0 A``, the largest speed of a sinusoidal motion
  of amplitude ``A`` at frequency ``f0``: the closing-speed estimate that DeJonckere & Lebacq
  (2020, "Vocal fold collision speed in vivo: the effect of loudness") write as their Eq. 4
  (read there).
- :func:`hertz_impact` is the classical Hertz impact of two elastic spheres (K. L. Johnson,
  *Contact Mechanics*, Cambridge University Press 1985, section 11.4): the largest approach,
  force, contact radius and pressure, and the contact time, when two bodies of effective mass
  ``m*`` meet at the relative speed ``v``. :func:`hertz_line_pressure` is Hertz's static
  pressure between two parallel cylinders pressed by a force per length (Johnson, section 4.2).
  Diaz-Cadiz et al. (Appl. Sci. 9(11):2384, 2019) estimate vocal fold contact pressure from
  high-speed video with "a Hertzian impact model" on "a more relevant VF contact geometry",
  "normalized by the tissue properties", with "a correction factor for using a superior view
  only" (their abstract); their equations and tissue constants could not be read here (see
  docs/validation/sources.md), so these functions are the textbook Hertz relations their
  method builds on, not their estimator: the geometry, the normalization and the correction
  factor are theirs to add once the paper's section 2 is read. :func:`hertz_sphere_pressure`
  and :func:`kinematic_hertz_pressure` turn f0 and amplitude into such a textbook estimate
  (two like tissue spheres, whose radius drops out), which docs/validation.md applies to the
  model's own kinematics.
- :func:`titze_threshold_pressure` is Titze's (J. Acoust. Soc. Am. 83:1536-1552, 1988)
  threshold pressure of a rectangular glottis, read second-hand as Eq. (1) of Fulcher, Scherer
  & Waddle, J. Acoust. Soc. Am. 132(4):2582-2591 (2012), whose web rendering lost the fraction
  bar ("Pth=ktBcxi0LgT2"); with ``B`` the fold's damping coefficient (kg/s) only
  ``k_t B c xi0 / (L_g T^2)`` is a pressure, which is how it is implemented.
- :func:`power_law_fit` and :func:`linear_fit` are ordinary least squares (in log-log for the
  power law) with Student-t confidence bounds on the coefficients.

Pure numpy/scipy; no vfrs module but the errors is imported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import VfrsError

#: Pascals in one centimetre of water (the conventional value, g = 9.80665 m/s^2, 1000 kg/m^3).
PA_PER_CM_H2O = 98.0665


def effective_modulus(E1: float, nu1: float, E2: float | None = None, nu2: float | None = None) -> float:
    """Hertz's contact modulus ``E*``: ``1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2`` (Pa); the
    second body defaults to the first (two like folds: ``E* = E / (2 (1 - nu^2))``).

    >>> round(effective_modulus(2.0e3, 0.0), 6)
    1000.0
    """
    E2 = E1 if E2 is None else E2
    nu2 = nu1 if nu2 is None else nu2
    _positive(E1=E1, E2=E2)
    for name, nu in (("nu1", nu1), ("nu2", nu2)):
        if not -1.0 < nu < 0.5 + 1e-12:
            raise VfrsError(f"{name} = {nu}: a Poisson's ratio lies in (-1, 0.5]")
    return 1.0 / ((1.0 - nu1**2) / E1 + (1.0 - nu2**2) / E2)


def effective_radius(R1: float, R2: float | None = None) -> float:
    """The effective radius ``R``: ``1/R = 1/R1 + 1/R2`` (m); ``R2`` None is a flat (infinite
    radius, ``R = R1``); two like surfaces of radius ``R1`` give ``R1/2``.

    >>> effective_radius(2e-3, 2e-3), effective_radius(2e-3)
    (0.001, 0.002)
    """
    _positive(R1=R1)
    if R2 is None:
        return R1
    _positive(R2=R2)
    return 1.0 / (1.0 / R1 + 1.0 / R2)


def sinusoid_peak_speed(f0: float, amplitude: float) -> float:
    """The largest speed of ``x(t) = A sin(2 pi f0 t)``: ``v = 2 pi f0 A`` (m/s), the
    closing-speed estimate of DeJonckere & Lebacq 2020, Eq. 4. One fold's speed; the
    approach speed of two folds moving mirror-symmetrically is twice it.

    >>> round(sinusoid_peak_speed(100.0, 1e-3), 6)
    0.628319
    """
    _positive(f0=f0, amplitude=amplitude)
    return 2.0 * math.pi * f0 * amplitude


@dataclass(frozen=True)
class HertzImpact:
    """The largest state of a Hertz impact (SI units): ``approach`` (m, the mutual approach
    delta of the two bodies' far points), ``force`` (N), ``contact_radius`` (m), ``peak_pressure``
    (Pa, the pressure at the centre of the contact circle, 3/2 of its mean), ``mean_pressure``
    (Pa, force / contact area) and ``duration`` (s, the time in contact, elastic rebound)."""

    approach: float
    force: float
    contact_radius: float
    peak_pressure: float
    mean_pressure: float
    duration: float


#: ``integral_0^1 dx / sqrt(1 - x^(5/2)) = (2/5) B(2/5, 1/2)``: the contact time of a Hertz
#: impact is ``2 * HERTZ_TIME_INTEGRAL * approach / v`` (Johnson 1985, section 11.4: about
#: 2.94 approach / v).
HERTZ_TIME_INTEGRAL = 0.4 * math.gamma(0.4) * math.gamma(0.5) / math.gamma(0.9)


def hertz_impact(speed: float, mass: float, E_star: float, radius: float) -> HertzImpact:
    """The Hertz impact of two elastic spheres meeting at the relative normal speed ``speed``
    (m/s), effective mass ``mass`` (kg: ``1/m* = 1/m1 + 1/m2``), contact modulus ``E_star``
    (Pa, :func:`effective_modulus`) and effective radius ``radius`` (m,
    :func:`effective_radius`). The force is ``F = 4/3 E* R^(1/2) delta^(3/2)``; all the kinetic
    energy ``m* v^2 / 2`` is stored at the largest approach, so
    ``delta = (15 m* v^2 / (16 E* R^(1/2)))^(2/5)``; then ``a = (R delta)^(1/2)``,
    ``p0 = 3 F / (2 pi a^2) = (2 E* / pi) (delta / R)^(1/2)`` (Johnson 1985, sections 4.2 and 11.4).
    Quasi-static and elastic: valid while the contact radius is small against ``R`` and the
    impact slow against the bodies' wave speeds.

    >>> h = hertz_impact(0.5, 1e-4, 1e3, 1e-3)
    >>> round(h.peak_pressure / h.mean_pressure, 6)
    1.5
    """
    _positive(speed=speed, mass=mass, E_star=E_star, radius=radius)
    delta = (15.0 * mass * speed**2 / (16.0 * E_star * math.sqrt(radius))) ** 0.4
    force = 4.0 / 3.0 * E_star * math.sqrt(radius) * delta**1.5
    a = math.sqrt(radius * delta)
    return HertzImpact(approach=delta, force=force, contact_radius=a,
                       peak_pressure=3.0 * force / (2.0 * math.pi * a * a),
                       mean_pressure=force / (math.pi * a * a),
                       duration=2.0 * HERTZ_TIME_INTEGRAL * delta / speed)


def hertz_sphere_pressure(speed: float, density: float, E_star: float) -> float:
    """The peak pressure of the Hertz impact of two like elastic spheres of tissue (density
    ``density``, kg/m^3; contact modulus ``E_star``, Pa, :func:`effective_modulus`) meeting at the
    relative normal speed ``speed`` (m/s): :func:`hertz_impact` with each sphere's mass
    ``4/3 pi rho R^3`` (so ``m* = 2/3 pi rho R^3``) and ``R* = R/2``. The radius drops out,
    ``delta / R* = 2 (5 sqrt(2) pi rho v^2 / (8 E*))^(2/5)``, so

        ``p0 = (2 sqrt(2) E* / pi) (5 sqrt(2) pi rho v^2 / (8 E*))^(1/5)``  (Pa),

    a pressure from a speed and the tissue's constants alone, growing as ``v^(2/5)`` and
    ``E*^(4/5)``. A textbook Hertz estimate (Johnson 1985, sections 4.2 and 11.4, with the
    sphere's own mass), not Diaz-Cadiz et al.'s estimator, whose equations were not read
    (docs/validation/sources.md).

    >>> p = hertz_sphere_pressure(0.2, 1070.0, 1e3)
    >>> round(hertz_sphere_pressure(0.4, 1070.0, 1e3) / p, 6) == round(2 ** 0.4, 6)
    True
    """
    _positive(speed=speed, density=density, E_star=E_star)
    radius = 1.0  # any: it drops out
    return hertz_impact(speed, 2.0 / 3.0 * math.pi * density * radius**3, E_star, radius / 2.0).peak_pressure


def kinematic_hertz_pressure(f0: float, amplitude: float, density: float, E: float, nu: float) -> tuple:
    """A Hertz estimate of the collision pressure from what a high-speed video of the superior
    view gives: the fundamental frequency ``f0`` (Hz) and one fold's medio-lateral amplitude
    ``amplitude`` (m, half its peak-to-peak), with the tissue's ``density`` (kg/m^3), Young's
    modulus ``E`` (Pa) and Poisson's ratio ``nu`` assumed isotropic. Each fold closes at the
    sinusoid's largest speed ``2 pi f0 A`` (:func:`sinusoid_peak_speed`), two mirror-symmetric
    folds at twice it; their impact is :func:`hertz_sphere_pressure` with ``E* = E / (2 (1 -
    nu^2))``. Returns ``(p0 (Pa), relative speed (m/s))``.

    >>> p0, v = kinematic_hertz_pressure(100.0, 1e-3, 1070.0, 2e3, 0.45)
    >>> round(v, 6)
    1.256637
    """
    speed = 2.0 * sinusoid_peak_speed(f0, amplitude)
    return hertz_sphere_pressure(speed, density, effective_modulus(E, nu)), speed


def hertz_line_pressure(force: float, length: float, E_star: float, radius: float) -> tuple:
    """Two parallel cylinders (effective radius ``radius``, m) pressed together along
    ``length`` (m) by ``force`` (N): Hertz's strip of half-width
    ``b = (4 F R / (pi L E*))^(1/2)`` and peak pressure ``p0 = (F E* / (pi L R))^(1/2)``
    (Johnson 1985, section 4.2), with ``F = pi p0 b L / 2``. Returns ``(p0 (Pa), b (m))``.

    >>> p0, b = hertz_line_pressure(0.02, 0.01, 1e3, 1e-3)
    >>> round(math.pi * p0 * b * 0.01 / 2, 12)
    0.02
    """
    _positive(force=force, length=length, E_star=E_star, radius=radius)
    p0 = math.sqrt(force * E_star / (math.pi * length * radius))
    b = math.sqrt(4.0 * force * radius / (math.pi * length * E_star))
    return p0, b


def titze_threshold_pressure(kt: float, damping: float, wave_speed: float, half_width: float,
                             length: float, thickness: float) -> float:
    """Titze's (1988) phonation threshold pressure of a rectangular glottis,
    ``P_th = k_t B c xi0 / (L_g T^2)`` (Pa), as Fulcher, Scherer & Waddle (2012) state it in
    their Eq. (1) (second-hand; the fraction read by dimensions, see the module text): ``kt``
    the transglottal pressure coefficient (1), ``damping`` B the damping factor of the fold's
    motion (kg/s), ``wave_speed`` c the speed of the mucosal wave (m/s), ``half_width`` xi0 the
    prephonatory glottal half-width (m), ``length`` L_g the glottal length (m) and
    ``thickness`` T the glottal thickness (m). With B per unit medial-surface area,
    ``B/(L_g T)``, it is the often-quoted ``k_t B c xi0 / T``. Linear in ``half_width``, the
    property Chan & Titze's physical-model measurements supported (Fulcher & Scherer 2011,
    abstract).

    >>> round(titze_threshold_pressure(1.1, 0.01, 1.0, 1e-4, 0.01, 3e-3), 6)
    12.222222
    """
    _positive(kt=kt, damping=damping, wave_speed=wave_speed, length=length, thickness=thickness)
    if half_width < 0:
        raise VfrsError(f"half_width = {half_width}: a prephonatory half-width is >= 0")
    return kt * damping * wave_speed * half_width / (length * thickness**2)


@dataclass(frozen=True)
class LinearFit:
    """``y = slope x + intercept`` by ordinary least squares, with two-sided Student-t
    confidence intervals (``confidence``) on both coefficients, the coefficient of
    determination ``r2`` and the number of points ``n``. ``through_origin``: whether the
    intercept's interval contains 0 (a proportional relation cannot be told apart)."""

    slope: float
    intercept: float
    slope_ci: tuple
    intercept_ci: tuple
    r2: float
    n: int
    confidence: float

    @property
    def through_origin(self) -> bool:
        return self.intercept_ci[0] <= 0.0 <= self.intercept_ci[1]


@dataclass(frozen=True)
class PowerLawFit:
    """``y = a x^b`` fitted as ``ln y = ln a + b ln x`` by ordinary least squares:
    ``a``, ``b`` with their Student-t confidence intervals (``a_ci`` is the interval of
    ``ln a`` mapped back, so it is not symmetric), ``r2`` of the log-log line, ``n``.
    ``contains(b0)``: whether the exponent ``b0`` (say 0.5, "the square root") lies in the
    interval of ``b``."""

    a: float
    b: float
    a_ci: tuple
    b_ci: tuple
    r2: float
    n: int
    confidence: float

    def contains(self, b0: float) -> bool:
        return self.b_ci[0] <= b0 <= self.b_ci[1]


def linear_fit(x, y, confidence: float = 0.95) -> LinearFit:
    """Fit ``y = slope x + intercept`` (at least 3 points, ``x`` not all equal).

    >>> f = linear_fit([1.0, 2.0, 3.0, 4.0], [2.0, 4.1, 5.9, 8.0])
    >>> round(f.slope, 3), f.slope_ci[0] < 2.0 < f.slope_ci[1]
    (1.98, True)
    """
    from scipy.stats import t as student_t

    xa, ya = _points(x, y)
    n = xa.size
    xm, ym = xa.mean(), ya.mean()
    sxx = float(np.sum((xa - xm) ** 2))
    if sxx == 0.0:
        raise VfrsError("linear_fit: all x are equal, so no slope can be fitted")
    slope = float(np.sum((xa - xm) * (ya - ym)) / sxx)
    intercept = float(ym - slope * xm)
    resid = ya - (slope * xa + intercept)
    ss_res = float(np.sum(resid**2))
    ss_tot = float(np.sum((ya - ym) ** 2))
    s2 = ss_res / (n - 2)
    se_slope = math.sqrt(s2 / sxx)
    se_int = math.sqrt(s2 * (1.0 / n + xm**2 / sxx))
    q = _quantile(student_t, confidence, n - 2)
    return LinearFit(slope=slope, intercept=intercept,
                     slope_ci=(slope - q * se_slope, slope + q * se_slope),
                     intercept_ci=(intercept - q * se_int, intercept + q * se_int),
                     r2=1.0 - ss_res / ss_tot if ss_tot > 0 else 1.0, n=n, confidence=confidence)


def power_law_fit(x, y, confidence: float = 0.95) -> PowerLawFit:
    """Fit ``y = a x^b`` (at least 3 points, all ``x`` and ``y`` > 0).

    >>> f = power_law_fit([0.4, 0.8, 1.6, 3.2], [1.0, 1.4142135, 2.0, 2.8284271])
    >>> round(f.b, 4), f.contains(0.5)
    (0.5, True)
    """
    xa, ya = _points(x, y)
    if np.any(xa <= 0) or np.any(ya <= 0):
        raise VfrsError("power_law_fit: a power law is fitted in log-log, so every x and y must be > 0")
    line = linear_fit(np.log(xa), np.log(ya), confidence)
    return PowerLawFit(a=math.exp(line.intercept), b=line.slope,
                       a_ci=(math.exp(line.intercept_ci[0]), math.exp(line.intercept_ci[1])),
                       b_ci=line.slope_ci, r2=line.r2, n=line.n, confidence=confidence)


def _points(x, y) -> tuple:
    xa = np.asarray(x, dtype=float).ravel()
    ya = np.asarray(y, dtype=float).ravel()
    if xa.size != ya.size:
        raise VfrsError(f"{xa.size} x values and {ya.size} y values: a fit needs pairs")
    if xa.size < 3:
        raise VfrsError(f"{xa.size} points: a fit with confidence bounds needs at least 3")
    if not (np.all(np.isfinite(xa)) and np.all(np.isfinite(ya))):
        raise VfrsError("a fit needs finite x and y (a run that did not phonate has no value: leave it out)")
    return xa, ya


def _quantile(dist, confidence: float, dof: int) -> float:
    if not 0.0 < confidence < 1.0:
        raise VfrsError(f"confidence = {confidence}: a confidence level lies in (0, 1)")
    return float(dist.ppf(0.5 + confidence / 2.0, dof))


def _positive(**values: float) -> None:
    for name, v in values.items():
        if not (math.isfinite(v) and v > 0):
            raise VfrsError(f"{name} = {v}: must be a finite number > 0")
