"""The estimators of vfrs.studies.validation against closed forms and independent computations, and
the literature tables of docs/validation/data against their documented form (issue 33)."""

from __future__ import annotations

import csv
import doctest
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.stats import linregress

import vfrs.studies.validation as va
from vfrs.errors import VfrsError

ROOT = Path(__file__).resolve().parent.parent
DATA = ROOT / "docs" / "validation" / "data"
SOURCES = ROOT / "docs" / "validation" / "sources.md"


def test_doctests():
    result = doctest.testmod(va)
    assert result.attempted > 0 and result.failed == 0


# --- Hertz ---------------------------------------------------------------------------------

def test_effective_modulus_of_like_bodies_and_of_a_rigid_wall():
    E, nu = 2.0e3, 0.45
    assert va.effective_modulus(E, nu) == pytest.approx(E / (2.0 * (1.0 - nu**2)), rel=1e-14)
    # a rigid second body leaves the first body's plane-strain modulus
    assert va.effective_modulus(E, nu, 1e15, 0.3) == pytest.approx(E / (1.0 - nu**2), rel=1e-9)
    with pytest.raises(VfrsError, match="Poisson"):
        va.effective_modulus(E, 0.6)
    with pytest.raises(VfrsError, match="E1"):
        va.effective_modulus(-1.0, 0.3)


def test_effective_radius():
    assert va.effective_radius(3e-3, 6e-3) == pytest.approx(2e-3, rel=1e-14)
    assert va.effective_radius(3e-3) == 3e-3


def test_sinusoid_peak_speed_is_the_largest_derivative():
    f0, A = 180.0, 0.4e-3
    t = np.linspace(0.0, 1.0 / f0, 20001)
    v = np.gradient(A * np.sin(2 * np.pi * f0 * t), t)
    assert va.sinusoid_peak_speed(f0, A) == pytest.approx(np.abs(v).max(), rel=1e-6)


# Soft-tissue-like numbers (the folds' in-plane modulus of the default tissue, a 1 mm radius, a
# tenth of a gram): the identities below hold for any positive values.
CASE = dict(speed=0.3, mass=1e-4, E_star=va.effective_modulus(2.0e3, 0.45), radius=1e-3)


def test_hertz_impact_stores_all_the_kinetic_energy_at_the_largest_approach():
    h = va.hertz_impact(**CASE)
    E_s, R = CASE["E_star"], CASE["radius"]
    work, _ = quad(lambda d: 4.0 / 3.0 * E_s * math.sqrt(R) * d**1.5, 0.0, h.approach)
    assert work == pytest.approx(0.5 * CASE["mass"] * CASE["speed"] ** 2, rel=1e-10)
    assert h.force == pytest.approx(4.0 / 3.0 * E_s * math.sqrt(R) * h.approach**1.5, rel=1e-14)


def test_hertz_impact_pressure_identities():
    h = va.hertz_impact(**CASE)
    assert h.contact_radius == pytest.approx(math.sqrt(CASE["radius"] * h.approach), rel=1e-14)
    # p0 = (2 E*/pi) sqrt(delta/R) = 3/2 of the mean pressure
    assert h.peak_pressure == pytest.approx(2.0 * CASE["E_star"] / math.pi * math.sqrt(h.approach / CASE["radius"]),
                                            rel=1e-12)
    assert h.peak_pressure == pytest.approx(1.5 * h.mean_pressure, rel=1e-14)


def test_hertz_impact_scales_with_speed_as_the_closed_form_says():
    h1 = va.hertz_impact(**CASE)
    h2 = va.hertz_impact(**{**CASE, "speed": 2 * CASE["speed"]})
    assert h2.approach / h1.approach == pytest.approx(2 ** 0.8, rel=1e-12)
    assert h2.force / h1.force == pytest.approx(2 ** 1.2, rel=1e-12)
    assert h2.peak_pressure / h1.peak_pressure == pytest.approx(2 ** 0.4, rel=1e-12)
    assert h2.duration / h1.duration == pytest.approx(2 ** -0.2, rel=1e-12)


def test_hertz_impact_against_the_integrated_equation_of_motion():
    """m* delta'' = -4/3 E* R^(1/2) delta^(3/2), delta(0) = 0, delta'(0) = v: the largest
    approach and the time back to delta = 0 from the ODE, not from the closed form."""
    m, E_s, R, v = CASE["mass"], CASE["E_star"], CASE["radius"], CASE["speed"]
    k = 4.0 / 3.0 * E_s * math.sqrt(R)
    h = va.hertz_impact(**CASE)

    def rhs(_t, y):
        return [y[1], -k * max(y[0], 0.0) ** 1.5 / m]

    def back(_t, y):
        return y[0]
    back.terminal, back.direction = True, -1  # type: ignore[attr-defined]
    sol = solve_ivp(rhs, (0.0, 10 * h.duration), [0.0, v], events=back, rtol=1e-11, atol=1e-16,
                    dense_output=True, max_step=h.duration / 200)
    t_end = sol.t_events[0][0]
    assert t_end == pytest.approx(h.duration, rel=1e-6)
    assert sol.sol(t_end / 2)[0] == pytest.approx(h.approach, rel=1e-6)  # the turn, half-way (symmetric)
    assert sol.y[1][-1] == pytest.approx(-v, rel=1e-6)  # elastic: it leaves at the speed it came


def test_hertz_time_integral_is_the_quadrature_and_johnsons_constant():
    val, _ = quad(lambda x: 1.0 / math.sqrt(1.0 - x**2.5), 0.0, 1.0)
    assert va.HERTZ_TIME_INTEGRAL == pytest.approx(val, rel=1e-10)
    assert round(2 * va.HERTZ_TIME_INTEGRAL, 2) == 2.94


@pytest.mark.parametrize("R", [0.3e-3, 1e-3, 4e-3])
def test_hertz_sphere_pressure_is_the_impact_of_two_tissue_spheres(R):
    """The closed form against hertz_impact (itself checked against the integrated equation of
    motion above) with two like spheres of radius R: each of mass 4/3 pi rho R^3, so m* = 2/3 pi
    rho R^3 and R* = R/2; any radius gives the same peak pressure."""
    rho, E_s, v = 1070.0, va.effective_modulus(2.0e3, 0.45), 0.5
    h = va.hertz_impact(v, 2.0 / 3.0 * math.pi * rho * R**3, E_s, R / 2.0)
    assert va.hertz_sphere_pressure(v, rho, E_s) == pytest.approx(h.peak_pressure, rel=1e-12)


def test_hertz_sphere_pressure_by_hand_and_its_scaling():
    # by hand: (5 sqrt2 pi 1070 / 8000)^(1/5) = 2.97118^(0.2) = 1.24333; x 2 sqrt2 1000 / pi = 1119.4 Pa
    assert va.hertz_sphere_pressure(1.0, 1070.0, 1000.0) == pytest.approx(1119.4, rel=1e-4)
    p = va.hertz_sphere_pressure(0.3, 1070.0, 1000.0)
    assert va.hertz_sphere_pressure(0.3, 1070.0, 2000.0) / p == pytest.approx(2 ** 0.8, rel=1e-12)
    assert va.hertz_sphere_pressure(0.3, 2140.0, 1000.0) / p == pytest.approx(2 ** 0.2, rel=1e-12)
    with pytest.raises(VfrsError, match="density"):
        va.hertz_sphere_pressure(0.3, 0.0, 1000.0)


def test_kinematic_hertz_pressure_closes_both_folds_at_the_sinusoids_speed():
    f0, A, rho, E, nu = 150.0, 0.4e-3, 1070.0, 2.0e3, 0.45
    p0, v = va.kinematic_hertz_pressure(f0, A, rho, E, nu)
    assert v == pytest.approx(2 * 2 * math.pi * f0 * A, rel=1e-14)
    assert p0 == pytest.approx(va.hertz_sphere_pressure(v, rho, E / (2 * (1 - nu**2))), rel=1e-14)
    # twice the amplitude (or f0) is twice the speed: 2^(2/5) the pressure
    assert va.kinematic_hertz_pressure(f0, 2 * A, rho, E, nu)[0] / p0 == pytest.approx(2 ** 0.4, rel=1e-12)


def test_hertz_line_pressure_carries_the_force():
    F, L, E_s, R = 0.02, 0.012, 1.1e3, 1.5e-3
    p0, b = va.hertz_line_pressure(F, L, E_s, R)
    carried, _ = quad(lambda x: p0 * math.sqrt(1.0 - (x / b) ** 2), -b, b)
    assert carried * L == pytest.approx(F, rel=1e-8)
    assert b == pytest.approx(math.sqrt(4 * F * R / (math.pi * L * E_s)), rel=1e-14)
    # the pressure grows as the square root of the force
    assert va.hertz_line_pressure(4 * F, L, E_s, R)[0] == pytest.approx(2 * p0, rel=1e-14)


def test_bad_inputs_are_refused():
    with pytest.raises(VfrsError, match="speed"):
        va.hertz_impact(0.0, 1e-4, 1e3, 1e-3)
    with pytest.raises(VfrsError, match="radius"):
        va.hertz_line_pressure(1.0, 1.0, 1.0, float("nan"))


# --- Titze's threshold pressure ----------------------------------------------------------------

def test_titze_threshold_pressure_form():
    base = dict(kt=1.1, damping=0.02, wave_speed=1.0, half_width=0.1e-3, length=0.01, thickness=3e-3)
    p = va.titze_threshold_pressure(**base)
    assert p == pytest.approx(1.1 * 0.02 * 1.0 * 0.1e-3 / (0.01 * 3e-3**2), rel=1e-14)
    # linear in the half-width, through zero
    assert va.titze_threshold_pressure(**{**base, "half_width": 0.3e-3}) == pytest.approx(3 * p, rel=1e-14)
    assert va.titze_threshold_pressure(**{**base, "half_width": 0.0}) == 0.0
    # 1/T^2 with a total damping; 1/T with a damping per unit medial area B/(L T)
    assert va.titze_threshold_pressure(**{**base, "thickness": 6e-3}) == pytest.approx(p / 4, rel=1e-14)
    per_area = base["damping"] / (base["length"] * base["thickness"])
    assert p == pytest.approx(base["kt"] * per_area * base["wave_speed"] * base["half_width"] / base["thickness"],
                              rel=1e-14)
    with pytest.raises(VfrsError, match="half_width"):
        va.titze_threshold_pressure(**{**base, "half_width": -1e-4})


def test_cm_h2o():
    assert 10 * va.PA_PER_CM_H2O == pytest.approx(980.665, rel=1e-15)


# --- fits ----------------------------------------------------------------------------------------

def test_linear_fit_matches_scipy_linregress():
    rng = np.random.default_rng(3)
    x = np.linspace(0.1, 0.6, 9)
    y = 4.0 * x + 0.2 + rng.normal(0.0, 0.05, x.size)
    f = va.linear_fit(x, y, confidence=0.9)
    ref = linregress(x, y)
    assert f.slope == pytest.approx(ref.slope, rel=1e-12)
    assert f.intercept == pytest.approx(ref.intercept, rel=1e-12)
    assert f.r2 == pytest.approx(ref.rvalue**2, rel=1e-12)
    from scipy.stats import t
    q = t.ppf(0.95, x.size - 2)
    assert (f.slope_ci[1] - f.slope_ci[0]) / 2 == pytest.approx(q * ref.stderr, rel=1e-10)
    assert (f.intercept_ci[1] - f.intercept_ci[0]) / 2 == pytest.approx(q * ref.intercept_stderr, rel=1e-10)


def test_linear_fit_of_an_exact_line_and_the_origin():
    f = va.linear_fit([1.0, 2.0, 3.0], [3.0, 5.0, 7.0])
    assert (f.slope, f.intercept, f.r2) == pytest.approx((2.0, 1.0, 1.0), abs=1e-12)
    assert not f.through_origin
    rng = np.random.default_rng(0)
    x = np.linspace(0.1, 1.0, 12)
    assert va.linear_fit(x, 2.0 * x + rng.normal(0, 0.01, x.size)).through_origin


def test_confidence_intervals_cover_at_their_level_with_few_points():
    """With 5 points (3 degrees of freedom) a normal quantile in place of Student's would
    cover about 86 %, not 95 %: the observed coverage tells the two apart."""
    rng = np.random.default_rng(20261204)
    x = np.array([0.2, 0.4, 0.6, 0.8, 1.0])
    hits_slope = hits_int = 0
    draws = 2000
    for _ in range(draws):
        f = va.linear_fit(x, 1.5 * x + 0.3 + rng.normal(0.0, 0.2, x.size))
        hits_slope += f.slope_ci[0] <= 1.5 <= f.slope_ci[1]
        hits_int += f.intercept_ci[0] <= 0.3 <= f.intercept_ci[1]
    assert 0.93 <= hits_slope / draws <= 0.97
    assert 0.93 <= hits_int / draws <= 0.97


def test_power_law_fit_recovers_the_square_root():
    ps = np.array([0.3, 0.5, 0.8, 1.2, 1.8, 2.5])  # kPa
    exact = va.power_law_fit(ps, 2.0 * ps**0.5)
    assert (exact.a, exact.b) == pytest.approx((2.0, 0.5), rel=1e-12)
    # scatter of 3 % orthogonal to (1, ln Ps): the fitted exponent stays 0.5, its bounds open
    X = np.column_stack([np.ones(ps.size), np.log(ps)])
    r = np.array([1.0, -1.0, 1.0, 1.0, -1.0, -1.0])
    r = 0.03 * (r - X @ np.linalg.lstsq(X, r, rcond=None)[0])
    noisy = va.power_law_fit(ps, 2.0 * ps**0.5 * np.exp(r))
    assert noisy.b == pytest.approx(0.5, rel=1e-12)
    assert noisy.b_ci[1] - noisy.b_ci[0] > 0.01
    assert noisy.contains(0.5) and not noisy.contains(1.0)
    assert noisy.a_ci[0] < noisy.a < noisy.a_ci[1]
    # a linear trend with the same scatter is told apart from the square root
    linear = va.power_law_fit(ps, 3.0 * ps * np.exp(r))
    assert linear.contains(1.0) and not linear.contains(0.5)


def test_fits_refuse_what_they_cannot_fit():
    with pytest.raises(VfrsError, match="at least 3"):
        va.linear_fit([1.0, 2.0], [1.0, 2.0])
    with pytest.raises(VfrsError, match="pairs"):
        va.linear_fit([1.0, 2.0, 3.0], [1.0, 2.0])
    with pytest.raises(VfrsError, match="all x are equal"):
        va.linear_fit([1.0, 1.0, 1.0], [1.0, 2.0, 3.0])
    with pytest.raises(VfrsError, match="finite"):
        va.linear_fit([1.0, 2.0, 3.0], [1.0, float("nan"), 3.0])
    with pytest.raises(VfrsError, match="> 0"):
        va.power_law_fit([0.0, 1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(VfrsError, match="confidence"):
        va.linear_fit([1.0, 2.0, 3.0], [1.0, 2.0, 4.0], confidence=1.0)


# --- the literature tables -----------------------------------------------------------------------

POINT_COLUMNS = ["source", "locator", "quantity", "unit", "value", "sd", "low", "high", "condition", "hand", "via"]
TREND_COLUMNS = ["source", "locator", "quantity", "against", "relation", "exponent", "condition", "hand", "via"]


@pytest.mark.parametrize("name, columns", [("literature_points.csv", POINT_COLUMNS),
                                           ("literature_trends.csv", TREND_COLUMNS)])
def test_literature_tables_are_sourced(name, columns):
    with open(DATA / name, newline="") as fh:
        reader = csv.DictReader(fh)
        assert reader.fieldnames == columns
        rows = list(reader)
    assert rows
    sources = SOURCES.read_text()
    for r in rows:
        assert r["hand"] in ("first", "second"), r
        assert r["locator"], r
        # a second-hand number says where it was read
        assert (r["hand"] == "second") == bool(r["via"]), r
        # every source key has its section in docs/validation/sources.md
        assert f"`{r['source']}`" in sources, r["source"]
        for key in ("value", "sd", "low", "high", "exponent"):
            if r.get(key):
                assert math.isfinite(float(r[key])), r
        if name == "literature_points.csv":
            assert r["value"] or (r["low"] and r["high"]), r
            if r["low"] and r["high"]:
                assert float(r["low"]) <= float(r["high"]), r
